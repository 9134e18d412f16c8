//! What the CPU systems of the methods share: the [`Method`] trait (an [`OdeSystem`] plus
//! the fields and energies that observers and outputs read), [`BlowUp`], the particle
//! state's field-wise arithmetic, the reference neighbours and gradients of the
//! total-Lagrangian methods, and the physics several families share: Monaghan's artificial
//! viscosity and the stress fields of a deformation gradient and a rate state.

use crate::boundary::{Boundary, Reaction};
use crate::correction;
use crate::integrate::OdeSystem;
use crate::interaction::Interactions;
use crate::material::Material;
use crate::methods::Problem;
use crate::neighbour::Csr;
use crate::observe::Snapshot;
use crate::reference::{self, Reference};
use crate::scene::validate::non_negative;
use crate::scene::{Case, CaseError};
use crate::tensor::{Dim, Words};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::ops::{Add, Mul};
use thiserror::Error;

/// Smallest slice length rayon splits down to: below it the per-task overhead dominates.
pub(crate) const MIN_CHUNK: usize = 256;

/// Reduces map(0), …, map(n − 1) with `add` in parallel, deterministically: in fixed
/// chunks of [`MIN_CHUNK`] indices, each folded in order, and the chunks' results then
/// folded in order, so the sum has the same bits whatever the number of threads and
/// however rayon steals work (rayon's `reduce` and `sum` combine in an order that
/// depends on both). Every floating-point sum over particles goes through it.
pub(crate) fn ordered_reduce<T: Send>(
    n: usize,
    identity: impl Fn() -> T + Sync,
    map: impl Fn(usize) -> T + Sync,
    add: impl Fn(T, T) -> T + Sync,
) -> T {
    let chunks: Vec<T> = (0..n.div_ceil(MIN_CHUNK))
        .into_par_iter()
        .map(|c| {
            (c * MIN_CHUNK..n.min((c + 1) * MIN_CHUNK))
                .map(&map)
                .fold(identity(), &add)
        })
        .collect();
    chunks.into_iter().fold(identity(), add)
}

/// y += a x, field by field.
pub(crate) fn axpy<T: Copy + Send + Sync + Add<Output = T> + Mul<f64, Output = T>>(
    y: &mut [T],
    a: f64,
    x: &[T],
) {
    y.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(x)
        .for_each(|(y, &x)| *y = *y + x * a);
}

/// y = a y + b x, field by field.
pub(crate) fn blend<T: Copy + Send + Sync + Add<Output = T> + Mul<f64, Output = T>>(
    y: &mut [T],
    a: f64,
    b: f64,
    x: &[T],
) {
    y.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(x)
        .for_each(|(y, &x)| *y = *y * a + x * b);
}

