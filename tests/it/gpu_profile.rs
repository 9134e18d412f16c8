//! The GPU pass report (`meshless bench --backend gpu`) on the adapter wgpu finds
//! (lavapipe here): every pass of a step of every GPU engine appears with a positive
//! time, the bytes of the model, and a sum of times within the measured wall time.
//! Without an adapter these tests fail: `bench::measure` on the GPU backend returns the
//! error, which they unwrap.

use crate::common::{cpu_options, load};
use meshless::bench::measure;
use meshless::core::integrate::{Op, program};
use meshless::core::tensor::{D2, D3};
use meshless::diagnostics::passes::PassReport;
use meshless::gpu::bytes::{Access, BindingUse, PassBytes, pass_model};
use meshless::reference::Reference;
use meshless::run::{Backend, RunOptions, run};
use meshless::scene::Scene;
use std::collections::BTreeMap;

/// Steps of each report: enough dispatches to time, few enough for lavapipe.
const STEPS: u32 = 6;

/// The pass report of `STEPS` steps of `case` on the GPU, with its particles and pairs
/// (the host's reference lists, built here independently of the engine's count).
fn profiled(case: &Scene) -> (PassReport, u64, u64) {
    let row = measure(case, Backend::Gpu, STEPS).unwrap_or_else(|e| {
        panic!(
            "the pass report needs a GPU adapter (CI installs Mesa lavapipe: apt-get install \
             mesa-vulkan-drivers): {e}"
        )
    });
    let report = row.passes.expect("a GPU engine has a pass report");
    let reference = Reference::<D2>::build(case).unwrap();
    let pairs = reference.neighbours().pair_count() as u64;
    (report, reference.x0.len() as u64, pairs)
}

/// `passes` and the blend passes of the case's integrator with their dispatches per
/// step: in place (`blend (blend)`) and from another buffer, a copy fused in
/// (`blend (blend_from)`).
fn with_blends<'a>(case: &Scene, passes: &[(&'a str, u64)]) -> Vec<(&'a str, u64)> {
    let ops = program(case.method.integrator);
    let count = |in_place: bool| {
        ops.iter()
            .filter(|op| matches!(op, Op::Blend { out, from, .. } if (out == from) == in_place))
            .count() as u64
    };
    let blends = [
        ("blend (blend)", count(true)),
        ("blend (blend_from)", count(false)),
    ];
    passes
        .iter()
        .copied()
        .chain(blends.into_iter().filter(|b| b.1 > 0))
        .collect()
}

/// Each blend, in place or from another buffer, moves 12 B per entry of a state of
/// `words` words a particle: two entries read and one written.
fn check_blends(report: &PassReport, words: u64, n: u64) {
    for r in report.rows.iter().filter(|r| r.pass.starts_with("blend (")) {
        assert_eq!(
            r.bytes.unwrap(),
            r.runs * 12 * words * n,
            "{}:\n{report}",
            r.pass
        );
    }
}

fn row<'a>(report: &'a PassReport, pass: &str) -> &'a meshless::diagnostics::passes::PassRow {
    report
        .rows
        .iter()
        .find(|r| r.pass == pass)
        .unwrap_or_else(|| panic!("no pass `{pass}` in the report:\n{report}"))
}

/// What every report must show: the passes named with their dispatches per step and no
/// other pass, a positive time and a model's bytes for each, and the sum of the passes'
/// device times within the wall time of the steps (the wall time also holds the copies
/// between state buffers, the launches and the resolve of the timestamps).
fn check_common(report: &PassReport, expected: &[(&str, u64)]) {
    assert_eq!(report.steps, STEPS);
    assert!(
        report.note.is_none(),
        "the adapter has timestamp queries: {report}"
    );
    assert!(
        report.copy_bandwidth.is_finite() && report.copy_bandwidth > 0.0,
        "{report}"
    );
    for &(pass, per_step) in expected {
        let r = row(report, pass);
        assert_eq!(
            r.dispatches,
            per_step * u64::from(STEPS),
            "{pass}:\n{report}"
        );
    }
    for r in &report.rows {
        let seconds = r.seconds.expect("timed");
        assert!(seconds > 0.0, "{}: {seconds} s\n{report}", r.pass);
        assert!(
            r.bytes.is_some_and(|b| b > 0),
            "{}: no bytes\n{report}",
            r.pass
        );
        assert!(r.runs <= r.dispatches, "{}\n{report}", r.pass);
    }
    let timed: f64 = report.rows.iter().filter_map(|r| r.seconds).sum();
    assert!(
        timed <= report.wall_seconds,
        "passes {timed} s, wall {} s\n{report}",
        report.wall_seconds
    );
}

