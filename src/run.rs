//! The run driver: sets up a case, integrates it to the end time with observers, frames
//! and blow-up detection, and writes the summary.

use crate::gpu::Gpu;
use crate::gpu::layout::GpuDim;
use crate::gpu::mixed::GpuMixed;
use crate::gpu::tlsph::{GpuTlsph, SetupError};
use crate::hourglass::HourglassIndicator;
use crate::integrate::Integrator;
use crate::material::{Material, von_mises};
use crate::method::mixed::MixedSph;
use crate::method::tlsph::Tlsph;
use crate::method::{BlowUp, Method};
use crate::observe::{Clock, Invariants, Observers, Snapshot};
use crate::output::{
    Field, FieldData, PvdIndex, RunSummary, SeriesWriter, write_summary, write_vtu,
};
use crate::scene::{
    Case, CaseError, CflWaveSpeed, Conserved, DeformationGradient, MethodName, discretise,
};
use crate::tensor::{D2, D3, Dim, smallest_stretch_squared};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;
use thiserror::Error;

/// Compute backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
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
    /// Show a progress bar on the terminal.
    pub progress: bool,
    /// Write VTU frames (the time series and summary are always written).
    pub frames: bool,
}

#[derive(Debug, Error)]
pub enum RunError {
    #[error(transparent)]
    Case(#[from] CaseError),
    #[error("output: {0}")]
    Io(#[from] std::io::Error),
    #[error("backend: {0}")]
    Backend(String),
    #[error(
        "blow-up at step {step}, t = {time:e} s: {cause}; outputs up to the last good frame are in {}",
        out_dir.display()
    )]
    BlowUp {
        step: u64,
        time: f64,
        cause: BlowUp,
        out_dir: PathBuf,
    },
}

/// Runs a case to its end time; returns the summary (also written as `summary.json`).
pub fn run(case: &Case, opts: &RunOptions) -> Result<RunSummary, RunError> {
    match case.dimension {
        2 => run_dim::<D2>(case, opts),
        _ => run_dim::<D3>(case, opts),
    }
}

