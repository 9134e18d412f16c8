//! Whole runs on the CPU: conservation on the rotating disk, wave speed in the rod with
//! refinement, blow-up detection and the command line's exit codes.

use crate::common::{case_file, cpu_options, load, shipped};
use meshless::bench::{BenchRow, measure, resize};
use meshless::core::integrate::Integrator;
use meshless::core::tensor::D2;
use meshless::methods::Method;
use meshless::methods::tlsph::Tlsph;
use meshless::reference::Reference;
use meshless::run::{Backend, RunError, build_method, run};
use std::path::Path;
use std::process::Command;

/// Column `name` of a series CSV.
fn column(csv: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let k = lines
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == name)
        .unwrap();
    lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn rotating_disk_keeps_its_angular_momentum() {
    // One full revolution (2π/50 = 0.126 s) of the seed-000 disk with RK4 at dt = 5e-6
    // (c0·dt/Δx = 0.19). Measured: max |H/H(0) − 1| = 2.4e-5 at dt = 5e-6 (5.7e-6 at the
    // paper's 1e-6 over 0.15 s). RL-corrected TLSPH does not conserve H exactly (seed 000
    // checklist 15), so the bound is the measured drift with a factor 4 margin: 1e-4.
    let dir = tempfile::tempdir().unwrap();
    let case = load("rotating-disk", &["method.dt=5e-6", "run.end_time=0.126"]);
    run(&case, &cpu_options(dir.path(), false)).unwrap();
    let h = column(&dir.path().join("series.csv"), "angular_momentum_z");
    let drift = h.iter().map(|x| (x / h[0] - 1.0).abs()).fold(0.0, f64::max);
    assert!(drift < 1e-4, "max |H/H(0) − 1| = {drift:e}");
    assert!(h.len() > 1000, "the series samples every 1e-4 s");
}

/// Speed of the right-moving half pulse: displacement of its velocity centroid over t.
fn measured_wave_speed(spacing: f64) -> (f64, usize) {
    let case = load("wave-rod", &[format!("spacing={spacing}")]);
    let mut m: Tlsph<D2> = build_method(&case).unwrap();
    let mut y = m.initial_state();
    let mut integ = Integrator::new(case.method.integrator, &y);
    let (t_end, mut t) = (case.run.end_time, 0.0);
    while t < t_end * (1.0 - 1e-12) {
        let dt = (case.method.cfl.unwrap() * spacing / m.max_signal_speed(&y)).min(t_end - t);
        integ.step(&mut m, t, dt, &mut y).unwrap();
        t += dt;
    }
    let x0 = m.reference();
    let (mut sx, mut s) = (0.0, 0.0);
    for (x, v) in x0.iter().zip(&y.v) {
        if x.x > 1.0 {
            sx += x.x * v.x;
            s += v.x;
        }
    }
    ((sx / s - 1.0) / t, x0.len())
}

#[test]
fn wave_speed_matches_the_confined_modulus_and_converges() {
    // c = sqrt(E(1−ν)/(ρ(1+ν)(1−2ν))) for E = 1e7, ν = 0.4, ρ = 1.
    let exact = (1e7 * 0.6 / (1.4 * 0.2f64)).sqrt();
    let errors: Vec<f64> = [0.02, 0.01, 0.005]
        .iter()
        .map(|&dx| {
            let (c, n) = measured_wave_speed(dx);
            let e = (c / exact - 1.0).abs();
            eprintln!("dx = {dx}: {n} particles, c = {c:.2} m/s, relative error {e:.3e}");
            e
        })
        .collect();
    // Dispersion error of the discrete operator falls with Δx/width; measured errors are
    // listed above. Require a monotone fall and the finest within 0.5 %.
    assert!(
        errors[1] < errors[0] && errors[2] < errors[1],
        "errors {errors:?}"
    );
    assert!(errors[2] < 5e-3, "finest relative error {:e}", errors[2]);
}

#[test]
fn blow_up_stops_the_run_with_a_diagnostic_and_keeps_earlier_frames() {
    // c·Δt/Δx = 9 is far past the RK4 stability limit: the run must stop, name the step, time,
    // particle and quantity, write a failed summary and keep a valid PVD of earlier frames.
    let dir = tempfile::tempdir().unwrap();
    let case = load(
        "wave-rod",
        &[
            "method.cfl=",
            "method.dt=2e-5",
            "output.frame_interval=2e-5",
        ],
    );
    let err = run(&case, &cpu_options(dir.path(), true)).unwrap_err();
    let RunError::BlowUp {
        step, time, cause, ..
    } = &err
    else {
        panic!("expected a blow-up, got {err}")
    };
    assert!(*step > 1 && *time > 0.0 && cause.particle < 2211);
    let text = err.to_string();
    assert!(
        text.contains("blow-up at step") && text.contains("particle"),
        "{text}"
    );
    let summary = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    assert!(summary.contains("\"failed\""), "{summary}");
    let pvd = std::fs::read_to_string(dir.path().join("wave-rod.pvd")).unwrap();
    assert!(pvd.trim_end().ends_with("</VTKFile>"));
    let frames = pvd.matches("<DataSet").count();
    assert!(frames >= 2, "frames before the blow-up are indexed");
    for line in pvd.lines().filter(|l| l.contains("<DataSet")) {
        let file = line
            .split("file=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        assert!(
            dir.path().join(file).is_file(),
            "indexed frame {file} exists"
        );
    }
}

