//! The `meshless` command line.

#![deny(clippy::too_many_lines)]

use clap::{Parser, Subcommand};
use meshless::bench::Size;
#[cfg(not(feature = "mpi"))]
use meshless::distributed::no_mpi_launcher;
#[cfg(feature = "mpi")]
use meshless::distributed::{launcher_size, ranks_on_node};
use meshless::methods::REGISTRY;
use meshless::run::ranks::run_on_threads;
#[cfg(feature = "mpi")]
use meshless::run::ranks::run_rank;
use meshless::run::{
    Backend, EXIT_FAILED, EXIT_INPUT, Limits, ProgressDisplay, RunError, RunOptions, budget, run,
};
use meshless::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

#[derive(Parser)]
#[command(
    name = "meshless",
    version,
    about = "Meshless particle methods for solids under very large deformation"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case file (or the name of a shipped case in cases/).
    Run {
        case: String,
        #[arg(long, value_enum, default_value_t = Backend::Auto)]
        backend: Backend,
        /// Output folder (default: out/<case name>).
        #[arg(long, conflicts_with = "resume")]
        out: Option<PathBuf>,
        /// Continue the run whose output folder is DIR from its last checkpoint
        /// (run.checkpoint_interval), with the same case and --set overrides.
        #[arg(long, value_name = "DIR")]
        resume: Option<PathBuf>,
        /// Override a case key, e.g. --set method.dt=1e-6 --set body.0.geometry.radius=0.5
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Write no VTU frames (series and summary only).
        #[arg(long)]
        no_frames: bool,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
        /// Print the plan (what runs once, per step, and what is left out) and exit.
        #[arg(long)]
        explain: bool,
        /// On the GPU, time every pass of the steps and print the pass report at the end.
        #[arg(long)]
        profile: bool,
        /// Run on N ranks that are threads of this process: the distributed path on one
        /// machine, without MPI (under mpirun, a build with the `mpi` feature runs one
        /// rank per process).
        #[arg(long, value_name = "N", conflicts_with = "explain")]
        ranks: Option<usize>,
        #[command(flatten)]
        limits: LimitArgs,
    },
    /// Check cases as `run` would (the file, the bodies, the boundary regions, the
    /// method's set-up on the backend) without running them.
    Check {
        /// Case files or shipped case names.
        #[arg(required = true)]
        cases: Vec<String>,
        #[arg(long, value_enum, default_value_t = Backend::Auto)]
        backend: Backend,
        /// Override case keys, as for `run`.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        #[command(flatten)]
        limits: LimitArgs,
    },
    /// List the shipped cases and the available methods.
    List,
    /// List the GPU adapters wgpu finds, with backend, type, limits and features.
    Info,
    /// Measure particle-steps/s of cases at several sizes on a backend.
    Bench {
        /// Case files or shipped case names.
        #[arg(required = true)]
        cases: Vec<String>,
        #[command(flatten)]
        args: BenchArgs,
    },
    /// Seed 000 Fig. 3: the neighbourhood algorithms of §3.2 (eqs 60–64) on a lattice
    /// under a prescribed shear and tension; writes neighbourhoods.csv and the figure.
    #[cfg(feature = "study")]
    Neighbourhoods {
        /// Output folder (default: out/neighbourhoods).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Run study suites: error against wall time and stability sweeps (see cases/studies/).
    #[cfg(feature = "study")]
    Study {
        /// Suite files, names of suites in cases/studies/, groups (`verification`: every
        /// verification-*.toml there), or `all` (the report's suites).
        #[arg(required = true)]
        suites: Vec<String>,
        /// Results root; each suite writes into <DIR>/<suite name>/ (default: out/study).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Redo every run (by default runs already in results.csv are kept).
        #[arg(long)]
        no_resume: bool,
        /// Also write a report over the suites (plots and CSV go to study/ beside it).
        #[arg(long)]
        report: Option<PathBuf>,
        /// Run nothing: rewrite only the report's "Which method for which job" section
        /// from the records in study/ beside it (the suites' [advice] applied to the
        /// results as last measured).
        #[arg(long, requires = "report")]
        advice_only: bool,
        /// No progress bar or per-run lines.
        #[arg(long, short)]
        quiet: bool,
        /// Stop a run after this many seconds of wall time and record it as an error; the
        /// study goes on.
        #[arg(long, value_name = "SECONDS", default_value_t = meshless::study::RUN_TIME_LIMIT.as_secs_f64())]
        run_time_limit: f64,
        /// Run nothing: list the suites whose report records (study/<suite>.csv beside
        /// --report, default docs/REPORT.md) another solver made; exit 1 if any.
        #[arg(long)]
        stale: bool,
    },
}

