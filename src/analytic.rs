//! Closed-form solutions that cases are checked against, and the relative L2 norm their
//! errors are measured in.

use crate::material::Material;
use crate::scene::{Case, Condition, DisplacementField, Shape, VelocityField};
use crate::tensor::{D2, D3, Dim};
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

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
mod tests {
    use super::*;
    use crate::material::MaterialModel;
    use crate::scene::MaterialSpec;
    use crate::tensor::{D2, D3};

    fn material() -> Material {
        Material::new(&MaterialSpec {
            model: MaterialModel::NeoHookean,
            density: 1100.0,
            youngs_modulus: Some(1.7e7),
            poisson_ratio: Some(0.3),
            yield_stress: None,
            hardening_modulus: None,
            c1: None,
            c2: None,
            lambda: None,
            plane: crate::scene::Plane::Strain,
        })
    }

    /// ρ0 ü = DIV P at interior points, by central differences of the analytic stress
    /// (step 1e-4: truncation ~1e-8 relative, well inside the 1e-6 bound).
    fn satisfies_elastodynamics<D: Dim>(kind: SwingingKind) {
        let mat = material();
        let sine = SwingingMode::new(5e-4, &mat, D::N, kind);
        for mode in [sine, sine.cosine()] {
            satisfies_elastodynamics_in::<D>(&mat, mode);
        }
    }

    fn satisfies_elastodynamics_in<D: Dim>(mat: &Material, mode: SwingingMode) {
        let t = 0.3 / mode.omega;
        let h = 1e-4;
        for x in [
            [0.3, 0.6, 0.2],
            [0.85, 0.1, 0.5],
            [0.5, 0.5, 0.9],
            [1.7, 1.2, 0.4],
        ] {
            let x = D::from_slice(&x);
            let accel = mode.displacement::<D>(x, t) * (-mode.omega * mode.omega * mat.rho0);
            let mut div = vec![0.0; D::N];
            for l in 0..D::N {
                let mut e = [0.0; 3];
                e[l] = h;
                let dp = mode.stress::<D>(mat, x + D::from_slice(&e), t)
                    - mode.stress::<D>(mat, x - D::from_slice(&e), t);
                for (k, d) in div.iter_mut().enumerate() {
                    *d += D::entry(dp, k, l) / (2.0 * h);
                }
            }
            let (a, d) = (D::to3(accel), div);
            let scale = D::norm2(accel).sqrt();
            for k in 0..D::N {
                assert!((a[k] - d[k]).abs() < 1e-6 * scale, "{a:?} vs {d:?}");
            }
        }
    }

    #[test]
    fn swinging_plate_and_cube_solve_linear_elastodynamics() {
        satisfies_elastodynamics::<D2>(SwingingKind::Dilatational);
        satisfies_elastodynamics::<D3>(SwingingKind::Dilatational);
        satisfies_elastodynamics::<D2>(SwingingKind::Shear);
    }

    #[test]
    fn the_cosine_form_starts_at_rest_displaced_by_the_shape() {
        // u = U0 cos(ωt) Φ: u(0) = U0 Φ as `shape_at` gives it, v(0) = 0, and at any t
        // the sine form a quarter period later (exact identities, so round-off bounds).
        let mat = material();
        let sine = SwingingMode::new(5e-4, &mat, 3, SwingingKind::Dilatational);
        let cosine = sine.cosine();
        let x = [0.3, 0.6, 0.2];
        let xv = D3::from_slice(&x);
        let u0 = D3::to3(cosine.displacement::<D3>(xv, 0.0));
        let phi = SwingingMode::shape_at(SwingingKind::Dilatational, 3, x);
        for k in 0..3 {
            assert!((u0[k] - 5e-4 * phi[k]).abs() < 1e-18, "{u0:?} vs {phi:?}");
        }
        // cos(π/2) is 6.1e-17 in f64: v(0) is that fraction of U0 ω.
        let v0 = D3::norm2(cosine.velocity::<D3>(xv, 0.0)).sqrt();
        assert!(v0 < 1e-16 * 5e-4 * sine.omega, "v(0) = {v0:e}");
        let t = 1.3e-3;
        let quarter = FRAC_PI_2 / sine.omega;
        let (a, b) = (
            cosine.velocity::<D3>(xv, t),
            sine.velocity::<D3>(xv, t + quarter),
        );
        assert!(D3::norm2(a - b).sqrt() < 1e-12 * D3::norm2(b).sqrt());
    }

    #[test]
    fn the_shear_mode_is_seed_002s_with_rollers_on_the_square() {
        // Eq 42 at a = π/2, ω of eq 43 (159.708 rad/s at E = 17 MPa, ν = 0.495 in the
        // note's derivation, here at ν = 0.3 from the same formula), and u·n = 0 on the
        // four edges of [0, 2]².
        let mat = material();
        let mode = SwingingMode::new(0.01, &mat, 2, SwingingKind::Shear);
        assert!((mode.omega - FRAC_PI_2 * (2.0 * mat.mu / mat.rho0).sqrt()).abs() < 1e-9);
        let t = 0.2 / mode.omega;
        let (x1, x2) = (0.7, 1.3);
        let u = mode.displacement::<D2>(D2::from_slice(&[x1, x2]), t);
        let a = FRAC_PI_2;
        let s = 0.01 * (mode.omega * t).sin();
        assert!((u.x + s * (a * x1).sin() * (a * x2).cos()).abs() < 1e-15);
        assert!((u.y - s * (a * x1).cos() * (a * x2).sin()).abs() < 1e-15);
        for e in [0.0, 2.0] {
            for q in [0.3, 1.1] {
                assert!(mode.displacement::<D2>(D2::from_slice(&[e, q]), t).x.abs() < 1e-15);
                assert!(mode.displacement::<D2>(D2::from_slice(&[q, e]), t).y.abs() < 1e-15);
            }
        }
    }

