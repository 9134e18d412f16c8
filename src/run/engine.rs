//! Engines: what the driver steps, and the factory that builds a case's engine through
//! its method's spec.

use super::{Backend, RunError};
use crate::balance::Booked;
use crate::boundary::Reaction;
#[cfg(feature = "gpu")]
use crate::gpu::{Gpu, SetupError};
use crate::integrate::{Integrator, OdeState, traffic};
use crate::methods::{BlowUp, Method, PseudoTime};
use crate::observe::{EngineColumns, Invariants, Snapshot};
use crate::reference::Reference;
use crate::scene::{Case, CaseError};
use crate::tensor::Dim;

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

/// Builds the CPU system `M` of a case.
pub fn build_method<D: Dim, M: Method<D>>(case: &Case) -> Result<M, CaseError> {
    M::build(case, Reference::build(case)?)
}

/// The engine a case runs on: the GPU when `backend` asks for it (or `auto` finds an
/// adapter and the method has a GPU engine), the CPU otherwise; the method's spec builds
/// them. A static run (`run.solve = "static"`) is on the CPU only.
pub fn engine<D: EngineDim>(case: &Case, backend: Backend) -> Result<Box<dyn Engine<D>>, RunError> {
    let spec = &case.method.spec;
    let backend = match (backend, super::cpu_only(case)) {
        (Backend::Gpu, Some(why)) => {
            return Err(RunError::Backend(format!(
                "{}: {why}; use --backend cpu (--backend auto picks the CPU for it)",
                case.file.display()
            )));
        }
        (Backend::Auto, Some(why)) => {
            eprintln!("note: --backend auto: {why}; running on the CPU (rayon, f64)");
            Backend::Cpu
        }
        (backend, _) => backend,
    };
    match gpu(backend)? {
        #[cfg(feature = "gpu")]
        Some(gpu) => spec.gpu_engine::<D>(case, gpu).map_err(|e| match e {
            SetupError::Case(c) => RunError::Case(c),
            SetupError::Gpu(g) => RunError::Backend(g.to_string()),
        }),
        _ => Ok(spec.cpu_engine::<D>(case)?),
    }
}

/// The GPU a backend choice asks for: none for `cpu`, an error for `gpu` without an
/// adapter, and for `auto` the adapter [`crate::gpu::context::auto_adapter`] picks.
#[cfg(feature = "gpu")]
fn gpu(backend: Backend) -> Result<Option<Gpu>, RunError> {
    Ok(match backend {
        Backend::Cpu => None,
        Backend::Gpu => Some(Gpu::new().map_err(|e| RunError::Backend(e.to_string()))?),
        Backend::Auto => match crate::gpu::context::auto_adapter() {
            Ok(_) => Gpu::new()
                .inspect_err(|e| eprintln!("note: {e}; running on the CPU (rayon, f64)"))
                .ok(),
            Err(why) => {
                eprintln!("note: --backend auto: {why}; running on the CPU (rayon, f64)");
                None
            }
        },
    })
}

/// Without the GPU backend: the CPU for `cpu` and `auto`, an error for `gpu`.
#[cfg(not(feature = "gpu"))]
fn gpu(backend: Backend) -> Result<Option<std::convert::Infallible>, RunError> {
    match backend {
        Backend::Gpu => Err(RunError::Backend(
            "this build has no GPU backend (cargo feature `gpu`); use --backend cpu".into(),
        )),
        Backend::Cpu | Backend::Auto => Ok(None),
    }
}

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
    /// The terms of the energy balance booked so far ([`crate::balance`]): the work of
    /// supports and loads, and the others this engine books.
    fn booked(&mut self) -> Booked;
    /// Pseudo-time iterations of a method that iterates within its stages
    /// ([`crate::methods::Method::pseudo_time`]); None for the others.
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
    /// What a step moves on the CPU by the method's traffic model, for `meshless bench
    /// --roofline`; none for a GPU engine or a method without a model.
    fn traffic(&self) -> Option<StepTraffic> {
        None
    }
    /// The pairs per particle a rate evaluation loops over ([`crate::methods::shared::Method::pairs`]),
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
    fn iterations(&mut self) -> Vec<Iteration> {
        (**self).iterations()
    }
    fn neighbour_seconds(&mut self) -> Option<f64> {
        (**self).neighbour_seconds()
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

/// A step's memory traffic by the method's model ([`crate::methods::Traffic`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepTraffic {
    /// Bytes per particle of the step: its rate evaluations and stage operations.
    pub bytes_per_particle: f64,
}

