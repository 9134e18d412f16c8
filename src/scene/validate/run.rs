//! `[run]`: the end time, the limits of a run, and the static path's keys.

use super::{Checked, fail, feature, positive, toml_name};
use crate::case::{Case, MethodKeys, RunSpec, Solve};
use crate::methods::{Feature, features};
use crate::physics::material::MaterialModel;

/// Largest `run.threads`: more than any machine this runs on, few enough that a typo
/// (`run.threads = 20000`) is refused rather than spawning the threads.
const MAX_THREADS: usize = 4096;

pub(super) fn check(r: &RunSpec, m: &MethodKeys) -> Checked {
    positive("run.end_time", r.end_time)?;
    if let Some(interval) = r.checkpoint_interval {
        positive("run.checkpoint_interval", interval)?;
    }
    if let Some(eta) = r.hourglass_limit {
        positive("run.hourglass_limit", eta)?;
    }
    if let Some(ratio) = r.min_step_ratio {
        if !(ratio > 0.0 && ratio < 1.0) {
            return fail(
                "run.min_step_ratio",
                format!("must lie in (0, 1) (a fraction of the first CFL step), got {ratio:?}"),
            );
        }
        if m.cfl.is_none() {
            return fail(
                "run.min_step_ratio",
                "needs method.cfl (a fixed method.dt never shrinks): give method.cfl instead of \
                 method.dt, or remove run.min_step_ratio",
            );
        }
    }
    if let Some(n) = r.threads
        && !(1..=MAX_THREADS).contains(&n)
    {
        return fail(
            "run.threads",
            format!("must be a whole number from 1 to {MAX_THREADS}, got {n}"),
        );
    }
    let limit = r.energy_growth_limit;
    if limit.is_nan() || limit <= 1.0 {
        return fail(
            "run.energy_growth_limit",
            format!(
                "must be > 1 (a factor on the initial energy plus boundary work), got {limit:?}"
            ),
        );
    }
    Ok(())
}

/// `run.solve`: a method that runs it; the static solve of an explicit method, and the
/// implicit solve of any method, take steps of `method.dt`, a state model without history
/// and no contact; `run.hht_alpha` belongs to the implicit solve.
pub(super) fn statics(case: &Case) -> Checked {
    let features = features(case.method.name);
    if let Some(solve @ (Solve::Static | Solve::Implicit)) = case.run.solve {
        feature(
            case,
            Feature::StaticSolve,
            "run.solve",
            match solve {
                Solve::Static => "`static` is the static solve",
                _ => "`implicit` integrates on the static solve's residual and tangent",
            },
            "give run.solve = \"dynamic\"",
        )?;
    }
    if let Some(alpha) = case.run.hht_alpha {
        if !case.is_implicit() {
            return fail(
                "run.hht_alpha",
                "is HHT's α of an implicit run: give run.solve = \"implicit\" or remove it",
            );
        }
        if !(-1.0 / 3.0..=0.0).contains(&alpha) {
            return fail(
                "run.hht_alpha",
                format!(
                    "must lie in [−1/3, 0] (0: Newmark's average acceleration, no numerical \
                     damping; −1/3: the most), got {alpha:?}"
                ),
            );
        }
    }
    let implicit = case.is_implicit();
    if !case.solves_by_newton() || (features.contains(&Feature::StaticDefault) && !implicit) {
        return Ok(());
    }
    if case.method.dt.is_none() || case.method.cfl.is_some() {
        return fail(
            "method.dt",
            if implicit {
                "an implicit run takes time steps of method.dt (it may exceed the explicit \
                 CFL step; end_time/dt steps): give method.dt and no method.cfl"
            } else {
                "a static run takes load steps of method.dt in the pseudo-time of \
                 run.end_time (end_time/dt load steps; dt = end_time for one): give method.dt \
                 and no method.cfl"
            },
        );
    }
    let model = case.material.model;
    if model.is_rate_based() || model == MaterialModel::VonMisesPlastic {
        return fail(
            "material.model",
            format!(
                "a static or implicit run solves for u alone, so the stress must follow from \
                 F without history: use {}, not `{}`",
                MaterialModel::names_where(
                    |m| !m.is_rate_based() && m != MaterialModel::VonMisesPlastic
                ),
                toml_name(&model)
            ),
        );
    }
    if case.contact.is_some() {
        return fail(
            "contact",
            "a static or implicit run has no contact (penalty contact acts through the \
             explicit time step); remove the [contact] table or give run.solve = \"dynamic\"",
        );
    }
    Ok(())
}

/// `run.tolerance`: each key in [ε, 1) (ε the double-precision epsilon, which no f64
/// residual falls below but to zero; 1 would accept the first iterate), on a static run.
pub(super) fn tolerance(case: &Case) -> Checked {
    let t = case.run.tolerance;
    for (key, value) in [
        ("run.tolerance.residual", t.residual),
        ("run.tolerance.increment", t.increment),
    ] {
        let Some(v) = value else { continue };
        if !(v.is_finite() && (crate::case::Tolerance::SMALLEST..1.0).contains(&v)) {
            return fail(
                key,
                format!(
                    "must be a number in [{:e}, 1) (a fraction of the force scale or of |u|; \
                     below the double-precision epsilon no residual can reach it), got {v:?}",
                    crate::case::Tolerance::SMALLEST
                ),
            );
        }
    }
    if !t.is_unset() && !case.solves_by_newton() {
        return fail(
            "run.tolerance",
            "is the Newton tolerance of a static or implicit run, and this run is explicit \
             dynamic (it has no Newton iteration): remove run.tolerance or give run.solve = \
             \"static\" or \"implicit\"",
        );
    }
    Ok(())
}
