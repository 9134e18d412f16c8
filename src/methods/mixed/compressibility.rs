//! Artificial compressibility for the mixed methods (seed 003 §5, eqs 42–58): the
//! {p, F, H, p} system, whose pressure p replaces J as the volumetric unknown.
//!
//! Every stage of the time integrator (a forward-Euler step of TVD-RK2 or SSP-RK3) is
//!
//! - a *predictor*, the explicit stage with the pressure rate of a fictitious bulk
//!   modulus κ̃ (eqs 51, with 46): p^int = p^n + Δt κ̃ H^n : ∇0v^n; the CFL step and the
//!   upwind fluxes take the wave speed c̃_p of κ̃;
//! - a *corrector* (eqs 52–58) that makes the velocity and pressure of the stage's end
//!   consistent with the true κ, iterated in pseudo time τ (TVD-RK2) to a steady state:
//!
//!   ∂v/∂τ = DIV[(p − p^n) H^n]/ρ0 − (v − v^int)/Δt,
//!   (1/γ) ∂p/∂τ = H^n : ∇0v − (p − p^n)/(κΔt) + η ℒ[p].
//!
//! κ = ∞ (ν = 0.5) is allowed: the constraint is then H^n : ∇0v^{n+1} + η ℒ[p] = 0.
//! The J dissipation D(J) of eqs 51d and 52b is left out (docs/methods/mixed.md: in the
//! constraint it is a compact Laplacian of P that the corrector's wide DIV cannot
//! balance, and it grows the pressure checkerboard); the pseudo-viscosity ℒ takes its
//! place.
//!
//! DIV is the method's own discrete divergence of the momentum equation (eq 21 or seed
//! 002 eq 22), so the corrector's forces come in equal and opposite pairs and the
//! stage conserves linear momentum exactly; eq 52a's gradient form would not.

use super::Momentum;
use super::system::pair_force;
use crate::case::Case;
use crate::core::check::{Problem, fail, positive, toml_name};
use crate::core::integrate::PseudoTime;
use crate::core::neighbour::Csr;
use crate::core::parallel::{MIN_CHUNK, put_row, take_row};
use crate::core::sum::Ranks;
use crate::core::tensor::{Dim, Linear};
use crate::physics::material::{Material, MaterialModel};
use crate::physics::mirror::Ghosts;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::sync::Arc;

/// `[method.artificial_compressibility]` of a mixed method.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ArtificialCompressibility {
    /// κ̃ [Pa], the fictitious bulk modulus of the predictor and of the CFL step (eq 46);
    /// default 10 μ, the bulk modulus of ν ≈ 0.45.
    pub kappa: Option<f64>,
    /// γ [Pa], the compressibility of the pseudo-time iteration (eq 48b); default the
    /// value that damps the body's longest pressure mode critically,
    /// max(ρ0 (L/2πΔt)², ρ0 c̃_p²) with L the largest extent of the body, and at most κ
    /// (above it the relaxation of p to κ's pressure, at the rate γ/κΔt, would limit
    /// the pseudo-time step).
    pub gamma: Option<f64>,
    /// α ∈ [0, 1] of the pseudo-viscosity η = α c_s² Δt/μ = α Δt/ρ0 (eq 54); default
    /// 0.2.
    #[serde(default = "default_alpha")]
    pub alpha: f64,
    /// The iteration stops when both residuals, as velocities (Δt |∂v/∂τ| and
    /// Δx |∂p/∂τ|/γ), are below `tolerance` times the largest velocity; default 1e-6.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Pseudo-time steps allowed per stage before the run stops; default 2000.
    #[serde(default = "default_max_iterations")]
    pub max_iterations: u32,
}

fn default_alpha() -> f64 {
    0.2
}

fn default_tolerance() -> f64 {
    1e-6
}

fn default_max_iterations() -> u32 {
    2000
}

/// The largest `max_iterations` accepted: a stage of this many pseudo-time steps costs
/// as much as 2e6 explicit stages.
const MAX_ITERATIONS: u32 = 1_000_000;

/// The pseudo-time step's fraction of the time a pseudo-acoustic wave takes to cross Δx.
const PSEUDO_CFL: f64 = 0.4;

impl ArtificialCompressibility {
    /// κ̃ of material `mat`.
    pub fn kappa(&self, mat: &Material) -> f64 {
        self.kappa.unwrap_or(10.0 * mat.mu)
    }