/// `OdeState`, `Clone` (whose `clone_from` copies into the buffers there are) and an
/// empty `Default` for a particle state of displacement `u`, velocity `v` and further
/// fields, each with a rate of its own: RK stages combine every field; the leapfrog drift
/// moves u with the state's own v and the other fields with their rates.
macro_rules! particle_state {
    ($state:ident { $($field:ident),* }) => {
        impl<D: Dim> Default for $state<D> {
            fn default() -> Self {
                Self {
                    u: Vec::new(),
                    v: Vec::new(),
                    $($field: Vec::new(),)*
                }
            }
        }

        impl<D: Dim> Clone for $state<D> {
            fn clone(&self) -> Self {
                Self {
                    u: self.u.clone(),
                    v: self.v.clone(),
                    $($field: self.$field.clone(),)*
                }
            }

            /// Field by field into the buffers there are: the integrators' stage copies
            /// allocate nothing.
            fn clone_from(&mut self, source: &Self) {
                self.u.clone_from(&source.u);
                self.v.clone_from(&source.v);
                $(self.$field.clone_from(&source.$field);)*
            }
        }

        impl<D: Dim> crate::integrate::OdeState for $state<D> {
            fn axpy(&mut self, a: f64, r: &Self) {
                crate::methods::shared::axpy(&mut self.u, a, &r.u);
                crate::methods::shared::axpy(&mut self.v, a, &r.v);
                $(crate::methods::shared::axpy(&mut self.$field, a, &r.$field);)*
            }

            fn blend(&mut self, a: f64, b: f64, o: &Self) {
                crate::methods::shared::blend(&mut self.u, a, b, &o.u);
                crate::methods::shared::blend(&mut self.v, a, b, &o.v);
                $(crate::methods::shared::blend(&mut self.$field, a, b, &o.$field);)*
            }

            fn kick(&mut self, h: f64, r: &Self) {
                crate::methods::shared::axpy(&mut self.v, h, &r.v);
            }

            fn drift(&mut self, h: f64, r: &Self) {
                crate::methods::shared::axpy(&mut self.u, h, &self.v);
                $(crate::methods::shared::axpy(&mut self.$field, h, &r.$field);)*
            }

            fn save(&self, out: &mut Vec<f64>) {
                crate::methods::shared::save_field(&self.u, out);
                crate::methods::shared::save_field(&self.v, out);
                $(crate::methods::shared::save_field(&self.$field, out);)*
            }

            fn load(&mut self, words: &mut &[f64]) -> Result<(), String> {
                crate::methods::shared::load_field(&mut self.u, "u", words)?;
                crate::methods::shared::load_field(&mut self.v, "v", words)?;
                $(crate::methods::shared::load_field(
                    &mut self.$field,
                    stringify!($field),
                    words,
                )?;)*
                Ok(())
            }
        }
    };
}
pub(crate) use particle_state;

/// Appends a field for a checkpoint: its length, then its values.
pub(crate) fn save_field<T: Words>(field: &[T], out: &mut Vec<f64>) {
    out.push(field.len() as f64);
    for x in field {
        x.put(out);
    }
}

/// Reads one word, `name`, from the front of a checkpoint's words.
pub(crate) fn load_word(words: &mut &[f64], name: &str) -> Result<f64, String> {
    let (&word, rest) = words
        .split_first()
        .ok_or_else(|| format!("the checkpoint ends before {name}"))?;
    *words = rest;
    Ok(word)
}

/// Reads a field [`save_field`] wrote into `field`, which must have its length.
pub(crate) fn load_field<T: Words>(
    field: &mut [T],
    name: &str,
    words: &mut &[f64],
) -> Result<(), String> {
    let (&len, rest) = words
        .split_first()
        .ok_or_else(|| format!("the checkpoint ends before the field {name}"))?;
    if len != field.len() as f64 || rest.len() < field.len() * T::LEN {
        return Err(format!(
            "the field {name} holds {len} values in the checkpoint and {} in this run",
            field.len()
        ));
    }
    for (x, w) in field.iter_mut().zip(rest.chunks_exact(T::LEN)) {
        *x = T::take(w);
    }
    *words = &rest[field.len() * T::LEN..];
    Ok(())
}

/// The kernel support of a case, with the margin of [`crate::reference::neighbour_radius`].
pub(crate) fn neighbour_radius<D: Dim>(case: &Case) -> f64 {
    reference::neighbour_radius(&case.kernel(D::N))
}

/// Corrected gradients g_ij on the neighbour lists `csr` of the reference positions x0
/// (and volumes) of a total-Lagrangian method, computed once.
pub(crate) fn reference_gradients<D: Dim>(
    case: &Case,
    x0: &[D::V],
    vol: &[f64],
    csr: &Csr,
) -> Result<Vec<D::V>, CaseError> {
    correction::gradients::<D>(case.method.correction, x0, vol, csr, &case.kernel(D::N))
        .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))
}

