//! The case each method of the registry is benchmarked on, shared by the CPU and GPU
//! benches: a shipped case of the method (or one switched to it), resized to about
//! [`PARTICLES`] particles by `meshless bench`'s rule, with a fixed Δt.

use meshless::bench::resize;
use meshless::core::tensor::D2;
use meshless::run::Engine;
use meshless::scene::Scene;
use std::path::PathBuf;

/// Particles of each method's bench case (the static plate keeps its 400).
pub const PARTICLES: f64 = 2e3;

/// How a method's steps are benchmarked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Time steps, one after the other, at about [`PARTICLES`] particles.
    Dynamic,
    /// A load step of a static engine, solved from a fresh engine each time, at the
    /// case's own size.
    Static,
}

/// Method, shipped case, overrides, kind.
const CASES: &[(&str, &str, &[&str], Kind)] = &[
    ("tlsph", "rotating-disk.toml", &[], Kind::Dynamic),
    (
        "tl-potential",
        "rotating-disk-potential.toml",
        &[],
        Kind::Dynamic,
    ),
    (
        "corotated-tlsph",
        "rotating-disk-corotated.toml",
        &[],
        Kind::Dynamic,
    ),
    (
        "gray-monaghan-sph",
        "rotating-disk-gray-monaghan.toml",
        &[],
        Kind::Dynamic,
    ),
    (
        "godunov-sph",
        "rotating-disk-godunov.toml",
        &[],
        Kind::Dynamic,
    ),
    ("tl-fem", "rotating-disk-fem.toml", &[], Kind::Dynamic),
    (
        "tl-weak-form",
        "rotating-disk-weak-form.toml",
        &[],
        Kind::Dynamic,
    ),
    ("ul-fem", "rotating-disk-ul-fem.toml", &[], Kind::Dynamic),
    (
        "ul-weak-form",
        "rotating-disk-ul-weak-form.toml",
        &[],
        Kind::Dynamic,
    ),
    (
        "kbm",
        "rotating-disk-weak-form.toml",
        &["method.name=kbm", "method.h_over_dx=1.3"],
        Kind::Dynamic,
    ),
    (
        "efg",
        "rotating-disk-weak-form.toml",
        &["method.name=efg", "method.h_over_dx=1.3"],
        Kind::Dynamic,
    ),
    ("upwind-sph", "swinging-plate.toml", &[], Kind::Dynamic),
    (
        "jst-sph",
        "swinging-plate.toml",
        &["method.name=jst-sph"],
        Kind::Dynamic,
    ),
    (
        "supg-sph",
        "swinging-plate.toml",
        &["method.name=supg-sph"],
        Kind::Dynamic,
    ),
    (
        "dual-support-sph",
        "plate-compression-2d.toml",
        &[],
        Kind::Static,
    ),
];

/// The 2D bench case of method `name` and how it is stepped; panics, naming the method,
/// when it has none (a new method adds its line to `CASES`).
pub fn method_case(name: &str) -> (Scene, Kind) {
    let &(_, file, extra, kind) = CASES
        .iter()
        .find(|(method, ..)| *method == name)
        .unwrap_or_else(|| panic!("no bench case for the method `{name}`: add one to CASES"));
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(file);
    let mut set: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
    let base = Scene::load(&path, &set).expect("case loads");
    if kind == Kind::Dynamic {
        set.extend(resize(&base, PARTICLES, false).expect("case resizes"));
    }
    (Scene::load(&path, &set).expect("resized case loads"), kind)
}

/// The case's fixed Δt, or its CFL step at the engine's initial signal speed.
pub fn time_step(case: &Scene, engine: &mut dyn Engine<D2>) -> f64 {
    match (case.method.dt, case.method.cfl) {
        (Some(dt), _) => dt,
        (_, Some(cfl)) => cfl * case.spacing / engine.max_signal_speed(),
        _ => unreachable!("a validated case has dt or cfl"),
    }
}
