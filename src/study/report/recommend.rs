//! The "which method for which job" section: per suite, advice in sentences a user acts
//! on, drawn from its records by the rules of its `[advice]` (`advice`), then a compact
//! table.

use super::advice::{Evidence, ROUND_OFF, Ranked, Reach, Scored, TIE_RATIO};
use super::*;
use crate::study::history::significant;
use crate::study::suite::{Advice, Measure, label};

/// The most lines to avoid a suite's advice names before it counts the rest.
pub(super) const AVOID_SHOWN: usize = 4;

/// A suite's advice: the sentences, and what the table shows of them.
pub struct Advised {
    /// A Markdown list item (with sub-items for the settings' effects).
    pub text: String,
    /// What to use, for the table.
    pub use_: String,
    /// Its evidence, for the table.
    pub evidence: String,
}

/// A time in seconds to about three significant digits ("0.572 s", "9.51 s", "572 s").
fn seconds(t: f64) -> String {
    let decimals = match t {
        t if t >= 100.0 => 0,
        t if t >= 10.0 => 1,
        t if t >= 1.0 => 2,
        _ => 3,
    };
    format!("{t:.decimals$} s")
}

/// A ratio ("5×", "1.8×").
fn times(x: f64) -> String {
    if x >= 10.0 {
        format!("{x:.0}×")
    } else {
        format!("{x:.1}×")
    }
}

/// The short name of a suite's measure in sentences (`e(P)`, `ΔH/H0`, `error`).
fn symbol(measure: Measure) -> &'static str {
    match measure {
        Measure::Velocity => "e(v)",
        Measure::Stress => "e(P)",
        Measure::AngularMomentum => "ΔH/H0",
        Measure::Energy => "R/S",
        Measure::History | Measure::Stability => "error",
    }
}

/// What a suite's measure is, in words.
fn measure_phrase(ev: &Evidence) -> String {
    let Some(a) = ev.advice() else {
        return String::new();
    };
    let label = ev.suite.history.as_ref().map_or("", |h| h.label.as_str());
    match (a.measure, &a.against) {
        (Measure::Velocity, _) => "e(v), the relative L2 error of v at the end".into(),
        (Measure::Stress, _) => "e(P), the relative L2 error of P at the end".into(),
        (Measure::AngularMomentum, _) => "ΔH/H0, the angular momentum's largest drift".into(),
        (Measure::Energy, _) => "R/S, the energy balance's largest residue".into(),
        (Measure::History, None) => format!("|{label}| at the end"),
        (Measure::History, Some(v)) => {
            format!("the relative L2 distance of the {label} curve from `{v}`'s")
        }
        (Measure::Stability, _) => "stability only".into(),
    }
}

/// "`line` at key = value".
fn at(r: &RunRecord) -> String {
    format!(
        "`{}` at {} = {}",
        r.line(),
        r.sweep_key,
        short_value(&r.sweep_value)
    )
}

/// "fails at key = v (t = …, quantity)" of a failed run.
fn failure(suite: &Suite, r: &RunRecord) -> String {
    match &r.status {
        Status::Failed { time, quantity, .. } => format!(
            "fails at {} = {} ({}, {})",
            suite.sweep.key,
            short_value(&r.sweep_value),
            failure_time(suite, *time, 2),
            short_quantity(quantity)
        ),
        _ => String::new(),
    }
}

/// "Avoid `a`: why; `b`: why." with at most [`AVOID_SHOWN`] named.
fn avoid_sentence(mut avoid: Vec<String>) -> String {
    if avoid.is_empty() {
        return String::new();
    }
    let more = avoid.len().saturating_sub(AVOID_SHOWN);
    avoid.truncate(AVOID_SHOWN);
    let rest = match more {
        0 => String::new(),
        n => format!("; and {n} more"),
    };
    format!(" Avoid {}{rest}.", avoid.join("; "))
}

/// Every line that failed, earliest in the sweep first, with its first failure; those
/// whose first failure `keep` accepts.
fn failures(ev: &Evidence, keep: impl Fn(&RunRecord) -> bool) -> Vec<String> {
    let vals = values(ev.records);
    let mut failed: Vec<&RunRecord> = ev
        .lines()
        .iter()
        .filter_map(|l| ev.first_failure(l))
        .filter(|r| keep(r))
        .collect();
    failed.sort_by_key(|r| vals.iter().position(|v| *v == r.sweep_value));
    failed
        .iter()
        .map(|r| format!("`{}`: {}", r.line(), failure(ev.suite, r)))
        .collect()
}

