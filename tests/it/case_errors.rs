//! Bad case files: every error names the file, the key and what is allowed.
//!
//! Each test starts from a minimal valid case, breaks one thing, and checks the text of
//! the error. `valid_minimal_case_loads` makes sure the starting point itself is fine, so
//! the other tests cannot pass merely because everything fails.

use crate::common::{cases_dir, toml_files};
use meshless::case::CaseError;
use meshless::core::tensor::D2;
use meshless::scene::Scene;
use std::path::Path;

/// 2D box body, hypoelastic, TLSPH with a fixed time step.
const VALID: &str = r#"name = "minimal"
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
name = "block"
geometry = { shape = "box", min = [0.0, 0.0], max = [1.0, 0.5] }

[run]
end_time = 1e-3
"#;

/// A richer valid 3D case: cylinder, initial rotation, boundaries, output and probes.
const VALID_3D: &str = r#"name = "spin_3d"
dimension = 3
spacing = 0.05

[material]
model = "neo-hookean"
density = 1100.0
youngs_modulus = 2e6
poisson_ratio = 0.45

[method]
name = "tlsph"
h_over_dx = 1.5
correction = "shepard"
cfl = 0.3
artificial_viscosity = { alpha = 1.0, beta = 2.0 }

[[body]]
name = "tube"
geometry = { shape = "cylinder", base = [0.0, 0.0, 0.0], axis = "z", radius = 0.5, inner_radius = 0.25, length = 1.0 }
initial_velocity = { type = "rigid-rotation", omega = 2.0, center = [0.0, 0.0, 0.0], axis = [0.0, 0.0, 1.0] }

[[body]]
name = "slab"
geometry = { shape = "box", min = [-1.0, -1.0, -0.5], max = [1.0, 1.0, -0.1] }

[[boundary]]
region = { body = "slab", z_max = -0.4 }
condition = { type = "fixed" }

[[boundary]]
region = { body = "tube", z_min = 0.95 }
condition = { type = "velocity", vz = -0.1 }

[[boundary]]
region = { x_min = -1.0, x_max = -0.99 }
condition = { type = "symmetry", normal = "x" }

[run]
end_time = 0.01
energy_growth_limit = 5.0

[output]
frame_interval = 1e-3
observers = ["energy", "angular-momentum", "extent"]

[[probe]]
name = "top-rim"
position = [0.5, 0.0, 1.0]
"#;

const FILE: &str = "cases/bad.toml";

/// `VALID` with `from` replaced by `to`; panics if `from` is not in the text, so that a
/// test cannot silently run on the unchanged valid case.
fn edit(base: &str, from: &str, to: &str) -> String {
    assert!(base.contains(from), "test case text has no {from:?}");
    base.replacen(from, to, 1)
}

/// Display text of the error for `text` with `overrides`; panics if the case loads.
fn error_with(text: &str, overrides: &[&str]) -> (CaseError, String) {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    match Scene::from_toml(text, Path::new(FILE), &overrides) {
        Ok(_) => panic!("bad case was accepted:\n{text}"),
        Err(e) => {
            let shown = e.to_string();
            (e, shown)
        }
    }
}

fn error(text: &str) -> String {
    error_with(text, &[]).1
}

/// Asserts that `message` contains every one of `parts`.
fn assert_mentions(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(
            message.contains(part),
            "error message lacks {part:?}:\n{message}"
        );
    }
}

/// Asserts an `Invalid` error for `key` whose text contains `parts`.
fn assert_invalid(text: &str, key: &str, parts: &[&str]) {
    let (e, shown) = error_with(text, &[]);
    assert!(
        matches!(e, CaseError::Invalid { .. }),
        "not a validation error: {shown}"
    );
    assert_mentions(&shown, &[FILE, &format!("key `{key}`:")]);
    assert_mentions(&shown, parts);
}

// ---------------------------------------------------------------------------------------
// Valid cases

#[test]
fn valid_minimal_case_loads() {
    let case = Scene::from_toml(VALID, Path::new(FILE), &[]).expect("minimal case is valid");
    assert_eq!(case.name, "minimal");
    assert_eq!(case.dim(), 2);
    assert_eq!(case.bodies.len(), 1);
    assert_eq!(case.method.dt, Some(1e-5));
    assert_eq!(case.base_dir(), Path::new("cases"));
    assert_eq!(case.file, Path::new(FILE));
}

#[test]
fn valid_3d_case_with_boundaries_and_probes_loads() {
    let case = Scene::from_toml(VALID_3D, Path::new(FILE), &[]).expect("3D case is valid");
    assert_eq!(case.dim(), 3);
    assert_eq!(case.boundaries.len(), 3);
    assert_eq!(case.probes.len(), 1);
}

#[test]
fn valid_case_loads_from_file_with_override() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ok.toml");
    std::fs::write(&path, VALID).unwrap();
    let case = Scene::load(&path, &["method.dt=2e-5".to_string()]).expect("valid");
    assert_eq!(case.method.dt, Some(2e-5));
    assert_eq!(case.base_dir(), dir.path());
}

// ---------------------------------------------------------------------------------------
// Parse errors (TOML syntax and serde)

#[test]
fn unknown_key_typo_is_named_with_allowed_keys() {
    let text = edit(
        VALID,
        "h_over_dx = 1.3",
        "h_over_dx = 1.3\nkernal = \"quintic\"",
    );
    let (e, shown) = error_with(&text, &[]);
    assert!(matches!(e, CaseError::Parse { .. }), "{shown}");
    assert_mentions(
        &shown,
        &[FILE, "unknown field `kernal`", "`kernel`", "line 14"],
    );
}

#[test]
fn wrong_enum_value_lists_allowed_variants() {
    let text = edit(VALID, "dt = 1e-5", "dt = 1e-5\nintegrator = \"rk5\"");
    let shown = error(&text);
    assert_mentions(
        &shown,
        &[FILE, "unknown variant `rk5`", "expected one of", "`rk4`"],
    );
}

#[test]
fn wrong_material_model_lists_allowed_models() {
    let text = edit(VALID, "\"hypoelastic\"", "\"hookean\"");
    let shown = error(&text);
    assert_mentions(
        &shown,
        &[
            FILE,
            "unknown variant `hookean`",
            "`hypoelastic`",
            "`saint-venant-kirchhoff`",
            "`neo-hookean`",
        ],
    );
}

#[test]
fn plane_stress_is_2d_and_for_the_models_linear_in_their_strain() {
    let stress = "poisson_ratio = 0.3\nplane = \"stress\"";
    let plane_stress = edit(VALID, "poisson_ratio = 0.3", stress);
    Scene::from_toml(&plane_stress, Path::new(FILE), &[]).unwrap();
    assert_invalid(
        &edit(&plane_stress, "\"hypoelastic\"", "\"neo-hookean\""),
        "material.plane",
        &[
            "`neo-hookean`",
            "`saint-venant-kirchhoff`",
            "plane = \"strain\"",
        ],
    );
    assert_invalid(
        &edit(
            VALID_3D,
            "poisson_ratio = 0.45",
            "poisson_ratio = 0.45\nplane = \"stress\"",
        ),
        "material.plane",
        &["2D"],
    );
    let shown = error(&edit(
        VALID,
        "poisson_ratio = 0.3",
        "poisson_ratio = 0.3\nplane = \"sheet\"",
    ));
    assert_mentions(&shown, &[FILE, "`strain`", "`stress`"]);
}

#[test]
fn objective_rates_are_for_rate_models_and_named() {
    let rate = |r: &str| {
        edit(
            VALID,
            "poisson_ratio = 0.3",
            &format!("poisson_ratio = 0.3\nobjective_rate = \"{r}\""),
        )
    };
    for r in ["jaumann", "green-naghdi", "truesdell"] {
        Scene::from_toml(&rate(r), Path::new(FILE), &[]).unwrap();
    }
    assert_invalid(
        &edit(&rate("truesdell"), "\"hypoelastic\"", "\"neo-hookean\""),
        "material.objective_rate",
        &["`hypoelastic`", "`neo-hookean`", "remove it"],
    );
    let shown = error(&rate("oldroyd"));
    assert_mentions(
        &shown,
        &[FILE, "`jaumann`", "`green-naghdi`", "`truesdell`"],
    );
}