/// The plan of a run: what is built once, what runs per step, and what the scene leaves
/// out. `gpu` selects the GPU pass list.
pub fn explain(case: &Case, gpu: bool) -> String {
    let m = &case.method;
    let mat = Material::new(&case.material);
    let mixed = m.name.is_mixed();
    let mut out = vec![
        format!(
            "case `{}`: {}D, spacing {} m, {} bod{}",
            case.name,
            case.dimension,
            case.spacing,
            case.bodies.len(),
            if case.bodies.len() == 1 { "y" } else { "ies" }
        ),
        format!(
            "method: {:?} with {:?} kernel, h/Δx = {}, {:?} correction, {:?} integrator",
            m.name, m.kernel, m.h_over_dx, m.correction, m.integrator
        ),
        format!(
            "backend: {}",
            if gpu {
                "GPU (wgpu/WGSL, f32)"
            } else {
                "CPU (rayon, f64)"
            }
        ),
    ];
    let conserved = m.variables.unwrap_or(Conserved::PFHJ);
    let projection = m.projection.unwrap_or(case.mirrors.is_empty());
    let bond = mixed && m.deformation_gradient == Some(DeformationGradient::BondBased);
    if mixed {
        let ghosts = if case.mirrors.is_empty() {
            String::new()
        } else {
            format!(", ghost particles of {} mirror planes", case.mirrors.len())
        };
        let weights = match m.name {
            MethodName::JstSph => "Laplacian weights ℓ_ab, s_ab",
            _ if m.reconstruction.unwrap_or(true) => "least-squares weights M_a⁻¹N_ab/|d_ab|",
            _ => "N_ab",
        };
        out.push(format!(
            "once, on the reference configuration (host, f64{}): cell-list neighbours (CSR){ghosts}, \
             corrected gradients g_ab and g_ba, {weights}{}",
            if gpu { ", uploaded in f32" } else { "" },
            if bond {
                ", bond weights V_b W̃_b(X_a)/|X_ab|²"
            } else {
                ""
            }
        ));
        out.push(format!(
            "state: u, v, F{}{} ({conserved:?}; {:?})",
            if conserved.evolves_h() { ", H" } else { "" },
            if conserved.evolves_j() { ", J" } else { "" },
            mat.model
        ));
    } else {
        out.push("once, on the reference configuration: cell-list neighbours (CSR), corrected gradients ∇0W̃_ij".into());
        if mat.model.is_rate_based() {
            out.push("state: u, v, ρ, S (rate model: Jaumann + linear EOS)".into());
        } else {
            out.push(format!(
                "state: u, v (state model {:?}: no ρ or S integrated)",
                mat.model
            ));
        }
    }
    out.push(format!(
        "time step: {}",
        match (m.dt, m.cfl) {
            (Some(dt), _) => format!("fixed Δt = {dt:e} s"),
            (_, Some(cfl)) if mixed => format!(
                "CFL {cfl}: Δt = cfl·min_ab r_ab/C_p,ab with C_p,ab = {} (seed 002 eqs 31–32), \
                 C_p^Lin = {:.1} m/s, updated at every check",
                match m.cfl_wave_speed.unwrap_or_default() {
                    CflWaveSpeed::Pair => "C_p^Lin/½(λ_a + λ_b)",
                    CflWaveSpeed::Linear => "C_p^Lin",
                },
                mat.p_wave_speed()
            ),
            (_, Some(cfl)) => format!(
                "CFL {cfl}: Δt = cfl·Δx/(c_p + max|v|), c_p = {:.1} m/s, updated at every check",
                mat.p_wave_speed()
            ),
            _ => unreachable!("validated"),
        }
    ));
    let rates = if mixed {
        crate::gpu::mixed::describe_rates(case)
    } else {
        crate::gpu::tlsph::RATES.to_string()
    };
    if gpu {
        out.push("per step (one command encoder for all steps between host checks):".into());
        out.extend(
            crate::gpu::program::describe_step(m.integrator, &rates)
                .into_iter()
                .map(|s| format!("  {s}")),
        );
    } else if mixed {
        out.push(format!(
            "per step: {} rate evaluations, each {rates}",
            m.integrator.stages()
        ));
    } else {
        out.push(format!(
            "per step: {} rate evaluations (two gathers each: F/P, then accelerations)",
            m.integrator.stages()
        ));
    }
    if mat.hardening.is_some() {
        out.push(
            "before every step: the plastic history C_p⁻¹, ε_p committed from the step's start \
             state (seed 003 Algorithm 2); every stage returns F from it"
                .into(),
        );
    }
    if let Some(contact) = case.contact {
        out.push(format!(
            "between steps: penalty contact (seed 000 §5.8, α = {}) of every particle against \
             the convex hulls of the other {} bodies, held through the next step",
            contact.penalty,
            case.bodies.len() - 1
        ));
    }
    let mut left_out = vec!["neighbour rebuild (total-Lagrangian)"];
    if case.contact.is_none() {
        left_out.push(if case.bodies.len() == 1 {
            "contact (one body)"
        } else {
            "contact (no [contact] table)"
        });
    }
    if mixed {
        if case.mirrors.is_empty() {
            left_out.push("ghost particles (no mirror planes)");
        }
        if !projection {
            left_out.push("angular-momentum projection");
        }
        if !conserved.evolves_h() {
            left_out.push("H evolution (H = cof F)");
        }
        if !conserved.evolves_j() {
            left_out.push("J evolution (J = det F)");
        }
        if !bond {
            left_out.push("bond-based F^c (P of the evolved F)");
        }
    } else {
        if m.artificial_viscosity.is_none() {
            left_out.push("artificial viscosity");
        }
        if mat.model.is_rate_based() {
            left_out.push("P(F) evaluation");
        } else {
            left_out.push("continuity and Jaumann rates");
        }
    }
    if case.boundaries.is_empty() {
        left_out.push("boundary conditions");
    }
    out.push(format!("left out: {}", left_out.join(", ")));
    out.push(format!(
        "host checks every {CHECK_EVERY} steps or at samples: det F{} ≤ 0, non-finite state, energy ≤ {}·(E0 + W_ext){}; observers: {:?}",
        if mixed { ", J" } else { "" },
        case.run.energy_growth_limit,
        if bond && gpu {
            format!(
                " (strain energy ψ(F^c): {}bond-based F^c of Y recorded before the reduction)",
                if case.mirrors.is_empty() {
                    ""
                } else {
                    "ghost motion and "
                }
            )
        } else {
            String::new()
        },
        case.output.observers
    ));
    out.join("\n")
}

