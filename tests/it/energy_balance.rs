//! The energy balance of every explicit method (src/diagnostics/balance.rs),
//! E_kin + E_stored + D_art + W_hg + W_p + E_contact − W_ext = E_0, its residue over its
//! scale, on a strip pulled at one end and clamped at the other and on a free bar released
//! with a velocity field, at two steps; a plastic strip whose balance needs its plastic
//! work; the hourglass control's work. docs/verification.md ("The energy balance") has the
//! measured residues.

use crate::common::material_and_method;
use meshless::core::tensor::D2;
use meshless::diagnostics::balance::{Balance, Booked};
use meshless::methods::REGISTRY;
use meshless::run::{Backend, Engine, engine};
use meshless::scene::Scene as Case;
use std::path::Path;

/// The strip and the bar: 1 m × 0.2 m at Δx = 0.05 m (21 × 5 particles), E = 1 MPa,
/// ν = 0.3, ρ0 = 1000 kg/m³ (c_p = 36.7 m/s, Δx/c_p = 1.36 ms), over 40 ms (1.5 transits
/// of the p-wave).
const END: f64 = 0.04;
/// The larger step [s] (c_p Δt/Δx = 0.15) and the smaller, half of it.
const DT: f64 = 2.0e-4;

/// The two scenes.
#[derive(Clone, Copy, Debug)]
enum Scene {
    /// Clamped at x = 0, the column at x = 1 m pulled at 0.02 m/s ramped up over 20 ms.
    Driven,
    /// Free, released with v_x = A cos(πx), v_y = A/2 sin(2πx), A = 0.02 m/s.
    Released,
}

/// The material of a method: neo-Hookean, or hypoelastic for the updated-Lagrangian
/// methods that integrate a stress rate (their only model).
fn model(method: &str) -> &'static str {
    match method {
        "gray-monaghan-sph" | "godunov-sph" | "ul-weak-form" | "ul-fem" => "hypoelastic",
        _ => "neo-hookean",
    }
}

/// The method's keys besides its defaults: the artificial viscosity on for the methods
/// that have one (α = β = 1), so that its dissipation is booked; run in time.
fn keys(method: &str) -> &'static str {
    match method {
        "tlsph" | "tl-potential" | "corotated-tlsph" | "gray-monaghan-sph" => {
            "artificial_viscosity = { alpha = 1.0, beta = 1.0, eta = 0.1 }"
        }
        _ => "",
    }
}

/// The case text of `scene` with `method` and `tables` (material and method) at step
/// `dt`.
fn case_text(scene: Scene, tables: &str, extra: &str, dt: f64) -> Case {
    let (velocity, boundaries) = match scene {
        Scene::Driven => (
            "",
            r#"
[[boundary]]
region = { x_max = 0.0 }
condition = { type = "fixed" }
[[boundary]]
region = { x_min = 1.0 }
condition = { type = "velocity", vx = 0.02, law = { type = "ramp", duration = 0.02 } }"#,
        ),
        Scene::Released => (
            r#"initial_velocity = { type = "expression", vx = "A*cos(k*x)", vy = "0.5*A*sin(2*k*x)", constants = { A = 0.02, k = 3.141592653589793 } }"#,
            "",
        ),
    };
    let text = format!(
        r#"
name = "energy-balance"
dimension = 2
spacing = 0.05
{tables}
{extra}
[[body]]
name = "strip"
geometry = {{ shape = "box", min = [0.0, 0.0], max = [1.0, 0.2] }}
{velocity}
{boundaries}
[run]
end_time = {END}
solve = "dynamic"
"#
    );
    let set = [format!("method.dt={dt:e}")];
    Case::from_toml(&text, Path::new("energy-balance.toml"), &set).unwrap_or_else(|e| panic!("{e}"))
}

/// The case of a registry method in `scene` at step `dt`.
fn case(method: &str, scene: Scene, dt: f64) -> Case {
    case_text(
        scene,
        &material_and_method(model(method), method),
        keys(method),
        dt,
    )
}

/// What a run gives: the largest |energy_residue| over ten samples, and the terms booked at
/// the end with the end's balance.
struct Measured {
    error: f64,
    end: Balance,
}

