//! Every WGSL pass validates with naga (and lowers to an IR) without any adapter, in both
//! dimensions and for every scene variant the solver compiles.

use crate::common::{
    block_case, block_text, is_supg, load, mixed_variants, shipped, validate_wgsl,
};
use meshless::core::quadrature::Rule;
use meshless::core::tensor::{D2, D3};
use meshless::gpu::context::reflect;
use meshless::gpu::layout::GpuDim;
use meshless::gpu::shaders::{self, Constants};
use meshless::methods::MethodSpec;
use meshless::methods::cores::galerkin::gpu as galerkin;
use meshless::methods::cores::tl::gpu::{self as tlsph, Layout, scene_constants};
use meshless::methods::cores::ul::gpu as ul;
use meshless::methods::corotated::gpu as corotated;
use meshless::methods::dual_support::gpu as dual_support;
use meshless::methods::dual_support::krylov;
use meshless::methods::godunov::gpu as godunov;
use meshless::methods::gray_monaghan::gpu as gray_monaghan;
use meshless::methods::kbm::gpu as kbm;
use meshless::methods::mixed::{MixedSph, gpu as mixed};
use meshless::methods::potential::gpu as potential;
use meshless::methods::ul_weak_form::gpu as ul_weak_form;
use meshless::run::build_method;
use meshless::scene::Scene;
use std::path::Path;

/// TLSPH scenes: each material model, kernel and correction the GPU passes compile.
fn variants() -> Vec<Scene> {
    vec![
        shipped("rotating-disk"),
        load(
            "rotating-disk",
            &[
                "material.model=saint-venant-kirchhoff",
                "method.artificial_viscosity=",
            ],
        ),
        load(
            "rotating-disk",
            &[
                "material.model=neo-hookean",
                "method.kernel=quintic",
                "method.correction=\"shepard\"",
            ],
        ),
        load("wave-rod", &["method.correction=\"none\""]),
        load("wave-rod", &["method.kernel=cubic-spline"]),
    ]
}

/// Mixed-method scenes of dimension `dim`: with ghosts (mirror planes) and without, each
/// material model the mixed methods allow, projection on and off, Upwind-SPH with and
/// without reconstruction and JST-SPH, each set of conserved variables, and each method
/// with the seed 002 options (symmetrised momentum, bond-based F with {p, F}).
fn mixed_cases(dim: usize) -> Vec<Scene> {
    let bases: Vec<(&str, Vec<&str>)> = if dim == 2 {
        vec![
            ("swinging-plate", vec!["spacing=0.125"]),
            ("spinning-plate", vec!["spacing=0.4"]),
            (
                "spinning-plate",
                vec![
                    "spacing=0.4",
                    "material.model=neo-hookean",
                    "method.projection=false",
                ],
            ),
        ]
    } else {
        vec![
            ("swinging-cube", vec!["spacing=0.125"]),
            ("swinging-cube", vec!["spacing=0.25", "mirror="]),
        ]
    };
    let mut cases = Vec::new();
    for (name, base) in &bases {
        for set in mixed_variants(base) {
            cases.push(load(name, &set));
        }
    }
    let (seed_002, base) = if dim == 2 {
        ("swinging-plate", "spacing=0.125")
    } else {
        ("bending-column", "method.jst=")
    };
    for mut set in mixed_variants(&[base]) {
        if set.last().is_some_and(|v| v == "method.variables=p-F") && !is_supg(&set) {
            set.extend(
                [
                    "method.momentum=symmetrised",
                    "method.deformation_gradient=bond-based",
                ]
                .map(String::from),
            );
            cases.push(load(seed_002, &set));
        }
    }
    cases
}

