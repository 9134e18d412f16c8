//! Distributed runs under `mpirun` (feature `mpi`; MPICH's Hydra launcher, 2 and 3 ranks
//! oversubscribed on the cores there are): the ranks end in the one-process state (TLSPH,
//! JST-SPH with its projection's sums inside every rate evaluation, and artificial
//! compressibility's exchanges inside every stage), a blow-up is reported once with its
//! particle, a rank killed mid-run leaves a checkpoint another rank count resumes, and
//! nothing waits forever (`MPIEXEC_TIMEOUT` ends a hung job).

#[path = "support/frames.rs"]
mod frames;

use frames::read_frame;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The shipped case file `name`.
fn case(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("cases/{name}.toml"));
    path.to_str().unwrap().to_string()
}

/// `meshless run` of `args` on `ranks` processes under mpirun (one process, no launcher,
/// for 0), ended by the launcher after 120 s at most.
fn command(ranks: usize, args: &[String]) -> Command {
    let exe = env!("CARGO_BIN_EXE_meshless");
    let mut c = if ranks == 0 {
        Command::new(exe)
    } else {
        let mut c = Command::new("mpirun");
        c.args(["-n", &ranks.to_string(), exe]);
        c
    };
    c.env("MPIEXEC_TIMEOUT", "120").arg("run").args(args);
    c
}

fn run(ranks: usize, args: &[String]) -> Output {
    command(ranks, args)
        .output()
        .expect("mpirun (MPICH) is installed")
}

/// The tensile strip (TLSPH's rate model, pulled supports, viscosity, RK4) with `set`,
/// into `out`, with frames every 1e-4 s and checkpoints every 5e-5 s.
fn strip(set: &[&str], out: &str) -> Vec<String> {
    let mut args = vec![case("tensile-strip")];
    args.extend(["--backend", "cpu", "-q", "--out", out].map(String::from));
    for s in ["output.frame_interval=1e-4", "run.checkpoint_interval=5e-5"]
        .iter()
        .chain(set)
    {
        args.extend(["--set".to_string(), s.to_string()]);
    }
    args
}

/// The last frame in `dir`: whole (`.vtu`) or in pieces (`.pvtu`).
fn last_frame(dir: &Path) -> PathBuf {
    let mut frames: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vtu" || e == "pvtu"))
        .collect();
    frames.sort();
    frames.pop().expect("a frame")
}

/// Whether two runs end with the same series, byte for byte, and the same last frame:
/// its values in particle order, bit for bit, whether written whole or in pieces.
fn same_final_state(a: &Path, b: &Path) -> bool {
    let series = |d: &Path| std::fs::read(d.join("series.csv")).unwrap();
    let same_series = series(a) == series(b);
    let (a, b) = (last_frame(a), last_frame(b));
    same_series && a.file_stem() == b.file_stem() && read_frame(&a) == read_frame(&b)
}

fn ok(out: &Output) -> bool {
    if !out.status.success() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    }
    out.status.success()
}

#[test]
fn two_and_three_ranks_end_in_the_one_process_state() {
    let dirs: Vec<_> = (0..3).map(|_| tempfile::tempdir().unwrap()).collect();
    let path = |k: usize| dirs[k].path().to_str().unwrap().to_string();
    for (k, ranks) in [0, 2, 3].into_iter().enumerate() {
        let out = run(ranks, &strip(&["run.end_time=3e-4"], &path(k)));
        assert!(ok(&out), "{ranks} ranks");
        if ranks > 0 {
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert!(
                stdout.contains(&format!("on cpu on {ranks} ranks")) && stdout.lines().count() == 1,
                "rank 0 alone reports the run: {stdout}"
            );
        }
    }
    assert!(same_final_state(dirs[0].path(), dirs[1].path()), "2 ranks");
    assert!(same_final_state(dirs[0].path(), dirs[2].path()), "3 ranks");
}

/// `case` with the overrides `set` on 2 and 3 processes ends in the one-process run's
/// last frame and series, byte for byte.
fn assert_processes_match_one(case_name: &str, set: &[&str]) {
    let dirs: Vec<_> = (0..3).map(|_| tempfile::tempdir().unwrap()).collect();
    for (dir, ranks) in dirs.iter().zip([0, 2, 3]) {
        let mut args = vec![case(case_name)];
        args.extend(["--backend", "cpu", "-q", "--out"].map(String::from));
        args.push(dir.path().to_str().unwrap().to_string());
        for s in set {
            args.extend(["--set".to_string(), s.to_string()]);
        }
        assert!(ok(&run(ranks, &args)), "{case_name}: {ranks} ranks");
    }
    assert!(
        same_final_state(dirs[0].path(), dirs[1].path()),
        "{case_name}: 2 ranks"
    );
    assert!(
        same_final_state(dirs[0].path(), dirs[2].path()),
        "{case_name}: 3 ranks"
    );
}

