//! What a method's CPU system gives the engine, the observers and the outputs: the
//! [`Method`] trait (an [`OdeSystem`] plus the fields and energies they read), the
//! [`BlowUp`] that stops a run, the boundary's work at a rate evaluation and the traffic
//! model of `meshless bench --roofline`.

use crate::boundary::{Boundary, ReactionSum};
use crate::core::integrate::{OdeSystem, PseudoTime};
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::interaction::Interactions;
use rayon::prelude::*;
use thiserror::Error;

/// The first particle with a non-finite displacement or velocity, as a blow-up.
pub fn check_motion<D: Dim>(x0: &[D::V], u: &[D::V], v: &[D::V]) -> Result<(), BlowUp> {
    let norm = |v: D::V| D::norm2(v).sqrt();
    if let Some(i) = u.par_iter().position_first(|&u| !D::is_finite_v(u)) {
        return Err(BlowUp::at::<D>(x0, i, "displacement |u|", norm(u[i])));
    }
    if let Some(i) = v.par_iter().position_first(|&v| !D::is_finite_v(v)) {
        return Err(BlowUp::at::<D>(x0, i, "velocity |v|", norm(v[i])));
    }
    Ok(())
}

/// What the end of a rate evaluation leaves for the work balance and the `reaction`
/// observer.
#[derive(Clone, Debug, Default)]
pub struct BoundaryWork {
    /// The power of supports, loads and the interactions other than contact.
    pub power: Exact,
    /// The power of the contact forces on the bodies (seed 000 §5.8).
    pub contact: Exact,
    /// The power of the same contact forces at the start of the step: they are held
    /// through it.
    pub contact_start: Exact,
    /// The reaction of every support of the case.
    pub reactions: Vec<ReactionSum>,
}

impl BoundaryWork {
    /// The end of a rate evaluation of every method: the interactions' accelerations, then
    /// the boundary's loads and constraints, on the rates `a` at velocities v.
    pub fn finish<D: Dim>(
        &mut self,
        interactions: &Interactions<D>,
        boundary: &Boundary<D>,
        v: &[D::V],
        mass: &[f64],
        a: &mut [D::V],
    ) {
        let interaction = interactions.accelerate(v, mass, a);
        self.contact = interaction.contact;
        self.contact_start = interaction.contact_start;
        self.power = boundary.apply(a, v, mass, &mut self.reactions);
        self.power.merge(&boundary.external_power(v, mass));
        self.power.merge(&interaction.external);
    }
}

/// A run stopped because the solution left the physically admissible set.
#[derive(Clone, Debug, Error, PartialEq)]
#[error("{quantity} = {value:e} at particle {particle} (reference position {position:?})")]
pub struct BlowUp {
    pub particle: usize,
    pub position: [f64; 3],
    /// What failed, e.g. `det F` or `velocity`.
    pub quantity: String,
    pub value: f64,
}

impl BlowUp {
    /// `quantity` = `value` at particle i of the reference positions x0.
    pub fn at<D: Dim>(x0: &[D::V], i: usize, quantity: &str, value: f64) -> Self {
        Self {
            particle: i,
            position: D::to3(x0[i]),
            quantity: quantity.to_string(),
            value,
        }
    }
}

