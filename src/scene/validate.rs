//! Semantic checks of a parsed case: everything serde cannot see (ranges, vector
//! lengths, shapes that exist only in one dimension, references between tables).
//!
//! Checks run in a fixed order (top level, material, method, bodies, boundaries, run,
//! output, the closed forms of the observers, probes) and the first problem found is reported, so the same bad file always
//! gives the same message.

use super::{
    Axis, BodySpec, BoundarySpec, Case, Condition, ContactSpec, DisplacementField, Hole, Lattice,
    MaterialSpec, MeshNodes, Observer, OutputSpec, Plane, ProbeSpec, Region, RingLattice, RunSpec,
    Shape, Solution, Solve, TimeLaw, VelocityField, Volumes,
};
use crate::material::{Material, MaterialModel};
use crate::methods::{Feature, MethodTable, Problem, REGISTRY, entry, quoted, supporting};
use serde::Serialize;
use std::collections::HashSet;

/// Largest `run.threads`: more than any machine this runs on, few enough that a typo
/// (`run.threads = 20000`) is refused rather than spawning the threads.
const MAX_THREADS: usize = 4096;

type Checked = Result<(), Problem>;

/// Semantic checks after parsing. Err((key, message)): the dotted key path, e.g. `material.poisson_ratio` or `body.1.geometry.radius` or `boundary.0.condition.vx`, and a message that says what is wrong and what is allowed, quoting the offending value.
pub(super) fn check(case: &Case) -> Result<(), (String, String)> {
    top_level(case)?;
    let dim = case.dim();
    material(
        &case.material,
        crate::methods::mixed::accepts_incompressible(case),
    )?;
    plane(&case.material, dim)?;
    method(&case.method)?;
    method_keys(case)?;
    case.method.spec.validate(case)?;
    if case.material.model == MaterialModel::VonMisesPlastic {
        feature(
            case,
            Feature::Plasticity,
            "material.model",
            "`von-mises-plastic` carries a plastic history (C_p⁻¹, ε_p)",
            "use an elastic model",
        )?;
    }
    bodies(&case.bodies, dim)?;
    for (b, body) in case.bodies.iter().enumerate() {
        if let Shape::Mesh {
            nodes: MeshNodes::Vertices,
            ..
        } = body.geometry
            && !case.method.spec.lattice_cells()
        {
            return fail(
                format!("body.{b}.geometry.nodes"),
                format!(
                    "\"vertices\" makes the mesh's cells the cells of the methods that \
                     integrate over cells (tl-fem, ul-fem, tl-weak-form, ul-weak-form, efg \
                     with integration = \"cells\", kbm with stress points), and `{}` \
                     integrates at its particles; remove the key (a particle at every cell's \
                     centroid) or choose one of those methods",
                    case.method.name()
                ),
            );
        }
        if let Some(u) = &body.initial_displacement {
            displacement(case, u, &format!("body.{b}.initial_displacement"))?;
        }
    }
    for (i, boundary) in case.boundaries.iter().enumerate() {
        self::boundary(boundary, &format!("boundary.{i}"), &case.bodies, dim)?;
        if (boundary.condition.is_timed_load() || boundary.condition.is_timed_velocity())
            && case.is_static()
        {
            return fail(
                format!("boundary.{i}.condition"),
                format!(
                    "the run of `{}` is static: its load steps scale the loads by t/end_time, \
                     so it takes no time law and no release (`until`); give a constant \
                     `traction`, `pressure` or `velocity`",
                    case.method.name()
                ),
            );
        }
        if matches!(
            boundary.condition,
            Condition::Displacement { .. } | Condition::SolutionDisplacement { .. }
        ) && !case.is_static()
        {
            return fail(
                format!("boundary.{i}.condition"),
                format!(
                    "a prescribed displacement is a condition of the static path: set \
                     run.solve = \"static\" (which {} run), or prescribe a velocity \
                     (`velocity`) instead",
                    quoted(supporting(Feature::StaticSolve))
                ),
            );
        }
    }
    mirrors(case)?;
    contact(case)?;
    run(&case.run, &case.method)?;
    statics(case)?;
    tolerance(case)?;
    output(&case.output)?;
    analytic_observers(case)?;
    front_observers(case)?;
    boundary_names(case)?;
    probes(&case.probes, dim)?;
    sections(case)
}

pub(crate) fn fail(key: impl Into<String>, message: impl Into<String>) -> Checked {
    Err((key.into(), message.into()))
}

/// The name a unit enum variant has in case files (`neck-height`, `z`).
pub(crate) fn toml_name<T: Serialize>(value: &T) -> String {
    serde_json::to_value(value)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| "?".to_string())
}

fn finite(key: &str, value: f64) -> Checked {
    if value.is_finite() {
        Ok(())
    } else {
        fail(key, format!("must be a finite number, got {value:?}"))
    }
}

/// Finite and strictly positive.
pub(crate) fn positive(key: &str, value: f64) -> Checked {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        fail(key, format!("must be a finite number > 0, got {value:?}"))
    }
}

/// Finite and ≥ 0.
pub(crate) fn non_negative(key: &str, value: f64) -> Checked {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        fail(key, format!("must be a finite number ≥ 0, got {value:?}"))
    }
}

/// A coordinate vector: one finite entry per dimension.
fn vector(key: &str, value: &[f64], dim: usize) -> Checked {
    if value.len() != dim {
        return fail(
            key,
            format!(
                "must have {dim} components (one per dimension; the case has dimension = {dim}), \
                 got {} in {value:?}",
                value.len()
            ),
        );
    }
    if let Some((k, v)) = value.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return fail(
            key,
            format!("component {k} must be a finite number, got {v:?} in {value:?}"),
        );
    }
    Ok(())
}

/// A direction: a vector of the given length that is not zero.
fn direction(key: &str, value: &[f64], dim: usize) -> Checked {
    vector(key, value, dim)?;
    if value.iter().all(|v| *v == 0.0) {
        return fail(key, format!("must be a non-zero direction, got {value:?}"));
    }
    Ok(())
}

/// Names that become file names or CSV column prefixes.
fn identifier(key: &str, value: &str, what: &str) -> Checked {
    if value.is_empty() {
        return fail(
            key,
            format!(
                "must not be empty; {what}, so use only letters, digits, '-' and '_' \
                 (e.g. \"beam-1\")"
            ),
        );
    }
    if let Some(c) = value
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '-' || *c == '_'))
    {
        return fail(
            key,
            format!(
                "{value:?} contains {c:?}; {what}, so only ASCII letters, digits, '-' and '_' \
                 are allowed"
            ),
        );
    }
    Ok(())
}

fn top_level(case: &Case) -> Checked {
    if !matches!(case.dimension, 2 | 3) {
        return fail(
            "dimension",
            format!("must be 2 (plane strain) or 3, got {}", case.dimension),
        );
    }
    positive("spacing", case.spacing)?;
    identifier(
        "name",
        &case.name,
        "the case name becomes the output file name",
    )
}