/// Updated-Lagrangian scenes of dimension `dim`: each method, with and without the
/// correction, and Gray–Monaghan with and without each of its terms.
fn ul_cases(dim: usize) -> Vec<Scene> {
    let max = block_max(dim);
    let all = "artificial_viscosity = { alpha = 1.0, beta = 1.0 }\n\
               artificial_stress = { epsilon = 0.3, n = 4.0 }\nxsph = 0.5";
    let mut cases = Vec::new();
    for correction in ["none", "randles-libersky", "rkpm"] {
        let c = format!("correction = \"{correction}\"");
        cases.push(block_case(max, "hypoelastic", "godunov-sph", &c));
        for keys in [all, ""] {
            let keys = format!("{c}\n{keys}");
            cases.push(block_case(max, "hypoelastic", "gray-monaghan-sph", &keys));
        }
    }
    cases
}

fn check_all<D: GpuDim>() {
    check_tlsph::<D>();
    check_mixed::<D>();
    check_ul::<D>();
    check_potential::<D>();
    check_corotated::<D>();
    check_dual_support::<D>();
    check_galerkin::<D>();
    check_eulerian_kbm::<D>();
    check_ul_weak_form::<D>();
    check_without_constants::<D>();
}

/// TLSPH: every variant, state and rate models.
fn check_tlsph<D: GpuDim>() {
    for case in variants() {
        for rate in [false, true] {
            let MethodSpec::Tlsph(spec) = &case.spec else {
                unreachable!("TLSPH variants")
            };
            let scheme = meshless::methods::tlsph::gpu::scheme::<D>(spec, case.method.correction);
            let layout = Layout::new(100, 10, D::N, rate, 1000, &scheme);
            for every in [false, true] {
                let constants = scene_constants(&case, &layout, &scheme, every);
                for source in tlsph::SHADERS {
                    let src = shaders::compose::<D>(source, &constants);
                    let name = format!("{}D {} ({})", D::N, source.name, case.name);
                    validate_wgsl(&name, &src);
                }
            }
        }
    }
}

/// Mixed SPH: the Upwind-SPH and JST-SPH variants.
fn check_mixed<D: GpuDim>() {
    for case in mixed_cases(D::N) {
        let cpu: MixedSph<D> = build_method(&case).unwrap();
        let spec: &dyn meshless::methods::mixed::MixedScheme = crate::common::spec_of(&case);
        let (_, constants) =
            mixed::scene(&case, spec.options(), &cpu, cpu.neighbours().pair_count());
        for source in mixed::SHADERS {
            let src = shaders::compose::<D>(source, &constants);
            validate_wgsl(&format!("{}D {} ({})", D::N, source.name, case.name), &src);
        }
    }
}

/// Godunov-SPH and Gray–Monaghan SPH, with and without correction.
fn check_ul<D: GpuDim>() {
    for case in ul_cases(D::N) {
        let (scheme, sources) = match &case.spec {
            MethodSpec::GrayMonaghanSph(spec) => {
                (gray_monaghan::scheme(&case, spec), gray_monaghan::SHADERS)
            }
            _ => (godunov::scheme(&Default::default()), godunov::SHADERS),
        };
        let layout = ul::Layout::new(100, 10, D::N, &scheme, &case);
        let constants = ul::scene_constants(&case, &layout, &scheme);
        for source in sources {
            let src = shaders::compose::<D>(source, &constants);
            validate_wgsl(&format!("{}D {} ({})", D::N, source.name, case.name), &src);
        }
    }
}

/// TL-potential SPH: both forces, with viscosity.
fn check_potential<D: GpuDim>() {
    for force in ["consistent", "reference-code"] {
        let keys =
            format!("force = \"{force}\"\nartificial_viscosity = {{ alpha = 1.0, beta = 1.0 }}");
        let max = block_max(D::N);
        let case = block_case(max, "saint-venant-kirchhoff", "tl-potential", &keys);
        let MethodSpec::TlPotential(spec) = &case.spec else {
            unreachable!("a tl-potential case")
        };
        let scheme = potential::scheme::<D>(spec);
        let layout = Layout::new(100, 10, D::N, false, 1000, &scheme);
        let constants = scene_constants(&case, &layout, &scheme, false);
        for source in potential::SHADERS {
            let src = shaders::compose::<D>(source, &constants);
            validate_wgsl(&format!("{}D {} ({force})", D::N, source.name), &src);
        }
    }
}

