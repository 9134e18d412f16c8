//! Seed 001 §9.5: J2 plasticity with softening at the quadrature points of the
//! total-Lagrangian Galerkin methods (the plastic history committed once per step), and
//! the steel ring, where the softening localises the plastic strain into bands that a
//! hardening material does not form.

use crate::common::{block_text, cpu_options, load};
use meshless::integrate::OdeSystem;
use meshless::methods::Method;
use meshless::methods::galerkin::TlGalerkin;
use meshless::output::series::read_column;
use meshless::plasticity::PLASTIC_STRAIN;
use meshless::run::{build_method, run};
use meshless::scene::Case;
use meshless::tensor::D2;
use std::path::Path;

#[test]
fn a_uniaxial_strain_path_gives_every_point_the_closed_form_plastic_history() {
    // u = (e^ε − 1) X e_x, F = diag(e^ε, 1) (plane strain, F_zz = 1) at every point, since
    // each method's shape functions reproduce a linear field; ε from 0 to 0.1 in 50
    // increments, each committed as a step's start. The principal frame is fixed, so the
    // return is exact and ε_p = (2με − τ_y⁰)/(3μ + H) past yield (src/plasticity.rs), with
    // E = 1e6 Pa, ν = 0.3, τ_y⁰ = 1e4 Pa (yield at ε = 0.013) and the softening H = −E/10,
    // whose yield stress stays positive on this path (ε_p ≤ 0.064 < τ_y⁰/|H| = 0.1). The
    // nodal ε_p and σ_xx = τ_xx/J, τ_xx = κε + ⅔τ_y(ε_p), must hold at every particle,
    // corners included. F is exact to the shape functions' round-off (~1e-13 for the
    // kernel methods' moment inverses), which moves ε_p by ~1e-13: bounds 1e-9 on ε_p
    // and 1e-9 τ_y⁰ on σ_xx. A point committed from the wrong state, or a history kept
    // per particle instead of per point, is off by the increment, ~2e-3.
    let (e, nu, tau_y, h) = (1e6, 0.3, 1e4, -1e5);
    let (mu, kappa) = (e / (2.0 * (1.0 + nu)), e / (3.0 * (1.0 - 2.0 * nu)));
    let material =
        format!("poisson_ratio = 0.3\nyield_stress = {tau_y:e}\nhardening_modulus = {h:e}\n");
    for (method, keys) in [
        ("kbm", ""),
        ("kbm", "stress_points = false"),
        ("efg", ""),
        ("tl-fem", ""),
    ] {
        let mut text = block_text(&[0.6, 0.4], "von-mises-plastic", method, keys).replacen(
            "poisson_ratio = 0.3\n",
            &material,
            1,
        );
        if !meshless::methods::entry(method).is_some_and(|e| e.kernel) {
            text = text.replacen("h_over_dx = 1.3\n", "", 1);
        }
        let case =
            Case::from_toml(&text, Path::new("block.toml"), &[]).unwrap_or_else(|e| panic!("{e}"));
        let mut m: TlGalerkin<D2> = build_method(&case).unwrap();
        let mut y = m.initial_state();
        for k in 1..=50 {
            let eps = 0.1 * k as f64 / 50.0;
            for (u, &x) in y.u.iter_mut().zip(m.reference()) {
                u.x = (eps.exp() - 1.0) * x.x;
                u.y = 0.0;
            }
            m.begin_step(0.0, 1e-5, &y);
            let snap = m.snapshot(&y);
            let eps_p = snap.field(PLASTIC_STRAIN).expect("a plastic field");
            let expected = ((2.0 * mu * eps - tau_y) / (3.0 * mu + h)).max(0.0);
            let q = if expected > 0.0 {
                tau_y + h * expected
            } else {
                2.0 * mu * eps
            };
            let sigma_xx = (kappa * eps + 2.0 / 3.0 * q) / eps.exp();
            for (a, (&p, s)) in eps_p.iter().zip(&snap.sigma).enumerate() {
                assert!(
                    (p - expected).abs() < 1e-9,
                    "{method} {keys}: ε = {eps}: particle {a} has ε_p = {p}, closed form \
                     {expected}"
                );
                assert!(
                    (s[0][0] - sigma_xx).abs() < 1e-9 * tau_y,
                    "{method} {keys}: ε = {eps}: particle {a} has σ_xx = {}, closed form \
                     {sigma_xx}",
                    s[0][0]
                );
            }
        }
    }
}

/// The largest and the last `plastic_strain_spread` of the steel ring run with overrides.
fn spread(overrides: &[&str]) -> (f64, f64) {
    let mut all = vec!["run.end_time=2.5e-4", "output.frame_interval="];
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
    // (cases/steel-ring-kbm.toml) to 0.25 ms (about 1,500 steps), its plastic strain's
    // spread around a ring (std over mean). With the paper's softening H = −E/10 and
    // the 1 m/s imperfection of the case, ε_p localises into bands: measured 1.5 at
    // 0.25 ms (2.5 at 0.5 ms), bound 0.5. The same imperfection with a hardening H =
    // +E/10 leaves a perturbation of the axisymmetric flow of the order of the noise over
    // the rim velocity (1/218): measured 1e-3 at 0.25 ms, bound 0.02 (while the plastic
    // front crosses a ring, at 15 µs, some of its particles have yielded and some not,
    // and the spread peaks at 0.09). Without the imperfection the polar lattice keeps
    // the softening ring axisymmetric to round-off: measured 8e-12, bound 1e-9.
    let (_, softening) = spread(&[]);
    assert!(softening > 0.5, "softening: spread {softening}");
    let (_, hardening) = spread(&["material.hardening_modulus=2e10"]);
    assert!(hardening < 0.02, "hardening: spread {hardening}");
    let (perfect, _) = spread(&["body.0.velocity_noise.amplitude=0"]);
    assert!(perfect < 1e-9, "no imperfection: spread up to {perfect}");
}