#[test]
fn the_prime_space_is_refused_in_3d() {
    // Eq 63's hull is planar: a 3D case is refused with the key and the keys that work.
    for method in ["gray-monaghan-sph", "godunov-sph"] {
        let key = "smoothing_length = \"prime-space\"";
        assert_invalid(
            &crate::common::block_text(&[0.4, 0.4, 0.4], "hypoelastic", method, key),
            "method.smoothing_length",
            &["2D only", "this case is 3D", "\"density\""],
        );
    }
}

#[test]
fn a_yield_stress_on_the_rate_model_is_for_the_ul_strong_forms_and_named() {
    let plastic = |method: &str, extra: &str| {
        let text = edit(
            VALID,
            "poisson_ratio = 0.3",
            &format!("poisson_ratio = 0.3\nyield_stress = 1e4\n{extra}"),
        );
        edit(&text, "\"tlsph\"", &format!("\"{method}\""))
    };
    for method in ["gray-monaghan-sph", "godunov-sph"] {
        Scene::from_toml(&plastic(method, ""), Path::new(FILE), &[]).unwrap();
        Scene::from_toml(
            &plastic(method, "hardening_modulus = 1e5"),
            Path::new(FILE),
            &[],
        )
        .unwrap();
    }
    assert_invalid(
        &plastic("tlsph", ""),
        "material.yield_stress",
        &[
            "`gray-monaghan-sph`",
            "`godunov-sph`",
            "`tlsph`",
            "remove it",
        ],
    );
    assert_invalid(
        &edit(
            VALID,
            "poisson_ratio = 0.3",
            "poisson_ratio = 0.3\nhardening_modulus = 1e5",
        ),
        "material.hardening_modulus",
        &["`yield_stress`"],
    );
    assert_invalid(
        &plastic("gray-monaghan-sph", "objective_rate = \"truesdell\""),
        "material.objective_rate",
        &["\"jaumann\"", "\"green-naghdi\""],
    );
    assert_invalid(
        &plastic("gray-monaghan-sph", "plane = \"stress\""),
        "material.plane",
        &["\"strain\""],
    );
    assert_invalid(
        &edit(
            &plastic("gray-monaghan-sph", ""),
            "\"hypoelastic\"",
            "\"neo-hookean\"",
        ),
        "material.yield_stress",
        &["`hypoelastic`", "`von-mises-plastic`", "`neo-hookean`"],
    );
}

#[test]
fn the_implicit_solve_takes_a_state_model_a_fixed_step_and_its_alpha() {
    let elastic = edit(VALID, "\"hypoelastic\"", "\"neo-hookean\"");
    let implicit = edit(
        &elastic,
        "end_time = 1e-3",
        "end_time = 1e-3\nsolve = \"implicit\"",
    );
    Scene::from_toml(&implicit, Path::new(FILE), &[]).unwrap();
    let with_alpha = |alpha: &str| {
        edit(
            &implicit,
            "solve = \"implicit\"",
            &format!("solve = \"implicit\"\nhht_alpha = {alpha}"),
        )
    };
    Scene::from_toml(&with_alpha("-0.1"), Path::new(FILE), &[]).unwrap();
    assert_invalid(&with_alpha("0.2"), "run.hht_alpha", &["[−1/3, 0]", "0.2"]);
    assert_invalid(
        &edit(
            &elastic,
            "end_time = 1e-3",
            "end_time = 1e-3\nhht_alpha = -0.1",
        ),
        "run.hht_alpha",
        &["run.solve = \"implicit\""],
    );
    assert_invalid(
        &edit(
            VALID,
            "end_time = 1e-3",
            "end_time = 1e-3\nsolve = \"implicit\"",
        ),
        "material.model",
        &["static or implicit", "`hypoelastic`"],
    );
    assert_invalid(
        &edit(&implicit, "dt = 1e-5", "cfl = 0.3"),
        "method.dt",
        &["implicit run", "CFL"],
    );
    // The viscosity acts on v, which a Newton solve for u does not carry.
    assert_invalid(
        &edit(
            &implicit,
            "dt = 1e-5",
            "dt = 1e-5\nartificial_viscosity = { alpha = 1.0, beta = 1.0 }",
        ),
        "method.artificial_viscosity",
        &["static or implicit", "left out", "run.hht_alpha"],
    );
}

#[test]
fn wrong_shape_lists_allowed_shapes() {
    let text = edit(VALID, "shape = \"box\"", "shape = \"sphere\"");
    let shown = error(&text);
    assert_mentions(
        &shown,
        &[
            FILE,
            "unknown variant `sphere`",
            "`box`",
            "`disk`",
            "`cylinder`",
        ],
    );
}

#[test]
fn missing_required_key_is_named() {
    let text = edit(VALID, "spacing = 0.1\n", "");
    let (e, shown) = error_with(&text, &[]);
    assert!(matches!(e, CaseError::Parse { .. }), "{shown}");
    assert_mentions(&shown, &[FILE, "missing field `spacing`"]);
}

#[test]
fn toml_syntax_error_gives_line_number() {
    let text = edit(VALID, "density = 1000.0", "density = = 1000.0");
    let line = 1 + text.lines().position(|l| l.contains("= =")).unwrap();
    let (e, shown) = error_with(&text, &[]);
    assert!(matches!(e, CaseError::Parse { .. }), "{shown}");
    assert_mentions(&shown, &[FILE, &format!("line {line}")]);
}

// ---------------------------------------------------------------------------------------
// Semantic errors (validate.rs)

#[test]
fn incompressible_poisson_ratio_is_rejected() {
    let text = edit(VALID, "poisson_ratio = 0.3", "poisson_ratio = 0.5");
    assert_invalid(
        &text,
        "material.poisson_ratio",
        &["0.5", "(−1, 0.5)", "incompressible"],
    );
}

#[test]
fn non_positive_youngs_modulus_is_rejected() {
    let text = edit(VALID, "youngs_modulus = 1e6", "youngs_modulus = 0.0");
    assert_invalid(&text, "material.youngs_modulus", &["> 0", "0.0"]);
}

#[test]
fn both_dt_and_cfl_is_rejected() {
    let text = edit(VALID, "dt = 1e-5", "dt = 1e-5\ncfl = 0.3");
    assert_invalid(&text, "method.dt", &["`method.cfl`", "both", "exactly one"]);
}

#[test]
fn neither_dt_nor_cfl_is_rejected() {
    let text = edit(VALID, "dt = 1e-5\n", "");
    assert_invalid(
        &text,
        "method.dt",
        &["`method.cfl`", "neither", "exactly one"],
    );
}

#[test]
fn cfl_out_of_range_is_rejected() {
    let text = edit(VALID, "dt = 1e-5", "cfl = 2.5");
    assert_invalid(&text, "method.cfl", &["(0, 2]", "2.5"]);
}

#[test]
fn smoothing_ratio_out_of_range_is_rejected() {
    let text = edit(VALID, "h_over_dx = 1.3", "h_over_dx = 0.2");
    assert_invalid(&text, "method.h_over_dx", &["[0.5, 4]", "0.2"]);
}

#[test]
fn case_name_that_is_not_a_file_name_is_rejected() {
    let text = edit(VALID, "name = \"minimal\"", "name = \"../minimal\"");
    assert_invalid(&text, "name", &["\"../minimal\"", "'-'", "'_'", "digits"]);
}

