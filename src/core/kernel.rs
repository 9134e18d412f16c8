//! Smoothing kernels W(r, h) and their radial derivatives dW/dr, normalised in 2D and 3D.

use crate::core::tensor::Dim;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Kernel family, as named in case files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KernelKind {
    /// M4 cubic B-spline, support 2h (seed 000 eq 6).
    CubicSpline,
    /// M6 quintic B-spline, support 3h.
    Quintic,
    /// Wendland C2, support 2h.
    WendlandC2,
    /// Quadratic kernel of Johnson, Stryk & Beissel (1996), support 2h: the kernel of
    /// seed 003, W = σ_d/h^d (3/16 q² − 3/4 q + 3/4).
    Quadratic,
}

impl KernelKind {
    pub const ALL: [KernelKind; 4] = [
        Self::CubicSpline,
        Self::Quintic,
        Self::WendlandC2,
        Self::Quadratic,
    ];

    /// Support radius in units of h.
    pub fn support_factor(self) -> f64 {
        match self {
            Self::CubicSpline | Self::WendlandC2 | Self::Quadratic => 2.0,
            Self::Quintic => 3.0,
        }
    }

    /// Normalisation constant σ_d such that W = σ_d / h^d · w(q) integrates to one.
    fn normalisation(self, dim: usize) -> f64 {
        match (self, dim) {
            (Self::CubicSpline, 2) => 10.0 / (7.0 * PI),
            (Self::CubicSpline, _) => 1.0 / PI,
            (Self::Quintic, 2) => 7.0 / (478.0 * PI),
            (Self::Quintic, _) => 1.0 / (120.0 * PI),
            (Self::WendlandC2, 2) => 7.0 / (4.0 * PI),
            (Self::WendlandC2, _) => 21.0 / (16.0 * PI),
            (Self::Quadratic, 2) => 2.0 / PI,
            (Self::Quadratic, _) => 5.0 / (4.0 * PI),
        }
    }
}

/// A kernel of fixed smoothing length h in a given dimension.
#[derive(Clone, Copy, Debug)]
pub struct Kernel {
    pub kind: KernelKind,
    pub h: f64,
    /// σ_d / h^d.
    scale: f64,
}

impl Kernel {
    pub fn new(kind: KernelKind, h: f64, dim: usize) -> Self {
        let scale = kind.normalisation(dim) / h.powi(dim as i32);
        Self { kind, h, scale }
    }

    /// σ_d / h^d, the factor in front of the kernel's shape function.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Support radius (W = 0 beyond it).
    pub fn support(&self) -> f64 {
        self.kind.support_factor() * self.h
    }

    /// W(r).
    pub fn w(&self, r: f64) -> f64 {
        let q = r / self.h;
        self.scale
            * match self.kind {
                KernelKind::CubicSpline => {
                    if q < 1.0 {
                        1.0 - 1.5 * q * q + 0.75 * q * q * q
                    } else if q < 2.0 {
                        0.25 * (2.0 - q).powi(3)
                    } else {
                        0.0
                    }
                }
                KernelKind::Quintic => {
                    let t = |a: f64| if q < a { (a - q).powi(5) } else { 0.0 };
                    t(3.0) - 6.0 * t(2.0) + 15.0 * t(1.0)
                }
                KernelKind::WendlandC2 => {
                    if q < 2.0 {
                        (1.0 - 0.5 * q).powi(4) * (2.0 * q + 1.0)
                    } else {
                        0.0
                    }
                }
                KernelKind::Quadratic => {
                    if q < 2.0 {
                        0.1875 * q * q - 0.75 * q + 0.75
                    } else {
                        0.0
                    }
                }
            }
    }

