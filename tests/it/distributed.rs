//! Distributed runs from the command line: a build without MPI started by an MPI
//! launcher on several processes refuses every command that computes, before any work,
//! rather than run one copy of the case per process (a build with MPI refuses every one
//! but `run`); on one process it runs as usual.

use crate::common::{case_file, cpu_options, load};
use crate::frames::{Frame, read_frame};
use meshless::distributed::{LAUNCHER_SIZES, Threads};
use meshless::engine::ranks::PieceStore;
use meshless::run::RunError;
use meshless::run::checkpoint::Pieces;
use meshless::run::ranks::{run_on_threads, run_rank};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// The `meshless` binary with `args`, as an MPI launcher would start it: `variable` set to
/// `size` and the other launchers' variables removed.
fn launched(variable: &str, size: &str, args: &[&str]) -> std::process::Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_meshless"));
    for v in LAUNCHER_SIZES {
        command.env_remove(v);
    }
    command.env(variable, size).args(args).output().unwrap()
}

#[test]
fn a_launch_on_two_processes_refuses_what_the_build_cannot_run_on_them() {
    let dir = tempfile::tempdir().unwrap();
    let case = case_file("wave-rod");
    let case = case.to_str().unwrap();
    let out = dir.path().to_str().unwrap();
    let mut commands = vec![vec!["check", case], vec!["bench", case, "--backend", "cpu"]];
    if cfg!(feature = "study") {
        commands.push(vec!["study", "all", "--out", out]);
    }
    // A build with MPI runs `run` on the launcher's ranks; one without refuses it too.
    if !cfg!(feature = "mpi") {
        commands.push(vec!["run", case, "--backend", "cpu", "--out", out]);
    }
    for args in commands {
        let refused = launched("OMPI_COMM_WORLD_SIZE", "2", &args);
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert_eq!(refused.status.code(), Some(2), "{args:?}: {stderr}");
        let says_why = if cfg!(feature = "mpi") {
            stderr.contains("only `meshless run` runs on several")
        } else {
            stderr.contains("has no MPI") && stderr.contains("cargo build --release --features mpi")
        };
        assert!(
            stderr.contains("OMPI_COMM_WORLD_SIZE=2") && says_why,
            "{args:?}: {stderr}"
        );
    }
    assert!(
        std::fs::read_dir(dir.path()).unwrap().next().is_none(),
        "a refused command wrote into its output folder"
    );
    // Listing computes nothing and is not refused.
    let list = launched("PMI_SIZE", "4", &["list"]);
    assert!(
        list.status.success(),
        "{}",
        String::from_utf8_lossy(&list.stderr)
    );
}

#[test]
fn a_launch_on_one_process_runs() {
    let dir = tempfile::tempdir().unwrap();
    let case = case_file("wave-rod");
    let args = [
        "run",
        case.to_str().unwrap(),
        "--backend",
        "cpu",
        "--no-frames",
        "--set",
        "run.end_time=1e-5",
        "--out",
        dir.path().to_str().unwrap(),
    ];
    let run = launched("OMPI_COMM_WORLD_SIZE", "1", &args);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(dir.path().join("summary.json").is_file());
}

/// Runs `case` with `overrides` on one rank (the one-rank driver) and on `ranks` thread
/// ranks, each into its own folder; returns the folders.
fn one_and_many(
    case: &str,
    overrides: &[&str],
    ranks: usize,
) -> (tempfile::TempDir, tempfile::TempDir) {
    let scene = load(case, overrides);
    let (one, many) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    meshless::run::run(&scene, &cpu_options(one.path(), true)).unwrap();
    run_on_threads(&scene, &cpu_options(many.path(), true), ranks).unwrap();
    (one, many)
}

/// The last frame of a run in `dir`: whole (`.vtu`, one rank) or in pieces (`.pvtu`).
fn last_frame(dir: &Path) -> PathBuf {
    let mut frames: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vtu" || e == "pvtu"))
        .collect();
    frames.sort();
    frames.pop().expect("a frame")
}

