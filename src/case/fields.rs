//! A body's initial fields: velocity v(X) and displacement u(X).

use super::expression::{self, Expression};
use serde::{Deserialize, Serialize};

/// Initial velocity fields v(X).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum VelocityField {
    Uniform {
        value: Vec<f64>,
    },
    /// v = G X with the velocity gradient G given row by row (G_ij = ∂v_i/∂X_j).
    Linear {
        gradient: Vec<Vec<f64>>,
    },
    /// v = ω × (X − c); in 2D ω is the out-of-plane rate, in 3D `axis` gives its direction.
    RigidRotation {
        omega: f64,
        center: Vec<f64>,
        axis: Option<Vec<f64>>,
    },
    /// Longitudinal pulse v = A d exp(−((X·d − s0)/w)²) along the unit direction d.
    GaussianPulse {
        amplitude: f64,
        direction: Vec<f64>,
        center: f64,
        width: f64,
    },
    /// A swinging mode at t = 0 of its sine form, v = U0 ω Φ(X)
    /// ([`crate::diagnostics::analytic::SwingingMode`]): `dilatational` (the default), seed 003
    /// §7.1.1's plate/cube on [0, 1]^d; `shear`, seed 002 §5.1's plate on [0, 2]².
    Swinging {
        amplitude: f64,
        #[serde(default)]
        mode: crate::diagnostics::analytic::SwingingKind,
    },
    /// The twisting column of seed 003 §7.3.1: v = ω(Y) × X with ω = Ω sin(πY/(2L)) ŷ,
    /// about the Y axis through the origin.
    Twist {
        omega: f64,
        length: f64,
    },
    /// Each component an expression of the reference coordinates x, y (z in 3D) and the
    /// named `constants` ([`Expression`]), e.g. `vy = "0.05*c*sin(PI*x/L)"`.
    Expression {
        vx: String,
        vy: String,
        vz: Option<String>,
        #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
        constants: std::collections::BTreeMap<String, f64>,
    },
}

impl VelocityField {
    /// The component expressions of an `expression` field, parsed for a `dim`-D scene
    /// (with `vz` in 3D only), each with its key below `key`; None for the other fields.
    pub fn expressions(
        &self,
        key: &str,
        dim: usize,
    ) -> Option<Result<Vec<Expression>, (String, String)>> {
        let Self::Expression {
            vx,
            vy,
            vz,
            constants,
        } = self
        else {
            return None;
        };
        let components = [("vx", Some(vx)), ("vy", Some(vy)), ("vz", vz.as_ref())];
        Some(component_expressions(&components, constants, key, dim))
    }
}

/// Initial displacement fields u(X), for the methods whose deformation gradient follows
/// from the displacement (the state starts at x = X + u(X)).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum DisplacementField {
    /// u = G X with G given row by row (G_ij = ∂u_i/∂X_j): the affine pre-deformation
    /// F = I + G.
    Linear { gradient: Vec<Vec<f64>> },
    /// Each component an expression of the reference coordinates x, y (z in 3D) and the
    /// named `constants` ([`Expression`]), e.g. `uy = "d*(x/L)^2"`.
    Expression {
        ux: String,
        uy: String,
        uz: Option<String>,
        #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
        constants: std::collections::BTreeMap<String, f64>,
    },
    /// A swinging mode at t = 0 of its cosine form, u = U0 Φ(X), at rest
    /// ([`crate::diagnostics::analytic::SwingingMode`], seed 003 §E.5): `dilatational` (the default),
    /// seed 003 §7.1.1's plate/cube on [0, 1]^d; `shear`, seed 002 §5.1's plate on [0, 2]².
    Swinging {
        amplitude: f64,
        #[serde(default)]
        mode: crate::diagnostics::analytic::SwingingKind,
    },
}

impl DisplacementField {
    /// u(X) of the field in a `dim`-D scene; `expressions` are its parsed components
    /// ([`Self::expressions`]).
    pub fn at(&self, expressions: &[Expression], x: [f64; 3], dim: usize) -> [f64; 3] {
        match self {
            Self::Linear { gradient } => linear_field(gradient, x),
            Self::Swinging { amplitude, mode } => {
                crate::diagnostics::analytic::SwingingMode::shape_at(*mode, dim, x)
                    .map(|phi| amplitude * phi)
            }
            Self::Expression { .. } => {
                let mut u = [0.0; 3];
                for (u, e) in u.iter_mut().zip(expressions) {
                    *u = e.at(&x);
                }
                u
            }
        }
    }

    /// The component expressions of an `expression` field, parsed for a `dim`-D scene,
    /// each with its key below `key`; empty for the other fields.
    pub fn expressions(&self, key: &str, dim: usize) -> Result<Vec<Expression>, (String, String)> {
        match self {
            Self::Linear { .. } | Self::Swinging { .. } => Ok(Vec::new()),
            Self::Expression {
                ux,
                uy,
                uz,
                constants,
            } => {
                let components = [("ux", Some(ux)), ("uy", Some(uy)), ("uz", uz.as_ref())];
                component_expressions(&components, constants, key, dim)
            }
        }
    }
}

/// G X of a linear field, G given row by row (rows beyond the dimension absent).
pub(crate) fn linear_field(gradient: &[Vec<f64>], x: [f64; 3]) -> [f64; 3] {
    let mut y = [0.0; 3];
    for (y, row) in y.iter_mut().zip(gradient) {
        *y = row.iter().zip(&x).map(|(g, x)| g * x).sum();
    }
    y
}

/// The first `dim` of the (name, text) components of a vector field, parsed as
/// expressions of the reference coordinates, each with its key `key.name`; the third is
/// required in 3D.
fn component_expressions(
    components: &[(&str, Option<&String>); 3],
    constants: &std::collections::BTreeMap<String, f64>,
    key: &str,
    dim: usize,
) -> Result<Vec<Expression>, (String, String)> {
    components[..dim]
        .iter()
        .map(|&(name, text)| {
            let key = format!("{key}.{name}");
            let text = text.ok_or_else(|| {
                (
                    key.clone(),
                    "is required in 3D: give the z component as an expression".to_string(),
                )
            })?;
            Expression::parse(
                text,
                &expression::COORDINATES[..dim],
                "the reference coordinates",
                constants,
            )
            .map_err(|e| (key, e))
        })
        .collect()
}
