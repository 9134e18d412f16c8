//! The choice behind a suite's advice, by its `[advice]`: the candidate with the smallest
//! error within the budget, the fastest of those within [`TIE_RATIO`] of it (its
//! runner-up, the cheapest within [`NEAR_RATIO`] of its error, a more accurate run over
//! the budget), or the candidate stable furthest into the sweep, then the cheapest.

use super::*;
use crate::study::history::{Curve, value_at};
use crate::study::suite::{Advice, Measure};

/// A suite and what it measured: its records and its history's curves.
pub struct Evidence<'a> {
    pub suite: &'a Suite,
    pub records: &'a [RunRecord],
    /// The `[history]` column of its runs (empty without one).
    pub history: &'a [Curve],
}

/// A candidate within this factor of the advised error is named when it is cheaper.
pub(super) const NEAR_RATIO: f64 = 2.0;

/// Errors within this factor of the smallest count as equal, and the fastest of their runs
/// is advised: a measured error's last few per cent do not separate two methods for a
/// user, while their wall times do.
pub(super) const TIE_RATIO: f64 = 1.05;

/// A cheaper run is named only when it is at least this much faster: below it, the wall
/// times of single runs on a shared machine do not separate them.
pub(super) const MIN_SPEEDUP: f64 = 1.2;

/// How much larger than the advised error a candidate's must be to be listed as one to
/// avoid.
pub(super) const AVOID_ERROR_RATIO: f64 = 10.0;

/// Errors below this are round-off (a conserved quantity kept to the last digits): their
/// ratios mean nothing, so the ratios above are taken of at least this.
pub(super) const ROUND_OFF: f64 = 1e-10;

/// A finished run and its error under the suite's measure.
#[derive(Clone, Copy, Debug)]
pub(super) struct Scored<'a> {
    pub run: &'a RunRecord,
    pub error: f64,
}

/// What the rule of an error measure picks among the candidates.
#[derive(Debug)]
pub(super) struct Ranked<'a> {
    /// The fastest run within the budget whose error is within [`TIE_RATIO`] of the
    /// smallest there.
    pub best: Scored<'a>,
    /// The best run of another candidate within the budget, unless it is one to avoid.
    pub runner_up: Option<Scored<'a>>,
    /// The fastest run within the budget whose error is within [`NEAR_RATIO`] of the
    /// best's, when it is [`MIN_SPEEDUP`] times faster than the best.
    pub cheapest_near: Option<Scored<'a>>,
    /// The most accurate run over the budget, when it beats the best by more than a tie.
    pub over_budget: Option<Scored<'a>>,
    /// Candidates' lines whose best error within the budget is over
    /// [`AVOID_ERROR_RATIO`] times the best's, the largest first.
    pub far: Vec<Scored<'a>>,
}

/// What the stability rule picks: per candidate line, how far into the sweep it stays
/// stable within the budget, and the run there.
#[derive(Debug)]
pub(super) struct Reach<'a> {
    pub line: String,
    /// Sweep values passed before the first failure or run over the budget.
    pub stable: usize,
    /// The run at the furthest of them.
    pub last: Option<&'a RunRecord>,
    /// The candidate's first run past the budget, where it ended its reach.
    pub over_budget: Option<&'a RunRecord>,
}