#[test]
fn command_line_exit_codes() {
    let exe = env!("CARGO_BIN_EXE_meshless");
    let dir = tempfile::tempdir().unwrap();
    let bad = Command::new(exe)
        .args([
            "run",
            case_file("wave-rod").to_str().unwrap(),
            "--set",
            "material.poisson_ratio=0.5",
        ])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(
        stderr.contains("material.poisson_ratio") && stderr.contains("wave-rod.toml"),
        "{stderr}"
    );

    let blow = Command::new(exe)
        .args([
            "run",
            case_file("wave-rod").to_str().unwrap(),
            "--set",
            "method.cfl=",
            "--set",
            "method.dt=2e-5",
            "--no-frames",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(blow.status.code(), Some(1));

    let ok = Command::new(exe)
        .args([
            "run",
            case_file("wave-rod").to_str().unwrap(),
            "--backend",
            "cpu",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert!(dir.path().join("wave-rod.pvd").is_file() && dir.path().join("summary.json").is_file());

    // A GPU backend that cannot start is input the run cannot start from: exit 2, for
    // `run` and `bench` alike.
    for args in [
        &["run", "wave-rod"][..],
        &["bench", "wave-rod", "--particles", "1e3", "--steps", "2"],
    ] {
        let no_gpu = Command::new(exe)
            .args(args)
            .args(["--backend", "gpu"])
            .env("MESHLESS_ADAPTER", "no-such-adapter")
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&no_gpu.stderr);
        assert_eq!(no_gpu.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("--backend cpu"), "{args:?}: {stderr}");
    }
}

/// The swinging plate (Upwind-SPH, Δx = 0.1, about 100 steps of one period) with the
/// hourglass observer and `overrides`, a sample after every step; its series and result.
#[test]
fn a_local_cases_folder_adds_to_the_shipped_cases_and_a_wrong_name_gets_suggestions() {
    // In a working directory with a `cases/` folder of its own (one case, a copy of
    // bar-mode under another name), `check` finds that case and a shipped one by name; a
    // misspelt name is refused with exit 2, the folders looked in and the nearest names.
    let exe = env!("CARGO_BIN_EXE_meshless");
    let cwd = tempfile::tempdir().unwrap();
    std::fs::create_dir(cwd.path().join("cases")).unwrap();
    let text = std::fs::read_to_string(case_file("bar-mode")).unwrap();
    std::fs::write(cwd.path().join("cases/my-bar.toml"), text).unwrap();
    let check = |name: &str| {
        Command::new(exe)
            .current_dir(cwd.path())
            .args(["check", "--backend", "cpu", name])
            .output()
            .unwrap()
    };
    for name in ["my-bar", "wave-rod"] {
        let out = check(name);
        assert_eq!(out.status.code(), Some(0), "{name}: {out:?}");
    }
    let out = check("wave-rods");
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("no case `wave-rods`")
            && stderr.contains("did you mean wave-rod")
            && stderr.contains("cases and "),
        "{stderr}"
    );
}

#[test]
fn a_batch_run_logs_plain_progress_and_its_summary_records_how_it_was_set_up() {
    // stderr is a pipe here, as in a batch job: no bar, but the plain start line (and a
    // line every 10 s, which this short run does not reach). summary.json names the file,
    // the overrides in order, the version and the case as run, defaults resolved.
    let exe = env!("CARGO_BIN_EXE_meshless");
    let dir = tempfile::tempdir().unwrap();
    let file = case_file("wave-rod");
    let out = Command::new(exe)
        .args([
            "run",
            file.to_str().unwrap(),
            "--backend",
            "cpu",
            "--no-frames",
        ])
        .args([
            "--set",
            "run.end_time=1e-4",
            "--set",
            "material.poisson_ratio=0.25",
        ])
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("wave-rod: "), "{stderr}");
    assert!(
        !stderr.contains('\r'),
        "a bar was drawn into a pipe: {stderr:?}"
    );
    let text = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(summary["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(summary["case_file"], file.display().to_string());
    assert_eq!(
        summary["overrides"],
        serde_json::json!(["run.end_time=1e-4", "material.poisson_ratio=0.25"])
    );
    let resolved = &summary["resolved_case"];
    assert_eq!(resolved["material"]["poisson_ratio"], 0.25);
    assert_eq!(resolved["run"]["end_time"], 1e-4);
    assert!(resolved["method"]["kernel"].is_string(), "{resolved}");
    assert_eq!(summary["backend"], "cpu");
}

#[test]
fn a_run_evaluates_its_cases_checks_on_the_series() {
    // The shipped disk's check is the relative drift of H over the series. Recomputed here
    // from series.csv by hand, it must equal the summary's value to round-off, lie in the
    // check's expected range [0, 1e-4], and be positive (RK4 drifts a little).
    let dir = tempfile::tempdir().unwrap();
    let case = load("rotating-disk", &["run.end_time=2e-3"]);
    let summary = run(&case, &cpu_options(dir.path(), false)).unwrap();
    let [check] = summary.checks.as_slice() else {
        panic!("{:?}", summary.checks)
    };
    let text = std::fs::read_to_string(dir.path().join("series.csv")).unwrap();
    let mut lines = text.lines();
    let k = lines
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "angular_momentum_z")
        .unwrap();
    let h: Vec<f64> = lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect();
    let drift = h.iter().map(|x| (x - h[0]).abs()).fold(0.0, f64::max) / h[0].abs();
    assert!(h.len() > 10);
    assert_eq!(check.statistic, "drift");
    assert!(
        (check.value - drift).abs() <= 1e-15,
        "{check} against {drift}"
    );
    assert!(check.value > 0.0 && check.within == Some(true), "{check}");
}

fn swinging_plate(dir: &Path, overrides: &[&str]) -> Result<(), RunError> {
    let mut set = vec![
        "spacing=0.1",
        "run.end_time=0.02",
        "output.observers=[\"energy\", \"hourglass\"]",
    ];
    set.extend_from_slice(overrides);
    run(&load("swinging-plate", &set), &cpu_options(dir, false)).map(|_| ())
}

/// Columns of the swinging plate's series without any failure limit, run once for the
/// tests that set a limit from it.
struct FreeRun {
    time: Vec<f64>,
    dt: Vec<f64>,
    eta: Vec<f64>,
}

fn free_run() -> &'static FreeRun {
    static FREE: std::sync::OnceLock<FreeRun> = std::sync::OnceLock::new();
    FREE.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        swinging_plate(dir.path(), &[]).unwrap();
        let csv = dir.path().join("series.csv");
        FreeRun {
            time: column(&csv, "time"),
            dt: column(&csv, "dt"),
            eta: column(&csv, "hourglass_max"),
        }
    })
}