/// TLSPH's rotating disk (2D, rate model, viscosity, RK4): the stress and accel passes
/// move 196 B per particle and 32 B per pair per rate evaluation, as read off the WGSL
/// (stress: the row end, V, u, v, ρ − ρ0, S in and P, F⁻ᵀ, ρ, ρ̇, Ṡ out, 25 words, H being
/// stored only by the kinematics pass of the outputs, since no force pass reads it; ids
/// and ∇0W̃ per pair, 3 words; accel: the row end, V and the mask, u, v, P, F⁻ᵀ, ρ, ext in
/// and the power, the viscous dissipation, u̇, v̇ out, 24 words; ids, ∇0W̃ and X_j − X_i per pair, 5 words), and
/// each RK4 blend reads and writes 3 words of the 9-word state per particle.
#[test]
fn the_rotating_disk_report_has_the_bytes_of_the_wgsl() {
    let case = load("rotating-disk", &[] as &[&str]);
    let (report, n, pairs) = profiled(&case);
    let evaluations = 4 * u64::from(STEPS);
    let expected = with_blends(&case, &[("tl stress (stress)", 4), ("tl accel (accel)", 4)]);
    check_common(&report, &expected);
    assert_eq!(report.rows.len(), expected.len(), "{report}");
    let stress = row(&report, "tl stress (stress)").bytes.unwrap();
    let accel = row(&report, "tl accel (accel)").bytes.unwrap();
    assert_eq!(stress, evaluations * (100 * n + 12 * pairs));
    assert_eq!(stress + accel, evaluations * (196 * n + 32 * pairs));
    check_blends(&report, 9, n);
    assert_eq!(report.particles as u64, n);
}

/// The tensile strip (TLSPH with grips) has the same passes and per-particle bytes.
#[test]
fn the_tensile_strip_report_has_the_bytes_of_the_wgsl() {
    let case = load("tensile-strip", &[] as &[&str]);
    let (report, n, pairs) = profiled(&case);
    check_common(
        &report,
        &with_blends(&case, &[("tl stress (stress)", 4), ("tl accel (accel)", 4)]),
    );
    let both = row(&report, "tl stress (stress)").bytes.unwrap()
        + row(&report, "tl accel (accel)").bytes.unwrap();
    assert_eq!(both, 4 * u64::from(STEPS) * (196 * n + 32 * pairs));
}

/// The elastic potential and corotated TLSPH on the rotating disk, on TLSPH's engine:
/// their own passes, with the bytes read off their WGSL for each case's settings. Per
/// particle a field counts once whether it is the particle's own or a neighbour's, per
/// pair what is indexed by the pair, and a load whose value the case's variant never uses
/// (behind a constant that is off) is no traffic.
///
/// The elastic potential (Saint Venant–Kirchhoff, not the rate model; consistent force,
/// no viscosity): its stress pass is TLSPH's (`tl/tlsph.wgsl`, RATE = 0): the row end,
/// V, u in and P out, 8 words = 32 B (v is read only for Ḟ of the rate model; H, F⁻ᵀ and
/// ρ, which the force pass reads only for the viscosity or the dual-support hourglass
/// force, are stored by the kinematics pass of the outputs alone); the id and ∇0W̃ per
/// pair, 3 words = 12 B. Its accel pass
/// (`potential/potential.wgsl`): the row end, V and the mask, v, P, ext in and the power,
/// the viscous dissipation, u̇, v̇ out, 17 words = 68 B (u, ρ and F⁻ᵀ feed only the
/// viscosity and H the dual-support hourglass force); the id, ∇0W̃_ij and ∇0W̃_ji per
/// pair, 5 words = 20 B. A rate evaluation: 100 B per particle, 32 B per pair.
///
/// Corotated TLSPH (linear elastic, the reference code's force, no viscosity): its stress
/// pass (`corotated/corotated.wgsl`, shape matching): the row end, V, u in and P̂, R out,
/// 12 words = 48 B (F̂ − I, R F̂⁻ᵀ and ρ, which its force pass reads only for the
/// viscosity, are stored by the kinematics pass of the outputs alone); the id, X_j − X_i and ∇0W_ij per pair (both loops
/// over the row read the same pairs), 5 words = 20 B. Its accel pass
/// (`corotated/corotated_accel.wgsl`): the row end, V and the mask, v, R, P̂, ext in and
/// the power, the viscous dissipation, u̇, v̇ out, 21 words = 84 B (u, ρ and R F̂⁻ᵀ feed
/// only the viscosity); the id and ∇0W_ij per pair, 3 words = 12 B (∇0W_ji is the
/// variational force's). A rate evaluation: 132 B per particle, 32 B per pair.
///
/// Both states are [u | v], 4 words a particle: each RK4 blend reads and writes 3 words
/// of each, 48 B per particle. The pairs are the host's reference lists, which both
/// schemes use (the kernel's support at each case's h).
#[test]
fn the_total_lagrangian_schemes_report_their_own_passes() {
    const STRESS: &str = "tl stress (stress)";
    const ACCEL: &str = "tl accel (accel)";
    // (case, stress per particle, per pair; accel per particle, per pair) in bytes.
    for (name, stress, accel) in [
        ("rotating-disk-potential", (32, 12), (68, 20)),
        ("rotating-disk-corotated", (48, 20), (84, 12)),
    ] {
        let case = load(name, &[] as &[&str]);
        let stages = case.method.integrator.stages() as u64;
        let (report, n, pairs) = profiled(&case);
        let expected = with_blends(&case, &[(STRESS, stages), (ACCEL, stages)]);
        check_common(&report, &expected);
        assert_eq!(report.rows.len(), expected.len(), "{name}:\n{report}");
        let evaluations = stages * u64::from(STEPS);
        // Each pass's bytes: its words per particle and per pair, per rate evaluation.
        for (pass, (item, pair)) in [(STRESS, stress), (ACCEL, accel)] {
            assert_eq!(
                row(&report, pass).bytes.unwrap(),
                evaluations * (item * n + pair * pairs),
                "{name} {pass}:\n{report}"
            );
        }
        // The blends: 12 B per entry of the 4-word state of a particle.
        check_blends(&report, 4, n);
        assert_eq!(report.particles as u64, n);
    }
}

