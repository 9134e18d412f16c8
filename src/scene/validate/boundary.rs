//! `[[boundary]]`: regions, conditions, time laws, closed-form solutions, and the names
//! that become reaction columns.

use super::{
    Checked, expression_constants, fail, finite, identifier, non_negative, only_in_3d, positive,
    toml_name, vector,
};
use crate::case::{
    Axis, BodySpec, BoundarySpec, Case, Condition, Observer, Region, Solution, TimeLaw,
};
use crate::methods::{Feature, quoted, supporting};
use std::collections::HashSet;

/// Every boundary condition, and whether the run (static or dynamic) takes it.
pub(super) fn check(case: &Case) -> Checked {
    let dim = case.dim();
    for (i, boundary) in case.boundaries.iter().enumerate() {
        let span = case.run.end_time;
        self::boundary(boundary, &format!("boundary.{i}"), &case.bodies, dim, span)?;
        if (boundary.condition.is_timed_load() || boundary.condition.is_timed_velocity())
            && case.solves_by_newton()
        {
            return fail(
                format!("boundary.{i}.condition"),
                format!(
                    "the run of `{}` is {}, so it takes no time law and no release \
                     (`until`); give a constant `traction`, `pressure` or `velocity`",
                    case.method.name,
                    if case.is_implicit() {
                        "implicit: its steps hold the loads and prescribed velocities constant"
                    } else {
                        "static: its load steps scale the loads by t/end_time"
                    }
                ),
            );
        }
        if matches!(
            boundary.condition,
            Condition::Displacement { .. } | Condition::SolutionDisplacement { .. }
        ) && !case.is_static()
        {
            return fail(
                format!("boundary.{i}.condition"),
                format!(
                    "a prescribed displacement is a condition of the static path: set \
                     run.solve = \"static\" (which {} run), or prescribe a velocity \
                     (`velocity`) instead",
                    quoted(supporting(Feature::StaticSolve))
                ),
            );
        }
    }
    Ok(())
}

/// One boundary condition of a run that ends at `span` [s].
fn boundary(b: &BoundarySpec, key: &str, bodies: &[BodySpec], dim: usize, span: f64) -> Checked {
    region(&b.region, &format!("{key}.region"), bodies, dim)?;
    let key = format!("{key}.condition");
    match &b.condition {
        Condition::Fixed {} => Ok(()),
        Condition::Velocity {
            vx,
            vy,
            vz,
            law,
            until,
        } => {
            components(
                &key,
                "velocity",
                [("vx", *vx), ("vy", *vy), ("vz", *vz)],
                dim,
            )?;
            if let Some(until) = until {
                positive(&format!("{key}.until"), *until)?;
            }
            time_law(law, &format!("{key}.law"), span)
        }
        Condition::Symmetry { normal } => {
            if dim != 3 && *normal == Axis::Z {
                return only_in_3d(
                    format!("{key}.normal"),
                    dim,
                    Some(&toml_name(normal)),
                    "in 2D the normal is \"x\" or \"y\"",
                );
            }
            Ok(())
        }
        Condition::Traction { traction, law } => {
            vector(&format!("{key}.traction"), traction, dim)?;
            time_law(law, &format!("{key}.law"), span)
        }
        Condition::BodyForce { acceleration, law } => {
            vector(&format!("{key}.acceleration"), acceleration, dim)?;
            time_law(law, &format!("{key}.law"), span)
        }
        Condition::Pressure {
            pressure,
            center,
            radius,
            law,
            ..
        } => {
            if dim != 2 {
                return fail(
                    key,
                    format!(
                        "a pressure acts on a circle of a 2D scene, but the case has dimension \
                         = {dim}; in 3D give a `traction` on a face"
                    ),
                );
            }
            finite(&format!("{key}.pressure"), *pressure)?;
            vector(&format!("{key}.center"), center, dim)?;
            positive(&format!("{key}.radius"), *radius)?;
            time_law(law, &format!("{key}.law"), span)
        }
        Condition::Displacement { ux, uy, uz } => components(
            &key,
            "displacement",
            [("ux", *ux), ("uy", *uy), ("uz", *uz)],
            dim,
        ),
        Condition::SolutionDisplacement {
            solution,
            components,
        } => {
            self::solution(solution, &format!("{key}.solution"), dim)?;
            if components.is_empty() {
                return fail(
                    format!("{key}.components"),
                    "lists no component; give some of \"x\", \"y\" (and \"z\" in 3D)",
                );
            }
            if let Some(z) = components.iter().find(|a| a.index() >= dim) {
                return only_in_3d(format!("{key}.components"), dim, Some(&toml_name(z)), "");
            }
            Ok(())
        }
        Condition::SolutionTraction { solution, normal } => {
            self::solution(solution, &format!("{key}.solution"), dim)?;
            vector(&format!("{key}.normal"), normal, dim)?;
            let axes = normal.iter().filter(|c| **c != 0.0).count();
            if axes != 1 || normal.iter().any(|c| *c != 0.0 && c.abs() != 1.0) {
                return fail(
                    format!("{key}.normal"),
                    format!(
                        "must be the outward unit normal of a face along an axis, such as \
                         [1, 0{}], got {normal:?}",
                        if dim == 3 { ", 0" } else { "" }
                    ),
                );
            }
            Ok(())
        }
    }
}

