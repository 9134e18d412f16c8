//! Initial fields given as expressions of the reference coordinates
//! (`initial_velocity = { type = "expression", … }`).

use crate::common::material_and_method;
use meshless::case::{CaseError, Discretised, discretise};
use meshless::core::tensor::D2;
use meshless::scene::Scene;
use std::path::Path;

/// The shipped rotating disk with its initial velocity replaced by `field`.
fn disk(field: &str) -> Result<Scene, CaseError> {
    let text = std::fs::read_to_string(crate::common::case_file("rotating-disk")).unwrap();
    let text = text.replace(
        r#"initial_velocity = { type = "rigid-rotation", omega = 50.0, center = [0.0, 0.0] }"#,
        &format!("initial_velocity = {field}"),
    );
    Scene::from_toml(&text, Path::new("disk.toml"), &[])
}

#[test]
fn an_expression_gives_the_field_it_writes() {
    // v = ω × X written out, against the built-in rigid rotation at every particle.
    // Bound 1e-13 of ω R: the two evaluate the same products in a different order.
    let rigid = discretise::<D2>(
        &disk(r#"{ type = "rigid-rotation", omega = 50.0, center = [0.0, 0.0] }"#).unwrap(),
    )
    .unwrap();
    let written = discretise::<D2>(
        &disk(r#"{ type = "expression", vx = "-w*y", vy = "w*x", constants = { w = 50.0 } }"#)
            .unwrap(),
    )
    .unwrap();
    assert_eq!(rigid.v0.len(), written.v0.len());
    for (a, b) in rigid.v0.iter().zip(&written.v0) {
        assert!((*a - *b).length() < 1e-13 * 50.0, "{a} against {b}");
    }
    // ω in scientific notation reads as the same number: the same field to the bit.
    let scientific = discretise::<D2>(
        &disk(r#"{ type = "expression", vx = "-5e1*y", vy = "5.0E+1*x" }"#).unwrap(),
    )
    .unwrap();
    assert_eq!(scientific.v0, written.v0);
}

#[test]
fn a_wrong_expression_is_refused_with_its_key_and_position() {
    let shown = |field: &str| disk(field).unwrap_err().to_string();
    let e = shown(r#"{ type = "expression", vx = "-w*y", vy = "w*xx", constants = { w = 50.0 } }"#);
    assert!(
        e.contains("disk.toml")
            && e.contains("body.0.initial_velocity.vy")
            && e.contains("`xx` at character 3")
            && e.contains("x, y, w"),
        "{e}"
    );
    let e = shown(r#"{ type = "expression", vx = "(y", vy = "0" }"#);
    assert!(
        e.contains("body.0.initial_velocity.vx") && e.contains("does not parse"),
        "{e}"
    );
    let e = shown(r#"{ type = "expression", vx = "y", vy = "0", vz = "1" }"#);
    assert!(
        e.contains("body.0.initial_velocity.vz") && e.contains("only in 3D"),
        "{e}"
    );
    let e = shown(r#"{ type = "expression", vx = "y", vy = "0", constants = { x = 1.0 } }"#);
    assert!(e.contains("body.0.initial_velocity.constants.x"), "{e}");
    // Finite everywhere is checked at the particles: sqrt of a negative number is NaN.
    let case = disk(r#"{ type = "expression", vx = "sqrt(-1 - x*x)", vy = "0" }"#).unwrap();
    let Err(e) = discretise::<D2>(&case) else {
        panic!("a NaN velocity is accepted")
    };
    let e = e.to_string();
    assert!(
        e.contains("body.0.initial_velocity") && e.contains("not a finite"),
        "{e}"
    );
}

/// The discretised block case of `common::block_text` with its body read from the points
/// file `rows` (with its header), written beside the case file in a temporary folder, and
/// `extra` lines in the body's table.
fn from_points(rows: &str, extra: &str) -> Result<Discretised<D2>, CaseError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("pts.csv"), rows).unwrap();
    let text = crate::common::block_text(&[0.1, 0.1], "neo-hookean", "tlsph", "").replacen(
        r#"geometry = { shape = "box", min = [0.0, 0.0], max = [0.1, 0.1], volumes = "uniform" }"#,
        &format!("geometry = {{ shape = \"points\", file = \"pts.csv\" }}\n{extra}"),
        1,
    );
    let path = dir.path().join("points.toml");
    std::fs::write(&path, &text).unwrap();
    let scene = Scene::load(&path, &[])?;
    discretise::<D2>(&scene)
}

#[test]
fn a_points_file_may_give_the_initial_velocities() {
    // The velocity columns become v0 of their rows, exactly.
    let d = from_points("x,y,volume,vx,vy\n0,0,0.01,1.5,-2\n0.1,0,0.01,0.25,3\n", "").unwrap();
    assert_eq!(
        d.v0,
        [glam::DVec2::new(1.5, -2.0), glam::DVec2::new(0.25, 3.0)]
    );
}

#[test]
fn velocity_columns_must_be_whole_and_not_given_twice() {
    let Err(partial) = from_points("x,y,vx\n0,0,1\n0.1,0,1\n", "") else {
        panic!("a vx column without vy is accepted")
    };
    let partial = partial.to_string();
    assert!(
        partial.contains("body.0.geometry.file") && partial.contains("vx, vy"),
        "{partial}"
    );
    let Err(twice) = from_points(
        "x,y,vx,vy\n0,0,1,0\n0.1,0,1,0\n",
        r#"initial_velocity = { type = "uniform", value = [1.0, 0.0] }"#,
    ) else {
        panic!("velocities given twice are accepted")
    };
    let twice = twice.to_string();
    assert!(
        twice.contains("body.0.initial_velocity") && twice.contains("given twice"),
        "{twice}"
    );
}

/// A 0.3 × 0.2 m block (Δx = 0.05) of Saint Venant–Kirchhoff rubber with `method` at rest
/// under the initial displacement `field`, RK4 at Δt = 1e-5 s (dynamic, also for the
/// methods that are static by default).
fn prestretched(method: &str, field: &str) -> Result<Scene, CaseError> {
    prestretched_in("saint-venant-kirchhoff", method, field)
}

/// [`prestretched`] with the material model `model`.
fn prestretched_in(model: &str, method: &str, field: &str) -> Result<Scene, CaseError> {
    let tables = material_and_method(model, method);
    let text = format!(
        r#"
name = "prestretched"
dimension = 2
spacing = 0.05
{tables}
[[body]]
name = "block"
geometry = {{ shape = "box", min = [0.0, 0.0], max = [0.3, 0.2] }}
initial_displacement = {field}
[run]
end_time = 1.0e-4
solve = "dynamic"
"#
    );
    Scene::from_toml(&text, Path::new("prestretched.toml"), &[])
}

/// The affine pre-deformation F = I + G of the test below, as a linear field and as the
/// same field written out.
const G: [[f64; 2]; 2] = [[0.1, 0.05], [-0.02, 0.03]];
const LINEAR: &str = "{ type = \"linear\", gradient = [[0.1, 0.05], [-0.02, 0.03]] }";
const WRITTEN: &str = "{ type = \"expression\", ux = \"a*x + b*y\", uy = \"c*x + d*y\", constants = { a = 0.1, b = 0.05, c = -0.02, d = 0.03 } }";

#[test]
fn an_affine_initial_displacement_stores_the_energy_of_its_deformation_gradient() {
    // u0 = G X: every method that takes an initial displacement reproduces linear fields
    // (the corrected kernel gradients, the elements, the moving least squares), so every
    // particle or quadrature point starts at F = I + G, and the stored energy is
    // ψ(I + G) times the method's own volume (Σ V of the particles, Σ w of its
    // quadrature points), to round-off (bound 1e-10). The same on the GPU engines, in f32
    // (bound 1e-5: F carries f32's relative 1e-7 per pair sum).
    let f = glam::DMat2::from_cols_array(&[1.0 + G[0][0], G[1][0], G[0][1], 1.0 + G[1][1]]);
    let methods: Vec<&str> = meshless::methods::REGISTRY
        .iter()
        .filter(|e| {
            e.features
                .contains(&meshless::methods::Feature::InitialDisplacement)
        })
        .map(|e| e.name)
        .collect();
    assert_eq!(methods.len(), 11, "{methods:?}");
    for method in methods {
        for field in [LINEAR, WRITTEN] {
            let case = prestretched(method, field).unwrap();
            let material = meshless::physics::material::Material::new(&case.material);
            let psi = material.energy_density::<D2>(f, glam::DMat2::ZERO, material.rho0);
            let mut backends = vec![(meshless::run::Backend::Cpu, 1e-10)];
            if field == LINEAR {
                backends.push((meshless::run::Backend::Gpu, 1e-5));
            }
            for (backend, bound) in backends {
                let mut engine = meshless::run::engine::<D2>(&case, backend).unwrap();
                let snap = engine.snapshot();
                let volume: f64 = match &snap.quadrature {
                    Some(q) => q.weight.iter().sum(),
                    None => snap.mass.iter().sum::<f64>() / material.rho0,
                };
                let stored = snap.strain_energy.value() / (psi * volume);
                assert!(
                    (stored - 1.0).abs() < bound,
                    "{method} on {backend:?}: stored energy over ψ(I + G) V = {stored}"
                );
            }
        }
    }
}

#[test]
fn an_initial_displacement_is_refused_where_f_does_not_follow_from_u() {
    let shown_in = |model: &str, method: &str, overrides: &[&str]| {
        let case = prestretched_in(model, method, LINEAR).unwrap_or_else(|e| panic!("{e}"));
        let text = toml::to_string(&case.resolved()).unwrap();
        let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        Scene::from_toml(&text, Path::new("prestretched.toml"), &overrides)
            .unwrap_err()
            .to_string()
    };
    let shown = |overrides: &[&str]| shown_in("saint-venant-kirchhoff", "tlsph", overrides);
    // An updated-Lagrangian method has no F of u to start from: refused, naming the
    // methods that take it.
    let e = prestretched_in("hypoelastic", "gray-monaghan-sph", LINEAR)
        .unwrap_err()
        .to_string();
    for part in [
        "body.0.initial_displacement",
        "`tlsph`",
        "`tl-fem`",
        "`upwind-sph`",
    ] {
        assert!(e.contains(part), "{e}");
    }
    // Artificial compressibility starts its pressure at zero, out of balance with a
    // displaced start.
    let e = shown_in(
        "nearly-incompressible-neo-hookean",
        "upwind-sph",
        &[
            "method.integrator=\"tvd-rk2\"",
            "method.artificial_compressibility={ alpha = 0.0 }",
        ],
    );
    assert!(
        e.contains("body.0.initial_displacement") && e.contains("artificial compressibility"),
        "{e}"
    );
    // A rate model would start unstressed; the static path starts from X.
    let e = shown(&["material.model=\"hypoelastic\""]);
    assert!(
        e.contains("`hypoelastic`") && e.contains("from zero"),
        "{e}"
    );
    let e = shown(&["run.solve=\"static\"", "method.dt=1.0"]);
    assert!(e.contains("static path"), "{e}");
    // An expression names its key and the variables it may use.
    let e = prestretched("tlsph", &WRITTEN.replace("a*x", "a*q"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("body.0.initial_displacement.ux") && e.contains("q"),
        "{e}"
    );
}