/// Builds the method of a case; `M` must be the method the case names.
pub fn build_method<D: Dim, M: Method<D>>(case: &Case) -> Result<M, CaseError> {
    if !M::NAMES.contains(&case.method.name) {
        return Err(case.invalid(
            "method.name",
            format!(
                "this engine runs {:?}, not {:?}",
                M::NAMES,
                case.method.name
            ),
        ));
    }
    M::build(case, discretise::<D>(case)?)
}

/// The engine a case runs on: the GPU when `backend` asks for it (or `auto` finds an
/// adapter), the CPU otherwise. Every method has both.
pub fn engine<D: GpuDim>(case: &Case, backend: Backend) -> Result<Box<dyn Engine<D>>, RunError> {
    let gpu = match backend {
        Backend::Cpu => None,
        Backend::Gpu => Some(Gpu::new().map_err(|e| RunError::Backend(e.to_string()))?),
        Backend::Auto => Gpu::new()
            .inspect_err(|e| eprintln!("note: {e}; running on the CPU (rayon, f64)"))
            .ok(),
    };
    let setup = |e: SetupError| match e {
        SetupError::Case(c) => RunError::Case(c),
        SetupError::Gpu(g) => RunError::Backend(g.to_string()),
    };
    Ok(match (gpu, case.method.name) {
        (Some(gpu), MethodName::Tlsph) => Box::new(GpuTlsph::<D>::new(case, gpu).map_err(setup)?),
        (Some(gpu), MethodName::UpwindSph | MethodName::JstSph) => {
            Box::new(GpuMixed::<D>::new(case, gpu).map_err(setup)?)
        }
        (None, MethodName::Tlsph) => Box::new(CpuEngine::<D, Tlsph<D>>::new(case)?),
        (None, MethodName::UpwindSph | MethodName::JstSph) => {
            Box::new(CpuEngine::<D, MixedSph<D>>::new(case)?)
        }
    })
}

/// A time stepper the driver runs: the CPU method with its integrator, or the GPU engine.
pub trait Engine<D: Dim> {
    /// "cpu", or "gpu: <adapter>".
    fn backend(&self) -> String;
    fn reference(&self) -> &[D::V];
    fn constrained(&self) -> &[(u32, u8)];
    /// Advances `steps` steps of size dt from time t.
    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), BlowUp>;
    /// Largest signal speed (for the CFL step Δt = α Δx / signal speed): c_p + max |v| for
    /// TLSPH, Δx max_ab C_p,ab / r_ab + max |v| over the current pairs for the mixed
    /// methods (seed 002 eqs 31–32).
    fn max_signal_speed(&mut self) -> f64;
    /// Work done on the bodies by supports and loads so far.
    fn external_work(&mut self) -> f64;
    /// Non-finite state or det F ≤ 0 since the start.
    fn check(&mut self) -> Result<(), BlowUp>;
    fn snapshot(&mut self) -> Snapshot<'_, D>;
    /// Energies and momenta of the current state.
    fn invariants(&mut self) -> Invariants {
        Invariants::of(&self.snapshot())
    }
    /// Waits until all submitted work is done (for timing).
    fn finish(&mut self) {}
}

/// Forwarding, so that the driver runs whichever engine [`engine`] chose.
impl<D: Dim> Engine<D> for Box<dyn Engine<D>> {
    fn backend(&self) -> String {
        (**self).backend()
    }
    fn reference(&self) -> &[D::V] {
        (**self).reference()
    }
    fn constrained(&self) -> &[(u32, u8)] {
        (**self).constrained()
    }
    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), BlowUp> {
        (**self).advance(t, dt, steps)
    }
    fn max_signal_speed(&mut self) -> f64 {
        (**self).max_signal_speed()
    }
    fn external_work(&mut self) -> f64 {
        (**self).external_work()
    }
    fn check(&mut self) -> Result<(), BlowUp> {
        (**self).check()
    }
    fn snapshot(&mut self) -> Snapshot<'_, D> {
        (**self).snapshot()
    }
    fn invariants(&mut self) -> Invariants {
        (**self).invariants()
    }
    fn finish(&mut self) {
        (**self).finish()
    }
}