/// The updated-Lagrangian engine: positions, the drift check and its arming at every rate
/// evaluation, the build's passes only in the builds that ran, and the method's passes
/// with the bytes read off their WGSL (both cases: the hypoelastic rate model, no
/// correction of L, so neither pass gathers A⁻ᵀ). Per particle a field counts once
/// whether it is the particle's own or a neighbour's, per pair what is indexed by it.
///
/// Gray–Monaghan (viscosity, artificial stress, XSPH on): `ul particle` reads V, ρ − ρ0,
/// S and writes σ/ρ², R, c and V = m/ρ, 16 words = 64 B, no pairs; `ul rates` reads the
/// row end, x, v, ρ − ρ0, S, F − I, σ/ρ², R, c, m/ρ, V and the mask, ext and writes the
/// power, u̇, v̇, ρ̇, Ṡ, Ḟ, 42 words = 168 B; the id per pair, 4 B.
///
/// Godunov: `ul particle` reads V, ρ − ρ0, S and writes σ, p, Z = ρc and V = m/ρ,
/// 13 words = 52 B; `ul rates` reads the row end, x, v, ρ − ρ0, S, F − I, σ, p, Z, m/ρ,
/// V and the mask, ext and writes the power, u̇, v̇, ρ̇, Ṡ, Ḟ, 39 words = 156 B; the id
/// per pair, 4 B.
///
/// The pairs are those of the device's last build, which the engine reads back: its
/// lists hold every pair within the kernel's support widened by the skin (and the f32
/// margin of `gpu::neighbour`), rebuilt once a particle has drifted half the skin. Over
/// these steps no particle drifts that far (the rim moves ω R t ≤ 3e-3 in at most 6e-5 s,
/// half the skin is 1.8e-2), so the last build is the first, on the reference positions:
/// the pairs here are the host's lists of the reference positions within that radius.
#[test]
fn the_updated_lagrangian_report_counts_the_builds_that_ran() {
    use meshless::core::neighbour::{SKIN, build};
    const PARTICLE: &str = "ul particle (particle)";
    const RATES: &str = "ul rates (rates)";
    // (case, particle per particle, rates per particle, rates per pair) in bytes.
    for (name, particle, rates, rates_pair) in [
        ("rotating-disk-gray-monaghan", 64, 168, 4),
        ("rotating-disk-godunov", 52, 156, 4),
    ] {
        let case = load(name, &[] as &[&str]);
        let stages = case.method.integrator.stages() as u64;
        let (report, n, _) = profiled(&case);
        check_common(
            &report,
            &with_blends(
                &case,
                &[
                    ("ul positions (positions)", stages),
                    ("check_drift (check_drift)", stages),
                    ("arm (arm)", stages),
                    (PARTICLE, stages),
                    (RATES, stages),
                ],
            ),
        );
        // x = X + u: X and u in, x out, DIM floats each.
        let positions = row(&report, "ul positions (positions)");
        assert_eq!(positions.bytes.unwrap(), positions.runs * 24 * n);
        for pass in [
            "clear_counts (clear_counts)",
            "bin_particles (bin_particles)",
            "scatter (scatter)",
            "count_neighbours (count_neighbours)",
            "fill_neighbours (fill_neighbours)",
            "save_built (save_built)",
        ] {
            let r = row(&report, pass);
            assert_eq!(r.dispatches, stages * u64::from(STEPS), "{name} {pass}");
        }
        // No rebuild on moved positions: at most one build ran over the steps.
        let built = row(&report, "fill_neighbours (fill_neighbours)").runs;
        assert!(built <= 1, "{name}: {built} builds\n{report}");
        let reference = Reference::<D2>::build(&case).unwrap();
        let radius = reference.kernel.support() * (1.0 + SKIN) * (1.0 + 1e-5);
        let pairs = build::<D2>(&reference.x0, radius).pair_count() as u64;
        let evaluations = stages * u64::from(STEPS);
        // The particle pass gathers nothing (no correction): bytes per particle alone.
        assert_eq!(
            row(&report, PARTICLE).bytes.unwrap(),
            evaluations * particle * n,
            "{name}:\n{report}"
        );
        assert_eq!(
            row(&report, RATES).bytes.unwrap(),
            evaluations * (rates * n + rates_pair * pairs),
            "{name}:\n{report}"
        );
        // The blends: 12 B per entry of the 13-word state [u | v | ρ − ρ0 | S | F − I].
        check_blends(&report, 13, n);
    }
}

