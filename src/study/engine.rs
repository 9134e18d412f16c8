//! One isolated run of a study: builds the engine of a case on a backend, drives it with
//! [`crate::run::drive`] through a wrapper that records the invariants at every check,
//! and reads the final state.

use super::fields::FinalState;
use crate::core::tensor::{D2, D3, Dim};
use crate::diagnostics::balance::{Balance, Booked};
use crate::diagnostics::observe::{Invariants, Snapshot};
use crate::engine::{BlowUp, Engine, EngineDim, Failed};
use crate::output::RunSummary;
use crate::run::{Backend, RunError, RunOptions, budget, drive, engine, may_use_gpu, with_threads};
use crate::scene::Scene;
use std::marker::PhantomData;
use std::time::Instant;

/// Largest drifts of the invariants over the checks of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Drift {
    /// max |H(t) − H(0)| / |H(0)| (NaN when H(0) = 0).
    pub angular_momentum: f64,
    /// The largest |energy_residue| of the energy balance ([`crate::diagnostics::balance`]): its
    /// residue over its scale.
    pub energy: f64,
    /// Number of states checked.
    pub samples: usize,
    h0: [f64; 3],
    e0: f64,
}

impl Drift {
    /// Records the invariants of the initial state; `h_scale` is Σ m |x| |v|, the largest
    /// angular momentum these speeds could carry: when |H(0)| is below 1e-9 of it, H(0)
    /// is zero up to round-off and its relative drift is not measured (NaN).
    pub fn start(&mut self, inv: &Invariants, h_scale: f64) {
        self.h0 = inv.angular;
        self.e0 = inv.total_energy();
        self.angular_momentum = if norm(self.h0) > 1e-9 * h_scale {
            0.0
        } else {
            f64::NAN
        };
        self.energy = 0.0;
        self.samples = 1;
    }

    /// Records the invariants of one state with the terms of the energy balance booked so
    /// far.
    pub fn record(&mut self, inv: &Invariants, booked: Booked) {
        if self.samples == 0 {
            self.start(inv, 0.0);
        }
        self.samples += 1;
        let dh = [0, 1, 2].map(|k| inv.angular[k] - self.h0[k]);
        let h = norm(dh) / norm(self.h0);
        let e = Balance {
            kinetic: inv.kinetic,
            stored: inv.strain,
            booked,
            e0: self.e0,
        }
        .relative_residue()
        .abs();
        // NaN (a state past a blow-up) does not replace a finite maximum.
        if !self.angular_momentum.is_nan() {
            self.angular_momentum = self.angular_momentum.max(h);
        }
        self.energy = self.energy.max(e);
    }
}

fn norm(a: [f64; 3]) -> f64 {
    a.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// An engine seen through a mutable borrow, recording the invariants at every check
/// and output of the driver.
struct Tracked<'a, D: Dim, E: Engine<D>> {
    inner: &'a mut E,
    drift: &'a mut Drift,
    _dim: PhantomData<D>,
}

impl<D: Dim, E: Engine<D>> Engine<D> for Tracked<'_, D, E> {
    fn backend(&self) -> String {
        self.inner.backend()
    }
    fn reference(&self) -> &[D::V] {
        self.inner.reference()
    }
    fn constrained(&self) -> &[(u32, u8)] {
        self.inner.constrained()
    }
    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        self.inner.advance(t, dt, steps)
    }
    fn max_signal_speed(&mut self) -> f64 {
        self.inner.max_signal_speed()
    }
    fn external_work(&mut self) -> f64 {
        self.inner.external_work()
    }
    fn reactions(&mut self) -> Vec<crate::boundary::Reaction> {
        self.inner.reactions()
    }
    fn booked(&mut self) -> Booked {
        self.inner.booked()
    }
    fn pseudo_time(&mut self) -> Option<crate::core::integrate::PseudoTime> {
        self.inner.pseudo_time()
    }
    fn check(&mut self) -> Result<(), BlowUp> {
        self.inner.check()
    }
    fn snapshot(&mut self) -> Snapshot<'_, D> {
        let booked = self.inner.booked();
        let snap = self.inner.snapshot();
        let inv = Invariants::of(&snap);
        if self.drift.samples == 0 {
            let scale: f64 = (0..snap.mass.len())
                .map(|i| {
                    let r = D::norm2(snap.x0[i] + snap.u[i]).sqrt();
                    snap.mass[i] * r * D::norm2(snap.v[i]).sqrt()
                })
                .sum();
            self.drift.start(&inv, scale);
        } else {
            self.drift.record(&inv, booked);
        }
        snap
    }
    fn invariants(&mut self) -> Invariants {
        let booked = self.inner.booked();
        let inv = self.inner.invariants();
        self.drift.record(&inv, booked);
        inv
    }
    fn finish(&mut self) {
        self.inner.finish()
    }
    fn save(&mut self) -> Vec<f64> {
        self.inner.save()
    }
    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        self.inner.restore(words)
    }
    fn iterations(&mut self) -> Vec<crate::engine::Iteration> {
        self.inner.iterations()
    }
}

/// What one run produced.
pub struct Outcome {
    /// The driver's result: the summary, or why the run stopped.
    pub result: Result<RunSummary, RunError>,
    /// Engine set-up plus time loop [s] (adapter and device creation excluded).
    pub wall_seconds: f64,
    pub drift: Drift,
    /// The state at the end (or at the failure).
    pub state: Option<FinalState>,
    /// Time reached.
    pub time: f64,
}

/// Runs a case on a backend (no frames, no progress bar) and reads its final state.
pub fn run_case(case: &Scene, backend: Backend, opts: &RunOptions) -> Outcome {
    with_threads(case, || match case.dimension {
        2 => run_dim::<D2>(case, backend, opts),
        _ => run_dim::<D3>(case, backend, opts),
    })
    .unwrap_or_else(failed)
}

fn failed(error: RunError) -> Outcome {
    Outcome {
        result: Err(error),
        wall_seconds: f64::NAN,
        drift: Drift::default(),
        state: None,
        time: f64::NAN,
    }
}

fn run_dim<D: EngineDim>(case: &Scene, backend: Backend, opts: &RunOptions) -> Outcome {
    let started = Instant::now();
    if let Err(e) = budget::check(case, may_use_gpu(case, backend), &opts.limits) {
        return failed(e.into());
    }
    match engine::<D>(case, backend) {
        Ok(mut engine) => drive_tracked(case, opts, &mut engine, started),
        Err(e) => failed(e),
    }
}

fn drive_tracked<D: Dim, E: Engine<D>>(
    case: &Scene,
    opts: &RunOptions,
    engine: &mut E,
    started: Instant,
) -> Outcome {
    let mut drift = Drift::default();
    let result = drive::<D, _>(
        case,
        opts,
        Tracked {
            inner: &mut *engine,
            drift: &mut drift,
            _dim: PhantomData,
        },
    );
    engine.finish();
    let wall_seconds = started.elapsed().as_secs_f64();
    let time = match &result {
        Ok(s) => s.end_time,
        Err(RunError::BlowUp { time, .. }) => *time,
        Err(_) => f64::NAN,
    };
    let state = FinalState::of(&engine.snapshot(), case.material.density);
    Outcome {
        result,
        wall_seconds,
        drift,
        state: Some(state),
        time,
    }
}
