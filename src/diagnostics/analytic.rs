//! Closed-form solutions that cases are checked against, and the relative L2 norm their
//! errors are measured in.

use crate::core::tensor::{D2, D3, Dim};
use crate::physics::material::Material;
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

mod cantilever;
mod rod;

pub use cantilever::{Cantilever, ClosedForm, Solution};
pub use rod::{DrivenEnd, Rod, bar_wave_speed};

/// The swinging modes u(X, t) = U0 sin(ωt + φ) Φ(X) of linear elastodynamics: the sine
/// form (φ = 0) starts undeformed (F = I) with velocity U0 ω Φ(X), the cosine form
/// (φ = π/2, seed 003 §E.5) at rest, displaced by U0 Φ(X).
///
/// - [`SwingingKind::Dilatational`]: the swinging cube (3D) and plate (2D, plane strain)
///   of seed 003 §7.1.1 on [0, 1]^d, Φ_k = sin(πX_k/2) Π_{m≠k} cos(πX_m/2)
///   (A = B = C = 1). Φ = −(2/π)∇Π cos(πX_m/2) is a gradient, so Δu = ∇(∇·u) =
///   −d (π/2)² u and ρ0 ü = (λ + 2μ) Δu holds with ω = (π/2) √d c_d, c_d = √((λ+2μ)/ρ0).
///   u_k = 0 on X_k = 0 (symmetry) and the tangential u = 0 on X_k = 1 (skew-symmetry).
/// - [`SwingingKind::Shear`]: the swinging plate of seed 002 §5.1 (eqs 42–43, 2D) on
///   [0, 2]², Φ = (−sin(πX_1/2) cos(πX_2/2), cos(πX_1/2) sin(πX_2/2)). Φ is
///   divergence-free, so ρ0 ü = μ Δu holds with ω = (π/2) √2 c_s, c_s = √(μ/ρ0); the
///   normal component of u vanishes on every edge of the square (rollers).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwingingMode {
    /// Displacement amplitude U0 [m].
    pub amplitude: f64,
    /// Angular frequency ω [rad/s].
    pub omega: f64,
    /// Phase φ [rad]: 0 for the sine form, π/2 for the cosine form.
    pub phase: f64,
    pub kind: SwingingKind,
}

/// Which swinging mode ([`SwingingMode`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SwingingKind {
    /// Seed 003's mode on [0, 1]^d (2D and 3D).
    #[default]
    Dilatational,
    /// Seed 002's divergence-free mode on [0, 2]² (2D only).
    Shear,
}

impl SwingingMode {
    pub fn new(amplitude: f64, material: &Material, dim: usize, kind: SwingingKind) -> Self {
        let omega = match kind {
            SwingingKind::Dilatational => FRAC_PI_2 * (dim as f64).sqrt() * material.p_wave_speed(),
            SwingingKind::Shear => {
                FRAC_PI_2 * std::f64::consts::SQRT_2 * (material.mu / material.rho0).sqrt()
            }
        };
        Self {
            amplitude,
            omega,
            phase: 0.0,
            kind,
        }
    }

    /// The cosine form u = U0 cos(ωt) Φ(X): at rest and displaced by U0 Φ(X) at t = 0.
    pub fn cosine(self) -> Self {
        Self {
            phase: FRAC_PI_2,
            ..self
        }
    }

    /// Φ(X) of the mode `kind` in `dim` dimensions: the cosine form's initial displacement
    /// per unit amplitude.
    pub fn shape_at(kind: SwingingKind, dim: usize, x: [f64; 3]) -> [f64; 3] {
        let unit = Self {
            amplitude: 1.0,
            omega: 0.0,
            phase: 0.0,
            kind,
        };
        match dim {
            2 => D2::to3(unit.shape::<D2>(D2::from_slice(&x[..2])).0),
            _ => D3::to3(unit.shape::<D3>(D3::from_slice(&x)).0),
        }
    }

