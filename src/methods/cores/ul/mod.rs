//! The core of the updated-Lagrangian SPH methods on the CPU: what Gray–Monaghan and
//! Godunov SPH (seed 000 Algorithms 1 and 2) share.
//!
//! [`UlSph`] is a whole CPU system, generic over a [`PairScheme`], which supplies the
//! per-particle quantities and the pair sums of one method. The core holds the particles,
//! the neighbour lists kept by the family's [`Rebuild`] policy (rebuilt from the current
//! positions at every rate evaluation, per body when the case has contact), the
//! boundary conditions and the interactions. At every rate evaluation it forms
//! x = X + u, updates the lists, checks ρ > 0, lets the scheme compute its particles and
//! rates (ẋ, v̇, ρ̇ and the velocity gradient L), and closes with the objective rate Ṡ, Ḟ = L F,
//! the prescribed velocities and the interactions. The state is [`UlState`]: u = x − X,
//! v, ρ, S and F (integrated for the outputs only).

#[cfg(feature = "gpu")]
pub mod gpu;

use crate::boundary::OnPatches;
use crate::case::{Case, CaseError};
use crate::core::check::{Problem, fail, toml_name};
use crate::core::correction::{CorrectionKind, Rkpm};
use crate::core::integrate::OdeSystem;
use crate::core::kernel::Kernel;
use crate::core::neighbour::{Csr, Neighbours, Rebuild};
use crate::core::neighbourhood::{
    continuity_smoothing_length, density_smoothing_length, prime_space,
};
use crate::core::parallel::{MIN_CHUNK, particle_state};
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::{ScalarField, Snapshot};
use crate::engine::{BlowUp, BoundaryWork, Method, Sizes, Traffic, check_motion};
use crate::interaction::Interactions;
use crate::methods::cores::particles::{
    Surroundings, check_stresses, check_tensors, particle_accessors, signal_speed_terms,
};
use crate::physics::material::{Material, stress_fields};
use crate::physics::plasticity::PLASTIC_STRAIN;
use crate::reference::{Build, Reference};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

particle_state! {
    /// Integrated state of an updated-Lagrangian SPH method.
    pub struct UlState {
        /// Density ρ.
        pub rho: Vec<f64>,
        /// Deviatoric Cauchy stress S (an objective rate, seed 000 §2.2 and §4.1).
        pub s: Vec<D::T>,
        /// Deformation gradient F, integrated by Ḟ = L F (outputs only).
        pub f: Vec<D::T>,
        /// Equivalent plastic strain ε_p of a rate model with a yield stress (empty for an
        /// elastic one): its rate is zero, and each step's end adds the radial return's
        /// Δε_p ([`Material::radial_return`]).
        pub eps_p: Vec<f64>,
    }
}

/// The rates of one particle that a scheme computes: ẋ, v̇ (before contact and boundary
/// conditions), ρ̇ and the velocity gradient L.
#[derive(Clone, Copy, Debug)]
pub struct PairRates<D: Dim> {
    pub x_dot: D::V,
    pub v_dot: D::V,
    /// The part of v̇ from the scheme's artificial dissipation (the artificial viscosity,
    /// the Riemann solver's velocity jump), whose power the energy balance books.
    pub v_dot_dissipative: D::V,
    pub rho_dot: f64,
    pub l: D::T,
}

/// The correction of a particle's velocity gradient on the current positions (eq 105
/// with the case's `correction`), with V_j = m_j/ρ_j: the gradient g_ij of each pair.
#[derive(Clone, Copy, Debug)]
pub enum Correction<D: Dim> {
    /// The plain kernel gradient g_ij = ∇W_ij (the paper's).
    Plain,
    /// Randles–Libersky: g_ij = A_i⁻ᵀ ∇W_ij with A_i = Σ_j V_j (x_j − x_i) ⊗ ∇W_ij (seed
    /// 000 §1.3; the paper's W↪ of §6.1).
    Linear { a_inv_t: D::T },
    /// RKPM: g_ij = ∇Ψ_j(x_i) of the reproducing kernel with a linear basis, its moments
    /// over the particle and its neighbours (seed 000 §1.4; the paper's W̊ of §6.1).
    Reproducing(Rkpm<D>),
    /// A correction the neighbours do not determine: |det A| ≤ 1e-10 (or NaN), or an
    /// RKPM moment matrix they do not span; `value` is det A (0 for RKPM).
    Singular { quantity: &'static str, value: f64 },
}

impl<D: Dim> Correction<D> {
    /// g_ij from x_ij = x_i − x_j with W_ij = `w` and ∇W_ij = `grad`.
    pub fn gradient(&self, x_ij: D::V, w: f64, grad: D::V) -> D::V {
        match self {
            Self::Linear { a_inv_t } => *a_inv_t * grad,
            Self::Reproducing(rkpm) => rkpm.gradient(x_ij, w, grad),
            Self::Plain | Self::Singular { .. } => grad,
        }
    }
}

/// A scheme's quantities `P` of one particle with the correction of its L, which the core
/// computes for every scheme ([`UlCore::correction_at`]); it reads as `P` (`Deref`).
#[derive(Clone, Copy, Debug)]
pub struct Corrected<D: Dim, P> {
    pub quantities: P,
    /// The correction of L_i.
    pub correction: Correction<D>,
}

impl<D: Dim, P> std::ops::Deref for Corrected<D, P> {
    type Target = P;

