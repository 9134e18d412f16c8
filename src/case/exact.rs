//! An analytic solution resolved for a case: the closed form of [`crate::diagnostics::analytic`] with
//! the case's material, the first body's initial field and, for the rods, its box.

use super::{Case, Condition, DisplacementField, Shape, VelocityField};
use crate::diagnostics::analytic::{
    AnalyticSolution, DrivenEnd, Exact, Rod, SwingingMode, bar_wave_speed,
};
use crate::physics::material::Material;

impl Exact {
    /// The solution `solution` of `case`, or why the case does not have it.
    pub fn of(solution: AnalyticSolution, case: &Case) -> Result<Self, String> {
        let body = case.bodies.first().ok_or("the case has no body")?;
        let material = Material::new(&case.material);
        let dim = case.dim();
        let name = crate::core::check::toml_name(&solution);
        match (solution, &body.initial_velocity) {
            (AnalyticSolution::Swinging, Some(VelocityField::Swinging { amplitude, mode })) => {
                if body.initial_displacement.is_some() {
                    return Err(format!(
                        "the analytic solution \"{name}\" in its sine form starts undeformed; \
                         remove the first body's initial displacement (or its velocity, for \
                         the cosine form)"
                    ));
                }
                Ok(Self::Swinging {
                    mode: SwingingMode::new(*amplitude, &material, dim, *mode),
                    dim,
                })
            }
            (AnalyticSolution::Swinging, None) => match &body.initial_displacement {
                Some(DisplacementField::Swinging { amplitude, mode }) => Ok(Self::Swinging {
                    mode: SwingingMode::new(*amplitude, &material, dim, *mode).cosine(),
                    dim,
                }),
                _ => Err(format!(
                    "the analytic solution \"{name}\" needs the first body to start in a \
                     swinging mode: a `swinging` initial velocity (sine form) or initial \
                     displacement (cosine form)"
                )),
            },
            (
                AnalyticSolution::RodPulse | AnalyticSolution::FreeRod,
                Some(VelocityField::GaussianPulse {
                    amplitude,
                    direction,
                    center,
                    width,
                }),
            ) => {
                let n = direction.iter().map(|d| d * d).sum::<f64>().sqrt();
                let mut d = [0.0; 3];
                for (k, x) in direction.iter().enumerate().take(3) {
                    d[k] = x / n;
                }
                let rod = if solution == AnalyticSolution::RodPulse {
                    Rod {
                        wave_speed: material.p_wave_speed(),
                        density: material.rho0,
                        ends: None,
                    }
                } else {
                    let Shape::Box { min, max, .. } = &body.geometry else {
                        return Err(format!(
                            "\"{name}\" is a rod between the faces of a box: give the first \
                             body a `box` geometry"
                        ));
                    };
                    let axis = (0..dim).find(|&k| d[k].abs() == 1.0).ok_or_else(|| {
                        format!(
                            "\"{name}\" needs the pulse along an axis of the box; the first \
                             body's `gaussian-pulse` direction is {direction:?}"
                        )
                    })?;
                    Rod {
                        wave_speed: bar_wave_speed(&material, dim),
                        density: material.rho0,
                        ends: Some([min[axis], max[axis]]),
                    }
                };
                Ok(Self::Wave {
                    rod,
                    direction: d,
                    amplitude: *amplitude,
                    center: *center,
                    width: *width,
                })
            }
            (AnalyticSolution::DrivenRod, None) => Self::driven(case, &material),
            (AnalyticSolution::DrivenRod, Some(field)) => Err(format!(
                "the analytic solution \"{name}\" is a rod at rest, driven at an end; the \
                 first body has the initial velocity `{}`: remove it",
                velocity_name(field)
            )),
            (_, field) => Err(format!(
                "the analytic solution \"{name}\" needs the matching initial velocity of the \
                 first body ({}), which has {}",
                match solution {
                    AnalyticSolution::Swinging => "`swinging`",
                    _ => "`gaussian-pulse`",
                },
                field
                    .as_ref()
                    .map_or("none".to_string(), |f| format!("`{}`", velocity_name(f)))
            )),
        }
    }

    /// The [`Exact::Driven`] rod of `case` (see [`AnalyticSolution::DrivenRod`]).
    fn driven(case: &Case, material: &Material) -> Result<Self, String> {
        let name = "\"driven-rod\"";
        let body = &case.bodies[0];
        let Shape::Box { min, max, .. } = &body.geometry else {
            return Err(format!(
                "{name} is a rod between the faces of a box: give the first body a `box` geometry"
            ));
        };
        let released: Vec<usize> = (0..case.boundaries.len())
            .filter(|&b| {
                matches!(
                    case.boundaries[b].condition,
                    Condition::Velocity { until: Some(_), .. }
                )
            })
            .collect();
        let [b] = released[..] else {
            return Err(format!(
                "{name} needs one `velocity` condition with `until` (the driven end), the case \
                 has {}",
                released.len()
            ));
        };
        let bc = &case.boundaries[b];
        let Condition::Velocity {
            vx,
            vy,
            vz,
            law,
            until: Some(until),
        } = &bc.condition
        else {
            unreachable!("a velocity condition with a release")
        };
        if !law.is_constant() {
            return Err(format!(
                "{name} holds the driven end at a constant velocity; boundary.{b}.condition has \
                 a time law: remove it"
            ));
        }
        let given: Vec<(usize, f64)> = [vx, vy, vz]
            .iter()
            .enumerate()
            .filter_map(|(k, v)| v.map(|v| (k, v)))
            .collect();
        let [(axis, amplitude)] = given[..] else {
            return Err(format!(
                "{name} drives the end along the rod's axis: boundary.{b}.condition must give \
                 one velocity component, it gives {}",
                given.len()
            ));
        };
        let region = &bc.region;
        let upper = [region.x_max, region.y_max, region.z_max][axis];
        if upper.is_none_or(|u| (u - min[axis]).abs() > 0.5 * case.spacing) {
            return Err(format!(
                "{name} drives the box's lower end along {}: boundary.{b}.region must hold the \
                 end face only, {}_max = {} (the box's lower bound)",
                ["x", "y", "z"][axis],
                ["x", "y", "z"][axis],
                min[axis]
            ));
        }
        let rod = Rod {
            wave_speed: bar_wave_speed(material, case.dim()),
            density: material.rho0,
            ends: Some([min[axis], max[axis]]),
        };
        let length = max[axis] - min[axis];
        if rod.wave_speed * until > length {
            return Err(format!(
                "{name} needs the pulse no longer than the rod: c t_p = {:.4e} m for `until` = \
                 {until:e} s, the rod is {length:e} m long",
                rod.wave_speed * until
            ));
        }
        let mut direction = [0.0; 3];
        direction[axis] = 1.0;
        Ok(Self::Driven {
            rod,
            direction,
            end: DrivenEnd {
                amplitude,
                duration: *until,
            },
        })
    }
}

/// The `type` of an initial velocity field, as case files name it.
fn velocity_name(field: &VelocityField) -> String {
    serde_json::to_value(field)
        .ok()
        .and_then(|v| v.get("type").and_then(|t| t.as_str().map(str::to_string)))
        .unwrap_or_else(|| "?".into())
}
