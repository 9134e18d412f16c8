//! What the CPU systems of the methods share: the [`Method`] trait (an [`OdeSystem`] plus
//! the fields and energies that observers and outputs read), [`BlowUp`], the reference
//! neighbours and gradients of the total-Lagrangian methods and the check of the
//! artificial viscosity's coefficients.

use crate::boundary::{Boundary, Reaction};
use crate::correction;
use crate::integrate::OdeSystem;
use crate::interaction::Interactions;
use crate::methods::Problem;
use crate::neighbour::Csr;
use crate::observe::Snapshot;
use crate::reference::{self, Reference};
use crate::scene::validate::non_negative;
use crate::scene::{Case, CaseError};
use crate::tensor::Dim;
use crate::viscosity::ArtificialViscosity;
use rayon::prelude::*;
use thiserror::Error;

/// The kernel support of a case, with the margin of [`crate::reference::neighbour_radius`].
pub(crate) fn neighbour_radius<D: Dim>(case: &Case) -> f64 {
    reference::neighbour_radius(&case.kernel(D::N))
}

/// Corrected gradients g_ij on the neighbour lists `csr` of the reference positions x0
/// (and volumes) of a total-Lagrangian method, computed once.
pub(crate) fn reference_gradients<D: Dim>(
    case: &Case,
    x0: &[D::V],
    vol: &[f64],
    csr: &Csr,
) -> Result<Vec<D::V>, CaseError> {
    correction::gradients::<D>(case.method.correction, x0, vol, csr, &case.kernel(D::N))
        .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))
}

/// For every pair (i, j) in CSR order, the index of the pair (j, i) in j's row. Lists
/// that are not symmetric (a neighbour at the kernel support, by round-off) name the
/// particle and the key to change.
pub fn reverse_pairs(case: &Case, csr: &Csr) -> Result<Vec<u32>, CaseError> {
    csr.map_rows(|i| {
        csr.neighbours(i)
            .iter()
            .map(|&j| {
                let row = j as usize;
                let back = csr.neighbours(row).binary_search(&(i as u32));
                back.map(|k| (csr.offsets[row] + k) as u32).map_err(|_| i)
            })
            .collect::<Result<Vec<_>, _>>()
    })
    .map_err(|i| {
        case.invalid(
            "method.h_over_dx",
            format!(
                "particle {i} has a neighbour at the kernel support that does not list it \
                 back; change h/dx slightly"
            ),
        )
    })
}

/// ∇0W̃_ji (j's corrected gradient, evaluated at i) for every pair (i, j), in CSR order:
/// the second gradient of a pair force that derives from Σ_i V_i ψ(F_i) (seed 000 eq 148).
pub(crate) fn reverse_gradients<D: Dim>(
    case: &Case,
    csr: &Csr,
    grad: &[D::V],
) -> Result<Vec<D::V>, CaseError> {
    let rev = reverse_pairs(case, csr)?;
    Ok(rev.par_iter().map(|&q| grad[q as usize]).collect())
}

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
    pub power: f64,
    /// The power of the contact forces on the bodies (seed 000 §5.8).
    pub contact: f64,
    /// The reaction of every support of the case.
    pub reactions: Vec<Reaction>,
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
        self.power = boundary.apply(a, v, mass, &mut self.reactions)
            + boundary.external_power(v, mass)
            + interaction.external;
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

/// What the driver, observers and outputs need from a method.
pub trait Method<D: Dim>: OdeSystem<Error = BlowUp> + Sized {
    /// Builds the method on the reference configuration of a case; a case that names a
    /// method this system does not run is an error.
    fn build(case: &Case, reference: Reference<D>) -> Result<Self, CaseError>;
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
    fn strain_energy(&self, y: &Self::State) -> f64;
    /// Everything observers and frames read, at state y.
    fn snapshot<'a>(&'a self, y: &Self::State) -> Snapshot<'a, D>;
    /// Largest signal speed c_p + |v| for the CFL condition.
    fn max_signal_speed(&self, y: &Self::State) -> f64;
    /// The power of supports, loads and interactions and the supports' reactions at the
    /// last rate evaluation.
    fn boundary_work(&self) -> &BoundaryWork;
    /// The power of the artificial dissipation at the last rate evaluation, −Σ m a_art·v
    /// with a_art the acceleration of the artificial viscosity, of a mixed method's
    /// stabilisation or of a Riemann solver's velocity jump (each method's document says
    /// which part of its dissipation this is); 0 for a method without one.
    fn dissipation_power(&self) -> f64 {
        0.0
    }
    /// The power against the hourglass control at the last rate evaluation, −Σ m a_hg·v;
    /// 0 for a method without one.
    fn hourglass_power(&self) -> f64 {
        0.0
    }
    /// The energy the method took out at the ends of the steps so far (the kinetic
    /// energy a velocity smoothing removes), booked with the artificial dissipation.
    fn step_dissipation(&self) -> f64 {
        0.0
    }
    /// The plastic work Σ_q w_q ∫ τ_y dε̄_p up to state y (the committed history's and
    /// the current step's, [`crate::plasticity::History::work_at`]); 0 for an elastic
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

    /// A point's plastic history, C_p⁻¹ (3 × 3 in 2D too) and ε_p, when the model keeps
    /// one; nothing otherwise.
    pub fn plastic_history(kept: bool) -> usize {
        if kept {
            size_of::<glam::DMat3>() + size_of::<f64>()
        } else {
            0
        }
    }
}

/// Pseudo-time iterations of a run with artificial compressibility.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PseudoTime {
    /// Iterations of the last step, summed over its stages.
    pub step: u64,
    /// Iterations since the run started.
    pub total: u64,
    /// The largest final residual of the last step's stages, relative to the velocity
    /// scale.
    pub residual: f64,
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
    /// operations move ([`crate::integrate::traffic`]).
    pub state: f64,
    /// Bytes of the velocity per particle (the leapfrog's kicks move only it).
    pub velocity: f64,
}

impl ArtificialViscosity {
    /// The coefficients must not be negative.
    pub fn validate(&self) -> Result<(), Problem> {
        non_negative("method.artificial_viscosity.alpha", self.alpha)?;
        non_negative("method.artificial_viscosity.beta", self.beta)?;
        non_negative("method.artificial_viscosity.eta", self.eta)
    }
}