/// The mixed family on the swinging plate at Δx = 0.05 (linear elastic {p, F}: the state
/// [u | v | F − I]; mirror planes on all four sides, so no projection): ghosts,
/// kinematics, slopes, forces and rates of Upwind-SPH (with reconstruction), the
/// Laplacian of JST-SPH, with the bytes read off their WGSL. Per particle a field counts
/// once whether it is the particle's own or a neighbour's, per pair what is indexed by
/// it; a gather reads a ghost's values once each, which the ghost pass that fills them
/// counts (per ghost), not the gather.
///
/// - `kinematics`: the row end, v, F − I in and P, Ḟ out, 15 words = 60 B; the id and
///   G_ab per pair, 3 words = 12 B.
/// - `slopes` (Upwind): the row end, v, P in and the slopes ∇0v, ∂P/∂X_l out, 19 words =
///   76 B; the id and the least-squares weight per pair, 3 words = 12 B.
/// - `laplacian` (JST): the row end, v in and ∇²v out, 5 words = 20 B; the id and ℓ_ab
///   per pair, 2 words = 8 B.
/// - `forces`, Upwind: the row end, u, v, P, the slopes in and T, D(p), D(J) out,
///   26 words = 104 B; the id, G_ab, G_ba and X_b − X_a per pair, 7 words = 28 B. JST:
///   the row end, v, P, ∇²v in and T, D(p), D(J) out, 14 words = 56 B (u orients only
///   the upwind flux); the id, G_ab, G_ba and s_ab per pair, 6 words = 24 B.
/// - `rates`: T, D(p), v, V and the mask, ext in and the power, u̇, v̇ out, 15 words =
///   60 B, no pairs.
/// - per ghost, its source and image (reflection and sign, 4 words) and: `ghost_motion`
///   the source's u, v in, the ghost's out, 12 words = 48 B; `ghost_kin` P in and out,
///   12 words = 48 B; `ghost_slopes` the slopes in and out, 28 words = 112 B;
///   `ghost_laplacian` ∇²v in and out, 8 words = 32 B.
/// - each TVD-RK2 blend: 12 B per entry of the 8-word state.
///
/// From the case's geometry: 20 × 20 cell-centred particles; the kernel's support is
/// 2h = 2.6 Δx, so the ghosts are the images of the 3 layers of particles within it of
/// each plane (3 · 20 a side) and of each corner's 3 × 3 (imaged through both planes),
/// 276; and every particle, its support closed by the ghosts, has the 20 lattice points
/// within 2.6 Δx (distances 1, √2, 2, √5) as neighbours: 20 pairs a particle.
#[test]
fn the_mixed_report_has_every_pass_of_a_stage() {
    let case = load("swinging-plate", &["spacing=0.05"]);
    let stages = case.method.integrator.stages() as u64;
    let (report, n, _) = profiled(&case);
    assert_eq!(n, 20 * 20);
    let (ghosts, pairs) = (4 * 3 * 20 + 4 * 3 * 3, 20 * n);
    let expected = with_blends(
        &case,
        &[
            ("ghost motion (ghost_motion)", stages),
            ("mixed kinematics (kinematics)", stages),
            ("ghost kinematics (ghost_kin)", stages),
            ("slopes (slopes)", stages),
            ("ghost slopes (ghost_slopes)", stages),
            ("mixed forces (forces)", stages),
            ("mixed rates (rates)", stages),
        ],
    );
    check_common(&report, &expected);
    assert_eq!(report.rows.len(), expected.len(), "{report}");
    let evaluations = stages * u64::from(STEPS);
    // Each pass's bytes per rate evaluation: (pass, per particle, per pair), and per ghost.
    let check = |report: &PassReport, passes: &[(&str, u64, u64)], ghost: &[(&str, u64)]| {
        for &(pass, item, pair) in passes {
            assert_eq!(
                row(report, pass).bytes.unwrap(),
                evaluations * (item * n + pair * pairs),
                "{pass}:\n{report}"
            );
        }
        for &(pass, item) in ghost {
            assert_eq!(
                row(report, pass).bytes.unwrap(),
                evaluations * item * ghosts,
                "{pass}:\n{report}"
            );
        }
        check_blends(report, 8, n);
    };
    check(
        &report,
        &[
            ("mixed kinematics (kinematics)", 60, 12),
            ("slopes (slopes)", 76, 12),
            ("mixed forces (forces)", 104, 28),
            ("mixed rates (rates)", 60, 0),
        ],
        &[
            ("ghost motion (ghost_motion)", 48),
            ("ghost kinematics (ghost_kin)", 48),
            ("ghost slopes (ghost_slopes)", 112),
        ],
    );
    let jst = load("swinging-plate", &["spacing=0.05", "method.name=jst-sph"]);
    let stages = jst.method.integrator.stages() as u64;
    let (report, _, _) = profiled(&jst);
    check_common(
        &report,
        &[
            ("slopes (laplacian)", stages),
            ("ghost slopes (ghost_laplacian)", stages),
            ("mixed forces (forces)", stages),
        ],
    );
    check(
        &report,
        &[
            ("mixed kinematics (kinematics)", 60, 12),
            ("slopes (laplacian)", 20, 8),
            ("mixed forces (forces)", 56, 24),
            ("mixed rates (rates)", 60, 0),
        ],
        &[
            ("ghost motion (ghost_motion)", 48),
            ("ghost kinematics (ghost_kin)", 48),
            ("ghost slopes (ghost_laplacian)", 32),
        ],
    );
}

