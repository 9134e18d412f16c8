//! `meshless study`: runs the suites of `cases/studies/` (variants × backends × a sweep of
//! one case key), measures each run's error against the suite's reference and its wall
//! time, and writes CSV, Markdown tables, error-against-time plots and the report.
//!
//! Runs are isolated (a blow-up, an invalid case or a panic is recorded and the study goes
//! on) and keyed by a hash of the resolved case and the backend, so a study that is run
//! again skips what it finished. Nothing here depends on the particle method: a method
//! family plugs in by being named in a variant's `method.name=…`.

pub mod convergence;
pub mod engine;
pub mod fields;
pub mod history;
pub mod neighbourhoods;
pub mod picture;
pub mod plot;
pub mod records;
pub mod report;
pub mod stale;
pub mod suite;

pub use records::{RunRecord, Status};
pub use suite::{Reference, Suite, SuiteKind};

use crate::run::{Backend, ProgressDisplay, RunError, RunOptions};
use engine::{Outcome, run_case};
use fields::{FinalState, analytic_fields, axial_stress, matched_fields, relative_l2};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;
use suite::{AnalyticSolution, BackendName, PlannedRun};

/// How a study runs.
#[derive(Clone, Debug)]
pub struct StudyOptions {
    /// Folder of this suite's results (`results.csv`, `results.md`, plots, run outputs).
    pub out_dir: PathBuf,
    /// Skip runs whose results are already in `results.csv`.
    pub resume: bool,
    /// Progress bar on the terminal.
    pub progress: bool,
    /// Wall time after which a run is stopped (after its current batch of steps) and
    /// recorded as an error; the study goes on.
    pub run_time_limit: Duration,
    /// Run what is not yet finished; `false` only reads the results already recorded (a
    /// long suite under `meshless study all`).
    pub measure: bool,
}

/// The default per-run wall-time limit: half an hour (the longest run of the published
/// report takes about two minutes on 2 cores).
pub const RUN_TIME_LIMIT: Duration = Duration::from_secs(1800);

/// What a study did.
#[derive(Clone, Debug)]
pub struct StudyOutcome {
    /// One record per planned run, in plan order.
    pub records: Vec<RunRecord>,
    /// Runs done now.
    pub executed: usize,
    /// Runs taken from an earlier study.
    pub skipped: usize,
    /// Files written (results, table, plots).
    pub files: Vec<PathBuf>,
}

/// File of a converged reference's final state.
fn reference_file(out_dir: &Path, id: &str) -> PathBuf {
    out_dir.join(format!("reference-{id}.csv"))
}

/// Runs a suite: every planned run not already finished, one after another (their wall
/// times are compared, so they do not share the cores).
pub fn run_suite(suite: &Suite, opts: &StudyOptions) -> std::io::Result<StudyOutcome> {
    std::fs::create_dir_all(&opts.out_dir)?;
    let results = opts.out_dir.join("results.csv");
    let plan = suite.plan();
    let mut records: Vec<RunRecord> = if opts.resume || !opts.measure {
        records::read(&results)?
            .into_iter()
            .filter(|r| plan.iter().any(|p| p.id == r.id))
            .collect()
    } else {
        Vec::new()
    };
    let reference_id = suite
        .reference_value()
        .and(plan.first().map(|p| p.id.clone()));
    let mut reference: Option<FinalState> = None;
    let machine = records::machine();

    let bar = progress(opts.progress, plan.len() as u64, &suite.name);
    let (mut executed, mut skipped) = (0, 0);
    for run in plan.iter().filter(|_| opts.measure) {
        let is_reference = reference_id.as_deref() == Some(run.id.as_str());
        let finished = records
            .iter()
            .any(|r| r.id == run.id && r.status != Status::Error);
        let reference_ready = !is_reference || reference_file(&opts.out_dir, &run.id).exists();
        if finished && reference_ready {
            if is_reference {
                reference = FinalState::read_csv(&reference_file(&opts.out_dir, &run.id)).ok();
            }
            skipped += 1;
            bar.inc(1);
            continue;
        }
        bar.set_message(format!("{} {}={}", run.variant, suite.sweep.key, run.value));
        let (record, state) = execute(suite, run, opts, reference.as_ref(), &machine);
        if is_reference && let (Some(state), Status::Ok) = (&state, &record.status) {
            state.write_csv(&reference_file(&opts.out_dir, &run.id))?;
            reference = Some(state.clone());
        }
        if let (Some(p), Some(state)) = (&suite.picture, &state) {
            let file = picture::points_file(&opts.out_dir, &run.id);
            if let Err(e) = picture::write_points(&file, p, state) {
                eprintln!("warning: {}: picture of run {}: {e}", suite.name, run.id);
            }
        }
        let line = summary_line(suite, &record);
        if bar.is_hidden() {
            if opts.progress {
                eprintln!("{line}");
            }
        } else {
            bar.println(line);
        }
        records.retain(|r| r.id != run.id);
        records.push(record);
        records::write(&results, &records)?;
        executed += 1;
        bar.inc(1);
    }
    bar.finish_and_clear();

    // Plan order, then the files.
    records.sort_by_key(|r| plan.iter().position(|p| p.id == r.id));
    records::write(&results, &records)?;
    let mut files = vec![results];
    files.extend(figures(suite, &records, &opts.out_dir, &opts.out_dir)?);
    let md = opts.out_dir.join("results.md");
    let section = report::suite_section(suite, &records, &[], 3)
        + &history::table(suite, &records, &opts.out_dir, "");
    crate::output::write_atomically(&md, |w| std::io::Write::write_all(w, section.as_bytes()))?;
    files.push(md);
    Ok(StudyOutcome {
        records,
        executed,
        skipped,
        files,
    })
}