    fn deref(&self) -> &P {
        &self.quantities
    }
}

/// What a scheme's pair sums read at one rate evaluation: the core (its positions and
/// lists current), the particles' records and the state y.
pub struct PairSums<'a, D: Dim, P> {
    pub core: &'a UlCore<D>,
    pub particles: &'a [Corrected<D, P>],
    pub y: &'a UlState<D>,
}

impl<D: Dim, P> PairSums<'_, D, P> {
    /// The neighbours j of particle i with their records, x_ij = x_i − x_j, r_ij = |x_ij|
    /// and the pair's kernel ([`UlCore::pair_kernel`]).
    pub fn pairs(
        &self,
        i: usize,
    ) -> impl Iterator<Item = (usize, &Corrected<D, P>, D::V, f64, Kernel)> {
        let (core, x_i) = (self.core, self.core.x[i]);
        core.neighbours().neighbours(i).iter().map(move |&j| {
            let j = j as usize;
            let x_ij = x_i - core.x[j];
            let kernel = core.pair_kernel(i, j);
            (j, &self.particles[j], x_ij, D::norm2(x_ij).sqrt(), kernel)
        })
    }
}

/// The traction-free treatment of the free surface (seed 000 §4, eq 110), a `[method]`
/// key of the updated-Lagrangian strong forms.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum FreeSurface {
    /// None (the paper's and the reference code's).
    #[default]
    None,
    /// σ·n = 0 solved at each surface particle by projection, σ ← (I − n⊗n) σ (I − n⊗n)
    /// (the paper's first option, "rotation of the stress tensor along n, then zeroing"
    /// the stresses along n).
    Projection,
}

/// The warning of a run under [`FreeSurface::Projection`]: the projected stress does no
/// work against the stress rate, which integrates S unprojected.
pub fn free_surface_warning(free_surface: FreeSurface) -> Option<String> {
    (free_surface == FreeSurface::Projection).then(|| {
        "method.free_surface = \"projection\" is not energy-consistent: the forces take the \
         projected stress while S is integrated whole, so energy appears at the surface (the \
         rotating disk blows up within 430 steps, the tensile strip's energy residue reaches \
         4; docs/methods/gray-monaghan.md); use free_surface = \"none\" (the default)"
            .to_string()
    })
}

/// The `[method]` keys of an updated-Lagrangian strong form that the core reads.
#[derive(Clone, Copy, Debug)]
pub struct CoreKeys {
    pub free_surface: FreeSurface,
    pub smoothing_length: SmoothingLength,
}

/// The smoothing length of the updated-Lagrangian strong forms (seed 000 §3.2), a
/// `[method]` key. An adaptive one gives each particle its own h_i, and each pair the
/// kernel at h_ij = ½(h_i + h_j), so that ∇W_ij stays antisymmetric and the pair forces
/// conserve linear momentum. It is capped at [`H_CAP`] times the case's h.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum SmoothingLength {
    /// The case's h for every particle (the paper's runs).
    #[default]
    Fixed,
    /// eqs 60–61: h_i = η_i (m_i/⟨ρ⟩_i)^(1/d) with the kernel-sum density ⟨ρ⟩_i, its
    /// fixed point by Newton steps ([`density_smoothing_length`]) on the current positions,
    /// from the continuity estimate; η_i = h (ρ0/m_i)^(1/d) makes it the case's h on a lattice
    /// whose kernel sums give ρ0.
    Density,
    /// eq 62: Mohammadi's h_i = h (ρ0/ρ_i)^(1/d) with ρ_i of the continuity equation.
    Continuity,
    /// eq 63 (2D): Randles and Libersky's prime space. The neighbours of particle i are
    /// its candidates within the kernel's support at the cap whose images x_ij/|x_ij|² lie
    /// on the images' convex hull ([`prime_space`]); a pair interacts when either particle
    /// takes the other. h_i puts i's farthest neighbour at [`PRIME_SPACE_REACH`] of the
    /// kernel's support.
    PrimeSpace,
}

/// Where the farthest prime-space neighbour lies, as a share of the kernel's support of
/// h_i: inside it, with a weight (at the support's edge it would have none). On a square
/// lattice the neighbours are the eight of the 3×3 stencil, and the support, 2√2/1.5 Δx
/// = 1.89Δx for the cubic spline, then holds exactly them.
pub const PRIME_SPACE_REACH: f64 = 0.75;

/// The output field of an adaptive smoothing length: h_i of the last rate evaluation.
pub const SMOOTHING_LENGTH: &str = "smoothing_length";

/// What a UL method leaves out with a fixed smoothing length, as `--explain` lists it.
pub fn left_out_smoothing(smoothing_length: SmoothingLength) -> Option<&'static str> {
    (smoothing_length == SmoothingLength::Fixed)
        .then_some("adaptive smoothing length (smoothing_length)")
}

