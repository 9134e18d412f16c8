//! Mixed total-Lagrangian SPH on the conservation laws of {p, F, H, J} (seed 003):
//! Upwind-SPH (acoustic Riemann stabilisation with linear reconstruction) and JST-SPH
//! (Jameson–Schmidt–Turkel dissipation on p), with the angular-momentum-preserving
//! projection of Appendix B.
//!
//! The state holds u = x − X, v = p/ρ0 (ρ0 is uniform, so this is p up to a constant),
//! F and, per variant, H and J. Neighbours, corrected gradients G_b(X_a) = V_b ∇̃0W̃_b(X_a)
//! and every per-pair weight are computed once on the reference configuration; every
//! pair sum is a gather over particle a's own list, in both directions of the pair.
//! Mirror planes are closed by ghost particles ([`crate::mirror`]): the per-pair data
//! and every per-particle field are extended to them, and only real particles are
//! integrated.

use super::compressibility::{Corrector, Pairs, StageStart, UNCONVERGED};
use super::projection::{Balance, Sums};
use super::weights::{brookshaw_weights, correct_laplacian, least_squares_weights, pair_map};
use super::{CflWaveSpeed, Conserved, DeformationGradient, JstLaplacian, Momentum, Stabiliser};
use crate::boundary::{Boundary, OnPatches};
use crate::correction;
use crate::integrate::{IntegratorKind, OdeSystem};
use crate::interaction::Interactions;
use crate::material::Material;
use crate::methods::not_run_by;
use crate::methods::shared::{
    BlowUp, BoundaryWork, MIN_CHUNK, Method, PseudoTime, Sizes, Traffic, check_motion,
    neighbour_radius, ordered_reduce, particle_state, reference_gradients,
};
use crate::mirror::Ghosts;
use crate::neighbour::{self, Csr};
use crate::observe::{ScalarField, Snapshot};
use crate::plasticity::{History, PLASTIC_STRAIN, Returned, from_mat3};
use crate::reference::Reference;
use crate::scene::{Case, CaseError};
use crate::tensor::{Dim, smallest_stretch_squared};
use rayon::prelude::*;

/// Integrated state of a mixed method.
#[derive(Debug)]
pub struct MixedState<D: Dim> {
    /// Displacement u = x − X.
    pub u: Vec<D::V>,
    /// Velocity v = p/ρ0.
    pub v: Vec<D::V>,
    /// Deformation gradient (eq 1b).
    pub f: Vec<D::T>,
    /// Area map H (eq 1c); empty unless {p, F, H, J}.
    pub h: Vec<D::T>,
    /// Volume map J (eq 1d); empty for {p, F} and with artificial compressibility.
    pub j: Vec<f64>,
    /// Pressure p of the {p, F, H, p} system (eq 42); empty without artificial
    /// compressibility.
    pub pressure: Vec<f64>,
}

particle_state!(MixedState { f, h, j, pressure });

/// The stabilising flux of a mixed method.
#[derive(Clone, Debug)]
enum Stabilisation {
    /// Acoustic Riemann solver on p and J (eqs 27–33), optionally with the least-squares
    /// linear reconstruction of p and P to the mid-pair (eq 37).
    Upwind { reconstruction: bool },
    /// JST dissipation on p: ½ε⁽²⁾c_p h Σ s_ab Δp − ½ε⁽⁴⁾c_p h³ Σ s_ab Δ(∇²p) (seed 002
    /// eq 28) with the per-pair Laplacian weights ℓ_ab and s_ab = ℓ_ab + (V_b/V_a) ℓ_ba.
    Jst {
        coefficients: super::Jst,
        ell: Vec<f64>,
        s: Vec<f64>,
    },
}

/// Per-particle quantities of one rate evaluation.
#[derive(Clone, Copy, Debug)]
struct Kinematics<D: Dim> {
    /// First Piola–Kirchhoff stress P(F, H, J).
    p: D::T,
    /// H used in the stress and the J fluxes (evolved, or cof F).
    h: D::T,
    /// Velocity gradient ∇0v = Σ_b (v_b − v_a) ⊗ G_b(X_a) (eq 39b).
    grad_v: D::T,
    /// J used in the stress (evolved, or det F) and det F.
    j: f64,
    det_f: f64,
}

/// Least-squares gradients of v and P (eq 37) for the reconstruction; in 2D the third
/// entry of `grad_p` is unused.
#[derive(Clone, Copy, Debug)]
struct Slopes<D: Dim> {
    grad_v: D::T,
    /// ∂P/∂X_l, l = 0..d.
    grad_p: [D::T; 3],
}

impl<D: Dim> Slopes<D> {
    /// Change of v and P from the particle to X_a + s d (s = ±½ for the faces).
    fn along(&self, d: D::V, s: f64) -> (D::V, D::T) {
        let mut dp = D::zero_t();
        for l in 0..D::N {
            dp += self.grad_p[l] * (s * D::comp(d, l));
        }
        (self.grad_v * d * s, dp)
    }
}

/// The internal-force and stabilisation parts of dp/dt, kept apart for the projection,
/// and the J dissipation.
#[derive(Clone, Copy, Debug)]
struct Forces<D: Dim> {
    /// T_a = Σ_b V_b [P_b ∇̃W̃_a(X_b) − P_a ∇̃W̃_b(X_a)] (eqs 20–21).
    t: D::V,
    /// D(p_a) (eq 32) or the JST term.
    d: D::V,
    /// D(J_a) (eq 33, corrected sign).
    dj: f64,
}

/// Per-particle parts of the rates, for inspection: T_a, D(p_a), D(J_a).
#[derive(Clone, Debug)]
pub struct Fluxes<D: Dim> {
    pub t: Vec<D::V>,
    pub d: Vec<D::V>,
    pub dj: Vec<f64>,
}

/// Displacements, velocities and size of the current step at its start.
type StepStart<D> = (Vec<<D as Dim>::V>, Vec<<D as Dim>::V>, f64);

