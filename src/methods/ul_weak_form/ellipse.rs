//! The covariance-ellipse neighbourhood and smoothing length of Algorithm 7 (seed 000
//! eq 64, with the reference code's recipe: notes §1.5).
//!
//! Over a point's N candidates (itself included, for a particle), with offsets
//! x_ij = x_i − x_j at the current positions:
//!
//! - C = (1/N) Σ_j x_ij ⊗ x_ij (1/N, not the paper's 1/(N − 1));
//! - h = max_j |x_ij| / 2, so that the cubic spline's support 2h reaches the farthest
//!   candidate;
//! - candidate j is a neighbour when it lies inside the ellipse with half-axes
//!   1.6651·sqrt(λ_k) along the eigenvectors e_k of C. With x_ij = Σ_k c_k e_k that is
//!   Σ_k c_k²/(1.6651² λ_k) = x_ijᵀ C⁻¹ x_ij ≤ 1.6651², which needs no eigenvectors and
//!   holds in 3D alike (where 1.6651, a 2-degree-of-freedom χ² scale, keeps a different
//!   share of the candidates).

use crate::core::tensor::Dim;

/// The scale of the half-axes over sqrt(λ): 1.6651² = 2.7726 = −2 ln 0.25, the 75 %
/// ellipse of a 2D normal distribution (the reference code's; the paper's example is the
/// 95 % ellipse, sqrt(5.991)).
pub const AXIS_SCALE: f64 = 1.6651;

/// The ellipse of a point.
#[derive(Clone, Copy, Debug)]
pub struct Ellipse<D: Dim> {
    /// C = (1/N) Σ_j x_ij ⊗ x_ij.
    pub c: D::T,
    c_inv: D::T,
    /// The smoothing length h = max_j |x_ij| / 2.
    pub h: f64,
}

impl<D: Dim> Ellipse<D> {
    /// The ellipse of the candidates at offsets x_ij; None when C is singular (the
    /// candidates all on one line or plane through the point).
    pub fn new(offsets: &[D::V]) -> Option<Self> {
        let n = offsets.len() as f64;
        let c = offsets
            .iter()
            .fold(D::zero_t(), |c, &r| c + D::outer(r, r) * (1.0 / n));
        let reach = offsets.iter().map(|&r| D::norm2(r)).fold(0.0, f64::max);
        let scale = (D::trace(c) / D::N as f64).powi(D::N as i32);
        let det = D::det(c);
        if det.is_nan() || det <= 1e-12 * scale {
            return None;
        }
        Some(Self {
            c,
            c_inv: D::inverse(c),
            h: reach.sqrt() / 2.0,
        })
    }

    /// Whether the candidate at offset x_ij lies inside (boundary included).
    pub fn contains(&self, x_ij: D::V) -> bool {
        D::dot(x_ij, self.c_inv * x_ij) <= AXIS_SCALE * AXIS_SCALE
    }
}