    /// The material of the predictor: `mat` with the fictitious bulk modulus κ̃ (and
    /// λ̃ = κ̃ − 2μ/3).
    pub fn predictor(&self, mat: &Material) -> Material {
        let bulk = self.kappa(mat);
        Material {
            bulk,
            lambda: bulk - 2.0 * mat.mu / 3.0,
            ..*mat
        }
    }

    /// c̃_p = sqrt((κ̃ + 4μ/3)/ρ0): the p-wave speed of the predictor, its fluxes and its
    /// CFL step.
    pub fn p_wave_speed(&self, mat: &Material) -> f64 {
        self.predictor(mat).p_wave_speed()
    }

    /// Checks of the table against the case: the polyconvex model (the only one with a
    /// separate pressure), the variables, an integrator made of forward-Euler stages
    /// and the ranges of the keys.
    pub(super) fn validate(
        &self,
        options: &super::MixedOptions,
        case: &Case,
    ) -> Result<(), Problem> {
        const KEY: &str = "method.artificial_compressibility";
        let model = case.material.model;
        if model != MaterialModel::NearlyIncompressibleNeoHookean {
            return fail(
                "material.model",
                format!(
                    "artificial compressibility evolves the pressure of the `{}` model; {} \
                     has no separate pressure",
                    toml_name(&MaterialModel::NearlyIncompressibleNeoHookean),
                    toml_name(&model)
                ),
            );
        }
        if options.variables == super::Conserved::PFJ {
            return fail(
                "method.variables",
                "with artificial compressibility the pressure replaces J: use \"p-F-H-J\" (the \
                 paper's {p, F, H, p}) or \"p-F\" ({p, F, p}, H = cof F)",
            );
        }
        use crate::core::integrate::IntegratorKind::{SspRk3, TvdRk2};
        if !matches!(case.method.integrator, TvdRk2 | SspRk3) {
            return fail(
                "method.integrator",
                format!(
                    "is `{}`; artificial compressibility corrects forward-Euler stages, so it \
                     runs with `tvd-rk2` (the paper's) or `ssp-rk3`",
                    toml_name(&case.method.integrator)
                ),
            );
        }
        let mat = Material::new(&case.material);
        if let Some(kappa) = self.kappa {
            positive(&format!("{KEY}.kappa"), kappa)?;
            if kappa >= mat.bulk {
                return fail(
                    format!("{KEY}.kappa"),
                    format!(
                        "is {kappa:e} Pa, not below the material's bulk modulus κ = {:e} Pa; \
                         the fictitious κ̃ < κ lengthens the step, else run without \
                         artificial compressibility",
                        mat.bulk
                    ),
                );
            }
        }
        if let Some(gamma) = self.gamma {
            positive(&format!("{KEY}.gamma"), gamma)?;
        }
        if !(0.0..=1.0).contains(&self.alpha) {
            return fail(
                format!("{KEY}.alpha"),
                format!("is {:?}; it must lie in [0, 1] (eq 54)", self.alpha),
            );
        }
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return fail(
                format!("{KEY}.tolerance"),
                format!("is {:?}; it must lie in (0, 1)", self.tolerance),
            );
        }
        if !(1..=MAX_ITERATIONS).contains(&self.max_iterations) {
            return fail(
                format!("{KEY}.max_iterations"),
                format!(
                    "is {}; it must lie in 1..={MAX_ITERATIONS}",
                    self.max_iterations
                ),
            );
        }
        Ok(())
    }
}

/// The reference data the corrector's pair sums read, borrowed from the method.
pub(super) struct Pairs<'a, D: Dim> {
    pub csr: &'a Csr,
    /// ∇̃0W̃_b(X_a) and ∇̃0W̃_a(X_b), CSR order.
    pub grad: &'a [D::V],
    pub grad_rev: &'a [D::V],
    /// Volumes of the real particles, then the ghosts.
    pub vol: &'a [f64],
    pub ghosts: &'a Ghosts<D>,
    pub momentum: Momentum,
}

/// What a stage hands the corrector (real particles).
pub(super) struct StageStart<'a, D: Dim> {
    pub dt: f64,
    /// v^int = v^n + Δt a: the predictor's velocities with loads, contact and the
    /// prescribed components.
    pub v_int: &'a [D::V],
    pub v_n: &'a [D::V],
    /// p^n and p^int.
    pub p_n: &'a [f64],
    pub p_int: &'a [f64],
    /// H^n.
    pub h: &'a [D::T],
    /// Components held by supports over the step (bit k: component k).
    pub held: &'a [u8],
}

