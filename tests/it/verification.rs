//! The verification matrix: the methods with a static path, each with its defaults (only
//! the keys a method requires are given), on problems whose answers do not come from this
//! code: a bar under an end traction (the reaction equals the load; the extension FL/EA,
//! the patch test), a bar under its own weight (the reaction equals ρ g times the named
//! area), Timoshenko's cantilever (the elasticity solution, its displacement on the
//! clamp and its traction on the loaded end) and Lamé's thick cylinder under an internal
//! pressure, with the observed order of convergence.
//! docs/verification.md has the matrix's figures.

use meshless::core::tensor::D2;
use meshless::diagnostics::analytic::Cantilever;
use meshless::run::{Backend, Engine, engine};
use meshless::scene::Scene;
use std::path::Path;

/// A row of the matrix: a method name, the keys it requires, its documented order of
/// convergence in the displacement and the error bounds at Δx = 0.125 m of the
/// cantilever and of the patch test under a traction (the end's mean u_x).
pub struct Row {
    pub method: &'static str,
    pub keys: &'static str,
    pub order: f64,
    pub cantilever_error: f64,
    pub patch_error: f64,
}

/// Every method with a static path (`run.solve = "static"`, or static by default). The
/// orders: two for the linearly complete Galerkin methods with cell quadrature (tl-fem,
/// tl-weak-form, EFG (ci)), one for KBM (si) (docs/methods/seed001.md), for dual-support
/// SPH (docs/methods/dual-support.md) and for TLSPH's nodal integration. The error
/// bounds are 1.5 times the errors measured at Δx = 0.125 m (docs/verification.md), so
/// that a change that adds half the error fails; tl-fem passes the patch test exactly
/// (its own test, bound 1e-9).
const ROWS: [Row; 6] = [
    Row {
        method: "tlsph",
        keys: "h_over_dx = 1.3",
        order: 1.0,
        cantilever_error: 0.07,
        patch_error: 5.3e-2,
    },
    Row {
        method: "tl-fem",
        keys: "",
        order: 2.0,
        cantilever_error: 2.8e-3,
        patch_error: 1e-9,
    },
    Row {
        method: "tl-weak-form",
        keys: "h_over_dx = 1.3",
        order: 2.0,
        cantilever_error: 7.2e-3,
        patch_error: 1.8e-3,
    },
    Row {
        method: "efg",
        keys: "h_over_dx = 1.3",
        order: 2.0,
        cantilever_error: 3.7e-3,
        patch_error: 5.2e-4,
    },
    Row {
        method: "kbm",
        keys: "h_over_dx = 1.3",
        order: 1.0,
        cantilever_error: 9.4e-2,
        patch_error: 5.5e-2,
    },
    Row {
        method: "dual-support-sph",
        keys: "h_over_dx = 1.0",
        order: 1.0,
        cantilever_error: 1.04e-2,
        patch_error: 1.3e-2,
    },
];

/// Young's modulus [Pa], Poisson's ratio and density [kg/m³] of every cell.
const E: f64 = 1.0e7;
const NU: f64 = 0.3;
const RHO: f64 = 1000.0;

/// A plane-stress linear-elastic box from `min` to `max` on the default (vertex) lattice
/// of spacing `dx`, solved statically in one load step, with `boundaries` appended.
fn static_case(row: &Row, dx: f64, min: [f64; 2], max: [f64; 2], boundaries: &str) -> Scene {
    let geometry = format!("{{ shape = \"box\", min = {min:?}, max = {max:?} }}");
    static_body(row, dx, &geometry, boundaries)
}

/// A plane-stress linear-elastic body of `geometry` at spacing `dx`, solved statically
/// in one load step, with `boundaries` appended.
fn static_body(row: &Row, dx: f64, geometry: &str, boundaries: &str) -> Scene {
    let text = format!(
        r#"
name = "verification"
dimension = 2
spacing = {dx}
[material]
model = "linear-elastic"
plane = "stress"
density = {RHO}
youngs_modulus = {E}
poisson_ratio = {NU}
[method]
name = "{method}"
{keys}
dt = 1.0
[[body]]
name = "body"
geometry = {geometry}
{boundaries}
[run]
solve = "static"
end_time = 1.0
"#,
        method = row.method,
        keys = row.keys,
    );
    Scene::from_toml(&text, Path::new("verification.toml"), &[])
        .unwrap_or_else(|e| panic!("{}: {e}", row.method))
}