/// The options of `meshless bench`.
#[derive(clap::Args)]
struct BenchArgs {
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    backend: Backend,
    /// Target particle counts (the spacing is scaled to reach them), e.g. 1e3,1e4,1e5, or
    /// `largest`: the most the memory holds by the estimate, a tenth kept free (the GPU's
    /// as `MESHLESS_DEVICE_MEMORY` or the platform states it, and the host's).
    #[arg(long, value_delimiter = ',', default_value = "1e3,1e4,1e5")]
    particles: Vec<Size>,
    /// Timed steps per configuration (after one warm-up step).
    #[arg(long, default_value_t = 200)]
    steps: u32,
    /// Override case keys, as for `run`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Also write the table as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Measure this machine's memory bandwidth (STREAM triad) first, and give each CPU
    /// row the bytes per particle-step of its method's traffic model, the bandwidth
    /// they reach and its fraction of the triad's.
    #[arg(long)]
    roofline: bool,
    /// Refuse a size of more particles than this (estimated before anything is
    /// allocated); a size past the memory is refused too.
    #[arg(long, value_name = "N", default_value_t = Limits::MAX_PARTICLES)]
    max_particles: f64,
}

/// Caps on what one run may ask for; a case past them is refused with exit code 2.
#[derive(clap::Args, Clone, Copy)]
struct LimitArgs {
    /// Refuse a run of more particles than this (estimated from the case before anything
    /// is allocated).
    #[arg(long, value_name = "N", default_value_t = Limits::MAX_PARTICLES)]
    max_particles: f64,
    /// Refuse a run of more time steps than this (end time over the first Δt).
    #[arg(long, value_name = "N", default_value_t = Limits::MAX_STEPS)]
    max_steps: f64,
}

impl From<LimitArgs> for Limits {
    fn from(a: LimitArgs) -> Self {
        Limits {
            max_particles: a.max_particles,
            max_steps: a.max_steps,
        }
    }
}