    /// Φ(X) and its gradient ∂Φ_k/∂X_l: the shear mode is the dilatational one with its
    /// first component negated.
    fn shape<D: Dim>(&self, x: D::V) -> (D::V, D::T) {
        let (phi, grad) = Self::dilatational::<D>(x);
        match self.kind {
            SwingingKind::Dilatational => (phi, grad),
            SwingingKind::Shear => {
                let e1 = D::from_slice(&[1.0, 0.0, 0.0][..D::N]);
                let flip = D::identity() - D::outer(e1, e1) * 2.0;
                (flip * phi, flip * grad)
            }
        }
    }

    /// Φ(X) and ∂Φ_k/∂X_l of the dilatational mode.
    fn dilatational<D: Dim>(x: D::V) -> (D::V, D::T) {
        let p = D::to3(x);
        let (s, c): (Vec<f64>, Vec<f64>) = (0..D::N)
            .map(|k| ((FRAC_PI_2 * p[k]).sin(), (FRAC_PI_2 * p[k]).cos()))
            .unzip();
        let prod = |sines: &[usize]| -> f64 {
            (0..D::N)
                .map(|m| if sines.contains(&m) { s[m] } else { c[m] })
                .product()
        };
        let phi: Vec<f64> = (0..D::N).map(|k| prod(&[k])).collect();
        let unit = |k: usize| {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            D::from_slice(&e)
        };
        let mut grad = D::zero_t();
        for k in 0..D::N {
            for l in 0..D::N {
                let g = if k == l {
                    FRAC_PI_2 * prod(&[])
                } else {
                    -FRAC_PI_2 * prod(&[k, l])
                };
                grad += D::outer(unit(k), unit(l)) * g;
            }
        }
        (D::from_slice(&phi), grad)
    }

    pub fn displacement<D: Dim>(&self, x: D::V, t: f64) -> D::V {
        self.shape::<D>(x).0 * (self.amplitude * (self.omega * t + self.phase).sin())
    }

    pub fn velocity<D: Dim>(&self, x: D::V, t: f64) -> D::V {
        self.shape::<D>(x).0 * (self.amplitude * self.omega * (self.omega * t + self.phase).cos())
    }

    /// Displacement gradient ∇0u.
    pub fn displacement_gradient<D: Dim>(&self, x: D::V, t: f64) -> D::T {
        self.shape::<D>(x).1 * (self.amplitude * (self.omega * t + self.phase).sin())
    }

    /// Linear-elastic first Piola–Kirchhoff stress λ tr(∇u) I + μ(∇u + ∇uᵀ).
    pub fn stress<D: Dim>(&self, material: &Material, x: D::V, t: f64) -> D::T {
        let g = self.displacement_gradient::<D>(x, t);
        D::identity() * (material.lambda * D::trace(g)) + (g + D::transpose(g)) * material.mu
    }
}

#[cfg(test)]
mod tests;

/// Relative L2 error e = sqrt(Σ_i w_i |q_i − q_ex,i|²) / sqrt(Σ_i w_i |q_ex,i|²), with
/// `q` and `q_ex` holding `w.len()` blocks of equal size (vector or tensor components).
/// NaN when the sizes disagree or the reference is zero.
pub fn relative_l2(w: &[f64], q: &[f64], q_ex: &[f64]) -> f64 {
    if w.is_empty() || q.len() != q_ex.len() || !q.len().is_multiple_of(w.len()) {
        return f64::NAN;
    }
    let block = q.len() / w.len();
    let (mut num, mut den) = (0.0, 0.0);
    for (i, &wi) in w.iter().enumerate() {
        for k in i * block..(i + 1) * block {
            num += wi * (q[k] - q_ex[k]).powi(2);
            den += wi * q_ex[k].powi(2);
        }
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        f64::NAN
    }
}

/// Closed forms a run's fields are measured against: by a study's `[reference]` at the end
/// time, and by the `velocity-error` observer at every row of the time series.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "kebab-case")]
pub enum AnalyticSolution {
    /// The swinging plate/cube of seed 003 §7.1.1 ([`SwingingMode`]); the amplitude is the
    /// case's `swinging` initial velocity.
    Swinging,
    /// d'Alembert's solution for the case's `gaussian-pulse` initial velocity in uniaxial
    /// strain (a laterally confined rod, c = c_p) before the pulse reaches an end: an
    /// unbounded [`Rod`].
    RodPulse,
    /// The free–free rod of seed 001 §9.2: the first body's `gaussian-pulse` initial
    /// velocity along an axis of its box, both ends of the box free: a [`Rod`] with ends,
    /// at the bar speed of [`bar_wave_speed`].
    FreeRod,
    /// The rod of seed 001 §9.2 case A: the first body's box at rest, one end driven at V
    /// along an axis for t < t_p and free after, the other free ([`Rod::driven`]): V, the
    /// axis and t_p from the case's one `velocity` condition with `until`, whose region
    /// holds the end face at the box's lower bound along the axis.
    DrivenRod,
}

