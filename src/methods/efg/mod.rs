//! The element-free Galerkin method as seed 001 compares it (§3.4, §5): a Bubnov–Galerkin
//! method on a Lagrangian kernel with moving least-squares functions of a linear basis
//! (eqs 37–42), integrated at the particles ("EFG (ni)", eqs 59–60), at the particles
//! with the gradients smoothed over their cells (stabilised conforming nodal integration,
//! Chen, Wu, Yoon and You 2001) or at 2×2 (2×2×2) Gauss points of the lattice cells
//! ("EFG (ci)", eqs 66–69), F_q = I + Σ_a u_a ⊗ ∇0Φ_a(X_q) and f_a = Σ_q w_q
//! ∇0Φ_a(X_q)·P_q. Everything is built once on the reference configuration. It runs on the shared Galerkin system ([`crate::methods::cores::galerkin`]).
//! Numerics notes: `docs/methods/seed001.md`.

use super::cores::galerkin::{Mass, TlGalerkin, TlSystem, particle_mass, smoothing_cells, tl_plan};
use crate::case::{Case, CaseError};
use crate::core::quadrature::{Cells, QuadraturePoints, Rule, Shapes};
use crate::core::tensor::Dim;
use crate::methods::cores::family::{Feature, MethodFamily, Plan};
use crate::reference::Reference;
use serde::{Deserialize, Serialize};

/// Where the element-free Galerkin method integrates (`method.integration`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Integration {
    /// At the particles, weighted by their volumes: EFG (ni).
    Nodal,
    /// At the particles, weighted by the areas of their cells, with the gradients
    /// smoothed over the cells: stabilised conforming nodal integration.
    Scni,
    /// At 2^d Gauss points of every lattice cell: EFG (ci).
    #[default]
    Cells,
}

/// The `[method]` keys of the element-free Galerkin method.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EfgSpec {
    /// `cells` (the default, EFG (ci)), `nodal` (EFG (ni)) or `scni` (stabilised
    /// conforming nodal integration).
    #[serde(default)]
    pub integration: Integration,
    /// The nodal masses (default `particle`, ρ0 V of each particle: the Voronoi masses of
    /// seed 001 eq 70 on a lattice of tributary volumes, `geometry.volumes = "tributary"`).
    #[serde(default = "particle_mass")]
    pub mass: Mass,
}

impl Default for EfgSpec {
    fn default() -> Self {
        Self {
            integration: Integration::Cells,
            mass: Mass::Particle,
        }
    }
}

impl<D: Dim> TlSystem<D> for EfgSpec {
    /// The Galerkin system with the MLS functions of the particles at the particles (their
    /// gradients smoothed over the particles' cells with SCNI) or at the Gauss points of
    /// the lattice cells.
    fn system(&self, case: &Case, reference: Reference<D>) -> Result<TlGalerkin<D>, CaseError> {
        let (x0, body, kernel) = (&reference.x0, &reference.body, &reference.kernel);
        let (cells, points, shapes) = match self.integration {
            Integration::Cells => {
                let cells = reference
                    .cells(case.spacing)
                    .map_err(|e| case.invalid("method.integration", e.to_string()))?;
                let points = QuadraturePoints::new(&cells, x0, Rule::Gauss2);
                let shapes =
                    Shapes::moving_least_squares(&points.x0, &points.body, x0, body, kernel);
                (cells, points, shapes)
            }
            Integration::Nodal => {
                let points = QuadraturePoints::at_particles(x0, &reference.vol, body);
                let shapes = Shapes::moving_least_squares(x0, body, x0, body, kernel);
                (Cells::default(), points, shapes)
            }
            Integration::Scni => {
                let smoothing = smoothing_cells(case, &reference, "method.integration")?;
                let points = QuadraturePoints::at_particles(x0, &smoothing.volumes::<D>(), body);
                let shapes = Shapes::smoothed_moving_least_squares(&smoothing, x0, body, kernel);
                (Cells::default(), points, shapes)
            }
        };
        let shapes = shapes.map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
        TlGalerkin::new(case, reference, cells, points, shapes, self.mass, None)
    }
}

impl MethodFamily for EfgSpec {
    const DESCRIPTION: &'static str = "element-free Galerkin (seed 001): Lagrangian kernel, \
        moving least-squares functions of a linear basis, integration at the particles \
        (unstabilised or SCNI) or at 2^d Gauss points of the lattice cells";
    const KEYS: &'static [&'static str] = &["integration", "mass"];
    const FEATURES: &'static [Feature] = super::cores::galerkin::FEATURES;
    const CORRECTED: bool = false;
    const HALO_LAYERS: Option<usize> = Some(1);
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = super::cores::galerkin::gpu::SHADERS;

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let points = match self.integration {
            Integration::Cells => "the lattice cells with 2^d Gauss points each",
            Integration::Nodal => "the particles as points, weighted by their volumes",
            Integration::Scni => {
                "the particles as points, weighted by the areas (volumes) of their Δx cells \
                 clipped to the body's box, with the gradients smoothed over the cells \
                 (SCNI: ∇̃Φ_a(X_L) = (1/A_L) Σ_g Φ_a(Y_g) n_g w_g over 2 Gauss points per \
                 cell edge, 2×2 per face in 3D)"
            }
        };
        let once = format!(
            "once, on the reference configuration: {points}, the particles within the \
             kernel support of every point (with SCNI, of its cell's boundary too), the \
             MLS functions Φ_a and ∇0Φ_a there, and the node-to-point gather lists"
        );
        let rates = if gpu {
            "points pass (F_q, P_q, w_q ψ_q, ρ̇_q, Ṡ_q) + nodes pass (−Σ_q w_q P_q \
             ∇0Φ_a(X_q) gathered per particle, BCs)"
        } else {
            "F_q (and Ḟ_q) and P_q at every point, then each particle gathers −Σ_q w_q \
             P_q ∇0Φ_a(X_q)"
        };
        tl_plan(case, once, rates.into(), "det F at the points", Vec::new())
    }

    super::cores::galerkin::tl_galerkin_engines!();

    #[cfg(feature = "gpu")]
    fn device_memory<D: crate::engine::EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        use crate::methods::cores::galerkin::gpu::{Frame, GpuGalerkin, Points};
        let points = match self.integration {
            Integration::Cells => Points::gauss(counts, D::N),
            Integration::Nodal | Integration::Scni => Points::nodal(counts),
        };
        Some(GpuGalerkin::<D>::memory(
            case,
            counts,
            &points,
            Frame::Reference,
        ))
    }

    fn warning(&self, _case: &Case) -> Option<String> {
        (self.integration == Integration::Nodal).then(|| {
            "method.integration = \"nodal\" integrates at the particles without \
             stabilisation: the stripes even about every particle are zero-energy modes \
             (docs/methods/seed001.md), and static bending gives deflections of the wrong \
             sign or several times too large; use integration = \"scni\" (stabilised \
             conforming nodal integration) or \"cells\" (the default)"
                .to_string()
        })
    }

    fn lattice_cells(&self) -> bool {
        self.integration == Integration::Cells
    }
}