#[test]
fn dimension_other_than_2_or_3_is_rejected() {
    let text = edit(VALID, "dimension = 2", "dimension = 4");
    assert_invalid(&text, "dimension", &["2", "3", "got 4"]);
}

#[test]
fn disk_in_3d_is_rejected() {
    let text = edit(
        &edit(VALID, "dimension = 2", "dimension = 3"),
        "{ shape = \"box\", min = [0.0, 0.0], max = [1.0, 0.5] }",
        "{ shape = \"disk\", center = [0.0, 0.0, 0.0], radius = 1.0 }",
    );
    assert_invalid(
        &text,
        "body.0.geometry.shape",
        &["\"disk\"", "only in 2D", "dimension = 3"],
    );
}

#[test]
fn cylinder_in_2d_is_rejected() {
    let text = edit(
        VALID,
        "{ shape = \"box\", min = [0.0, 0.0], max = [1.0, 0.5] }",
        "{ shape = \"cylinder\", base = [0.0, 0.0], axis = \"y\", radius = 1.0, length = 2.0 }",
    );
    assert_invalid(
        &text,
        "body.0.geometry.shape",
        &["\"cylinder\"", "only in 3D", "\"disk\""],
    );
}

#[test]
fn vector_of_wrong_length_is_rejected() {
    let text = edit(VALID, "min = [0.0, 0.0]", "min = [0.0, 0.0, 0.0]");
    assert_invalid(
        &text,
        "body.0.geometry.min",
        &["2 components", "got 3", "[0.0, 0.0, 0.0]"],
    );
}

#[test]
fn empty_box_is_rejected() {
    let text = edit(VALID, "max = [1.0, 0.5]", "max = [1.0, -0.5]");
    assert_invalid(&text, "body.0.geometry.max", &["axis 1", "-0.5", "min"]);
}

#[test]
fn ring_with_inner_radius_not_below_outer_is_rejected() {
    let text = edit(
        VALID,
        "{ shape = \"box\", min = [0.0, 0.0], max = [1.0, 0.5] }",
        "{ shape = \"ring\", center = [0.0, 0.0], inner_radius = 1.0, outer_radius = 0.5 }",
    );
    assert_invalid(
        &text,
        "body.0.geometry.inner_radius",
        &["outer_radius = 0.5", "1.0"],
    );
}

#[test]
fn holes_are_disks_in_2d_and_need_an_axis_in_3d() {
    let box_2d = "{ shape = \"box\", min = [0.0, 0.0], max = [1.0, 0.5] }";
    let with_hole = |hole: &str| edit(VALID, box_2d, &format!("{box_2d}\nholes = [{hole}]"));
    assert_invalid(
        &with_hole("{ center = [0.5, 0.25], radius = 0.1, axis = \"x\" }"),
        "body.0.holes.0.axis",
        &["3D holes only", "disk"],
    );
    assert_invalid(
        &with_hole("{ center = [0.5, 0.25], radius = -0.1 }"),
        "body.0.holes.0.radius",
        &["-0.1"],
    );
    assert_invalid(
        &with_hole("{ center = [0.5, 0.25, 0.0], radius = 0.1 }"),
        "body.0.holes.0.center",
        &["2 components", "got 3"],
    );
    let text_3d = edit(
        VALID_3D,
        "max = [1.0, 1.0, -0.1] }",
        "max = [1.0, 1.0, -0.1] }\nholes = [{ center = [0.0, 0.0, 0.0], radius = 0.1 }]",
    );
    assert_invalid(&text_3d, "body.1.holes.0.axis", &["missing", "\"x\""]);
    let polar = edit(
        VALID,
        box_2d,
        "{ shape = \"ring\", center = [0.0, 0.0], inner_radius = 0.5, outer_radius = 1.0, \
         lattice = \"polar\" }\nholes = [{ center = [0.75, 0.0], radius = 0.1 }]",
    );
    assert_invalid(&polar, "body.0.holes.0", &["polar ring", "\"square\""]);
}

#[test]
fn duplicate_body_names_are_rejected() {
    let text = format!(
        "{VALID}\n[[body]]\nname = \"block\"\ngeometry = {{ shape = \"disk\", center = [3.0, 0.0], radius = 0.5 }}\n"
    );
    assert_invalid(&text, "body.1.name", &["\"block\"", "unique"]);
}

#[test]
fn rotation_axis_in_2d_is_rejected() {
    let text = edit(
        VALID,
        "max = [1.0, 0.5] }",
        "max = [1.0, 0.5] }\ninitial_velocity = { type = \"rigid-rotation\", omega = 1.0, center = [0.0, 0.0], axis = [0.0, 0.0, 1.0] }",
    );
    assert_invalid(
        &text,
        "body.0.initial_velocity.axis",
        &["absent in 2D", "[0.0, 0.0, 1.0]"],
    );
}

#[test]
fn rotation_axis_missing_in_3d_is_rejected() {
    let text = edit(VALID_3D, ", axis = [0.0, 0.0, 1.0] }", " }");
    assert_invalid(&text, "body.0.initial_velocity.axis", &["required in 3D"]);
}

#[test]
fn boundary_naming_missing_body_is_rejected() {
    let text = edit(VALID_3D, "body = \"tube\"", "body = \"tubes\"");
    assert_invalid(
        &text,
        "boundary.1.region.body",
        &["\"tubes\"", "\"tube\"", "\"slab\""],
    );
}

#[test]
fn z_bound_in_2d_is_rejected() {
    let text = format!(
        "{VALID}\n[[boundary]]\nregion = {{ z_min = 0.0 }}\ncondition = {{ type = \"fixed\" }}\n"
    );
    assert_invalid(
        &text,
        "boundary.0.region.z_min",
        &["only in 3D", "dimension = 2"],
    );
}

#[test]
fn velocity_condition_without_components_is_rejected() {
    let text = format!(
        "{VALID}\n[[boundary]]\nregion = {{ x_max = 0.0 }}\ncondition = {{ type = \"velocity\" }}\n"
    );
    assert_invalid(&text, "boundary.0.condition", &["at least one of vx, vy"]);
}

#[test]
fn traction_of_wrong_length_is_rejected() {
    let text = format!(
        "{VALID}\n[[boundary]]\nregion = {{ x_min = 1.0 }}\ncondition = {{ type = \"traction\", traction = [1e3] }}\n"
    );
    assert_invalid(
        &text,
        "boundary.0.condition.traction",
        &["2 components", "got 1"],
    );
}

#[test]
fn energy_growth_limit_not_above_one_is_rejected() {
    let text = edit(
        VALID,
        "end_time = 1e-3",
        "end_time = 1e-3\nenergy_growth_limit = 0.9",
    );
    assert_invalid(&text, "run.energy_growth_limit", &["> 1", "0.9"]);
}

#[test]
fn step_collapse_ratio_outside_zero_one_or_with_a_fixed_step_is_rejected() {
    let with = |ratio: &str| {
        edit(
            VALID_3D,
            "energy_growth_limit = 5.0",
            &format!("energy_growth_limit = 5.0\nmin_step_ratio = {ratio}"),
        )
    };
    assert_invalid(&with("1.0"), "run.min_step_ratio", &["(0, 1)", "1.0"]);
    assert_invalid(&with("0.0"), "run.min_step_ratio", &["(0, 1)", "0.0"]);
    let fixed = edit(&with("0.1"), "cfl = 0.3", "dt = 1e-5");
    assert_invalid(&fixed, "run.min_step_ratio", &["method.cfl", "method.dt"]);
}

#[test]
fn hourglass_limit_not_positive_is_rejected() {
    let text = edit(
        VALID,
        "end_time = 1e-3",
        "end_time = 1e-3\nhourglass_limit = -0.5",
    );
    assert_invalid(&text, "run.hourglass_limit", &["> 0", "-0.5"]);
}