/// The arrays the method fills for a stage's [`StageStart`] (v^int, the predictor's
/// acceleration, which then takes the corrector's force, p^int, H^n, the held
/// components), kept between stages.
pub(super) struct StageBuffers<D: Dim> {
    pub v_int: Vec<D::V>,
    pub a_int: Vec<D::V>,
    pub p_int: Vec<f64>,
    pub h: Vec<D::T>,
    pub held: Vec<u8>,
    /// The predictor's loads and supports on a^int (its reactions' list kept).
    pub work: crate::engine::BoundaryWork,
}

impl<D: Dim> Default for StageBuffers<D> {
    fn default() -> Self {
        Self {
            v_int: Vec::new(),
            a_int: Vec::new(),
            p_int: Vec::new(),
            h: Vec::new(),
            held: Vec::new(),
            work: Default::default(),
        }
    }
}

/// The quantity of the blow-up a stage that does not converge stops the run with.
pub(super) const UNCONVERGED: &str = "pseudo-time residual of artificial compressibility over \
     the velocity scale, at max_iterations (raise method.artificial_compressibility.\
     max_iterations or tolerance)";

/// Where the pseudo-time iteration stopped short of its tolerance: the particle of the
/// largest residual and that residual relative to the velocity scale.
pub(super) struct Unconverged {
    pub particle: usize,
    pub residual: f64,
}

/// The pseudo-time corrector, built once: its constants, the Laplacian weights of the
/// pseudo-viscosity and the arrays of the iteration.
pub(super) struct Corrector<D: Dim> {
    /// κ (∞ at ν = 0.5) and κ̃.
    kappa: f64,
    kappa_tilde: f64,
    gamma: Option<f64>,
    alpha: f64,
    tolerance: f64,
    max_iterations: u32,
    rho0: f64,
    /// c̃_p.
    c_p: f64,
    /// Δx and the largest extent L of the reference configuration, from the box of its
    /// particles as (−lo, hi).
    spacing: f64,
    size: f64,
    bounds: [f64; 6],
    /// ℓ_ab = 2 V_b N_ab · ∇̃W̃^Ave_b(X_a)/|X_ab| (eq 58), CSR order, and max_a Σ_b |ℓ_ab|.
    ell: Vec<f64>,
    ell_sum: f64,
    /// The ranks that share the particles: each iterates all its rows, measures the
    /// residual on its own (`counted`) ones and refreshes its ghosts after every
    /// pseudo-stage; and whether L and max Σ|ℓ| are the run's yet (taken over the ranks
    /// at the first stage, once every rank is set up).
    ranks: Arc<dyn Ranks>,
    counted: Vec<bool>,
    agreed: bool,
    /// The iterate (v, p), the pseudo-stage's and their residuals.
    v: Vec<D::V>,
    p: Vec<f64>,
    v1: Vec<D::V>,
    p1: Vec<f64>,
    rv: Vec<D::V>,
    rp: Vec<f64>,
    /// v, (p − p^n) H^n and p of the real particles and ghosts.
    v_ext: Vec<D::V>,
    dp_ext: Vec<D::T>,
    p_ext: Vec<f64>,
    /// The caller's arrays of a stage.
    pub buffers: StageBuffers<D>,
    pub stats: PseudoTime,
}

