//! Corotated total-Lagrangian SPH (after Becker, Ihmsen and Teschner; seed 000 §5.5,
//! eqs 149–155).
//!
//! Every rate evaluation finds each particle's rotation R_i by shape matching (the polar
//! factor of A_i = Σ_j m_j W_ij (x_j − x_i) ⊗ (X_j − X_i), eq 151), measures the
//! displacement gradient in the rotated frame, F̂_i = I + Σ_j V_j [R_iᵀ x_ji − X_ji] ⊗
//! ∇0W_ij (eqs 152–153), evaluates the stress P̂(F̂) of a state model and rotates each
//! side's stress back with its own rotation on its own gradient, R_i P̂_i ∇0W_ij −
//! R_j P̂_j ∇0W_ji (`force = "variational"`, the default), or the pair's stresses with
//! ½(R_i + R_j) on i's gradient (`"reference-code"`: eq 155 as the reference code writes
//! it). The state is u = x − X and v.

use super::{CorotatedForce, CorotatedSpec};
use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::parallel::MIN_CHUNK;
use crate::core::sum::par_sum;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, Sizes, Traffic};
use crate::methods::cores::tl::{
    Fields, ReferencePairs, TlCore, TlScheme, TlSph, TlState, ViscousPairs, viscous_pair_pass,
};
use crate::physics::material::Material;
use crate::physics::viscosity::ArtificialViscosity;
use crate::reference::Reference;
use rayon::prelude::*;

/// Most iterations of the 3D polar decomposition; scaled Newton converges in under ten
/// for condition numbers up to 1e16.
const POLAR_ITERATIONS: usize = 50;

/// The rotation R of the polar decomposition A = R U, U symmetric positive definite.
///
/// 2D: the closed form of seed 000 §3.5 step 3 without trigonometry, cos θ and sin θ
/// from (A_xx + A_yy, A_yx − A_xy) (the rotation closest to A, also for det A ≤ 0).
/// 3D: Newton's iteration R ← ½(γR + R⁻ᵀ/γ) with Higham's scaling
/// γ = (|R⁻¹|/|R|)^½, which converges to the polar factor of an invertible A; det A ≤ 0
/// (an inverted neighbourhood) has no proper rotation as its factor.
/// None when A has no such factor (singular, inverted in 3D, or not converged).
pub fn rotation<D: Dim>(a: D::T) -> Option<D::T> {
    if D::N == 2 {
        let (c, s) = (
            D::entry(a, 0, 0) + D::entry(a, 1, 1),
            D::entry(a, 1, 0) - D::entry(a, 0, 1),
        );
        let n = c.hypot(s);
        if !(n > 0.0 && n.is_finite()) {
            return None;
        }
        let e0 = D::from_slice(&[1.0, 0.0, 0.0]);
        let e1 = D::from_slice(&[0.0, 1.0, 0.0]);
        let skew = D::outer(e1, e0) - D::outer(e0, e1);
        return Some(D::identity() * (c / n) + skew * (s / n));
    }
    let det = D::det(a);
    if !(det > 0.0 && det.is_finite()) {
        return None;
    }
    let mut r = a;
    for _ in 0..POLAR_ITERATIONS {
        let r_inv_t = D::transpose(D::inverse(r));
        let gamma = (D::ddot(r_inv_t, r_inv_t) / D::ddot(r, r)).sqrt().sqrt();
        let next = (r * gamma + r_inv_t * (1.0 / gamma)) * 0.5;
        let step = next - r;
        r = next;
        // |ΔR| of a few ulps of O(1) entries: converged.
        if D::ddot(step, step) <= 1e-28 {
            return Some(r);
        }
    }
    None
}

/// Per-particle quantities of one rate evaluation.
#[derive(Clone, Copy, Debug)]
struct Kinematics<D: Dim> {
    /// Shape-matching rotation R_i (eq 151); zero when A_i has no polar factor.
    r: D::T,
    /// Corotated deformation gradient F̂_i (eq 153).
    f_hat: D::T,
    /// Stress P̂(F̂) of the material in the rotated frame.
    p_hat: D::T,
    /// R F̂⁻ᵀ: the push-forward of reference gradients (artificial viscosity).
    push: D::T,
    /// Current density ρ0/det F̂ (artificial viscosity).
    rho: f64,
}