#[test]
fn duplicate_observer_is_rejected() {
    let text = edit(VALID_3D, "\"extent\"]", "\"extent\", \"energy\"]");
    assert_invalid(&text, "output.observers", &["\"energy\"", "more than once"]);
}

#[test]
fn probe_position_and_name_are_checked() {
    let text = edit(
        VALID_3D,
        "position = [0.5, 0.0, 1.0]",
        "position = [0.5, 0.0]",
    );
    assert_invalid(&text, "probe.0.position", &["3 components", "got 2"]);
    let text = edit(VALID_3D, "name = \"top-rim\"", "name = \"top rim\"");
    assert_invalid(&text, "probe.0.name", &["\"top rim\"", "CSV"]);
}

// ---------------------------------------------------------------------------------------
// --set overrides and files

#[test]
fn set_to_nonexistent_table_is_named() {
    let (e, shown) = error_with(VALID, &["solver.dt=1e-6"]);
    assert!(matches!(e, CaseError::Override { .. }), "{shown}");
    assert_mentions(&shown, &[FILE, "--set solver.dt=1e-6", "no key `solver`"]);
}

#[test]
fn set_to_unknown_key_is_named() {
    let (_, shown) = error_with(VALID, &["method.kernal=quintic"]);
    assert_mentions(&shown, &[FILE, "unknown field `kernal`", "`kernel`"]);
}

#[test]
fn set_past_the_last_body_is_named() {
    let (e, shown) = error_with(VALID, &["body.1.name=x"]);
    assert!(matches!(e, CaseError::Override { .. }), "{shown}");
    assert_mentions(&shown, &[FILE, "--set body.1.name=x", "no index 1"]);
}

#[test]
fn set_that_makes_the_case_invalid_is_named() {
    let (e, shown) = error_with(VALID, &["method.dt=-1"]);
    assert!(matches!(e, CaseError::Invalid { .. }), "{shown}");
    assert_mentions(&shown, &[FILE, "key `method.dt`", "> 0", "-1"]);
}

#[test]
fn set_on_a_file_reports_the_file_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("beam.toml");
    std::fs::write(&path, VALID).unwrap();
    let e = Scene::load(&path, &["method.dt=-1".to_string()]).unwrap_err();
    let shown = e.to_string();
    assert_mentions(
        &shown,
        &[&path.display().to_string(), "key `method.dt`", "> 0"],
    );
}

#[test]
fn invalid_file_reports_its_path_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nu.toml");
    std::fs::write(
        &path,
        edit(VALID, "poisson_ratio = 0.3", "poisson_ratio = 0.5"),
    )
    .unwrap();
    let shown = Scene::load(&path, &[]).unwrap_err().to_string();
    assert_mentions(
        &shown,
        &[
            &path.display().to_string(),
            "key `material.poisson_ratio`",
            "(−1, 0.5)",
        ],
    );
}

/// A key that a fixed support does not take is refused, not ignored: `vx` on `fixed`
/// would otherwise read as a prescribed velocity that never acts.
#[test]
fn a_velocity_on_a_fixed_support_is_refused() {
    let text = format!(
        "{VALID}\n[[boundary]]\nregion = {{ x_max = 0.0 }}\ncondition = {{ type = \"fixed\", vx = 1.0 }}\n"
    );
    assert_mentions(&error(&text), &[FILE, "unknown field `vx`"]);
}

#[test]
fn missing_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("does-not-exist.toml");
    let e = Scene::load(&path, &[]).unwrap_err();
    assert!(matches!(e, CaseError::Read { .. }), "{e}");
    assert_mentions(&e.to_string(), &["does-not-exist.toml", "cannot read"]);
}

/// The case path itself is read only if it is a regular file of bounded size: a device
/// (an endless read), a folder and a file past the cap are refused before reading.
#[test]
fn a_case_path_that_is_not_a_bounded_regular_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for path in [Path::new("/dev/zero"), dir.path()] {
        let e = Scene::load(path, &[]).unwrap_err();
        assert!(matches!(e, CaseError::Read { .. }), "{e}");
        assert_mentions(&e.to_string(), &["cannot read", "not a regular file"]);
    }
    let big = dir.path().join("big.toml");
    let file = std::fs::File::create(&big).unwrap();
    file.set_len((16 << 20) + 1).unwrap();
    let e = Scene::load(&big, &[]).unwrap_err().to_string();
    assert_mentions(
        &e,
        &["big.toml", "larger than 16777216 bytes", "a case file"],
    );
}

// ---------------------------------------------------------------------------------------
// Method-specific keys and requirements of the mixed methods

#[test]
fn mixed_method_rejects_rate_models_plain_gradients_and_viscosity() {
    let mixed = edit(
        &edit(VALID, "name = \"tlsph\"", "name = \"upwind-sph\""),
        "model = \"hypoelastic\"",
        "model = \"nearly-incompressible-neo-hookean\"",
    );
    let mixed = edit(
        &mixed,
        "h_over_dx = 1.3",
        "h_over_dx = 1.3\ncorrection = \"cgck\"",
    );
    Scene::from_toml(&mixed, Path::new(FILE), &[]).expect("a valid mixed case");
    assert_invalid(
        &edit(
            &mixed,
            "model = \"nearly-incompressible-neo-hookean\"",
            "model = \"hypoelastic\"",
        ),
        "material.model",
        &["state model", "hypoelastic"],
    );
    assert_invalid(
        &edit(&mixed, "correction = \"cgck\"", "correction = \"shepard\""),
        "method.correction",
        &["exact for linear fields", "cgck", "shepard"],
    );
    assert_invalid(
        &edit(
            &mixed,
            "dt = 1e-5",
            "dt = 1e-5\nartificial_viscosity = { alpha = 1.0, beta = 1.0 }",
        ),
        "method.artificial_viscosity",
        &["tlsph"],
    );
    assert_invalid(
        &edit(&mixed, "dt = 1e-5", "dt = 1e-5\njst = { eps4 = 0.1 }"),
        "method.jst",
        &["jst-sph"],
    );
    let linear = "cfl = 0.3\ncfl_wave_speed = \"linear\"";
    Scene::from_toml(&edit(&mixed, "dt = 1e-5", linear), Path::new(FILE), &[])
        .expect("C_p^Lin with a CFL step");
    assert_invalid(
        &edit(
            &mixed,
            "dt = 1e-5",
            "dt = 1e-5\ncfl_wave_speed = \"linear\"",
        ),
        "method.cfl_wave_speed",
        &["method.cfl", "method.dt"],
    );
    assert_invalid(
        &edit(VALID, "dt = 1e-5", linear),
        "method.cfl_wave_speed",
        &["upwind-sph", "jst-sph", "remove it"],
    );
}

#[test]
fn tlsph_rejects_the_keys_of_the_mixed_methods() {
    assert_invalid(
        &edit(VALID, "dt = 1e-5", "dt = 1e-5\nvariables = \"p-F-J\""),
        "method.variables",
        &["upwind-sph", "jst-sph", "remove it"],
    );
    let (e, shown) = error_with(
        &edit(VALID, "dt = 1e-5", "dt = 1e-5\nvariables = \"p-J\""),
        &[],
    );
    assert!(matches!(e, CaseError::Parse { .. }), "{shown}");
    assert_mentions(&shown, &["p-F", "p-F-J", "p-F-H-J"]);
}