/// The model of entry point `pass` written above it in a one-file source `test.wgsl`:
/// `rows`, one `// - ` row (or prose line) each, after the header.
fn model(rows: &[&str]) -> Result<Option<PassBytes>, String> {
    pass_model(&source(rows), "pass")
}

fn source(rows: &[&str]) -> String {
    let rows: String = rows.iter().map(|r| format!("{r}\n")).collect();
    format!("// file: test.wgsl\n// bytes:\n{rows}@compute @workgroup_size(1)\nfn pass() {{}}\n")
}

/// A model's bytes: each direction the WGSL uses a binding in once (a binding read and
/// written twice, or its loads and stores apart), times the bytes of the binding's
/// element; conditions on the variant's constants, slopes (DIM + 1)·DIM² elements, moduli
/// DIM⁴. A count of a binding, or of a direction of one, that the entry point does not use
/// is an error naming the row's file and line.
#[test]
fn a_bytes_model_counts_directions_conditions_and_slopes() {
    let parsed = |rows: &[&str]| model(rows).unwrap().unwrap();
    let model = parsed(&[
        "// - a: 1 scalar + 1 vector + 1 tensor per item; 1 scalar per pair",
        "// Prose between the rows.",
        "// - b: 1 vector per item, when AV",
        "// - c: 1 slope per item, when STAB == STAB_JST",
    ]);
    let missing = parsed(&["// - a: 1 scalar per item, when XSPH"]);
    // A binding read and written with one tensor loaded and a scalar stored per item, and
    // a vec4<f32> (16 bytes) read per item.
    let split = parsed(&[
        "// - c loads: 1 tensor per item",
        "// - c stores: 1 scalar per item",
        "// - v: 1 scalar per item",
    ]);
    let unused = parsed(&["// - e: 1 scalar per item"]);
    let not_stored = parsed(&["// - a stores: 1 scalar per item"]);
    let moduli = parsed(&["// - a: 1 modulus per item; 2 vectors per pair, when AV != 0"]);
    let constants = |av: i64, stab: i64| {
        move |name: &str| match name {
            "DIM" => Some(3),
            "AV" => Some(av),
            "STAB" => Some(stab),
            "STAB_JST" => Some(1),
            _ => None,
        }
    };
    // As naga's reflection of a WGSL source would give them: a read, b written, c read
    // and written, f32 elements; v read, vec4<f32> elements; e not used.
    let uses = |name: &str| {
        let (access, element_bytes) = match name {
            "a" => (Access::Read, 4),
            "b" => (Access::Write, 4),
            "c" => (Access::ReadWrite, 4),
            "v" => (Access::Read, 16),
            _ => return None,
        };
        Some(BindingUse {
            access,
            element_bytes,
        })
    };
    let cost = model.cost(constants(0, 0), uses).unwrap();
    assert_eq!((cost.item, cost.pair), (4 * (1 + 3 + 9), 4));
    let cost = model.cost(constants(1, 1), uses).unwrap();
    assert_eq!(cost.item, 4 * (1 + 3 + 9 + 3 + 2 * 4 * 9));
    let err = missing.cost(constants(0, 0), uses).unwrap_err();
    assert!(err.contains("XSPH") && err.contains("test.wgsl:2"), "{err}");
    let cost = split.cost(constants(0, 0), uses).unwrap();
    assert_eq!((cost.item, cost.pair), (4 * 9 + 4 + 16, 0));
    let err = unused.cost(constants(0, 0), uses).unwrap_err();
    assert!(err.contains("`e`") && err.contains("does not use"), "{err}");
    let err = not_stored.cost(constants(0, 0), uses).unwrap_err();
    assert!(err.contains("stores of `a`"), "{err}");
    let cost = moduli.cost(constants(1, 0), uses).unwrap();
    assert_eq!((cost.item, cost.pair), (4 * 81, 4 * 6));
    let cost = moduli.cost(constants(0, 0), uses).unwrap();
    assert_eq!((cost.item, cost.pair), (0, 0));
}

