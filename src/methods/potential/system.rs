//! Total-Lagrangian SPH from the elastic potential (seed 000 §5.4, eqs 138–148, App. 9.2).
//!
//! The internal force is minus the gradient of the discrete strain energy
//! Π = Σ_i V_i ψ(F_i) with F_i = I + Σ_j V_j (u_j − u_i) ⊗ ∇0W̃_ij, which gives the
//! symmetrised pair force of eq 148 with the corrected gradient of each side,
//! f_i = Σ_j V_i V_j [P_i ∇0W̃_ij − P_j ∇0W̃_ji], P = ∂ψ/∂F. Each pair's two terms appear
//! with opposite signs in the two rows, so Σ_i f_i = 0 to round-off whatever the
//! correction (seed 000 checklist 13). The state is u = x − X and v: no density or
//! stress is integrated.

use super::{PotentialForce, PotentialSpec};
use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::parallel::MIN_CHUNK;
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, Sizes, Traffic};
use crate::methods::cores::tl::{
    ReferencePairs, TlCore, TlScheme, TlSph, TlState, ViscousPairs, snapshot, viscous_pair_pass,
};
use crate::physics::material::stress_fields;
use crate::physics::viscosity::ArtificialViscosity;
use crate::reference::Reference;
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
pub type Potential<D> = TlSph<D, PotentialScheme<D>>;

/// The stress pass and pair force of TLSPH from the elastic potential.
pub struct PotentialScheme<D: Dim> {
    csr: Csr,
    /// Corrected reference gradients ∇0W̃_ij, one per CSR pair.
    grad: Vec<D::V>,
    /// ∇0W̃_ji (j's correction, evaluated at i) for every pair (i, j), in CSR order.
    grad_rev: Vec<D::V>,
    force: PotentialForce,
    /// The weight of each particle's ψ in the energy the force derives from: V_i for the
    /// consistent force, 1 for the reference code's (whose force is that of Σ_i ψ_i when
    /// the volumes are uniform).
    energy_weight: Vec<f64>,
    av: Option<ArtificialViscosity>,
    kin: Vec<Kinematics<D>>,
}

impl<D: Dim> PotentialScheme<D> {
    /// F_i = I + Σ_j V_j (u_j − u_i) ⊗ ∇0W̃_ij (eq 137).
    fn deformation_gradient_of(&self, vol: &[f64], i: usize, u: &[D::V]) -> D::T {
        let mut h = D::zero_t();
        for p in self.csr.range(i) {
            let j = self.csr.ids[p] as usize;
            h += D::outer(u[j] - u[i], self.grad[p]) * vol[j];
        }
        D::identity() + h
    }

    fn each_f(&self, vol: &[f64], u: &[D::V]) -> Vec<D::T> {
        (0..u.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|i| self.deformation_gradient_of(vol, i, u))
            .collect()
    }

