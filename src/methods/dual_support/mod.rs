//! Implicit dual-support SPH (Ren, Zhuang, Rabczuk & Zhu; seed 004): a smoothing length
//! per particle with supports and dual-supports ([`support`]), the variational internal
//! force and hourglass energy with their tangent ([`model`]), the model of the static
//! Newton engine of [`crate::statics`] ([`statics`]; on the GPU with its Newton steps
//! solved matrix-free, [`krylov`]), and the explicit dynamic variant on the same forces
//! ([`dynamics`], `run.solve = "dynamic"`; also on the GPU, [`gpu`]).
//! Numerics notes: `docs/methods/dual-support.md`.

pub mod dynamics;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(feature = "gpu")]
pub mod krylov;
pub mod model;
pub mod statics;
pub mod support;

pub use crate::statics::sparse::SolverKind;
pub use dynamics::DualSupportDynamics;
pub use model::{DualSupport, Energies};
pub use statics::{Statics, pattern};
pub use support::Support;

use crate::engine::ranks::RankStart;
#[cfg(feature = "gpu")]
use crate::methods::cores::family::GpuBuild;
use crate::methods::cores::family::{CpuBuild, Feature, MethodFamily, Plan, RankBuild};
use crate::methods::cores::shared;

use crate::case::{Case, CaseError};
use crate::core::check::{Problem, fail, non_negative, toml_name};
use crate::core::neighbour;
use crate::core::tensor::Dim;
use crate::engine::{CpuEngine, EngineDim};
use crate::physics::material::Material;
use crate::reference::Reference;
use serde::{Deserialize, Serialize};

/// How the smoothing length of each particle is chosen (`method.smoothing_length`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SmoothingLength {
    /// h = h_over_dx · Δx for every particle.
    #[default]
    Uniform,
    /// h_i = h_over_dx · V_i^(1/d) (eq 58 with Δx_i from the particle's volume).
    Volume,
    /// The support radius of i reaches its k-th nearest particle (§6.2, §6.5: "the k
    /// nearest particles"; that particle sits where W and W′ vanish).
    Nearest(u32),
}

/// The `[method]` keys of dual-support SPH.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DualSupportSpec {
    /// Hourglass penalty α in units of the shear modulus μ (eq 21 with α replacing μ in
    /// α/m_L; §6.5's "α = 5μ" is 5); 0 switches the hourglass energy off. Default 1.
    #[serde(default = "one")]
    pub hourglass: f64,
    #[serde(default)]
    pub smoothing_length: SmoothingLength,
    /// `direct` (sparse Cholesky, the default) or `cg` (Jacobi-preconditioned CG), on the
    /// CPU; the GPU solves matrix-free by Jacobi CG whatever this says.
    #[serde(default)]
    pub solver: SolverKind,
    /// Newton stops when |R| ≤ this × the force scale: this method's older name of
    /// `run.tolerance.residual` ([`crate::case::Tolerance`]), which it overrides;
    /// absent: run.tolerance's (default 1e-8). Not both.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual_tolerance: Option<f64>,
    /// … or when |Δu| ≤ this × |u|: the older name of `run.tolerance.increment`, as
    /// above (default 1e-10).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub increment_tolerance: Option<f64>,
    /// Newton iterations of a load step before it is cut in half. Default 20.
    #[serde(default = "max_iterations")]
    pub max_iterations: u32,
    /// Halvings of a load step before the run fails. Default 6.
    #[serde(default = "max_cuts")]
    pub max_cuts: u32,
    /// CG's relative residual. Default 1e-10 (the GPU's f32 CG stops at no less than
    /// 1e-5, `krylov::F32_TOLERANCE`).
    #[serde(default = "linear_tolerance")]
    pub linear_tolerance: f64,
    /// CG's iteration limit. Default 20000.
    #[serde(default = "linear_max_iterations")]
    pub linear_max_iterations: u32,
}

fn one() -> f64 {
    1.0
}
fn max_iterations() -> u32 {
    20
}
fn max_cuts() -> u32 {
    6
}
fn linear_tolerance() -> f64 {
    1e-10
}
fn linear_max_iterations() -> u32 {
    20_000
}