/// The last frame's name (without its extension) and its values in particle order, and
/// the series, of a run in `dir`.
fn final_state(dir: &Path) -> (String, Frame, Vec<u8>) {
    let frame = last_frame(dir);
    let name = frame.file_stem().unwrap().to_string_lossy().into_owned();
    let series = std::fs::read(dir.join("series.csv")).unwrap();
    (name, read_frame(&frame), series)
}

/// A case on 2 and 3 ranks ends with the one-rank run's last frame and series, digit for
/// digit: each rank's particles and their ghosts follow the one-rank arithmetic (rows in
/// global order, ghosts' rates from their owners), and the sums over particles
/// (energies, powers, reactions) are exact sums of the ranks' shares, rounded once. The
/// ranks' pieces of the frame, put in particle order, hold the bits of the one-rank
/// frame's every field (the hourglass indicator and the pressure deviation, which each
/// rank evaluates from its neighbours' state, included) and its cells.
fn assert_ranks_match_one(case: &str, overrides: &[&str]) {
    for ranks in [2, 3] {
        let (one, many) = one_and_many(case, overrides, ranks);
        let (name_a, frame_a, series_a) = final_state(one.path());
        let (name_b, frame_b, series_b) = final_state(many.path());
        assert_eq!(name_a, name_b, "{case} on {ranks} ranks");
        assert!(
            frame_a == frame_b,
            "{case} on {ranks} ranks: the last frames differ"
        );
        assert_eq!(
            String::from_utf8(series_a).unwrap(),
            String::from_utf8(series_b).unwrap(),
            "{case} on {ranks} ranks: the series differ"
        );
    }
}

#[test]
fn tlsph_on_two_and_three_ranks_ends_in_the_one_rank_state() {
    // The rate model (ρ and S integrated), pulled supports, Monaghan viscosity, RK4.
    assert_ranks_match_one(
        "tensile-strip",
        &[
            "run.end_time=2e-4",
            "output.frame_interval=1e-4",
            "output.series_interval=2e-5",
        ],
    );
}

#[test]
fn tlsph_in_3d_with_the_variational_force_and_hourglass_control_matches_one_rank() {
    // A state model (neo-Hookean), the variational force (−∂Π/∂u, which reads the
    // neighbours' corrected gradients ∇0W̃_ji), hourglass control (the neighbours' F),
    // SSP-RK3 with a CFL step; 9³ particles.
    assert_ranks_match_one(
        "spinning-block-3d",
        &[
            "spacing=0.125",
            "method.force=variational",
            "method.hourglass=0.05",
            "run.end_time=2e-3",
            "output.frame_interval=1e-3",
            "output.series_interval=2e-4",
        ],
    );
}

#[test]
fn the_mixed_methods_on_two_and_three_ranks_match_one_rank() {
    // The free spinning plate, with the angular-momentum projection: its sums over all
    // particles inside every rate evaluation are exact and completed over the ranks.
    let short = [
        "run.end_time=2e-3",
        "output.frame_interval=1e-3",
        "output.series_interval=2e-4",
    ];
    // Upwind-SPH on {p, F, H, J} with the reconstruction (the slopes of the neighbours'
    // v and P in the force: two layers).
    assert_ranks_match_one("spinning-plate", &short);
    // JST-SPH (the neighbours' Laplacians of v in the dissipation).
    let jst = [&short[..], &["method.name=jst-sph"]].concat();
    assert_ranks_match_one("spinning-plate", &jst);
    // {p, F} with the bond-based F^c (from the neighbours' u) and the reconstruction.
    let bond = [
        &short[..],
        &[
            "method.variables=\"p-F\"",
            "method.deformation_gradient=\"bond-based\"",
        ],
    ]
    .concat();
    assert_ranks_match_one("spinning-plate", &bond);
}