    /// F, P = ∂ψ/∂F, F⁻ᵀ and ρ0/J of every particle.
    fn kinematics(&mut self, core: &TlCore<D>, y: &TlState<D>) {
        let mat = core.material;
        let mut kin = std::mem::take(&mut self.kin);
        kin.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(i, k)| {
                let f = self.deformation_gradient_of(&core.vol, i, &y.u);
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
    fn pair_weights(&self, vol: &[f64], i: usize, j: usize) -> (f64, f64) {
        match self.force {
            PotentialForce::Consistent => {
                let w = vol[i] * vol[j];
                (w, w)
            }
            PotentialForce::ReferenceCode => (vol[i], vol[j]),
        }
    }

    fn first_inadmissible(&self, core: &TlCore<D>) -> Option<BlowUp> {
        let det = |k: &Kinematics<D>| D::det(k.f);
        // A rank's own particles: its outer ghosts' F lack neighbours.
        let i = (self.kin.par_iter().zip(&core.counted))
            .position_first(|(k, &counted)| counted && (det(k).is_nan() || det(k) <= 0.0))?;
        Some(core.blow_up(i, "det F", det(&self.kin[i])))
    }
}

impl<D: Dim> ViscousPairs<D> for PotentialScheme<D> {
    fn viscosity(&self) -> Option<&ArtificialViscosity> {
        self.av.as_ref()
    }

    fn rho(&self, i: usize) -> f64 {
        self.kin[i].rho
    }

    /// w_ij P_i ∇0W̃_ij − w_ji P_j ∇0W̃_ji.
    fn stress(&self, core: &TlCore<D>, i: usize, j: usize, p: usize) -> D::V {
        let (ki, kj) = (self.kin[i], self.kin[j]);
        let (w_ij, w_ji) = self.pair_weights(&core.vol, i, j);
        ki.p * self.grad[p] * w_ij - kj.p * self.grad_rev[p] * w_ji
    }

    /// F_i⁻ᵀ ∇0W̃_ij − F_j⁻ᵀ ∇0W̃_ji.
    fn viscous_direction(&self, i: usize, j: usize, p: usize) -> D::V {
        self.kin[i].f_inv_t * self.grad[p] - self.kin[j].f_inv_t * self.grad_rev[p]
    }

    /// f_i/m_i.
    fn acceleration(&self, core: &TlCore<D>, i: usize, force: D::V) -> D::V {
        force * (1.0 / core.mass[i])
    }
}

impl<D: Dim> TlScheme<D> for PotentialScheme<D> {
    /// Builds neighbours, corrected gradients and their reverses on the reference
    /// configuration.
    type Spec = PotentialSpec;

    fn new(case: &Case, spec: &PotentialSpec, reference: &Reference<D>) -> Result<Self, CaseError> {
        let pairs = ReferencePairs::new(case, reference)?;
        let grad_rev = pairs.reverse(case)?;
        let ReferencePairs { csr, grad } = pairs;
        let (vol, n) = (&reference.vol, reference.x0.len());
        let identity = Kinematics {
            f: D::identity(),
            p: D::zero_t(),
            f_inv_t: D::identity(),
            rho: reference.material.rho0,
        };
        // Zero at a rank's ghosts: the energy sums its own particles.
        let energy_weight = (vol.iter().zip(&reference.counted))
            .map(|(&v, &counted)| match (counted, spec.force) {
                (false, _) => 0.0,
                (true, PotentialForce::Consistent) => v,
                (true, PotentialForce::ReferenceCode) => 1.0,
            })
            .collect();
        Ok(Self {
            kin: vec![identity; n],
            csr,
            grad,
            grad_rev,
            force: spec.force,
            energy_weight,
            av: spec.artificial_viscosity,
        })
    }

    fn lists(&self) -> &Csr {
        &self.csr
    }

    /// Pass 1: F, P = ∂ψ/∂F, F⁻ᵀ and ρ0/J of every particle; det F > 0.
    fn stresses(
        &mut self,
        core: &TlCore<D>,
        y: &TlState<D>,
        _d: &mut TlState<D>,
    ) -> Option<BlowUp> {
        self.kinematics(core, y);
        self.first_inadmissible(core)
    }

    /// Pass 2: m_i a_i = Σ_j [w_ij P_i ∇0W̃_ij − w_ji P_j ∇0W̃_ji] (eq 148 symmetrised),
    /// plus Monaghan viscosity along ½(F_i⁻ᵀ ∇0W̃_ij − F_j⁻ᵀ ∇0W̃_ji): the TLSPH direction
    /// F_i⁻ᵀ ∇0W̃_ij made antisymmetric in the pair as the stress term is, so that the
    /// viscosity too keeps Σ m a = 0; then u̇ = v.
    fn forces(&mut self, core: &mut TlCore<D>, y: &TlState<D>, d: &mut TlState<D>) {
        viscous_pair_pass(self, core, y, d);
    }

    fn deformation_gradient(&self, core: &TlCore<D>, y: &TlState<D>) -> Vec<D::T> {
        self.each_f(&core.vol, &y.u)
    }

    fn cauchy_stress(&self, core: &TlCore<D>, y: &TlState<D>) -> Vec<[[f64; 3]; 3]> {
        let f = self.each_f(&core.vol, &y.u);
        stress_fields::<D>(&core.material, &f, &[], &[], &self.energy_weight).0
    }

    /// Σ_i w_i ψ(F_i): the energy the force is minus the gradient of (w_i = V_i for the
    /// consistent force; 1 for the reference code's, Π/V on a uniform lattice).
    fn strain_energy(&self, core: &TlCore<D>, y: &TlState<D>) -> Exact {
        let f = self.each_f(&core.vol, &y.u);
        stress_fields::<D>(&core.material, &f, &[], &[], &self.energy_weight).1
    }

    fn snapshot<'a>(&'a self, core: &'a TlCore<D>, y: &TlState<D>) -> Snapshot<'a, D> {
        let f = self.each_f(&core.vol, &y.u);
        let (x0, mass, body) = (&core.x0, &core.mass, &core.body);
        let weight = &self.energy_weight;
        snapshot(&core.material, (x0, mass, body), weight, y.clone(), f, None)
    }

    /// c_p, scaled by the reference code's stiffness factor 1/V (in SI units, the
    /// smallest volume's) for its force.
    fn wave_speed(&self, core: &TlCore<D>) -> f64 {
        let scale = match self.force {
            PotentialForce::Consistent => 1.0,
            PotentialForce::ReferenceCode => unit_weight_wave_speed_scale(&core.vol),
        };
        core.material.p_wave_speed() * scale
    }

    /// Pass 1 reads u and V and writes the kinematics records (F, P, F⁻ᵀ, ρ); the det F
    /// check reads the records; pass 2 reads the records, X, u, v, V and m and writes a
    /// and the dissipation; the last pass copies v into u̇. Pass 1 reads the ids and
    /// ∇0W̃_ij of every pair, pass 2 the ids, ∇0W̃_ij and ∇0W̃_ji. Neither the force nor
    /// the viscosity changes the bytes (X_i and u_i are read with or without it).
    fn traffic(&self, _core: &TlCore<D>) -> Traffic {
        let (Sizes { v, f, id, .. }, k) = (Sizes::of::<D>(), size_of::<Kinematics<D>>());
        let pass_1 = v + f + k;
        let pass_2 = k + 4 * v + 3 * f;
        let pair = id + v;
        Traffic {
            per_particle: (pass_1 + k + pass_2 + 2 * v) as f64,
            per_pair: (2 * pair + v) as f64,
            state: (2 * v) as f64,
            velocity: v as f64,
        }
    }
}
