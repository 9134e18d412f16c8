//! Markdown: the table of one suite's runs, the stability map, and the report over suites
//! with its "which method for which job" section drawn from the records alone.

use super::history::{self, Curve};
use super::plot::{metrics, pareto, plottable};
use super::records::{self, RunRecord, Status};
use super::suite::{AnalyticSolution, Choice, InvariantKind, Reference, Suite, SuiteKind};
use std::fmt::Write;
use std::path::Path;

mod advice;
mod recommend;

use advice::{AVOID_ERROR_RATIO, MIN_SPEEDUP, NEAR_RATIO, ROUND_OFF, TIE_RATIO};
pub use advice::{Evidence, distance};
use recommend::AVOID_SHOWN;
pub use recommend::{Advised, advise, recommendations};

fn sci(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2e}")
    } else {
        "–".into()
    }
}

fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// The failed quantity without its parenthesised detail (`total energy`, `det F`).
fn short_quantity(q: &str) -> &str {
    q.split(" (").next().unwrap_or(q)
}

/// What the errors of a suite are measured against, in words.
pub fn reference_statement(suite: &Suite) -> String {
    match &suite.reference {
        Reference::Analytic {
            solution: AnalyticSolution::Swinging,
        } => "analytic: the swinging plate/cube mode of the case (linear elastodynamics: seed \
              003 §7.1.1's dilatational mode, or seed 002 §5.1's shear mode). Errors are relative L2 norms at the end time, weighted by particle volume, \
              e = sqrt(Σ V |q − q_ex|²)/sqrt(Σ V |q_ex|²), of the velocity v and of the \
              first Piola–Kirchhoff stress P = J σ F⁻ᵀ (all in-plane components)."
            .into(),
        Reference::Analytic {
            solution: AnalyticSolution::RodPulse,
        } => "analytic: d'Alembert's solution of the Gaussian velocity pulse in uniaxial strain \
              (v = ½A[g(s − ct) + g(s + ct)], c = sqrt((λ + 2μ)/ρ0)). Errors are relative L2 \
              norms at the end time, weighted by particle volume, of the velocity v and of the \
              axial first Piola–Kirchhoff stress P_xx (the lateral components depend on the \
              constitutive model's plane-strain closure and are left out)."
            .into(),
        Reference::Analytic {
            solution: AnalyticSolution::FreeRod,
        } => "analytic: d'Alembert's solution of the Gaussian initial velocity in a rod with \
              both ends free (v = ½[ĝ(s − ct) + ĝ(s + ct)], ĝ the even extension of g about \
              both ends, c the bar speed, sqrt(E/ρ0) at ν = 0). Errors are relative L2 norms at \
              the end time, weighted by particle volume, of the velocity v (all components); the \
              stress error is the L2 norm of P_xx − σ_ex over that of ρ0 c |v_ex|, the stress \
              the exact velocity carries as a wave (at the returns σ_ex vanishes)."
            .into(),
        Reference::Analytic {
            solution: AnalyticSolution::DrivenRod,
        } => "analytic: d'Alembert's solution of a rod at rest driven at one end at V for t_p \
              and free after (v = f(s − ct) + H(t − t_p) f(2a − s − ct), f the rectangular pulse \
              of V over c t_p, 2L-periodic, c the bar speed, sqrt(E/ρ0) at ν = 0). Errors are \
              relative L2 norms at the end time, weighted by particle volume, of the velocity v \
              (all components); the stress error is the L2 norm of P_xx − σ_ex over that of \
              ρ0 c |v_ex|."
            .into(),
        Reference::Invariant {
            quantity: InvariantKind::AngularMomentum,
        } => "invariant: the angular momentum H = Σ m x × v must stay at H(0) (no external \
              moment). The error is max |H(t) − H(0)|/|H(0)| over every check of the run (at \
              least every 100 steps and every series sample)."
            .into(),
        Reference::Invariant {
            quantity: InvariantKind::Energy,
        } => "invariant: the energy balance E_kin + E_stored + D_art + W_hg + W_p + E_contact \
              − W_ext = E(0) (src/diagnostics/balance.rs: the artificial dissipation, the hourglass \
              control's, plastic and contact work and the work of supports and loads, each \
              where the engine books it). The error is max |R(t)|/S(t) over every check of \
              the run, R the balance's residue and S = E(0) + E_kin + E_stored + |W_ext|. A \
              term a backend does not book stays in the residue (docs/verification.md), and \
              for the hypoelastic model E_stored is the complementary energy of its \
              linearisation, so there it is approximate."
            .into(),
        Reference::Converged { .. } => {
            let (variant, value) = suite
                .reference_value()
                .map(|(v, x)| (v.to_string(), x))
                .unwrap_or_default();
            format!(
                "**converged reference** (not an exact solution): the final state of variant \
                 `{variant}` at {} = {value}, the finest run of the suite. Every other run's \
                 particles take the reference values of the reference particle nearest to their \
                 reference position (on the nested lattices of one spacing ladder the positions \
                 coincide). Errors are relative L2 norms at the end time, weighted by particle \
                 volume, of the velocity v and the first Piola–Kirchhoff stress P.",
                suite.sweep.key
            )
        }
        Reference::None => {
            "none: stability only. A run is stable when it reaches the end time without the \
             driver's blow-up checks firing (non-finite state, det F ≤ 0, total energy above \
             `run.energy_growth_limit` × (E0 + work of supports and loads))."
                .into()
        }
    }
}