fn main() -> ExitCode {
    let command = Cli::parse().command;
    // A command that computes refuses a launch of several copies by an MPI launcher,
    // but `run` in a build with MPI, which runs one rank per process.
    let computes = !matches!(command, Command::List | Command::Info);
    #[cfg(feature = "mpi")]
    if computes
        && !matches!(command, Command::Run { .. })
        && let Some((variable, size)) = launcher_size(env)
    {
        eprintln!(
            "error: {variable}={size}: an MPI launcher started {size} processes, and only \
             `meshless run` runs on several; run this command as one process"
        );
        return ExitCode::from(EXIT_INPUT);
    }
    #[cfg(not(feature = "mpi"))]
    if computes && let Err(e) = no_mpi_launcher(env) {
        eprintln!("error: {e}");
        return ExitCode::from(EXIT_INPUT);
    }
    match command {
        Command::Run {
            case,
            backend,
            out,
            resume,
            set,
            no_frames,
            quiet,
            explain,
            profile,
            ranks,
            limits,
        } => {
            if explain {
                explain_command(&case, backend, &set)
            } else {
                let output = Output {
                    resume: resume.is_some(),
                    dir: resume.or(out),
                    frames: !no_frames,
                    quiet,
                    profile,
                };
                let on = match ranks {
                    Some(n) => Ranks::Threads(n),
                    None => Ranks::One,
                };
                // One rank per process when an MPI launcher started several; MPI is
                // finalised when `mpi` is dropped, after the run on every rank.
                #[cfg(feature = "mpi")]
                let mpi = launcher_size(env).map(|_| meshless::distributed::mpi::Mpi::init());
                #[cfg(feature = "mpi")]
                let on = match &mpi {
                    Some(Some(mpi)) => Ranks::Mpi(mpi.world()),
                    Some(None) => {
                        eprintln!("error: MPI could not be initialised");
                        return ExitCode::from(EXIT_INPUT);
                    }
                    None => on,
                };
                run_command(&case, backend, output, &set, limits.into(), on)
            }
        }
        Command::Check {
            cases,
            backend,
            set,
            limits,
        } => check_command(&cases, backend, &set, &limits.into()),
        Command::List => list(),
        Command::Info => info(),
        Command::Bench { cases, args } => bench_command(&cases, &args),
        #[cfg(feature = "study")]
        Command::Neighbourhoods { out } => {
            let dir = out.unwrap_or_else(|| PathBuf::from("out/neighbourhoods"));
            match meshless::study::neighbourhoods::write(&dir) {
                Ok(files) => {
                    for f in files {
                        println!("{}", f.display());
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {}: {e}", dir.display());
                    ExitCode::FAILURE
                }
            }
        }
        #[cfg(feature = "study")]
        Command::Study {
            suites,
            report,
            stale: true,
            ..
        } => stale_command(&suites, report.as_deref()),
        #[cfg(feature = "study")]
        Command::Study {
            suites,
            out,
            no_resume,
            report,
            advice_only,
            quiet,
            run_time_limit,
            stale: false,
        } => match (advice_only, report.as_deref()) {
            (true, Some(report)) => advice_command(&suites, report),
            _ => study_command(
                &suites,
                out,
                !no_resume,
                report.as_deref(),
                quiet,
                run_time_limit,
            ),
        },
    }
}

/// The suite files `names` stand for, in the case folders' `studies/`; an unknown name is
/// refused with exit code 2.
#[cfg(feature = "study")]
fn suite_paths(names: &[String]) -> Result<Vec<PathBuf>, ExitCode> {
    let studies: Vec<PathBuf> = case_dirs().iter().map(|d| d.join("studies")).collect();
    meshless::study::resolve_suites(names, &studies).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(EXIT_INPUT)
    })
}

/// `meshless study … --report PATH --advice-only`: the advice section rewritten from the
/// recorded results.
#[cfg(feature = "study")]
fn advice_command(names: &[String], report: &Path) -> ExitCode {
    use meshless::study::{StudyError, rewrite_advice};
    let paths = match suite_paths(names) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let result = rewrite_advice(&paths, report).map_err(|e| match e {
        StudyError::Suite(_) => (EXIT_INPUT, e.to_string()),
        StudyError::Io(_) => (EXIT_FAILED, e.to_string()),
    });
    match result {
        Ok(()) => {
            println!("report: {} (its advice section)", report.display());
            ExitCode::SUCCESS
        }
        Err((code, e)) => {
            eprintln!("error: {e}");
            ExitCode::from(code)
        }
    }
}

/// `meshless study --stale`: the freshness of every named suite's report records.
#[cfg(feature = "study")]
fn stale_command(names: &[String], report: Option<&Path>) -> ExitCode {
    use meshless::study::stale::{Freshness, freshness, line};
    use meshless::study::{Suite, records};
    let paths = match suite_paths(names) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let report = report.unwrap_or(Path::new("docs/REPORT.md"));
    let dir = report.parent().unwrap_or(Path::new(".")).join("study");
    let mut stale = 0;
    for path in &paths {
        let suite = match Suite::load(path) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(EXIT_INPUT);
            }
        };
        let file = dir.join(format!("{}.csv", suite.name));
        let recs = match records::read(&file) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("error: {}: {e}", file.display());
                return ExitCode::from(EXIT_FAILED);
            }
        };
        let fresh = freshness(&recs);
        stale += usize::from(matches!(fresh, Freshness::Stale { .. }));
        println!("{}", line(&suite.name, &fresh));
    }
    println!("{stale} stale (records in {})", dir.display());
    if stale == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

