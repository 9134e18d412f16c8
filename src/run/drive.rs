//! The time loop, a scheduler of events: it steps to the next sample, frame, checkpoint,
//! check or the end, whichever comes first, and tells its callbacks ([`Callback`]: the
//! outputs, the blow-up checks, the profile, the progress and the iteration log) of each
//! batch; then it writes the summary.

use super::batch::{Batch, Callback, End, Indicators, Needs};
use super::checkpoint;
use super::checks::{BlowUpChecks, step_collapse};
use super::frames::{Frames, next_frame_time};
use super::outputs::{Series, clear_previous_run, evaluate_checks};
use super::profile::Profile;
use super::progress::{IterationLog, Progress, ProgressDisplay, ShowProgress};
use super::{Engine, Failed, RunError, RunOptions, output_error};
use crate::core::tensor::Dim;
use crate::diagnostics::balance::Balance;
use crate::diagnostics::observe::{Clock, Observers};
use crate::engine::BlowUp;
use crate::output::{RunSummary, write_summary};
use crate::scene::Scene;
use std::time::Instant;

/// Steps between blow-up checks (and CFL updates) when samples are rarer.
pub(super) const CHECK_EVERY: u64 = 100;

/// Time-step size: fixed, or from the CFL number.
pub(super) fn time_step<D: Dim>(case: &Scene, engine: &mut dyn Engine<D>) -> f64 {
    match (case.method.dt, case.method.cfl) {
        (Some(dt), _) => dt,
        (None, Some(cfl)) => cfl * case.spacing / engine.max_signal_speed(),
        (None, None) => unreachable!("validation requires dt or cfl"),
    }
}

/// Runs an engine to the end time with observers, frames, checks and the summary.
pub fn drive<D: Dim, E: Engine<D>>(
    case: &Scene,
    opts: &RunOptions,
    mut engine: E,
) -> Result<RunSummary, RunError> {
    let engine: &mut dyn Engine<D> = &mut engine;
    let backend = engine.backend();
    let n = engine.reference().len();
    // The folder's lock before its checkpoint is read, held to the end of the run.
    std::fs::create_dir_all(&opts.out_dir).map_err(output_error(&opts.out_dir))?;
    let _lock = crate::output::lock_folder(&opts.out_dir).map_err(|e| match e.kind() {
        std::io::ErrorKind::WouldBlock => RunError::Busy {
            dir: opts.out_dir.clone(),
        },
        _ => output_error(&opts.out_dir)(e),
    })?;
    let resumed = resume(opts, case, &backend, engine)?;
    // The step count once the first Δt is known, before anything is written.
    let dt_first = match &resumed {
        Some(p) => p.dt_first,
        None => time_step(case, engine),
    };
    let t_end = case.run.end_time;
    super::budget::check_steps(case, t_end / dt_first, dt_first, &opts.limits)?;
    let engine_columns = engine.columns();
    let constrained = engine.constrained().to_vec();
    let observers = Observers::new::<D>(case, &engine.snapshot(), &constrained, engine_columns)?;
    if resumed.is_none() {
        clear_previous_run(&opts.out_dir, &case.name)?;
    }
    let mut frames = Frames::new(case, opts, engine.writes_frame_pieces())?;
    if let Some(p) = &resumed {
        frames.resume(p.next_frame, &p.frames)?;
    }
    let (row_eta, row_deviation) = (
        observers.need_hourglass(),
        observers.need_pressure_deviation(),
    );
    let mut series = Series::new(case, &opts.out_dir, observers, resumed.as_ref())?;
    let indicators = Indicators::new(case, row_eta, row_deviation);
    if opts.progress != ProgressDisplay::Off {
        eprintln!("{}: {n} particles on {backend}", case.name);
    }
    let running = running_summary(case, backend, n);
    let summary_path = opts.out_dir.join("summary.json");
    write_summary(&summary_path, &running).map_err(output_error(&summary_path))?;
    let mut checks = BlowUpChecks::new(case, engine, dt_first, resumed.is_some());
    let display = Progress::new(opts.progress, case);
    let mut iterations = IterationLog::new(&opts.out_dir, &display);
    let mut show = ShowProgress::new(&display, t_end, n);
    let mut profile = Profile::new(opts.profile);
    let started = Instant::now();
    let series_path = series.path().to_path_buf();
    let callbacks: &mut [&mut dyn Callback<D>] = &mut [
        &mut checks,
        &mut series,
        &mut frames,
        &mut iterations,
        &mut show,
        &mut profile,
    ];
    let run = Scheduler {
        case,
        opts,
        n,
        dt_first,
        indicators,
    };
    let ending = run
        .from(engine, callbacks, resumed.as_ref(), &running.backend)
        .map_err(|error| failed(&summary_path, &running, started, error))?;
    let wall = started.elapsed().as_secs_f64();
    let mut end = End {
        engine,
        clock: ending.clock,
        passes: None,
    };
    for callback in callbacks.iter_mut() {
        callback.on_end(&mut end);
    }
    let summary = run.summary(&mut end, &ending, wall, &series_path, running);
    if opts.progress != ProgressDisplay::Off {
        for check in &summary.checks {
            eprintln!("check: {check}");
        }
    }
    write_summary(&summary_path, &summary).map_err(output_error(&summary_path))?;
    ending.result(summary, opts)
}