/// The variants a suite shows but never advises.
fn evidence_only(ev: &Evidence) -> String {
    let Some(a) = ev.advice() else {
        return String::new();
    };
    let names: Vec<String> = ev
        .suite
        .variants
        .iter()
        .filter(|v| !a.candidates.contains(&v.name))
        .map(|v| format!("`{}`", v.name))
        .collect();
    match names.is_empty() {
        true => String::new(),
        false => format!(" Evidence only, never advised: {}.", names.join(", ")),
    }
}

/// The advice of a suite with an error measure.
fn error_advice(ev: &Evidence, a: &Advice, ranked: &Ranked) -> Advised {
    let sym = symbol(a.measure);
    let best = ranked.best;
    let show = |s: &Scored| {
        format!(
            "{sym} = {} in {}",
            sci(s.error),
            seconds(s.run.wall_seconds)
        )
    };
    let evidence = format!("{} at {} = {}", show(&best), best.run.sweep_key, {
        short_value(&best.run.sweep_value)
    });
    let compared =
        a.at.as_ref()
            .map(|v| format!(", compared at {} = {}", ev.suite.sweep.key, label(v)))
            .unwrap_or_default();
    let mut s = format!(
        "use {}: {} on this machine (measure: {}{compared}; budget {} a run).",
        at(best.run),
        show(&best),
        measure_phrase(ev),
        seconds(a.budget)
    );
    if let Some(r) = &ranked.runner_up {
        let tie = match r.error < best.error {
            true => format!(
                ", as accurate to {:.0} % but slower",
                (TIE_RATIO - 1.0) * 100.0
            ),
            false => String::new(),
        };
        let _ = write!(s, " Runner-up: {} ({}){tie}.", at(r.run), show(r));
    }
    if let Some(c) = &ranked.cheapest_near {
        let error = match c.error <= ROUND_OFF {
            true => "its error at round-off too".to_string(),
            false => format!("at {} the error", times(c.error / best.error)),
        };
        let _ = write!(
            s,
            " {} is {} faster, {error} ({}).",
            at(c.run),
            times(best.run.wall_seconds / c.run.wall_seconds),
            show(c)
        );
    }
    if let Some(o) = &ranked.over_budget {
        let _ = write!(
            s,
            " {} is more accurate ({sym} = {}) but takes {}, over the budget.",
            at(o.run),
            sci(o.error),
            seconds(o.run.wall_seconds)
        );
    }
    let mut avoid = failures(ev, |_| true);
    avoid.extend(ranked.far.iter().map(|f| {
        let ratio = match best.error <= ROUND_OFF {
            true => "where the advised's is at round-off".to_string(),
            false => format!("{} the advised", times(f.error / best.error)),
        };
        format!(
            "`{}`: {sym} = {} at best within the budget, {ratio}",
            f.run.line(),
            sci(f.error)
        )
    }));
    s += &avoid_sentence(avoid);
    Advised {
        text: s,
        use_: format!("`{}`", best.run.line()),
        evidence,
    }
}

/// "stable to key = v (the whole sweep) in t".
fn reach_phrase(ev: &Evidence, r: &Reach) -> String {
    let vals = values(ev.records);
    let Some(last) = r.last else {
        return "stable at no sweep value".into();
    };
    let whole = match r.stable == vals.len() {
        true => ", the whole sweep",
        false => "",
    };
    format!(
        "stable to {} = {}{whole}, in {} there",
        ev.suite.sweep.key,
        short_value(&last.sweep_value),
        seconds(last.wall_seconds)
    )
}

/// The advice of a stability-only suite.
fn stability_advice(ev: &Evidence, a: &Advice) -> Advised {
    let ranked = ev.reach();
    let head = format!("stability only; budget {} a run", seconds(a.budget));
    let Some(best) = ranked.first().filter(|r| r.stable > 0) else {
        return lasts_longest(ev, &head);
    };
    let evidence = reach_phrase(ev, best);
    let mut s = format!("use `{}` ({head}): {evidence}.", best.line);
    if let Some(r) = ranked.get(1).filter(|r| r.stable > 0) {
        let _ = write!(s, " Runner-up: `{}`, {}.", r.line, reach_phrase(ev, r));
    }
    if let Some(o) = ranked.iter().find_map(|r| r.over_budget) {
        let _ = write!(
            s,
            " {} is stable but takes {}, over the budget.",
            at(o),
            seconds(o.wall_seconds)
        );
    }
    // Lines that fail within the advised one's reach; a failure beyond it is that
    // line's limit, not a reason to avoid it here.
    let vals = values(ev.records);
    let reach = best
        .last
        .and_then(|r| vals.iter().position(|v| *v == r.sweep_value));
    let within = |r: &RunRecord| {
        r.line() != best.line && vals.iter().position(|v| *v == r.sweep_value) <= reach
    };
    s += &avoid_sentence(failures(ev, within));
    Advised {
        text: s,
        use_: format!("`{}`", best.line),
        evidence,
    }
}

