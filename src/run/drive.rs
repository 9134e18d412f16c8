//! The time loop: steps between events (samples, frames, checks, the end), the blow-up
//! checks, outputs and the summary.

use super::checkpoint;
use super::checks::{
    energy_blow_up, fixed_step_warning, hourglass_blow_up, length_notes, mass_notes, step_collapse,
};
use super::frames::{Frames, next_frame_time};
use super::progress::{Progress, ProgressDisplay};
use super::{Engine, Failed, Iteration, RunError, RunOptions, output_error};
use crate::balance::Balance;
use crate::hourglass::HourglassIndicator;
use crate::observe::{Clock, IndicatorFields, Invariants, Observers, Snapshot};
use crate::output::series::read_column;
use crate::output::{CheckResult, RunSummary, SeriesWriter, write_summary};
use crate::pressure::{PressureFit, pressures};
use crate::scene::Case;
use crate::scene::validate::toml_name;
use crate::tensor::Dim;
use std::path::Path;
use std::time::Instant;

/// Steps between blow-up checks (and CFL updates) when samples are rarer.
pub(super) const CHECK_EVERY: u64 = 100;

/// Time-step size: fixed, or from the CFL number.
fn time_step<D: Dim>(case: &Case, engine: &mut impl Engine<D>) -> f64 {
    match (case.method.dt, case.method.cfl) {
        (Some(dt), _) => dt,
        (None, Some(cfl)) => cfl * case.spacing / engine.max_signal_speed(),
        (None, None) => unreachable!("validation requires dt or cfl"),
    }
}

/// Where a profiled run started: when, at which step, and the runs of the indirect passes
/// so far.
#[cfg(feature = "gpu")]
struct Profiled {
    started: Instant,
    step: u64,
    indirect: Option<crate::gpu::profile::IndirectRuns>,
}

/// Without the GPU backend no run is profiled.
#[cfg(not(feature = "gpu"))]
type Profiled = std::convert::Infallible;

/// Starts profiling the passes of a GPU engine (none on the CPU).
#[cfg(feature = "gpu")]
fn start_profile<D: Dim>(engine: &mut impl Engine<D>, step: u64) -> Option<Profiled> {
    let (gpu, scale) = engine.device()?;
    gpu.profile(true);
    Some(Profiled {
        started: Instant::now(),
        step,
        indirect: scale.indirect,
    })
}

#[cfg(not(feature = "gpu"))]
fn start_profile<D: Dim>(_: &mut impl Engine<D>, _: u64) -> Option<Profiled> {
    None
}

/// The pass report of the steps since `from` up to `step`; stops profiling.
#[cfg(feature = "gpu")]
fn pass_report<D: Dim>(
    engine: &mut impl Engine<D>,
    from: Profiled,
    step: u64,
) -> Option<crate::bench::PassReport> {
    let wall = from.started.elapsed().as_secs_f64();
    let particles = engine.reference().len();
    let (gpu, mut scale) = engine.device()?;
    scale.indirect = scale
        .indirect
        .zip(from.indirect)
        .map(|(now, then)| now - then);
    let steps = u32::try_from(step - from.step).unwrap_or(u32::MAX);
    let report = crate::bench::PassReport {
        particles,
        ..gpu.pass_report(scale, steps, wall)
    };
    gpu.profile(false);
    Some(report)
}

#[cfg(not(feature = "gpu"))]
fn pass_report<D: Dim>(
    _: &mut impl Engine<D>,
    from: Profiled,
    _: u64,
) -> Option<crate::bench::PassReport> {
    match from {}
}

