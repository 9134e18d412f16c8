//! Helpers the test modules share: the GPU, the shipped cases, run options, deterministic
//! random numbers and states, WGSL validation, and the largest difference between two
//! fields.
//!
//! Some helpers serve only the modules compiled with the `gpu` or `study` feature; a
//! build without them leaves those unused.
#![cfg_attr(not(all(feature = "gpu", feature = "study")), allow(dead_code))]

use meshless::core::tensor::Dim;
#[cfg(feature = "gpu")]
use meshless::gpu::Gpu;
use meshless::methods::mixed::{MixedSph, MixedState};
use meshless::methods::{Method, Runs};
use meshless::run::{Backend, CpuEngine, Engine, ProgressDisplay, RunOptions};
use meshless::scene::Scene;
use std::ops::Sub;
use std::path::{Path, PathBuf};
#[cfg(feature = "gpu")]
use std::sync::Arc;

#[cfg(feature = "gpu")]
/// The adapter wgpu finds, with uncaptured wgpu errors raised as panics. Without an
/// adapter the test fails, it does not skip: the GPU path is part of what CI checks (on
/// Linux without a GPU, Mesa's Vulkan CPU driver lavapipe).
pub fn gpu() -> Gpu {
    let gpu = Gpu::new().unwrap_or_else(|e| {
        panic!(
            "GPU tests need an adapter (CI installs Mesa lavapipe: apt-get install \
             mesa-vulkan-drivers): {e}"
        )
    });
    gpu.device
        .on_uncaptured_error(Arc::new(|e| panic!("wgpu error: {e}")));
    gpu
}

#[cfg(feature = "gpu")]
/// Every adapter wgpu enumerates (Mesa's lavapipe through Vulkan and llvmpipe through GL
/// here, where both are installed), best first, each with uncaptured wgpu errors raised as
/// panics: the cross-checks that call this run on each, not only on the one `gpu()`
/// picks. No adapter, or one that cannot open a device, fails the test; with a single
/// adapter they run on that one.
pub fn gpus() -> Vec<Gpu> {
    let all: Vec<Gpu> = Gpu::every()
        .into_iter()
        .map(|gpu| gpu.unwrap_or_else(|e| panic!("an adapter has no device: {e}")))
        .collect();
    assert!(
        !all.is_empty(),
        "GPU tests need an adapter (CI installs Mesa lavapipe: apt-get install \
         mesa-vulkan-drivers)"
    );
    for gpu in &all {
        gpu.device
            .on_uncaptured_error(Arc::new(|e| panic!("wgpu error: {e}")));
    }
    all
}

#[cfg(feature = "gpu")]
/// The GPU scheme of a total-Lagrangian SPH case's method (`tlsph`, `tl-potential`,
/// `corotated-tlsph`, `dual-support-sph`), as the method's GPU engine builds it.
pub fn tl_scheme<D: meshless::gpu::GpuDim>(
    case: &Scene,
) -> meshless::methods::cores::tl::gpu::TlScheme<D> {
    use meshless::methods::{MethodSpec, corotated, dual_support, potential, tlsph};
    match &case.spec {
        MethodSpec::Tlsph(s) => tlsph::gpu::scheme(s, case.method.correction),
        MethodSpec::TlPotential(s) => potential::gpu::scheme(s),
        MethodSpec::CorotatedTlsph(s) => corotated::gpu::scheme(s),
        MethodSpec::DualSupportSph(s) => dual_support::gpu::scheme(s),
        other => panic!("{other:?} has no GpuTlsph scheme"),
    }
}

/// The spec of the system `S` runs in a case's method (the registry's [`Runs`]); panics
/// for a method that does not run it.
pub fn spec_of<S: Runs + ?Sized>(case: &Scene) -> &S {
    S::spec_of(&case.spec)
        .unwrap_or_else(|| panic!("`{}` does not run this system", case.method.name))
}

/// The folder of the shipped cases.
pub fn cases_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("cases")
}

/// The file of the shipped case `name`: `cases/<name>.toml`.
pub fn case_file(name: &str) -> PathBuf {
    cases_dir().join(format!("{name}.toml"))
}

/// The `.toml` files in `dir`, in the order the folder lists them.
pub fn toml_files(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|e| e == "toml"))
        .collect()
}