/// The error that ends a run after its running summary, which it makes say "failed" and
/// why (written where it can be: the error is what the run reports either way).
fn failed(
    path: &std::path::Path,
    running: &RunSummary,
    started: Instant,
    error: RunError,
) -> RunError {
    let summary = RunSummary {
        status: "failed".into(),
        failure: Some(error.to_string()),
        wall_seconds: started.elapsed().as_secs_f64(),
        ..running.clone()
    };
    let _ = write_summary(path, &summary);
    error
}

/// The checkpoint's progress of a resumed run, with its state restored into `engine`;
/// None for a run that starts.
fn resume<D: Dim>(
    opts: &RunOptions,
    case: &Scene,
    backend: &str,
    engine: &mut dyn Engine<D>,
) -> Result<Option<checkpoint::Progress>, RunError> {
    if !opts.resume {
        return Ok(None);
    }
    let n = engine.reference().len();
    // An engine saves its state and what a step carries to the next: at most one more
    // copy of the state (a multistep integrator's last rates, absent at the start).
    let engine_words = 2 * engine.checkpoint_words();
    let read = checkpoint::read(&opts.out_dir, case, backend, n, engine_words)?;
    let restored = match read.pieces {
        None => engine.restore(&read.engine),
        Some(ranks) => engine.restore_pieces(ranks, &read.engine),
    };
    restored.map_err(|message| RunError::Checkpoint {
        path: opts.out_dir.join(checkpoint::FILE),
        message,
    })?;
    Ok(Some(read.progress))
}

/// The summary written before the first step: the case, the method and status "running".
fn running_summary(case: &Scene, backend: String, particles: usize) -> RunSummary {
    RunSummary {
        passes: None,
        case: case.name.clone(),
        version: env!("CARGO_PKG_VERSION").into(),
        case_file: case.file.display().to_string(),
        overrides: case.overrides.clone(),
        resolved_case: serde_json::to_value(case.resolved()).unwrap_or_default(),
        method: case.method.name.to_string(),
        backend,
        dimension: case.dimension,
        particles,
        steps: 0,
        dt_last: f64::NAN,
        end_time: 0.0,
        wall_seconds: 0.0,
        particle_steps_per_second: f64::NAN,
        halo_seconds: None,
        status: "running".into(),
        failure: None,
        final_invariants: Default::default(),
        energy_balance: Default::default(),
        checks: Vec::new(),
    }
}

/// The steps of the next batch from t with step `dt`: to the first of `events` (the
/// callbacks' next times, the next checkpoint, the end), at most [`CHECK_EVERY`]; one
/// that would pass the end lands on it, with whole steps of `dt`, then one shorter.
fn batch_steps(t: f64, dt: f64, t_end: f64, events: impl Iterator<Item = f64>) -> (u32, f64) {
    let to_event = events
        .map(|te| ((te - t) / dt - 0.5).ceil().max(1.0))
        .fold(CHECK_EVERY as f64, f64::min) as u32;
    if t + f64::from(to_event) * dt > t_end {
        let whole = ((t_end - t) / dt).floor() as u32;
        if whole == 0 {
            (1, t_end - t)
        } else {
            (whole, dt)
        }
    } else {
        (to_event, dt)
    }
}

/// What the scheduler holds through a run.
struct Scheduler<'a, D: Dim> {
    case: &'a Scene,
    opts: &'a RunOptions,
    n: usize,
    dt_first: f64,
    indicators: Indicators<'a, D>,
}

/// How the time loop ended.
struct Ending {
    clock: Clock,
    failure: Option<BlowUp>,
    /// Where the failure was found, when not at the current step: (first step it may
    /// have happened in, the step it is reported at, the time at the end of that step).
    found: Option<(u64, u64, f64)>,
    interrupted: bool,
}

