//! Total-Lagrangian SPH after Reveles (seed 000 §5.3, eqs 134–137).
//!
//! Neighbours and corrected reference gradients ∇0W̃_ij are computed once on the
//! reference configuration. The state stores the displacement u = x − X (not x), the
//! velocity v and, for the rate-based (hypoelastic) model, the density ρ and the
//! deviatoric stress S.

use super::{ArtificialViscosity, TlsphForce, ViscosityGradient};
use crate::boundary::{Boundary, OnPatches};
use crate::interaction::Interactions;
use crate::methods::shared::{
    BlowUp, BoundaryWork, MIN_CHUNK, Method, Sizes, Traffic, check_motion, particle_state,
    reference_gradients, reverse_gradients,
};
use crate::methods::{MethodSpec, not_run_by};

use crate::integrate::OdeSystem;

use crate::material::Material;
use crate::neighbour::Csr;
use crate::observe::Snapshot;
use crate::reference::Reference;
use crate::scene::{Case, CaseError};
use crate::statics::explicit::AtRest;
use crate::tensor::Dim;
use rayon::prelude::*;
use std::mem::take;

/// Integrated state of TLSPH.
#[derive(Debug)]
pub struct TlState<D: Dim> {
    /// Displacement u = x − X.
    pub u: Vec<D::V>,
    pub v: Vec<D::V>,
    /// Density (rate-based model only; empty otherwise).
    pub rho: Vec<f64>,
    /// Deviatoric Cauchy stress (rate-based model only; empty otherwise).
    pub s: Vec<D::T>,
}

particle_state!(TlState { rho, s });

/// What the pair loop of the acceleration pass reads of each neighbour j, packed in
/// one record (64 bytes in 2D) so that a neighbour costs one gather.
#[derive(Clone, Copy, Debug)]
struct Gathered<D: Dim> {
    /// First Piola–Kirchhoff stress P = J σ F⁻ᵀ.
    p: D::T,
    /// Current position x = X + u.
    x: D::V,
    /// Sound speed c = √(K/ρ).
    c: f64,
    /// Current density (ρ, or ρ0/J for state-based models).
    rho: f64,
}

/// What the acceleration pass reads of particle i alone.
#[derive(Clone, Copy, Debug)]
struct Own<D: Dim> {
    /// Deformation gradient F = I + Σ_j V_j (u_j − u_i) ⊗ ∇0W̃_ij (eq 137).
    f: D::T,
    /// F⁻ᵀ, which pushes reference gradients forward: ∇W = F⁻ᵀ ∇0W.
    f_inv_t: D::T,
}

/// The first particle with a non-finite u, v, ρ or S, as a blow-up.
pub fn check_state<D: Dim>(x0: &[D::V], y: &TlState<D>) -> Result<(), BlowUp> {
    check_motion::<D>(x0, &y.u, &y.v)?;
    let fail = |i: usize, quantity: &str, value: f64| BlowUp::at::<D>(x0, i, quantity, value);
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
    Ok(())
}

/// Cauchy stress (3×3; 2D plane strain fills σ_zz) and strain energy Σ V0 ψ of every
/// particle from F and, for the rate model, S and ρ (empty slices for state models).
/// Shared by the CPU and GPU paths for their outputs.
pub fn stress_fields<D: Dim>(
    mat: &Material,
    f: &[D::T],
    s: &[D::T],
    rho: &[f64],
    vol: &[f64],
) -> (Vec<[[f64; 3]; 3]>, f64) {
    let rate = mat.model.is_rate_based();
    let per_particle: Vec<([[f64; 3]; 3], f64)> = f
        .par_iter()
        .enumerate()
        .map(|(i, &f)| {
            let (s, rho) = if rate {
                (s[i], rho[i])
            } else {
                (D::zero_t(), mat.rho0 / D::det(f))
            };
            let sigma = if rate {
                s - D::identity() * mat.pressure(rho)
            } else {
                mat.pk1::<D>(f) * D::transpose(f) * (1.0 / D::det(f))
            };
            let mut out = D::to3x3(sigma);
            if D::N == 2 {
                out[2][2] = mat.sigma_zz::<D>(f, s, rho);
            }
            let energy_rho = if rate { rho } else { mat.rho0 };
            (out, vol[i] * mat.energy_density::<D>(f, s, energy_rho))
        })
        .collect();
    let energy = per_particle.iter().map(|p| p.1).sum();
    (per_particle.into_iter().map(|p| p.0).collect(), energy)
}

