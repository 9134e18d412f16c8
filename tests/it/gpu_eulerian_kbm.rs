//! The Krongauz–Belytschko method on an Eulerian kernel (`kernel_frame = "eulerian"`) on
//! the GPU against the f64 CPU reference on a software (or real) adapter: one rate
//! evaluation of a rotated, stretched and disordered state in 2D and 3D, the device's
//! lists against the CPU's set for set, and whole runs whose particles move past the
//! search distance between the searches. A missing adapter fails these tests.

use crate::common::{gpu, max_s, max_t, max_v, noise, random_tensor, random_vector};
use crate::galerkin::block;
use meshless::core::integrate::{Integrator, OdeSystem};
use meshless::core::neighbour::Csr;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::layout::GpuDim;
use meshless::methods::Method;
use meshless::methods::cores::galerkin::updated::{MovingPoints, UlGalerkin, UlGalerkinState};
use meshless::methods::kbm::KbmSpec;
use meshless::methods::kbm::eulerian::EulerianPoints;
use meshless::methods::kbm::gpu::GpuEulerianKbm;
use meshless::run::{Engine, build_method};
use meshless::scene::Scene;

type Eulerian<D> = UlGalerkin<D, EulerianPoints<D>>;

/// The device's engine of an Eulerian-kernel `kbm` case.
fn device<D: GpuDim>(case: &Scene) -> GpuEulerianKbm<D> {
    GpuEulerianKbm::<D>::new(case, crate::common::spec_of::<KbmSpec>(case), gpu()).unwrap()
}

/// A state far from the reference: the block rotated by 1 rad and stretched by up to
/// 10 % (x = R (I + G) X, particles and stress points alike), with |Δu| ~ 1 mm (1 % of
/// Δx) of noise on top, |v| ~ 1 m/s, ρ within 1 % of ρ0 and |S| ~ 1e4 Pa. The lists are
/// the reference configuration's on both backends, which a rotation keeps.
fn deformed<D: Dim>(m: &Eulerian<D>, seed: u64) -> UlGalerkinState<D> {
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
    let n = y.u.len();
    for (u, v) in y.u.iter_mut().zip(y.v.iter_mut()) {
        *u = random_vector::<D>(&mut seed, 1e-3);
        *v = random_vector::<D>(&mut seed, 1.0);
    }
    let x0 = &m.points().points().x0;
    for (q, pu) in y.point_u.iter_mut().enumerate() {
        let noise = if q < n {
            y.u[q]
        } else {
            random_vector::<D>(&mut seed, 1e-3)
        };
        *pu = map * x0[q] - x0[q] + noise;
    }
    y.u.copy_from_slice(&y.point_u[..n]);
    for (rho, s) in y.rho.iter_mut().zip(y.s.iter_mut()) {
        *rho *= 1.0 + 0.01 * noise(&mut seed);
        *s = random_tensor::<D>(&mut seed, 1e4);
    }
    y
}