impl<D: Dim> Scheduler<'_, D> {
    /// Runs from the start (its outputs at t = 0 first) or from the checkpoint's
    /// `resumed` progress to the end time, a failure or a stop.
    fn from(
        &self,
        engine: &mut dyn Engine<D>,
        callbacks: &mut [&mut dyn Callback<D>],
        resumed: Option<&checkpoint::Progress>,
        backend: &str,
    ) -> Result<Ending, RunError> {
        let (clock, next_checkpoint) = match resumed {
            Some(p) => {
                let clock = Clock {
                    t: p.t,
                    step: p.step,
                    dt: p.dt,
                    booked: engine.booked(),
                    e0: p.e0,
                    pseudo_time: engine.pseudo_time().unwrap_or_default(),
                };
                (clock, p.next_checkpoint)
            }
            None => (
                self.first_outputs(engine, callbacks)?,
                self.case.run.checkpoint_interval.unwrap_or(f64::INFINITY),
            ),
        };
        for callback in callbacks.iter_mut() {
            callback.on_start(engine, &clock);
        }
        self.steps(engine, callbacks, clock, next_checkpoint, backend)
    }

    /// The outputs at t = 0 of a run that starts: its clock, with E0 of the state.
    fn first_outputs(
        &self,
        engine: &mut dyn Engine<D>,
        callbacks: &mut [&mut dyn Callback<D>],
    ) -> Result<Clock, RunError> {
        let clock = Clock {
            dt: self.dt_first,
            ..Clock::default()
        };
        // Every output is written; a row has no reactions before the first step.
        let needs = Needs {
            state: true,
            reactions: false,
            ..union(callbacks, &clock, true)
        };
        let mut batch = Batch::read(engine, clock, needs, &self.indicators);
        batch.clock.e0 = batch.inv.total_energy();
        (batch.start, batch.last) = (true, true);
        for callback in callbacks.iter_mut() {
            callback.after_batch(&mut batch)?;
        }
        let clock = batch.clock;
        for callback in callbacks.iter_mut() {
            callback.after_outputs(engine, &clock, true)?;
        }
        Ok(clock)
    }

    /// Steps from `clock` to the end time, a failure or a stop.
    fn steps(
        &self,
        engine: &mut dyn Engine<D>,
        callbacks: &mut [&mut dyn Callback<D>],
        mut clock: Clock,
        mut next_checkpoint: f64,
        backend: &str,
    ) -> Result<Ending, RunError> {
        let (case, dt_first) = (self.case, self.dt_first);
        let t_end = case.run.end_time;
        let done = |t: f64| t >= t_end * (1.0 - 1e-12);
        let mut found = None;
        let mut interrupted = false;
        let failure = loop {
            let Clock { t, step, .. } = clock;
            if done(t) {
                break None;
            }
            let dt = time_step(case, engine);
            if let Some(ratio) = case.run.min_step_ratio
                && dt < ratio * dt_first
            {
                let floor = ratio * dt_first;
                break Some(step_collapse::<D>(case, &engine.snapshot(), floor));
            }
            let events = callbacks.iter().map(|c| c.next_time());
            let (steps, dt) = batch_steps(t, dt, t_end, events.chain([next_checkpoint, t_end]));
            let advanced = engine.advance(t, dt, steps);
            for callback in callbacks.iter_mut() {
                callback.after_steps(engine)?;
            }
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
                e0: clock.e0,
                pseudo_time: engine.pseudo_time().unwrap_or_default(),
            };
            if let Err(cause) = engine.check() {
                // Found at the check after the batch: in one of its steps.
                found = Some((step + 1, clock.step, clock.t));
                break Some(cause);
            }
            // The full state is read (and F, σ evaluated) only when a callback needs it.
            let last = done(clock.t);
            let needs = union(callbacks, &clock, last);
            let mut batch = Batch::read(engine, clock, needs, &self.indicators);
            (batch.last, batch.stop) = (last, self.stop_requested());
            if let Some(cause) = after_batch(callbacks, &mut batch)? {
                break Some(cause);
            }
            let stop = batch.stop;
            for callback in callbacks.iter_mut() {
                callback.after_outputs(engine, &clock, last)?;
            }
            // A checkpoint when one is due, and on a stop (with checkpoints on), after
            // the batch's outputs: a resumed run goes on from here exactly as this one
            // would.
            let due = clock.t >= next_checkpoint * (1.0 - 1e-9);
            if let Some(interval) = case.run.checkpoint_interval
                && (due || stop)
            {
                if due {
                    next_checkpoint = next_frame_time(next_checkpoint, interval, clock.t);
                }
                self.checkpoint(engine, callbacks, &clock, next_checkpoint, backend)?;
            }
            if stop {
                interrupted = true;
                break None;
            }
        };
        Ok(Ending {
            clock,
            failure,
            found,
            interrupted,
        })
    }

    /// Whether a stop was asked for (by SIGINT or SIGTERM).
    fn stop_requested(&self) -> bool {
        self.opts
            .stop
            .as_ref()
            .is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed))
    }

    /// Writes the checkpoint at `clock`: the driver's progress, the callbacks' and the
    /// engine's state.
    fn checkpoint(
        &self,
        engine: &mut dyn Engine<D>,
        callbacks: &[&mut dyn Callback<D>],
        clock: &Clock,
        next_checkpoint: f64,
        backend: &str,
    ) -> Result<(), RunError> {
        let mut at = checkpoint::Progress {
            t: clock.t,
            step: clock.step,
            dt: clock.dt,
            dt_first: self.dt_first,
            e0: clock.e0,
            next_sample: f64::NAN,
            next_checkpoint,
            series_bytes: 0,
            next_frame: f64::NAN,
            frames: Vec::new(),
        };
        for callback in callbacks {
            callback.save(&mut at);
        }
        let dir = &self.opts.out_dir;
        let Some(pieces) = engine.save_pieces(clock.step) else {
            let words = engine.save();
            return checkpoint::write(dir, self.case, backend, self.n, &at, &words, None);
        };
        let (words, ranks) = pieces.map_err(|e| RunError::Output {
            path: dir.join(checkpoint::PIECES_DIR),
            source: std::io::Error::other(e),
        })?;
        checkpoint::write(dir, self.case, backend, self.n, &at, &words, Some(ranks))?;
        checkpoint::prune_pieces(dir, clock.step);
        Ok(())
    }

    /// The summary of a run that ended as `ending` says, after `wall` seconds.
    fn summary(
        &self,
        end: &mut End<D>,
        ending: &Ending,
        wall: f64,
        series: &std::path::Path,
        running: RunSummary,
    ) -> RunSummary {
        let Clock { t, step, dt, .. } = ending.clock;
        let inv = end.engine.invariants();
        let energy_balance = Balance {
            kinetic: inv.kinetic,
            stored: inv.strain,
            booked: end.engine.booked(),
            e0: ending.clock.e0,
        }
        .named();
        let (first_step, failed_step, failed_time) = ending.found_at();
        RunSummary {
            passes: end.passes.take(),
            steps: step,
            dt_last: dt,
            end_time: t,
            wall_seconds: wall,
            particle_steps_per_second: self.n as f64 * step as f64 / wall.max(1e-12),
            halo_seconds: end.engine.halo_seconds(),
            status: match (&ending.failure, ending.interrupted) {
                (Some(_), _) => "failed",
                (None, true) => "interrupted",
                (None, false) => "completed",
            }
            .into(),
            failure: ending.failure.as_ref().map(|c| {
                let steps = if first_step < failed_step {
                    format!("in steps {first_step} to {failed_step}")
                } else {
                    format!("at step {failed_step}")
                };
                format!("{steps}, t = {failed_time:e} s: {c}")
            }),
            final_invariants: inv.named::<D>(),
            energy_balance,
            checks: evaluate_checks(self.case, series),
            ..running
        }
    }
}