/// A snapshot of state y with deformation gradients f: stresses and strain energy
/// follow from `stress_fields`. Shared by the CPU and GPU paths.
pub fn snapshot<'a, D: Dim>(
    material: &Material,
    x0: &'a [D::V],
    mass: &'a [f64],
    body: &'a [u32],
    vol: &[f64],
    y: TlState<D>,
    f: Vec<D::T>,
) -> Snapshot<'a, D> {
    let (sigma, strain_energy) = stress_fields::<D>(material, &f, &y.s, &y.rho, vol);
    Snapshot {
        x0,
        mass,
        body,
        u: y.u,
        v: y.v,
        f,
        sigma,
        strain_energy,
        extra: Vec::new(),
        cells: &[],
        quadrature: None,
    }
}

/// The stiffness κ_ij = α E V_j W(|X_ij|)/(ρ0 |X_ij|²) of the hourglass control of every
/// pair, in CSR order: the acceleration of i per unit δ_ij ([`hourglass_acceleration`]).
/// m_i κ_ij = α E V_i V_j W/|X_ij|² is symmetric, so the pair forces are equal and
/// opposite.
pub fn hourglass_stiffness<D: Dim>(
    case: &Case,
    alpha: f64,
    x0: &[D::V],
    vol: &[f64],
    csr: &Csr,
) -> Vec<f64> {
    let kernel = &case.kernel(D::N);
    let (e, _) = case.material.youngs_and_poisson();
    let rho0 = case.material.density;
    (0..csr.len())
        .into_par_iter()
        .flat_map_iter(|i| {
            csr.range(i).map(move |p| {
                let j = csr.ids[p] as usize;
                let r0_squared = D::norm2(x0[j] - x0[i]);
                alpha * e * vol[j] * kernel.w(r0_squared.sqrt()) / (rho0 * r0_squared)
            })
        })
        .collect()
}

/// The hourglass control's acceleration of i from its bond to j (Ganzenmüller 2015, the
/// stiffness form of LAMMPS's SMD package): −κ_ij δ_ij e_ij, with the error vector
/// γ_ij = ½(F_i + F_j) X_ij − x_ij = ½(H_i + H_j) X_ij − (u_j − u_i) (H = F − I, which
/// keeps the digits of a small mismatch), e_ij = x_ij/|x_ij| and δ_ij = ½ γ_ij·e_ij. It
/// vanishes when F_i and F_j map the bond exactly, as for every affine motion.
pub fn hourglass_acceleration<D: Dim>(kappa: f64, dx0: D::V, du: D::V, h_sum: D::T) -> D::V {
    let dx = dx0 + du;
    let e = dx * (1.0 / D::norm2(dx).sqrt());
    let gamma = h_sum * dx0 * 0.5 - du;
    e * (-0.5 * kappa * D::dot(gamma, e))
}

/// `Some(i)` when det F_i ≤ 0 or NaN: the particle's F is not admissible.
#[inline]
fn inadmissible<D: Dim>(i: usize, f: D::T) -> Option<usize> {
    let det = D::det(f);
    (det.is_nan() || det <= 0.0).then_some(i)
}

/// Each pair's vector scaled by the neighbour's volume V_j, in CSR order.
fn weighted<D: Dim>(csr: &Csr, vol: &[f64], mut per_pair: Vec<D::V>) -> Vec<D::V> {
    per_pair
        .par_iter_mut()
        .zip(csr.ids.par_iter())
        .for_each(|(g, &j)| *g = *g * vol[j as usize]);
    per_pair
}