/// The table of every run of a suite.
pub fn runs_table(suite: &Suite, recs: &[RunRecord]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| variant | backend | {} | particles | steps | wall [s] | e(v) | e(P) | ΔH/H0 | R/S | status |",
        suite.sweep.key
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|");
    for r in recs {
        let status = match &r.status {
            Status::Ok if r.reason.is_empty() => "ok".to_string(),
            Status::Ok => format!("ok: {}", r.reason),
            Status::Failed { time, quantity, .. } => {
                format!(
                    "failed at {}: {}",
                    failure_time(suite, *time, 3),
                    short_quantity(quantity)
                )
            }
            Status::Error => format!("not run: {}", r.reason),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.3} | {} | {} | {} | {} | {} |",
            r.variant,
            cell(&r.backend),
            r.sweep_value,
            r.particles,
            r.steps,
            r.wall_seconds,
            sci(r.error_velocity),
            sci(r.error_stress),
            sci(r.drift_angular_momentum),
            sci(r.drift_energy),
            cell(&status)
        );
    }
    s
}

/// Lines (variant and backend) in the order they first appear.
pub(super) fn lines(recs: &[RunRecord]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for r in recs {
        if !out.contains(&r.line()) {
            out.push(r.line());
        }
    }
    out
}

/// Sweep values in the order they first appear.
pub(super) fn values(recs: &[RunRecord]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for r in recs {
        if !out.contains(&r.sweep_value) {
            out.push(r.sweep_value.clone());
        }
    }
    out
}

/// "t = 2.30e0 s", with the suite's failure measure when it has one.
pub(crate) fn failure_time(suite: &Suite, time: f64, digits: usize) -> String {
    let t = format!("t = {time:.digits$e} s");
    match &suite.failure_measure {
        Some(m) => format!("{t}, {}", m.at(time)),
        None => t,
    }
}