/// What the callbacks need read back after the batch that ends at `clock`.
fn union<D: Dim>(callbacks: &[&mut dyn Callback<D>], clock: &Clock, last: bool) -> Needs {
    callbacks
        .iter()
        .fold(Needs::default(), |needs, c| needs | c.needs(clock, last))
}

/// Tells the callbacks of a batch, in order, up to the first that finds a failure.
fn after_batch<D: Dim>(
    callbacks: &mut [&mut dyn Callback<D>],
    batch: &mut Batch<D>,
) -> Result<Option<BlowUp>, RunError> {
    for callback in callbacks.iter_mut() {
        if let Some(cause) = callback.after_batch(batch)? {
            return Ok(Some(cause));
        }
    }
    Ok(None)
}

impl Ending {
    /// The first step a failure may have happened in, the step and time it is reported
    /// at (the current ones when it was found there).
    fn found_at(&self) -> (u64, u64, f64) {
        let Clock { t, step, .. } = self.clock;
        self.found.unwrap_or((step, step, t))
    }

    /// The run's result: the summary, or the failure or interruption.
    fn result(self, summary: RunSummary, opts: &RunOptions) -> Result<RunSummary, RunError> {
        let (first_step, step, time) = self.found_at();
        match self.failure {
            Some(cause) => Err(RunError::BlowUp {
                step,
                first_step,
                time,
                cause,
                out_dir: opts.out_dir.clone(),
            }),
            None if self.interrupted => Err(RunError::Interrupted {
                step: self.clock.step,
                time: self.clock.t,
                out_dir: opts.out_dir.clone(),
            }),
            None => Ok(summary),
        }
    }
}