/// For every pair (i, j) in CSR order, the index of the pair (j, i) in j's row. Lists
/// that are not symmetric (a neighbour at the kernel support, by round-off) name the
/// particle and the key to change.
pub fn reverse_pairs(case: &Case, csr: &Csr) -> Result<Vec<u32>, CaseError> {
    csr.map_rows(|i| {
        csr.neighbours(i)
            .iter()
            .map(|&j| {
                let row = j as usize;
                let back = csr.neighbours(row).binary_search(&(i as u32));
                back.map(|k| (csr.offsets[row] + k) as u32).map_err(|_| i)
            })
            .collect::<Result<Vec<_>, _>>()
    })
    .map_err(|i| {
        case.invalid(
            "method.h_over_dx",
            format!(
                "particle {i} has a neighbour at the kernel support that does not list it \
                 back; change h/dx slightly"
            ),
        )
    })
}

/// ∇0W̃_ji (j's corrected gradient, evaluated at i) for every pair (i, j), in CSR order:
/// the second gradient of a pair force that derives from Σ_i V_i ψ(F_i) (seed 000 eq 148).
pub(crate) fn reverse_gradients<D: Dim>(
    case: &Case,
    csr: &Csr,
    grad: &[D::V],
) -> Result<Vec<D::V>, CaseError> {
    let rev = reverse_pairs(case, csr)?;
    Ok(rev.par_iter().map(|&q| grad[q as usize]).collect())
}

/// The first particle with a non-finite displacement or velocity, as a blow-up.
pub fn check_motion<D: Dim>(x0: &[D::V], u: &[D::V], v: &[D::V]) -> Result<(), BlowUp> {
    let norm = |v: D::V| D::norm2(v).sqrt();
    if let Some(i) = u.par_iter().position_first(|&u| !D::is_finite_v(u)) {
        return Err(BlowUp::at::<D>(x0, i, "displacement |u|", norm(u[i])));
    }
    if let Some(i) = v.par_iter().position_first(|&v| !D::is_finite_v(v)) {
        return Err(BlowUp::at::<D>(x0, i, "velocity |v|", norm(v[i])));
    }
    Ok(())
}

/// What the end of a rate evaluation leaves for the work balance and the `reaction`
/// observer.
#[derive(Clone, Debug, Default)]
pub struct BoundaryWork {
    /// The power of supports, loads and the interactions other than contact.
    pub power: f64,
    /// The power of the contact forces on the bodies (seed 000 §5.8).
    pub contact: f64,
    /// The reaction of every support of the case.
    pub reactions: Vec<Reaction>,
}

impl BoundaryWork {
    /// The end of a rate evaluation of every method: the interactions' accelerations, then
    /// the boundary's loads and constraints, on the rates `a` at velocities v.
    pub fn finish<D: Dim>(
        &mut self,
        interactions: &Interactions<D>,
        boundary: &Boundary<D>,
        v: &[D::V],
        mass: &[f64],
        a: &mut [D::V],
    ) {
        let interaction = interactions.accelerate(v, mass, a);
        self.contact = interaction.contact;
        self.power = boundary.apply(a, v, mass, &mut self.reactions)
            + boundary.external_power(v, mass)
            + interaction.external;
    }
}

/// A run stopped because the solution left the physically admissible set.
#[derive(Clone, Debug, Error, PartialEq)]
#[error("{quantity} = {value:e} at particle {particle} (reference position {position:?})")]
pub struct BlowUp {
    pub particle: usize,
    pub position: [f64; 3],
    /// What failed, e.g. `det F` or `velocity`.
    pub quantity: String,
    pub value: f64,
}

impl BlowUp {
    /// `quantity` = `value` at particle i of the reference positions x0.
    pub fn at<D: Dim>(x0: &[D::V], i: usize, quantity: &str, value: f64) -> Self {
        Self {
            particle: i,
            position: D::to3(x0[i]),
            quantity: quantity.to_string(),
            value,
        }
    }
}