/// Mixed {p, F, H, J} SPH on the CPU (f64, rayon). Per-particle arrays of the reference
/// configuration and of the passes hold the n real particles, then the ghosts.
pub struct MixedSph<D: Dim> {
    /// Number of real particles.
    n: usize,
    ghosts: Ghosts<D>,
    x0: Vec<D::V>,
    vol: Vec<f64>,
    mass: Vec<f64>,
    body: Vec<u32>,
    v0: Vec<D::V>,
    /// Initial displacements of the real particles.
    u0: Vec<D::V>,
    csr: Csr,
    /// g_ab = ∇̃0W̃_b(X_a), CSR order.
    grad: Vec<D::V>,
    /// g_ba = ∇̃0W̃_a(X_b) for pair (a, b), CSR order.
    grad_rev: Vec<D::V>,
    /// N_ab = (X_b − X_a)/|X_b − X_a|.
    normal: Vec<D::V>,
    /// Least-squares weights M_a⁻¹ N_ab / |d_ab| (eq 37).
    ls: Vec<D::V>,
    material: Material,
    conserved: Conserved,
    momentum: Momentum,
    /// V_b W̃_b(X_a) / |X_ab|² per pair, for the bond-based F; None for the evolved F.
    bond_weights: Option<Vec<f64>>,
    /// The plastic history of the real particles (von Mises); None for the elastic
    /// models.
    plastic: Option<History>,
    stabilisation: Stabilisation,
    /// The pseudo-time corrector of artificial compressibility; None without.
    compressibility: Option<Corrector<D>>,
    /// The p-wave speed of the fluxes and the CFL step: c_p, or c̃_p of the fictitious
    /// bulk modulus of artificial compressibility.
    c_p: f64,
    projection: bool,
    integrator: IntegratorKind,
    /// Particle spacing Δx: the driver's CFL step is α Δx / signal speed.
    spacing: f64,
    /// C_p,ab of the CFL step.
    cfl_wave_speed: CflWaveSpeed,
    h: f64,
    boundary: Boundary<D>,
    /// Forces from outside the method (contact).
    interactions: Interactions<D>,
    /// Displacements and velocities of real particles and ghosts at the current stage.
    u_ext: Vec<D::V>,
    v_ext: Vec<D::V>,
    kin: Vec<Kinematics<D>>,
    slopes: Vec<Slopes<D>>,
    /// JST: the Laplacian ∇²v of every particle.
    lap: Vec<D::V>,
    /// The forces of the current stage, T and D(p) apart for the projection, and the
    /// positions it balances about, with its sums: kept so that a rate evaluation
    /// allocates nothing.
    forces: Vec<Forces<D>>,
    t: Vec<D::V>,
    dp: Vec<D::V>,
    /// The power of the stabilisation D(p) at the last rate evaluation, −Σ V D(p)·v.
    dissipation: f64,
    points: Vec<D::V>,
    sums: Sums<D>,
    /// State at the start of the step (u, v) and the step size, for the projection's
    /// positions 𝒳 at the second TVD-RK2 stage.
    step_start: Option<StepStart<D>>,
    stage: usize,
    /// The size of the current step.
    dt: f64,
    /// The power of supports, loads and interactions and the supports' reactions at the
    /// last rate evaluation.
    boundary_work: BoundaryWork,
}

impl<D: Dim> MixedSph<D> {
    /// Builds neighbours, corrected gradients and the per-pair weights on the reference
    /// configuration.
    pub fn new(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        let (options, stabiliser) =
            super::scheme(case).ok_or_else(|| not_run_by(case, "MixedSph"))?;
        let Reference {
            x0: x_real,
            vol: vol_real,
            mass,
            body: body_real,
            v0,
            u0,
            boundary,
            material,
            kernel,
            ..
        } = reference;
        let m = &case.method;
        let n = x_real.len();
        let radius = neighbour_radius::<D>(case);
        let ghosts = Ghosts::build(case, &x_real, &vol_real, radius)?;
        let (x0, vol) = ghosts.extend_reference(&x_real, &vol_real);
        // Real and ghost particles together: the ghosts close the real rows' lists.
        let mut csr = neighbour::build::<D>(&x0, radius);
        let mut grad = reference_gradients::<D>(case, &x0, &vol, &csr)?;
        csr.truncate(n);
        grad.truncate(csr.pair_count());
        let rev = ghosts.reverse_pairs(&csr).map_err(|a| {
            case.invalid(
                "method.h_over_dx",
                format!(
                    "particle {a} has a neighbour at the kernel support whose mirror image \
                     falls outside it by round-off; change h/dx slightly"
                ),
            )
        })?;
        let grad_rev: Vec<D::V> = rev
            .par_iter()
            .map(|&(q, image)| {
                let g = grad[q as usize];
                image.map_or(g, |m| m.reflect::<D>(g))
            })
            .collect();
        let normal: Vec<D::V> = pair_map(&csr, |i, j| {
            let d = x0[j] - x0[i];
            d * (1.0 / D::norm2(d).sqrt())
        });
        let ls = least_squares_weights::<D>(&x0, &csr, &normal).map_err(|i| {
            case.invalid(
                "method.h_over_dx",
                format!(
                    "the least-squares matrix Σ N_ab ⊗ N_ab of particle {i} is singular (its \
                 neighbours lie on a line); increase h/dx"
                ),
            )
        })?;
        let stabilisation = match stabiliser {
            Stabiliser::Jst(coefficients) => {
                let pairs = pair_map(&csr, |i, j| (i, j));
                let mut ell = brookshaw_weights::<D>(&x0, &vol, &pairs, &grad, &normal);
                if coefficients.laplacian == JstLaplacian::Corrected {
                    ell = correct_laplacian::<D>(&x0, &csr, &ell).map_err(|i| {
                        case.invalid(
                            "method.jst.laplacian",
                            format!(
                                "the Laplacian correction of particle {i} is singular; \
                                 increase h/dx or use `brookshaw`"
                            ),
                        )
                    })?;
                }
                let s = (0..pairs.len())
                    .into_par_iter()
                    .map(|q| {
                        let (i, j) = pairs[q];
                        ell[q] + vol[j] / vol[i] * ell[rev[q].0 as usize]
                    })
                    .collect();
                Stabilisation::Jst {
                    coefficients,
                    ell,
                    s,
                }
            }
            Stabiliser::Upwind { reconstruction } => Stabilisation::Upwind { reconstruction },
        };
        let bond_weights = match options.deformation_gradient {
            DeformationGradient::Evolved => None,
            DeformationGradient::BondBased => {
                let w = correction::kernel_weights::<D>(m.correction, &x0, &vol, &csr, &kernel)
                    .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
                let r2 = pair_map(&csr, |i, j| D::norm2(x0[j] - x0[i]));
                Some(w.iter().zip(&r2).map(|(w, r2)| w / r2).collect())
            }
        };
        let mut body = vec![0; x0.len()];
        ghosts.fill(&mut body, |a| body_real[a], |_, b| b);
        let interactions =
            Interactions::build(case, &x0[..n], &body, &OnPatches, &mass, || csr.clone())?;
        let n_ext = x0.len();
        let compressibility = options.artificial_compressibility.map(|spec| {
            let pairs = Pairs {
                csr: &csr,
                grad: &grad,
                grad_rev: &grad_rev,
                vol: &vol,
                ghosts: &ghosts,
                momentum: options.momentum,
            };
            Corrector::new(&spec, case, &pairs, &x0, &normal)
        });
        let c_p = match options.artificial_compressibility {
            Some(spec) => spec.p_wave_speed(&material),
            None => material.p_wave_speed(),
        };
        Ok(Self {
            kin: vec![
                Kinematics {
                    p: D::zero_t(),
                    h: D::identity(),
                    grad_v: D::zero_t(),
                    j: 1.0,
                    det_f: 1.0,
                };
                n_ext
            ],
            slopes: vec![
                Slopes {
                    grad_v: D::zero_t(),
                    grad_p: [D::zero_t(); 3],
                };
                n_ext
            ],
            lap: vec![D::zero(); n_ext],
            forces: vec![
                Forces {
                    t: D::zero(),
                    d: D::zero(),
                    dj: 0.0,
                };
                n
            ],
            t: vec![D::zero(); n],
            dp: vec![D::zero(); n],
            dissipation: 0.0,
            points: vec![D::zero(); n],
            sums: Sums::default(),
            u_ext: vec![D::zero(); n_ext],
            v_ext: vec![D::zero(); n_ext],
            n,
            ghosts,
            x0,
            vol,
            mass,
            body: body_real,
            v0,
            u0,
            csr,
            grad,
            grad_rev,
            normal,
            ls,
            material,
            conserved: options.evolved(case.material.model),
            momentum: options.momentum,
            bond_weights,
            plastic: material.von_mises().map(|model| History::virgin(model, n)),
            stabilisation,
            compressibility,
            c_p,
            projection: options.projection(case),
            integrator: m.integrator,
            spacing: case.spacing,
            cfl_wave_speed: options.cfl_wave_speed,
            h: kernel.h,
            boundary,
            interactions,
            step_start: None,
            stage: 0,
            dt: 0.0,
            boundary_work: BoundaryWork::default(),
        })
    }

