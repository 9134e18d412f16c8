//! What the CPU systems of the method cores (total- and updated-Lagrangian SPH, the
//! Galerkin methods, mixed SPH) share about their particles: the `Method` accessors of
//! fields they all hold ([`particle_accessors`]), the signal speed of the CFL step and
//! the finiteness checks of the integrated density and stresses, and what acts on the
//! particles from outside the method ([`Surroundings`]).

use crate::boundary::Boundary;
use crate::core::tensor::Dim;
use crate::engine::{BlowUp, BoundaryWork};
use crate::interaction::Interactions;
use crate::physics::material::Material;
use rayon::prelude::*;

/// The `Method` accessors of a CPU system whose state type `$state` holds u and v and
/// whose particles hold `mass`, `body` and `surroundings` ([`Surroundings`]), in the system
/// itself or in the field path that follows the state type (`particle_accessors!(S, core)`
/// reads `self.core.mass`): displacement, velocity, mass, body, constrained and
/// boundary_work. The system's generic dimension is `D`; the caller has `BoundaryWork` in
/// scope.
macro_rules! particle_accessors {
    ($state:ty $(, $field:ident)*) => {
        fn displacement<'a>(&self, y: &'a $state) -> &'a [D::V] {
            &y.u
        }

        fn velocity<'a>(&self, y: &'a $state) -> &'a [D::V] {
            &y.v
        }

        fn mass(&self) -> &[f64] {
            &self$(.$field)*.mass
        }

        fn body(&self) -> &[u32] {
            &self$(.$field)*.body
        }

        fn constrained(&self) -> &[(u32, u8)] {
            &self$(.$field)*.surroundings.boundary.constrained
        }

        fn boundary_work(&self) -> &BoundaryWork {
            &self$(.$field)*.surroundings.work
        }
    };
}
pub(crate) use particle_accessors;

/// max_i |v_i|.
pub fn max_speed<D: Dim>(v: &[D::V]) -> f64 {
    v.par_iter()
        .map(|&v| D::norm2(v))
        .reduce(|| 0.0, f64::max)
        .sqrt()
}

/// c_p and max |v|: the terms of the signal speed of the CFL step of a method whose waves
/// travel at the material's p-wave speed.
pub fn signal_speed_terms<D: Dim>(material: &Material, v: &[D::V]) -> [f64; 2] {
    [material.p_wave_speed(), max_speed::<D>(v)]
}

/// The first non-finite density ρ_k or deviatoric stress S_k (either empty where a model
/// does not integrate it), as the blow-up `at(k, quantity, value)`.
pub fn check_stresses<D: Dim>(
    rho: &[f64],
    s: &[D::T],
    at: impl Fn(usize, &str, f64) -> BlowUp,
) -> Result<(), BlowUp> {
    if let Some(k) = rho.par_iter().position_first(|r| !r.is_finite()) {
        return Err(at(k, "density", rho[k]));
    }
    check_tensors::<D>(s, "deviatoric stress |S|", at)
}

/// The first non-finite tensor t_k, as the blow-up `at(k, quantity, √(t_k : t_k))`.
pub fn check_tensors<D: Dim>(
    t: &[D::T],
    quantity: &str,
    at: impl Fn(usize, &str, f64) -> BlowUp,
) -> Result<(), BlowUp> {
    match t.par_iter().position_first(|&t| !D::is_finite_t(t)) {
        Some(k) => Err(at(k, quantity, D::ddot(t[k], t[k]).sqrt())),
        None => Ok(()),
    }
}

/// What acts on a CPU system's particles from outside its method: the boundary conditions
/// (supports, prescribed motions, loads), the interactions (contact) and their work at the
/// last rate evaluation.
pub struct Surroundings<D: Dim> {
    pub boundary: Boundary<D>,
    pub interactions: Interactions<D>,
    /// The power of supports, loads and interactions and the supports' reactions at the
    /// last rate evaluation.
    pub work: BoundaryWork,
}

impl<D: Dim> Surroundings<D> {
    pub fn new(boundary: Boundary<D>, interactions: Interactions<D>) -> Self {
        Self {
            boundary,
            interactions,
            work: BoundaryWork::default(),
        }
    }

    /// The boundary conditions' step and the interactions' work before it (the contact
    /// forces of seed 000 §5.8), at the displacements u and velocities v of the particles
    /// at reference positions x0.
    pub fn begin_step(&mut self, t: f64, dt: f64, x0: &[D::V], u: &[D::V], v: &[D::V]) {
        self.boundary.begin_step(t, dt);
        self.interactions.begin_step(t, dt, x0, u, v);
    }

    /// The end of a rate evaluation: the interactions and the boundary conditions act on
    /// the accelerations a at velocities v, and their work is recorded.
    pub fn close(&mut self, v: &[D::V], mass: &[f64], a: &mut [D::V]) {
        self.work
            .finish(&self.interactions, &self.boundary, v, mass, a);
    }
}
