//! The size of each body, estimated without sampling it: its particles, and its
//! neighbour pairs, from the lattice's density, or from the density of the points a
//! points or mesh file actually holds.

use super::file_error;
use super::files::{read_mesh, read_points};
use super::lattice::{around, lattice_counts, polar_counts};
use crate::case::{Case, CaseError, Lattice, RingLattice, Shape};
use crate::core::tensor::{D2, D3, Dim};
use std::collections::HashMap;
use std::path::Path;

/// The size of a body, estimated without sampling it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySize {
    /// Its particles: the lattice points of its bounding box times the fraction of the
    /// box the shape fills (exact for a box; π/4 of the box for a disk), or the points a
    /// points or mesh file gives (read as the sampler reads them).
    pub particles: f64,
    /// The lattice points the sampler visits to find them (its bounding box's).
    pub visited: f64,
    /// Its neighbour pairs within the kernel's support, κh: on a lattice, the particles
    /// times the lattice points within κh of one, ω_d (κh/Δx)^d; for a points or mesh
    /// file, from a histogram of its points ([`histogram_pairs`]), which sees a file
    /// denser than `spacing`.
    pub pairs: f64,
}

/// The size of each body of a case. In f64: a spacing of 1e-300 gives 1e600 → ∞, never
/// a wrapped count.
pub fn estimate_particles(case: &Case) -> Result<Vec<BodySize>, CaseError> {
    let dx = case.spacing;
    let half = 0.5 * dx;
    let box_of = |lo: &[f64], hi: &[f64]| -> f64 { lattice_counts(lo, hi, dx).iter().product() };
    let annulus =
        |inner: f64, outer: f64| std::f64::consts::FRAC_PI_4 * (1.0 - (inner / outer).powi(2));
    let d = case.dim();
    let reach = case.method.kernel.support_factor() * case.method.h_over_dx;
    let ball = if d == 2 {
        std::f64::consts::PI * reach.powi(2)
    } else {
        4.0 / 3.0 * std::f64::consts::PI * reach.powi(3)
    };
    let size = |visited: f64, fraction: f64| {
        // ∞ · 0 (an infinite lattice of a zero fraction) counts as ∞.
        let particles = visited * fraction;
        let particles = if particles.is_nan() {
            f64::INFINITY
        } else {
            particles
        };
        BodySize {
            particles,
            visited,
            pairs: particles * ball.floor(),
        }
    };
    case.bodies
        .iter()
        .enumerate()
        .map(|(b, spec)| {
            Ok(match &spec.geometry {
                Shape::Box {
                    min,
                    max,
                    lattice: Lattice::CellCentred,
                    ..
                } => {
                    let lo: Vec<f64> = min.iter().map(|m| m + half).collect();
                    let hi: Vec<f64> = max.iter().map(|m| m - half).collect();
                    size(box_of(&lo, &hi), 1.0)
                }
                Shape::Box { min, max, .. } => size(box_of(min, max), 1.0),
                Shape::Disk { center, radius, .. } => {
                    let (lo, hi) = around(center, *radius);
                    size(box_of(&lo, &hi), annulus(0.0, *radius))
                }
                Shape::Ring {
                    inner_radius,
                    outer_radius,
                    lattice: RingLattice::Polar,
                    sectors,
                    ..
                } => {
                    let (n_r, n_theta) = polar_counts(*inner_radius, *outer_radius, dx, *sectors);
                    size((n_r + 1.0) * n_theta, 1.0)
                }
                Shape::Ring {
                    center,
                    inner_radius,
                    outer_radius,
                    ..
                } => {
                    let (lo, hi) = around(center, *outer_radius);
                    size(box_of(&lo, &hi), annulus(*inner_radius, *outer_radius))
                }
                Shape::Cylinder {
                    radius,
                    inner_radius,
                    ..
                } => {
                    let (lo, hi) = spec.geometry.extent(3).expect("a cylinder has its box");
                    size(box_of(&lo, &hi), annulus(*inner_radius, *radius))
                }
                Shape::Polygon { vertices, .. } => {
                    let (lo, hi) = crate::case::polygon::bounds(vertices);
                    let bounding: f64 = (0..2).map(|k| hi[k] - lo[k]).product();
                    size(
                        box_of(&lo, &hi),
                        crate::case::polygon::area(vertices) / bounding,
                    )
                }
                Shape::Points { file } | Shape::Mesh { file, .. } => {
                    let path = case.base_dir().join(file);
                    let points = match d {
                        2 => file_points::<D2>(&spec.geometry, &path, dx),
                        _ => file_points::<D3>(&spec.geometry, &path, dx),
                    }
                    .map_err(|m| file_error(case, b, &path, m))?;
                    BodySize {
                        pairs: histogram_pairs(&points, d, reach * dx),
                        ..size(points.len() as f64, 1.0)
                    }
                }
            })
        })
        .collect()
}