/// Stability map: one row per variant (and backend), one column per sweep value.
pub fn stability_map(suite: &Suite, recs: &[RunRecord]) -> String {
    let vals = values(recs);
    let metric = metrics(suite).into_iter().next();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| variant \\ {} | {} |",
        suite.sweep.key,
        vals.join(" | ")
    );
    let _ = writeln!(s, "|---|{}", "---|".repeat(vals.len()));
    for line in lines(recs) {
        let cells: Vec<String> = vals
            .iter()
            .map(|v| {
                match recs
                    .iter()
                    .find(|r| r.line() == line && &r.sweep_value == v)
                {
                    None => String::new(),
                    Some(r) => match &r.status {
                        Status::Ok => match &metric {
                            Some(m) => format!("stable ({} {})", m.symbol, sci((m.value)(r))),
                            None => format!("stable (R/S {})", sci(r.drift_energy)),
                        },
                        Status::Failed { time, quantity, .. } => format!(
                            "**failed** at {}: {}",
                            failure_time(suite, *time, 2),
                            short_quantity(quantity)
                        ),
                        Status::Error => {
                            // The message without the file and key it names.
                            let why = r.reason.rsplit("`: ").next().unwrap_or(&r.reason);
                            let mut short: String = why.chars().take(60).collect();
                            if short.len() < why.len() {
                                short.push('…');
                            }
                            format!("not run: {}", cell(&short))
                        }
                    },
                }
            })
            .collect();
        let _ = writeln!(s, "| {} | {} |", line, cells.join(" | "));
    }
    s
}

/// A suite's section: description, reference, plots, stability map and the table of runs.
/// `plot_links` are paths of the PNG plots relative to the Markdown file.
pub fn suite_section(
    suite: &Suite,
    recs: &[RunRecord],
    plot_links: &[String],
    level: usize,
) -> String {
    let h = "#".repeat(level);
    let mut s = String::new();
    let _ = writeln!(s, "{h} `{}`\n", suite.name);
    if !suite.description.is_empty() {
        let _ = writeln!(s, "{}\n", suite.description.trim());
    }
    let case = recs
        .iter()
        .find(|r| !r.case.is_empty())
        .map(|r| r.case.as_str());
    // The suite file relative to the repository when it is a shipped one.
    let file = suite.file.strip_prefix(env!("CARGO_MANIFEST_DIR"));
    let _ = writeln!(
        s,
        "Case `{}` (suite file `{}`), sweep over `{}`; overrides of every run: `{}`. {}\n",
        case.unwrap_or(&suite.case),
        file.unwrap_or(&suite.file).display(),
        suite.sweep.key,
        suite.set.join(" "),
        super::stale::provenance(recs)
    );
    let _ = writeln!(s, "Variants:\n");
    for v in &suite.variants {
        let _ = writeln!(
            s,
            "- `{}`: {}`{}`{}",
            v.name,
            v.case
                .as_ref()
                .map(|c| format!("case `{c}`, "))
                .unwrap_or_default(),
            v.set.join(" "),
            v.backends
                .as_ref()
                .map(|b| format!(
                    " on {}",
                    b.iter().map(|b| b.as_str()).collect::<Vec<_>>().join(", ")
                ))
                .unwrap_or_default()
        );
    }
    let _ = writeln!(s, "\nReference: {}\n", reference_statement(suite));
    for link in plot_links {
        let svg = link.replace(".png", ".svg");
        let _ = writeln!(s, "![{link}]({link})\n\n([SVG]({svg}))\n");
    }
    if suite.kind == SuiteKind::Stability {
        let _ = writeln!(s, "Stability map:\n\n{}", stability_map(suite, recs));
    }
    let _ = writeln!(s, "Runs:\n\n{}", runs_table(suite, recs));
    s
}

/// A sweep value as a point label or in running text: numbers to four significant
/// digits (`0.04167` for 0.041666666666666664), anything else as it is.
pub fn short_value(v: &str) -> String {
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() && x != 0.0 && v.len() > 8 => {
            let magnitude = x.abs().log10().floor();
            if !(-3.0..5.0).contains(&magnitude) {
                let text = format!("{x:.3e}");
                let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
                let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
                format!("{mantissa}e{exponent}")
            } else {
                let decimals = (3.0 - magnitude).max(0.0) as usize;
                let text = format!("{x:.decimals$}");
                if text.contains('.') {
                    text.trim_end_matches('0').trim_end_matches('.').to_string()
                } else {
                    text
                }
            }
        }
        _ => v.to_string(),
    }
}

/// The job a suite's table row and findings name: its `job`, else its name.
fn job_name(suite: &Suite) -> &str {
    if suite.job.is_empty() {
        &suite.name
    } else {
        &suite.job
    }
}

