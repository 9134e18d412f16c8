//! The loads of boundary conditions: the points of loaded surfaces and their forces, the
//! loads that vary in time, and the total force of each condition.

use super::summed;
use crate::case::{Case, CaseError, Condition, Discretised, Surface, TimeLaw};
use crate::core::neighbour;
use crate::core::tensor::Dim;
use crate::diagnostics::analytic::ClosedForm;

/// The face a traction region loads: the axes along it, and the extent its particles'
/// patches are clipped to, the named shapes' bounds (and the region's own, where it sets
/// them) along those axes. On a vertex lattice the edge and corner particles then carry
/// half and a quarter of a patch, on a cell-centred one whole patches, and on either the
/// patches tile the face the case names. A body without a named extent (a points file, a
/// mesh) extends Δx/2 past its particles, as a sample of cell centres does (a mesh's
/// centroids, the shipped irregular points files).
struct Face {
    along: Vec<usize>,
    bounds: ([f64; 3], [f64; 3]),
    half: f64,
}

impl Face {
    /// The face of boundary condition b's region, whose particles are `particles`: normal
    /// to the condition's `normal` if it has one, else to the axis along which the
    /// particles spread least.
    fn of<D: Dim>(case: &Case, b: usize, particles: &[usize], x0: &[D::V], body: &[u32]) -> Self {
        let spread = neighbour::bounding_box(particles.iter().map(|&i| D::to3(x0[i])));
        let normal = match &case.boundaries[b].condition {
            Condition::SolutionTraction { normal, .. } => {
                (0..D::N).find(|&k| normal[k] != 0.0).unwrap_or(0)
            }
            _ => (0..D::N)
                .min_by(|&j, &k| {
                    (spread.1[j] - spread.0[j]).total_cmp(&(spread.1[k] - spread.0[k]))
                })
                .unwrap_or(0),
        };
        let mut bodies: Vec<usize> = particles.iter().map(|&i| body[i] as usize).collect();
        bodies.sort_unstable();
        bodies.dedup();
        let half = 0.5 * case.spacing;
        let mut bounds = bodies
            .iter()
            .map(|&b| {
                case.bodies[b].geometry.extent(D::N).unwrap_or_else(|| {
                    let (lo, hi) = neighbour::bounding_box(
                        (0..x0.len())
                            .filter(|&i| body[i] as usize == b)
                            .map(|i| D::to3(x0[i])),
                    );
                    (lo.map(|c| c - half), hi.map(|c| c + half))
                })
            })
            .fold(
                ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
                |acc, (lo, hi)| {
                    (
                        std::array::from_fn(|k| acc.0[k].min(lo[k])),
                        std::array::from_fn(|k| acc.1[k].max(hi[k])),
                    )
                },
            );
        let region = &case.boundaries[b].region;
        let limits = [
            (region.x_min, region.x_max),
            (region.y_min, region.y_max),
            (region.z_min, region.z_max),
        ];
        for (k, (lo, hi)) in limits.into_iter().enumerate() {
            if let Some(lo) = lo {
                bounds.0[k] = bounds.0[k].max(lo);
            }
            if let Some(hi) = hi {
                bounds.1[k] = bounds.1[k].min(hi);
            }
        }
        Self {
            along: (0..D::N).filter(|&k| k != normal).collect(),
            bounds,
            half,
        }
    }

    /// The patch of the particle at reference position x.
    fn patch<D: Dim>(&self, x: D::V) -> Patch<'_> {
        Patch {
            centre: D::to3(x),
            face: self,
        }
    }
}

/// The patch of a face that a particle carries the traction of: Δx wide in each
/// direction of the face, centred at the particle, clipped to the face's bounds.
struct Patch<'a> {
    centre: [f64; 3],
    face: &'a Face,
}

