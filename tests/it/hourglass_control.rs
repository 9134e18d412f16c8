//! TLSPH's hourglass control (`method.hourglass`, Ganzenmüller 2015): no force for affine
//! motion, equal, opposite and central pair forces, a checkerboard that nodal integration
//! does not resist held down, and the GPU pass against the CPU.

use glam::DVec2;
use meshless::core::integrate::OdeSystem;
use meshless::core::tensor::D2;
use meshless::methods::Method;
use meshless::methods::tlsph::{TlState, Tlsph};
use meshless::run::build_method;
use meshless::scene::Scene;
use std::path::Path;

/// TLSPH (Randles–Libersky, h/Δx = 1.3, RK4, Δt = 5e-4 s: 0.18 of Δx/c_p) on a free SVK
/// block [0, 1.6] × [0, 1.2] of 17 × 13 particles, E = 1e6 Pa, ρ0 = 1000.
fn block_source() -> String {
    let keys = "correction = \"randles-libersky\"\nintegrator = \"rk4\"";
    crate::common::block_text(&[1.6, 1.2], "saint-venant-kirchhoff", "tlsph", keys)
        .replace("dt = 1.0e-5", "dt = 5.0e-4")
}

/// The block with the `--set` overrides `set`.
fn block(set: &[&str]) -> Scene {
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    Scene::from_toml(&block_source(), Path::new("block.toml"), &set)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The block at rest but for the checkerboard v = v0 (−1)^(i+j) e_y under a smooth
/// envelope that vanishes on the boundary, v0 = 1e-3 m/s.
fn checkerboard(case: &Scene, m: &Tlsph<D2>) -> TlState<D2> {
    let mut y = m.initial_state();
    for (v, x) in y.v.iter_mut().zip(m.reference()) {
        let envelope =
            (std::f64::consts::PI * x.x / 1.6).sin() * (std::f64::consts::PI * x.y / 1.2).sin();
        let (i, j) = ((x.x / case.spacing).round(), (x.y / case.spacing).round());
        *v = DVec2::new(0.0, 1e-3 * (-1f64).powi((i + j) as i32) * envelope);
    }
    y
}

/// The largest hourglass indicator η after each of `steps` steps from the checkerboard.
fn checkerboard_eta(case: &Scene, steps: &[usize]) -> Vec<f64> {
    let mut m: Tlsph<D2> = build_method(case).unwrap();
    let y = checkerboard(case, &m);
    crate::common::hourglass_after(case, &mut m, y, steps, |m, y| {
        (y.u.clone(), m.deformation_gradient(y))
    })
}

#[test]
fn the_control_holds_down_a_checkerboard() {
    // In the interior the checkerboard leaves TLSPH's F at I (the odd neighbours' gradients
    // cancel in pairs), so nothing but the envelope's gradient resists it and its
    // displacement, and η with it, grows with time. The control (α = 10) gives the mode a
    // stiffness of order α E/(ρ0 Δx²), so it oscillates with an amplitude v0/ω.
    // η is sampled every 50 steps over 1,000 steps (0.5 s). Measured largest η: 4.7e-3
    // without the control, 2.3e-5 with it (1/200); bound 1/20.
    let steps: Vec<usize> = (1..=20).map(|k| 50 * k).collect();
    let peak = |case: &Scene| {
        let eta = checkerboard_eta(case, &steps);
        eta.iter().copied().fold(0.0, f64::max)
    };
    let free = peak(&block(&[]));
    let held = peak(&block(&["method.hourglass=10.0"]));
    eprintln!("largest η over 0.5 s: without control {free:e}, with α = 10 {held:e}");
    assert!(
        held < 0.05 * free,
        "with control {held:e}, without {free:e}"
    );
}

/// The accelerations of TLSPH on the block in state y with the control off and on
/// (α = 10), and the masses.
fn with_and_without(y: &TlState<D2>) -> (Vec<DVec2>, Vec<DVec2>, Vec<f64>) {
    let rates = |set: &[&str]| {
        let mut m: Tlsph<D2> = build_method(&block(set)).unwrap();
        let mut d = y.clone();
        m.rates(0.0, y, &mut d).unwrap();
        (d.v, m.mass().to_vec())
    };
    let (off, mass) = rates(&[]);
    let (on, _) = rates(&["method.hourglass=10.0"]);
    (off, on, mass)
}

#[test]
fn affine_motion_has_no_hourglass_force_and_the_pair_forces_balance() {
    // With the Randles–Libersky correction F is exact for a linear field at every particle,
    // the block's corners included, so an affine motion (a rotation by 1 rad with stretch,
    // shear and translation) leaves every bond where F maps it: the control adds round-off,
    // measured 9e-15 of the largest acceleration; bound 1e-9.
    let case = block(&[]);
    let m: Tlsph<D2> = build_method(&case).unwrap();
    let f = glam::DMat2::from_angle(1.0) * glam::DMat2::from_cols_array(&[1.2, 0.1, -0.05, 0.9]);
    let mut y = m.initial_state();
    for (u, &x) in y.u.iter_mut().zip(m.reference()) {
        *u = f * x - x + DVec2::new(0.3, -0.2);
    }
    let (off, on, _) = with_and_without(&y);
    let scale = off.iter().map(|a| a.length()).fold(0.0, f64::max);
    let added = off
        .iter()
        .zip(&on)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0, f64::max);
    eprintln!("affine: the control adds {added:e} to accelerations of {scale:e}");
    assert!(added < 1e-9 * scale, "affine: {added:e} against {scale:e}");
    // A checkerboard of ±1 % of Δx: the control's forces m (a_on − a_off) have no resultant
    // and no moment about the origin (pairs equal and opposite along the current bond), to
    // round-off, 1e-12 of their Σ |m a|; and they oppose the checkerboard, Σ m a·u < 0.
    let mut y = m.initial_state();
    for (u, x) in y.u.iter_mut().zip(m.reference()) {
        let (i, j) = ((x.x / case.spacing).round(), (x.y / case.spacing).round());
        *u = DVec2::new(0.3, 1.0) * 1e-3 * (-1f64).powi((i + j) as i32);
    }
    let (off, on, mass) = with_and_without(&y);
    let forces: Vec<DVec2> = (0..mass.len())
        .map(|i| (on[i] - off[i]) * mass[i])
        .collect();
    let size: f64 = forces.iter().map(|f| f.length()).sum();
    let net: DVec2 = forces.iter().sum();
    let torque: f64 = (0..mass.len())
        .map(|i| (m.reference()[i] + y.u[i]).perp_dot(forces[i]))
        .sum();
    let work: f64 = (0..mass.len()).map(|i| forces[i].dot(y.u[i])).sum();
    assert!(size > 0.0);
    assert!(net.length() < 1e-12 * size, "Σ f = {net} against {size:e}");
    assert!(
        torque.abs() < 1e-12 * size,
        "Σ x × f = {torque:e} against {size:e}"
    );
    assert!(work < 0.0, "Σ f·u = {work:e}");
}

