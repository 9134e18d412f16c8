//! The updated-Lagrangian weak form (`ul-weak-form`) on the GPU against the f64 CPU
//! reference on a software (or real) adapter: one rate evaluation of a rotated, stretched
//! and disordered state in 2D and 3D, the device's ellipse neighbourhoods against the
//! CPU's set for set, whole runs with the velocity smoothing, and a collapsed particle.
//! A missing adapter fails these tests.

use crate::common::{gpu, load, max_s, max_t, max_v, noise, random_tensor, random_vector};
use crate::galerkin::block;
use meshless::core::integrate::{Integrator, OdeSystem};
use meshless::core::neighbour::Csr;
use meshless::core::neighbourhood::Ellipse;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::layout::GpuDim;
use meshless::methods::Method;
use meshless::methods::cores::galerkin::updated::{MovingPoints, UlGalerkin, UlGalerkinState};
use meshless::methods::ul_weak_form::UlWeakFormSpec;
use meshless::methods::ul_weak_form::gpu::GpuUlWeakForm;
use meshless::methods::ul_weak_form::points::StressPoints;
use meshless::run::{Engine, build_method};
use meshless::scene::Scene;

type UlWeak<D> = UlGalerkin<D, StressPoints<D>>;

/// The device's engine of a `ul-weak-form` case.
fn device<D: GpuDim>(case: &Scene) -> GpuUlWeakForm<D> {
    GpuUlWeakForm::<D>::new(case, crate::common::spec_of::<UlWeakFormSpec>(case), gpu()).unwrap()
}

/// A state far from the reference: the block rotated by 1 rad and stretched by up to
/// 10 % (x = R (I + G) X, particles and stress points alike), with |Δu| ~ 1 mm (1 % of
/// Δx) of noise on top, |v| ~ 1 m/s, ρ within 1 % of ρ0 at the particles and stress
/// points and |S| ~ 1e4 Pa. A linear map keeps every r · C⁻¹ r, so that the ellipses keep
/// the candidates of the reference configuration but where the noise moves one across.
fn deformed<D: Dim>(m: &UlWeak<D>, seed: u64) -> UlGalerkinState<D> {
    let mut seed = seed;
    let (c, s) = (1f64.cos(), 1f64.sin());
    // The columns of R (I + G), the rotation about z.
    let columns = [
        [1.1 * c, 1.1 * s + 0.05 * c, 0.0],
        [-0.95 * s, 0.95 * c, 0.03],
        [0.0, 0.0, 1.05],
    ];
    let map = crate::common::of_columns::<D>(&columns);
    let mut y = m.initial_state();
    for ((u, v), &x) in y.u.iter_mut().zip(y.v.iter_mut()).zip(m.reference()) {
        *u = map * x - x + random_vector::<D>(&mut seed, 1e-3);
        *v = random_vector::<D>(&mut seed, 1.0);
    }
    let x0 = &m.points().points().x0;
    for (pu, &x) in y.point_u.iter_mut().zip(x0) {
        *pu = map * x - x + random_vector::<D>(&mut seed, 1e-3);
    }
    for rho in y.rho.iter_mut().chain(y.node_rho.iter_mut()) {
        *rho *= 1.0 + 0.01 * noise(&mut seed);
    }
    for s in y.s.iter_mut() {
        *s = random_tensor::<D>(&mut seed, 1e4);
    }
    y
}

/// The candidates each stress point's ellipse keeps in state y, by the CPU's ellipses
/// (f64) at the state's positions.
fn cpu_ellipses<D: Dim>(m: &UlWeak<D>, y: &UlGalerkinState<D>) -> Csr {
    let lists = m.points().lists();
    let points = &m.points().points().x0;
    let x = |j: u32| m.reference()[j as usize] + y.u[j as usize];
    let mut kept = Csr {
        offsets: vec![0],
        ids: Vec::new(),
    };
    for (q, (&x0, &u)) in points.iter().zip(&y.point_u).enumerate() {
        let centre = x0 + u;
        let row = lists.neighbours(q);
        let r: Vec<D::V> = row.iter().map(|&j| centre - x(j)).collect();
        let ellipse = Ellipse::<D>::new(&r).unwrap();
        let inside = row.iter().zip(&r).filter(|&(_, &r)| ellipse.contains(r));
        kept.ids.extend(inside.map(|(&j, _)| j));
        kept.offsets.push(kept.ids.len());
    }
    kept
}