#[test]
fn mirror_planes_are_checked() {
    let plane = "\n[[mirror]]\nnormal = \"x\"\nat = 0.0\nkind = \"symmetric\"\n";
    assert_invalid(
        &format!("{VALID}{plane}"),
        "mirror.0",
        &["upwind-sph", "jst-sph", "tlsph", "symmetry"],
    );
    let mixed = edit(
        &edit(
            &edit(VALID, "name = \"tlsph\"", "name = \"upwind-sph\""),
            "model = \"hypoelastic\"",
            "model = \"linear-elastic\"",
        ),
        "h_over_dx = 1.3",
        "h_over_dx = 1.3\ncorrection = \"cgck\"",
    );
    Scene::from_toml(&format!("{mixed}{plane}"), Path::new(FILE), &[]).expect("a valid mirror");
    assert_invalid(
        &format!("{mixed}{}", plane.replace("\"x\"", "\"z\"")),
        "mirror.0.normal",
        &["3D", "dimension = 2"],
    );
    assert_invalid(
        &format!("{mixed}{plane}{plane}{plane}"),
        "mirror.2.normal",
        &["at most two"],
    );
    assert_invalid(
        &format!(
            "{}{plane}",
            edit(&mixed, "dt = 1e-5", "dt = 1e-5\nprojection = true")
        ),
        "method.projection",
        &["mirror", "projection = false"],
    );
    let (e, shown) = error_with(
        &format!("{mixed}{}", plane.replace("\"symmetric\"", "\"odd\"")),
        &[],
    );
    assert!(matches!(e, CaseError::Parse { .. }), "{shown}");
    assert_mentions(&shown, &["symmetric", "skew-symmetric"]);
}

#[test]
fn tributary_volumes_need_a_vertex_lattice() {
    assert_invalid(
        &edit(
            VALID,
            "max = [1.0, 0.5] }",
            "max = [1.0, 0.5], volumes = \"tributary\", lattice = \"cell-centred\" }",
        ),
        "body.0.geometry.volumes",
        &["vertex lattice", "uniform"],
    );
}

// ---------------------------------------------------------------------------------------
// Contact

/// `VALID` with a second block 0.5 m above the first and penalty contact.
fn two_blocks(penalty: &str) -> String {
    let second = "[[body]]\nname = \"lid\"\ngeometry = { shape = \"box\", min = [0.0, 1.0], \
                  max = [1.0, 1.5] }\n\n[contact]\npenalty = ";
    edit(VALID, "\n[run]", &format!("\n{second}{penalty}\n\n[run]"))
}

#[test]
fn contact_needs_a_penalty_in_range_2d_and_two_bodies() {
    Scene::from_toml(&two_blocks("0.1"), Path::new(FILE), &[]).expect("valid contact");
    assert_invalid(
        &two_blocks("1.5"),
        "contact.penalty",
        &["(0, 1]", "0.1", "1.5"],
    );
    assert_invalid(&two_blocks("0.0"), "contact.penalty", &["(0, 1]", "0.0"]);
    let one_body = edit(VALID, "\n[run]", "\n[contact]\npenalty = 0.1\n\n[run]");
    assert_invalid(&one_body, "contact", &["one", "[[body]]"]);
    let mixed = edit(
        &edit(&two_blocks("0.1"), "name = \"tlsph\"", "name = \"jst-sph\""),
        "model = \"hypoelastic\"",
        "model = \"neo-hookean\"",
    );
    let mixed = edit(
        &mixed,
        "h_over_dx = 1.3",
        "h_over_dx = 1.3\ncorrection = \"cgck\"",
    );
    // Contact is an interaction of the scene, which every method runs.
    Scene::from_toml(&mixed, Path::new(FILE), &[]).expect("contact under jst-sph");
    let spun = edit(VALID_3D, "\n[run]", "\n[contact]\npenalty = 0.1\n\n[run]");
    assert_invalid(&spun, "contact", &["2D", "3D"]);
}

#[test]
fn contact_between_bodies_that_a_kernel_spans_is_rejected() {
    // The lid 0.1 m (one Δx) above the block: within the support 2h = 0.26 m.
    let close = edit(&two_blocks("0.1"), "min = [0.0, 1.0]", "min = [0.0, 0.6]");
    let case = Scene::from_toml(&close, Path::new(FILE), &[]).expect("parses and validates");
    let e = match meshless::run::build_method::<D2, meshless::methods::tlsph::Tlsph<D2>>(&case) {
        Ok(_) => panic!("bodies within the kernel support were accepted"),
        Err(e) => e.to_string(),
    };
    assert_mentions(
        &e,
        &[
            "key `contact`",
            "`block`",
            "`lid`",
            "support",
            "move them apart",
        ],
    );
}

// ---------------------------------------------------------------------------------------
// Plasticity

#[test]
fn johnson_cooks_keys_are_checked_and_named() {
    // The strain-rate and thermal terms of `von-mises-plastic` (docs/materials.md): each
    // refused key is named with what it needs.
    let mixed = edit(
        &edit(VALID, "name = \"tlsph\"", "name = \"upwind-sph\""),
        "h_over_dx = 1.3",
        "h_over_dx = 1.3\ncorrection = \"cgck\"",
    );
    let jc = edit(
        &mixed,
        "model = \"hypoelastic\"",
        "model = \"von-mises-plastic\"\nyield_stress = 1e5\nhardening_modulus = 1e5\n\
         hardening_exponent = 0.3\nstrain_rate_coefficient = 0.02\n\
         thermal_softening_exponent = 1.0\nmelting_temperature = 1000.0\n\
         specific_heat = 400.0",
    );
    Scene::from_toml(&jc, Path::new(FILE), &[]).expect("a valid Johnson–Cook case");
    let cases: [(&str, &str, &str, &[&str]); 6] = [
        (
            "melting_temperature = 1000.0\n",
            "",
            "material.melting_temperature",
            &["missing", "thermal_softening_exponent", "specific_heat"],
        ),
        (
            "melting_temperature = 1000.0",
            "melting_temperature = 200.0",
            "material.melting_temperature",
            &["200", "293.15", "T_m > T_r"],
        ),
        (
            "hardening_modulus = 1e5",
            "hardening_modulus = -1e4",
            "material.hardening_exponent",
            &["0.3", "softening is linear only"],
        ),
        (
            "strain_rate_coefficient = 0.02",
            "strain_rate_coefficient = -0.02",
            "material.strain_rate_coefficient",
            &["-0.02"],
        ),
        (
            "specific_heat = 400.0",
            "specific_heat = 400.0\ntaylor_quinney = 1.5",
            "material.taylor_quinney",
            &["1.5", "[0, 1]"],
        ),
        (
            "strain_rate_coefficient = 0.02",
            "reference_strain_rate = 1.0",
            "material.reference_strain_rate",
            &["strain_rate_coefficient"],
        ),
    ];
    for (from, to, key, words) in cases {
        assert_invalid(&edit(&jc, from, to), key, words);
    }
    // The rate model's radial return takes no Johnson–Cook term.
    assert_invalid(
        &edit(
            VALID,
            "poisson_ratio = 0.3",
            "poisson_ratio = 0.3\nyield_stress = 1e5\nhardening_exponent = 0.5",
        ),
        "material.hardening_exponent",
        &["`von-mises-plastic`", "remove it"],
    );
}