/// A key of `[material]` that only some models read.
struct ModelKey {
    key: &'static str,
    value: Option<f64>,
    reads: fn(MaterialModel) -> bool,
    /// What a model that reads it must be given.
    needs: &'static str,
}

/// The keys of `[material]` that only some models read.
fn model_keys(m: &MaterialSpec) -> [ModelKey; 7] {
    let elastic = |model: MaterialModel| !model.reads_mooney_rivlin_constants();
    let plastic = |model| model == MaterialModel::VonMisesPlastic;
    let rubber = MaterialModel::reads_mooney_rivlin_constants;
    const E_NU: &str = "give `youngs_modulus` (E [Pa], > 0) and `poisson_ratio` (ν in (−1, 0.5))";
    const PLASTIC: &str = "give `yield_stress` (τ_y⁰ [Pa], > 0) and `hardening_modulus` (H \
                           [Pa], > −3μ; negative softens, the yield stress stopping at zero)";
    const RUBBER: &str = "give `c1` [Pa] (> 0), `c2` [Pa] (≥ 0) and `lambda` [Pa] (> 0), the \
                          constants of seed 001 eq 18";
    let key = |key, value, reads, needs| ModelKey {
        key,
        value,
        reads,
        needs,
    };
    [
        key("youngs_modulus", m.youngs_modulus, elastic, E_NU),
        key("poisson_ratio", m.poisson_ratio, elastic, E_NU),
        key("yield_stress", m.yield_stress, plastic, PLASTIC),
        key("hardening_modulus", m.hardening_modulus, plastic, PLASTIC),
        key("c1", m.c1, rubber, RUBBER),
        key("c2", m.c2, rubber, RUBBER),
        key("lambda", m.lambda, rubber, RUBBER),
    ]
}

/// Checks of the `[material]` table; ν = 0.5 where the method accepts it.
fn material(m: &MaterialSpec, incompressible: bool) -> Checked {
    positive("material.density", m.density)?;
    for ModelKey {
        key,
        value,
        reads,
        needs,
    } in model_keys(m)
    {
        let key = format!("material.{key}");
        match value {
            Some(_) if !reads(m.model) => {
                let names: Vec<String> = MaterialModel::ALL
                    .iter()
                    .filter(|&&r| reads(r))
                    .map(|r| format!("`{}`", toml_name(r)))
                    .collect();
                return fail(
                    key,
                    format!(
                        "is read only by {}, not by `{}`; remove it",
                        names.join(", "),
                        toml_name(&m.model)
                    ),
                );
            }
            None if reads(m.model) => {
                return fail(
                    key,
                    format!("the `{}` model needs it: {needs}", toml_name(&m.model)),
                );
            }
            _ => {}
        }
    }
    if let Some(e) = m.youngs_modulus {
        positive("material.youngs_modulus", e)?;
    }
    if let Some(nu) = m.poisson_ratio
        && !(nu > -1.0 && (nu < 0.5 || (nu == 0.5 && incompressible)))
    {
        return fail(
            "material.poisson_ratio",
            format!(
                "is {nu:?}; it must lie in (−1, 0.5); 0.5 is incompressible, which only \
                 `upwind-sph` and `jst-sph` with [method.artificial_compressibility] and the \
                 `nearly-incompressible-neo-hookean` model run"
            ),
        );
    }
    if let Some(y) = m.yield_stress {
        positive("material.yield_stress", y)?;
    }
    if let Some(h) = m.hardening_modulus {
        finite("material.hardening_modulus", h)?;
        // Δγ = f/(3μ + H) of the radial return needs 3μ + H > 0: the yield function then
        // decreases along the return and has one root.
        let mu = Material::new(m).mu;
        if h <= -3.0 * mu {
            return fail(
                "material.hardening_modulus",
                format!(
                    "is {h:?}; softening (H < 0) must stay above −3μ = {:e} Pa (μ = E/(2(1 + \
                     ν))), where the radial return has no unique solution",
                    -3.0 * mu
                ),
            );
        }
    }
    if let Some(c1) = m.c1 {
        positive("material.c1", c1)?;
    }
    if let Some(c2) = m.c2 {
        non_negative("material.c2", c2)?;
    }
    if let Some(lambda) = m.lambda {
        positive("material.lambda", lambda)?;
    }
    Ok(())
}

/// Plane stress is a 2D assumption, which the models linear in their strain measure take.
fn plane(m: &MaterialSpec, dim: usize) -> Checked {
    if m.plane == Plane::Strain {
        return Ok(());
    }
    if dim != 2 {
        return fail(
            "material.plane",
            "applies to 2D scenes (dimension = 2) only; remove it from a 3D case",
        );
    }
    if !MaterialModel::PLANE_STRESS.contains(&m.model) {
        let models: Vec<String> = MaterialModel::PLANE_STRESS
            .iter()
            .map(|m| format!("`{}`", toml_name(m)))
            .collect();
        return fail(
            "material.plane",
            format!(
                "\"stress\" is taken by the models {} (linear in their strain measure), not \
                 by `{}`, whose σ_zz = 0 would need a per-particle solve for F_zz; use \
                 plane = \"strain\" or one of those models",
                models.join(", "),
                toml_name(&m.model)
            ),
        );
    }
    Ok(())
}

fn method(m: &MethodTable) -> Checked {
    // The support radius (support factor × h) must reach the nearest lattice neighbour:
    // h ≥ Δx/2 for the kernels of support 2h, Δx/3 for the quintic (support 3h; seed 004
    // §6.4's smallest support, 0.9 times a particle's diameter, is h = 0.338 Δx).
    let h = m.h_over_dx;
    let lowest = 1.0 / m.kernel.support_factor();
    if !(h.is_finite() && (lowest..=4.0).contains(&h)) {
        return fail(
            "method.h_over_dx",
            format!(
                "must be a finite number in [{}, 4] (the {} kernel's support {}h must \
                 reach one spacing), got {h:?}",
                (lowest * 1e4).round() / 1e4,
                toml_name(&m.kernel),
                m.kernel.support_factor()
            ),
        );
    }
    match (m.dt, m.cfl) {
        (Some(dt), Some(cfl)) => {
            return fail(
                "method.dt",
                format!(
                    "`method.dt` = {dt:?} and `method.cfl` = {cfl:?} are both given; give \
                     exactly one of them: `dt` for a fixed time step [s] or `cfl` for an \
                     adaptive one"
                ),
            );
        }
        (None, None) => {
            return fail(
                "method.dt",
                "neither `method.dt` nor `method.cfl` is given; give exactly one of them: `dt` \
                 for a fixed time step [s] or `cfl` for an adaptive one",
            );
        }
        (Some(dt), None) => positive("method.dt", dt)?,
        (None, Some(cfl)) => {
            if !(cfl > 0.0 && cfl <= 2.0) {
                return fail("method.cfl", format!("must lie in (0, 2], got {cfl:?}"));
            }
        }
    }
    Ok(())
}

