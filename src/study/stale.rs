//! Which suites' records another solver made (`meshless study --stale`): a record carries
//! the build that measured it (its commit and the hash of the solver's sources,
//! `records::this_build`), and a suite whose records were not all made by this solver
//! needs running again before its figures are quoted.

use super::records::{RunRecord, this_solver};
use std::collections::BTreeSet;

/// What the records of one suite say about the solver that made them.
#[derive(Clone, Debug, PartialEq)]
pub enum Freshness {
    /// No records.
    NotRun,
    /// Every record made by this solver: the commits and dates they carry.
    Current {
        commits: Vec<String>,
        dates: Vec<String>,
    },
    /// `stale` of `of` records made by another solver (or before builds were recorded):
    /// the builds they carry (`unrecorded` when empty).
    Stale {
        stale: usize,
        of: usize,
        builds: Vec<String>,
    },
}

/// The distinct values of `f` over `records`, sorted.
fn distinct<'a>(
    records: impl Iterator<Item = &'a RunRecord>,
    f: impl Fn(&'a RunRecord) -> &'a str,
) -> Vec<String> {
    let set: BTreeSet<&str> = records.map(f).collect();
    set.into_iter().map(str::to_string).collect()
}

/// The freshness of `records` against this build's solver.
pub fn freshness(records: &[RunRecord]) -> Freshness {
    if records.is_empty() {
        return Freshness::NotRun;
    }
    let others: Vec<&RunRecord> = records
        .iter()
        .filter(|r| r.solver() != this_solver())
        .collect();
    if others.is_empty() {
        let commits = distinct(records.iter(), RunRecord::build_commit);
        let dates = distinct(records.iter(), |r| r.date.as_str());
        return Freshness::Current { commits, dates };
    }
    let builds = distinct(others.iter().copied(), |r| match r.build.as_str() {
        "" => "unrecorded",
        b => b,
    });
    Freshness::Stale {
        stale: others.len(),
        of: records.len(),
        builds,
    }
}

/// Which builds measured `records`, for a report's section: "Measured by commit C on D."
/// with every distinct commit and date, or that they predate the recorded builds.
pub fn provenance(records: &[RunRecord]) -> String {
    let built: Vec<&RunRecord> = records.iter().filter(|r| !r.build.is_empty()).collect();
    let unrecorded = records.len() - built.len();
    let mut s = match built.is_empty() {
        true => String::from("Measured before records carried their build"),
        false => format!(
            "Measured by commit {} on {}",
            distinct(built.iter().copied(), RunRecord::build_commit).join(", "),
            distinct(built.iter().copied(), |r| r.date.as_str()).join(", ")
        ),
    };
    if unrecorded > 0 && !built.is_empty() {
        let total = records.len();
        s += &format!(" ({unrecorded} of its {total} runs from before records carried builds)");
    }
    s + " (`meshless study --stale` says whether this build's solver made them)."
}

/// One line of `--stale` for suite `name`.
pub fn line(name: &str, freshness: &Freshness) -> String {
    match freshness {
        Freshness::NotRun => format!("{name}: no records"),
        Freshness::Current { commits, dates } => format!(
            "{name}: current (commit {}, measured {})",
            commits.join(", "),
            dates.join(", ")
        ),
        Freshness::Stale { stale, of, builds } => format!(
            "{name}: stale: {stale} of {of} runs made by another solver (builds: {})",
            builds.join("; ")
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::plot::tests::record;

    #[test]
    fn records_of_another_solver_make_a_suite_stale() {
        // Records made by this build are current; one from another solver hash, or one
        // without a build, makes the suite stale and is named.
        let ours = |sweep: &str| {
            let mut r = record("v", "cpu", sweep, 1.0, 0.1);
            r.build = crate::study::records::this_build();
            r.date = "2026-11-29".into();
            r
        };
        assert_eq!(freshness(&[]), Freshness::NotRun);
        let current = freshness(&[ours("0.1"), ours("0.05")]);
        let Freshness::Current { commits, dates } = &current else {
            panic!("{current:?}");
        };
        assert_eq!(
            (commits.len(), dates.as_slice()),
            (1, &["2026-11-29".to_string()][..])
        );
        let mut other = ours("0.025");
        other.build = "0123456789ab ffffffffffffffff".into();
        let unrecorded = record("v", "cpu", "0.0125", 1.0, 0.1);
        let stale = freshness(&[ours("0.1"), other, unrecorded]);
        assert_eq!(
            stale,
            Freshness::Stale {
                stale: 2,
                of: 3,
                builds: vec!["0123456789ab ffffffffffffffff".into(), "unrecorded".into()],
            }
        );
        assert!(line("s", &stale).starts_with("s: stale: 2 of 3 runs"));
        // A report section names the commits and dates, and counts the unrecorded runs.
        let mut first = ours("0.1");
        first.build = "aaaaaaaaaaaa 0000000000000000".into();
        let text = provenance(&[first, ours("0.05"), record("v", "cpu", "0.025", 1.0, 0.1)]);
        let commit = ours("0.1").build_commit().to_string();
        for part in [
            "Measured by commit ",
            "aaaaaaaaaaaa",
            commit.as_str(),
            " on 2026-11-29 (1 of its 3 runs from before records carried builds)",
        ] {
            assert!(text.contains(part), "{part} in {text}");
        }
        assert!(provenance(&[record("v", "cpu", "0.1", 1.0, 0.1)]).starts_with("Measured before"));
    }
}