    #[test]
    fn swinging_mode_meets_its_boundary_conditions() {
        let mode = SwingingMode::new(1.0, &material(), 3, SwingingKind::Dilatational);
        let u0 = D3::to3(mode.displacement::<D3>(D3::from_slice(&[0.0, 0.4, 0.7]), 1e-3));
        assert_eq!(u0[0], 0.0);
        let u1 = D3::to3(mode.displacement::<D3>(D3::from_slice(&[1.0, 0.4, 0.7]), 1e-3));
        assert!(u1[1].abs() < 1e-15 && u1[2].abs() < 1e-15 && u1[0] != 0.0);
    }
}

/// The cantilever of Timoshenko & Goodier with a parabolic shear P at x = L (seed 004 eqs
/// 53–55; plane stress, I = D³/12 per unit thickness): u_y(L, y) = −P/(6EI) [(4 + 5ν)
/// D² L/4 + 2L³] at the loaded end, 2.77284e-6 m for the seed's beam. The traction on
/// x = L is t_y = τ_xy(L, y), of resultant −P; the end x = 0 takes the solution's own
/// displacement (u = 0 at y = 0, not zero elsewhere). The beam is plane stress; plane strain with E and ν has the same
/// solution with E/(1 − ν²) and ν/(1 − ν) in their place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cantilever {
    /// End load P per unit thickness [N/m].
    pub load: f64,
    pub length: f64,
    pub depth: f64,
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
}

impl Cantilever {
    /// I = D³/12.
    fn inertia(&self) -> f64 {
        self.depth.powi(3) / 12.0
    }

    /// (u_x, u_y) at (x, y), eqs 53–54.
    pub fn displacement(&self, x: f64, y: f64) -> [f64; 2] {
        let (p, l, d, nu) = (self.load, self.length, self.depth, self.poisson_ratio);
        let c = p / (6.0 * self.youngs_modulus * self.inertia());
        [
            c * y * ((6.0 * l - 3.0 * x) * x + (2.0 + nu) * (y * y - d * d / 4.0)),
            -c * (3.0 * nu * y * y * (l - x)
                + (4.0 + 5.0 * nu) * d * d * x / 4.0
                + (3.0 * l - x) * x * x),
        ]
    }

    /// The displacement gradient ∂u_k/∂x_l of eqs 53–54, [[∂u_x/∂x, ∂u_x/∂y], [∂u_y/∂x,
    /// ∂u_y/∂y]].
    pub fn displacement_gradient(&self, x: f64, y: f64) -> [[f64; 2]; 2] {
        let (p, l, d, nu) = (self.load, self.length, self.depth, self.poisson_ratio);
        let c = p / (6.0 * self.youngs_modulus * self.inertia());
        [
            [
                c * y * (6.0 * l - 6.0 * x),
                c * ((6.0 * l - 3.0 * x) * x + (2.0 + nu) * (3.0 * y * y - d * d / 4.0)),
            ],
            [
                -c * (-3.0 * nu * y * y + (4.0 + 5.0 * nu) * d * d / 4.0 + 6.0 * l * x
                    - 3.0 * x * x),
                -c * 6.0 * nu * y * (l - x),
            ],
        ]
    }

    /// (σ_xx, σ_yy, τ_xy) at (x, y), eq 55.
    pub fn stress(&self, x: f64, y: f64) -> [f64; 3] {
        let (p, l, d, i) = (self.load, self.length, self.depth, self.inertia());
        [
            p * (l - x) * y / i,
            0.0,
            -p / (2.0 * i) * (d * d / 4.0 - y * y),
        ]
    }
}

/// A case's closed-form solution with its material's E and ν.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClosedForm {
    Cantilever(Cantilever),
    /// Uniaxial stress σ along the axis a: u_a = σX_a/E, u_k = −νσX_k/E (k ≠ a).
    Uniaxial {
        stress: f64,
        axis: usize,
        youngs_modulus: f64,
        poisson_ratio: f64,
    },
}

impl ClosedForm {
    pub fn of(solution: &crate::scene::Solution, material: &crate::scene::MaterialSpec) -> Self {
        let (youngs_modulus, poisson_ratio) = material.youngs_and_poisson();
        match *solution {
            crate::scene::Solution::TimoshenkoCantilever {
                load,
                length,
                depth,
            } => Self::Cantilever(Cantilever {
                load,
                length,
                depth,
                youngs_modulus,
                poisson_ratio,
            }),
            crate::scene::Solution::UniaxialStress { stress, axis } => Self::Uniaxial {
                stress,
                axis: axis.index(),
                youngs_modulus,
                poisson_ratio,
            },
        }
    }

    /// The displacement at a reference position, three components (the cantilever's
    /// plane-stress solution has u_z = 0).
    pub fn displacement3(&self, x: [f64; 3]) -> [f64; 3] {
        match *self {
            Self::Cantilever(c) => {
                let [ux, uy] = c.displacement(x[0], x[1]);
                [ux, uy, 0.0]
            }
            Self::Uniaxial {
                stress,
                axis,
                youngs_modulus,
                poisson_ratio,
            } => {
                let e = stress / youngs_modulus;
                std::array::from_fn(|k| {
                    if k == axis {
                        e * x[k]
                    } else {
                        -poisson_ratio * e * x[k]
                    }
                })
            }
        }
    }

    /// The displacement gradient ∂u_k/∂X_l at a reference position, 3×3.
    pub fn displacement_gradient3(&self, x: [f64; 3]) -> [[f64; 3]; 3] {
        match *self {
            Self::Cantilever(c) => {
                let g = c.displacement_gradient(x[0], x[1]);
                [[g[0][0], g[0][1], 0.0], [g[1][0], g[1][1], 0.0], [0.0; 3]]
            }
            Self::Uniaxial {
                stress,
                axis,
                youngs_modulus,
                poisson_ratio,
            } => {
                let e = stress / youngs_modulus;
                std::array::from_fn(|k| {
                    std::array::from_fn(|l| match (k == l, k == axis) {
                        (false, _) => 0.0,
                        (true, true) => e,
                        (true, false) => -poisson_ratio * e,
                    })
                })
            }
        }
    }