/// What the driver, observers and outputs need from a method.
pub trait Method<D: Dim>: OdeSystem<Error = BlowUp> + Sized {
    /// Builds the method on the reference configuration of a case; a case that names a
    /// method this system does not run is an error.
    fn build(case: &Case, reference: Reference<D>) -> Result<Self, CaseError>;
    /// Initial state (displacement zero, initial velocities with BCs imposed).
    fn initial_state(&self) -> Self::State;
    /// Displacement u = x − X and velocity v of a state.
    fn displacement<'a>(&self, y: &'a Self::State) -> &'a [D::V];
    fn velocity<'a>(&self, y: &'a Self::State) -> &'a [D::V];
    /// Reference positions X, masses and body indices.
    fn reference(&self) -> &[D::V];
    fn mass(&self) -> &[f64];
    fn body(&self) -> &[u32];
    /// Particles with prescribed velocity components (particle, component mask).
    fn constrained(&self) -> &[(u32, u8)];
    /// Deformation gradient F of every particle.
    fn deformation_gradient(&self, y: &Self::State) -> Vec<D::T>;
    /// Cauchy stress of every particle as a 3×3 tensor (2D: σ_zz of plane strain).
    fn cauchy_stress(&self, y: &Self::State) -> Vec<[[f64; 3]; 3]>;
    /// Σ V0 ψ: the stored strain energy.
    fn strain_energy(&self, y: &Self::State) -> f64;
    /// Everything observers and frames read, at state y.
    fn snapshot<'a>(&'a self, y: &Self::State) -> Snapshot<'a, D>;
    /// Largest signal speed c_p + |v| for the CFL condition.
    fn max_signal_speed(&self, y: &Self::State) -> f64;
    /// The power of supports, loads and interactions and the supports' reactions at the
    /// last rate evaluation.
    fn boundary_work(&self) -> &BoundaryWork;
    /// The power of the artificial dissipation at the last rate evaluation, −Σ m a_art·v
    /// with a_art the acceleration of the artificial viscosity, of a mixed method's
    /// stabilisation or of a Riemann solver's velocity jump (each method's document says
    /// which part of its dissipation this is); 0 for a method without one.
    fn dissipation_power(&self) -> f64 {
        0.0
    }
    /// The power against the hourglass control at the last rate evaluation, −Σ m a_hg·v;
    /// 0 for a method without one.
    fn hourglass_power(&self) -> f64 {
        0.0
    }
    /// The energy the method took out at the ends of the steps so far (the kinetic
    /// energy a velocity smoothing removes), booked with the artificial dissipation.
    fn step_dissipation(&self) -> f64 {
        0.0
    }
    /// The plastic work Σ_q w_q ∫ τ_y dε̄_p up to state y (the committed history's and
    /// the current step's, [`crate::plasticity::History::work_at`]); 0 for an elastic
    /// material.
    fn plastic_work(&self, _y: &Self::State) -> f64 {
        0.0
    }
    /// The pseudo-time iterations of a method that iterates within its stages
    /// (artificial compressibility); None for the others.
    fn pseudo_time(&self) -> Option<PseudoTime> {
        None
    }
    /// The first particle whose state is not finite, if any.
    fn check_finite(&self, y: &Self::State) -> Result<(), BlowUp>;
    /// What the method carries from step to step besides the state (a plastic
    /// history), for a checkpoint; none by default.
    fn save_history(&self, _out: &mut Vec<f64>) {}
    /// Reads what [`Self::save_history`] wrote.
    fn load_history(&mut self, _words: &mut &[f64]) -> Result<(), String> {
        Ok(())
    }
    /// Wall time spent keeping the neighbour lists up to date since the method was built
    /// [s]; none for lists built once on the reference configuration.
    fn neighbour_seconds(&self) -> Option<f64> {
        None
    }
    /// The ordered pairs of the lists a rate evaluation loops over (particle–neighbour
    /// pairs; point–node pairs of a Galerkin method's shape functions), for the cost per
    /// pair `meshless bench` reports.
    fn pairs(&self) -> usize;
    /// The bytes a rate evaluation moves on the CPU, for `meshless bench --roofline`;
    /// none for a method without a model.
    fn traffic(&self) -> Option<Traffic> {
        None
    }
}

