//! Penalty contact on whole runs: the seed-000 rubber rings, coarsened, under TLSPH and a
//! mixed method, on the CPU and on the GPU (a missing adapter fails the GPU tests: CI
//! installs Mesa lavapipe).

use crate::common::case_file;
use meshless::case::CaseError;
use meshless::core::tensor::D2;
use meshless::diagnostics::balance::Balance;
use meshless::run::{Backend, Engine, engine};
use meshless::scene::Scene;

/// The shipped rings case on the nbox = 20 lattice (Δx = 0.08/19): the centres at ∓47.5 mm,
/// so that the 23.4 mm between the nearest particles exceed the kernel support
/// 2h = 3.4Δx = 14.3 mm; Δt scaled with Δx (c_p Δt/Δx = 0.44); plane strain, the
/// material every method here reads the same way (the shipped case is the seed's plane
/// stress).
pub(crate) fn rings(extra: &[&str]) -> Result<Scene, CaseError> {
    let mut set = vec![
        "material.plane=\"strain\"",
        "spacing=4.2105263157894736e-3",
        "method.dt=4.0e-7",
        "body.0.geometry.center=[-0.0475, 0.0]",
        "body.1.geometry.center=[0.0475, 0.0]",
    ];
    set.extend_from_slice(extra);
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    Scene::load(&case_file("rings-impact"), &set)
}

/// Centre-of-mass velocity v_x of each ring after `time` on an engine.
fn ring_velocities_on(e: &mut impl Engine<D2>, case: &Scene, time: f64) -> [f64; 2] {
    let dt = case.method.dt.unwrap();
    e.advance(0.0, dt, (time / dt).round() as u32).unwrap();
    centre_velocities(e)
}

/// Centre-of-mass velocity v_x of each ring now.
fn centre_velocities(e: &mut impl Engine<D2>) -> [f64; 2] {
    let s = e.snapshot();
    let mut p = [[0.0; 2]; 2];
    for i in 0..s.mass.len() {
        p[s.body[i] as usize][0] += s.mass[i] * s.v[i].x;
        p[s.body[i] as usize][1] += s.mass[i];
    }
    p.map(|[mv, m]| mv / m)
}

/// The same on the CPU reference of the case's method.
fn ring_velocities(case: &Scene, time: f64) -> [f64; 2] {
    let mut e = engine::<D2>(case, Backend::Cpu).unwrap();
    ring_velocities_on(&mut e, case, time)
}

/// The rings under {p, F} Upwind-SPH: the same lattice, material and step.
const UPWIND: [&str; 3] = [
    "method.name=upwind-sph",
    "method.variables=p-F",
    "method.correction=cgck",
];

#[test]
fn colliding_rings_rebound_alike_in_every_frame() {
    // Two identical rings at ±180 m/s, head on, and the same impact seen from the right
    // ring (see `assert_rebound`). The nearest particles touch at 65 µs (23.4 mm at
    // 360 m/s); the rings have separated by 400 µs (measured e = 0.46; mirror symmetry
    // holds to 4e-14 relative over the 1,000 steps).
    assert_rebound(&[], 4.0e-4);
}

/// The rings under Gray–Monaghan SPH at the seed's `rings_monaghan_contact` constants
/// (AV α = β = 1, η = 0.1, artificial stress ε = 0.3, n = 4, XSPH 0.5), on the same
/// lattice and step: its neighbours are rebuilt per body at every stage, so the rings meet
/// through contact alone.
const GRAY_MONAGHAN: [&str; 6] = [
    "method.name=gray-monaghan-sph",
    "material.model=hypoelastic",
    "method.correction=none",
    "method.artificial_viscosity={ alpha = 1.0, beta = 1.0, eta = 0.1 }",
    "method.artificial_stress={ epsilon = 0.3, n = 4.0 }",
    "method.xsph=0.5",
];

#[test]
fn gray_monaghan_rings_rebound_through_contact() {
    assert_rebound(&GRAY_MONAGHAN, 4.0e-4);
}

/// The rings under Godunov SPH, which has no artificial viscosity: the key is dropped
/// with the method change.
const GODUNOV: [&str; 3] = [
    "method.name=godunov-sph",
    "material.model=hypoelastic",
    "method.correction=none",
];