    /// The Cauchy stress at a reference position as a 3×3 tensor.
    pub fn stress3(&self, x: [f64; 3]) -> [[f64; 3]; 3] {
        match *self {
            Self::Cantilever(c) => {
                let [sxx, syy, txy] = c.stress(x[0], x[1]);
                [[sxx, txy, 0.0], [txy, syy, 0.0], [0.0, 0.0, 0.0]]
            }
            Self::Uniaxial { stress, axis, .. } => {
                let mut s = [[0.0; 3]; 3];
                s[axis][axis] = stress;
                s
            }
        }
    }
}

#[cfg(test)]
mod cantilever_tests {
    use super::*;

    /// The substitute beam of seed 001 §9.1: L = 48, D = 12, E = 3e7, ν = 0.3, P = 1000.
    const BEAM: Cantilever = Cantilever {
        load: 1000.0,
        length: 48.0,
        depth: 12.0,
        youngs_modulus: 3.0e7,
        poisson_ratio: 0.3,
    };

    /// Points spread over the beam, edges included.
    fn points() -> Vec<(f64, f64)> {
        let mut p = Vec::new();
        for x in [0.0, 7.3, 24.0, 40.1, 48.0] {
            for y in [-6.0, -2.9, 0.0, 4.4, 6.0] {
                p.push((x, y));
            }
        }
        p
    }

    #[test]
    fn the_cantilever_gradient_is_the_derivative_of_its_displacement() {
        // Central differences of step 1e-3 of a cubic displacement: the truncation h²/6
        // times the third derivative (6P/(6EI)) is 4e-14, below 1e-9 of the largest
        // gradient component (6.7e-5), so 1e-8 of it leaves a margin; a wrong term is off
        // by 1e-2 of it or more.
        let h = 1e-3;
        let scale = points()
            .iter()
            .flat_map(|&(x, y)| BEAM.displacement_gradient(x, y).into_iter().flatten())
            .fold(0.0, |m: f64, g| m.max(g.abs()));
        for (x, y) in points() {
            let g = BEAM.displacement_gradient(x, y);
            let dx = [0, 1].map(|k| {
                (BEAM.displacement(x + h, y)[k] - BEAM.displacement(x - h, y)[k]) / (2.0 * h)
            });
            let dy = [0, 1].map(|k| {
                (BEAM.displacement(x, y + h)[k] - BEAM.displacement(x, y - h)[k]) / (2.0 * h)
            });
            for k in 0..2 {
                assert!((g[k][0] - dx[k]).abs() < 1e-8 * scale, "({x}, {y}): {g:?}");
                assert!((g[k][1] - dy[k]).abs() < 1e-8 * scale, "({x}, {y}): {g:?}");
            }
        }
    }

    #[test]
    fn the_cantilever_stress_is_plane_stress_hooke_and_in_equilibrium() {
        // σ = E/(1 − ν²)(ε + ν ε_other) and τ = G γ (plane stress) from the gradient equal
        // eq 55 to 1e-9 of the largest stress PLD/(2I) (round-off), and div σ = 0 by
        // central differences of step 1e-3 (σ is at most quadratic: exact up to
        // round-off, which the step magnifies to ~1e-10; bound 1e-6).
        let (e, nu) = (BEAM.youngs_modulus, BEAM.poisson_ratio);
        let scale = BEAM.load * BEAM.length * 6.0 / 144.0;
        let h = 1e-3;
        for (x, y) in points() {
            let g = BEAM.displacement_gradient(x, y);
            let (exx, eyy, gxy) = (g[0][0], g[1][1], g[0][1] + g[1][0]);
            let hooke = [
                e / (1.0 - nu * nu) * (exx + nu * eyy),
                e / (1.0 - nu * nu) * (eyy + nu * exx),
                e / (2.0 * (1.0 + nu)) * gxy,
            ];
            let s = BEAM.stress(x, y);
            for k in 0..3 {
                assert!(
                    (s[k] - hooke[k]).abs() < 1e-9 * scale,
                    "({x}, {y}): {s:?} {hooke:?}"
                );
            }
            let d = |k: usize, dx: f64, dy: f64| {
                (BEAM.stress(x + dx, y + dy)[k] - BEAM.stress(x - dx, y - dy)[k]) / (2.0 * h)
            };
            let div_x = d(0, h, 0.0) + d(2, 0.0, h);
            let div_y = d(2, h, 0.0) + d(1, 0.0, h);
            assert!(div_x.abs() < 1e-6 * scale && div_y.abs() < 1e-6 * scale);
        }
    }

    #[test]
    fn the_cantilever_meets_its_boundary_conditions() {
        // Free faces y = ±D/2 (σ_yy = τ_xy = 0), no normal stress at x = L and a shear
        // there summing to −P (2-point Gauss on 4 pieces, exact for the parabola); the
        // point (0, 0) is fixed. Bounds: round-off.
        let scale = BEAM.load * BEAM.length * 6.0 / 144.0;
        for x in [0.0, 13.0, 48.0] {
            for y in [-6.0, 6.0] {
                let s = BEAM.stress(x, y);
                assert!(s[1].abs() < 1e-12 * scale && s[2].abs() < 1e-12 * scale);
            }
        }
        let g = 0.5 / 3f64.sqrt();
        let mut resultant = 0.0;
        for piece in 0..4 {
            let (lo, hi) = (-6.0 + 3.0 * f64::from(piece), -3.0 + 3.0 * f64::from(piece));
            for s in [-g, g] {
                let y = 0.5 * (lo + hi) + s * (hi - lo);
                assert!(BEAM.stress(48.0, y)[0].abs() < 1e-12 * scale);
                resultant += BEAM.stress(48.0, y)[2] * (hi - lo) / 2.0;
            }
        }
        assert!(
            (resultant + BEAM.load).abs() < 1e-12 * BEAM.load,
            "{resultant}"
        );
        assert_eq!(BEAM.displacement(0.0, 0.0), [0.0, 0.0]);
        // The benchmark's tip deflection −P/(6EI)[(4 + 5ν)D²L/4 + 2L³] = −0.0089.
        let tip = BEAM.displacement(48.0, 0.0)[1];
        assert!((tip + 0.0089).abs() < 1e-12, "{tip}");
    }
}

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

