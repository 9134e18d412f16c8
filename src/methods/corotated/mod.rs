//! Corotated total-Lagrangian SPH (after Becker, Ihmsen and Teschner; seed 000 §5.5): the
//! spec, the CPU system ([`system`]) and its passes on the total-Lagrangian GPU engine
//! ([`gpu`]). Numerics notes: `docs/methods/corotated-tlsph.md`.

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod system;

pub use system::{Corotated, CorotatedScheme, outputs, rotation};

use crate::engine::ranks::RankStart;
#[cfg(feature = "gpu")]
use crate::methods::cores::family::GpuBuild;
use crate::methods::cores::family::{
    CpuBuild, Feature, MethodFamily, Plan, RankBuild, cfl_step, check_viscosity,
    left_out_viscosity, state_model,
};
use crate::methods::cores::shared;
#[cfg(feature = "gpu")]
use crate::methods::cores::tl::gpu::GpuTlsph;
use crate::reference::Reference;

use crate::case::Case;
use crate::core::check::{Problem, toml_name};
use crate::engine::{CpuEngine, EngineDim};
use crate::physics::material::Material;
use crate::physics::viscosity::ArtificialViscosity;
use serde::{Deserialize, Serialize};

/// The pair force of corotated TLSPH.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum CorotatedForce {
    /// m_i a_i = V_i Σ_j V_j (R_i P̂_i ∇0W_ij − R_j P̂_j ∇0W_ji): each side's stress
    /// rotated back by its own rotation on its own corrected gradient, −∂Π/∂u_i of
    /// Π = Σ_i V_i ψ(F̂_i) with the rotations held (TLSPH's `variational`). The default:
    /// it carries surface loads whole and keeps linear momentum with every correction.
    #[default]
    Variational,
    /// m_i a_i = V_i Σ_j V_j ½(R_i + R_j)(P̂_i + P̂_j) ∇0W_ij (seed 000 eq 155 as the
    /// reference code writes it): i's gradient on both stresses, like TLSPH's eq 134.
    /// With a correction it carries about half a surface load. The seed-000 cases set it.
    ReferenceCode,
}

/// The `[method]` keys of corotated TLSPH.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
pub struct CorotatedSpec {
    /// Monaghan artificial viscosity; none when absent.
    pub artificial_viscosity: Option<ArtificialViscosity>,
    /// The pair force (default `variational`; `reference-code` is eq 155 of the code).
    #[serde(default)]
    pub force: CorotatedForce,
}

impl MethodFamily for CorotatedSpec {
    const DESCRIPTION: &'static str = "corotated total-Lagrangian SPH (Becker et al.; seed 000 \
        §5.5): shape-matching rotations, stress of the rotated displacements, each side's \
        force rotated back with its own R (or with ½(R_i + R_j), the reference code's), \
        Monaghan artificial viscosity";
    const KEYS: &'static [&'static str] = &["artificial_viscosity", "force"];
    const FEATURES: &'static [Feature] = &[Feature::Contact, Feature::InitialDisplacement];
    /// A neighbour's kinematics (pass 1), then its stress in the force (pass 2).
    const HALO_LAYERS: Option<usize> = Some(2);
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = gpu::SHADERS;

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        check_viscosity(self.artificial_viscosity.as_ref())?;
        state_model(case)
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let left_out = left_out_viscosity(self.artificial_viscosity.as_ref());
        let (reverse, force) = match self.force {
            CorotatedForce::Variational => (
                " and their reverses ∇0W_ji",
                "R_i P̂_i ∇0W_ij − R_j P̂_j ∇0W_ji, variational",
            ),
            CorotatedForce::ReferenceCode => {
                ("", "½(R_i + R_j)(P̂_i + P̂_j)∇0W_ij, the reference code's")
            }
        };
        let rotation = if case.dimension == 2 {
            "closed form"
        } else {
            "polar decomposition by scaled Newton iteration"
        };
        Plan {
            once: format!(
                "once, on the reference configuration: cell-list neighbours (CSR), reference \
                 gradients ∇0W_ij ({} correction){reverse}, {}",
                toml_name(&case.method.correction),
                if gpu {
                    "pair offsets X_j − X_i"
                } else {
                    "shape-matching weights m_j W_ij"
                }
            ),
            state: format!("u, v (state model {:?} of the corotated F̂)", mat.model),
            cfl_step: cfl_step(&mat),
            rates: if gpu {
                format!(
                    "shape-matching pass (A_i, its rotation R_i ({rotation}), F̂_i, \
                     P̂(F̂_i); R_i kept per particle) + acceleration pass (the forces \
                     {force}, a, u̇ = v, BCs)"
                )
            } else {
                format!(
                    "two gathers: shape matching A_i, its rotation R_i ({rotation}), F̂_i and \
                     P̂(F̂_i); then the forces {force}"
                )
            },
            checked: "det R, det F̂",
            check_note: String::new(),
            left_out,
        }
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        Ok(Box::new(CpuEngine::<D, Corotated<D>>::new(case, self)?))
    }

    fn rank_engine<D: EngineDim>(
        &self,
        case: &Case,
        reference: Reference<D>,
        start: RankStart<D>,
    ) -> RankBuild<D> {
        shared::rank_engine::<D, Corotated<D>>(case, self, reference, start)
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D> {
        Ok(Box::new(GpuTlsph::<D>::new(case, gpu::scheme(self), gpu)?))
    }

    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        Some(GpuTlsph::<D>::memory(case, &gpu::scheme(self), counts))
    }

    fn warning(&self, case: &Case) -> Option<String> {
        let undamped = self.artificial_viscosity.is_none() && !case.is_static();
        (self.force == CorotatedForce::ReferenceCode && undamped).then(|| {
            "method.force = \"reference-code\" is not the gradient of an energy, and without \
             artificial viscosity a vibration gains energy: a released cantilever gains 11 % \
             in a sixth of its period (docs/methods/corotated-tlsph.md); use force = \
             \"variational\" (the default) or add artificial_viscosity"
                .to_string()
        })
    }
}