#[test]
fn the_plastic_model_needs_its_hardening_and_a_mixed_method() {
    let mixed = edit(
        &edit(VALID, "name = \"tlsph\"", "name = \"upwind-sph\""),
        "h_over_dx = 1.3",
        "h_over_dx = 1.3\ncorrection = \"cgck\"",
    );
    let plastic = edit(
        &mixed,
        "model = \"hypoelastic\"",
        "model = \"von-mises-plastic\"\nyield_stress = 1e5\nhardening_modulus = 1e4",
    );
    Scene::from_toml(&plastic, Path::new(FILE), &[]).expect("a valid plastic case");
    assert_invalid(
        &edit(&plastic, "yield_stress = 1e5\n", ""),
        "material.yield_stress",
        &["von-mises-plastic", "yield_stress", "hardening_modulus"],
    );
    assert_invalid(
        &edit(&plastic, "yield_stress = 1e5", "yield_stress = -1e5"),
        "material.yield_stress",
        &["-100000"],
    );
    assert_invalid(
        &edit(
            VALID,
            "poisson_ratio = 0.3",
            "poisson_ratio = 0.3\nyield_stress = 1e5",
        ),
        "material.yield_stress",
        &["`gray-monaghan-sph`", "`tlsph`", "remove it"],
    );
    // Softening (seed 001 §9.5: H = −E/10) is accepted down to −3μ (μ = 3.85e5 Pa here).
    let softening = edit(
        &plastic,
        "hardening_modulus = 1e4",
        "hardening_modulus = -1e5",
    );
    Scene::from_toml(&softening, Path::new(FILE), &[]).expect("a softening plastic case");
    assert_invalid(
        &edit(
            &plastic,
            "hardening_modulus = 1e4",
            "hardening_modulus = -2e6",
        ),
        "material.hardening_modulus",
        &["-2000000", "−3μ", "-1.153846"],
    );
    // TLSPH takes it; the elastic potential, whose force is ∂Π/∂u of an elastic Π, does not.
    let on_tlsph = edit(&plastic, "name = \"upwind-sph\"", "name = \"tlsph\"");
    let on_tlsph = edit(
        &on_tlsph,
        "correction = \"cgck\"",
        "correction = \"randles-libersky\"",
    );
    Scene::from_toml(&on_tlsph, Path::new(FILE), &[]).expect("a plastic TLSPH case");
    assert_invalid(
        &edit(&on_tlsph, "name = \"tlsph\"", "name = \"tl-potential\""),
        "material.model",
        &[
            "von-mises-plastic",
            "upwind-sph",
            "jst-sph",
            "`tlsph`",
            "tl-potential",
        ],
    );
}

// ---------------------------------------------------------------------------------------
// The Mooney–Rivlin rubber

#[test]
fn the_mooney_rivlin_model_takes_c1_c2_and_lambda_instead_of_e_and_nu() {
    let elastic = "youngs_modulus = 1e6\npoisson_ratio = 0.3";
    let constants = "c1 = 1.265e5\nc2 = 1.012e4\nlambda = 1.012e7";
    let rubber = edit(
        &edit(VALID, "\"hypoelastic\"", "\"mooney-rivlin\""),
        elastic,
        constants,
    );
    Scene::from_toml(&rubber, Path::new(FILE), &[]).expect("a valid Mooney–Rivlin case");
    assert_invalid(
        &edit(
            &rubber,
            "c1 = 1.265e5",
            "c1 = 1.265e5\nyoungs_modulus = 1e6",
        ),
        "material.youngs_modulus",
        &["not by `mooney-rivlin`", "`neo-hookean`", "remove it"],
    );
    assert_invalid(
        &edit(&rubber, "c2 = 1.012e4\n", ""),
        "material.c2",
        &[
            "`mooney-rivlin` model needs it",
            "`c1`",
            "`lambda`",
            "eq 18",
        ],
    );
    assert_invalid(
        &edit(&rubber, "c1 = 1.265e5", "c1 = 0.0"),
        "material.c1",
        &["> 0", "0.0"],
    );
    assert_invalid(
        &edit(
            &rubber,
            "lambda = 1.012e7",
            "lambda = 1.012e7\nplane = \"stress\"",
        ),
        "material.plane",
        &["`mooney-rivlin`", "plane = \"strain\""],
    );
    let neo_hookean = edit(VALID, "\"hypoelastic\"", "\"neo-hookean\"");
    assert_invalid(
        &edit(&neo_hookean, elastic, &format!("{elastic}\nc1 = 1e5")),
        "material.c1",
        &["read only by `mooney-rivlin`", "not by `neo-hookean`"],
    );
    // The updated-Lagrangian SPH methods integrate the rate model only.
    let on_godunov = edit(&rubber, "name = \"tlsph\"", "name = \"godunov-sph\"");
    assert_invalid(&on_godunov, "material.model", &["mooney-rivlin"]);
}

// ---------------------------------------------------------------------------------------
// Time laws and pressures

#[test]
fn time_laws_and_pressures_are_checked() {
    let traction = "[[boundary]]\nregion = { x_min = 1.0 }\ncondition = { type = \"traction\", \
                    traction = [1e4, 0.0], law = LAW }\n\n[run]";
    let with_law = |law: &str| edit(VALID, "[run]", &traction.replace("LAW", law));
    Scene::from_toml(
        &with_law("{ type = \"exponential\", tau = 1e-4 }"),
        Path::new(FILE),
        &[],
    )
    .expect("a traction decaying exponentially");
    assert_invalid(
        &with_law("{ type = \"ramp\", duration = 0.0 }"),
        "boundary.0.condition.law.duration",
        &["> 0"],
    );
    assert_invalid(
        &with_law("{ type = \"table\", points = [[1e-4, 1.0], [0.0, 0.0]] }"),
        "boundary.0.condition.law.points",
        &["back in time", "must not decrease"],
    );
    assert_invalid(
        &with_law("{ type = \"table\", points = [] }"),
        "boundary.0.condition.law.points",
        &["is empty", "[time, value]"],
    );
    let pressure = "[[boundary]]\nregion = {}\ncondition = { type = \"pressure\", pressure = \
                    1e4, center = [0.5, 0.25], radius = 0.1, surface = \"inner\" }\n\n[run]";
    let with_pressure = edit(VALID, "[run]", pressure);
    assert_invalid(
        &edit(&with_pressure, "radius = 0.1", "radius = -0.1"),
        "boundary.0.condition.radius",
        &["> 0"],
    );
    // The static path scales its loads by t/end_time and takes no time law.
    let cantilever = std::fs::read_to_string(crate::common::case_file("cantilever-3d")).unwrap();
    let timed = cantilever.replacen(
        "[[boundary]]",
        "[[boundary]]\nregion = { x_min = 8.0 }\ncondition = { type = \"traction\", traction = \
         [0.0, -1.0, 0.0], law = { type = \"ramp\", duration = 1.0 } }\n\n[[boundary]]",
        1,
    );
    assert_invalid(
        &timed,
        "boundary.0.condition",
        &["`dual-support-sph` is static", "time law"],
    );
    // A static run of an explicit method: load steps of method.dt, a method that has it.
    let beam = std::fs::read_to_string(crate::common::case_file("cantilever-convergence")).unwrap();
    assert_invalid(
        &edit(&beam, "dt = 1.0", "cfl = 0.3"),
        "method.dt",
        &["load steps", "no method.cfl"],
    );
    // (The beam's `force = "reveles"` is a TLSPH value, not the potential's.)
    let potential = edit(&beam, "name = \"tlsph\"", "name = \"tl-potential\"");
    assert_invalid(
        &edit(&potential, "force = \"reveles\"", ""),
        "run.solve",
        &["`tlsph`", "`kbm`", "`efg`"],
    );
}

// ---------------------------------------------------------------------------------------
// Shipped cases

#[test]
fn every_shipped_case_validates_and_discretises() {
    // Each file in cases/ parses, passes validation and samples its bodies: a renamed key
    // or a geometry that holds no particle fails here, before any run.
    let mut count = 0;
    for path in toml_files(&cases_dir()) {
        let case = Scene::load(&path, &[]).unwrap_or_else(|e| panic!("{e}"));
        let particles = match case.dimension {
            2 => meshless::case::discretise::<D2>(&case).map(|d| d.x0.len()),
            _ => {
                meshless::case::discretise::<meshless::core::tensor::D3>(&case).map(|d| d.x0.len())
            }
        }
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(particles > 0, "{}: no particle", path.display());
        count += 1;
    }
    assert!(count >= 12, "{count} shipped cases");
}

// ---------------------------------------------------------------------------------------
// Points files

