//! What the driver hands its callbacks: the [`Callback`] trait, the end of a batch of
//! steps ([`Batch`]) with the state read back when a callback [`Needs`] it, and the
//! per-particle indicators written with that state ([`Indicators`]).

use super::{Engine, RunError, checkpoint};
use crate::boundary::Reaction;
use crate::core::kernel::Kernel;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::{Clock, IndicatorFields, Invariants, Snapshot};
use crate::engine::BlowUp;
use crate::physics::hourglass::HourglassIndicator;
use crate::physics::pressure::{PressureFit, pressures};
use crate::scene::Scene;
use std::cell::OnceCell;

/// An output, check or log of a run. The driver schedules the events (sample, frame,
/// checkpoint, check, end); a callback is told of each and says when it wants the next.
pub(super) trait Callback<D: Dim> {
    /// The run starts stepping (after the outputs at t = 0, or from a checkpoint).
    fn on_start(&mut self, _engine: &mut dyn Engine<D>, _clock: &Clock) {}

    /// The time of the next event this callback waits for (infinite for none).
    fn next_time(&self) -> f64 {
        f64::INFINITY
    }

    /// What it needs read back after the batch that ends at `clock`.
    fn needs(&self, _clock: &Clock, _last: bool) -> Needs {
        Needs::default()
    }

    /// After the engine advanced a batch of steps, whether or not they failed.
    fn after_steps(&mut self, _engine: &mut dyn Engine<D>) -> Result<(), RunError> {
        Ok(())
    }

    /// After a batch that passed the engine's check (and for the outputs at t = 0): a
    /// failure found ends the run, and no later callback sees the batch.
    fn after_batch(&mut self, _batch: &mut Batch<D>) -> Result<Option<BlowUp>, RunError> {
        Ok(None)
    }

    /// After the batch's outputs that read the state back (and those at t = 0): the
    /// outputs the engine writes itself (a distributed run's frames in pieces).
    fn after_outputs(
        &mut self,
        _engine: &mut dyn Engine<D>,
        _clock: &Clock,
        _last: bool,
    ) -> Result<(), RunError> {
        Ok(())
    }

    /// Its part of a checkpoint, from which [`Self`] goes on when the run is resumed.
    fn save(&self, _at: &mut checkpoint::Progress) {}

    /// The run has ended (completed, failed or interrupted) at `clock`.
    fn on_end(&mut self, _end: &mut End<D>) {}
}

/// What the callbacks get at the end of a run.
pub(super) struct End<'a, D: Dim> {
    pub engine: &'a mut dyn Engine<D>,
    pub clock: Clock,
    /// With `--profile` on a GPU engine: the pass report of the run's steps.
    pub passes: Option<crate::diagnostics::passes::PassReport>,
}

/// What the callbacks need read back after a batch; the union of theirs is read.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Needs {
    /// The full state (F and σ evaluated), else only the engine's invariants (a reduction
    /// on the GPU).
    pub state: bool,
    /// A series row is written: the indicators its observers need.
    pub row: bool,
    /// A frame is written: every indicator.
    pub frame: bool,
    /// The supports' reactions.
    pub reactions: bool,
}

impl std::ops::BitOr for Needs {
    type Output = Self;
    fn bitor(self, o: Self) -> Self {
        Self {
            state: self.state || o.state,
            row: self.row || o.row,
            frame: self.frame || o.frame,
            reactions: self.reactions || o.reactions,
        }
    }
}

/// The end of a batch of steps as the callbacks see it.
pub(super) struct Batch<'a, D: Dim> {
    pub clock: Clock,
    /// The outputs at t = 0, before the first step (no check is made).
    pub start: bool,
    /// At the end time: every output is written.
    pub last: bool,
    /// A stop was asked for: the run ends after this batch.
    pub stop: bool,
    pub needs: Needs,
    /// The invariants: of the state when it is read, else the engine's.
    pub inv: Invariants,
    read: Read<'a, D>,
    indicators: &'a Indicators<'a, D>,
    fields: OnceCell<IndicatorFields>,
}

/// The state read back after a batch, or the engine to read it from.
enum Read<'a, D: Dim> {
    State {
        snap: Box<Snapshot<'a, D>>,
        reactions: Vec<Reaction>,
    },
    Engine(&'a mut dyn Engine<D>),
}