impl<D: Dim> Corrector<D> {
    /// The corrector of `spec` for the real particles of `pairs`, at reference positions
    /// x0 (real then ghosts), with the unit normals N_ab of their pairs, on the ranks
    /// that share the particles (`counted`: this rank's own).
    pub fn new(
        spec: &ArtificialCompressibility,
        case: &Case,
        pairs: &Pairs<D>,
        (x0, normal): (&[D::V], &[D::V]),
        (counted, ranks): (&[bool], Arc<dyn Ranks>),
    ) -> Self {
        let mat = Material::new(&case.material);
        let n = pairs.csr.len();
        let ell: Vec<f64> = (0..n)
            .into_par_iter()
            .flat_map_iter(|a| pairs.csr.range(a).map(move |q| (a, q)))
            .map(|(a, q)| {
                let b = pairs.csr.ids[q] as usize;
                let g_ave = (pairs.grad[q] - pairs.grad_rev[q]) * 0.5;
                2.0 * pairs.vol[b] * D::dot(normal[q], g_ave) / D::norm2(x0[b] - x0[a]).sqrt()
            })
            .collect();
        let ell_sum = (0..n)
            .into_par_iter()
            .filter(|&a| counted[a])
            .map(|a| pairs.csr.range(a).map(|q| ell[q].abs()).sum::<f64>())
            .reduce(|| 0.0, f64::max);
        // The own particles' box, as (−lo, hi) so that the ranks take its maxima.
        let mut bounds = [f64::NEG_INFINITY; 6];
        for (&x, _) in x0[..n].iter().zip(counted).filter(|(_, c)| **c) {
            for (k, c) in D::to3(x).into_iter().enumerate().take(D::N) {
                bounds[k] = bounds[k].max(-c);
                bounds[3 + k] = bounds[3 + k].max(c);
            }
        }
        let n_ext = x0.len();
        Self {
            kappa: mat.bulk,
            kappa_tilde: spec.kappa(&mat),
            gamma: spec.gamma,
            alpha: spec.alpha,
            tolerance: spec.tolerance,
            max_iterations: spec.max_iterations,
            rho0: mat.rho0,
            c_p: spec.p_wave_speed(&mat),
            spacing: case.spacing,
            size: largest_extent::<D>(&bounds, case.spacing),
            bounds,
            ell,
            ell_sum,
            ranks,
            counted: counted.to_vec(),
            agreed: false,
            v: vec![D::zero(); n],
            p: vec![0.0; n],
            v1: vec![D::zero(); n],
            p1: vec![0.0; n],
            rv: vec![D::zero(); n],
            rp: vec![0.0; n],
            v_ext: vec![D::zero(); n_ext],
            dp_ext: vec![D::zero_t(); n_ext],
            p_ext: vec![0.0; n_ext],
            buffers: StageBuffers::default(),
            stats: PseudoTime::default(),
        }
    }

    /// κ̃ of the predictor.
    pub fn kappa_tilde(&self) -> f64 {
        self.kappa_tilde
    }

    /// Starts a step's count of iterations.
    pub fn begin_step(&mut self) {
        self.stats.step = 0;
        self.stats.residual = 0.0;
    }

    /// η = α Δt/ρ0 of a stage of size Δt (eq 54).
    pub fn eta(&self, dt: f64) -> f64 {
        self.alpha * dt / self.rho0
    }

    /// γ of a stage of size Δt.
    pub fn gamma(&self, dt: f64) -> f64 {
        self.gamma.unwrap_or_else(|| {
            let critical = self.size / (2.0 * std::f64::consts::PI * dt);
            (self.rho0 * critical.max(self.c_p).powi(2)).min(self.kappa)
        })
    }

    /// The pseudo-time step: a fraction of the pseudo-acoustic crossing time of Δx, and
    /// within the stability bounds of the relaxation terms (rates 1/Δt and γ/(κΔt)) and
    /// of the pseudo-viscosity (rate γη max_a Σ_b |ℓ_ab|).
    pub fn pseudo_step(&self, dt: f64, gamma: f64) -> f64 {
        let mut dtau = (PSEUDO_CFL * self.spacing * (self.rho0 / gamma).sqrt())
            .min(dt)
            .min(self.kappa * dt / gamma);
        let eta = self.eta(dt);
        if eta > 0.0 {
            dtau = dtau.min(1.0 / (gamma * eta * self.ell_sum));
        }
        dtau
    }