/// Runs an engine to the end time with observers, frames, checks and the summary.
pub fn drive<D: Dim, E: Engine<D>>(
    case: &Case,
    opts: &RunOptions,
    mut engine: E,
) -> Result<RunSummary, RunError> {
    let t_end = case.run.end_time;
    let backend = engine.backend();
    let n = engine.reference().len();
    // A resumed run continues from the state and progress of its checkpoint.
    let resumed = match opts.resume {
        true => {
            let (progress, words) = checkpoint::read(&opts.out_dir, case, &backend, n)?;
            engine
                .restore(&words)
                .map_err(|message| RunError::Checkpoint {
                    path: opts.out_dir.join(checkpoint::FILE),
                    message,
                })?;
            Some(progress)
        }
        false => None,
    };
    // The step count once the first Δt is known, before anything is written.
    let dt_first = match &resumed {
        Some(p) => p.dt_first,
        None => time_step(case, &mut engine),
    };
    super::budget::check_steps(case, t_end / dt_first, dt_first, &opts.limits)?;
    let engine_columns = engine.columns();
    let constrained = engine.constrained().to_vec();
    let observers = Observers::new::<D>(case, &engine.snapshot(), &constrained, engine_columns)?;
    std::fs::create_dir_all(&opts.out_dir).map_err(output_error(&opts.out_dir))?;
    let series_path = opts.out_dir.join("series.csv");
    let columns = observers.column_names();
    if resumed.is_none() {
        clear_previous_run(&opts.out_dir)?;
    }
    let mut frames = Frames::new(case, opts)?;
    let mut series = match &resumed {
        Some(p) => {
            frames.resume(p.next_frame, &p.frames)?;
            SeriesWriter::resume(&series_path, columns, p.series_bytes)
        }
        None => SeriesWriter::create(&series_path, columns),
    }
    .map_err(output_error(&series_path))?;
    // η and δp of every particle, each evaluated at an output only when a frame, a series
    // row with its observer or the hourglass limit needs it.
    let hourglass =
        (frames.on() || observers.need_hourglass() || case.run.hourglass_limit.is_some())
            .then(|| HourglassIndicator::new::<D>(case, engine.reference()));
    let pressure_fit = std::cell::OnceCell::new();
    let indicators_of = |snap: &Snapshot<D>, frame: bool, row: bool| {
        let eta_needed =
            frame || (row && observers.need_hourglass()) || case.run.hourglass_limit.is_some();
        let deviation_needed = frame || (row && observers.need_pressure_deviation());
        IndicatorFields {
            eta: hourglass
                .as_ref()
                .filter(|_| eta_needed)
                .map(|h| h.of::<D>(snap.x0, &snap.u, &snap.f)),
            pressure_deviation: deviation_needed.then(|| {
                pressure_fit
                    .get_or_init(|| PressureFit::new::<D>(case, snap.x0, snap.body))
                    .deviation(&pressures(&snap.sigma))
            }),
        }
    };
    if opts.progress != ProgressDisplay::Off {
        eprintln!("{}: {n} particles on {backend}", case.name);
    }

    let summary_path = opts.out_dir.join("summary.json");
    let running = RunSummary {
        passes: None,
        case: case.name.clone(),
        version: env!("CARGO_PKG_VERSION").into(),
        case_file: case.file.display().to_string(),
        overrides: case.overrides.clone(),
        resolved_case: serde_json::to_value(case).unwrap_or_default(),
        method: case.method.name().to_string(),
        backend: backend.clone(),
        dimension: case.dimension,
        particles: n,
        steps: 0,
        dt_last: f64::NAN,
        end_time: 0.0,
        wall_seconds: 0.0,
        particle_steps_per_second: f64::NAN,
        status: "running".into(),
        failure: None,
        final_invariants: Default::default(),
        energy_balance: Default::default(),
        checks: Vec::new(),
    };
    write_summary(&summary_path, &running).map_err(output_error(&summary_path))?;
    let done = |t: f64| t >= t_end * (1.0 - 1e-12);
    if case.method.dt.is_some()
        && let Some(warning) =
            fixed_step_warning(dt_first, case.spacing / engine.max_signal_speed())
    {
        eprintln!("warning: {}: {warning}", case.file.display());
    }
    if resumed.is_none() {
        let mut notes = mass_notes(case, &engine.snapshot());
        notes.extend(length_notes(case));
        for note in notes {
            eprintln!("note: {}: {note}", case.file.display());
        }
    }
    let mut progress = Progress::new(opts.progress, case);
    let mut iterations = IterationLog::new(&opts.out_dir);
    let started = Instant::now();
    let series_every = case.output.series_interval.unwrap_or(0.0);
    let checkpoint_every = case.run.checkpoint_interval;

    let (mut clock, e0, mut next_sample, mut next_checkpoint) = match &resumed {
        Some(p) => {
            let clock = Clock {
                t: p.t,
                step: p.step,
                dt: p.dt,
                booked: engine.booked(),
                e0: p.e0,
                pseudo_time: engine.pseudo_time().unwrap_or_default(),
            };
            (clock, p.e0, p.next_sample, p.next_checkpoint)
        }
        None => {
            let snap = engine.snapshot();
            let inv0 = Invariants::of(&snap);
            let clock = Clock {
                dt: dt_first,
                e0: inv0.total_energy(),
                ..Clock::default()
            };
            let fields = indicators_of(&snap, frames.will_write(0.0, true), true);
            series
                .write_row(&observers.sample(&snap, &inv0, &clock, &fields, &[]))
                .map_err(output_error(&series_path))?;
            frames.write(&snap, 0.0, true, &fields)?;
            let first_checkpoint = checkpoint_every.unwrap_or(f64::INFINITY);
            (clock, inv0.total_energy(), series_every, first_checkpoint)
        }
    };

    // With --profile on a GPU engine: the pass report of the steps from here.
    let profiled = match opts.profile {
        true => start_profile(&mut engine, clock.step),
        false => None,
    };
    // Where a failure was found, when not at the current step: (first step it may have
    // happened in, the step it is reported at, the time at the end of that step).
    let mut found = None;
    let stop_requested = || {
        opts.stop
            .as_ref()
            .is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed))
    };
    let mut interrupted = false;
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
        // Steps to the next sample, frame, checkpoint, check or the end, whichever comes
        // first.
        let to_event = [next_sample, frames.next_time(), next_checkpoint, t_end]
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
        let advanced = engine.advance(t, dt, steps);
        iterations.record(engine.iterations(), &progress)?;
        if let Err(Failed { completed, cause }) = advanced {
            // Found during a step: reported at that step, and at the time it would end.
            let failing = step + u64::from(completed) + 1;
            clock.t = t + f64::from(completed) * dt;
            clock.step = failing - 1;
            found = Some((failing, failing, clock.t + dt));
            break Some(cause);
        }
        clock = Clock {
            t: t + f64::from(steps) * dt,
            step: step + u64::from(steps),
            dt,
            booked: engine.booked(),
            e0,
            pseudo_time: engine.pseudo_time().unwrap_or_default(),
        };
        let t = clock.t;
        if let Err(cause) = engine.check() {
            // Found at the check after the batch: in one of its steps.
            found = Some((step + 1, clock.step, t));
            break Some(cause);
        }
        // The full state is read (and F, σ evaluated) only when a row or frame is due;
        // other checks use the engine's invariants (a reduction on the GPU).
        let sample = t + 0.5 * dt >= next_sample || done(t);
        let output = sample || frames.due(t) || done(t);
        let bound = case.run.energy_growth_limit * (e0 + clock.booked.external_work.max(0.0));
        // A non-finite energy (an overflowing velocity of a rigid motion, which leaves F
        // finite) is a blow-up whatever the bound.
        let too_much = |inv: &Invariants| {
            let e = inv.total_energy();
            !e.is_finite() || (e > bound && bound > 0.0)
        };
        if output {
            let reactions = match sample && observers.need_reactions() {
                true => engine.reactions(),
                false => Vec::new(),
            };
            let snap = engine.snapshot();
            let inv = Invariants::of(&snap);
            if too_much(&inv) {
                break Some(energy_blow_up::<D>(&snap, inv.total_energy(), bound));
            }
            let fields = indicators_of(&snap, frames.will_write(t, done(t)), sample);
            if let (Some(limit), Some(eta)) = (case.run.hourglass_limit, &fields.eta)
                && let Some(cause) = hourglass_blow_up::<D>(&snap, eta, limit)
            {
                break Some(cause);
            }
            if sample {
                series
                    .write_row(&observers.sample(&snap, &inv, &clock, &fields, &reactions))
                    .map_err(output_error(&series_path))?;
                next_sample = t + series_every;
            }
            frames.write(&snap, t, done(t), &fields)?;
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
        // A checkpoint when one is due, and on a stop (with checkpoints on), after the
        // batch's outputs: a resumed run goes on from here exactly as this one would.
        let stop = stop_requested();
        let due = t >= next_checkpoint * (1.0 - 1e-9);
        if let Some(interval) = checkpoint_every
            && (due || stop)
        {
            if due {
                next_checkpoint = next_frame_time(next_checkpoint, interval, t);
            }
            let (next_frame, frame_times) = frames.progress();
            let at = checkpoint::Progress {
                t,
                step: clock.step,
                dt: clock.dt,
                dt_first,
                e0,
                next_sample,
                next_checkpoint,
                series_bytes: series.bytes(),
                next_frame,
                frames: frame_times,
            };
            checkpoint::write(&opts.out_dir, case, &backend, n, &at, &engine.save())?;
        }
        if stop {
            interrupted = true;
            break None;
        }
        let rate = (n as f64 * clock.step as f64) / started.elapsed().as_secs_f64();
        progress.update(t, t_end, clock.step, rate);
    };
    progress.finish();

    let Clock { t, step, dt, .. } = clock;
    let (first_step, failed_step, failed_time) = found.unwrap_or((step, step, t));
    let wall = started.elapsed().as_secs_f64();
    let passes = profiled.and_then(|from| pass_report(&mut engine, from, step));
    let inv = engine.invariants();
    let energy_balance = Balance {
        kinetic: inv.kinetic,
        stored: inv.strain,
        booked: engine.booked(),
        e0,
    }
    .named();
    let summary = RunSummary {
        passes,
        steps: step,
        dt_last: dt,
        end_time: t,
        wall_seconds: wall,
        particle_steps_per_second: n as f64 * step as f64 / wall.max(1e-12),
        status: match (&failure, interrupted) {
            (Some(_), _) => "failed",
            (None, true) => "interrupted",
            (None, false) => "completed",
        }
        .into(),
        failure: failure.as_ref().map(|c| {
            let steps = if first_step < failed_step {
                format!("in steps {first_step} to {failed_step}")
            } else {
                format!("at step {failed_step}")
            };
            format!("{steps}, t = {failed_time:e} s: {c}")
        }),
        final_invariants: inv.named::<D>(),
        energy_balance,
        checks: evaluate_checks(case, &series_path),
        ..running
    };
    if opts.progress != ProgressDisplay::Off {
        for check in &summary.checks {
            eprintln!("check: {check}");
        }
    }
    write_summary(&summary_path, &summary).map_err(output_error(&summary_path))?;
    match failure {
        Some(cause) => Err(RunError::BlowUp {
            step: failed_step,
            first_step,
            time: failed_time,
            cause,
            out_dir: opts.out_dir.clone(),
        }),
        None if interrupted => Err(RunError::Interrupted {
            step,
            time: t,
            out_dir: opts.out_dir.clone(),
        }),
        None => Ok(summary),
    }
}