impl<'a, D: Dim> Batch<'a, D> {
    /// Reads what `needs` asks of `engine`: the reactions (before the state), the state
    /// and its invariants, or the engine's invariants alone.
    pub(super) fn read(
        engine: &'a mut dyn Engine<D>,
        clock: Clock,
        needs: Needs,
        indicators: &'a Indicators<'a, D>,
    ) -> Self {
        let (inv, read) = if needs.state {
            let reactions = match needs.reactions {
                true => engine.reactions(),
                false => Vec::new(),
            };
            let snap = Box::new(engine.snapshot());
            (Invariants::of(&snap), Read::State { snap, reactions })
        } else {
            (engine.invariants(), Read::Engine(engine))
        };
        Self {
            clock,
            start: false,
            last: false,
            stop: false,
            needs,
            inv,
            read,
            indicators,
            fields: OnceCell::new(),
        }
    }

    /// The state and the supports' reactions, when they were read.
    pub(super) fn state(&self) -> Option<(&Snapshot<'a, D>, &[Reaction])> {
        match &self.read {
            Read::State { snap, reactions } => Some((snap, reactions)),
            Read::Engine(_) => None,
        }
    }

    /// The indicators of the state the outputs need, evaluated at the first call; None
    /// when the state was not read.
    pub(super) fn fields(&self) -> Option<&IndicatorFields> {
        let (snap, _) = self.state()?;
        Some(
            self.fields
                .get_or_init(|| self.indicators.of(snap, self.needs.frame, self.needs.row)),
        )
    }

    /// `f` of the state: the one read, or one read now.
    pub(super) fn with_snapshot<R>(&mut self, f: impl FnOnce(&Snapshot<D>) -> R) -> R {
        match &mut self.read {
            Read::State { snap, .. } => f(snap),
            Read::Engine(engine) => f(&engine.snapshot()),
        }
    }
}

/// η and δp of every particle, each evaluated at an output only when a frame, a series
/// row with its observer or the hourglass limit needs it.
pub(super) struct Indicators<'a, D: Dim> {
    case: &'a Scene,
    fits: IndicatorFits,
    /// The series' observers need η, δp.
    row_eta: bool,
    row_deviation: bool,
    _dim: std::marker::PhantomData<D>,
}

impl<'a, D: Dim> Indicators<'a, D> {
    /// The indicators of a run whose rows need η and δp as `row_eta` and
    /// `row_deviation` say.
    pub(super) fn new(case: &'a Scene, row_eta: bool, row_deviation: bool) -> Self {
        Self {
            case,
            fits: IndicatorFits::new(case.kernel(D::N)),
            row_eta,
            row_deviation,
            _dim: std::marker::PhantomData,
        }
    }

    /// The fields of `snap` a frame (`frame`), a row (`row`) and the hourglass limit need.
    fn of(&self, snap: &Snapshot<D>, frame: bool, row: bool) -> IndicatorFields {
        let eta_needed = frame || (row && self.row_eta) || self.case.run.hourglass_limit.is_some();
        let deviation_needed = frame || (row && self.row_deviation);
        IndicatorFields {
            eta: eta_needed.then(|| self.fits.eta(snap)),
            pressure_deviation: deviation_needed.then(|| self.fits.deviation(snap)),
        }
    }
}

/// The neighbours and weights η and δp are evaluated with, each built at its first use
/// on the reference positions of the state it is given (always the same particles).
pub(super) struct IndicatorFits {
    kernel: Kernel,
    hourglass: OnceCell<HourglassIndicator>,
    pressure: OnceCell<PressureFit>,
}

impl IndicatorFits {
    /// The fits with the case's `kernel`.
    pub(super) fn new(kernel: Kernel) -> Self {
        Self {
            kernel,
            hourglass: OnceCell::new(),
            pressure: OnceCell::new(),
        }
    }

    /// The kernel's support [m].
    pub(super) fn reach(&self) -> f64 {
        self.kernel.support()
    }

    /// The hourglass indicator η of every particle of `snap`.
    pub(super) fn eta<D: Dim>(&self, snap: &Snapshot<D>) -> Vec<f64> {
        (self.hourglass)
            .get_or_init(|| HourglassIndicator::new::<D>(&self.kernel, snap.x0))
            .of::<D>(snap.x0, &snap.u, &snap.f)
    }

    /// The pressure deviation δp of every particle of `snap`.
    pub(super) fn deviation<D: Dim>(&self, snap: &Snapshot<D>) -> Vec<f64> {
        (self.pressure)
            .get_or_init(|| PressureFit::new::<D>(&self.kernel, snap.x0, snap.body))
            .deviation(&pressures(&snap.sigma))
    }
}