    /// Neighbour lists (reference configuration).
    pub fn neighbours(&self) -> &Csr {
        &self.csr
    }

    /// Reference volumes V0 of the real particles.
    pub fn volume(&self) -> &[f64] {
        &self.vol[..self.n]
    }

    /// The F, H and J the stress of particle a is evaluated at: F evolved or the
    /// bond-based F^c (from the displacements `u_ext` of the real particles and the
    /// ghosts); H and J evolved, or cof F and det F.
    fn stress_arguments(&self, y: &MixedState<D>, a: usize, u_ext: &[D::V]) -> (D::T, D::T, f64) {
        let f = match &self.bond_weights {
            Some(w) => self.bond_based_f(a, y.f[a], u_ext, w),
            None => y.f[a],
        };
        let h = if self.conserved.evolves_h() {
            y.h[a]
        } else {
            D::cof(f)
        };
        let j = if self.evolves_j() { y.j[a] } else { D::det(f) };
        (f, h, j)
    }

    /// Whether J is evolved: as the variables say, unless artificial compressibility
    /// evolves the pressure in its place.
    pub(super) fn evolves_j(&self) -> bool {
        self.conserved.evolves_j() && self.compressibility.is_none()
    }

    /// Algorithm 2 of seed 003 for real particle a at F from its history at the start of
    /// the step; None for the elastic models.
    fn returned(&self, a: usize, f: D::T) -> Option<Returned> {
        self.plastic.as_ref().map(|pl| pl.returned::<D>(a, f))
    }

    /// Algorithm 2 for every real particle at state y from the step's history; None for
    /// the elastic models.
    fn returned_all(&self, y: &MixedState<D>) -> Option<Vec<Returned>> {
        self.plastic.as_ref()?;
        let u_ext = self.extended_displacement(&y.u);
        (0..self.n)
            .into_par_iter()
            .map(|a| {
                let (f, ..) = self.stress_arguments(y, a, &u_ext);
                self.returned(a, f)
            })
            .collect()
    }

    /// P(F, H, J) of real particle a of state y, with the evolved pressure under
    /// artificial compressibility.
    fn stress(&self, y: &MixedState<D>, a: usize, f: D::T, h: D::T, j: f64) -> D::T {
        match self.returned(a, f) {
            Some(r) => from_mat3::<D>(r.p),
            None if self.compressibility.is_some() => {
                self.material.pk1_with_pressure::<D>(f, h, j, y.pressure[a])
            }
            None => self.material.pk1_mixed::<D>(f, h, j),
        }
    }

    /// F^c_a = F_a + Σ_b V_b W̃_b(X_a) [(x_b − x_a) − F_a X_ab] ⊗ X_ab / |X_ab|²: the
    /// kernel-smoothed Breitzman–Dayal bond F with the self-bond F_aa = F_a (seed 002 eqs
    /// 37 and 39, summed with the partition of unity Σ_b V_b W̃_b = 1). Exact for affine
    /// motion: the bracket vanishes.
    /// `w` holds V_b W̃_b(X_a) / |X_ab|² per pair.
    fn bond_based_f(&self, a: usize, f: D::T, u_ext: &[D::V], w: &[f64]) -> D::T {
        let mut fc = f;
        for (b, &w) in self.csr.pairs(a, w) {
            let x_ab = self.x0[b] - self.x0[a];
            let dx = x_ab + u_ext[b] - u_ext[a];
            fc += D::outer(dx - f * x_ab, x_ab) * w;
        }
        fc
    }

    /// The corrected gradient Σ_b V_b (φ_b − φ_a) ⊗ ∇̃0W̃_b(X_a) of a field φ given at the
    /// real particles and their ghosts.
    fn gradient(&self, phi_ext: &[D::V], a: usize) -> D::T {
        let mut grad = D::zero_t();
        for (b, &g) in self.csr.pairs(a, &self.grad) {
            grad += D::outer(phi_ext[b] - phi_ext[a], g) * self.vol[b];
        }
        grad
    }

    /// F0 = I + ∇̃0u0 of the initial displacement (I where there is none), so that the
    /// evolved F starts as the gradient of the initial motion.
    fn initial_deformation_gradient(&self) -> Vec<D::T> {
        let mut u_ext = vec![D::zero(); self.x0.len()];
        fill_extended(&self.ghosts, &mut u_ext, &self.u0);
        (0..self.n)
            .into_par_iter()
            .map(|a| D::identity() + self.gradient(&u_ext, a))
            .collect()
    }

    /// Displacements of the real particles and the ghosts, when the bond-based F needs
    /// them outside a rate evaluation (outputs); empty otherwise.
    fn extended_displacement(&self, u: &[D::V]) -> Vec<D::V> {
        if self.bond_weights.is_none() {
            return Vec::new();
        }
        let mut u_ext = vec![D::zero(); self.x0.len()];
        fill_extended(&self.ghosts, &mut u_ext, u);
        u_ext
    }

    fn blow_up(&self, i: usize, quantity: &str, value: f64) -> BlowUp {
        BlowUp::at::<D>(&self.x0, i, quantity, value)
    }

    /// u and v of the real particles and their ghosts.
    fn extend_motion(&mut self, y: &MixedState<D>) {
        fill_extended(&self.ghosts, &mut self.u_ext, &y.u);
        fill_extended(&self.ghosts, &mut self.v_ext, &y.v);
    }

    /// Pass 1: P(F, H, J) and the corrected velocity gradient of every particle.
    fn kinematics(&mut self, y: &MixedState<D>) -> Result<(), BlowUp> {
        self.extend_motion(y);
        let mut kin = std::mem::take(&mut self.kin);
        let kinematics = |a: usize| {
            let (f, h, j) = self.stress_arguments(y, a, &self.u_ext);
            Kinematics {
                p: self.stress(y, a, f, h, j),
                h,
                grad_v: self.gradient(&self.v_ext, a),
                j,
                det_f: D::det(f),
            }
        };
        self.ghosts.fill(&mut kin, kinematics, |m, k| Kinematics {
            p: m.tensor::<D>(k.p),
            h: m.unit_tensor::<D>(k.h),
            grad_v: m.tensor::<D>(k.grad_v),
            j: m.unit_scalar(k.j),
            det_f: m.unit_scalar(k.det_f),
        });
        self.kin = kin;
        let bad = self.kin[..self.n]
            .par_iter()
            .position_first(|k| !(k.j > 0.0 && k.det_f > 0.0));
        match bad {
            Some(a) if self.kin[a].det_f > 0.0 => Err(self.blow_up(a, "J", self.kin[a].j)),
            Some(a) => Err(self.blow_up(a, "det F", self.kin[a].det_f)),
            None => Ok(()),
        }
    }