/// The TLSPH system on the CPU (f64, rayon).
pub struct Tlsph<D: Dim> {
    x0: Vec<D::V>,
    vol: Vec<f64>,
    mass: Vec<f64>,
    body: Vec<u32>,
    v0: Vec<D::V>,
    /// Initial displacements.
    u0: Vec<D::V>,
    csr: Csr,
    /// Corrected reference gradients weighted by the neighbour's volume, V_j ∇0W̃_ij, one
    /// per CSR pair: every pair sum of the method carries that product.
    grad: Vec<D::V>,
    /// V_j ∇0W̃_ji for every pair (i, j), in CSR order: the variational force only.
    grad_rev: Option<Vec<D::V>>,
    /// Σ_j V_j ∇0W̃_ij of every particle.
    grad_sum: Vec<D::V>,
    /// The hourglass stiffness κ_ij of every pair, in CSR order, with the control on.
    hourglass: Option<Vec<f64>>,
    material: Material,
    av: Option<ArtificialViscosity>,
    /// The direction of the viscous pair force.
    av_gradient: ViscosityGradient,
    h: f64,
    boundary: Boundary<D>,
    interactions: Interactions<D>,
    gathered: Vec<Gathered<D>>,
    own: Vec<Own<D>>,
    /// The power of supports, loads and interactions and the supports' reactions at the
    /// last rate evaluation.
    boundary_work: BoundaryWork,
    /// Each particle's power of the viscosity and against the hourglass control,
    /// [−m a_visc·v, −m a_hg·v], at the last rate evaluation.
    powers: Vec<[f64; 2]>,
}

