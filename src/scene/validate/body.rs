//! `[[body]]`: names, geometries and holes; the initial fields are checked in `fields`.

use super::fields::{displacement, velocity};
use super::{Checked, fail, non_negative, positive, unique_names, vector};
use crate::case::{
    BodySpec, Case, Hole, HoleAxis, Lattice, MeshNodes, RingLattice, Shape, Volumes,
};

pub(super) fn check(bodies: &[BodySpec], dim: usize) -> Checked {
    if bodies.is_empty() {
        return fail(
            "body",
            "the case has no body; add at least one [[body]] table with a name and a geometry",
        );
    }
    unique_names(
        bodies,
        "body",
        |body| &body.name,
        "body names label output fields and boundary regions",
    )?;
    for (i, body) in bodies.iter().enumerate() {
        let key = format!("body.{i}");
        shape(&body.geometry, &format!("{key}.geometry"), dim)?;
        for (k, hole) in body.holes.iter().enumerate() {
            self::hole(hole, &body.geometry, &format!("{key}.holes.{k}"), dim)?;
        }
        if let Some(v) = &body.initial_velocity {
            velocity(v, &format!("{key}.initial_velocity"), dim)?;
        }

        if let Some(noise) = &body.velocity_noise {
            non_negative(&format!("{key}.velocity_noise.amplitude"), noise.amplitude)?;
        }
        if let Some(tolerance) = body.volume_tolerance {
            non_negative(&format!("{key}.volume_tolerance"), tolerance)?;
        }
    }
    Ok(())
}

/// What the case's method and run make of each body: a mesh's vertices as cells, an
/// initial displacement.
pub(super) fn against_method(case: &Case) -> Checked {
    for (b, body) in case.bodies.iter().enumerate() {
        if let Shape::Mesh {
            nodes: MeshNodes::Vertices,
            ..
        } = body.geometry
            && !case.method.lattice_cells
        {
            return fail(
                format!("body.{b}.geometry.nodes"),
                format!(
                    "\"vertices\" makes the mesh's cells the cells of the methods that \
                     integrate over cells (tl-fem, ul-fem, tl-weak-form, ul-weak-form, efg \
                     with integration = \"cells\", kbm with stress points), and `{}` \
                     integrates at its particles; remove the key (a particle at every cell's \
                     centroid) or choose one of those methods",
                    case.method.name
                ),
            );
        }
        if matches!(body.geometry, Shape::Tube { .. }) && case.method.lattice_cells {
            return fail(
                format!("body.{b}.geometry.shape"),
                format!(
                    "\"tube\" samples the cell centres of a cylindrical lattice, which has no \
                     cells for `{}` to integrate over; take shape = \"cylinder\" with an \
                     inner_radius, or a method that integrates at its particles",
                    case.method.name
                ),
            );
        }
        if let Some(u) = &body.initial_displacement {
            displacement(case, u, &format!("body.{b}.initial_displacement"))?;
        }
    }
    Ok(())
}

/// The `volumes` of a shape that is not a box (round, or a polygon): `scaled` or
/// `uniform`, no `tributary` (the halving on the faces of a box's vertex lattice).
fn round_volumes(key: &str, volumes: Option<Volumes>) -> Checked {
    if volumes == Some(Volumes::Tributary) {
        return fail(
            format!("{key}.volumes"),
            "`tributary` halves the volumes on the faces of a box's vertex lattice; a disk, \
             ring, cylinder or polygon takes `scaled` (the default: summing to the shape) or \
             `uniform` (Δx^d)",
        );
    }
    Ok(())
}

fn hole(hole: &Hole, shape: &Shape, key: &str, dim: usize) -> Checked {
    match shape {
        Shape::Ring {
            lattice: RingLattice::Polar,
            ..
        } => {
            return fail(
                key,
                "a polar ring comes with its cells, which a hole would cut; use lattice = \
                 \"square\" or remove the hole",
            );
        }
        Shape::Mesh {
            nodes: MeshNodes::Vertices,
            ..
        } => {
            return fail(
                key,
                "a mesh with nodes = \"vertices\" comes with its cells, which a hole would \
                 cut; mesh the hole, or remove it",
            );
        }
        _ => {}
    }
    vector(&format!("{key}.center"), &hole.center, dim)?;
    positive(&format!("{key}.radius"), hole.radius)?;
    if let Some(HoleAxis::Direction(a)) = hole.axis
        && !(a.iter().all(|x| x.is_finite()) && a.iter().any(|&x| x != 0.0))
    {
        return fail(
            format!("{key}.axis"),
            format!(
                "must be \"x\", \"y\", \"z\" or a direction [a_x, a_y, a_z] of finite \
                 components, not all zero; got {a:?}"
            ),
        );
    }
    match (dim, hole.axis) {
        (3, None) => fail(
            format!("{key}.axis"),
            "is missing: a hole in 3D is a cylinder through the body along \"x\", \"y\" or \
             \"z\"",
        ),
        (2, Some(_)) => fail(
            format!("{key}.axis"),
            "is for 3D holes only; in 2D a hole is the disk of `center` and `radius`, so \
             remove the key",
        ),
        _ => Ok(()),
    }
}

