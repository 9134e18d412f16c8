//! Mixed total-Lagrangian SPH on the conservation laws of {p, F, H, J} (seed 003):
//! Upwind-SPH (acoustic Riemann stabilisation with linear reconstruction), JST-SPH
//! (Jameson–Schmidt–Turkel dissipation on p) and SUPG-SPH (residuals at stress points),
//! with the angular-momentum-preserving projection of Appendix B.
//!
//! The state holds u = x − X, v = p/ρ0 (ρ0 is uniform, so this is p up to a constant),
//! F and, per variant, H and J. Neighbours, corrected gradients G_b(X_a) = V_b ∇̃0W̃_b(X_a)
//! and every per-pair weight are computed once on the reference configuration; every
//! pair sum is a gather over particle a's own list, in both directions of the pair.
//! Mirror planes are closed by ghost particles ([`crate::physics::mirror`]): the per-pair data
//! and every per-particle field are extended to them, and only real particles are
//! integrated.

use super::compressibility::{Corrector, Pairs, StageStart, UNCONVERGED};
use super::projection::Balance;
use super::stress_points::StressPoints;
use super::weights::{brookshaw_weights, correct_laplacian, least_squares_weights, pair_map};
use super::{
    CflWaveSpeed, Conserved, DeformationGradient, JstLaplacian, MixedScheme, Momentum, Stabiliser,
};
use crate::boundary::OnPatches;
use crate::core::correction;
use crate::core::integrate::{IntegratorKind, OdeSystem, PseudoTime};
use crate::core::kernel::Kernel;
use crate::engine::{BlowUp, BoundaryWork, Method, Sizes, Traffic, check_motion};
use crate::interaction::Interactions;
use supg::SupgBuffers;

use crate::case::{Case, CaseError};
use crate::core::neighbour::{self, Csr};
use crate::core::parallel::{MIN_CHUNK, particle_state};
use crate::core::sum::{Exact, Ranks, par_sum};
use crate::core::tensor::{Dim, smallest_stretch_squared};
use crate::diagnostics::observe::{ScalarField, Snapshot};
use crate::methods::cores::particles::Surroundings;
use crate::methods::cores::shared::{neighbour_radius, reference_gradients};
use crate::physics::material::Material;
use crate::physics::mirror::{Ghosts, Image};
use crate::physics::plasticity::{History, Returned, from_mat3};
use crate::reference::Reference;
use rayon::prelude::*;
use std::sync::Arc;

