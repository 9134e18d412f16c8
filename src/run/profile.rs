//! `--profile`: the pass report of a GPU engine's steps from the start of a run (or of
//! its resumption) to its end, in the summary; the CPU has none.

use super::Engine;
use super::batch::{Callback, End};
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Clock;

/// The profile callback: on when `--profile` asks for it.
pub(super) struct Profile {
    on: bool,
    from: Option<Profiled>,
}

impl Profile {
    pub(super) fn new(on: bool) -> Self {
        Self { on, from: None }
    }
}

impl<D: Dim> Callback<D> for Profile {
    fn on_start(&mut self, engine: &mut dyn Engine<D>, clock: &Clock) {
        if self.on {
            self.from = start_profile(engine, clock.step);
        }
    }

    fn on_end(&mut self, end: &mut End<D>) {
        end.passes = self
            .from
            .take()
            .and_then(|from| pass_report(end.engine, from, end.clock.step));
    }
}

/// Where a profiled run started: when, at which step, and the runs of the indirect passes
/// so far.
#[cfg(feature = "gpu")]
struct Profiled {
    started: std::time::Instant,
    step: u64,
    indirect: Option<crate::gpu::profile::IndirectRuns>,
}

/// Without the GPU backend no run is profiled.
#[cfg(not(feature = "gpu"))]
type Profiled = std::convert::Infallible;

/// Starts profiling the passes of a GPU engine (none on the CPU).
#[cfg(feature = "gpu")]
fn start_profile<D: Dim>(engine: &mut dyn Engine<D>, step: u64) -> Option<Profiled> {
    let (gpu, scale) = engine.device()?;
    gpu.profile(true);
    Some(Profiled {
        started: std::time::Instant::now(),
        step,
        indirect: scale.indirect,
    })
}

#[cfg(not(feature = "gpu"))]
fn start_profile<D: Dim>(_: &mut dyn Engine<D>, _: u64) -> Option<Profiled> {
    None
}

/// The pass report of the steps since `from` up to `step`; stops profiling.
#[cfg(feature = "gpu")]
fn pass_report<D: Dim>(
    engine: &mut dyn Engine<D>,
    from: Profiled,
    step: u64,
) -> Option<crate::diagnostics::passes::PassReport> {
    let wall = from.started.elapsed().as_secs_f64();
    let particles = engine.reference().len();
    let (gpu, mut scale) = engine.device()?;
    scale.indirect = scale
        .indirect
        .zip(from.indirect)
        .map(|(now, then)| now - then);
    let steps = u32::try_from(step - from.step).unwrap_or(u32::MAX);
    let report = crate::diagnostics::passes::PassReport {
        particles,
        ..gpu.pass_report(scale, steps, wall)
    };
    gpu.profile(false);
    Some(report)
}

#[cfg(not(feature = "gpu"))]
fn pass_report<D: Dim>(
    _: &mut dyn Engine<D>,
    from: Profiled,
    _: u64,
) -> Option<crate::diagnostics::passes::PassReport> {
    match from {}
}
