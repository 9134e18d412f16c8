//! Total-Lagrangian SPH from the elastic potential (seed 000 §5.4, eqs 138–148, App. 9.2).
//!
//! The internal force is minus the gradient of the discrete strain energy
//! Π = Σ_i V_i ψ(F_i) with F_i = I + Σ_j V_j (u_j − u_i) ⊗ ∇0W̃_ij, which gives the
//! symmetrised pair force of eq 148 with the corrected gradient of each side,
//! f_i = Σ_j V_i V_j [P_i ∇0W̃_ij − P_j ∇0W̃_ji], P = ∂ψ/∂F. Each pair's two terms appear
//! with opposite signs in the two rows, so Σ_i f_i = 0 to round-off whatever the
//! correction (seed 000 checklist 13). The state is u = x − X and v: no density or
//! stress is integrated.

use super::PotentialForce;
use crate::boundary::{Boundary, OnPatches};
use crate::integrate::OdeSystem;
use crate::interaction::Interactions;
use crate::material::Material;
use crate::methods::shared::{
    BlowUp, BoundaryWork, MIN_CHUNK, Method, Sizes, Traffic, reference_gradients, reverse_gradients,
};
use crate::methods::tlsph::{ArtificialViscosity, TlState, system as tl};
use crate::methods::{MethodSpec, not_run_by};
use crate::neighbour::Csr;
use crate::observe::Snapshot;
use crate::reference::Reference;
use crate::scene::{Case, CaseError};
use crate::tensor::Dim;
use rayon::prelude::*;

/// Per-particle quantities of one rate evaluation.
#[derive(Clone, Copy, Debug)]
struct Kinematics<D: Dim> {
    /// F = I + Σ_j V_j (u_j − u_i) ⊗ ∇0W̃_ij (eq 137).
    f: D::T,
    /// First Piola–Kirchhoff stress P = ∂ψ/∂F.
    p: D::T,
    /// F⁻ᵀ, the push-forward of reference gradients (artificial viscosity).
    f_inv_t: D::T,
    /// Current density ρ0/J (artificial viscosity).
    rho: f64,
}

/// The factor 1/√V_min on c_p in the CFL step of the reference code's force, which is
/// that of Σ_i ψ_i and so 1/V stiffer than the consistent one.
pub fn unit_weight_wave_speed_scale(vol: &[f64]) -> f64 {
    vol.iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .sqrt()
        .recip()
}

/// The elastic-potential system on the CPU (f64, rayon).
pub struct Potential<D: Dim> {
    x0: Vec<D::V>,
    vol: Vec<f64>,
    mass: Vec<f64>,
    body: Vec<u32>,
    v0: Vec<D::V>,
    /// Initial displacements.
    u0: Vec<D::V>,
    csr: Csr,
    /// Corrected reference gradients ∇0W̃_ij, one per CSR pair.
    grad: Vec<D::V>,
    /// ∇0W̃_ji (j's correction, evaluated at i) for every pair (i, j), in CSR order.
    grad_rev: Vec<D::V>,
    material: Material,
    force: PotentialForce,
    /// The weight of each particle's ψ in the energy the force derives from: V_i for the
    /// consistent force, 1 for the reference code's (whose force is that of Σ_i ψ_i when
    /// the volumes are uniform).
    energy_weight: Vec<f64>,
    av: Option<ArtificialViscosity>,
    h: f64,
    boundary: Boundary<D>,
    interactions: Interactions<D>,
    kin: Vec<Kinematics<D>>,
    /// The power of supports, loads and interactions and the supports' reactions at the
    /// last rate evaluation.
    boundary_work: BoundaryWork,
    /// Each particle's viscous dissipation −m a_visc·v at the last rate evaluation.
    dissipation: Vec<f64>,
}

impl<D: Dim> Potential<D> {
    /// Builds neighbours, corrected gradients and their reverses on the reference
    /// configuration.
    pub fn new(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        let MethodSpec::TlPotential(spec) = &case.method.spec else {
            return Err(not_run_by(case, "Potential"));
        };
        let csr = reference.neighbours();
        let Reference {
            x0,
            vol,
            mass,
            body,
            v0,
            u0,
            boundary,
            material,
            kernel,
            ..
        } = reference;
        let grad = reference_gradients::<D>(case, &x0, &vol, &csr)?;
        let grad_rev = reverse_gradients::<D>(case, &csr, &grad)?;
        let interactions =
            Interactions::build(case, &x0, &body, &OnPatches, &mass, || csr.clone())?;
        let identity = Kinematics {
            f: D::identity(),
            p: D::zero_t(),
            f_inv_t: D::identity(),
            rho: material.rho0,
        };
        let energy_weight = match spec.force {
            PotentialForce::Consistent => vol.clone(),
            PotentialForce::ReferenceCode => vec![1.0; vol.len()],
        };
        Ok(Self {
            kin: vec![identity; x0.len()],
            dissipation: vec![0.0; x0.len()],
            x0,
            vol,
            mass,
            body,
            v0,
            u0,
            csr,
            grad,
            grad_rev,
            material,
            force: spec.force,
            energy_weight,
            av: spec.artificial_viscosity,
            h: kernel.h,
            boundary,
            interactions,
            boundary_work: BoundaryWork::default(),
        })
    }