/// A malformed row, an include of a block that no line declares, and a model above no
/// entry point are errors that name the file, the entry point and the line; an entry
/// point without a model has none; a block's rows count where it is included.
#[test]
fn a_malformed_bytes_model_names_its_file_entry_and_line() {
    for (rows, wrong) in [
        (&["// - a 1 scalar per item"][..], "binding"),
        (&["// - a: 1 scalar"], "per item"),
        (&["// - a: one scalar per item"], "count"),
        (&["// - a: 1 bushel per item"], "word"),
        (&["// - a twice: 1 scalar per item"], "part"),
        (&["// - include nowhere"], "`nowhere`"),
    ] {
        let err = model(rows).unwrap_err();
        assert!(
            err.contains("shaders/test.wgsl:2") && err.contains("`pass`") && err.contains(wrong),
            "{rows:?}: {err}"
        );
    }
    let stray = "// file: test.wgsl\n// bytes:\n// - a: 1 scalar per item\n\n\
                 @compute @workgroup_size(1)\nfn pass() {}\n";
    let err = pass_model(stray, "pass").unwrap_err();
    assert!(
        err.contains("shaders/test.wgsl:1") && err.contains("not directly above"),
        "{err}"
    );
    assert_eq!(
        pass_model(&source(&[]).replace("// bytes:\n", ""), "pass"),
        Ok(None)
    );
    let shared = format!(
        "// file: shared.wgsl\n// bytes block core:\n// - a: 2 scalars per item\nfn f() {{}}\n{}",
        source(&["// - include core", "// - b: 1 scalar per pair"])
    );
    let with_block = pass_model(&shared, "pass").unwrap().unwrap();
    let rows: Vec<_> = with_block
        .traffic
        .iter()
        .map(|t| (t.binding.as_str(), t.at.as_str()))
        .collect();
    assert_eq!(
        rows,
        [("a", "shaders/shared.wgsl:2"), ("b", "shaders/test.wgsl:3")]
    );
}

/// A row that names a binding the entry point does not use fails the pass's cost, named
/// by its file and line: the reflection check over a real composed pass.
#[test]
fn a_bytes_model_of_a_binding_the_entry_does_not_use_fails() {
    use meshless::gpu::context::pass_cost;
    use meshless::gpu::shaders::{COPY, Constants, compose};
    let text = compose::<D2>(&COPY, &Constants::default());
    assert!(pass_cost(&text, "copy").unwrap().is_some());
    let broken = text.replacen(
        "// - dst:",
        "// - elsewhere: 1 scalar per item\n// - dst:",
        1,
    );
    assert_ne!(broken, text, "copy.wgsl's model counts dst");
    let err = pass_cost(&broken, "copy").unwrap_err();
    assert!(
        err.contains("shaders/common/copy.wgsl:") && err.contains("`elsewhere`"),
        "{err}"
    );
}