fn progress(show: bool, len: u64, name: &str) -> ProgressBar {
    if !show || !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} {msg}")
            .expect("static progress template is valid"),
    );
    bar.set_prefix(name.to_string());
    bar
}

/// A suite's figures, written into `dir`: the accuracy plots, then the history and the
/// picture, drawn from the runs' files under `suite_dir`.
fn figures(
    suite: &Suite,
    records: &[RunRecord],
    suite_dir: &Path,
    dir: &Path,
) -> std::io::Result<Vec<PathBuf>> {
    let mut files = plot::plots(suite, records, dir)?;
    files.extend(history::write(suite, records, suite_dir, dir)?);
    files.extend(picture::write(suite, records, suite_dir, dir)?);
    Ok(files)
}

fn summary_line(suite: &Suite, r: &RunRecord) -> String {
    let what = match &r.status {
        Status::Ok => {
            format!(
                "ok in {:.2} s, {} particles, {} steps{}{}",
                r.wall_seconds,
                r.particles,
                r.steps,
                opt(" e_v", r.error_velocity),
                opt(" e_P", r.error_stress)
            ) + &opt(" ΔH/H0", r.drift_angular_momentum)
                + &opt(" R/S", r.drift_energy)
        }
        Status::Failed { time, quantity, .. } => format!(
            "failed at {}: {quantity}",
            report::failure_time(suite, *time, 3)
        ),
        Status::Error => format!("not run: {}", r.reason),
    };
    format!(
        "  {} [{}] {}={}: {what}",
        r.variant, r.backend, r.sweep_key, r.sweep_value
    )
}

fn opt(name: &str, x: f64) -> String {
    if x.is_finite() {
        format!("{name} = {x:.3e}")
    } else {
        String::new()
    }
}