#[cfg(feature = "study")]
fn study_command(
    names: &[String],
    out: Option<PathBuf>,
    resume: bool,
    report: Option<&Path>,
    quiet: bool,
    run_time_limit: f64,
) -> ExitCode {
    use meshless::study::{StudyError, run_suites};
    let paths = match suite_paths(names) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let out = out.unwrap_or_else(|| Path::new("out").join("study"));
    let mut command = format!("meshless study {}", names.join(" "));
    if let Some(r) = report {
        command += &format!(" --report {}", r.display());
    }
    let Ok(limit) = std::time::Duration::try_from_secs_f64(run_time_limit) else {
        eprintln!("error: --run-time-limit must be a number of seconds ≥ 0, got {run_time_limit}");
        return ExitCode::from(EXIT_INPUT);
    };
    let options = meshless::study::SuitesOptions {
        resume,
        progress: !quiet,
        run_time_limit: limit,
        long: !names.iter().any(|n| n == "all"),
    };
    match run_suites(&paths, &out, &options, report, &command) {
        Ok(done) => {
            for (suite, o) in &done {
                let failed = o.records.iter().filter(|r| r.status.name() != "ok").count();
                println!(
                    "{}: {} runs ({} done now, {} kept from an earlier study, {} not ok); results in {}",
                    suite.name,
                    o.records.len(),
                    o.executed,
                    o.skipped,
                    failed,
                    out.join(&suite.name).display()
                );
            }
            if let Some(r) = report {
                println!("report: {}", r.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(match e {
                StudyError::Suite(_) => EXIT_INPUT,
                StudyError::Io(_) => EXIT_FAILED,
            })
        }
    }
}

/// The folders case and suite names are looked up in, in order: `./cases` where the
/// working directory has one, then the shipped cases (so a local folder adds to the
/// shipped cases, and a name in both is the local one).
fn case_dirs() -> Vec<PathBuf> {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let local = PathBuf::from("cases");
    let same = |a: &Path, b: &Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(a), Ok(b)) if a == b);
    let mut dirs = Vec::new();
    if local.is_dir() && !same(&local, &shipped) {
        dirs.push(local);
    }
    dirs.push(shipped);
    dirs
}

/// The names (file stems) of the `.toml` files in `dir`, sorted.
fn toml_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| {
                let path = e.ok()?.path();
                (path.extension()? == "toml")
                    .then(|| path.file_stem()?.to_str().map(String::from))?
            })
            .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// The edit distance (insertions, deletions, substitutions) between two names.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let next = (diagonal + usize::from(ca != cb))
                .min(row[j] + 1)
                .min(row[j + 1] + 1);
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// Up to three of `names` nearest `name` (within a third of its length, or containing
/// it), nearest first.
fn nearest_names(name: &str, names: &[String]) -> Vec<String> {
    let mut near: Vec<(usize, &String)> = names
        .iter()
        .map(|n| (edit_distance(name, n), n))
        .filter(|(d, n)| *d <= name.len().div_ceil(3) || n.contains(name))
        .collect();
    near.sort();
    near.dedup_by(|a, b| a.1 == b.1);
    near.into_iter().take(3).map(|(_, n)| n.clone()).collect()
}

/// A path as given, or a case by name from [`case_dirs`]; Err names the folders looked in
/// and the nearest names.
fn resolve(case: &str) -> Result<PathBuf, String> {
    let given = PathBuf::from(case);
    if given.exists() || case.ends_with(".toml") {
        return Ok(given);
    }
    let dirs = case_dirs();
    if let Some(path) = dirs
        .iter()
        .map(|d| d.join(format!("{case}.toml")))
        .find(|p| p.is_file())
    {
        return Ok(path);
    }
    let names: Vec<String> = dirs.iter().flat_map(|d| toml_names(d)).collect();
    let near = nearest_names(case, &names);
    let looked = dirs
        .iter()
        .map(|d| d.display().to_string())
        .collect::<Vec<_>>()
        .join(" and ");
    Err(format!(
        "no case `{case}`: it is not a file, and neither {looked} holds `{case}.toml`{}; \
         `meshless list` lists the cases",
        if near.is_empty() {
            String::new()
        } else {
            format!(" (did you mean {}?)", near.join(", "))
        }
    ))
}