#[test]
fn godunov_rings_rebound_through_contact() {
    assert_rebound(&GODUNOV, 4.0e-4);
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_contact_pass_matches_the_cpu_on_the_updated_lagrangian_methods() {
    // The same pass in the updated-Lagrangian GPU engine, whose lists are rebuilt per body
    // on the device: the rebound velocities at 400 µs against the CPU, with the bound of
    // the TLSPH comparison (1e-4 of the impact speed; measured on lavapipe 1.3e-6 for
    // Gray–Monaghan, rebound at 75.01 m/s, and 4e-8 for Godunov, 19.75 m/s).
    assert_gpu_matches_cpu(&rings(&GRAY_MONAGHAN).unwrap(), 4.0e-4);
    assert_gpu_matches_cpu(&rings(&GODUNOV).unwrap(), 4.0e-4);
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_contact_pass_matches_the_cpu_on_the_elastic_potential() {
    // The potential's force on the TLSPH GPU engine, same rings and bound (measured on
    // lavapipe: 6e-7 of the impact speed, rebound at 55.77 m/s).
    // The rings' `force = "reveles"` is TLSPH's: the potential takes its own default.
    let potential = rings(&["method.name=tl-potential", "method.force="]).unwrap();
    assert_gpu_matches_cpu(&potential, 4.0e-4);
}

/// The rings under `method` after `end`, checked against what the contact code does not
/// produce:
/// - Galilean invariance: the same impact seen from the right ring (the left at 360 m/s,
///   the right at rest) gives the same relative rebound velocity v_L − v_R. The penalty
///   force reads only relative positions and the artificial dissipation only relative
///   velocities, so the two runs differ by the round-off of coordinates shifted by
///   V t ≤ 0.15 m, amplified over the impact (measured 1e-12 m/s for TLSPH): bound 1e-9
///   of the closing speed.
/// - Mirror symmetry in the centre-of-mass frame: v_L = −v_R to 1e-9 of the impact speed
///   (the round-off of the mirrored lattice amplified over the impact).
/// - The restitution e = −(v_L − v_R)/360 m/s of an impact that the method dissipates in
///   (0, 1].
fn assert_rebound(method: &[&str], end: f64) {
    let ([left, right], _) = rebound(&rings(method).unwrap(), end);
    let restitution = -(left - right) / 360.0;
    let ([left_b, right_b], _) = rebound(&boosted(method), end);
    eprintln!(
        "{} rings after {end:e} s: v_x = {left} and {right} m/s, e = {restitution}; \
         in the right ring's frame {left_b} and {right_b} m/s",
        rings(method).unwrap().method.name
    );
    assert!(
        restitution > 0.0 && restitution <= 1.0,
        "restitution {restitution} (v_x = {left} and {right} m/s)"
    );
    assert!(
        (left + right).abs() < 1e-9 * 180.0,
        "mirror symmetry: v_x = {left} and {right} m/s"
    );
    let (relative, relative_b) = (left - right, left_b - right_b);
    assert!(
        (relative - relative_b).abs() < 1e-9 * 360.0,
        "Galilean invariance: v_L − v_R = {relative} m/s in the centre-of-mass frame, \
         {relative_b} m/s in the right ring's"
    );
}

#[test]
fn the_energy_balance_closes_through_the_contact() {
    // The balance E_kin + E_stored + D_art + E_contact = E_0 of the TLSPH rings with the
    // variational force, which closes its balance without contact (docs/methods/tlsph.md),
    // over the impact at Δt and Δt/2: what the integrator leaves shrinks with Δt (by more
    // than 2^½, first order with half an order of slack, as in tests/it/energy_balance.rs);
    // a term booked wrong does not (docs/verification.md, "The contact's work"). Measured:
    // the largest |R/S| is 3.6e-2 at Δt = 0.4 µs and 6.5e-3 at 0.2 µs; with the contact's
    // held force integrated by the trapezoid across steps, 3.3e-2 and 4.7e-2.
    let residue = |dt: &str| {
        let dt = format!("method.dt={dt}");
        let case = rings(&["method.force=", dt.as_str()]).unwrap();
        rebound(&case, 4.0e-4).1
    };
    let (coarse, fine) = (residue("4.0e-7"), residue("2.0e-7"));
    eprintln!("rings energy residue: {coarse:e} at 0.4 µs, {fine:e} at 0.2 µs");
    assert!(
        fine < coarse / 2f64.sqrt(),
        "the residue {coarse:e} → {fine:e} does not shrink with Δt"
    );
}

/// The rings under `method` seen from the right ring: every velocity shifted by +180 m/s.
fn boosted(method: &[&str]) -> Scene {
    let mut set = method.to_vec();
    set.extend([
        "body.0.initial_velocity.value=[360.0, 0.0]",
        "body.1.initial_velocity.value=[0.0, 0.0]",
    ]);
    rings(&set).unwrap()
}

/// Centre-of-mass velocities v_x of the rings after `end` on the CPU, and the largest
/// |R|/S of the energy balance over twenty samples of the impact.
fn rebound(case: &Scene, end: f64) -> ([f64; 2], f64) {
    let mut e = engine::<D2>(case, Backend::Cpu).unwrap();
    let dt = case.method.dt.unwrap();
    let steps = (end / dt).round() as u32;
    let e0 = e.invariants().total_energy();
    let mut residue = 0.0f64;
    for k in 0..20 {
        let (from, to) = (k * steps / 20, (k + 1) * steps / 20);
        e.advance(f64::from(from) * dt, dt, to - from).unwrap();
        let inv = e.invariants();
        let balance = Balance {
            kinetic: inv.kinetic,
            stored: inv.strain,
            booked: e.booked(),
            e0,
        };
        residue = residue.max(balance.relative_residue().abs());
    }
    (centre_velocities(&mut e), residue)
}

/// Without contact the rings pass through each other unchanged: their velocities stay
/// uniform at ±180 m/s to 1e-9 relative (F stays I but for round-off, and no kernel joins
/// the bodies).
#[test]
fn without_contact_the_rings_pass_through_each_other() {
    let [left, right] = ring_velocities(&rings(&["contact="]).unwrap(), 4.0e-4);
    eprintln!("rings without contact: v_x = {left} and {right} m/s");
    for (v, v0) in [(left, 180.0), (right, -180.0)] {
        assert!(
            (v / v0 - 1.0).abs() < 1e-9,
            "v_x = {v} m/s, started at {v0}"
        );
    }
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_contact_pass_matches_the_cpu() {
    // The whole impact in f32 on the GPU against f64 on the CPU: the rebound velocity of
    // each ring. The penalty force is continuous across the contact switch (zero at
    // d·n = 0), so f32 round-off (6e-8 of the coordinates, 1e-7 of the forces) spreads
    // only smoothly; the closest hull particle can differ on near-ties, which moves the
    // normal by one hull edge for a particle at zero depth. Measured 2e-6 of the impact
    // speed on lavapipe; bound 1e-4.
    assert_gpu_matches_cpu(&rings(&[]).unwrap(), 4.0e-4);
}

/// The rings' velocities after `end` on the GPU engine of the case's method against its
/// CPU reference, within 1e-4 of the impact speed.
#[cfg(feature = "gpu")]
pub(crate) fn assert_gpu_matches_cpu(case: &Scene, end: f64) {
    let mut g = engine::<D2>(case, Backend::Gpu).unwrap();
    let on_gpu = ring_velocities_on(&mut g, case, end);
    let on_cpu = ring_velocities(case, end);
    eprintln!(
        "{} ring v_x after the impact: GPU {on_gpu:?}, CPU {on_cpu:?} m/s",
        case.method.name
    );
    for (g, c) in on_gpu.iter().zip(&on_cpu) {
        assert!(
            (g - c).abs() < 1e-4 * 180.0,
            "GPU {on_gpu:?} against CPU {on_cpu:?} m/s"
        );
    }
}

#[test]
fn contact_acts_on_a_mixed_method_as_on_tlsph() {
    // Contact is an interaction of the scene, not of a method: under Upwind-SPH the rings
    // rebound too, with a restitution in (0, 1] (the upwind flux dissipates), and mirror
    // symmetry holds to round-off (bound 1e-9 of 180 m/s, as for TLSPH). The mixed rings
    // stay in contact longer: their centres still close at 7 m/s at 400 µs, and have
    // separated at 800 µs (measured v_x = −64 m/s, e = 0.36; TLSPH: e = 0.46 by 400 µs).
    assert_rebound(&UPWIND, 8.0e-4);
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_contact_pass_matches_the_cpu_on_a_mixed_method() {
    // The same pass in the mixed GPU engine: the rebound velocities at 800 µs against the
    // CPU, with the bound of the TLSPH comparison above (1e-4 of the impact speed;
    // measured 5.5e-6 on lavapipe).
    assert_gpu_matches_cpu(&rings(&UPWIND).unwrap(), 8.0e-4);
}

#[test]
#[ignore = "finding: docs/methods/tlsph.md, \"The rings' artificial viscosity\" (AV 1/1 completes the impact)"]
fn tlsph_needs_the_papers_viscosity_for_the_rings_impact() {
    // Seed 000 §6.3: "to get a stable result, Reveles' algorithm had to be stabilized by
    // quite large amounts of artificial viscosity: α = 3, β = 3". The claim: the shipped
    // rings (the seed's set-up: 4,232 particles, state-based SVK, eq 134, RK4 at 1e-7 s)
    // with α = β = 1 do not complete the 400 µs. Here they do (37 s on one thread).
    let case = Scene::load(
        &case_file("rings-impact"),
        &["method.artificial_viscosity={ alpha = 1.0, beta = 1.0, eta = 0.1 }".to_string()],
    )
    .unwrap();
    let mut e = engine::<D2>(&case, Backend::Cpu).unwrap();
    let failed = e.advance(0.0, 1e-7, 4_000).is_err() || e.check().is_err();
    assert!(failed, "the rings complete the impact at α = β = 1");
}