/// The prescribed components of a `what` condition (`vx`, `vy`, `vz` or `ux`, `uy`,
/// `uz`): at least one, the third in 3D only, each finite.
fn components(key: &str, what: &str, given: [(&str, Option<f64>); 3], dim: usize) -> Checked {
    let names = given.map(|(name, _)| name);
    if given.iter().all(|(_, c)| c.is_none()) {
        let allowed = names[..if dim == 3 { 3 } else { 2 }].join(", ");
        return fail(
            key,
            format!("a {what} condition needs at least one of {allowed}; none is given"),
        );
    }
    if dim != 3
        && let Some(c) = given[2].1
    {
        return only_in_3d(
            format!("{key}.{}", names[2]),
            dim,
            None,
            &format!("got {c:?}; in 2D give {} and/or {}", names[0], names[1]),
        );
    }
    for (name, c) in given {
        if let Some(c) = c {
            finite(&format!("{key}.{name}"), c)?;
        }
    }
    Ok(())
}

/// A time law: its keys ([`time_law_keys`]), and a finite value at every time of the run,
/// [0, `span`], sampled ([`TimeLaw::over_run`]). Its range on the GPU, f32's, is checked
/// where a GPU run starts (`gpu::check_f32_run`).
fn time_law(law: &TimeLaw, key: &str, span: f64) -> Checked {
    time_law_keys(law, key)?;
    if !(span.is_finite() && span > 0.0) {
        return Ok(()); // run.end_time's own check names it
    }
    match law.over_run(span).find(|(_, value)| !value.is_finite()) {
        Some((t, value)) => fail(
            key,
            format!(
                "is {value} at t = {t:.4e} s, within the run (0 to run.end_time = {span:e} \
                 s); a law must be a finite number at every time of the run"
            ),
        ),
        None => Ok(()),
    }
}

/// The keys of a time law: positive durations and time constants, a table of finite
/// points with non-decreasing times, an expression that parses.
fn time_law_keys(law: &TimeLaw, key: &str) -> Checked {
    match law {
        TimeLaw::Constant => Ok(()),
        TimeLaw::Ramp { duration } => positive(&format!("{key}.duration"), *duration),
        TimeLaw::Exponential { tau, start } => {
            positive(&format!("{key}.tau"), *tau)?;
            non_negative(&format!("{key}.start"), *start)
        }
        TimeLaw::Expression { constants, .. } => {
            expression_constants(key, constants, &["t"])?;
            match law.expression() {
                Some(Err(message)) => fail(format!("{key}.value"), message),
                _ => Ok(()),
            }
        }
        TimeLaw::Table { points } => {
            if points.is_empty() {
                return fail(
                    format!("{key}.points"),
                    "is empty; give [time, value] points, e.g. [[0.0, 1.0], [1e-4, 1.0], \
                     [1e-4, 0.0]] (held for 0.1 ms, then removed)",
                );
            }
            if let Some(p) = points
                .iter()
                .find(|p| !(p[0].is_finite() && p[1].is_finite()))
            {
                return fail(
                    format!("{key}.points"),
                    format!("holds {p:?}; every time and value must be a finite number"),
                );
            }
            if let Some(w) = points.windows(2).find(|w| w[1][0] < w[0][0]) {
                return fail(
                    format!("{key}.points"),
                    format!(
                        "goes back in time from {:?} to {:?}; the times must not decrease (a \
                         time given twice is a jump)",
                        w[0], w[1]
                    ),
                );
            }
            Ok(())
        }
    }
}