impl Default for DualSupportSpec {
    fn default() -> Self {
        Self {
            hourglass: one(),
            smoothing_length: SmoothingLength::default(),
            solver: SolverKind::default(),
            residual_tolerance: None,
            increment_tolerance: None,
            max_iterations: max_iterations(),
            max_cuts: max_cuts(),
            linear_tolerance: linear_tolerance(),
            linear_max_iterations: linear_max_iterations(),
        }
    }
}

impl DualSupportSpec {
    /// The smoothing length of every particle of a reference configuration, by the rule
    /// `method.smoothing_length`.
    pub fn particle_smoothing_lengths<D: Dim>(
        &self,
        case: &Case,
        reference: &Reference<D>,
    ) -> Result<Vec<f64>, CaseError> {
        let h = case.smoothing_length();
        Ok(match self.smoothing_length {
            SmoothingLength::Uniform => vec![h; reference.len()],
            SmoothingLength::Volume => reference
                .vol
                .iter()
                .map(|v| case.method.h_over_dx * v.powf(1.0 / D::N as f64))
                .collect(),
            SmoothingLength::Nearest(k) => {
                let k = k as usize;
                if reference.len() <= k {
                    return Err(case.invalid(
                        "method.smoothing_length.nearest",
                        format!(
                            "asks for the {k}th nearest particle, but the case has {} particles",
                            reference.len()
                        ),
                    ));
                }
                let factor = case.method.kernel.support_factor();
                nearest_distances::<D>(&reference.x0, k, case.spacing)
                    .into_iter()
                    .map(|r| r / factor)
                    .collect()
            }
        })
    }

    /// The method on the reference configuration of `case`: smoothing lengths, supports,
    /// dual-supports and the hourglass coefficients (the static, dynamic and GPU paths
    /// alike).
    pub fn model<D: Dim>(
        &self,
        case: &Case,
        reference: &Reference<D>,
    ) -> Result<DualSupport<D>, CaseError> {
        // A rank's share carries the lengths of the whole run, set before its halo was
        // built ([`MethodFamily::smoothing_lengths`]): the nearest-particle rule on the
        // share alone would lengthen its outer ghosts' supports.
        let h = if reference.method_lengths {
            reference.h.clone()
        } else {
            self.particle_smoothing_lengths::<D>(case, reference)?
        };
        let (x0, vol) = (reference.x0.clone(), reference.vol.clone());
        let support = Support::<D>::new(x0, vol, h, case.method.kernel)
            .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
        Ok(DualSupport::new(
            support,
            reference.material,
            self.hourglass,
            reference.counted.clone(),
        ))
    }
}

/// The distance from every particle to its k-th nearest other particle (a radius search
/// doubled until every particle has k neighbours).
fn nearest_distances<D: Dim>(x0: &[D::V], k: usize, spacing: f64) -> Vec<f64> {
    let mut radius = spacing * (k as f64).powf(1.0 / D::N as f64);
    loop {
        let csr = neighbour::build::<D>(x0, radius);
        if (0..x0.len()).all(|i| csr.neighbours(i).len() >= k) {
            return (0..x0.len())
                .map(|i| {
                    let mut d: Vec<f64> = csr
                        .neighbours(i)
                        .iter()
                        .map(|&j| D::norm2(x0[j as usize] - x0[i]).sqrt())
                        .collect();
                    d.sort_by(f64::total_cmp);
                    d[k - 1]
                })
                .collect();
        }
        radius *= 2.0;
    }
}

