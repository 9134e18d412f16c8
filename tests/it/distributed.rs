//! Distributed runs from the command line: a build without MPI started by an MPI
//! launcher on several processes refuses every command that computes, before any work,
//! rather than run one copy of the case per process; on one process it runs as usual.

use crate::common::case_file;
use meshless::distributed::LAUNCHER_SIZES;
use std::process::Command;

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