    /// Pass 2 (Upwind-SPH with reconstruction): least-squares slopes of v and P.
    fn slopes(&mut self) {
        let mut slopes = std::mem::take(&mut self.slopes);
        let least_squares = |a: usize| {
            let mut grad_v = D::zero_t();
            let mut grad_p = [D::zero_t(); 3];
            let pa = self.kin[a].p;
            for (b, &w) in self.csr.pairs(a, &self.ls) {
                grad_v += D::outer(self.v_ext[b] - self.v_ext[a], w);
                let dp = self.kin[b].p - pa;
                for (l, g) in grad_p.iter_mut().enumerate().take(D::N) {
                    *g += dp * D::comp(w, l);
                }
            }
            Slopes { grad_v, grad_p }
        };
        // ∂P'/∂X'_l = r_l σ R (∂P/∂X_l) R.
        self.ghosts.fill(&mut slopes, least_squares, |m, s| Slopes {
            grad_v: m.tensor::<D>(s.grad_v),
            grad_p: std::array::from_fn(|l| {
                let sign = if l < D::N { m.axis_sign(l) } else { 0.0 };
                m.tensor::<D>(s.grad_p[l]) * sign
            }),
        });
        self.slopes = slopes;
    }

    /// Pass 2 (JST-SPH): ∇²v_a = Σ_b ℓ_ab (v_b − v_a) (seed 002 eq 27).
    fn laplacians(&mut self) {
        let Stabilisation::Jst { ell, .. } = &self.stabilisation else {
            return;
        };
        let mut lap = std::mem::take(&mut self.lap);
        let laplacian = |a: usize| {
            let mut sum = D::zero();
            for (b, &ell) in self.csr.pairs(a, ell) {
                sum += (self.v_ext[b] - self.v_ext[a]) * ell;
            }
            sum
        };
        self.ghosts
            .fill(&mut lap, laplacian, |m, l| m.vector::<D>(l));
        self.lap = lap;
    }