/// A cylinder's or tube's radii: 0 ≤ inner_radius < radius.
fn radii(key: &str, inner_radius: f64, radius: f64) -> Checked {
    positive(&format!("{key}.radius"), radius)?;
    non_negative(&format!("{key}.inner_radius"), inner_radius)?;
    if inner_radius >= radius {
        return fail(
            format!("{key}.inner_radius"),
            format!(
                "must be smaller than radius = {radius:?} (0 ≤ inner_radius < radius), got \
                 {inner_radius:?}"
            ),
        );
    }
    Ok(())
}

/// A tube's `angles` [θ0, θ1] (degrees, 0 < θ1 − θ0 ≤ 360) and `sectors` (≥ 1).
fn tube_angles(key: &str, angles: Option<[f64; 2]>, sectors: Option<u32>) -> Checked {
    if sectors == Some(0) {
        return fail(
            format!("{key}.sectors"),
            "must be at least 1: the rays of the tube's lattice over its angles",
        );
    }
    if let Some([theta0, theta1]) = angles {
        let span = theta1 - theta0;
        if !(theta0.is_finite() && span > 0.0 && span <= 360.0) {
            return fail(
                format!("{key}.angles"),
                format!(
                    "must be [θ0, θ1] in degrees with 0 < θ1 − θ0 ≤ 360, got [{theta0:?}, \
                     {theta1:?}]"
                ),
            );
        }
    }
    Ok(())
}

/// A shape that exists only in `exists` dimensions, in a `dim`-D case.
fn only_in(key: &str, dim: usize, name: &str, exists: usize, instead: &str) -> Checked {
    fail(
        format!("{key}.shape"),
        format!(
            "shape \"{name}\" exists only in {exists}D, but the case has dimension = {dim}; \
             in {dim}D use {instead}"
        ),
    )
}

fn shape(shape: &Shape, key: &str, dim: usize) -> Checked {
    match shape {
        Shape::Box {
            min,
            max,
            volumes,
            lattice,
        } => box_shape(key, (min, max), *volumes, *lattice, dim)?,
        Shape::Disk {
            center,
            radius,
            volumes,
        } => {
            round_volumes(key, *volumes)?;
            if dim != 2 {
                return only_in(key, dim, "disk", 2, "\"cylinder\" or \"box\"");
            }
            vector(&format!("{key}.center"), center, dim)?;
            positive(&format!("{key}.radius"), *radius)?;
        }
        Shape::Ring {
            center,
            inner_radius,
            outer_radius,
            lattice,
            sectors,
            volumes,
        } => {
            if dim != 2 {
                return only_in(key, dim, "ring", 2, "\"cylinder\" with an inner_radius");
            }
            vector(&format!("{key}.center"), center, dim)?;
            non_negative(&format!("{key}.inner_radius"), *inner_radius)?;
            positive(&format!("{key}.outer_radius"), *outer_radius)?;
            if inner_radius >= outer_radius {
                return fail(
                    format!("{key}.inner_radius"),
                    format!(
                        "must be smaller than outer_radius = {outer_radius:?} (0 ≤ inner < \
                         outer), got {inner_radius:?}"
                    ),
                );
            }
            round_volumes(key, *volumes)?;
            ring_lattice(key, *inner_radius, *lattice, *sectors, *volumes)?;
        }
        Shape::Cylinder {
            base,
            axis: _,
            radius,
            inner_radius,
            length,
            lattice: _,
            volumes,
        } => {
            round_volumes(key, *volumes)?;
            if dim != 3 {
                return only_in(key, dim, "cylinder", 3, "\"disk\" or \"ring\"");
            }
            vector(&format!("{key}.base"), base, dim)?;
            radii(key, *inner_radius, *radius)?;
            positive(&format!("{key}.length"), *length)?;
        }
        Shape::Tube {
            base,
            inner_radius,
            radius,
            length,
            angles,
            sectors,
            ..
        } => {
            if dim != 3 {
                return only_in(key, dim, "tube", 3, "\"ring\" with lattice = \"polar\"");
            }
            vector(&format!("{key}.base"), base, dim)?;
            radii(key, *inner_radius, *radius)?;
            positive(&format!("{key}.length"), *length)?;
            tube_angles(key, *angles, *sectors)?;
        }
        Shape::Polygon { vertices, volumes } => {
            if dim != 2 {
                return only_in(key, dim, "polygon", 2, "\"box\", \"cylinder\" or \"mesh\"");
            }
            round_volumes(key, *volumes)?;
            for (k, v) in vertices.iter().enumerate() {
                vector(&format!("{key}.vertices.{k}"), v, dim)?;
            }
            if let Some(why) = crate::case::polygon::not_simple(vertices) {
                return fail(format!("{key}.vertices"), why);
            }
        }
        Shape::Points { file } => {
            if file.as_os_str().is_empty() {
                return fail(
                    format!("{key}.file"),
                    "must name a CSV file (relative to the case file) with columns x, y[, z][, \
                     volume]; got an empty path",
                );
            }
        }
        Shape::Mesh { file, .. } => {
            if file.as_os_str().is_empty() {
                return fail(
                    format!("{key}.file"),
                    "must name a Gmsh mesh file (.msh, ASCII, relative to the case file); got an \
                     empty path",
                );
            }
        }
    }
    Ok(())
}

