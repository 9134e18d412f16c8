//! Seed 001 §9.5: J2 plasticity with softening at the quadrature points of the Galerkin
//! methods, on the Lagrangian and the Eulerian kernel (the plastic history committed once
//! per step), and the steel ring, where the softening localises the plastic strain into
//! bands that a hardening material does not form.

use crate::common::{block_text, cpu_options, load};
use glam::DVec2;
use meshless::core::tensor::D2;
use meshless::methods::Method;
use meshless::methods::cores::galerkin::TlGalerkin;
use meshless::methods::cores::galerkin::updated::UlGalerkin;
use meshless::methods::kbm::eulerian::EulerianPoints;
use meshless::output::series::read_column;
use meshless::physics::plasticity::PLASTIC_STRAIN;
use meshless::run::{RunError, build_method, run};
use meshless::scene::Scene;
use std::path::Path;

/// E = 1e6 Pa, ν = 0.3, τ_y⁰ = 1e4 Pa and H = −E/10 (see the test below).
const E: f64 = 1e6;
const NU: f64 = 0.3;
const TAU_Y: f64 = 1e4;
const H: f64 = -1e5;

/// The block of spacing 0.1 over [0, 0.6] × [0, 0.4] in this von Mises material under
/// `method` with `[method]` keys.
fn plastic_block(method: &str, keys: &str) -> Scene {
    let material =
        format!("poisson_ratio = {NU}\nyield_stress = {TAU_Y:e}\nhardening_modulus = {H:e}\n");
    let mut text = block_text(&[0.6, 0.4], "von-mises-plastic", method, keys).replacen(
        "poisson_ratio = 0.3\n",
        &material,
        1,
    );
    if !meshless::methods::entry(method).is_some_and(|e| e.kernel) {
        text = text.replacen("h_over_dx = 1.3\n", "", 1);
    }
    Scene::from_toml(&text, Path::new("block.toml"), &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// Drives `m` along u = (e^ε − 1) X e_x, ε from 0 to 0.1 in 50 increments (`state(m, ε)`
/// the state there), each committed as a step's start, and checks every node's ε_p and
/// σ_xx against the closed form after each.
fn uniaxial_path<M: Method<D2>>(name: &str, m: &mut M, state: impl Fn(&M, f64) -> M::State) {
    let (mu, kappa) = (E / (2.0 * (1.0 + NU)), E / (3.0 * (1.0 - 2.0 * NU)));
    for k in 1..=50 {
        let eps = 0.1 * k as f64 / 50.0;
        let y = state(m, eps);
        m.begin_step(0.0, 1e-5, &y);
        let snap = m.snapshot(&y);
        let eps_p = snap.field(PLASTIC_STRAIN).expect("a plastic field");
        let expected = ((2.0 * mu * eps - TAU_Y) / (3.0 * mu + H)).max(0.0);
        let q = if expected > 0.0 {
            TAU_Y + H * expected
        } else {
            2.0 * mu * eps
        };
        let sigma_xx = (kappa * eps + 2.0 / 3.0 * q) / eps.exp();
        for (a, (&p, s)) in eps_p.iter().zip(&snap.sigma).enumerate() {
            assert!(
                (p - expected).abs() < 1e-9,
                "{name}: ε = {eps}: particle {a} has ε_p = {p}, closed form {expected}"
            );
            assert!(
                (s[0][0] - sigma_xx).abs() < 1e-9 * TAU_Y,
                "{name}: ε = {eps}: particle {a} has σ_xx = {}, closed form {sigma_xx}",
                s[0][0]
            );
        }
    }
}

/// x = A X with A = diag(e^ε, 1) for the nodes and, with its own points, every point.
fn stretched(x0: &[DVec2], eps: f64) -> Vec<DVec2> {
    x0.iter()
        .map(|x| DVec2::new((eps.exp() - 1.0) * x.x, 0.0))
        .collect()
}

#[test]
fn a_uniaxial_strain_path_gives_every_point_the_closed_form_plastic_history() {
    // F = diag(e^ε, 1) (plane strain, F_zz = 1) at every point, since each method's shape
    // functions reproduce a linear field, on the Lagrangian kernel (F = I + Σ u_a ⊗ G_a)
    // and on the Eulerian one (F = (Σ X_a ⊗ ∇N_a(x))⁻¹ on the current positions). The
    // principal frame is fixed, so the return is exact and ε_p = (2με − τ_y⁰)/(3μ + H)
    // past yield (src/physics/plasticity.rs): with E = 1e6 Pa, ν = 0.3, τ_y⁰ = 1e4 Pa yield is
    // at ε = 0.013, and the softening H = −E/10 keeps the yield stress positive on this
    // path (ε_p ≤ 0.064 < τ_y⁰/|H| = 0.1). The nodal ε_p and σ_xx = τ_xx/J, τ_xx = κε +
    // ⅔τ_y(ε_p), must hold at every particle, corners included. F is exact to the shape
    // functions' round-off (~1e-13 for the kernel methods' moment inverses), which moves
    // ε_p by ~1e-13: bounds 1e-9 on ε_p and 1e-9 τ_y⁰ on σ_xx. A point committed from the
    // wrong state, or a history kept per particle instead of per point, is off by the
    // increment, ~2e-3.
    for (method, keys) in [
        ("kbm", ""),
        ("kbm", "integration = \"nodal\""),
        ("efg", ""),
        ("tl-fem", ""),
    ] {
        let mut m: TlGalerkin<D2> = build_method(&plastic_block(method, keys)).unwrap();
        uniaxial_path(&format!("{method} {keys}"), &mut m, |m, eps| {
            let mut y = m.initial_state();
            y.u = stretched(m.reference(), eps);
            y
        });
    }
    let case = plastic_block("kbm", "kernel_frame = \"eulerian\"");
    let mut m: UlGalerkin<D2, EulerianPoints<D2>> = build_method(&case).unwrap();
    uniaxial_path("kbm on the Eulerian kernel", &mut m, |m, eps| {
        let mut y = m.initial_state();
        y.u = stretched(m.reference(), eps);
        y.point_u = stretched(&m.points().points().x0, eps);
        y
    });
}

/// The largest and the last `plastic_strain_spread` of the steel ring run with overrides.
fn spread(overrides: &[&str]) -> (f64, f64) {
    let mut all = vec!["output.frame_interval="];
    all.extend(overrides);
    let dir = tempfile::tempdir().unwrap();
    run(
        &load("steel-ring-kbm", &all),
        &cpu_options(dir.path(), false),
    )
    .unwrap();
    let rows = read_column(&dir.path().join("series.csv"), "plastic_strain_spread").unwrap();
    let largest = rows.iter().map(|r| r.1).fold(0.0, f64::max);
    (largest, rows.last().expect("a row").1)
}

#[test]
fn softening_localises_the_steel_rings_plastic_strain_and_hardening_does_not() {
    // Spec §11 item 10, what a run can show without the paper's figure: the steel ring
    // (cases/steel-ring-kbm.toml) to 0.5 ms (about 3,000 steps), its plastic strain's
    // spread around a ring (std over mean). With the paper's softening H = −E/10 and
    // the 1 m/s imperfection of the case, ε_p localises into bands: measured 1.54 at
    // 0.5 ms (0.44 at 0.25 ms: the pressure's consistent nodal forces ∫ W^S_a p n dΓ share
    // the load with the second row of particles), bound 0.5. The same imperfection with a
    // hardening H = +E/10 leaves a perturbation of the axisymmetric flow of the order of
    // the noise over the rim velocity (1/218): measured 1.1e-3 at 0.5 ms, bound 0.02
    // (while the plastic front crosses a ring, at 15 µs, some of its particles have
    // yielded and some not, and the spread peaks at 0.017). Without the imperfection the
    // polar lattice keeps the softening ring axisymmetric to round-off: measured 5e-11,
    // bound 1e-9.
    let (_, softening) = spread(&[]);
    assert!(softening > 0.5, "softening: spread {softening}");
    let (_, hardening) = spread(&["material.hardening_modulus=2e10"]);
    assert!(hardening < 0.02, "hardening: spread {hardening}");
    let (perfect, _) = spread(&["body.0.velocity_noise.amplitude=0"]);
    assert!(perfect < 1e-9, "no imperfection: spread up to {perfect}");
}

#[test]
fn the_eulerian_kernel_clusters_the_hardening_steel_ring_and_the_lagrangian_one_does_not() {
    // Spec §11 item 9 on the steel ring: the hardening material (H = +E/10), which stays
    // axisymmetric on the Lagrangian kernel, under the ring's hoop tension and the 1 m/s
    // imperfection. On the Eulerian kernel the particles pair up around the rings: the
    // gaps' std over mean reaches 0.5 by 0.12 ms (the gaps from 0.2 to 2.5 spacings) and
    // det F < 0 stops the run at 0.122 ms. On the Lagrangian kernel it stays 2e-3 to
    // 0.5 ms. Bounds: a failure before 0.2 ms with a gap spread above 0.2 first, and below
    // 0.01 on the Lagrangian kernel to 0.25 ms.
    let hard = ["material.hardening_modulus=2e10", "output.frame_interval="];
    let lagrangian = tempfile::tempdir().unwrap();
    let mut overrides = hard.to_vec();
    overrides.push("run.end_time=2.5e-4");
    run(
        &load("steel-ring-kbm", &overrides),
        &cpu_options(lagrangian.path(), false),
    )
    .unwrap();
    let gaps = read_column(&lagrangian.path().join("series.csv"), "hoop_gap_spread").unwrap();
    let largest = gaps.iter().map(|r| r.1).fold(0.0, f64::max);
    assert!(
        largest < 0.01,
        "Lagrangian kernel: gap spread up to {largest}"
    );
    let eulerian = tempfile::tempdir().unwrap();
    let mut overrides = hard.to_vec();
    overrides.push("method.kernel_frame=eulerian");
    match run(
        &load("steel-ring-kbm", &overrides),
        &cpu_options(eulerian.path(), false),
    ) {
        Err(RunError::BlowUp { time, .. }) => assert!(time < 2e-4, "fails at t = {time:e}"),
        other => panic!("the Eulerian kernel's ring should blow up: {other:?}"),
    }
    let gaps = read_column(&eulerian.path().join("series.csv"), "hoop_gap_spread").unwrap();
    let largest = gaps.iter().map(|r| r.1).fold(0.0, f64::max);
    assert!(largest > 0.2, "Eulerian kernel: gap spread up to {largest}");
}
