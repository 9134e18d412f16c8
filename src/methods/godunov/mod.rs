//! Godunov SPH with the acoustic Riemann solver of Parshikov and Medin (seed 000 §5.2,
//! Algorithm 2, eqs 128–133): the spec and the CPU system ([`system`], a pair scheme of
//! the updated-Lagrangian core [`super::cores::ul`]). Numerics notes: `docs/methods/godunov.md`.

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod system;

pub use system::Godunov;

#[cfg(feature = "gpu")]
use crate::methods::cores::family::GpuBuild;
use crate::methods::cores::family::{CpuBuild, Feature, MethodFamily, Plan, cfl_step};
#[cfg(feature = "gpu")]
use crate::methods::cores::ul::gpu::GpuUl;
use crate::methods::cores::ul::{FreeSurface, SmoothingLength};

use crate::case::Case;
use crate::core::check::Problem;
use crate::core::neighbour::Rebuild;
use crate::engine::{CpuEngine, EngineDim};
use crate::physics::material::Material;
use serde::{Deserialize, Serialize};

/// The `[method]` keys of Godunov SPH.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GodunovSpec {
    /// The traction-free treatment of the surface (none by default).
    #[serde(default)]
    pub free_surface: FreeSurface,
    /// The smoothing length, fixed (the default) or adaptive (eqs 60–62).
    #[serde(default)]
    pub smoothing_length: SmoothingLength,
}

impl MethodFamily for GodunovSpec {
    const DESCRIPTION: &'static str = "Godunov SPH (Parshikov–Medin; seed 000 §5.2): \
        updated-Lagrangian, neighbours rebuilt every stage, acoustic Riemann solutions in \
        the continuity and momentum equations, no artificial viscosity";
    const KEYS: &'static [&'static str] = &["free_surface", "smoothing_length"];
    const FEATURES: &'static [Feature] = &[Feature::Contact, Feature::RatePlasticity];
    const NEIGHBOURS: Rebuild = Rebuild::OnDrift;
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = gpu::SHADERS;

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        super::cores::ul::validate(case, self.smoothing_length)
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        Plan {
            once: "nothing: the neighbour lists follow the particles (see the rates)".into(),
            state: super::cores::ul::plan_state(case),
            cfl_step: cfl_step(&mat),
            rates: format!(
                "{}, Ṡ, Ḟ, and ρ̇ and a from the pairs' acoustic Riemann solutions",
                super::cores::ul::plan_rebuild(case, gpu, self.smoothing_length)
            ),
            checked: "ρ",
            check_note: String::new(),
            left_out: [
                Some("artificial viscosity (the Riemann solver dissipates)"),
                (self.free_surface == FreeSurface::None)
                    .then_some("traction-free surface (free_surface)"),
                super::cores::ul::left_out_smoothing(self.smoothing_length),
            ]
            .into_iter()
            .flatten()
            .collect(),
        }
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        Ok(Box::new(CpuEngine::<D, Godunov<D>>::new(case, self)?))
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D> {
        Ok(Box::new(GpuUl::<D>::new(case, gpu, &gpu::scheme(self))?))
    }

    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        Some(GpuUl::<D>::memory(case, &gpu::scheme(self), counts))
    }

    fn warning(&self, _case: &Case) -> Option<String> {
        super::cores::ul::free_surface_warning(self.free_surface)
    }
}