/// One rate evaluation of a deformed state ([`deformed`]) on both backends. Each node's
/// acceleration is a sum over 20–60 points of w_q σ_q ∇W^S_a(x_q), each from the Shepard
/// sums, M_q⁻¹ and the gradients of 10–40 f32 kernel evaluations (ε = 6e-8); the bound is
/// the other updated-Lagrangian methods' (tests/it/gpu_ul_galerkin.rs): 1e-4 of the sum of
/// the terms' magnitudes, which cancel in the interior. ρ̇ and Ṡ from L_q = Σ_a (v_a −
/// v_o) ⊗ G_a: 1e-5 of the largest rate; the stress points' ẋ_q = Σ_a W^S_a v_a, a convex
/// combination of |v| ~ 1 m/s: 1e-5 of the largest.
fn compare_rates<D: GpuDim>(case: &Scene) {
    let mut cpu: Eulerian<D> = build_method(case).unwrap();
    let y = deformed(&cpu, 7);
    let mut d = y.clone();
    cpu.rates(0.0, &y, &mut d).unwrap();
    let dg = device::<D>(case).rates(&y);
    let what = format!(
        "eulerian kbm {}D {:?} ({} points)",
        D::N,
        case.material.model,
        y.point_u.len()
    );
    let (shapes, gather) = (cpu.shapes(), cpu.shapes().gather(y.u.len()));
    let test = shapes.test_gradients();
    let (w, sigma) = (cpu.weights(), cpu.stresses());
    let mut worst = 0.0f64;
    for a in 0..d.v.len() {
        let terms: f64 = gather
            .range(a)
            .map(|e| {
                let (q, p) = (gather.point[e] as usize, gather.pair[e] as usize);
                w[q] * D::ddot(sigma[q], sigma[q]).sqrt() * D::norm2(test[p]).sqrt()
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
    let mut rates = (0.0, 0.0);
    if !d.rho.is_empty() {
        let (er, scale_r) = max_s(&d.rho, &dg.rho);
        assert!(er < 1e-5 * scale_r, "{what}: |Δρ̇| = {er:e} of {scale_r:e}");
        let (es, scale_s) = max_t::<D>(&d.s, &dg.s);
        assert!(es < 1e-5 * scale_s, "{what}: |ΔṠ| = {es:e} of {scale_s:e}");
        rates = (er / scale_r, es / scale_s);
    }
    eprintln!(
        "{what}: a {worst:.2e} of the terms, ẋ {:.2e}, ρ̇ {:.2e}, Ṡ {:.2e}",
        ex / scale_x,
        rates.0,
        rates.1
    );
}

/// The keys of the Eulerian kernel with `integration`.
fn eulerian(integration: &str) -> String {
    format!("kernel_frame = \"eulerian\"\nintegration = \"{integration}\"")
}

#[test]
fn eulerian_kbm_rates_match_the_cpu() {
    for model in ["hypoelastic", "saint-venant-kirchhoff", "neo-hookean"] {
        let keys = eulerian("stress-points");
        compare_rates::<D2>(&block(&[1.0, 0.6], model, "kbm", &keys));
    }
    compare_rates::<D2>(&block(
        &[1.0, 0.6],
        "neo-hookean",
        "kbm",
        &eulerian("nodal"),
    ));
    let keys = eulerian("stress-points");
    compare_rates::<D3>(&block(&[0.4, 0.3, 0.3], "hypoelastic", "kbm", &keys));
    compare_rates::<D3>(&block(&[0.4, 0.3, 0.3], "neo-hookean", "kbm", &keys));
}

/// The lists as sets, row by row.
fn sorted(csr: &Csr) -> Vec<Vec<u32>> {
    (0..csr.offsets.len() - 1)
        .map(|q| {
            let mut row = csr.neighbours(q).to_vec();
            row.sort_unstable();
            row
        })
        .collect()
}

/// A block of `model` under the Eulerian kernel with `search_every`, sheared by
/// v_x = 20 s⁻¹ (y − y_c) and spun by v_y = 10 s⁻¹ (x − x_c): in 0.01 s neighbours 2.86Δx
/// apart (the reach) slide 0.57Δx past each other, twice the skin (0.29Δx), so the
/// searches every 10 steps change the lists.
fn sheared(max: &[f64], model: &str) -> Scene {
    let keys = eulerian("stress-points") + "\nsearch_every = 10";
    let (xc, yc) = (max[0] / 2.0, max[1] / 2.0);
    let vz = if max.len() == 3 { ", vz = \"0\"" } else { "" };
    let velocity = format!(
        "initial_velocity = {{ type = \"expression\", vx = \"20*(y-{yc})\", vy = \"10*(x-{xc})\"{vz} }}\n"
    );
    let text = crate::common::block_text(max, model, "kbm", &keys).replacen(
        "volumes = \"uniform\" }\n",
        &format!("volumes = \"uniform\" }}\n{velocity}"),
        1,
    );
    let path = std::path::Path::new("sheared.toml");
    Scene::from_toml(&text, path, &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// 100 steps of Δt = 1e-4 s (a tenth of the CFL step) on both backends, searching every
/// 10 steps; the states, energies and the last search's lists compared.
fn compare_runs<D: GpuDim>(case: &Scene) {
    let (dt, steps) = (1e-4, 100);
    let mut cpu: Eulerian<D> = build_method(case).unwrap();
    let first = sorted(cpu.points().lists());
    let mut y = cpu.initial_state();
    let mut integrator = Integrator::new(case.method.integrator, &y);
    let mut searched = y.clone();
    for k in 0..steps {
        if k == steps - 1 {
            searched = y.clone();
        }
        integrator
            .step(&mut cpu, k as f64 * dt, dt, &mut y)
            .unwrap();
    }
    let mut g = device::<D>(case);
    g.advance_steps(dt, steps as u32).unwrap();
    g.check().unwrap();
    let what = format!("eulerian kbm {}D {:?}", D::N, case.material.model);
    // The last search was at the start of the 100th step, from the state after 99: the
    // lists are the CPU's set for set, but for pairs whose distance then lies within the
    // f32 rounding and the device's margin (1e-5, gpu::neighbour) of the reach.
    let (lists, device_lists) = (sorted(cpu.points().lists()), sorted(&g.lists()));
    assert_ne!(
        lists, first,
        "{what}: the searches left the lists as they were"
    );
    let x = |q: usize| cpu.points().points().x0[q] + searched.point_u[q];
    let reach = case.kernel(D::N).support() * (1.0 + meshless::core::neighbour::SKIN);
    let mut differing = 0;
    for (q, (a, b)) in lists.iter().zip(&device_lists).enumerate() {
        for &p in a
            .iter()
            .filter(|p| !b.contains(p))
            .chain(b.iter().filter(|p| !a.contains(p)))
        {
            let r = D::norm2(x(q) - x(p as usize)).sqrt();
            assert!(
                (r / reach - 1.0).abs() < 2e-5,
                "{what}: point {q} and particle {p} at {r} apart (reach {reach}) in one list only"
            );
            differing += 1;
        }
    }
    // f32 round-off of v per stage update ~ 6e-8 |v|, accumulating at worst linearly over
    // 100 steps of several stages: 3e-5 of max |v|; bound 1e-4, as for the other
    // updated-Lagrangian methods (tests/it/gpu_ul_galerkin.rs). The kinetic energy of the
    // reduction (f32 partials of ≤ 256 positive terms): 1e-5; the stored energy, second
    // order in the strain that f32 resolves of F − I: 1e-3.
    let yg = g.state();
    let (ev, scale) = max_v::<D>(&y.v, &yg.v);
    assert!(ev < 1e-4 * scale, "{what}: max |Δv| = {ev:e} of {scale:e}");
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
        "{what}: kinetic energy {} against {kinetic}",
        invariants.kinetic
    );
    assert!(
        es < 1e-3,
        "{what}: stored energy {} against {strain}",
        invariants.strain
    );
    eprintln!(
        "{what}: v {:.2e}, kinetic {ek:.2e}, stored {es:.2e}; {differing} pairs at the reach in one list",
        ev / scale
    );
}

#[test]
fn eulerian_kbm_whole_runs_track_the_cpu_through_the_searches() {
    compare_runs::<D2>(&sheared(&[1.0, 0.6], "hypoelastic"));
    compare_runs::<D3>(&sheared(&[0.4, 0.3, 0.3], "neo-hookean"));
}

#[test]
fn a_search_past_the_room_grows_the_lists_and_runs_the_batch_again() {
    // A block squeezed at 30 s⁻¹ from the centre, searching every 5 steps: lists with room
    // for exactly the first search's pairs overflow at the second search (the block 1.5 %
    // smaller, more points within reach); the engine grows them, searches again from the
    // positions of the last search before the batch and runs the batch again, ending on the
    // bits of a run whose lists had room from the start. Elastic (the rate model) and von
    // Mises with τ_y = 1 kPa (yielding at 0.1 % strain, so that every step commits a
    // history the rerun must start from anew).
    let plastic = "poisson_ratio = 0.3\nyield_stress = 1.0e3\nhardening_modulus = 1.0e4";
    for (model, extra) in [("hypoelastic", ""), ("von-mises-plastic", plastic)] {
        let keys = eulerian("stress-points") + "\nsearch_every = 5";
        let text = crate::common::block_text(&[1.0, 0.6], model, "kbm", &keys);
        let text = if extra.is_empty() {
            text
        } else {
            text.replacen("poisson_ratio = 0.3", extra, 1)
        };
        let squeeze = "initial_velocity = { type = \"expression\", vx = \"-30*(x-0.5)\", vy = \"-30*(y-0.3)\" }\n";
        let text = text.replacen(
            "volumes = \"uniform\" }\n",
            &format!("volumes = \"uniform\" }}\n{squeeze}"),
            1,
        );
        let case = Scene::from_toml(&text, std::path::Path::new("squeezed.toml"), &[]).unwrap();
        let mut roomy = device::<D2>(&case);
        let mut tight = device::<D2>(&case);
        let first = tight.pairs();
        tight.set_capacity(first).unwrap();
        assert_eq!(tight.capacity(), first);
        for g in [&mut roomy, &mut tight] {
            g.advance_steps(1e-4, 20).unwrap();
            g.check().unwrap();
        }
        assert!(tight.pairs() > first, "{model}: the squeeze added no pairs");
        assert!(
            tight.capacity() >= tight.pairs(),
            "{model}: the lists did not grow"
        );
        let bits = |g: &mut GpuEulerianKbm<D2>| -> Vec<u64> {
            let y = g.state();
            let snap = Engine::<D2>::snapshot(g);
            let eps_p = snap.extra.iter().flat_map(|f| f.values.iter().copied());
            (y.u.iter().chain(&y.v).chain(&y.point_u))
                .flat_map(|&v| D2::to3(v))
                .chain(y.rho.iter().copied())
                .chain(eps_p.collect::<Vec<_>>())
                .map(f64::to_bits)
                .collect()
        };
        if !extra.is_empty() {
            let snap = Engine::<D2>::snapshot(&mut tight);
            let eps_p = snap
                .field(meshless::physics::plasticity::PLASTIC_STRAIN)
                .unwrap();
            assert!(
                eps_p.iter().all(|&e| e > 0.0),
                "{model}: not every point yielded"
            );
        }
        assert!(
            bits(&mut roomy) == bits(&mut tight),
            "{model}: the grown run left the roomy run's bits"
        );
    }
}

#[test]
fn the_eulerian_steel_ring_flows_plastically_as_on_the_cpu() {
    // The steel ring of tests/it/gpu_galerkin.rs (J2 with softening, the history at the
    // particles and the stress points, no imperfection) on the Eulerian kernel: 300 leapfrog
    // steps of 0.16 µs, searching every 30, by 48 µs the whole wall yielded. The GPU
    // commits its f32 history from the step's start state before every step, on the lists
    // of the last search, as the CPU does in f64. The bounds are the Lagrangian kernel's:
    // the displacement within 1e-4 of its largest (f32 round-off through the return
    // map's tangent over 300 steps, ~1e-5), ε_p within 1e-3 of its largest (the gradient's
    // round-off, larger by the ring's size over the spacing, 30).
    let case = crate::common::load(
        "steel-ring-kbm",
        &[
            "body.0.velocity_noise.amplitude=0",
            "method.cfl=",
            "method.dt=1.6e-7",
            "method.kernel_frame=eulerian",
        ],
    );
    let (dt, steps) = (1.6e-7, 300);
    let mut cpu = meshless::scene::cpu_engine::<D2, Eulerian<D2>>(&case).unwrap();
    cpu.advance(0.0, dt, steps).unwrap();
    let mut g = device::<D2>(&case);
    Engine::<D2>::advance(&mut g, 0.0, dt, steps).unwrap();
    g.check().unwrap();
    let (on_cpu, on_gpu) = (cpu.snapshot(), Engine::<D2>::snapshot(&mut g));
    let (du, largest) = max_v::<D2>(&on_cpu.u, &on_gpu.u);
    let field = |s: &meshless::diagnostics::observe::Snapshot<D2>| {
        s.field(meshless::physics::plasticity::PLASTIC_STRAIN)
            .unwrap()
            .to_vec()
    };
    let (eps_cpu, eps_gpu) = (field(&on_cpu), field(&on_gpu));
    let (de, eps_max) = max_s(&eps_cpu, &eps_gpu);
    let eps_min = eps_cpu.iter().copied().fold(f64::INFINITY, f64::min);
    eprintln!(
        "eulerian steel ring: max |Δu| = {du:e} of {largest:e} m; ε_p from {eps_min} to \
         {eps_max}: max |Δε_p| = {de:e}"
    );
    assert!(du < 1e-4 * largest, "max |Δu| = {du:e} of {largest:e} m");
    assert!(
        eps_min > 0.05,
        "the whole wall must flow: min ε_p = {eps_min}"
    );
    assert!(de < 1e-3 * eps_max, "max |Δε_p| = {de:e} of {eps_max}");
}