/// The largest adaptive smoothing length, in units of the case's h: a particle that has
/// lost its neighbours would otherwise grow without bound under eqs 60–61.
pub const H_CAP: f64 = 2.0;

/// A particle is on the surface where its Shepard sum S_i = Σ_j V_j W_ij (itself included)
/// is below this: 0.70–0.84 on a lattice's face and 0.95–0.99 one row in, for h/Δx from 1
/// to 1.7 (cubic spline).
pub const SURFACE_SHEPARD: f64 = 0.9;

/// The corrections of the velocity gradient (eq 105) the UL methods run.
const CORRECTIONS: [CorrectionKind; 3] = [
    CorrectionKind::None,
    CorrectionKind::RandlesLibersky,
    CorrectionKind::Rkpm,
];

/// The checks every UL method makes of a case: the hypoelastic model, a correction of
/// [`CORRECTIONS`], and the prime space in 2D only.
pub fn validate(case: &Case, smoothing_length: SmoothingLength) -> Result<(), Problem> {
    let name = case.method.name;
    if smoothing_length == SmoothingLength::PrimeSpace && case.dim() != 2 {
        return fail(
            "method.smoothing_length",
            format!(
                "\"prime-space\" (eq 63) selects the neighbours by a convex hull in the \
                 plane and runs in 2D only, and this case is {}D; use \"density\", \
                 \"continuity\" or \"fixed\"",
                case.dim()
            ),
        );
    }
    if !case.material.model.is_rate_based() {
        return fail(
            "material.model",
            format!(
                "`{name}` integrates ρ and S with an objective rate: use `hypoelastic`, not {}",
                toml_name(&case.material.model)
            ),
        );
    }
    if !CORRECTIONS.contains(&case.method.correction) {
        return fail(
            "method.correction",
            format!(
                "`{name}` corrects its velocity gradient with `none` (the paper's), \
                 `randles-libersky` or `rkpm`, not {}",
                toml_name(&case.method.correction)
            ),
        );
    }
    Ok(())
}

/// A UL method's state as `--explain` prints it: ε_p with a yield stress.
pub fn plan_state(case: &Case) -> String {
    let plastic = Material::new(&case.material).rate_plasticity().is_some();
    format!(
        "u, v, ρ, S, {}F integrated by Ḟ = L F for the outputs",
        if plastic { "ε_p, and " } else { "and " }
    )
}

/// The start of a UL method's rate evaluation as `--explain` prints it: the rebuild (on
/// drift on both backends, decided on the device on the GPU), per body with contact, and
/// the gradients of L.
pub fn plan_rebuild(case: &Case, gpu: bool, smoothing_length: SmoothingLength) -> String {
    let lists = if gpu {
        format!("the lists reach the kernel's support at the cap, h = {H_CAP}h0")
    } else {
        "the lists grow with it".to_string()
    };
    let smoothing = match smoothing_length {
        SmoothingLength::Fixed => String::new(),
        SmoothingLength::Density => format!(
            ", h_i = η (m_i/⟨ρ⟩_i)^(1/d) (eqs 60–61, Newton steps to the fixed point; \
             {lists}), pair kernels at ½(h_i + h_j)"
        ),
        SmoothingLength::Continuity => {
            format!(", h_i = h (ρ0/ρ_i)^(1/d) (eq 62; {lists}), pair kernels at ½(h_i + h_j)")
        }
        SmoothingLength::PrimeSpace => format!(
            ", the neighbours of the prime space (eq 63: the candidates within the support \
             at {H_CAP}h0 whose images x_ij/|x_ij|² lie on their convex hull, a pair when \
             either takes the other), h_i with the farthest at {PRIME_SPACE_REACH} of the \
             support, pair kernels at ½(h_i + h_j)"
        ),
    };
    format!(
        "{}{}{smoothing}, then one gather: L ({})",
        if gpu {
            "device cell list from x = X + u, rebuilt on drift (a device check sets the \
             build's indirect dispatches)"
        } else {
            "cell-list neighbours from the current positions (rebuilt on drift)"
        },
        if case.contact.is_some() {
            " (per body)"
        } else {
            ""
        },
        match case.method.correction {
            CorrectionKind::RandlesLibersky => "Randles–Libersky-corrected gradients",
            CorrectionKind::Rkpm => "RKPM gradients on the current positions",
            _ => "plain kernel gradients",
        }
    )
}

