//! The geometry and case-file pieces a new case meets first: polygon bodies, names on
//! loads with their applied-force columns, the discretisation that `--explain` prints,
//! a static Galerkin body with a particle in no cell, and a cylinder whose length the
//! lattice cannot sample.

use crate::common::cpu_options;
use meshless::boundary::condition_totals;
use meshless::case::{CaseError, discretise};
use meshless::core::tensor::{D2, D3};
use meshless::output::series::read_column;
use meshless::run::{Backend, engine, explain, run};
use meshless::scene::Scene;
use std::path::Path;

/// Young's modulus [Pa], density [kg/m³] and spacing [m] of the 2D cases.
const E: f64 = 1.0e7;
const RHO: f64 = 1000.0;
const DX: f64 = 0.125;

/// An L-shape of area 3 m²: [0, 2]² without the square [1, 2]², its vertices on the
/// lattice of spacing 0.125.
const L_SHAPE: &str = "[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]";

/// A plane-stress linear-elastic 2D case at Δx = 0.125 m: `method` with `keys` (method.dt
/// among them), the body `geometry`, then `rest` (boundaries, run and output tables).
fn case(method: &str, keys: &str, geometry: &str, rest: &str) -> Result<Scene, CaseError> {
    let text = format!(
        r#"
name = "shapes"
dimension = 2
spacing = {DX}
[material]
model = "linear-elastic"
plane = "stress"
density = {RHO}
youngs_modulus = {E}
poisson_ratio = 0.3
[method]
name = "{method}"
{keys}
[[body]]
name = "part"
geometry = {geometry}
{rest}
"#
    );
    Scene::from_toml(&text, Path::new("shapes.toml"), &[])
}

/// A static run in one load step, and the method keys of TLSPH for it.
const STATIC_RUN: &str = "[run]\nsolve = \"static\"\nend_time = 1.0\n";
const TLSPH: &str = "h_over_dx = 1.3\ndt = 1.0";

/// The key and message of a refused case.
fn refusal(result: Result<Scene, CaseError>) -> (String, String) {
    match result {
        Err(CaseError::Invalid { key, message, .. }) => (key, message),
        other => panic!("expected a refusal naming a key, got {other:?}"),
    }
}

#[test]
fn polygon_volumes_sum_to_the_area_in_either_orientation() {
    // Scaled volumes sum to the shoelace area: one factor, so to round-off (1e-14 of a
    // sum of ~200 terms). Uniform volumes are as the lattice falls: the L-shape's vertex
    // lattice has 225 points (9 too many rows of Δx² for the 3 m² of its 192 cells).
    let triangle = "[[0.0, 0.0], [1.3, 0.1], [0.2, 0.9]]";
    let triangle_area = 0.5 * (1.3 * 0.9 - 0.1 * 0.2);
    let reversed = "[[0.0, 2.0], [1.0, 2.0], [1.0, 1.0], [2.0, 1.0], [2.0, 0.0], [0.0, 0.0]]";
    for (vertices, area) in [(L_SHAPE, 3.0), (reversed, 3.0), (triangle, triangle_area)] {
        let geometry = format!("{{ shape = \"polygon\", vertices = {vertices} }}");
        let c = case("tlsph", TLSPH, &geometry, STATIC_RUN).unwrap();
        let disc = discretise::<D2>(&c).unwrap();
        let sum: f64 = disc.vol.iter().sum();
        assert!((sum / area - 1.0).abs() < 1e-14, "{vertices}: Σ V = {sum}");
    }
    let geometry =
        format!("{{ shape = \"polygon\", vertices = {L_SHAPE}, volumes = \"uniform\" }}");
    let c = case("tlsph", TLSPH, &geometry, STATIC_RUN).unwrap();
    let disc = discretise::<D2>(&c).unwrap();
    // 17 × 9 points of the lower arm plus 9 × 8 of the upper: the edges kept.
    assert_eq!(disc.x0.len(), 17 * 9 + 9 * 8);
    assert!(disc.vol.iter().all(|&v| v == DX * DX));
}