impl<D: Dim> Tlsph<D> {
    /// Builds neighbours and corrected gradients on the reference configuration.
    pub fn new(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        let MethodSpec::Tlsph(spec) = &case.method.spec else {
            return Err(not_run_by(case, "Tlsph"));
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
        let grad_rev = match spec.force {
            TlsphForce::Reveles => None,
            TlsphForce::Variational => Some(weighted::<D>(
                &csr,
                &vol,
                reverse_gradients::<D>(case, &csr, &grad)?,
            )),
        };
        let grad = weighted::<D>(&csr, &vol, grad);
        let grad_sum = (0..csr.len())
            .into_par_iter()
            .map(|i| csr.range(i).fold(D::zero(), |sum, p| sum + grad[p]))
            .collect();
        let hourglass = spec
            .hourglass
            .map(|alpha| hourglass_stiffness::<D>(case, alpha, &x0, &vol, &csr));
        let interactions =
            Interactions::build(case, &x0, &body, &OnPatches, &mass, || csr.clone())?;
        let at_rest = Gathered {
            p: D::zero_t(),
            x: D::zero(),
            c: 0.0,
            rho: material.rho0,
        };
        let identity = Own {
            f: D::identity(),
            f_inv_t: D::identity(),
        };
        Ok(Self {
            gathered: vec![at_rest; x0.len()],
            own: vec![identity; x0.len()],
            powers: vec![[0.0; 2]; x0.len()],
            x0,
            vol,
            mass,
            body,
            v0,
            u0,
            csr,
            grad,
            grad_rev,
            grad_sum,
            hourglass,
            material,
            av: spec.artificial_viscosity,
            av_gradient: spec.viscosity_gradient,
            h: kernel.h,
            boundary,
            interactions,
            boundary_work: BoundaryWork::default(),
        })
    }

    /// Neighbour lists (reference configuration).
    pub fn neighbours(&self) -> &Csr {
        &self.csr
    }

    /// Reference volumes V0.
    pub fn volume(&self) -> &[f64] {
        &self.vol
    }

    /// Corrected reference gradients ∇0W̃_ij, in CSR order.
    pub fn gradients(&self) -> Vec<D::V> {
        self.grad
            .iter()
            .zip(&self.csr.ids)
            .map(|(&g, &j)| g * (1.0 / self.vol[j as usize]))
            .collect()
    }

    /// Σ_j V_j (f_j − f_i) ⊗ ∇0W̃_ij of K particle fields in one pass over i's
    /// neighbours: their corrected gradients.
    #[inline]
    fn gradients_of<const K: usize>(&self, i: usize, fields: [&[D::V]; K]) -> [D::T; K] {
        let mut g = [D::zero_t(); K];
        let own = fields.map(|f| f[i]);
        for (j, &w) in self.csr.pairs(i, &self.grad) {
            for k in 0..K {
                g[k] += D::outer(fields[k][j] - own[k], w);
            }
        }
        g
    }

    fn blow_up(&self, i: usize, quantity: &str, value: f64) -> BlowUp {
        BlowUp::at::<D>(&self.x0, i, quantity, value)
    }

    /// Pass 1: F, P, current position, density and sound speed per particle; ρ̇ and Ṡ
    /// for the rate model. Returns the first particle with det F ≤ 0 (or NaN).
    fn stresses(&mut self, y: &TlState<D>, d: &mut TlState<D>) -> Option<BlowUp> {
        let mat = self.material;
        let (mut gathered, mut own) = (take(&mut self.gathered), take(&mut self.own));
        let records = gathered.par_iter_mut().zip(own.par_iter_mut());
        let bad = if mat.model.is_rate_based() {
            records
                .zip(d.rho.par_iter_mut().zip(d.s.par_iter_mut()))
                .with_min_len(MIN_CHUNK)
                .enumerate()
                .filter_map(|(i, ((g, o), (rho_dot, s_dot)))| {
                    let [h, f_dot] = self.gradients_of(i, [&y.u, &y.v]); // eqs 136–137
                    let f = D::identity() + h;
                    let r = mat.rate_response::<D>(f, f_dot, y.rho[i], y.s[i]);
                    (*rho_dot, *s_dot) = (r.rho_dot, r.s_dot);
                    *o = Own {
                        f,
                        f_inv_t: r.f_inv_t,
                    };
                    *g = self.gathered(i, y, r.pk1, y.rho[i]);
                    inadmissible::<D>(i, f)
                })
                .min()
        } else {
            records
                .with_min_len(MIN_CHUNK)
                .enumerate()
                .filter_map(|(i, (g, o))| {
                    let [h] = self.gradients_of(i, [&y.u]);
                    let f = D::identity() + h;
                    *o = Own {
                        f,
                        f_inv_t: D::transpose(D::inverse(f)),
                    };
                    *g = self.gathered(i, y, mat.pk1::<D>(f), mat.rho0 / D::det(f));
                    inadmissible::<D>(i, f)
                })
                .min()
        };
        (self.gathered, self.own) = (gathered, own);
        bad.map(|i| self.blow_up(i, "det F", D::det(self.own[i].f)))
    }

    /// The record neighbours gather of particle i, with stress P and density ρ.
    #[inline]
    fn gathered(&self, i: usize, y: &TlState<D>, p: D::T, rho: f64) -> Gathered<D> {
        Gathered {
            p,
            x: self.x0[i] + y.u[i],
            c: (self.material.bulk / rho).sqrt(),
            rho,
        }
    }

    /// Pass 2: a_i = (1/ρ0) Σ_j V_j (P_i + P_j) ∇0W̃_ij (eq 134), or the variational
    /// (1/ρ0) Σ_j V_j (P_i ∇0W̃_ij − P_j ∇0W̃_ji), plus artificial viscosity and the
    /// hourglass control.
    ///
    /// The viscous term acts along the current-configuration gradient F_i⁻ᵀ ∇0W̃_ij, or, with
    /// `viscosity_gradient = "reference"`, along ∇0W̃_ij unmapped as the paper and the
    /// reference code have it; after a quarter turn of rigid rotation that direction points
    /// across the pair and feeds energy in (docs/methods/tlsph.md).
    /// Also writes each particle's powers [−m_i a_visc·v_i, −m_i a_hg·v_i] into `powers`.
    fn accelerations(&self, y: &TlState<D>, d: &mut TlState<D>, powers: &mut [[f64; 2]]) {
        match (self.av.is_some(), self.hourglass.is_some()) {
            (false, false) => self.accelerations_with::<false, false>(y, d, powers),
            (false, true) => self.accelerations_with::<false, true>(y, d, powers),
            (true, false) => self.accelerations_with::<true, false>(y, d, powers),
            (true, true) => self.accelerations_with::<true, true>(y, d, powers),
        }
    }

    /// [`Self::accelerations`] with the viscous and hourglass terms chosen at compile
    /// time, so that the pair loop carries only the terms the case runs.
    fn accelerations_with<const VISCOUS: bool, const HOURGLASS: bool>(
        &self,
        y: &TlState<D>,
        d: &mut TlState<D>,
        powers: &mut [[f64; 2]],
    ) {
        let inv_rho0 = 1.0 / self.material.rho0;
        let rho0 = self.material.rho0;
        let h = self.h;
        let av = self.av;
        let kappa = self.hourglass.as_deref().unwrap_or_default();
        let pushed_forward = self.av_gradient == ViscosityGradient::PushedForward;
        let rev = self.grad_rev.as_deref();
        d.v.par_iter_mut()
            .zip(d.u.par_iter_mut())
            .zip(powers.par_iter_mut())
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(i, ((a, u_dot), powers))| {
                let (gi, oi, vi) = (self.gathered[i], self.own[i], y.v[i]);
                // Σ_j P_j ∇0W̃_ij V_j (eq 134) or −Σ_j P_j ∇0W̃_ji V_j (variational); P_i's
                // term is P_i Σ_j V_j ∇0W̃_ij, summed once on the reference.
                let mut stress = gi.p * self.grad_sum[i];
                // Σ_j m_j Π_ij ∇0W̃_ij: F_i⁻ᵀ applies once to the sum.
                let mut viscous = D::zero();
                let mut hourglass = D::zero();
                let pairs = self.csr.range(i).zip(self.csr.pairs(i, &self.grad));
                for (p, (j, &w)) in pairs {
                    let gj = self.gathered[j];
                    stress += match rev {
                        None => gj.p * w,
                        Some(rev) => -(gj.p * rev[p]),
                    };
                    if HOURGLASS {
                        let (dx0, du) = (self.x0[j] - self.x0[i], y.u[j] - y.u[i]);
                        let h_sum = oi.f + self.own[j].f - D::identity() * 2.0;
                        hourglass += hourglass_acceleration::<D>(kappa[p], dx0, du, h_sum);
                    }
                    if VISCOUS && let Some(av) = av {
                        let c = 0.5 * (gi.c + gj.c);
                        let rho = 0.5 * (gi.rho + gj.rho);
                        let pi = av.pi::<D>(h, gi.x - gj.x, vi - y.v[j], c, rho);
                        // m_j = ρ0 V_j: every particle's mass is ρ0 V.
                        viscous -= w * (rho0 * pi);
                    }
                }
                if pushed_forward {
                    viscous = oi.f_inv_t * viscous;
                }
                *a = stress * inv_rho0 + viscous + hourglass;
                *u_dot = vi;
                *powers = [
                    -self.mass[i] * D::dot(viscous, vi),
                    -self.mass[i] * D::dot(hourglass, vi),
                ];
            });
    }

