//! The updated-Lagrangian GPU engines (Gray–Monaghan and Godunov SPH) against the f64 CPU
//! reference on a software (or real) adapter: rates on disordered states in 2D and 3D,
//! whole runs that carry particles past the rebuild distance, and the device's rebuilt
//! lists against brute force. A missing adapter fails these tests.

use crate::common::{block_case, gpu, gpus, load, max_s, max_t, max_v, shipped};
use crate::gray_monaghan::random_state;
use meshless::core::neighbour::SKIN;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::Gpu;
use meshless::gpu::layout::GpuDim;
use meshless::methods::cores::ul::gpu::{GpuUl, Scheme};
use meshless::methods::cores::ul::{H_CAP, PairScheme, UlSph, UlState};
use meshless::methods::godunov::system::Scheme as GodunovScheme;
use meshless::methods::godunov::{Godunov, gpu as godunov};
use meshless::methods::gray_monaghan::system::Scheme as GmScheme;
use meshless::methods::gray_monaghan::{GrayMonaghan, gpu as gray_monaghan};
use meshless::methods::{Method, MethodSpec, Runs};
use meshless::reference::Build;
use meshless::run::{Engine, build_method};
use meshless::scene::Scene;

/// The GPU scheme of a UL case.
pub fn scheme(case: &Scene) -> Scheme {
    match &case.spec {
        MethodSpec::GrayMonaghanSph(spec) => gray_monaghan::scheme(case, spec),
        MethodSpec::GodunovSph(spec) => godunov::scheme(spec),
        other => panic!("not an updated-Lagrangian method: {other:?}"),
    }
}

