//! Every WGSL pass validates with naga (and lowers to an IR) without any adapter, in both
//! dimensions and for every scene variant the solver compiles.

use meshless::gpu::layout::GpuDim;
use meshless::gpu::mixed;
use meshless::gpu::shaders::{self, Constants};
use meshless::gpu::tlsph::{Layout, scene_constants};
use meshless::method::mixed::MixedSph;
use meshless::run::build_method;
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

/// Mixed-method scenes of dimension `dim`: with ghosts (mirror planes) and without, each
/// material model the mixed methods allow, projection on and off, Upwind-SPH with and
/// without reconstruction and JST-SPH, each set of conserved variables, and each method
/// with the seed 002 options (symmetrised momentum, bond-based F with {p, F}).
fn mixed_variants(dim: usize) -> Vec<Case> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
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
    let methods: [&[&str]; 3] = [
        &["method.name=upwind-sph"],
        &["method.name=upwind-sph", "method.reconstruction=false"],
        &["method.name=jst-sph"],
    ];
    let mut cases = Vec::new();
    for (name, base) in &bases {
        for method in methods {
            for variables in ["p-F", "p-F-J", "p-F-H-J"] {
                let mut set: Vec<String> = base.iter().map(|s| s.to_string()).collect();
                set.extend(method.iter().map(|s| s.to_string()));
                set.push(format!("method.variables={variables}"));
                let path = dir.join(format!("{name}.toml"));
                cases.push(Case::load(&path, &set).unwrap());
            }
        }
    }
    let (seed_002, base) = if dim == 2 {
        ("swinging-plate", "spacing=0.125")
    } else {
        ("bending-column", "method.jst=")
    };
    for method in methods {
        let mut set = vec![base.to_string()];
        set.extend(method.iter().map(|s| s.to_string()));
        set.extend(
            [
                "method.variables=p-F",
                "method.momentum=symmetrised",
                "method.deformation_gradient=bond-based",
            ]
            .map(String::from),
        );
        let path = dir.join(format!("{seed_002}.toml"));
        cases.push(Case::load(&path, &set).unwrap());
    }
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
    for case in mixed_variants(D::N) {
        let cpu: MixedSph<D> = build_method(&case).unwrap();
        let (_, constants) = mixed::scene(&case, &cpu);
        for source in shaders::MIXED_SCENE {
            let src = shaders::compose::<D>(source, &constants);
            validate(&format!("{}D {} ({})", D::N, source.name, case.name), &src);
        }
    }
    // Passes without scene constants (neighbour build, scans) validate on their own.
    for source in shaders::ALL {
        if !shaders::SCENE.contains(source) && !shaders::MIXED_SCENE.contains(source) {
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
