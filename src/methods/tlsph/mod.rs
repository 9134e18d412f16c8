//! Total-Lagrangian SPH after Reveles (seed 000 §5.3): the spec, the CPU system
//! ([`system`]) and its scheme on the total-Lagrangian core's GPU engine ([`gpu`]).
//! Numerics notes: `docs/methods/tlsph.md`.

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod system;

pub use crate::methods::cores::tl::TlState;
#[cfg(feature = "gpu")]
pub use crate::methods::cores::tl::gpu::GpuTlsph;
pub use system::{Tlsph, TlsphScheme};

use crate::engine::ranks::RankStart;
#[cfg(feature = "gpu")]
use crate::methods::cores::family::GpuBuild;
use crate::methods::cores::family::{
    CpuBuild, Feature, MethodFamily, Plan, RankBuild, cfl_step, check_viscosity,
};
use crate::methods::cores::shared;
use crate::reference::Reference;

use crate::case::Case;
use crate::core::check::{Problem, fail, positive};
use crate::engine::EngineDim;
use crate::physics::material::{Material, MaterialModel};
use crate::physics::viscosity::ArtificialViscosity;
use serde::{Deserialize, Serialize};

/// The direction along which TLSPH's artificial viscosity acts on a pair.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum ViscosityGradient {
    /// F_i⁻ᵀ ∇0W̃_ij: the reference gradient pushed forward to the current configuration,
    /// which stays along the pair under rigid rotation.
    #[default]
    PushedForward,
    /// ∇0W̃_ij unmapped, as the paper writes Algorithm 3 step 7 and the reference code
    /// runs it; after a rotation it points across the pair.
    Reference,
}

/// The pair force of TLSPH.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum TlsphForce {
    /// m_i a_i = V_i Σ_j V_j (P_i + P_j) ∇0W̃_ij (seed 000 eq 134): i's corrected
    /// gradient on both terms, as the paper and the reference code have it. With a
    /// correction it is not the gradient of the strain energy: at a surface row it
    /// carries about half a load, and the work of driven boundaries does not balance
    /// the energy (docs/methods/tlsph.md). The seed-000 and seed-001 cases set it.
    Reveles,
    /// m_i a_i = V_i Σ_j V_j (P_i ∇0W̃_ij − P_j ∇0W̃_ji) = −∂Π/∂u_i with
    /// Π = Σ_i V_i ψ(F_i) (the form of seed 000 eq 148): each term with its own side's
    /// corrected gradient. Both coincide without a correction. The default: it carries
    /// surface loads whole and closes the energy balance of driven boundaries.
    #[default]
    Variational,
    /// m_i a_i = V_i Σ_{j∈N(X_i)} V_j P_j ∇0W̃_j(X_i) (seed 002 eq 21): the plain
    /// collocation of div P, the sum over the whole neighbourhood with i's own term
    /// V_i P_i ∇0W̃_i(X_i) ([`crate::core::correction::own_gradients`]). Its pair terms
    /// are not equal and opposite under a correction, so it does not conserve linear
    /// momentum: the reason for seed 002's symmetrised eq 22.
    Plain,
}

/// The `[method]` keys of TLSPH.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
pub struct TlsphSpec {
    /// Monaghan artificial viscosity; none when absent.
    pub artificial_viscosity: Option<ArtificialViscosity>,
    /// The direction of the viscous pair force.
    #[serde(default)]
    pub viscosity_gradient: ViscosityGradient,
    /// The pair force (default `variational`, −∂Π/∂u; `reveles` is eq 134; `plain` is seed
    /// 002 eq 21).
    #[serde(default)]
    pub force: TlsphForce,
    /// Ganzenmüller's hourglass control with stiffness α (in units of Young's modulus);
    /// none when absent.
    pub hourglass: Option<f64>,
}

/// One rate evaluation on the GPU, as `--explain` prints it.
const GPU_RATES: &str = "stress pass (F, P, ρ̇, Ṡ) + acceleration pass (a, u̇ = v, BCs)";