/// The element sizes a traffic model counts in [bytes]: a vector, a tensor and a scalar
/// of the dimension, and a pair's id.
#[derive(Clone, Copy, Debug)]
pub struct Sizes {
    pub v: usize,
    pub t: usize,
    pub f: usize,
    pub id: usize,
}

impl Sizes {
    pub fn of<D: Dim>() -> Self {
        Self {
            v: size_of::<D::V>(),
            t: size_of::<D::T>(),
            f: size_of::<f64>(),
            id: size_of::<u32>(),
        }
    }

    /// A point's plastic history, C_p⁻¹ (3 × 3 in 2D too) and ε_p, when the model keeps
    /// one; nothing otherwise.
    pub fn plastic_history(kept: bool) -> usize {
        if kept {
            size_of::<glam::DMat3>() + size_of::<f64>()
        } else {
            0
        }
    }
}

/// Pseudo-time iterations of a run with artificial compressibility.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PseudoTime {
    /// Iterations of the last step, summed over its stages.
    pub step: u64,
    /// Iterations since the run started.
    pub total: u64,
    /// The largest final residual of the last step's stages, relative to the velocity
    /// scale.
    pub residual: f64,
}

/// The memory traffic of one rate evaluation on the CPU, by the minimum-traffic model:
/// every array a pass reads or writes crosses the memory bus once per pass (a neighbour's
/// record, gathered again by its other neighbours, comes from cache).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Traffic {
    /// Bytes per particle: per-particle arrays, summed over the passes.
    pub per_particle: f64,
    /// Bytes per neighbour pair: per-pair arrays (ids, gradients), summed over passes.
    pub per_pair: f64,
    /// Bytes of the integrated state per particle, which the integrator's stage
    /// operations move ([`crate::integrate::traffic`]).
    pub state: f64,
    /// Bytes of the velocity per particle (the leapfrog's kicks move only it).
    pub velocity: f64,
}

/// Monaghan artificial viscosity Π_ij = (−α c̄ μ_ij + β μ_ij²)/ρ̄_ij (seed 000 §3.1 step 6).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ArtificialViscosity {
    pub alpha: f64,
    pub beta: f64,
    #[serde(default = "default_eta")]
    pub eta: f64,
}

fn default_eta() -> f64 {
    0.1
}

impl ArtificialViscosity {
    /// The coefficients must not be negative.
    pub fn validate(&self) -> Result<(), Problem> {
        non_negative("method.artificial_viscosity.alpha", self.alpha)?;
        non_negative("method.artificial_viscosity.beta", self.beta)?;
        non_negative("method.artificial_viscosity.eta", self.eta)
    }

    /// Π_ij of a pair at distance x_ij = x_i − x_j with relative velocity v_ij, mean sound
    /// speed c̄ and mean density ρ̄, smoothing length h: μ_ij = h v_ij·x_ij/(|x_ij|² + η²h²)
    /// for approaching pairs, and zero for separating ones (v_ij·x_ij ≥ 0).
    ///
    /// With one division, as Π = h v·x (−α c̄ d + β h v·x)/(d² ρ̄), d = |x_ij|² + η²h².
    #[inline]
    pub fn pi<D: Dim>(&self, h: f64, x_ij: D::V, v_ij: D::V, c: f64, rho: f64) -> f64 {
        let vx = D::dot(v_ij, x_ij);
        if vx >= 0.0 {
            return 0.0;
        }
        let d = D::norm2(x_ij) + self.eta * self.eta * h * h;
        h * vx * (-self.alpha * c * d + self.beta * h * vx) / (d * d * rho)
    }
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