/// Corotated TLSPH: each state model, each correction (the RKPM and CGCK gradients are
/// solved on the host and compile as the linear correction), each kernel, with and
/// without viscosity.
fn check_corotated<D: GpuDim>() {
    let max = block_max(D::N);
    let av = "artificial_viscosity = { alpha = 1.0, beta = 1.0 }";
    for (model, keys) in [
        ("linear-elastic", "correction = \"none\""),
        ("linear-elastic", &format!("correction = \"none\"\n{av}")),
        (
            "saint-venant-kirchhoff",
            "correction = \"shepard\"\nkernel = \"quintic\"",
        ),
        (
            "neo-hookean",
            &format!("correction = \"randles-libersky\"\n{av}"),
        ),
        (
            "nearly-incompressible-neo-hookean",
            "correction = \"none\"\nkernel = \"wendland-c2\"",
        ),
    ] {
        let case = block_case(max, model, "corotated-tlsph", keys);
        let MethodSpec::CorotatedTlsph(spec) = &case.spec else {
            unreachable!("a corotated-tlsph case")
        };
        let scheme = corotated::scheme::<D>(spec);
        let layout = Layout::new(100, 10, D::N, false, 1000, &scheme);
        let constants = scene_constants(&case, &layout, &scheme, false);
        for source in corotated::SHADERS {
            let src = shaders::compose::<D>(source, &constants);
            validate_wgsl(&format!("{}D {} ({model})", D::N, source.name), &src);
        }
    }
}

/// Dual-support SPH in time: each state model of the block's material keys.
fn check_dual_support<D: GpuDim>() {
    let max = block_max(D::N);
    for model in [
        "linear-elastic",
        "saint-venant-kirchhoff",
        "neo-hookean",
        "nearly-incompressible-neo-hookean",
    ] {
        let text = block_text(max, model, "dual-support-sph", "");
        let case = Scene::from_toml(
            &text,
            Path::new("block.toml"),
            &["run.solve=dynamic".to_string()],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let MethodSpec::DualSupportSph(spec) = &case.spec else {
            unreachable!("a dual-support-sph case")
        };
        let scheme = dual_support::scheme::<D>(spec);
        let layout = Layout::new(100, 10, D::N, false, 1000, &scheme);
        let constants = scene_constants(&case, &layout, &scheme, false);
        for source in dual_support::SHADERS
            .iter()
            .filter(|s| **s != krylov::KRYLOV)
        {
            let src = shaders::compose::<D>(source, &constants);
            validate_wgsl(&format!("{}D {} ({model})", D::N, source.name), &src);
        }
    }
    // Dual-support SPH's matrix-free static solve, with and without the hourglass term.
    for hourglass in [false, true] {
        let constants = krylov::constants(D::N, 100, hourglass, (1, 1));
        let src = shaders::compose::<D>(&krylov::KRYLOV, &constants);
        validate_wgsl(&format!("{}D krylov (hourglass {hourglass})", D::N), &src);
    }
}

/// The Galerkin passes, rate and state models, on the reference and on the current
/// configuration (the weak form's and the elements' passes are the same files).
fn check_galerkin<D: GpuDim>() {
    let max = block_max(D::N);
    for model in ["hypoelastic", "neo-hookean"] {
        for frame in [
            galerkin::Frame::Reference,
            galerkin::Frame::Current(Rule::Gauss2),
        ] {
            let case = block_case(max, model, "tl-weak-form", "");
            let rate = model == "hypoelastic";
            let lists = galerkin::ListSizes::whole(100, 1600);
            let layout = galerkin::Layout::new(100, 10, 400, lists, 1000, D::N, rate).on(frame);
            let constants = galerkin::scene_constants(&case, &layout);
            for source in galerkin::SHADERS {
                let src = shaders::compose::<D>(source, &constants);
                let what = format!("{}D {} ({model}, {frame:?})", D::N, source.name);
                validate_wgsl(&what, &src);
            }
        }
    }
}

/// The Eulerian kernel's passes, rate and state models, with and without stress points.
fn check_eulerian_kbm<D: GpuDim>() {
    let max = block_max(D::N);
    for model in ["hypoelastic", "neo-hookean"] {
        let case = block_case(max, model, "kbm", "kernel_frame = \"eulerian\"");
        let rate = model == "hypoelastic";
        for q in [100, 180] {
            let layout = kbm::Layout::new(100, 10, q, D::N, rate);
            let constants = kbm::scene_constants(&case, &layout);
            for source in [kbm::RATES, galerkin::FOLDED_REDUCE] {
                let src = shaders::compose::<D>(&source, &constants);
                let what = format!("{}D {} ({model}, {q} points)", D::N, source.name);
                validate_wgsl(&what, &src);
            }
        }
    }
}

/// The weak form's passes, with fewer and more stress points than particles.
fn check_ul_weak_form<D: GpuDim>() {
    let case = crate::galerkin::block(block_max(D::N), "hypoelastic", "ul-weak-form", "");
    for q in [80, 120] {
        let layout = ul_weak_form::Layout::new(100, 10, q, D::N);
        let constants = ul_weak_form::scene_constants(&case, &layout);
        for source in ul_weak_form::SHADERS {
            let src = shaders::compose::<D>(source, &constants);
            validate_wgsl(&format!("{}D {} ({q} points)", D::N, source.name), &src);
        }
    }
}

/// Passes without scene constants (neighbour build, scans) validate on their own.
fn check_without_constants<D: GpuDim>() {
    let ul_shaders = [
        gray_monaghan::SHADERS,
        godunov::SHADERS,
        potential::SHADERS,
        corotated::SHADERS,
        galerkin::SHADERS,
        kbm::SHADERS,
        ul_weak_form::SHADERS,
        dual_support::SHADERS,
    ]
    .concat();
    for source in meshless::methods::shaders() {
        if !tlsph::SHADERS.contains(&source)
            && !mixed::SHADERS.contains(&source)
            && !ul_shaders.contains(&source)
        {
            let constants = match source == shaders::CELL_LIST {
                true => meshless::gpu::neighbour::constants(0, true),
                false => Constants::default(),
            };
            validate_wgsl(source.name, &shaders::compose::<D>(&source, &constants));
        }
    }
}

/// The extent of the test block in 2D and 3D.
fn block_max(dim: usize) -> &'static [f64] {
    if dim == 2 {
        &[1.0, 0.6]
    } else {
        &[0.5, 0.4, 0.3]
    }
}

