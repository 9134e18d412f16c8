//! Markdown: the table of one suite's runs, the stability map, and the report over suites
//! with its "which method for which job" section drawn from the records alone.

use super::plot::{Metric, metrics, pareto, plots, plottable};
use super::records::{self, RunRecord, Status};
use super::suite::{AnalyticSolution, Choice, InvariantKind, Reference, Suite, SuiteKind};
use super::{history, picture};
use std::fmt::Write;
use std::path::Path;

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
              − W_ext = E(0) (src/balance.rs: the artificial dissipation, the hourglass \
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
    let _ = writeln!(
        s,
        "Case `{}` (suite file `{}`), sweep over `{}`; overrides of every run: `{}`.\n",
        case.unwrap_or(&suite.case),
        suite.file.display(),
        suite.sweep.key,
        suite.set.join(" ")
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

/// How much larger than the recommended line's error another's must be to be listed as
/// one to avoid.
const AVOID_ERROR_RATIO: f64 = 10.0;

/// Errors within this factor of the lowest count as equal: the energy drift decides.
const TIE_RATIO: f64 = 1.1;

/// The job a suite's table row and findings name: its `job`, else its name.
fn job_name(suite: &Suite) -> &str {
    if suite.job.is_empty() {
        &suite.name
    } else {
        &suite.job
    }
}

/// "fails at key = v (t = …, quantity)" of a line's first failed run.
fn first_failure(suite: &Suite, recs: &[RunRecord], line: &str) -> Option<String> {
    recs.iter()
        .filter(|r| r.line() == line)
        .find_map(|r| match &r.status {
            Status::Failed { time, quantity, .. } => Some(format!(
                "fails at {} = {} ({}, {})",
                suite.sweep.key,
                short_value(&r.sweep_value),
                failure_time(suite, *time, 2),
                short_quantity(quantity)
            )),
            _ => None,
        })
}

/// A table row: job and suite, what to use, the evidence, what to avoid.
fn row(suite: &Suite, use_: &str, evidence: &str, avoid: Vec<String>) -> String {
    format!(
        "| {} (`{}`) | {use_} | {evidence} | {} |",
        job_name(suite),
        suite.name,
        avoid_cell(avoid)
    )
}

/// The row of a suite in the report's "which method for which job" table: the job, the
/// line (variant and backend) to use with its evidence, and the lines to avoid with why.
/// Accuracy suites recommend the line whose most expensive finished run has the smallest
/// headline error, among the lines that never failed (errors within [`TIE_RATIO`] of it
/// count as equal, and the smaller energy drift decides); they list the lines that failed and
/// those whose error is more than [`AVOID_ERROR_RATIO`] times that. Stability suites
/// recommend the line that stays stable furthest into the sweep (then the cheapest), and
/// list the lines that fail, earliest first; where every line fails at once (a run to
/// failure), the one that lasts longest.
pub fn recommendation(suite: &Suite, recs: &[RunRecord]) -> String {
    match (suite.choice, metrics(suite).first()) {
        (Choice::Sweep, _) => sweep_recommendation(suite, recs),
        (Choice::Variants, Some(m)) if suite.kind == SuiteKind::Accuracy => {
            accuracy_recommendation(suite, recs, m)
        }
        _ => stability_recommendation(suite, recs),
    }
}

fn accuracy_recommendation(suite: &Suite, recs: &[RunRecord], m: &Metric) -> String {
    let key = &suite.sweep.key;
    let pts = plottable(suite, recs, m);
    let all_lines = lines(recs);
    // Each line at its most expensive finished run.
    let longest: Vec<(String, &RunRecord, f64, f64)> = all_lines
        .iter()
        .filter_map(|line| {
            pts.iter()
                .filter(|p| &p.0.line() == line)
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|&(r, t, e)| (line.clone(), r, t, e))
        })
        .collect();
    let never_failed: Vec<_> = longest
        .iter()
        .filter(|l| first_failure(suite, recs, &l.0).is_none())
        .collect();
    let pool = if never_failed.is_empty() {
        longest.iter().collect()
    } else {
        never_failed
    };
    let Some(lowest) = pool.iter().map(|l| l.3).min_by(f64::total_cmp) else {
        return row(suite, "–", "no finished run", Vec::new());
    };
    // Among the errors within TIE_RATIO of the lowest, the smallest energy drift (a run
    // whose energy grew is no recommendation; an unmeasured drift ranks last), then the
    // fastest.
    let drift = |r: &RunRecord| {
        if r.drift_energy.is_finite() {
            r.drift_energy
        } else {
            f64::INFINITY
        }
    };
    let best = pool
        .into_iter()
        .filter(|l| l.3 <= TIE_RATIO * lowest)
        .min_by(|a, b| drift(a.1).total_cmp(&drift(b.1)).then(a.2.total_cmp(&b.2)))
        .expect("the lowest error is in the pool");
    // Failed lines first, then the others over 10× the best error, the largest first.
    let mut avoid: Vec<(f64, String)> = all_lines
        .iter()
        .filter(|line| **line != best.0)
        .filter_map(|line| match first_failure(suite, recs, line) {
            Some(f) => Some((f64::INFINITY, format!("`{line}`: {f}"))),
            None => longest
                .iter()
                .find(|l| &l.0 == line && l.3 > AVOID_ERROR_RATIO * best.3)
                .map(|l| {
                    let why = format!(
                        "`{line}`: {} = {} at {key} = {}, over {AVOID_ERROR_RATIO:.0}× the \
                         recommended's",
                        m.symbol,
                        sci(l.3),
                        short_value(&l.1.sweep_value)
                    );
                    (l.3, why)
                }),
        })
        .collect();
    avoid.sort_by(|a, b| b.0.total_cmp(&a.0));
    let avoid = avoid.into_iter().map(|(_, why)| why).collect();
    let evidence = format!(
        "{} = {} at {key} = {}, {:.3} s",
        m.symbol,
        sci(best.3),
        short_value(&best.1.sweep_value),
        best.2
    );
    row(suite, &format!("`{}`", best.0), &evidence, avoid)
}

fn stability_recommendation(suite: &Suite, recs: &[RunRecord]) -> String {
    let key = &suite.sweep.key;
    let vals = values(recs);
    let all_lines = lines(recs);
    let first_failure = |line: &str| first_failure(suite, recs, line);
    // Per line: how many sweep values it passes before its first failure, and the wall
    // time of its finished runs.
    let reach = |line: &str| {
        let mut stable = 0;
        for v in &vals {
            match recs
                .iter()
                .find(|r| r.line() == line && &r.sweep_value == v)
            {
                Some(r) if r.status == Status::Ok => stable += 1,
                Some(r) if matches!(r.status, Status::Failed { .. }) => break,
                _ => {}
            }
        }
        stable
    };
    let wall = |line: &str| -> f64 {
        recs.iter()
            .filter(|r| r.line() == line && r.status == Status::Ok)
            .map(|r| r.wall_seconds)
            .sum()
    };
    let Some(best) = all_lines
        .iter()
        .filter(|l| reach(l) > 0)
        .max_by(|a, b| reach(a).cmp(&reach(b)).then(wall(b).total_cmp(&wall(a))))
    else {
        return failure_recommendation(suite, recs);
    };
    let last_stable = vals
        .iter()
        .rfind(|v| {
            recs.iter()
                .any(|r| &r.line() == best && &r.sweep_value == *v && r.status == Status::Ok)
        })
        .map(|v| short_value(v))
        .unwrap_or_default();
    let evidence = match first_failure(best) {
        None => format!(
            "stable over the sweep ({key} to {last_stable}), {:.1} s in all",
            wall(best)
        ),
        Some(f) => format!("stable to {key} = {last_stable}, {f}"),
    };
    let mut failing: Vec<&String> = all_lines
        .iter()
        .filter(|l| *l != best && first_failure(l).is_some())
        .collect();
    failing.sort_by_key(|l| reach(l));
    let avoid = failing
        .into_iter()
        .map(|l| format!("`{l}`: {}", first_failure(l).unwrap_or_default()))
        .collect();
    row(suite, &format!("`{best}`"), &evidence, avoid)
}

/// Every line fails at its first sweep value (a run to failure): the one that lasts
/// longest there, the others shortest first.
fn failure_recommendation(suite: &Suite, recs: &[RunRecord]) -> String {
    let vals = values(recs);
    let lasts = |line: &str| {
        recs.iter()
            .find(|r| r.line() == line && Some(&r.sweep_value) == vals.first())
            .and_then(|r| match r.status {
                Status::Failed { time, .. } => Some(time),
                _ => None,
            })
    };
    let all_lines = lines(recs);
    let mut ranked: Vec<(&String, f64)> = all_lines
        .iter()
        .filter_map(|l| lasts(l).map(|t| (l, t)))
        .collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    let Some((best, _)) = ranked.first().copied() else {
        return row(suite, "–", "no finished run", Vec::new());
    };
    let why = |l: &str| first_failure(suite, recs, l).unwrap_or_default();
    let avoid = ranked[1..]
        .iter()
        .rev()
        .map(|(l, _)| format!("`{l}`: {}", why(l)))
        .collect();
    row(
        suite,
        &format!("`{best}`"),
        &format!("lasts longest: {}", why(best)),
        avoid,
    )
}

/// The most entries the "avoid" cell lists before it counts the rest.
const AVOID_SHOWN: usize = 4;

fn avoid_cell(mut avoid: Vec<String>) -> String {
    if avoid.is_empty() {
        return "–".into();
    }
    let more = avoid.len().saturating_sub(AVOID_SHOWN);
    avoid.truncate(AVOID_SHOWN);
    if more > 0 {
        avoid.push(format!("{more} more in the section"));
    }
    cell(&avoid.join("; "))
}

/// The row of a suite whose choice is the sweep value (its variants are scenes): the
/// values stable on every variant, and those that fail on some, with the first failure.
fn sweep_recommendation(suite: &Suite, recs: &[RunRecord]) -> String {
    let key = &suite.sweep.key;
    let all_lines = lines(recs);
    let mut stable = Vec::new();
    let mut avoid = Vec::new();
    for v in values(recs) {
        let runs: Vec<&RunRecord> = recs.iter().filter(|r| r.sweep_value == v).collect();
        let failure = runs.iter().find_map(|r| match &r.status {
            Status::Failed { time, quantity, .. } => Some(format!(
                "{key} = {}: fails on `{}` ({}, {})",
                short_value(&v),
                r.line(),
                failure_time(suite, *time, 2),
                short_quantity(quantity)
            )),
            _ => None,
        });
        match failure {
            Some(f) => avoid.push(f),
            None if runs.len() == all_lines.len()
                && runs.iter().all(|r| r.status == Status::Ok) =>
            {
                stable.push(short_value(&v))
            }
            None => {}
        }
    }
    let compared = suite
        .history
        .as_ref()
        .map(|h| format!("; its section compares them on {}", h.label))
        .unwrap_or_default();
    let use_ = if stable.is_empty() {
        "–".to_string()
    } else {
        format!("{key} = {}", stable.join(", "))
    };
    let evidence = format!("stable on all {} variants{compared}", all_lines.len());
    row(suite, &use_, &evidence, avoid)
}

/// The "which method for which job" table over suites.
pub fn recommendations(entries: &[(Suite, Vec<RunRecord>)]) -> String {
    let mut s =
        String::from("| job (suite) | use | evidence | avoid, and why |\n|---|---|---|---|\n");
    for (suite, recs) in entries {
        let _ = writeln!(s, "{}", recommendation(suite, recs));
    }
    s
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
    let _ = writeln!(s, "## Which method for which job\n");
    let _ = writeln!(
        s,
        "Read off the measurements below, suite by suite (nothing here is extrapolated). \
         Accuracy suites recommend the variant whose most expensive finished run has the \
         smallest headline error among the variants that never failed (errors within \
         {:.0} % of it count as equal, and the smaller energy drift decides), and list the ones \
         that failed, then those whose error is over {AVOID_ERROR_RATIO:.0} times that, the \
         largest first; stability suites recommend the variant stable furthest into the sweep (then the cheapest) and \
         list the ones that fail, earliest first. A row shows at most {AVOID_SHOWN} to avoid and \
         counts the rest, which the suite's section lists. A recommendation holds for the suite's \
         case and the variants it compares; the suite's section below says what its \
         figures mean.\n\n{}",
        (TIE_RATIO - 1.0) * 100.0,
        recommendations(entries)
    );
    let _ = writeln!(s, "In detail:\n");
    for (suite, recs) in entries {
        let _ = writeln!(s, "{}", findings(suite, recs));
    }
    let _ = writeln!(s, "\n## Suites\n");
    for (suite, recs) in entries {
        records::write(&assets.join(format!("{}.csv", suite.name)), recs)?;
        let mut files = plots(suite, recs, &assets)?;
        let suite_dir = out_root.join(&suite.name);
        files.extend(history::write(suite, recs, &suite_dir, &assets)?);
        files.extend(picture::write(suite, recs, &suite_dir, &assets)?);
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
mod tests {
    use super::*;

    fn suite(kind: &str, reference: &str) -> Suite {
        toml::from_str(&format!(
            r#"
name = "s"
job = "the job"
kind = "{kind}"
case = "c"
sweep = {{ key = "spacing", values = [0.1, 0.05] }}
reference = {reference}
[[variant]]
name = "a"
"#
        ))
        .unwrap()
    }

    fn record(variant: &str, sweep: &str, wall: f64, error: f64, status: Status) -> RunRecord {
        RunRecord {
            status,
            ..crate::study::plot::tests::record(variant, "cpu", sweep, wall, error)
        }
    }

    fn failed(time: f64) -> Status {
        Status::Failed {
            time,
            step: 7,
            particle: 3,
            quantity: "det F".into(),
        }
    }

    #[test]
    fn long_numbers_are_shown_to_four_significant_digits() {
        assert_eq!(short_value("0.041666666666666664"), "0.04167");
        assert_eq!(short_value("0.0010666666666666667"), "0.001067");
        assert_eq!(short_value("5.333333333333333e-4"), "5.333e-4");
        assert_eq!(short_value("0.16666666666666666"), "0.1667");
        assert_eq!(short_value("166.66666666666666"), "166.7");
        assert_eq!(short_value("123456.78901"), "1.235e5");
        // Short numbers and words stay as written.
        assert_eq!(short_value("8e-4"), "8e-4");
        assert_eq!(short_value("0.125"), "0.125");
        assert_eq!(short_value("p-F-H-J"), "p-F-H-J");
    }

    #[test]
    fn accuracy_suites_recommend_the_most_accurate_line_that_never_failed() {
        // `b` is the most accurate at its longest run but failed at the coarse spacing;
        // `a` is the best of the others; `e` and `c` are 40 and 20 times worse than `a`;
        // `d` is 5 times worse, within the ratio, so not listed. The failure comes first,
        // then the larger error.
        let s = suite(
            "accuracy",
            r#"{ type = "analytic", solution = "swinging" }"#,
        );
        let recs = vec![
            record("a", "0.1", 1.0, 1e-2, Status::Ok),
            record("a", "0.05", 8.0, 2.5e-3, Status::Ok),
            record("b", "0.1", 0.5, 1.0, failed(0.25)),
            record("b", "0.05", 4.0, 1e-3, Status::Ok),
            record("c", "0.05", 2.0, 5e-2, Status::Ok),
            record("d", "0.05", 3.0, 1.25e-2, Status::Ok),
            record("e", "0.05", 2.0, 1e-1, Status::Ok),
        ];
        let row = recommendation(&s, &recs);
        assert!(
            row.starts_with("| the job (`s`) | `a` | e(v) = 2.50e-3 at spacing = 0.05, 8.000 s |"),
            "{row}"
        );
        assert!(
            row.contains("`b`: fails at spacing = 0.1 (t = 2.50e-1 s, det F)"),
            "{row}"
        );
        assert!(
            row.contains("`c`: e(v) = 5.00e-2 at spacing = 0.05, over 10× the recommended's"),
            "{row}"
        );
        assert!(!row.contains("`d`"), "{row}");
        let at = |line: &str| row.find(&format!("`{line}`:")).expect(line);
        assert!(at("b") < at("e") && at("e") < at("c"), "{row}");
    }

    #[test]
    fn near_equal_errors_are_decided_by_the_energy_drift() {
        // `a` is 5 % more accurate than `b` but its energy grew by 24 %: `b` is used.
        let s = suite(
            "accuracy",
            r#"{ type = "analytic", solution = "swinging" }"#,
        );
        let mut a = record("a", "0.05", 1.0, 2.10e-2, Status::Ok);
        a.drift_energy = 0.24;
        let mut b = record("b", "0.05", 2.0, 2.20e-2, Status::Ok);
        b.drift_energy = 0.04;
        let row = recommendation(&s, &[a, b]);
        assert!(row.starts_with("| the job (`s`) | `b` |"), "{row}");
    }

    #[test]
    fn runs_to_failure_recommend_the_line_that_lasts_longest() {
        let s = suite("stability", r#"{ type = "none" }"#);
        let recs = vec![
            record("a", "0.1", 1.0, f64::NAN, failed(0.5)),
            record("b", "0.1", 1.0, f64::NAN, failed(0.9)),
            record("c", "0.1", 1.0, f64::NAN, failed(0.2)),
        ];
        let row = recommendation(&s, &recs);
        assert_eq!(
            row,
            "| the job (`s`) | `b` | lasts longest: fails at spacing = 0.1 (t = 9.00e-1 s, det \
             F) | `c`: fails at spacing = 0.1 (t = 2.00e-1 s, det F); `a`: fails at spacing = \
             0.1 (t = 5.00e-1 s, det F) |"
        );
    }

    #[test]
    fn a_sweep_choice_recommends_the_values_stable_on_every_variant() {
        // Variants `a` and `b` are scenes; 0.1 is stable on both, 0.05 fails on `b`.
        let mut s = suite("stability", r#"{ type = "none" }"#);
        s.choice = Choice::Sweep;
        let recs = vec![
            record("a", "0.1", 1.0, f64::NAN, Status::Ok),
            record("b", "0.1", 1.0, f64::NAN, Status::Ok),
            record("a", "0.05", 1.0, f64::NAN, Status::Ok),
            record("b", "0.05", 1.0, f64::NAN, failed(0.5)),
        ];
        let row = recommendation(&s, &recs);
        assert_eq!(
            row,
            "| the job (`s`) | spacing = 0.1 | stable on all 2 variants | spacing = 0.05: fails \
             on `b` (t = 5.00e-1 s, det F) |"
        );
    }

    #[test]
    fn stability_suites_recommend_the_line_stable_furthest_then_the_cheapest() {
        // `a` and `b` pass both values, `b` faster; `c` fails at the second value, `e`
        // at the first: listed earliest first.
        let s = suite("stability", r#"{ type = "none" }"#);
        let recs = vec![
            record("a", "0.1", 2.0, f64::NAN, Status::Ok),
            record("a", "0.05", 9.0, f64::NAN, Status::Ok),
            record("b", "0.1", 1.0, f64::NAN, Status::Ok),
            record("b", "0.05", 3.0, f64::NAN, Status::Ok),
            record("c", "0.1", 1.0, f64::NAN, Status::Ok),
            record("c", "0.05", 3.0, f64::NAN, failed(0.5)),
            record("e", "0.1", 1.0, f64::NAN, failed(0.01)),
        ];
        let row = recommendation(&s, &recs);
        assert!(
            row.starts_with(
                "| the job (`s`) | `b` | stable over the sweep (spacing to 0.05), 4.0 s in all |"
            ),
            "{row}"
        );
        let (e, c) = (
            row.find("`e`: fails at spacing = 0.1").unwrap(),
            row.find("`c`: fails at spacing = 0.05").unwrap(),
        );
        assert!(e < c, "earliest failure first: {row}");
        assert!(!row.contains("`a`"), "{row}");
    }
}