impl Patch<'_> {
    /// The points of 2-point Gauss rules in each direction of the face over the patch
    /// (exact for tractions quadratic in X), each with its share t(X) dA of ∫ t dA, held
    /// by `particle`.
    fn points<D: Dim>(
        &self,
        particle: usize,
        t: impl Fn([f64; 3]) -> [f64; 3],
    ) -> Vec<SurfacePoint<D>> {
        let Face {
            along,
            bounds: face,
            half,
        } = self.face;
        let half = *half;
        let bounds: Vec<(f64, f64)> = along
            .iter()
            .map(|&k| {
                let lo = (self.centre[k] - half).max(face.0[k]);
                let hi = (self.centre[k] + half).min(face.1[k]);
                (lo, hi.max(lo))
            })
            .collect();
        // A region one particle thick along a direction of the face: a full patch there.
        let bounds: Vec<(f64, f64)> = bounds
            .iter()
            .zip(along)
            .map(|(&(lo, hi), &k)| {
                if hi - lo < 1e-12 * half {
                    (self.centre[k] - half, self.centre[k] + half)
                } else {
                    (lo, hi)
                }
            })
            .collect();
        let area: f64 = bounds.iter().map(|(lo, hi)| hi - lo).product();
        let gauss = 0.5 / 3f64.sqrt();
        let count = 1usize << along.len();
        let centre = self.centre;
        (0..count)
            .map(|corner| {
                let mut p = centre;
                for (bit, (&k, &(lo, hi))) in along.iter().zip(&bounds).enumerate() {
                    let s = if corner & (1 << bit) != 0 {
                        gauss
                    } else {
                        -gauss
                    };
                    p[k] = 0.5 * (lo + hi) + s * (hi - lo);
                }
                let tp = t(p);
                SurfacePoint {
                    particle: particle as u32,
                    x: D::from_slice(&p[..D::N]),
                    force: D::from_slice(&tp[..D::N]) * (area / count as f64),
                }
            })
            .collect()
    }
}

/// A point of a loaded surface of the reference configuration: the particle whose patch
/// of the surface holds it, its position X, and the force t dA of its share of the patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint<D: Dim> {
    pub particle: u32,
    pub x: D::V,
    pub force: D::V,
}

/// How a method carries the forces of its loaded surfaces to its nodes: the nodal forces
/// f_a = Σ_q Φ_a(X_q) f_q of its functions Φ_a at the surface points, ∫ Φ_a t dΓ.
pub trait NodalForces<D: Dim> {
    /// The (node, force) of the points' forces; a node may come more than once.
    fn spread(&self, points: &[SurfacePoint<D>]) -> Result<Vec<(u32, D::V)>, CaseError>;
}

/// Each point's force to the particle whose patch holds it: the tributary forces of the
/// collocation methods, and the consistent forces of bilinear elements on a vertex
/// lattice (their functions integrate to the patches under a traction constant along
/// the face).
pub struct OnPatches;

impl<D: Dim> NodalForces<D> for OnPatches {
    fn spread(&self, points: &[SurfacePoint<D>]) -> Result<Vec<(u32, D::V)>, CaseError> {
        Ok(points.iter().map(|p| (p.particle, p.force)).collect())
    }
}

/// A load of [`timed_loads`]: one boundary condition's time law and the accelerations it
/// gives its particles at law value 1.
#[derive(Clone, Debug)]
pub struct TimedLoad<D: Dim> {
    pub law: TimeLaw,
    /// (particle, acceleration), by particle.
    pub accelerations: Vec<(u32, D::V)>,
}

/// The loads of a case that vary in time, one per condition: its time law and the
/// (particle, acceleration) of every particle it loads, from the discretisation, the way
/// the method carries surface forces to its nodes (`nodal`) and its nodal masses. A
/// traction with a time law has the points of the particles' patches of the face, as a
/// constant one does ([`Face`]), a pressure those of the particles' arcs of the circle
/// ([`pressure_points`]); a force's acceleration is f/m. A body force gives its
/// acceleration g to each particle of its region.
pub fn timed_loads<D: Dim>(
    case: &Case,
    disc: &Discretised<D>,
    nodal: &dyn NodalForces<D>,
    mass: &[f64],
) -> Result<Vec<TimedLoad<D>>, CaseError> {
    let (x0, body) = (&disc.x0[..], &disc.body[..]);
    let mut loads = Vec::new();
    let per_mass = |points: Vec<SurfacePoint<D>>| -> Result<Vec<(u32, D::V)>, CaseError> {
        let forces = summed::<D>(mass.len(), nodal.spread(&points)?);
        Ok(forces
            .into_iter()
            .map(|(i, f)| (i, f * (1.0 / mass[i as usize])))
            .collect())
    };
    for (b, bc) in case.boundaries.iter().enumerate() {
        if !bc.condition.is_timed_load() {
            continue;
        }
        let (law, accelerations): (&TimeLaw, Vec<(u32, D::V)>) = match &bc.condition {
            Condition::Traction { law, .. } | Condition::Pressure { law, .. } => {
                let particles = selected::<D>(case, b, x0, body)?;
                let points = surface_points::<D>(case, b, &particles, x0, body)?;
                (law, per_mass(points)?)
            }
            Condition::BodyForce { acceleration, law } => {
                let g = D::from_slice(acceleration);
                let particles = selected::<D>(case, b, x0, body)?;
                (law, particles.into_iter().map(|i| (i as u32, g)).collect())
            }
            _ => unreachable!("the timed loads are tractions, pressures and body forces"),
        };
        loads.push(TimedLoad {
            law: law.clone(),
            accelerations,
        });
    }
    Ok(loads)
}

