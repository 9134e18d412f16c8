//! Progress of a run on stderr: a bar on a terminal, a plain line every few seconds in a
//! batch log (stderr redirected to a file or a pipe), or nothing; and the log of a static
//! engine's solver iterations (`iterations.csv`, a line each above the bar).

use super::batch::{Batch, Callback, End};
use super::{Engine, Iteration, RunError, output_error};
use crate::core::tensor::Dim;
use crate::engine::BlowUp;
use crate::output::SeriesWriter;
use crate::scene::Scene;
use indicatif::{ProgressBar, ProgressStyle};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How a run shows its progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressDisplay {
    Off,
    /// A bar redrawn in place (stderr is a terminal).
    Bar,
    /// A plain line every [`LINE_EVERY`] (stderr is a file or a pipe).
    Lines,
}

impl ProgressDisplay {
    /// A bar on a terminal, lines elsewhere; nothing when `quiet`.
    pub fn for_stderr(quiet: bool) -> Self {
        use std::io::IsTerminal;
        match (quiet, std::io::stderr().is_terminal()) {
            (true, _) => Self::Off,
            (false, true) => Self::Bar,
            (false, false) => Self::Lines,
        }
    }
}

/// The interval of the plain progress lines.
pub const LINE_EVERY: Duration = Duration::from_secs(10);

/// A run's progress display.
pub(super) struct Progress {
    bar: ProgressBar,
    /// With [`ProgressDisplay::Lines`]: the case's name and when the last line was written.
    lines: Option<(String, Cell<Instant>)>,
}

impl Progress {
    pub(super) fn new(display: ProgressDisplay, case: &Scene) -> Self {
        let bar = if display == ProgressDisplay::Bar {
            let bar = ProgressBar::new(1000);
            bar.set_style(
                ProgressStyle::with_template(
                    "{prefix} [{elapsed_precise}] {wide_bar} {percent}% eta {eta} {msg}",
                )
                .expect("static progress template is valid"),
            );
            bar.set_prefix(case.name.clone());
            bar
        } else {
            ProgressBar::hidden()
        };
        let lines = (display == ProgressDisplay::Lines)
            .then(|| (case.name.clone(), Cell::new(Instant::now())));
        Self { bar, lines }
    }

    /// A message above the bar, or a line of its own.
    pub(super) fn println(&self, message: String) {
        if self.lines.is_some() {
            eprintln!("{message}");
        } else {
            self.bar.println(message);
        }
    }

    /// The run is at time t of t_end after `step` steps, at `rate` particle-steps/s.
    fn update(&self, t: f64, t_end: f64, step: u64, rate: f64) {
        let status = format!("step {step}, t = {t:.4e} s, {rate:.3e} particle-steps/s");
        if let Some((name, last)) = &self.lines {
            if last.get().elapsed() >= LINE_EVERY {
                last.set(Instant::now());
                eprintln!("{name}: {:.1} % ({status})", 100.0 * t / t_end);
            }
            return;
        }
        self.bar.set_position((t / t_end * 1000.0) as u64);
        self.bar.set_message(status);
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// The progress display updated after each batch (not the last, on a stop) and cleared
/// at the end.
pub(super) struct ShowProgress<'a> {
    display: &'a Progress,
    started: Instant,
    t_end: f64,
    particles: usize,
}

impl<'a> ShowProgress<'a> {
    pub(super) fn new(display: &'a Progress, t_end: f64, particles: usize) -> Self {
        Self {
            display,
            started: Instant::now(),
            t_end,
            particles,
        }
    }
}

impl<D: Dim> Callback<D> for ShowProgress<'_> {
    fn after_batch(&mut self, batch: &mut Batch<D>) -> Result<Option<BlowUp>, RunError> {
        if !batch.start && !batch.stop {
            let step = batch.clock.step;
            let rate = (self.particles as f64 * step as f64) / self.started.elapsed().as_secs_f64();
            self.display.update(batch.clock.t, self.t_end, step, rate);
        }
        Ok(None)
    }

    fn on_end(&mut self, _: &mut End<D>) {
        self.display.finish();
    }
}

/// The file of a static engine's solver iterations.
pub(super) const ITERATIONS: &str = "iterations.csv";

/// `iterations.csv`, created at the first iteration an engine reports (time steppers
/// report none), one row per iteration, and a progress line each.
pub(super) struct IterationLog<'a> {
    path: PathBuf,
    writer: Option<SeriesWriter>,
    display: &'a Progress,
}

impl<'a> IterationLog<'a> {
    pub(super) fn new(dir: &Path, display: &'a Progress) -> Self {
        Self {
            path: dir.join(ITERATIONS),
            writer: None,
            display,
        }
    }

    fn record(&mut self, it: &Iteration) -> Result<(), RunError> {
        if self.writer.is_none() {
            let columns: Vec<String> = Iteration::COLUMNS.map(String::from).to_vec();
            self.writer =
                Some(SeriesWriter::create(&self.path, &columns).map_err(output_error(&self.path))?);
        }
        if let Some(w) = self.writer.as_mut() {
            w.write_row(&it.row()).map_err(output_error(&self.path))?;
        }
        self.display.println(format!(
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
        Ok(())
    }
}

impl<D: Dim> Callback<D> for IterationLog<'_> {
    fn after_steps(&mut self, engine: &mut dyn Engine<D>) -> Result<(), RunError> {
        engine
            .iterations()
            .iter()
            .try_for_each(|it| self.record(it))
    }
}
