//! The size of each body, estimated without sampling it.

use super::file_error;
use super::files::count_point_rows;
use super::lattice::{around, lattice_counts, polar_counts};
use crate::scene::{Case, CaseError, Lattice, RingLattice, Shape};

/// The size of a body, estimated without sampling it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySize {
    /// Its particles: the lattice points of its bounding box times the fraction of the
    /// box the shape fills (exact for a box; π/4 of the box for a disk), or the data rows
    /// of a points file (counted, not parsed).
    pub particles: f64,
    /// The lattice points the sampler visits to find them (its bounding box's).
    pub visited: f64,
}

/// The size of each body of a case. In f64: a spacing of 1e-300 gives 1e600 → ∞, never
/// a wrapped count.
pub fn estimate_particles(case: &Case) -> Result<Vec<BodySize>, CaseError> {
    let dx = case.spacing;
    let half = 0.5 * dx;
    let box_of = |lo: &[f64], hi: &[f64]| -> f64 { lattice_counts(lo, hi, dx).iter().product() };
    let annulus =
        |inner: f64, outer: f64| std::f64::consts::FRAC_PI_4 * (1.0 - (inner / outer).powi(2));
    let size = |visited: f64, fraction: f64| {
        // ∞ · 0 (an infinite lattice of a zero fraction) counts as ∞.
        let particles = visited * fraction;
        BodySize {
            particles: if particles.is_nan() {
                f64::INFINITY
            } else {
                particles
            },
            visited,
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
                    let (lo, hi) = crate::scene::polygon::bounds(vertices);
                    let bounding: f64 = (0..2).map(|k| hi[k] - lo[k]).product();
                    size(
                        box_of(&lo, &hi),
                        crate::scene::polygon::area(vertices) / bounding,
                    )
                }
                Shape::Points { file } | Shape::Mesh { file, .. } => {
                    // A mesh has at most one cell per line.
                    let path = case.base_dir().join(file);
                    let rows =
                        count_point_rows(&path).map_err(|m| file_error(case, b, &path, m))? as f64;
                    size(rows, 1.0)
                }
            })
        })
        .collect()
}