#[test]
fn polygon_edges_keep_their_lattice_rows_and_the_cells_span_it() {
    // Points on the edges (within 1e-9 Δx) are inside, so the L-shape's vertex lattice has
    // its edge rows and the reflex corner (1, 1), and tl-fem's cells tile the polygon:
    // 16 × 8 + 8 × 8 = 192 cells of Δx², 3 m² exactly.
    let geometry = format!("{{ shape = \"polygon\", vertices = {L_SHAPE} }}");
    let c = case("tl-fem", "dt = 1.0", &geometry, STATIC_RUN).unwrap();
    let disc = discretise::<D2>(&c).unwrap();
    let at = |x: f64, y: f64| {
        disc.x0
            .iter()
            .any(|p| (p.x - x).abs() < 1e-12 && (p.y - y).abs() < 1e-12)
    };
    assert!(at(1.0, 1.0) && at(2.0, 1.0) && at(1.0, 2.0) && at(0.0, 2.0));
    assert!(!at(1.125, 1.125) && !at(2.0, 1.125));
    let plan = explain(&c, false);
    assert!(plan.contains("cells: 192 "), "{plan}");
    assert!(plan.contains("lattice: vertex"), "{plan}");
}

#[test]
fn polygons_that_are_not_simple_or_not_2d_are_refused_with_the_key() {
    let with = |vertices: &str| {
        case(
            "tlsph",
            TLSPH,
            &format!("{{ shape = \"polygon\", vertices = {vertices} }}"),
            STATIC_RUN,
        )
    };
    let (key, message) = refusal(with("[[0.0, 0.0], [1.0, 0.0]]"));
    assert_eq!(key, "body.0.geometry.vertices");
    assert!(message.contains("at least 3"), "{message}");
    let (key, message) = refusal(with("[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]"));
    assert_eq!(key, "body.0.geometry.vertices");
    assert!(message.contains("not a simple polygon"), "{message}");
    let (key, message) = refusal(with("[[0.0, 0.0], [1.0, 0.0, 2.0], [0.0, 1.0]]"));
    assert_eq!(key, "body.0.geometry.vertices.1");
    assert!(message.contains("2 components"), "{message}");
    // Vertices on one line: the closing edge runs back over the other two.
    let (key, message) = refusal(with("[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]"));
    assert_eq!(key, "body.0.geometry.vertices");
    assert!(message.contains("not a simple polygon"), "{message}");
    let (key, message) = refusal(case(
        "tlsph",
        TLSPH,
        &format!("{{ shape = \"polygon\", vertices = {L_SHAPE}, volumes = \"tributary\" }}"),
        STATIC_RUN,
    ));
    assert_eq!(key, "body.0.geometry.volumes");
    assert!(message.contains("polygon takes `scaled`"), "{message}");
    let three_d = format!(
        r#"
name = "shapes"
dimension = 3
spacing = 0.1
[material]
model = "linear-elastic"
density = 1000.0
youngs_modulus = 1e7
poisson_ratio = 0.3
[method]
name = "tlsph"
h_over_dx = 1.3
dt = 1e-5
[[body]]
name = "part"
geometry = {{ shape = "polygon", vertices = {L_SHAPE} }}
[run]
end_time = 1e-3
"#
    );
    let (key, message) = refusal(Scene::from_toml(&three_d, Path::new("shapes.toml"), &[]));
    assert_eq!(key, "body.0.geometry.shape");
    assert!(message.contains("only in 2D"), "{message}");
}

/// The L-shape clamped on its edge x = 0 and pulled by t = (1e4, −2e3) Pa on its edge x = 2,
/// y ∈ [0, 1] (the region's y_max clips the face there), with the load named `pull`.
fn pulled_l(method: &str, keys: &str) -> Scene {
    let rest = format!(
        r#"
[[boundary]]
name = "clamp"
region = {{ x_max = 0.0 }}
condition = {{ type = "fixed" }}
[[boundary]]
name = "pull"
region = {{ x_min = 2.0, y_max = 1.0 }}
condition = {{ type = "traction", traction = [1.0e4, -2.0e3] }}
{STATIC_RUN}
[output]
observers = ["energy", "reaction"]
"#
    );
    let geometry = format!("{{ shape = \"polygon\", vertices = {L_SHAPE} }}");
    case(method, keys, &geometry, &rest).unwrap()
}