/// d'Alembert's solution of the 1D wave equation ρ0 ∂v/∂t = ∂σ/∂s, ∂σ/∂t = ρ0 c² ∂v/∂s
/// from an initial velocity g(s) and no initial stress:
///
///   v(s, t) = ½[ĝ(s − ct) + ĝ(s + ct)],   σ(s, t) = ½ ρ0 c [ĝ(s + ct) − ĝ(s − ct)].
///
/// Unbounded (`ends = None`), ĝ = g. Between free ends a < b (σ = 0 there), ĝ is the even,
/// 2(b − a)-periodic extension of g about both ends: a free end reflects the velocity
/// with its sign kept and the stress with its sign reversed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rod {
    /// c [m/s].
    pub wave_speed: f64,
    /// ρ0 [kg/m³].
    pub density: f64,
    /// The free ends [a, b], if any.
    pub ends: Option<[f64; 2]>,
}

impl Rod {
    /// The point of [a, b] that s folds onto, so that ĝ(s) = g(fold(s)).
    pub fn fold(&self, s: f64) -> f64 {
        let Some([a, b]) = self.ends else {
            return s;
        };
        let l = b - a;
        let r = (s - a).rem_euclid(2.0 * l);
        a + if r > l { 2.0 * l - r } else { r }
    }

    /// v(s, t) for the initial velocity g.
    pub fn velocity(&self, g: impl Fn(f64) -> f64, s: f64, t: f64) -> f64 {
        let ct = self.wave_speed * t;
        0.5 * (g(self.fold(s - ct)) + g(self.fold(s + ct)))
    }

    /// σ(s, t) for the initial velocity g (small strain: the axial stress, P = σ).
    pub fn stress(&self, g: impl Fn(f64) -> f64, s: f64, t: f64) -> f64 {
        let ct = self.wave_speed * t;
        0.5 * self.density * self.wave_speed * (g(self.fold(s + ct)) - g(self.fold(s - ct)))
    }
}

/// The rod at rest whose end a is driven at velocity V from t = 0 to the release t_p and
/// free after, the end b free (seed 001 §9.2 case A; c t_p ≤ L = b − a, so the pulse has
/// left the driven end before it returns). With f the 2L-periodic function equal to V on
/// (a − c t_p, a) modulo 2L and 0 elsewhere:
///
///   v(s, t) = f(s − ct) + H(t − t_p) f(2a − s − ct),
///   σ(s, t) = ρ0 c [H(t − t_p) f(2a − s − ct) − f(s − ct)].
///
/// While driven (t < t_p) only the right-running wave f(s − ct) is in the rod: V on
/// (a, a + ct), 0 ahead, the end keeping v = V. From the release both ends are free,
/// where d'Alembert's v = F(s − ct) + G(s + ct) needs σ = ρ0 c (G − F) = 0: G(a + ct) =
/// F(a − ct), so G(ξ) = F(2a − ξ), and F(b − ct) = F(2a − b − ct), so F is 2L-periodic;
/// F = f matches the state at t_p, where f(2a − s − ct_p) vanishes on (a, b). The image
/// term is the wave the free end reflects with its velocity sign kept (and its stress
/// sign reversed). A right-running wave carries σ = −ρ0 c v: compression behind a pushed
/// end. Momentum ρ0 V c min(t, t_p) per unit area, energy ρ0 V² c min(t, t_p), half of it
/// kinetic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrivenEnd {
    /// V [m/s].
    pub amplitude: f64,
    /// t_p [s].
    pub duration: f64,
}

impl Rod {
    /// f(ξ) of [`DrivenEnd`]: V on (a − c t_p, a) modulo 2L.
    fn driven_profile(&self, end: DrivenEnd, xi: f64) -> f64 {
        let [a, b] = self.ends.expect("a driven rod has ends");
        let length = self.wave_speed * end.duration;
        if (xi - (a - length)).rem_euclid(2.0 * (b - a)) < length {
            end.amplitude
        } else {
            0.0
        }
    }

    /// The right-running wave f(s − ct) and the image f(2a − s − ct) present from t_p.
    fn driven_waves(&self, end: DrivenEnd, s: f64, t: f64) -> (f64, f64) {
        let [a, _] = self.ends.expect("a driven rod has ends");
        let ct = self.wave_speed * t;
        let image = if t >= end.duration {
            self.driven_profile(end, 2.0 * a - s - ct)
        } else {
            0.0
        };
        (self.driven_profile(end, s - ct), image)
    }

    /// v(s, t) of the rod driven at its end a ([`DrivenEnd`]).
    pub fn driven(&self, end: DrivenEnd, s: f64, t: f64) -> f64 {
        let (right, image) = self.driven_waves(end, s, t);
        right + image
    }

    /// σ(s, t) of the rod driven at its end a ([`DrivenEnd`]).
    pub fn driven_stress(&self, end: DrivenEnd, s: f64, t: f64) -> f64 {
        let (right, image) = self.driven_waves(end, s, t);
        self.density * self.wave_speed * (image - right)
    }

