//! Total-Lagrangian SPH after Reveles (seed 000 §5.3, eqs 134–137).
//!
//! Neighbours and corrected reference gradients ∇0W̃_ij are computed once on the
//! reference configuration. The state stores the displacement u = x − X (not x), the
//! velocity v and, for the rate-based (hypoelastic) model, the density ρ and the
//! deviatoric stress S.

use super::{ArtificialViscosity, TlsphForce, TlsphSpec, ViscosityGradient};
use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::parallel::MIN_CHUNK;
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, Method, Sizes, Traffic};
use crate::methods::cores::tl::hourglass::{hourglass_acceleration, hourglass_stiffness};
use crate::methods::cores::tl::{
    ReferencePairs, TlCore, TlScheme, TlSph, TlState, inadmissible, snapshot, stress_state,
};
use crate::physics::plasticity::from_mat3;
use crate::reference::Reference;
use crate::statics::explicit::AtRest;
use rayon::prelude::*;
use std::mem::take;

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

/// Each pair's vector scaled by the neighbour's volume V_j, in CSR order.
fn weighted<D: Dim>(csr: &Csr, vol: &[f64], mut per_pair: Vec<D::V>) -> Vec<D::V> {
    per_pair
        .par_iter_mut()
        .zip(csr.ids.par_iter())
        .for_each(|(g, &j)| *g = *g * vol[j as usize]);
    per_pair
}

/// The TLSPH system on the CPU (f64, rayon).
pub type Tlsph<D> = TlSph<D, TlsphScheme<D>>;

/// The stress pass and pair force of TLSPH.
pub struct TlsphScheme<D: Dim> {
    csr: Csr,
    /// Corrected reference gradients weighted by the neighbour's volume, V_j ∇0W̃_ij, one
    /// per CSR pair: every pair sum of the method carries that product.
    grad: Vec<D::V>,
    /// V_j ∇0W̃_ji for every pair (i, j), in CSR order: the variational force only.
    grad_rev: Option<Vec<D::V>>,
    /// What multiplies P_i in particle i's sum: Σ_j V_j ∇0W̃_ij (eq 134 and the
    /// variational force), or V_i ∇0W̃_i(X_i) (the plain force of seed 002 eq 21).
    own_term: Vec<D::V>,
    /// The hourglass stiffness κ_ij of every pair, in CSR order, with the control on.
    hourglass: Option<Vec<f64>>,
    av: Option<ArtificialViscosity>,
    /// The direction of the viscous pair force.
    av_gradient: ViscosityGradient,
    gathered: Vec<Gathered<D>>,
    own: Vec<Own<D>>,
    /// Each particle's power of the viscosity and against the hourglass control,
    /// [−m a_visc·v, −m a_hg·v], at the last rate evaluation.
    powers: Vec<[f64; 2]>,
}

impl<D: Dim> TlsphScheme<D> {
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

    /// Pass 2: a_i = (1/ρ0) Σ_j V_j (P_i + P_j) ∇0W̃_ij (eq 134), the variational
    /// (1/ρ0) Σ_j V_j (P_i ∇0W̃_ij − P_j ∇0W̃_ji), or the plain (1/ρ0) Σ_j V_j P_j ∇0W̃_ij
    /// with i's own term V_i P_i ∇0W̃_i(X_i) (seed 002 eq 21), plus artificial viscosity
    /// and the hourglass control.
    ///
    /// The viscous term acts along the current-configuration gradient F_i⁻ᵀ ∇0W̃_ij, or, with
    /// `viscosity_gradient = "reference"`, along ∇0W̃_ij unmapped as the paper and the
    /// reference code have it; after a quarter turn of rigid rotation that direction points
    /// across the pair and feeds energy in (docs/methods/tlsph.md).
    /// Also writes each particle's powers [−m_i a_visc·v_i, −m_i a_hg·v_i] into `powers`.
    fn accelerations(
        &self,
        core: &TlCore<D>,
        y: &TlState<D>,
        d: &mut TlState<D>,
        powers: &mut [[f64; 2]],
    ) {
        match (self.av.is_some(), self.hourglass.is_some()) {
            (false, false) => self.accelerations_with::<false, false>(core, y, d, powers),
            (false, true) => self.accelerations_with::<false, true>(core, y, d, powers),
            (true, false) => self.accelerations_with::<true, false>(core, y, d, powers),
            (true, true) => self.accelerations_with::<true, true>(core, y, d, powers),
        }
    }

