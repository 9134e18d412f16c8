//! The GPU passes of the total-Lagrangian Galerkin methods (`tl-fem`, `tl-weak-form`,
//! `kbm`, `efg`) against the f64 CPU reference on a software (or real) adapter: one rate evaluation on a
//! deformed, moving, stressed state, and whole runs with the weak form's smoothing. A
//! missing adapter fails these tests.

use crate::common::{gpu, load, max_s, max_t, max_v, noise, random_tensor, random_vector};
use crate::galerkin::block;
use meshless::core::integrate::{Integrator, OdeSystem};
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::layout::GpuDim;
use meshless::methods::Method;
use meshless::methods::cores::galerkin::gpu::GpuGalerkin;
use meshless::methods::cores::galerkin::{GalerkinState, TlGalerkin};
use meshless::physics::plasticity::PLASTIC_STRAIN;
use meshless::run::{Engine, build_method};
use meshless::scene::Scene;

/// One rate evaluation of a random state (|u| ~ 1 mm, |v| ~ 1 m/s, ρ within 1 % of ρ0,
/// |S| ~ 1e4 Pa) on both backends.
pub fn compare_rates<D: GpuDim>(case: &Scene) {
    let mut cpu: TlGalerkin<D> = build_method(case).unwrap();
    let mut seed = 11;
    let mut y = cpu.initial_state();
    for (u, v) in y.u.iter_mut().zip(y.v.iter_mut()) {
        *u = random_vector::<D>(&mut seed, 1e-3);
        *v = random_vector::<D>(&mut seed, 1.0);
    }
    for (rho, s) in y.rho.iter_mut().zip(y.s.iter_mut()) {
        *rho *= 1.0 + 0.01 * noise(&mut seed);
        *s = random_tensor::<D>(&mut seed, 1e4);
    }
    let mut d = y.clone();
    cpu.rates(0.0, &y, &mut d).unwrap();
    let mut g = GpuGalerkin::<D>::new(case, crate::common::spec_of(case), gpu()).unwrap();
    let (dg, pg) = g.rates(&y);
    let what = format!("{} {}D {:?}", case.method.name, D::N, case.material.model);
    // P_q from F_q = I + Σ_a (u_a − u_first) ⊗ ∇0N_a: ≤ 40 f32 terms of |u|·|∇N| ~ 1e-2
    // (ε = 6e-8) and the f32 stress state: relative 1e-5 of max |P|.
    let (ep, scale_p) = max_t::<D>(cpu.first_piola(), &pg);
    assert!(
        ep < 1e-5 * scale_p,
        "{what}: max |ΔP| = {ep:e} of {scale_p:e}"
    );
    check_rates(&what, &cpu, &d, &dg);
}

/// The GPU's rates `dg` against the CPU's `d` of one state, under the bounds of
/// [`compare_rates`], with the terms of each node's force from `cpu`'s evaluation of that
/// state: a_a = −(1/m_a) Σ_q w_q P_q ∇0Φ_a: the node's terms cancel to a small net force,
/// so the f32 bound is relative to the sum of their magnitudes (16 to 50 terms of
/// relative error 1e-5 each from P): 1e-4 of Σ_q w_q |P_q| |∇0Φ_a| / m_a.
pub fn check_rates<D: Dim>(
    what: &str,
    cpu: &TlGalerkin<D>,
    d: &GalerkinState<D>,
    dg: &GalerkinState<D>,
) {
    let (shapes, gather, w) = (cpu.shapes(), cpu.gather(), &cpu.points().weight);
    for a in 0..d.u.len() {
        let terms: f64 = gather
            .range(a)
            .map(|e| {
                let q = gather.point[e] as usize;
                let p = cpu.first_piola()[q];
                w[q] * D::ddot(p, p).sqrt()
                    * D::norm2(shapes.test_gradient(gather.pair[e] as usize)).sqrt()
            })
            .sum::<f64>()
            / cpu.mass()[a];
        let diff = D::norm2(d.v[a] - dg.v[a]).sqrt();
        assert!(
            diff <= 1e-4 * terms + 1e-12,
            "{what}: node {a}: |Δa| = {diff:e} of {terms:e}"
        );
    }
    // u̇ = v exactly in f32.
    let (eu, scale_v) = max_v::<D>(&d.u, &dg.u);
    assert!(eu < 1e-6 * scale_v, "{what}: u̇ off by {eu:e}");
    if !d.rho.is_empty() {
        // ρ̇ = −ρ tr L and the Jaumann Ṡ from Ḟ = Σ_a (v_a − v_first) ⊗ ∇0N_a: 40 terms of
        // |v||∇N| ~ 10 s⁻¹ in f32: 1e-5 of the largest rate.
        let (er, scale_r) = max_s(&d.rho, &dg.rho);
        assert!(
            er < 1e-5 * scale_r,
            "{what}: max |Δρ̇| = {er:e} of {scale_r:e}"
        );
        let (es, scale_s) = max_t::<D>(&d.s, &dg.s);
        assert!(
            es < 1e-5 * scale_s,
            "{what}: max |ΔṠ| = {es:e} of {scale_s:e}"
        );
    }
}