/// One rate evaluation of a deformed state ([`deformed`]) on both backends. Each node's
/// acceleration is a sum over its stress points of w_q σ_q ∇N_j(x_q), each from an
/// ellipse and RKPM moments of 15–50 f32 kernel evaluations (ε = 6e-8); the bound is the
/// other updated-Lagrangian methods' (tests/it/gpu_ul_galerkin.rs): 1e-4 of the sum of the
/// terms' magnitudes, which cancel in the interior. ρ̇ and Ṡ at the stress points and ρ̇
/// at the particles, from L = Σ_j (v_j − v_o) ⊗ ∇N_j: 1e-5 of the largest rate; the stress
/// points' ẋ_q = Σ_j N_j v_j, a near-convex combination of |v| ~ 1 m/s: 1e-5 of the
/// largest. The device's ellipses are the CPU's set for set.
fn compare_rates<D: GpuDim>(case: &Scene) {
    let mut cpu: UlWeak<D> = build_method(case).unwrap();
    let y = deformed(&cpu, 7);
    let mut d = y.clone();
    cpu.rates(0.0, &y, &mut d).unwrap();
    let mut g = device::<D>(case);
    let dg = g.rates(&y);
    let what = format!("ul-weak-form {}D ({} stress points)", D::N, y.point_u.len());
    let kept = cpu_ellipses(&cpu, &y);
    assert!(
        kept == g.ellipses().unwrap(),
        "{what}: the device's ellipses are not the CPU's"
    );
    let (shapes, gather) = (cpu.shapes(), cpu.shapes().gather(y.u.len()));
    let (w, sigma) = (cpu.weights(), cpu.stresses());
    let mut worst = 0.0f64;
    for a in 0..d.v.len() {
        let terms: f64 = gather
            .range(a)
            .map(|e| {
                let (q, p) = (gather.point[e] as usize, gather.pair[e] as usize);
                w[q] * D::ddot(sigma[q], sigma[q]).sqrt() * D::norm2(shapes.grad[p]).sqrt()
            })
            .sum::<f64>()
            / cpu.mass()[a];
        let diff = D::norm2(d.v[a] - dg.v[a]).sqrt();
        worst = worst.max(diff / terms);
        assert!(
            diff <= 1e-4 * terms,
            "{what}: node {a}: |Δa| = {diff:e} of {terms:e}"
        );
    }
    let (eu, scale_v) = max_v::<D>(&d.u, &dg.u);
    assert!(eu < 1e-6 * scale_v, "{what}: u̇ off by {eu:e}");
    let (ex, scale_x) = max_v::<D>(&d.point_u, &dg.point_u);
    assert!(
        ex < 1e-5 * scale_x,
        "{what}: ẋ_q off by {ex:e} of {scale_x:e}"
    );
    let mut rates = [0.0; 3];
    for (k, (a, b)) in [(&d.rho, &dg.rho), (&d.node_rho, &dg.node_rho)]
        .into_iter()
        .enumerate()
    {
        let (er, scale_r) = max_s(a, b);
        assert!(er < 1e-5 * scale_r, "{what}: |Δρ̇| = {er:e} of {scale_r:e}");
        rates[k] = er / scale_r;
    }
    let (es, scale_s) = max_t::<D>(&d.s, &dg.s);
    assert!(es < 1e-5 * scale_s, "{what}: |ΔṠ| = {es:e} of {scale_s:e}");
    rates[2] = es / scale_s;
    eprintln!(
        "{what}: a {worst:.2e} of the terms, ẋ {:.2e}, ρ̇ points {:.2e}, ρ̇ particles \
         {:.2e}, Ṡ {:.2e}; {} of {} candidates kept",
        ex / scale_x,
        rates[0],
        rates[1],
        rates[2],
        kept.ids.len(),
        cpu.points().lists().ids.len()
    );
}

#[test]
fn ul_weak_form_rates_and_ellipses_match_the_cpu() {
    compare_rates::<D2>(&block(&[1.0, 0.6], "hypoelastic", "ul-weak-form", ""));
    compare_rates::<D3>(&block(&[0.4, 0.3, 0.3], "hypoelastic", "ul-weak-form", ""));
}

