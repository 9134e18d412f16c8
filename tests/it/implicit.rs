//! Implicit dynamics (`run.solve = "implicit"`, `statics::newmark`) on the static path's
//! residual and tangent: the cantilever of `cases/cantilever-mode.toml` released in its
//! first bending mode, linear elastic (f_int linear in u and −∂Π/∂u under the variational
//! TLSPH force), at time steps hundreds of times the explicit CFL step. The scheme's own
//! closed forms (energy, order, spectral radius) are checked on an oscillator in
//! `statics::newmark`.

use crate::common::{load, nearest};
use meshless::core::tensor::D2;
use meshless::run::{Backend, Engine, engine};
use meshless::scene::Scene;

/// The cantilever at Δx = 0.04 (5 particles through the depth), linear elastic, with
/// `solve` and the further overrides.
fn cantilever(solve: &[&str]) -> Scene {
    let mut set = vec![
        "spacing=0.04",
        "material.model=\"linear-elastic\"",
        "output.check=[]",
    ];
    set.extend_from_slice(solve);
    load("cantilever-mode", &set)
}

/// The tip's u_y after each of `steps` steps of dt, the largest |E/E0 − 1| of the total
/// energy over them and its last E/E0 − 1.
fn run(case: &Scene, dt: f64, steps: u32) -> (Vec<f64>, f64, f64) {
    let mut e = engine::<D2>(case, Backend::Cpu).unwrap();
    let tip = nearest(e.snapshot().x0, [2.0, 0.0]);
    let e0 = e.invariants().total_energy();
    let (mut tip_uy, mut drift, mut last) = (Vec::new(), 0.0f64, 0.0);
    for k in 0..steps {
        e.advance(f64::from(k) * dt, dt, 1).unwrap();
        tip_uy.push(e.snapshot().u[tip].y);
        last = e.invariants().total_energy() / e0 - 1.0;
        drift = drift.max(last.abs());
    }
    (tip_uy, drift, last)
}

/// The implicit case with Δt = dt and HHT's α.
fn implicit(dt: f64, alpha: f64) -> Scene {
    cantilever(&[
        "run.solve=\"implicit\"",
        &format!("run.hht_alpha={alpha}"),
        "method.cfl=",
        &format!("method.dt={dt}"),
        "method.integrator=",
    ])
}

#[test]
fn newmark_keeps_the_energy_of_a_free_vibration_at_steps_far_past_the_cfl_limit() {
    // The period is about 1.2 s at this spacing (the case's notes); the explicit CFL
    // step is 0.3 Δx/c_p ≈ 9.2e-5 s (c_p ≈ 130 m/s). Newmark's average acceleration at
    // Δt = 0.024 s (T/50, about 260 CFL steps) conserves ½vᵀMv + Π(u) of a linear system
    // exactly: what is left is Newton's (one iteration solves the linear G to the
    // round-off of the finite-difference tangent, which the next makes ~1e-11 of the
    // force). Bound 1e-6 over 50 steps.
    let dt = 0.024;
    let (tip, drift, _) = run(&implicit(dt, 0.0), dt, 50);
    eprintln!("Newmark Δt = {dt} s: max |E/E0 − 1| = {drift:e}");
    assert!(drift < 1e-6, "max |E/E0 − 1| = {drift:e}");
    // The tip swings: it goes up and comes back through zero within the 1.2 s.
    let (peak, last) = (tip.iter().copied().fold(0.0, f64::max), tip[tip.len() - 1]);
    assert!(
        peak > 1e-2 && last < 0.5 * peak,
        "tip u_y peak {peak:e}, last {last:e}"
    );
}