/// The particles of an updated-Lagrangian method and what every such method does with
/// them.
pub struct UlCore<D: Dim> {
    pub x0: Vec<D::V>,
    /// Reference volumes V0 (the strain energy is per reference volume).
    pub vol0: Vec<f64>,
    pub mass: Vec<f64>,
    pub body: Vec<u32>,
    v0: Vec<D::V>,
    pub surroundings: Surroundings<D>,
    pub material: Material,
    /// The case's kernel (one smoothing length, as in seed 000).
    pub kernel: Kernel,
    /// The correction of the velocity gradient (`none`, `randles-libersky` or `rkpm`, eq
    /// 105).
    pub correction: CorrectionKind,
    /// The traction-free treatment of the surface.
    pub free_surface: FreeSurface,
    /// The smoothing length: fixed or adaptive.
    pub smoothing_length: SmoothingLength,
    /// h_i of every particle at the last rate evaluation with an adaptive smoothing
    /// length (empty with a fixed one).
    h: Vec<f64>,
    /// The candidates of every particle: all of them within its kernel's support (of h_i
    /// with an adaptive h, of the cap under the prime space).
    neighbours: Neighbours,
    /// [`SmoothingLength::PrimeSpace`]: the pairs of the prime space at the last rate
    /// evaluation, a subset of the candidates.
    prime: Option<Csr>,
    /// Current positions x = X + u of the last rate evaluation.
    pub x: Vec<D::V>,
}

impl<D: Dim> UlCore<D> {
    /// The particles of the reference configuration r with their lists kept by `rebuild`,
    /// per body when the case has contact (without it the bodies interact through the SPH
    /// sums as one body).
    pub fn new(case: &Case, r: Reference<D>, rebuild: Rebuild) -> Result<Self, CaseError> {
        let neighbours = r.neighbour_lists(rebuild, case.contact.is_some());
        let lists = || neighbours.lists().clone();
        let interactions = Interactions::build(case, &r.x0, &r.body, &OnPatches, &r.mass, lists)?;
        Ok(Self {
            x: r.x0.clone(),
            x0: r.x0,
            vol0: r.vol,
            mass: r.mass,
            body: r.body,
            v0: r.v0,
            surroundings: Surroundings::new(r.boundary, interactions),
            material: r.material,
            kernel: r.kernel,
            correction: case.method.correction,
            free_surface: FreeSurface::None,
            smoothing_length: SmoothingLength::Fixed,
            h: Vec::new(),
            neighbours,
            prime: None,
        })
    }

    /// Whether the material has a yield stress, and the state an ε_p.
    pub fn plastic(&self) -> bool {
        self.material.rate_plasticity().is_some()
    }

    /// The neighbour lists of the last rate evaluation.
    pub fn neighbours(&self) -> &Csr {
        self.prime.as_ref().unwrap_or(self.neighbours.lists())
    }

    /// The smoothing length h_i of particle i at the last rate evaluation.
    pub fn h(&self, i: usize) -> f64 {
        self.h.get(i).copied().unwrap_or(self.kernel.h)
    }

    /// The kernel of the pair (i, j): at h_ij = ½(h_i + h_j) with an adaptive smoothing
    /// length, the case's kernel with a fixed one.
    pub fn pair_kernel(&self, i: usize, j: usize) -> Kernel {
        if self.h.is_empty() {
            return self.kernel;
        }
        Kernel::new(self.kernel.kind, 0.5 * (self.h[i] + self.h[j]), D::N)
    }

    /// eq 62 at density ρ, capped at [`H_CAP`] h: the continuity smoothing length, and the
    /// start of the fixed point of eqs 60–61.
    fn continuity_h(&self, rho: f64) -> f64 {
        let h = self.kernel.h;
        continuity_smoothing_length(h, self.material.rho0, rho, D::N).min(H_CAP * h)
    }

    /// The Cauchy stress σ_i = S_i − p(ρ_i) I of the state, with σ·n = 0 projected at a
    /// surface particle under [`FreeSurface::Projection`] ([`Self::surface_normal`]).
    pub fn cauchy(&self, i: usize, y: &UlState<D>) -> D::T {
        let sigma = y.s[i] - D::identity() * self.material.pressure(y.rho[i]);
        if self.free_surface == FreeSurface::None {
            return sigma;
        }
        match self.surface_normal(i, &y.rho) {
            Some(n) => {
                let p = D::identity() - D::outer(n, n);
                p * sigma * p
            }
            None => sigma,
        }
    }

    /// The outward unit normal n_i = −∇S_i/|∇S_i| of a surface particle, S_i = V_i W(0) +
    /// Σ_j V_j W_ij below [`SURFACE_SHEPARD`] and ∇S_i = Σ_j V_j ∇W_ij (V_j = m_j/ρ_j);
    /// None inside.
    pub fn surface_normal(&self, i: usize, rho: &[f64]) -> Option<D::V> {
        let own = self.pair_kernel(i, i).w(0.0);
        let (mut s, mut g) = (self.mass[i] / rho[i] * own, D::zero());
        for &j in self.neighbours().neighbours(i) {
            let j = j as usize;
            let (x_ij, v) = (self.x[i] - self.x[j], self.mass[j] / rho[j]);
            let kernel = self.pair_kernel(i, j);
            s += v * kernel.w(D::norm2(x_ij).sqrt());
            g += kernel.grad::<D>(x_ij) * v;
        }
        let norm = D::norm2(g).sqrt();
        (s < SURFACE_SHEPARD && norm > 0.0).then(|| g * (-1.0 / norm))
    }