    /// Iterates the stage `s` to its pseudo steady state; `p()` then holds p^{n+1}.
    pub fn solve(&mut self, pairs: &Pairs<D>, s: &StageStart<D>) -> Result<(), Unconverged> {
        if !self.agreed {
            let mut run = [self.ell_sum, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            run[1..].copy_from_slice(&self.bounds);
            self.ranks.max(&mut run);
            self.ell_sum = run[0];
            self.bounds.copy_from_slice(&run[1..]);
            self.size = largest_extent::<D>(&self.bounds, self.spacing);
            self.agreed = true;
        }
        let gamma = self.gamma(s.dt);
        let dtau = self.pseudo_step(s.dt, gamma);
        let counted = &self.counted;
        let largest = |v: &[D::V]| {
            (v.par_iter().zip(counted))
                .map(|(&v, &c)| if c { D::norm2(v) } else { 0.0 })
                .reduce(|| 0.0, f64::max)
        };
        let mut scale = [largest(s.v_int).max(largest(s.v_n))];
        self.ranks.max(&mut scale);
        let scale = scale[0].sqrt();
        self.v.copy_from_slice(s.v_int);
        self.p.copy_from_slice(s.p_int);
        refresh::<D>(self.ranks.as_ref(), &mut self.v, &mut self.p);
        let mut iterations = 0;
        let residual = loop {
            let (v, p) = (std::mem::take(&mut self.v), std::mem::take(&mut self.p));
            let (worst, r) = self.residual(pairs, s, gamma, &v, &p);
            (self.v, self.p) = (v, p);
            let (mine, r) = self.ranks.worst(worst, r);
            let relative = if scale > 0.0 { r / scale } else { r };
            if r <= self.tolerance * scale {
                break relative;
            }
            if iterations == self.max_iterations {
                // The rank that holds the worst particle reports it; the others end the
                // stage, and the step, with it.
                return match mine {
                    true => Err(Unconverged {
                        particle: worst,
                        residual: relative,
                    }),
                    false => Ok(()),
                };
            }
            self.pseudo_step_rk2(pairs, s, gamma, dtau);
            iterations += 1;
        };
        self.stats.step += u64::from(iterations);
        self.stats.total += u64::from(iterations);
        self.stats.residual = self.stats.residual.max(residual);
        Ok(())
    }

    /// p^{n+1} after [`Self::solve`].
    pub fn p(&self) -> &[f64] {
        &self.p
    }

    /// One TVD-RK2 step in pseudo time from the iterate, whose residuals `rv`, `rp`
    /// [`Self::residual`] has just computed.
    fn pseudo_step_rk2(&mut self, pairs: &Pairs<D>, s: &StageStart<D>, gamma: f64, dtau: f64) {
        let mut v1 = std::mem::take(&mut self.v1);
        let mut p1 = std::mem::take(&mut self.p1);
        euler(&mut v1, &self.v, &self.rv, dtau);
        euler(&mut p1, &self.p, &self.rp, dtau);
        refresh::<D>(self.ranks.as_ref(), &mut v1, &mut p1);
        self.residual(pairs, s, gamma, &v1, &p1);
        // y ← ½(y + y1 + Δτ R(y1)).
        average(&mut self.v, &v1, &self.rv, dtau);
        average(&mut self.p, &p1, &self.rp, dtau);
        refresh::<D>(self.ranks.as_ref(), &mut self.v, &mut self.p);
        (self.v1, self.p1) = (v1, p1);
    }

    /// The pseudo-time rates of (v, p) into `rv`, `rp`; returns the particle with the
    /// largest residual as a velocity, max(Δt |∂v/∂τ|, Δx |∂p/∂τ|/γ), and that residual.
    fn residual(
        &mut self,
        pairs: &Pairs<D>,
        s: &StageStart<D>,
        gamma: f64,
        v: &[D::V],
        p: &[f64],
    ) -> (usize, f64) {
        let g = pairs.ghosts;
        g.fill(&mut self.v_ext, |a| v[a], |m, v| m.vector::<D>(v));
        g.fill(
            &mut self.dp_ext,
            |a| s.h[a] * (p[a] - s.p_n[a]),
            |m, t| m.tensor::<D>(t),
        );
        let eta = self.eta(s.dt);
        if eta > 0.0 {
            g.fill(&mut self.p_ext, |a| p[a], |m, p| m.scalar(p));
        }
        let (inv_rho0, inv_dt) = (1.0 / self.rho0, 1.0 / s.dt);
        let relax_p = 1.0 / (self.kappa * s.dt);
        let (v_ext, dp_ext, p_ext, ell) = (&self.v_ext, &self.dp_ext, &self.p_ext, &self.ell);
        let counted = &self.counted;
        let (csr, vol) = (pairs.csr, pairs.vol);
        self.rv
            .par_iter_mut()
            .zip(self.rp.par_iter_mut())
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .map(|(a, (rv, rp))| {
                let (mut t, mut div, mut lap) = (D::zero(), 0.0, 0.0);
                let hg = |q: usize| s.h[a] * pairs.grad[q];
                for q in csr.range(a) {
                    let b = csr.ids[q] as usize;
                    t += pair_force::<D>(
                        pairs.momentum,
                        vol[b],
                        dp_ext[a],
                        dp_ext[b],
                        pairs.grad[q],
                        pairs.grad_rev[q],
                    );
                    // H_a : (v_b − v_a) ⊗ V_b g_ab.
                    div += vol[b] * D::dot(v_ext[b] - v_ext[a], hg(q));
                    if eta > 0.0 {
                        lap += ell[q] * (p_ext[b] - p_ext[a]);
                    }
                }
                // eq 52a with the divergence of eq 21: ρ0 ∂v/∂τ = −T[(p − p^n)H^n] − ρ0 (v − v^int)/Δt.
                let mut r = t * (-inv_rho0) - (v[a] - s.v_int[a]) * inv_dt;
                if s.held[a] != 0 {
                    let mut c = D::to3(r);
                    for (k, c) in c.iter_mut().enumerate() {
                        if s.held[a] & (1 << k) != 0 {
                            *c = 0.0;
                        }
                    }
                    r = D::from_slice(&c[..D::N]);
                }
                *rv = r;
                // eqs 52b, 53–54, 58.
                *rp = gamma * (div - (p[a] - s.p_n[a]) * relax_p + eta * lap);
                let size = (D::norm2(r).sqrt() * s.dt).max(rp.abs() * self.spacing / gamma);
                (a, if counted[a] { size } else { 0.0 })
            })
            .reduce(|| (0, 0.0), |x, y| if y.1 > x.1 { y } else { x })
    }

    /// −T_a[(p − p^n)H^n] of every real particle at the converged pressure, into `out`:
    /// the corrector's force per unit reference volume. [`Self::solve`] stops right
    /// after the residual of that pressure, so (p − p^n)H^n is still in `dp_ext`.
    pub fn force(&self, pairs: &Pairs<D>, out: &mut [D::V]) {
        let dp_ext = &self.dp_ext;
        out.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(a, out)| {
                let mut t = D::zero();
                for q in pairs.csr.range(a) {
                    let b = pairs.csr.ids[q] as usize;
                    t += pair_force::<D>(
                        pairs.momentum,
                        pairs.vol[b],
                        dp_ext[a],
                        dp_ext[b],
                        pairs.grad[q],
                        pairs.grad_rev[q],
                    );
                }
                *out = t * -1.0;
            });
    }
}