/// What the driver, observers and outputs need from a method's CPU system; it is built
/// by [`crate::reference::Build`].
pub trait Method<D: Dim>: OdeSystem<Error = BlowUp> + Sized {
    /// Initial state (displacement zero, initial velocities with BCs imposed).
    fn initial_state(&self) -> Self::State;
    /// Displacement u = x − X and velocity v of a state.
    fn displacement<'a>(&self, y: &'a Self::State) -> &'a [D::V];
    fn velocity<'a>(&self, y: &'a Self::State) -> &'a [D::V];
    /// Reference positions X, masses and body indices.
    fn reference(&self) -> &[D::V];
    fn mass(&self) -> &[f64];
    fn body(&self) -> &[u32];
    /// Particles with prescribed velocity components (particle, component mask).
    fn constrained(&self) -> &[(u32, u8)];
    /// Deformation gradient F of every particle.
    fn deformation_gradient(&self, y: &Self::State) -> Vec<D::T>;
    /// Cauchy stress of every particle as a 3×3 tensor (2D: σ_zz of plane strain).
    fn cauchy_stress(&self, y: &Self::State) -> Vec<[[f64; 3]; 3]>;
    /// Σ V0 ψ: the stored strain energy.
    fn strain_energy(&self, y: &Self::State) -> Exact;
    /// Everything observers and frames read, at state y.
    fn snapshot<'a>(&'a self, y: &Self::State) -> Snapshot<'a, D>;
    /// The two maxima over the particles whose sum is the CFL condition's signal speed:
    /// a wave speed and the largest |v|. A distributed run takes each over the ranks
    /// before adding them, as the largest of the ranks' sums would not be one rank's.
    fn signal_speed_terms(&self, y: &Self::State) -> [f64; 2];
    /// Largest signal speed c_p + |v| for the CFL condition: the sum of the terms.
    fn max_signal_speed(&self, y: &Self::State) -> f64 {
        let [waves, flow] = self.signal_speed_terms(y);
        waves + flow
    }
    /// The power of supports, loads and interactions and the supports' reactions at the
    /// last rate evaluation.
    fn boundary_work(&self) -> &BoundaryWork;
    /// The power of the artificial dissipation at the last rate evaluation, −Σ m a_art·v
    /// with a_art the acceleration of the artificial viscosity, of a mixed method's
    /// stabilisation or of a Riemann solver's velocity jump (each method's document says
    /// which part of its dissipation this is); 0 for a method without one.
    fn dissipation_power(&self) -> Exact {
        Exact::default()
    }
    /// The power against the hourglass control at the last rate evaluation, −Σ m a_hg·v;
    /// 0 for a method without one.
    fn hourglass_power(&self) -> Exact {
        Exact::default()
    }
    /// The kinetic energy the end of the last step took out (a velocity smoothing), the
    /// exact sum over the counted particles; the engine books it with the artificial
    /// dissipation. 0 for a method whose steps' ends change nothing.
    fn step_end_dissipation(&self) -> Exact {
        Exact::default()
    }
    /// Whether the end of a step changes the state (a velocity smoothing), so that the
    /// ghosts of a rank take their owners' state again after it.
    fn step_end_changes_state(&self) -> bool {
        false
    }
    /// The plastic work Σ_q w_q ∫ τ_y dε̄_p up to state y (the committed history's and
    /// the current step's, [`crate::physics::plasticity::History::work_at`]); 0 for an elastic
    /// material.
    fn plastic_work(&self, _y: &Self::State) -> f64 {
        0.0
    }
    /// The pseudo-time iterations of a method that iterates within its stages
    /// (artificial compressibility); None for the others.
    fn pseudo_time(&self) -> Option<PseudoTime> {
        None
    }
    /// The first particle whose state is not finite, if any.
    fn check_finite(&self, y: &Self::State) -> Result<(), BlowUp>;
    /// What the method carries from step to step besides the state (a plastic
    /// history), for a checkpoint; none by default.
    fn save_history(&self, _out: &mut Vec<f64>) {}
    /// Reads what [`Self::save_history`] wrote.
    fn load_history(&mut self, _words: &mut &[f64]) -> Result<(), String> {
        Ok(())
    }
    /// Wall time spent keeping the neighbour lists up to date since the method was built
    /// [s]; none for lists built once on the reference configuration.
    fn neighbour_seconds(&self) -> Option<f64> {
        None
    }
    /// The ordered pairs of the lists a rate evaluation loops over (particle–neighbour
    /// pairs; point–node pairs of a Galerkin method's shape functions), for the cost per
    /// pair `meshless bench` reports.
    fn pairs(&self) -> usize;
    /// The bytes a rate evaluation moves on the CPU, for `meshless bench --roofline`;
    /// none for a method without a model.
    fn traffic(&self) -> Option<Traffic> {
        None
    }
}

/// The element sizes a traffic model counts in [bytes]: a vector, a tensor and a scalar
/// of the dimension, and a pair's id.
#[derive(Clone, Copy, Debug)]
pub struct Sizes {
    pub v: usize,
    pub t: usize,
    pub f: usize,
    pub id: usize,
}

impl Sizes {
    pub fn of<D: Dim>() -> Self {
        Self {
            v: size_of::<D::V>(),
            t: size_of::<D::T>(),
            f: size_of::<f64>(),
            id: size_of::<u32>(),
        }
    }

    /// A point's plastic history, C_p⁻¹ (3 × 3 in 2D too), ε_p and ΔT, when the model
    /// keeps one; nothing otherwise.
    pub fn plastic_history(kept: bool) -> usize {
        if kept {
            size_of::<glam::DMat3>() + 2 * size_of::<f64>()
        } else {
            0
        }
    }
}

/// The memory traffic of one rate evaluation on the CPU, by the minimum-traffic model:
/// every array a pass reads or writes crosses the memory bus once per pass (a neighbour's
/// record, gathered again by its other neighbours, comes from cache).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Traffic {
    /// Bytes per particle: per-particle arrays, summed over the passes.
    pub per_particle: f64,
    /// Bytes per neighbour pair: per-pair arrays (ids, gradients), summed over passes.
    pub per_pair: f64,
    /// Bytes of the integrated state per particle, which the integrator's stage
    /// operations move ([`crate::core::integrate::traffic`]).
    pub state: f64,
    /// Bytes of the velocity per particle (the leapfrog's kicks move only it).
    pub velocity: f64,
}