/// Keys of other methods in the `[method]` table: named with the methods that read them
/// and the keys this one reads.
fn method_keys(case: &Case) -> Checked {
    let Some(key) = case.method.foreign.first() else {
        return Ok(());
    };
    let name = case.method.name();
    let owners = REGISTRY
        .iter()
        .filter(|e| e.keys.contains(&key.as_str()))
        .map(|e| e.name);
    let own = entry(name).map_or(&[][..], |e| e.keys);
    fail(
        format!("method.{key}"),
        format!(
            "is read only by {}, not by `{name}`; remove it (the keys of `{name}` besides \
             the common ones: {})",
            quoted(owners),
            if own.is_empty() {
                "none".to_string()
            } else {
                own.join(", ")
            }
        ),
    )
}

/// A scene feature the case's method must run: names the methods that do.
fn feature(case: &Case, feature: Feature, key: &str, what: &str, instead: &str) -> Checked {
    let name = case.method.name();
    if case.method.spec.entry().features.contains(&feature) {
        return Ok(());
    }
    fail(
        key,
        format!(
            "{what}, which {} run, not `{name}`; {instead} or choose one of those methods",
            quoted(supporting(feature))
        ),
    )
}

/// Penalty contact: 2D, a method that runs it, at least two bodies, 0 < α ≤ 1. That the bodies lie
/// apart by more than the kernel support is checked on their particles, when the method
/// finds its neighbours.
fn contact(case: &Case) -> Checked {
    let Some(ContactSpec { penalty }) = case.contact else {
        return Ok(());
    };
    if !(penalty > 0.0 && penalty <= 1.0) {
        return fail(
            "contact.penalty",
            format!(
                "must lie in (0, 1] (the fraction of a penetration removed in one step; the \
                 seed uses 0.1), got {penalty:?}"
            ),
        );
    }
    if case.dim() != 2 {
        return fail(
            "contact",
            "contact finds each body's boundary as a 2D convex hull; a 3D case cannot have \
             contact, remove the [contact] table",
        );
    }
    feature(
        case,
        Feature::Contact,
        "contact",
        "penalty contact is a pass of the methods",
        "remove the [contact] table",
    )?;
    if case.bodies.len() < 2 {
        return fail(
            "contact",
            "contact acts between bodies and the case has one; add a [[body]] or remove the \
             [contact] table",
        );
    }
    Ok(())
}

