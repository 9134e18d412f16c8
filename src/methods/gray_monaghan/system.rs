//! Gray–Monaghan stress-corrected updated-Lagrangian SPH on the CPU (seed 000 §5.1,
//! Algorithm 1, eqs 103–105 and 118–127).
//!
//! The neighbour lists are rebuilt from the current positions at every rate evaluation
//! ([`Rebuild::EveryStage`]), per body when the case has contact. The momentum equation
//! (eq 118) uses the plain, antisymmetric kernel gradient ∇W_ij, so the pair forces
//! (stress, artificial stress and artificial viscosity) conserve linear momentum; the
//! case's correction (`none`, the paper's, or `randles-libersky`) acts on the velocity
//! gradient L_i of eq 105, which feeds ρ̇, Ṡ and Ḟ. The state stores the displacement
//! u = x − X, the velocity v, the density ρ, the deviatoric stress S and the deformation
//! gradient F, integrated by Ḟ = L F for the outputs only.

use super::{ArtificialStress, GrayMonaghanSpec};
use crate::boundary::Boundary;
use crate::correction::CorrectionKind;
use crate::integrate::OdeSystem;
use crate::interaction::Interactions;
use crate::kernel::Kernel;
use crate::material::Material;
use crate::methods::shared::{BlowUp, MIN_CHUNK, Method, check_motion, particle_state};
use crate::methods::tlsph::ArtificialViscosity;
use crate::methods::tlsph::system::stress_fields;
use crate::methods::{MethodFamily, MethodSpec, not_run_by};
use crate::neighbour::{Csr, Neighbours};
use crate::observe::Snapshot;
use crate::plasticity::{symmetric_eigen, to_mat3};
use crate::reference::Reference;
use crate::scene::{Case, CaseError};
use crate::tensor::Dim;
use rayon::prelude::*;

/// Integrated state of an updated-Lagrangian SPH method.
#[derive(Clone, Debug)]
pub struct UlState<D: Dim> {
    /// Displacement u = x − X.
    pub u: Vec<D::V>,
    pub v: Vec<D::V>,
    /// Density ρ (eq 104).
    pub rho: Vec<f64>,
    /// Deviatoric Cauchy stress S (Jaumann rate, seed 000 §2.2).
    pub s: Vec<D::T>,
    /// Deformation gradient F, integrated by Ḟ = L F (outputs only).
    pub f: Vec<D::T>,
}

particle_state!(UlState { rho, s, f });

/// Per-particle quantities of one rate evaluation (Algorithm 1 steps 1–3).
#[derive(Clone, Copy, Debug)]
struct Particle<D: Dim> {
    /// Current position x = X + u.
    x: D::V,
    /// σ_i/ρ_i² with σ = S − p I.
    sigma_rho2: D::T,
    /// Artificial stress R_i (eqs 119–125); zero without it.
    r: D::T,
    /// V_i = m_i/ρ_i.
    vol: f64,
    /// Sound speed c_i = sqrt(K/ρ_i).
    c: f64,
    /// A_i⁻ᵀ of the Randles–Libersky correction of L_i; I without it.
    a_inv_t: D::T,
    /// det A_i (1 without the correction).
    det_a: f64,
}

/// The artificial stress R of a particle with Cauchy stress σ and density ρ (eqs
/// 119–125, with the errata of seed 000 §8): R = Σ_k R̄_k n_k ⊗ n_k over the principal
/// stresses σ̄_k with directions n_k, where R̄_k = −ε σ̄_k/ρ² for σ̄_k > 0 (tension) and 0
/// otherwise. In 2D n_1 = (c, s), n_2 = (−s, c) with θ of tan 2θ = 2σ_xy/(σ_xx − σ_yy)
/// (eq 119) in closed form; in 3D the directions are the Jacobi eigenvectors of σ.
pub fn artificial_stress<D: Dim>(sigma: D::T, rho: f64, epsilon: f64) -> D::T {
    let (values, directions) = principal_stresses::<D>(sigma);
    let mut r = D::zero_t();
    for k in 0..D::N {
        if values[k] > 0.0 {
            let n = directions[k];
            r += D::outer(n, n) * (-epsilon * values[k] / (rho * rho)); // eq 122
        }
    }
    r
}