/// The static engine of `case` after its one load step.
fn solved(case: &Scene) -> Box<dyn Engine<D2>> {
    let mut e = engine::<D2>(case, Backend::Cpu).unwrap_or_else(|e| panic!("{e}"));
    e.advance(0.0, 1.0, 1)
        .unwrap_or_else(|f| panic!("{}: {f:?}", case.method.name));
    e
}

/// The roller supports of a uniaxial bar: the end x = 0 held in x, its lower corner in y.
const ROLLERS: &str = r#"
[[boundary]]
name = "end"
region = { x_max = 0.0 }
condition = { type = "velocity", vx = 0.0 }
[[boundary]]
name = "pin"
region = { x_max = 0.0, y_max = 0.0 }
condition = { type = "velocity", vy = 0.0 }
"#;

/// The bar 4 m × 1 m on rollers pulled by t = 1e4 Pa on its free end, solved by `row`:
/// (the supports' reaction, the mean u_x of the loaded end).
fn pulled_bar(row: &Row, dx: f64) -> (f64, f64) {
    let (l, t) = (4.0, 1.0e4);
    let load = format!(
        "{ROLLERS}[[boundary]]\nregion = {{ x_min = {l} }}\ncondition = {{ type = \"traction\", traction = [{t}, 0.0] }}\n"
    );
    let case = static_case(row, dx, [0.0, 0.0], [l, 1.0], &load);
    let mut e = solved(&case);
    let reaction = e.reactions()[0].force[0];
    let s = e.snapshot();
    let end: Vec<usize> = (0..s.x0.len())
        .filter(|&i| (s.x0[i].x - l).abs() < 1e-9)
        .collect();
    let stretch = end.iter().map(|&i| s.u[i].x).sum::<f64>() / end.len() as f64;
    eprintln!(
        "{} at Δx = {dx}: reaction {reaction:.9e}, end u_x {stretch:.9e} (tL/E {:e})",
        row.method,
        t * l / E
    );
    (reaction, stretch)
}