impl<'a> Evidence<'a> {
    pub fn advice(&self) -> Option<&'a Advice> {
        self.suite.advice.as_ref()
    }

    /// Whether a line (variant, with a backend off the CPU) is one of the candidates.
    pub(super) fn is_candidate(&self, r: &RunRecord) -> bool {
        self.advice()
            .is_some_and(|a| a.candidates.contains(&r.variant))
    }

    /// Lines in the order they first appear, candidates or not.
    pub(super) fn lines(&self) -> Vec<String> {
        lines(self.records)
    }

    /// The history curve of a run.
    fn curve(&self, line: &str, sweep_value: &str) -> Option<&'a Curve> {
        self.history
            .iter()
            .find(|c| c.name == line && c.sweep_value == sweep_value)
    }

    /// The last value of a run's history curve (NaN without one).
    pub(super) fn history_last(&self, r: &RunRecord) -> f64 {
        self.curve(&r.line(), &r.sweep_value)
            .and_then(|c| c.points.last())
            .map_or(f64::NAN, |p| p.1)
    }

    /// The error of a finished run under the suite's measure; NaN where it measures
    /// nothing (no measure, a failed run, a run at the converged reference's own sweep
    /// value, the `against` curve itself).
    pub(super) fn error(&self, r: &RunRecord) -> f64 {
        let Some(advice) = self.advice() else {
            return f64::NAN;
        };
        if r.status != Status::Ok {
            return f64::NAN;
        }
        let at_reference = || {
            self.suite
                .reference_value()
                .is_some_and(|(_, v)| v == r.sweep_value)
        };
        let e = match advice.measure {
            Measure::Velocity if !at_reference() => r.error_velocity,
            Measure::Stress if !at_reference() => r.error_stress,
            Measure::AngularMomentum => r.drift_angular_momentum,
            Measure::Energy => r.drift_energy,
            Measure::History => match &advice.against {
                None => self.history_last(r).abs(),
                Some(v) if *v == r.line() => f64::NAN,
                Some(v) => match (
                    self.curve(&r.line(), &r.sweep_value),
                    self.curve(v, &r.sweep_value),
                ) {
                    (Some(c), Some(reference)) => distance(&c.points, &reference.points),
                    _ => f64::NAN,
                },
            },
            _ => f64::NAN,
        };
        if e.is_finite() && e >= 0.0 {
            e
        } else {
            f64::NAN
        }
    }

    /// The first failed run of a line.
    pub(super) fn first_failure(&self, line: &str) -> Option<&'a RunRecord> {
        self.records
            .iter()
            .find(|r| r.line() == line && matches!(r.status, Status::Failed { .. }))
    }

    /// The rule of an error measure: among the runs within the budget of the candidates
    /// that never failed (at the advice's sweep value `at` when it names one), the
    /// smallest error, errors within [`TIE_RATIO`] of it (or all at round-off) counting as
    /// equal, then the faster run.
    pub(super) fn ranked(&self) -> Option<Ranked<'a>> {
        let advice = self.advice()?;
        let at = advice.at.as_ref().map(crate::study::suite::label);
        let scored: Vec<Scored<'a>> = self
            .records
            .iter()
            .filter(|r| self.is_candidate(r) && self.first_failure(&r.line()).is_none())
            .filter(|r| at.as_ref().is_none_or(|v| *v == r.sweep_value))
            .map(|r| Scored {
                run: r,
                error: self.error(r),
            })
            .filter(|s| s.error.is_finite())
            .collect();
        let within: Vec<Scored> = scored
            .iter()
            .filter(|s| s.run.wall_seconds <= advice.budget)
            .copied()
            .collect();
        // Errors at round-off count as equal.
        let floor = |e: f64| e.max(ROUND_OFF);
        let smallest = floor(within.iter().min_by(|a, b| by_error(a, b))?.error);
        let best = *within
            .iter()
            .filter(|s| floor(s.error) <= TIE_RATIO * smallest)
            .min_by(|a, b| wall_order(a, b))?;
        // Each other candidate line at its best run within the budget.
        let mut others: Vec<Scored> = Vec::new();
        for s in &within {
            let line = s.run.line();
            if line == best.run.line() {
                continue;
            }
            match others.iter_mut().find(|o| o.run.line() == line) {
                Some(o) if by_error(s, o).is_lt() => *o = *s,
                Some(_) => {}
                None => others.push(*s),
            }
        }
        others.sort_by(by_error);
        let scale = floor(best.error);
        let cheapest_near = within
            .iter()
            .filter(|s| s.error <= NEAR_RATIO * scale)
            .min_by(|a, b| wall_order(a, b))
            .filter(|s| best.run.wall_seconds >= MIN_SPEEDUP * s.run.wall_seconds)
            .copied();
        let over_budget = scored
            .iter()
            .filter(|s| s.run.wall_seconds > advice.budget)
            .filter(|s| TIE_RATIO * floor(s.error) < smallest)
            .min_by(|a, b| by_error(a, b))
            .copied();
        let mut far: Vec<Scored> = others
            .iter()
            .filter(|o| o.error > AVOID_ERROR_RATIO * scale)
            .copied()
            .collect();
        far.reverse();
        Some(Ranked {
            best,
            runner_up: others
                .first()
                .filter(|o| o.error <= AVOID_ERROR_RATIO * scale)
                .copied(),
            cheapest_near,
            over_budget,
            far,
        })
    }

    /// The stability rule: candidate lines by how far into the sweep they stay stable
    /// within the budget, then by the wall time of their furthest stable run.
    pub(super) fn reach(&self) -> Vec<Reach<'a>> {
        let Some(advice) = self.advice() else {
            return Vec::new();
        };
        let values = values(self.records);
        let mut out: Vec<Reach> = Vec::new();
        for line in self.lines() {
            let runs = || self.records.iter().filter(|r| r.line() == line);
            if !runs().any(|r| self.is_candidate(r)) {
                continue;
            }
            let mut reach = Reach {
                line: line.clone(),
                stable: 0,
                last: None,
                over_budget: None,
            };
            for v in &values {
                match runs().find(|r| &r.sweep_value == v) {
                    Some(r) if r.status == Status::Ok && r.wall_seconds <= advice.budget => {
                        reach.stable += 1;
                        reach.last = Some(r);
                    }
                    Some(r) if r.status == Status::Ok => {
                        reach.over_budget = Some(r);
                        break;
                    }
                    Some(r) if matches!(r.status, Status::Failed { .. }) => break,
                    _ => {}
                }
            }
            out.push(reach);
        }
        let wall = |r: &Reach| r.last.map_or(f64::INFINITY, |r| r.wall_seconds);
        out.sort_by(|a, b| b.stable.cmp(&a.stable).then(wall(a).total_cmp(&wall(b))));
        out
    }
}

fn wall_order(a: &Scored, b: &Scored) -> std::cmp::Ordering {
    a.run.wall_seconds.total_cmp(&b.run.wall_seconds)
}

/// The smaller error first, then the faster run.
fn by_error(a: &Scored, b: &Scored) -> std::cmp::Ordering {
    a.error.total_cmp(&b.error).then(wall_order(a, b))
}

/// The relative L2 distance of a curve from a reference curve, over the curve's points
/// within the reference's x range (the reference linear between its points):
/// sqrt(Σ (y − y_ref(x))²) / sqrt(Σ y_ref(x)²); NaN where they share no x.
pub fn distance(curve: &[(f64, f64)], reference: &[(f64, f64)]) -> f64 {
    let (mut difference, mut norm) = (0.0, 0.0);
    for &(x, y) in curve {
        let y_ref = value_at(reference, x);
        if y_ref.is_finite() {
            difference += (y - y_ref) * (y - y_ref);
            norm += y_ref * y_ref;
        }
    }
    if norm > 0.0 {
        (difference / norm).sqrt()
    } else {
        f64::NAN
    }
}