/// The CPU reference engine: a method and an integrator (f64, rayon).
pub struct CpuEngine<D: Dim, M: Method<D> = Tlsph<D>> {
    pub method: M,
    pub y: M::State,
    integrator: Integrator<M::State>,
    work: f64,
    last_power: f64,
    _dim: std::marker::PhantomData<D>,
}

impl<D: Dim, M: Method<D>> CpuEngine<D, M> {
    pub fn new(case: &Case) -> Result<Self, CaseError> {
        let method = build_method::<D, M>(case)?;
        let y = method.initial_state();
        let integrator = Integrator::new(case.method.integrator, &y);
        Ok(Self {
            method,
            y,
            integrator,
            work: 0.0,
            last_power: 0.0,
            _dim: std::marker::PhantomData,
        })
    }
}

impl<D: Dim, M: Method<D>> Engine<D> for CpuEngine<D, M> {
    fn backend(&self) -> String {
        "cpu".into()
    }

    fn reference(&self) -> &[D::V] {
        self.method.reference()
    }

    fn constrained(&self) -> &[(u32, u8)] {
        self.method.constrained()
    }

    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), BlowUp> {
        for k in 0..steps {
            self.integrator
                .step(&mut self.method, t + f64::from(k) * dt, dt, &mut self.y)?;
            // Trapezoidal work of the supports and loads, from successive step powers.
            let power = self.method.boundary_power();
            self.work += 0.5 * (self.last_power + power) * dt;
            self.last_power = power;
        }
        Ok(())
    }

    fn max_signal_speed(&mut self) -> f64 {
        self.method.max_signal_speed(&self.y)
    }

    fn external_work(&mut self) -> f64 {
        self.work
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        self.method.check_finite(&self.y)
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        self.method.snapshot(&self.y)
    }
}

/// Steps between blow-up checks (and CFL updates) when samples are rarer.
const CHECK_EVERY: u64 = 100;

fn run_dim<D: GpuDim>(case: &Case, opts: &RunOptions) -> Result<RunSummary, RunError> {
    drive::<D, _>(case, opts, engine::<D>(case, opts.backend)?)
}

/// Time-step size: fixed, or from the CFL number.
fn time_step<D: Dim>(case: &Case, engine: &mut impl Engine<D>) -> f64 {
    match (case.method.dt, case.method.cfl) {
        (Some(dt), _) => dt,
        (None, Some(cfl)) => cfl * case.spacing / engine.max_signal_speed(),
        (None, None) => unreachable!("validation requires dt or cfl"),
    }
}