/// The blow-up of a run that must fail.
fn blow_up(result: Result<(), RunError>) -> (f64, meshless::methods::BlowUp) {
    match result {
        Err(RunError::BlowUp { time, cause, .. }) => (time, cause),
        other => panic!("expected a blow-up, got {other:?}"),
    }
}

#[test]
fn hourglass_limit_stops_the_run_at_the_first_sample_above_it() {
    // The free run's series says when max η first exceeds half its largest value; the
    // limited run must stop there. Both runs compute the same states (the CPU path is
    // deterministic), so the times agree to round-off of the time sum.
    let FreeRun { time, eta, .. } = free_run();
    assert_eq!(eta[0], 0.0, "η vanishes on the undeformed lattice");
    let limit = 0.5 * eta.iter().fold(0.0, |a: f64, &b| a.max(b));
    let first = eta.iter().position(|&e| e > limit).unwrap();

    let limited = tempfile::tempdir().unwrap();
    let set = format!("run.hourglass_limit={limit}");
    let (t, cause) = blow_up(swinging_plate(limited.path(), &[&set]));
    assert!(cause.quantity.contains("hourglass"), "{cause}");
    assert_eq!(cause.value, eta[first]);
    assert!(
        (t - time[first]).abs() <= 1e-12 * t,
        "{t} vs {}",
        time[first]
    );
}

#[test]
fn a_collapsing_cfl_step_stops_the_run_before_the_step_below_the_floor() {
    // The CFL step of the mixed method follows λ²_min and |v|: over the period it dips to
    // about 0.9992 of the first step. A floor between the two must stop the run at the
    // start of the first step below it; a floor below the dip must not.
    let FreeRun { time, dt, .. } = free_run();
    // The last step is shortened to land on the end time, so it is left out.
    let steps = &dt[1..dt.len() - 1];
    let dip = steps.iter().fold(f64::INFINITY, |a, &b| a.min(b)) / dt[0];
    assert!(
        dip < 1.0 - 1e-4,
        "the step must vary over the run, dip {dip}"
    );
    let ratio = 0.5 * (1.0 + dip);
    let first = 1 + steps.iter().position(|&d| d < ratio * dt[0]).unwrap();

    let limited = tempfile::tempdir().unwrap();
    let set = format!("run.min_step_ratio={ratio}");
    let (t, cause) = blow_up(swinging_plate(limited.path(), &[&set]));
    assert!(
        cause.quantity.starts_with("collapse of the CFL step"),
        "{cause}"
    );
    assert!((t - time[first - 1]).abs() <= 1e-12 * t.max(1e-12));

    let below = format!("run.min_step_ratio={}", 0.9 * dip);
    swinging_plate(tempfile::tempdir().unwrap().path(), &[&below]).unwrap();
}