/// Runs a case on the CPU in ten batches, taking the balance after each.
fn measure(case: &Case, dt: f64) -> Measured {
    let mut e = engine::<D2>(case, Backend::Cpu).unwrap_or_else(|e| panic!("{e}"));
    let e0 = e.invariants().total_energy();
    let steps = (END / dt).round() as u32;
    let mut error = 0.0f64;
    let mut end = None;
    for k in 0..10 {
        let (from, to) = (k * steps / 10, (k + 1) * steps / 10);
        e.advance(f64::from(from) * dt, dt, to - from)
            .unwrap_or_else(|f| panic!("{}: {}", case.method.name, f.cause));
        let balance = balance_of(&mut *e, e0);
        error = error.max(balance.relative_residue().abs());
        end = Some(balance);
    }
    Measured {
        error,
        end: end.expect("ten batches"),
    }
}

/// The balance of an engine's current state, from E_0 = `e0`.
fn balance_of(e: &mut dyn Engine<D2>, e0: f64) -> Balance {
    let inv = e.invariants();
    Balance {
        kinetic: inv.kinetic,
        stored: inv.strain,
        booked: e.booked(),
        e0,
    }
}

/// The explicit methods whose residue is not the integrator's (docs/verification.md, "The
/// energy balance"): Gray–Monaghan and Godunov SPH (their velocity gradient and their
/// momentum equation are not work-conjugate, and their hypoelastic stored energy is the
/// complementary energy of its linearisation), KBM (a Petrov–Galerkin force is not the
/// gradient of its stored energy) and the updated-Lagrangian FEM (the hypoelastic stored
/// energy again: a floor of 1.1e-4 on the released bar).
const NOT_CLOSED: [&str; 4] = ["gray-monaghan-sph", "godunov-sph", "kbm", "ul-fem"];

/// The residues of a method on both scenes at Δt and Δt/2, printed; the scenes whose
/// residue does not shrink with Δt at first order at least.
fn open_scenes(method: &str) -> Vec<String> {
    let mut open = Vec::new();
    for scene in [Scene::Driven, Scene::Released] {
        let coarse = measure(&case(method, scene, DT), DT);
        let fine = measure(&case(method, scene, DT / 2.0), DT / 2.0);
        let order = (coarse.error / fine.error).log2();
        let b = fine.end.booked;
        eprintln!(
            "{method:18} {scene:?}: residue {:.2e} (Δt) {:.2e} (Δt/2), order {order:.2}; \
             E_kin {:.3e} E_stored {:.3e} W_ext {:.3e} D {:.3e} W_hg {:.3e} W_p {:.3e}",
            coarse.error,
            fine.error,
            fine.end.kinetic,
            fine.end.stored,
            b.external_work,
            b.dissipated.unwrap_or(f64::NAN),
            b.hourglass_work.unwrap_or(f64::NAN),
            b.plastic_work.unwrap_or(f64::NAN),
        );
        // Halving Δt must divide a residue of first order by more than 2^(1 − ½) = 1.41
        // (half an order of slack for the steps before the asymptotic range); a residue
        // at round-off (1e-10 of the scale) cannot shrink further.
        if fine.error > 1e-10 && order < 0.5 {
            open.push(format!("{method} {scene:?}: order {order:.2}"));
        }
    }
    open
}

#[test]
fn every_explicit_method_closes_its_energy_balance() {
    // Each method on both scenes at Δt and Δt/2, with every term it has booked. The
    // balance is exact but for the integrator and the booking: the powers are those of the
    // last rate evaluation of each step (RK4's fourth stage, not the step's end state),
    // integrated by the trapezoidal rule, so the residue is at least first order in Δt
    // over a run (measured: order 1.0 on the released bar with viscosity, where the
    // power's lag dominates, 2.0 on the driven strip, 2 to 5 without dissipation). The
    // bound is that order: halving Δt must shrink the residue. A term left out (or booked
    // with a wrong sign or factor) leaves its own size in the residue, which does not
    // shrink with Δt: the booked dissipation is 0.1 % (JST, driven) to 84 % (the weak
    // form's smoothing, released) of the scale S here, W_hg 0.2 to 0.3 % (dual-support).
    let open: Vec<String> = REGISTRY
        .iter()
        .map(|e| e.name)
        .filter(|m| !NOT_CLOSED.contains(m))
        .flat_map(open_scenes)
        .collect();
    assert!(open.is_empty(), "{open:#?}");
}