/// One run, isolated: any failure, including a panic, becomes its record.
fn execute(
    suite: &Suite,
    run: &PlannedRun,
    opts: &StudyOptions,
    reference: Option<&FinalState>,
    machine: &str,
) -> (RunRecord, Option<FinalState>) {
    let mut record = RunRecord::unmeasured(
        run.id.clone(),
        suite.name.clone(),
        run.variant.clone(),
        run.backend.as_str().to_string(),
        (suite.sweep.key.clone(), run.value.clone()),
        machine.to_string(),
    );
    let case = match &run.case {
        Ok(c) => c,
        Err(e) => {
            record.reason = e.clone();
            return (record, None);
        }
    };
    record.case = case.name.clone();
    record.spacing = case.spacing;
    let run_opts = RunOptions {
        out_dir: opts.out_dir.join("runs").join(&run.id),
        backend: match run.backend {
            BackendName::Cpu => Backend::Cpu,
            BackendName::Gpu => Backend::Gpu,
        },
        progress: ProgressDisplay::Off,
        frames: false,
        stop: Some(Arc::new(AtomicBool::new(false))),
        limits: Default::default(),
        resume: false,
        profile: false,
    };
    let (outcome, timed_out) = within_time_limit(opts.run_time_limit, &run_opts, || {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            run_case(case, run_opts.backend, &run_opts)
        }))
    });
    let Outcome {
        result,
        wall_seconds,
        drift,
        state,
        time,
    } = match outcome {
        Ok(o) => o,
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            record.reason = format!("panic: {msg}");
            return (record, None);
        }
    };
    record.wall_seconds = wall_seconds;
    record.time = time;
    record.particles = state.as_ref().map_or(0, |s| s.x0.len());
    match result {
        Ok(summary) => {
            record.status = Status::Ok;
            record.backend = summary.backend;
            record.steps = summary.steps;
            record.dt_last = summary.dt_last;
            record.drift_angular_momentum = drift.angular_momentum;
            record.drift_energy = drift.energy;
            if let Some(state) = &state {
                let is_reference = suite
                    .reference_value()
                    .is_some_and(|(v, value)| v == run.variant && value == run.value);
                match errors(suite, case, state, time, reference) {
                    Ok((ev, es)) if !is_reference => {
                        record.error_velocity = ev;
                        record.error_stress = es;
                    }
                    Ok(_) => {
                        record.reason = "converged reference: the other runs' errors are \
                                         measured against this run"
                            .into()
                    }
                    Err(e) => record.reason = e,
                }
            }
        }
        Err(RunError::BlowUp {
            step, time, cause, ..
        }) => {
            record.steps = step;
            record.reason = cause.to_string();
            record.status = Status::Failed {
                time,
                step,
                particle: cause.particle,
                quantity: cause.quantity.clone(),
            };
        }
        Err(RunError::Interrupted { step, time, .. }) if timed_out => {
            record.steps = step;
            record.reason = format!(
                "stopped at the per-run wall-time limit of {} s, at step {step}, t = {time:e} s",
                opts.run_time_limit.as_secs_f64()
            );
        }
        Err(e) => record.reason = e.to_string(),
    }
    (record, state)
}

/// Runs `run` with a watchdog that sets the stop flag of `opts` once `limit` has passed
/// (the driver then ends the run after its current batch of steps); returns its result
/// and whether the watchdog fired.
fn within_time_limit<T>(limit: Duration, opts: &RunOptions, run: impl FnOnce() -> T) -> (T, bool) {
    let Some(stop) = opts.stop.clone() else {
        return (run(), false);
    };
    if limit.is_zero() {
        // Past the limit before it starts: stopped at its first check, whatever the
        // watchdog thread's start-up latency.
        stop.store(true, Ordering::Relaxed);
        return (run(), true);
    }
    let (done, finished) = std::sync::mpsc::channel::<()>();
    let watchdog = std::thread::spawn(move || {
        let fired = finished.recv_timeout(limit) == Err(std::sync::mpsc::RecvTimeoutError::Timeout);
        if fired {
            stop.store(true, Ordering::Relaxed);
        }
        fired
    });
    let result = run();
    drop(done);
    (result, watchdog.join().unwrap_or(false))
}