#[test]
fn output_intervals_below_the_step_give_one_frame_and_row_per_step() {
    // Intervals of 1e-22 s, far below the 1e-6 s step and the resolution of t: a frame
    // and a series row at every step (the first at t = 0), and the run ends. The frame
    // schedule once stepped to the next frame time by repeated addition of the interval,
    // which no longer moved t and never ended.
    let dir = tempfile::tempdir().unwrap();
    let case = load(
        "tensile-strip",
        &[
            "run.end_time=2e-5",
            "output.frame_interval=1e-22",
            "output.series_interval=1e-22",
        ],
    );
    let summary = run(&case, &cpu_options(dir.path(), true)).unwrap();
    assert_eq!(summary.steps, 20);
    let frames = std::fs::read_dir(dir.path())
        .unwrap()
        .filter(|e| {
            let name = e.as_ref().unwrap().file_name();
            name.to_string_lossy().ends_with(".vtu")
        })
        .count();
    assert_eq!(
        frames, 21,
        "a frame at t = 0 and after each of the 20 steps"
    );
    let rows = column(&dir.path().join("series.csv"), "time");
    assert_eq!(
        rows.len(),
        21,
        "a row at t = 0 and after each of the 20 steps"
    );
}

#[test]
fn an_output_error_names_the_path() {
    // An output folder below a regular file cannot be created: the error names that
    // folder and what to do, and the command line exits with 1 (a failed run).
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("not-a-folder");
    std::fs::write(&file, "x").unwrap();
    let out = file.join("run");
    let case = load("tensile-strip", &["run.end_time=1e-5"]);
    let e = run(&case, &cpu_options(&out, false)).unwrap_err();
    let shown = e.to_string();
    assert!(matches!(e, RunError::Output { .. }), "{shown}");
    assert!(shown.contains(&out.display().to_string()), "{shown}");
    assert!(shown.contains("--out"), "{shown}");
}

#[cfg(unix)]
#[test]
fn outputs_replace_planted_symlinks_and_never_write_through_them() {
    // Symlinks to files outside --out planted as every file a run writes (the series, the
    // summary, the index, a frame) and as the fixed temporary names of earlier versions:
    // after the run every target holds what it held, and the run's files are its own.
    let outside = tempfile::tempdir().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let names = [
        "series.csv",
        "summary.json",
        "tensile-strip.pvd",
        "tensile-strip_000000.vtu",
        "series.csv.tmp",
        "summary.json.tmp",
        "tensile-strip.pvd.tmp",
    ];
    for (k, name) in names.iter().enumerate() {
        let target = outside.path().join(format!("target-{k}"));
        std::fs::write(&target, format!("precious {k}")).unwrap();
        std::os::unix::fs::symlink(&target, dir.path().join(name)).unwrap();
    }
    let case = load("tensile-strip", &["run.end_time=2e-6"]);
    run(&case, &cpu_options(dir.path(), true)).unwrap();
    for k in 0..names.len() {
        let target = outside.path().join(format!("target-{k}"));
        assert_eq!(
            std::fs::read_to_string(target).unwrap(),
            format!("precious {k}")
        );
    }
    for name in &names[..4] {
        let meta = std::fs::symlink_metadata(dir.path().join(name)).unwrap();
        assert!(meta.is_file(), "{name} is not the run's own file");
    }
    let series = std::fs::read_to_string(dir.path().join("series.csv")).unwrap();
    assert_eq!(
        series.lines().count(),
        3,
        "header and the rows at t = 0 and the end: {series}"
    );
}

#[test]
fn bench_sizes_keep_the_regions_of_a_case() {
    // The strip's grips select the lattice rows at x = 0 and x = 1 (20 spacings apart):
    // every rescaled spacing keeps a row on both, so each size builds its boundary
    // conditions (a region that selects no particle is an error), with a particle count
    // within a factor 2.5 of the target (whole divisors and multiples of the spacing).
    let base = shipped("tensile-strip");
    for target in [100.0, 200.0, 1e3, 1e4] {
        let case = load("tensile-strip", &resize(&base, target, false).unwrap());
        let n = Reference::<D2>::build(&case)
            .unwrap_or_else(|e| panic!("{target} particles: {e}"))
            .len() as f64;
        assert!(
            n / target < 2.5 && target / n < 2.5,
            "{n} particles for {target}"
        );
    }
}

#[test]
fn bench_reports_the_neighbour_share_of_the_methods_whose_lists_follow_the_particles() {
    // On the CPU the share is the wall time of the lists' updates inside the timed steps,
    // a part of those steps: strictly between 0 and 1. On the GPU it is the rebuilds
    // recorded times one rebuild timed alone, an estimate: positive, and below 2 (a
    // rebuild is one of the three parts of a rate evaluation, so a share near or above 1
    // would be a wrong count). Lists built once report no share.
    let ul = shipped("rotating-disk-gray-monaghan");
    let cpu = measure(&ul, Backend::Cpu, 20).unwrap();
    let share = cpu
        .neighbour_share
        .expect("the UL lists follow the particles");
    assert!(share > 0.0 && share < 1.0, "CPU share {share}");
    let gpu = measure(&ul, Backend::Gpu, 20).unwrap();
    let share = gpu
        .neighbour_share
        .expect("the GPU rebuilds every evaluation");
    assert!(share > 0.0 && share < 2.0, "GPU share {share}");
    let tl = measure(&shipped("rotating-disk"), Backend::Cpu, 5).unwrap();
    assert_eq!(tl.neighbour_share, None);
    let share = format!("{:.4}", cpu.neighbour_share.unwrap());
    assert_eq!(csv_field(&cpu, "neighbour_share"), share);
    assert_eq!(csv_field(&tl, "neighbour_share"), "");
}