/// The corotated TLSPH system on the CPU (f64, rayon).
pub type Corotated<D> = TlSph<D, CorotatedScheme<D>>;

/// The shape matching, stress pass and pair force of corotated TLSPH.
pub struct CorotatedScheme<D: Dim> {
    csr: Csr,
    /// Reference gradients ∇0W_ij (the paper's: uncorrected), one per CSR pair.
    grad: Vec<D::V>,
    /// ∇0W_ji for every pair (i, j), in CSR order: the variational force only.
    grad_rev: Option<Vec<D::V>>,
    /// Shape-matching weights m_j W(|X_ij|) (eq 151), one per CSR pair.
    shape: Vec<f64>,
    av: Option<ArtificialViscosity>,
    kin: Vec<Kinematics<D>>,
}

impl<D: Dim> CorotatedScheme<D> {
    /// R_i, F̂_i, P̂_i, R_i F̂_i⁻ᵀ and ρ0/det F̂_i of particle i at displacements u.
    fn kinematics_of(&self, core: &TlCore<D>, i: usize, u: &[D::V]) -> Kinematics<D> {
        let x0 = &core.x0;
        let xi = core.x(i, u);
        let mut a = D::zero_t();
        for p in self.csr.range(i) {
            let j = self.csr.ids[p] as usize;
            a += D::outer(x0[j] + u[j] - xi, x0[j] - x0[i]) * self.shape[p];
        }
        let Some(r) = rotation::<D>(a) else {
            return Kinematics {
                r: D::zero_t(),
                f_hat: D::zero_t(),
                p_hat: D::zero_t(),
                push: D::zero_t(),
                rho: f64::NAN,
            };
        };
        let r_t = D::transpose(r);
        let mut h = D::zero_t();
        for p in self.csr.range(i) {
            let j = self.csr.ids[p] as usize;
            // û_ij = R_iᵀ (x_j − x_i) − (X_j − X_i) (eq 152).
            let u_hat = r_t * (x0[j] + u[j] - xi) - (x0[j] - x0[i]);
            h += D::outer(u_hat, self.grad[p]) * core.vol[j];
        }
        let f_hat = D::identity() + h;
        Kinematics {
            r,
            f_hat,
            p_hat: core.material.pk1::<D>(f_hat),
            push: r * D::transpose(D::inverse(f_hat)),
            rho: core.material.rho0 / D::det(f_hat),
        }
    }

    fn each_kinematics(&self, core: &TlCore<D>, u: &[D::V]) -> Vec<Kinematics<D>> {
        (0..u.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|i| self.kinematics_of(core, i, u))
            .collect()
    }

    fn first_inadmissible(&self, core: &TlCore<D>) -> Option<BlowUp> {
        let det = |k: &Kinematics<D>| D::det(k.f_hat);
        let bad = |k: &Kinematics<D>| D::det(k.r).is_nan() || D::det(k.r) <= 0.0;
        // A rank's own particles: its outer ghosts' F lack neighbours.
        let inadmissible = |k: &Kinematics<D>| bad(k) || det(k).is_nan() || det(k) <= 0.0;
        let i = (self.kin.par_iter().zip(&core.counted))
            .position_first(|(k, &counted)| counted && inadmissible(k))?;
        let k = &self.kin[i];
        Some(if bad(k) {
            let quantity = "det R (shape matching: A_i has no rotation as its polar factor)";
            core.blow_up(i, quantity, D::det(k.r))
        } else {
            core.blow_up(i, "det F̂", det(k))
        })
    }
}

impl<D: Dim> Corotated<D> {
    /// Shape-matching rotations R_i at state y (zero where A_i has no polar factor).
    pub fn rotations(&self, y: &TlState<D>) -> Vec<D::T> {
        let kin = self.scheme.each_kinematics(&self.core, &y.u);
        kin.iter().map(|k| k.r).collect()
    }

