//! Artificial compressibility of the mixed methods (seed 003 §5): momenta in free flight
//! at ν = 0.5, the volume the corrector keeps, the limit κ̃ → κ, Δt → 0 (the explicit
//! scheme), and the pseudo-viscosity's effect on the iteration counts.

use crate::common::{load, run_mixed_steps};
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::mixed::MixedSph;
use meshless::run::{CpuEngine, Engine};
use meshless::scene::Scene;

/// The keys that switch a mixed case to artificial compressibility at Poisson ratio ν.
fn incompressible(nu: f64, alpha: f64) -> Vec<String> {
    vec![
        format!("material.poisson_ratio={nu}"),
        format!("method.artificial_compressibility={{ alpha = {alpha:?} }}"),
    ]
}

/// Σ V0 det F over the particles: the current volume of the body.
fn volume<D: Dim>(e: &mut CpuEngine<D, MixedSph<D>>, rho0: f64) -> f64 {
    let snap = e.snapshot();
    snap.f
        .iter()
        .zip(snap.mass)
        .map(|(&f, m)| m / rho0 * D::det(f))
        .sum()
}

/// The free spinning plate (21 × 21 particles, ω = 105 rad/s) at ν = 0.5 for 2 ms, at
/// the CFL step Δt (CFL 0.3) and at Δt/2.
///
/// The corrector's forces come in equal and opposite pairs and are projected with the
/// stage's other forces, so both momenta are conserved to round-off, as in the explicit
/// scheme: bounds 1e-12 relative (~1e-15 a step, with margin).
///
/// The volume Σ V0 det F: the corrector holds H^n : ∇0v^{n+1} at zero (κ = ∞, D(J) =
/// 0) up to the pseudo-viscosity, but F evolves with the stage's starting velocity
/// (eq 44b), whose constraint was met with the previous stage's H. Each stage so moves
/// det F by O(Δt² |∇0v|²), and the volume drifts at first order in Δt, by about
/// Δt ω² t: measured 3.2e-3 at Δt and 1.6e-3 at Δt/2. Bounds: below 5e-3 at Δt, and a
/// ratio between 1.6 and 2.4 (2 at first order), which a physical compressibility
/// (no dependence on Δt) would fail.
#[test]
fn at_nu_one_half_the_spinning_plate_keeps_its_momenta_and_its_volume_to_first_order() {
    let rho0 = 1100.0;
    let h0 = 373527.0; // Σ m |X|² ω for the 21 × 21 lattice at ω = 105 rad/s
    let case = load("spinning-plate", &incompressible(0.5, 0.2));
    let run = |halves: u32| {
        let mut e = meshless::scene::cpu_engine::<D2, MixedSph<D2>>(&case).unwrap();
        let v0 = volume(&mut e, rho0);
        let dt = case.method.cfl.unwrap() * case.spacing / e.max_signal_speed();
        let steps = (2e-3 / dt).round() as u32;
        let h = f64::from(halves);
        e.advance(0.0, dt / h, steps * halves).unwrap();
        let dv = (volume(&mut e, rho0) / v0 - 1.0).abs();
        let inv = e.invariants();
        let scale: f64 = e.snapshot().mass.iter().sum::<f64>() * 105.0;
        let pseudo = e
            .pseudo_time()
            .expect("the corrector reports its iterations");
        eprintln!(
            "ν = 0.5, {} steps: |ΔV/V| = {dv:e}, {} pseudo-time iterations",
            steps * halves,
            pseudo.total
        );
        (
            (inv.angular[2] / h0 - 1.0).abs(),
            inv.linear[0].hypot(inv.linear[1]) / scale,
            dv,
        )
    };
    let (dh, dp, dv) = run(1);
    eprintln!("|ΔH/H0| = {dh:e}, |Σ m v| = {dp:e} of Σ m|v|");
    assert!(dh < 1e-12, "|ΔH/H0| = {dh:e}");
    assert!(dp < 1e-12, "|Σ m v| = {dp:e} of Σ m|v|");
    assert!(dv < 5e-3, "|ΔV/V| = {dv:e}");
    let (_, _, dv_half) = run(2);
    let ratio = dv / dv_half;
    assert!(
        (1.6..2.4).contains(&ratio),
        "|ΔV/V| {dv:e} at Δt, {dv_half:e} at Δt/2: ratio {ratio}"
    );
}