/// The field `column` of a bench row's CSV line, found by the header.
fn csv_field(row: &BenchRow, column: &str) -> String {
    let k = BenchRow::HEADER.split(',').position(|c| c == column);
    let line = row.csv();
    line.split(',')
        .nth(k.expect("a column of the header"))
        .unwrap()
        .to_string()
}

#[test]
fn bench_gives_the_pairs_and_the_traffic_model_of_the_method() {
    // TLSPH's pairs per particle are those of the lists it builds, the cost per pair
    // follows from the rate evaluations per second, and the CSV carries both and the
    // model's bytes.
    let case = shipped("rotating-disk");
    let row = measure(&case, Backend::Cpu, 2).unwrap();
    let traffic = row.traffic.expect("TLSPH has a traffic model");
    let tlsph: Tlsph<D2> = build_method(&case).unwrap();
    let pairs = tlsph.neighbours().pair_count() as f64 / tlsph.volume().len() as f64;
    assert_eq!(row.pairs_per_particle, Some(pairs));
    let ns = 1e9 / (row.rate_evaluations_per_second * pairs);
    assert_eq!(csv_field(&row, "ns_per_pair"), format!("{ns:.3}"));
    let bytes = format!("{:.0}", traffic.bytes_per_particle);
    assert_eq!(csv_field(&row, "bytes_per_particle_step"), bytes);
}

#[test]
fn an_infinite_energy_stops_the_run() {
    // A free strip moving rigidly at 1e300 m/s: F stays I and the state finite, but the
    // kinetic energy overflows to infinity, which the energy check must report.
    let dir = tempfile::tempdir().unwrap();
    let case = load(
        "tensile-strip",
        &[
            "boundary=",
            "body.0.initial_velocity={ type = \"uniform\", value = [1e300, 0.0] }",
            "run.end_time=1e-5",
        ],
    );
    let (_, cause) = blow_up(run(&case, &cpu_options(dir.path(), false)).map(|_| ()));
    assert!(cause.quantity.contains("total energy"), "{cause}");
    assert!(cause.value.is_infinite(), "{cause}");
}

#[test]
fn a_blow_up_during_a_step_is_reported_at_that_step() {
    // The wave rod at 2e-5 s (CFL 4.6): the CPU finds det F ≤ 0 during a step and reports
    // that step, not the first of its check batch. Running one step fewer completes, and
    // running exactly to the reported step fails there.
    let dt = 2e-5;
    let set = |end: f64| {
        load(
            "wave-rod",
            &[
                "method.cfl=".to_string(),
                format!("method.dt={dt}"),
                format!("run.end_time={end}"),
            ],
        )
    };
    let dir = tempfile::tempdir().unwrap();
    let err = run(&set(1.3e-4), &cpu_options(dir.path(), false)).unwrap_err();
    let RunError::BlowUp {
        step, first_step, ..
    } = err
    else {
        panic!("expected a blow-up, got {err}")
    };
    assert_eq!(first_step, step, "found during a step: exactly one step");
    assert!(step > 1, "step {step}");
    let before = (step - 1) as f64 * dt;
    run(&set(before), &cpu_options(dir.path(), false))
        .unwrap_or_else(|e| panic!("{} steps fail: {e}", step - 1));
    let at = step as f64 * dt;
    match run(&set(at), &cpu_options(dir.path(), false)) {
        Err(RunError::BlowUp { step: again, .. }) => assert_eq!(again, step),
        other => panic!("{step} steps: {other:?}"),
    }
}