/// The integral of a power over the steps, trapezoidal from the powers at the last rate
/// evaluation of successive steps, and the last of those powers.
#[derive(Clone, Copy, Debug, Default)]
struct Trapezoid {
    integral: f64,
    last: f64,
}

impl Trapezoid {
    fn add(&mut self, power: f64, dt: f64) {
        self.integral += 0.5 * (self.last + power) * dt;
        self.last = power;
    }
}

/// The CPU reference engine: a method and an integrator (f64, rayon).
pub struct CpuEngine<D: Dim, M: Method<D>> {
    pub method: M,
    pub y: M::State,
    integrator: Integrator<M::State>,
    /// The power of supports and loads, of the artificial dissipation, against the
    /// hourglass control and of contact, integrated over the steps.
    external: Trapezoid,
    dissipation: Trapezoid,
    hourglass: Trapezoid,
    contact: Trapezoid,
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
            external: Trapezoid::default(),
            dissipation: Trapezoid::default(),
            hourglass: Trapezoid::default(),
            contact: Trapezoid::default(),
            _dim: std::marker::PhantomData,
        })
    }

    /// The integrated powers, in the order a checkpoint holds them.
    fn powers(&mut self) -> [&mut Trapezoid; 4] {
        [
            &mut self.external,
            &mut self.dissipation,
            &mut self.hourglass,
            &mut self.contact,
        ]
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

    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        for k in 0..steps {
            self.integrator
                .step(&mut self.method, t + f64::from(k) * dt, dt, &mut self.y)
                .map_err(|cause| Failed {
                    completed: k,
                    cause,
                })?;
            // The balance's powers, trapezoidal over successive steps; the work against
            // contact is minus its power on the bodies.
            let boundary = self.method.boundary_work();
            self.external.add(boundary.power, dt);
            self.contact.add(-boundary.contact, dt);
            self.dissipation.add(self.method.dissipation_power(), dt);
            self.hourglass.add(self.method.hourglass_power(), dt);
        }
        Ok(())
    }

    fn max_signal_speed(&mut self) -> f64 {
        self.method.max_signal_speed(&self.y)
    }

    fn external_work(&mut self) -> f64 {
        self.external.integral
    }

    fn reactions(&mut self) -> Vec<Reaction> {
        self.method.boundary_work().reactions.clone()
    }

    fn booked(&mut self) -> Booked {
        Booked {
            external_work: self.external.integral,
            dissipated: Some(self.dissipation.integral + self.method.step_dissipation()),
            hourglass_work: Some(self.hourglass.integral),
            plastic_work: Some(self.method.plastic_work(&self.y)),
            contact_energy: Some(self.contact.integral),
        }
    }

    fn pseudo_time(&mut self) -> Option<PseudoTime> {
        self.method.pseudo_time()
    }

    fn traffic(&self) -> Option<StepTraffic> {
        let t = self.method.traffic()?;
        let kind = self.integrator.kind();
        let evaluation = t.per_particle + self.pairs_per_particle()? * t.per_pair;
        Some(StepTraffic {
            bytes_per_particle: kind.stages() as f64 * evaluation
                + traffic(kind, t.state, t.velocity),
        })
    }

    fn pairs_per_particle(&self) -> Option<f64> {
        let n = self.method.reference().len();
        (n > 0).then(|| self.method.pairs() as f64 / n as f64)
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        self.method.check_finite(&self.y)
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        self.method.snapshot(&self.y)
    }

    /// The integrals of the balance's powers and their last powers, the state y, the
    /// integrator's and the method's history.
    fn save(&mut self) -> Vec<f64> {
        let mut out: Vec<f64> = self
            .powers()
            .iter()
            .flat_map(|p| [p.integral, p.last])
            .collect();
        self.y.save(&mut out);
        self.integrator.save(&mut out);
        self.method.save_history(&mut out);
        out
    }

    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        let (powers, mut rest): (&[f64; 8], _) = words
            .split_first_chunk()
            .ok_or("the checkpoint holds no engine state")?;
        self.y.load(&mut rest)?;
        self.integrator.load(&mut rest)?;
        self.method.load_history(&mut rest)?;
        if !rest.is_empty() {
            return Err(format!(
                "{} words are left over after the engine's state",
                rest.len()
            ));
        }
        for (p, w) in self.powers().into_iter().zip(powers.chunks_exact(2)) {
            (p.integral, p.last) = (w[0], w[1]);
        }
        Ok(())
    }

    fn neighbour_seconds(&mut self) -> Option<f64> {
        self.method.neighbour_seconds()
    }
}