fn bodies(bodies: &[BodySpec], dim: usize) -> Checked {
    if bodies.is_empty() {
        return fail(
            "body",
            "the case has no body; add at least one [[body]] table with a name and a geometry",
        );
    }
    let mut seen = HashSet::new();
    for (i, body) in bodies.iter().enumerate() {
        let key = format!("body.{i}");
        identifier(
            &format!("{key}.name"),
            &body.name,
            "body names label output fields and boundary regions",
        )?;
        if !seen.insert(body.name.as_str()) {
            return fail(
                format!("{key}.name"),
                format!(
                    "{:?} is already the name of an earlier body; body names must be unique",
                    body.name
                ),
            );
        }
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

fn shape(shape: &Shape, key: &str, dim: usize) -> Checked {
    let only = |name: &str, exists: usize, instead: &str| {
        fail(
            format!("{key}.shape"),
            format!(
                "shape \"{name}\" exists only in {exists}D, but the case has dimension = {dim}; \
                 in {dim}D use {instead}"
            ),
        )
    };
    match shape {
        Shape::Box {
            min,
            max,
            volumes,
            lattice,
        } => {
            vector(&format!("{key}.min"), min, dim)?;
            vector(&format!("{key}.max"), max, dim)?;
            if *volumes == Some(Volumes::Scaled) {
                return fail(
                    format!("{key}.volumes"),
                    "`scaled` is for round shapes, whose lattice cannot follow the boundary; a \
                     box's `tributary` (vertex lattice) or `uniform` (cell-centred) volumes sum \
                     to it",
                );
            }
            if (*volumes, *lattice) == (Some(Volumes::Tributary), Lattice::CellCentred) {
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
        }
        Shape::Disk {
            center,
            radius,
            volumes,
        } => {
            round_volumes(key, *volumes)?;
            if dim != 2 {
                return only("disk", 2, "\"cylinder\" or \"box\"");
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
                return only("ring", 2, "\"cylinder\" with an inner_radius");
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
            if *lattice == RingLattice::Polar && volumes.is_some() {
                return fail(
                    format!("{key}.volumes"),
                    "a polar ring's volumes are a quarter of each adjacent cell, which sum to \
                     the ring: remove the key, or use lattice = \"square\"",
                );
            }
            match (lattice, sectors) {
                (RingLattice::Square, Some(_)) => {
                    return fail(
                        format!("{key}.sectors"),
                        "is read by a polar lattice only: add lattice = \"polar\" or remove it",
                    );
                }
                (RingLattice::Polar, _) if *inner_radius <= 0.0 => {
                    return fail(
                        format!("{key}.inner_radius"),
                        "must be positive with lattice = \"polar\" (its rays meet at the centre \
                         otherwise); use lattice = \"square\" or a disk for a full one",
                    );
                }
                (RingLattice::Polar, Some(n)) if *n < 3 => {
                    return fail(
                        format!("{key}.sectors"),
                        format!("must be at least 3 (rays around the ring), got {n}"),
                    );
                }
                _ => {}
            }
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
                return only("cylinder", 3, "\"disk\" or \"ring\"");
            }
            vector(&format!("{key}.base"), base, dim)?;
            positive(&format!("{key}.radius"), *radius)?;
            non_negative(&format!("{key}.inner_radius"), *inner_radius)?;
            if inner_radius >= radius {
                return fail(
                    format!("{key}.inner_radius"),
                    format!(
                        "must be smaller than radius = {radius:?} (0 ≤ inner_radius < radius), \
                         got {inner_radius:?}"
                    ),
                );
            }
            positive(&format!("{key}.length"), *length)?;
        }
        Shape::Polygon { vertices, volumes } => {
            if dim != 2 {
                return only("polygon", 2, "\"box\", \"cylinder\" or \"mesh\"");
            }
            round_volumes(key, *volumes)?;
            for (k, v) in vertices.iter().enumerate() {
                vector(&format!("{key}.vertices.{k}"), v, dim)?;
            }
            if let Some(why) = super::polygon::not_simple(vertices) {
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

/// An initial displacement: a method whose F follows from u, a dynamic run (the static
/// path starts from the reference configuration), and a gradient of d rows of d numbers.
fn displacement(case: &Case, field: &DisplacementField, key: &str) -> Checked {
    feature(
        case,
        Feature::InitialDisplacement,
        key,
        "an initial displacement sets the state's u, from which F follows",
        "remove the key",
    )?;
    if case.is_static() {
        return fail(
            key,
            "the static path solves from the reference configuration; remove the key or run \
             dynamically (run.solve = \"dynamic\")",
        );
    }
    if case.material.model.is_rate_based() {
        return fail(
            key,
            format!(
                "`{}` integrates its stress from zero, so the body would start deformed but \
                 unstressed; use a model whose stress follows from F",
                toml_name(&case.material.model)
            ),
        );
    }
    let dim = case.dim();
    match field {
        DisplacementField::Linear { gradient } => gradient_rows(key, gradient, dim, "displacement"),
        DisplacementField::Expression { uz, constants, .. } => {
            if dim != 3 && uz.is_some() {
                return fail(
                    format!("{key}.uz"),
                    format!(
                        "exists only in 3D, but the case has dimension = {dim}; give ux and uy"
                    ),
                );
            }
            expression_constants(key, constants, &["x", "y", "z"])?;
            field.expressions(key, dim).map(|_| ())
        }
        DisplacementField::Swinging { amplitude, mode } => {
            swinging_mode(&format!("{key}.mode"), *mode, dim)?;
            finite(&format!("{key}.amplitude"), *amplitude)
        }
    }
}

/// A swinging mode that exists in the scene's dimension.
fn swinging_mode(key: &str, mode: crate::analytic::SwingingKind, dim: usize) -> Checked {
    if mode == crate::analytic::SwingingKind::Shear && dim != 2 {
        return fail(
            key,
            format!(
                "the `shear` mode is seed 002's plate, 2D only, but the case has dimension = \
                 {dim}; use `dilatational`"
            ),
        );
    }
    Ok(())
}

/// The gradient of a linear `field` (velocity, displacement): d rows of d finite numbers.
fn gradient_rows(key: &str, gradient: &[Vec<f64>], dim: usize, field: &str) -> Checked {
    if gradient.len() != dim {
        return fail(
            format!("{key}.gradient"),
            format!(
                "must have {dim} rows (one per {field} component), got {}",
                gradient.len()
            ),
        );
    }
    for (i, row) in gradient.iter().enumerate() {
        vector(&format!("{key}.gradient.{i}"), row, dim)?;
    }
    Ok(())
}

fn velocity(field: &VelocityField, key: &str, dim: usize) -> Checked {
    match field {
        VelocityField::Uniform { value } => vector(&format!("{key}.value"), value, dim),
        VelocityField::Linear { gradient } => gradient_rows(key, gradient, dim, "velocity"),
        VelocityField::RigidRotation {
            omega,
            center,
            axis,
        } => {
            finite(&format!("{key}.omega"), *omega)?;
            vector(&format!("{key}.center"), center, dim)?;
            match (dim, axis) {
                (3, Some(axis)) => direction(&format!("{key}.axis"), axis, 3),
                (3, None) => fail(
                    format!("{key}.axis"),
                    "is required in 3D: give the direction of ω as 3 components, e.g. [0.0, \
                     0.0, 1.0]",
                ),
                (_, Some(axis)) => fail(
                    format!("{key}.axis"),
                    format!(
                        "must be absent in 2D (ω is the out-of-plane rotation rate), got \
                         {axis:?}"
                    ),
                ),
                (_, None) => Ok(()),
            }
        }
        VelocityField::GaussianPulse {
            amplitude,
            direction: d,
            center,
            width,
        } => {
            finite(&format!("{key}.amplitude"), *amplitude)?;
            direction(&format!("{key}.direction"), d, dim)?;
            finite(&format!("{key}.center"), *center)?;
            positive(&format!("{key}.width"), *width)
        }
        VelocityField::Swinging { amplitude, mode } => {
            swinging_mode(&format!("{key}.mode"), *mode, dim)?;
            finite(&format!("{key}.amplitude"), *amplitude)
        }
        VelocityField::Expression { vz, constants, .. } => {
            if dim != 3 && vz.is_some() {
                return fail(
                    format!("{key}.vz"),
                    format!(
                        "exists only in 3D, but the case has dimension = {dim}; give vx and vy"
                    ),
                );
            }
            expression_constants(key, constants, &["x", "y", "z"])?;
            match field.expressions(key, dim) {
                Some(Err((key, message))) => fail(key, message),
                _ => Ok(()),
            }
        }
        VelocityField::Twist { omega, length } => {
            if dim != 3 {
                return fail(
                    key,
                    "a twist is a 3D field (about the Y axis); use it in 3D",
                );
            }
            finite(&format!("{key}.omega"), *omega)?;
            positive(&format!("{key}.length"), *length)
        }
    }
}

/// Mirror planes: a method that runs them, at most two per axis. Where the particles lie
/// against the planes is checked when the ghosts are built.
fn mirrors(case: &Case) -> Checked {
    let dim = case.dim();
    for (i, mirror) in case.mirrors.iter().enumerate() {
        let key = format!("mirror.{i}");
        feature(
            case,
            Feature::MirrorPlanes,
            &key,
            "mirror planes are ghost particles",
            "use a [[boundary]] with a `symmetry` condition instead",
        )?;
        if mirror.normal.index() >= dim {
            return fail(
                format!("{key}.normal"),
                format!(
                    "\"z\" exists only in 3D, but the case has dimension = {dim}; use \"x\" or \"y\""
                ),
            );
        }
        finite(&format!("{key}.at"), mirror.at)?;
        let same_axis = case.mirrors[..i]
            .iter()
            .filter(|o| o.normal == mirror.normal)
            .count();
        if same_axis >= 2 {
            return fail(
                format!("{key}.normal"),
                format!(
                    "a body lies between at most two planes normal to {}; this is the third",
                    toml_name(&mirror.normal)
                ),
            );
        }
    }
    Ok(())
}

fn boundary(b: &BoundarySpec, key: &str, bodies: &[BodySpec], dim: usize) -> Checked {
    region(&b.region, &format!("{key}.region"), bodies, dim)?;
    let key = format!("{key}.condition");
    match &b.condition {
        Condition::Fixed => Ok(()),
        Condition::Velocity {
            vx,
            vy,
            vz,
            law,
            until,
        } => {
            if vx.is_none() && vy.is_none() && vz.is_none() {
                let allowed = if dim == 3 { "vx, vy, vz" } else { "vx, vy" };
                return fail(
                    key,
                    format!("a velocity condition needs at least one of {allowed}; none is given"),
                );
            }
            if dim != 3
                && let Some(vz) = vz
            {
                return fail(
                    format!("{key}.vz"),
                    format!(
                        "exists only in 3D, but the case has dimension = {dim}; got {vz:?}; in 2D give vx and/or vy"
                    ),
                );
            }
            for (name, v) in [("vx", vx), ("vy", vy), ("vz", vz)] {
                if let Some(v) = v {
                    finite(&format!("{key}.{name}"), *v)?;
                }
            }
            if let Some(until) = until {
                positive(&format!("{key}.until"), *until)?;
            }
            time_law(law, &format!("{key}.law"))
        }
        Condition::Symmetry { normal } => {
            if dim != 3 && *normal == Axis::Z {
                return fail(
                    format!("{key}.normal"),
                    format!(
                        "\"{}\" exists only in 3D, but the case has dimension = {dim}; in 2D \
                         the normal is \"x\" or \"y\"",
                        toml_name(normal)
                    ),
                );
            }
            Ok(())
        }
        Condition::Traction { traction, law } => {
            vector(&format!("{key}.traction"), traction, dim)?;
            time_law(law, &format!("{key}.law"))
        }
        Condition::BodyForce { acceleration, law } => {
            vector(&format!("{key}.acceleration"), acceleration, dim)?;
            time_law(law, &format!("{key}.law"))
        }
        Condition::Pressure {
            pressure,
            center,
            radius,
            law,
            ..
        } => {
            if dim != 2 {
                return fail(
                    key,
                    format!(
                        "a pressure acts on a circle of a 2D scene, but the case has dimension \
                         = {dim}; in 3D give a `traction` on a face"
                    ),
                );
            }
            finite(&format!("{key}.pressure"), *pressure)?;
            vector(&format!("{key}.center"), center, dim)?;
            positive(&format!("{key}.radius"), *radius)?;
            time_law(law, &format!("{key}.law"))
        }
        Condition::Displacement { ux, uy, uz } => {
            if ux.is_none() && uy.is_none() && uz.is_none() {
                let allowed = if dim == 3 { "ux, uy, uz" } else { "ux, uy" };
                return fail(
                    key,
                    format!(
                        "a displacement condition needs at least one of {allowed}; none is given"
                    ),
                );
            }
            if dim != 3
                && let Some(uz) = uz
            {
                return fail(
                    format!("{key}.uz"),
                    format!(
                        "exists only in 3D, but the case has dimension = {dim}; got {uz:?}; in 2D give ux and/or uy"
                    ),
                );
            }
            for (name, u) in [("ux", ux), ("uy", uy), ("uz", uz)] {
                if let Some(u) = u {
                    finite(&format!("{key}.{name}"), *u)?;
                }
            }
            Ok(())
        }
        Condition::SolutionDisplacement {
            solution,
            components,
        } => {
            self::solution(solution, &format!("{key}.solution"), dim)?;
            if components.is_empty() {
                return fail(
                    format!("{key}.components"),
                    "lists no component; give some of \"x\", \"y\" (and \"z\" in 3D)",
                );
            }
            if let Some(z) = components.iter().find(|a| a.index() >= dim) {
                return fail(
                    format!("{key}.components"),
                    format!(
                        "\"{}\" exists only in 3D, but the case has dimension = {dim}",
                        toml_name(z)
                    ),
                );
            }
            Ok(())
        }
        Condition::SolutionTraction { solution, normal } => {
            self::solution(solution, &format!("{key}.solution"), dim)?;
            vector(&format!("{key}.normal"), normal, dim)?;
            let axes = normal.iter().filter(|c| **c != 0.0).count();
            if axes != 1 || normal.iter().any(|c| *c != 0.0 && c.abs() != 1.0) {
                return fail(
                    format!("{key}.normal"),
                    format!(
                        "must be the outward unit normal of a face along an axis, such as \
                         [1, 0{}], got {normal:?}",
                        if dim == 3 { ", 0" } else { "" }
                    ),
                );
            }
            Ok(())
        }
    }
}

/// A time law: positive durations and time constants, a table of finite points with
/// non-decreasing times.
/// The named constants of an expression below `key`: names of letters, digits and _ (not
/// first a digit) other than the expression's `variables`, PI and E; finite values.
fn expression_constants(
    key: &str,
    constants: &std::collections::BTreeMap<String, f64>,
    variables: &[&str],
) -> Checked {
    for (name, &c) in constants {
        if variables.contains(&name.as_str())
            || ["PI", "E"].contains(&name.as_str())
            || !name.chars().all(|c| c.is_alphanumeric() || c == '_')
            || name.starts_with(|c: char| c.is_ascii_digit())
        {
            return fail(
                format!("{key}.constants.{name}"),
                format!(
                    "is not a name a constant can have: use letters, digits and _ (not first a digit), other than {}, PI and E",
                    variables.join(", ")
                ),
            );
        }
        finite(&format!("{key}.constants.{name}"), c)?;
    }
    Ok(())
}

fn time_law(law: &TimeLaw, key: &str) -> Checked {
    match law {
        TimeLaw::Constant => Ok(()),
        TimeLaw::Ramp { duration } => positive(&format!("{key}.duration"), *duration),
        TimeLaw::Exponential { tau, start } => {
            positive(&format!("{key}.tau"), *tau)?;
            non_negative(&format!("{key}.start"), *start)
        }
        TimeLaw::Expression { constants, .. } => {
            expression_constants(key, constants, &["t"])?;
            match law.expression() {
                Some(Err(message)) => fail(format!("{key}.value"), message),
                _ => Ok(()),
            }
        }
        TimeLaw::Table { points } => {
            if points.is_empty() {
                return fail(
                    format!("{key}.points"),
                    "is empty; give [time, value] points, e.g. [[0.0, 1.0], [1e-4, 1.0], \
                     [1e-4, 0.0]] (held for 0.1 ms, then removed)",
                );
            }
            if let Some(p) = points
                .iter()
                .find(|p| !(p[0].is_finite() && p[1].is_finite()))
            {
                return fail(
                    format!("{key}.points"),
                    format!("holds {p:?}; every time and value must be a finite number"),
                );
            }
            if let Some(w) = points.windows(2).find(|w| w[1][0] < w[0][0]) {
                return fail(
                    format!("{key}.points"),
                    format!(
                        "goes back in time from {:?} to {:?}; the times must not decrease (a \
                         time given twice is a jump)",
                        w[0], w[1]
                    ),
                );
            }
            Ok(())
        }
    }
}

fn solution(s: &Solution, key: &str, dim: usize) -> Checked {
    match *s {
        Solution::TimoshenkoCantilever {
            load,
            length,
            depth,
        } => {
            finite(&format!("{key}.load"), load)?;
            positive(&format!("{key}.length"), length)?;
            positive(&format!("{key}.depth"), depth)
        }
        Solution::UniaxialStress { stress, axis } => {
            if axis.index() >= dim {
                return fail(
                    format!("{key}.axis"),
                    format!("\"z\" exists only in 3D, but the case has dimension = {dim}"),
                );
            }
            finite(&format!("{key}.stress"), stress)
        }
    }
}

fn region(r: &Region, key: &str, bodies: &[BodySpec], dim: usize) -> Checked {
    if let Some(name) = &r.body
        && !bodies.iter().any(|b| &b.name == name)
    {
        let names: Vec<String> = bodies.iter().map(|b| format!("{:?}", b.name)).collect();
        return fail(
            format!("{key}.body"),
            format!(
                "names no body: {name:?}; the bodies are {}",
                names.join(", ")
            ),
        );
    }
    let axes = [
        ("x", r.x_min, r.x_max),
        ("y", r.y_min, r.y_max),
        ("z", r.z_min, r.z_max),
    ];
    for (k, (axis, lo, hi)) in axes.into_iter().enumerate() {
        for (end, bound) in [("min", lo), ("max", hi)] {
            let Some(v) = bound else { continue };
            let bound_key = format!("{key}.{axis}_{end}");
            if k >= dim {
                return fail(
                    bound_key,
                    format!(
                        "exists only in 3D, but the case has dimension = {dim}; got {v:?}; in \
                         2D bound the region with x_min, x_max, y_min, y_max"
                    ),
                );
            }
            finite(&bound_key, v)?;
        }
        if let (Some(lo), Some(hi)) = (lo, hi)
            && lo > hi
        {
            return fail(
                format!("{key}.{axis}_max"),
                format!("must be ≥ {axis}_min = {lo:?}, got {hi:?}"),
            );
        }
    }
    Ok(())
}

/// `run.solve`: a method that runs it; the static solve of an explicit method takes
/// load steps of `method.dt`, a state model without history and no contact.
fn statics(case: &Case) -> Checked {
    let features = case.method.spec.entry().features;
    if case.run.solve == Some(Solve::Static) {
        feature(
            case,
            Feature::StaticSolve,
            "run.solve",
            "`static` is the static solve",
            "give run.solve = \"dynamic\"",
        )?;
    }
    if !case.is_static() || features.contains(&Feature::StaticDefault) {
        return Ok(());
    }
    if case.method.dt.is_none() || case.method.cfl.is_some() {
        return fail(
            "method.dt",
            "a static run takes load steps of method.dt in the pseudo-time of run.end_time \
             (end_time/dt load steps; dt = end_time for one): give method.dt and no method.cfl",
        );
    }
    let model = case.material.model;
    if model.is_rate_based() || model == MaterialModel::VonMisesPlastic {
        return fail(
            "material.model",
            format!(
                "a static run solves for u alone, so the stress must follow from F without \
                 history: use {}, not {}",
                MaterialModel::names_where(
                    |m| !m.is_rate_based() && m != MaterialModel::VonMisesPlastic
                ),
                toml_name(&model)
            ),
        );
    }
    if case.contact.is_some() {
        return fail(
            "contact",
            "a static run has no contact (penalty contact acts through the time step); \
             remove the [contact] table or give run.solve = \"dynamic\"",
        );
    }
    Ok(())
}

/// `run.tolerance`: each key in [ε, 1) (ε the double-precision epsilon, which no f64
/// residual falls below but to zero; 1 would accept the first iterate), on a static run.
fn tolerance(case: &Case) -> Checked {
    let t = case.run.tolerance;
    for (key, value) in [
        ("run.tolerance.residual", t.residual),
        ("run.tolerance.increment", t.increment),
    ] {
        let Some(v) = value else { continue };
        if !(v.is_finite() && (crate::statics::Tolerance::SMALLEST..1.0).contains(&v)) {
            return fail(
                key,
                format!(
                    "must be a number in [{:e}, 1) (a fraction of the force scale or of |u|; \
                     below the double-precision epsilon no residual can reach it), got {v:?}",
                    crate::statics::Tolerance::SMALLEST
                ),
            );
        }
    }
    if !t.is_unset() && !case.is_static() {
        return fail(
            "run.tolerance",
            "is the Newton tolerance of a static run, and this run is dynamic (it has no \
             Newton iteration): remove run.tolerance or give run.solve = \"static\"",
        );
    }
    Ok(())
}

fn run(r: &RunSpec, m: &MethodTable) -> Checked {
    positive("run.end_time", r.end_time)?;
    if let Some(interval) = r.checkpoint_interval {
        positive("run.checkpoint_interval", interval)?;
    }
    if let Some(eta) = r.hourglass_limit {
        positive("run.hourglass_limit", eta)?;
    }
    if let Some(ratio) = r.min_step_ratio {
        if !(ratio > 0.0 && ratio < 1.0) {
            return fail(
                "run.min_step_ratio",
                format!("must lie in (0, 1) (a fraction of the first CFL step), got {ratio:?}"),
            );
        }
        if m.cfl.is_none() {
            return fail(
                "run.min_step_ratio",
                "needs method.cfl (a fixed method.dt never shrinks): give method.cfl instead of \
                 method.dt, or remove run.min_step_ratio",
            );
        }
    }
    if let Some(n) = r.threads
        && !(1..=MAX_THREADS).contains(&n)
    {
        return fail(
            "run.threads",
            format!("must be a whole number from 1 to {MAX_THREADS}, got {n}"),
        );
    }
    let limit = r.energy_growth_limit;
    if limit.is_nan() || limit <= 1.0 {
        return fail(
            "run.energy_growth_limit",
            format!(
                "must be > 1 (a factor on the initial energy plus boundary work), got {limit:?}"
            ),
        );
    }
    Ok(())
}

fn output(o: &OutputSpec) -> Checked {
    if let Some(v) = o.frame_interval {
        positive("output.frame_interval", v)?;
    }
    if let Some(v) = o.series_interval {
        positive("output.series_interval", v)?;
    }
    let mut seen = HashSet::new();
    for observer in &o.observers {
        if !seen.insert(*observer) {
            return fail(
                "output.observers",
                format!(
                    "\"{}\" is listed more than once; list each observer at most once",
                    toml_name(observer)
                ),
            );
        }
    }
    for (k, check) in o.checks.iter().enumerate() {
        if check.label.trim().is_empty() {
            return fail(
                format!("output.check.{k}.label"),
                "is empty: say in words what the number is",
            );
        }
        if let Some([lo, hi]) = check.expected
            && !(lo.is_finite() && hi.is_finite() && lo <= hi)
        {
            return fail(
                format!("output.check.{k}.expected"),
                format!("[{lo}, {hi}] is not a range: give [lo, hi] with finite lo ≤ hi"),
            );
        }
    }
    Ok(())
}

/// At most one `velocity-error` observer, and its closed form one the case has.
fn analytic_observers(case: &Case) -> Checked {
    let mut solutions = case.output.observers.iter().filter_map(|o| match o {
        Observer::VelocityError(s) => Some(*s),
        _ => None,
    });
    let Some(solution) = solutions.next() else {
        return Ok(());
    };
    if solutions.next().is_some() {
        return fail(
            "output.observers",
            "lists `velocity-error` more than once; its column `velocity_error` holds the error \
             against one closed form",
        );
    }
    match crate::analytic::Exact::of(solution, case) {
        Ok(_) => Ok(()),
        Err(message) => fail("output.observers", message),
    }
}

/// At most one `front-oscillation` observer, and its closed form one with jumps that the
/// case has.
fn front_observers(case: &Case) -> Checked {
    let solutions: Vec<_> = case
        .output
        .observers
        .iter()
        .filter_map(|o| match o {
            Observer::FrontOscillation(s) => Some(*s),
            _ => None,
        })
        .collect();
    match solutions[..] {
        [] => Ok(()),
        [solution] => match crate::analytic::Exact::of(solution, case) {
            Ok(exact) if exact.front_distance([0.0; 3], 0.0).is_some() => Ok(()),
            Ok(_) => fail(
                "output.observers",
                format!(
                    "`front-oscillation` measures about the jumps of a closed form; \
                     \"{}\" has none: give \"driven-rod\"",
                    toml_name(&solution)
                ),
            ),
            Err(message) => fail("output.observers", message),
        },
        _ => fail(
            "output.observers",
            "lists `front-oscillation` more than once; its columns hold the oscillations \
             about one closed form",
        ),
    }
}

fn probes(probes: &[ProbeSpec], dim: usize) -> Checked {
    let mut seen = HashSet::new();
    for (i, probe) in probes.iter().enumerate() {
        let key = format!("probe.{i}");
        identifier(
            &format!("{key}.name"),
            &probe.name,
            "probe names become CSV column prefixes",
        )?;
        if !seen.insert(probe.name.as_str()) {
            return fail(
                format!("{key}.name"),
                format!(
                    "{:?} is already the name of an earlier probe; probe names must be unique",
                    probe.name
                ),
            );
        }
        vector(&format!("{key}.position"), &probe.position, dim)?;
    }
    Ok(())
}

/// Names of boundary conditions: each a column prefix (a support's reaction columns, a
/// load's applied-force columns) unique among the conditions, the unnamed supports
/// counting as `boundary<k>`; the `reaction` observer needs a support or a named load.
fn boundary_names(case: &Case) -> Checked {
    let mut seen = HashSet::new();
    let mut columns = false;
    for (i, b) in case.boundaries.iter().enumerate() {
        let key = format!("boundary.{i}.name");
        if let Some(name) = &b.name {
            identifier(&key, name, "boundary names become CSV column prefixes")?;
        }
        if (b.name.is_some() || b.condition.is_support()) && !seen.insert(b.name(i)) {
            return fail(
                key,
                format!(
                    "{:?} is already the name of an earlier boundary condition (unnamed \
                     supports are `boundary<k>`); boundary names must be unique",
                    b.name(i)
                ),
            );
        }
        columns |= b.name.is_some() || b.condition.is_support();
    }
    if case.output.observers.contains(&Observer::Reaction) && !columns {
        return fail(
            "output.observers",
            "lists `reaction`, but no boundary condition prescribes motion (`fixed`, \
             `velocity`, `symmetry`, a displacement) and no load has a `name`; add one or \
             remove the observer",
        );
    }
    Ok(())
}

fn sections(case: &Case) -> Checked {
    let dim = case.dim();
    let mut seen = HashSet::new();
    for (i, section) in case.sections.iter().enumerate() {
        let key = format!("section.{i}");
        identifier(
            &format!("{key}.name"),
            &section.name,
            "section names become CSV column prefixes",
        )?;
        if !seen.insert(section.name.as_str()) {
            return fail(
                format!("{key}.name"),
                format!(
                    "{:?} is already the name of an earlier section; section names must be \
                     unique",
                    section.name
                ),
            );
        }
        if section.normal.index() >= dim {
            return fail(
                format!("{key}.normal"),
                "is \"z\", which exists only in 3D; in 2D use \"x\" or \"y\"",
            );
        }
        finite(&format!("{key}.at"), section.at)?;
        region(
            &Region {
                body: section.body.clone(),
                ..Region::default()
            },
            &key,
            &case.bodies,
            dim,
        )?;
    }
    Ok(())
}

/// A valid minimal case (2D box, hypoelastic, TLSPH with a fixed step) for unit tests
/// that break one thing of it.
#[cfg(test)]
pub(crate) fn minimal_case() -> Case {
    toml::from_str(
        r#"
        name = "ok"
        dimension = 2
        spacing = 0.1
        [material]
        model = "hypoelastic"
        density = 1000.0
        youngs_modulus = 1e6
        poisson_ratio = 0.3
        [method]
        name = "tlsph"
        h_over_dx = 1.3
        dt = 1e-5
        [[body]]
        name = "b"
        geometry = { shape = "box", min = [0.0, 0.0], max = [1.0, 1.0] }
        [run]
        end_time = 1e-3
        "#,
    )
    .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Observer;

    fn key_of(case: &Case) -> String {
        check(case).unwrap_err().0
    }

    #[test]
    fn valid_case_passes() {
        let c = minimal_case();
        assert_eq!(c.method.name(), "tlsph");
        check(&c).unwrap();
    }

    #[test]
    fn first_problem_in_order_is_reported() {
        let mut c = minimal_case();
        c.dimension = 4;
        c.material.poisson_ratio = Some(0.5);
        assert_eq!(key_of(&c), "dimension");
        c.dimension = 2;
        assert_eq!(key_of(&c), "material.poisson_ratio");
        let (_, msg) = check(&c).unwrap_err();
        assert!(msg.contains("(−1, 0.5)") && msg.contains("0.5"), "{msg}");
    }

    #[test]
    fn names_and_numbers() {
        let mut c = minimal_case();
        c.name = "a b".into();
        assert_eq!(key_of(&c), "name");
        c.name = "a-b_1".into();
        c.spacing = f64::NAN;
        assert_eq!(key_of(&c), "spacing");
        c.spacing = 0.1;
        c.method.h_over_dx = 5.0;
        assert_eq!(key_of(&c), "method.h_over_dx");
        c.method.h_over_dx = 1.3;
        c.method.dt = None;
        c.method.cfl = Some(2.5);
        assert_eq!(key_of(&c), "method.cfl");
        c.method.cfl = Some(2.0);
        check(&c).unwrap();
    }

    /// A ring about the origin of outer radius 1.
    fn unit_ring(inner_radius: f64, lattice: RingLattice, sectors: Option<u32>) -> Shape {
        Shape::Ring {
            center: vec![0.0, 0.0],
            inner_radius,
            outer_radius: 1.0,
            lattice,
            sectors,
            volumes: None,
        }
    }

    #[test]
    fn bodies_and_shapes() {
        let mut c = minimal_case();
        c.bodies.push(c.bodies[0].clone());
        assert_eq!(key_of(&c), "body.1.name");
        c.bodies[1].name = "c".into();
        c.bodies[1].geometry = unit_ring(1.0, RingLattice::Square, None);
        assert_eq!(key_of(&c), "body.1.geometry.inner_radius");
        c.bodies[1].geometry = unit_ring(0.5, RingLattice::Square, Some(60));
        assert_eq!(key_of(&c), "body.1.geometry.sectors");
        c.bodies[1].geometry = unit_ring(0.5, RingLattice::Polar, Some(2));
        assert_eq!(key_of(&c), "body.1.geometry.sectors");
        c.bodies[1].geometry = unit_ring(0.0, RingLattice::Polar, None);
        assert_eq!(key_of(&c), "body.1.geometry.inner_radius");
        c.bodies[1].geometry = Shape::Cylinder {
            base: vec![0.0, 0.0, 0.0],
            axis: Axis::Z,
            radius: 1.0,
            inner_radius: 0.0,
            length: 1.0,
            lattice: Lattice::Vertex,
            volumes: None,
        };
        let (key, msg) = check(&c).unwrap_err();
        assert_eq!(key, "body.1.geometry.shape");
        assert!(msg.contains("only in 3D"), "{msg}");
        c.bodies[1].geometry = Shape::Box {
            min: vec![0.0, 1.0],
            max: vec![1.0, 1.0],
            volumes: None,
            lattice: Default::default(),
        };
        assert_eq!(key_of(&c), "body.1.geometry.max");
        c.bodies[1].geometry = Shape::Points { file: "".into() };
        assert_eq!(key_of(&c), "body.1.geometry.file");
        c.bodies.pop();
        c.bodies[0].initial_velocity = Some(VelocityField::RigidRotation {
            omega: 1.0,
            center: vec![0.0, 0.0],
            axis: Some(vec![0.0, 0.0, 1.0]),
        });
        assert_eq!(key_of(&c), "body.0.initial_velocity.axis");
        c.bodies[0].initial_velocity = Some(VelocityField::GaussianPulse {
            amplitude: 1.0,
            direction: vec![0.0, 0.0],
            center: 0.0,
            width: 1.0,
        });
        assert_eq!(key_of(&c), "body.0.initial_velocity.direction");
        c.bodies.clear();
        assert_eq!(key_of(&c), "body");
    }

    #[test]
    fn three_d_requirements() {
        let mut c = minimal_case();
        c.dimension = 3;
        assert_eq!(key_of(&c), "body.0.geometry.min");
        c.bodies[0].geometry = Shape::Cylinder {
            base: vec![0.0, 0.0, 0.0],
            axis: Axis::Z,
            radius: 1.0,
            inner_radius: 0.5,
            length: 1.0,
            lattice: Lattice::Vertex,
            volumes: None,
        };
        check(&c).unwrap();
        c.bodies[0].initial_velocity = Some(VelocityField::RigidRotation {
            omega: 1.0,
            center: vec![0.0, 0.0, 0.0],
            axis: None,
        });
        assert_eq!(key_of(&c), "body.0.initial_velocity.axis");
    }

    #[test]
    fn boundaries_run_output_probes() {
        let mut c = minimal_case();
        c.boundaries.push(BoundarySpec {
            name: None,
            region: Region {
                body: Some("nope".into()),
                ..Region::default()
            },
            condition: Condition::Fixed,
        });
        let (key, msg) = check(&c).unwrap_err();
        assert_eq!(key, "boundary.0.region.body");
        assert!(msg.contains("\"nope\"") && msg.contains("\"b\""), "{msg}");
        c.boundaries[0].region.body = Some("b".into());
        c.boundaries[0].region.z_min = Some(0.0);
        assert_eq!(key_of(&c), "boundary.0.region.z_min");
        c.boundaries[0].region.z_min = None;
        c.boundaries[0].region.x_min = Some(1.0);
        c.boundaries[0].region.x_max = Some(0.0);
        assert_eq!(key_of(&c), "boundary.0.region.x_max");
        c.boundaries[0].region.x_max = Some(1.0);
        c.boundaries[0].condition = Condition::Velocity {
            vx: None,
            vy: None,
            vz: None,
            law: TimeLaw::Constant,
            until: None,
        };
        assert_eq!(key_of(&c), "boundary.0.condition");
        c.boundaries[0].condition = Condition::Velocity {
            vx: Some(1.0),
            vy: None,
            vz: Some(0.0),
            law: TimeLaw::Constant,
            until: None,
        };
        assert_eq!(key_of(&c), "boundary.0.condition.vz");
        c.boundaries[0].condition = Condition::Velocity {
            vx: Some(1.0),
            vy: None,
            vz: None,
            law: TimeLaw::Constant,
            until: Some(0.0),
        };
        assert_eq!(key_of(&c), "boundary.0.condition.until");
        c.boundaries[0].condition = Condition::Velocity {
            vx: Some(1.0),
            vy: None,
            vz: None,
            law: TimeLaw::Ramp { duration: -1.0 },
            until: None,
        };
        assert_eq!(key_of(&c), "boundary.0.condition.law.duration");
        c.boundaries[0].condition = Condition::Symmetry { normal: Axis::Z };
        let (key, msg) = check(&c).unwrap_err();
        assert_eq!(key, "boundary.0.condition.normal");
        assert!(msg.contains("\"z\""), "{msg}");
        c.boundaries[0].condition = Condition::Traction {
            traction: vec![1.0],
            law: TimeLaw::Constant,
        };
        assert_eq!(key_of(&c), "boundary.0.condition.traction");
        c.boundaries.clear();
        c.run.energy_growth_limit = 1.0;
        assert_eq!(key_of(&c), "run.energy_growth_limit");
        c.run.energy_growth_limit = 10.0;
        c.output.observers = vec![Observer::Energy, Observer::NeckHeight, Observer::NeckHeight];
        let (key, msg) = check(&c).unwrap_err();
        assert_eq!(key, "output.observers");
        assert!(msg.contains("\"neck-height\""), "{msg}");
        c.output.observers.pop();
        c.output.frame_interval = Some(0.0);
        assert_eq!(key_of(&c), "output.frame_interval");
        c.output.frame_interval = None;
        c.probes.push(ProbeSpec {
            name: "tip.x".into(),
            position: vec![0.0, 0.0],
        });
        assert_eq!(key_of(&c), "probe.0.name");
        c.probes[0].name = "tip".into();
        c.probes.push(c.probes[0].clone());
        assert_eq!(key_of(&c), "probe.1.name");
        c.probes[1].name = "mid".into();
        c.probes[1].position = vec![0.0];
        assert_eq!(key_of(&c), "probe.1.position");
    }
}