#[test]
fn check_builds_a_case_without_running_it() {
    // `meshless check` exits 0 for a case whose set-up succeeds, and 2 with the key for
    // one that `run` would refuse only once its bodies are sampled (a boundary region
    // beyond the strip), which validation of the file alone cannot see.
    let exe = env!("CARGO_BIN_EXE_meshless");
    let ok = Command::new(exe)
        .args([
            "check",
            "tensile-strip",
            "swinging-plate",
            "--backend",
            "cpu",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&ok.stdout);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert_eq!(stdout.matches(": ok (").count(), 2, "{stdout}");
    assert_eq!(stdout.matches("of host memory").count(), 2, "{stdout}");
    assert!(!stdout.contains("device"), "{stdout}");
    // On the GPU: the device's share, and its buffers, largest first (the per-pair data
    // of TLSPH's 11 pairs a particle, 16 B each in 2D, above its 16 B-a-particle state).
    let gpu = Command::new(exe)
        .args(["check", "tensile-strip", "--backend", "gpu"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&gpu.stdout);
    assert!(
        gpu.status.success(),
        "{}",
        String::from_utf8_lossy(&gpu.stderr)
    );
    assert!(stdout.contains("of device memory ("), "{stdout}");
    let first = stdout
        .lines()
        .skip_while(|l| *l != "device buffers:")
        .nth(1);
    assert!(
        first.is_some_and(|l| l.starts_with("  per-pair data: ")),
        "{stdout}"
    );
    let bad = Command::new(exe)
        .args(["check", "tensile-strip", "--backend", "cpu"])
        .args(["--set", "boundary.1.region.x_min=5.0"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("key `boundary.1.region`"), "{stderr}");
}

#[test]
fn a_case_past_the_stated_device_memory_is_refused_before_any_buffer() {
    // MESHLESS_DEVICE_MEMORY states the GPU's memory, which wgpu does not report. The
    // strip (441 particles, about 0.5 MB on the device by the estimate) does not fit in
    // 64 kB: `check --backend gpu` exits 2 naming the variable and a spacing that fits,
    // before an adapter is opened; a malformed value is refused naming the variable; in
    // 1 GB it fits, and the CPU backend ignores the variable.
    let exe = env!("CARGO_BIN_EXE_meshless");
    let check = |memory: &str, backend: &str| {
        Command::new(exe)
            .args(["check", "tensile-strip", "--backend", backend])
            .env("MESHLESS_DEVICE_MEMORY", memory)
            .env("MESHLESS_ADAPTER", "no adapter has this name")
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    let small = check("64kB", "gpu");
    let stderr = String::from_utf8_lossy(&small.stderr);
    assert_eq!(small.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("MESHLESS_DEVICE_MEMORY says the device has")
            && stderr.contains("key `spacing`")
            && stderr.contains("particles fit"),
        "{stderr}"
    );
    let bad = check("lots", "gpu");
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("MESHLESS_DEVICE_MEMORY=lots"), "{stderr}");
    let cpu = check("64kB", "cpu");
    assert!(
        cpu.status.success(),
        "{}",
        String::from_utf8_lossy(&cpu.stderr)
    );
    // In 1 GB the estimate fits: the check goes on to open the adapter, which the
    // name given does not match (its error, not the memory's).
    let fits = check("1GB", "gpu");
    let stderr = String::from_utf8_lossy(&fits.stderr);
    assert!(!stderr.contains("MESHLESS_DEVICE_MEMORY"), "{stderr}");
}

#[test]
fn a_bench_of_the_largest_size_fills_the_stated_device_memory_and_no_more() {
    // `bench --particles largest` sizes TLSPH on the plate to the 40 MB MESHLESS_DEVICE_MEMORY
    // states, by the estimate with a tenth kept free. The bytes the engine books (the CSV's
    // device_bytes) are within the 40 MB, and above 70 % of it: the headroom keeps 90 %,
    // and the spacing, a whole divisor k ≥ 10 of the case's (about 4e4 particles from
    // 441), loses at most (k/(k+1))² ≥ 83 % to the rounding, 75 % together, less the
    // estimate's 1 % on a box. A size past the memory is refused with exit 2, naming the
    // variable, before any buffer is made.
    let exe = env!("CARGO_BIN_EXE_meshless");
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("bench.csv");
    let bench = |size: &str| {
        Command::new(exe)
            .args(["bench", "studies/cases/swinging-plate", "--backend", "gpu"])
            .args(["--particles", size, "--steps", "1"])
            .args(["--set", "method.name=tlsph", "--set", "method.force="])
            .arg("--csv")
            .arg(&csv)
            .env("MESHLESS_DEVICE_MEMORY", "40MB")
            .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/cases"))
            .output()
            .unwrap()
    };
    let largest = bench("largest");
    assert!(
        largest.status.success(),
        "{}",
        String::from_utf8_lossy(&largest.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let row: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    let value = |name: &str| -> f64 {
        let at = header.iter().position(|h| *h == name).unwrap();
        row[at].parse().unwrap()
    };
    let (bytes, memory) = (value("device_bytes"), 40e6);
    assert!(
        bytes <= memory && bytes > 0.7 * memory,
        "{} particles, {bytes} B booked of {memory} B",
        value("particles")
    );
    let past = bench("1e5");
    let stderr = String::from_utf8_lossy(&past.stderr);
    assert_eq!(past.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("MESHLESS_DEVICE_MEMORY says the device has"),
        "{stderr}"
    );
}

#[test]
fn runs_that_would_not_fit_or_never_end_are_refused_at_once() {
    // The inputs that grew to 4 GB and aborted (spacing 1e-6), wrapped the particle count
    // to zero (1e-300) or ran forever (Δt = 1e-300, an end time of 1e300, CFL 1e-12):
    // each exits with 2 and the key within seconds, before a file is written; a cap
    // given on the command line is obeyed (the strip's 441 particles over 400).
    let exe = env!("CARGO_BIN_EXE_meshless");
    let dir = tempfile::tempdir().unwrap();
    for (args, key) in [
        (&["--set", "spacing=1e-6"][..], "spacing"),
        (&["--set", "spacing=1e-300"], "spacing"),
        (&["--set", "method.dt=1e-300"], "method.dt"),
        (&["--set", "run.end_time=1e300"], "run.end_time"),
        (
            &["--set", "method.dt=", "--set", "method.cfl=1e-12"],
            "method.cfl",
        ),
        (&["--max-particles", "400"], "spacing"),
        (&["--max-steps", "1000"], "run.end_time"),
    ] {
        let started = std::time::Instant::now();
        let out = Command::new(exe)
            .args(["run", "tensile-strip", "--backend", "cpu", "-q", "--out"])
            .arg(dir.path())
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains(&format!("key `{key}`")),
            "{args:?}: {stderr}"
        );
        // Seconds of process start-up on a loaded machine, not the hours of the run.
        assert!(started.elapsed().as_secs() < 30, "{args:?}");
        assert!(!dir.path().join("summary.json").exists(), "{args:?}");
    }
}

#[test]
fn a_run_clears_the_previous_runs_files_and_nothing_else() {
    // A first run writes 20 frames, their index, a series and a summary; a second run
    // into the same folder without frames leaves none of the first run's frames or index
    // (which it lists), a summary of its own, and the user's own files untouched, a VTU
    // the index does not list included.
    let dir = tempfile::tempdir().unwrap();
    let first = load(
        "tensile-strip",
        &["run.end_time=2e-5", "output.frame_interval=1e-6"],
    );
    run(&first, &cpu_options(dir.path(), true)).unwrap();
    let files = |ext: &str| {
        std::fs::read_dir(dir.path())
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .path()
                    .extension()
                    .is_some_and(|x| x == ext)
            })
            .count()
    };
    assert!(files("vtu") > 10 && files("pvd") == 1);
    std::fs::write(dir.path().join("notes.txt"), "mine").unwrap();
    std::fs::write(dir.path().join("mesh.vtu"), "mine").unwrap();
    let second = load("tensile-strip", &["run.end_time=1e-5"]);
    let summary = run(&second, &cpu_options(dir.path(), false)).unwrap();
    assert_eq!(
        (files("vtu"), files("pvd")),
        (1, 0),
        "only the user's VTU is left"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("notes.txt")).unwrap(),
        "mine"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("mesh.vtu")).unwrap(),
        "mine"
    );
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(written["status"], "completed");
    assert_eq!(written["steps"], summary.steps);
}

