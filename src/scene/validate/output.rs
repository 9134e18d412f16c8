//! `[output]` (frames, series, observers, checks), `[[probe]]` and `[[section]]`.

use super::boundary::region;
use super::{Checked, fail, finite, only_in_3d, positive, toml_name, unique_names, vector};
use crate::case::{Case, Observer, OutputSpec, ProbeSpec, Region};
use std::collections::HashSet;

pub(super) fn check(o: &OutputSpec) -> Checked {
    if let Some(v) = o.frame_interval {
        positive("output.frame_interval", v)?;
    }
    if let Some(v) = o.series_interval {
        positive("output.series_interval", v)?;
    }
    let mut seen = HashSet::new();
    for observer in &o.observers {
        if !seen.insert(*observer) {
            return fail(
                "output.observers",
                format!(
                    "\"{}\" is listed more than once; list each observer at most once",
                    toml_name(observer)
                ),
            );
        }
    }
    for (k, check) in o.checks.iter().enumerate() {
        if check.label.trim().is_empty() {
            return fail(
                format!("output.check.{k}.label"),
                "is empty: say in words what the number is",
            );
        }
        if let Some([lo, hi]) = check.expected
            && !(lo.is_finite() && hi.is_finite() && lo <= hi)
        {
            return fail(
                format!("output.check.{k}.expected"),
                format!("[{lo}, {hi}] is not a range: give [lo, hi] with finite lo ≤ hi"),
            );
        }
    }
    Ok(())
}

/// At most one `velocity-error` observer, and its closed form one the case has.
pub(super) fn analytic_observers(case: &Case) -> Checked {
    let mut solutions = case.output.observers.iter().filter_map(|o| match o {
        Observer::VelocityError(s) => Some(*s),
        _ => None,
    });
    let Some(solution) = solutions.next() else {
        return Ok(());
    };
    if solutions.next().is_some() {
        return fail(
            "output.observers",
            "lists `velocity-error` more than once; its column `velocity_error` holds the error \
             against one closed form",
        );
    }
    match crate::diagnostics::analytic::Exact::of(solution, case) {
        Ok(_) => Ok(()),
        Err(message) => fail("output.observers", message),
    }
}

/// At most one `front-oscillation` observer, and its closed form one with jumps that the
/// case has.
pub(super) fn front_observers(case: &Case) -> Checked {
    let solutions: Vec<_> = case
        .output
        .observers
        .iter()
        .filter_map(|o| match o {
            Observer::FrontOscillation(s) => Some(*s),
            _ => None,
        })
        .collect();
    match solutions[..] {
        [] => Ok(()),
        [solution] => match crate::diagnostics::analytic::Exact::of(solution, case) {
            Ok(exact) if exact.front_distance([0.0; 3], 0.0).is_some() => Ok(()),
            Ok(_) => fail(
                "output.observers",
                format!(
                    "`front-oscillation` measures about the jumps of a closed form; \
                     \"{}\" has none: give \"driven-rod\"",
                    toml_name(&solution)
                ),
            ),
            Err(message) => fail("output.observers", message),
        },
        _ => fail(
            "output.observers",
            "lists `front-oscillation` more than once; its columns hold the oscillations \
             about one closed form",
        ),
    }
}

pub(super) fn probes(probes: &[ProbeSpec], dim: usize) -> Checked {
    unique_names(
        probes,
        "probe",
        |probe| &probe.name,
        "probe names become CSV column prefixes",
    )?;
    for (i, probe) in probes.iter().enumerate() {
        let key = format!("probe.{i}");
        vector(&format!("{key}.position"), &probe.position, dim)?;
    }
    Ok(())
}
pub(super) fn sections(case: &Case) -> Checked {
    let dim = case.dim();
    unique_names(
        &case.sections,
        "section",
        |section| &section.name,
        "section names become CSV column prefixes",
    )?;
    for (i, section) in case.sections.iter().enumerate() {
        let key = format!("section.{i}");
        if section.normal.index() >= dim {
            return only_in_3d(
                format!("{key}.normal"),
                dim,
                Some("z"),
                "use \"x\" or \"y\"",
            );
        }
        finite(&format!("{key}.at"), section.at)?;
        region(
            &Region {
                body: section.body.clone(),
                ..Region::default()
            },
            &key,
            &case.bodies,
            dim,
        )?;
    }
    Ok(())
}
