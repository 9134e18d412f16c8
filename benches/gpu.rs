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
//! engine, the build not timed; and `gpu_binding`, the two ways past the largest storage
//! binding on one gather (below). Runs on the adapter `Gpu::new` picks
//! (`MESHLESS_ADAPTER` to choose); without one it stops with the reason.

mod common;

use criterion::{
    BatchSize, BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use meshless::bench::resize;
use meshless::core::tensor::{D2, D3};
use meshless::gpu::Gpu;
use meshless::gpu::context::Pipeline;
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
    let mut sizes = resize(&base, particles, false).expect("case resizes");
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
                GpuTlsph::<D2>::new(&case, scheme(spec, case.method.correction), gpu())
                    .expect("GPU set-up")
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
    for entry in REGISTRY {
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

/// The gather of TLSPH's stress pass, H_i = Σ_j (u_j − u_i) ⊗ g_ij over a 2D lattice's
/// pairs within 2.6 spacings (20 a particle), three ways: the lists whole in one dispatch;
/// in four parts, a dispatch each with its own offsets, ids and per-pair buffers and the
/// uniform `part` (`gpu::parts`, what the engines do); and whole lists with the per-pair
/// field in four bindings that the shader selects by pair index (`switch` on p / CHUNK).
const GATHER: &str = "
struct Part { first: u32, rows: u32 }
@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> u: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> h: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> pair: array<vec2<f32>>;
@group(0) @binding(5) var<storage, read> pair1: array<vec2<f32>>;
@group(0) @binding(6) var<storage, read> pair2: array<vec2<f32>>;
@group(0) @binding(7) var<storage, read> pair3: array<vec2<f32>>;
@group(0) @binding(8) var<uniform> part: Part;

fn term(i: u32, j: u32, g: vec2<f32>) -> vec4<f32> {
    let du = u[j] - u[i];
    return vec4<f32>(du.x * g.x, du.y * g.x, du.x * g.y, du.y * g.y);
}

@compute @workgroup_size(256)
fn parts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = gid.x + gid.y * nwg.x * 256u;
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    var acc: vec4<f32>;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        acc += term(i, ids[p], pair[p]);
    }
    h[i] = acc;
}

fn chunked(p: u32) -> vec2<f32> {
    let k = p % CHUNK;
    switch p / CHUNK {
        case 0u: { return pair[k]; }
        case 1u: { return pair1[k]; }
        case 2u: { return pair2[k]; }
        default: { return pair3[k]; }
    }
}

@compute @workgroup_size(256)
fn addressing(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * 256u;
    if i >= part.rows {
        return;
    }
    var acc: vec4<f32>;
    let p_end = offsets[i + 1u];
    for (var p = offsets[i]; p < p_end; p++) {
        acc += term(i, ids[p], chunked(p));
    }
    h[i] = acc;
}
";

fn binding(c: &mut Criterion) {
    use meshless::core::neighbour::Csr;
    use meshless::gpu::parts::{PartLists, Split};
    let gpu = gpu();
    let side = 362usize;
    let n = side * side;
    let reach: Vec<(i64, i64)> = (-2i64..=2)
        .flat_map(|a| (-2i64..=2).map(move |b| (a, b)))
        .filter(|&(a, b)| (a, b) != (0, 0) && ((a * a + b * b) as f64) <= 2.6 * 2.6)
        .collect();
    let rows: Vec<Vec<u32>> = (0..n as i64)
        .map(|i| {
            let (x, y) = (i % side as i64, i / side as i64);
            (reach.iter())
                .map(|(a, b)| (x + a, y + b))
                .filter(|&(x, y)| (0..side as i64).contains(&x) && (0..side as i64).contains(&y))
                .map(|(x, y)| (y * side as i64 + x) as u32)
                .collect()
        })
        .collect();
    let csr = Csr::from_rows(&rows);
    let pairs = csr.pair_count();
    let g: Vec<[f32; 2]> = (0..pairs).map(|p| [p as f32 * 1e-6, 1.0]).collect();
    let u: Vec<[f32; 2]> = (0..n).map(|i| [i as f32 * 1e-5, 0.0]).collect();
    let u = gpu.storage("u", &u);
    let h = gpu.zeroed("h", n as u64 * 16);
    let chunk = pairs.div_ceil(4);
    let source = |chunk: usize| format!("const CHUNK: u32 = {chunk}u;\n{GATHER}");
    let (parts_pass, addressing_pass) = (
        gpu.pipeline("parts", &source(chunk), "parts").unwrap(),
        gpu.pipeline("addressing", &source(chunk), "addressing")
            .unwrap(),
    );
    let bind = |pipeline, lists: &PartLists, pair: [&wgpu::Buffer; 4]| {
        let [offsets, ids, part] = lists.table();
        let table = [
            offsets,
            ids,
            part,
            ("u", &u),
            ("h", &h),
            ("pair", pair[0]),
            ("pair1", pair[1]),
            ("pair2", pair[2]),
            ("pair3", pair[3]),
        ];
        gpu.bind(pipeline, &table).unwrap()
    };
    // The lists in four parts of about a quarter of the pair bytes each, and whole.
    let quarter = Split::plan(&csr, 8, (pairs as u64 * 8).div_ceil(4) + 8 * 32, 256).unwrap();
    let whole = Split::whole(&csr);
    let upload = |split: &Split| {
        let lists = PartLists::upload(&gpu, &csr, split);
        let pair: Vec<wgpu::Buffer> = (split.parts.iter())
            .map(|p| gpu.storage("pair", &g[p.start..p.start + p.pairs]))
            .collect();
        (lists, pair)
    };
    let (whole_lists, whole_pair) = upload(&whole);
    let (part_lists, part_pair) = upload(&quarter);
    let chunks: Vec<wgpu::Buffer> = g.chunks(chunk).map(|c| gpu.storage("pair", c)).collect();
    let one = &whole_pair[0];
    let variants: [(String, Vec<wgpu::BindGroup>, &Split, &Pipeline); 3] = [
        (
            "whole".into(),
            vec![bind(&parts_pass, &whole_lists[0], [one; 4])],
            &whole,
            &parts_pass,
        ),
        (
            format!("parts_{}", quarter.parts.len()),
            (part_lists.iter().zip(&part_pair))
                .map(|(l, p)| bind(&parts_pass, l, [p; 4]))
                .collect(),
            &quarter,
            &parts_pass,
        ),
        (
            "addressing_4".into(),
            vec![bind(
                &addressing_pass,
                &whole_lists[0],
                [&chunks[0], &chunks[1], &chunks[2], &chunks[3]],
            )],
            &whole,
            &addressing_pass,
        ),
    ];
    let mut group = c.benchmark_group("gpu_binding");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sampling_mode(SamplingMode::Flat)
        .throughput(Throughput::Elements(n as u64 * 10));
    for (name, binds, split, pipeline) in &variants {
        assert_eq!(binds.len(), split.parts.len());
        group.bench_function(BenchmarkId::new(name, n), |b| {
            b.iter(|| {
                let mut encoder = gpu.device.create_command_encoder(&Default::default());
                {
                    let mut pass = encoder.begin_compute_pass(&Default::default());
                    for _ in 0..10 {
                        split.dispatch(&gpu, &mut pass, pipeline, binds);
                    }
                }
                gpu.queue.submit([encoder.finish()]);
                gpu.wait();
            })
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    binding,
    methods,
    disk,
    disk_gray_monaghan,
    disk_godunov,
    strip_potential,
    block,
    setup
);
criterion_main!(benches);