/// The shipped case `name` with `--set` overrides (`key=value`); panics if it does not
/// load.
pub fn load(name: &str, overrides: &[impl AsRef<str>]) -> Scene {
    let overrides: Vec<String> = overrides.iter().map(|s| s.as_ref().to_string()).collect();
    Scene::load(&case_file(name), &overrides).unwrap()
}

/// The shipped case `name` as its file has it.
pub fn shipped(name: &str) -> Scene {
    Scene::load(&case_file(name), &[]).unwrap()
}

/// Options of a CPU run into `dir`: series and summary, frames if `frames`, no progress
/// bar.
pub fn cpu_options(dir: &Path, frames: bool) -> RunOptions {
    RunOptions {
        out_dir: dir.to_path_buf(),
        backend: Backend::Cpu,
        progress: ProgressDisplay::Off,
        frames,
        stop: None,
        limits: Default::default(),
        resume: false,
        profile: false,
    }
}

/// Every variant the mixed methods compile, on top of the overrides `base`: Upwind-SPH
/// with and without reconstruction, JST-SPH and SUPG-SPH, each with each set of conserved
/// variables (the last override of each variant); the sets with H or J on the polyconvex
/// model, the one model that reads them (a model of F alone evolves {p, F}).
pub fn mixed_variants(base: &[&str]) -> Vec<Vec<String>> {
    let methods: [&[&str]; 4] = [
        &["method.name=upwind-sph"],
        &["method.name=upwind-sph", "method.reconstruction=false"],
        &["method.name=jst-sph"],
        &["method.name=supg-sph"],
    ];
    let mut out = Vec::new();
    for method in methods {
        for variables in ["p-F", "p-F-J", "p-F-H-J"] {
            let mut set: Vec<String> = base.iter().map(|s| s.to_string()).collect();
            set.extend(method.iter().map(|s| s.to_string()));
            if variables != "p-F" {
                set.push("material.model=nearly-incompressible-neo-hookean".into());
            }
            set.push(format!("method.variables={variables}"));
            out.push(set);
        }
    }
    out
}

/// Whether a variant of [`mixed_variants`] is SUPG-SPH, which stabilises the evolved F
/// only (no bond-based F).
pub fn is_supg(set: &[String]) -> bool {
    set.iter().any(|s| s == "method.name=supg-sph")
}

/// Deterministic pseudo-random numbers in [0, 1) (64-bit LCG, as in src/core/neighbour.rs).
pub fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// Deterministic numbers in [−1, 1): `lcg` stretched.
pub fn noise(seed: &mut u64) -> f64 {
    lcg(seed) * 2.0 - 1.0
}

/// A tensor with entries scale × noise.
pub fn random_tensor<D: Dim>(seed: &mut u64, scale: f64) -> D::T {
    let mut t = D::zero_t();
    for k in 0..D::N {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        let row: Vec<f64> = (0..D::N).map(|_| scale * noise(seed)).collect();
        t += D::outer(D::from_slice(&e), D::from_slice(&row));
    }
    t
}

/// A random admissible state: |v| ~ 1 m/s, |u| ~ 1 cm, F = I + 5 % noise,
/// H = cof F + `h_noise` noise, J = det F + 1 %.
pub fn random_state<D: Dim>(m: &MixedSph<D>, seed: &mut u64, h_noise: f64) -> MixedState<D> {
    let mut y = m.initial_state();
    let vec = random_vector::<D>;
    for a in 0..y.v.len() {
        y.v[a] = vec(seed, 1.0);
        y.u[a] = vec(seed, 0.01);
        y.f[a] = D::identity() + random_tensor::<D>(seed, 0.05);
        if !y.h.is_empty() {
            y.h[a] = D::cof(y.f[a]) + random_tensor::<D>(seed, h_noise);
        }
        if !y.j.is_empty() {
            y.j[a] = D::det(y.f[a]) * (1.0 + 0.01 * noise(seed));
        }
    }
    y
}

/// Parses and validates the WGSL `src` with naga and translates it with the SPIR-V, MSL,
/// HLSL and GLSL (ES 3.1 compute) back ends; checks every entry point against WebGPU's
/// default limits, which every adapter meets (`Gpu::pipeline` checks the adapter's own
/// at run time). Panics with the located error, under `name`.
#[cfg(feature = "gpu")]
pub fn validate_wgsl(name: &str, src: &str) {
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string_with_path(src, name)));
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{}", e.emit_to_string_with_path(src, name)));
    within_webgpu_limits(name, src, &module);
    translate(name, &module, &info);
    bytes_model_matches_the_bindings(name, src, &module);
}