#[test]
fn jst_sph_with_its_projection_on_two_and_three_ranks_ends_in_the_one_process_state() {
    // The spinning plate: the angular-momentum projection adds the ranks' exact sums in
    // every rate evaluation, through MPI.
    assert_processes_match_one(
        "spinning-plate",
        &[
            "method.name=jst-sph",
            "run.end_time=2e-3",
            "output.frame_interval=1e-3",
            "output.series_interval=2e-4",
        ],
    );
}

#[test]
fn artificial_compressibility_on_two_and_three_ranks_ends_in_the_one_process_state() {
    // ν = 0.5: the pseudo-time iteration of every stage exchanges the ghosts' v and p
    // after each pseudo-stage and takes its residual over the ranks, through MPI.
    assert_processes_match_one(
        "spinning-plate",
        &[
            "material.poisson_ratio=0.5",
            "method.artificial_compressibility={}",
            "run.end_time=2e-3",
            "output.frame_interval=1e-3",
            "output.series_interval=2e-4",
        ],
    );
}

#[test]
fn a_blow_up_on_three_ranks_is_reported_as_one_process_reports_it() {
    let dirs: Vec<_> = (0..2).map(|_| tempfile::tempdir().unwrap()).collect();
    let outputs: Vec<Output> = [0, 3]
        .into_iter()
        .zip(&dirs)
        .map(|(ranks, dir)| {
            // A step 18 times the CFL step: det F < 0 in the first step.
            let set = ["run.end_time=2e-2", "method.dt=2e-4"];
            run(ranks, &strip(&set, dir.path().to_str().unwrap()))
        })
        .collect();
    let error = |o: &Output| {
        let text = String::from_utf8_lossy(&o.stderr).to_string();
        text.lines()
            .find(|l| l.starts_with("error: blow-up"))
            .map(|l| l.split("; outputs").next().unwrap().to_string())
            .unwrap_or_else(|| panic!("no blow-up reported: {text}"))
    };
    assert_eq!(outputs[0].status.code(), Some(1));
    assert_eq!(
        outputs[1].status.code(),
        Some(1),
        "mpirun passes rank 0's code"
    );
    assert_eq!(error(&outputs[0]), error(&outputs[1]));
    let reports = String::from_utf8_lossy(&outputs[1].stderr)
        .matches("error: blow-up")
        .count();
    assert_eq!(reports, 1, "rank 0 alone reports the blow-up");
}

#[test]
fn a_rank_killed_mid_run_leaves_a_checkpoint_that_two_ranks_resume() {
    let (one, many) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let end = ["run.end_time=1e-2"];
    assert!(ok(&run(0, &strip(&end, one.path().to_str().unwrap()))));
    let dir = many.path().to_str().unwrap();
    let mut job = command(3, &strip(&end, dir)).spawn().unwrap();
    // Once a checkpoint is there, kill rank 1's process (the other ranks and the
    // launcher then end).
    let started = Instant::now();
    let checkpoint = many.path().join("checkpoint.bin");
    while !checkpoint.exists() {
        assert!(started.elapsed() < Duration::from_secs(60), "no checkpoint");
        std::thread::sleep(Duration::from_millis(5));
    }
    let victim = rank_process(dir).expect("a rank's process");
    Command::new("kill")
        .args(["-9", &victim.to_string()])
        .status()
        .unwrap();
    let status = job.wait().unwrap();
    assert!(!status.success(), "the job fails with a killed rank");
    // The same case and overrides, from the folder's checkpoint.
    let resume: Vec<String> = (strip(&end, dir).into_iter())
        .map(|a| if a == "--out" { "--resume".into() } else { a })
        .collect();
    let resumed = run(2, &resume);
    assert!(ok(&resumed));
    assert!(same_final_state(one.path(), many.path()));
}

/// A process of the meshless binary whose command line names `dir`: one rank of the job.
fn rank_process(dir: &str) -> Option<u32> {
    let exe = env!("CARGO_BIN_EXE_meshless");
    std::fs::read_dir("/proc").ok()?.find_map(|e| {
        let pid: u32 = e.ok()?.file_name().to_str()?.parse().ok()?;
        let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).ok()?;
        let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).collect();
        let is_rank = args.first() == Some(&exe.as_bytes()) && args.contains(&dir.as_bytes());
        is_rank.then_some(pid)
    })
}