    /// The correction of particle i's velocity gradient ([`Self::correction`]), with
    /// V_j = m_j/ρ_j.
    pub fn correction_at(&self, i: usize, rho: &[f64]) -> Correction<D> {
        let volume = |j: usize| self.mass[j] / rho[j];
        // (x_ij, V_j, W_ij, ∇W_ij) of every neighbour.
        let pairs = self.neighbours().neighbours(i).iter().map(|&j| {
            let j = j as usize;
            let (x_ij, kernel) = (self.x[i] - self.x[j], self.pair_kernel(i, j));
            let w = kernel.w(D::norm2(x_ij).sqrt());
            (x_ij, volume(j), w, kernel.grad::<D>(x_ij))
        });
        match self.correction {
            CorrectionKind::RandlesLibersky => {
                let a = pairs.fold(D::zero_t(), |a, (x_ij, v, _, grad)| {
                    a + D::outer(-x_ij, grad) * v
                });
                let det = D::det(a);
                if det.is_nan() || det.abs() <= 1e-10 {
                    return Correction::Singular {
                        quantity: "det A (Randles–Libersky)",
                        value: det,
                    };
                }
                Correction::Linear {
                    a_inv_t: D::transpose(D::inverse(a)),
                }
            }
            CorrectionKind::Rkpm => {
                let w_ii = self.pair_kernel(i, i).w(0.0);
                let own = std::iter::once((D::zero(), volume(i), w_ii, D::zero()));
                match Rkpm::weighted(own.chain(pairs)) {
                    Some(rkpm) => Correction::Reproducing(rkpm),
                    None => Correction::Singular {
                        quantity: "RKPM moment matrix (neighbours that do not span the linear basis)",
                        value: 0.0,
                    },
                }
            }
            _ => Correction::Plain,
        }
    }