/// Findings of one suite, drawn from its records only.
pub fn findings(suite: &Suite, recs: &[RunRecord]) -> String {
    let mut s = format!("- **{}** (`{}`): ", job_name(suite), suite.name);
    match suite.kind {
        SuiteKind::Accuracy => {
            let ms = metrics(suite);
            let mut parts = Vec::new();
            for (k, m) in ms.iter().enumerate() {
                let pts = plottable(suite, recs, m);
                if pts.is_empty() {
                    continue;
                }
                let coords: Vec<(f64, f64)> = pts.iter().map(|p| (p.1, p.2)).collect();
                let front = pareto(&coords);
                let show = |i: usize| {
                    let (r, t, e) = pts[i];
                    format!(
                        "`{}` at {} = {} (e = {e:.2e} in {t:.2} s)",
                        r.line(),
                        r.sweep_key,
                        short_value(&r.sweep_value)
                    )
                };
                let best = (0..pts.len())
                    .min_by(|&a, &b| pts[a].2.total_cmp(&pts[b].2))
                    .expect("not empty");
                if k == 0 {
                    parts.push(format!(
                        "on {}, the Pareto front of error against wall time is {}; the most accurate run is {}",
                        m.tag,
                        front.iter().map(|&i| show(i)).collect::<Vec<_>>().join(", "),
                        show(best)
                    ));
                    // Each line at its most expensive finished run.
                    let mut last = Vec::new();
                    for line in lines(recs) {
                        let i = (0..pts.len())
                            .filter(|&i| pts[i].0.line() == line)
                            .max_by(|&a, &b| pts[a].1.total_cmp(&pts[b].1));
                        if let Some(i) = i {
                            last.push(show(i));
                        }
                    }
                    if last.len() > 1 {
                        parts.push(format!(
                            "each variant at its longest run: {}",
                            last.join(", ")
                        ));
                    }
                } else {
                    parts.push(format!(
                        "on {} the most accurate run is {}",
                        m.tag,
                        show(best)
                    ));
                }
            }
            let failed: Vec<String> = recs
                .iter()
                .filter_map(|r| match &r.status {
                    Status::Failed { time, quantity, .. } => Some(format!(
                        "`{}` at {} = {} ({}, {})",
                        r.line(),
                        r.sweep_key,
                        short_value(&r.sweep_value),
                        failure_time(suite, *time, 2),
                        short_quantity(quantity)
                    )),
                    _ => None,
                })
                .collect();
            if !failed.is_empty() {
                parts.push(format!("failed: {}", failed.join(", ")));
            }
            s += &parts.join("; ");
            s += ".";
        }
        SuiteKind::Stability => {
            let vals = values(recs);
            let mut parts = Vec::new();
            for line in lines(recs) {
                let mut last_stable = None;
                let mut first_fail = None;
                for v in &vals {
                    let Some(r) = recs
                        .iter()
                        .find(|r| r.line() == line && &r.sweep_value == v)
                    else {
                        continue;
                    };
                    match &r.status {
                        Status::Ok if first_fail.is_none() => last_stable = Some(short_value(v)),
                        Status::Failed { time, quantity, .. } if first_fail.is_none() => {
                            first_fail = Some(format!(
                                "fails at {} ({}, {})",
                                short_value(v),
                                failure_time(suite, *time, 2),
                                short_quantity(quantity)
                            ))
                        }
                        _ => {}
                    }
                }
                parts.push(match (last_stable, first_fail) {
                    (Some(v), None) => format!("`{line}` stable over the sweep (to {v})"),
                    (Some(v), Some(f)) => format!("`{line}` stable to {v}, {f}"),
                    (None, Some(f)) => format!("`{line}` {f}"),
                    (None, None) => format!("`{line}` not run"),
                });
            }
            let shown: Vec<String> = vals.iter().map(|v| short_value(v)).collect();
            s += &format!("over {} = {}: ", suite.sweep.key, shown.join(", "));
            s += &parts.join("; ");
            s += ".";
        }
    }
    s
}

