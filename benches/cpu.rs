//! CPU-path throughput in particle-steps per second (criterion's elements/s).
//!
//! One benchmark iteration is one time step of the whole scene, with
//! `Throughput::Elements(particle count)`, so elements/s = particle-steps/s. Each size
//! runs on a local rayon pool of 1 and 2 threads. The state advances between iterations
//! (one step's cost does not depend on the time); the time step is scaled with the
//! spacing to keep the CFL number ≤ 0.2 so nothing blows up over the iterations.
//!
//! Groups:
//! - `rotating_disk`: `cases/rotating-disk.toml` (hypoelastic, RK4) at the paper's 276
//!   particles and refined to ~1e4 and ~1e5 particles; leapfrog at ~1e4.
//! - `tensile_strip`: `cases/tensile-strip.toml` with leapfrog and Saint Venant–Kirchhoff
//!   (the 2D linear-elastic strip of the LAMMPS comparison) at ~1e4 and ~1e5 particles;
//!   the case's hypoelastic model at ~1e5 for comparison.
//! - `neighbour_build`: the cell-list neighbour build on the ~1e5-particle disk.
//! - `methods`: one step of every method of the registry (`meshless list`) on a case of
//!   its own at about 2,000 particles (`common`), through the engine `meshless run`
//!   builds, on a thread of the global pool; each sample steps an engine of its own,
//!   built untimed. For the static dual-support method, one load step of the plate (400
//!   particles) from a freshly built engine, the build not timed.

mod common;

use criterion::{
    BatchSize, BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use meshless::core::integrate::Integrator;
use meshless::core::kernel::Kernel;
use meshless::core::tensor::D2;
use meshless::methods::tlsph::Tlsph;
use meshless::methods::{Method, REGISTRY};
use meshless::run::{Backend, Engine, build_method, engine};
use meshless::scene::Scene;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

const THREADS: [usize; 2] = [1, 2];

/// Bulk wave speed bound used to scale dt (m/s) and the CFL number kept.
const WAVE_SPEED: f64 = 4700.0;
const CFL: f64 = 0.2;

fn case_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(name)
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("rayon pool")
}

/// Loads a case with `--set`-style overrides; a refined `spacing` also gets a scaled dt.
fn load(file: &str, spacing: Option<f64>, extra: &[&str]) -> Scene {
    let mut overrides: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
    if let Some(dx) = spacing {
        overrides.push(format!("spacing={dx:e}"));
        let dt = (CFL * dx / WAVE_SPEED).min(1.0e-6);
        overrides.push(format!("method.dt={dt:e}"));
    }
    Scene::load(&case_path(file), &overrides).expect("case loads")
}

/// Benchmarks one time step of `case` on 1 and 2 threads as `label/threads=n/particles`.
fn bench_steps(c: &mut Criterion, group: &str, label: &str, case: &Scene) {
    let mut g = c.benchmark_group(group);
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3))
        .sampling_mode(SamplingMode::Flat);
    for threads in THREADS {
        let pool = pool(threads);
        let mut method =
            pool.install(|| build_method::<D2, Tlsph<D2>>(case).expect("method builds"));
        let mut state = method.initial_state();
        let mut integrator = Integrator::new(case.method.integrator, &state);
        let dt = case.method.dt.expect("case has a fixed dt");
        let n = method.reference().len();
        g.throughput(Throughput::Elements(n as u64));
        let mut t = 0.0;
        g.bench_with_input(
            BenchmarkId::new(format!("{label}/threads={threads}"), n),
            &n,
            |b, _| {
                pool.install(|| {
                    b.iter(|| {
                        integrator
                            .step(&mut method, t, dt, &mut state)
                            .expect("step stays finite");
                        t += dt;
                    })
                })
            },
        );
        method.check_finite(&state).expect("state stays finite");
    }
    g.finish();
}

fn rotating_disk(c: &mut Criterion) {
    let file = "rotating-disk.toml";
    for spacing in [None, Some(0.0177), Some(0.0056)] {
        bench_steps(c, "rotating_disk", "rk4", &load(file, spacing, &[]));
    }
    let leapfrog = load(file, Some(0.0177), &["method.integrator=leapfrog"]);
    bench_steps(c, "rotating_disk", "leapfrog", &leapfrog);
}

fn tensile_strip(c: &mut Criterion) {
    let file = "tensile-strip.toml";
    let svk = [
        "method.integrator=leapfrog",
        "material.model=\"saint-venant-kirchhoff\"",
    ];
    for spacing in [0.01, 1.0 / 316.0] {
        bench_steps(
            c,
            "tensile_strip",
            "leapfrog-svk",
            &load(file, Some(spacing), &svk),
        );
    }
    let hypo = load(file, Some(1.0 / 316.0), &["method.integrator=leapfrog"]);
    bench_steps(c, "tensile_strip", "leapfrog-hypoelastic", &hypo);
}

fn neighbour_build(c: &mut Criterion) {
    let case = load("rotating-disk.toml", Some(0.0056), &[]);
    let method = build_method::<D2, Tlsph<D2>>(&case).expect("method builds");
    let x = method.reference();
    let h = case.method.h_over_dx * case.spacing;
    let radius = Kernel::new(case.method.kernel, h, 2).support() * (1.0 + 1e-9);
    let mut g = c.benchmark_group("neighbour_build");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3))
        .sampling_mode(SamplingMode::Flat)
        .throughput(Throughput::Elements(x.len() as u64));
    for threads in THREADS {
        let pool = pool(threads);
        g.bench_with_input(
            BenchmarkId::new(format!("threads={threads}"), x.len()),
            x,
            |b, x| {
                pool.install(|| {
                    b.iter(|| meshless::core::neighbour::build::<D2>(black_box(x), radius))
                })
            },
        );
    }
    g.finish();
}

fn methods(c: &mut Criterion) {
    let mut g = c.benchmark_group("methods");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2))
        .sampling_mode(SamplingMode::Flat);
    for entry in REGISTRY {
        let (case, kind) = common::method_case(entry.name);
        let build = || engine::<D2>(&case, Backend::Cpu).expect("CPU engine builds");
        let mut probe = build();
        let dt = common::time_step(&case, probe.as_mut());
        let n = probe.reference().len();
        g.throughput(Throughput::Elements(n as u64));
        let id = BenchmarkId::new(entry.name, n);
        // Each sample builds its engine (untimed) and steps it on a thread of the global
        // pool, as `meshless run` and `meshless bench` do: a step's parallel loops then
        // start inside the pool instead of handing over from the bench's thread.
        g.bench_function(id, |b| {
            rayon::scope(|_| match kind {
                common::Kind::Static => b.iter_batched(
                    build,
                    |mut e| e.advance(0.0, dt, 1).expect("load step converges"),
                    BatchSize::PerIteration,
                ),
                common::Kind::Dynamic => {
                    let mut stepper = build();
                    let mut t = 0.0;
                    b.iter(|| {
                        stepper.advance(t, dt, 1).expect("step stays finite");
                        t += dt;
                    });
                    stepper.check().expect("state stays finite");
                }
            })
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    rotating_disk,
    tensile_strip,
    neighbour_build,
    methods
);
criterion_main!(benches);