    /// The first particle of `corrections` whose correction is singular, as a blow-up.
    pub fn first_singular<'a>(
        &self,
        corrections: impl IndexedParallelIterator<Item = &'a Correction<D>>,
    ) -> Option<BlowUp> {
        corrections.enumerate().find_map_first(|(i, c)| match c {
            Correction::Singular { quantity, value } => {
                Some(BlowUp::at::<D>(&self.x0, i, quantity, *value))
            }
            _ => None,
        })
    }

    /// x = X + u, the smoothing lengths and the lists; the first particle with ρ ≤ 0
    /// fails.
    fn positions(&mut self, y: &UlState<D>) -> Result<(), BlowUp> {
        self.x
            .par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(&self.x0)
            .zip(&y.u)
            .for_each(|((x, &x0), &u)| *x = x0 + u);
        if let Some(i) = y
            .rho
            .par_iter()
            .position_first(|&rho| rho.is_nan() || rho <= 0.0)
        {
            return Err(BlowUp::at::<D>(&self.x0, i, "density", y.rho[i]));
        }
        let support = self.kernel.kind.support_factor();
        match self.smoothing_length {
            SmoothingLength::Fixed => {
                self.neighbours.update::<D>(&self.x);
            }
            SmoothingLength::Continuity => {
                self.h = y.rho.iter().map(|&rho| self.continuity_h(rho)).collect();
                let need: Vec<f64> = self.h.iter().map(|h| support * h).collect();
                self.neighbours.update_reaching::<D>(&self.x, &need);
            }
            SmoothingLength::Density => self.density_lengths(y)?,
            SmoothingLength::PrimeSpace => self.prime_space_lists(),
        }
        Ok(())
    }

    /// eq 63 at every particle, over its candidates within the kernel's support at the
    /// cap (at the current positions, so that the choice does not depend on when the lists
    /// were built): its prime-space neighbours and h_i, capped at [`H_CAP`] h (the cap alone
    /// without neighbours); then the lists of the pairs either particle takes.
    fn prime_space_lists(&mut self) {
        let (h0, support) = (self.kernel.h, self.kernel.kind.support_factor());
        let reach = support * H_CAP * h0;
        let n = self.x.len();
        self.neighbours
            .update_reaching::<D>(&self.x, &vec![reach; n]);
        let (x, candidates) = (&self.x, self.neighbours.lists());
        let offset = |i: usize, j: u32| x[i] - x[j as usize];
        // Per particle: the candidates in reach, those it takes, and h_i.
        let chosen: Vec<(Vec<u32>, Vec<u32>, f64)> = (0..n)
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|i| {
                let in_reach = |&j: &u32| D::norm2(offset(i, j)) <= reach * reach;
                let near: Vec<u32> = candidates
                    .neighbours(i)
                    .iter()
                    .copied()
                    .filter(in_reach)
                    .collect();
                let planar = |&j: &u32| {
                    let x_ij = D::to3(offset(i, j));
                    [x_ij[0], x_ij[1]]
                };
                let offsets: Vec<[f64; 2]> = near.iter().map(planar).collect();
                let taken: Vec<u32> = prime_space(&offsets).into_iter().map(|k| near[k]).collect();
                let farthest = taken
                    .iter()
                    .map(|&j| D::norm2(offset(i, j)).sqrt())
                    .fold(0.0, f64::max);
                let h = if taken.is_empty() {
                    H_CAP * h0
                } else {
                    (farthest / (PRIME_SPACE_REACH * support)).min(H_CAP * h0)
                };
                (near, taken, h)
            })
            .collect();
        // Candidates are sorted, and so is each particle's choice.
        let takes = |i: usize, j: u32| chosen[i].1.binary_search(&j).is_ok();
        let rows: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|i| {
                let paired = |&j: &u32| takes(i, j) || takes(j as usize, i as u32);
                chosen[i].0.iter().copied().filter(paired).collect()
            })
            .collect();
        self.h = chosen.into_iter().map(|(_, _, h)| h).collect();
        self.prime = Some(Csr::from_rows(&rows));
    }

    /// eqs 60–61 at every particle over the lists, each from its continuity estimate; the
    /// lists are rebuilt until they reach every h_i's support (from the last evaluation's
    /// h, a pass or two when h grows past the lists' headroom).
    fn density_lengths(&mut self, y: &UlState<D>) -> Result<(), BlowUp> {
        let (kind, h0, rho0) = (self.kernel.kind, self.kernel.h, self.material.rho0);
        let support = kind.support_factor();
        let d = D::N as f64;
        let mut need: Vec<f64> = if self.h.is_empty() {
            y.rho
                .iter()
                .map(|&rho| support * self.continuity_h(rho))
                .collect()
        } else {
            self.h.iter().map(|h| support * h).collect()
        };
        for _ in 0..8 {
            self.neighbours.update_reaching::<D>(&self.x, &need);
            let core = &*self;
            let h: Vec<Option<f64>> = (0..core.x.len())
                .into_par_iter()
                .with_min_len(MIN_CHUNK)
                .map(|i| {
                    let (x_i, m_i) = (core.x[i], core.mass[i]);
                    let others = core.neighbours().neighbours(i).iter();
                    let candidates = std::iter::once((D::zero(), m_i))
                        .chain(others.map(|&j| (x_i - core.x[j as usize], core.mass[j as usize])));
                    let eta = h0 * (rho0 / m_i).powf(1.0 / d);
                    let start = core.continuity_h(y.rho[i]);
                    density_smoothing_length::<D>(candidates, m_i, eta, kind, start, H_CAP * h0)
                })
                .collect();
            if let Some(i) = h.iter().position(Option::is_none) {
                let quantity = "smoothing length (eqs 60–61 found no fixed point)";
                return Err(BlowUp::at::<D>(&self.x0, i, quantity, f64::NAN));
            }
            self.h = h.into_iter().flatten().collect();
            need = self.h.iter().map(|h| support * h).collect();
            let covered = self.neighbours.covered();
            if need.iter().zip(covered).all(|(n, c)| n <= c) {
                return Ok(());
            }
        }
        let i = (need.iter().zip(self.neighbours.covered()))
            .position(|(n, c)| n > c)
            .unwrap_or(0);
        let quantity = "smoothing length (eqs 60–61: its support outgrew the lists 8 times)";
        Err(BlowUp::at::<D>(&self.x0, i, quantity, need[i] / support))
    }

    /// Velocity components prescribed over the step: ẋ takes them (a scheme's XSPH term is left out)
    /// and v̇ is zeroed; then the interactions' accelerations. Records the power.
    fn close(&mut self, y: &UlState<D>, d: &mut UlState<D>) {
        for (i, mask) in self.surroundings.boundary.held_now() {
            let i = i as usize;
            let (mut x_dot, vi) = (D::to3(d.u[i]), D::to3(y.v[i]));
            for k in 0..D::N {
                if mask & (1 << k) != 0 {
                    x_dot[k] = vi[k];
                }
            }
            d.u[i] = D::from_slice(&x_dot[..D::N]);
        }
        self.surroundings.close(&y.v, &self.mass, &mut d.v);
    }
}

/// The pair sums of one updated-Lagrangian method, on the core's particles and lists.
pub trait PairScheme<D: Dim>: Sized + Send + Sync {
    /// What the scheme computes per particle before its pair sums.
    type Particle: Copy + Send + Sync;
    /// The family's neighbour policy.
    const REBUILD: Rebuild;

    /// The typed spec of the scheme's method.
    type Spec;

    /// The scheme of a method's spec on the case's core.
    fn new(case: &Case, spec: &Self::Spec, core: &UlCore<D>) -> Result<Self, CaseError>;

    /// The spec's keys that the core reads.
    fn core_keys(spec: &Self::Spec) -> CoreKeys;

    /// The quantities of particle i at state y (the core's positions and lists are
    /// current), besides the correction of its L.
    fn particle(&self, core: &UlCore<D>, i: usize, y: &UlState<D>) -> Self::Particle;

    /// The rates of particle i from its neighbours.
    fn rates_of(&self, sums: &PairSums<D, Self::Particle>, i: usize) -> PairRates<D>;
}

/// An updated-Lagrangian SPH system on the CPU (f64, rayon): the core and a scheme.
pub struct UlSph<D: Dim, S: PairScheme<D>> {
    pub core: UlCore<D>,
    pub scheme: S,
    particles: Vec<Corrected<D, S::Particle>>,
    /// Each particle's power of the artificial dissipation, −m a_art·v, at the last rate
    /// evaluation.
    dissipation: Vec<f64>,
    /// The strain energy the radial returns of the steps so far took out of S: the
    /// plastic work of the balance.
    plastic_work: f64,
}