/// The positions of a points or mesh body, as the sampler reads them.
fn file_points<D: Dim>(shape: &Shape, path: &Path, dx: f64) -> Result<Vec<[f64; 3]>, String> {
    let sampled = match shape {
        Shape::Mesh { nodes, .. } => read_mesh::<D>(path, *nodes)?,
        _ => read_points::<D>(path, dx.powi(D::N as i32))?,
    };
    Ok(sampled.points.into_iter().map(D::to3).collect())
}

/// The neighbour pairs among `points` (ordered, each pair twice, as the lists hold them)
/// within `radius`, estimated from a histogram of cells of half the radius: the points of
/// two cells c and c + o are taken as spread evenly over each, so that a pair of them is
/// within the radius with the probability w_o that a midpoint rule of [`QUADRATURE`]^d
/// points a cell gives, and the pairs are Σ_c n_c (Σ_o w_o n_{c+o} − w_0), over the 5^d
/// offsets o that can hold a neighbour. Linear in the points, with memory for the
/// occupied cells only; it sees a file denser than `spacing`, and a body's edges at the
/// resolution of its cells.
pub(super) fn histogram_pairs(points: &[[f64; 3]], d: usize, radius: f64) -> f64 {
    let side = 0.5 * radius;
    let cell = |x: &[f64; 3]| -> [i64; 3] {
        let mut c = [0; 3];
        for k in 0..d {
            c[k] = (x[k] / side).floor() as i64;
        }
        c
    };
    let mut counts: HashMap<[i64; 3], f64> = HashMap::new();
    for x in points {
        *counts.entry(cell(x)).or_default() += 1.0;
    }
    let weights = offset_weights(d);
    counts
        .iter()
        .map(|(c, &n)| {
            let near: f64 = weights
                .iter()
                .filter_map(|(o, w)| {
                    let n = counts.get(&[c[0] + o[0], c[1] + o[1], c[2] + o[2]])?;
                    Some(w * n)
                })
                .sum();
            n * (near - weights[weights.len() / 2].1).max(0.0)
        })
        .sum()
}

/// The midpoint rule's points along each side of a cell in [`offset_weights`].
const QUADRATURE: usize = 6;

/// For each offset o ∈ {−2, …, 2}^d of cells of half a radius, in lexicographic order (so
/// o = 0 is the middle entry), the probability that a point spread evenly over cell 0 and
/// one over cell o are within the radius (of 1: two cell sides).
fn offset_weights(d: usize) -> Vec<([i64; 3], f64)> {
    let m = QUADRATURE;
    let nodes: Vec<[f64; 3]> = (0..m.pow(d as u32))
        .map(|q| {
            let mut p = [0.0; 3];
            for (k, p) in p.iter_mut().enumerate().take(d) {
                *p = ((q / m.pow(k as u32) % m) as f64 + 0.5) / m as f64;
            }
            p
        })
        .collect();
    (0..5i64.pow(d as u32))
        .map(|j| {
            let mut o = [0i64; 3];
            for (k, o) in o.iter_mut().enumerate().take(d) {
                *o = j / 5i64.pow((d - 1 - k) as u32) % 5 - 2;
            }
            let within = nodes
                .iter()
                .flat_map(|a| nodes.iter().map(move |b| (a, b)))
                .filter(|(a, b)| {
                    // In cell sides: within two sides.
                    let r2: f64 = (0..d).map(|k| (b[k] + o[k] as f64 - a[k]).powi(2)).sum();
                    r2 < 4.0
                })
                .count();
            (o, within as f64 / nodes.len().pow(2) as f64)
        })
        .collect()
}
