//! Geometry generators: sample every body of a case on a lattice of spacing Δx (or read
//! its points from CSV) and set the initial velocity field.
//!
//! `lattice` samples the shapes, `shape` says what a shape names (its volume, extent and
//! sampled length), `files` reads points and mesh files, and `estimate` sizes the bodies
//! without sampling them.

mod estimate;
mod files;
mod lattice;
mod shape;

pub use estimate::{BOX_HALF, BodySize, estimate_particles};
pub(crate) use files::read_capped;
pub use lattice::PARTICLE_ID_LIMIT;

use super::{BodySpec, Case, CaseError, Expression, Hole, Shape, VelocityField, VelocityNoise};
use crate::core::quadrature::{Cells, CylindricalFrame};
use crate::core::tensor::Dim;
use crate::diagnostics::analytic::SwingingMode;
use crate::physics::material::Material;
use std::path::Path;

/// The cylindrical lattice of every body of `case` that is a tube, by body (None for the
/// others).
pub fn tube_frames(case: &Case) -> Vec<Option<CylindricalFrame>> {
    (case.bodies.iter())
        .map(|b| match &b.geometry {
            Shape::Tube { base, axis, .. } => {
                lattice::TubeLattice::of(&b.geometry, case.spacing).map(|t| t.frame(base, *axis))
            }
            _ => None,
        })
        .collect()
}

/// The particles of a case in the reference configuration.
#[derive(Clone, Debug)]
pub struct Discretised<D: Dim> {
    /// Reference positions X.
    pub x0: Vec<D::V>,
    /// Reference volumes V0 (Δx^d for lattice points; 2D volumes are per unit thickness).
    pub vol: Vec<f64>,
    /// Body index of every particle (into `Case::bodies`).
    pub body: Vec<u32>,
    /// Initial velocities.
    pub v0: Vec<D::V>,
    /// Initial displacements (zero unless a body sets `initial_displacement`).
    pub u0: Vec<D::V>,
    /// The cells of the bodies whose generator makes them (polar rings, meshes read at
    /// their vertices); the other bodies' cells are found on their lattice
    /// ([`crate::core::quadrature::lattice_cells`]).
    pub cells: Cells,
}

/// The particles of one body, with its cells where the generator makes them.
struct Sampled<D: Dim> {
    points: Vec<D::V>,
    volumes: Vec<f64>,
    /// The corners of its cells (2^d each, VTK order), numbered within the body.
    corners: Vec<u32>,
    /// Initial velocities of the points, where a points file gives them.
    velocities: Option<Vec<D::V>>,
}

impl<D: Dim> From<(Vec<D::V>, Vec<f64>)> for Sampled<D> {
    fn from((points, volumes): (Vec<D::V>, Vec<f64>)) -> Self {
        Self {
            points,
            volumes,
            corners: Vec::new(),
            velocities: None,
        }
    }
}

/// Samples every body of the case.
pub fn discretise<D: Dim>(case: &Case) -> Result<Discretised<D>, CaseError> {
    let mut out = Discretised {
        x0: Vec::new(),
        vol: Vec::new(),
        body: Vec::new(),
        v0: Vec::new(),
        u0: Vec::new(),
        cells: Cells::default(),
    };
    for (b, spec) in case.bodies.iter().enumerate() {
        let Sampled {
            points,
            volumes,
            corners,
            velocities,
        } = drill(lattice::sample::<D>(case, b, spec)?, &spec.holes);
        if points.is_empty() {
            return Err(case.invalid(
                format!("body.{b}.geometry"),
                format!(
                    "body `{}` contains no particle at spacing {}; reduce `spacing` or enlarge the shape",
                    spec.name, case.spacing
                ),
            ));
        }
        sampled_volume_fits(case, b, spec, &volumes)?;
        let first = out.x0.len() as u32;
        out.cells.corners.extend(corners.iter().map(|a| first + a));
        out.cells
            .body
            .extend(std::iter::repeat_n(b as u32, corners.len() >> D::N));
        let noise = spec
            .velocity_noise
            .map_or_else(Vec::new, |n| velocity_noise::<D>(&n, points.len()));
        let key = format!("body.{b}.initial_velocity");
        if velocities.is_some() && spec.initial_velocity.is_some() {
            return Err(case.invalid(
                key,
                "is given twice: the points file of the body has velocity columns too; \
                 remove the key or the columns",
            ));
        }
        let expressions = match spec
            .initial_velocity
            .as_ref()
            .and_then(|f| f.expressions(&key, D::N))
        {
            Some(parsed) => parsed.map_err(|(key, message)| case.invalid(key, message))?,
            None => Vec::new(),
        };
        let u_key = format!("body.{b}.initial_displacement");
        let displacement = match &spec.initial_displacement {
            Some(field) => Some((
                field,
                field
                    .expressions(&u_key, D::N)
                    .map_err(|(key, message)| case.invalid(key, message))?,
            )),
            None => None,
        };
        for (i, (&x, &v)) in points.iter().zip(&volumes).enumerate() {
            out.x0.push(x);
            out.vol.push(v);
            out.body.push(b as u32);
            let v0 = match &velocities {
                Some(given) => given[i],
                None => {
                    initial_velocity::<D>(case, spec.initial_velocity.as_ref(), &expressions, x)
                }
            };
            finite_field(
                case,
                &key,
                "velocity",
                "m/s",
                D::to3(v0),
                D::to3(x),
                &spec.name,
            )?;
            out.v0.push(noise.get(i).map_or(v0, |&dv| v0 + dv));
            let u0 = displacement.as_ref().map_or([0.0; 3], |(field, parsed)| {
                field.at(parsed, D::to3(x), D::N)
            });
            finite_field(case, &u_key, "displacement", "m", u0, D::to3(x), &spec.name)?;
            out.u0.push(D::from_slice(&u0[..D::N]));
        }
    }
    Ok(out)
}