/// Principal stresses σ̄_k and their unit directions n_k (the first D::N entries).
pub fn principal_stresses<D: Dim>(sigma: D::T) -> ([f64; 3], [D::V; 3]) {
    if D::N == 2 {
        let (sxx, syy, sxy) = (
            D::entry(sigma, 0, 0),
            D::entry(sigma, 1, 1),
            D::entry(sigma, 0, 1),
        );
        // eq 119 without trigonometry: cos 2θ and sin 2θ from d = sqrt((σ_xx − σ_yy)² + 4σ_xy²);
        // θ = 0 for an isotropic stress (d = 0), as atan2(0, 0) = 0.
        let d = ((sxx - syy).powi(2) + 4.0 * sxy * sxy).sqrt();
        let (c, s) = if d == 0.0 {
            (1.0, 0.0)
        } else {
            let (cos2, sin2) = ((sxx - syy) / d, 2.0 * sxy / d);
            let s = ((1.0 - cos2) / 2.0).max(0.0).sqrt();
            (
                ((1.0 + cos2) / 2.0).max(0.0).sqrt(),
                if sin2 < 0.0 { -s } else { s },
            )
        };
        let bar_xx = c * c * sxx + 2.0 * c * s * sxy + s * s * syy; // eq 120
        let bar_yy = s * s * sxx - 2.0 * c * s * sxy + c * c * syy; // eq 121 (erratum: −2csσ_xy)
        let n1 = D::from_slice(&[c, s]);
        let n2 = D::from_slice(&[-s, c]);
        ([bar_xx, bar_yy, 0.0], [n1, n2, D::zero()])
    } else {
        let (values, vectors) = symmetric_eigen(to_mat3::<D>(sigma, 0.0));
        let n = |k: usize| D::from_slice(&vectors.col(k).to_array());
        (values.to_array(), [n(0), n(1), n(2)])
    }
}

/// The Gray–Monaghan system on the CPU (f64, rayon).
pub struct GrayMonaghan<D: Dim> {
    x0: Vec<D::V>,
    /// Reference volumes V0 (the strain energy is per reference volume).
    vol0: Vec<f64>,
    mass: Vec<f64>,
    body: Vec<u32>,
    v0: Vec<D::V>,
    boundary: Boundary<D>,
    material: Material,
    kernel: Kernel,
    correction: CorrectionKind,
    av: Option<ArtificialViscosity>,
    /// The artificial stress with W(Δp), Δp the particle spacing (eq 118's f_ij = W_ij/W(Δp)).
    stress: Option<(ArtificialStress, f64)>,
    xsph: Option<f64>,
    neighbours: Neighbours,
    /// Current positions, rebuilt at every rate evaluation.
    x: Vec<D::V>,
    particles: Vec<Particle<D>>,
    interactions: Interactions<D>,
    power: f64,
}

impl<D: Dim> GrayMonaghan<D> {
    /// The method on the reference configuration of a case: the neighbour lists of the
    /// reference positions (per body with contact), rebuilt at every rate evaluation.
    pub fn new(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        let MethodSpec::GrayMonaghanSph(spec) = &case.method.spec else {
            return Err(not_run_by(case, "GrayMonaghan"));
        };
        let neighbours =
            reference.neighbour_lists(GrayMonaghanSpec::NEIGHBOURS, case.contact.is_some());
        let Reference {
            x0,
            vol,
            mass,
            body,
            v0,
            boundary,
            material,
            kernel,
            ..
        } = reference;
        let interactions = Interactions::build(case, &x0, &body, || neighbours.lists().clone())?;
        let n = x0.len();
        let still = Particle {
            x: D::zero(),
            sigma_rho2: D::zero_t(),
            r: D::zero_t(),
            vol: 0.0,
            c: 0.0,
            a_inv_t: D::identity(),
            det_a: 1.0,
        };
        Ok(Self {
            x: x0.clone(),
            x0,
            vol0: vol,
            mass,
            body,
            v0,
            boundary,
            material,
            kernel,
            correction: case.method.correction,
            av: spec.artificial_viscosity,
            stress: spec.artificial_stress.map(|s| (s, kernel.w(case.spacing))),
            xsph: spec.xsph,
            neighbours,
            particles: vec![still; n],
            interactions,
            power: 0.0,
        })
    }

    /// The current neighbour lists (those of the last rate evaluation).
    pub fn neighbours(&self) -> &Csr {
        self.neighbours.lists()
    }