    /// The distance from s to the nearest jump of the driven rod's v at time t: the jumps
    /// of f at a − c t_p and a (modulo 2L), carried by both waves.
    pub fn driven_front_distance(&self, end: DrivenEnd, s: f64, t: f64) -> f64 {
        let [a, b] = self.ends.expect("a driven rod has ends");
        let (ct, length, period) = (
            self.wave_speed * t,
            self.wave_speed * end.duration,
            2.0 * (b - a),
        );
        let mut jumps = vec![a - length + ct, a + ct];
        if t >= end.duration {
            // 2a − s − ct = ξ at s = 2a − ct − ξ.
            jumps.extend([a + length - ct, a - ct]);
        }
        jumps
            .into_iter()
            .map(|p| ((s - p + 0.5 * period).rem_euclid(period) - 0.5 * period).abs())
            .fold(f64::INFINITY, f64::min)
    }
}

/// The speed of a longitudinal wave in a bar with free lateral faces, long waves:
/// sqrt(E_bar/ρ0) with E_bar the modulus of uniaxial stress. In 3D E_bar = E =
/// μ(3λ + 2μ)/(λ + μ). In 2D E_bar = 4μ(λ + μ)/(λ + 2μ) with the model's in-plane λ: E in
/// plane stress, E/(1 − ν²) in plane strain (σ_zz holds ε_zz = 0). At ν = 0 every one of
/// them is sqrt(E/ρ0) = c_p, and the 1D solution is exact; at ν ≠ 0 the lateral inertia
/// makes the wave dispersive and this is its long-wave limit only.
pub fn bar_wave_speed(material: &Material, dim: usize) -> f64 {
    let (lambda, mu) = (material.lambda, material.mu);
    let modulus = if dim == 2 {
        4.0 * mu * (lambda + mu) / (lambda + 2.0 * mu)
    } else {
        mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu)
    };
    (modulus / material.rho0).sqrt()
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
    /// The solution `solution` of `case`, or why the case does not have it.
    pub fn of(solution: AnalyticSolution, case: &Case) -> Result<Self, String> {
        let body = case.bodies.first().ok_or("the case has no body")?;
        let material = Material::new(&case.material);
        let dim = case.dim();
        let name = crate::scene::validate::toml_name(&solution);
        match (solution, &body.initial_velocity) {
            (AnalyticSolution::Swinging, Some(VelocityField::Swinging { amplitude, mode })) => {
                if body.initial_displacement.is_some() {
                    return Err(format!(
                        "the analytic solution \"{name}\" in its sine form starts undeformed; \
                         remove the first body's initial displacement (or its velocity, for \
                         the cosine form)"
                    ));
                }
                Ok(Self::Swinging {
                    mode: SwingingMode::new(*amplitude, &material, dim, *mode),
                    dim,
                })
            }
            (AnalyticSolution::Swinging, None) => match &body.initial_displacement {
                Some(DisplacementField::Swinging { amplitude, mode }) => Ok(Self::Swinging {
                    mode: SwingingMode::new(*amplitude, &material, dim, *mode).cosine(),
                    dim,
                }),
                _ => Err(format!(
                    "the analytic solution \"{name}\" needs the first body to start in a \
                     swinging mode: a `swinging` initial velocity (sine form) or initial \
                     displacement (cosine form)"
                )),
            },
            (
                AnalyticSolution::RodPulse | AnalyticSolution::FreeRod,
                Some(VelocityField::GaussianPulse {
                    amplitude,
                    direction,
                    center,
                    width,
                }),
            ) => {
                let n = direction.iter().map(|d| d * d).sum::<f64>().sqrt();
                let mut d = [0.0; 3];
                for (k, x) in direction.iter().enumerate().take(3) {
                    d[k] = x / n;
                }
                let rod = if solution == AnalyticSolution::RodPulse {
                    Rod {
                        wave_speed: material.p_wave_speed(),
                        density: material.rho0,
                        ends: None,
                    }
                } else {
                    let Shape::Box { min, max, .. } = &body.geometry else {
                        return Err(format!(
                            "\"{name}\" is a rod between the faces of a box: give the first \
                             body a `box` geometry"
                        ));
                    };
                    let axis = (0..dim).find(|&k| d[k].abs() == 1.0).ok_or_else(|| {
                        format!(
                            "\"{name}\" needs the pulse along an axis of the box; the first \
                             body's `gaussian-pulse` direction is {direction:?}"
                        )
                    })?;
                    Rod {
                        wave_speed: bar_wave_speed(&material, dim),
                        density: material.rho0,
                        ends: Some([min[axis], max[axis]]),
                    }
                };
                Ok(Self::Wave {
                    rod,
                    direction: d,
                    amplitude: *amplitude,
                    center: *center,
                    width: *width,
                })
            }
            (AnalyticSolution::DrivenRod, None) => Self::driven(case, &material),
            (AnalyticSolution::DrivenRod, Some(field)) => Err(format!(
                "the analytic solution \"{name}\" is a rod at rest, driven at an end; the \
                 first body has the initial velocity `{}`: remove it",
                velocity_name(field)
            )),
            (_, field) => Err(format!(
                "the analytic solution \"{name}\" needs the matching initial velocity of the \
                 first body ({}), which has {}",
                match solution {
                    AnalyticSolution::Swinging => "`swinging`",
                    _ => "`gaussian-pulse`",
                },
                field
                    .as_ref()
                    .map_or("none".to_string(), |f| format!("`{}`", velocity_name(f)))
            )),
        }
    }

    /// The [`Exact::Driven`] rod of `case` (see [`AnalyticSolution::DrivenRod`]).
    fn driven(case: &Case, material: &Material) -> Result<Self, String> {
        let name = "\"driven-rod\"";
        let body = &case.bodies[0];
        let Shape::Box { min, max, .. } = &body.geometry else {
            return Err(format!(
                "{name} is a rod between the faces of a box: give the first body a `box` geometry"
            ));
        };
        let released: Vec<usize> = (0..case.boundaries.len())
            .filter(|&b| {
                matches!(
                    case.boundaries[b].condition,
                    Condition::Velocity { until: Some(_), .. }
                )
            })
            .collect();
        let [b] = released[..] else {
            return Err(format!(
                "{name} needs one `velocity` condition with `until` (the driven end), the case \
                 has {}",
                released.len()
            ));
        };
        let bc = &case.boundaries[b];
        let Condition::Velocity {
            vx,
            vy,
            vz,
            law,
            until: Some(until),
        } = &bc.condition
        else {
            unreachable!("a velocity condition with a release")
        };
        if !law.is_constant() {
            return Err(format!(
                "{name} holds the driven end at a constant velocity; boundary.{b}.condition has \
                 a time law: remove it"
            ));
        }
        let given: Vec<(usize, f64)> = [vx, vy, vz]
            .iter()
            .enumerate()
            .filter_map(|(k, v)| v.map(|v| (k, v)))
            .collect();
        let [(axis, amplitude)] = given[..] else {
            return Err(format!(
                "{name} drives the end along the rod's axis: boundary.{b}.condition must give \
                 one velocity component, it gives {}",
                given.len()
            ));
        };
        let region = &bc.region;
        let upper = [region.x_max, region.y_max, region.z_max][axis];
        if upper.is_none_or(|u| (u - min[axis]).abs() > 0.5 * case.spacing) {
            return Err(format!(
                "{name} drives the box's lower end along {}: boundary.{b}.region must hold the \
                 end face only, {}_max = {} (the box's lower bound)",
                ["x", "y", "z"][axis],
                ["x", "y", "z"][axis],
                min[axis]
            ));
        }
        let rod = Rod {
            wave_speed: bar_wave_speed(material, case.dim()),
            density: material.rho0,
            ends: Some([min[axis], max[axis]]),
        };
        let length = max[axis] - min[axis];
        if rod.wave_speed * until > length {
            return Err(format!(
                "{name} needs the pulse no longer than the rod: c t_p = {:.4e} m for `until` = \
                 {until:e} s, the rod is {length:e} m long",
                rod.wave_speed * until
            ));
        }
        let mut direction = [0.0; 3];
        direction[axis] = 1.0;
        Ok(Self::Driven {
            rod,
            direction,
            end: DrivenEnd {
                amplitude,
                duration: *until,
            },
        })
    }

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
                2 => swinging_velocity::<crate::tensor::D2>(mode, x, t),
                _ => swinging_velocity::<crate::tensor::D3>(mode, x, t),
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