/// The nominal stress P11 of compressible neo-Hooke (P = μ(F − F⁻ᵀ) + λ ln J F⁻ᵀ) in
/// homogeneous uniaxial tension λ1 under plane strain (λ3 = 1, the lateral faces free):
/// μ(λ1 − 1/λ1) + λ ln(λ1 λ2)/λ1, with the lateral stretch λ2 from P22 = 0,
/// μ(λ2² − 1) + λ ln(λ1 λ2) = 0, solved by Newton's method from λ2 = 1 (the left side is
/// increasing in λ2, so the root is unique) to round-off.
pub fn neo_hooke_plane_strain_tension(lambda1: f64, mu: f64, lambda: f64) -> f64 {
    let mut lambda2 = 1.0f64;
    for _ in 0..100 {
        let g = mu * (lambda2 * lambda2 - 1.0) + lambda * (lambda1 * lambda2).ln();
        let step = g / (2.0 * mu * lambda2 + lambda / lambda2);
        lambda2 -= step;
        if step.abs() <= 1e-15 * lambda2 {
            break;
        }
    }
    mu * (lambda1 - 1.0 / lambda1) + lambda * (lambda1 * lambda2).ln() / lambda1
}

/// An [`AnalyticSolution`] resolved for a case: with its material, the first body's
/// initial velocity and, for the free rod, its box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Exact {
    Swinging {
        mode: SwingingMode,
        dim: usize,
    },
    /// A longitudinal wave along the unit direction d: v = v(s, t) d, s = X·d, from the
    /// profile g(s) = A exp(−((s − s0)/w)²) of a `gaussian-pulse`.
    Wave {
        rod: Rod,
        direction: [f64; 3],
        amplitude: f64,
        center: f64,
        width: f64,
    },
    /// The rod driven at its lower end along the unit axis d: v = v(s, t) d, s = X·d
    /// ([`DrivenEnd`]).
    Driven {
        rod: Rod,
        direction: [f64; 3],
        end: DrivenEnd,
    },
}

impl Exact {
    /// Of the driven rod: V, and the distance from reference position x to the nearest
    /// jump of v at time t (None for the other solutions).
    pub fn front_distance(&self, x: [f64; 3], t: f64) -> Option<(f64, f64)> {
        match *self {
            Self::Driven { rod, end, .. } => Some((
                end.amplitude,
                rod.driven_front_distance(end, self.coordinate(x), t),
            )),
            _ => None,
        }
    }

    /// Of the driven rod, at a point at rest at distance d from the nearest jump: whether
    /// that jump runs towards it (the point lies ahead of the pulse), i.e. whether it
    /// moves at t + (d + δ)/c, once the jump has passed it by δ (less than the pulse's
    /// length c t_p). False for the other solutions.
    pub fn ahead(&self, x: [f64; 3], t: f64, distance: f64, delta: f64) -> bool {
        match *self {
            Self::Driven { rod, end, .. } => {
                let later = t + (distance + delta) / rod.wave_speed;
                rod.driven(end, self.coordinate(x), later) != 0.0
            }
            _ => false,
        }
    }

    /// The unit direction d of a wave's velocity (NaN for the swinging mode).
    pub fn velocity_direction(&self) -> [f64; 3] {
        match *self {
            Self::Wave { direction, .. } | Self::Driven { direction, .. } => direction,
            Self::Swinging { .. } => [f64::NAN; 3],
        }
    }