/// The surface points of boundary condition b over its particles: the points of their
/// patches of the face for a traction, constant or timed, or a closed-form solution's
/// traction ([`Face`]), those of their arcs for a pressure ([`pressure_points`]); none for
/// the other conditions.
pub(super) fn surface_points<D: Dim>(
    case: &Case,
    b: usize,
    particles: &[usize],
    x0: &[D::V],
    body: &[u32],
) -> Result<Vec<SurfacePoint<D>>, CaseError> {
    let on_face = |t: &dyn Fn([f64; 3]) -> [f64; 3]| {
        let face = Face::of::<D>(case, b, particles, x0, body);
        particles
            .iter()
            .flat_map(|&i| face.patch::<D>(x0[i]).points(i, t))
            .collect()
    };
    Ok(match &case.boundaries[b].condition {
        Condition::Traction { traction, .. } => {
            let t: [f64; 3] = std::array::from_fn(|k| traction.get(k).copied().unwrap_or(0.0));
            on_face(&|_| t)
        }
        Condition::SolutionTraction { solution, normal } => {
            let closed = ClosedForm::of(solution, &case.material);
            on_face(&|x| {
                let s = closed.stress3(x);
                std::array::from_fn(|r| (0..D::N).map(|c| s[r][c] * normal[c]).sum())
            })
        }
        Condition::Pressure { .. } => pressure_points::<D>(case, b, x0, body)?,
        _ => Vec::new(),
    })
}

/// The surface points of boundary condition b, a pressure p on a circle of radius R: each
/// particle within Δx of it on the body's side holds the point of the circle at its
/// angle, X = c + R n, with the force p R Δθ n, Δθ half the angle between its neighbours
/// along the circle (so that the shares sum to 2πR) and n the reference normal into the
/// body, ±(X − c)/|X − c| (a midpoint rule over its arc).
fn pressure_points<D: Dim>(
    case: &Case,
    b: usize,
    x0: &[D::V],
    body: &[u32],
) -> Result<Vec<SurfacePoint<D>>, CaseError> {
    let Condition::Pressure {
        pressure,
        center,
        radius,
        surface,
        ..
    } = &case.boundaries[b].condition
    else {
        unreachable!("boundary condition {b} is a pressure")
    };
    // Within Δx of the circle on the body's side, with a round-off margin on both ends (a
    // lattice point on the circle, a layer Δx off it).
    let (dx, tol) = (case.spacing, 1e-9 * case.spacing);
    let on_circle: Vec<usize> = selected::<D>(case, b, x0, body)?
        .into_iter()
        .filter(|&i| {
            let r = D::norm2(x0[i] - D::from_slice(center)).sqrt();
            match surface {
                Surface::Inner => r >= radius - tol && r < radius + dx - tol,
                Surface::Outer => r <= radius + tol && r > radius - dx + tol,
            }
        })
        .collect();
    let sign = match surface {
        Surface::Inner => 1.0,
        Surface::Outer => -1.0,
    };
    let c = D::from_slice(center);
    Ok(pressure_shares::<D>(case, b, x0, &on_circle, center)?
        .into_iter()
        .map(|(i, dtheta, radial)| SurfacePoint {
            particle: i as u32,
            x: c + radial * *radius,
            force: radial * (sign * pressure * radius * dtheta),
        })
        .collect())
}