/// A pass file that declares a bytes model (`gpu::profile`) declares one for each of its
/// entry points, and each counts exactly the storage bindings the entry point uses
/// (naga's loads and stores of each global by the entry point and the functions it
/// calls): none it does not use, every one it does; the directions it counts apart
/// (loads, stores) are ones the entry point makes, and its conditions name constants of
/// the variant ([`pass_cost`] fails otherwise).
#[cfg(feature = "gpu")]
fn bytes_model_matches_the_bindings(name: &str, src: &str, module: &naga::Module) {
    use meshless::gpu::bytes::pass_model;
    use meshless::gpu::context::{pass_cost, reflect};
    let models: Vec<_> = module
        .entry_points
        .iter()
        .map(|e| {
            let model = pass_model(src, &e.name).unwrap_or_else(|e| panic!("{name}: {e}"));
            (e.name.as_str(), model)
        })
        .collect();
    if models.iter().all(|(_, m)| m.is_none()) {
        return;
    }
    for (entry, model) in models {
        let model = model.unwrap_or_else(|| {
            panic!("{name}: entry point `{entry}` has no bytes model beside the others'")
        });
        let r = reflect(src, entry).unwrap();
        let used = |binding: &str| r.reads.iter().chain(&r.writes).any(|b| b == binding);
        for t in &model.traffic {
            assert!(
                used(&t.binding),
                "{name}: {}: the bytes model of `{entry}` counts `{}`, which its WGSL does \
                 not use",
                t.at,
                t.binding
            );
        }
        for binding in r.reads.iter().chain(&r.writes) {
            assert!(
                model.traffic.iter().any(|t| &t.binding == binding),
                "{name}: the bytes model of `{entry}` does not count `{binding}`, which its \
                 WGSL uses"
            );
        }
        let cost = pass_cost(src, entry).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            cost.is_some_and(|c| c.item + c.pair > 0),
            "{name}: `{entry}` moves no bytes"
        );
    }
}

/// WebGPU's default limits: `max_storage_buffers_per_shader_stage`,
/// `max_compute_invocations_per_workgroup` and `max_compute_workgroup_storage_size`.
#[cfg(feature = "gpu")]
pub const WEBGPU_STORAGE_BUFFERS: u32 = 8;
#[cfg(feature = "gpu")]
const WEBGPU_INVOCATIONS: u32 = 256;
#[cfg(feature = "gpu")]
const WEBGPU_WORKGROUP_BYTES: u32 = 16_384;

#[cfg(feature = "gpu")]
fn within_webgpu_limits(name: &str, src: &str, module: &naga::Module) {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let shared: u32 = module
        .global_variables
        .iter()
        .filter(|(_, v)| v.space == naga::AddressSpace::WorkGroup)
        .map(|(_, v)| layouter[v.ty].size)
        .sum();
    assert!(
        shared <= WEBGPU_WORKGROUP_BYTES,
        "{name}: {shared} bytes of workgroup memory, above WebGPU's {WEBGPU_WORKGROUP_BYTES}"
    );
    for entry in &module.entry_points {
        let r = meshless::gpu::context::reflect(src, &entry.name).unwrap();
        assert!(
            r.storage_buffers <= WEBGPU_STORAGE_BUFFERS,
            "{name}: entry point `{}` binds {} storage buffers, above WebGPU's default of \
             {WEBGPU_STORAGE_BUFFERS}",
            entry.name,
            r.storage_buffers
        );
        let invocations: u32 = entry.workgroup_size.iter().product();
        assert!(
            invocations <= WEBGPU_INVOCATIONS,
            "{name}: entry point `{}` has {invocations} invocations per workgroup",
            entry.name
        );
    }
}

