//! Godunov SPH with the acoustic Riemann solver of Parshikov and Medin (seed 000 §5.2,
//! Algorithm 2, eqs 128–133): the spec and the CPU system ([`system`], a pair scheme of
//! the updated-Lagrangian core [`super::ul`]). Numerics notes: `docs/methods/godunov.md`.

pub mod system;

pub use system::Godunov;

use super::{Feature, MethodFamily, Plan, Problem};
use crate::correction::CorrectionKind;
use crate::material::Material;
use crate::neighbour::Rebuild;
use crate::run::{CpuEngine, Engine, EngineDim};
use crate::scene::Case;
use crate::scene::validate::{fail, toml_name};
use crate::tensor::Dim;
use serde::{Deserialize, Serialize};

/// The `[method]` keys of Godunov SPH: none besides the common ones.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GodunovSpec {}

/// The corrections of the velocity gradient (eq 105) this method runs.
const CORRECTIONS: [CorrectionKind; 2] = [CorrectionKind::None, CorrectionKind::RandlesLibersky];

impl MethodFamily for GodunovSpec {
    const DESCRIPTION: &'static str = "Godunov SPH (Parshikov–Medin; seed 000 §5.2): \
        updated-Lagrangian, neighbours rebuilt every stage, acoustic Riemann solutions in \
        the continuity and momentum equations, no artificial viscosity (CPU only)";
    const KEYS: &'static [&'static str] = &[];
    const FEATURES: &'static [Feature] = &[Feature::Contact];
    const NEIGHBOURS: Rebuild = Rebuild::EveryStage;
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = &[];

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        let name = case.method.name();
        if !case.material.model.is_rate_based() {
            return fail(
                "material.model",
                format!(
                    "`{name}` integrates ρ and S with the Jaumann rate: use `hypoelastic`, not {}",
                    toml_name(&case.material.model)
                ),
            );
        }
        if !CORRECTIONS.contains(&case.method.correction) {
            return fail(
                "method.correction",
                format!(
                    "`{name}` corrects its velocity gradient with `none` (the paper's) or \
                     `randles-libersky`, not {}",
                    toml_name(&case.method.correction)
                ),
            );
        }
        Ok(())
    }

    fn plan(&self, case: &Case, _gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        Plan {
            once: "nothing: the neighbours are rebuilt at every rate evaluation".into(),
            state: "u, v, ρ, S, and F integrated by Ḟ = L F for the outputs".into(),
            cfl_step: format!(
                "Δt = cfl·Δx/(c_p + max|v|), c_p = {:.1} m/s",
                mat.p_wave_speed()
            ),
            rates: format!(
                "cell-list neighbours from the current positions (per body), then one gather: \
                 L ({} gradients), Ṡ, Ḟ, and ρ̇ and a from the pairs' acoustic Riemann \
                 solutions",
                toml_name(&case.method.correction)
            ),
            checked: "ρ > 0",
            check_note: String::new(),
            left_out: vec!["artificial viscosity (the Riemann solver dissipates)"],
        }
    }

    fn cpu_engine<D: EngineDim>(
        &self,
        case: &Case,
    ) -> Result<Box<dyn Engine<D>>, crate::scene::CaseError> {
        Ok(Box::new(CpuEngine::<D, Godunov<D>>::new(case)?))
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(
        &self,
        case: &Case,
        _gpu: crate::gpu::Gpu,
    ) -> Result<Box<dyn Engine<D>>, crate::gpu::SetupError> {
        Err(case
            .invalid(
                "method.name",
                "`godunov-sph` has no GPU engine; run it with --backend cpu",
            )
            .into())
    }

    /// The step Δt = cfl Δx/(c_p + max|v|) does not depend on the stretch.
    fn stretch_signal_speed<D: Dim>(&self, _c_p: f64, _f: D::T) -> f64 {
        0.0
    }
}
