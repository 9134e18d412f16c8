//! `[[boundary]]`: regions, conditions, time laws and the closed-form solutions that
//! conditions take their values from; and `[[mirror]]`, the planes closed by ghost
//! particles.

use super::{Axis, Expression, Solution};
use serde::{Deserialize, Serialize};

/// A boundary condition on a region of the reference configuration.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    /// The prefix of the condition's columns of the `reaction` observer: a support's
    /// reaction, a load's applied force; absent: `boundary<k>` for a support, k its index
    /// among the case's `[[boundary]]` tables, and no column for a load.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub region: Region,
    pub condition: Condition,
}

impl BoundarySpec {
    /// The name of the `k`-th boundary condition of a case.
    pub fn name(&self, k: usize) -> String {
        self.name.clone().unwrap_or_else(|| format!("boundary{k}"))
    }
}

/// Axis-aligned box in reference coordinates (every bound optional), optionally limited
/// to one body. Bounds are inclusive and widened by Δx/4 so that lattice rows lying on a
/// bound are selected despite round-off.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    pub body: Option<String>,
    pub x_min: Option<f64>,
    pub x_max: Option<f64>,
    pub y_min: Option<f64>,
    pub y_max: Option<f64>,
    pub z_min: Option<f64>,
    pub z_max: Option<f64>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Condition {
    /// u = 0, v = 0. A struct variant, without fields, so that a key given to it (such
    /// as `vx`) is refused by `deny_unknown_fields`, as an internally tagged unit variant's
    /// keys are not.
    Fixed {},
    /// Prescribed velocity components (the others stay free): v times the time law
    /// (constant by default) while t < `until` [s] (for the whole run without it), the
    /// components free from `until` on; u follows as ∫ v dt.
    Velocity {
        vx: Option<f64>,
        vy: Option<f64>,
        vz: Option<f64>,
        #[serde(default, skip_serializing_if = "TimeLaw::is_constant")]
        law: TimeLaw,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        until: Option<f64>,
    },
    /// Mirror plane with the given normal: the normal velocity component is zero.
    Symmetry { normal: Axis },
    /// Surface traction t [Pa] on the face the region's particles lie on: each carries
    /// f = ∫ t dA over its patch of the face, Δx wide in each direction along it and
    /// clipped to the named shape (half a patch at the edge of a vertex lattice), times the
    /// time law (constant by default). The force does not depend on a method's masses.
    Traction {
        traction: Vec<f64>,
        #[serde(default, skip_serializing_if = "TimeLaw::is_constant")]
        law: TimeLaw,
    },
    /// A pressure p [Pa] on a circle of the reference configuration (2D): the region's
    /// particles within Δx of the circle on the body's side (`inner`: the body lies
    /// outside it, as round a ring's hole; `outer`: inside) carry p times their share of
    /// the circle's length (half the angle to each neighbour along it, times the radius)
    /// along the normal into the body, times the time law.
    Pressure {
        pressure: f64,
        center: Vec<f64>,
        radius: f64,
        surface: Surface,
        #[serde(default, skip_serializing_if = "TimeLaw::is_constant")]
        law: TimeLaw,
    },
    /// A body force: the acceleration g [m/s²] (gravity, or any other field) on every
    /// particle of the region (`region = {}`: the whole scene; `{ body = "…" }`: one body),
    /// whatever its volume, times the time law (constant by default). Its work enters the
    /// energy balance with the other loads'.
    BodyForce {
        acceleration: Vec<f64>,
        #[serde(default, skip_serializing_if = "TimeLaw::is_constant")]
        law: TimeLaw,
    },
    /// Prescribed displacement components [m] reached at the end time (static path: the
    /// load steps ramp them with the load factor t/end_time); the others stay free.
    Displacement {
        ux: Option<f64>,
        uy: Option<f64>,
        uz: Option<f64>,
    },
    /// The displacement of a closed-form solution at each particle's reference position,
    /// for the listed components (static path, ramped like `displacement`).
    SolutionDisplacement {
        solution: Solution,
        components: Vec<Axis>,
    },
    /// The traction t = σ(X) n of a closed-form solution's stress on a face with outward
    /// unit normal n along an axis: each particle carries ∫ t dA over its patch of the
    /// face, Δx wide in each direction and clipped to the extent of the region's particles
    /// (the tributary patch of a vertex lattice), by 2-point Gauss in each direction of the
    /// face (exact for tractions quadratic in X).
    SolutionTraction {
        solution: Solution,
        normal: Vec<f64>,
    },
}