fn solution(s: &Solution, key: &str, dim: usize) -> Checked {
    match *s {
        Solution::TimoshenkoCantilever {
            load,
            length,
            depth,
        } => {
            finite(&format!("{key}.load"), load)?;
            positive(&format!("{key}.length"), length)?;
            positive(&format!("{key}.depth"), depth)
        }
        Solution::UniaxialStress { stress, axis } => {
            if axis.index() >= dim {
                return only_in_3d(format!("{key}.axis"), dim, Some("z"), "");
            }
            finite(&format!("{key}.stress"), stress)
        }
    }
}

pub(super) fn region(r: &Region, key: &str, bodies: &[BodySpec], dim: usize) -> Checked {
    if let Some(name) = &r.body
        && !bodies.iter().any(|b| &b.name == name)
    {
        let names: Vec<String> = bodies.iter().map(|b| format!("{:?}", b.name)).collect();
        return fail(
            format!("{key}.body"),
            format!(
                "names no body: {name:?}; the bodies are {}",
                names.join(", ")
            ),
        );
    }
    let axes = [
        ("x", r.x_min, r.x_max),
        ("y", r.y_min, r.y_max),
        ("z", r.z_min, r.z_max),
    ];
    for (k, (axis, lo, hi)) in axes.into_iter().enumerate() {
        for (end, bound) in [("min", lo), ("max", hi)] {
            let Some(v) = bound else { continue };
            let bound_key = format!("{key}.{axis}_{end}");
            if k >= dim {
                return only_in_3d(
                    bound_key,
                    dim,
                    None,
                    &format!("got {v:?}; in 2D bound the region with x_min, x_max, y_min, y_max"),
                );
            }
            finite(&bound_key, v)?;
        }
        if let (Some(lo), Some(hi)) = (lo, hi)
            && lo > hi
        {
            return fail(
                format!("{key}.{axis}_max"),
                format!("must be ≥ {axis}_min = {lo:?}, got {hi:?}"),
            );
        }
    }
    Ok(())
}

/// Names of boundary conditions: each a column prefix (a support's reaction columns, a
/// load's applied-force columns) unique among the conditions, the unnamed supports
/// counting as `boundary<k>`; the `reaction` observer needs a support or a named load.
pub(super) fn names(case: &Case) -> Checked {
    let mut seen = HashSet::new();
    let mut columns = false;
    for (i, b) in case.boundaries.iter().enumerate() {
        let key = format!("boundary.{i}.name");
        if let Some(name) = &b.name {
            identifier(&key, name, "boundary names become CSV column prefixes")?;
        }
        if (b.name.is_some() || b.condition.is_support()) && !seen.insert(b.name(i)) {
            return fail(
                key,
                format!(
                    "{:?} is already the name of an earlier boundary condition (unnamed \
                     supports are `boundary<k>`); boundary names must be unique",
                    b.name(i)
                ),
            );
        }
        columns |= b.name.is_some() || b.condition.is_support();
    }
    if case.output.observers.contains(&Observer::Reaction) && !columns {
        return fail(
            "output.observers",
            "lists `reaction`, but no boundary condition prescribes motion (`fixed`, \
             `velocity`, `symmetry`, a displacement) and no load has a `name`; add one or \
             remove the observer",
        );
    }
    Ok(())
}
