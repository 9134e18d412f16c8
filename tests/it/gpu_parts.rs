//! Neighbour lists split into parts past the largest storage binding (`gpu::parts`): the
//! rates of a run whose binding limit is forced down to 1 MiB against the unsplit run's on
//! the same adapter, and the refusals, by name, of the passes that still need a buffer
//! whole.

use crate::common::{gpu, load, tl_scheme};
use meshless::core::tensor::{D2, D3};
use meshless::gpu::layout::GpuDim;
use meshless::methods::tlsph::{GpuTlsph, TlState};
use meshless::scene::Scene;
use std::process::Command;

/// The forced binding limit: several parts for the per-pair data of the scenes below
/// (3–9 MB), none for their per-particle buffers (under 0.8 MB each).
const LIMIT: u64 = 1 << 20;

/// A deformed, moving state of the engine's particles: a smooth stretch and shear
/// u = 0.02 (x y, −x², x z) and the velocity 0.3 u / |u|max, so that every pair term
/// (F, Ḟ, the viscosity, the hourglass control) is non-zero.
fn deformed<D: GpuDim>(g: &GpuTlsph<D>) -> TlState<D> {
    let mut y = g.state();
    for (i, &x) in g.reference().x0.iter().enumerate() {
        let x = D::to3(x);
        let u = [0.02 * x[0] * x[1], -0.02 * x[0] * x[0], 0.02 * x[0] * x[2]];
        y.u[i] = D::from_slice(&u);
        y.v[i] = D::from_slice(&u.map(|c| 15.0 * c));
    }
    y
}

/// The f32 values of rates, F and P, and the corrected gradients, as bits.
fn bits<D: GpuDim>(g: &mut GpuTlsph<D>, y: &TlState<D>) -> Vec<u64> {
    let (d, f, p) = g.rates(y);
    let mut out = Vec::new();
    let mut vectors = |vs: &[D::V]| {
        out.extend(vs.iter().flat_map(|&v| D::to3(v)).map(f64::to_bits));
    };
    vectors(&d.u);
    vectors(&d.v);
    vectors(&g.gradients());
    let tensors = [d.s, f, p].concat();
    out.extend(
        tensors
            .iter()
            .flat_map(|&t| D::to3x3(t).into_iter().flatten())
            .map(f64::to_bits),
    );
    out.extend(d.rho.iter().map(|r| r.to_bits()));
    out
}

/// The rates of `case` on lists split by [`LIMIT`] and on whole lists: the same bits. The
/// split run sums each particle's pairs in the same order, from the same f32 inputs.
fn split_equals_whole<D: GpuDim>(what: &str, case: &Scene) {
    let mut whole = GpuTlsph::<D>::new(case, tl_scheme(case), gpu()).unwrap();
    let split_gpu = gpu().with_binding_limit(LIMIT);
    let mut split = GpuTlsph::<D>::new(case, tl_scheme(case), split_gpu).unwrap();
    assert!(
        whole.split().is_whole(),
        "{what}: one part without the limit"
    );
    let parts = split.split().parts.len();
    assert!(parts >= 3, "{what}: {parts} parts under 1 MiB");
    let y = deformed(&whole);
    let (a, b) = (bits(&mut whole, &y), bits(&mut split, &y));
    assert_eq!(a.len(), b.len());
    let differ = a.iter().zip(&b).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{what}: {differ} of {} values differ", a.len());
}

#[test]
fn tl_rates_on_lists_split_past_a_1mib_binding_are_the_unsplit_bits() {
    // Every scheme of the total-Lagrangian engine: the pair data of each (∇0W̃, X_j − X_i,
    // the reverse gradients of the variational forces, the hourglass stiffnesses), 2D on
    // the plate at Δx = 0.01 (10,201 particles, about 21 pairs each) and TLSPH in 3D on
    // the block at Δx = 1/16 (4,913 particles, about 74 pairs each).
    let plate = |set: &[&str]| {
        let mut set = set.to_vec();
        set.push("spacing=0.01");
        load("studies/cases/swinging-plate", &set)
    };
    let schemes: [(&str, &[&str]); 7] = [
        ("tlsph (reveles)", &[]),
        ("tlsph (variational)", &["method.force=variational"]),
        ("tlsph (hourglass control)", &["method.hourglass=0.1"]),
        ("tlsph (hypoelastic)", &["material.model=hypoelastic"]),
        (
            "tl-potential",
            &["method.name=tl-potential", "method.force="],
        ),
        (
            "corotated-tlsph (variational)",
            &["method.name=corotated-tlsph", "method.force=variational"],
        ),
        (
            "corotated-tlsph (reference code)",
            &[
                "method.name=corotated-tlsph",
                "method.correction=none",
                "method.force=\"reference-code\"",
            ],
        ),
    ];
    for (what, set) in schemes {
        split_equals_whole::<D2>(what, &plate(set));
    }
    let block = load("spinning-block-3d", &["spacing=0.0625"]);
    split_equals_whole::<D3>("tlsph 3D", &block);
}