impl<D: Dim, S: PairScheme<D>> UlSph<D, S> {
    /// The current neighbour lists (those of the last rate evaluation).
    pub fn neighbours(&self) -> &Csr {
        self.core.neighbours()
    }
}

impl<D: Dim, S: PairScheme<D>> OdeSystem for UlSph<D, S> {
    type State = UlState<D>;
    type Error = BlowUp;

    fn rates(&mut self, _t: f64, y: &UlState<D>, d: &mut UlState<D>) -> Result<(), BlowUp> {
        self.core.positions(y)?;
        let (core, scheme) = (&self.core, &self.scheme);
        (0..y.u.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|i| Corrected {
                quantities: scheme.particle(core, i, y),
                correction: core.correction_at(i, &y.rho),
            })
            .collect_into_vec(&mut self.particles);
        let corrections = self.particles.par_iter().map(|p| &p.correction);
        if let Some(b) = core.first_singular(corrections) {
            return Err(b);
        }
        let sums = PairSums {
            core,
            particles: &self.particles,
            y,
        };
        self.dissipation.resize(y.u.len(), 0.0);
        d.u.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(d.v.par_iter_mut())
            .zip(d.rho.par_iter_mut())
            .zip(d.s.par_iter_mut())
            .zip(d.f.par_iter_mut())
            .zip(self.dissipation.par_iter_mut())
            .enumerate()
            .for_each(
                |(i, (((((u_dot, v_dot), rho_dot), s_dot), f_dot), dissipation))| {
                    let r = scheme.rates_of(&sums, i);
                    (*u_dot, *v_dot, *rho_dot) = (r.x_dot, r.v_dot, r.rho_dot);
                    *dissipation = -core.mass[i] * D::dot(r.v_dot_dissipative, y.v[i]);
                    *s_dot = core.material.stress_rate::<D>(y.s[i], r.l, y.f[i]);
                    *f_dot = r.l * y.f[i];
                },
            );
        d.eps_p.par_iter_mut().for_each(|e| *e = 0.0);
        self.core.close(y, d);
        Ok(())
    }

    /// With a yield stress, the radial return of every particle's S onto the von Mises
    /// surface; the strain energy it takes out is booked as plastic work.
    fn end_step(&mut self, _t: f64, y: &mut UlState<D>) {
        if y.eps_p.is_empty() {
            return;
        }
        let (mat, vol0) = (&self.core.material, &self.core.vol0);
        let work: Exact = (y.s.par_iter_mut())
            .with_min_len(MIN_CHUNK)
            .zip(y.eps_p.par_iter_mut())
            .zip(&y.rho)
            .zip(&y.f)
            .zip(vol0)
            .map(|((((s, eps_p), &rho), &f), &vol0)| {
                let Some((returned, d_eps)) = mat.radial_return::<D>(*s, rho, *eps_p) else {
                    return 0.0;
                };
                let before = mat.energy_density::<D>(f, *s, rho);
                (*s, *eps_p) = (returned, *eps_p + d_eps);
                vol0 * (before - mat.energy_density::<D>(f, returned, rho))
            })
            .sum();
        self.plastic_work += work.value();
    }

    /// The interactions' work before the step (the contact forces of seed 000 §5.8).
    fn begin_step(&mut self, t: f64, dt: f64, y: &UlState<D>) {
        self.core
            .surroundings
            .begin_step(t, dt, &self.core.x0, &y.u, &y.v);
    }
}

impl<D: Dim, S: PairScheme<D>> Build<D> for UlSph<D, S> {
    type Spec = S::Spec;

    fn build(case: &Case, spec: &S::Spec, reference: Reference<D>) -> Result<Self, CaseError> {
        let mut core = UlCore::new(case, reference, S::REBUILD)?;
        let keys = S::core_keys(spec);
        (core.free_surface, core.smoothing_length) = (keys.free_surface, keys.smoothing_length);
        let scheme = S::new(case, spec, &core)?;
        Ok(Self {
            core,
            scheme,
            particles: Vec::new(),
            dissipation: Vec::new(),
            plastic_work: 0.0,
        })
    }
}

impl<D: Dim, S: PairScheme<D>> Method<D> for UlSph<D, S> {
    fn initial_state(&self) -> UlState<D> {
        let n = self.core.x0.len();
        UlState {
            u: vec![D::zero(); n],
            v: self.core.v0.clone(),
            rho: vec![self.core.material.rho0; n],
            s: vec![D::zero_t(); n],
            f: vec![D::identity(); n],
            eps_p: vec![0.0; if self.core.plastic() { n } else { 0 }],
        }
    }

    particle_accessors!(UlState<D>, core);

    fn reference(&self) -> &[D::V] {
        &self.core.x0
    }

    fn deformation_gradient(&self, y: &UlState<D>) -> Vec<D::T> {
        y.f.clone()
    }

    fn cauchy_stress(&self, y: &UlState<D>) -> Vec<[[f64; 3]; 3]> {
        stress_fields::<D>(&self.core.material, &y.f, &y.s, &y.rho, &self.core.vol0).0
    }