    /// Corotated deformation gradients F̂_i at state y.
    pub fn corotated_gradients(&self, y: &TlState<D>) -> Vec<D::T> {
        let kin = self.scheme.each_kinematics(&self.core, &y.u);
        kin.iter().map(|k| k.f_hat).collect()
    }
}

/// The outputs of rotations R_i and corotated gradients F̂_i: F = R F̂, the Cauchy stress
/// σ = R (P̂ F̂ᵀ/det F̂) Rᵀ (2D: with σ_zz of F̂) and the strain energy Σ V ψ(F̂). Shared by
/// the CPU system and the GPU engine (which reads R and F̂ back).
pub fn outputs<D: Dim>(mat: &Material, vol: &[f64], r: &[D::T], f_hat: &[D::T]) -> Fields<D> {
    let f = r.iter().zip(f_hat).map(|(&r, &f_hat)| r * f_hat).collect();
    let sigma = r
        .par_iter()
        .zip(f_hat)
        .map(|(&r, &f_hat)| {
            let p_hat = mat.pk1::<D>(f_hat);
            let local = p_hat * D::transpose(f_hat) * (1.0 / D::det(f_hat));
            let mut out = D::to3x3(r * local * D::transpose(r));
            if D::N == 2 {
                out[2][2] = mat.sigma_zz::<D>(f_hat, D::zero_t(), mat.rho0);
            }
            out
        })
        .collect();
    let strain_energy = par_sum(f_hat.len(), |a| {
        vol[a] * mat.energy_density::<D>(f_hat[a], D::zero_t(), mat.rho0)
    });
    Fields {
        f,
        sigma,
        strain_energy,
    }
}

impl<D: Dim> ViscousPairs<D> for CorotatedScheme<D> {
    fn viscosity(&self) -> Option<&ArtificialViscosity> {
        self.av.as_ref()
    }

    fn rho(&self, i: usize) -> f64 {
        self.kin[i].rho
    }

    /// V_j (R_i P̂_i ∇0W_ij − R_j P̂_j ∇0W_ji), or V_j ½(R_i + R_j)(P̂_i + P̂_j) ∇0W_ij.
    fn stress(&self, core: &TlCore<D>, i: usize, j: usize, p: usize) -> D::V {
        let (ki, kj, g, vol) = (self.kin[i], self.kin[j], self.grad[p], &core.vol);
        match &self.grad_rev {
            Some(rev) => (ki.r * (ki.p_hat * g) - kj.r * (kj.p_hat * rev[p])) * vol[j],
            None => (ki.r + kj.r) * ((ki.p_hat + kj.p_hat) * g) * (0.5 * vol[j]),
        }
    }

    /// (R_i F̂_i⁻ᵀ + R_j F̂_j⁻ᵀ) ∇0W_ij.
    fn viscous_direction(&self, i: usize, j: usize, p: usize) -> D::V {
        (self.kin[i].push + self.kin[j].push) * self.grad[p]
    }

    /// Σ/ρ0.
    fn acceleration(&self, core: &TlCore<D>, _i: usize, stress: D::V) -> D::V {
        stress * (1.0 / core.material.rho0)
    }
}

impl<D: Dim> TlScheme<D> for CorotatedScheme<D> {
    /// Builds neighbours, reference gradients and shape-matching weights on the reference
    /// configuration.
    type Spec = CorotatedSpec;

    fn new(case: &Case, spec: &CorotatedSpec, reference: &Reference<D>) -> Result<Self, CaseError> {
        let CorotatedSpec {
            artificial_viscosity,
            force,
        } = spec;
        let pairs = ReferencePairs::new(case, reference)?;
        let grad_rev = match force {
            CorotatedForce::ReferenceCode => None,
            CorotatedForce::Variational => Some(pairs.reverse(case)?),
        };
        let ReferencePairs { csr, grad } = pairs;
        let (m, x, kernel) = (&reference.mass, &reference.x0, &reference.kernel);
        let shape = (0..x.len())
            .into_par_iter()
            .flat_map_iter(|i| {
                let w = move |j: usize| m[j] * kernel.w(D::norm2(x[j] - x[i]).sqrt());
                csr.neighbours(i).iter().map(move |&j| w(j as usize))
            })
            .collect();
        let identity = Kinematics {
            r: D::identity(),
            f_hat: D::identity(),
            p_hat: D::zero_t(),
            push: D::identity(),
            rho: reference.material.rho0,
        };
        Ok(Self {
            kin: vec![identity; x.len()],
            csr,
            grad,
            grad_rev,
            shape,
            av: *artificial_viscosity,
        })
    }

