//! The run driver: builds a case's engine through its method's spec ([`engine`]),
//! integrates it to the end time ([`drive`]: a scheduler of events whose callbacks are
//! the outputs, the blow-up checks and the logs), and writes the summary. The driver knows stages, not methods.

mod batch;
pub mod budget;
pub mod checkpoint;
mod checks;
mod drive;
mod engine;
mod frames;
mod outputs;
mod profile;
mod progress;
pub mod ranks;

pub use crate::engine::{CpuEngine, Engine, EngineDim, Failed, Iteration, StepTraffic};
pub use crate::scene::build_method;
pub use budget::{Estimate, Limits};
pub use drive::drive;
pub use engine::engine;
pub use frames::{FrameConstants, Piece, write_frame};
pub use progress::ProgressDisplay;

use crate::case::CaseError;
use crate::core::check::toml_name;
use crate::core::tensor::{D2, D3};
use crate::engine::BlowUp;
use crate::methods::{Feature, supporting};
use crate::output::RunSummary;
use crate::physics::material::Material;
use crate::scene::Scene;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use thiserror::Error;

/// Compute backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Backend {
    /// Rayon, f64: the reference path.
    Cpu,
    /// wgpu/WGSL compute shaders, f32.
    Gpu,
    /// The GPU when an adapter is found, else the CPU.
    Auto,
}

/// Run-time options that are not part of the scene.
#[derive(Clone, Debug)]
pub struct RunOptions {
    pub out_dir: PathBuf,
    pub backend: Backend,
    /// How the run shows its progress on stderr.
    pub progress: ProgressDisplay,
    /// Write VTU frames (the time series and summary are always written).
    pub frames: bool,
    /// Set (by the command line's SIGINT/SIGTERM handler, say) to end the run after its
    /// current batch of steps, with an "interrupted" summary.
    pub stop: Option<Arc<AtomicBool>>,
    /// Caps on the particle and step counts (`--max-particles`, `--max-steps`).
    pub limits: Limits,
    /// Continue from the checkpoint in `out_dir` (`--resume`) instead of starting.
    pub resume: bool,
    /// On the GPU, time every pass of the run's steps and return their report in the
    /// summary (`--profile`).
    pub profile: bool,
}

#[derive(Debug, Error)]
pub enum RunError {
    #[error(
        "interrupted at step {step}, t = {time:e} s; the series and frames so far and an \
         'interrupted' summary are in {}",
        out_dir.display()
    )]
    Interrupted {
        step: u64,
        time: f64,
        out_dir: PathBuf,
    },
    #[error(transparent)]
    Case(#[from] CaseError),
    #[error("checkpoint {}: {message}", path.display())]
    Checkpoint { path: PathBuf, message: String },
    #[error(
        "output {}: {source}; check that the folder is writable and the disk has room, or \
         choose another with --out",
        path.display()
    )]
    Output {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "output folder {} is in use: another meshless run holds its lock until it ends; \
         wait for it, or choose another folder with --out",
        dir.display()
    )]
    Busy { dir: PathBuf },
    #[error("backend: {0}")]
    Backend(String),
    /// A run on several ranks that cannot go on (its case, the rank count).
    #[error("distributed run: {0}")]
    Ranks(String),
    /// A benchmark's steps failed (they write no outputs).
    #[error("{0}")]
    Benchmark(String),
    #[error(
        "blow-up at step {step}{}, t = {time:e} s: {cause}; outputs up to the last good frame are in {}",
        if first_step < step {
            format!(" (found at the check after steps {first_step} to {step})")
        } else {
            String::new()
        },
        out_dir.display()
    )]
    BlowUp {
        /// The step the failure is reported at: the one it happened in, or the last of
        /// the steps before the check that found it.
        step: u64,
        /// The first step it may have happened in (`step` when it is known exactly).
        first_step: u64,
        /// The time at the end of `step`.
        time: f64,
        cause: BlowUp,
        out_dir: PathBuf,
    },
}

/// Exit code for invalid input (case files, arguments, checkpoints), as clap uses for
/// usage errors.
pub const EXIT_INPUT: u8 = 2;
/// Exit code for a run that failed (blow-up, I/O).
pub const EXIT_FAILED: u8 = 1;
/// Exit code of a run ended by SIGINT or SIGTERM (128 + SIGINT, the shell's convention).
pub const EXIT_INTERRUPTED: u8 = 130;

