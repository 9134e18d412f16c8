//! The neighbourhoods and smoothing lengths of an updated-Lagrangian particle method, seed
//! 000 §3.2 (eqs 60–64), each at one particle from its candidates' offsets x_ij = x_i − x_j
//! at the current positions:
//!
//! - **eqs 60–61** ([`density_smoothing_length`]): h ∝ ⟨ρ⟩^(−1/d) with the kernel-sum
//!   density ⟨ρ⟩_i = Σ_j W(x_ij, h_i) m_j, interdependent with h: the fixed point of
//!   h_i = η (m_i/⟨ρ⟩_i)^(1/d) (Monaghan; Springel–Hernquist), reached by Newton steps;
//! - **eq 62** ([`continuity_smoothing_length`]): Mohammadi's update h^(n+1) = h^n
//!   (ρ^n/ρ^(n+1))^(1/d) with ρ of the continuity equation, which telescopes to h = h0
//!   (ρ0/ρ)^(1/d) (the printed equation is garbled; notes §1.5);
//! - **eq 63** ([`prime_space`]): Randles and Libersky's prime space, the candidates mapped
//!   so that the closest lie farthest, x'_j = x_ij/|x_ij|², and the neighbourhood the
//!   mapped points on their convex hull's boundary (2D). The paper's anisotropy scale χ is
//!   garbled in the equation and not recoverable; it is 1 here;
//! - **eq 64** ([`Ellipse`]): the covariance ellipse, with the reference code's recipe
//!   (notes §1.5), which the updated-Lagrangian weak form uses.
//!
//! The isotropic ones (60–62) keep the candidates within the kernel's support of h
//! ([`within`]). Seed 000 Fig. 3 compares all four under a prescribed shear and tension
//! (`meshless neighbourhoods`, docs/methods/ul-neighbourhoods.md).
//!
//! The covariance ellipse over a point's N candidates (itself included, for a particle):
//!
//! - C = (1/N) Σ_j x_ij ⊗ x_ij (1/N, not the paper's 1/(N − 1));
//! - h = max_j |x_ij| / 2, so that the cubic spline's support 2h reaches the farthest
//!   candidate;
//! - candidate j is a neighbour when it lies inside the ellipse with half-axes
//!   1.6651·sqrt(λ_k) along the eigenvectors e_k of C. With x_ij = Σ_k c_k e_k that is
//!   Σ_k c_k²/(1.6651² λ_k) = x_ijᵀ C⁻¹ x_ij ≤ 1.6651², which needs no eigenvectors and
//!   holds in 3D alike (where 1.6651, a 2-degree-of-freedom χ² scale, keeps a different
//!   share of the candidates).

use crate::core::hull::convex_hull;
use crate::core::kernel::{Kernel, KernelKind};
use crate::core::tensor::Dim;

/// eqs 60–61 at particle i: the fixed point of h = min(η (m_i/⟨ρ⟩)^(1/d), h_max) with
/// ⟨ρ⟩ = Σ_j W(x_ij, h) m_j over its candidates `(x_ij, m_j)` (itself included at
/// x_ij = 0), from h = `start`; η is the ratio h/Δx of a lattice whose density is m/Δx^d.
/// The cap h_max keeps a particle that has lost its neighbours from growing without bound
/// (alone, ⟨ρ⟩ = m W(0, h) ∝ h^(−d) and the map diverges for η σ_d^(−1/d) > 1).
///
/// Each iteration takes the Newton step on h − η (m_i/⟨ρ⟩)^(1/d) = 0, with ∂W/∂h =
/// −(d W + r ∂W/∂r)/h, where its slope is above 0.1 and the step stays within a factor of
/// two; else the plain fixed-point step. It stops when h changes by less than 1e-12 of
/// itself; None after 100 iterations or where no candidate is in reach (⟨ρ⟩ = 0).
pub fn density_smoothing_length<D: Dim>(
    candidates: impl Iterator<Item = (D::V, f64)> + Clone,
    m_i: f64,
    eta: f64,
    kind: KernelKind,
    start: f64,
    h_max: f64,
) -> Option<f64> {
    let d = D::N as f64;
    let mut h = start.min(h_max);
    for _ in 0..100 {
        let kernel = Kernel::new(kind, h, D::N);
        let (rho, rho_h) = candidates.clone().fold((0.0, 0.0), |(rho, rho_h), (x, m)| {
            let r = D::norm2(x).sqrt();
            let w = kernel.w(r);
            (rho + m * w, rho_h - m * (d * w + r * kernel.dw_dr(r)) / h)
        });
        if rho.is_nan() || rho <= 0.0 {
            return None;
        }
        let target = eta * (m_i / rho).powf(1.0 / d);
        let next = if target >= h_max {
            h_max
        } else {
            let slope = 1.0 + target / d * rho_h / rho;
            let newton = h - (h - target) / slope;
            if slope > 0.1 && newton > 0.5 * h && newton < 2.0 * h {
                newton.min(h_max)
            } else {
                target
            }
        };
        if (next - h).abs() <= 1e-12 * h {
            return Some(next);
        }
        h = next;
    }
    None
}