#[test]
fn every_static_method_holds_an_end_traction() {
    // The reaction of the bar is −t H at equilibrium whatever the method, mass or lattice
    // (the traction is a force over each particle's patch of the face, the corners half
    // a patch), to the Newton tolerance: bound 1e-8 of the load (the residual is judged
    // at 1e-10 of the load scale, with room for its round-off). With t·Δx on every end
    // particle it was 1.125 t H, and with the row-sum mass 0.5 t H.
    let load = 1.0e4;
    let failures: Vec<String> = ROWS
        .iter()
        .filter_map(|row| {
            let (reaction, _) = pulled_bar(row, 0.125);
            ((reaction + load).abs() > 1e-8 * load)
                .then(|| format!("{}: reaction {reaction} against {}", row.method, -load))
        })
        .collect();
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn the_finite_elements_pass_the_patch_test_under_a_traction() {
    // The stress is uniform and u_x = t x/E is in the bilinear space, and the patches'
    // loads are the consistent nodal forces ∫ N t dΓ of bilinear elements: the end's
    // mean u_x is tL/E to round-off of a conditioned solve (bound 1e-9).
    let (_, stretch) = pulled_bar(&ROWS[1], 0.125);
    let exact = 1.0e4 * 4.0 / E;
    assert!(
        (stretch / exact - 1.0).abs() < 1e-9,
        "{stretch} against {exact}"
    );
}

#[test]
fn every_method_converges_in_the_patch_test_under_a_traction() {
    // The methods whose patch loads or quadrature are not those of their own functions do
    // not reproduce u_x = t x/E exactly: the meshfree Galerkin methods integrate rational
    // functions with Gauss points (tl-weak-form, EFG (ci)) or at the particles and stress
    // points (KBM (si)), so Σ_q w_q ∇Φ_a(X_q) misses ∫_Γ Φ_a n dΓ; TLSPH and dual-support
    // SPH are collocation methods whose boundary rows see a truncated kernel. Their
    // error in the end's mean u_x at Δx = 0.125 m stays under the row's bound, and falls
    // from Δx = 0.25 m at 0.8 of the row's order at least (issue 47's rule: 0.8 for a
    // first-order method, 1.6 for a second-order one).
    let exact = 1.0e4 * 4.0 / E;
    let mut failures = Vec::new();
    for row in ROWS.iter().filter(|r| r.method != "tl-fem") {
        let error = |dx: f64| (pulled_bar(row, dx).1 / exact - 1.0).abs();
        let (coarse, fine) = (error(0.25), error(0.125));
        let order = (coarse / fine).log2();
        eprintln!(
            "{}: patch error {coarse:.3e} → {fine:.3e}, order {order:.2}",
            row.method
        );
        if fine > row.patch_error || order < 0.8 * row.order {
            failures.push(format!(
                "{}: patch error {coarse:.3e} → {fine:.3e}, order {order:.2}",
                row.method
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn every_static_method_holds_the_weight_of_the_named_body() {
    // The same bar hanging from its end x = 0 under g = 9.81 m/s² along −x: the supports
    // hold ρ g L H, the weight of the box the case names (its particles' volumes sum to
    // it, the lattice's outer rows carrying half cells), to the Newton tolerance (1e-8).
    let (l, h, g) = (4.0, 1.0, 9.81);
    let load = format!(
        "{ROLLERS}[[boundary]]\nregion = {{}}\ncondition = {{ type = \"body-force\", acceleration = [{}, 0.0] }}\n",
        -g
    );
    let weight = RHO * g * l * h;
    let mut failures = Vec::new();
    for row in &ROWS {
        let case = static_case(row, 0.125, [0.0, 0.0], [l, h], &load);
        let mut e = solved(&case);
        let reaction = e.reactions()[0].force[0];
        eprintln!(
            "{}: reaction {reaction:.9e} (weight {weight:e})",
            row.method
        );
        if (reaction - weight).abs() > 1e-8 * weight {
            failures.push(format!(
                "{}: reaction {reaction} against {weight}",
                row.method
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Timoshenko's cantilever of length 8 m and depth 2 m (centred on y = 0) under an end
/// load P = −1e3 N/m at spacing `dx`: the relative volume-weighted L2 error of u.
pub fn cantilever_error(row: &Row, dx: f64) -> f64 {
    let (l, d, p) = (8.0, 2.0, -1.0e3);
    let solution = format!(
        "solution = {{ type = \"timoshenko-cantilever\", load = {p}, length = {l}, depth = {d} }}"
    );
    let boundaries = format!(
        r#"
[[boundary]]
name = "clamp"
region = {{ x_max = 0.0 }}
condition = {{ type = "solution-displacement", components = ["x", "y"], {solution} }}
[[boundary]]
region = {{ x_min = {l} }}
condition = {{ type = "solution-traction", normal = [1.0, 0.0], {solution} }}
"#
    );
    let case = static_case(row, dx, [0.0, -d / 2.0], [l, d / 2.0], &boundaries);
    let mut e = solved(&case);
    let exact = Cantilever {
        load: p,
        length: l,
        depth: d,
        youngs_modulus: E,
        poisson_ratio: NU,
    };
    let s = e.snapshot();
    let (mut num, mut den) = (0.0, 0.0);
    for ((x, u), m) in s.x0.iter().zip(&s.u).zip(s.mass) {
        let [ux, uy] = exact.displacement(x.x, x.y);
        num += ((ux - u.x).powi(2) + (uy - u.y).powi(2)) * m;
        den += (ux * ux + uy * uy) * m;
    }
    (num / den).sqrt()
}

#[test]
fn every_static_method_converges_to_timoshenkos_cantilever() {
    // The error at Δx = 0.125 m under the row's bound, and the observed order from 0.25
    // m at least 0.8 for a first-order method and 1.6 for a second-order one (issue 47's
    // rule).
    let mut failures = Vec::new();
    for row in &ROWS {
        let coarse = cantilever_error(row, 0.25);
        let fine = cantilever_error(row, 0.125);
        let order = (coarse / fine).log2();
        eprintln!(
            "{}: error {coarse:.3e} → {fine:.3e}, order {order:.2}",
            row.method
        );
        if fine > row.cantilever_error || order < 0.8 * row.order {
            failures.push(format!(
                "{}: error {coarse:.3e} → {fine:.3e}, order {order:.2}",
                row.method
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The plate of `cases/cantilever-mode.toml` (2 × 0.2 m, period about 1 s) at Δx = 0.04
/// m, released in its first bending mode, run by `method` with the `overrides` to
/// `end` s: the largest |E(t) − E0|/E0 of its total energy, and whether the case is
/// warned about.
fn released_plate(method: &str, overrides: &[&str], end: f64) -> (f64, bool) {
    let mut all = vec![
        format!("method.name={method}"),
        "spacing=0.04".into(),
        format!("run.end_time={end}"),
        "output.check=".into(),
        "output.series_interval=0.01".into(),
    ];
    all.extend(overrides.iter().map(|s| s.to_string()));
    let case = crate::common::load("cantilever-mode", &all);
    let warned = case.spec.warning(&case).is_some();
    let dir = tempfile::tempdir().unwrap();
    meshless::run::run(&case, &crate::common::cpu_options(dir.path(), false))
        .unwrap_or_else(|e| panic!("{method} {overrides:?}: {e}"));
    let energy =
        meshless::output::series::read_column(&dir.path().join("series.csv"), "total_energy")
            .unwrap();
    let e0 = energy[0].1;
    let drift = energy
        .iter()
        .map(|&(_, e)| (e / e0 - 1.0).abs())
        .fold(0.0, f64::max);
    eprintln!("{method} {overrides:?}: energy drift {drift:.3e} to {end} s, warned {warned}");
    (drift, warned)
}

#[test]
fn a_released_cantilever_keeps_its_energy_with_the_defaults_and_the_warned_options_do_not() {
    // The defaults of tl-weak-form (no velocity smoothing) and corotated-tlsph (the
    // variational force, no artificial viscosity) keep the energy of a free vibration:
    // over one period RK4's error at this Δt is below 1e-5 (measured 4e-6 and 1e-5 at
    // Δx = 0.02 m), bound 1e-4. The options they warn about feed it: the paper's
    // smoothing (+150 % in 1.7 periods at Δx = 0.02 m) and the reference code's force
    // without viscosity (+11 % in a sixth of a period); each gains more than 5 % within
    // the period here, and is warned about, where the defaults are not.
    let mut failures = Vec::new();
    for (method, warned_option) in [
        ("tl-weak-form", "method.smoothing=true"),
        ("corotated-tlsph", "method.force=reference-code"),
    ] {
        let (drift, warned) = released_plate(method, &[], 1.0);
        if drift > 1e-4 || warned {
            failures.push(format!("{method}: drift {drift:e}, warned {warned}"));
        }
        let (drift, warned) = released_plate(method, &[warned_option], 1.0);
        if drift < 0.05 || !warned {
            failures.push(format!(
                "{method} {warned_option}: drift {drift:e}, warned {warned}"
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Lamé's thick cylinder, radii a = 1 m and b = 2 m, under an internal pressure p = 1e4
/// Pa, in plane stress, on a polar lattice of radial spacing `dx` and `sectors` sectors
/// (the symmetry planes x = 0 and y = 0 hold the rigid motions): the relative
/// mass-weighted L2 error of u against u_r = [(1 − ν) A r + (1 + ν) B / r]/E, A =
/// p a²/(b² − a²), B = p a² b²/(b² − a²).
fn lame_error(row: &Row, dx: f64, sectors: usize) -> f64 {
    let (a, b, p) = (1.0, 2.0, 1.0e4);
    let geometry = format!(
        "{{ shape = \"ring\", center = [0.0, 0.0], inner_radius = {a}, outer_radius = {b}, \
         lattice = \"polar\", sectors = {sectors} }}"
    );
    let boundaries = format!(
        r#"
[[boundary]]
region = {{ y_min = 0.0, y_max = 0.0 }}
condition = {{ type = "symmetry", normal = "y" }}
[[boundary]]
region = {{ x_min = 0.0, x_max = 0.0 }}
condition = {{ type = "symmetry", normal = "x" }}
[[boundary]]
region = {{}}
condition = {{ type = "pressure", pressure = {p}, center = [0.0, 0.0], radius = {a}, surface = "inner" }}
"#
    );
    let case = static_body(row, dx, &geometry, &boundaries);
    let mut e = solved(&case);
    let (big_a, big_b) = (
        p * a * a / (b * b - a * a),
        p * a * a * b * b / (b * b - a * a),
    );
    let s = e.snapshot();
    let (mut num, mut den) = (0.0, 0.0);
    for ((x, u), m) in s.x0.iter().zip(&s.u).zip(s.mass) {
        let r = x.length();
        let ur = ((1.0 - NU) * big_a * r + (1.0 + NU) * big_b / r) / E;
        let exact = *x * (ur / r);
        num += (exact - *u).length_squared() * m;
        den += exact.length_squared() * m;
    }
    (num / den).sqrt()
}

#[test]
fn every_static_method_converges_to_lames_thick_cylinder() {
    // The error at Δx = 0.125 m (80 sectors) under 1.5 times the one measured
    // (docs/verification.md), so that a change that adds half the error fails, and the
    // observed order from Δx = 0.25 m (40 sectors) at least 0.8 of the row's (issue 47's
    // rule). The pressure acts on the polar lattice's inner circle, its consistent nodal
    // forces for the meshfree Galerkin methods.
    let bounds = [3.3e-2, 1.6e-3, 4.0e-3, 5.1e-3, 6.1e-3, 7.1e-3];
    let mut failures = Vec::new();
    for (row, bound) in ROWS.iter().zip(bounds) {
        let coarse = lame_error(row, 0.25, 40);
        let fine = lame_error(row, 0.125, 80);
        let order = (coarse / fine).log2();
        eprintln!(
            "{}: Lamé error {coarse:.3e} → {fine:.3e}, order {order:.2}",
            row.method
        );
        if fine > bound || order < 0.8 * row.order {
            failures.push(format!(
                "{}: Lamé error {coarse:.3e} → {fine:.3e}, order {order:.2}",
                row.method
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn kbm_is_warned_about_in_dynamics_where_a_released_plate_blows_up() {
    // KBM's Petrov–Galerkin force is not the gradient of an energy: on the plate released
    // in its first bending mode (period about 1 s) it blows up within the first period
    // and a quarter at Δx = 0.04 m (measured 1.19 s; 0.37 s at Δx = 0.02 m, whatever the
    // integrator or time step, docs/verification.md), so every dynamic run of kbm is
    // warned about; its static solve is not.
    let case = crate::common::load(
        "cantilever-mode",
        &[
            "method.name=kbm",
            "spacing=0.04",
            "run.end_time=1.3",
            "output.check=",
            "output.series_interval=0.01",
        ],
    );
    assert!(case.spec.warning(&case).is_some());
    let dir = tempfile::tempdir().unwrap();
    let run = meshless::run::run(&case, &crate::common::cpu_options(dir.path(), false));
    assert!(run.is_err(), "kbm ran the plate to 1.3 s");
    let statics = static_case(&ROWS[4], 0.25, [0.0, 0.0], [4.0, 1.0], ROLLERS);
    assert!(statics.spec.warning(&statics).is_none());
}

/// The closed-form first period of `cases/bar-mode.toml`: T = 4 L/c, L = 2 m, c =
/// sqrt(E/ρ) with E = 1.7e7 Pa and ρ = 1100 kg/m³.
fn bar_period() -> f64 {
    4.0 * 2.0 / (1.7e7_f64 / 1100.0).sqrt()
}

/// The bar of `cases/bar-mode.toml` released in its first axial mode, run by `method`
/// with the `overrides` at spacing `dx` to 1.25 closed-form periods: the relative error
/// of its first period, the time of the tip's second pass through u_x = 0 (upwards,
/// linear between the rows around it, which are T/1300 apart).
fn bar_period_error(method: &str, overrides: &[&str], dx: f64) -> f64 {
    let period = bar_period();
    let mut all = vec![
        format!("method.name={method}"),
        format!("spacing={dx}"),
        format!("run.end_time={}", 1.25 * period),
        "output.check=".into(),
    ];
    all.extend(overrides.iter().map(|s| s.to_string()));
    let case = crate::common::load("bar-mode", &all);
    let dir = tempfile::tempdir().unwrap();
    meshless::run::run(&case, &crate::common::cpu_options(dir.path(), false))
        .unwrap_or_else(|e| panic!("{method} {overrides:?}: {e}"));
    let tip =
        meshless::output::series::read_column(&dir.path().join("series.csv"), "tip.ux").unwrap();
    let crossing = tip
        .windows(2)
        .find(|w| w[0].0 > 0.5 * period && w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].1 / (w[0].1 - w[1].1))
        .unwrap_or_else(|| panic!("{method} {overrides:?}: the tip did not come back"));
    crossing / period - 1.0
}

/// A row of the dynamic column: a method, the keys it needs (the Jaumann-rate methods
/// read the hypoelastic model), its documented order and the bound on the period's
/// error at Δx = 0.025 m: 1.5 times the error measured there (docs/verification.md).
struct PeriodRow {
    method: &'static str,
    keys: &'static [&'static str],
    order: f64,
    bound: f64,
}

const HYPOELASTIC: &[&str] = &["material.model=hypoelastic"];

/// Every explicit method but ul-weak-form (whose period does not converge, a finding:
/// `ul_weak_forms_period_converges`), with its defaults. The collocation methods (the
/// TLSPH family, the mixed methods, Gray–Monaghan, Godunov) are first order at the
/// bar's clamped and free ends, SUPG-SPH below it; KBM is first order (docs/methods/seed001.md); the
/// Galerkin methods with cell quadrature are second order.
const PERIOD_ROWS: [PeriodRow; 13] = [
    PeriodRow {
        method: "tlsph",
        keys: &[],
        order: 1.0,
        bound: 7.7e-3,
    },
    PeriodRow {
        method: "upwind-sph",
        keys: &[],
        order: 1.0,
        bound: 7.5e-3,
    },
    PeriodRow {
        method: "jst-sph",
        keys: &[],
        order: 1.0,
        bound: 7.4e-3,
    },
    // SUPG-SPH's own order, measured 0.75 on Δx = 0.05, 0.025 and 0.0125 m (errors 7.76e-3,
    // 4.62e-3, 2.76e-3), below the first order of the other collocation methods: its τ_p
    // and ξ_F terms act in the boundary layers (docs/methods/mixed.md "SUPG-SPH").
    PeriodRow {
        method: "supg-sph",
        keys: &[],
        order: 0.75,
        bound: 6.9e-3,
    },
    PeriodRow {
        method: "tl-potential",
        keys: &[],
        order: 1.0,
        bound: 7.7e-3,
    },
    PeriodRow {
        method: "corotated-tlsph",
        keys: &[],
        order: 1.0,
        bound: 7.7e-3,
    },
    PeriodRow {
        method: "gray-monaghan-sph",
        keys: HYPOELASTIC,
        order: 1.0,
        bound: 0.11,
    },
    PeriodRow {
        method: "godunov-sph",
        keys: HYPOELASTIC,
        order: 1.0,
        bound: 0.153,
    },
    PeriodRow {
        method: "tl-weak-form",
        keys: &[],
        order: 2.0,
        bound: 7.5e-4,
    },
    PeriodRow {
        method: "tl-fem",
        keys: &[],
        order: 2.0,
        bound: 2.5e-5,
    },
    PeriodRow {
        method: "ul-fem",
        keys: &[],
        order: 2.0,
        bound: 2.5e-5,
    },
    PeriodRow {
        method: "kbm",
        keys: &[],
        order: 1.0,
        bound: 2.4e-2,
    },
    PeriodRow {
        method: "efg",
        keys: &[],
        order: 2.0,
        bound: 3.5e-4,
    },
];

#[test]
fn every_explicit_method_converges_to_the_bars_closed_form_period() {
    // The error at Δx = 0.025 m under its row's bound (1.5 times the one measured, so that
    // a change that adds half the error fails) and the observed order from Δx = 0.05 m at
    // least 0.8 of the row's (issue 47's rule); every error is positive: each
    // discretisation is softer than the continuum at the bar's ends.
    let mut failures = Vec::new();
    for row in &PERIOD_ROWS {
        let coarse = bar_period_error(row.method, row.keys, 0.05);
        let fine = bar_period_error(row.method, row.keys, 0.025);
        let order = (coarse / fine).log2();
        let line = format!(
            "{}: period error {coarse:.3e} → {fine:.3e}, order {order:.2}",
            row.method
        );
        eprintln!("{line}");
        if fine <= 0.0 || fine > row.bound || order < 0.8 * row.order {
            failures.push(line);
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
#[ignore = "finding: docs/verification.md, \"ul-weak-form's period\""]
fn ul_weak_forms_period_converges() {
    // The claim every other explicit method meets: the period converges at 0.8 of first
    // order or better. ul-weak-form's default velocity smoothing takes 73 % of the bar's
    // energy in two periods, and its error falls from 1.07e-2 at Δx = 0.05 m to only
    // 7.2e-3 at 0.025 m (order 0.57).
    let coarse = bar_period_error("ul-weak-form", HYPOELASTIC, 0.05);
    let fine = bar_period_error("ul-weak-form", HYPOELASTIC, 0.025);
    let order = (coarse / fine).log2();
    assert!(
        order >= 0.8,
        "period error {coarse:.3e} → {fine:.3e}, order {order:.2}"
    );
}

#[test]
fn dual_support_sph_has_no_dynamic_path_and_says_so() {
    // The matrix's dynamic cell of the one static-only method: the bar is refused with
    // the reason, and its static rows stand for it.
    let overrides = [
        "method.name=dual-support-sph".to_string(),
        "output.check=".into(),
    ];
    let error = meshless::scene::Scene::load(&crate::common::case_file("bar-mode"), &overrides)
        .unwrap_err()
        .to_string();
    assert!(error.contains("is static"), "{error}");
}