/// Throughput rows: per suite and line, the largest finished run.
fn throughput(entries: &[(Suite, Vec<RunRecord>)]) -> String {
    let mut s = String::from(
        "| suite | variant | backend | particles | steps | wall [s] | particle-steps/s |\n|---|---|---|---|---|---|---|\n",
    );
    for (suite, recs) in entries {
        for line in lines(recs) {
            let best = recs
                .iter()
                .filter(|r| r.line() == line && r.status == Status::Ok)
                .max_by_key(|r| r.particles as u64 * r.steps);
            if let Some(r) = best {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {:.2} | {:.3e} |",
                    suite.name,
                    r.variant,
                    cell(&r.backend),
                    r.particles,
                    r.steps,
                    r.wall_seconds,
                    r.particles as f64 * r.steps as f64 / r.wall_seconds
                );
            }
        }
    }
    s
}

/// The heading of the report's advice, which [`rewrite_advice`] finds.
pub const ADVICE_HEADING: &str = "## Which method for which job";

/// The report's "which method for which job" section: its rules, each suite's advice,
/// the table, and the findings of every suite; up to the next section.
pub fn advice_section(entries: &[Evidence]) -> String {
    let mut s = format!("{ADVICE_HEADING}\n\n");
    let _ = writeln!(
        s,
        "Read off the measurements below, suite by suite (nothing here is extrapolated), by \
         the rules each suite declares in its `[advice]`: its measure of the job (an error, \
         or stability only), its budget (the wall time of one run that a user would spend, \
         on the machine above) and its candidates (the variants a user may be advised to \
         use; the others are evidence, such as a run without contact, the reference code's \
         force or a stand-in material, and are never advised). With an error measure, the \
         advice is the candidate run with the smallest error within the budget, among the \
         candidates that never failed, errors within {tie:.0} % of it (or all below \
         {ROUND_OFF:e}) counting as equal, the fastest of them advised; it names the \
         runner-up (another candidate's best run within the budget, unless one to avoid), \
         the fastest run within {NEAR_RATIO:.0}× of the advised error when it is at least \
         {MIN_SPEEDUP}× faster, and a more accurate run over the budget. A stability-only suite advises the \
         candidate stable furthest into the sweep within the budget, then the one whose \
         furthest stable run is the fastest. A suite whose choice is its sweep value, or \
         that compares settings of one method, also gives each setting's effect (its error, \
         else the last value of its history, else its wall time; down a spacing ladder, the \
         observed orders). Each advice names the variants to avoid: every one that failed \
         (in a stability-only suite, within the advised one's reach), earliest in the \
         sweep first, then the candidates whose best error within the budget is over \
         {AVOID_ERROR_RATIO:.0}× the advised (errors below the round-off floor count as it); {AVOID_SHOWN} at most, the rest counted. An advice holds for the suite's case and the variants it compares; \
         the suite's section below says what its figures mean.\n\n{}",
        recommendations(entries),
        tie = (TIE_RATIO - 1.0) * 100.0
    );
    let _ = writeln!(s, "In detail:\n");
    for ev in entries {
        let _ = writeln!(s, "{}", findings(ev.suite, ev.records));
    }
    s + "\n"
}

/// Replaces the advice section of the report at `path` (from [`ADVICE_HEADING`] to the
/// next section) with `section`, leaving the rest as it is.
pub fn rewrite_advice(path: &Path, section: &str) -> std::io::Result<()> {
    let text = std::fs::read_to_string(path)?;
    let invalid = |what: &str| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{}: {what}", path.display()),
        )
    };
    let start = text
        .find(&format!("{ADVICE_HEADING}\n"))
        .ok_or_else(|| invalid(&format!("no `{ADVICE_HEADING}` section to rewrite")))?;
    let after = start + ADVICE_HEADING.len();
    let end = text[after..]
        .find("\n## ")
        .map_or(text.len(), |k| after + k + 1);
    let out = format!("{}{section}{}", &text[..start], &text[end..]);
    crate::output::write_atomically(path, |w| std::io::Write::write_all(w, out.as_bytes()))
}