#[test]
fn a_bad_coefficient_is_refused_by_key() {
    let err = Scene::from_toml(
        &block_source(),
        Path::new("block.toml"),
        &["method.hourglass=-1.0".to_string()],
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("method.hourglass") && err.contains("> 0"),
        "{err}"
    );
    // Only TLSPH reads it.
    let text = crate::common::block_text(
        &[1.0, 1.0],
        "saint-venant-kirchhoff",
        "kbm",
        "hourglass = 10.0",
    );
    let err = Scene::from_toml(&text, Path::new("block.toml"), &[])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("method.hourglass") && err.contains("tlsph"),
        "{err}"
    );
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_control_tracks_the_cpu() {
    // 400 RK4 steps (0.2 s) from the checkerboard with α = 10 on both backends. The
    // control's accelerations sum ~20 bond terms of κ δ in f32 (ε = 6e-8 relative) from
    // u stored in f32: the displacements agree to f32 accumulation over the run,
    // measured 5e-12 m against |u| = 1.7e-6 m; bound 1e-3 of the largest |u|. Without the GPU pass the
    // runs would differ by the control's whole effect, the difference between the CPU
    // runs with and without it, which the test measures too.
    use meshless::methods::tlsph::GpuTlsph;
    let steps = 400;
    let run_cpu = |case: &Scene| {
        let mut m: Tlsph<D2> = build_method(case).unwrap();
        let mut y = checkerboard(case, &m);
        let mut integrator = meshless::core::integrate::Integrator::new(case.method.integrator, &y);
        let dt = case.method.dt.unwrap();
        for k in 0..steps {
            integrator.step(&mut m, k as f64 * dt, dt, &mut y).unwrap();
        }
        y.u
    };
    let case = block(&["method.hourglass=10.0"]);
    let cpu = run_cpu(&case);
    let free = run_cpu(&block(&[]));
    let host: Tlsph<D2> = build_method(&case).unwrap();
    let mut gpu =
        GpuTlsph::<D2>::new(&case, crate::common::tl_scheme(&case), crate::common::gpu()).unwrap();
    gpu.set_state(&checkerboard(&case, &host));
    gpu.advance_steps(case.method.dt.unwrap(), steps as u32)
        .unwrap();
    let on_gpu = gpu.state().u;
    let largest = |a: &[DVec2], b: &[DVec2]| {
        a.iter()
            .zip(b)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f64::max)
    };
    let zero = vec![DVec2::ZERO; cpu.len()];
    let (deviation, size, effect) = (
        largest(&cpu, &on_gpu),
        largest(&cpu, &zero),
        largest(&cpu, &free),
    );
    eprintln!(
        "max |u_GPU − u_CPU| {deviation:e} m, max |u| {size:e} m, control's effect {effect:e} m"
    );
    assert!(
        deviation < 1e-3 * size,
        "GPU {deviation:e} m against |u| {size:e} m"
    );
    assert!(
        effect > 100.0 * deviation,
        "the control moves u by only {effect:e} m"
    );
}