    /// [`Self::accelerations`] with the viscous and hourglass terms chosen at compile
    /// time, so that the pair loop carries only the terms the case runs.
    fn accelerations_with<const VISCOUS: bool, const HOURGLASS: bool>(
        &self,
        core: &TlCore<D>,
        y: &TlState<D>,
        d: &mut TlState<D>,
        powers: &mut [[f64; 2]],
    ) {
        let inv_rho0 = 1.0 / core.material.rho0;
        let rho0 = core.material.rho0;
        let h = core.h;
        let av = self.av;
        let kappa = self.hourglass.as_deref().unwrap_or_default();
        let pushed_forward = self.av_gradient == ViscosityGradient::PushedForward;
        let rev = self.grad_rev.as_deref();
        let x0 = &core.x0;
        d.v.par_iter_mut()
            .zip(d.u.par_iter_mut())
            .zip(powers.par_iter_mut())
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(i, ((a, u_dot), powers))| {
                let (gi, oi, vi) = (self.gathered[i], self.own[i], y.v[i]);
                // Σ_j P_j ∇0W̃_ij V_j (eq 134, plain) or −Σ_j P_j ∇0W̃_ji V_j (variational);
                // P_i's term is P_i Σ_j V_j ∇0W̃_ij, or P_i V_i ∇0W̃_i(X_i) (plain), set once
                // on the reference.
                let mut stress = gi.p * self.own_term[i];
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
                        let (dx0, du) = (x0[j] - x0[i], y.u[j] - y.u[i]);
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
                    -core.mass[i] * D::dot(viscous, vi),
                    -core.mass[i] * D::dot(hourglass, vi),
                ];
            });
    }

    fn each_f(&self, y: &TlState<D>) -> Vec<D::T> {
        (0..y.u.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|i| D::identity() + self.gradients_of(i, [&y.u])[0])
            .collect()
    }
}

/// The record neighbours gather of particle i, with stress P and density ρ.
#[inline]
fn gathered_of<D: Dim>(
    core: &TlCore<D>,
    i: usize,
    y: &TlState<D>,
    p: D::T,
    rho: f64,
) -> Gathered<D> {
    Gathered {
        p,
        x: core.x(i, &y.u),
        c: (core.material.bulk / rho).sqrt(),
        rho,
    }
}

impl<D: Dim> TlScheme<D> for TlsphScheme<D> {
    /// Builds neighbours and corrected gradients on the reference configuration.
    type Spec = TlsphSpec;

    fn new(case: &Case, spec: &TlsphSpec, reference: &Reference<D>) -> Result<Self, CaseError> {
        let pairs = ReferencePairs::new(case, reference)?;
        let (x0, vol) = (&reference.x0, &reference.vol);
        let grad_rev = match spec.force {
            TlsphForce::Reveles | TlsphForce::Plain => None,
            TlsphForce::Variational => Some(weighted::<D>(&pairs.csr, vol, pairs.reverse(case)?)),
        };
        let own_gradients = match spec.force {
            TlsphForce::Plain => pairs.own(case, reference)?,
            TlsphForce::Reveles | TlsphForce::Variational => Vec::new(),
        };
        let ReferencePairs { csr, grad } = pairs;
        let grad = weighted::<D>(&csr, vol, grad);
        let own_term = match spec.force {
            TlsphForce::Plain => own_gradients
                .iter()
                .zip(vol)
                .map(|(&g, &v)| g * v)
                .collect(),
            TlsphForce::Reveles | TlsphForce::Variational => (0..csr.len())
                .into_par_iter()
                .map(|i| csr.range(i).fold(D::zero(), |sum, p| sum + grad[p]))
                .collect(),
        };
        let hourglass = spec
            .hourglass
            .map(|alpha| hourglass_stiffness::<D>(case, alpha, x0, vol, &csr));
        let at_rest = Gathered {
            p: D::zero_t(),
            x: D::zero(),
            c: 0.0,
            rho: reference.material.rho0,
        };
        let identity = Own {
            f: D::identity(),
            f_inv_t: D::identity(),
        };
        Ok(Self {
            gathered: vec![at_rest; x0.len()],
            own: vec![identity; x0.len()],
            powers: vec![[0.0; 2]; x0.len()],
            csr,
            grad,
            grad_rev,
            own_term,
            hourglass,
            av: spec.artificial_viscosity,
            av_gradient: spec.viscosity_gradient,
        })
    }

    fn lists(&self) -> &Csr {
        &self.csr
    }

    fn integrates_stress(&self, core: &TlCore<D>) -> bool {
        core.material.model.is_rate_based()
    }