    /// Pass 3: the internal force, the stabilisation of p and the dissipation of J of
    /// every real particle, into `out`.
    fn forces(&self, y: &MixedState<D>, out: &mut [Forces<D>]) {
        let mat = &self.material;
        let (c_p, c_s) = (self.c_p, mat.s_wave_speed());
        // Artificial compressibility leaves D(J) out: in the corrector's constraint it is a
        // compact Laplacian of P that the wide DIV of the pair sums cannot balance, and it
        // grows the pressure checkerboard (docs/methods/mixed.md).
        let dissipates_j = self.compressibility.is_none();
        // JST's ε⁽²⁾h, ε⁽⁴⁾h³ and ½ c_p ρ0 of eq 26, once for all pairs.
        let (e2_h, e4_h3, jst_scale) = match &self.stabilisation {
            Stabilisation::Jst { coefficients, .. } => (
                coefficients.eps2 * self.h,
                coefficients.eps4 * self.h.powi(3),
                0.5 * c_p * mat.rho0,
            ),
            Stabilisation::Upwind { .. } => (0.0, 0.0, 0.0),
        };
        let (u, v) = (&self.u_ext, &self.v_ext);
        out.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(a, out)| {
                let ka = self.kin[a];
                let xa = self.x0[a] + y.u[a];
                let mut t = D::zero();
                let mut d = D::zero();
                let mut dj = 0.0;
                let row = self.csr.range(a);
                let pairs = self
                    .csr
                    .pairs(a, &self.grad)
                    .zip(&self.grad_rev[row.clone()]);
                for (q, ((b, &g_ab), &g_ba)) in row.zip(pairs) {
                    let kb = self.kin[b];
                    t += pair_force::<D>(self.momentum, self.vol[b], ka.p, kb.p, g_ab, g_ba);
                    match &self.stabilisation {
                        Stabilisation::Upwind { reconstruction } => {
                            let n_ref = self.normal[q];
                            let (mut dv, mut dp) = (v[b] - v[a], kb.p - ka.p);
                            if *reconstruction {
                                // eq 37: faces at the mid-pair, p_f⁻ from a, p_f⁺ from b.
                                let d_ab = self.x0[b] - self.x0[a];
                                let (va, pa) = self.slopes[a].along(d_ab, 0.5);
                                let (vb, pb) = self.slopes[b].along(d_ab, -0.5);
                                dv = dv + vb - va;
                                dp = dp + pb - pa;
                            }
                            let x_ab = self.x0[b] + u[b] - xa;
                            let n = x_ab * (1.0 / D::norm2(x_ab).sqrt());
                            // eq 28: S^p Δp = ½[c_p n (n·Δp) + c_s (Δp − n (n·Δp))].
                            let dp_mom = dv * mat.rho0;
                            let normal_part = n * D::dot(n, dp_mom);
                            let s_dp = (normal_part * c_p + (dp_mom - normal_part) * c_s) * 0.5;
                            // eq 32: 2 V_b (S^p Δp)(N_ab · ∇̃W̃^Ave_b(X_a)).
                            let g_ave = (g_ab - g_ba) * 0.5;
                            d += s_dp * (2.0 * self.vol[b] * D::dot(n_ref, g_ave));
                            // eq 28: p^stab = n (n · ΔP N_ab)/(2 c_p); eq 33 with the
                            // dissipative sign: V_b p^stab/ρ0 · (H_a g_ab − H_b g_ba).
                            if dissipates_j {
                                let p_stab = n * (D::dot(n, dp * n_ref) / (2.0 * c_p));
                                let h_g = ka.h * g_ab - kb.h * g_ba;
                                dj += self.vol[b] / mat.rho0 * D::dot(p_stab, h_g);
                            }
                        }
                        Stabilisation::Jst { s, .. } => {
                            let lap = self.lap[b] - self.lap[a];
                            let dv = v[b] - v[a];
                            d += (dv * e2_h - lap * e4_h3) * (jst_scale * s[q]);
                        }
                    }
                }
                *out = Forces { t, d, dj };
            });
    }

    /// Positions 𝒳_a about which angular momentum is balanced (eq B.1): the stage
    /// positions, and x^n + Δt/2 (v^n + v*) = x^{n+1} at the second TVD-RK2 stage, which
    /// makes the step conserve angular momentum exactly.
    fn balance_points(&self, y: &MixedState<D>, out: &mut [D::V]) {
        let points = out.par_iter_mut().with_min_len(MIN_CHUNK).enumerate();
        match (&self.step_start, self.stage) {
            (Some((u0, v0, dt)), 1) if self.integrator == IntegratorKind::TvdRk2 => {
                points.for_each(|(a, x)| *x = self.x0[a] + u0[a] + (v0[a] + y.v[a]) * (0.5 * dt))
            }
            _ => points.for_each(|(a, x)| *x = self.x0[a] + y.u[a]),
        }
    }

    /// The parts of the rates at state y before projection and boundary conditions:
    /// the internal force T_a, the stabilisation D(p_a) (both per unit reference volume)
    /// and the J dissipation D(J_a).
    pub fn fluxes(&mut self, y: &MixedState<D>) -> Result<Fluxes<D>, BlowUp> {
        self.prepare(y)?;
        let mut forces = std::mem::take(&mut self.forces);
        self.forces(y, &mut forces);
        self.forces = forces;
        let forces = &self.forces;
        Ok(Fluxes {
            t: forces.iter().map(|f| f.t).collect(),
            d: forces.iter().map(|f| f.d).collect(),
            dj: forces.iter().map(|f| f.dj).collect(),
        })
    }

    /// Passes 1 and 2: stresses, velocity gradients and the slopes or Laplacians the
    /// stabilisation reads.
    fn prepare(&mut self, y: &MixedState<D>) -> Result<(), BlowUp> {
        self.kinematics(y)?;
        match self.stabilisation {
            Stabilisation::Upwind {
                reconstruction: true,
            } => self.slopes(),
            Stabilisation::Jst { .. } => self.laplacians(),
            Stabilisation::Upwind { .. } => {}
        }
        Ok(())
    }

    /// Artificial compressibility: the pressure rate of the predictor and the corrector
    /// of the stage (eqs 51d, 52–58, without D(J)) on the rates `d` of the explicit stage, before loads
    /// and supports. v^int and p^int are the predictor's stage ends, loads, contact and
    /// supports included; the converged pressure's force −T[(p^{n+1} − p^n)H^n] is
    /// added to v̇ (projected with the stage's other forces), and ṗ = (p^{n+1} − p^n)/Δt.
    fn correct(&mut self, y: &MixedState<D>, d: &mut MixedState<D>) -> Result<(), BlowUp> {
        let mut corrector = self
            .compressibility
            .take()
            .expect("correct runs with artificial compressibility");
        let (n, dt) = (self.n, self.dt);
        let kappa_tilde = corrector.kappa_tilde();
        // eq 51d without D(J): (p^int − p^n)/Δt = κ̃ H^n : ∇0v^n.
        d.pressure
            .par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(&self.kin[..n])
            .for_each(|(p, k)| *p = kappa_tilde * D::ddot(k.h, k.grad_v));
        let mut b = std::mem::take(&mut corrector.buffers);
        b.p_int.clear();
        b.p_int
            .extend((0..n).map(|a| y.pressure[a] + dt * d.pressure[a]));
        b.a_int.clone_from(&d.v);
        b.work.finish(
            &self.interactions,
            &self.boundary,
            &y.v,
            &self.mass,
            &mut b.a_int,
        );
        b.v_int.clear();
        b.v_int.extend((0..n).map(|a| y.v[a] + b.a_int[a] * dt));
        b.held.clear();
        b.held.resize(n, 0);
        for (i, mask) in self.boundary.held_now() {
            b.held[i as usize] = mask;
        }
        b.h.clear();
        b.h.extend(self.kin[..n].iter().map(|k| k.h));
        let stage = StageStart {
            dt,
            v_int: &b.v_int,
            v_n: &y.v,
            p_n: &y.pressure,
            p_int: &b.p_int,
            h: &b.h,
            held: &b.held,
        };
        let pairs = Pairs {
            csr: &self.csr,
            grad: &self.grad,
            grad_rev: &self.grad_rev,
            vol: &self.vol,
            ghosts: &self.ghosts,
            momentum: self.momentum,
        };
        let solved = corrector
            .solve(&pairs, &stage)
            .map_err(|u| self.blow_up(u.particle, UNCONVERGED, u.residual));
        if solved.is_ok() {
            // The corrector's force, into the predictor's stage ends' array.
            let force = &mut b.a_int;
            corrector.force(&pairs, force);
            if self.projection {
                let balance = Balance::<D>::new(&self.points, &self.vol[..n], &mut self.sums);
                balance.project(force, &mut self.sums);
            }
            let inv_rho0 = 1.0 / self.material.rho0;
            let p_next = corrector.p();
            for a in 0..n {
                d.v[a] += force[a] * inv_rho0;
                d.pressure[a] = (p_next[a] - y.pressure[a]) / dt;
            }
        }
        corrector.buffers = b;
        self.compressibility = Some(corrector);
        solved
    }

    /// Δx max_ab C_p,ab / r_ab over the neighbour pairs of real particles (seed 002 eqs
    /// 31–32): the speed that crosses the spacing Δx in the shortest time r_ab / C_p,ab
    /// a wave takes across a pair, r_ab = |x_b − x_a| the current distance.
    ///
    /// Pairs with a ghost do not count: a ghost is no material point, and counting it
    /// could only lower Δt through the mirror construction. Across a symmetry plane the
    /// image b' of b is no nearer to a than b is (|x_a − x_b'| ≥ |x_a − x_b| for a and b
    /// on the body's side, likewise in the reference, so (a, b) is a pair too) and
    /// λ_b' = λ_b; only a particle's pair with its own image would add a rate, at twice
    /// its distance to the plane: Δx at rest on a cell-centred lattice, and for a locally
    /// affine motion stretched as the real pairs along the plane's normal are. Across a
    /// skew-symmetric plane the image carries −u along the plane, and its distance to a is
    /// no distance in the body.
    ///
    /// With [`CflWaveSpeed::Linear`] every pair has C_p,ab = C_p^Lin.
    pub fn pair_wave_speed(&self, y: &MixedState<D>) -> f64 {
        // λ_a: the smallest principal stretch, sqrt of the smallest eigenvalue of C_a;
        // 1 for C_p^Lin.
        let stretch: Vec<f64> = match self.cfl_wave_speed {
            CflWaveSpeed::Pair => {
                y.f.par_iter()
                    .map(|&f| smallest_stretch_squared::<D>(f).sqrt())
                    .collect()
            }
            CflWaveSpeed::Linear => vec![1.0; self.n],
        };
        let c_p = self.c_p;
        let fastest = (0..self.n)
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|a| {
                let xa = self.x0[a] + y.u[a];
                self.csr
                    .neighbours(a)
                    .iter()
                    .map(|&b| b as usize)
                    .filter(|&b| b < self.n)
                    .map(|b| {
                        let r_ab = D::norm2(self.x0[b] + y.u[b] - xa).sqrt();
                        // eq 32: C_p,ab = C_p^Lin / λ^Ave_ab, λ^Ave_ab = ½(λ_a + λ_b).
                        let c_ab = c_p / (0.5 * (stretch[a] + stretch[b]));
                        c_ab / r_ab
                    })
                    .fold(0.0, f64::max)
            })
            .reduce(|| 0.0, f64::max);
        self.spacing * fastest
    }

    /// First Piola–Kirchhoff stress of every particle.
    pub fn first_piola(&mut self, y: &MixedState<D>) -> Result<Vec<D::T>, BlowUp> {
        self.kinematics(y)?;
        Ok(self.kin.iter().map(|k| k.p).collect())
    }
}

