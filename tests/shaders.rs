//! Every WGSL pass validates with naga (and lowers to an IR) without any adapter, in both
//! dimensions and for every scene variant the solver compiles.

use meshless::gpu::layout::GpuDim;
use meshless::gpu::shaders::{self, Constants};
use meshless::gpu::tlsph::{Layout, scene_constants};
use meshless::scene::Case;
use meshless::tensor::{D2, D3};
use std::path::Path;

fn validate(name: &str, src: &str) {
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string_with_path(src, name)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{}", e.emit_to_string_with_path(src, name)));
}

fn variants() -> Vec<Case> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let disk = dir.join("rotating-disk.toml");
    let mut cases = vec![
        Case::load(&disk, &[]).unwrap(),
        Case::load(
            &disk,
            &[
                "material.model=saint-venant-kirchhoff".into(),
                "method.artificial_viscosity=".into(),
            ],
        )
        .unwrap(),
        Case::load(
            &disk,
            &[
                "material.model=neo-hookean".into(),
                "method.kernel=quintic".into(),
                "method.correction=\"shepard\"".into(),
            ],
        )
        .unwrap(),
        Case::load(
            &dir.join("wave-rod.toml"),
            &["method.correction=\"none\"".into()],
        )
        .unwrap(),
    ];
    cases.push(
        Case::load(
            &dir.join("wave-rod.toml"),
            &["method.kernel=cubic-spline".into()],
        )
        .unwrap(),
    );
    cases
}

fn check_all<D: GpuDim>() {
    for case in variants() {
        for rate in [false, true] {
            let constants = scene_constants(&case, &Layout::new(100, D::N, rate));
            for source in shaders::SCENE {
                let src = shaders::compose::<D>(source, &constants);
                validate(&format!("{}D {} ({})", D::N, source.name, case.name), &src);
            }
        }
    }
    // Passes without scene constants (neighbour build, scans) validate on their own.
    for source in shaders::ALL {
        if !shaders::SCENE.contains(source) {
            validate(
                source.name,
                &shaders::compose::<D>(source, &Constants::default()),
            );
        }
    }
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