#[test]
fn implicit_steps_converge_at_second_order_to_the_explicit_run() {
    // The tip's u_y at t = 0.48 s (in the first half period, near its peak) under
    // Newmark and HHT (α = −0.1) at Δt = 0.048, 0.024 and 0.012 s against an RK4 run at
    // Δt = 8e-5 s (CFL 0.26; time error ~1e-12 of it): the difference falls by about 4 per halving
    // (order 2; bound: each ratio in [3, 5]).
    let explicit = cantilever(&[]);
    let mut e = engine::<D2>(&explicit, Backend::Cpu).unwrap();
    let tip = nearest(e.snapshot().x0, [2.0, 0.0]);
    let dt_explicit = 0.48 / 6000.0;
    e.advance(0.0, dt_explicit, 6000).unwrap();
    let reference = e.snapshot().u[tip].y;
    for alpha in [0.0, -0.1] {
        let errors: Vec<f64> = [0.048f64, 0.024, 0.012]
            .map(|dt| {
                let steps = (0.48 / dt).round() as u32;
                let (tip_uy, ..) = run(&implicit(dt, alpha), dt, steps);
                (tip_uy[tip_uy.len() - 1] - reference).abs()
            })
            .to_vec();
        eprintln!("α = {alpha}: |Δu_tip| at 0.48 s = {errors:?} of {reference:e}");
        for pair in errors.windows(2) {
            let ratio = pair[0] / pair[1];
            assert!(
                (3.0..5.0).contains(&ratio),
                "α = {alpha}: ratio {ratio} from {errors:?}"
            );
        }
    }
}

#[test]
fn dual_support_sph_keeps_the_energy_on_its_assembled_tangent() {
    // Dual-support SPH (seed 004) on the same cantilever: its closed-form tangent
    // (sparse Cholesky) with the mass added. Without hourglass control its force is
    // −∂Π/∂u of Π = Σ V ψ alone, linear in u for the linear-elastic model, so Newmark at
    // Δt = T/50 keeps ½vᵀMv + Π to Newton's tolerance (bound 1e-6 over 50 steps), and
    // HHT's α = −0.1 takes energy out (its numerical damping; measured: Newmark 1.4e-13,
    // HHT a loss of 5.4e-3 over the 1.2 s; bound: a loss of at least 1e-3).
    let case = |alpha: f64| {
        let mut set = vec![
            "method.name=\"dual-support-sph\"",
            "method.force=",
            "method.correction=",
            "method.hourglass=0",
        ];
        let alpha = format!("run.hht_alpha={alpha}");
        set.extend([
            "run.solve=\"implicit\"",
            alpha.as_str(),
            "method.cfl=",
            "method.dt=0.024",
            "method.integrator=",
        ]);
        cantilever(&set)
    };
    let (tip, drift, _) = run(&case(0.0), 0.024, 50);
    eprintln!("dual-support, Newmark: max |E/E0 − 1| = {drift:e}");
    assert!(drift < 1e-6, "max |E/E0 − 1| = {drift:e}");
    let peak = tip.iter().copied().fold(0.0, f64::max);
    assert!(peak > 1e-2, "tip u_y peak {peak:e}");
    let (.., hht) = run(&case(-0.1), 0.024, 50);
    eprintln!("dual-support, HHT α = −0.1: E/E0 − 1 = {hht:e} at 1.2 s");
    assert!(hht < -1e-3, "HHT's damping: E/E0 − 1 = {hht:e}");
}

#[test]
fn a_free_body_runs_implicitly_and_keeps_its_momentum() {
    // Without the clamp the static stiffness is singular under the rigid motions, which the
    // static solve refuses; an implicit step's M/(β Δt²) holds them. The variational
    // force's pairs are equal and opposite, so Σ f_int = 0 and Newmark keeps Σ m v: the
    // first mode's velocity field (net momentum 16.8 kg m/s; measured change 5e-15) is kept to Newton's tolerance
    // over 20 steps of T/50 (bound 1e-8 of Σ m |v|).
    let case = implicit(0.024, 0.0);
    let free = Scene::from_toml(
        &std::fs::read_to_string(&case.file).unwrap(),
        &case.file,
        &[
            case.overrides.clone(),
            vec!["boundary=[]".to_string(), "probe=[]".to_string()],
        ]
        .concat(),
    )
    .unwrap();
    let mut e = engine::<D2>(&free, Backend::Cpu).unwrap();
    let momentum = |e: &mut Box<dyn Engine<D2>>| {
        let s = e.snapshot();
        let total =
            s.v.iter()
                .zip(s.mass)
                .fold(glam::DVec2::ZERO, |p, (&v, &m)| p + v * m);
        let size: f64 = s.v.iter().zip(s.mass).map(|(v, m)| v.length() * m).sum();
        (total, size)
    };
    let (p0, size) = momentum(&mut e);
    e.advance(0.0, 0.024, 20).unwrap();
    let (p, _) = momentum(&mut e);
    eprintln!("free body: Σ m v from {p0} to {p} (Σ m |v| = {size:e})");
    assert!((p - p0).length() < 1e-8 * size, "Σ m v: {p0} → {p}");
}