    /// Steps 1–3: current positions and neighbours, then per particle V, σ/ρ², R, c and
    /// the correction of L. The first particle with ρ ≤ 0 or a singular correction fails.
    fn particles(&mut self, y: &UlState<D>) -> Result<(), BlowUp> {
        self.x
            .par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(&self.x0)
            .zip(&y.u)
            .for_each(|((x, &x0), &u)| *x = x0 + u);
        self.neighbours.update::<D>(&self.x);
        let mut particles = std::mem::take(&mut self.particles);
        particles
            .par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(i, p)| *p = self.particle(i, y));
        self.particles = particles;
        if let Some(i) = y
            .rho
            .par_iter()
            .position_first(|&rho| rho.is_nan() || rho <= 0.0)
        {
            return Err(BlowUp::at::<D>(&self.x0, i, "density", y.rho[i]));
        }
        if let Some(i) = self
            .particles
            .par_iter()
            .position_first(|p| p.det_a.is_nan() || p.det_a.abs() <= 1e-10)
        {
            return Err(BlowUp::at::<D>(
                &self.x0,
                i,
                "det A (Randles–Libersky)",
                self.particles[i].det_a,
            ));
        }
        Ok(())
    }

    fn particle(&self, i: usize, y: &UlState<D>) -> Particle<D> {
        let rho = y.rho[i];
        let sigma = y.s[i] - D::identity() * self.material.pressure(rho); // σ = S − pI
        let (a_inv_t, det_a) = match self.correction {
            CorrectionKind::RandlesLibersky => {
                let a = self.correction_matrix(i, &y.rho);
                (D::transpose(D::inverse(a)), D::det(a))
            }
            _ => (D::identity(), 1.0),
        };
        Particle {
            x: self.x[i],
            sigma_rho2: sigma * (1.0 / (rho * rho)),
            r: self.stress.map_or(D::zero_t(), |(s, _)| {
                artificial_stress::<D>(sigma, rho, s.epsilon)
            }),
            vol: self.mass[i] / rho,
            c: (self.material.bulk / rho).sqrt(),
            a_inv_t,
            det_a,
        }
    }

    /// A_i = Σ_j V_j (x_j − x_i) ⊗ ∇W_ij on the current positions (seed 000 §1.3).
    fn correction_matrix(&self, i: usize, rho: &[f64]) -> D::T {
        let csr = self.neighbours.lists();
        let mut a = D::zero_t();
        for &j in csr.neighbours(i) {
            let j = j as usize;
            let x_ij = self.x[i] - self.x[j];
            a += D::outer(-x_ij, self.kernel.grad::<D>(x_ij)) * (self.mass[j] / rho[j]);
        }
        a
    }

    /// Steps 4–11 for particle i: (ẋ_i, v̇_i, ρ̇_i, Ṡ_i, Ḟ_i) before contact and BCs.
    fn rates_of(&self, i: usize, y: &UlState<D>) -> (D::V, D::V, f64, D::T, D::T) {
        let csr = self.neighbours.lists();
        let h = self.kernel.h;
        let pi = self.particles[i];
        let (vi, rho_i) = (y.v[i], y.rho[i]);
        let mut l = D::zero_t();
        let mut a = D::zero();
        let mut xsph = D::zero();
        for &j in csr.neighbours(i) {
            let j = j as usize;
            let pj = self.particles[j];
            let x_ij = pi.x - pj.x;
            let r = D::norm2(x_ij).sqrt();
            let grad = self.kernel.grad::<D>(x_ij);
            let v_ji = y.v[j] - vi;
            l += D::outer(v_ji, pi.a_inv_t * grad) * pj.vol; // eq 105
            let mut t = pi.sigma_rho2 + pj.sigma_rho2;
            if let Some((s, w_dp)) = self.stress {
                t += (pi.r + pj.r) * (self.kernel.w(r) / w_dp).powf(s.n); // eq 118
            }
            a += t * grad * self.mass[j];
            let rho_bar = 0.5 * (rho_i + y.rho[j]);
            if let Some(av) = &self.av {
                let vx = -D::dot(v_ji, x_ij);
                if vx < 0.0 {
                    // Monaghan viscosity for approaching pairs (seed 000 §3.1 step 6).
                    let mu = h * vx / (r * r + av.eta * av.eta * h * h);
                    let c = 0.5 * (pi.c + pj.c);
                    let pi_ij = (-av.alpha * c * mu + av.beta * mu * mu) / rho_bar;
                    a -= grad * (self.mass[j] * pi_ij);
                }
            }
            if self.xsph.is_some() {
                xsph += v_ji * (self.mass[j] / rho_bar * self.kernel.w(r)); // eq 127
            }
        }
        let x_dot = vi + xsph * self.xsph.unwrap_or(0.0);
        let rho_dot = -rho_i * D::trace(l); // eq 104
        let s_dot = self.material.jaumann_rate::<D>(y.s[i], l);
        (x_dot, a, rho_dot, s_dot, l * y.f[i])
    }

    /// Constrained particles move with their prescribed velocity: the XSPH term leaves
    /// their constrained components of ẋ.
    fn constrain_drift(&self, u_dot: &mut [D::V], v: &[D::V]) {
        for &(i, mask) in &self.boundary.constrained {
            let i = i as usize;
            let (mut x_dot, vi) = (D::to3(u_dot[i]), D::to3(v[i]));
            for k in 0..D::N {
                if mask & (1 << k) != 0 {
                    x_dot[k] = vi[k];
                }
            }
            u_dot[i] = D::from_slice(&x_dot[..D::N]);
        }
    }
}