impl RunError {
    /// The command line's exit code: 2 for input a run cannot start from (the case, the
    /// backend, the ranks, a checkpoint, an output folder in use), 1 for a run that
    /// failed (blow-up, output), 130 for one interrupted.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Case(_)
            | Self::Backend(_)
            | Self::Ranks(_)
            | Self::Checkpoint { .. }
            | Self::Busy { .. } => EXIT_INPUT,
            Self::Output { .. } | Self::BlowUp { .. } | Self::Benchmark(_) => EXIT_FAILED,
            Self::Interrupted { .. } => EXIT_INTERRUPTED,
        }
    }
}

/// Every check `run` makes before its first step, without running: the resource
/// estimate against `limits` and the machine, then the engine built on `backend`
/// (bodies, boundary regions, neighbours, corrected gradients, the method's weights; on
/// the GPU its passes and the f32 range of what reaches the device). Returns the
/// estimate and the particle count. `meshless check` is this.
pub fn check(
    case: &Scene,
    backend: Backend,
    limits: &Limits,
) -> Result<(Estimate, usize), RunError> {
    let mut estimate = budget::check(case, may_use_gpu(case, backend), limits)?;
    let (particles, dt_first) = match case.dimension {
        2 => built::<D2>(case, backend, limits)?,
        _ => built::<D3>(case, backend, limits)?,
    };
    estimate.steps = case.run.end_time / dt_first;
    Ok((estimate, particles))
}

/// Builds a case's engine and its series' observers (probes, checks) as `run` does, and
/// checks the step count with the first Δt; the particle count and the first Δt.
fn built<D: EngineDim>(
    case: &Scene,
    backend: Backend,
    limits: &Limits,
) -> Result<(usize, f64), RunError> {
    let mut engine = engine::<D>(case, backend)?;
    let dt_first = drive::time_step(case, &mut engine);
    budget::check_steps(case, case.run.end_time / dt_first, dt_first, limits)?;
    let columns = engine.columns();
    let constrained = engine.constrained().to_vec();
    crate::diagnostics::observe::Observers::new::<D>(
        case,
        &engine.snapshot(),
        &constrained,
        columns,
    )?;
    Ok((engine.reference().len(), dt_first))
}