/// The files of `dir` named `<prefix>_*.vtu`.
fn frames_of(dir: &Path, prefix: &str) -> usize {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with(&format!("{prefix}_")) && n.ends_with(".vtu"))
        .count()
}

#[cfg(unix)]
#[test]
fn another_cases_frames_stay_and_a_folder_in_use_is_refused() {
    // Two cases with frames into one folder: the second removes nothing of the first
    // (its index and its six frames stay). While the folder's lock is held, as by a run
    // still going, a third run is refused at once with exit code 2 and the folder named;
    // once it is released the run goes ahead.
    let dir = tempfile::tempdir().unwrap();
    let set = ["run.end_time=1e-5", "output.frame_interval=2e-6"];
    let first = load("tensile-strip", &set);
    run(&first, &cpu_options(dir.path(), true)).unwrap();
    let mut other = set.to_vec();
    other.push("name=\"other\"");
    run(
        &load("tensile-strip", &other),
        &cpu_options(dir.path(), true),
    )
    .unwrap();
    for name in ["tensile-strip", "other"] {
        assert!(
            dir.path().join(format!("{name}.pvd")).is_file(),
            "{name}.pvd"
        );
        assert_eq!(frames_of(dir.path(), name), 6, "the frames of {name}");
    }
    let held = meshless::output::lock_folder(dir.path()).unwrap();
    let e = run(&first, &cpu_options(dir.path(), false)).unwrap_err();
    let shown = e.to_string();
    assert!(matches!(e, RunError::Busy { .. }), "{shown}");
    assert_eq!(e.exit_code(), 2);
    assert!(shown.contains(&dir.path().display().to_string()) && shown.contains("--out"));
    drop(held);
    run(&first, &cpu_options(dir.path(), false)).unwrap();
    assert_eq!(frames_of(dir.path(), "tensile-strip"), 0);
    assert_eq!(frames_of(dir.path(), "other"), 6);
}

#[cfg(unix)]
#[test]
fn fifos_in_the_output_folder_are_never_waited_on() {
    // FIFOs under the names of the index, the series and the summary: opened for reading
    // they would block until a writer came. The run removes the entries, writes its own
    // files and ends within the time limit (it takes well under a second). A FIFO in place
    // of the checkpoint of a resume is refused with the reason.
    let dir = tempfile::tempdir().unwrap();
    for name in ["tensile-strip.pvd", "series.csv", "summary.json"] {
        let made = Command::new("mkfifo").arg(dir.path().join(name)).status();
        assert!(made.unwrap().success(), "mkfifo {name}");
    }
    let out = dir.path().to_path_buf();
    let (sender, receiver) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let case = load("tensile-strip", &["run.end_time=2e-6"]);
        let _ = sender.send(run(&case, &cpu_options(&out, true)).map(|s| s.status));
    });
    let status = receiver
        .recv_timeout(std::time::Duration::from_secs(120))
        .expect("the run waits on a FIFO")
        .unwrap();
    assert_eq!(status, "completed");
    for name in ["tensile-strip.pvd", "series.csv", "summary.json"] {
        assert!(
            dir.path().join(name).is_file(),
            "{name} is the run's own file"
        );
    }
    std::fs::remove_file(dir.path().join("checkpoint.bin")).ok();
    let made = Command::new("mkfifo")
        .arg(dir.path().join("checkpoint.bin"))
        .status();
    assert!(made.unwrap().success());
    let case = load("tensile-strip", &["run.end_time=2e-6"]);
    let opts = meshless::run::RunOptions {
        resume: true,
        ..cpu_options(dir.path(), false)
    };
    let e = run(&case, &opts).unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
}

