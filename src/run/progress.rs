//! Progress of a run on stderr: a bar on a terminal, a plain line every few seconds in a
//! batch log (stderr redirected to a file or a pipe), or nothing.

use crate::scene::Case;
use indicatif::{ProgressBar, ProgressStyle};
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
    lines: Option<(String, Instant)>,
}

impl Progress {
    pub(super) fn new(display: ProgressDisplay, case: &Case) -> Self {
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
        let lines =
            (display == ProgressDisplay::Lines).then(|| (case.name.clone(), Instant::now()));
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
    pub(super) fn update(&mut self, t: f64, t_end: f64, step: u64, rate: f64) {
        let status = format!("step {step}, t = {t:.4e} s, {rate:.3e} particle-steps/s");
        if let Some((name, last)) = &mut self.lines {
            if last.elapsed() >= LINE_EVERY {
                *last = Instant::now();
                eprintln!("{name}: {:.1} % ({status})", 100.0 * t / t_end);
            }
            return;
        }
        self.bar.set_position((t / t_end * 1000.0) as u64);
        self.bar.set_message(status);
    }

    pub(super) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
