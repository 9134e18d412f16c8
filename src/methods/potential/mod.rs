//! Total-Lagrangian SPH from the elastic potential (after Müller et al.; seed 000 §5.4):
//! the spec, the CPU system ([`system`]) and its force on the total-Lagrangian GPU engine
//! ([`gpu`]). Numerics notes: `docs/methods/tl-potential.md`.

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod system;

pub use system::Potential;

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

/// The volume factors of the symmetrised potential force (seed 000 §3.4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PotentialForce {
    /// f_i = Σ_j V_i V_j [P_i ∇0W̃_ij − P_j ∇0W̃_ji] = −∂Π/∂u_i, Π = Σ_i V_i ψ(F_i).
    #[default]
    Consistent,
    /// The reference code's f_i = Σ_j [V_i P_i ∇0W̃_ij − V_j P_j ∇0W̃_ji]: each term lacks
    /// the neighbour's volume, a stiffness scale of 1/V (in SI units) on a uniform lattice.
    ReferenceCode,
}

/// The `[method]` keys of the elastic-potential method.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
pub struct PotentialSpec {
    /// The volume factors of the force (default `consistent`).
    #[serde(default)]
    pub force: PotentialForce,
    /// Monaghan artificial viscosity; none when absent.
    pub artificial_viscosity: Option<ArtificialViscosity>,
}

impl MethodFamily for PotentialSpec {
    const DESCRIPTION: &'static str = "total-Lagrangian SPH from the elastic potential \
        (Müller et al.; seed 000 §5.4): symmetrised force −∂Π/∂u with corrected reference \
        gradients of both sides, state-based stress, Monaghan artificial viscosity";
    const KEYS: &'static [&'static str] = &["force", "artificial_viscosity"];
    const FEATURES: &'static [Feature] = &[Feature::Contact, Feature::InitialDisplacement];
    /// A neighbour's kinematics (pass 1), then its stress in the force (pass 2).
    const HALO_LAYERS: Option<usize> = Some(2);
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = gpu::SHADERS;

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        check_viscosity(self.artificial_viscosity.as_ref())?;
        state_model(case)
    }

    fn plan(&self, case: &Case, _gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let left_out = left_out_viscosity(self.artificial_viscosity.as_ref());
        Plan {
            once: "once, on the reference configuration: cell-list neighbours (CSR), corrected \
                   gradients ∇0W̃_ij and their reverses ∇0W̃_ji"
                .into(),
            state: format!("u, v (state model {:?})", mat.model),
            cfl_step: match self.force {
                PotentialForce::Consistent => cfl_step(&mat),
                PotentialForce::ReferenceCode => format!(
                    "Δt = cfl·Δx/(c_p/√V_min + max|v|), c_p = {:.1} m/s (the reference \
                     code's force is 1/V stiffer)",
                    mat.p_wave_speed()
                ),
            },
            rates: format!(
                "two gathers: F and P = ∂ψ/∂F, then the {} symmetrised forces",
                toml_name(&self.force)
            ),
            checked: "det F",
            check_note: String::new(),
            left_out,
        }
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        Ok(Box::new(CpuEngine::<D, Potential<D>>::new(case, self)?))
    }

    fn rank_engine<D: EngineDim>(
        &self,
        case: &Case,
        reference: Reference<D>,
        start: RankStart<D>,
    ) -> RankBuild<D> {
        shared::rank_engine::<D, Potential<D>>(case, self, reference, start)
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
}