/// Writes the report over suites to `path`, with plots and CSV copies in `study/` beside it;
/// `out_root` holds each suite's results (`<out_root>/<suite name>/`, with the runs' series).
pub fn write_report(
    entries: &[(Suite, Vec<RunRecord>)],
    out_root: &Path,
    path: &Path,
    command: &str,
) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let assets = dir.join("study");
    std::fs::create_dir_all(&assets)?;
    let mut s = String::new();
    let _ = writeln!(s, "# Error against run time, and stability\n");
    let _ = writeln!(
        s,
        "Generated by `{command}` from the suites in `cases/studies/`; every number below is \
         measured by that command (results per suite in [`study/`](study/), one CSV row per \
         run). Do not edit by hand: change a suite and regenerate.\n"
    );
    let mut machines: Vec<&str> = entries
        .iter()
        .flat_map(|(_, r)| r.iter().map(|r| r.machine.as_str()))
        .filter(|m| !m.is_empty())
        .collect();
    machines.sort_unstable();
    machines.dedup();
    let _ = writeln!(
        s,
        "Measured on: {}. Runs of a suite go one after another (each run uses every thread); \
         wall time is engine set-up (neighbours, corrected gradients) plus the time loop, \
         without GPU adapter creation or error evaluation.\n",
        machines.join("; ")
    );
    let curves: Vec<Vec<Curve>> = entries
        .iter()
        .map(|(suite, recs)| match &suite.history {
            Some(h) => history::curves(h, recs, &out_root.join(&suite.name)).0,
            None => Vec::new(),
        })
        .collect();
    let evidence: Vec<Evidence> = entries
        .iter()
        .zip(&curves)
        .map(|((suite, records), history)| Evidence {
            suite,
            records,
            history,
        })
        .collect();
    s += &advice_section(&evidence);
    let _ = writeln!(s, "## Suites\n");
    for (suite, recs) in entries {
        records::write(&assets.join(format!("{}.csv", suite.name)), recs)?;
        let files = super::figures(suite, recs, &out_root.join(&suite.name), &assets)?;
        let links: Vec<String> = files
            .iter()
            .filter(|f| f.extension().is_some_and(|e| e == "png"))
            .filter_map(|f| f.file_name())
            .map(|n| format!("study/{}", n.to_string_lossy()))
            .collect();
        s += &suite_section(suite, recs, &links, 3);
        s += &history::table(suite, recs, &out_root.join(&suite.name), "study/");
        let _ = writeln!(s, "Results: [`study/{0}.csv`](study/{0}.csv)\n", suite.name);
    }
    let _ = writeln!(
        s,
        "## Throughput\n\nThe largest finished run of every variant (particle-steps/s = \
         particles × steps / wall time, set-up included):\n\n{}",
        throughput(entries)
    );
    let _ = writeln!(
        s,
        "## Failure reasons\n\nA run fails at the first of: a non-finite state or det F ≤ 0 \
         (every evaluation); total energy above `run.energy_growth_limit` × (E(0) + work of \
         supports and loads); a particle's hourglass indicator η = Σ W|F X_ab − x_ab| / \
         Σ W|X_ab| above `run.hourglass_limit` (at every series sample), i.e. its bonds \
         misplaced, on average, by that fraction of their length relative to its own F; a CFL \
         step below `run.min_step_ratio` × the first step. Which limits a suite sets is in \
         its overrides.\n"
    );
    let emulated: Vec<&str> = entries
        .iter()
        .flat_map(|(_, r)| r.iter().map(|r| r.backend.as_str()))
        .filter(|b| b.starts_with("gpu") && b.ends_with(", Cpu)"))
        .collect();
    if let Some(adapter) = emulated.first() {
        let _ = writeln!(
            s,
            "## Not measured here\n\n- GPU speed: the GPU runs above used `{adapter}`, a CPU \
             emulation of a GPU; their wall times check the GPU path's results, not its \
             speed. `meshless bench` measures a hardware adapter."
        );
    }
    crate::output::write_atomically(path, |w| std::io::Write::write_all(w, s.as_bytes()))
}

#[cfg(test)]
mod tests;