#[test]
#[ignore = "finding: docs/verification.md, The energy balance (residues of 1e-4 to 0.26 that do not shrink with Δt)"]
fn the_energy_balance_closes_for_the_remaining_methods() {
    // The same requirement for the methods of NOT_CLOSED. Measured (Δt, Δt/2): Gray–
    // Monaghan 0.260, 0.260 (driven) and 0.088, 0.089 (released); Godunov 0.151, 0.151 and
    // 0.052, 0.052; KBM 0.121, 0.121 and 5.1e-3, 5.1e-3; UL FEM 5.2e-4, 1.5e-4 and 1.14e-4,
    // 1.14e-4.
    let open: Vec<String> = NOT_CLOSED.into_iter().flat_map(open_scenes).collect();
    assert!(open.is_empty(), "{open:#?}");
}

/// Seed 003's copper: von Mises, E = 117 GPa, ν = 0.35, τ_y = 0.4 GPa, H = 0.1 GPa,
/// ρ0 = 8930 kg/m³ (c_p = 4.6 km/s).
const SEED_003_COPPER: &str = r#"model = "von-mises-plastic"
density = 8930.0
youngs_modulus = 117.0e9
poisson_ratio = 0.35
yield_stress = 0.4e9
hardening_modulus = 0.1e9"#;

/// Johnson and Cook's OFHC copper (1983, Table 1) with adiabatic heating, E and ν of
/// `taylor-bar-johnson-cook.toml`.
const JOHNSON_COOK_COPPER: &str = r#"model = "von-mises-plastic"
density = 8960.0
youngs_modulus = 124.0e9
poisson_ratio = 0.34
yield_stress = 90.0e6
hardening_modulus = 292.0e6
hardening_exponent = 0.31
strain_rate_coefficient = 0.025
thermal_softening_exponent = 1.09
melting_temperature = 1356.0
specific_heat = 383.0"#;

