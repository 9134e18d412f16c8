//! The explicit dynamic variant of dual-support SPH (`run.solve = "dynamic"`): the same
//! energy, variational force and hourglass control as the static method ([`super::model`]),
//! integrated in time with a lumped mass, m_i ü_i = f_i^int + f_i^ext with
//! f^int = −∂(E_strain + E_hg)/∂u (eq 18, eq 28). The force is the gradient of an energy,
//! so with a symplectic integrator the stored energy E_strain + E_hg plus the kinetic
//! energy is conserved but for the integrator's error, and Σ_i f_i^int = 0 to round-off.
//! The state is u and v, as for total-Lagrangian SPH ([`TlState`]).

use super::model::DualSupport;
use crate::boundary::{Boundary, OnPatches};
use crate::integrate::OdeSystem;
use crate::interaction::Interactions;
use crate::methods::shared::{BlowUp, BoundaryWork, MIN_CHUNK, Method, Sizes, Traffic};
use crate::methods::tlsph::{TlState, system as tl};
use crate::methods::{MethodSpec, not_run_by};
use crate::observe::Snapshot;
use crate::reference::Reference;
use crate::scene::{Case, CaseError};
use crate::tensor::Dim;
use rayon::prelude::*;

/// Dual-support SPH integrated in time on the CPU (f64, rayon).
pub struct DualSupportDynamics<D: Dim> {
    pub model: DualSupport<D>,
    mass: Vec<f64>,
    body: Vec<u32>,
    v0: Vec<D::V>,
    u0: Vec<D::V>,
    boundary: Boundary<D>,
    interactions: Interactions<D>,
    boundary_work: BoundaryWork,
    /// The power against the hourglass control at the last rate evaluation.
    hourglass_power: f64,
}

impl<D: Dim> DualSupportDynamics<D> {
    /// Smoothing lengths, supports and dual-supports on the reference configuration.
    pub fn new(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        let MethodSpec::DualSupportSph(spec) = &case.method.spec else {
            return Err(not_run_by(case, "DualSupportDynamics"));
        };
        let model = spec.model(case, &reference)?;
        let Reference {
            mass,
            body,
            v0,
            u0,
            boundary,
            ..
        } = reference;
        let s = &model.support;
        let interactions =
            Interactions::build(case, &s.x0, &body, &OnPatches, &mass, || s.lists.clone())?;
        Ok(Self {
            model,
            mass,
            body,
            v0,
            u0,
            boundary,
            interactions,
            boundary_work: BoundaryWork::default(),
            hourglass_power: 0.0,
        })
    }
}

impl<D: Dim> OdeSystem for DualSupportDynamics<D> {
    type State = TlState<D>;
    type Error = BlowUp;

    /// u̇ = v, v̇ = f^int/m plus the loads and constraints.
    fn rates(&mut self, _t: f64, y: &TlState<D>, d: &mut TlState<D>) -> Result<(), BlowUp> {
        let h = self.model.displacement_gradients(&y.u);
        if let Some(b) = self.model.first_inadmissible(&h) {
            return Err(b);
        }
        let f = self.model.internal_force_at(&y.u, &h, true);
        self.hourglass_power = self.model.hourglass_power(&y.v);
        d.v.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(f.par_iter().zip(&self.mass))
            .for_each(|(a, (&f, &m))| *a = f * (1.0 / m));
        d.u.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(&y.v)
            .for_each(|(u, &v)| *u = v);
        self.boundary_work.finish(
            &self.interactions,
            &self.boundary,
            &y.v,
            &self.mass,
            &mut d.v,
        );
        Ok(())
    }

    fn begin_step(&mut self, t: f64, dt: f64, y: &TlState<D>) {
        self.boundary.begin_step(t, dt);
        let x0 = &self.model.support.x0;
        self.interactions.begin_step(t, dt, x0, &y.u, &y.v);
    }
}

impl<D: Dim> Method<D> for DualSupportDynamics<D> {
    fn build(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        Self::new(case, reference)
    }

    fn initial_state(&self) -> TlState<D> {
        TlState {
            u: self.u0.clone(),
            v: self.v0.clone(),
            rho: Vec::new(),
            s: Vec::new(),
        }
    }

    fn displacement<'a>(&self, y: &'a TlState<D>) -> &'a [D::V] {
        &y.u
    }

    fn velocity<'a>(&self, y: &'a TlState<D>) -> &'a [D::V] {
        &y.v
    }

    fn reference(&self) -> &[D::V] {
        &self.model.support.x0
    }

    fn mass(&self) -> &[f64] {
        &self.mass
    }

    fn body(&self) -> &[u32] {
        &self.body
    }

    fn constrained(&self) -> &[(u32, u8)] {
        &self.boundary.constrained
    }

    fn deformation_gradient(&self, y: &TlState<D>) -> Vec<D::T> {
        self.model.deformation_gradients(&y.u)
    }

    fn cauchy_stress(&self, y: &TlState<D>) -> Vec<[[f64; 3]; 3]> {
        self.snapshot(y).sigma
    }

    /// E_strain alone: the hourglass energy is booked as the work against the hourglass
    /// control ([`Self::hourglass_power`]; its density is also a field of the frames).
    fn strain_energy(&self, y: &TlState<D>) -> f64 {
        self.model.energies(&y.u).strain
    }

    fn snapshot<'a>(&'a self, y: &TlState<D>) -> Snapshot<'a, D> {
        let (mass, body) = (&self.mass, &self.body);
        self.model
            .snapshot(y.u.clone(), y.v.clone(), mass, body, false)
    }

    /// c_p + max |v|.
    fn max_signal_speed(&self, y: &TlState<D>) -> f64 {
        let vmax =
            y.v.par_iter()
                .map(|&v| D::norm2(v))
                .reduce(|| 0.0, f64::max)
                .sqrt();
        self.model.material.p_wave_speed() + vmax
    }

    fn boundary_work(&self) -> &BoundaryWork {
        &self.boundary_work
    }

    /// −Σ f^hg·v at the last rate evaluation: its integral is the hourglass energy E_hg
    /// gained since the start, as the force derives from it (eq 21).
    fn hourglass_power(&self) -> f64 {
        self.hourglass_power
    }

    fn pairs(&self) -> usize {
        self.model.support.lists.pair_count()
    }

    /// Pass 1 reads u and the ids and g_ij of every pair and writes H = F − I; the det F
    /// check reads H; pass 2 reads H and V and writes V P; the force gather reads V P,
    /// g_i0, the ids and pair slots of the dual-support and g_ij through the slot, and
    /// writes f, evaluating each pair's hourglass term at both ends (X, u, H, V and c of
    /// the owner; the ids and w_ij of every pair, in each direction); the last passes
    /// write a = f/m (reading m) and u̇ = v.
    fn traffic(&self) -> Option<Traffic> {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let gather = t + 2 * v + (2 * v + t + 2 * f);
        let per_particle = (v + t) + t + (2 * t + f) + gather + (2 * v + f) + 2 * v;
        let per_pair = (id + v) + (2 * id + v) + 2 * (id + f);
        Some(Traffic {
            per_particle: per_particle as f64,
            per_pair: per_pair as f64,
            state: (2 * v) as f64,
            velocity: v as f64,
        })
    }

    fn check_finite(&self, y: &TlState<D>) -> Result<(), BlowUp> {
        tl::check_state(&self.model.support.x0, y)
    }
}