/// `steps` steps of `dt` of the case on both backends; the velocities, the stress points'
/// positions, the energies and the ellipses at the end compared. f32 round-off of v per
/// stage update ~ 6e-8 |v|, four stages and a smoothing per step, accumulating at worst
/// linearly over 100 steps: 3e-5 of max |v|; bound 1e-4, as for the other
/// updated-Lagrangian methods (tests/it/gpu_ul_galerkin.rs), and the same for the stress
/// points' displacements against their largest. The kinetic energy of the reduction (f32
/// partials of ≤ 256 positive terms): 1e-5; the stored energy, second order in the strain
/// that f32 resolves: 1e-3.
fn compare_runs<D: GpuDim>(name: &str, case: &Scene, dt: f64, steps: usize) {
    let mut cpu: UlWeak<D> = build_method(case).unwrap();
    let mut y = cpu.initial_state();
    let mut integrator = Integrator::new(case.method.integrator, &y);
    for k in 0..steps {
        integrator
            .step(&mut cpu, k as f64 * dt, dt, &mut y)
            .unwrap();
    }
    let mut g = device::<D>(case);
    g.advance_steps(dt, steps as u32).unwrap();
    g.check().unwrap();
    let yg = g.state();
    let (ev, scale) = max_v::<D>(&y.v, &yg.v);
    assert!(ev < 1e-4 * scale, "{name}: max |Δv| = {ev:e} of {scale:e}");
    let (ex, scale_x) = max_v::<D>(&y.point_u, &yg.point_u);
    assert!(
        ex < 1e-4 * scale_x,
        "{name}: max |Δx_q| = {ex:e} of {scale_x:e}"
    );
    assert!(
        cpu_ellipses(&cpu, &y) == g.ellipses().unwrap(),
        "{name}: the device's ellipses after {steps} steps are not the CPU's"
    );
    let kinetic: f64 = (y.v.iter().zip(cpu.mass()))
        .map(|(&v, m)| 0.5 * m * D::norm2(v))
        .sum();
    let strain = cpu.strain_energy(&y).value();
    let invariants = g.invariants();
    let (ek, es) = (
        (invariants.kinetic / kinetic - 1.0).abs(),
        (invariants.strain / strain - 1.0).abs(),
    );
    assert!(
        ek < 1e-5,
        "{name}: kinetic energy {} against {kinetic}",
        invariants.kinetic
    );
    assert!(
        es < 1e-3,
        "{name}: stored energy {} against {strain}",
        invariants.strain
    );
    eprintln!(
        "{name}: v {:.2e}, x_q {:.2e}, kinetic {ek:.2e}, stored {es:.2e}",
        ev / scale,
        ex / scale_x
    );
}

#[test]
fn ul_weak_form_whole_runs_track_the_cpu() {
    // The seed-000 strip (grips at ±10 m/s) and the rotating disk (ω = 50 rad/s, |v| ≤
    // 50 m/s: in 100 steps of 1e-5 s the rim moves 0.05 m, half a spacing, across the
    // candidate boxes fixed at set-up), both with the velocity smoothing after each step.
    for (name, dt) in [
        ("tensile-strip-ul-weak-form", 1e-6),
        ("rotating-disk-ul-weak-form", 1e-5),
    ] {
        compare_runs::<D2>(name, &load(name, &[] as &[&str]), dt, 100);
    }
    // The block template's h_over_dx left out: the method has no kernel keys.
    let spun = crate::common::block_text(&[0.4, 0.3, 0.3], "hypoelastic", "ul-weak-form", "")
        .replacen("h_over_dx = 1.3\n", "", 1)
        .replacen(
            "volumes = \"uniform\" }\n",
            "volumes = \"uniform\" }\ninitial_velocity = { type = \"rigid-rotation\", \
             omega = 50.0, axis = [0.0, 0.0, 1.0], center = [0.2, 0.15, 0.15] }\n",
            1,
        );
    let case = Scene::from_toml(&spun, std::path::Path::new("spun.toml"), &[]).unwrap();
    compare_runs::<D3>("spun block 3D", &case, 1e-5, 100);
}

#[test]
fn a_collapsed_particle_stops_the_gpu_run_by_name() {
    // A particle's density driven to −ρ0 (its volume m/ρ negative) is flagged by the
    // particles pass and reported as the density at that particle.
    let case = block(&[1.0, 0.6], "hypoelastic", "ul-weak-form", "");
    let cpu: UlWeak<D2> = build_method(&case).unwrap();
    let mut y = cpu.initial_state();
    y.node_rho[5] = -cpu.material().rho0;
    let mut g = device::<D2>(&case);
    g.rates(&y);
    let e = g.check().unwrap_err().to_string();
    assert!(e.contains("density (f32, GPU) at the particle"), "{e}");
}
