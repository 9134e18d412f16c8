//! What a shape names: its volume, its bounding box, and a cylinder's sampled length.

use super::lattice::{around, lattice_counts};
use crate::case::{Lattice, Shape};

impl Shape {
    /// A cylinder's length along its axis as its lattice of spacing Δx samples it, and the
    /// length the case names: the span (n − 1)Δx of the n layers of a vertex lattice from
    /// the base, or the n layers Δx thick of a cell-centred one; the methods that
    /// integrate over lattice cells (`cells`) take the vertex lattice. They differ when
    /// the length is no multiple of Δx, which scaled volumes hide from the mass. None for
    /// the other shapes.
    pub fn sampled_length(&self, dx: f64, cells: bool) -> Option<(f64, f64)> {
        let Shape::Cylinder {
            length, lattice, ..
        } = self
        else {
            return None;
        };
        let sampled = match lattice {
            Lattice::CellCentred if !cells => {
                lattice_counts(&[0.5 * dx], &[length - 0.5 * dx], dx)[0] * dx
            }
            _ => (lattice_counts(&[0.0], &[*length], dx)[0] - 1.0) * dx,
        };
        Some((sampled, *length))
    }

    /// Whether the case gives the shape's `volumes` key.
    pub fn volumes_given(&self) -> bool {
        match self {
            Shape::Box { volumes, .. }
            | Shape::Disk { volumes, .. }
            | Shape::Ring { volumes, .. }
            | Shape::Cylinder { volumes, .. }
            | Shape::Polygon { volumes, .. } => volumes.is_some(),
            Shape::Tube { .. } | Shape::Points { .. } | Shape::Mesh { .. } => false,
        }
    }

    /// The d-dimensional volume of the shape the case names (an area in 2D); None for a
    /// points file or a mesh, whose volumes are given.
    pub fn volume(&self, d: usize) -> Option<f64> {
        let pi = std::f64::consts::PI;
        match self {
            Shape::Box { min, max, .. } => Some((0..d).map(|k| max[k] - min[k]).product()),
            Shape::Disk { radius, .. } => Some(pi * radius * radius),
            Shape::Ring {
                inner_radius,
                outer_radius,
                ..
            } => Some(pi * (outer_radius * outer_radius - inner_radius * inner_radius)),
            Shape::Cylinder {
                radius,
                inner_radius,
                length,
                ..
            } => Some(pi * (radius * radius - inner_radius * inner_radius) * length),
            Shape::Tube {
                inner_radius,
                radius,
                length,
                angles,
                ..
            } => {
                let [theta0, theta1] = angles.unwrap_or([0.0, 360.0]).map(f64::to_radians);
                Some(
                    0.5 * (radius * radius - inner_radius * inner_radius)
                        * (theta1 - theta0)
                        * length,
                )
            }
            Shape::Polygon { vertices, .. } => Some(crate::case::polygon::area(vertices)),
            Shape::Points { .. } | Shape::Mesh { .. } => None,
        }
    }

    /// The bounding box of the shape the case names, in d dimensions (padded with zeros
    /// to three), whatever lattice samples it; None for a points file or a mesh, whose
    /// shape is only its particles.
    pub fn extent(&self, d: usize) -> Option<([f64; 3], [f64; 3])> {
        let (lo, hi) = match self {
            Shape::Box { min, max, .. } => (min.clone(), max.clone()),
            Shape::Disk { center, radius, .. } => around(center, *radius),
            Shape::Ring {
                center,
                outer_radius,
                ..
            } => around(center, *outer_radius),
            // A tube's whole circle: the box of its angles lies within it.
            Shape::Cylinder {
                base,
                axis,
                radius,
                length,
                ..
            }
            | Shape::Tube {
                base,
                axis,
                radius,
                length,
                ..
            } => {
                let a = axis.index();
                let (mut lo, mut hi) = around(base, *radius);
                lo[a] = base[a];
                hi[a] = base[a] + length;
                (lo, hi)
            }
            Shape::Polygon { vertices, .. } => crate::case::polygon::bounds(vertices),
            Shape::Points { .. } | Shape::Mesh { .. } => return None,
        };
        let pad = |v: &[f64]| std::array::from_fn(|k| if k < d { v[k] } else { 0.0 });
        Some((pad(&lo), pad(&hi)))
    }
}