/// The error of an output file or folder at `path`.
pub(crate) fn output_error(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> RunError {
    let path = path.to_path_buf();
    move |source| RunError::Output { path, source }
}

/// Runs a case to its end time; returns the summary (also written as `summary.json`).
/// The case's resources are estimated first ([`budget::check`]): nothing is allocated for
/// a run that would not fit.
pub fn run(case: &Scene, opts: &RunOptions) -> Result<RunSummary, RunError> {
    budget::check(case, may_use_gpu(case, opts.backend), &opts.limits)?;
    with_threads(case, || match case.dimension {
        2 => drive::<D2, _>(case, opts, engine::<D2>(case, opts.backend)?),
        _ => drive::<D3, _>(case, opts, engine::<D3>(case, opts.backend)?),
    })?
}

/// Runs `f` in a pool of the case's `run.threads` CPU threads, or in the global pool (every
/// core) when the case sets none. Either way `f` runs on one of the pool's threads, so a
/// step's parallel loops start there without handing every loop to another thread.
pub fn with_threads<T: Send>(case: &Scene, f: impl FnOnce() -> T + Send) -> Result<T, RunError> {
    match case.run.threads {
        None => Ok(rayon::scope(|_| f())),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map(|pool| pool.install(f))
            .map_err(|e| {
                RunError::Case(case.invalid(
                    "run.threads",
                    format!("cannot start {n} threads ({e}); give fewer"),
                ))
            }),
    }
}

/// Whether a run of `case` on `backend` may use the GPU (the memory estimate then counts
/// the device's share too): `gpu`, or `auto` for a method with a GPU engine.
pub fn may_use_gpu(case: &Scene, backend: Backend) -> bool {
    backend != Backend::Cpu && cpu_only(case).is_none()
}

/// Why a case runs on the CPU only (a static solve of a method without one on the GPU,
/// or its method, keys or material), or None if it has a GPU engine.
pub fn cpu_only(case: &Scene) -> Option<String> {
    let features = case.spec.entry().features;
    if case.is_implicit() {
        return Some(
            "the implicit solve (run.solve = \"implicit\") runs on the CPU only".to_string(),
        );
    }
    if case.is_static() && !features.contains(&crate::methods::Feature::GpuStaticSolve) {
        return Some(format!(
            "the static solve (run.solve = \"static\") of `{}` runs on the CPU only (on the \
             GPU: {})",
            case.method.name,
            crate::methods::quoted(crate::methods::supporting(
                crate::methods::Feature::GpuStaticSolve
            ))
        ));
    }
    let why = case.spec.gpu_refusal(case)?;
    Some(format!("`{}` {why}", case.method.name))
}

/// The plan of a run: what is built once, what runs per step, and what the scene leaves
/// out. `gpu` selects the GPU pass list.
pub fn explain(case: &Scene, gpu: bool) -> String {
    let m = &case.method;
    let name = m.name;
    let plan = case.spec.plan(case, gpu);
    let mat = Material::new(&case.material);
    let mut out = vec![
        format!(
            "case `{}`: {}D, spacing {} m, {} bod{}",
            case.name,
            case.dimension,
            case.spacing,
            case.bodies.len(),
            if case.bodies.len() == 1 { "y" } else { "ies" }
        ),
        {
            let integrator = if case.is_static() {
                String::new()
            } else if case.is_implicit() {
                format!(
                    ", implicit HHT-α integrator (α = {})",
                    case.run.hht_alpha.unwrap_or(0.0)
                )
            } else {
                format!(", {} integrator", toml_name(&m.integrator))
            };
            if case.spec.entry().kernel {
                let correction = match case.spec.entry().corrected {
                    true => format!(", {} correction", toml_name(&m.correction)),
                    false => String::new(),
                };
                format!(
                    "method: {name} with {} kernel, h/Δx = {}{correction}{integrator}",
                    toml_name(&m.kernel),
                    m.h_over_dx
                )
            } else {
                format!("method: {name} (no kernel keys){integrator}")
            }
        },
        format!(
            "backend: {}",
            if gpu {
                "GPU (wgpu/WGSL, f32)"
            } else {
                "CPU (rayon, f64)"
            }
        ),
    ];
    out.extend(match case.dimension {
        2 => discretisation_lines::<D2>(case),
        _ => discretisation_lines::<D3>(case),
    });
    out.extend([plan.once, format!("state: {}", plan.state)]);
    if case.is_static() {
        out.extend(load_step_lines(case, &plan.rates));
    } else if case.is_implicit() {
        out.extend(implicit_step_lines(case, &plan.rates));
    } else {
        out.push(format!(
            "time step: {}",
            match (m.dt, m.cfl) {
                (Some(dt), _) => format!("fixed Δt = {dt:e} s"),
                (_, Some(cfl)) => format!("CFL {cfl}: {}, updated at every check", plan.cfl_step),
                _ => unreachable!("validated"),
            }
        ));
        out.extend(step_lines(case, gpu, &plan.rates));
    }
    if mat.von_mises().is_some() {
        out.push(
            "before every step: the plastic history C_p⁻¹, ε_p committed from the step's start \
             state (seed 003 Algorithm 2); every stage returns F from it"
                .into(),
        );
    }
    if let Some(h) = mat.rate_plasticity() {
        out.push(format!(
            "after every step: the radial return of S to the von Mises surface, τ_y = {:e} + \
             {:e} ε_p Pa (seed 000 App. 9.1; its plastic work booked on the CPU only)",
            h.yield_stress, h.modulus
        ));
    }
    if let Some(contact) = case.contact {
        out.push(format!(
            "between steps: penalty contact (seed 000 §5.8, α = {}) of every particle against \
             the convex hulls of the other {} bodies, held through the next step",
            contact.penalty,
            case.bodies.len() - 1
        ));
    }
    let mut left_out = Vec::new();
    if !case.spec.searches_current_configuration() {
        left_out.push("neighbour rebuild (total-Lagrangian)");
    }
    let runs = |f: Feature| supporting(f).any(|n| n == name);
    if case.contact.is_none() && runs(Feature::Contact) {
        left_out.push(if case.bodies.len() == 1 {
            "contact (one body)"
        } else {
            "contact (no [contact] table)"
        });
    }
    if case.mirrors.is_empty() && runs(Feature::MirrorPlanes) {
        left_out.push("ghost particles (no mirror planes)");
    }
    left_out.extend(plan.left_out);
    if case.boundaries.is_empty() {
        left_out.push("boundary conditions");
    }
    out.push(format!("left out: {}", left_out.join(", ")));
    out.push(format!(
        "host checks every {} steps or at samples: {} ≤ 0, non-finite state, energy ≤ {}·(E0 + W_ext){}; observers: {:?}",
        drive::CHECK_EVERY,
        plan.checked,
        case.run.energy_growth_limit,
        plan.check_note,
        case.output.observers
    ));
    out.extend(memory_lines(case, gpu));
    out.join("\n")
}

/// The `--explain` lines of the memory a run needs, estimated from the case before
/// anything is built ([`Estimate`]): the host's, and on the GPU the device's by buffer.
fn memory_lines(case: &Scene, gpu: bool) -> Vec<String> {
    let Ok(estimate) = Estimate::of(case) else {
        return Vec::new();
    };
    let line = format!("memory (estimated): {}", estimate.describe(gpu));
    #[cfg(feature = "gpu")]
    if let Some(table) = estimate.device_table().filter(|_| gpu) {
        return vec![line, format!("device buffers:\n{}", table.trim_end())];
    }
    #[cfg(not(feature = "gpu"))]
    let _ = gpu;
    vec![line]
}

/// The discretisation lines of the plan: the lattice the method samples on and why
/// ([`crate::methods::MethodFamily::lattice_cells`]), its cells, every body's particles,
/// named volume and Σ V, and every boundary condition's region with its particles and,
/// for a load, its total force at law value 1 (a body force's on the particle masses
/// ρ0 V). A case that cannot be sampled says why instead.
fn discretisation_lines<D: crate::core::tensor::Dim>(case: &Scene) -> Vec<String> {
    let name = case.method.name;
    let cells = case.method.lattice_cells;
    let mut out = vec![if cells {
        format!(
            "lattice: vertex: `{name}` integrates over the lattice's cells, so boxes and \
             cylinders are sampled on the vertex lattice, whose cells span the shape, \
             whatever their `lattice` key"
        )
    } else {
        format!(
            "lattice: as each body's `lattice` key says (vertex by default): `{name}` does not \
             integrate over lattice cells"
        )
    }];
    let disc = match crate::case::discretise::<D>(case) {
        Ok(disc) => disc,
        Err(e) => {
            out.push(format!("bodies: cannot be sampled: {e}"));
            return out;
        }
    };
    let (area, force) = match D::N {
        2 => ("m² (per unit thickness)", "N/m"),
        _ => ("m³", "N"),
    };
    let body_of = &disc.body;
    let members = |b: usize| (0..body_of.len()).filter(move |&i| body_of[i] as usize == b);
    if cells {
        match crate::core::quadrature::lattice_cells::<D>(
            &disc.x0,
            &disc.body,
            case.spacing,
            &disc.cells,
            &[],
        ) {
            Ok(found) => {
                let mut corner = vec![false; disc.x0.len()];
                found
                    .corners
                    .iter()
                    .for_each(|&a| corner[a as usize] = true);
                let orphans = corner.iter().filter(|&&c| !c).count();
                out.push(format!(
                    "cells: {} (a quadrilateral or hexahedron per lattice square or cube whose \
                     corners are all particles of one body, or a generator's own){}",
                    found.len(),
                    match orphans {
                        0 => String::new(),
                        n => format!("; {n} particles are the corner of no cell"),
                    }
                ));
            }
            Err(e) => out.push(format!("cells: none can be built: {e}")),
        }
    } else {
        out.push("cells: none (the method integrates at its particles)".into());
    }
    for (b, body) in case.bodies.iter().enumerate() {
        let sum: f64 = members(b).map(|i| disc.vol[i]).sum();
        let named = match body.geometry.volume(D::N) {
            Some(v) if body.holes.is_empty() => format!("named volume {v:.6e}"),
            Some(_) => "named volume not computed (holes)".into(),
            None => "no named volume (its points are the shape)".into(),
        };
        out.push(format!(
            "body `{}`: {} particles, {named}, Σ V = {sum:.6e} {area}",
            body.name,
            members(b).count()
        ));
    }
    let rho0 = Material::new(&case.material).rho0;
    let mass: Vec<f64> = disc.vol.iter().map(|v| v * rho0).collect();
    match crate::boundary::condition_totals::<D>(case, &disc.x0, &disc.body, &mass) {
        Ok(totals) => {
            for (k, (bc, total)) in case.boundaries.iter().zip(totals).enumerate() {
                let kind = serde_json::to_value(&bc.condition)
                    .ok()
                    .and_then(|v| Some(v.get("type")?.as_str()?.to_string()))
                    .unwrap_or_default();
                let region = serde_json::to_value(&bc.region)
                    .ok()
                    .and_then(|v| v.as_object().cloned())
                    .map(|bounds| {
                        bounds
                            .iter()
                            .filter(|(_, v)| !v.is_null())
                            .map(|(key, v)| format!("{key} = {v}"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    })
                    .unwrap_or_default();
                let loaded = total.force.map_or_else(String::new, |f| {
                    let components: Vec<String> =
                        f[..D::N].iter().map(|c| format!("{c:.6e}")).collect();
                    format!(
                        ", total force ({}) {force}{}{}",
                        components.join(", "),
                        match bc.condition {
                            crate::case::Condition::BodyForce { .. } => {
                                " on the particle masses ρ0 V"
                            }
                            _ => "",
                        },
                        match bc.condition.law().is_constant() {
                            true => "",
                            false => " at law value 1",
                        }
                    )
                });
                out.push(format!(
                    "boundary `{}` ({kind}) on {{ {region} }}: {} particles{loaded}",
                    bc.name(k),
                    total.particles
                ));
            }
        }
        Err(e) => out.push(format!("boundary conditions: cannot be resolved: {e}")),
    }
    out
}

/// The per-load-step lines of a static run's plan: its load steps in pseudo-time and the
/// Newton iterations of each; `rates` is what one evaluation of the method computes.
fn load_step_lines(case: &Scene, rates: &str) -> Vec<String> {
    let dt = case
        .method
        .dt
        .map_or_else(|| "method.dt".to_string(), |dt| format!("{dt:e} s"));
    vec![
        format!(
            "load steps: {dt} of pseudo-time t to run.end_time = {:e} s, the loads and \
             prescribed motions scaled by λ = t/end_time",
            case.run.end_time
        ),
        "per load step:".to_string(),
        "  the prescribed components moved to their values at t, the free ones predicted \
         linearly"
            .to_string(),
        format!(
            "  Newton–Raphson until the residual or the increment tolerance, each iteration: \
             {rates}"
        ),
        "  a load step whose Newton iterations stall is cut".to_string(),
    ]
}

/// The plan of an implicit run's steps (`statics::newmark`).
fn implicit_step_lines(case: &Scene, rates: &str) -> Vec<String> {
    let newmark = crate::statics::newmark::Newmark::hht(case.run.hht_alpha.unwrap_or(0.0));
    let dt = case
        .method
        .dt
        .map_or_else(|| "method.dt".to_string(), |dt| format!("{dt:e} s"));
    vec![
        format!(
            "time steps: fixed Δt = {dt} (not bound by the CFL step), HHT-α with α = {}, β = \
             {}, γ = {}; loads whole, prescribed velocities held",
            newmark.alpha, newmark.beta, newmark.gamma
        ),
        "per step:".to_string(),
        "  Newmark's predictor u_n + Δt v_n + ½ Δt² a_n".to_string(),
        format!(
            "  Newton–Raphson on G = (1 + α) f_int(u) − α f_int(u_n) + f_ext − M a(u) with \
             the tangent (1 + α) K + M/(β Δt²), until the residual or the increment \
             tolerance; each iteration: {rates}"
        ),
        "  v and a from Newmark's update; a step whose Newton iterations stall is cut".to_string(),
    ]
}

/// The per-step lines of the plan: the integrator's program with the method's rate
/// evaluations (the same on both backends).
fn step_lines(case: &Scene, gpu: bool, rates: &str) -> Vec<String> {
    let mut lines = vec![if gpu {
        "per step (one command encoder for all steps between host checks):".to_string()
    } else {
        "per step:".to_string()
    }];
    lines.extend(
        crate::core::integrate::describe_step(case.method.integrator, rates)
            .into_iter()
            .map(|s| format!("  {s}")),
    );
    lines
}