    fn lists(&self) -> &Csr {
        &self.csr
    }

    /// Pass 1: shape matching and the stress of every particle; det R > 0 and det F̂ > 0.
    fn stresses(
        &mut self,
        core: &TlCore<D>,
        y: &TlState<D>,
        _d: &mut TlState<D>,
    ) -> Option<BlowUp> {
        let mut kin = std::mem::take(&mut self.kin);
        kin.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(i, k)| *k = self.kinematics_of(core, i, &y.u));
        self.kin = kin;
        self.first_inadmissible(core)
    }

    /// Pass 2: a_i = (1/ρ0) Σ_j V_j (R_i P̂_i ∇0W_ij − R_j P̂_j ∇0W_ji) (variational), or
    /// (1/ρ0) Σ_j V_j ½(R_i + R_j)(P̂_i + P̂_j) ∇0W_ij (eqs 154–155 as the reference code
    /// writes them), plus Monaghan viscosity along ½(R_i F̂_i⁻ᵀ + R_j F̂_j⁻ᵀ) ∇0W_ij; then
    /// u̇ = v.
    fn forces(&mut self, core: &mut TlCore<D>, y: &TlState<D>, d: &mut TlState<D>) {
        viscous_pair_pass(self, core, y, d);
    }

    /// F = R F̂: the corotated gradient rotated back to the current configuration.
    fn deformation_gradient(&self, core: &TlCore<D>, y: &TlState<D>) -> Vec<D::T> {
        self.each_kinematics(core, &y.u)
            .iter()
            .map(|k| k.r * k.f_hat)
            .collect()
    }

    /// F = R F̂, the Cauchy stress σ = R (P̂ F̂ᵀ/det F̂) Rᵀ (2D: with σ_zz of F̂) and
    /// Σ V ψ(F̂), the energy of the corotated strains.
    fn snapshot<'a>(&'a self, core: &'a TlCore<D>, y: &TlState<D>) -> Snapshot<'a, D> {
        let kin = self.each_kinematics(core, &y.u);
        let r: Vec<D::T> = kin.iter().map(|k| k.r).collect();
        let f_hat: Vec<D::T> = kin.iter().map(|k| k.f_hat).collect();
        let fields = outputs::<D>(&core.material, &core.energy_weights, &r, &f_hat);
        fields.snapshot(&core.x0, &core.mass, &core.body, y.clone())
    }

    /// Pass 1 reads X, u and V and writes the kinematics records (R, F̂, P̂, R F̂⁻ᵀ, ρ);
    /// the det check reads the records; pass 2 reads the records, X, u, v, V and m and
    /// writes a and the dissipation; the last pass copies v into u̇. Pass 1 reads the
    /// ids, shape-matching weights and ∇0W_ij of every pair, pass 2 the ids and ∇0W_ij
    /// (and ∇0W_ji for the variational force).
    /// The viscosity does not change the bytes (X_i and u_i are read with or without it).
    fn traffic(&self, _core: &TlCore<D>) -> Traffic {
        let (Sizes { v, f, id, .. }, k) = (Sizes::of::<D>(), size_of::<Kinematics<D>>());
        let pass_1 = 2 * v + f + k;
        let pass_2 = k + 4 * v + 3 * f;
        let pair = id + v;
        let reverse = if self.grad_rev.is_some() { v } else { 0 };
        Traffic {
            per_particle: (pass_1 + k + pass_2 + 2 * v) as f64,
            per_pair: (2 * pair + f + reverse) as f64,
            state: (2 * v) as f64,
            velocity: v as f64,
        }
    }
}