/// Runs an engine to the end time with observers, frames, checks and the summary.
pub fn drive<D: Dim, E: Engine<D>>(
    case: &Case,
    opts: &RunOptions,
    mut engine: E,
) -> Result<RunSummary, RunError> {
    let observers = Observers::new::<D>(case, engine.reference(), engine.constrained())?;
    std::fs::create_dir_all(&opts.out_dir)?;
    let mut series =
        SeriesWriter::create(&opts.out_dir.join("series.csv"), observers.column_names())?;
    let mut frames = Frames::new(case, opts)?;
    // η of every particle, evaluated at an output only when a frame, a series row with the
    // observer or the limit needs it.
    let hourglass =
        (frames.on() || observers.need_hourglass() || case.run.hourglass_limit.is_some())
            .then(|| HourglassIndicator::new::<D>(case, engine.reference()));
    let eta_of = |snap: &Snapshot<D>, frame: bool, row: bool| {
        let needed =
            frame || (row && observers.need_hourglass()) || case.run.hourglass_limit.is_some();
        hourglass
            .as_ref()
            .filter(|_| needed)
            .map(|h| h.of::<D>(snap.x0, &snap.u, &snap.f))
    };
    let backend = engine.backend();
    if opts.progress {
        eprintln!(
            "{}: {} particles on {backend}",
            case.name,
            engine.reference().len()
        );
    }

    let n = engine.reference().len();
    let t_end = case.run.end_time;
    let done = |t: f64| t >= t_end * (1.0 - 1e-12);
    let mut clock = Clock {
        dt: time_step(case, &mut engine),
        ..Clock::default()
    };
    let dt_first = clock.dt;
    let progress = progress_bar(opts.progress, case);
    let started = Instant::now();

    let snap = engine.snapshot();
    let inv0 = Invariants::of(&snap);
    let eta = eta_of(&snap, frames.will_write(0.0, true), true);
    series.write_row(&observers.sample(&snap, &inv0, &clock, eta.as_deref()))?;
    frames.write(&snap, 0.0, true, eta.as_deref())?;
    drop(snap);
    let series_every = case.output.series_interval.unwrap_or(0.0);
    let mut next_sample = series_every;

    let failure = loop {
        let Clock { t, step, .. } = clock;
        if done(t) {
            break None;
        }
        let dt = time_step(case, &mut engine);
        if let Some(ratio) = case.run.min_step_ratio
            && dt < ratio * dt_first
        {
            break Some(step_collapse::<D>(
                case,
                &engine.snapshot(),
                ratio * dt_first,
            ));
        }
        // Steps to the next sample, frame, check or the end, whichever comes first.
        let to_event = [next_sample, frames.next_time(), t_end]
            .into_iter()
            .map(|te| ((te - t) / dt - 0.5).ceil().max(1.0))
            .fold(CHECK_EVERY as f64, f64::min) as u32;
        let (steps, dt) = if t + f64::from(to_event) * dt > t_end {
            // Land on the end time: whole steps of dt, then one shorter step.
            let whole = ((t_end - t) / dt).floor() as u32;
            if whole == 0 {
                (1, t_end - t)
            } else {
                (whole, dt)
            }
        } else {
            (to_event, dt)
        };
        if let Err(cause) = engine.advance(t, dt, steps) {
            break Some(cause);
        }
        clock = Clock {
            t: t + f64::from(steps) * dt,
            step: step + u64::from(steps),
            dt,
            external_work: engine.external_work(),
        };
        let t = clock.t;
        if let Err(cause) = engine.check() {
            break Some(cause);
        }
        // The full state is read (and F, σ evaluated) only when a row or frame is due;
        // other checks use the engine's invariants (a reduction on the GPU).
        let sample = t + 0.5 * dt >= next_sample || done(t);
        let output = sample || frames.due(t) || done(t);
        let bound =
            case.run.energy_growth_limit * (inv0.total_energy() + clock.external_work.max(0.0));
        let too_much = |inv: &Invariants| inv.total_energy() > bound && bound > 0.0;
        if output {
            let snap = engine.snapshot();
            let inv = Invariants::of(&snap);
            if too_much(&inv) {
                break Some(energy_blow_up::<D>(&snap, inv.total_energy(), bound));
            }
            let eta = eta_of(&snap, frames.will_write(t, done(t)), sample);
            if let (Some(limit), Some(eta)) = (case.run.hourglass_limit, &eta)
                && let Some(cause) = hourglass_blow_up::<D>(&snap, eta, limit)
            {
                break Some(cause);
            }
            if sample {
                series.write_row(&observers.sample(&snap, &inv, &clock, eta.as_deref()))?;
                next_sample = t + series_every;
            }
            frames.write(&snap, t, done(t), eta.as_deref())?;
        } else {
            let inv = engine.invariants();
            if too_much(&inv) {
                break Some(energy_blow_up::<D>(
                    &engine.snapshot(),
                    inv.total_energy(),
                    bound,
                ));
            }
        }
        progress.set_position((t / t_end * 1000.0) as u64);
        let rate = (n as f64 * clock.step as f64) / started.elapsed().as_secs_f64();
        progress.set_message(format!(
            "step {}, t = {t:.4e} s, {rate:.3e} particle-steps/s",
            clock.step
        ));
    };
    progress.finish_and_clear();

    let Clock { t, step, dt, .. } = clock;
    let wall = started.elapsed().as_secs_f64();
    let inv = engine.invariants();
    let summary = RunSummary {
        case: case.name.clone(),
        method: format!("{:?}", case.method.name).to_lowercase(),
        backend,
        dimension: case.dimension,
        particles: n,
        steps: step,
        dt_last: dt,
        end_time: t,
        wall_seconds: wall,
        particle_steps_per_second: n as f64 * step as f64 / wall.max(1e-12),
        status: if failure.is_some() {
            "failed"
        } else {
            "completed"
        }
        .into(),
        failure: failure
            .as_ref()
            .map(|c| format!("by step {step}, t = {t:e} s: {c}")),
        final_invariants: inv.named::<D>(),
    };
    write_summary(&opts.out_dir.join("summary.json"), &summary)?;
    match failure {
        Some(cause) => Err(RunError::BlowUp {
            step,
            time: t,
            cause,
            out_dir: opts.out_dir.clone(),
        }),
        None => Ok(summary),
    }
}