#[test]
fn a_pass_that_reads_split_lists_whole_is_refused_by_name() {
    // Dual-support SPH's energy reduction sums each particle's support from the whole
    // lists: past one binding its set-up is refused, naming the buffer and the limit.
    let case = load(
        "studies/cases/swinging-plate",
        &[
            "method.name=dual-support-sph",
            "method.correction=",
            "method.force=",
            "run.solve=dynamic",
            "spacing=0.01",
        ],
    );
    let gpu = gpu().with_binding_limit(LIMIT);
    let err = match GpuTlsph::<D2>::new(&case, tl_scheme(&case), gpu) {
        Ok(_) => panic!("dual-support SPH ran on split lists"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("energy reduction reads every pair") && err.contains(&LIMIT.to_string()),
        "{err}"
    );
}

#[test]
fn the_binding_limit_variable_splits_a_run_or_refuses_it_by_name() {
    // MESHLESS_MAX_BINDING forces the limit on any adapter. A TLSPH check and run go on
    // with split lists; the upwind-SPH engine, whose per-pair buffer stays whole, is
    // refused with exit code 2 naming the buffer and the variable; a malformed value is
    // refused naming the variable.
    let exe = env!("CARGO_BIN_EXE_meshless");
    let dir = tempfile::tempdir().unwrap();
    let run = |limit: &str, method: &str| {
        Command::new(exe)
            .args(["run", "studies/cases/swinging-plate", "--backend", "gpu"])
            .args(["--set", "spacing=0.01", "--set", "run.end_time=2e-5"])
            .args(["--set", &format!("method.name={method}")])
            .args(["--set", "method.force=", "--quiet", "--out"])
            .arg(dir.path())
            .env("MESHLESS_MAX_BINDING", limit)
            .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/cases"))
            .output()
            .unwrap()
    };
    let tl = run("1MiB", "tlsph");
    let stderr = String::from_utf8_lossy(&tl.stderr);
    assert!(tl.status.success(), "{stderr}");
    let mixed = run("1MiB", "upwind-sph");
    let stderr = String::from_utf8_lossy(&mixed.stderr);
    assert_eq!(mixed.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("per-pair buffer") && stderr.contains("MESHLESS_MAX_BINDING"),
        "{stderr}"
    );
    let bad = run("a lot", "tlsph");
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success(), "{stderr}");
    assert!(stderr.contains("MESHLESS_MAX_BINDING=a lot"), "{stderr}");
}

#[test]
fn a_split_run_reports_the_bytes_of_the_unsplit_one() {
    // The pass report's bytes model counts a pass's pairs once over the dispatches of its
    // parts: `meshless bench` of TLSPH on the plate at about 1e4 particles gives each pass
    // the same bytes per step, and the step the same bytes per particle, split by a 1 MiB
    // binding or whole (the dispatches per step differ: one a part).
    let exe = env!("CARGO_BIN_EXE_meshless");
    let bench = |limit: Option<&str>| {
        let mut command = Command::new(exe);
        command
            .args(["bench", "studies/cases/swinging-plate", "--backend", "gpu"])
            .args(["--particles", "1e4", "--steps", "2"])
            .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/cases"));
        if let Some(limit) = limit {
            command.env("MESHLESS_MAX_BINDING", limit);
        }
        let out = command.output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // (pass, bytes per step) of each row of the pass report, and its last line.
        let rows: Vec<(String, String)> = stdout
            .lines()
            .filter(|l| l.starts_with("| tl ") || l.starts_with("| blend"))
            .map(|l| {
                let cells: Vec<&str> = l.split('|').map(str::trim).collect();
                (cells[1].to_string(), cells[4].to_string())
            })
            .collect();
        let total = stdout
            .lines()
            .find(|l| l.contains("bytes per particle-step"))
            .and_then(|l| l.rsplit('(').next())
            .unwrap_or_default()
            .to_string();
        (rows, total)
    };
    let (whole, split) = (bench(None), bench(Some("1MiB")));
    assert_eq!(whole.0.len(), 3, "{whole:?}");
    assert_eq!(whole, split);
}