/// The plastic strip of `material`, pulled at 20 m/s (ramped over 0.1 ms) for 0.4 ms:
/// 0.8 % extension, past the yield strain of seed 003's copper (0.34 %) and of Johnson
/// and Cook's (0.07 %).
fn plastic_strip(method: &str, dt: f64, (material, integrator): (&str, &str)) -> Case {
    let kernel = match method {
        "tlsph" => "\nh_over_dx = 1.3",
        _ => "",
    };
    let tables = format!(
        r#"[material]
{material}
[method]
name = "{method}"
integrator = "{integrator}"
dt = {dt:e}{kernel}"#
    );
    let text = format!(
        r#"
name = "plastic-strip"
dimension = 2
spacing = 0.05
{tables}
[[body]]
name = "strip"
geometry = {{ shape = "box", min = [0.0, 0.0], max = [1.0, 0.2] }}
[[boundary]]
region = {{ x_max = 0.0 }}
condition = {{ type = "fixed" }}
[[boundary]]
region = {{ x_min = 1.0 }}
condition = {{ type = "velocity", vx = 20.0, law = {{ type = "ramp", duration = 1.0e-4 }} }}
[run]
end_time = 4.0e-4
"#
    );
    Case::from_toml(&text, Path::new("plastic-strip.toml"), &[]).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_plastic_work_closes_the_balance_of_a_yielding_strip() {
    // tl-fem (history at the Gauss points) and TLSPH (at the particles) on the copper strip
    // at Δt = 2 µs and 1 µs (c_p Δt/Δx = 0.18, 0.09). The plastic work W_p = Σ w_q ∫ τ_y
    // dε̄_p is booked at every commit of the history and for the current step; the return's
    // potential makes it exact but for the integrator's error (src/physics/plasticity.rs),
    // so the residue shrinks at first order at least (measured 7.9e-4 → 3.9e-4 and 9.4e-4
    // → 4.6e-4) and stays far below W_p (W_p/S = 0.33 and 0.38): leaving W_p out leaves a
    // residue of W_p/S itself, which must exceed tenfold the residue with it at Δt.
    let dt = 2.0e-6;
    for method in ["tl-fem", "tlsph"] {
        plastic_balance(method, dt, (SEED_003_COPPER, "rk4"));
    }
}

#[test]
#[ignore = "finding: docs/materials.md, Johnson–Cook, \"Not yet\": the residue converges at order 0.4"]
fn the_plastic_work_closes_the_balance_under_johnson_cook() {
    // The same strip in Johnson and Cook's copper on tl-fem with `tvd-rk2`, whose stages
    // sit at the step's ends, where the implicit rate Δγ/Δt is the flow's
    // (src/physics/plasticity.rs): the work booked at the step's rate should close the
    // balance to first order in the step, under the same bounds. Measured: 1.80e-3 →
    // 1.36e-3 (order 0.41; W_p/S 0.49, residue without W_p 0.49), so the residue is 0.4 %
    // of the plastic work but does not yet shrink at first order.
    plastic_balance("tl-fem", 2.0e-6, (JOHNSON_COOK_COPPER, "tvd-rk2"));
}

/// [`the_plastic_work_closes_the_balance_of_a_yielding_strip`] under `method`.
fn plastic_balance(method: &str, dt: f64, material: (&str, &str)) {
    let (coarse, fine) = (
        measure_plastic(&plastic_strip(method, dt, material), dt),
        measure_plastic(&plastic_strip(method, dt / 2.0, material), dt / 2.0),
    );
    let b = fine.end.booked;
    let w_p = b.plastic_work.unwrap();
    let scale = fine.end.scale();
    let without = Balance {
        booked: Booked {
            plastic_work: Some(0.0),
            ..b
        },
        ..fine.end
    };
    eprintln!(
        "plastic strip, {method}: residue {:.2e} (Δt) {:.2e} (Δt/2); W_p/S {:.2e}, residue \
         without W_p {:.2e}",
        coarse.error,
        fine.error,
        w_p / scale,
        without.relative_residue()
    );
    assert!(w_p > 0.0, "{method}: the strip must yield: W_p = {w_p:e}");
    assert!(
        (coarse.error / fine.error).log2() > 0.5,
        "{} vs {}",
        coarse.error,
        fine.error
    );
    assert!(
        without.relative_residue().abs() > 10.0 * coarse.error,
        "without W_p {:e}, with {:e}",
        without.relative_residue(),
        coarse.error
    );
}

/// [`measure`] over the plastic strip's end time.
fn measure_plastic(case: &Case, dt: f64) -> Measured {
    let mut e = engine::<D2>(case, Backend::Cpu).unwrap_or_else(|e| panic!("{e}"));
    let e0 = e.invariants().total_energy();
    let steps = (case.run.end_time / dt).round() as u32;
    let mut error = 0.0f64;
    let mut end = None;
    for k in 0..10 {
        let (from, to) = (k * steps / 10, (k + 1) * steps / 10);
        e.advance(f64::from(from) * dt, dt, to - from).unwrap();
        let balance = balance_of(&mut *e, e0);
        error = error.max(balance.relative_residue().abs());
        end = Some(balance);
    }
    Measured {
        error,
        end: end.expect("ten batches"),
    }
}

#[test]
fn the_hourglass_control_books_its_work() {
    // TLSPH with Ganzenmüller's hourglass control (α = 0.1, no viscosity) and dual-support
    // SPH's hourglass energy (its default, factor 1), on the released bar: the hourglass
    // forces do work (measured W_hg/S = 8.3e-5 and 3.3e-3), and the balance with it closes
    // at first order in Δt at least (residues 5.4e-8 → 5.4e-9 and 2.4e-6 → 5.9e-7).
    for (method, extra) in [("tlsph", "hourglass = 0.1"), ("dual-support-sph", "")] {
        let tables = material_and_method("neo-hookean", method);
        let (coarse, fine) = (
            measure(&case_text(Scene::Released, &tables, extra, DT), DT),
            measure(
                &case_text(Scene::Released, &tables, extra, DT / 2.0),
                DT / 2.0,
            ),
        );
        let w_hg = fine.end.booked.hourglass_work.unwrap();
        eprintln!(
            "{method}: W_hg/S {:.2e}, residue {:.2e} (Δt) {:.2e} (Δt/2)",
            w_hg / fine.end.scale(),
            coarse.error,
            fine.error
        );
        // Without W_hg the residue would be W_hg/S: it must exceed tenfold the residue
        // with it, which must shrink at first order at least.
        assert!(
            w_hg.abs() / fine.end.scale() > 10.0 * coarse.error,
            "{method}: W_hg {w_hg:e}"
        );
        assert!((coarse.error / fine.error).log2() > 0.5, "{method}");
    }
}