/// The `type` of an initial velocity field, as case files name it.
fn velocity_name(field: &VelocityField) -> String {
    serde_json::to_value(field)
        .ok()
        .and_then(|v| v.get("type").and_then(|t| t.as_str().map(str::to_string)))
        .unwrap_or_else(|| "?".into())
}

#[cfg(test)]
mod rod_tests {
    use super::*;
    use crate::material::MaterialModel;
    use crate::scene::{MaterialSpec, Plane};

    /// Seed 001 §9.2's rod: L = 60 mm, c = sqrt(E/ρ0) of steel, a Gaussian of α = 0.025
    /// mm⁻² at x0 (m).
    const L: f64 = 0.06;
    const C: f64 = 5188.745216627708;
    const RHO: f64 = 7800.0;

    fn rod() -> Rod {
        Rod {
            wave_speed: C,
            density: RHO,
            ends: Some([0.0, L]),
        }
    }

    fn gaussian(x0: f64) -> impl Fn(f64) -> f64 {
        move |s: f64| (-((s - x0) / 6.324555320336759e-3).powi(2)).exp()
    }

    /// s = 0, …, L in n steps.
    fn grid(n: usize) -> impl Iterator<Item = f64> {
        (0..=n).map(move |k| L * k as f64 / n as f64)
    }

    #[test]
    fn folding_reflects_about_both_ends_with_period_2l() {
        let r = rod();
        // Inside the rod nothing moves; outside, mirror images about 0 and L, period 2L.
        // Bounds: round-off of rem_euclid on numbers of size L (1e-17 m).
        for (s, folded) in [
            (0.02, 0.02),
            (-0.02, 0.02),
            (0.07, 0.05),
            (0.12, 0.0),
            (0.13, 0.01),
            (-0.11, 0.01),
        ] {
            assert!(
                (r.fold(s) - folded).abs() < 1e-15,
                "fold({s}) = {}",
                r.fold(s)
            );
        }
        let free = Rod { ends: None, ..r };
        assert_eq!(free.fold(-0.3), -0.3);
    }

