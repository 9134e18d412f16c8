//! Distributed runs from the command line: a build without MPI started by an MPI
//! launcher on several processes refuses every command that computes, before any work,
//! rather than run one copy of the case per process; on one process it runs as usual.

use crate::common::{case_file, cpu_options, load};
use meshless::distributed::LAUNCHER_SIZES;
use meshless::run::RunError;
use meshless::run::ranks::run_on_threads;
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
fn a_launch_on_two_processes_is_refused_without_mpi() {
    let dir = tempfile::tempdir().unwrap();
    let case = case_file("wave-rod");
    let case = case.to_str().unwrap();
    let out = dir.path().to_str().unwrap();
    let mut commands = vec![
        vec!["run", case, "--backend", "cpu", "--out", out],
        vec!["check", case],
        vec!["bench", case, "--backend", "cpu"],
    ];
    if cfg!(feature = "study") {
        commands.push(vec!["study", "all", "--out", out]);
    }
    for args in commands {
        let refused = launched("OMPI_COMM_WORLD_SIZE", "2", &args);
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert_eq!(refused.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("OMPI_COMM_WORLD_SIZE=2")
                && stderr.contains("has no MPI")
                && stderr.contains("cargo build --release --features mpi"),
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

/// The last frame of a run in `dir`.
fn last_frame(dir: &Path) -> PathBuf {
    let mut frames: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vtu"))
        .collect();
    frames.sort();
    frames.pop().expect("a frame")
}

/// The rows of a series.csv: header, then the values.
fn series(dir: &Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(dir.join("series.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// A case on 2 and 3 ranks ends with the one-rank run's frames, digit for digit: each
/// rank's particles and their ghosts follow the one-rank arithmetic (rows in global
/// order, ghosts' rates from their owners). Its series agree within 1e-12 of each
/// column's scale (its largest value; 1 for the energy residue, a fraction of the
/// energies' scale): their sums over particles (energies, powers, reactions) are each
/// rank's partial sum, added over the ranks in rank order, so they differ from the
/// one-rank sum by rounding, a few ulps times the number of ranks.
fn assert_ranks_match_one(case: &str, overrides: &[&str]) {
    for ranks in [2, 3] {
        let (one, many) = one_and_many(case, overrides, ranks);
        let (a, b) = (last_frame(one.path()), last_frame(many.path()));
        assert_eq!(a.file_name(), b.file_name(), "{case} on {ranks} ranks");
        let (a, b) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        assert!(a == b, "{case} on {ranks} ranks: the last frames differ");
        let (head_a, rows_a) = series(one.path());
        let (head_b, rows_b) = series(many.path());
        assert_eq!(head_a, head_b);
        assert_eq!(rows_a.len(), rows_b.len());
        let columns: Vec<&str> = head_a.split(',').collect();
        for (k, name) in columns.iter().enumerate() {
            // The residue R/S is a fraction of the energy scale S already: its terms'
            // rounding is relative to S, not to the small R.
            let scale = match *name {
                "energy_residue" => 1.0,
                _ => rows_a.iter().map(|r| r[k].abs()).fold(0.0, f64::max),
            };
            for (ra, rb) in rows_a.iter().zip(&rows_b) {
                let gap = (ra[k] - rb[k]).abs();
                assert!(
                    gap <= 1e-12 * scale,
                    "{case} on {ranks} ranks, {name}: {} and {} (scale {scale:e})",
                    ra[k],
                    rb[k]
                );
            }
        }
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
fn a_run_interrupted_on_two_ranks_resumes_on_three_in_the_one_rank_state() {
    // The checkpoint is the one-rank engine's words, gathered by global id, so any rank
    // count resumes it.
    let overrides = [
        "run.end_time=2e-4",
        "output.frame_interval=1e-4",
        "run.checkpoint_interval=5e-5",
    ];
    let scene = load("tensile-strip", &overrides);
    let (one, many) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    meshless::run::run(&scene, &cpu_options(one.path(), true)).unwrap();
    let mut opts = cpu_options(many.path(), true);
    // Stopped after its first batch, with a checkpoint, as SIGINT does.
    opts.stop = Some(Arc::new(AtomicBool::new(true)));
    let stopped = run_on_threads(&scene, &opts, 2);
    assert!(
        matches!(stopped, Err(RunError::Interrupted { .. })),
        "{stopped:?}"
    );
    opts.stop = None;
    opts.resume = true;
    run_on_threads(&scene, &opts, 3).unwrap();
    let (a, b) = (last_frame(one.path()), last_frame(many.path()));
    assert_eq!(a.file_name(), b.file_name());
    assert!(std::fs::read(a).unwrap() == std::fs::read(b).unwrap());
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
    refused(
        "tensile-strip-potential",
        &["method.force=reference-code"],
        2,
        "on several ranks use the default force",
    );
    refused(
        "tensile-strip",
        &["spacing=0.5"],
        10,
        "10 ranks for 9 particles: run on at most 9 ranks",
    );
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
    // The reference code's force (½(R_i + R_j)) and the variational one.
    assert_ranks_match_one("tensile-strip-corotated", &short);
    let variational = [&short[..], &["method.force=variational"]].concat();
    assert_ranks_match_one("tensile-strip-corotated", &variational);
}