/// eq 62: h = h0 (ρ0/ρ)^(1/d), Mohammadi's update over the steps with ρ of the continuity
/// equation.
pub fn continuity_smoothing_length(h0: f64, rho0: f64, rho: f64, dim: usize) -> f64 {
    h0 * (rho0 / rho).powf(1.0 / dim as f64)
}

/// The candidates within the support `reach` of the kernel (|x_ij| ≤ reach), by index
/// into `offsets`.
pub fn within<D: Dim>(offsets: &[D::V], reach: f64) -> Vec<usize> {
    (0..offsets.len())
        .filter(|&k| D::norm2(offsets[k]) <= reach * reach)
        .collect()
}

/// The share of the largest image's length within which an image counts as on the
/// boundary of the images' convex hull in [`prime_space`]: a lattice's diagonal
/// neighbours lie on it exactly (their images on the edges between the nearest ones'),
/// and positions in f32 put them up to about 1e-5 off.
pub const PRIME_SPACE_TOLERANCE: f64 = 1e-3;

/// eq 63 in 2D: the candidates at offsets x_ij (the particle itself, x_ij = 0, left out)
/// whose images x_ij/|x_ij|² lie on the boundary of the images' convex hull, within
/// [`PRIME_SPACE_TOLERANCE`], by index into `offsets`, ascending. An image inside a convex
/// polygon is as far from its boundary as from the nearest edge's line, so the choice is
/// continuous in the positions: a point that moves onto an edge joins, whether or not it
/// becomes a vertex. Candidates all on one line through the particle are all taken.
///
/// The hull is built over the images that are not deep inside the polygon of those
/// extreme along x, y, x + y and x − y (Akl and Toussaint's filter): that polygon lies
/// within the hull, so an image farther inside it than the tolerance is not taken, and
/// far candidates, whose images crowd about the origin, are dropped at once.
pub fn prime_space(offsets: &[[f64; 2]]) -> Vec<usize> {
    let images: Vec<[f64; 2]> = offsets
        .iter()
        .map(|&[x, y]| {
            let r2 = x * x + y * y;
            [x / r2, y / r2]
        })
        .collect();
    let at = |k: u32| images[k as usize];
    let others: Vec<u32> = (0..offsets.len() as u32)
        .filter(|&k| offsets[k as usize] != [0.0, 0.0])
        .collect();
    // The largest image's length, and the largest image along each of the eight
    // directions ±x, ±y, ±(x + y), ±(x − y).
    let mut scale: f64 = 0.0;
    let mut best = [(f64::NEG_INFINITY, u32::MAX); 8];
    for &k in &others {
        let [x, y] = at(k);
        scale = scale.max((x * x + y * y).sqrt());
        for (slot, along) in best
            .iter_mut()
            .zip([x, -x, y, -y, x + y, -x - y, x - y, y - x])
        {
            if along > slot.0 {
                *slot = (along, k);
            }
        }
    }
    let mut extreme: Vec<u32> = best
        .iter()
        .map(|&(_, k)| k)
        .filter(|&k| k != u32::MAX)
        .collect();
    extreme.sort_unstable();
    extreme.dedup();
    let tolerance = PRIME_SPACE_TOLERANCE * scale;
    let inner = polygon(&convex_hull(&extreme, at), at);
    let near: Vec<u32> = others
        .into_iter()
        .filter(|&k| depth(&inner, at(k)) <= tolerance)
        .collect();
    let hull = polygon(&convex_hull(&near, at), at);
    near.into_iter()
        .filter(|&k| depth(&hull, at(k)) <= tolerance)
        .map(|k| k as usize)
        .collect()
}

/// The edges of a counter-clockwise polygon `vertices` as (a point, inward unit normal),
/// without those of length zero; none for fewer than three vertices.
fn polygon(vertices: &[u32], at: impl Fn(u32) -> [f64; 2]) -> Vec<([f64; 2], [f64; 2])> {
    if vertices.len() < 3 {
        return Vec::new();
    }
    (0..vertices.len())
        .filter_map(|e| {
            let (a, b) = (at(vertices[e]), at(vertices[(e + 1) % vertices.len()]));
            let (tx, ty) = (b[0] - a[0], b[1] - a[1]);
            let length = (tx * tx + ty * ty).sqrt();
            (length > 0.0).then(|| (a, [-ty / length, tx / length]))
        })
        .collect()
}

/// How far p lies inside the polygon of `edges` ([`polygon`]): its distance to the
/// nearest edge's line, negative outside; −∞ without edges (nothing is inside), and at
/// most 0 for a polygon flat on a line (whose two sides face each other).
fn depth(edges: &[([f64; 2], [f64; 2])], p: [f64; 2]) -> f64 {
    if edges.is_empty() {
        return f64::NEG_INFINITY;
    }
    edges
        .iter()
        .map(|(a, n)| n[0] * (p[0] - a[0]) + n[1] * (p[1] - a[1]))
        .fold(f64::INFINITY, f64::min)
}

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
