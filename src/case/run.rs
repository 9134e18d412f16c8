//! `[run]`: the end time, how the run advances, and the limits that stop it.

use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// Simulated end time [s] (of the static path: the pseudo-time of the full load).
    pub end_time: f64,
    /// How the run advances: `dynamic`, integrating in time, `static`, solving for
    /// equilibrium at every load step of `method.dt` ([`crate::statics`]), or `implicit`,
    /// integrating in time by Newmark/HHT-α steps of `method.dt` on the static path's
    /// residual and tangent ([`crate::statics::newmark`]). Absent: the method's own
    /// (static for the static-only methods, dynamic for the others).
    #[serde(default)]
    pub solve: Option<Solve>,
    /// `implicit`: HHT's α in [−1/3, 0] (β = (1 − α)²/4, γ = ½ − α); absent: 0, Newmark's
    /// average-acceleration rule.
    #[serde(default)]
    pub hht_alpha: Option<f64>,
    /// Newton's convergence tolerances of a static run, `{ residual = …, increment = … }`
    /// (each optional; the defaults and the force scale: [`Tolerance`]).
    #[serde(default, skip_serializing_if = "Tolerance::is_unset")]
    pub tolerance: Tolerance,
    /// Stop as failed when the total energy exceeds this factor times the initial
    /// energy plus the work done by boundary conditions.
    #[serde(default = "default_energy_growth")]
    pub energy_growth_limit: f64,
    /// Stop as failed when the hourglass indicator η of a particle exceeds this, checked
    /// at every series sample (see [`crate::physics::hourglass`]).
    #[serde(default)]
    pub hourglass_limit: Option<f64>,
    /// Stop as failed when the CFL step falls below this fraction of the first step
    /// (a collapse of the step: the run would crawl rather than end).
    #[serde(default)]
    pub min_step_ratio: Option<f64>,
    /// Simulated time between checkpoints [s] (`checkpoint.bin` in the output folder,
    /// from which `--resume` continues); absent: none.
    #[serde(default)]
    pub checkpoint_interval: Option<f64>,
    /// CPU threads of the run (a pool of its own); absent: every core. A study sweeps it
    /// to measure the parallel speed-up.
    #[serde(default)]
    pub threads: Option<usize>,
}

/// `run.solve`.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Solve {
    Dynamic,
    Static,
    Implicit,
}

fn default_energy_growth() -> f64 {
    10.0
}

/// `run.tolerance`: when Newton's iteration of a load step has converged, for every
/// static engine ([`crate::statics`]). A load step has converged when
///
/// - |R| ≤ `residual` × the force scale, |R| the residual on the free components, or
/// - |Δu| ≤ `increment` × |u|, the last Newton correction against the displacement
///   (all components), after at least one solve.
///
/// **The force scale** is √(|λ f_ext|² + |r|² + |f_int|²) at the current iterate, over all
/// components: the applied loads, the supports' reactions r = −(f_int + λ f_ext) on the
/// prescribed components, and the internal force. Under loads alone the first is the
/// load; under prescribed displacements alone (no f_ext) the second is the force that
/// moves them; the third is the size of the stresses the residual is computed from,
/// which balance both and whose round-off the residual carries. So the scale is never
/// near zero for a loaded problem, whichever way it is loaded. It lies within √3 of the
/// largest of the three (at equilibrium |f_int| holds most of the other two); the root of
/// the sum of squares rather than the largest alone keeps it at least the scale the
/// static path had before (√(|λ f_ext|² + |f_int|²)), so that no solve that converged
/// then fails now. One number per iterate, not per particle: interior particles carry no
/// load and would divide by ~0.
///
/// **Why the defaults are these sizes.** The residual of a converged solve does not fall
/// to 1e-16 of the force scale. Every method computes its stress from F = I + H, whose
/// entries of size 1 hold a strain H ~ ε to 1e-16 absolute, 1e-16/ε relative; the
/// residual, a sum over neighbours of such stresses that cancel, stalls near 1e-15/ε of
/// the force scale. Measured on a steel cantilever (E = 2e11 Pa) at a peak strain of
/// 1e-6 (`tests/it/static_tolerance.rs`): 8e-10 to 9e-10 with `tl-fem`, 2e-10 to 4e-10
/// with `efg`, `kbm`, `tlsph`, `tl-weak-form` and `dual-support-sph`; 64 times that at
/// 1/64 of the load. The former fixed 1e-10 lay below that floor, and the run failed.
/// [`Tolerance::RESIDUAL`] = 1e-8 lies a decade above the largest floor at 1e-6, so the
/// residual alone ends solves at strains down to ~1e-7; on neo-Hookean rubber stretched
/// 500 % (floor ~1e-14) it is met one or two iterations after quadratic convergence sets
/// in, and the support reactions agree with those of a solve to 1e-13 within 2e-12. A
/// tighter default would fail realistic small-strain parts; a looser one would gain
/// nothing on a nonlinear solve, whose quadratic step from 1e-8 to round-off is a single
/// iteration, and leave its linear convergence (finite-difference tangents, the GPU's
/// f32 Krylov steps) further from the solution. The increment criterion ends a solve at
/// round-off where the residual cannot: at the floor Newton's corrections are the
/// round-off of u, |Δu|/|u| ~ 1e-17/ε (measured 1.5e-12 to 1.4e-11 at ε = 1e-6), so
/// [`Tolerance::INCREMENT`] = 1e-10 stops a stalled solve at strains down to ~1e-7 as
/// well, with u exact to about ten digits, yet lies far below any correction of a solve
/// still converging (the former 1e-12 lay below the floor of 1e-6 strains).
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Tolerance {
    /// |R| ≤ this × the force scale; absent: [`Tolerance::RESIDUAL`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<f64>,
    /// |Δu| ≤ this × |u|; absent: [`Tolerance::INCREMENT`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub increment: Option<f64>,
}

impl Tolerance {
    /// The default of `run.tolerance.residual` (see the type's notes for its size).
    pub const RESIDUAL: f64 = 1e-8;
    /// The default of `run.tolerance.increment` (see the type's notes for its size).
    pub const INCREMENT: f64 = 1e-10;
    /// The smallest value either key takes: the double-precision epsilon, below which no
    /// residual or increment computed in f64 can fall (but exactly to zero).
    pub const SMALLEST: f64 = f64::EPSILON;

    /// The residual tolerance, given or default.
    pub fn residual(&self) -> f64 {
        self.residual.unwrap_or(Self::RESIDUAL)
    }

    /// The increment tolerance, given or default.
    pub fn increment(&self) -> f64 {
        self.increment.unwrap_or(Self::INCREMENT)
    }

    /// Neither key given (the table is then left out of the case's serialisation, so that
    /// a case's fingerprint does not change with it).
    pub fn is_unset(&self) -> bool {
        self.residual.is_none() && self.increment.is_none()
    }
}