/// [`resolve`], its error said on stderr with exit code 2.
fn resolved(case: &str) -> Result<PathBuf, ExitCode> {
    resolve(case).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(EXIT_INPUT)
    })
}

/// Where and what a run writes.
struct Output {
    /// The output folder (default: out/<case name>).
    dir: Option<PathBuf>,
    /// Continue from the checkpoint in `dir`.
    resume: bool,
    frames: bool,
    quiet: bool,
    /// Print the pass report of a GPU run.
    profile: bool,
}

/// The process's own environment variable `k`.
fn env(k: &str) -> Option<String> {
    std::env::var(k).ok()
}

/// The ranks a run is on.
enum Ranks {
    /// This process alone.
    One,
    /// N threads of this process, each a rank.
    Threads(usize),
    /// This process as one rank of the processes an MPI launcher started.
    #[cfg(feature = "mpi")]
    Mpi(meshless::distributed::mpi::World),
}

fn run_command(
    case: &str,
    backend: Backend,
    output: Output,
    set: &[String],
    limits: Limits,
    ranks: Ranks,
) -> ExitCode {
    // Rank 0 alone speaks for a run on several processes.
    #[cfg(feature = "mpi")]
    let speaks = !matches!(&ranks, Ranks::Mpi(w) if meshless::distributed::Comm::rank(w) > 0);
    #[cfg(not(feature = "mpi"))]
    let speaks = true;
    let case =
        match resolve(case).and_then(|path| Scene::load(&path, set).map_err(|e| e.to_string())) {
            Ok(c) => {
                if speaks {
                    show_notes(&c);
                }
                c
            }
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(EXIT_INPUT);
            }
        };
    let opts = RunOptions {
        out_dir: output
            .dir
            .unwrap_or_else(|| Path::new("out").join(&case.name)),
        backend,
        progress: ProgressDisplay::for_stderr(output.quiet),
        frames: output.frames,
        stop: Some(stop_on_signal()),
        limits,
        resume: output.resume,
        profile: output.profile,
    };
    let result = match ranks {
        Ranks::One => run(&case, &opts).map(Some),
        Ranks::Threads(n) => run_on_threads(&case, &opts, n).map(Some),
        #[cfg(feature = "mpi")]
        Ranks::Mpi(world) => {
            use meshless::distributed::Comm;
            let (rank, size) = (world.rank(), world.size());
            let result = run_rank(&case, &opts, Arc::new(world), ranks_on_node(env, size));
            if rank > 0 {
                // Rank 0 reports the run; another rank, only what stopped it.
                return match result {
                    Ok(_) => ExitCode::SUCCESS,
                    Err(e) => {
                        eprintln!("error (rank {rank}): {e}");
                        exit_code(&e)
                    }
                };
            }
            result
        }
    };
    match result.map(|s| s.expect("rank 0 and a run on one rank return the summary")) {
        Ok(s) => {
            let halo = s.halo_seconds.map_or(String::new(), |h| {
                let share = 100.0 * h / s.wall_seconds.max(1e-12);
                format!(", {share:.0} % of it in the exchanges between ranks")
            });
            println!(
                "{} on {}: {} particles, {} steps to t = {:e} s in {:.2} s ({:.3e} particle-steps/s{halo}); outputs in {}",
                s.case,
                s.backend,
                s.particles,
                s.steps,
                s.end_time,
                s.wall_seconds,
                s.particle_steps_per_second,
                opts.out_dir.display()
            );
            match &s.passes {
                Some(report) => println!("{report}"),
                None if opts.profile => {
                    println!(
                        "note: --profile reports the passes of a GPU run; this one ran on the CPU"
                    )
                }
                None => {}
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            exit_code(&e)
        }
    }
}

/// The exit code of a failed run or measurement ([`RunError::exit_code`]).
fn exit_code(e: &RunError) -> ExitCode {
    ExitCode::from(e.exit_code())
}

/// A flag that SIGINT (Ctrl-C) or SIGTERM sets, so that a run ends after its current
/// batch of steps with an "interrupted" summary. Without a handler (one is already
/// installed) the signal ends the process as usual, and the summary says "running".
fn stop_on_signal() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)) {
        eprintln!(
            "warning: no SIGINT/SIGTERM handler ({e}): an interrupted run keeps a 'running' summary"
        );
    }
    stop
}