/// Velocity and stress errors of a final state against the suite's reference (NaN where
/// the reference measures no field).
fn errors(
    suite: &Suite,
    case: &crate::scene::Scene,
    state: &FinalState,
    time: f64,
    reference: Option<&FinalState>,
) -> Result<(f64, f64), String> {
    let w = &state.volume;
    match &suite.reference {
        Reference::Analytic { solution } => {
            let (v_ex, p_ex) = analytic_fields(*solution, case, state, time)?;
            let ev = relative_l2(w, &state.velocity_flat(), &v_ex);
            let es = match solution {
                AnalyticSolution::RodPulse => relative_l2(w, &axial_stress(state, case), &p_ex),
                AnalyticSolution::FreeRod | AnalyticSolution::DrivenRod => {
                    // At the returns the exact stress vanishes (the pulse is all velocity),
                    // so the stress error is measured against the stress ρ0 c |v| that the
                    // exact velocity carries as a wave: the L2 norm of P_xx − σ_ex over
                    // ρ0 c ‖v_ex‖.
                    let material = crate::physics::material::Material::new(&case.material);
                    let c = crate::diagnostics::analytic::bar_wave_speed(&material, state.dim);
                    let p = axial_stress(state, case);
                    let difference: Vec<f64> = p.iter().zip(&p_ex).map(|(a, b)| a - b).collect();
                    let scale: Vec<f64> = v_ex
                        .chunks(state.dim)
                        .map(|v| material.rho0 * c * v.iter().map(|x| x * x).sum::<f64>().sqrt())
                        .collect();
                    let norm =
                        |q: &[f64]| w.iter().zip(q).map(|(w, q)| w * q * q).sum::<f64>().sqrt();
                    norm(&difference) / norm(&scale)
                }
                AnalyticSolution::Swinging => relative_l2(w, &state.stress_flat(), &p_ex),
            };
            Ok((ev, es))
        }
        Reference::Converged { .. } => {
            let Some(reference) = reference else {
                // The reference run itself, or its run failed.
                return Ok((f64::NAN, f64::NAN));
            };
            let (v_ex, p_ex, _) = matched_fields(reference, state);
            Ok((
                relative_l2(w, &state.velocity_flat(), &v_ex),
                relative_l2(w, &state.stress_flat(), &p_ex),
            ))
        }
        Reference::Invariant { .. } | Reference::None => Ok((f64::NAN, f64::NAN)),
    }
}

/// The suite files of `names`, looked up in `dirs` in order (the first folder holding a
/// name wins): a path as given, a suite by name, `all` (every suite of the folders that
/// the report includes), or a group (every suite whose name starts with `name-`). A name
/// found nowhere is kept as the missing file of the first folder, which loading names.
pub fn resolve_suites(names: &[String], dirs: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let suite_files = || -> Result<Vec<PathBuf>, String> {
        let mut files: Vec<PathBuf> = Vec::new();
        for dir in dirs.iter().filter(|d| d.is_dir()) {
            let found = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            for path in found.filter_map(|e| e.ok().map(|e| e.path())) {
                let taken = files.iter().any(|f| f.file_name() == path.file_name());
                if path.extension().is_some_and(|e| e == "toml") && !taken {
                    files.push(path);
                }
            }
        }
        files.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
        Ok(files)
    };
    let mut out = Vec::new();
    for name in names {
        let given = PathBuf::from(name);
        let file = dirs
            .iter()
            .map(|d| d.join(format!("{name}.toml")))
            .find(|f| f.exists());
        if name == "all" {
            let all = suite_files()?.into_iter();
            out.extend(all.filter(|p| Suite::load(p).is_ok_and(|s| s.report)));
        } else if given.exists() || name.ends_with(".toml") {
            out.push(given);
        } else if let Some(file) = file {
            out.push(file);
        } else {
            let prefix = format!("{name}-");
            let group: Vec<PathBuf> = suite_files()?
                .into_iter()
                .filter(|p| {
                    p.file_stem()
                        .and_then(|s| s.to_str())
                        .is_some_and(|s| s.starts_with(&prefix))
                })
                .collect();
            // No group either: the missing file, which loading names.
            if group.is_empty() {
                let first = dirs.first().map_or_else(PathBuf::new, PathBuf::clone);
                out.push(first.join(format!("{name}.toml")));
            }
            out.extend(group);
        }
    }
    Ok(out)
}

/// How the suites of one `meshless study` run.
#[derive(Clone, Debug)]
pub struct SuitesOptions {
    /// Skip runs whose results are already recorded.
    pub resume: bool,
    /// Progress bars on the terminal.
    pub progress: bool,
    /// See [`StudyOptions::run_time_limit`].
    pub run_time_limit: Duration,
    /// Run the suites marked `long` too (`meshless study all` does not: their sections are
    /// drawn from the results they have).
    pub long: bool,
}