    /// F_i = I + Σ_j V_j (u_j − u_i) ⊗ ∇0W̃_ij (eq 137).
    fn deformation_gradient_of(&self, i: usize, u: &[D::V]) -> D::T {
        let mut h = D::zero_t();
        for p in self.csr.range(i) {
            let j = self.csr.ids[p] as usize;
            h += D::outer(u[j] - u[i], self.grad[p]) * self.vol[j];
        }
        D::identity() + h
    }

    fn each_f(&self, u: &[D::V]) -> Vec<D::T> {
        (0..self.x0.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|i| self.deformation_gradient_of(i, u))
            .collect()
    }

    /// Pass 1: F, P = ∂ψ/∂F, F⁻ᵀ and ρ0/J of every particle.
    fn stresses(&mut self, y: &TlState<D>) {
        let mat = self.material;
        let mut kin = std::mem::take(&mut self.kin);
        kin.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(i, k)| {
                let f = self.deformation_gradient_of(i, &y.u);
                *k = Kinematics {
                    f,
                    p: mat.pk1::<D>(f),
                    f_inv_t: D::transpose(D::inverse(f)),
                    rho: mat.rho0 / D::det(f),
                };
            });
        self.kin = kin;
    }

    /// The pair weights (w_ij of P_i ∇0W̃_ij, w_ji of P_j ∇0W̃_ji) of the force on i.
    /// Consistent: both V_i V_j (−∂Π/∂u_i). Reference code: ½(f_ji − f_ij) with
    /// f_ij = −2 V_i F_i S_i ∇0W̃_ij (seed 000 §3.4), i.e. V_i and V_j.
    #[inline]
    fn pair_weights(&self, i: usize, j: usize) -> (f64, f64) {
        match self.force {
            PotentialForce::Consistent => {
                let w = self.vol[i] * self.vol[j];
                (w, w)
            }
            PotentialForce::ReferenceCode => (self.vol[i], self.vol[j]),
        }
    }

    /// Pass 2: m_i a_i = Σ_j [w_ij P_i ∇0W̃_ij − w_ji P_j ∇0W̃_ji] (eq 148 symmetrised),
    /// plus Monaghan viscosity along ½(F_i⁻ᵀ ∇0W̃_ij − F_j⁻ᵀ ∇0W̃_ji): the TLSPH direction
    /// F_i⁻ᵀ ∇0W̃_ij made antisymmetric in the pair as the stress term is, so that the
    /// viscosity too keeps Σ m a = 0.
    /// Also writes each particle's viscous dissipation −m_i a_visc·v_i into `dissipation`.
    fn accelerations(&self, y: &TlState<D>, a: &mut [D::V], dissipation: &mut [f64]) {
        let bulk = self.material.bulk;
        let h = self.h;
        a.par_iter_mut()
            .zip(dissipation.par_iter_mut())
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(i, (a, dissipation))| {
                let ki = self.kin[i];
                let xi = self.x0[i] + y.u[i];
                let ci = (bulk / ki.rho).sqrt();
                let mut force = D::zero();
                let mut viscous = D::zero();
                for p in self.csr.range(i) {
                    let j = self.csr.ids[p] as usize;
                    let kj = self.kin[j];
                    let (w_ij, w_ji) = self.pair_weights(i, j);
                    force += ki.p * self.grad[p] * w_ij - kj.p * self.grad_rev[p] * w_ji;
                    if let Some(av) = &self.av {
                        let x_ij = xi - (self.x0[j] + y.u[j]);
                        let c = 0.5 * (ci + (bulk / kj.rho).sqrt());
                        let rho = 0.5 * (ki.rho + kj.rho);
                        let pi = av.pi::<D>(h, x_ij, y.v[i] - y.v[j], c, rho);
                        let dir = ki.f_inv_t * self.grad[p] - kj.f_inv_t * self.grad_rev[p];
                        viscous -= dir * (0.5 * self.mass[j] * pi);
                    }
                }
                *a = force * (1.0 / self.mass[i]) + viscous;
                *dissipation = -self.mass[i] * D::dot(viscous, y.v[i]);
            });
    }

    fn first_inadmissible(&self) -> Option<BlowUp> {
        let det = |k: &Kinematics<D>| D::det(k.f);
        let i = self
            .kin
            .par_iter()
            .position_first(|k| det(k).is_nan() || det(k) <= 0.0)?;
        Some(BlowUp::at::<D>(&self.x0, i, "det F", det(&self.kin[i])))
    }
}

