//! The updated-Lagrangian weak form with moving stress points (seed 000 §5.7, Algorithm
//! 7): one stress point per lattice cell, at its centre, carrying ρ and S and advected
//! with the interpolated velocity (eq 169); particles carrying ρ; reproducing-kernel
//! (RKPM) functions recomputed at every rate evaluation on covariance-ellipse
//! neighbourhoods with their own smoothing length (eq 64, [`ellipse`]) from candidate
//! lists fixed at set-up; the velocity smoothing after each step with the particles'
//! current functions. It runs on the shared updated-Lagrangian Galerkin system
//! ([`crate::methods::cores::galerkin::updated`]) on the CPU, and on the GPU on passes of
//! its own ([`gpu`]). Numerics notes: `docs/methods/galerkin.md`.

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod points;

use super::cores::galerkin::updated::{self, UlGalerkin};
use crate::case::Case;
use crate::core::check::{Problem, fail, toml_name};
use crate::core::neighbour::Rebuild;
use crate::engine::{CpuEngine, EngineDim};
#[cfg(feature = "gpu")]
use crate::methods::cores::family::GpuBuild;
use crate::methods::cores::family::{CpuBuild, Feature, MethodFamily, Plan, cfl_step};
use crate::physics::material::Material;
use points::StressPoints;
use serde::{Deserialize, Serialize};

fn yes() -> bool {
    true
}

/// The `[method]` keys of the updated-Lagrangian weak form.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct UlWeakFormSpec {
    /// The velocity smoothing v_i ← Σ_j V_j Ψ_j(x_i) v_j after each step (default true,
    /// as the paper and the reference code).
    #[serde(default = "yes")]
    pub smoothing: bool,
}

impl Default for UlWeakFormSpec {
    fn default() -> Self {
        Self { smoothing: true }
    }
}

impl MethodFamily for UlWeakFormSpec {
    const DESCRIPTION: &'static str = "updated-Lagrangian weak form (seed 000 §5.7): one \
        stress point per lattice cell moved with the interpolated velocity, RKPM recomputed \
        every stage on covariance-ellipse neighbourhoods, velocity smoothing after each \
        step";
    const KEYS: &'static [&'static str] = &["smoothing"];
    const FEATURES: &'static [Feature] = &[Feature::Contact];
    const NEIGHBOURS: Rebuild = Rebuild::EveryStage;
    const KERNEL: bool = false;
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = gpu::SHADERS;

    /// The rate model only: the stress points carry ρ and S, not F.
    fn validate(&self, case: &Case) -> Result<(), Problem> {
        if case.material.model.is_rate_based() {
            return Ok(());
        }
        fail(
            "material.model",
            format!(
                "`ul-weak-form` integrates ρ and S at its moving stress points with an \
                 objective rate: use `hypoelastic`, not {}; for a state model use \
                 `tl-weak-form` or `ul-fem`",
                toml_name(&case.material.model)
            ),
        )
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let mut left_out = vec!["the kernel keys (cubic spline, h from the ellipse)"];
        if !self.smoothing {
            left_out.push("the velocity smoothing after each step");
        }
        Plan {
            once: "once, on the reference configuration: one stress point at the centre of \
                   every lattice cell, and the candidate lists of stress points and particles \
                   (the particles of the body within ±3Δx in every direction, itself \
                   included)"
                .into(),
            state: format!(
                "{}; ρ at the particles; the stress points' displacements",
                updated::state(&mat, "the stress points")
            ),
            cfl_step: cfl_step(&mat),
            rates: format!(
                "covariance ellipses, h and RKPM N_j = V_j Ψ_j at every stress point and \
                 particle (V_j = m_j/ρ_j); L, ρ̇, the objective Ṡ, σ and ẋ_q = Σ_j N_j v_j at \
                 the stress points, ρ̇ at the particles; each particle gathers −Σ_q V_q σ_q \
                 ∇N_j(x_q){}; after each step v_i ← Σ_j N_j(x_i) v_j with the particles' \
                 functions anew{}",
                if gpu {
                    " over the stress points it is a candidate of, its function there from \
                     the point's stored ellipse and coefficients (points, particles and nodes \
                     passes)"
                } else {
                    ""
                },
                if gpu {
                    " (smooth and settle passes)"
                } else {
                    ""
                }
            ),
            checked: "ρ at the particles and stress points, det of every covariance ellipse \
                      and moment matrix,",
            check_note: String::new(),
            left_out,
        }
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        Ok(Box::new(
            CpuEngine::<D, UlGalerkin<D, StressPoints<D>>>::new(case, self)?,
        ))
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D> {
        Ok(Box::new(gpu::GpuUlWeakForm::<D>::new(case, self, gpu)?))
    }

    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        Some(gpu::GpuUlWeakForm::<D>::memory(case, counts))
    }

    fn lattice_cells(&self) -> bool {
        true
    }
}