#[test]
fn a_static_tlsph_l_shape_holds_its_named_load() {
    // The static solve converges and the clamp holds the load: reaction = −applied force
    // = −t × 1 m, to the Newton tolerance (1e-8 of the force scale; 1e-6 relative leaves
    // room). The applied-force column is the total traction at the load factor t/end_time
    // = 1, exactly the sum of the patches: t × 1 m to round-off (1e-12).
    let c = pulled_l("tlsph", TLSPH);
    let dir = tempfile::tempdir().unwrap();
    run(&c, &cpu_options(dir.path(), false)).unwrap();
    let series = dir.path().join("series.csv");
    let end = |column: &str| read_column(&series, column).unwrap().last().unwrap().1;
    for (k, t) in [("x", 1.0e4), ("y", -2.0e3)] {
        let applied = end(&format!("pull.applied_force_{k}"));
        assert!((applied / t - 1.0).abs() < 1e-12, "{k}: {applied}");
        let reaction = end(&format!("clamp.reaction_{k}"));
        assert!((reaction / -t - 1.0).abs() < 1e-6, "{k}: {reaction}");
    }
    // At t = 0 the load factor is zero.
    let first = read_column(&series, "pull.applied_force_x").unwrap()[0].1;
    assert_eq!(first, 0.0);
}