#[test]
fn rates_match_the_cpu() {
    for method in ["tl-fem", "tl-weak-form"] {
        for model in ["hypoelastic", "saint-venant-kirchhoff", "neo-hookean"] {
            compare_rates::<D2>(&block(&[1.0, 0.6], model, method, ""));
        }
    }
    compare_rates::<D3>(&block(&[0.4, 0.3, 0.3], "hypoelastic", "tl-fem", ""));
    compare_rates::<D3>(&block(&[0.4, 0.3, 0.3], "neo-hookean", "tl-weak-form", ""));
}

#[test]
fn seed_001_rates_match_the_cpu() {
    // The Krongauz–Belytschko trial gradients and Shepard test gradients (KBM with and
    // without stress points) and the MLS functions (EFG at cells and at the particles) on
    // the same passes, under the bounds of `compare_rates`.
    for (method, keys) in [
        ("kbm", ""),
        ("kbm", "integration = \"nodal\""),
        ("efg", ""),
        ("efg", "integration = \"nodal\""),
    ] {
        for model in ["hypoelastic", "neo-hookean"] {
            compare_rates::<D2>(&block(&[1.0, 0.6], model, method, keys));
        }
    }
    compare_rates::<D3>(&block(
        &[0.4, 0.3, 0.3],
        "saint-venant-kirchhoff",
        "kbm",
        "",
    ));
    compare_rates::<D3>(&block(&[0.4, 0.3, 0.3], "hypoelastic", "efg", ""));
}

#[test]
fn scni_rates_match_the_cpu() {
    // Stabilised conforming nodal integration (`integration = "scni"`) of EFG and KBM: the
    // host's smoothed gradients at the particles on the same passes, under the bounds of
    // `compare_rates`. A particle's row holds the nodes that reach its cell's boundary,
    // up to 36 in 2D (within the 40 f32 terms the bound on P allows) and the whole
    // 80-particle box in 3D, whose F sums twice the terms: f32 round-off grows as their
    // square root there, 1.4 × 6e-8 per term, still below the bound of 1e-5.
    for method in ["efg", "kbm"] {
        for model in ["hypoelastic", "neo-hookean"] {
            compare_rates::<D2>(&block(&[1.0, 0.6], model, method, "integration = \"scni\""));
        }
        compare_rates::<D3>(&block(
            &[0.4, 0.3, 0.3],
            "saint-venant-kirchhoff",
            method,
            "integration = \"scni\"",
        ));
    }
}

/// Runs `steps` CPU steps of size dt.
fn cpu_run<D: Dim>(case: &Scene, steps: usize, dt: f64) -> (TlGalerkin<D>, GalerkinState<D>) {
    let mut m: TlGalerkin<D> = build_method(case).unwrap();
    let mut y = m.initial_state();
    let mut integrator = Integrator::new(case.method.integrator, &y);
    for k in 0..steps {
        integrator.step(&mut m, k as f64 * dt, dt, &mut y).unwrap();
    }
    (m, y)
}

#[test]
fn whole_runs_track_the_cpu() {
    // 100 steps of the seed-000 strip under the elements (grips at ±10 m/s, the rate model)
    // and of the disk under the weak form with its smoothing after every step (ω = 50 rad/s,
    // |v| ≤ 50 m/s). f32 round-off of v per stage update ~ 6e-8 |v|, four stages and the
    // smoothing per step, 100 steps, accumulating at worst linearly: 3e-5 of max |v|;
    // bound 1e-4 (measured 6e-7 and 1.3e-6). The kinetic energy of the GPU reduction (f32
    // partials of ≤ 256 terms, f64 sums): 256 × 6e-8 = 1.5e-5; bound 1e-5 (measured 2e-8).
    // The stored energy is second order in the strain, which on the rotating disk is
    // what f32 resolves of H = F − I = O(1) under rotation: measured 6e-5 relative there
    // (3e-8 on the strip); bound 1e-3.
    for (name, dt) in [
        ("tensile-strip-fem", 1e-6),
        ("rotating-disk-weak-form", 1e-6),
    ] {
        let case = load(name, &[] as &[&str]);
        let steps = 100;
        let (cpu, y) = cpu_run::<D2>(&case, steps, dt);
        let mut g = GpuGalerkin::<D2>::new(&case, crate::common::spec_of(&case), gpu()).unwrap();
        g.advance_steps(dt, steps as u32).unwrap();
        let strain = cpu.strain_energy(&y).value();
        check_run(name, &mut g, &y.v, cpu.mass(), strain);
    }
}