/// Refuses a body whose sampled volume Σ V differs from the volume of the shape the case
/// names by more than `volume_tolerance`, saying by how much and what to change. A body
/// with holes is not checked (its named volume is not computed), nor one whose `volumes`
/// the case gives: the case asked for them (the run says the difference in mass). A
/// cylinder whose sampled length differs from the named one by more than the tolerance is
/// refused whatever its volumes ([`Shape::sampled_length`]): scaled volumes keep its mass
/// but not its shape.
fn sampled_volume_fits(
    case: &Case,
    b: usize,
    spec: &BodySpec,
    volumes: &[f64],
) -> Result<(), CaseError> {
    let tolerance = spec.volume_tolerance.unwrap_or(super::VOLUME_TOLERANCE);
    if let Some((sampled, named)) = spec
        .geometry
        .sampled_length(case.spacing, case.method.lattice_cells)
        .filter(|(sampled, named)| (sampled / named - 1.0).abs() > tolerance)
    {
        return Err(case.invalid(
            format!("body.{b}.geometry.length"),
            format!(
                "body `{}` is sampled {sampled:.6e} long along its axis against the named \
                 {named:.6e} ({:+.2} %), past the volume_tolerance of {:.2} %: the length is \
                 {:.3} spacings; give a length that is a whole multiple of `spacing` (e.g. \
                 spacing = {:e}), or raise `body.{b}.volume_tolerance` to accept the difference",
                spec.name,
                100.0 * (sampled / named - 1.0),
                100.0 * tolerance,
                named / case.spacing,
                named / (named / case.spacing).round().max(1.0)
            ),
        ));
    }
    let Some(named) = spec.geometry.volume(case.dimension as usize) else {
        return Ok(());
    };
    if !spec.holes.is_empty() || named <= 0.0 || spec.geometry.volumes_given() {
        return Ok(());
    }
    let sampled: f64 = volumes.iter().sum();
    if !sampled.is_finite() {
        // A spacing beyond the body's size: refused by the checks of the values it gives.
        return Ok(());
    }
    let difference = sampled / named - 1.0;
    if difference.abs() <= tolerance {
        return Ok(());
    }
    let advice = match &spec.geometry {
        Shape::Box { min, max, .. } => {
            let cells: Vec<f64> = (0..case.dimension as usize)
                .map(|k| (max[k] - min[k]) / case.spacing)
                .collect();
            let shortest = min
                .iter()
                .zip(max)
                .map(|(lo, hi)| hi - lo)
                .fold(f64::INFINITY, f64::min);
            format!(
                "the box's sides are {cells:.3?} spacings; give sides that are whole \
                 multiples of `spacing` (e.g. spacing = {:e}) or `volumes` that sum to the box",
                shortest / (shortest / case.spacing).round().max(1.0)
            )
        }
        _ => "refine `spacing` until the lattice fits the shape".to_string(),
    };
    Err(case.invalid(
        format!("body.{b}.geometry"),
        format!(
            "body `{}` is sampled with volume {sampled:.6e} against the {named:.6e} of the \
             named shape ({:+.2} %, and its mass as much), past the volume_tolerance of \
             {:.2} %; {advice}, or raise `body.{b}.volume_tolerance` to accept the difference",
            spec.name,
            100.0 * difference,
            100.0 * tolerance
        ),
    ))
}

