//! A body's initial fields: `initial_velocity` and `initial_displacement`.

use super::{
    Checked, direction, expression_constants, fail, feature, finite, only_in_3d, positive,
    toml_name, vector,
};
use crate::case::{Case, DisplacementField, VelocityField};
use crate::methods::Feature;

/// An initial displacement: a method whose F follows from u, a dynamic run (the static
/// path starts from the reference configuration), and a gradient of d rows of d numbers.
pub(super) fn displacement(case: &Case, field: &DisplacementField, key: &str) -> Checked {
    feature(
        case,
        Feature::InitialDisplacement,
        key,
        "an initial displacement sets the state's u, from which F follows",
        "remove the key",
    )?;
    if case.is_static() {
        return fail(
            key,
            "the static path solves from the reference configuration; remove the key or run \
             dynamically (run.solve = \"dynamic\")",
        );
    }
    if case.material.model.is_rate_based() {
        return fail(
            key,
            format!(
                "`{}` integrates its stress from zero, so the body would start deformed but \
                 unstressed; use a model whose stress follows from F",
                toml_name(&case.material.model)
            ),
        );
    }
    let dim = case.dim();
    match field {
        DisplacementField::Linear { gradient } => gradient_rows(key, gradient, dim, "displacement"),
        DisplacementField::Expression { uz, constants, .. } => {
            if dim != 3 && uz.is_some() {
                return only_in_3d(format!("{key}.uz"), dim, None, "give ux and uy");
            }
            expression_constants(key, constants, &["x", "y", "z"])?;
            field.expressions(key, dim).map(|_| ())
        }
        DisplacementField::Swinging { amplitude, mode } => {
            swinging_mode(&format!("{key}.mode"), *mode, dim)?;
            finite(&format!("{key}.amplitude"), *amplitude)
        }
    }
}

/// A swinging mode that exists in the scene's dimension.
fn swinging_mode(
    key: &str,
    mode: crate::diagnostics::analytic::SwingingKind,
    dim: usize,
) -> Checked {
    if mode == crate::diagnostics::analytic::SwingingKind::Shear && dim != 2 {
        return fail(
            key,
            format!(
                "the `shear` mode is seed 002's plate, 2D only, but the case has dimension = \
                 {dim}; use `dilatational`"
            ),
        );
    }
    Ok(())
}

/// The gradient of a linear `field` (velocity, displacement): d rows of d finite numbers.
fn gradient_rows(key: &str, gradient: &[Vec<f64>], dim: usize, field: &str) -> Checked {
    if gradient.len() != dim {
        return fail(
            format!("{key}.gradient"),
            format!(
                "must have {dim} rows (one per {field} component), got {}",
                gradient.len()
            ),
        );
    }
    for (i, row) in gradient.iter().enumerate() {
        vector(&format!("{key}.gradient.{i}"), row, dim)?;
    }
    Ok(())
}

pub(super) fn velocity(field: &VelocityField, key: &str, dim: usize) -> Checked {
    match field {
        VelocityField::Uniform { value } => vector(&format!("{key}.value"), value, dim),
        VelocityField::Linear { gradient } => gradient_rows(key, gradient, dim, "velocity"),
        VelocityField::RigidRotation {
            omega,
            center,
            axis,
        } => {
            finite(&format!("{key}.omega"), *omega)?;
            vector(&format!("{key}.center"), center, dim)?;
            match (dim, axis) {
                (3, Some(axis)) => direction(&format!("{key}.axis"), axis, 3),
                (3, None) => fail(
                    format!("{key}.axis"),
                    "is required in 3D: give the direction of ω as 3 components, e.g. [0.0, \
                     0.0, 1.0]",
                ),
                (_, Some(axis)) => fail(
                    format!("{key}.axis"),
                    format!(
                        "must be absent in 2D (ω is the out-of-plane rotation rate), got \
                         {axis:?}"
                    ),
                ),
                (_, None) => Ok(()),
            }
        }
        VelocityField::GaussianPulse {
            amplitude,
            direction: d,
            center,
            width,
        } => {
            finite(&format!("{key}.amplitude"), *amplitude)?;
            direction(&format!("{key}.direction"), d, dim)?;
            finite(&format!("{key}.center"), *center)?;
            positive(&format!("{key}.width"), *width)
        }
        VelocityField::Swinging { amplitude, mode } => {
            swinging_mode(&format!("{key}.mode"), *mode, dim)?;
            finite(&format!("{key}.amplitude"), *amplitude)
        }
        VelocityField::Expression { vz, constants, .. } => {
            if dim != 3 && vz.is_some() {
                return only_in_3d(format!("{key}.vz"), dim, None, "give vx and vy");
            }
            expression_constants(key, constants, &["x", "y", "z"])?;
            match field.expressions(key, dim) {
                Some(Err((key, message))) => fail(key, message),
                _ => Ok(()),
            }
        }
        VelocityField::Twist { omega, length } => {
            if dim != 3 {
                return fail(
                    key,
                    "a twist is a 3D field (about the Y axis); use it in 3D",
                );
            }
            finite(&format!("{key}.omega"), *omega)?;
            positive(&format!("{key}.length"), *length)
        }
    }
}
