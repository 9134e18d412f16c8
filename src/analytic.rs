//! Closed-form solutions that cases are checked against.

use crate::material::Material;
use crate::tensor::Dim;
use std::f64::consts::FRAC_PI_2;

/// The swinging cube (3D) and plate (2D, plane strain) of seed 003 §7.1.1 on [0, 1]^d:
/// u(X, t) = U0 sin(ωt) Φ(X), Φ_k = sin(πX_k/2) Π_{m≠k} cos(πX_m/2) (A = B = C = 1).
///
/// Φ = −(2/π)∇Π cos(πX_m/2) is a gradient, so Δu = ∇(∇·u) = −d (π/2)² u and linear
/// elastodynamics ρ0 ü = (λ + 2μ) Δu holds with ω = (π/2) √d c_d, c_d = √((λ+2μ)/ρ0).
/// u_k = 0 on X_k = 0 (symmetry) and the tangential u = 0 on X_k = 1 (skew-symmetry).
/// The sine form starts undeformed (F = I) with velocity U0 ω Φ(X).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwingingMode {
    /// Displacement amplitude U0 [m].
    pub amplitude: f64,
    /// Angular frequency ω [rad/s].
    pub omega: f64,
}

impl SwingingMode {
    pub fn new(amplitude: f64, material: &Material, dim: usize) -> Self {
        Self {
            amplitude,
            omega: FRAC_PI_2 * (dim as f64).sqrt() * material.p_wave_speed(),
        }
    }

    /// Φ(X) and its gradient ∂Φ_k/∂X_l.
    fn shape<D: Dim>(x: D::V) -> (D::V, D::T) {
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
        Self::shape::<D>(x).0 * (self.amplitude * (self.omega * t).sin())
    }

    pub fn velocity<D: Dim>(&self, x: D::V, t: f64) -> D::V {
        Self::shape::<D>(x).0 * (self.amplitude * self.omega * (self.omega * t).cos())
    }

    /// Displacement gradient ∇0u.
    pub fn displacement_gradient<D: Dim>(&self, x: D::V, t: f64) -> D::T {
        Self::shape::<D>(x).1 * (self.amplitude * (self.omega * t).sin())
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
    fn satisfies_elastodynamics<D: Dim>() {
        let mat = material();
        let mode = SwingingMode::new(5e-4, &mat, D::N);
        let t = 0.3 / mode.omega;
        let h = 1e-4;
        for x in [[0.3, 0.6, 0.2], [0.85, 0.1, 0.5], [0.5, 0.5, 0.9]] {
            let x = D::from_slice(&x);
            let accel = mode.displacement::<D>(x, t) * (-mode.omega * mode.omega * mat.rho0);
            let mut div = vec![0.0; D::N];
            for l in 0..D::N {
                let mut e = [0.0; 3];
                e[l] = h;
                let dp = mode.stress::<D>(&mat, x + D::from_slice(&e), t)
                    - mode.stress::<D>(&mat, x - D::from_slice(&e), t);
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
        satisfies_elastodynamics::<D2>();
        satisfies_elastodynamics::<D3>();
    }

    #[test]
    fn swinging_mode_meets_its_boundary_conditions() {
        let mode = SwingingMode::new(1.0, &material(), 3);
        let u0 = D3::to3(mode.displacement::<D3>(D3::from_slice(&[0.0, 0.4, 0.7]), 1e-3));
        assert_eq!(u0[0], 0.0);
        let u1 = D3::to3(mode.displacement::<D3>(D3::from_slice(&[1.0, 0.4, 0.7]), 1e-3));
        assert!(u1[1].abs() < 1e-15 && u1[2].abs() < 1e-15 && u1[0] != 0.0);
    }
}

/// The cantilever of Timoshenko & Goodier with a parabolic shear P at x = L (seed 004 eqs
/// 53–55; plane stress, I = D³/12 per unit thickness): u_y(L, y) = −P/(6EI) [(4 + 5ν)
/// D² L/4 + 2L³] at the loaded end, 2.77284e-6 m for the seed's beam.
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