#[test]
fn sigint_and_sigterm_end_a_run_with_an_interrupted_summary() {
    // The rotating disk (150,000 steps, a minute or more) started from the command line:
    // its summary says "running" once it has begun; SIGINT or SIGTERM then ends it after
    // the current batch of steps with exit code 130 and an "interrupted" summary that
    // names the step reached, the series rows so far intact.
    let exe = env!("CARGO_BIN_EXE_meshless");
    for signal in ["-INT", "-TERM"] {
        let dir = tempfile::tempdir().unwrap();
        let mut child = Command::new(exe)
            .args(["run", case_file("rotating-disk").to_str().unwrap()])
            .args(["--backend", "cpu", "--no-frames", "-q", "--out"])
            .arg(dir.path())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let summary = dir.path().join("summary.json");
        let read = || -> Option<serde_json::Value> {
            serde_json::from_str(&std::fs::read_to_string(&summary).ok()?).ok()
        };
        let started = std::time::Instant::now();
        while read().is_none_or(|s| s["status"] != "running") {
            assert!(started.elapsed().as_secs() < 60, "no 'running' summary");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        std::thread::sleep(std::time::Duration::from_millis(300));
        let sent = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(130), "{signal}");
        let s = read().expect("a summary");
        assert_eq!(s["status"], "interrupted", "{signal}");
        assert!(s["steps"].as_u64().unwrap() > 0 && s["steps"].as_u64().unwrap() < 150_000);
        let rows = std::fs::read_to_string(dir.path().join("series.csv")).unwrap();
        assert!(rows.lines().count() >= 2, "{rows}");
    }
}

#[test]
fn the_plan_of_a_static_run_gives_load_steps_and_newton_not_an_integrator() {
    // A static run has no integrator: its plan names the load steps and the Newton
    // iterations, where a time stepper's names the integrator's stage operations.
    let static_plan = meshless::run::explain(&shipped("rubber-pull-2d"), false);
    assert!(
        static_plan.contains("load steps: 2.5e-2 s"),
        "{static_plan}"
    );
    assert!(static_plan.contains("Newton–Raphson"), "{static_plan}");
    for absent in ["integrator", "copy Y", "time step:"] {
        assert!(!static_plan.contains(absent), "{absent}: {static_plan}");
    }
    let dynamic_plan = meshless::run::explain(&shipped("rotating-disk"), false);
    assert!(dynamic_plan.contains("time step:"), "{dynamic_plan}");
    assert!(dynamic_plan.contains("rates of Y"), "{dynamic_plan}");
    assert!(!dynamic_plan.contains("load steps"), "{dynamic_plan}");
}

/// The status and failure of the summary in `dir`.
fn summary_status(dir: &Path) -> (String, String) {
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let failure = summary["failure"].as_str().unwrap_or_default().to_string();
    (summary["status"].as_str().unwrap().to_string(), failure)
}

#[cfg(unix)]
#[test]
fn a_frame_the_disk_refuses_ends_the_summary_failed_with_the_reason() {
    // A file size limit (ulimit -f, 1024 blocks of 512 bytes: 512 KiB) with its signal
    // ignored makes a write past it fail with "File too large", as a full disk makes one
    // fail with "No space left": the summary (about 70 KiB with its reserve) fits, the
    // first frame of wave-rod (2211 particles, about 750 KiB) does not. The run exits 1,
    // naming the frame, and its summary says "failed" and why.
    let dir = tempfile::tempdir().unwrap();
    let exe = env!("CARGO_BIN_EXE_meshless");
    let script = format!(
        "trap '' XFSZ; ulimit -f 1024; exec '{exe}' run '{}' --backend cpu --out '{}'",
        case_file("wave-rod").display(),
        dir.path().display()
    );
    let out = Command::new("sh").args(["-c", &script]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("wave-rod_000000.vtu"), "{stderr}");
    let (status, failure) = summary_status(dir.path());
    assert_eq!(status, "failed");
    assert!(failure.contains("wave-rod_000000.vtu"), "{failure}");
}

#[test]
fn frames_that_cannot_fit_on_the_disk_are_refused_after_the_first() {
    // A frame at every millisecond of a billion seconds: 10¹² frames of about 750 KiB,
    // beyond any disk. Once the first frame gives their size the run is refused, before
    // its first step, naming output.frame_interval and the free space; the summary says
    // "failed" and why.
    let dir = tempfile::tempdir().unwrap();
    let case = load(
        "wave-rod",
        &["run.end_time=1e9", "output.frame_interval=1e-3"],
    );
    let mut opts = cpu_options(dir.path(), true);
    opts.limits.max_steps = 1e16;
    let e = run(&case, &opts).unwrap_err();
    let shown = e.to_string();
    assert_eq!(e.exit_code(), 2, "{shown}");
    assert!(
        shown.contains("output.frame_interval") && shown.contains("will not fit"),
        "{shown}"
    );
    assert_eq!(frames_of(dir.path(), "wave-rod"), 1);
    let (status, failure) = summary_status(dir.path());
    assert_eq!(status, "failed");
    assert!(failure.contains("will not fit"), "{failure}");
}
