//! GPU-path throughput in particle-steps per second (criterion's elements/s): one
//! iteration is 10 time steps recorded into one command encoder and waited for, with
//! `Throughput::Elements(10 × particles)`. Scenes at about 1e3, 1e4 and 1e5 particles: the
//! rotating disk (2D, RK4) under TLSPH, Gray–Monaghan and Godunov SPH (the last two
//! rebuild their neighbours on the device before every rate evaluation), the potential's
//! tensile strip and the spinning 3D block (SSP-RK3); plus the TLSPH set-up (cell-list
//! neighbour build, pair offsets, corrected gradients); and `gpu_methods`, 10 steps of
//! every method of the registry with a GPU engine on a case of its own at about 2,000
//! particles (`common`), and for the static dual-support method one load step of the
//! plate (400 particles, Newton with matrix-free CG on the device) from a freshly built
//! engine, the build not timed. Runs on the adapter `Gpu::new` picks (`MESHLESS_ADAPTER`
//! to choose); without one it stops with the reason.

mod common;

use criterion::{
    BatchSize, BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use meshless::bench::resize;
use meshless::core::tensor::{D2, D3};
use meshless::gpu::Gpu;
use meshless::methods::tlsph::GpuTlsph;
use meshless::methods::tlsph::gpu::scheme;
use meshless::methods::{MethodSpec, REGISTRY};
use meshless::run::{Engine, EngineDim};
use meshless::scene::Scene;
use std::path::PathBuf;
use std::time::Duration;

const STEPS_PER_ITERATION: u32 = 10;

fn load(name: &str, particles: f64) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(name);
    let base = Scene::load(&path, &[]).expect("case loads");
    let mut sizes = resize(&base, particles).expect("case resizes");
    // A fixed step at the case's Courant number, so every iteration does the same work.
    if let Some(dt) = base.method.dt {
        let spacing = Scene::load(&path, &sizes)
            .expect("resized case loads")
            .spacing;
        sizes.push(format!("method.dt={:e}", dt * spacing / base.spacing));
    }
    if base.method.cfl.is_some() {
        let dt =
            0.3 * base.spacing / 5000.0 * (particles / 1e4).powf(-1.0 / f64::from(base.dimension));
        sizes.extend(["method.cfl=".into(), format!("method.dt={dt:e}")]);
    }
    Scene::load(&path, &sizes).expect("resized case loads")
}

fn gpu() -> Gpu {
    Gpu::new().unwrap_or_else(|e| panic!("the GPU benchmarks need an adapter: {e}"))
}

fn steps<D: EngineDim>(c: &mut Criterion, group: &str, name: &str) {
    let mut g = c.benchmark_group(group);
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sampling_mode(SamplingMode::Flat);
    for particles in [1e3, 1e4, 1e5] {
        let case = load(name, particles);
        let mut engine = case
            .spec
            .gpu_engine::<D>(&case, gpu())
            .unwrap_or_else(|e| panic!("GPU set-up of {name}: {e}"));
        let dt = case.method.dt.expect("fixed dt");
        let n = engine.reference().len();
        g.throughput(Throughput::Elements(
            n as u64 * u64::from(STEPS_PER_ITERATION),
        ));
        g.bench_with_input(BenchmarkId::new("steps", n), &n, |b, _| {
            b.iter(|| {
                engine
                    .advance(0.0, dt, STEPS_PER_ITERATION)
                    .expect("steps run");
                engine.finish();
            })
        });
        engine.check().expect("state stays finite");
    }
    g.finish();
}

fn setup(c: &mut Criterion) {
    let mut g = c.benchmark_group("gpu_setup");
    g.sample_size(10).sampling_mode(SamplingMode::Flat);
    let case = load("rotating-disk.toml", 1e5);
    let n = case.spacing;
    g.bench_function(
        BenchmarkId::new("rotating_disk", format!("spacing={n:.4}")),
        |b| {
            b.iter(|| {
                let MethodSpec::Tlsph(spec) = &case.spec else {
                    panic!("rotating-disk runs tlsph")
                };
                GpuTlsph::<D2>::new(&case, scheme(spec), gpu()).expect("GPU set-up")
            })
        },
    );
    g.finish();
}

fn disk(c: &mut Criterion) {
    steps::<D2>(c, "gpu_rotating_disk", "rotating-disk.toml");
}

fn disk_gray_monaghan(c: &mut Criterion) {
    steps::<D2>(
        c,
        "gpu_rotating_disk_gray_monaghan",
        "rotating-disk-gray-monaghan.toml",
    );
}

fn disk_godunov(c: &mut Criterion) {
    steps::<D2>(c, "gpu_rotating_disk_godunov", "rotating-disk-godunov.toml");
}

fn strip_potential(c: &mut Criterion) {
    steps::<D2>(
        c,
        "gpu_tensile_strip_potential",
        "tensile-strip-potential.toml",
    );
}

fn block(c: &mut Criterion) {
    steps::<D3>(c, "gpu_spinning_block_3d", "spinning-block-3d.toml");
}

fn methods(c: &mut Criterion) {
    let mut g = c.benchmark_group("gpu_methods");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sampling_mode(SamplingMode::Flat);
    for entry in REGISTRY.iter().filter(|e| e.gpu_engine) {
        let (case, kind) = common::method_case(entry.name);
        let build = || {
            case.spec
                .gpu_engine::<D2>(&case, gpu())
                .unwrap_or_else(|e| panic!("GPU set-up of {}: {e}", entry.name))
        };
        let mut engine = build();
        let dt = common::time_step(&case, engine.as_mut());
        let n = engine.reference().len();
        if kind == common::Kind::Static {
            g.throughput(Throughput::Elements(n as u64));
            g.bench_function(BenchmarkId::new(entry.name, n), |b| {
                b.iter_batched(
                    build,
                    |mut e| e.advance(0.0, dt, 1).expect("load step converges"),
                    BatchSize::PerIteration,
                )
            });
            continue;
        }
        g.throughput(Throughput::Elements(
            n as u64 * u64::from(STEPS_PER_ITERATION),
        ));
        g.bench_function(BenchmarkId::new(entry.name, n), |b| {
            b.iter(|| {
                engine
                    .advance(0.0, dt, STEPS_PER_ITERATION)
                    .expect("steps run");
                engine.finish();
            })
        });
        engine.check().expect("state stays finite");
    }
    g.finish();
}

criterion_group!(
    benches,
    methods,
    disk,
    disk_gray_monaghan,
    disk_godunov,
    strip_potential,
    block,
    setup
);
criterion_main!(benches);