/// The twisting column of seed 003 §7.3.1 on 4 × 24 × 4 particles at the cell centres
/// (`twisting-column` with the paper's lattice), with `overrides`.
fn column(overrides: &[String]) -> Scene {
    let mut all: Vec<String> = [
        "spacing=0.25",
        "body.0.geometry.lattice=cell-centred",
        "boundary.0.region.y_max=0.1",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    all.extend_from_slice(overrides);
    load("twisting-column", &all)
}

/// u of the column's top corner (0.375, 5.875, 0.375) after 0.02 s at the fixed step Δt.
fn top_corner(overrides: &[String], dt: f64) -> glam::DVec3 {
    let case = column(overrides);
    let mut e = meshless::scene::cpu_engine::<D3, MixedSph<D3>>(&case).unwrap();
    let steps = (0.02 / dt).round() as u32;
    e.advance(0.0, dt, steps).unwrap();
    let snap = e.snapshot();
    let corner = snap
        .x0
        .iter()
        .position(|x| (*x - glam::DVec3::new(0.375, 5.875, 0.375)).length() < 1e-9)
        .expect("the lattice has a particle at the top corner");
    snap.u[corner]
}

/// With κ̃ → κ the predictor is the explicit stage without D(J), and the corrector
/// differs from it only in taking the pressure of the stage's end into the momentum and
/// its velocity into the pressure: a first-order change in Δt. On the twisting column
/// at ν = 0.45 (κ = 5.67e7 Pa, κ̃ = 5.6e7 Pa, Ω = 105 rad/s) the top corner after 0.02 s
/// therefore tends to the explicit scheme's as Δt falls, up to the J dissipation the
/// corrected scheme leaves out: measured gaps 6.6 % of |u| at Δt = 3e-4 s (the CFL
/// step), 2.6 % at 1e-4 s and 1.1 % at 3e-5 s (ratios 2.5 and 2.4; 3 at first order).
/// Bounds: gap below 4 % at 1e-4 s and falling by more than 2 from 3e-4 s. The explicit
/// result itself moves by 1e-4 of |u| between these steps, so it is the limit.
#[test]
fn with_kappa_tilde_near_kappa_the_corrected_scheme_tends_to_the_explicit_one() {
    let explicit = top_corner(&["material.poisson_ratio=0.45".into()], 1e-4);
    let corrected = |dt: f64| {
        let u = top_corner(
            &[
                "material.poisson_ratio=0.45".into(),
                "method.artificial_compressibility={ kappa = 5.6e7, tolerance = 1e-5 }".into(),
            ],
            dt,
        );
        (u - explicit).length() / explicit.length()
    };
    let (coarse, fine) = (corrected(3e-4), corrected(1e-4));
    eprintln!(
        "top corner: explicit {explicit}; corrected gaps {coarse:e} at 3e-4 s, {fine:e} at 1e-4 s"
    );
    assert!(explicit.length() > 0.8, "the column must twist: {explicit}");
    assert!(fine < 0.04, "gap {fine:e} at Δt = 1e-4 s");
    assert!(
        coarse / fine > 2.0,
        "gaps {coarse:e} → {fine:e}: not first order"
    );
}

/// Seed 003 Fig. 27: the pseudo-viscosity (eq 58) cuts the pseudo-time iterations. The
/// column at ν = 0.5 over its first 10 CFL steps: measured 13,110 iterations without it
/// and 2251 with α = 0.2 (5.8 times fewer). Bound: at least 3 times fewer.
#[test]
fn the_pseudo_viscosity_cuts_the_pseudo_time_iterations() {
    let iterations = |alpha: f64| {
        let mut overrides = incompressible(0.5, alpha);
        overrides.push("method.artificial_compressibility.max_iterations=20000".into());
        let case = column(&overrides);
        let mut e = run_mixed_steps::<D3>(&case, 10);
        e.pseudo_time().unwrap().total
    };
    let (without, with) = (iterations(0.0), iterations(0.2));
    eprintln!("10 steps at ν = 0.5: {without} pseudo-time iterations at α = 0, {with} at α = 0.2");
    assert!(without >= 3 * with, "α = 0: {without}, α = 0.2: {with}");
}