/// The GPU engine `g` after a run against the CPU's velocities `v`, masses and stored
/// energy at its end, under the bounds of [`whole_runs_track_the_cpu`]: v within 1e-4 of
/// max |v|, the kinetic energy within 1e-5 and the stored energy within 1e-3; and the
/// device's checks pass.
pub fn check_run(
    name: &str,
    g: &mut GpuGalerkin<D2>,
    v: &[<D2 as Dim>::V],
    mass: &[f64],
    strain: f64,
) {
    let yg = g.state();
    let (ev, scale) = max_v::<D2>(v, &yg.v);
    assert!(ev < 1e-4 * scale, "{name}: max |Δv| = {ev:e} of {scale:e}");
    g.check().unwrap();
    let kinetic: f64 = (v.iter().zip(mass))
        .map(|(v, m)| 0.5 * m * v.length_squared())
        .sum();
    let invariants = g.invariants();
    assert!(
        (invariants.kinetic - kinetic).abs() < 1e-5 * kinetic,
        "{name}: kinetic energy {} on the GPU, {kinetic} on the CPU",
        invariants.kinetic
    );
    assert!(
        (invariants.strain - strain).abs() < 1e-3 * strain,
        "{name}: strain energy {} on the GPU, {strain} on the CPU",
        invariants.strain
    );
}

#[test]
fn the_seed_001_rod_tracks_the_cpu() {
    // 500 leapfrog steps (4.6 µs, the two halves of the pulse 24 mm apart) of the Gaussian
    // rod at Δx = 0.5 mm under KBM with stress points and EFG at Gauss points. f32
    // round-off of v per step ~ 6e-8 |v|, two kicks per step, accumulating at worst
    // linearly over 500 steps: 6e-5 of max |v|; bound 1e-4.
    for name in ["rod-gaussian-kbm", "rod-gaussian-efg"] {
        let case = load(name, &["spacing=5e-4"]);
        let (dt, steps) = (case.method.dt.unwrap(), 500);
        let (_, y) = cpu_run::<D2>(&case, steps, dt);
        let mut g = GpuGalerkin::<D2>::new(&case, crate::common::spec_of(&case), gpu()).unwrap();
        g.advance_steps(dt, steps as u32).unwrap();
        g.check().unwrap();
        let (ev, scale) = max_v::<D2>(&y.v, &g.state().v);
        eprintln!("{name}: max |Δv| = {ev:e} of {scale:e}");
        assert!(ev < 1e-4 * scale, "{name}: max |Δv| = {ev:e} of {scale:e}");
    }
}

#[test]
fn the_seed_001_steel_ring_flows_plastically_as_on_the_cpu() {
    // The steel ring (J2 with softening, the history at the particles and the stress
    // points) without its imperfection, 300 leapfrog steps of 0.16 µs: by 48 µs the whole
    // wall has yielded (ε_p from 0.1 to 0.25). The GPU commits its f32 history before every
    // step as the CPU does in f64. f32 round-off of ~6e-8 per operation, amplified through
    // the return map's plastic tangent and accumulated over 300 steps at worst linearly:
    // ~1e-5 of the displacement, bound 1e-4; ε_p follows the displacement gradient, whose
    // round-off is larger by the ratio of the ring's size to the spacing (30): bound 1e-3 of
    // its largest value. A history not committed, or committed from another state, is off
    // by the plastic increment of a step, ~1e-3 of ε_p per step.
    let case = load(
        "steel-ring-kbm",
        &[
            "body.0.velocity_noise.amplitude=0",
            "method.cfl=",
            "method.dt=1.6e-7",
        ],
    );
    let (dt, steps) = (1.6e-7, 300);
    let mut cpu = meshless::scene::cpu_engine::<D2, TlGalerkin<D2>>(&case).unwrap();
    cpu.advance(0.0, dt, steps).unwrap();
    let mut g = GpuGalerkin::<D2>::new(&case, crate::common::spec_of(&case), gpu()).unwrap();
    Engine::<D2>::advance(&mut g, 0.0, dt, steps).unwrap();
    g.check().unwrap();
    let (on_cpu, on_gpu) = (cpu.snapshot(), Engine::<D2>::snapshot(&mut g));
    let (du, largest) = max_v::<D2>(&on_cpu.u, &on_gpu.u);
    eprintln!("steel ring: max |Δu| = {du:e} of {largest:e} m");
    assert!(du < 1e-4 * largest, "max |Δu| = {du:e} of {largest:e} m");
    let (eps_cpu, eps_gpu) = (
        on_cpu.field(PLASTIC_STRAIN).unwrap().to_vec(),
        on_gpu.field(PLASTIC_STRAIN).unwrap().to_vec(),
    );
    let (de, eps_max) = max_s(&eps_cpu, &eps_gpu);
    let eps_min = eps_cpu.iter().copied().fold(f64::INFINITY, f64::min);
    eprintln!("ε_p from {eps_min} to {eps_max}: max |Δε_p| = {de:e}");
    assert!(
        eps_min > 0.05,
        "the whole wall must flow: min ε_p = {eps_min}"
    );
    assert!(de < 1e-3 * eps_max, "max |Δε_p| = {de:e} of {eps_max}");
}