/// Runs suites one after another (results in `<out_root>/<suite name>/`) and, with
/// `report`, writes the report over them. `command` is quoted in the report as the way to
/// regenerate it.
pub fn run_suites(
    paths: &[PathBuf],
    out_root: &Path,
    options: &SuitesOptions,
    report: Option<&Path>,
    command: &str,
) -> Result<Vec<(Suite, StudyOutcome)>, StudyError> {
    let suites = paths
        .iter()
        .map(|p| Suite::load(p))
        .collect::<Result<Vec<_>, _>>()?;
    let mut done = Vec::new();
    for suite in suites {
        let measure = options.long || !suite.long;
        if !measure && options.progress {
            eprintln!(
                "{}: a long suite, not run by `meshless study all`: its results so far are \
                 reported (run it by its name: `meshless study {}`)",
                suite.name, suite.name
            );
        }
        let opts = StudyOptions {
            out_dir: out_root.join(&suite.name),
            resume: options.resume,
            progress: options.progress,
            run_time_limit: options.run_time_limit,
            measure,
        };
        let outcome = run_suite(&suite, &opts)?;
        done.push((suite, outcome));
    }
    if let Some(path) = report {
        let entries: Vec<(Suite, Vec<RunRecord>)> = done
            .iter()
            .map(|(s, o)| (s.clone(), o.records.clone()))
            .collect();
        report::write_report(&entries, out_root, path, command)?;
    }
    Ok(done)
}

/// Rewrites only the advice section of the report at `report` from the records beside it
/// (`study/<suite>.csv` and `study/<suite>-history.csv`, as the report last wrote them),
/// running nothing: the suites' `[advice]` applied to the results as last measured.
pub fn rewrite_advice(paths: &[PathBuf], report: &Path) -> Result<(), StudyError> {
    let suites = paths
        .iter()
        .map(|p| Suite::load(p))
        .collect::<Result<Vec<_>, _>>()?;
    let study = report.parent().unwrap_or(Path::new(".")).join("study");
    let mut measured = Vec::new();
    for suite in &suites {
        let records = records::read(&study.join(format!("{}.csv", suite.name)))?;
        let curves = history::read_csv(&study.join(format!("{}-history.csv", suite.name)))?;
        measured.push((records, curves));
    }
    let evidence: Vec<report::Evidence> = suites
        .iter()
        .zip(&measured)
        .map(|(suite, (records, history))| report::Evidence {
            suite,
            records,
            history,
        })
        .collect();
    report::rewrite_advice(report, &report::advice_section(&evidence))?;
    Ok(())
}

/// Why a study could not run (failed runs are results, not errors).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error(transparent)]
    Suite(#[from] suite::SuiteError),
    #[error("output: {0}")]
    Io(#[from] std::io::Error),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_name_without_a_file_of_its_own_is_the_group_of_its_prefix() {
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "check-b.toml",
            "check-a.toml",
            "check.toml.bak",
            "checked.toml",
        ] {
            std::fs::write(dir.path().join(name), "").unwrap();
        }
        let dirs = [dir.path().to_path_buf()];
        let resolve = |name: &str| resolve_suites(&[name.to_string()], &dirs).unwrap();
        let names = |paths: Vec<PathBuf>| -> Vec<String> {
            let name = |p: &PathBuf| p.file_name().unwrap().to_string_lossy().into_owned();
            paths.iter().map(name).collect()
        };
        assert_eq!(names(resolve("check")), ["check-a.toml", "check-b.toml"]);
        assert_eq!(names(resolve("checked")), ["checked.toml"]);
        assert_eq!(names(resolve("check-b")), ["check-b.toml"]);
        // Neither a file nor a group: the missing file, for loading to name.
        assert_eq!(names(resolve("other")), ["other.toml"]);
        // A second folder after it (the shipped suites after a local `cases/studies`):
        // its names add to the first's, and a name in both is the first's.
        let second = tempfile::tempdir().unwrap();
        for name in ["check-a.toml", "check-c.toml", "extra.toml"] {
            std::fs::write(second.path().join(name), "").unwrap();
        }
        let both = [dir.path().to_path_buf(), second.path().to_path_buf()];
        let resolve = |name: &str| resolve_suites(&[name.to_string()], &both).unwrap();
        let group = resolve("check");
        assert_eq!(
            names(group.clone()),
            ["check-a.toml", "check-b.toml", "check-c.toml"]
        );
        assert!(group[0].starts_with(dir.path()), "{group:?}");
        assert!(resolve("extra")[0].starts_with(second.path()));
    }
}