/// Translates a validated module with every back end wgpu uses: SPIR-V (Vulkan), MSL
/// (Metal), HLSL (DX12) and GLSL ES 3.1 (GL, one entry point at a time).
#[cfg(feature = "gpu")]
fn translate(name: &str, module: &naga::Module, info: &naga::valid::ModuleInfo) {
    use naga::back::{glsl, hlsl, msl, spv};
    let fail = |back: &str, e: &dyn std::fmt::Display| -> ! {
        panic!("{name}: the {back} back end does not translate it: {e}")
    };
    spv::write_vec(module, info, &spv::Options::default(), None)
        .unwrap_or_else(|e| fail("SPIR-V", &e));
    let msl_options = msl::Options {
        lang_version: (2, 0),
        ..Default::default()
    };
    msl::write_string(module, info, &msl_options, &msl::PipelineOptions::default())
        .unwrap_or_else(|e| fail("MSL", &e));
    let mut hlsl_out = String::new();
    hlsl::Writer::new(
        &mut hlsl_out,
        &hlsl::Options::default(),
        &hlsl::PipelineOptions::default(),
    )
    .write(module, info, None)
    .unwrap_or_else(|e| fail("HLSL", &e));
    for entry in &module.entry_points {
        let pipeline = glsl::PipelineOptions {
            shader_stage: naga::ShaderStage::Compute,
            entry_point: entry.name.clone(),
            multiview: None,
        };
        let mut out = String::new();
        glsl::Writer::new(
            &mut out,
            module,
            info,
            &glsl::Options::default(),
            &pipeline,
            naga::proc::BoundsCheckPolicies::default(),
        )
        .and_then(|mut w| w.write().map(|_| ()))
        .unwrap_or_else(|e| fail("GLSL ES 3.1", &e));
    }
}

/// The largest `norm` over `values` (0 for none).
fn largest<T>(values: impl IntoIterator<Item = T>, norm: impl Fn(T) -> f64) -> f64 {
    values.into_iter().map(norm).fold(0.0, f64::max)
}

/// The largest length over the vectors `values`.
pub fn largest_v<D: Dim>(values: impl IntoIterator<Item = D::V>) -> f64 {
    largest(values, norm_v::<D>)
}

/// The largest Frobenius norm over the tensors `values`.
pub fn largest_t<D: Dim>(values: impl IntoIterator<Item = D::T>) -> f64 {
    largest(values, norm_t::<D>)
}

/// The length |v| of a vector.
fn norm_v<D: Dim>(v: D::V) -> f64 {
    D::norm2(v).sqrt()
}

/// The Frobenius norm |T| = √(T : T) of a tensor.
fn norm_t<D: Dim>(t: D::T) -> f64 {
    D::ddot(t, t).sqrt()
}

/// The largest difference between the fields `a` (the reference) and `b`, and the scale
/// to hold it against: (max |a − b|, max |a|), so that a bound can be relative to the
/// field (f32 round-off is relative to the values summed, not to each difference).
fn max_diff<T: Copy + Sub<Output = T>>(a: &[T], b: &[T], norm: impl Fn(T) -> f64) -> (f64, f64) {
    let error = largest(a.iter().zip(b).map(|(&x, &y)| x - y), &norm);
    (error, largest(a.iter().copied(), norm))
}

/// `max_diff` of vector fields.
pub fn max_v<D: Dim>(a: &[D::V], b: &[D::V]) -> (f64, f64) {
    max_diff(a, b, norm_v::<D>)
}

/// `max_diff` of tensor fields, in the Frobenius norm.
pub fn max_t<D: Dim>(a: &[D::T], b: &[D::T]) -> (f64, f64) {
    max_diff(a, b, norm_t::<D>)
}

/// `max_diff` of scalar fields.
pub fn max_s(a: &[f64], b: &[f64]) -> (f64, f64) {
    max_diff(a, b, f64::abs)
}

/// The case text of a block of one body, Δx = 0.1 with Δx^d volumes (the convention the
/// method tests' figures were made with), ρ0 = 1000, E = 1e6, ν = 0.3, h/Δx = 1.3, no
/// boundary conditions: `[method]` gets `name = "<method>"` and the lines
/// `method_keys`; `max` is the far corner (2D or 3D) from the origin.
pub fn block_text(max: &[f64], model: &str, method: &str, method_keys: &str) -> String {
    let dim = max.len();
    format!(
        r#"
name = "block"
dimension = {dim}
spacing = 0.1
{}
[method]
name = "{method}"
h_over_dx = 1.3
dt = 1.0e-5
{method_keys}
[[body]]
name = "b"
geometry = {{ shape = "box", min = {:?}, max = {max:?}, volumes = "uniform" }}
[run]
end_time = 1.0e-4
"#,
        material_table(model),
        vec![0.0; dim]
    )
}