    /// dW/dr (≤ 0).
    pub fn dw_dr(&self, r: f64) -> f64 {
        let q = r / self.h;
        self.scale / self.h
            * match self.kind {
                KernelKind::CubicSpline => {
                    if q < 1.0 {
                        -3.0 * q + 2.25 * q * q
                    } else if q < 2.0 {
                        -0.75 * (2.0 - q).powi(2)
                    } else {
                        0.0
                    }
                }
                KernelKind::Quintic => {
                    let t = |a: f64| if q < a { -5.0 * (a - q).powi(4) } else { 0.0 };
                    t(3.0) - 6.0 * t(2.0) + 15.0 * t(1.0)
                }
                KernelKind::WendlandC2 => {
                    if q < 2.0 {
                        -5.0 * q * (1.0 - 0.5 * q).powi(3)
                    } else {
                        0.0
                    }
                }
                KernelKind::Quadratic => {
                    if q < 2.0 {
                        0.375 * q - 0.75
                    } else {
                        0.0
                    }
                }
            }
    }

    /// ∇W_ij = ∂W(x_i − x_j)/∂x_i = (x_ij / r) dW/dr; zero for the self pair.
    #[inline]
    pub fn grad<D: Dim>(&self, x_ij: D::V) -> D::V {
        let r = D::norm2(x_ij).sqrt();
        if r <= 1e-12 * self.h {
            D::zero()
        } else {
            x_ij * (self.dw_dr(r) / r)
        }
    }
}

/// The kernel support, with a relative margin so that lattice neighbours exactly at the
/// support are found on both sides despite round-off (their W and ∇W vanish).
pub fn neighbour_radius(kernel: &Kernel) -> f64 {
    kernel.support() * (1.0 + 1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ W dV by the midpoint rule on a fine radial grid, in `dim` dimensions.
    fn integral(k: &Kernel, dim: usize) -> f64 {
        let n = 20_000;
        let dr = k.support() / n as f64;
        (0..n)
            .map(|i| {
                let r = (i as f64 + 0.5) * dr;
                let shell = if dim == 2 {
                    2.0 * PI * r
                } else {
                    4.0 * PI * r * r
                };
                k.w(r) * shell * dr
            })
            .sum()
    }

    #[test]
    fn kernels_integrate_to_one() {
        // Midpoint rule with 20,000 radial cells on a piecewise polynomial: error ~1e-9.
        for kind in KernelKind::ALL {
            for dim in [2, 3] {
                let k = Kernel::new(kind, 0.37, dim);
                let s = integral(&k, dim);
                assert!((s - 1.0).abs() < 1e-7, "{kind:?} {dim}D integrates to {s}");
            }
        }
    }

    #[test]
    fn kernels_are_c1_and_vanish_at_the_support() {
        for kind in KernelKind::ALL {
            let k = Kernel::new(kind, 1.0, 2);
            let rs = k.support();
            assert!(k.w(rs).abs() < 1e-14 && k.dw_dr(rs).abs() < 1e-14);
            // The quadratic kernel has a cusp at q = 0 by construction (dW/dr(0) = −¾σ/h);
            // its gradient is defined as zero for the self pair.
            if kind != KernelKind::Quadratic {
                assert!(k.dw_dr(0.0).abs() < 1e-14, "{kind:?}: dW/dr(0) must vanish");
            }
            // Continuity of W and dW/dr across every knot (q = 1, 2): one-sided values
            // 1e-9 apart differ by O(1e-9) for a C1 function, O(1) for a jump.
            for knot in [1.0, 2.0] {
                let (a, b) = (knot - 1e-9, knot + 1e-9);
                assert!((k.w(a) - k.w(b)).abs() < 1e-7, "{kind:?} W jumps at {knot}");
                assert!(
                    (k.dw_dr(a) - k.dw_dr(b)).abs() < 1e-7,
                    "{kind:?} W' jumps at {knot}"
                );
            }
            // dW/dr matches a central difference of W (checks the derivative formula).
            for r in [0.3, 0.9, 1.4, 1.9, 2.5] {
                if r >= rs {
                    continue;
                }
                let fd = (k.w(r + 1e-6) - k.w(r - 1e-6)) / 2e-6;
                assert!((fd - k.dw_dr(r)).abs() < 1e-6, "{kind:?} dW/dr at {r}");
            }
        }
    }

    #[test]
    fn cubic_spline_matches_the_seed_normalisation() {
        let k = Kernel::new(KernelKind::CubicSpline, 0.5, 2);
        assert!((k.w(0.0) - 10.0 / (7.0 * PI * 0.25)).abs() < 1e-12);
    }
}