#[test]
fn the_mixed_methods_with_mirror_planes_match_one_rank() {
    // The swinging plate (seed 003 §7.1.1), closed by four mirror planes: every rank
    // images its own particles and its ghosts, and the rows it never reads (the images
    // of its outer ghosts) are not set up.
    let short = [
        "run.end_time=2e-3",
        "output.frame_interval=1e-3",
        "output.series_interval=2e-4",
    ];
    assert_ranks_match_one("swinging-plate", &short);
    let jst = [&short[..], &["method.name=jst-sph"]].concat();
    assert_ranks_match_one("swinging-plate", &jst);
}

#[test]
fn dual_support_dynamics_matches_one_rank() {
    // The plate under a pressure (seed 004), in time: supports reaching each particle's
    // 10th nearest (the halo is built on the lists of these lengths, taken over all the
    // particles; a rank's own nearest-particle rule would lengthen its outer ghosts'
    // supports into its own particles' dual-supports), the variational force gathered over
    // supports and dual-supports, hourglass control (its power an exact sum).
    assert_ranks_match_one(
        "plate-compression-2d",
        &[
            "run.solve=dynamic",
            "method.dt=1e-3",
            "run.end_time=2e-2",
            "output.frame_interval=1e-2",
            "output.series_interval=2e-3",
        ],
    );
}

#[test]
fn artificial_compressibility_matches_one_rank() {
    // ν = 0.5: every stage's pseudo-time iteration reads the neighbours' iterates of v
    // and p, so the ranks exchange their ghosts' after every pseudo-stage and agree on
    // the residual, the velocity scale, L and max Σ|ℓ| over all their particles; every
    // rank counts the same iterations. The free spinning plate (projection on), then the
    // twisting column (3D, its clamped end held inside the iteration).
    let incompressible = [
        "material.poisson_ratio=0.5",
        "method.artificial_compressibility={}",
    ];
    let plate = [
        "run.end_time=2e-3",
        "output.frame_interval=1e-3",
        "output.series_interval=2e-4",
    ];
    assert_ranks_match_one("spinning-plate", &[&plate[..], &incompressible].concat());
    let column = [
        "run.end_time=1e-3",
        "output.frame_interval=5e-4",
        "output.series_interval=1e-4",
    ];
    assert_ranks_match_one("twisting-column", &[&column[..], &incompressible].concat());
}

#[test]
fn upwind_sph_in_3d_with_a_clamped_end_matches_one_rank() {
    // The twisting column: a fixed support on one rank's particles, the projection's
    // 3×3 inertia, {p, F, H, J} with D(J).
    assert_ranks_match_one(
        "twisting-column",
        &[
            "run.end_time=2e-3",
            "output.frame_interval=1e-3",
            "output.series_interval=2e-4",
        ],
    );
}

