//! The engine contracts: what the driver steps ([`Engine`]), what a method's CPU system
//! gives the driver, observers and outputs ([`Method`]), the CPU engine that integrates one
//! ([`CpuEngine`]), the GPU engine of every device family (`GpuEngine` on a `GpuFamily`,
//! in `gpu.rs`), and what a step reports (a [`BlowUp`], [`Iteration`]s of a static solve,
//! the traffic of a step). Below the method cores and families and the driver, which both
//! speak through it; the factory that picks a case's engine is [`crate::run::engine`].

mod cpu;
#[cfg(feature = "gpu")]
mod gpu;
mod method;
pub mod ranks;

pub use cpu::{AfterRates, CpuEngine};
#[cfg(feature = "gpu")]
pub use gpu::{GpuEngine, GpuFamily, Start};
pub use method::{BlowUp, BoundaryWork, Method, Sizes, Traffic, check_motion};

use crate::boundary::Reaction;
use crate::core::integrate::PseudoTime;
use crate::core::tensor::Dim;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::{EngineColumns, Invariants, Snapshot};
#[cfg(feature = "gpu")]
use crate::gpu::Gpu;

/// A blow-up found during [`Engine::advance`], after `completed` whole steps of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Failed {
    pub completed: u32,
    pub cause: BlowUp,
}

/// The dimensions an engine runs in: [`Dim`], and with the GPU backend its WGSL layouts.
#[cfg(feature = "gpu")]
pub trait EngineDim: crate::gpu::GpuDim {}
#[cfg(feature = "gpu")]
impl<D: crate::gpu::GpuDim> EngineDim for D {}
/// The dimensions an engine runs in.
#[cfg(not(feature = "gpu"))]
pub trait EngineDim: Dim {}
#[cfg(not(feature = "gpu"))]
impl<D: Dim> EngineDim for D {}

/// One iteration of a static engine's nonlinear solve (seed 004 §2): a row of
/// `iterations.csv` and a progress line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Iteration {
    /// The load step being solved (1, 2, …; a cut step keeps its number).
    pub load_step: u64,
    /// The pseudo-time t of the load being solved (the load factor is t/end_time).
    pub time: f64,
    /// 0 for the residual before the first solve.
    pub iteration: u32,
    /// |R| over the free degrees of freedom [N].
    pub residual: f64,
    /// |R| over the force scale the tolerance is relative to.
    pub relative_residual: f64,
    /// |Δu| of the solve that led here [m] (0 at iteration 0).
    pub increment: f64,
    /// Iterations of the linear solver (0 for a direct solve).
    pub linear_iterations: u32,
    /// Wall time of the tangent assembly and linear solve [s].
    pub solve_seconds: f64,
    /// The solve that led here met an indefinite tangent (solved by LU).
    pub indefinite: bool,
}

impl Iteration {
    /// The columns of `iterations.csv`.
    pub const COLUMNS: [&'static str; 9] = [
        "load_step",
        "time",
        "iteration",
        "residual",
        "relative_residual",
        "increment",
        "linear_iterations",
        "solve_seconds",
        "indefinite",
    ];

    /// The row of `iterations.csv`.
    pub fn row(&self) -> [f64; 9] {
        [
            self.load_step as f64,
            self.time,
            f64::from(self.iteration),
            self.residual,
            self.relative_residual,
            self.increment,
            f64::from(self.linear_iterations),
            self.solve_seconds,
            f64::from(u8::from(self.indefinite)),
        ]
    }
}