fn list() -> ExitCode {
    for dir in case_dirs() {
        println!("Cases ({}):", dir.display());
        for name in toml_names(&dir) {
            match Scene::load(&dir.join(format!("{name}.toml")), &[]) {
                Ok(c) => println!("  {:<24} {}D  {}", c.name, c.dimension, c.description),
                Err(e) => println!("  {name:<24} invalid: {e}"),
            }
        }
    }
    println!("\nMethods:");
    for m in REGISTRY {
        println!("  {:<24} {}", m.name, m.description);
    }
    ExitCode::SUCCESS
}

fn explain_command(case: &str, backend: Backend, set: &[String]) -> ExitCode {
    match resolve(case).and_then(|path| Scene::load(&path, set).map_err(|e| e.to_string())) {
        Ok(c) => {
            show_notes(&c);
            let gpu = match backend {
                Backend::Cpu => false,
                Backend::Gpu => true,
                Backend::Auto => meshless::run::cpu_only(&c).is_none() && has_adapter(),
            };
            println!("{}", meshless::run::explain(&c, gpu));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_INPUT)
        }
    }
}

fn bench_command(cases: &[String], args: &BenchArgs) -> ExitCode {
    use meshless::bench::{BenchRow, measure, resize, triad_bandwidth};
    let BenchArgs {
        backend,
        ref particles,
        steps,
        ref set,
        ref csv,
        roofline,
        max_particles,
    } = *args;
    let limits = Limits {
        max_particles,
        ..Limits::default()
    };
    let mut rows = Vec::new();
    let triad = roofline.then(|| {
        let triad = triad_bandwidth();
        println!(
            "STREAM triad on {} thread(s): {:.2} GB/s\n",
            rayon::current_num_threads(),
            triad * 1e-9
        );
        triad
    });
    let roofline_header = if roofline {
        " bytes/particle-step | GB/s | of triad |"
    } else {
        ""
    };
    println!(
        "| case | backend | particles | steps | set-up [s] | particle-steps/s | rate evaluations/s | neighbours [% of steps] | pairs/particle | ns per pair | device B/particle |{roofline_header}"
    );
    println!(
        "|---|---|---|---|---|---|---|---|---|---|---|{}",
        "---|".repeat(3 * usize::from(roofline))
    );
    let dash = || "–".to_string();
    for name in cases {
        let path = match resolved(name) {
            Ok(path) => path,
            Err(code) => return code,
        };
        for &size in particles {
            let sized = |base: Scene| {
                let gpu = meshless::run::may_use_gpu(&base, backend);
                let sizes = match size {
                    Size::About(n) => resize(&base, n, false)?,
                    Size::Largest => resize(&base, budget::largest(&base, gpu, &limits)?, true)?,
                };
                let all: Vec<String> = set.iter().cloned().chain(sizes).collect();
                let case = Scene::load(&path, &all)?;
                budget::fits(&case, gpu, &limits)?;
                Ok::<_, RunError>(case)
            };
            let result = Scene::load(&path, set)
                .map_err(RunError::from)
                .and_then(sized)
                .and_then(|case| measure(&case, backend, steps));
            match result {
                Ok(r) => {
                    let fractions = triad.map_or(String::new(), |triad| {
                        let bandwidth = r.modelled_bandwidth();
                        format!(
                            " {} | {} | {} |",
                            r.traffic
                                .map_or_else(dash, |t| format!("{:.0}", t.bytes_per_particle)),
                            bandwidth.map_or_else(dash, |b| format!("{:.2}", b * 1e-9)),
                            bandwidth.map_or_else(dash, |b| format!("{:.3}", b / triad))
                        )
                    });
                    println!(
                        "| {} | {} | {} | {} | {:.2} | {:.3e} | {:.3e} | {} | {} | {} | {} |{fractions}",
                        r.case,
                        r.backend,
                        r.particles,
                        r.steps,
                        r.setup_seconds,
                        r.particle_steps_per_second,
                        r.rate_evaluations_per_second,
                        r.neighbour_share
                            .map_or_else(dash, |s| format!("{:.1}", 100.0 * s)),
                        r.pairs_per_particle
                            .map_or_else(dash, |p| format!("{p:.1}")),
                        r.seconds_per_pair()
                            .map_or_else(dash, |s| format!("{:.2}", s * 1e9)),
                        r.device_bytes_per_particle()
                            .map_or_else(dash, |b| format!("{b:.0}")),
                    );
                    rows.push(r);
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    return exit_code(&e);
                }
            }
        }
    }
    for r in &rows {
        if let Some(report) = &r.passes {
            println!("\n{}, {} particles. {report}", r.case, r.particles);
        }
    }
    if let Some(path) = csv {
        let text: String = std::iter::once(BenchRow::HEADER.to_string())
            .chain(rows.iter().map(BenchRow::csv))
            .map(|l| l + "\n")
            .collect();
        if let Err(e) = meshless::output::write_atomically(path, |w| {
            std::io::Write::write_all(w, text.as_bytes())
        }) {
            eprintln!("error: {}: {e}", path.display());
            return ExitCode::from(EXIT_FAILED);
        }
    }
    ExitCode::SUCCESS
}

