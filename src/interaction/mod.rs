//! Interactions: forces that act on the bodies besides a method's internal forces
//! (contact between bodies, and the loads that vary in time: tractions, pressures and
//! body forces under a time law; constant tractions and body forces are the boundary's
//! external accelerations, [`crate::boundary::Boundary::external`]). A method holds the
//! scene's [`Interactions`] and calls them at named points of a step, on either backend:
//!
//! - before the step ([`Interaction::begin_step`]), from the positions and velocities at
//!   its start;
//! - after the method's forces ([`Interaction::accelerate`]), adding accelerations to the
//!   rates before the boundary conditions act, and returning their power for the energy
//!   balance.
//!
//! On the GPU an interaction is a pass recorded before every step that writes its
//! accelerations, with the traction loads, into the `ext` buffer the rate passes add
//! ([`gpu`]).

pub mod contact;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod loads;

pub use contact::Contact;
pub use loads::TimedLoads;

use crate::boundary::NodalForces;
use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::sum::Exact;
use crate::core::tensor::Dim;

/// A force on the particles from outside the method, at named points of a step.
pub trait Interaction<D: Dim>: Send + Sync {
    /// Before every step of size dt from time t, with the current positions x and
    /// velocities v of the particles.
    fn begin_step(&mut self, t: f64, dt: f64, x: &[D::V], v: &[D::V]);

    /// Adds the interaction's accelerations to `a` at a rate evaluation with velocities v
    /// and masses m; returns their power Σ m a·v.
    fn accelerate(&self, v: &[D::V], mass: &[f64], a: &mut [D::V]) -> Exact;

    /// Whether its forces are contact between the bodies, whose work the energy balance
    /// books apart from the work of the loads ([`crate::diagnostics::balance`]).
    fn contact(&self) -> bool {
        false
    }

    /// For forces held through a step (contact, found from the positions at its start):
    /// their power Σ m a·v at the start of the current step, with which the balance
    /// integrates their work over the step. `None` for forces that follow the stages.
    fn start_power(&self) -> Option<Exact> {
        None
    }

    /// The interaction's device pass, if it has one.
    #[cfg(feature = "gpu")]
    fn gpu_pass(&self) -> Option<&dyn gpu::GpuInteraction>;
}

/// The power of the interactions at a rate evaluation, Σ m a·v: of the loads, and of
/// contact.
#[derive(Clone, Debug, Default)]
pub struct Power {
    pub external: Exact,
    pub contact: Exact,
    /// The contact's power at the start of the step (its forces are held through it).
    pub contact_start: Exact,
}

/// The interactions a case asks for, in the order they act.
pub struct Interactions<D: Dim> {
    list: Vec<Box<dyn Interaction<D>>>,
}

impl<D: Dim> Interactions<D> {
    /// The case's interactions on the particles at reference positions x0, with
    /// `neighbours` giving the neighbour lists of a total-Lagrangian method (read only by
    /// contact: its kernels must not join two bodies), `body` the body of every
    /// particle those lists name (the particles of x0 first, then any ghosts) and `mass`
    /// the method's nodal mass of the particles of x0, and `nodal` how the method carries
    /// the forces of a loaded surface to its nodes.
    pub fn build(
        case: &Case,
        x0: &[D::V],
        body: &[u32],
        nodal: &dyn NodalForces<D>,
        mass: &[f64],
        neighbours: impl FnOnce() -> Csr,
    ) -> Result<Self, CaseError> {
        let mut list: Vec<Box<dyn Interaction<D>>> = Vec::new();
        if let Some(loads) = TimedLoads::<D>::build(case, nodal, mass)? {
            list.push(Box::new(loads));
        }
        if let Some(spec) = case.contact {
            contact::apart::<D>(case, &neighbours(), body)?;
            list.push(Box::new(Contact::<D>::new(
                spec.penalty,
                x0,
                &body[..x0.len()],
                mass,
            )));
        }
        Ok(Self { list })
    }

    /// Every interaction's work before a step (see [`Interaction::begin_step`]); `x0 + u`
    /// are the positions.
    pub fn begin_step(&mut self, t: f64, dt: f64, x0: &[D::V], u: &[D::V], v: &[D::V]) {
        if self.list.is_empty() {
            return;
        }
        let x: Vec<D::V> = x0.iter().zip(u).map(|(&x0, &u)| x0 + u).collect();
        for i in &mut self.list {
            i.begin_step(t, dt, &x, v);
        }
    }

    /// Adds every interaction's accelerations to `a`; returns their power, the loads'
    /// and the contact's.
    pub fn accelerate(&self, v: &[D::V], mass: &[f64], a: &mut [D::V]) -> Power {
        let mut power = Power::default();
        for i in &self.list {
            let p = i.accelerate(v, mass, a);
            match i.contact() {
                true => power.contact.merge(&p),
                false => power.external.merge(&p),
            }
            if let Some(start) = i.start_power() {
                power.contact_start.merge(&start);
            }
        }
        power
    }

    /// The device passes of the interactions.
    #[cfg(feature = "gpu")]
    pub fn gpu_passes(&self) -> impl Iterator<Item = &dyn gpu::GpuInteraction> {
        self.list.iter().filter_map(|i| i.gpu_pass())
    }
}