/// A time stepper the driver runs: the CPU method with its integrator, or the GPU engine;
/// or a static engine, whose steps are load steps in the pseudo-time of the run.
pub trait Engine<D: Dim> {
    /// "cpu", or "gpu: <adapter>".
    fn backend(&self) -> String;
    fn reference(&self) -> &[D::V];
    fn constrained(&self) -> &[(u32, u8)];
    /// Advances `steps` steps of size dt from time t; a blow-up found during a step says
    /// how many whole steps came before it.
    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed>;
    /// Largest signal speed for the CFL step Δt = α Δx / signal speed, as the method
    /// defines it (`Plan::cfl_step`; e.g. c_p + max |v|, or Δx max_ab C_p,ab / r_ab + max
    /// |v| over the current pairs for seed 002 eqs 31–32).
    fn max_signal_speed(&mut self) -> f64;
    /// Work done on the bodies by supports and loads so far.
    fn external_work(&mut self) -> f64;
    /// The reaction of every support of the case ([`crate::boundary::supports`]) at the last
    /// rate evaluation.
    fn reactions(&mut self) -> Vec<Reaction>;
    /// The terms of the energy balance booked so far ([`crate::diagnostics::balance`]): the work of
    /// supports and loads, and the others this engine books.
    fn booked(&mut self) -> Booked;
    /// Pseudo-time iterations of a method that iterates within its stages
    /// ([`Method::pseudo_time`]); None for the others.
    fn pseudo_time(&mut self) -> Option<PseudoTime> {
        None
    }
    /// The series columns this engine adds besides the observers'.
    fn columns(&mut self) -> EngineColumns {
        EngineColumns {
            pseudo_time: self.pseudo_time().is_some(),
        }
    }
    /// Non-finite state or det F ≤ 0 since the start.
    fn check(&mut self) -> Result<(), BlowUp>;
    fn snapshot(&mut self) -> Snapshot<'_, D>;
    /// Energies and momenta of the current state.
    fn invariants(&mut self) -> Invariants {
        Invariants::of(&self.snapshot())
    }
    /// Waits until all submitted work is done (for timing).
    fn finish(&mut self) {}
    /// Everything the engine carries from one step to the next (the state, the work of
    /// the supports and loads, an integrator's or material's history), as f64 words for
    /// a checkpoint.
    fn save(&mut self) -> Vec<f64>;
    /// Continues from what [`Self::save`] returned; Err says what does not fit.
    fn restore(&mut self, words: &[f64]) -> Result<(), String>;
    /// The words [`Self::save`] returns at the start of a run: what bounds a checkpoint
    /// that an engine of this run reads (with at most one more copy of the state, a
    /// multistep integrator's rates).
    fn checkpoint_words(&mut self) -> usize {
        self.save().len()
    }
    /// A checkpoint in pieces, on several ranks: every rank writes its own particles'
    /// words for `step` ([`ranks::PieceStore`]); returns the words of the checkpoint file
    /// itself, which name the pieces, and the rank count. None: the engine's words are
    /// [`Self::save`]'s.
    fn save_pieces(&mut self, _step: u64) -> Option<Result<(Vec<f64>, usize), String>> {
        None
    }
    /// Continues from a checkpoint in pieces that `ranks` ranks wrote, whose file holds
    /// `words`.
    fn restore_pieces(&mut self, ranks: usize, _words: &[f64]) -> Result<(), String> {
        Err(format!(
            "it was written in pieces by {ranks} ranks; resume it on several ranks \
             (--ranks N, or mpirun with a build with MPI), any number of them"
        ))
    }
    /// Whether the engine writes its frames itself, in pieces (one a rank of a
    /// distributed run), rather than the driver writing them whole from
    /// [`Self::snapshot`].
    fn writes_frame_pieces(&self) -> bool {
        false
    }
    /// Writes frame `frame` at time t in pieces with their index
    /// ([`ranks::FrameStore`]); returns the bytes written.
    fn write_frame_pieces(&mut self, _frame: usize, _t: f64) -> Result<u64, String> {
        Err("this engine's frames are written whole".into())
    }
    /// The nonlinear-solver iterations since the last call (a static engine's Newton
    /// iterations; a time stepper has none).
    fn iterations(&mut self) -> Vec<Iteration> {
        Vec::new()
    }
    /// Wall time spent keeping the neighbour lists up to date since the engine was built
    /// [s], for the methods whose lists follow the particles (`meshless bench` reports it
    /// as a share of the step time); none for lists built once.
    fn neighbour_seconds(&mut self) -> Option<f64> {
        None
    }
    /// Wall time this rank of a distributed run spent since its engine was built in the
    /// exchanges with the other ranks during the steps (the halo's rows after every rate
    /// evaluation and the collective that ends each step), waiting for them included [s];
    /// none on one rank.
    fn halo_seconds(&mut self) -> Option<f64> {
        None
    }
    /// What a step moves on the CPU by the method's traffic model, for `meshless bench
    /// --roofline`; none for a GPU engine or a method without a model.
    fn traffic(&self) -> Option<StepTraffic> {
        None
    }
    /// The pairs per particle a rate evaluation loops over ([`Method::pairs`]),
    /// for `meshless bench`'s cost per pair; none for a GPU or static engine.
    fn pairs_per_particle(&self) -> Option<f64> {
        None
    }
    /// A GPU engine's device, for the pass report, and what scales its passes' bytes
    /// (the pairs of its lists, the builds its device ran); none on the CPU.
    #[cfg(feature = "gpu")]
    fn device(&mut self) -> Option<(&Gpu, crate::gpu::profile::Scale)> {
        None
    }
}

/// Forwarding, so that the driver runs whichever engine [`crate::run::engine`] chose.
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
    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        (**self).advance(t, dt, steps)
    }
    fn max_signal_speed(&mut self) -> f64 {
        (**self).max_signal_speed()
    }
    fn external_work(&mut self) -> f64 {
        (**self).external_work()
    }
    fn reactions(&mut self) -> Vec<Reaction> {
        (**self).reactions()
    }
    fn booked(&mut self) -> Booked {
        (**self).booked()
    }
    fn pseudo_time(&mut self) -> Option<PseudoTime> {
        (**self).pseudo_time()
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
    fn save(&mut self) -> Vec<f64> {
        (**self).save()
    }
    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        (**self).restore(words)
    }
    fn checkpoint_words(&mut self) -> usize {
        (**self).checkpoint_words()
    }
    fn save_pieces(&mut self, step: u64) -> Option<Result<(Vec<f64>, usize), String>> {
        (**self).save_pieces(step)
    }
    fn restore_pieces(&mut self, ranks: usize, words: &[f64]) -> Result<(), String> {
        (**self).restore_pieces(ranks, words)
    }
    fn writes_frame_pieces(&self) -> bool {
        (**self).writes_frame_pieces()
    }
    fn write_frame_pieces(&mut self, frame: usize, t: f64) -> Result<u64, String> {
        (**self).write_frame_pieces(frame, t)
    }
    fn iterations(&mut self) -> Vec<Iteration> {
        (**self).iterations()
    }
    fn neighbour_seconds(&mut self) -> Option<f64> {
        (**self).neighbour_seconds()
    }
    fn halo_seconds(&mut self) -> Option<f64> {
        (**self).halo_seconds()
    }
    fn traffic(&self) -> Option<StepTraffic> {
        (**self).traffic()
    }
    fn pairs_per_particle(&self) -> Option<f64> {
        (**self).pairs_per_particle()
    }
    #[cfg(feature = "gpu")]
    fn device(&mut self) -> Option<(&Gpu, crate::gpu::profile::Scale)> {
        (**self).device()
    }
}

/// A step's memory traffic by the method's model ([`Traffic`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepTraffic {
    /// Bytes per particle of the step: its rate evaluations and stage operations.
    pub bytes_per_particle: f64,
}