impl Condition {
    /// Whether the condition is a load that `interaction::TimedLoads` applies: a traction,
    /// pressure or body force with a time law (a constant one is the boundary's).
    pub fn is_timed_load(&self) -> bool {
        match self {
            Self::Traction { law, .. }
            | Self::BodyForce { law, .. }
            | Self::Pressure { law, .. } => !law.is_constant(),
            _ => false,
        }
    }

    /// The size of what the condition's time law multiplies: the largest prescribed
    /// velocity component, the norm of a traction or a body force, a pressure (0 for the
    /// conditions without a law).
    pub fn law_scale(&self) -> f64 {
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        match self {
            Self::Velocity { vx, vy, vz, .. } => [vx, vy, vz]
                .iter()
                .filter_map(|v| v.map(f64::abs))
                .fold(0.0, f64::max),
            Self::Traction { traction, .. } => norm(traction),
            Self::BodyForce { acceleration, .. } => norm(acceleration),
            Self::Pressure { pressure, .. } => pressure.abs(),
            _ => 0.0,
        }
    }

    /// The condition's time law (constant for the conditions without one).
    pub fn law(&self) -> &TimeLaw {
        const CONSTANT: &TimeLaw = &TimeLaw::Constant;
        match self {
            Self::Traction { law, .. }
            | Self::BodyForce { law, .. }
            | Self::Pressure { law, .. }
            | Self::Velocity { law, .. } => law,
            _ => CONSTANT,
        }
    }

    /// Whether the condition prescribes motion (velocity or displacement components), so
    /// that a support holds it with a reaction force.
    pub fn is_support(&self) -> bool {
        matches!(
            self,
            Self::Fixed {}
                | Self::Velocity { .. }
                | Self::Symmetry { .. }
                | Self::Displacement { .. }
                | Self::SolutionDisplacement { .. }
        )
    }

    /// Whether the condition is a prescribed velocity that varies in time: under a time
    /// law, or released at `until`.
    pub fn is_timed_velocity(&self) -> bool {
        match self {
            Self::Velocity { law, until, .. } => !law.is_constant() || until.is_some(),
            _ => false,
        }
    }
}

/// Which side of a pressure's circle the body lies on.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Surface {
    /// The body lies outside the circle (a hole): the pressure pushes outwards.
    Inner,
    /// The body lies inside the circle: the pressure pushes inwards.
    Outer,
}

/// The intervals a time law is sampled at over a run ([`TimeLaw::over_run`]): enough
/// that a law leaving the finite numbers, or f32's range, over 1/4096 of the run is caught.
pub const LAW_SAMPLES: usize = 4096;

/// How a load varies in time: its value at time t is the condition's times law(t). A
/// load is evaluated at the middle of each step and held through its stages (as the
/// contact forces are), on both backends.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum TimeLaw {
    /// 1 at every time.
    #[default]
    Constant,
    /// t/duration until `duration`, 1 after.
    Ramp { duration: f64 },
    /// 1 until `start` (default 0), exp(−(t − start)/tau) after: a load held and then
    /// decaying with the time constant tau [s].
    Exponential {
        tau: f64,
        #[serde(default)]
        start: f64,
    },
    /// Linear between the points [t, value], times non-decreasing; the first value before
    /// the first time and the last after the last. A time given twice is a jump: the
    /// second value holds from that time on (`[[0, 1], [1e-4, 1], [1e-4, 0]]` holds a load
    /// for 0.1 ms and removes it).
    Table { points: Vec<[f64; 2]> },
    /// An expression of the time t [s] and named `constants` ([`Expression`]), e.g.
    /// `value = "sin(2*PI*f*t)"` with `constants = { f = 50.0 }`.
    Expression {
        value: String,
        #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
        constants: std::collections::BTreeMap<String, f64>,
    },
}