impl<D: Dim> OdeSystem for GrayMonaghan<D> {
    type State = UlState<D>;
    type Error = BlowUp;

    fn rates(&mut self, _t: f64, y: &UlState<D>, d: &mut UlState<D>) -> Result<(), BlowUp> {
        self.particles(y)?;
        let this = &*self;
        d.u.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(d.v.par_iter_mut())
            .zip(d.rho.par_iter_mut())
            .zip(d.s.par_iter_mut())
            .zip(d.f.par_iter_mut())
            .enumerate()
            .for_each(|(i, ((((u_dot, v_dot), rho_dot), s_dot), f_dot))| {
                (*u_dot, *v_dot, *rho_dot, *s_dot, *f_dot) = this.rates_of(i, y);
            });
        self.constrain_drift(&mut d.u, &y.v);
        let interaction_power = self.interactions.accelerate(&y.v, &self.mass, &mut d.v);
        self.power = self.boundary.apply(&mut d.v, &y.v, &self.mass)
            + self.boundary.external_power(&y.v, &self.mass)
            + interaction_power;
        Ok(())
    }

    /// The interactions' work before the step (the contact forces of seed 000 §5.8).
    fn begin_step(&mut self, t: f64, dt: f64, y: &UlState<D>) {
        self.interactions.begin_step(t, dt, &self.x0, &y.u, &y.v);
    }
}

impl<D: Dim> Method<D> for GrayMonaghan<D> {
    fn build(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        Self::new(case, reference)
    }

    fn initial_state(&self) -> UlState<D> {
        let n = self.x0.len();
        UlState {
            u: vec![D::zero(); n],
            v: self.v0.clone(),
            rho: vec![self.material.rho0; n],
            s: vec![D::zero_t(); n],
            f: vec![D::identity(); n],
        }
    }

    fn displacement<'a>(&self, y: &'a UlState<D>) -> &'a [D::V] {
        &y.u
    }

    fn velocity<'a>(&self, y: &'a UlState<D>) -> &'a [D::V] {
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

    fn deformation_gradient(&self, y: &UlState<D>) -> Vec<D::T> {
        y.f.clone()
    }

    fn cauchy_stress(&self, y: &UlState<D>) -> Vec<[[f64; 3]; 3]> {
        stress_fields::<D>(&self.material, &y.f, &y.s, &y.rho, &self.vol0).0
    }

    fn strain_energy(&self, y: &UlState<D>) -> f64 {
        stress_fields::<D>(&self.material, &y.f, &y.s, &y.rho, &self.vol0).1
    }

    fn snapshot<'a>(&'a self, y: &UlState<D>) -> Snapshot<'a, D> {
        let (sigma, strain_energy) =
            stress_fields::<D>(&self.material, &y.f, &y.s, &y.rho, &self.vol0);
        Snapshot {
            x0: &self.x0,
            mass: &self.mass,
            body: &self.body,
            u: y.u.clone(),
            v: y.v.clone(),
            f: y.f.clone(),
            sigma,
            strain_energy,
            extra: Vec::new(),
        }
    }

    fn max_signal_speed(&self, y: &UlState<D>) -> f64 {
        let vmax =
            y.v.par_iter()
                .map(|&v| D::norm2(v))
                .reduce(|| 0.0, f64::max)
                .sqrt();
        self.material.p_wave_speed() + vmax
    }

    fn boundary_power(&self) -> f64 {
        self.power
    }

    fn check_finite(&self, y: &UlState<D>) -> Result<(), BlowUp> {
        check_motion::<D>(&self.x0, &y.u, &y.v)?;
        let fail =
            |i: usize, quantity: &str, value: f64| BlowUp::at::<D>(&self.x0, i, quantity, value);
        if let Some(i) = y.rho.par_iter().position_first(|r| !r.is_finite()) {
            return Err(fail(i, "density", y.rho[i]));
        }
        if let Some(i) = y.s.par_iter().position_first(|&s| !D::is_finite_t(s)) {
            return Err(fail(
                i,
                "deviatoric stress |S|",
                D::ddot(y.s[i], y.s[i]).sqrt(),
            ));
        }
        if let Some(i) = y.f.par_iter().position_first(|&f| !D::is_finite_t(f)) {
            return Err(fail(
                i,
                "deformation gradient |F|",
                D::ddot(y.f[i], y.f[i]).sqrt(),
            ));
        }
        Ok(())
    }
}