/// Pair b's share of the internal force T_a (per unit reference volume) of the stresses
/// P_a, P_b with g_ab = ∇̃W̃_b(X_a), g_ba = ∇̃W̃_a(X_b).
pub(super) fn pair_force<D: Dim>(
    momentum: Momentum,
    vol_b: f64,
    p_a: D::T,
    p_b: D::T,
    g_ab: D::V,
    g_ba: D::V,
) -> D::V {
    match momentum {
        // seed 003 eq 21: V_b [P_b ∇̃W̃_a(X_b) − P_a ∇̃W̃_b(X_a)].
        Momentum::Weak => (p_b * g_ba - p_a * g_ab) * vol_b,
        // seed 002 eq 22: −½ V_b (P_a + P_b)(∇W̃_b(X_a) − ∇W̃_a(X_b)).
        Momentum::Symmetrised => (p_a + p_b) * (g_ab - g_ba) * (-0.5 * vol_b),
    }
}

/// `real` into out[..n] and the ghosts' images σR v into the rest.
fn fill_extended<D: Dim>(ghosts: &Ghosts<D>, out: &mut [D::V], real: &[D::V]) {
    ghosts.fill(out, |a| real[a], |m, v| m.vector::<D>(v));
}

impl<D: Dim> OdeSystem for MixedSph<D> {
    type State = MixedState<D>;
    type Error = BlowUp;

    fn begin_step(&mut self, t: f64, dt: f64, y: &MixedState<D>) {
        self.stage = 0;
        self.boundary.begin_step(t, dt);
        self.interactions
            .begin_step(t, dt, &self.x0[..self.n], &y.u, &y.v);
        // The plastic history is committed once per step, from the state at its start.
        if let Some(committed) = self.returned_all(y)
            && let Some(pl) = self.plastic.as_mut()
        {
            pl.commit(&committed, &self.vol[..self.n]);
        }
        if self.projection && self.integrator == IntegratorKind::TvdRk2 {
            self.step_start = Some((y.u.clone(), y.v.clone(), dt));
        }
        self.dt = dt;
        if let Some(c) = self.compressibility.as_mut() {
            c.begin_step();
        }
    }

    fn rates(&mut self, _t: f64, y: &MixedState<D>, d: &mut MixedState<D>) -> Result<(), BlowUp> {
        self.prepare(y)?;
        let mut forces = std::mem::take(&mut self.forces);
        self.forces(y, &mut forces);
        let (mut t, mut dp) = (std::mem::take(&mut self.t), std::mem::take(&mut self.dp));
        if self.projection {
            t.par_iter_mut()
                .with_min_len(MIN_CHUNK)
                .zip(dp.par_iter_mut())
                .zip(&forces)
                .for_each(|((t, dp), f)| (*t, *dp) = (f.t, f.d));
            let mut points = std::mem::take(&mut self.points);
            self.balance_points(y, &mut points);
            let balance = Balance::<D>::new(&points, &self.vol[..self.n], &mut self.sums);
            balance.project(&mut t, &mut self.sums);
            balance.project(&mut dp, &mut self.sums);
            self.points = points;
        }
        self.stage += 1;
        let inv_rho0 = 1.0 / self.material.rho0;
        let projected = self.projection;
        // eq 38a: dp/dt = −T + D(p) (the state holds v = p/ρ0); u̇ = v; eq 39b: Ḟ = ∇0v.
        d.v.par_iter_mut()
            .zip(d.u.par_iter_mut())
            .zip(d.f.par_iter_mut())
            .enumerate()
            .with_min_len(MIN_CHUNK)
            .for_each(|(a, ((v_dot, u_dot), f_dot))| {
                let (t_a, dp_a) = if projected {
                    (t[a], dp[a])
                } else {
                    (forces[a].t, forces[a].d)
                };
                *v_dot = (dp_a - t_a) * inv_rho0;
                *u_dot = y.v[a];
                *f_dot = self.kin[a].grad_v;
            });
        // The stabilisation's power on the bodies, Σ_a V_a D(p_a)·v_a (D per unit reference
        // volume, m_a = ρ0 V_a): minus the power the balance books as dissipated. D(J) acts
        // on J, not on the momentum, and stays in the residue (docs/methods/mixed.md).
        // A serial sum in particle order: deterministic, and without the chunks' buffer
        // that a parallel ordered reduction allocates at every rate evaluation.
        let stabilisation = |a: usize| if projected { dp[a] } else { forces[a].d };
        let power: f64 = (0..self.n)
            .map(|a| self.vol[a] * D::dot(stabilisation(a), y.v[a]))
            .sum();
        self.dissipation = -power;
        // eqs 38c–d in the difference form 39c–d.
        if self.conserved.evolves_h() {
            d.h.par_iter_mut()
                .with_min_len(MIN_CHUNK)
                .enumerate()
                .for_each(|(a, h)| *h = D::cof_rate(y.f[a], self.kin[a].grad_v));
        }
        if self.evolves_j() {
            d.j.par_iter_mut()
                .with_min_len(MIN_CHUNK)
                .enumerate()
                .for_each(|(a, j)| {
                    let k = self.kin[a];
                    *j = D::ddot(k.h, k.grad_v) + forces[a].dj;
                });
        }
        (self.forces, self.t, self.dp) = (forces, t, dp);
        if self.compressibility.is_some() {
            self.correct(y, d)?;
        }
        self.boundary_work.finish(
            &self.interactions,
            &self.boundary,
            &y.v,
            &self.mass,
            &mut d.v,
        );
        Ok(())
    }
}

impl<D: Dim> Method<D> for MixedSph<D> {
    fn build(case: &Case, reference: Reference<D>) -> Result<Self, CaseError> {
        Self::new(case, reference)
    }

    fn initial_state(&self) -> MixedState<D> {
        let n = self.n;
        let f = self.initial_deformation_gradient();
        MixedState {
            u: self.u0.clone(),
            v: self.v0.clone(),
            h: if self.conserved.evolves_h() {
                f.iter().map(|&f| D::cof(f)).collect()
            } else {
                Vec::new()
            },
            j: if self.evolves_j() {
                f.iter().map(|&f| D::det(f)).collect()
            } else {
                Vec::new()
            },
            f,
            pressure: if self.compressibility.is_some() {
                vec![0.0; n]
            } else {
                Vec::new()
            },
        }
    }

