//! The finite-element reference of seed 000 (§5, "TL FEM"): 4-node quadrilaterals (8-node
//! hexahedra in 3D) on the lattice cells of the bodies, 2×2 (2×2×2) Gauss points, the
//! total-Lagrangian weak form with a lumped mass, explicit, on the shared Galerkin system
//! ([`crate::methods::cores::galerkin`]). Numerics notes: `docs/methods/galerkin.md`.

use super::cores::galerkin::{Mass, TlGalerkin, TlSystem, tl_plan};
use crate::case::{Case, CaseError};
use crate::core::quadrature::{QuadraturePoints, Rule, Shapes};
use crate::core::tensor::Dim;
use crate::methods::cores::family::{Feature, MethodFamily, Plan};
use crate::reference::Reference;
use serde::{Deserialize, Serialize};

/// The device memory of the Galerkin passes on the elements of `case` with their Gauss
/// points evaluated in `frame` (`tl-fem`'s and `ul-fem`'s).
#[cfg(feature = "gpu")]
pub fn element_memory<D: crate::engine::EngineDim>(
    case: &Case,
    counts: &crate::gpu::memory::Counts,
    frame: crate::methods::cores::galerkin::gpu::Frame,
) -> crate::gpu::memory::DeviceMemory {
    use crate::methods::cores::galerkin::gpu::{GpuGalerkin, Points};
    let points = Points::elements(counts, D::N);
    GpuGalerkin::<D>::memory(case, counts, &points, frame)
}

/// The Gauss rule of the elements (also `ul-fem`'s).
pub const RULE: Rule = Rule::Gauss2;

/// The `[method]` keys of the total-Lagrangian FEM.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FemSpec {
    /// The nodal masses (default `row-sum`).
    #[serde(default)]
    pub mass: Mass,
}

impl<D: Dim> TlSystem<D> for FemSpec {
    /// The Galerkin system on the bilinear (trilinear) elements of the lattice cells.
    fn system(&self, case: &Case, reference: Reference<D>) -> Result<TlGalerkin<D>, CaseError> {
        let cells = reference
            .cells(case.spacing)
            .map_err(|e| case.invalid("body", e.to_string()))?;
        let points = QuadraturePoints::new(&cells, &reference.x0, RULE);
        let shapes = Shapes::isoparametric(&cells, &points, &reference.x0);
        TlGalerkin::new(case, reference, cells, points, shapes, self.mass, None)
    }
}

impl MethodFamily for FemSpec {
    const DESCRIPTION: &'static str = "total-Lagrangian finite elements (seed 000's FEM \
        reference): bilinear quadrilaterals (trilinear hexahedra) on the lattice cells, 2^d \
        Gauss points, lumped mass, explicit";
    const KEYS: &'static [&'static str] = &["mass"];
    const FEATURES: &'static [Feature] = super::cores::galerkin::FEATURES;
    const KERNEL: bool = false;
    const HALO_LAYERS: Option<usize> = Some(1);
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = super::cores::galerkin::gpu::SHADERS;

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let once = format!(
            "once, on the reference configuration: the lattice cells of every body as \
             elements, 2^d Gauss points each, ∇0N_a = J⁻ᵀ ∂N_a/∂ξ, the node-to-point gather \
             lists, {} nodal masses",
            self.mass.name()
        );
        let rates = if gpu {
            "points pass (F_q, P_q, w_q ψ_q, ρ̇_q, Ṡ_q) + nodes pass (−Σ_q w_q P_q \
             ∇0N_a(X_q) gathered per node, BCs)"
        } else {
            "F_q (and Ḟ_q) and P_q at every Gauss point, then each node gathers \
             −Σ_q w_q P_q ∇0N_a(X_q)"
        };
        let left_out = vec!["kernels and neighbour lists (the cells are the mesh)"];
        tl_plan(
            case,
            once,
            rates.into(),
            "det F at the Gauss points",
            left_out,
        )
    }

    super::cores::galerkin::tl_galerkin_engines!();

    #[cfg(feature = "gpu")]
    fn device_memory<D: crate::engine::EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        let frame = crate::methods::cores::galerkin::gpu::Frame::Reference;
        Some(element_memory::<D>(case, counts, frame))
    }

    fn lattice_cells(&self) -> bool {
        true
    }
}