impl<D: Dim> OdeSystem for Potential<D> {
    type State = TlState<D>;
    type Error = BlowUp;

    fn rates(&mut self, _t: f64, y: &TlState<D>, d: &mut TlState<D>) -> Result<(), BlowUp> {
        self.stresses(y);
        if let Some(b) = self.first_inadmissible() {
            return Err(b);
        }
        let mut dissipation = std::mem::take(&mut self.dissipation);
        self.accelerations(y, &mut d.v, &mut dissipation);
        self.dissipation = dissipation;
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

    /// The interactions' work before the step (the contact forces of seed 000 §5.8).
    fn begin_step(&mut self, t: f64, dt: f64, y: &TlState<D>) {
        self.boundary.begin_step(t, dt);
        self.interactions.begin_step(t, dt, &self.x0, &y.u, &y.v);
    }
}

impl<D: Dim> Method<D> for Potential<D> {
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
        &self.x0
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
        self.each_f(&y.u)
    }

    fn cauchy_stress(&self, y: &TlState<D>) -> Vec<[[f64; 3]; 3]> {
        let f = self.each_f(&y.u);
        tl::stress_fields::<D>(&self.material, &f, &[], &[], &self.energy_weight).0
    }

    /// Σ_i w_i ψ(F_i): the energy the force is minus the gradient of (w_i = V_i for the
    /// consistent force; 1 for the reference code's, Π/V on a uniform lattice).
    fn strain_energy(&self, y: &TlState<D>) -> f64 {
        let f = self.each_f(&y.u);
        tl::stress_fields::<D>(&self.material, &f, &[], &[], &self.energy_weight).1
    }

    fn snapshot<'a>(&'a self, y: &TlState<D>) -> Snapshot<'a, D> {
        let f = self.each_f(&y.u);
        let (x0, mass, body) = (&self.x0, &self.mass, &self.body);
        tl::snapshot(
            &self.material,
            x0,
            mass,
            body,
            &self.energy_weight,
            y.clone(),
            f,
        )
    }

    /// c_p + max|v|, with c_p scaled by the reference code's stiffness factor 1/V (in SI
    /// units, the smallest volume's) for its force.
    fn max_signal_speed(&self, y: &TlState<D>) -> f64 {
        let vmax =
            y.v.par_iter()
                .map(|&v| D::norm2(v))
                .reduce(|| 0.0, f64::max)
                .sqrt();
        let scale = match self.force {
            PotentialForce::Consistent => 1.0,
            PotentialForce::ReferenceCode => unit_weight_wave_speed_scale(&self.vol),
        };
        self.material.p_wave_speed() * scale + vmax
    }

    fn boundary_work(&self) -> &BoundaryWork {
        &self.boundary_work
    }

    fn dissipation_power(&self) -> f64 {
        self.dissipation.iter().sum()
    }

    fn pairs(&self) -> usize {
        self.csr.pair_count()
    }

    /// Pass 1 reads u and V and writes the kinematics records (F, P, F⁻ᵀ, ρ); the det F
    /// check reads the records; pass 2 reads the records, X, u, v, V and m and writes a
    /// and the dissipation; the last pass copies v into u̇. Pass 1 reads the ids and
    /// ∇0W̃_ij of every pair, pass 2 the ids, ∇0W̃_ij and ∇0W̃_ji. Neither the force nor
    /// the viscosity changes the bytes (X_i and u_i are read with or without it).
    fn traffic(&self) -> Option<Traffic> {
        let (Sizes { v, f, id, .. }, k) = (Sizes::of::<D>(), size_of::<Kinematics<D>>());
        let pass_1 = v + f + k;
        let pass_2 = k + 4 * v + 3 * f;
        let pair = id + v;
        Some(Traffic {
            per_particle: (pass_1 + k + pass_2 + 2 * v) as f64,
            per_pair: (2 * pair + v) as f64,
            state: (2 * v) as f64,
            velocity: v as f64,
        })
    }

    fn check_finite(&self, y: &TlState<D>) -> Result<(), BlowUp> {
        tl::check_state(&self.x0, y)
    }
}