/// Every `.wgsl` file under `shaders/` is a pass of some method (or a shared pass), a
/// function file one of them includes, or a prelude (dimension, dispatch): so the checks above
/// validate every file there is.
#[test]
fn every_wgsl_file_is_a_validated_pass_or_included() {
    let mut reached: Vec<&str> = vec![
        "common/dim2.wgsl",
        "common/dim3.wgsl",
        meshless::gpu::shaders::DISPATCH.name,
    ];
    for source in meshless::methods::shaders() {
        reached.push(source.name);
        reached.extend(source.common.iter().map(|f| f.name));
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut files = Vec::new();
    for folder in std::fs::read_dir(&root).unwrap() {
        let folder = folder.unwrap().path();
        for file in std::fs::read_dir(&folder).unwrap() {
            let file = file.unwrap().path();
            if file.extension().is_some_and(|e| e == "wgsl") {
                files.push(
                    file.strip_prefix(&root)
                        .unwrap()
                        .to_string_lossy()
                        .into_owned(),
                );
            }
        }
    }
    assert!(files.len() > 20, "{files:?}");
    for file in &files {
        assert!(
            reached.contains(&file.as_str()),
            "shaders/{file} is neither a pass nor included by one"
        );
    }
}

/// No `for` loop condition reads memory (an index or a call): a loop bound from a buffer is
/// read into a `let` before the loop. Mesa's llvmpipe through GL (22.3) reuses the load of
/// a loop condition for the same load after the loop, where an invocation that left the
/// loop before the last iteration of its SIMD group reads 0 (docs/gpu.md, "Adapters"):
/// a second loop over the same CSR row then ran zero times.
#[test]
fn no_loop_condition_reads_a_buffer() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut loops = 0;
    for folder in std::fs::read_dir(&root).unwrap() {
        for file in std::fs::read_dir(folder.unwrap().path()).unwrap() {
            let path = file.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            for (n, line) in text.lines().enumerate() {
                let Some(at) = line.find("for (") else {
                    continue;
                };
                loops += 1;
                let condition = line[at..].split(';').nth(1).unwrap_or_default();
                assert!(
                    !condition.contains('[') && !condition.contains('('),
                    "{}:{}: the loop condition `{}` reads memory; read the bound into a \
                     `let` before the loop",
                    path.display(),
                    n + 1,
                    condition.trim()
                );
            }
        }
    }
    assert!(loops > 20, "{loops} loops found");
}