#[test]
fn a_run_interrupted_on_ranks_resumes_on_any_rank_count_in_the_one_rank_state() {
    // Each rank writes its own particles' rows (and global ids) into its piece of the
    // checkpoint; a resume on any rank count reads every piece and takes the rows of its
    // particles, so 2 ranks stopped and 3 resumed end in the one-rank state. The same
    // holds for 2 and 2, for the Galerkin weak form with its velocity smoothing, and
    // for one process's checkpoint (the one-rank words) resumed on 2 ranks.
    let weak_form = ["material.model=neo-hookean"];
    for (case, extra, stopped, resumed) in [
        ("tensile-strip", &[][..], 2, 3),
        ("tensile-strip", &[], 2, 2),
        ("tensile-strip-weak-form", &weak_form[..], 2, 3),
        ("tensile-strip", &[], 1, 2),
    ] {
        let overrides = [
            &[
                "run.end_time=2e-4",
                "output.frame_interval=1e-4",
                "run.checkpoint_interval=5e-5",
            ][..],
            extra,
        ]
        .concat();
        let scene = load(case, &overrides);
        let (one, many) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        meshless::run::run(&scene, &cpu_options(one.path(), true)).unwrap();
        let mut opts = cpu_options(many.path(), true);
        // Stopped after its first batch, with a checkpoint, as SIGINT does.
        opts.stop = Some(Arc::new(AtomicBool::new(true)));
        let end = match stopped {
            1 => meshless::run::run(&scene, &opts).map(drop),
            _ => run_on_threads(&scene, &opts, stopped).map(drop),
        };
        assert!(matches!(end, Err(RunError::Interrupted { .. })), "{end:?}");
        if stopped > 1 {
            let steps: Vec<_> = std::fs::read_dir(many.path().join("checkpoint.pieces"))
                .unwrap()
                .map(|e| e.unwrap().path())
                .collect();
            assert_eq!(steps.len(), 1, "{steps:?}");
            for rank in ["rank-00000.bin", "rank-00001.bin"] {
                assert!(steps[0].join(rank).is_file(), "{case}: no piece {rank}");
            }
        }
        // A frame past the checkpoint in the other form, as a run killed after writing
        // it leaves: the resumed run replaces it.
        let stale = many.path().join(format!("{case}_000001.vtu"));
        std::fs::write(&stale, "stale").unwrap();
        opts.stop = None;
        opts.resume = true;
        run_on_threads(&scene, &opts, resumed).unwrap();
        assert!(!stale.exists(), "{case}: the stale frame is left");
        let (name_a, frame_a, series_a) = final_state(one.path());
        let (name_b, frame_b, series_b) = final_state(many.path());
        assert_eq!(name_a, name_b);
        assert!(
            frame_a == frame_b,
            "{case}, {resumed} ranks: the last frames differ"
        );
        assert_eq!(
            String::from_utf8(series_a).unwrap(),
            String::from_utf8(series_b).unwrap()
        );
        // Every frame the index lists, those before the checkpoint as the stopped run
        // wrote them (whole on one rank), the others in pieces.
        let (listed_a, listed_b) = (listed(one.path()), listed(many.path()));
        assert_eq!(listed_a.len(), listed_b.len(), "{case}");
        for (k, (a, b)) in listed_a.iter().zip(&listed_b).enumerate() {
            let whole = stopped == 1 && k == 0;
            let form = if whole { "vtu" } else { "pvtu" };
            assert_eq!(b.extension().unwrap(), form, "{case}: frame {k}");
            assert!(read_frame(a) == read_frame(b), "{case}: frame {k} differs");
        }
    }
}

/// The frames the PVD index of a run in `dir` lists, in order.
fn listed(dir: &Path) -> Vec<PathBuf> {
    let index = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "pvd"))
        .expect("an index");
    let text = std::fs::read_to_string(index).unwrap();
    (text.split("file=\"").skip(1))
        .map(|t| dir.join(&t[..t.find('"').unwrap()]))
        .collect()
}