particle_state! {
    /// Integrated state of a mixed method (its velocity v = p/ρ0).
    pub struct MixedState {
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
}

/// The stabilising flux of a mixed method.
enum Stabilisation<D: Dim> {
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
    /// SUPG: the stress increments ΔP_s = P(F^st_s) − P(F_s) and velocity increments
    /// Δv_s = (τ_p/ρ0)(DIV P − ṗ)_s at the stress points, tested with the particles'
    /// functions (`supg` pass).
    Supg {
        parameters: super::Supg,
        points: Box<StressPoints<D>>,
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

impl<D: Dim> Kinematics<D> {
    /// The undeformed particle at rest: P = 0, H = I, J = det F = 1.
    fn rest() -> Self {
        Self {
            p: D::zero_t(),
            h: D::identity(),
            grad_v: D::zero_t(),
            j: 1.0,
            det_f: 1.0,
        }
    }
}

impl<D: Dim> Slopes<D> {
    /// No slopes.
    fn flat() -> Self {
        Self {
            grad_v: D::zero_t(),
            grad_p: [D::zero_t(); 3],
        }
    }

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

impl<D: Dim> Forces<D> {
    fn zero() -> Self {
        Self {
            t: D::zero(),
            d: D::zero(),
            dj: 0.0,
        }
    }
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
    /// Whether the bond F is eq 38's purely kinematic one rather than eq 39's.
    kinematic_bond: bool,
    /// The plastic history of the real particles (von Mises); None for the elastic
    /// models.
    plastic: Option<History>,
    stabilisation: Stabilisation<D>,
    /// SUPG's buffers of a rate evaluation (empty for the other stabilisations).
    supg: SupgBuffers<D>,
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
    surroundings: Surroundings<D>,
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
    dissipation: Exact,
    points: Vec<D::V>,
    /// Whether each real particle's shares are booked in the sums (a rank's own), and
    /// the ranks that complete them ([`Reference::counted`], [`Reference::ranks`]).
    counted: Vec<bool>,
    ranks: Arc<dyn Ranks>,
    /// State at the start of the step (u, v) and the step size, for the projection's
    /// positions 𝒳 at the second TVD-RK2 stage.
    step_start: Option<StepStart<D>>,
    stage: usize,
    /// The size of the current step.
    dt: f64,
}

impl<D: Dim> MixedSph<D> {
    /// Builds neighbours, corrected gradients and the per-pair weights on the reference
    /// configuration.
    pub fn new(
        case: &Case,
        spec: &dyn MixedScheme,
        reference: Reference<D>,
    ) -> Result<Self, CaseError> {
        let (options, stabiliser) = (spec.options(), spec.stabiliser());
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
            counted,
            ranks,
            generated_cells,
            ..
        } = reference;
        let m = &case.method;
        let n = x_real.len();
        let radius = neighbour_radius::<D>(case);
        let ghosts = Ghosts::build(&case.mirrors, case.spacing, &x_real, &vol_real, radius)
            .map_err(|(key, message)| case.invalid(key, message))?;
        let (x0, vol) = ghosts.extend_reference(&x_real, &vol_real);
        // The real rows' lists over real and ghost particles: the ghosts close them, and a
        // ghost's own row is never read (on a rank, that of an image of an outer ghost
        // may lack neighbours on one side).
        let mut csr = neighbour::build::<D>(&x0, radius);
        csr.truncate(n);
        let grad = reference_gradients::<D>(case, &x0, &vol, &csr)?;
        let (rev, grad_rev) = reverse_pairs(case, &ghosts, &csr, &grad)?;
        let normal: Vec<D::V> = pair_map(&csr, |i, j| {
            let d = x0[j] - x0[i];
            d * (1.0 / D::norm2(d).sqrt())
        });
        let ls = least_squares_weights::<D>(&x0, &csr, &normal)
            .map_err(|i| singular_least_squares(case, i))?;
        let pairs = Pairs {
            csr: &csr,
            grad: &grad,
            grad_rev: &grad_rev,
            vol: &vol,
            ghosts: &ghosts,
            momentum: options.momentum,
        };
        let mut body = vec![0; x0.len()];
        ghosts.fill(&mut body, |a| body_real[a], |_, b| b);
        let stabilisation = match stabiliser {
            Stabiliser::Jst(coefficients) => jst(case, coefficients, &pairs, &x0, &normal, &rev)?,
            Stabiliser::Upwind { reconstruction } => Stabilisation::Upwind { reconstruction },
            Stabiliser::Supg(p) => {
                supg::stabilisation(case, p, (&x0, &body), &ghosts, &generated_cells)?
            }
        };
        let bond_weights = match options.deformation_gradient {
            DeformationGradient::Evolved => None,
            DeformationGradient::BondBased | DeformationGradient::KinematicBond => {
                Some(bond_weights::<D>(case, &x0, &vol, &csr, &kernel)?)
            }
        };
        let kinematic_bond = options.deformation_gradient == DeformationGradient::KinematicBond;
        let interactions =
            Interactions::build(case, &x0[..n], &body, &OnPatches, &mass, || csr.clone())?;
        let n_ext = x0.len();
        let compressibility = options.artificial_compressibility.map(|spec| {
            let ranks = (&counted[..], ranks.clone());
            Corrector::new(&spec, case, &pairs, (&x0, &normal), ranks)
        });
        let c_p = match options.artificial_compressibility {
            Some(spec) => spec.p_wave_speed(&material),
            None => material.p_wave_speed(),
        };
        Ok(Self {
            kin: vec![Kinematics::rest(); n_ext],
            slopes: vec![Slopes::flat(); n_ext],
            lap: vec![D::zero(); n_ext],
            forces: vec![Forces::zero(); n],
            t: vec![D::zero(); n],
            dp: vec![D::zero(); n],
            dissipation: Exact::default(),
            points: vec![D::zero(); n],
            counted,
            ranks,
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
            kinematic_bond,
            plastic: material.von_mises().map(|model| History::virgin(model, n)),
            stabilisation,
            supg: SupgBuffers::default(),
            compressibility,
            c_p,
            projection: options.projection(case),
            integrator: m.integrator,
            spacing: case.spacing,
            cfl_wave_speed: options.cfl_wave_speed,
            h: kernel.h,
            surroundings: Surroundings::new(boundary, interactions),
            step_start: None,
            stage: 0,
            dt: 0.0,
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

    /// F^c_a = Σ_b V_b W̃_b(X_a) F_ab over the whole neighbourhood with the self-bond
    /// F_aa = F_a (seed 002 eq 37), summed with the partition of unity Σ_b V_b W̃_b = 1 as
    /// F_a + Σ_{b≠a} V_b W̃_b(X_a) (F_ab − F_a), the bond F_ab of [`bond_gradient`]. With
    /// eq 39's, the term is [(x_b − x_a) − F_a X_ab] ⊗ X_ab / |X_ab|², which vanishes for
    /// affine motion. `w` holds V_b W̃_b(X_a) / |X_ab|² per pair.
    fn bond_based_f(&self, a: usize, f: D::T, u_ext: &[D::V], w: &[f64]) -> D::T {
        let mut fc = f;
        for (b, &w) in self.csr.pairs(a, w) {
            let x_ab = self.x0[b] - self.x0[a];
            let dx = x_ab + u_ext[b] - u_ext[a];
            let f_ab = bond_gradient::<D>(self.kinematic_bond, f, dx, x_ab);
            fc += (f_ab - f) * (w * D::norm2(x_ab));
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

/// The reverse pair (b, a) of every pair (a, b), in CSR order, with the mirror image it
/// goes through (None: none).
type ReversePairs = Vec<(u32, Option<Image>)>;

/// The error of a particle whose least-squares matrix Σ N_ab ⊗ N_ab is singular.
fn singular_least_squares(case: &Case, i: usize) -> CaseError {
    case.invalid(
        "method.h_over_dx",
        format!(
            "the least-squares matrix Σ N_ab ⊗ N_ab of particle {i} is singular (its \
             neighbours lie on a line); increase h/dx"
        ),
    )
}

/// The [`ReversePairs`] of the real rows' pairs, and g_ba = ∇̃0W̃_a(X_b) in CSR order.
fn reverse_pairs<D: Dim>(
    case: &Case,
    ghosts: &Ghosts<D>,
    csr: &Csr,
    grad: &[D::V],
) -> Result<(ReversePairs, Vec<D::V>), CaseError> {
    let rev = ghosts.reverse_pairs(csr).map_err(|a| {
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
    Ok((rev, grad_rev))
}

/// JST's per-pair Laplacian weights ℓ_ab (Brookshaw's, corrected if the spec asks) and
/// s_ab = ℓ_ab + (V_b/V_a) ℓ_ba, with `rev` the reverse pair of each pair.
fn jst<D: Dim>(
    case: &Case,
    coefficients: super::Jst,
    pairs: &Pairs<D>,
    x0: &[D::V],
    normal: &[D::V],
    rev: &ReversePairs,
) -> Result<Stabilisation<D>, CaseError> {
    let (csr, vol, grad) = (pairs.csr, pairs.vol, pairs.grad);
    let ij = pair_map(csr, |i, j| (i, j));
    let mut ell = brookshaw_weights::<D>(x0, vol, &ij, grad, normal);
    if coefficients.laplacian == JstLaplacian::Corrected {
        ell = correct_laplacian::<D>(x0, csr, &ell).map_err(|i| {
            case.invalid(
                "method.jst.laplacian",
                format!(
                    "the Laplacian correction of particle {i} is singular; \
                     increase h/dx or use `brookshaw`"
                ),
            )
        })?;
    }
    let s = (0..ij.len())
        .into_par_iter()
        .map(|q| {
            let (i, j) = ij[q];
            ell[q] + vol[j] / vol[i] * ell[rev[q].0 as usize]
        })
        .collect();
    Ok(Stabilisation::Jst {
        coefficients,
        ell,
        s,
    })
}

/// The bond deformation gradient F_ab of a bond X_ab = X_b − X_a, r = |X_ab|, n = X_ab/r,
/// stretched to x_ab: eq 39 (Breitzman–Dayal) F_a − (F_a n) ⊗ n + (x_ab/r) ⊗ n, or with
/// `kinematic` eq 38, (x_ab/r) ⊗ n, which has rank one.
pub fn bond_gradient<D: Dim>(kinematic: bool, f: D::T, x_ab: D::V, x0_ab: D::V) -> D::T {
    let r2 = D::norm2(x0_ab);
    let stretch = D::outer(x_ab, x0_ab) * (1.0 / r2);
    match kinematic {
        true => stretch,
        false => f - D::outer(f * x0_ab, x0_ab) * (1.0 / r2) + stretch,
    }
}

/// The bond-based F's per-pair weights V_b W̃_b(X_a) / |X_ab|².
fn bond_weights<D: Dim>(
    case: &Case,
    x0: &[D::V],
    vol: &[f64],
    csr: &Csr,
    kernel: &Kernel,
) -> Result<Vec<f64>, CaseError> {
    let w = correction::kernel_weights::<D>(case.method.correction, x0, vol, csr, kernel)
        .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
    let r2 = pair_map(csr, |i, j| D::norm2(x0[j] - x0[i]));
    Ok(w.iter().zip(&r2).map(|(w, r2)| w / r2).collect())
}

/// `real` into out[..n] and the ghosts' images σR v into the rest.
fn fill_extended<D: Dim>(ghosts: &Ghosts<D>, out: &mut [D::V], real: &[D::V]) {
    ghosts.fill(out, |a| real[a], |m, v| m.vector::<D>(v));
}

#[cfg(feature = "gpu")]
mod accessors;
mod contracts;
mod passes;
mod supg;
#[cfg(test)]
mod tests;
