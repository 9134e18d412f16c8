//! Prescribed velocities under a time law and with a release time (`law`, `until` of a
//! `velocity` condition): the held components against the law's closed form, the work the
//! supports book, the refusals, and the GPU against the CPU.

use meshless::boundary::TimedVelocity;
use meshless::case::TimeLaw;
use meshless::core::tensor::D2;
use meshless::run::{Backend, Engine, engine};
use meshless::scene::Scene;
use std::path::Path;

/// A plane-stress linear-elastic bar 1 m × 0.2 m (E = 1e6 Pa, ν = 0.3, ρ0 = 1000: c =
/// √(E/ρ0) = 31.6 m/s) on the vertex lattice of Δx = 0.05 (21 × 5 particles), its left
/// column driven along x by `left` (the condition's keys after `vx`) and its right column
/// along y by `right`, `integrator` at Δt = 5e-4 s (a third of Δx/c_p); `method` is the
/// `[method]` table's name and keys.
fn bar(method: &str, integrator: &str, left: &str, right: &str) -> Scene {
    Scene::from_toml(
        &bar_text(method, integrator, left, right),
        Path::new("driven-bar.toml"),
        &[],
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// The text of [`bar`].
fn bar_text(method: &str, integrator: &str, left: &str, right: &str) -> String {
    format!(
        r#"
name = "driven-bar"
dimension = 2
spacing = 0.05
[material]
model = "linear-elastic"
density = 1000.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
plane = "stress"
[method]
{method}
integrator = "{integrator}"
dt = 5.0e-4
[[body]]
name = "bar"
geometry = {{ shape = "box", min = [0.0, 0.0], max = [1.0, 0.2], volumes = "tributary" }}
[[boundary]]
region = {{ x_max = 0.0 }}
condition = {{ type = "velocity", vx = {left} }}
[[boundary]]
region = {{ x_min = 1.0 }}
condition = {{ type = "velocity", vy = {right} }}
[run]
end_time = 1.0
"#
    )
}

const TLSPH: &str = "name = \"tlsph\"\nh_over_dx = 1.3\ncorrection = \"randles-libersky\"";

/// The left column's x velocity law: 0.2 m/s ramped over 0.3 s, held to 0.6 s, then free.
const RAMPED: &str = "0.2, law = { type = \"ramp\", duration = 0.3 }, until = 0.6";
/// The right column's y velocity: 0.05 m/s until 0.4 s, then free.
const RELEASED: &str = "0.05, until = 0.4";

/// The particles of the left (x = 0) and right (x = 1) columns.
fn columns(x0: &[glam::DVec2]) -> (Vec<usize>, Vec<usize>) {
    let at = |x: f64| {
        (0..x0.len())
            .filter(|&i| (x0[i].x - x).abs() < 1e-9)
            .collect()
    };
    (at(0.0), at(1.0))
}

#[test]
fn the_laws_over_a_step_end_on_their_values() {
    // The mean rate over a step, held through it, ends every step on law(t + Δt) from
    // law(t), for every law, a table's jump included; the release falls on the first step
    // whose middle is at or after `until`. Round-off of the differences: 1e-12.
    let laws = [
        TimeLaw::Ramp { duration: 0.3 },
        TimeLaw::Exponential {
            tau: 0.2,
            start: 0.1,
        },
        TimeLaw::Table {
            points: vec![[0.0, 0.0], [0.2, 1.0], [0.2, -0.5], [0.5, 0.25]],
        },
    ];
    let dt = 0.01;
    for law in laws {
        let timed = TimedVelocity {
            law: law.clone(),
            until: Some(0.455),
        };
        let mut value = law.at(0.0);
        for k in 0..60 {
            let t = f64::from(k) * dt;
            match timed.over_step(t, dt) {
                Some(step) => {
                    assert!(t + 0.5 * dt < 0.455, "{law:?}: held at t = {t}");
                    value += step.rate * dt;
                    assert!((value - law.at(t + dt)).abs() < 1e-12, "{law:?}: t = {t}");
                    assert_eq!(step.value, law.at(t + dt));
                }
                None => assert!(t + 0.5 * dt >= 0.455, "{law:?}: released at t = {t}"),
            }
        }
    }
    assert!(
        TimedVelocity {
            law: TimeLaw::Constant,
            until: None
        }
        .holds(1e9, 1.0)
    );
}

#[test]
fn a_ramped_and_a_released_velocity_follow_their_closed_forms_on_the_cpu() {
    // RK4 at Δt = 5e-4 s: the ramp's kinks (0.3 s) and the releases (0.4 and 0.6 s) fall on
    // step boundaries, so the held components are the closed form to round-off at every
    // step: v_x = 0.2 min(t/0.3, 1), u_x = 0.2 (t²/0.6) before 0.3 s and 0.2 (t − 0.15)
    // after (RK4 integrates the velocity, linear over each step, exactly); v_y = 0.05, u_y =
    // 0.05 t on the right. Bound 1e-12 m/s and 1e-12 m.
    let case = bar(TLSPH, "rk4", RAMPED, RELEASED);
    let mut e = engine::<D2>(&case, Backend::Cpu).unwrap();
    let (left, right) = columns(e.reference());
    let dt = 5e-4;
    let ramp = |t: f64| 0.2 * (t / 0.3).min(1.0);
    let ramp_u = |t: f64| {
        if t <= 0.3 {
            0.2 * t * t / 0.6
        } else {
            0.2 * (t - 0.15)
        }
    };
    let mut t = 0.0;
    for _ in 0..8 {
        // 100 steps a batch, to t = 0.4 s.
        e.advance(t, dt, 100).unwrap();
        t += 100.0 * dt;
        let snap = e.snapshot();
        for &i in &left {
            assert!(
                (snap.v[i].x - ramp(t)).abs() < 1e-12,
                "t = {t}: v_x {}",
                snap.v[i].x
            );
            assert!(
                (snap.u[i].x - ramp_u(t)).abs() < 1e-12,
                "t = {t}: u_x {}",
                snap.u[i].x
            );
        }
        for &i in &right {
            assert!(
                (snap.v[i].y - 0.05).abs() < 1e-12,
                "t = {t}: v_y {}",
                snap.v[i].y
            );
            assert!(
                (snap.u[i].y - 0.05 * t).abs() < 1e-12,
                "t = {t}: u_y {}",
                snap.u[i].y
            );
        }
    }
    // Free from 0.4 s: the right column, bent back by the bar, leaves 0.05 m/s (by 0.1 m/s
    // and more within 0.1 s here; a held one stays at 0.05 to round-off).
    e.advance(t, dt, 200).unwrap();
    t += 200.0 * dt;
    let snap = e.snapshot();
    let leaves = right
        .iter()
        .map(|&i| (snap.v[i].y - 0.05).abs())
        .fold(0.0, f64::max);
    assert!(
        leaves > 1e-3,
        "the released column still at 0.05 m/s: {leaves:e}"
    );
    for &i in &left {
        assert!(
            (snap.v[i].x - 0.2).abs() < 1e-12,
            "t = {t}: v_x {}",
            snap.v[i].x
        );
    }
    // And the left from 0.6 s.
    e.advance(t, dt, 400).unwrap();
    let snap = e.snapshot();
    let leaves = left
        .iter()
        .map(|&i| (snap.v[i].x - 0.2).abs())
        .fold(0.0, f64::max);
    assert!(
        leaves > 1e-3,
        "the released column still at 0.2 m/s: {leaves:e}"
    );
}

#[test]
fn the_supports_book_the_work_they_do() {
    // Kinetic + strain energy against the work of the supports, Σ m (a_prescribed − a) v
    // over the held components integrated by the driver's rule: the work a wrong rate
    // would miss is ½ m v² of the driven columns and more (20 % of the energy here). RK4
    // on an elastic bar conserves energy over these 2,000 steps to the
    // truncation of the integrator and of the driver's work rule, the trapezoid of the
    // step powers) while the columns are held: within 3e-4 here. A release is a jump of
    // the reaction's power, of which the trapezoid misses up to half a step: the left
    // column's costs 2.2e-3 of the energy; bound 5e-3. TLSPH
    // without correction, whose pair forces derive from its strain energy (the
    // Randles–Libersky one does not conserve energy, spec §7.3 f).
    let method = "name = \"tlsph\"\nh_over_dx = 1.3\ncorrection = \"none\"";
    let case = bar(method, "rk4", RAMPED, RELEASED);
    let mut e = engine::<D2>(&case, Backend::Cpu).unwrap();
    let dt = 5e-4;
    // The right column starts at 0.05 m/s.
    let start = e.invariants().kinetic;
    for k in 0..20 {
        e.advance(f64::from(k) * 100.0 * dt, dt, 100).unwrap();
        let energy = e.invariants();
        let (stored, work) = (energy.kinetic + energy.strain - start, e.external_work());
        assert!(
            (stored - work).abs() < 5e-3 * work,
            "t = {}: energy {stored:e} J against the supports' work {work:e} J",
            f64::from(k + 1) * 100.0 * dt
        );
    }
}

#[test]
fn a_bad_law_or_release_names_its_key() {
    for (right, key, words) in [
        ("0.05, until = -1.0", "boundary.1.condition.until", "> 0"),
        (
            "0.05, law = { type = \"ramp\", duration = 0.0 }",
            "boundary.1.condition.law.duration",
            "> 0",
        ),
        (
            "0.05, law = { type = \"sine\" }",
            "unknown variant `sine`",
            "expected one of `constant`, `ramp`, `exponential`, `table`",
        ),
    ] {
        let text = bar_text(TLSPH, "rk4", RAMPED, right);
        let error = Scene::from_toml(&text, Path::new("bad.toml"), &[])
            .err()
            .unwrap_or_else(|| panic!("{right} accepted"))
            .to_string();
        assert!(
            error.contains(key) && error.contains(words) && error.contains("bad.toml"),
            "{right}: {error}"
        );
    }
    // The static path scales its loads by the load factor and refuses a law and a release.
    let method = "name = \"dual-support-sph\"\nh_over_dx = 2.0";
    let text = bar_text(method, "rk4", "0.0", RELEASED);
    let error = Scene::from_toml(&text, Path::new("static.toml"), &[])
        .expect_err("a release on the static path")
        .to_string();
    assert!(
        error.contains("boundary.1.condition") && error.contains("until"),
        "{error}"
    );
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_holds_ramps_and_releases_as_the_cpu() {
    // The bar with the ramped and the released column, 1,200 RK4 steps (to 0.6 s, both
    // releases in), on both backends for a method of each GPU engine: TLSPH (with its
    // `TlScheme`s), the Galerkin engine (KBM), the updated-Lagrangian core (Gray–Monaghan)
    // and the mixed one (upwind SPH). A release a step late on one backend would keep 0.05
    // m/s for 5e-4 s: 2.5e-5 m on a largest |u| of 0.1 m, 2.5e-4 of it, and a ramp
    // without its rate would leave u_x at 0 (all of it). f32 states over 1,200 steps:
    // ≤ 1e-5 of max |u| measured; bound 1e-4. The supports' work: the CPU's trapezoid
    // over every step against the GPU's over the 10 steps between its power reductions,
    // which misses up to 5 steps of the jump in the reaction's power at each release
    // (f32 sums of m a v besides): 1.4e-3 of it measured; bound 3e-3.
    let methods = [
        TLSPH,
        "name = \"kbm\"\nh_over_dx = 1.3",
        "name = \"gray-monaghan-sph\"\nh_over_dx = 1.3",
        "name = \"upwind-sph\"\nh_over_dx = 1.3",
    ];
    let (dt, steps) = (5e-4, 1200);
    for method in methods {
        // The updated-Lagrangian core integrates ρ and S: its material is hypoelastic.
        let text = bar_text(method, "rk4", RAMPED, RELEASED);
        let text = if method.contains("gray-monaghan") {
            text.replace("linear-elastic", "hypoelastic")
        } else {
            text
        };
        let case = Scene::from_toml(&text, Path::new("driven-bar.toml"), &[]).unwrap();
        let mut cpu = engine::<D2>(&case, Backend::Cpu).unwrap();
        let mut gpu = engine::<D2>(&case, Backend::Gpu).unwrap();
        // The GPU books the work by the trapezoidal rule between the reductions of its
        // power: one every 10 steps.
        let (mut work_cpu, mut work_gpu) = (0.0, 0.0);
        for k in (0..steps).step_by(10) {
            let t = f64::from(k) * dt;
            cpu.advance(t, dt, 10).unwrap();
            gpu.advance(t, dt, 10).unwrap();
            (work_cpu, work_gpu) = (cpu.external_work(), gpu.external_work());
        }
        let (du, largest) = crate::common::max_v::<D2>(&cpu.snapshot().u, &gpu.snapshot().u);
        eprintln!(
            "{}: max |Δu| = {du:e} of {largest:e} m; work {work_cpu:e} / {work_gpu:e} J",
            case.method.name
        );
        assert!(
            du < 1e-4 * largest,
            "{}: {du:e} of {largest:e}",
            case.method.name
        );
        assert!(
            (work_cpu - work_gpu).abs() < 3e-3 * work_cpu.abs(),
            "{}: work {work_cpu:e} against {work_gpu:e}",
            case.method.name
        );
    }
}
