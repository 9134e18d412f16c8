//! The CPU reference engine: a [`Method`] and an integrator (f64, rayon).

use super::{BlowUp, Engine, Failed, Method, StepTraffic};
use crate::boundary::{Reaction, ReactionSum};
use crate::core::integrate::{
    Integrator, IntegratorKind, OdeState, OdeSystem, PseudoTime, traffic,
};
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::Snapshot;

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

    /// A step of a power whose force is held through the step: the trapezoid of its power
    /// at the step's start and at its last rate evaluation.
    fn add_held(&mut self, start: f64, power: f64, dt: f64) {
        self.last = start;
        self.add(power, dt);
    }
}

/// What the balance takes at the end of a step: the powers at its last rate evaluation
/// (of the supports and loads, of contact at the step's start and at its end, of the
/// artificial dissipation and against the hourglass control), then the kinetic energy
/// the step's end took out ([`Method::step_end_dissipation`]).
pub type StepSums<T> = [T; 6];

/// The words of the balance's integrals a checkpoint of the engine starts with: four
/// integrated powers and their last values, then the energy the steps' ends took out.
pub const BALANCE_WORDS: usize = 9;

/// What runs after each rate evaluation of a method and at the end of each step: nothing
/// on one rank; on the ranks of a distributed run, the exchange of the ghosts' rates with
/// their owners, of their state after a step whose end changes it, and the sum of the
/// ranks' shares of the step's sums ([`crate::engine::ranks`]).
pub trait AfterRates<S> {
    /// Called with the rates of each evaluation and how it ended; returns how it ends.
    fn after_rates(&mut self, d: &mut S, result: Result<(), BlowUp>) -> Result<(), BlowUp>;

    /// Called with the state after the method's end of a step.
    fn after_step(&mut self, _y: &mut S) {}

    /// The run's sums at the end of a step, from this process's exact shares.
    fn sums(&mut self, shares: StepSums<Exact>) -> StepSums<f64>;
}

/// Nothing after the rates, and the powers are this process's: a run on one rank.
struct Alone;

impl<S> AfterRates<S> for Alone {
    fn after_rates(&mut self, _d: &mut S, result: Result<(), BlowUp>) -> Result<(), BlowUp> {
        result
    }

    fn sums(&mut self, shares: StepSums<Exact>) -> StepSums<f64> {
        shares.each_ref().map(Exact::value)
    }
}

/// A method whose rate evaluations are followed by a hook.
struct Hooked<'a, M, H> {
    method: &'a mut M,
    hook: &'a mut H,
}

impl<M: OdeSystem<Error = BlowUp>, H: AfterRates<M::State>> OdeSystem for Hooked<'_, M, H> {
    type State = M::State;
    type Error = BlowUp;

    fn rates(&mut self, t: f64, y: &M::State, d: &mut M::State) -> Result<(), BlowUp> {
        let result = self.method.rates(t, y, d);
        self.hook.after_rates(d, result)
    }

    fn begin_step(&mut self, t: f64, dt: f64, y: &M::State) {
        self.method.begin_step(t, dt, y);
    }

    fn end_step(&mut self, t: f64, y: &mut M::State) {
        self.method.end_step(t, y);
        self.hook.after_step(y);
    }
}

/// The CPU reference engine: a method and an integrator (f64, rayon). Built from the two
/// ([`Self::with`]), or from a case by `CpuEngine::new` ([`crate::methods::cores::shared`]).
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
    /// The kinetic energy the steps' ends took out so far, booked with the artificial
    /// dissipation.
    step_ends: f64,
    _dim: std::marker::PhantomData<D>,
}

impl<D: Dim, M: Method<D>> CpuEngine<D, M> {
    /// The engine of `method` from its initial state, stepped by `integrator`.
    pub fn with(method: M, integrator: IntegratorKind) -> Self {
        let y = method.initial_state();
        let integrator = Integrator::new(integrator, &y);
        Self {
            method,
            y,
            integrator,
            external: Trapezoid::default(),
            dissipation: Trapezoid::default(),
            hourglass: Trapezoid::default(),
            contact: Trapezoid::default(),
            step_ends: 0.0,
            _dim: std::marker::PhantomData,
        }
    }

    /// [`Engine::advance`] with `hook` after each rate evaluation.
    pub fn advance_hooked<H: AfterRates<M::State>>(
        &mut self,
        t: f64,
        dt: f64,
        steps: u32,
        hook: &mut H,
    ) -> Result<(), Failed> {
        for k in 0..steps {
            let mut system = Hooked {
                method: &mut self.method,
                hook,
            };
            self.integrator
                .step(&mut system, t + f64::from(k) * dt, dt, &mut self.y)
                .map_err(|cause| Failed {
                    completed: k,
                    cause,
                })?;
            // The balance's powers, trapezoidal over successive steps, but the contact's
            // within the step its forces are held through; the work against contact is
            // minus its power on the bodies.
            let boundary = self.method.boundary_work();
            let [
                power,
                contact_start,
                contact,
                dissipation,
                hourglass,
                step_end,
            ] = hook.sums([
                boundary.power.clone(),
                boundary.contact_start.clone(),
                boundary.contact.clone(),
                self.method.dissipation_power(),
                self.method.hourglass_power(),
                self.method.step_end_dissipation(),
            ]);
            self.external.add(power, dt);
            self.contact.add_held(-contact_start, -contact, dt);
            self.dissipation.add(dissipation, dt);
            self.hourglass.add(hourglass, dt);
            self.step_ends += step_end;
        }
        Ok(())
    }

    /// The balance's terms: the integrated powers and the steps' ends, with the method's
    /// plastic work as given.
    pub fn booked_with(&self, plastic_work: f64) -> Booked {
        Booked {
            external_work: self.external.integral,
            dissipated: Some(self.dissipation.integral + self.step_ends),
            hourglass_work: Some(self.hourglass.integral),
            plastic_work: Some(plastic_work),
            contact_energy: Some(self.contact.integral),
        }
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
        self.advance_hooked(t, dt, steps, &mut Alone)
    }

    fn max_signal_speed(&mut self) -> f64 {
        self.method.max_signal_speed(&self.y)
    }

    fn external_work(&mut self) -> f64 {
        self.external.integral
    }

    fn reactions(&mut self) -> Vec<Reaction> {
        (self.method.boundary_work().reactions.iter())
            .map(ReactionSum::value)
            .collect()
    }

    fn booked(&mut self) -> Booked {
        let plastic_work = self.method.plastic_work(&self.y);
        self.booked_with(plastic_work)
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

    /// The integrals of the balance's powers and their last powers, the steps' ends
    /// ([`BALANCE_WORDS`]), the state y, the integrator's and the method's history.
    fn save(&mut self) -> Vec<f64> {
        let mut out: Vec<f64> = self
            .powers()
            .iter()
            .flat_map(|p| [p.integral, p.last])
            .collect();
        out.push(self.step_ends);
        self.y.save(&mut out);
        self.integrator.save(&mut out);
        self.method.save_history(&mut out);
        out
    }

    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        let (balance, mut rest): (&[f64; BALANCE_WORDS], _) = words
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
        let (powers, step_ends) = balance.split_at(BALANCE_WORDS - 1);
        for (p, w) in self.powers().into_iter().zip(powers.chunks_exact(2)) {
            (p.integral, p.last) = (w[0], w[1]);
        }
        self.step_ends = step_ends[0];
        Ok(())
    }

    fn neighbour_seconds(&mut self) -> Option<f64> {
        self.method.neighbour_seconds()
    }
}