    fn displacement<'a>(&self, y: &'a MixedState<D>) -> &'a [D::V] {
        &y.u
    }

    fn velocity<'a>(&self, y: &'a MixedState<D>) -> &'a [D::V] {
        &y.v
    }

    fn reference(&self) -> &[D::V] {
        &self.x0[..self.n]
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

    fn deformation_gradient(&self, y: &MixedState<D>) -> Vec<D::T> {
        y.f.clone()
    }

    /// σ = J⁻¹ P Fᵀ with the method's J (2D: σ_zz of plane strain from F).
    fn cauchy_stress(&self, y: &MixedState<D>) -> Vec<[[f64; 3]; 3]> {
        let mat = &self.material;
        let u_ext = self.extended_displacement(&y.u);
        (0..self.n)
            .into_par_iter()
            .map(|a| {
                let (f, h, j) = self.stress_arguments(y, a, &u_ext);
                if let Some(r) = self.returned(a, f) {
                    return r.cauchy::<D>(f);
                }
                let sigma = self.stress(y, a, f, h, j) * D::transpose(f) * (1.0 / j);
                let mut out = D::to3x3(sigma);
                if D::N == 2 {
                    out[2][2] = match self.compressibility {
                        Some(_) => mat.sigma_zz_with_pressure::<D>(f, y.pressure[a]),
                        None => mat.sigma_zz::<D>(f, D::zero_t(), mat.rho0),
                    };
                }
                out
            })
            .collect()
    }

    fn strain_energy(&self, y: &MixedState<D>) -> f64 {
        let u_ext = self.extended_displacement(&y.u);
        ordered_reduce(
            self.n,
            || 0.0,
            |a| {
                let (f, _, j) = self.stress_arguments(y, a, &u_ext);
                self.vol[a]
                    * match self.returned(a, f) {
                        Some(r) => r.psi,
                        // ψ = ψ_iso + p²/(2κ): no volumetric energy at κ = ∞.
                        None if self.compressibility.is_some() => {
                            self.material.isochoric_energy_density::<D>(f, j)
                                + y.pressure[a].powi(2) / (2.0 * self.material.bulk)
                        }
                        None => self.material.energy_density_mixed::<D>(f, j),
                    }
            },
            |x, y| x + y,
        )
    }

    fn dissipation_power(&self) -> f64 {
        self.dissipation
    }

    /// The committed plastic work and the current step's, over the reference volumes.
    fn plastic_work(&self, y: &MixedState<D>) -> f64 {
        let Some(pl) = &self.plastic else {
            return 0.0;
        };
        self.returned_all(y)
            .map_or(0.0, |r| pl.work_at(&r, &self.vol[..self.n]))
    }

    fn snapshot<'a>(&'a self, y: &MixedState<D>) -> Snapshot<'a, D> {
        Snapshot {
            x0: &self.x0[..self.n],
            mass: &self.mass,
            body: &self.body,
            u: y.u.clone(),
            v: y.v.clone(),
            f: y.f.clone(),
            sigma: self.cauchy_stress(y),
            strain_energy: self.strain_energy(y),
            extra: self
                .returned_all(y)
                .map(|r| ScalarField {
                    name: PLASTIC_STRAIN,
                    values: r.iter().map(|r| r.eps_p).collect(),
                })
                .into_iter()
                .collect(),
            cells: &[],
            quadrature: None,
        }
    }

    /// Δx max_ab C_p,ab / r_ab + max |v| ([`MixedSph::pair_wave_speed`]): with v = 0 the
    /// driver's Δt = α Δx / signal speed is seed 002 eq 31, α min_ab r_ab / C_p,ab.
    fn max_signal_speed(&self, y: &MixedState<D>) -> f64 {
        let v2_max =
            y.v.par_iter()
                .map(|&v| D::norm2(v))
                .reduce(|| 0.0, f64::max);
        self.pair_wave_speed(y) + v2_max.sqrt()
    }

    fn boundary_work(&self) -> &BoundaryWork {
        &self.boundary_work
    }

    fn pseudo_time(&self) -> Option<PseudoTime> {
        self.compressibility.as_ref().map(|c| c.stats)
    }

    fn pairs(&self) -> usize {
        self.csr.pair_count()
    }

    /// Two copies extend u and v to the ghosts. Pass 1 reads F, v, V (H, J, p when
    /// evolved; X and u with the bond-based F; C_p⁻¹, ε_p when plastic) and writes the
    /// kinematics, which the admissibility check reads again; pass 2 reads v and writes
    /// ∇²v (JST), or also reads the kinematics and writes the slopes (reconstruction);
    /// pass 3 reads the kinematics, X, u, v, V (the slopes or ∇²v) and writes the forces.
    /// The projection splits them into T and D(p) and moves its points, V and both
    /// fields; one pass then reads the forces (or the projected T and D(p)), v and the
    /// kinematics and writes v̇, u̇ and Ḟ, and others Ḣ and J̇. Per pair:
    /// the ids and g_ab (w_ab) in pass 1, the ids and least-squares weights or ℓ_ab in
    /// pass 2, the ids, g_ab, g_ba and N_ab or s_ab in pass 3. Real particles only: the
    /// ghosts' records, the TVD-RK2 balance points and the pseudo-time corrector are left
    /// out.
    fn traffic(&self) -> Option<Traffic> {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let (kin, slopes, forces) = (
            size_of::<Kinematics<D>>(),
            size_of::<Slopes<D>>(),
            size_of::<Forces<D>>(),
        );
        let when = |on: bool, bytes: usize| if on { bytes } else { 0 };
        let (upwind, reconstruction, jst) = match self.stabilisation {
            Stabilisation::Upwind { reconstruction } => (true, reconstruction, false),
            Stabilisation::Jst { .. } => (false, false, true),
        };
        let (evolves_h, evolves_j) = (self.conserved.evolves_h(), self.evolves_j());
        let pressure = self.compressibility.is_some();
        let bond = self.bond_weights.is_some();
        let extend = 4 * v;
        let pass_1 = t
            + v
            + f
            + 2 * kin
            + when(evolves_h, t)
            + when(evolves_j, f)
            + when(pressure, f)
            + when(bond, 2 * v)
            + Sizes::plastic_history(self.plastic.is_some());
        let pass_2 = when(reconstruction, kin + v + slopes) + when(jst, 2 * v);
        let pass_3 = kin
            + 3 * v
            + f
            + forces
            + when(upwind, v)
            + when(reconstruction, slopes)
            + when(jst, v);
        let projection = when(self.projection, forces + 2 * v + 15 * v + 5 * f);
        let stage_forces = if self.projection { 2 * v } else { forces };
        let rates = stage_forces
            + v
            + kin
            + 2 * v
            + t
            + when(evolves_h, 2 * t + kin)
            + when(evolves_j, kin + forces + f);
        let per_pair = (id + v + when(bond, f))
            + when(reconstruction, id + v)
            + when(jst, id + f)
            + (id + 2 * v + when(upwind, v) + when(jst, f));
        let state = 2 * v + t + when(evolves_h, t) + when(evolves_j, f) + when(pressure, f);
        Some(Traffic {
            per_particle: (extend + pass_1 + pass_2 + pass_3 + projection + rates) as f64,
            per_pair: per_pair as f64,
            state: state as f64,
            velocity: v as f64,
        })
    }

    fn check_finite(&self, y: &MixedState<D>) -> Result<(), BlowUp> {
        check_motion::<D>(&self.x0, &y.u, &y.v)?;
        let norm_t = |t: D::T| D::ddot(t, t).sqrt();
        if let Some(i) = y.f.par_iter().position_first(|&f| !D::is_finite_t(f)) {
            return Err(self.blow_up(i, "|F|", norm_t(y.f[i])));
        }
        if let Some(i) = y.h.par_iter().position_first(|&h| !D::is_finite_t(h)) {
            return Err(self.blow_up(i, "|H|", norm_t(y.h[i])));
        }
        if let Some(i) = y.j.par_iter().position_first(|j| !j.is_finite()) {
            return Err(self.blow_up(i, "J", y.j[i]));
        }
        if let Some(i) = y.pressure.par_iter().position_first(|p| !p.is_finite()) {
            return Err(self.blow_up(i, "pressure", y.pressure[i]));
        }
        Ok(())
    }

    /// The plastic history C_p⁻¹, ε_p of a `von-mises-plastic` material.
    fn save_history(&self, out: &mut Vec<f64>) {
        History::save(self.plastic.as_ref(), out);
    }

    fn load_history(&mut self, words: &mut &[f64]) -> Result<(), String> {
        History::load(self.plastic.as_mut(), words)
    }
}

