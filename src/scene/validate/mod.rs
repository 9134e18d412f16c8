//! Semantic checks of a parsed case: everything serde cannot see (ranges, vector
//! lengths, shapes that exist only in one dimension, references between tables).
//!
//! Checks run in a fixed order (top level, material, method, bodies, boundaries, run,
//! output, the closed forms of the observers, probes) and the first problem found is reported, so the same bad file always
//! gives the same message.
//!
//! One file per section of the case: `material`, `method`, `body` (with the initial
//! fields in `fields`), `boundary`, `mirror`, `contact`, `run` and `output` (with the
//! probes and sections); this file holds the order and the checks they share.

mod body;
mod boundary;
mod contact;
mod fields;
mod material;
mod method;
mod mirror;
mod output;
mod run;
#[cfg(test)]
mod tests;

use super::Scene;
use crate::case::Case;
use crate::core::check::{Checked, fail, non_negative, positive, toml_name};
use crate::methods::{Feature, features, quoted, supporting};
use crate::physics::material::MaterialModel;
use std::collections::HashSet;

/// Semantic checks after parsing. Err((key, message)): the dotted key path, e.g. `material.poisson_ratio` or `body.1.geometry.radius` or `boundary.0.condition.vx`, and a message that says what is wrong and what is allowed, quoting the offending value.
pub(super) fn check(scene: &Scene) -> Result<(), (String, String)> {
    let case = &scene.case;
    top_level(case)?;
    let dim = case.dim();
    material::check(&case.material, scene.spec.accepts_incompressible())?;
    material::plane(&case.material, dim)?;
    method::check(&case.method)?;
    method::foreign_keys(scene)?;
    scene.spec.validate(case)?;
    if case.material.model == MaterialModel::VonMisesPlastic {
        feature(
            case,
            Feature::Plasticity,
            "material.model",
            "`von-mises-plastic` carries a plastic history (C_p⁻¹, ε_p)",
            "use an elastic model",
        )?;
    }
    if case.material.model.is_rate_based() && case.material.yield_stress.is_some() {
        feature(
            case,
            Feature::RatePlasticity,
            "material.yield_stress",
            "a yield stress on the rate model is a radial return of S at every step's end",
            "remove it",
        )?;
    }
    body::check(&case.bodies, dim)?;
    body::against_method(case)?;
    boundary::check(case)?;
    mirror::check(case)?;
    contact::check(case)?;
    run::check(&case.run, &case.method)?;
    run::statics(case)?;
    run::tolerance(case)?;
    output::check(&case.output)?;
    output::analytic_observers(case)?;
    output::front_observers(case)?;
    boundary::names(case)?;
    output::probes(&case.probes, dim)?;
    output::sections(case)
}

fn finite(key: &str, value: f64) -> Checked {
    if value.is_finite() {
        Ok(())
    } else {
        fail(key, format!("must be a finite number, got {value:?}"))
    }
}

/// A coordinate vector: one finite entry per dimension.
fn vector(key: &str, value: &[f64], dim: usize) -> Checked {
    if value.len() != dim {
        return fail(
            key,
            format!(
                "must have {dim} components (one per dimension; the case has dimension = {dim}), \
                 got {} in {value:?}",
                value.len()
            ),
        );
    }
    if let Some((k, v)) = value.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return fail(
            key,
            format!("component {k} must be a finite number, got {v:?} in {value:?}"),
        );
    }
    Ok(())
}

/// A direction: a vector of the given length that is not zero.
fn direction(key: &str, value: &[f64], dim: usize) -> Checked {
    vector(key, value, dim)?;
    if value.iter().all(|v| *v == 0.0) {
        return fail(key, format!("must be a non-zero direction, got {value:?}"));
    }
    Ok(())
}

/// Names that become file names or CSV column prefixes.
/// The longest name (of a case, body, probe or section) [characters]: output files are
/// named `<case>_<frame>.vtu`, written through `.<file>.<pid>-<k>.tmp`, and a file name
/// holds 255 bytes on the common file systems.
const NAME_LIMIT: usize = 128;