/// The particles `on_circle` about `center` by angle, each with its share Δθ of the
/// circle (half the angle to each neighbour along it) and its radial unit vector
/// (X − c)/|X − c|. The shares of a whole circle sum to 2π; a circle that the particles
/// leave open (a gap wider than a quarter turn, as under a region that cuts it) is refused,
/// as is one with fewer than three particles.
fn pressure_shares<D: Dim>(
    case: &Case,
    b: usize,
    x0: &[D::V],
    on_circle: &[usize],
    center: &[f64],
) -> Result<Vec<(usize, f64, D::V)>, CaseError> {
    let key = format!("boundary.{b}.condition");
    if on_circle.len() < 3 {
        return Err(case.invalid(
            key,
            format!(
                "the pressure's circle has {} particle(s) within Δx of it on the body's \
                 side; check `center`, `radius` and `surface` against the body",
                on_circle.len()
            ),
        ));
    }
    let c = D::from_slice(center);
    let mut by_angle: Vec<(f64, usize)> = on_circle
        .iter()
        .map(|&i| {
            let d = D::to3(x0[i] - c);
            (d[1].atan2(d[0]), i)
        })
        .collect();
    by_angle.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = by_angle.len();
    let tau = std::f64::consts::TAU;
    // gap[k]: the angle from particle k to the next one round the circle.
    let gap: Vec<f64> = (0..n)
        .map(|k| (by_angle[(k + 1) % n].0 - by_angle[k].0).rem_euclid(tau))
        .collect();
    let widest = gap.iter().copied().fold(0.0, f64::max);
    if widest > tau / 4.0 {
        return Err(case.invalid(
            key,
            format!(
                "the pressure's particles leave a gap of {widest:.3} rad on the circle; a \
                 pressure acts on a whole circle: let the region take every particle along it"
            ),
        ));
    }
    Ok((0..n)
        .map(|k| {
            let (_, i) = by_angle[k];
            let r = x0[i] - c;
            let share = 0.5 * (gap[(k + n - 1) % n] + gap[k]);
            (i, share, r * (1.0 / D::norm2(r).sqrt()))
        })
        .collect())
}

/// The particles of boundary condition b's region among those at reference positions x0
/// with bodies `body`; an error if it selects none.
pub(super) fn selected<D: Dim>(
    case: &Case,
    b: usize,
    x0: &[D::V],
    body: &[u32],
) -> Result<Vec<usize>, CaseError> {
    let region = &case.boundaries[b].region;
    let tol = 0.25 * case.spacing;
    let of_body = region
        .body
        .as_ref()
        .and_then(|name| case.bodies.iter().position(|b| &b.name == name));
    let bounds = [
        (region.x_min, region.x_max),
        (region.y_min, region.y_max),
        (region.z_min, region.z_max),
    ];
    let inside: Vec<usize> = (0..x0.len())
        .filter(|&i| of_body.is_none_or(|b| body[i] as usize == b))
        .filter(|&i| {
            let p = D::to3(x0[i]);
            bounds.iter().zip(p).all(|(&(lo, hi), c)| {
                lo.is_none_or(|lo| c >= lo - tol) && hi.is_none_or(|hi| c <= hi + tol)
            })
        })
        .collect();
    if inside.is_empty() {
        return Err(case.invalid(
            format!("boundary.{b}.region"),
            "selects no particle; check the bounds against the bodies' reference positions",
        ));
    }
    Ok(inside)
}

/// What one boundary condition acts on: its region's particles and, for a load (a
/// traction, pressure, body force or a solution's traction), the total force it applies
/// at law value 1, the sum of its particles' forces (∫ t dA over their patches of the
/// face, p R Δθ n along a circle, m g on the masses given).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConditionTotal {
    pub particles: usize,
    pub force: Option<[f64; 3]>,
}

/// The [`ConditionTotal`] of every boundary condition of a case, in case order, on the
/// particles at reference positions x0 with bodies `body` and nodal masses `mass` (which
/// only a body force's total depends on): for `--explain`, and the applied-force columns
/// of the named loads in the series.
pub fn condition_totals<D: Dim>(
    case: &Case,
    x0: &[D::V],
    body: &[u32],
    mass: &[f64],
) -> Result<Vec<ConditionTotal>, CaseError> {
    let sum = |forces: &mut dyn Iterator<Item = D::V>| {
        let total = forces.fold(D::zero(), |a, f| a + f);
        Some(D::to3(total))
    };
    (0..case.boundaries.len())
        .map(|b| {
            let particles = selected::<D>(case, b, x0, body)?;
            let force = match &case.boundaries[b].condition {
                Condition::BodyForce { acceleration, .. } => {
                    let g = D::from_slice(acceleration);
                    sum(&mut particles.iter().map(|&i| g * mass[i]))
                }
                Condition::Traction { .. }
                | Condition::SolutionTraction { .. }
                | Condition::Pressure { .. } => {
                    let points = surface_points::<D>(case, b, &particles, x0, body)?;
                    sum(&mut points.iter().map(|p| p.force))
                }
                _ => None,
            };
            Ok(ConditionTotal {
                particles: particles.len(),
                force,
            })
        })
        .collect()
}