    fn strain_energy(&self, y: &UlState<D>) -> Exact {
        stress_fields::<D>(&self.core.material, &y.f, &y.s, &y.rho, &self.core.vol0).1
    }

    fn snapshot<'a>(&'a self, y: &UlState<D>) -> Snapshot<'a, D> {
        let core = &self.core;
        let mut snapshot = snapshot(
            &core.material,
            &core.x0,
            &core.mass,
            &core.body,
            &core.vol0,
            y.clone(),
        );
        if !core.h.is_empty() {
            snapshot.extra.push(ScalarField {
                name: SMOOTHING_LENGTH,
                values: core.h.clone(),
            });
        }
        snapshot
    }

    fn neighbour_seconds(&self) -> Option<f64> {
        Some(self.core.neighbours.seconds())
    }

    fn dissipation_power(&self) -> Exact {
        self.dissipation.iter().copied().sum()
    }

    fn step_end_changes_state(&self) -> bool {
        self.core.plastic()
    }

    fn plastic_work(&self, _y: &UlState<D>) -> f64 {
        self.plastic_work
    }

    fn save_history(&self, out: &mut Vec<f64>) {
        out.push(self.plastic_work);
    }

    fn load_history(&mut self, words: &mut &[f64]) -> Result<(), String> {
        let (&work, rest) = (words.split_first())
            .ok_or("the checkpoint ends before the plastic work of the returns")?;
        (self.plastic_work, *words) = (work, rest);
        Ok(())
    }

    fn signal_speed_terms(&self, y: &UlState<D>) -> [f64; 2] {
        signal_speed_terms::<D>(&self.core.material, &y.v)
    }

    fn pairs(&self) -> usize {
        self.core.neighbours().pair_count()
    }

    /// x = X + u; the lists' drift check reads x and the positions of the last build (a
    /// rebuild, on drift only, is left out) and ρ > 0 reads ρ; the particle pass reads ρ,
    /// S and m (with the Randles–Libersky correction also x and the ids of every pair)
    /// and writes the scheme's records, which the admissibility check reads again; the
    /// pair pass reads the records, x, v, ρ, S, F and m and the ids of every pair and
    /// writes u̇, v̇, ρ̇, Ṡ and Ḟ. The kernel is evaluated per pair, not stored.
    fn traffic(&self) -> Option<Traffic> {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let record = size_of::<Corrected<D, S::Particle>>();
        // The particle pass sums the Randles–Libersky correction over the pairs.
        let corrected = self.core.correction == CorrectionKind::RandlesLibersky;
        let positions = 3 * v + (v + size_of::<[f64; 3]>()) + f;
        let particle = 2 * f + t + record + if corrected { v } else { 0 };
        let pair_pass = record + 2 * v + 2 * f + 2 * t + (2 * v + f + 2 * t);
        Some(Traffic {
            per_particle: (positions + particle + record + pair_pass) as f64,
            per_pair: (id + if corrected { id } else { 0 }) as f64,
            state: (2 * v + f + 2 * t) as f64,
            velocity: v as f64,
        })
    }

    fn check_finite(&self, y: &UlState<D>) -> Result<(), BlowUp> {
        check_state(&self.core.x0, y)
    }
}

/// A snapshot of the UL state y: stresses and strain energy (per reference volume
/// `vol0`) from `stress_fields`. Shared by the CPU and GPU paths.
pub fn snapshot<'a, D: Dim>(
    material: &crate::physics::material::Material,
    x0: &'a [D::V],
    mass: &'a [f64],
    body: &'a [u32],
    vol0: &[f64],
    y: UlState<D>,
) -> Snapshot<'a, D> {
    let (sigma, strain_energy) = stress_fields::<D>(material, &y.f, &y.s, &y.rho, vol0);
    // The method's own ρ (continuity equation) and V = m/ρ, in place of ρ0/J and V0 J of
    // the integrated F.
    let volume = mass.iter().zip(&y.rho).map(|(m, rho)| m / rho).collect();
    let mut extra = vec![
        ScalarField {
            name: "density",
            values: y.rho,
        },
        ScalarField {
            name: "volume",
            values: volume,
        },
    ];
    if !y.eps_p.is_empty() {
        extra.push(ScalarField {
            name: PLASTIC_STRAIN,
            values: y.eps_p,
        });
    }
    Snapshot {
        x0,
        mass,
        body,
        u: y.u,
        v: y.v,
        f: y.f,
        sigma,
        strain_energy,
        extra,
        cells: &[],
        quadrature: None,
    }
}

/// The first non-finite entry of a UL state, as a blow-up at its particle.
pub fn check_state<D: Dim>(x0: &[D::V], y: &UlState<D>) -> Result<(), BlowUp> {
    check_motion::<D>(x0, &y.u, &y.v)?;
    let at = |i: usize, quantity: &str, value: f64| BlowUp::at::<D>(x0, i, quantity, value);
    check_stresses::<D>(&y.rho, &y.s, at)?;
    check_tensors::<D>(&y.f, "deformation gradient |F|", at)
}