/// `meshless run --profile` on the GPU: the summary carries the report of every step of
/// the run, its passes' times within the run's wall time; without `--profile`, none.
#[test]
fn a_profiled_run_reports_the_passes_of_its_steps() {
    let case = load("rotating-disk", &["run.end_time=3e-5"]);
    let dir = tempfile::tempdir().unwrap();
    let options = |profile| RunOptions {
        backend: Backend::Gpu,
        profile,
        ..cpu_options(dir.path(), false)
    };
    let summary = run(&case, &options(true)).unwrap_or_else(|e| {
        panic!("a profiled run needs a GPU adapter (CI installs Mesa lavapipe): {e}")
    });
    let report = summary
        .passes
        .expect("a profiled GPU run has a pass report");
    assert_eq!(u64::from(report.steps), summary.steps);
    let steps = u64::from(report.steps);
    // The stress pass also runs for the snapshots of the series rows: at least 4 a step.
    assert!(
        row(&report, "tl stress (stress)").dispatches >= 4 * steps,
        "{report}"
    );
    assert_eq!(row(&report, "tl accel (accel)").dispatches, 4 * steps);
    let timed: f64 = report.rows.iter().filter_map(|r| r.seconds).sum();
    assert!(
        timed > 0.0 && timed <= summary.wall_seconds,
        "passes {timed} s, run {} s",
        summary.wall_seconds
    );
    assert!(run(&case, &options(false)).unwrap().passes.is_none());
}

/// The Galerkin engine: the points and nodes passes at every rate evaluation (on the
/// current cells for `ul-fem`), and the weak form's two smoothing passes after every step.
#[test]
fn the_galerkin_report_has_its_points_nodes_and_smoothing_passes() {
    for (name, smoothing) in [
        ("tensile-strip-fem", false),
        ("tensile-strip-ul-fem", false),
        ("rotating-disk-weak-form", true),
    ] {
        let case = load(name, &[] as &[&str]);
        let stages = case.method.integrator.stages() as u64;
        let (report, _, _) = profiled(&case);
        let mut expected = with_blends(
            &case,
            &[
                ("galerkin points (points)", stages),
                ("galerkin nodes (nodes)", stages),
            ],
        );
        if smoothing {
            expected.push(("smooth velocities (smooth_velocities)", 1));
            expected.push(("settle (settle)", 1));
        }
        check_common(&report, &expected);
        assert_eq!(report.rows.len(), expected.len(), "{name}:\n{report}");
    }
}

#[test]
fn the_ledger_books_every_buffer_the_device_keeps() {
    // A storage buffer of 100 f32, a zeroed one of 10 bytes (made 12, a multiple of 4)
    // and an indirect one of 12 are booked at their sizes; a read-back's staging buffer,
    // which lives for one copy, is not.
    let gpu = crate::common::gpu();
    let before = gpu.allocated();
    let a = gpu.storage("ledger a", &[1.0f32; 100]);
    let _b = gpu.zeroed("ledger b", 10);
    let _c = gpu.indirect("ledger c", 12);
    assert_eq!(gpu.read::<f32>(&a), vec![1.0; 100]);
    let book = gpu.allocations();
    assert_eq!(
        [book["ledger a"], book["ledger b"], book["ledger c"]],
        [400, 12, 12]
    );
    assert_eq!(gpu.allocated(), before + 424);
}

/// The device bytes the GPU engine of `case` books (`Gpu::allocated`) after its set-up
/// and one step, with its ledger by label.
fn allocated<D: meshless::engine::EngineDim>(case: &Scene) -> (f64, BTreeMap<String, u64>) {
    let mut engine = meshless::run::engine::<D>(case, Backend::Gpu).unwrap();
    let dt = case.method.dt.unwrap_or(1e-7);
    engine.advance(0.0, dt, 1).unwrap();
    engine.finish();
    let (gpu, _) = engine.device().expect("a GPU engine");
    (gpu.allocated() as f64, gpu.allocations())
}