/// No candidate finishes its first sweep value: the one that lasts longest there.
fn lasts_longest(ev: &Evidence, head: &str) -> Advised {
    let first = values(ev.records).into_iter().next();
    let time = |r: &RunRecord| match r.status {
        Status::Failed { time, .. } => time,
        _ => f64::NEG_INFINITY,
    };
    let longest = ev
        .records
        .iter()
        .filter(|r| ev.is_candidate(r) && Some(&r.sweep_value) == first.as_ref())
        .filter(|r| ev.advice().is_some_and(|a| r.wall_seconds <= a.budget))
        .filter(|r| matches!(r.status, Status::Failed { .. }))
        .max_by(|a, b| time(a).total_cmp(&time(b)));
    let Some(r) = longest else {
        return Advised {
            text: format!("no candidate finished a run within the budget ({head})."),
            use_: "–".into(),
            evidence: "no finished run".into(),
        };
    };
    let evidence = format!("lasts longest: {}", failure(ev.suite, r));
    let others = failures(ev, |f| f.line() != r.line());
    let s = format!(
        "no candidate completes the run; use `{}` ({head}), which {evidence}.{}",
        r.line(),
        avoid_sentence(others)
    );
    Advised {
        text: s,
        use_: format!("`{}`", r.line()),
        evidence,
    }
}

/// The advice of a suite whose choice is its sweep value: the values stable on every
/// scene, and per candidate scene, the value with the smallest error within the budget.
fn sweep_advice(ev: &Evidence) -> Advised {
    let key = &ev.suite.sweep.key;
    let scenes = ev.lines();
    let stable: Vec<String> = values(ev.records)
        .into_iter()
        .filter(|v| {
            let runs: Vec<&RunRecord> = ev.records.iter().filter(|r| r.sweep_value == *v).collect();
            runs.len() == scenes.len() && runs.iter().all(|r| r.status == Status::Ok)
        })
        .map(|v| short_value(&v))
        .collect();
    let evidence = match stable.is_empty() {
        true => format!("no {key} is stable on every scene"),
        false => format!("{key} = {} stable on every scene", stable.join(", ")),
    };
    let mut s = format!("the choice is the setting `{key}`: {evidence}.");
    if let Some(a) = ev.advice().filter(|a| a.measure != Measure::Stability) {
        let sym = symbol(a.measure);
        for line in &scenes {
            let best = ev
                .records
                .iter()
                .filter(|r| r.line() == *line && ev.is_candidate(r))
                .filter(|r| r.wall_seconds <= a.budget)
                .map(|r| (r, ev.error(r)))
                .filter(|(_, e)| e.is_finite())
                .min_by(|x, y| x.1.total_cmp(&y.1));
            if let Some((r, e)) = best {
                let _ = write!(
                    s,
                    " On `{line}` use {key} = {}: {sym} = {} in {}.",
                    short_value(&r.sweep_value),
                    sci(e),
                    seconds(r.wall_seconds)
                );
            }
        }
        let _ = write!(
            s,
            " (Measure: {}; budget {} a run.)",
            measure_phrase(ev),
            seconds(a.budget)
        );
    }
    s += &avoid_sentence(failures(ev, |_| true));
    Advised {
        text: s,
        use_: format!("`{key}`"),
        evidence,
    }
}

/// What a setting's effect is shown as: the measure's error, else the history's last
/// value, else the wall time.
fn effect_of(ev: &Evidence, r: &RunRecord) -> String {
    if matches!(r.status, Status::Failed { .. }) {
        return failure(ev.suite, r);
    }
    if r.status != Status::Ok {
        return "not run".into();
    }
    let measured = ev.advice().is_some_and(|a| a.measure != Measure::Stability);
    let e = ev.error(r);
    let last = ev.history_last(r);
    let recorded = metrics(ev.suite).first().map(|m| (m.value)(r));
    let value = match recorded {
        _ if measured && e.is_finite() => sci(e),
        _ if last.is_finite() => significant(last),
        Some(x) if x.is_finite() => sci(x),
        _ => seconds(r.wall_seconds),
    };
    format!("{value} at {}", short_value(&r.sweep_value))
}

