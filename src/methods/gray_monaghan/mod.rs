//! Gray–Monaghan stress-corrected updated-Lagrangian SPH (seed 000 §5.1, Algorithm 1,
//! eqs 118–127): the spec and the CPU system ([`system`], a pair scheme of the
//! updated-Lagrangian core [`super::cores::ul`]). Numerics notes:
//! `docs/methods/gray-monaghan.md`.

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod system;

pub use system::GrayMonaghan;

#[cfg(feature = "gpu")]
use crate::methods::cores::family::GpuBuild;
use crate::methods::cores::family::{
    CpuBuild, Feature, MethodFamily, Plan, cfl_step, check_viscosity, left_out_viscosity,
};
#[cfg(feature = "gpu")]
use crate::methods::cores::ul::gpu::GpuUl;
use crate::methods::cores::ul::{FreeSurface, SmoothingLength};

use crate::case::Case;
use crate::core::check::{Problem, fail, non_negative};
use crate::core::integrate::IntegratorKind;
use crate::core::neighbour::Rebuild;
use crate::engine::{CpuEngine, EngineDim};
use crate::physics::material::Material;
use crate::physics::viscosity::ArtificialViscosity;
use serde::{Deserialize, Serialize};

/// The artificial stress of Gray, Monaghan and Swift (eqs 118–125): R_i from the tensile
/// principal stresses of particle i, weighted per pair by f_ij^n with f_ij = W_ij/W(Δp).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ArtificialStress {
    /// ε of eq 122 (the seed: 0.3).
    pub epsilon: f64,
    /// The exponent n of f_ij^n in eq 118 (the seed: 4).
    pub n: f64,
}

/// The `[method]` keys of Gray–Monaghan SPH.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
pub struct GrayMonaghanSpec {
    /// Monaghan artificial viscosity; none when absent.
    pub artificial_viscosity: Option<ArtificialViscosity>,
    /// Artificial stress; none when absent.
    pub artificial_stress: Option<ArtificialStress>,
    /// The XSPH factor ε of eq 127; none when absent.
    pub xsph: Option<f64>,
    /// The traction-free treatment of the surface (none by default).
    #[serde(default)]
    pub free_surface: FreeSurface,
    /// The smoothing length, fixed (the default) or adaptive (eqs 60–62).
    #[serde(default)]
    pub smoothing_length: SmoothingLength,
}

impl MethodFamily for GrayMonaghanSpec {
    const DESCRIPTION: &'static str = "Gray–Monaghan stress-corrected updated-Lagrangian SPH \
        (seed 000 §5.1): neighbours rebuilt every stage, objective stress rate, artificial viscosity, \
        artificial stress and XSPH";
    const KEYS: &'static [&'static str] = &[
        "artificial_viscosity",
        "artificial_stress",
        "xsph",
        "free_surface",
        "smoothing_length",
    ];
    const FEATURES: &'static [Feature] = &[Feature::Contact, Feature::RatePlasticity];
    const NEIGHBOURS: Rebuild = Rebuild::OnDrift;
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = gpu::SHADERS;

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        super::cores::ul::validate(case, self.smoothing_length)?;
        check_viscosity(self.artificial_viscosity.as_ref())?;
        if let Some(ArtificialStress { epsilon, n }) = self.artificial_stress {
            non_negative("method.artificial_stress.epsilon", epsilon)?;
            non_negative("method.artificial_stress.n", n)?;
        }
        if let Some(xsph) = self.xsph {
            if !(0.0..=1.0).contains(&xsph) {
                return fail(
                    "method.xsph",
                    format!("must lie in [0, 1] (the seed uses 0.5), got {xsph:?}"),
                );
            }
            if case.method.integrator == IntegratorKind::Leapfrog {
                return fail(
                    "method.integrator",
                    "the leapfrog drifts the positions with the velocity alone, which leaves \
                     out the XSPH term of ẋ (method.xsph); use `rk4`, `ssp-rk3` or `tvd-rk2`, \
                     or remove method.xsph",
                );
            }
        }
        Ok(())
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let mut left_out = left_out_viscosity(self.artificial_viscosity.as_ref());
        if self.artificial_stress.is_none() {
            left_out.push("artificial stress");
        }
        if self.xsph.is_none() {
            left_out.push("XSPH");
        }
        if self.free_surface == FreeSurface::None {
            left_out.push("traction-free surface (free_surface)");
        }
        left_out.extend(super::cores::ul::left_out_smoothing(self.smoothing_length));
        Plan {
            once: "nothing but W(Δp): the neighbour lists follow the particles (see the rates)"
                .into(),
            state: super::cores::ul::plan_state(case),
            cfl_step: cfl_step(&mat),
            rates: format!(
                "{}, ρ̇, Ṡ, Ḟ, a, ẋ",
                super::cores::ul::plan_rebuild(case, gpu, self.smoothing_length)
            ),
            checked: "ρ",
            check_note: String::new(),
            left_out,
        }
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        Ok(Box::new(CpuEngine::<D, GrayMonaghan<D>>::new(case, self)?))
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D> {
        Ok(Box::new(GpuUl::<D>::new(
            case,
            gpu,
            &gpu::scheme(case, self),
        )?))
    }

    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        Some(GpuUl::<D>::memory(case, &gpu::scheme(case, self), counts))
    }

    fn warning(&self, _case: &Case) -> Option<String> {
        super::cores::ul::free_surface_warning(self.free_surface)
    }
}