/// Loads each case, estimates its resources against the caps and the machine's memory,
/// and builds its engine (reference configuration, neighbours, corrected gradients, the
/// method's weights; on the GPU its passes and the f32 range of its constants), as `run`
/// does before its first step; exit 2 at the first case that fails.
fn check_command(cases: &[String], backend: Backend, set: &[String], limits: &Limits) -> ExitCode {
    for name in cases {
        let path = match resolved(name) {
            Ok(path) => path,
            Err(code) => return code,
        };
        let built = Scene::load(&path, set)
            .map_err(RunError::from)
            .and_then(|case| {
                show_notes(&case);
                let (estimate, particles) = meshless::run::check(&case, backend, limits)?;
                Ok((case, particles, estimate))
            });
        match built {
            Ok((case, particles, estimate)) => {
                let gpu = meshless::run::may_use_gpu(&case, backend);
                println!(
                    "{}: ok ({}D, {particles} particles, {}; estimated {})",
                    path.display(),
                    case.dimension,
                    case.method.name,
                    estimate.describe(gpu)
                );
                #[cfg(feature = "gpu")]
                if let Some(table) = estimate.device_table().filter(|_| gpu) {
                    print!("device buffers:\n{table}");
                }
            }
            Err(e) => {
                eprintln!("error: {e}");
                return exit_code(&e);
            }
        }
    }
    ExitCode::SUCCESS
}

/// What loading changed in a case (keys dropped by a change of method), and the method's
/// warning for a combination of keys known to give wrong answers.
fn show_notes(case: &Scene) {
    for note in &case.notes {
        eprintln!("note: {}: {note}", case.file.display());
    }
    if let Some(warning) = case.spec.warning(case) {
        eprintln!("warning: {}: {warning}", case.file.display());
    }
}

/// Whether `--backend auto` runs on a GPU.
#[cfg(feature = "gpu")]
fn has_adapter() -> bool {
    meshless::gpu::context::auto_adapter().is_ok()
}

#[cfg(not(feature = "gpu"))]
fn has_adapter() -> bool {
    false
}

#[cfg(not(feature = "gpu"))]
fn info() -> ExitCode {
    println!("This build has no GPU backend (cargo feature `gpu`); runs use the CPU backend.");
    ExitCode::SUCCESS
}

#[cfg(feature = "gpu")]
fn info() -> ExitCode {
    let adapters = meshless::gpu::context::adapters();
    if adapters.is_empty() {
        println!(
            "No GPU adapter found. Runs use the CPU backend; on Linux without a GPU, Mesa's \
             Vulkan CPU driver (Debian: mesa-vulkan-drivers) provides one."
        );
    }
    for (k, a) in adapters.iter().enumerate() {
        println!("[{k}] {a}");
    }
    println!(
        "\nThe first listed is used; set {}=<name substring or backend> to pick another.",
        meshless::gpu::context::ADAPTER_ENV
    );
    ExitCode::SUCCESS
}
