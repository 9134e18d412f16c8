//! The total-Lagrangian weak form after Jun, Liu and Belytschko (seed 000 §5.6,
//! Algorithm 6): reproducing-kernel (RKPM) shape functions of the particles at 2×2 Gauss
//! points of the lattice cells, a lumped mass, and, as an option (`smoothing`), the
//! velocity smoothing after each step that turns the RKPM coefficients into nodal values
//! ("virtual to actual"). It runs on
//! the shared Galerkin system ([`crate::methods::cores::galerkin`]). Numerics
//! notes: `docs/methods/galerkin.md`.

use super::cores::galerkin::{
    Mass, TlGalerkin, TlSystem, particle_mass, smoothing_shapes, tl_plan,
};
use crate::case::{Case, CaseError};
use crate::core::quadrature::{QuadraturePoints, Rule, Shapes};
use crate::core::tensor::Dim;
use crate::methods::cores::family::{Feature, MethodFamily, Plan};
use crate::reference::Reference;
use serde::{Deserialize, Serialize};

/// The `[method]` keys of the total-Lagrangian weak form.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WeakFormSpec {
    /// The velocity smoothing v_i ← Σ_j Ψ_j(X_i) V_j v_j after each step, as the paper
    /// and the reference code have it (default false: it feeds energy into a vibration,
    /// docs/methods/galerkin.md).
    #[serde(default)]
    pub smoothing: bool,
    /// The nodal masses (default `particle`, the paper's eq 163).
    #[serde(default = "particle_mass")]
    pub mass: Mass,
}

impl Default for WeakFormSpec {
    fn default() -> Self {
        Self {
            smoothing: false,
            mass: Mass::Particle,
        }
    }
}

impl<D: Dim> TlSystem<D> for WeakFormSpec {
    /// The Galerkin system with the RKPM functions of the particles at the Gauss points of
    /// the lattice cells.
    fn system(&self, case: &Case, reference: Reference<D>) -> Result<TlGalerkin<D>, CaseError> {
        let cells = reference
            .cells(case.spacing)
            .map_err(|e| case.invalid("body", e.to_string()))?;
        let points = QuadraturePoints::new(&cells, &reference.x0, Rule::Gauss2);
        let shapes = Shapes::reproducing(
            &points.x0,
            &points.body,
            &reference.x0,
            &reference.vol,
            &reference.body,
            &reference.kernel,
        )
        .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
        let smoothing = if self.smoothing {
            Some(
                smoothing_shapes(&reference)
                    .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?,
            )
        } else {
            None
        };
        TlGalerkin::new(case, reference, cells, points, shapes, self.mass, smoothing)
    }
}

impl MethodFamily for WeakFormSpec {
    const DESCRIPTION: &'static str = "total-Lagrangian weak form (Jun–Liu–Belytschko; seed \
        000 §5.6): RKPM shape functions at 2×2 Gauss points of the lattice cells, lumped \
        mass, optional velocity smoothing after each step";
    const KEYS: &'static [&'static str] = &["smoothing", "mass"];
    const FEATURES: &'static [Feature] = super::cores::galerkin::FEATURES;
    const CORRECTED: bool = false;
    const HALO_LAYERS: Option<usize> = Some(1);
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = super::cores::galerkin::gpu::SHADERS;

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let once = "once, on the reference configuration: the lattice cells with 2^d Gauss \
                    points each, the particles within the kernel support of every point, RKPM \
                    N_a = V_a Ψ_a and ∇0N_a there, the node-to-point gather lists, and the \
                    particles' own RKPM weights for the smoothing";
        let rates = if gpu {
            "points pass (F_q, P_q, w_q ψ_q, ρ̇_q, Ṡ_q) + nodes pass (−Σ_q w_q P_q \
             ∇0N_a(X_q) gathered per particle, BCs); after each step the smooth and settle \
             passes (v_i ← Σ_j V_j Ψ_j(X_i) v_j, prescribed components kept)"
        } else {
            "F_q (and Ḟ_q) and P_q at every Gauss point, then each particle gathers \
             −Σ_q w_q P_q ∇0N_a(X_q); after each step v_i ← Σ_j V_j Ψ_j(X_i) v_j"
        };
        let mut left_out = Vec::new();
        if !self.smoothing {
            left_out.push("the velocity smoothing after each step");
        }
        let checked = "det F at the Gauss points";
        tl_plan(case, once.into(), rates.into(), checked, left_out)
    }

    super::cores::galerkin::tl_galerkin_engines!();

    #[cfg(feature = "gpu")]
    fn device_memory<D: crate::engine::EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        use crate::methods::cores::galerkin::gpu::{Frame, GpuGalerkin, Points};
        let gauss = Points::gauss(counts, D::N);
        let points = if self.smoothing {
            gauss.smoothed(counts)
        } else {
            gauss
        };
        Some(GpuGalerkin::<D>::memory(
            case,
            counts,
            &points,
            Frame::Reference,
        ))
    }

    fn lattice_cells(&self) -> bool {
        true
    }

    fn warning(&self, case: &Case) -> Option<String> {
        (self.smoothing && !case.is_static()).then(|| {
            "method.smoothing = true (seed 000 Algorithm 6) feeds energy into a vibration: \
             a released cantilever gains 150 % of its energy in 1.7 periods \
             (docs/methods/galerkin.md); leave it out (smoothing = false, the default) \
             unless reproducing the paper"
                .to_string()
        })
    }
}