/// Energy-growth failure, attributed to the particle with the largest kinetic energy.
fn energy_blow_up<D: Dim>(snap: &Snapshot<D>, energy: f64, bound: f64) -> BlowUp {
    let (v, m) = (&snap.v, snap.mass);
    let i = (0..m.len())
        .max_by(|&a, &b| (m[a] * D::norm2(v[a])).total_cmp(&(m[b] * D::norm2(v[b]))))
        .unwrap_or(0);
    BlowUp {
        particle: i,
        position: D::to3(snap.x0[i]),
        quantity: format!("total energy (bound {bound:e}, fastest particle shown)"),
        value: energy,
    }
}

/// Hourglass failure: the particle with the largest η, when η exceeds the limit.
fn hourglass_blow_up<D: Dim>(snap: &Snapshot<D>, eta: &[f64], limit: f64) -> Option<BlowUp> {
    let (i, &worst) = eta.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    (worst > limit).then(|| {
        let quantity = format!("hourglass indicator η (run.hourglass_limit = {limit})");
        BlowUp::at::<D>(snap.x0, i, &quantity, worst)
    })
}

/// Collapse of the CFL step below `floor`, attributed to the particle with the largest
/// signal-speed estimate: c_p/λ²_min + |v| for the mixed methods (λ²_min the smallest
/// eigenvalue of C; their per-pair step of seed 002 eqs 31–32 falls as r_ab λ_ab, and
/// r_ab ≥ λ_min |X_ab| for a locally affine motion), |v| for TLSPH (its step does not
/// depend on the stretch).
fn step_collapse<D: Dim>(case: &Case, snap: &Snapshot<D>, floor: f64) -> BlowUp {
    let c_p = Material::new(&case.material).p_wave_speed();
    let speed = |i: usize| {
        let stretch = match case.method.name {
            MethodName::Tlsph => 0.0,
            MethodName::UpwindSph | MethodName::JstSph => {
                c_p / smallest_stretch_squared::<D>(snap.f[i])
            }
        };
        stretch + D::norm2(snap.v[i]).sqrt()
    };
    let i = (0..snap.v.len())
        .max_by(|&a, &b| speed(a).total_cmp(&speed(b)))
        .unwrap_or(0);
    let quantity = format!(
        "collapse of the CFL step (below run.min_step_ratio × the first step = {floor:e} s); \
         signal speed [m/s] of the fastest particle"
    );
    BlowUp::at::<D>(snap.x0, i, &quantity, speed(i))
}

fn progress_bar(show: bool, case: &Case) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix} [{elapsed_precise}] {wide_bar} {percent}% eta {eta} {msg}",
        )
        .expect("static progress template is valid"),
    );
    bar.set_prefix(case.name.clone());
    bar
}

/// VTU frames and their PVD index.
struct Frames {
    index: Option<PvdIndex>,
    dir: PathBuf,
    name: String,
    interval: Option<f64>,
    next: f64,
    count: usize,
}

impl Frames {
    fn new(case: &Case, opts: &RunOptions) -> std::io::Result<Self> {
        let index = if opts.frames {
            Some(PvdIndex::create(&opts.out_dir, &case.name)?)
        } else {
            None
        };
        Ok(Self {
            index,
            dir: opts.out_dir.clone(),
            name: case.name.clone(),
            interval: case.output.frame_interval,
            next: 0.0,
            count: 0,
        })
    }

    /// Whether frames are written at all.
    fn on(&self) -> bool {
        self.index.is_some()
    }