/// Removes what an earlier run wrote into `dir`, and nothing else: its summary, its
/// series, its checkpoint, and each PVD index with the frames it lists, so that no stale file of it is
/// left beside the new run's.
fn clear_previous_run(dir: &Path) -> Result<(), RunError> {
    let remove = |path: &Path| match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(output_error(path)(e)),
        _ => Ok(()),
    };
    for name in ["summary.json", "series.csv", checkpoint::FILE, ITERATIONS] {
        remove(&dir.join(name))?;
    }
    let entries = std::fs::read_dir(dir).map_err(output_error(dir))?;
    for entry in entries {
        let index = entry.map_err(output_error(dir))?.path();
        if index.extension().is_none_or(|e| e != "pvd") {
            continue;
        }
        let text = std::fs::read_to_string(&index).unwrap_or_default();
        for frame in text
            .split("file=\"")
            .skip(1)
            .filter_map(|t| t.split('"').next())
        {
            let frame = Path::new(frame);
            // Only frames the index names in this folder (a name, no path).
            if frame.components().count() == 1 && frame.extension().is_some_and(|e| e == "vtu") {
                remove(&dir.join(frame))?;
            }
        }
        remove(&index)?;
    }
    Ok(())
}

/// The case's checks on the series written so far; a check whose column cannot be read
/// has the value NaN.
fn evaluate_checks(case: &Case, series: &Path) -> Vec<CheckResult> {
    case.output
        .checks
        .iter()
        .map(|c| {
            let values: Vec<f64> = read_column(series, &c.column)
                .map(|rows| rows.into_iter().map(|(_, v)| v).collect())
                .unwrap_or_default();
            let value = c.statistic.of(&values);
            CheckResult {
                label: c.label.clone(),
                column: c.column.clone(),
                statistic: toml_name(&c.statistic),
                value,
                expected: c.expected,
                source: c.source.clone(),
                within: c.expected.map(|[lo, hi]| value >= lo && value <= hi),
            }
        })
        .collect()
}