/// What the settings' effects are measured in: as [`effect_of`] chooses.
fn effect_unit(ev: &Evidence) -> String {
    let measured = ev.advice().is_some_and(|a| a.measure != Measure::Stability);
    match (&ev.suite.history, metrics(ev.suite).first()) {
        _ if measured => measure_phrase(ev),
        (Some(h), _) => format!("{}, the last value of each run", h.label),
        (None, Some(m)) => format!("{}, {}", m.symbol, m.label),
        (None, None) => "the wall time of each run".into(),
    }
}

/// The observed orders of a line's errors down a spacing ladder,
/// ln(e_k/e_k+1)/ln(Δx_k/Δx_k+1) between successive finished runs.
fn orders(ev: &Evidence, line: &str) -> Vec<f64> {
    let points: Vec<(f64, f64)> = ev
        .records
        .iter()
        .filter(|r| r.line() == line)
        .filter_map(|r| {
            let h: f64 = r.sweep_value.parse().ok()?;
            let e = ev.error(r);
            (e > 0.0 && e.is_finite() && h > 0.0).then_some((h, e))
        })
        .collect();
    points
        .windows(2)
        .filter(|w| w[0].0 != w[1].0)
        .map(|w| (w[0].1 / w[1].1).ln() / (w[0].0 / w[1].0).ln())
        .collect()
}

/// Each setting's effect, a sub-item per line: its value at every sweep value, and down a
/// spacing ladder with an error measure, the observed orders.
fn effects(ev: &Evidence) -> String {
    let mut s = format!(
        "\n  Each setting's effect ({} against {}):",
        effect_unit(ev),
        ev.suite.sweep.key
    );
    let ladder = ev.suite.sweep.key == "spacing"
        && ev.advice().is_some_and(|a| a.measure != Measure::Stability);
    for line in ev.lines() {
        let cells: Vec<String> = ev
            .records
            .iter()
            .filter(|r| r.line() == line)
            .map(|r| effect_of(ev, r))
            .collect();
        let _ = write!(s, "\n  - `{line}`: {}", cells.join(", "));
        let p = orders(ev, &line);
        if ladder && !p.is_empty() {
            let shown: Vec<String> = p.iter().map(|p| format!("{p:.2}")).collect();
            let _ = write!(s, "; observed order {}", shown.join(", "));
        }
    }
    s
}

/// The advice of one suite, drawn from its records by the rules of its `[advice]`.
pub fn advise(ev: &Evidence) -> Advised {
    let head = format!("- For **{}** (`{}`) ", job_name(ev.suite), ev.suite.name);
    let Some(a) = ev.advice() else {
        return Advised {
            text: format!("{head}there is no advice: the suite declares no [advice]."),
            use_: "–".into(),
            evidence: "no [advice]".into(),
        };
    };
    let advised = match (ev.suite.choice, a.measure) {
        (Choice::Sweep, _) => sweep_advice(ev),
        (_, Measure::Stability) => stability_advice(ev, a),
        _ => match ev.ranked() {
            Some(r) => error_advice(ev, a, &r),
            None => Advised {
                text: format!(
                    "no candidate has a measured run within the budget (measure: {}; budget \
                     {} a run).",
                    measure_phrase(ev),
                    seconds(a.budget)
                ),
                use_: "–".into(),
                evidence: "no measured run".into(),
            },
        },
    };
    let mut text = head + &advised.text + &evidence_only(ev);
    if ev.suite.choice == Choice::Sweep || a.settings {
        text += &effects(ev);
    }
    Advised { text, ..advised }
}

/// The section's body over suites: each suite's advice, then the compact table.
pub fn recommendations(entries: &[Evidence]) -> String {
    let advised: Vec<Advised> = entries.iter().map(advise).collect();
    let mut s = String::new();
    for a in &advised {
        let _ = writeln!(s, "{}", a.text);
    }
    s += "\n| job (suite) | use | evidence |\n|---|---|---|\n";
    for (ev, a) in entries.iter().zip(&advised) {
        let _ = writeln!(
            s,
            "| {} (`{}`) | {} | {} |",
            job_name(ev.suite),
            ev.suite.name,
            a.use_,
            cell(&a.evidence)
        );
    }
    s
}