fn identifier(key: &str, value: &str, what: &str) -> Checked {
    if value.is_empty() {
        return fail(
            key,
            format!(
                "must not be empty; {what}, so use only letters, digits, '-' and '_' \
                 (e.g. \"beam-1\")"
            ),
        );
    }
    if value.len() > NAME_LIMIT {
        return fail(
            key,
            format!(
                "is {} characters long; {what}, and a file name holds 255 bytes with the \
                 frame number and a temporary suffix, so at most {NAME_LIMIT}",
                value.len()
            ),
        );
    }
    if let Some(c) = value
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '-' || *c == '_'))
    {
        return fail(
            key,
            format!(
                "{value:?} contains {c:?}; {what}, so only ASCII letters, digits, '-' and '_' \
                 are allowed"
            ),
        );
    }
    Ok(())
}

/// Checks the names of the tables `kind.0`, `kind.1`, …: identifiers (the names become
/// `becomes`), each unique among them.
fn unique_names<'a, T>(
    items: &'a [T],
    kind: &str,
    name: impl Fn(&'a T) -> &'a str,
    becomes: &str,
) -> Checked {
    let mut seen = HashSet::new();
    for (i, item) in items.iter().enumerate() {
        let (key, name) = (format!("{kind}.{i}.name"), name(item));
        identifier(&key, name, becomes)?;
        if !seen.insert(name) {
            return fail(
                key,
                format!(
                    "{name:?} is already the name of an earlier {kind}; {kind} names must be unique"
                ),
            );
        }
    }
    Ok(())
}

/// Refuses `key` in a case of fewer than three dimensions: it (or its value `value`)
/// exists only in 3D; `advice` says what a 2D case gives instead (empty: nothing to add).
fn only_in_3d(key: String, dim: usize, value: Option<&str>, advice: &str) -> Checked {
    let what = value.map_or(String::new(), |v| format!("\"{v}\" "));
    let mut message = format!("{what}exists only in 3D, but the case has dimension = {dim}");
    if !advice.is_empty() {
        message = format!("{message}; {advice}");
    }
    fail(key, message)
}

fn top_level(case: &Case) -> Checked {
    if !matches!(case.dimension, 2 | 3) {
        return fail(
            "dimension",
            format!("must be 2 (plane strain) or 3, got {}", case.dimension),
        );
    }
    positive("spacing", case.spacing)?;
    identifier(
        "name",
        &case.name,
        "the case name becomes the output file name",
    )
}

/// A scene feature the case's method must run: names the methods that do.
fn feature(case: &Case, feature: Feature, key: &str, what: &str, instead: &str) -> Checked {
    let name = case.method.name;
    if features(name).contains(&feature) {
        return Ok(());
    }
    fail(
        key,
        format!(
            "{what}, which {} run, not `{name}`; {instead} or choose one of those methods",
            quoted(supporting(feature))
        ),
    )
}

/// The named constants of an expression below `key`: names of letters, digits and _ (not
/// first a digit) other than the expression's `variables`, PI and E; finite values.
fn expression_constants(
    key: &str,
    constants: &std::collections::BTreeMap<String, f64>,
    variables: &[&str],
) -> Checked {
    for (name, &c) in constants {
        if variables.contains(&name.as_str())
            || ["PI", "E"].contains(&name.as_str())
            || !name.chars().all(|c| c.is_alphanumeric() || c == '_')
            || name.starts_with(|c: char| c.is_ascii_digit())
        {
            return fail(
                format!("{key}.constants.{name}"),
                format!(
                    "is not a name a constant can have: use letters, digits and _ (not first a digit), other than {}, PI and E",
                    variables.join(", ")
                ),
            );
        }
        finite(&format!("{key}.constants.{name}"), c)?;
    }
    Ok(())
}

/// A valid minimal case (2D box, hypoelastic, TLSPH with a fixed step) for unit tests
/// that break one thing of it.
#[cfg(test)]
pub(crate) fn minimal_case() -> Scene {
    let case: Case<crate::methods::MethodTable> = toml::from_str(
        r#"
        name = "ok"
        dimension = 2
        spacing = 0.1
        [material]
        model = "hypoelastic"
        density = 1000.0
        youngs_modulus = 1e6
        poisson_ratio = 0.3
        [method]
        name = "tlsph"
        h_over_dx = 1.3
        dt = 1e-5
        [[body]]
        name = "b"
        geometry = { shape = "box", min = [0.0, 0.0], max = [1.0, 1.0] }
        [run]
        end_time = 1e-3
        "#,
    )
    .unwrap();
    Scene::new(case)
}