/// The file of a static engine's solver iterations.
const ITERATIONS: &str = "iterations.csv";

/// `iterations.csv`, created at the first iteration an engine reports (time steppers
/// report none), one row per iteration, and a progress line each.
struct IterationLog {
    path: std::path::PathBuf,
    writer: Option<SeriesWriter>,
}

impl IterationLog {
    fn new(dir: &Path) -> Self {
        Self {
            path: dir.join(ITERATIONS),
            writer: None,
        }
    }

    fn record(&mut self, rows: Vec<Iteration>, progress: &Progress) -> Result<(), RunError> {
        for it in rows {
            if self.writer.is_none() {
                let columns: Vec<String> = Iteration::COLUMNS.map(String::from).to_vec();
                self.writer = Some(
                    SeriesWriter::create(&self.path, &columns).map_err(output_error(&self.path))?,
                );
            }
            if let Some(w) = self.writer.as_mut() {
                w.write_row(&it.row()).map_err(output_error(&self.path))?;
            }
            progress.println(format!(
                "load step {}, t = {:.4e}: iteration {}, |R| = {:.3e} ({:.3e} relative), \
                 |Δu| = {:.3e}{}{}",
                it.load_step,
                it.time,
                it.iteration,
                it.residual,
                it.relative_residual,
                it.increment,
                if it.linear_iterations > 0 {
                    format!(", {} CG iterations", it.linear_iterations)
                } else {
                    String::new()
                },
                if it.indefinite {
                    ", tangent indefinite (solved by LU)"
                } else {
                    ""
                }
            ));
        }
        Ok(())
    }
}