/// `VALID` with its body sampled from the points file `file`, loaded and discretised.
fn points_error(file: &Path) -> String {
    let text = edit(
        VALID,
        "geometry = { shape = \"box\", min = [0.0, 0.0], max = [1.0, 0.5] }",
        &format!(
            "geometry = {{ shape = \"points\", file = {:?} }}",
            file.display().to_string()
        ),
    );
    let case = Scene::from_toml(&text, Path::new(FILE), &[]).expect("the file validates");
    match meshless::case::discretise::<D2>(&case) {
        Ok(_) => panic!("{} was sampled", file.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn points_files_are_regular_files_whose_text_errors_never_echo() {
    // A device is refused before it is read (reading /dev/zero would never end), and the
    // errors about a file's lines name line and column but not their text.
    let shown = points_error(Path::new("/dev/zero"));
    assert_mentions(&shown, &["body.0.geometry.file", "not a regular file"]);
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret.csv");
    std::fs::write(&secret, "password-in-the-header\n1,2\n").unwrap();
    let shown = points_error(&secret);
    assert_mentions(&shown, &["no column `x`", "header"]);
    assert!(!shown.contains("password"), "{shown}");
    // A column the dimension does not read (z in 2D) is refused, named by its place.
    std::fs::write(&secret, "x,y,z\n0.0,0.0,0.0\n").unwrap();
    let shown = points_error(&secret);
    assert_mentions(
        &shown,
        &["column 3 is not one a 2D points file takes", "x, y, volume"],
    );
    std::fs::write(&secret, "x,y\n0.0,0.0\n1.0,token-on-line-3\n").unwrap();
    let shown = points_error(&secret);
    assert_mentions(&shown, &["line 3"]);
    assert!(!shown.contains("token"), "{shown}");
}

/// The error of building `text`'s reference configuration (None if it builds).
fn reference_error(text: &str) -> Option<String> {
    let case = Scene::from_toml(text, Path::new(FILE), &[]).expect("the file validates");
    meshless::reference::Reference::<D2>::build(&case)
        .err()
        .map(|e| e.to_string())
}

#[test]
fn coincident_particles_and_overlapping_bodies_are_refused() {
    // A row repeated in a points file: two particles at one position of one body.
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("points.csv");
    std::fs::write(&points, "x,y\n0.0,0.0\n0.1,0.0\n0.1,0.0\n0.2,0.0\n").unwrap();
    let repeated = edit(
        VALID,
        "geometry = { shape = \"box\", min = [0.0, 0.0], max = [1.0, 0.5] }",
        &format!(
            "geometry = {{ shape = \"points\", file = {:?} }}",
            points.display().to_string()
        ),
    );
    let shown = reference_error(&repeated).expect("a repeated point is refused");
    assert_mentions(
        &shown,
        &[
            "body.0.geometry",
            "particles 1 and 2",
            "`block`",
            "coincide",
        ],
    );
    // The same box twice: every particle of the second lies on one of the first.
    let twice = format!(
        "{VALID}\n[[body]]\nname = \"copy\"\n\
         geometry = {{ shape = \"box\", min = [0.0, 0.0], max = [1.0, 0.5] }}\n"
    );
    let shown = reference_error(&twice).expect("overlapping bodies are refused");
    assert_mentions(
        &shown,
        &["body.1.geometry", "`block`", "`copy`", "the bodies overlap"],
    );
    // The same box offset by 0.3 of the spacing: no particle coincides, every one lies
    // within 0.3·√2 Δx < Δx/2 of one of the first body's.
    let offset = format!(
        "{VALID}\n[[body]]\nname = \"offset\"\n\
         geometry = {{ shape = \"box\", min = [0.03, 0.03], max = [1.03, 0.53] }}\n"
    );
    let shown = reference_error(&offset).expect("offset lattices are refused");
    assert_mentions(
        &shown,
        &[
            "body.1.geometry",
            "`block`",
            "`offset`",
            "the bodies overlap",
        ],
    );
    // Bodies side by side a spacing apart build.
    let beside = format!(
        "{VALID}\n[[body]]\nname = \"beside\"\n\
         geometry = {{ shape = \"box\", min = [1.1, 0.0], max = [2.0, 0.5] }}\n"
    );
    assert_eq!(reference_error(&beside), None);
}

#[test]
fn reaction_and_section_observers_name_their_errors() {
    let support = "[[boundary]]\nname = \"left\"\nregion = { x_max = 0.0 }\ncondition = { type = \"fixed\" }\n";
    let with = |extra: &str| format!("{VALID}{extra}");
    // A load's name repeated by a support, a name that is no column prefix, a repeated
    // name (the default of the first support is `boundary0`).
    assert_invalid(
        &with(&format!(
            "[[boundary]]\nname = \"g\"\nregion = {{}}\ncondition = {{ type = \"body-force\", acceleration = [0.0, -9.81] }}\n{}",
            support.replace("\"left\"", "\"g\"")
        )),
        "boundary.1.name",
        &["\"g\"", "must be unique"],
    );
    assert_invalid(
        &with(&support.replace("\"left\"", "\"left grip\"")),
        "boundary.0.name",
        &["\"left grip\"", "' '", "column prefixes"],
    );
    assert_invalid(
        &with(&format!(
            "[[boundary]]\nregion = {{ x_min = 1.0 }}\ncondition = {{ type = \"fixed\" }}\n{}",
            support.replace("\"left\"", "\"boundary0\"")
        )),
        "boundary.1.name",
        &["\"boundary0\"", "must be unique"],
    );
    // The observer needs a support or a named load.
    assert_invalid(
        &with("[output]\nobservers = [\"reaction\"]\n"),
        "output.observers",
        &[
            "`reaction`",
            "no boundary condition prescribes motion",
            "no load has a `name`",
        ],
    );
    // A section along z in 2D, at no number, in no body, named twice.
    let section = "[[section]]\nname = \"mid\"\nnormal = \"x\"\nat = 0.5\n";
    assert_invalid(
        &with(&section.replace("\"x\"", "\"z\"")),
        "section.0.normal",
        &["only in 3D"],
    );
    assert_invalid(
        &with(&section.replace("0.5", "nan")),
        "section.0.at",
        &["finite"],
    );
    assert_invalid(
        &with(&format!("{section}body = \"nope\"\n")),
        "section.0.body",
        &["\"nope\"", "\"block\""],
    );
    assert_invalid(
        &with(&format!("{section}{section}")),
        "section.1.name",
        &["\"mid\"", "must be unique"],
    );
}

/// The error of running `text` on the CPU, where it loads but is refused at set-up.
fn setup_error(text: &str) -> String {
    let case = Scene::from_toml(text, Path::new(FILE), &[]).expect("the file validates");
    let dir = tempfile::tempdir().unwrap();
    match meshless::run::run(&case, &crate::common::cpu_options(dir.path(), false)) {
        Ok(_) => panic!("the run went ahead:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// An observer that could watch nothing is refused, not run: a probe far outside the
/// block (which would watch the nearest particle under another name) and a section plane
/// that crosses no particle (whose force would read zero whatever the load). A probe on
/// the block's corner, Δx/2 from its nearest particle, and a plane through it run.
#[test]
fn probes_and_sections_outside_the_bodies_are_refused() {
    let probe = |at: &str| format!("{VALID}[[probe]]\nname = \"p\"\nposition = {at}\n");
    let shown = setup_error(&probe("[100.0, 0.0]"));
    assert_mentions(&shown, &[FILE, "probe.0.position", "outside the bodies"]);
    let section =
        |at: &str| format!("{VALID}[[section]]\nname = \"s\"\nnormal = \"x\"\nat = {at}\n");
    let shown = setup_error(&section("7.5"));
    assert_mentions(&shown, &[FILE, "section.0.at", "no particle"]);
    let dir = tempfile::tempdir().unwrap();
    let short = |text: String| {
        let case = Scene::from_toml(&text, Path::new(FILE), &["run.end_time=1e-5".into()])
            .expect("the file validates");
        meshless::run::run(&case, &crate::common::cpu_options(dir.path(), false))
    };
    short(probe("[0.0, 0.0]")).expect("a probe on the corner runs");
    short(section("0.5")).expect("a plane through the block runs");
}

/// ν = 0.5 only with artificial compressibility, and the table's own checks: the model,
/// the variables, the integrator and the ranges of its keys.
#[test]
fn artificial_compressibility_alone_takes_nu_one_half_and_checks_its_keys() {
    let plate = std::fs::read_to_string(cases_dir().join("spinning-plate.toml")).unwrap();
    let incompressible = edit(&plate, "poisson_ratio = 0.45", "poisson_ratio = 0.5");
    assert_invalid(
        &incompressible,
        "material.poisson_ratio",
        &[
            "0.5",
            "`upwind-sph` and `jst-sph`",
            "artificial_compressibility",
        ],
    );
    let with = |table: &str| edit(&incompressible, "cfl = 0.3", &format!("cfl = 0.3\n{table}"));
    let ac = with("artificial_compressibility = {}");
    Scene::from_toml(&ac, Path::new(FILE), &[]).expect("ν = 0.5 with artificial compressibility");
    let key = "method.artificial_compressibility";
    for (table, key, parts) in [
        ("{ kappa = -1.0 }", format!("{key}.kappa"), &["> 0"][..]),
        ("{ alpha = 1.5 }", format!("{key}.alpha"), &["[0, 1]"][..]),
        (
            "{ tolerance = 0.0 }",
            format!("{key}.tolerance"),
            &["(0, 1)"][..],
        ),
        (
            "{ max_iterations = 0 }",
            format!("{key}.max_iterations"),
            &["1..="][..],
        ),
        ("{ gamma = 0.0 }", format!("{key}.gamma"), &["> 0"][..]),
    ] {
        assert_invalid(
            &with(&format!("artificial_compressibility = {table}")),
            &key,
            parts,
        );
    }
    let unknown = error(&with("artificial_compressibility = { kapa = 1e7 }"));
    assert_mentions(&unknown, &["kapa", "kappa"]);
    assert_invalid(
        &edit(&ac, "integrator = \"tvd-rk2\"", "integrator = \"rk4\""),
        "method.integrator",
        &["`rk4`", "`tvd-rk2`", "`ssp-rk3`"],
    );
    assert_invalid(
        &edit(&ac, "cfl = 0.3", "cfl = 0.3\nvariables = \"p-F-J\""),
        "method.variables",
        &["replaces J", "\"p-F-H-J\""],
    );
    let compressible = edit(
        &plate,
        "cfl = 0.3",
        "cfl = 0.3\nartificial_compressibility = { kappa = 1e9 }",
    );
    assert_invalid(
        &compressible,
        "method.artificial_compressibility.kappa",
        &["bulk modulus κ"],
    );
    assert_invalid(
        &edit(
            &compressible,
            "nearly-incompressible-neo-hookean",
            "neo-hookean",
        ),
        "material.model",
        &[
            "`nearly-incompressible-neo-hookean`",
            "no separate pressure",
        ],
    );
}

/// VALID_3D with its tube body sampled as a `tube` of `keys` (angles, sectors).
fn tube_case(keys: &str) -> String {
    edit(
        VALID_3D,
        "{ shape = \"cylinder\", base = [0.0, 0.0, 0.0], axis = \"z\", radius = 0.5, inner_radius = 0.25, length = 1.0 }",
        &format!(
            "{{ shape = \"tube\", base = [0.0, 0.0, 0.0], axis = \"z\", radius = 0.5, inner_radius = 0.25, length = 1.0{keys} }}"
        ),
    )
}

#[test]
fn a_tube_is_refused_with_the_key_that_is_wrong() {
    Scene::from_toml(
        &tube_case(", angles = [0.0, 90.0], sectors = 12"),
        Path::new(FILE),
        &[],
    )
    .expect("a quarter tube is valid");
    assert_invalid(
        &tube_case(", angles = [10.0, 10.0]"),
        "body.0.geometry.angles",
        &["0 < θ1 − θ0 ≤ 360", "[10.0, 10.0]"],
    );
    assert_invalid(
        &tube_case(", angles = [0.0, 400.0]"),
        "body.0.geometry.angles",
        &["0 < θ1 − θ0 ≤ 360"],
    );
    assert_invalid(
        &tube_case(", sectors = 0"),
        "body.0.geometry.sectors",
        &["at least 1"],
    );
    let inverted = edit(&tube_case(""), "inner_radius = 0.25", "inner_radius = 0.5");
    assert_invalid(
        &inverted,
        "body.0.geometry.inner_radius",
        &["smaller than radius"],
    );
    let in_2d = edit(
        VALID,
        "{ shape = \"box\", min = [0.0, 0.0], max = [1.0, 0.5] }",
        "{ shape = \"tube\", base = [0.0, 0.0], axis = \"y\", inner_radius = 0.5, radius = 1.0, length = 2.0 }",
    );
    assert_invalid(&in_2d, "body.0.geometry.shape", &["\"tube\"", "only in 3D"]);
    let cells = edit(
        &tube_case(""),
        "name = \"tlsph\"\nh_over_dx = 1.5\ncorrection = \"shepard\"\ncfl = 0.3\nartificial_viscosity = { alpha = 1.0, beta = 2.0 }",
        "name = \"tl-fem\"\ncfl = 0.3",
    );
    assert_invalid(
        &cells,
        "body.0.geometry.shape",
        &["\"tube\"", "no cells", "tl-fem", "\"cylinder\""],
    );
}

#[test]
fn a_hole_direction_of_zero_length_is_refused() {
    let text = edit(
        &tube_case(""),
        "initial_velocity = { type = \"rigid-rotation\"",
        "holes = [{ center = [0.0, 0.0, 0.5], radius = 0.05, axis = [0.0, 0.0, 0.0] }]\ninitial_velocity = { type = \"rigid-rotation\"",
    );
    assert_invalid(
        &text,
        "body.0.holes.0.axis",
        &["\"x\", \"y\", \"z\" or a direction", "not all zero"],
    );
}

// ---------------------------------------------------------------------------------------
// SUPG-SPH

/// SUPG-SPH's parameters are checked by name, and what it does not run is refused with
/// the methods that do: artificial compressibility, the bond-based F and plasticity.
#[test]
fn supg_sph_checks_its_parameters_and_refuses_what_it_does_not_run() {
    let plate = std::fs::read_to_string(cases_dir().join("spinning-plate.toml")).unwrap();
    let supg = edit(&plate, "name = \"upwind-sph\"", "name = \"supg-sph\"");
    Scene::from_toml(&supg, Path::new(FILE), &[]).expect("the plate under SUPG-SPH");
    let with = |line: &str| edit(&supg, "cfl = 0.3", &format!("cfl = 0.3\n{line}"));
    assert_invalid(
        &with("supg = { tau_p = -0.1 }"),
        "method.supg.tau_p",
        &["-0.1"],
    );
    assert_invalid(
        &with("supg = { xi_f = 1.5 }"),
        "method.supg.xi_f",
        &["1.5", "[0, 1)", "0.2"],
    );
    let (_, shown) = error_with(&with("supg = { tau = 1.0 }"), &[]);
    assert_mentions(
        &shown,
        &[FILE, "unknown field `tau`", "tau_f", "tau_p", "xi_f"],
    );
    assert_invalid(
        &with("artificial_compressibility = {}"),
        "method.artificial_compressibility",
        &["supg-sph", "upwind-sph", "jst-sph"],
    );
    assert_invalid(
        &with("variables = \"p-F\"\ndeformation_gradient = \"bond-based\""),
        "method.deformation_gradient",
        &["supg-sph", "upwind-sph"],
    );
    let plastic = [
        "material.model=von-mises-plastic",
        "material.yield_stress=1e5",
        "material.hardening_modulus=1e4",
    ];
    let (_, shown) = error_with(&supg, &plastic);
    assert_mentions(&shown, &["material.model", "upwind-sph", "jst-sph"]);
}