/// A box: its corners, and volumes that sum to it on its lattice.
fn box_shape(
    key: &str,
    (min, max): (&[f64], &[f64]),
    volumes: Option<Volumes>,
    lattice: Lattice,
    dim: usize,
) -> Checked {
    vector(&format!("{key}.min"), min, dim)?;
    vector(&format!("{key}.max"), max, dim)?;
    if volumes == Some(Volumes::Scaled) {
        return fail(
            format!("{key}.volumes"),
            "`scaled` is for round shapes, whose lattice cannot follow the boundary; a \
             box's `tributary` (vertex lattice) or `uniform` (cell-centred) volumes sum \
             to it",
        );
    }
    if (volumes, lattice) == (Some(Volumes::Tributary), Lattice::CellCentred) {
        return fail(
            format!("{key}.volumes"),
            "`tributary` halves the volumes of the particles on the faces of a vertex \
             lattice; a `cell-centred` lattice has none there, so use `uniform`",
        );
    }
    for (k, (lo, hi)) in min.iter().zip(max).enumerate() {
        if lo >= hi {
            return fail(
                format!("{key}.max"),
                format!(
                    "must exceed `min` on every axis, but on axis {k} max = {hi:?} ≤ \
                     min = {lo:?} (min = {min:?}, max = {max:?})"
                ),
            );
        }
    }
    Ok(())
}

/// The keys of a ring's lattice: a polar one makes its own volumes, takes `sectors` (at
/// least 3) and needs a hole.
fn ring_lattice(
    key: &str,
    inner_radius: f64,
    lattice: RingLattice,
    sectors: Option<u32>,
    volumes: Option<Volumes>,
) -> Checked {
    if lattice == RingLattice::Polar && volumes.is_some() {
        return fail(
            format!("{key}.volumes"),
            "a polar ring's volumes are a quarter of each adjacent cell, which sum to \
             the ring: remove the key, or use lattice = \"square\"",
        );
    }
    match (lattice, sectors) {
        (RingLattice::Square, Some(_)) => fail(
            format!("{key}.sectors"),
            "is read by a polar lattice only: add lattice = \"polar\" or remove it",
        ),
        (RingLattice::Polar, _) if inner_radius <= 0.0 => fail(
            format!("{key}.inner_radius"),
            "must be positive with lattice = \"polar\" (its rays meet at the centre \
             otherwise); use lattice = \"square\" or a disk for a full one",
        ),
        (RingLattice::Polar, Some(n)) if n < 3 => fail(
            format!("{key}.sectors"),
            format!("must be at least 3 (rays around the ring), got {n}"),
        ),
        _ => Ok(()),
    }
}