/// Every GPU method's set-up on a 2D plate and a 3D block, a few thousand particles each:
/// the ones of `scripts/bench-methods.sh`, the mixed family on its shipped cases, the
/// dual-support static solve.
fn every_gpu_method() -> Vec<(&'static str, Scene)> {
    let plate = "studies/cases/swinging-plate";
    let block = "spinning-block-3d";
    let variants: [(&str, &[&str]); 14] = [
        ("tlsph", &[]),
        ("tlsph-hypoelastic", &["material.model=hypoelastic"]),
        (
            "tl-potential",
            &["method.name=tl-potential", "method.force="],
        ),
        (
            "corotated-tlsph",
            &[
                "method.name=corotated-tlsph",
                "method.correction=none",
                "method.force=\"reference-code\"",
            ],
        ),
        (
            "gray-monaghan-sph",
            &[
                "method.name=gray-monaghan-sph",
                "material.model=hypoelastic",
                "method.kernel=cubic-spline",
                "method.correction=none",
            ],
        ),
        (
            "godunov-sph",
            &[
                "method.name=godunov-sph",
                "material.model=hypoelastic",
                "method.kernel=cubic-spline",
                "method.h_over_dx=1.7",
                "method.correction=none",
            ],
        ),
        (
            "dual-support-sph",
            &[
                "method.name=dual-support-sph",
                "method.correction=",
                "run.solve=dynamic",
            ],
        ),
        (
            "tl-weak-form",
            &[
                "method.name=tl-weak-form",
                "method.kernel=cubic-spline",
                "method.correction=",
            ],
        ),
        (
            "tl-fem",
            &[
                "method.name=tl-fem",
                "method.kernel=",
                "method.h_over_dx=",
                "method.correction=",
            ],
        ),
        (
            "ul-fem",
            &[
                "method.name=ul-fem",
                "method.kernel=",
                "method.h_over_dx=",
                "method.correction=",
            ],
        ),
        (
            "ul-weak-form",
            &[
                "method.name=ul-weak-form",
                "material.model=hypoelastic",
                "method.kernel=",
                "method.h_over_dx=",
                "method.correction=",
            ],
        ),
        (
            "kbm",
            &[
                "method.name=kbm",
                "method.kernel=cubic-spline",
                "method.correction=",
                "body.0.geometry.volumes=tributary",
            ],
        ),
        (
            "kbm (eulerian)",
            &[
                "method.name=kbm",
                "method.kernel=cubic-spline",
                "method.correction=",
                "method.kernel_frame=eulerian",
                "body.0.geometry.volumes=tributary",
            ],
        ),
        (
            "efg",
            &[
                "method.name=efg",
                "method.kernel=cubic-spline",
                "method.correction=",
                "body.0.geometry.volumes=tributary",
            ],
        ),
    ];
    let mut cases = Vec::new();
    for (base, spacing) in [(plate, "spacing=0.025"), (block, "spacing=0.1")] {
        for (name, set) in variants {
            let mut set = set.to_vec();
            set.push(spacing);
            cases.push((name, load(base, &set)));
        }
    }
    for method in ["upwind-sph", "jst-sph"] {
        let name = format!("method.name={method}");
        cases.push((
            method,
            load("swinging-plate", &[name.as_str(), "spacing=0.025"]),
        ));
        cases.push((method, load("twisting-column", &[name.as_str()])));
    }
    cases.push((
        "dual-support-sph (static)",
        load("tension-bar-3d", &[] as &[&str]),
    ));
    cases
}

#[test]
fn the_device_memory_estimate_is_the_bytes_the_engines_allocate() {
    // `meshless check` and `--explain` give, and a run past the device's memory is refused
    // by, the estimate of `run::Estimate` (each engine's `memory`, sized from the case's
    // keys before anything is built). On a box lattice its counts are exact: within 1 %
    // of the bytes booked, the constrained particles' reaction slots (2d words each, a
    // surface's) left out. Every buffer of over 1 % of the total has its row.
    for (method, case) in every_gpu_method() {
        let estimate = meshless::run::Estimate::of(&case).unwrap();
        let (used, book) = match case.dimension {
            2 => allocated::<D2>(&case),
            _ => allocated::<D3>(&case),
        };
        let device = estimate
            .device
            .as_ref()
            .expect("a GPU method has its table");
        let what = format!("{method} {}D", case.dimension);
        assert!(
            (estimate.device_bytes / used - 1.0).abs() < 0.01,
            "{what}: estimate {:.0} B, allocated {used} B\n{book:#?}\n{device:#?}",
            estimate.device_bytes
        );
        for (label, &bytes) in &book {
            assert!(
                bytes as f64 <= 0.01 * used || device.rows().iter().any(|r| r.0 == label),
                "{what}: the buffer `{label}` ({bytes} B) has no row in the estimate"
            );
        }
    }
}

#[test]
fn the_device_memory_estimate_holds_on_shapes_whose_counts_are_estimated() {
    // On a disk, rings in contact, a cylinder with a mirror plane and a block with holes the
    // counts come from the shapes' areas (the particles a body's lattice keeps inside a
    // curve, the pairs its holes cut): within 10 % of the bytes booked.
    let cases = [
        load("rotating-disk", &["spacing=0.05"]),
        load("rings-impact-gray-monaghan", &[] as &[&str]),
        load("taylor-bar", &["spacing=8e-4"]),
        load("perforated-block-tension", &[] as &[&str]),
    ];
    for case in cases {
        let estimate = meshless::run::Estimate::of(&case).unwrap();
        let (used, _) = match case.dimension {
            2 => allocated::<D2>(&case),
            _ => allocated::<D3>(&case),
        };
        assert!(
            (estimate.device_bytes / used - 1.0).abs() < 0.1,
            "{}: estimate {:.0} B, allocated {used} B",
            case.name,
            estimate.device_bytes
        );
    }
}
