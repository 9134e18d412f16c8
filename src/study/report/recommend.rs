//! The "which method for which job" table: one row per suite, drawn from its records.

use super::*;

/// How much larger than the recommended line's error another's must be to be listed as
/// one to avoid.
pub(super) const AVOID_ERROR_RATIO: f64 = 10.0;

/// Errors within this factor of the lowest count as equal: the energy drift decides.
pub(super) const TIE_RATIO: f64 = 1.1;
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
pub(super) const AVOID_SHOWN: usize = 4;

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