/// The largest |Δ| of every rate between the CPU's `d` and the GPU's `g`, each relative
/// to the largest CPU rate of its kind.
fn rate_errors<D: Dim>(d: &UlState<D>, g: &UlState<D>) -> [(&'static str, f64); 5] {
    let rel = |(e, scale): (f64, f64)| e / scale.max(f64::MIN_POSITIVE);
    [
        ("ẋ", rel(max_v::<D>(&d.u, &g.u))),
        ("v̇", rel(max_v::<D>(&d.v, &g.v))),
        ("ρ̇", rel(max_s(&d.rho, &g.rho))),
        ("Ṡ", rel(max_t::<D>(&d.s, &g.s))),
        ("Ḟ", rel(max_t::<D>(&d.f, &g.f))),
    ]
}

/// One rate evaluation of the CPU system and of the GPU engine on a disordered state
/// (|u| ~ 0.2 Δx, |v| ~ 10 m/s, ρ within 1 %, |S| ~ 1e5 Pa in tension and compression).
fn compare_rates<D: GpuDim, S: PairScheme<D>>(case: &Scene)
where
    S::Spec: Runs,
{
    compare_rates_on::<D, S>(case, gpu());
}

/// [`compare_rates`] on `gpu`.
fn compare_rates_on<D: GpuDim, S: PairScheme<D>>(case: &Scene, gpu: Gpu)
where
    S::Spec: Runs,
{
    compare_edited_rates::<D, S>(case, gpu, |_| {});
}

/// [`compare_rates`] on `gpu`, with the disordered state changed by `edit`.
pub fn compare_edited_rates<D: GpuDim, S: PairScheme<D>>(
    case: &Scene,
    gpu: Gpu,
    edit: impl FnOnce(&mut UlState<D>),
) where
    S::Spec: Runs,
{
    let mut cpu: UlSph<D, S> = build_method(case).unwrap();
    let mut y = random_state(&cpu, case.spacing, &mut 17);
    edit(&mut y);
    let mut d = y.clone();
    meshless::core::integrate::OdeSystem::rates(&mut cpu, 0.0, &y, &mut d).unwrap();
    let mut g = GpuUl::<D>::new(case, gpu, &scheme(case)).unwrap();
    let dg = g.rates(&y);
    // Each rate is a gather of 20–80 pair terms of the random state, which do not cancel:
    // f32 rounding of the inputs (positions 6e-8 of |x| ≲ 1 m against pair distances of
    // 0.1 m, so ~1e-6 in x_ij and ∇W_ij; stresses and velocities 6e-8) and of the sums
    // leaves ~1e-6 of the largest rate; the inverse of the correction (A of
    // Randles–Libersky, the moment matrix of RKPM) adds its condition number (≲ 10 here).
    // Bound 1e-4 of the largest rate of each kind.
    for (what, e) in rate_errors::<D>(&d, &dg) {
        assert!(
            e < 1e-4,
            "{} {}D: max |Δ{what}| = {e:e} of the largest",
            case.name,
            D::N
        );
    }
}

pub fn block(dim: usize, method: &str, keys: &str) -> Scene {
    let max: &[f64] = if dim == 2 {
        &[1.0, 0.6]
    } else {
        &[0.5, 0.4, 0.3]
    };
    block_case(max, "hypoelastic", method, keys)
}

pub const GRAY_MONAGHAN_KEYS: &str = "artificial_viscosity = { alpha = 1.0, beta = 1.0 }\n\
    artificial_stress = { epsilon = 0.3, n = 4.0 }\nxsph = 0.5";

#[test]
fn gray_monaghan_rates_match_the_cpu_in_2d_and_3d() {
    for correction in ["none", "randles-libersky", "rkpm"] {
        let keys = format!("correction = \"{correction}\"\n{GRAY_MONAGHAN_KEYS}");
        compare_rates::<D2, GmScheme>(&block(2, "gray-monaghan-sph", &keys));
        compare_rates::<D3, GmScheme>(&block(3, "gray-monaghan-sph", &keys));
    }
    // The traction-free projection at the surface (`cauchy_of`), and the adaptive
    // smoothing lengths (the `smoothing` pass; with the surface, which reads h too).
    for extra in [
        "free_surface = \"projection\"",
        "smoothing_length = \"density\"\nfree_surface = \"projection\"",
        "smoothing_length = \"continuity\"\ncorrection = \"randles-libersky\"",
        "smoothing_length = \"density\"\ncorrection = \"rkpm\"",
    ] {
        let keys = format!("{extra}\n{GRAY_MONAGHAN_KEYS}");
        compare_rates::<D2, GmScheme>(&block(2, "gray-monaghan-sph", &keys));
        compare_rates::<D3, GmScheme>(&block(3, "gray-monaghan-sph", &keys));
    }
    // The prime space (2D): the `smoothing` pass's hull and each pair loop's test of it,
    // in the correction's, the surface's and the momentum's sums.
    for extra in [
        "smoothing_length = \"prime-space\"",
        "smoothing_length = \"prime-space\"\ncorrection = \"rkpm\"\nfree_surface = \"projection\"",
    ] {
        let keys = format!("{extra}\n{GRAY_MONAGHAN_KEYS}");
        compare_rates::<D2, GmScheme>(&block(2, "gray-monaghan-sph", &keys));
    }
}

#[test]
fn ul_rates_match_the_cpu_on_every_adapter() {
    // Both schemes with the Randles–Libersky correction (the updated-Lagrangian core's
    // neighbour loops, its device cell list and its correction pass) on every adapter
    // wgpu enumerates, with the bounds above.
    let keys = format!("correction = \"randles-libersky\"\n{GRAY_MONAGHAN_KEYS}");
    for gpu in gpus() {
        println!("adapter {}", gpu.name());
        compare_rates_on::<D2, GmScheme>(&block(2, "gray-monaghan-sph", &keys), gpu);
    }
    for gpu in gpus() {
        println!("adapter {}", gpu.name());
        let c = block(2, "godunov-sph", "correction = \"randles-libersky\"");
        compare_rates_on::<D2, GodunovScheme>(&c, gpu);
    }
}

#[test]
fn godunov_rates_match_the_cpu_in_2d_and_3d() {
    let projection = "correction = \"randles-libersky\"\nfree_surface = \"projection\"";
    let density = "correction = \"randles-libersky\"\nsmoothing_length = \"density\"";
    let continuity = "smoothing_length = \"continuity\"";
    for keys in ["none", "randles-libersky", "rkpm"]
        .map(|c| format!("correction = \"{c}\""))
        .into_iter()
        .chain([projection, density, continuity].map(String::from))
    {
        compare_rates::<D2, GodunovScheme>(&block(2, "godunov-sph", &keys));
        compare_rates::<D3, GodunovScheme>(&block(3, "godunov-sph", &keys));
    }
    let prime = "correction = \"randles-libersky\"\nsmoothing_length = \"prime-space\"";
    compare_rates::<D2, GodunovScheme>(&block(2, "godunov-sph", prime));
}

/// Runs `steps` steps of the shipped disk of `name` on both backends (on the GPU in
/// `batches` batches) and compares the final states; then the device's lists of that
/// state against brute force.
fn compare_runs<M: Method<D2, State = UlState<D2>> + Build<D2, Spec: Runs>>(
    name: &str,
    dt: f64,
    (steps, batches): (u32, u32),
    min_builds: i64,
) {
    let case = load(name, &[&format!("method.dt={dt}")]);
    let mut cpu = meshless::scene::cpu_engine::<D2, M>(&case).unwrap();
    cpu.advance(0.0, dt, steps).unwrap();
    let mut g = GpuUl::<D2>::new(&case, gpu(), &scheme(&case)).unwrap();
    let built = g.builds();
    for _ in 0..batches {
        g.advance(0.0, dt, steps / batches).unwrap();
    }
    g.check().unwrap();
    // Each batch builds at its start, and again once a particle has moved half the skin,
    // 0.05 × 2h = 0.018 m (`min_builds` in all: more than `batches` needs a rebuild from
    // the motion of the rim), and far fewer times than the 4 × steps rate evaluations (at
    // most 10).
    let builds = g.builds() - built;
    assert!(
        (min_builds..=10).contains(&builds),
        "{name}: {builds} builds"
    );
    let yg = g.state();
    // The rim moves 50 m/s × steps·dt = 0.05 m, past the half skin of the CPU's lists
    // (0.05 × 2h = 0.018 m), so both rebuilt their lists on the way. f32 rounding of u
    // (|x| ≤ 1 m ⇒ 6e-8 m) in 4 stage updates a step over 400 steps accumulates to at
    // most 1e-4 m if it adds up linearly; the bound is that.
    let (eu, _) = max_v::<D2>(&cpu.y.u, &yg.u);
    assert!(eu < 1e-4, "{name}: max |Δu| = {eu:e} m after {steps} steps");
    let (ev, _) = max_v::<D2>(&cpu.y.v, &yg.v);
    assert!(ev < 1e-2, "{name}: max |Δv| = {ev:e} m/s (|v| ≤ 50 m/s)");

    // The device's lists are those of its last build, searched with the skin
    // (1 + SKIN)·support and kept while no particle has moved half the skin since: every
    // pair within the support of the positions of the last rate evaluation (the last
    // stage of RK4, within one step of the final state) must be there, except those
    // within one step's motion (50 m/s × dt) or f32 rounding of the support; and no pair
    // farther than the skin plus both particles' allowed drift, (1 + 2 SKIN)·support.
    let lists = g.neighbours();
    let x: Vec<_> = g
        .reference()
        .x0
        .iter()
        .zip(&yg.u)
        .map(|(&x0, &u)| x0 + u)
        .collect();
    let support = g.reference().kernel.support();
    let slack = 50.0 * dt + 1e-5 * support;
    for i in 0..x.len() {
        let found = lists.neighbours(i);
        for j in 0..x.len() {
            if j == i {
                continue;
            }
            let r = (x[i] - x[j]).length();
            let listed = found.contains(&(j as u32));
            if r < support - slack {
                assert!(listed, "{name}: pair ({i}, {j}) at r = {r} missing");
            } else if r > support * (1.0 + 2.0 * SKIN) + slack {
                assert!(!listed, "{name}: pair ({i}, {j}) at r = {r} listed");
            }
        }
    }
}

#[test]
fn gray_monaghan_runs_track_the_cpu_past_the_rebuild_distance() {
    // The rim keeps its 50 m/s: each batch of 50 steps moves it 0.025 m, past half the
    // skin, so each batch builds twice at least.
    compare_runs::<GrayMonaghan<D2>>("rotating-disk-gray-monaghan", 1e-5, (100, 2), 3);
}

#[test]
fn godunov_runs_track_the_cpu_past_the_rebuild_distance() {
    // The Riemann traction stops the rotation within a few milliseconds and the rim
    // slows down from the start, so the steps go in one batch of 1 ms: its start builds
    // once, and the rim's travel past half the skin must build again within it.
    compare_runs::<Godunov<D2>>("rotating-disk-godunov", 2.5e-6, (400, 1), 2);
}

/// The largest differences between the CPU's and the device's runs: |Δu|, |Δv| and the
/// |Δh| of the smoothing-length fields; and the spread of the CPU's h.
fn disk_gaps(
    cpu: &mut meshless::engine::CpuEngine<D2, GrayMonaghan<D2>>,
    g: &mut GpuUl<D2>,
) -> [f64; 4] {
    let yg = g.state();
    let (eu, _) = max_v::<D2>(&cpu.y.u, &yg.u);
    let (ev, _) = max_v::<D2>(&cpu.y.v, &yg.v);
    let h = |s: &meshless::diagnostics::observe::Snapshot<D2>| -> Vec<f64> {
        let field = s.extra.iter().find(|f| f.name == "smoothing_length");
        field.expect("the smoothing_length field").values.clone()
    };
    let (hc, hg) = (h(&cpu.snapshot()), h(&g.snapshot()));
    let eh = hc
        .iter()
        .zip(&hg)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let spread =
        hc.iter().copied().fold(0.0, f64::max) - hc.iter().copied().fold(f64::MAX, f64::min);
    [eu, ev, eh, spread]
}

#[test]
fn adaptive_smoothing_lengths_track_the_cpu() {
    // The disk's rim at 50 m/s for 100 steps, each smoothing length on both backends: the
    // states within the bounds of `compare_runs` (f32 rounding of u over 400 stage
    // updates), and the h of the last rate evaluation (the output field) within 1e-5 of h:
    // eqs 60–61 stop at 1e-6 of h in f32, and the kernel sums carry the f32 rounding of
    // the positions (1e-6 of the pair distances).
    let dt = 1e-5;
    for mode in ["density", "continuity"] {
        let keys = [
            format!("method.dt={dt}"),
            format!("method.smoothing_length=\"{mode}\""),
        ];
        let case = load("rotating-disk-gray-monaghan", &[&keys[0], &keys[1]]);
        let mut cpu = meshless::scene::cpu_engine::<D2, GrayMonaghan<D2>>(&case).unwrap();
        cpu.advance(0.0, dt, 100).unwrap();
        let mut g = GpuUl::<D2>::new(&case, gpu(), &scheme(&case)).unwrap();
        g.advance(0.0, dt, 100).unwrap();
        g.check().unwrap();
        let [eu, ev, eh, spread] = disk_gaps(&mut cpu, &mut g);
        let h0 = cpu.method.core.kernel.h;
        eprintln!(
            "{mode}: max |Δu| = {eu:e} m, |Δv| = {ev:e} m/s, |Δh| = {eh:e} m, h0 = {h0}, spread {spread:e}"
        );
        assert!(eu < 1e-4, "{mode}: max |Δu| = {eu:e} m");
        assert!(ev < 1e-2, "{mode}: max |Δv| = {ev:e} m/s (|v| ≤ 50 m/s)");
        assert!(eh < 1e-5 * h0, "{mode}: max |Δh| = {eh:e} m of h = {h0}");
        // The comparison means something only where h varies past its bound.
        assert!(spread > 1e-4 * h0, "{mode}: h varies by {spread:e} only");
    }
}

#[test]
fn lists_that_overflow_grow_and_the_steps_run_again() {
    // Lists with room for one pair overflow at the first rebuild: the engine must grow
    // them to the count the device asked for and run the batch again from its start, so
    // that the state is bit for bit that of an engine whose lists never overflowed (the
    // same passes on the same device, lists sorted per particle).
    let case = shipped("rotating-disk-gray-monaghan");
    let run = |capacity: Option<u64>| {
        let mut g = GpuUl::<D2>::new(&case, gpu(), &scheme(&case)).unwrap();
        if let Some(c) = capacity {
            g.set_capacity(c).unwrap();
        }
        g.advance_steps(1e-5, 20).unwrap();
        let pairs = g.neighbours().pair_count() as u64;
        assert!(g.capacity() >= pairs, "capacity {} < {pairs}", g.capacity());
        (g.state(), g.capacity())
    };
    let (grown, capacity) = run(Some(1));
    let (roomy, _) = run(None);
    assert!(capacity > 1, "the lists did not grow");
    assert_eq!(grown.u, roomy.u);
    assert_eq!(grown.v, roomy.v);
    assert_eq!(grown.s, roomy.s);
}

/// Whether eq 63's choice at every particle of the disk at displacements `u` stays the
/// same when each offset is scaled by 1 ± 1e-5: above the f32 rounding of the offsets
/// (6e-8 of |x| ≤ 1 over |x_ij| ≥ Δx/2 = 0.05, 1.2e-6) with room for the device's
/// images and depths, so that both backends take the same pairs at that state.
fn prime_space_is_clear(x0: &[[f64; 2]], u: &[[f64; 2]], reach: f64) -> bool {
    use meshless::core::neighbourhood::prime_space;
    let x: Vec<[f64; 2]> = x0
        .iter()
        .zip(u)
        .map(|(a, b)| [a[0] + b[0], a[1] + b[1]])
        .collect();
    (0..x.len()).all(|i| {
        let offsets: Vec<[f64; 2]> = (0..x.len())
            .filter(|&j| j != i)
            .map(|j| [x[i][0] - x[j][0], x[i][1] - x[j][1]])
            .filter(|o| o[0] * o[0] + o[1] * o[1] <= reach * reach)
            .collect();
        let taken = prime_space(&offsets);
        [1e-5, -1e-5].iter().all(|eps| {
            // Each offset scaled by its own factor in [1 - 2ε, 1 + 2ε], along x and y.
            let scaled: Vec<[f64; 2]> = offsets
                .iter()
                .enumerate()
                .map(|(k, o)| {
                    let (a, b) = ((k * 7 % 5) as f64 - 2.0, (k * 3 % 5) as f64 - 2.0);
                    [o[0] * (1.0 + eps * a), o[1] * (1.0 - eps * b)]
                })
                .collect();
            prime_space(&scaled) == taken
        })
    })
}

#[test]
fn the_prime_space_tracks_the_cpu() {
    // Eq 63's choice is a step function of the positions: on the rotating disk the CPU's
    // pairs first change in the 14th step, then in most steps after, and a pair that one backend takes
    // a stage before the other parts the runs by its force. So the runs are compared over
    // the 12 steps in which the CPU's pairs stay those of the lattice (checked here), with
    // the bounds of `adaptive_smoothing_lengths_track_the_cpu`; and after 100 steps the
    // rates at the device's state, where no particle's choice is within the f32 band of
    // the tolerance (checked), within 1e-4 of the largest (`compare_rates`).
    let (dt, steps) = (1e-5, 12);
    let keys = [
        format!("method.dt={dt}"),
        "method.smoothing_length=\"prime-space\"".to_string(),
    ];
    let case = load("rotating-disk-gray-monaghan", &[&keys[0], &keys[1]]);
    let mut cpu = meshless::scene::cpu_engine::<D2, GrayMonaghan<D2>>(&case).unwrap();
    cpu.advance(0.0, dt, 1).unwrap();
    let lattice = cpu.method.core.neighbours().clone();
    for step in 1..steps {
        cpu.advance(step as f64 * dt, dt, 1).unwrap();
        assert!(
            *cpu.method.core.neighbours() == lattice,
            "the pairs change at step {step}"
        );
    }
    let mut g = GpuUl::<D2>::new(&case, gpu(), &scheme(&case)).unwrap();
    g.advance(0.0, dt, steps).unwrap();
    g.check().unwrap();
    let [eu, ev, eh, _] = disk_gaps(&mut cpu, &mut g);
    let h0 = cpu.method.core.kernel.h;
    eprintln!("prime space, {steps} steps: |Δu| = {eu:e} m, |Δv| = {ev:e} m/s, |Δh| = {eh:e} m");
    assert!(eu < 1e-4, "max |Δu| = {eu:e} m");
    assert!(ev < 1e-2, "max |Δv| = {ev:e} m/s (|v| ≤ 50 m/s)");
    assert!(eh < 1e-5 * h0, "max |Δh| = {eh:e} m of h = {h0}");

    g.advance(steps as f64 * dt, dt, 100 - steps).unwrap();
    g.check().unwrap();
    let yg = g.state();
    let core = &cpu.method.core;
    let reach = core.kernel.kind.support_factor() * H_CAP * h0;
    let pair = |v: &<D2 as Dim>::V| [v[0], v[1]];
    let x0: Vec<[f64; 2]> = core.x0.iter().map(pair).collect();
    let u: Vec<[f64; 2]> = yg.u.iter().map(pair).collect();
    assert!(
        prime_space_is_clear(&x0, &u, reach),
        "a choice at the device's state lies within the f32 band of the tolerance"
    );
    let mut d = yg.clone();
    meshless::core::integrate::OdeSystem::rates(&mut cpu.method, 0.0, &yg, &mut d).unwrap();
    for (what, e) in rate_errors::<D2>(&d, &g.rates(&yg)) {
        eprintln!("prime space at the device's state after 100 steps: |Δ{what}| = {e:e}");
        assert!(e < 1e-4, "max |Δ{what}| = {e:e} of the largest");
    }
}
