//! The closed-form static solutions: the Timoshenko–Goodier cantilever and uniaxial
//! stress, and the solutions a boundary condition can take its values from.

use crate::core::tensor::Axis;
use serde::{Deserialize, Serialize};

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
    Uniaxial(Uniaxial),
}

/// Uniaxial stress σ along the axis a: u_a = σX_a/E, u_k = −νσX_k/E (k ≠ a).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Uniaxial {
    pub stress: f64,
    pub axis: usize,
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
}

impl Uniaxial {
    /// The principal strains: ε_a = σ/E along the axis, ε_k = −νσ/E across it.
    pub fn strains(&self) -> [f64; 3] {
        let e = self.stress / self.youngs_modulus;
        std::array::from_fn(|k| {
            if k == self.axis {
                e
            } else {
                -self.poisson_ratio * e
            }
        })
    }
}

/// Closed-form solutions that boundary conditions can take their values from.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Solution {
    /// The cantilever with a parabolic end shear of Timoshenko & Goodier (seed 004 eqs
    /// 53–55, plane stress, the material's E and ν): x ∈ [0, length] from the clamped
    /// end, y ∈ [−depth/2, depth/2], end load `load` per unit thickness [N/m].
    TimoshenkoCantilever { load: f64, length: f64, depth: f64 },
    /// Uniaxial stress σ_aa = `stress` [Pa] along `axis` (default x; seed 004 §6.3): u_a =
    /// σX_a/E, the other components −νσX_k/E. As a traction on the face normal to that
    /// axis it is a uniform pressure −`stress` (§6.2's plate, §6.6's cube).
    UniaxialStress {
        stress: f64,
        #[serde(default = "x_axis")]
        axis: Axis,
    },
}

fn x_axis() -> Axis {
    Axis::X
}

impl ClosedForm {
    pub fn of(solution: &Solution, material: &crate::physics::material::MaterialSpec) -> Self {
        let (youngs_modulus, poisson_ratio) = material.youngs_and_poisson();
        match *solution {
            Solution::TimoshenkoCantilever {
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
            Solution::UniaxialStress { stress, axis } => Self::Uniaxial(Uniaxial {
                stress,
                axis: axis.index(),
                youngs_modulus,
                poisson_ratio,
            }),
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
            Self::Uniaxial(u) => {
                let strain = u.strains();
                std::array::from_fn(|k| strain[k] * x[k])
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
            Self::Uniaxial(u) => {
                let strain = u.strains();
                std::array::from_fn(|k| {
                    std::array::from_fn(|l| if k == l { strain[k] } else { 0.0 })
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
            Self::Uniaxial(u) => {
                let mut s = [[0.0; 3]; 3];
                s[u.axis][u.axis] = u.stress;
                s
            }
        }
    }
}

#[cfg(test)]
mod tests {
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