/// The particles of a body outside all of its holes (validation keeps holes away from
/// the generators that make cells).
fn drill<D: Dim>(body: Sampled<D>, holes: &[Hole]) -> Sampled<D> {
    if holes.is_empty() {
        return body;
    }
    let kept: Vec<usize> = (0..body.points.len())
        .filter(|&i| !holes.iter().any(|h| h.contains(D::to3(body.points[i]))))
        .collect();
    Sampled {
        points: kept.iter().map(|&i| body.points[i]).collect(),
        volumes: kept.iter().map(|&i| body.volumes[i]).collect(),
        corners: body.corners,
        velocities: body
            .velocities
            .map(|v| kept.iter().map(|&i| v[i]).collect()),
    }
}

/// The noise's velocities, one per particle: per axis uniform in ±amplitude, from the
/// SplitMix64 sequence of the seed.
fn velocity_noise<D: Dim>(noise: &VelocityNoise, particles: usize) -> Vec<D::V> {
    let mut state = noise.seed;
    let mut uniform = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..particles)
        .map(|_| {
            let v: Vec<f64> = (0..D::N).map(|_| uniform() * noise.amplitude).collect();
            D::from_slice(&v)
        })
        .collect()
}

/// Refuses an initial field (key `key`) that is not finite at X of body `body`.
fn finite_field(
    case: &Case,
    key: &str,
    what: &str,
    unit: &str,
    value: [f64; 3],
    x: [f64; 3],
    body: &str,
) -> Result<(), CaseError> {
    if value.iter().all(|c| c.is_finite()) {
        return Ok(());
    }
    Err(case.invalid(
        key,
        format!(
            "gives the {what} {value:?} {unit} at X = {x:?} (body `{body}`), not a finite one; \
             make the field finite over the body"
        ),
    ))
}

/// v0(X) of `field`; `expressions` are the parsed components of an `expression` field.
fn initial_velocity<D: Dim>(
    case: &Case,
    field: Option<&VelocityField>,
    expressions: &[Expression],
    x: D::V,
) -> D::V {
    let Some(field) = field else { return D::zero() };
    let p = D::to3(x);
    match field {
        VelocityField::Expression { .. } => {
            let v: Vec<f64> = expressions.iter().map(|e| e.at(&p)).collect();
            D::from_slice(&v)
        }
        VelocityField::Uniform { value } => D::from_slice(value),
        VelocityField::Linear { gradient } => {
            D::from_slice(&super::linear_field(gradient, p)[..D::N])
        }
        VelocityField::RigidRotation {
            omega,
            center,
            axis,
        } => {
            let c = pad3(center);
            let w = match axis {
                Some(a) => {
                    let a = pad3(a);
                    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                    [a[0] / n * omega, a[1] / n * omega, a[2] / n * omega]
                }
                None => [0.0, 0.0, *omega],
            };
            let r = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let v = [
                w[1] * r[2] - w[2] * r[1],
                w[2] * r[0] - w[0] * r[2],
                w[0] * r[1] - w[1] * r[0],
            ];
            D::from_slice(&v)
        }
        VelocityField::GaussianPulse {
            amplitude,
            direction,
            center,
            width,
        } => {
            let d = D::from_slice(direction);
            let d = d * (1.0 / D::norm2(d).sqrt());
            let s = D::dot(x, d);
            d * (amplitude * (-((s - center) / width).powi(2)).exp())
        }
        VelocityField::Twist { omega, length } => {
            let w = omega * (std::f64::consts::FRAC_PI_2 * p[1] / length).sin();
            // ω ŷ × X = (ω Z, 0, −ω X).
            D::from_slice(&[w * p[2], 0.0, -w * p[0]])
        }
        VelocityField::Swinging { amplitude, mode } => {
            SwingingMode::new(*amplitude, &Material::new(&case.material), D::N, *mode)
                .velocity::<D>(x, 0.0)
        }
    }
}

fn pad3(v: &[f64]) -> [f64; 3] {
    [v[0], v[1], v.get(2).copied().unwrap_or(0.0)]
}

/// An error about the points or mesh file of body `b`.
fn file_error(case: &Case, b: usize, path: &Path, message: String) -> CaseError {
    case.invalid(
        format!("body.{b}.geometry.file"),
        format!("{}: {message}", path.display()),
    )
}