    #[test]
    fn the_pulse_re_forms_at_every_return() {
        // g symmetric about L/2 comes back at t = L/c and 2L/c; g off the centre comes back
        // mirrored, g(L − s), at L/c and as it was at 2L/c (the period). Only round-off of
        // fold and exp separates them: 1e-12 of the amplitude.
        let r = rod();
        for x0 in [0.5 * L, 0.02] {
            let g = gaussian(x0);
            for s in grid(600) {
                let first = r.velocity(&g, s, L / C);
                let second = r.velocity(&g, s, 2.0 * L / C);
                assert!(
                    (first - g(L - s)).abs() < 1e-12,
                    "x0 = {x0}, s = {s}: {first}"
                );
                assert!(
                    (second - g(s)).abs() < 1e-12,
                    "x0 = {x0}, s = {s}: {second}"
                );
            }
        }
        // Halfway to the first return the halves sit at the ends, each of half the peak
        // there, merged with their images into the full peak: v(0, L/2c) = g(L/2) = 1.
        let g = gaussian(0.5 * L);
        assert!((r.velocity(&g, 0.0, 0.5 * L / C) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn momentum_and_energy_stay_constant_and_the_ends_stay_free() {
        // ∫ρ0 v ds and ∫(½ρ0 v² + σ²/(2ρ0c²)) ds over [0, L] by the trapezoidal rule on
        // 24,000 intervals: g is smooth (its tails at the ends are 1e-10 of the peak and
        // the folds keep ĝ continuous), so the rule's error is far below the 1e-9 bound.
        let r = rod();
        let g = gaussian(0.021);
        let n = 24_000;
        let ds = L / n as f64;
        let integral = |f: &dyn Fn(f64) -> f64| {
            grid(n)
                .map(|s| if s == 0.0 || s == L { 0.5 } else { 1.0 } * f(s))
                .sum::<f64>()
                * ds
        };
        let energy = |t: f64| {
            integral(&|s| {
                let (v, sigma) = (r.velocity(&g, s, t), r.stress(&g, s, t));
                0.5 * RHO * v * v + sigma * sigma / (2.0 * RHO * C * C)
            })
        };
        let (p0, e0) = (integral(&|s| RHO * g(s)), energy(0.0));
        for t in [1.3e-6, 4.0e-6, 9.7e-6, 1.6e-5, 2.9e-5] {
            let p = integral(&|s| RHO * r.velocity(&g, s, t));
            assert!((p - p0).abs() < 1e-9 * p0, "t = {t}: momentum {p} vs {p0}");
            let e = energy(t);
            assert!((e - e0).abs() < 1e-9 * e0, "t = {t}: energy {e} vs {e0}");
            // σ = 0 at both ends (ĝ is even about them), up to the round-off of fold, 1e-17
            // m on a profile of slope ≤ 1/w: 1e-12 of the scale ρ0c.
            for end in [0.0, L] {
                let sigma = r.stress(&g, end, t);
                assert!(sigma.abs() < 1e-12 * RHO * C, "t = {t}: σ({end}) = {sigma}");
            }
        }
    }

    #[test]
    fn the_solution_satisfies_the_wave_equation() {
        // ρ0 ∂v/∂t = ∂σ/∂s and ∂σ/∂t = ρ0c² ∂v/∂s by central differences (step δ = 1 µm
        // and its time of flight): truncation ~(δ/w)²/6 = 4e-9 of the terms' scale ρ0c/w
        // (times c for the second), bound 1e-6.
        let r = rod();
        let g = gaussian(0.03);
        let (ds, t) = (1e-6, 7.1e-6);
        let dt = ds / C;
        for s in [0.004, 0.019, 0.033, 0.0571] {
            let v_t = (r.velocity(&g, s, t + dt) - r.velocity(&g, s, t - dt)) / (2.0 * dt);
            let sigma_s = (r.stress(&g, s + ds, t) - r.stress(&g, s - ds, t)) / (2.0 * ds);
            let sigma_t = (r.stress(&g, s, t + dt) - r.stress(&g, s, t - dt)) / (2.0 * dt);
            let v_s = (r.velocity(&g, s + ds, t) - r.velocity(&g, s - ds, t)) / (2.0 * ds);
            let scale = RHO * C / 6.3e-3;
            assert!((RHO * v_t - sigma_s).abs() < 1e-6 * scale, "s = {s}");
            assert!(
                (sigma_t - RHO * C * C * v_s).abs() < 1e-6 * scale * C * C,
                "s = {s}"
            );
        }
    }

    fn material(nu: f64, plane: Plane) -> Material {
        Material::new(&MaterialSpec {
            model: MaterialModel::LinearElastic,
            density: RHO,
            youngs_modulus: Some(2.1e11),
            poisson_ratio: Some(nu),
            yield_stress: None,
            hardening_modulus: None,
            c1: None,
            c2: None,
            lambda: None,
            plane,
        })
    }

    #[test]
    fn bar_speed_is_sqrt_e_over_rho_at_nu_zero() {
        // The paper's c = sqrt(E/ρ) = 5188.7 m/s (seed 001 §9.2); in plane strain at ν ≠ 0
        // the bar modulus is E/(1 − ν²), in plane stress and 3D it is E. Round-off only.
        let c = (2.1e11f64 / RHO).sqrt();
        assert!((c - C).abs() < 1e-9);
        for dim in [2, 3] {
            let m = material(0.0, Plane::Strain);
            assert!((bar_wave_speed(&m, dim) - c).abs() < 1e-9 * c);
            assert!((m.p_wave_speed() - c).abs() < 1e-9 * c);
        }
        let nu: f64 = 0.3;
        let strain = bar_wave_speed(&material(nu, Plane::Strain), 2);
        assert!((strain - c / (1.0 - nu * nu).sqrt()).abs() < 1e-9 * c);
        let stress = bar_wave_speed(&material(nu, Plane::Stress), 2);
        assert!((stress - c).abs() < 1e-9 * c);
        assert!((bar_wave_speed(&material(nu, Plane::Strain), 3) - c).abs() < 1e-9 * c);
    }

    #[test]
    fn relative_l2_weights_by_volume() {
        // Two particles, volumes 1 and 3, one component: e² = (1·1 + 3·0)/(1·4 + 3·1).
        let e = relative_l2(&[1.0, 3.0], &[1.0, 1.0], &[2.0, 1.0]);
        assert!((e - (1.0f64 / 7.0).sqrt()).abs() < 1e-15);
        assert!(relative_l2(&[1.0], &[1.0, 2.0], &[1.0]).is_nan());
        assert!(relative_l2(&[1.0], &[1.0], &[0.0]).is_nan());
    }

    /// Case A of seed 001 §9.2: V = 50 m/s for t_p = 5.8 µs at the end s = 0.
    const DRIVEN: DrivenEnd = DrivenEnd {
        amplitude: 50.0,
        duration: 5.8e-6,
    };

    /// ∫ over [0, L] by the midpoint rule on n cells, whose cell edges the pulse's jumps
    /// fall between: its error is at most one cell at each jump, bounded by the caller.
    fn cells(n: usize, f: impl Fn(f64) -> f64) -> f64 {
        let ds = L / n as f64;
        (0..n).map(|k| f((k as f64 + 0.5) * ds)).sum::<f64>() * ds
    }

    #[test]
    fn the_driven_pulse_carries_the_impulse_and_work_of_the_end() {
        // Per unit area: the end pushes with σ = ρ0 c V at V for min(t, t_p), giving the
        // momentum ρ0 V c min(t, t_p) and the energy ρ0 V² c min(t, t_p) (half kinetic,
        // half strain; a pulse of c t_p = 30.1 mm). The midpoint rule on 240,000 cells
        // misses at most a cell (2.5e-7 m) at each of four jumps: 4e-5 of c t_p; bound 1e-4.
        let r = rod();
        let n = 240_000;
        for t in [2.1e-6f64, 5.7e-6, 8.0e-6, 1.4e-5, 2.0e-5, 2.6e-5, 4.2e-5] {
            let held = C * t.min(DRIVEN.duration);
            let p = cells(n, |s| RHO * r.driven(DRIVEN, s, t));
            let p_ex = RHO * DRIVEN.amplitude * held;
            assert!(
                (p - p_ex).abs() < 1e-4 * p_ex,
                "t = {t}: momentum {p} vs {p_ex}"
            );
            let kinetic = cells(n, |s| 0.5 * RHO * r.driven(DRIVEN, s, t).powi(2));
            let strain = cells(n, |s| {
                r.driven_stress(DRIVEN, s, t).powi(2) / (2.0 * RHO * C * C)
            });
            let e_ex = RHO * DRIVEN.amplitude.powi(2) * held;
            assert!(
                (kinetic + strain - e_ex).abs() < 1e-4 * e_ex,
                "t = {t}: energy"
            );
            // Half and half, but while a reflection overlaps the pulse with itself (the
            // strain cancels there): at 1.4e-5 s and 2.6e-5 s.
            if ![1.4e-5, 2.6e-5].contains(&t) {
                assert!(
                    (kinetic - strain).abs() < 1e-4 * e_ex,
                    "t = {t}: kinetic {kinetic}"
                );
            }
        }
    }

    #[test]
    fn the_driven_end_holds_v_and_the_free_ends_carry_no_stress() {
        // Exact values away from the jumps: v = V and σ = −ρ0 c V at the driven end while
        // driven; σ = 0 at both ends once free (and at the right end always).
        let r = rod();
        let (v, sigma) = (DRIVEN.amplitude, RHO * C * DRIVEN.amplitude);
        for t in [1e-7, 3.0e-6, 5.7e-6] {
            assert_eq!(r.driven(DRIVEN, 0.0, t), v);
            assert_eq!(r.driven_stress(DRIVEN, 0.0, t), -sigma);
            assert_eq!(r.driven_stress(DRIVEN, L, t), 0.0);
        }
        for t in [6.0e-6, 1.2e-5, 1.4e-5, 2.4e-5, 2.6e-5, 3.5e-5] {
            for end in [0.0, L] {
                assert_eq!(r.driven_stress(DRIVEN, end, t), 0.0, "t = {t}, s = {end}");
            }
        }
    }

    #[test]
    fn the_pulse_folds_about_the_free_ends_with_its_velocity_sign_kept() {
        // At t = 0.8, 1.8 and 2.8 L/c the pulse lies on (0.8L − c t_p, 0.8L) running right
        // (compression, σ = −ρ0 c V), on (0.2L, 0.2L + c t_p) running left after the right
        // end (tension, σ = +ρ0 c V), and on the first interval again running right after
        // the left end: V everywhere on it, 0 elsewhere, 1.5 mm from the jumps.
        let r = rod();
        let (v, sigma, length) = (
            DRIVEN.amplitude,
            RHO * C * DRIVEN.amplitude,
            C * DRIVEN.duration,
        );
        let period = L / C;
        for (t, (lo, hi), stress) in [
            (0.8 * period, (0.8 * L - length, 0.8 * L), -sigma),
            (1.8 * period, (0.2 * L, 0.2 * L + length), sigma),
            (2.8 * period, (0.8 * L - length, 0.8 * L), -sigma),
        ] {
            for s in grid(600) {
                let (inside, away) = (s > lo && s < hi, (s - lo).abs().min((s - hi).abs()));
                if away < 1.5e-3 {
                    continue;
                }
                let expected = if inside { (v, stress) } else { (0.0, 0.0) };
                let got = (r.driven(DRIVEN, s, t), r.driven_stress(DRIVEN, s, t));
                assert_eq!(got, expected, "t = {t}, s = {s}");
                // The jumps the observer measures from: lo and hi, nothing else.
                let d = r.driven_front_distance(DRIVEN, s, t);
                assert!((d - away).abs() < 1e-12, "t = {t}, s = {s}: {d} vs {away}");
            }
        }
        // While the pulse reflects at the right end (L/c < t < L/c + t_p) the incoming and
        // reflected halves overlap there: v = 2V and σ = 0 at the end.
        let t = period + 0.5 * DRIVEN.duration;
        assert_eq!(r.driven(DRIVEN, L - 1e-4, t), 2.0 * v);
        assert_eq!(r.driven_stress(DRIVEN, L - 1e-4, t), 0.0);
    }
}

#[cfg(test)]
mod tension_tests {
    use super::neo_hooke_plane_strain_tension;
    use crate::material::Material;
    use crate::scene::MaterialSpec;
    use crate::tensor::{D2, Dim};

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