impl MethodFamily for TlsphSpec {
    const DESCRIPTION: &'static str = "total-Lagrangian SPH (Reveles; seed 000 §5.3): corrected \
        reference kernel, rate- or state-based stress, Monaghan artificial viscosity";
    const KEYS: &'static [&'static str] = &[
        "artificial_viscosity",
        "viscosity_gradient",
        "force",
        "hourglass",
    ];
    const FEATURES: &'static [Feature] = &[
        Feature::Contact,
        Feature::Plasticity,
        Feature::StaticSolve,
        Feature::InitialDisplacement,
    ];
    /// A neighbour's F (pass 1), then its stress in the force (pass 2).
    const HALO_LAYERS: Option<usize> = Some(2);
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = crate::methods::cores::tl::gpu::SHADERS;

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        if let Some(alpha) = self.hourglass {
            positive("method.hourglass", alpha)?;
        }
        if self.artificial_viscosity.is_some() && case.solves_by_newton() {
            return fail(
                "method.artificial_viscosity",
                "a static or implicit run solves for u alone and the viscosity acts on the \
                 velocities, so it would be left out: remove it (an implicit run damps the \
                 modes its step does not resolve with run.hht_alpha)",
            );
        }
        check_viscosity(self.artificial_viscosity.as_ref())
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let rate = mat.model.is_rate_based();
        let mut left_out = Vec::new();
        left_out.push(
            match (&self.artificial_viscosity, self.viscosity_gradient) {
                (None, _) => "artificial viscosity",
                (Some(_), ViscosityGradient::PushedForward) => {
                    "viscosity along ∇0W̃_ij unmapped (the paper's form)"
                }
                (Some(_), ViscosityGradient::Reference) => "viscosity along F⁻ᵀ ∇0W̃_ij",
            },
        );
        if self.hourglass.is_none() {
            left_out.push("hourglass control");
        }
        left_out.push(if rate {
            "P(F) evaluation"
        } else {
            "continuity and stress rates"
        });
        let (once, force) = match self.force {
            TlsphForce::Reveles => ("", "(P_i + P_j) ∇0W̃_ij, eq 134"),
            TlsphForce::Variational => (
                " and their reverses ∇0W̃_ji",
                "P_i ∇0W̃_ij − P_j ∇0W̃_ji, variational",
            ),
            TlsphForce::Plain => (
                " and each particle's own ∇0W̃_i(X_i)",
                "P_j ∇0W̃_ij with i's own term, seed 002 eq 21",
            ),
        };
        let force = match self.hourglass {
            None => force.to_string(),
            Some(alpha) => format!("{force}, hourglass control α = {alpha}"),
        };
        Plan {
            once: format!(
                "once, on the reference configuration: cell-list neighbours (CSR), corrected \
                 gradients ∇0W̃_ij{once}"
            ),
            state: if rate {
                format!("u, v, ρ, S (rate model: {})", mat.rate_model())
            } else if mat.model == MaterialModel::VonMisesPlastic {
                "u, v; the plastic history C_p⁻¹, ε_p of every particle, committed once per \
                 step from F at the step's start"
                    .into()
            } else {
                format!("u, v (state model {:?}: no ρ or S integrated)", mat.model)
            },
            cfl_step: cfl_step(&mat),
            rates: if gpu {
                format!("{GPU_RATES}; pair force {force}")
            } else {
                format!("two gathers: F and P, then the accelerations ({force})")
            },
            checked: "det F",
            check_note: String::new(),
            left_out,
        }
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        crate::statics::explicit::cpu_engine::<D, Tlsph<D>>(case, self)
    }

    fn rank_engine<D: EngineDim>(
        &self,
        case: &Case,
        reference: Reference<D>,
        start: RankStart<D>,
    ) -> RankBuild<D> {
        if case.material.model == MaterialModel::VonMisesPlastic {
            return Err(case.invalid(
                "material.model",
                "`tlsph` with `von-mises-plastic` does not run on several ranks yet (the \
                 halo particles' plastic history is not exchanged); run it on one",
            ));
        }
        shared::rank_engine::<D, Tlsph<D>>(case, self, reference, start)
    }

    fn gpu_refusal(&self, case: &Case) -> Option<&'static str> {
        (case.material.model == MaterialModel::VonMisesPlastic).then_some(
            "with `von-mises-plastic` has no GPU engine (its plastic history per particle \
             runs on the CPU)",
        )
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D> {
        if let Some(why) = self.gpu_refusal(case) {
            let what = format!("`tlsph` {why}; run it with `--backend cpu`");
            return Err(case.invalid("material.model", what).into());
        }
        Ok(Box::new(GpuTlsph::<D>::new(
            case,
            gpu::scheme(self, case.method.correction),
            gpu,
        )?))
    }

    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        Some(GpuTlsph::<D>::memory(
            case,
            &gpu::scheme(self, case.method.correction),
            counts,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viscosity_coefficients_must_not_be_negative() {
        let spec = |beta: f64| TlsphSpec {
            artificial_viscosity: Some(ArtificialViscosity {
                alpha: 1.0,
                beta,
                eta: 0.1,
            }),
            viscosity_gradient: ViscosityGradient::PushedForward,
            force: TlsphForce::Reveles,
            hourglass: None,
        };
        let case = crate::scene::validate::minimal_case();
        spec(1.0).validate(&case).unwrap();
        let (key, message) = spec(-1.0).validate(&case).unwrap_err();
        assert_eq!(key, "method.artificial_viscosity.beta");
        assert!(message.contains("-1"), "{message}");
    }
}