impl MethodFamily for DualSupportSpec {
    const DESCRIPTION: &'static str = "implicit dual-support SPH (Ren et al.; seed 004): \
        smoothing length per particle, variational force with dual-supports, hourglass \
        energy, tangent and static Newton–Raphson with load steps (CPU: assembled tangent; \
        GPU: matrix-free CG); explicit in time with run.solve = \"dynamic\" (CPU and GPU)";
    const KEYS: &'static [&'static str] = &[
        "hourglass",
        "smoothing_length",
        "solver",
        "residual_tolerance",
        "increment_tolerance",
        "max_iterations",
        "max_cuts",
        "linear_tolerance",
        "linear_max_iterations",
    ];
    const FEATURES: &'static [Feature] = &[
        Feature::StaticSolve,
        Feature::GpuStaticSolve,
        Feature::StaticDefault,
        Feature::InitialDisplacement,
    ];
    /// F_j of a neighbour j (from its support) enters the gather of i's force over its
    /// support and dual-support, as do the hourglass terms of j's pair slots.
    const HALO_LAYERS: Option<usize> = Some(2);
    const CORRECTED: bool = false;
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = gpu::SHADERS;

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        let model = case.material.model;
        if model.is_rate_based() {
            return fail(
                "material.model",
                format!(
                    "`dual-support-sph` derives its force from the strain energy ψ(F): use a \
                     model whose stress follows from F, not {}",
                    toml_name(&model)
                ),
            );
        }
        if case.solves_by_newton() && !model.has_tangent() {
            return fail(
                "material.model",
                format!(
                    "`dual-support-sph` needs the tangent ∂P/∂F of its model: use \
                     `linear-elastic`, `neo-hookean`, `nearly-incompressible-neo-hookean` or \
                     `saint-venant-kirchhoff`, not {} (or run it in time with run.solve = \
                     \"dynamic\")",
                    toml_name(&model)
                ),
            );
        }
        if case.solves_by_newton() && (case.method.dt.is_none() || case.method.cfl.is_some()) {
            return fail(
                "method.dt",
                if case.is_implicit() {
                    "`dual-support-sph` runs implicitly here: give method.dt, the time step \
                     (end_time/dt steps), and no method.cfl"
                } else {
                    "`dual-support-sph` is static: give method.dt, the load step in the \
                     pseudo-time of run.end_time (end_time/dt load steps), and no method.cfl"
                },
            );
        }
        non_negative("method.hourglass", self.hourglass)?;
        for (key, v) in [
            ("method.residual_tolerance", self.residual_tolerance),
            ("method.increment_tolerance", self.increment_tolerance),
            ("method.linear_tolerance", Some(self.linear_tolerance)),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0 && v < 1.0)
            {
                return fail(key, format!("must lie in (0, 1), got {v:?}"));
            }
        }
        for (key, own, run) in [
            (
                "residual",
                self.residual_tolerance,
                case.run.tolerance.residual,
            ),
            (
                "increment",
                self.increment_tolerance,
                case.run.tolerance.increment,
            ),
        ] {
            if own.is_some() && run.is_some() {
                return fail(
                    format!("method.{key}_tolerance"),
                    format!(
                        "and run.tolerance.{key} are the same tolerance: give \
                         run.tolerance.{key} only (method.{key}_tolerance is this method's \
                         older name of it)"
                    ),
                );
            }
        }
        for (key, v) in [
            ("method.max_iterations", self.max_iterations),
            ("method.linear_max_iterations", self.linear_max_iterations),
        ] {
            if v == 0 {
                return fail(key, "must be at least 1, got 0");
            }
        }
        if self.smoothing_length == SmoothingLength::Nearest(0) {
            return fail(
                "method.smoothing_length.nearest",
                "must be at least the dimension + 1, got 0",
            );
        }
        Ok(())
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let smoothing = match self.smoothing_length {
            SmoothingLength::Uniform => "uniform".to_string(),
            SmoothingLength::Volume => "h_over_dx · V^(1/d)".to_string(),
            SmoothingLength::Nearest(k) => format!("{k} nearest"),
        };
        if !case.solves_by_newton() {
            let mut left_out = vec!["the tangent and the linear solver (explicit in time)"];
            if self.hourglass == 0.0 {
                left_out.push("hourglass energy");
            }
            return Plan {
                once: format!(
                    "once, on the reference configuration: smoothing lengths ({smoothing}), \
                     supports S_i and dual-supports S'_i, corrected gradients g_ij = \
                     L_i⁻¹∇W_i V_j"
                ),
                state: format!("u, v (state model {:?})", mat.model),
                cfl_step: "Δt = cfl · Δx / (c_p + max |v|)".into(),
                rates: format!(
                    "F_i, P_i; m_i ü_i = f_i (eq 18) + hourglass (eq 28, α = {}μ) + loads",
                    self.hourglass
                ),
                checked: "det F",
                check_note: String::new(),
                left_out,
            };
        }
        let implicit = case.is_implicit();
        let mut left_out = match implicit {
            true => vec![],
            false => vec!["time integration (static)"],
        };
        if self.hourglass == 0.0 {
            left_out.push("hourglass energy");
        }
        Plan {
            once: format!(
                "once, on the reference configuration: smoothing lengths ({}), supports S_i \
                 and dual-supports S'_i, corrected gradients g_ij = L_i⁻¹∇W_i V_j, {}",
                smoothing,
                match (gpu, self.solver) {
                    (true, _) => {
                        "the device's union lists S_i ∪ S'_i with their pair data and the \
                         Krylov buffers (no tangent pattern)"
                    }
                    (false, SolverKind::Direct) => {
                        "the two-hop pattern of the tangent and its symbolic Cholesky"
                    }
                    (false, SolverKind::Cg) => "the two-hop pattern of the tangent",
                }
            ),
            state: match implicit {
                true => format!("u, v, a and f_int(u_n) (state model {:?})", mat.model),
                false => format!("u (state model {:?}); no velocity", mat.model),
            },
            cfl_step: match implicit {
                true => "none: implicit steps of method.dt".into(),
                false => "none: load steps of method.dt".into(),
            },
            rates: format!(
                "F_i, P_i, 𝔸_i; R = f_int + λ f_ext; K = Σ_i V_i δF_iᵀ𝔸_iδF_i + hourglass \
                 (α = {}μ); {}",
                self.hourglass,
                match (gpu, self.solver) {
                    (true, _) => {
                        "K never assembled: Jacobi CG on the device (f32, K p by the force \
                         pass's gather with P → 𝔸:δH), 𝔸 and diag K from the host's f64"
                    }
                    (false, SolverKind::Direct) => {
                        "sparse Cholesky (LU if the tangent is indefinite)"
                    }
                    (false, SolverKind::Cg) => "conjugate gradients",
                }
            ),
            checked: "det F",
            check_note: String::new(),
            left_out,
        }
    }

    fn smoothing_lengths<D: Dim>(
        &self,
        case: &Case,
        reference: &Reference<D>,
    ) -> Result<Option<Vec<f64>>, CaseError> {
        self.particle_smoothing_lengths(case, reference).map(Some)
    }

    /// The dynamic variant's system on a rank's particles (the static solve does not run
    /// on several ranks).
    fn rank_engine<D: EngineDim>(
        &self,
        case: &Case,
        reference: Reference<D>,
        start: RankStart<D>,
    ) -> RankBuild<D> {
        shared::rank_engine::<D, DualSupportDynamics<D>>(case, self, reference, start)
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        Ok(if case.solves_by_newton() {
            Box::new(Statics::<D>::new(case, self)?)
        } else {
            Box::new(CpuEngine::<D, DualSupportDynamics<D>>::new(case, self)?)
        })
    }

    /// The dynamic variant, or the static solve with its Newton steps solved matrix-free
    /// on the device ([`krylov`]).
    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D> {
        if case.is_static() {
            let reference = Reference::<D>::build(case)?;
            let lists = gpu::lists(case, self, &reference)?;
            let iterations = self.linear_max_iterations as usize;
            let solver = krylov::NewtonKrylov::new(gpu, &lists, self.linear_tolerance, iterations)?;
            let linearisation = crate::statics::Linearisation::MatrixFree(Box::new(solver));
            let engine = Statics::<D>::on(case, self, reference, lists.model, linearisation)?;
            return Ok(Box::new(engine));
        }
        let scheme = gpu::scheme(self);
        Ok(Box::new(
            crate::methods::cores::tl::gpu::GpuTlsph::<D>::new(case, scheme, gpu)?,
        ))
    }

    /// The dynamic variant's buffers, or the static solve's ([`krylov`]).
    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        use crate::methods::cores::tl::gpu::GpuTlsph;
        Some(match case.is_static() {
            true => krylov::NewtonKrylov::memory(counts, D::N),
            false => GpuTlsph::<D>::memory(case, &gpu::scheme(self), counts),
        })
    }

    /// c_p, the wave speed of the dynamic variant's step (the static path has none).
    fn stretch_signal_speed<D: Dim>(&self, c_p: f64, _f: D::T) -> f64 {
        c_p
    }
}