/// The `[material]` table of the tests' small cases: `model` at ρ0 = 1000 kg/m³,
/// E = 1 MPa, ν = 0.3.
fn material_table(model: &str) -> String {
    format!(
        r#"[material]
model = "{model}"
density = 1000.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3"#
    )
}

/// The case of [`block_text`]; panics if it does not load.
pub fn block_case(max: &[f64], model: &str, method: &str, method_keys: &str) -> Scene {
    let text = block_text(max, model, method, method_keys);
    Scene::from_toml(&text, Path::new("block.toml"), &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// A vector with components scale × noise.
pub fn random_vector<D: Dim>(seed: &mut u64, scale: f64) -> D::V {
    D::from_slice(&(0..D::N).map(|_| scale * noise(seed)).collect::<Vec<_>>())
}

/// The particle of a 2D scene nearest to `point` in the reference configuration x0.
pub fn nearest(x0: &[glam::DVec2], point: [f64; 2]) -> usize {
    let d = |i: usize| (x0[i] - glam::DVec2::from_array(point)).length();
    (0..x0.len())
        .min_by(|&a, &b| d(a).total_cmp(&d(b)))
        .unwrap()
}

/// The largest hourglass indicator η after each of `steps` (increasing) steps of the
/// system `m` from the state `y`, with the case's integrator and Δt; `fields` gives the
/// displacements and deformation gradients of a state.
pub fn hourglass_after<S: Method<meshless::core::tensor::D2>>(
    case: &Scene,
    m: &mut S,
    mut y: S::State,
    steps: &[usize],
    fields: impl Fn(&S, &S::State) -> (Vec<glam::DVec2>, Vec<glam::DMat2>),
) -> Vec<f64> {
    let x0 = m.reference().to_vec();
    let indicator = meshless::physics::hourglass::HourglassIndicator::new::<
        meshless::core::tensor::D2,
    >(&case.kernel(2), &x0);
    let mut integrator = meshless::core::integrate::Integrator::new(case.method.integrator, &y);
    let dt = case.method.dt.unwrap();
    let mut done = 0;
    steps
        .iter()
        .map(|&n| {
            for k in done..n {
                integrator.step(m, k as f64 * dt, dt, &mut y).unwrap();
            }
            done = n;
            let (u, f) = fields(m, &y);
            let eta = indicator.of::<meshless::core::tensor::D2>(&x0, &u, &f);
            eta.into_iter().fold(0.0, f64::max)
        })
        .collect()
}

/// The `[material]` ([`material_table`]) and `[method]` tables of the tests' small cases:
/// `method` on RK4 at Δt = 1e-5 s, with h/Δx = 1.3
/// where the method has a kernel.
pub fn material_and_method(model: &str, method: &str) -> String {
    let entry = meshless::methods::REGISTRY
        .iter()
        .find(|e| e.name == method)
        .unwrap();
    let kernel = if entry.kernel { "h_over_dx = 1.3" } else { "" };
    format!(
        r#"{}
[method]
name = "{method}"
{kernel}
integrator = "rk4"
dt = 1.0e-5"#,
        material_table(model)
    )
}

/// A mixed method's CPU engine on `case` after `steps` steps at the CFL step of the
/// initial state.
pub fn run_mixed_steps<D: Dim>(case: &Scene, steps: u32) -> CpuEngine<D, MixedSph<D>> {
    let mut e = meshless::scene::cpu_engine::<D, MixedSph<D>>(case).unwrap();
    let dt = case.method.cfl.unwrap() * case.spacing / e.max_signal_speed();
    e.advance(0.0, dt, steps).unwrap();
    e
}

/// The tensor whose columns are the first D::N entries of the first D::N of `columns`.
pub fn of_columns<D: Dim>(columns: &[[f64; 3]; 3]) -> D::T {
    (0..D::N).fold(D::zero_t(), |m, k| {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        m + D::outer(
            D::from_slice(&columns[k][..D::N]),
            D::from_slice(&e[..D::N]),
        )
    })
}
