//! The Krongauz–Belytschko method of Rabczuk, Belytschko and Xiao (seed 001, "EFG–KBM"):
//! a Petrov–Galerkin particle method on a Lagrangian kernel, with Shepard functions W^S_a
//! as test functions and the corrected gradient G_a = M⁻¹ ∇0W^S_a (eqs 27–32) as trial
//! gradient, F_q = I + Σ_a u_a ⊗ G_a(X_q) and f_a = Σ_q V_q ∇0W^S_a(X_q)·P_q (eq 64, spec
//! §7.4). Its points are the particles (nodal integration, "KBM (ni)") and, by default, a
//! stress point at the centre of every lattice cell ("KBM (si)", §5.2), weighted by the
//! Voronoi diagram of both (eq 65). Everything is built once on the reference
//! configuration (§2.2). It runs on the shared Galerkin system
//! ([`crate::methods::galerkin`]). Numerics notes: `docs/methods/seed001.md`.

use super::fem::galerkin_state;
use super::galerkin::{Mass, TlGalerkin, particle_mass};
use super::{Feature, MethodFamily, Plan, Problem};
use crate::material::Material;
use crate::quadrature::{Cells, QuadraturePoints, Shapes, lattice_cells};
use crate::reference::Reference;
use crate::run::{Engine, EngineDim};
use crate::scene::{Case, CaseError};
use crate::tensor::Dim;
use serde::{Deserialize, Serialize};

fn yes() -> bool {
    true
}

/// The `[method]` keys of the Krongauz–Belytschko method.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct KbmSpec {
    /// A stress point at the centre of every lattice cell besides the particles (default
    /// true, the paper's KBM (si)); false integrates at the particles only (KBM (ni)).
    #[serde(default = "yes")]
    pub stress_points: bool,
    /// The nodal masses (default `particle`, the Voronoi masses of eq 70).
    #[serde(default = "particle_mass")]
    pub mass: Mass,
}

impl Default for KbmSpec {
    fn default() -> Self {
        Self {
            stress_points: true,
            mass: Mass::Particle,
        }
    }
}

impl KbmSpec {
    /// The Galerkin system with the Krongauz–Belytschko functions at the particles and,
    /// with stress points, at the cell centres.
    pub fn system<D: Dim>(
        &self,
        case: &Case,
        reference: Reference<D>,
    ) -> Result<TlGalerkin<D>, CaseError> {
        let (cells, points) = if self.stress_points {
            let cells = lattice_cells::<D>(&reference.x0, &reference.body, case.spacing)
                .map_err(|e| case.invalid("method.stress_points", e.to_string()))?;
            let points =
                QuadraturePoints::with_stress_points(&cells, &reference.x0, &reference.body);
            (cells, points)
        } else {
            let points =
                QuadraturePoints::at_particles(&reference.x0, &reference.vol, &reference.body);
            (Cells::default(), points)
        };
        let shapes = Shapes::krongauz_belytschko(
            &points.x0,
            &points.body,
            &reference.x0,
            &reference.body,
            &reference.kernel,
        )
        .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
        TlGalerkin::new(case, reference, cells, points, shapes, self.mass, None)
    }
}

impl MethodFamily for KbmSpec {
    const DESCRIPTION: &'static str = "Krongauz–Belytschko Petrov–Galerkin method (seed \
        001, EFG–KBM): Lagrangian kernel, Shepard test functions, corrected trial gradient, \
        integration at the particles and at stress points in the cell centres";
    const KEYS: &'static [&'static str] = &["stress_points", "mass"];
    const FEATURES: &'static [Feature] = &[Feature::Contact, Feature::StaticSolve];
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = super::galerkin::gpu::SHADERS;

    fn validate(&self, _case: &Case) -> Result<(), Problem> {
        Ok(())
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let mut left_out = Vec::new();
        if !self.stress_points {
            left_out.push("stress points (nodal integration only: KBM (ni))");
        }
        left_out.push(if mat.model.is_rate_based() {
            "P(F) evaluation"
        } else {
            "continuity and Jaumann rates"
        });
        let points = if self.stress_points {
            "the particles and a stress point at every lattice-cell centre, weighted by \
             their joint Voronoi cells"
        } else {
            "the particles, weighted by their volumes"
        };
        Plan {
            once: format!(
                "once, on the reference configuration: the points ({points}), the particles \
                 within the kernel support of every point, the Shepard functions W^S_a and \
                 ∇0W^S_a there, M = Σ_a ∇0W^S_a ⊗ (X_a − X_q) and G_a = M⁻¹ ∇0W^S_a, and the \
                 node-to-point gather lists"
            ),
            state: galerkin_state(&mat),
            cfl_step: super::cfl_step(&mat),
            rates: if gpu {
                "points pass (F_q = I + Σ_a u_a ⊗ G_a, P_q, w_q ψ_q, ρ̇_q, Ṡ_q) + nodes pass \
                 (−Σ_q w_q P_q ∇0W^S_a(X_q) gathered per particle, BCs)"
                    .into()
            } else {
                "F_q = I + Σ_a u_a ⊗ G_a (and Ḟ_q) and P_q at every point, then each particle \
                 gathers −Σ_q w_q P_q ∇0W^S_a(X_q)"
                    .into()
            },
            checked: "det F at the points",
            check_note: String::new(),
            left_out,
        }
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> Result<Box<dyn Engine<D>>, CaseError> {
        super::galerkin::cpu_engine(case)
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(
        &self,
        case: &Case,
        gpu: crate::gpu::Gpu,
    ) -> Result<Box<dyn Engine<D>>, crate::gpu::SetupError> {
        super::galerkin::gpu_engine(case, gpu)
    }

    /// Δt = α Δx/(c_p + max|v|) does not depend on the stretch.
    fn stretch_signal_speed<D: Dim>(&self, _c_p: f64, _f: D::T) -> f64 {
        0.0
    }
}