    /// First Piola–Kirchhoff stress of every particle.
    pub fn first_piola(&mut self, y: &TlState<D>) -> Vec<D::T> {
        let mut scratch = y.clone();
        self.stresses(y, &mut scratch);
        self.gathered.iter().map(|g| g.p).collect()
    }

    fn each_f(&self, y: &TlState<D>) -> Vec<D::T> {
        (0..self.x0.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|i| D::identity() + self.gradients_of(i, [&y.u])[0])
            .collect()
    }
}

impl<D: Dim> OdeSystem for Tlsph<D> {
    type State = TlState<D>;
    type Error = BlowUp;

    fn rates(&mut self, _t: f64, y: &TlState<D>, d: &mut TlState<D>) -> Result<(), BlowUp> {
        if let Some(b) = self.stresses(y, d) {
            return Err(b);
        }
        let mut powers = take(&mut self.powers);
        self.accelerations(y, d, &mut powers);
        self.powers = powers;
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

impl<D: Dim> AtRest<D> for Tlsph<D> {
    /// u, v = 0 (ρ and S of a rate model, which a static run refuses, as initially).
    fn at_rest(&self, u: &[D::V]) -> TlState<D> {
        TlState {
            u: u.to_vec(),
            v: vec![D::zero(); u.len()],
            ..self.initial_state()
        }
    }
}

impl<D: Dim> Method<D> for Tlsph<D> {
    fn build(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        Self::new(case, reference)
    }

    fn initial_state(&self) -> TlState<D> {
        let n = self.x0.len();
        let rate = self.material.model.is_rate_based();
        TlState {
            u: self.u0.clone(),
            v: self.v0.clone(),
            rho: if rate {
                vec![self.material.rho0; n]
            } else {
                Vec::new()
            },
            s: if rate {
                vec![D::zero_t(); n]
            } else {
                Vec::new()
            },
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
        self.each_f(y)
    }

    fn cauchy_stress(&self, y: &TlState<D>) -> Vec<[[f64; 3]; 3]> {
        stress_fields::<D>(&self.material, &self.each_f(y), &y.s, &y.rho, &self.vol).0
    }

    fn strain_energy(&self, y: &TlState<D>) -> f64 {
        stress_fields::<D>(&self.material, &self.each_f(y), &y.s, &y.rho, &self.vol).1
    }

    fn snapshot<'a>(&'a self, y: &TlState<D>) -> Snapshot<'a, D> {
        let f = self.each_f(y);
        let (x0, mass, body, vol) = (&self.x0, &self.mass, &self.body, &self.vol);
        snapshot(&self.material, x0, mass, body, vol, y.clone(), f)
    }

    fn max_signal_speed(&self, y: &TlState<D>) -> f64 {
        let vmax =
            y.v.par_iter()
                .map(|&v| D::norm2(v))
                .reduce(|| 0.0, f64::max)
                .sqrt();
        self.material.p_wave_speed() + vmax
    }

    fn boundary_work(&self) -> &BoundaryWork {
        &self.boundary_work
    }

    fn dissipation_power(&self) -> f64 {
        self.powers.iter().map(|p| p[0]).sum()
    }

    fn hourglass_power(&self) -> f64 {
        self.powers.iter().map(|p| p[1]).sum()
    }

    fn pairs(&self) -> usize {
        self.csr.pair_count()
    }

    /// Pass 1 reads X and u (and v, ρ, S of the rate model) and writes the two records (and
    /// ρ̇, Ṡ); pass 2 reads the records, v, Σ V_j ∇0W̃_ij and m (and X, u with hourglass
    /// control) and writes a, u̇ and the dissipation. Both read the ids and V_j ∇0W̃_ij of
    /// every pair; the variational force also V_j ∇0W̃_ji, the hourglass control κ_ij.
    fn traffic(&self) -> Option<Traffic> {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let records = size_of::<Gathered<D>>() + size_of::<Own<D>>();
        // ρ and S of the rate model, each read and its rate written.
        let rate = if self.material.model.is_rate_based() {
            f + t
        } else {
            0
        };
        let hourglass = self.hourglass.is_some();
        let pass_1 = 2 * v + records + 2 * rate + if rate > 0 { v } else { 0 };
        let pass_2 = records + 4 * v + 2 * f + if hourglass { 2 * v } else { 0 };
        let pair = id + v;
        let per_pair =
            2 * pair + if self.grad_rev.is_some() { v } else { 0 } + if hourglass { f } else { 0 };
        Some(Traffic {
            per_particle: (pass_1 + pass_2) as f64,
            per_pair: per_pair as f64,
            state: (2 * v + rate) as f64,
            velocity: v as f64,
        })
    }

    fn check_finite(&self, y: &TlState<D>) -> Result<(), BlowUp> {
        check_state(&self.x0, y)
    }
}