    /// Pass 1: F, P, current position, density and sound speed per particle; ρ̇ and Ṡ
    /// for the rate model. Returns the first particle with det F ≤ 0 (or NaN).
    fn stresses(&mut self, core: &TlCore<D>, y: &TlState<D>, d: &mut TlState<D>) -> Option<BlowUp> {
        let mat = core.material;
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
                    *g = gathered_of(core, i, y, r.pk1, y.rho[i]);
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
                    // P(F), or the von Mises return from the committed history.
                    let p = match &core.plastic {
                        Some(history) => from_mat3::<D>(history.returned::<D>(i, f).p),
                        None => mat.pk1::<D>(f),
                    };
                    *g = gathered_of(core, i, y, p, mat.rho0 / D::det(f));
                    inadmissible::<D>(i, f)
                })
                .min()
        };
        (self.gathered, self.own) = (gathered, own);
        bad.map(|i| core.blow_up(i, "det F", D::det(self.own[i].f)))
    }

    fn forces(&mut self, core: &mut TlCore<D>, y: &TlState<D>, d: &mut TlState<D>) {
        let mut powers = take(&mut self.powers);
        self.accelerations(core, y, d, &mut powers);
        self.powers = powers;
    }

    fn deformation_gradient(&self, _core: &TlCore<D>, y: &TlState<D>) -> Vec<D::T> {
        self.each_f(y)
    }

    fn cauchy_stress(&self, core: &TlCore<D>, y: &TlState<D>) -> Vec<[[f64; 3]; 3]> {
        let history = core.plastic.as_ref();
        stress_state::<D>(&core.material, &self.each_f(y), y, &core.vol, history).sigma
    }

    fn strain_energy(&self, core: &TlCore<D>, y: &TlState<D>) -> Exact {
        let (weights, history) = (&core.energy_weights, core.plastic.as_ref());
        stress_state::<D>(&core.material, &self.each_f(y), y, weights, history).energy
    }

    fn snapshot<'a>(&'a self, core: &'a TlCore<D>, y: &TlState<D>) -> Snapshot<'a, D> {
        let f = self.each_f(y);
        let (x0, mass, body) = (&core.x0, &core.mass, &core.body);
        let vol = &core.energy_weights;
        let history = core.plastic.as_ref();
        snapshot(&core.material, (x0, mass, body), vol, y.clone(), f, history)
    }

    fn dissipation_power(&self, core: &TlCore<D>) -> Exact {
        core.booked_sum(self.powers.iter().map(|p| p[0]))
    }

    fn hourglass_power(&self, core: &TlCore<D>) -> Exact {
        core.booked_sum(self.powers.iter().map(|p| p[1]))
    }

    /// Pass 1 reads X and u (and v, ρ, S of the rate model, or the plastic history) and
    /// writes the two records (and ρ̇, Ṡ); pass 2 reads the records, v, Σ V_j ∇0W̃_ij and m
    /// (and X, u with hourglass control) and writes a, u̇ and the dissipation. Both read the
    /// ids and V_j ∇0W̃_ij of every pair; the variational force also V_j ∇0W̃_ji, the
    /// hourglass control κ_ij. The commit of a plastic history once a step is left out.
    fn traffic(&self, core: &TlCore<D>) -> Traffic {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let records = size_of::<Gathered<D>>() + size_of::<Own<D>>();
        // ρ and S of the rate model, each read and its rate written.
        let rate = if core.material.model.is_rate_based() {
            f + t
        } else {
            0
        };
        let hourglass = self.hourglass.is_some();
        let plastic = Sizes::plastic_history(core.plastic.is_some());
        let pass_1 = 2 * v + records + 2 * rate + if rate > 0 { v } else { 0 } + plastic;
        let pass_2 = records + 4 * v + 2 * f + if hourglass { 2 * v } else { 0 };
        let pair = id + v;
        let per_pair =
            2 * pair + if self.grad_rev.is_some() { v } else { 0 } + if hourglass { f } else { 0 };
        Traffic {
            per_particle: (pass_1 + pass_2) as f64,
            per_pair: per_pair as f64,
            state: (2 * v + rate) as f64,
            velocity: v as f64,
        }
    }
}

impl<D: Dim> Tlsph<D> {
    /// Corrected reference gradients ∇0W̃_ij, in CSR order.
    pub fn gradients(&self) -> Vec<D::V> {
        let s = &self.scheme;
        s.grad
            .iter()
            .zip(&s.csr.ids)
            .map(|(&g, &j)| g * (1.0 / self.core.vol[j as usize]))
            .collect()
    }

    /// First Piola–Kirchhoff stress of every particle.
    pub fn first_piola(&mut self, y: &TlState<D>) -> Vec<D::T> {
        let mut scratch = y.clone();
        self.scheme.stresses(&self.core, y, &mut scratch);
        self.scheme.gathered.iter().map(|g| g.p).collect()
    }
}

impl<D: Dim> AtRest<D> for Tlsph<D> {
    /// u, v (ρ and S of a rate model, which a static or implicit run refuses, as
    /// initially).
    fn moving(&self, u: &[D::V], v: &[D::V]) -> TlState<D> {
        self.initial_state().moving(u, v)
    }
}