impl TimeLaw {
    /// The parsed expression of an `expression` law; None for the other laws.
    pub fn expression(&self) -> Option<Result<Expression, String>> {
        let Self::Expression { value, constants } = self else {
            return None;
        };
        Some(Expression::parse(value, &["t"], "the time [s]", constants))
    }

    pub fn is_constant(&self) -> bool {
        *self == Self::Constant
    }

    /// The law sampled over a run of `span` seconds: (t, law(t)) at [`LAW_SAMPLES`] + 1
    /// evenly spaced times from 0 to `span`.
    pub fn over_run(&self, span: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
        (0..=LAW_SAMPLES).map(move |k| {
            let t = span * k as f64 / LAW_SAMPLES as f64;
            (t, self.at(t))
        })
    }

    /// The law's value at time t.
    pub fn at(&self, t: f64) -> f64 {
        match self {
            Self::Constant => 1.0,
            Self::Ramp { duration } => (t / duration).clamp(0.0, 1.0),
            Self::Exponential { tau, start } => (-(t - start).max(0.0) / tau).exp(),
            Self::Table { points } => {
                // The last point at or before t (right-continuous at a jump).
                match points.iter().rposition(|p| p[0] <= t) {
                    None => points.first().map_or(1.0, |p| p[1]),
                    Some(k) if k + 1 == points.len() => points[k][1],
                    Some(k) => {
                        let ([t0, v0], [t1, v1]) = (points[k], points[k + 1]);
                        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
                    }
                }
            }
            Self::Expression { .. } => self
                .expression()
                .and_then(Result::ok)
                .map_or(f64::NAN, |e| e.at(&[t])),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::TimeLaw;

    #[test]
    fn time_laws_take_their_values() {
        // Exact values (the arithmetic is a division, a clamp or one exponential, ~1e-16).
        assert_eq!(TimeLaw::Constant.at(-1.0), 1.0);
        assert_eq!(TimeLaw::Constant.at(5.0), 1.0);
        let ramp = TimeLaw::Ramp { duration: 2.0 };
        assert_eq!(
            [ramp.at(-1.0), ramp.at(0.5), ramp.at(2.0), ramp.at(7.0)],
            [0.0, 0.25, 1.0, 1.0]
        );
        let decay = TimeLaw::Exponential {
            tau: 1e-4,
            start: 2e-4,
        };
        assert_eq!(decay.at(1e-4), 1.0);
        assert!((decay.at(3e-4) - (-1f64).exp()).abs() < 1e-15);
        assert!((decay.at(4e-4) - (-2f64).exp()).abs() < 1e-15);
        // Held for 0.1 ms, then removed: a jump at a time given twice, the later value
        // from that time on; linear between points; the end values beyond the ends.
        let held = TimeLaw::Table {
            points: vec![[0.0, 1.0], [1e-4, 1.0], [1e-4, 0.0]],
        };
        assert_eq!(
            [held.at(-1.0), held.at(5e-5), held.at(1e-4), held.at(1.0)],
            [1.0, 1.0, 0.0, 0.0]
        );
        let table = TimeLaw::Table {
            points: vec![[1.0, 2.0], [3.0, 6.0], [4.0, 0.0]],
        };
        assert_eq!(
            [table.at(0.0), table.at(2.0), table.at(3.5), table.at(9.0)],
            [2.0, 4.0, 3.0, 0.0]
        );
    }
}