    /// The velocity at reference position x (3 components, the unused ones 0) at time t.
    pub fn velocity(&self, x: [f64; 3], t: f64) -> [f64; 3] {
        match *self {
            Self::Swinging { mode, dim } => match dim {
                2 => swinging_velocity::<crate::core::tensor::D2>(mode, x, t),
                _ => swinging_velocity::<crate::core::tensor::D3>(mode, x, t),
            },
            Self::Wave { rod, direction, .. } => {
                let speed = rod.velocity(|s| self.profile(s), self.coordinate(x), t);
                direction.map(|d| speed * d)
            }
            Self::Driven {
                rod,
                direction,
                end,
            } => {
                let speed = rod.driven(end, self.coordinate(x), t);
                direction.map(|d| speed * d)
            }
        }
    }

    /// The axial stress d·P·d of a wave at reference position x and time t (NaN for the
    /// swinging mode, whose stress is a tensor: [`SwingingMode::stress`]).
    pub fn axial_stress(&self, x: [f64; 3], t: f64) -> f64 {
        match *self {
            Self::Swinging { .. } => f64::NAN,
            Self::Wave { rod, .. } => rod.stress(|s| self.profile(s), self.coordinate(x), t),
            Self::Driven { rod, end, .. } => rod.driven_stress(end, self.coordinate(x), t),
        }
    }

    /// s = X·d of a wave.
    fn coordinate(&self, x: [f64; 3]) -> f64 {
        match self {
            Self::Wave { direction, .. } | Self::Driven { direction, .. } => {
                (0..3).map(|k| x[k] * direction[k]).sum()
            }
            Self::Swinging { .. } => f64::NAN,
        }
    }

    /// The initial velocity profile g(s) of a wave.
    fn profile(&self, s: f64) -> f64 {
        match *self {
            Self::Wave {
                amplitude,
                center,
                width,
                ..
            } => amplitude * (-((s - center) / width).powi(2)).exp(),
            Self::Swinging { .. } | Self::Driven { .. } => f64::NAN,
        }
    }
}

fn swinging_velocity<D: Dim>(mode: SwingingMode, x: [f64; 3], t: f64) -> [f64; 3] {
    D::to3(mode.velocity::<D>(D::from_slice(&x), t))
}

#[cfg(test)]
mod tension_tests {
    use super::neo_hooke_plane_strain_tension;
    use crate::core::tensor::{D2, Dim};
    use crate::physics::material::Material;
    use crate::physics::material::MaterialSpec;

    /// Neo-Hooke, E = 1 MPa, ν = 0.45.
    fn rubber() -> Material {
        let spec: MaterialSpec = toml::from_str(
            "model = \"neo-hookean\"\ndensity = 1000.0\nyoungs_modulus = 1.0e6\npoisson_ratio = 0.45",
        )
        .unwrap();
        Material::new(&spec)
    }

    #[test]
    fn uniaxial_plane_strain_tension_leaves_the_lateral_faces_free() {
        let m = rubber();
        // Small strain: the slope is the plane-strain bar modulus 4μ(λ + μ)/(λ + 2μ) =
        // E/(1 − ν²), to the first-order term's relative 1e-3 at ε = 1e-6 (round-off).
        let eps = 1e-6;
        let slope = neo_hooke_plane_strain_tension(1.0 + eps, m.mu, m.lambda) / eps;
        let bar = 4.0 * m.mu * (m.lambda + m.mu) / (m.lambda + 2.0 * m.mu);
        assert!((slope / bar - 1.0).abs() < 1e-5, "{slope} vs {bar}");
        // At λ1 = 1.5: the material's own P at F = diag(λ1, λ2), λ2 found by bisection
        // on its P22, has P11 equal to the closed form and P12 = P21 = 0.
        let p = |l2: f64| m.pk1::<D2>(glam::DMat2::from_diagonal(glam::DVec2::new(1.5, l2)));
        let (mut lo, mut hi) = (0.3, 1.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if D2::entry(p(mid), 1, 1) < 0.0 {
                lo = mid
            } else {
                hi = mid
            }
        }
        let p11 = D2::entry(p(lo), 0, 0);
        let closed = neo_hooke_plane_strain_tension(1.5, m.mu, m.lambda);
        assert!((closed / p11 - 1.0).abs() < 1e-12, "{closed} vs {p11}");
    }
}