#[test]
fn a_checkpoint_in_pieces_is_refused_where_it_cannot_be_read() {
    // One process (not on ranks) cannot read pieces: refused, saying how to resume; a
    // piece that is missing is named. Exit 2 each, and the run does not start over.
    let overrides = ["run.end_time=2e-4", "run.checkpoint_interval=5e-5"];
    let scene = load("tensile-strip", &overrides);
    let dir = tempfile::tempdir().unwrap();
    let mut opts = cpu_options(dir.path(), true);
    opts.stop = Some(Arc::new(AtomicBool::new(true)));
    let stopped = run_on_threads(&scene, &opts, 2);
    assert!(
        matches!(stopped, Err(RunError::Interrupted { .. })),
        "{stopped:?}"
    );
    opts.stop = None;
    opts.resume = true;
    let alone = meshless::run::run(&scene, &opts).unwrap_err();
    assert!(
        alone.to_string().contains("written in pieces by 2 ranks"),
        "{alone}"
    );
    assert_eq!(alone.exit_code(), 2);
    let step = std::fs::read_dir(dir.path().join("checkpoint.pieces"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    // Rank 1's piece replaced by rank 0's words under rank 1's name (a valid file whose
    // particles another piece holds too): refused, not restored with rows left at zero.
    let pieces = |rank| Pieces::new(dir.path(), &scene, rank);
    let name = step.file_name().unwrap().to_string_lossy().into_owned();
    let at: u64 = name.parse().unwrap();
    let rank0 = pieces(0).read(at, 0, 2, u64::MAX).unwrap();
    pieces(1).write(at, 2, &rank0).unwrap();
    let twice = run_on_threads(&scene, &opts, 2).unwrap_err();
    assert!(twice.to_string().contains("holds twice"), "{twice}");
    std::fs::remove_file(step.join("rank-00001.bin")).unwrap();
    let missing = run_on_threads(&scene, &opts, 3).unwrap_err();
    assert!(missing.to_string().contains("rank-00001.bin"), "{missing}");
    assert_eq!(missing.exit_code(), 2);
    // A later checkpoint prunes the other steps' folders, and only those.
    let stale = dir.path().join("checkpoint.pieces/000000000000");
    let other = dir.path().join("checkpoint.pieces/notes.txt");
    std::fs::create_dir_all(&stale).unwrap();
    std::fs::write(&other, "kept").unwrap();
    pieces(0).write(0, 2, &[]).unwrap();
    meshless::run::checkpoint::prune_pieces(dir.path(), at);
    assert!(!stale.exists() && other.is_file() && step.is_dir());
}

#[test]
fn what_does_not_run_on_several_ranks_is_refused_by_every_rank() {
    let dir = tempfile::tempdir().unwrap();
    let opts = cpu_options(dir.path(), false);
    let refused = |case: &str, overrides: &[&str], ranks: usize, needle: &str| {
        let scene = load(case, overrides);
        match run_on_threads(&scene, &opts, ranks) {
            Err(e @ (RunError::Ranks(_) | RunError::Case(_))) => {
                assert!(e.to_string().contains(needle), "{case}: {e}");
                assert_eq!(e.exit_code(), 2);
            }
            other => panic!("{case} on {ranks} ranks: {other:?}"),
        }
    };
    refused("rings-impact", &[], 2, "contact ([contact])");
    refused("wave-rod", &["method.name=gray-monaghan-sph"], 2, "`tlsph`");
    // The rate model of a Galerkin method keeps ρ and S at its points.
    refused(
        "tensile-strip-fem",
        &[],
        2,
        "keeps its state at the quadrature points",
    );
    refused(
        "rod-rectangular-kbm",
        &["method.kernel_frame=eulerian"],
        2,
        "Eulerian kernel",
    );
    refused(
        "tensile-strip",
        &["spacing=0.5"],
        10,
        "10 ranks for 9 particles: run on at most 9 ranks",
    );
    // Each of the ranks on a machine builds the whole run's set-up (the strip at Δx = 1
    // mm: about 2.9 GB by the estimate): 64 of them need about 190 GB at once, refused
    // before any is built.
    refused(
        "tensile-strip",
        &["spacing=1e-3"],
        64,
        "for 64 ranks on this machine",
    );
}

#[test]
fn a_rank_that_reads_another_case_stops_every_rank() {
    // Rank 1 reads the case with another end time (as a case file that differs on one
    // node would): every rank refuses with exit 2, and none waits for another.
    let dir = tempfile::tempdir().unwrap();
    let opts = cpu_options(dir.path(), false);
    let mine = load("tensile-strip", &["run.end_time=2e-5"]);
    let other = load("tensile-strip", &["run.end_time=3e-5"]);
    let results: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = (Threads::ranks(2).into_iter().enumerate())
            .map(|(r, comm)| {
                let (case, opts) = (if r == 1 { &other } else { &mine }, &opts);
                s.spawn(move || run_rank(case, opts, Arc::new(comm), 2))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for (r, result) in results.iter().enumerate() {
        match result {
            Err(e @ RunError::Ranks(_)) => {
                let shown = e.to_string();
                assert!(shown.contains("read another case"), "rank {r}: {shown}");
                assert_eq!(e.exit_code(), 2);
            }
            other => panic!("rank {r}: {other:?}"),
        }
    }
}

#[test]
fn a_set_up_that_fails_on_one_rank_is_reported_with_its_own_error() {
    // A second body of two particles on a line, far above the strip: the bisection cuts
    // across y, so only rank 1 holds it, and its Randles–Libersky matrix is singular. Rank
    // 0 stops with an error that names rank 1; the run reports rank 1's own.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("stray.toml");
    let strip = std::fs::read_to_string(case_file("tensile-strip")).unwrap();
    let stray = "\n[[body]]\nname = \"stray\"\ngeometry = { shape = \"box\", \
                 min = [0.4, 5.0], max = [0.45, 5.01], volumes = \"uniform\" }\n";
    std::fs::write(&file, strip + stray).unwrap();
    let case = meshless::scene::Scene::load(&file, &[]).unwrap();
    let e = run_on_threads(&case, &cpu_options(&dir.path().join("out"), false), 2).unwrap_err();
    let shown = e.to_string();
    assert!(
        shown.contains("correction matrix of particle") && shown.contains("is singular"),
        "{shown}"
    );
    assert_eq!(e.exit_code(), 2);
}

/// The error of `case` with `overrides` on `ranks` thread ranks, within two minutes: a
/// rank waiting for another in a collective would hang the run, and the test fails
/// instead of waiting with it.
fn error_on_ranks(case: &str, overrides: &[&str], ranks: usize) -> RunError {
    let scene = load(case, overrides);
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let dir = tempfile::tempdir().unwrap();
        let result = run_on_threads(&scene, &cpu_options(dir.path(), false), ranks);
        send.send(result.map(drop)).unwrap();
    });
    match receive.recv_timeout(std::time::Duration::from_secs(120)) {
        Ok(result) => result.expect_err("a blow-up"),
        Err(_) => panic!("{case} on {ranks} ranks: no result after 120 s (a rank waits)"),
    }
}

#[test]
fn a_blow_up_inside_the_mixed_family_s_collectives_is_reported_as_one_rank_reports_it() {
    // A step 7.8 times the CFL step: J < 0 at particle 0 in the third step, found by the
    // kinematics before the projection's sums; and, with artificial compressibility, the
    // energy bound in the fifth, after corrector iterations that do not converge. One
    // rank meets the blow-up first; the others, in the projection's or the corrector's
    // collectives, must not wait for it.
    let blow_up = ["method.cfl=", "method.dt=2e-3", "run.end_time=2e-2"];
    let incompressible = [
        &blow_up[..],
        &[
            "method.artificial_compressibility={}",
            "material.poisson_ratio=0.5",
        ],
    ]
    .concat();
    for overrides in [&blow_up[..], &incompressible] {
        let scene = load("spinning-plate", overrides);
        let dir = tempfile::tempdir().unwrap();
        let one = meshless::run::run(&scene, &cpu_options(dir.path(), false)).unwrap_err();
        assert!(matches!(one, RunError::BlowUp { .. }), "{one}");
        for ranks in [2, 3] {
            let many = error_on_ranks("spinning-plate", overrides, ranks);
            let (a, b) = (one.to_string(), many.to_string());
            let cause = |s: &str| s.split("; outputs").next().unwrap().to_string();
            assert_eq!(cause(&a), cause(&b), "{ranks} ranks");
            assert_eq!(many.exit_code(), one.exit_code());
        }
    }
}

#[test]
fn rank_zero_failing_to_write_ends_the_other_ranks() {
    // The output folder lies below a regular file: rank 0's driver fails on its first
    // write, names the folder, and its engine's end releases the ranks serving it.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("not-a-folder");
    std::fs::write(&file, "x").unwrap();
    let out = file.join("run");
    let case = load("tensile-strip", &["run.end_time=2e-5"]);
    let e = run_on_threads(&case, &cpu_options(&out, true), 3).unwrap_err();
    assert!(matches!(e, RunError::Output { .. }), "{e}");
    assert!(e.to_string().contains(&out.display().to_string()), "{e}");
}

#[test]
fn a_rank_failing_to_write_its_piece_of_a_frame_ends_every_rank() {
    // Rank 1's piece of the second frame cannot be written (a folder holds its name):
    // the run fails on every rank with the error naming rank 1 and the piece, nothing
    // waits, and the index lists only the frames written whole.
    let dir = tempfile::tempdir().unwrap();
    let blocked = dir.path().join("tensile-strip_000001/rank-00001.vtu");
    std::fs::create_dir_all(blocked.join("x")).unwrap();
    let case = load(
        "tensile-strip",
        &["run.end_time=2e-5", "output.frame_interval=1e-5"],
    );
    let e = run_on_threads(&case, &cpu_options(dir.path(), true), 3).unwrap_err();
    let message = e.to_string();
    assert!(matches!(e, RunError::Output { .. }), "{message}");
    assert!(
        message.contains("rank 1") && message.contains(&blocked.display().to_string()),
        "{message}"
    );
    let index = std::fs::read_to_string(dir.path().join("tensile-strip.pvd")).unwrap();
    assert!(index.contains("tensile-strip_000000.pvtu"), "{index}");
    assert!(!index.contains("tensile-strip_000001"), "{index}");
}

#[test]
fn a_new_run_removes_the_frames_an_earlier_run_wrote_in_pieces() {
    // A run on 2 ranks leaves `.pvtu` indices and their folders of pieces; the next run
    // of the case in the folder, on one rank, removes them with the index that lists
    // them, and leaves another file alone.
    let dir = tempfile::tempdir().unwrap();
    let case = load(
        "tensile-strip",
        &["run.end_time=2e-5", "output.frame_interval=1e-5"],
    );
    run_on_threads(&case, &cpu_options(dir.path(), true), 2).unwrap();
    let names = || -> Vec<String> {
        let mut n: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        n.sort();
        n
    };
    assert!(
        names().contains(&"tensile-strip_000002.pvtu".to_string()),
        "{:?}",
        names()
    );
    assert!(
        dir.path()
            .join("tensile-strip_000002/rank-00001.vtu")
            .is_file()
    );
    std::fs::write(dir.path().join("notes.txt"), "mine").unwrap();
    meshless::run::run(&case, &cpu_options(dir.path(), true)).unwrap();
    let left: Vec<String> = names()
        .into_iter()
        .filter(|n| n.contains("pvtu") || !n.contains('.'))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    assert!(names().contains(&"notes.txt".to_string()));
}

#[test]
fn the_potential_and_corotated_tlsph_on_two_and_three_ranks_match_one_rank() {
    let short = [
        "run.end_time=2e-4",
        "output.frame_interval=1e-4",
        "output.series_interval=2e-5",
    ];
    // The consistent force (V_i V_j), Saint Venant–Kirchhoff.
    assert_ranks_match_one("tensile-strip-potential", &short);
    // The reference code's unit weights, its CFL wave speed scaled by 1/√V of the
    // smallest volume of all the particles: the largest of the ranks' speeds. On a 3 × 1
    // strip with tributary volumes the smallest are the corners' (V/4), which the middle
    // rank of three does not hold: taking its speed would lengthen the steps.
    let reference_code = [
        "method.force=reference-code",
        "body.0.geometry={ shape = \"box\", min = [0.0, 0.0], max = [3.0, 1.0], \
         volumes = \"tributary\" }",
        "method.dt=",
        "method.cfl=0.3",
        "run.end_time=2e-5",
        "output.frame_interval=1e-5",
        "output.series_interval=2e-6",
    ];
    assert_ranks_match_one("tensile-strip-potential", &reference_code);
    // The reference code's force (½(R_i + R_j)) and the variational one.
    assert_ranks_match_one("tensile-strip-corotated", &short);
    let variational = [&short[..], &["method.force=variational"]].concat();
    assert_ranks_match_one("tensile-strip-corotated", &variational);
}

#[test]
fn the_tl_galerkin_methods_on_two_and_three_ranks_match_one_rank() {
    // The nodes are split along the points they share: a rank holds the points of its
    // own nodes with all their nodes, computes the stresses there and gathers its own
    // nodes' forces in the one-rank order. A state model (the rate model keeps ρ and S
    // at the points, which is refused).
    let strip = [
        "material.model=neo-hookean",
        "run.end_time=2e-5",
        "output.frame_interval=1e-5",
        "output.series_interval=2e-6",
    ];
    // Bilinear cells with 2 × 2 Gauss points, row-sum masses, pulled supports.
    assert_ranks_match_one("tensile-strip-fem", &strip);
    // Reproducing-kernel functions at the Gauss points, and the velocity smoothing after
    // each step: the ghosts' velocities are their owners' again after it, and the energy
    // it takes out is an exact sum over the ranks.
    assert_ranks_match_one("tensile-strip-weak-form", &strip);
    // The driven rod (1 331 particles, a timed velocity): EFG at the Gauss points of the
    // cells and at the particles (nodal integration, where the points of a rank's outer
    // ghosts lack some of their nodes), and KBM with its test functions.
    let rod = [
        "spacing=5e-4",
        "run.end_time=2e-7",
        "output.frame_interval=1e-7",
        "output.series_interval=4e-8",
    ];
    assert_ranks_match_one("rod-rectangular-efg", &rod);
    let nodal = [&rod[..], &["method.integration=nodal"]].concat();
    assert_ranks_match_one("rod-rectangular-efg", &nodal);
    assert_ranks_match_one("rod-rectangular-kbm", &rod);
}

#[test]
fn a_traction_spread_to_nodes_of_several_ranks_matches_one_rank() {
    // The plate's top edge carries a pressure: the FEM spreads each surface point's
    // force over its patch, and the meshfree methods over the nodes their functions
    // reach there, nodes that may be other ranks'. In time, from rest.
    let dynamic = [
        "run.solve=dynamic",
        "method.dt=1e-3",
        "run.end_time=2e-2",
        "output.frame_interval=1e-2",
        "output.series_interval=2e-3",
    ];
    assert_ranks_match_one("plate-compression-fem", &dynamic);
    let efg = [
        &dynamic[..],
        &[
            "method.name=efg",
            "method.h_over_dx=1.3",
            "method.kernel=cubic-spline",
        ],
    ]
    .concat();
    assert_ranks_match_one("plate-compression-fem", &efg);
    // In 3D (trilinear cells, 9³ nodes): the pressure on half the cube's top.
    let cube = [
        "run.solve=dynamic",
        "spacing=0.125",
        "method.dt=1e-3",
        "run.end_time=1e-2",
        "output.frame_interval=5e-3",
        "output.series_interval=1e-3",
    ];
    assert_ranks_match_one("hyperelastic-cube-fem", &cube);
}

#[test]
fn a_galerkin_blow_up_is_reported_as_one_rank_reports_it() {
    // The rod's far end driven into it at 10 km/s, twice its wave speed:
    // det F < 0 at the points of the last rank's nodes, named as one rank names them:
    // the inadmissible point whose strongest node comes first, its global index.
    let overrides = [
        "spacing=5e-4",
        "boundary.0.region={ x_min = 0.06 }",
        "boundary.0.condition={ type = \"velocity\", vx = -1.0e4 }",
        "output.observers=[\"energy\"]",
        "run.end_time=2e-6",
    ];
    let scene = load("rod-rectangular-efg", &overrides);
    let dir = tempfile::tempdir().unwrap();
    let one = meshless::run::run(&scene, &cpu_options(dir.path(), false)).unwrap_err();
    assert!(matches!(one, RunError::BlowUp { .. }), "{one}");
    assert!(
        one.to_string().contains("det F at quadrature point"),
        "{one}"
    );
    for ranks in [2, 3] {
        let many = error_on_ranks("rod-rectangular-efg", &overrides, ranks);
        let cause = |s: &str| s.split("; outputs").next().unwrap().to_string();
        assert_eq!(
            cause(&one.to_string()),
            cause(&many.to_string()),
            "{ranks} ranks"
        );
    }
}