/// The constants and weights the GPU's corrector takes (`gpu_corrector`).
#[cfg(feature = "gpu")]
impl<D: Dim> Corrector<D> {
    /// κ, infinite at ν = 0.5.
    pub fn kappa(&self) -> f64 {
        self.kappa
    }

    /// The iteration's stopping tolerance and its limit of pseudo steps per stage.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    pub fn max_iterations(&self) -> u32 {
        self.max_iterations
    }

    /// ℓ_ab of the pseudo-viscosity (eq 58) in CSR order; None when α = 0.
    pub fn laplacian_weights(&self) -> Option<&[f64]> {
        (self.alpha > 0.0).then_some(&self.ell[..])
    }
}

/// The largest extent of the box (−lo, hi), at least Δx.
fn largest_extent<D: Dim>(bounds: &[f64; 6], spacing: f64) -> f64 {
    (0..D::N)
        .map(|k| bounds[3 + k] + bounds[k])
        .fold(spacing, f64::max)
}

/// The owners' v and p of the ghosts of the rank ([`Ranks::refresh`]).
fn refresh<D: Dim>(ranks: &dyn Ranks, v: &mut [D::V], p: &mut [f64]) {
    let (v, p) = (RefCell::new(v), RefCell::new(p));
    ranks.refresh(
        &|ids, out| {
            let (v, p) = (v.borrow(), p.borrow());
            for &i in ids {
                put_row(&v, i, out);
                put_row(&p, i, out);
            }
        },
        &mut |ids, mut words| {
            let (mut v, mut p) = (v.borrow_mut(), p.borrow_mut());
            for &i in ids {
                take_row(&mut v, i, &mut words);
                take_row(&mut p, i, &mut words);
            }
        },
    );
}

/// out = y + h r.
fn euler<T: Linear>(out: &mut [T], y: &[T], r: &[T], h: f64) {
    out.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(y.par_iter().zip(r))
        .for_each(|(o, (&y, &r))| *o = y + r * h);
}

/// y ← ½(y + y1 + h r).
fn average<T: Linear>(y: &mut [T], y1: &[T], r: &[T], h: f64) {
    y.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(y1.par_iter().zip(r))
        .for_each(|(y, (&y1, &r))| *y = (*y + y1 + r * h) * 0.5);
}