    /// Whether [`Self::write`] at time t writes a frame.
    fn will_write(&self, t: f64, force: bool) -> bool {
        self.on() && (self.due(t) || force)
    }

    /// Time of the next frame (infinite when frames are off or have no interval).
    fn next_time(&self) -> f64 {
        match (&self.index, self.interval) {
            (Some(_), Some(_)) => self.next,
            _ => f64::INFINITY,
        }
    }

    /// Whether a frame is due at time t.
    fn due(&self, t: f64) -> bool {
        self.index.is_some() && self.interval.is_some() && t >= self.next * (1.0 - 1e-9)
    }

    /// Writes a frame when one is due (or `force`); `eta` is the hourglass indicator,
    /// given whenever [`Self::will_write`].
    fn write<D: Dim>(
        &mut self,
        snap: &Snapshot<D>,
        t: f64,
        force: bool,
        eta: Option<&[f64]>,
    ) -> std::io::Result<()> {
        if !self.will_write(t, force) {
            return Ok(());
        }
        let (Some(index), Some(eta)) = (&mut self.index, eta) else {
            return Ok(());
        };
        let file = format!("{}_{:06}.vtu", self.name, self.count);
        write_frame::<D>(&self.dir.join(&file), snap, t, eta)?;
        index.push(t, &file)?;
        self.count += 1;
        if let Some(dt) = self.interval {
            while self.next <= t * (1.0 + 1e-9) {
                self.next += dt;
            }
        }
        Ok(())
    }
}

/// One VTU frame: current positions with u, v, F, σ, von Mises stress, J, the hourglass
/// indicator η, body, and the plastic strain ε_p of a plastic material.
pub fn write_frame<D: Dim>(
    path: &Path,
    snap: &Snapshot<D>,
    t: f64,
    eta: &[f64],
) -> std::io::Result<()> {
    let points: Vec<[f64; 3]> = snap
        .x0
        .iter()
        .zip(&snap.u)
        .map(|(&x, &u)| D::to3(x + u))
        .collect();
    let uu: Vec<[f64; 3]> = snap.u.iter().map(|&a| D::to3(a)).collect();
    let vv: Vec<[f64; 3]> = snap.v.iter().map(|&a| D::to3(a)).collect();
    let jac: Vec<f64> = snap.f.iter().map(|&f| D::det(f)).collect();
    let f9: Vec<[f64; 9]> = snap.f.iter().map(|&f| flatten(pad_f::<D>(f))).collect();
    let vm: Vec<f64> = snap.sigma.iter().map(von_mises).collect();
    let s9: Vec<[f64; 9]> = snap.sigma.iter().map(|s| flatten(*s)).collect();
    let body: Vec<i32> = snap.body.iter().map(|&b| b as i32).collect();
    let mut fields = vec![
        Field {
            name: "u",
            data: FieldData::Vector(&uu),
        },
        Field {
            name: "v",
            data: FieldData::Vector(&vv),
        },
        Field {
            name: "F",
            data: FieldData::Tensor(&f9),
        },
        Field {
            name: "sigma",
            data: FieldData::Tensor(&s9),
        },
        Field {
            name: "von_mises",
            data: FieldData::Scalar(&vm),
        },
        Field {
            name: "J",
            data: FieldData::Scalar(&jac),
        },
        Field {
            name: "hourglass",
            data: FieldData::Scalar(eta),
        },
        Field {
            name: "body",
            data: FieldData::Int(&body),
        },
    ];
    if let Some(eps_p) = &snap.plastic_strain {
        fields.push(Field {
            name: "plastic_strain",
            data: FieldData::Scalar(eps_p),
        });
    }
    write_vtu(path, &points, &fields, t)
}

/// F as 3×3; in plane strain F_zz = 1.
fn pad_f<D: Dim>(f: D::T) -> [[f64; 3]; 3] {
    let mut m = D::to3x3(f);
    if D::N == 2 {
        m[2][2] = 1.0;
    }
    m
}

fn flatten(m: [[f64; 3]; 3]) -> [f64; 9] {
    let mut out = [0.0; 9];
    for k in 0..3 {
        out[3 * k..3 * k + 3].copy_from_slice(&m[k]);
    }
    out
}