#[test]
fn every_shader_validates_in_2d() {
    check_all::<D2>();
}

#[test]
fn every_shader_validates_in_3d() {
    check_all::<D3>();
}

#[test]
fn a_broken_shader_is_rejected() {
    // The validator is live: a type error must be reported with the file name.
    let src = "@compute @workgroup_size(1) fn main() { let x: f32 = 1u; }";
    let err = naga::front::wgsl::parse_str(src).unwrap_err();
    assert!(
        err.emit_to_string_with_path(src, "broken.wgsl")
            .contains("broken.wgsl")
    );
}

/// The bindings an entry point uses, by name, and its storage buffers, as the pipeline
/// check counts them: those it reads or writes, not every one its module declares.
#[test]
fn bindings_are_reflected_per_entry_point() {
    let src = "
        @group(0) @binding(0) var<storage, read> a: array<f32>;
        @group(0) @binding(1) var<storage, read> b: array<f32>;
        @group(0) @binding(2) var<storage, read_write> c: array<f32>;
        @group(0) @binding(3) var<uniform> k: vec4<f32>;
        @compute @workgroup_size(1) fn both(@builtin(global_invocation_id) i: vec3<u32>) {
            c[i.x] = a[i.x] + k.x;
        }
        @compute @workgroup_size(1) fn one(@builtin(global_invocation_id) i: vec3<u32>) {
            c[i.x] = b[i.x];
        }
    ";
    let names = |entry: &str| {
        let r = reflect(src, entry).unwrap();
        let mut names: Vec<String> = r.bindings.into_iter().map(|(_, n)| n).collect();
        names.sort();
        (names, r.storage_buffers)
    };
    assert_eq!(names("both"), (vec!["a".into(), "c".into(), "k".into()], 2));
    assert_eq!(names("one"), (vec!["b".into(), "c".into()], 2));
    assert!(reflect(src, "none").unwrap_err().contains("none"));
}

/// The per-pass check against WebGPU's limits is live: nine storage buffers, or 512
/// invocations per workgroup, or 32 KB of workgroup memory are each refused.
#[test]
fn a_pass_above_webgpu_limits_is_rejected() {
    let buffers: String = (0..9)
        .map(|k| format!("@group(0) @binding({k}) var<storage, read_write> b{k}: array<f32>;\n"))
        .collect();
    let sum: String = (0..9).map(|k| format!("b{k}[0] = 1.0;")).collect();
    let nine = format!("{buffers}@compute @workgroup_size(64) fn nine() {{ {sum} }}");
    let wide = "@compute @workgroup_size(512) fn wide() {}".to_string();
    let shared = "var<workgroup> t: array<f32, 8192>;
        @compute @workgroup_size(64) fn fill(@builtin(local_invocation_index) i: u32) { t[i] = 1.0; }"
        .to_string();
    for (src, says) in [
        (nine, "9 storage buffers"),
        (wide, "512 invocations"),
        (shared, "32768 bytes of workgroup memory"),
    ] {
        let refused = std::panic::catch_unwind(|| validate_wgsl("limits", &src))
            .expect_err("accepted above WebGPU's limits");
        let message = refused
            .downcast_ref::<String>()
            .expect("a formatted message");
        assert!(message.contains(says), "{message}");
    }
}
