//! Particle methods. Each method is an [`OdeSystem`] plus the fields and energies that
//! observers and outputs read.

pub mod mixed;
pub mod tlsph;

use crate::integrate::OdeSystem;
use crate::observe::Snapshot;
use crate::scene::{Case, CaseError, Discretised, MethodName};
use crate::tensor::Dim;
use rayon::prelude::*;
use std::ops::{Add, Mul};
use thiserror::Error;

/// Smallest slice length rayon splits down to: below it the per-task overhead dominates.
pub(crate) const MIN_CHUNK: usize = 256;

/// y += a x, field by field.
pub(crate) fn axpy<T: Copy + Send + Sync + Add<Output = T> + Mul<f64, Output = T>>(
    y: &mut [T],
    a: f64,
    x: &[T],
) {
    y.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(x)
        .for_each(|(y, &x)| *y = *y + x * a);
}

/// y = a y + b x, field by field.
pub(crate) fn blend<T: Copy + Send + Sync + Add<Output = T> + Mul<f64, Output = T>>(
    y: &mut [T],
    a: f64,
    b: f64,
    x: &[T],
) {
    y.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(x)
        .for_each(|(y, &x)| *y = *y * a + x * b);
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

/// What the driver, observers and outputs need from a method.
pub trait Method<D: Dim>: OdeSystem<Error = BlowUp> + Sized {
    /// The case-file method names this type implements.
    const NAMES: &'static [MethodName];
    /// Builds the method on the reference configuration of a case.
    fn build(case: &Case, disc: Discretised<D>) -> Result<Self, CaseError>;
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
    /// Power of the boundary reactions and external loads at the last rate evaluation.
    fn boundary_power(&self) -> f64;
    /// The first particle whose state is not finite, if any.
    fn check_finite(&self, y: &Self::State) -> Result<(), BlowUp>;
}