/// Read access to the reference set-up, for the GPU engine ([`super::gpu`]).
#[cfg(feature = "gpu")]
impl<D: Dim> MixedSph<D> {
    pub(crate) fn ghosts(&self) -> &Ghosts<D> {
        &self.ghosts
    }

    /// Reference positions and volumes of the real particles, then the ghosts.
    pub(crate) fn extended_reference(&self) -> (&[D::V], &[f64]) {
        (&self.x0, &self.vol)
    }

    /// g_ab and g_ba, CSR order.
    pub(crate) fn pair_gradients(&self) -> (&[D::V], &[D::V]) {
        (&self.grad, &self.grad_rev)
    }

    /// Least-squares weights M_a⁻¹ N_ab / |d_ab|, CSR order.
    pub(crate) fn ls_weights(&self) -> &[D::V] {
        &self.ls
    }

    /// Upwind-SPH: whether p and P are reconstructed to the mid-pair.
    pub(crate) fn reconstruction(&self) -> bool {
        matches!(
            self.stabilisation,
            Stabilisation::Upwind {
                reconstruction: true
            }
        )
    }

    /// JST-SPH: the coefficients and the per-pair ℓ_ab and s_ab.
    pub(crate) fn jst(&self) -> Option<(super::Jst, &[f64], &[f64])> {
        match &self.stabilisation {
            Stabilisation::Jst {
                coefficients,
                ell,
                s,
            } => Some((*coefficients, ell, s)),
            Stabilisation::Upwind { .. } => None,
        }
    }

    /// The bond-based F: w_ab = V_b W̃_b(X_a) / |X_ab|² per pair, CSR order.
    pub(crate) fn bond_weights(&self) -> Option<&[f64]> {
        self.bond_weights.as_deref()
    }

    pub(crate) fn momentum(&self) -> Momentum {
        self.momentum
    }

    pub(crate) fn material(&self) -> &Material {
        &self.material
    }

    pub(crate) fn conserved(&self) -> Conserved {
        self.conserved
    }

    pub(crate) fn projection(&self) -> bool {
        self.projection
    }

    /// The plastic history, for the GPU engine to replace by its own before a snapshot.
    pub(crate) fn plastic_mut(&mut self) -> Option<&mut History> {
        self.plastic.as_mut()
    }

    /// The pseudo-time corrector of artificial compressibility; None without.
    pub(super) fn corrector(&self) -> Option<&Corrector<D>> {
        self.compressibility.as_ref()
    }

    pub(crate) fn cfl_wave_speed(&self) -> CflWaveSpeed {
        self.cfl_wave_speed
    }

    pub(crate) fn boundary(&self) -> &Boundary<D> {
        &self.boundary
    }

    pub(crate) fn interactions(&self) -> &Interactions<D> {
        &self.interactions
    }

    pub(crate) fn smoothing_length(&self) -> f64 {
        self.h
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::MethodSpec;
    use crate::tensor::{D2, D3};

    /// A shipped case.
    fn shipped(name: &str) -> Case {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("cases")
            .join(format!("{name}.toml"));
        Case::load(&path, &[]).unwrap()
    }

    /// The driver's CFL step α Δx / signal speed of a case's lattice at rest with the
    /// uniform stretch F = diag(s) (u = (F − I) X), against seed 002 eq 31 in closed form:
    /// every particle has λ = λ_min = min s, so Δt = α min |F X_ab| λ_min / c_p over the
    /// lattice bonds X_ab = Δx k (k integer, 0 < |X_ab| ≤ the kernel support). Then one
    /// particle alone stretched to F = diag(s) at u = 0: its pairs with the nearest
    /// neighbours give Δt = α Δx ½(λ_min + 1) / c_p, the pair average of eq 32 (a
    /// per-particle λ²_min would give α Δx λ²_min / c_p). With C_p^Lin for every pair the
    /// stretches drop out: λ is 1 in both. Round-off of the distances and the eigenvalue:
    /// 1e-12.
    fn check_stretched_step<D: Dim>(case: &Case, s: [f64; 3], wave: CflWaveSpeed) {
        let mut case = case.clone();
        match &mut case.method.spec {
            MethodSpec::UpwindSph(s) => s.mixed.cfl_wave_speed = wave,
            MethodSpec::JstSph(s) => s.mixed.cfl_wave_speed = wave,
            _ => panic!("{} is not a mixed case", case.name),
        }
        let case = &case;
        let m: MixedSph<D> = crate::run::build_method(case).unwrap();
        let (alpha, dx) = (case.method.cfl.unwrap(), case.spacing);
        let c_p = m.material.p_wave_speed();
        let axis = |k: usize| {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            D::from_slice(&e[..D::N])
        };
        let f = (0..D::N).fold(D::zero_t(), |f, k| f + D::outer(axis(k), axis(k)) * s[k]);
        let lambda_min = match wave {
            CflWaveSpeed::Pair => s[..D::N].iter().copied().fold(f64::INFINITY, f64::min),
            CflWaveSpeed::Linear => 1.0,
        };
        let step = |y: &MixedState<D>| alpha * dx / m.max_signal_speed(y);
        let check = |what: &str, dt: f64, exact: f64| {
            let deviation = (dt / exact - 1.0).abs();
            eprintln!(
                "{}D {what}, {wave:?}: Δt = {dt:e} s ({deviation:.1e} from eq 31)",
                D::N
            );
            assert!(
                deviation < 1e-12,
                "{}D {what}, {wave:?}: Δt = {dt:e} s, eq 31 gives {exact:e} s",
                D::N
            );
        };

        let mut y = m.initial_state();
        for a in 0..m.n {
            y.u[a] = f * m.x0[a] - m.x0[a];
            y.v[a] = D::zero();
            y.f[a] = f;
        }
        let support = case.kernel(D::N).support();
        let reach = (support / dx) as i64;
        let side = 2 * reach + 1;
        let shortest = (0..side.pow(D::N as u32))
            .filter_map(|cell| {
                let k: Vec<f64> = (0..D::N as u32)
                    .map(|l| (cell / side.pow(l) % side - reach) as f64 * dx)
                    .collect();
                let x_ab = D::from_slice(&k);
                let r0 = D::norm2(x_ab).sqrt();
                (r0 > 0.0 && r0 <= support).then(|| D::norm2(f * x_ab).sqrt())
            })
            .fold(f64::INFINITY, f64::min);
        check(
            "uniform stretch",
            step(&y),
            alpha * shortest * lambda_min / c_p,
        );

        let mut y = m.initial_state();
        y.v.fill(D::zero());
        y.f[m.n / 2] = f;
        check(
            "one stretched particle",
            step(&y),
            alpha * dx * 0.5 * (lambda_min + 1.0) / c_p,
        );
    }

    #[test]
    fn the_cfl_step_is_the_shortest_pair_crossing_of_eq_31() {
        for wave in [CflWaveSpeed::Pair, CflWaveSpeed::Linear] {
            check_stretched_step::<D2>(&shipped("spinning-plate"), [1.3, 0.7, 1.0], wave);
            check_stretched_step::<D3>(&shipped("pulling-column"), [0.8, 1.5, 0.6], wave);
        }
    }
}