#[test]
fn a_named_load_under_a_time_law_gives_its_force_at_the_rows_time() {
    // A dynamic TLSPH bar 2 × 0.5 m with a body force g = −9.81 m/s² on all of it, ramped
    // over 1 ms, named `weight`: the column is Σ m g × t/1 ms, m the particle masses ρ0 V
    // (tributary: Σ V = 1 m², so Σ m g = −9810 N/m), to round-off (1e-12).
    let rest = r#"
[[boundary]]
name = "clamp"
region = { x_max = 0.0 }
condition = { type = "fixed" }
[[boundary]]
name = "weight"
region = {}
condition = { type = "body-force", acceleration = [0.0, -9.81], law = { type = "ramp", duration = 1.0e-3 } }
[run]
end_time = 2.0e-3
[output]
series_interval = 2.5e-4
observers = ["reaction"]
"#;
    let c = case(
        "tlsph",
        "h_over_dx = 1.3\ndt = 1.0e-5",
        "{ shape = \"box\", min = [0.0, 0.0], max = [2.0, 0.5] }",
        rest,
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    run(&c, &cpu_options(dir.path(), false)).unwrap();
    let rows = read_column(&dir.path().join("series.csv"), "weight.applied_force_y").unwrap();
    assert!(rows.len() >= 8, "{rows:?}");
    for (t, f) in rows {
        let expected = -9810.0 * (t / 1.0e-3).min(1.0);
        assert!(
            (f - expected).abs() <= 1e-12 * 9810.0,
            "t = {t}: {f} against {expected}"
        );
    }
}

#[test]
fn explain_lists_the_lattice_cells_bodies_and_the_total_load() {
    // A tl-fem bar 4 × 1 m under t = 1e4 Pa on its end x = 4: the traction's total is
    // t × 1 m = 1e4 N/m (printed to 7 digits; the sum of the patches below to round-off).
    let rest = format!(
        r#"
[[boundary]]
name = "end"
region = {{ x_max = 0.0 }}
condition = {{ type = "fixed" }}
[[boundary]]
name = "load"
region = {{ x_min = 4.0 }}
condition = {{ type = "traction", traction = [1.0e4, 0.0] }}
{STATIC_RUN}"#
    );
    let c = case(
        "tl-fem",
        "dt = 1.0",
        "{ shape = \"box\", min = [0.0, 0.0], max = [4.0, 1.0], lattice = \"cell-centred\" }",
        &rest,
    )
    .unwrap();
    let plan = explain(&c, false);
    for line in [
        "lattice: vertex: `tl-fem` integrates over the lattice's cells",
        "cells: 256 ",
        "body `part`: 297 particles, named volume 4.000000e0, Σ V = 4.000000e0 m²",
        "boundary `end` (fixed) on { x_max = 0.0 }: 9 particles",
        "boundary `load` (traction) on { x_min = 4.0 }: 9 particles, total force \
         (1.000000e4, 0.000000e0) N/m",
    ] {
        assert!(plan.contains(line), "no {line:?} in\n{plan}");
    }
    let disc = discretise::<D2>(&c).unwrap();
    let mass: Vec<f64> = disc.vol.iter().map(|v| v * RHO).collect();
    let totals = condition_totals::<D2>(&c, &disc.x0, &disc.body, &mass).unwrap();
    assert_eq!(totals[0].force, None);
    let f = totals[1].force.unwrap();
    assert!((f[0] / 1.0e4 - 1.0).abs() < 1e-14 && f[1] == 0.0, "{f:?}");
    // A method at its particles says so.
    let plan = explain(
        &case(
            "tlsph",
            TLSPH,
            "{ shape = \"box\", min = [0.0, 0.0], max = [4.0, 1.0] }",
            &rest,
        )
        .unwrap(),
        false,
    );
    assert!(plan.contains("cells: none"), "{plan}");
}

#[test]
fn a_static_galerkin_particle_in_no_cell_is_named_not_called_a_rigid_motion() {
    // A triangle whose apex (1, 1.0625) leaves the lattice point (1, 1) below it with no
    // neighbour at either side (the edges pass x = 0.875 and 1.125 below y = 0.93): every
    // lattice square at (1, 1) leaves the triangle. With mass = "particle" (the row-sum
    // mass refuses such a particle first) the static tl-fem solve has no stiffness there,
    // which is reported as such, with the particle.
    let rest = format!(
        "[[boundary]]\nregion = {{ y_max = 0.0 }}\ncondition = {{ type = \"fixed\" }}\n{STATIC_RUN}"
    );
    let c = case(
        "tl-fem",
        "mass = \"particle\"\ndt = 1.0",
        "{ shape = \"polygon\", vertices = [[0.0, 0.0], [2.0, 0.0], [1.0, 1.0625]] }",
        &rest,
    )
    .unwrap();
    let Err(e) = engine::<D2>(&c, Backend::Cpu) else {
        panic!("the static engine of a disk with cornerless particles builds");
    };
    let shown = e.to_string();
    for part in [
        "key `body.0.geometry`",
        "at [1.0, 1.0, 0.0]",
        "corner of no cell",
        "`tl-fem`",
    ] {
        assert!(shown.contains(part), "no {part:?} in {shown}");
    }
    assert!(!shown.contains("rigid"), "{shown}");
}

/// A 3D TLSPH cylinder of radius 0.3 m and `length` at Δx = 0.1 m.
fn cylinder(length: f64) -> Result<Scene, CaseError> {
    let text = format!(
        r#"
name = "cylinder"
dimension = 3
spacing = 0.1
[material]
model = "linear-elastic"
density = 1000.0
youngs_modulus = 1e7
poisson_ratio = 0.3
[method]
name = "tlsph"
h_over_dx = 1.3
dt = 1e-5
[[body]]
name = "rod"
geometry = {{ shape = "cylinder", base = [0.0, 0.0, 0.0], axis = "z", radius = 0.3, length = {length} }}
[run]
end_time = 1e-3
"#
    );
    Scene::from_toml(&text, Path::new("cylinder.toml"), &[])
}

#[test]
fn a_cylinder_whose_length_the_lattice_misses_is_refused_past_the_tolerance() {
    // 1.05 m at Δx = 0.1 m: its vertex lattice spans 1.0 m, −4.76 %, past the 2 %
    // tolerance although the scaled volumes sum to the named volume.
    let c = cylinder(1.05).unwrap();
    let Err(CaseError::Invalid { key, message, .. }) = discretise::<D3>(&c) else {
        panic!("a cylinder sampled 5 % short is accepted");
    };
    assert_eq!(key, "body.0.geometry.length");
    assert!(
        message.contains("-4.76 %") && message.contains("spacing = "),
        "{message}"
    );
    // 1.0 m fits; 1.01 m (−0.99 %) is within the tolerance: sampled, and said at the
    // start of a run (src/run/checks.rs).
    assert!(discretise::<D3>(&cylinder(1.0).unwrap()).is_ok());
    let c = cylinder(1.01).unwrap();
    assert!(discretise::<D3>(&c).is_ok());
    let (sampled, named) = c.bodies[0].geometry.sampled_length(0.1, false).unwrap();
    assert!((sampled - 1.0).abs() < 1e-12 && named == 1.01);
}
