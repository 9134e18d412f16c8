//! Geometry generators: sample every body of a case on a lattice of spacing Δx (or read
//! its points from CSV) and set the initial velocity field.

use super::expression::COORDINATES;
use super::{
    BodySpec, Case, CaseError, Expression, Hole, Lattice, MeshNodes, RingLattice, Shape,
    VelocityField, VelocityNoise, Volumes,
};
use crate::analytic::SwingingMode;
use crate::material::Material;
use crate::quadrature::Cells;
use crate::tensor::Dim;
use std::path::Path;

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
    /// ([`crate::quadrature::lattice_cells`]).
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
        } = drill(sample::<D>(case, b, spec)?, &spec.holes);
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

/// The volumes of a round shape's square-lattice points, `scaled` by default: by one factor
/// so that they sum to the named shape's volume. The lattice cannot follow a curved
/// boundary, and without the factor (`uniform`) the body's mass is off by the area of the
/// cells the boundary cuts (−2.7 % on a disk of radius 9.5Δx).
fn to_named_volume(
    shape: &Shape,
    volumes: Option<Volumes>,
    d: usize,
    mut vol: Vec<f64>,
) -> Vec<f64> {
    if volumes == Some(Volumes::Uniform) {
        return vol;
    }
    let sampled: f64 = vol.iter().sum();
    if let Some(named) = shape.volume(d).filter(|_| sampled > 0.0) {
        let factor = named / sampled;
        vol.iter_mut().for_each(|v| *v *= factor);
    }
    vol
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
        .sampled_length(case.spacing, case.method.spec.lattice_cells())
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

fn sample<D: Dim>(case: &Case, b: usize, spec: &BodySpec) -> Result<Sampled<D>, CaseError> {
    let dx = case.spacing;
    let cell = dx.powi(D::N as i32);
    let lattice_of = |lo: &[f64], hi: &[f64], inside: &dyn Fn(&[f64]) -> bool| {
        let points = lattice::<D>(lo, hi, dx, inside).map_err(|total| {
            case.invalid(
                "spacing",
                format!(
                    "{dx:e} samples body `{}` on a lattice of {total:.3e} points, more than \
                     the {PARTICLE_ID_LIMIT:.0} particle ids hold; increase `spacing`",
                    spec.name
                ),
            )
        })?;
        let vol = vec![cell; points.len()];
        Ok::<_, CaseError>((points, vol))
    };
    // The methods that integrate over the lattice's cells take the vertex lattice, whose
    // cells span the shape ([`crate::methods::MethodFamily::lattice_cells`]).
    let cells = case.method.spec.lattice_cells();
    let vertex_box;
    let vertex_cylinder;
    let geometry = match &spec.geometry {
        Shape::Box {
            min,
            max,
            lattice: Lattice::CellCentred,
            ..
        } if cells => {
            vertex_box = Shape::Box {
                min: min.clone(),
                max: max.clone(),
                volumes: None,
                lattice: Lattice::Vertex,
            };
            &vertex_box
        }
        Shape::Cylinder {
            base,
            axis,
            radius,
            inner_radius,
            length,
            lattice: Lattice::CellCentred,
            volumes,
        } if cells => {
            vertex_cylinder = Shape::Cylinder {
                base: base.clone(),
                axis: *axis,
                radius: *radius,
                inner_radius: *inner_radius,
                length: *length,
                lattice: Lattice::Vertex,
                volumes: *volumes,
            };
            &vertex_cylinder
        }
        other => other,
    };
    Ok(match geometry {
        Shape::Ring {
            center,
            inner_radius,
            outer_radius,
            lattice: RingLattice::Polar,
            sectors,
            ..
        } => {
            let (n_r, n_theta) = polar_counts(*inner_radius, *outer_radius, dx, *sectors);
            let total = (n_r + 1.0) * n_theta;
            if total > PARTICLE_ID_LIMIT {
                return Err(case.invalid(
                    "spacing",
                    format!(
                        "{dx:e} samples body `{}` on a polar lattice of {total:.3e} points, \
                         more than the {PARTICLE_ID_LIMIT:.0} particle ids hold; increase \
                         `spacing` or give fewer `sectors`",
                        spec.name
                    ),
                ));
            }
            polar_ring::<D>(
                center,
                (*inner_radius, *outer_radius),
                (n_r as usize, n_theta as usize),
            )
        }
        Shape::Box {
            min,
            max,
            lattice: Lattice::CellCentred,
            ..
        } => {
            let half: Vec<f64> = (0..D::N).map(|_| 0.5 * dx).collect();
            let lo: Vec<f64> = min.iter().zip(&half).map(|(m, h)| m + h).collect();
            let hi: Vec<f64> = max.iter().zip(&half).map(|(m, h)| m - h).collect();
            lattice_of(&lo, &hi, &|_| true)?.into()
        }
        Shape::Box {
            min,
            max,
            volumes,
            lattice,
        } => {
            let (points, mut vol) = lattice_of(min, max, &|_| true)?;
            if Volumes::or_default_for(*volumes, *lattice) == Volumes::Tributary {
                for (p, v) in points.iter().zip(vol.iter_mut()) {
                    let p = D::to3(*p);
                    for k in 0..D::N {
                        let on_face = |bound: f64| (p[k] - bound).abs() < 1e-9 * dx;
                        if on_face(min[k]) || on_face(max[k]) {
                            *v *= 0.5;
                        }
                    }
                }
            }
            (points, vol).into()
        }
        Shape::Disk {
            center,
            radius,
            volumes,
        } => {
            let (lo, hi) = around(center, *radius);
            let (points, vol) = lattice_of(&lo, &hi, &|p| dist2(p, center) < radius * radius)?;
            (points, to_named_volume(geometry, *volumes, D::N, vol)).into()
        }
        Shape::Ring {
            center,
            inner_radius,
            outer_radius,
            volumes,
            ..
        } => {
            let (lo, hi) = around(center, *outer_radius);
            let (points, vol) = lattice_of(&lo, &hi, &|p| {
                let r2 = dist2(p, center);
                r2 >= inner_radius * inner_radius && r2 < outer_radius * outer_radius
            })?;
            (points, to_named_volume(geometry, *volumes, D::N, vol)).into()
        }
        Shape::Cylinder {
            base,
            axis,
            radius,
            inner_radius,
            lattice,
            volumes,
            ..
        } => {
            let a = axis.index();
            let (lo, hi) = geometry.extent(3).expect("a cylinder has its bounding box");
            let (mut lo, mut hi) = (lo.to_vec(), hi.to_vec());
            if *lattice == Lattice::CellCentred {
                lo.iter_mut().for_each(|x| *x += 0.5 * dx);
                hi.iter_mut().for_each(|x| *x -= 0.5 * dx);
            }
            let (points, vol) = lattice_of(&lo, &hi, &|p| {
                let r2: f64 = (0..3)
                    .filter(|&k| k != a)
                    .map(|k| (p[k] - base[k]).powi(2))
                    .sum();
                r2 >= inner_radius * inner_radius && r2 <= radius * radius
            })?;
            (points, to_named_volume(geometry, *volumes, D::N, vol)).into()
        }
        Shape::Polygon { vertices, volumes } => {
            let (lo, hi) = super::polygon::bounds(vertices);
            let tol = 1e-9 * dx;
            let (points, vol) =
                lattice_of(&lo, &hi, &|p| super::polygon::contains(vertices, p, tol))?;
            (points, to_named_volume(geometry, *volumes, D::N, vol)).into()
        }
        Shape::Points { file } => {
            let path = case.base_dir().join(file);
            read_points::<D>(&path, cell).map_err(|m| {
                case.invalid(
                    format!("body.{b}.geometry.file"),
                    format!("{}: {m}", path.display()),
                )
            })?
        }
        Shape::Mesh { file, nodes } => {
            let path = case.base_dir().join(file);
            read_mesh::<D>(&path, *nodes).map_err(|m| {
                case.invalid(
                    format!("body.{b}.geometry.file"),
                    format!("{}: {m}", path.display()),
                )
            })?
        }
    })
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

/// The particles of a Gmsh mesh ([`super::mesh`]): at the centroid of each cell, with
/// the cell's measure as its volume; or at the vertices of its quadrangles (hexahedra),
/// which are the body's cells, each vertex with a 2^-d share of every cell it is a corner
/// of, so that the volumes sum to the mesh's.
fn read_mesh<D: Dim>(path: &Path, nodes: MeshNodes) -> Result<Sampled<D>, String> {
    let text = read_points_file(path)?;
    if nodes == MeshNodes::Vertices {
        let mesh = super::mesh::vertex_cells(&text, D::N)?;
        let mut volumes = vec![0.0; mesh.points.len()];
        let share = 1.0 / f64::from(1u32 << D::N);
        for (corners, measure) in mesh.corners.chunks(1 << D::N).zip(&mesh.measures) {
            for &a in corners {
                volumes[a as usize] += share * measure;
            }
        }
        return Ok(Sampled {
            points: mesh
                .points
                .iter()
                .map(|x| D::from_slice(&x[..D::N]))
                .collect(),
            volumes,
            corners: mesh.corners,
            velocities: None,
        });
    }
    let cells = super::mesh::cells(&text, D::N)?;
    Ok(cells
        .iter()
        .map(|c| (D::from_slice(&c.centroid[..D::N]), c.measure))
        .unzip::<_, _, Vec<D::V>, Vec<f64>>()
        .into())
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

/// The polar lattice of a ring (see [`RingLattice::Polar`]): n_r + 1 rings, n_r the
/// spacings across the wall nearest (r_o − r_i)/Δx, times n_θ rays; particle k·n_θ + j at
/// (r_i + kΔr, 2πj/n_θ). Cell (k, j) has the corners (k, j), (k + 1, j), (k + 1, j + 1),
/// (k, j + 1), counter-clockwise; its area is the trapezium's ½ sin(Δθ)(r_(k+1)² − r_k²).
fn polar_ring<D: Dim>(
    center: &[f64],
    (inner, outer): (f64, f64),
    (n_r, n_theta): (usize, usize),
) -> Sampled<D> {
    let dr = (outer - inner) / n_r as f64;
    let dtheta = std::f64::consts::TAU / n_theta as f64;
    let radius = |k: usize| inner + k as f64 * dr;
    let mut points = Vec::with_capacity((n_r + 1) * n_theta);
    for k in 0..=n_r {
        for j in 0..n_theta {
            let (s, c) = (j as f64 * dtheta).sin_cos();
            points.push(D::from_slice(&[
                center[0] + radius(k) * c,
                center[1] + radius(k) * s,
            ]));
        }
    }
    let index = |k: usize, j: usize| (k * n_theta + j % n_theta) as u32;
    let mut volumes = vec![0.0; points.len()];
    let mut corners = Vec::with_capacity(4 * n_r * n_theta);
    for k in 0..n_r {
        let area = 0.5 * dtheta.sin() * (radius(k + 1).powi(2) - radius(k).powi(2));
        for j in 0..n_theta {
            let cell = [
                index(k, j),
                index(k + 1, j),
                index(k + 1, j + 1),
                index(k, j + 1),
            ];
            for &a in &cell {
                volumes[a as usize] += area / 4.0;
            }
            corners.extend(cell);
        }
    }
    Sampled {
        points,
        volumes,
        corners,
        velocities: None,
    }
}

/// The spacings across the wall and the rays of a polar ring lattice, in f64 so that a
/// vanishing spacing gives a huge count, never a wrapped one.
fn polar_counts(inner: f64, outer: f64, dx: f64, sectors: Option<u32>) -> (f64, f64) {
    let n_r = ((outer - inner) / dx).round().max(1.0);
    let n_theta = sectors.map_or_else(
        || {
            (std::f64::consts::PI * (inner + outer) / dx)
                .round()
                .max(3.0)
        },
        f64::from,
    );
    (n_r, n_theta)
}

impl Shape {
    /// A cylinder's length along its axis as its lattice of spacing Δx samples it, and the
    /// length the case names: the span (n − 1)Δx of the n layers of a vertex lattice from
    /// the base, or the n layers Δx thick of a cell-centred one; the methods that
    /// integrate over lattice cells (`cells`) take the vertex lattice. They differ when
    /// the length is no multiple of Δx, which scaled volumes hide from the mass. None for
    /// the other shapes.
    pub fn sampled_length(&self, dx: f64, cells: bool) -> Option<(f64, f64)> {
        let Shape::Cylinder {
            length, lattice, ..
        } = self
        else {
            return None;
        };
        let sampled = match lattice {
            Lattice::CellCentred if !cells => {
                lattice_counts(&[0.5 * dx], &[length - 0.5 * dx], dx)[0] * dx
            }
            _ => (lattice_counts(&[0.0], &[*length], dx)[0] - 1.0) * dx,
        };
        Some((sampled, *length))
    }

    /// Whether the case gives the shape's `volumes` key.
    pub fn volumes_given(&self) -> bool {
        match self {
            Shape::Box { volumes, .. }
            | Shape::Disk { volumes, .. }
            | Shape::Ring { volumes, .. }
            | Shape::Cylinder { volumes, .. }
            | Shape::Polygon { volumes, .. } => volumes.is_some(),
            Shape::Points { .. } | Shape::Mesh { .. } => false,
        }
    }

    /// The d-dimensional volume of the shape the case names (an area in 2D); None for a
    /// points file or a mesh, whose volumes are given.
    pub fn volume(&self, d: usize) -> Option<f64> {
        let pi = std::f64::consts::PI;
        match self {
            Shape::Box { min, max, .. } => Some((0..d).map(|k| max[k] - min[k]).product()),
            Shape::Disk { radius, .. } => Some(pi * radius * radius),
            Shape::Ring {
                inner_radius,
                outer_radius,
                ..
            } => Some(pi * (outer_radius * outer_radius - inner_radius * inner_radius)),
            Shape::Cylinder {
                radius,
                inner_radius,
                length,
                ..
            } => Some(pi * (radius * radius - inner_radius * inner_radius) * length),
            Shape::Polygon { vertices, .. } => Some(super::polygon::area(vertices)),
            Shape::Points { .. } | Shape::Mesh { .. } => None,
        }
    }

    /// The bounding box of the shape the case names, in d dimensions (padded with zeros
    /// to three), whatever lattice samples it; None for a points file or a mesh, whose
    /// shape is only its particles.
    pub fn extent(&self, d: usize) -> Option<([f64; 3], [f64; 3])> {
        let (lo, hi) = match self {
            Shape::Box { min, max, .. } => (min.clone(), max.clone()),
            Shape::Disk { center, radius, .. } => around(center, *radius),
            Shape::Ring {
                center,
                outer_radius,
                ..
            } => around(center, *outer_radius),
            Shape::Cylinder {
                base,
                axis,
                radius,
                length,
                ..
            } => {
                let a = axis.index();
                let (mut lo, mut hi) = around(base, *radius);
                lo[a] = base[a];
                hi[a] = base[a] + length;
                (lo, hi)
            }
            Shape::Polygon { vertices, .. } => super::polygon::bounds(vertices),
            Shape::Points { .. } | Shape::Mesh { .. } => return None,
        };
        let pad = |v: &[f64]| std::array::from_fn(|k| if k < d { v[k] } else { 0.0 });
        Some((pad(&lo), pad(&hi)))
    }
}

fn around(center: &[f64], r: f64) -> (Vec<f64>, Vec<f64>) {
    (
        center.iter().map(|c| c - r).collect(),
        center.iter().map(|c| c + r).collect(),
    )
}

fn dist2(p: &[f64], c: &[f64]) -> f64 {
    p.iter().zip(c).map(|(a, b)| (a - b).powi(2)).sum()
}

/// Lattice points per axis from lo to hi at spacing Δx (i = 0, 1, … while lo + i·Δx ≤ hi,
/// with a 1e-9 relative tolerance so that an end point on the bound is kept), in f64 so
/// that a spacing far below the shape (1e-300) gives a huge count, never a wrapped one;
/// zero on an axis where hi < lo.
fn lattice_counts(lo: &[f64], hi: &[f64], dx: f64) -> Vec<f64> {
    lo.iter()
        .zip(hi)
        .map(|(l, h)| ((h - l) / dx + 1e-9).floor().max(-1.0) + 1.0)
        .collect()
}

/// The most particles a case may have: ids are u32 on both backends.
pub const PARTICLE_ID_LIMIT: f64 = u32::MAX as f64;

/// Points lo + i·Δx (see [`lattice_counts`]) that satisfy `inside`. Err: the lattice
/// has more points than particle ids hold.
fn lattice<D: Dim>(
    lo: &[f64],
    hi: &[f64],
    dx: f64,
    inside: &dyn Fn(&[f64]) -> bool,
) -> Result<Vec<D::V>, f64> {
    let counts = lattice_counts(&lo[..D::N], &hi[..D::N], dx);
    let total: f64 = counts.iter().product();
    if total > PARTICLE_ID_LIMIT {
        return Err(total);
    }
    let n: Vec<usize> = counts.iter().map(|&c| c as usize).collect();
    let mut points = Vec::new();
    let mut p = vec![0.0; D::N];
    for flat in 0..total as usize {
        let mut rest = flat;
        for k in 0..D::N {
            p[k] = lo[k] + (rest % n[k]) as f64 * dx;
            rest /= n[k];
        }
        if inside(&p) {
            points.push(D::from_slice(&p));
        }
    }
    Ok(points)
}

/// The size of a body, estimated without sampling it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySize {
    /// Its particles: the lattice points of its bounding box times the fraction of the
    /// box the shape fills (exact for a box; π/4 of the box for a disk), or the data rows
    /// of a points file (counted, not parsed).
    pub particles: f64,
    /// The lattice points the sampler visits to find them (its bounding box's).
    pub visited: f64,
}

/// The size of each body of a case. In f64: a spacing of 1e-300 gives 1e600 → ∞, never
/// a wrapped count.
pub fn estimate_particles(case: &Case) -> Result<Vec<BodySize>, CaseError> {
    let dx = case.spacing;
    let half = 0.5 * dx;
    let box_of = |lo: &[f64], hi: &[f64]| -> f64 { lattice_counts(lo, hi, dx).iter().product() };
    let annulus =
        |inner: f64, outer: f64| std::f64::consts::FRAC_PI_4 * (1.0 - (inner / outer).powi(2));
    let size = |visited: f64, fraction: f64| {
        // ∞ · 0 (an infinite lattice of a zero fraction) counts as ∞.
        let particles = visited * fraction;
        BodySize {
            particles: if particles.is_nan() {
                f64::INFINITY
            } else {
                particles
            },
            visited,
        }
    };
    case.bodies
        .iter()
        .enumerate()
        .map(|(b, spec)| {
            Ok(match &spec.geometry {
                Shape::Box {
                    min,
                    max,
                    lattice: Lattice::CellCentred,
                    ..
                } => {
                    let lo: Vec<f64> = min.iter().map(|m| m + half).collect();
                    let hi: Vec<f64> = max.iter().map(|m| m - half).collect();
                    size(box_of(&lo, &hi), 1.0)
                }
                Shape::Box { min, max, .. } => size(box_of(min, max), 1.0),
                Shape::Disk { center, radius, .. } => {
                    let (lo, hi) = around(center, *radius);
                    size(box_of(&lo, &hi), annulus(0.0, *radius))
                }
                Shape::Ring {
                    inner_radius,
                    outer_radius,
                    lattice: RingLattice::Polar,
                    sectors,
                    ..
                } => {
                    let (n_r, n_theta) = polar_counts(*inner_radius, *outer_radius, dx, *sectors);
                    size((n_r + 1.0) * n_theta, 1.0)
                }
                Shape::Ring {
                    center,
                    inner_radius,
                    outer_radius,
                    ..
                } => {
                    let (lo, hi) = around(center, *outer_radius);
                    size(box_of(&lo, &hi), annulus(*inner_radius, *outer_radius))
                }
                Shape::Cylinder {
                    radius,
                    inner_radius,
                    ..
                } => {
                    let (lo, hi) = spec.geometry.extent(3).expect("a cylinder has its box");
                    size(box_of(&lo, &hi), annulus(*inner_radius, *radius))
                }
                Shape::Polygon { vertices, .. } => {
                    let (lo, hi) = super::polygon::bounds(vertices);
                    let bounding: f64 = (0..2).map(|k| hi[k] - lo[k]).product();
                    size(box_of(&lo, &hi), super::polygon::area(vertices) / bounding)
                }
                Shape::Points { file } | Shape::Mesh { file, .. } => {
                    // A mesh has at most one cell per line.
                    let path = case.base_dir().join(file);
                    let rows = count_point_rows(&path).map_err(|m| {
                        case.invalid(
                            format!("body.{b}.geometry.file"),
                            format!("{}: {m}", path.display()),
                        )
                    })? as f64;
                    size(rows, 1.0)
                }
            })
        })
        .collect()
}

/// The largest points or mesh file read [bytes]: 1 GiB, about 15 million rows of x, y, z
/// and a volume.
const POINTS_FILE_CAP: u64 = 1 << 30;

/// A points or mesh file that may be read: a regular file (not a device, pipe or folder)
/// of at most [`POINTS_FILE_CAP`] bytes.
fn open_points_file(path: &Path) -> Result<std::fs::File, String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot read: {e}"))?;
    if !meta.is_file() {
        return Err("is not a regular file; give the path of a file".into());
    }
    if meta.len() > POINTS_FILE_CAP {
        return Err(format!(
            "is larger than {POINTS_FILE_CAP} bytes, the most a points or mesh file may hold"
        ));
    }
    std::fs::File::open(path).map_err(|e| format!("cannot read: {e}"))
}

/// A points file as text (see [`open_points_file`]); at most the cap is read, should the
/// file grow after its size was checked.
fn read_points_file(path: &Path) -> Result<String, String> {
    use std::io::Read;
    let mut text = String::new();
    open_points_file(path)?
        .take(POINTS_FILE_CAP + 1)
        .read_to_string(&mut text)
        .map_err(|e| format!("cannot read as UTF-8 text: {e}"))?;
    if text.len() as u64 > POINTS_FILE_CAP {
        return Err(format!(
            "is larger than {POINTS_FILE_CAP} bytes, the most a points or mesh file may hold"
        ));
    }
    Ok(text)
}

/// The data rows of a points file (its non-empty lines after the header), counted in
/// chunks without holding the file.
fn count_point_rows(path: &Path) -> Result<u64, String> {
    use std::io::Read;
    let mut file = open_points_file(path)?.take(POINTS_FILE_CAP + 1);
    let mut chunk = vec![0u8; 1 << 16];
    let (mut rows, mut blank) = (0u64, true);
    loop {
        let read = file
            .read(&mut chunk)
            .map_err(|e| format!("cannot read: {e}"))?;
        if read == 0 {
            break;
        }
        for &byte in &chunk[..read] {
            match byte {
                b'\n' => {
                    rows += u64::from(!blank);
                    blank = true;
                }
                b' ' | b'\t' | b'\r' => {}
                _ => blank = false,
            }
        }
    }
    rows += u64::from(!blank);
    Ok(rows.saturating_sub(1))
}

/// Reads `x,y[,z][,volume][,vx,vy[,vz]]` rows (header required, any column order).
/// Without a volume column every point gets Δx^d; the velocity columns, all or none,
/// give the points' initial velocities. Errors name lines and columns, never the file's text.
fn read_points<D: Dim>(path: &Path, cell: f64) -> Result<Sampled<D>, String> {
    let text = read_points_file(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or("empty file; expected a header line x,y[,z][,volume][,vx,vy[,vz]]")?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |name: &str| names.iter().position(|&c| c == name);
    let axes: Vec<usize> = COORDINATES[..D::N]
        .iter()
        .map(|a| {
            column(a).ok_or(format!(
                "the header (its first non-empty line) has no column `{a}` (needed in {}D); a \
                 points file starts with a header such as `x,y,volume`",
                D::N
            ))
        })
        .collect::<Result<_, _>>()?;
    let volume = column("volume");
    let speeds: Vec<Option<usize>> = ["vx", "vy", "vz"][..D::N]
        .iter()
        .map(|&c| column(c))
        .collect();
    let velocity_columns: Option<Vec<usize>> = speeds.iter().copied().collect();
    if velocity_columns.is_none() && speeds.iter().any(Option::is_some) {
        return Err(format!(
            "the header has some velocity columns but not all of {}; give every component \
             or none",
            ["vx", "vy", "vz"][..D::N].join(", ")
        ));
    }
    let (mut points, mut vols, mut velocities) = (Vec::new(), Vec::new(), Vec::new());
    for (line_no, line) in lines {
        let fields: Vec<f64> = line
            .split(',')
            .map(|f| f.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("line {}: {e}", line_no + 1))?;
        if fields.len() != names.len() || fields.iter().any(|v| !v.is_finite()) {
            return Err(format!(
                "line {}: expected {} finite numbers separated by commas, one per header column",
                line_no + 1,
                names.len()
            ));
        }
        let p: Vec<f64> = axes.iter().map(|&c| fields[c]).collect();
        points.push(D::from_slice(&p));
        let v = volume.map_or(cell, |c| fields[c]);
        if v <= 0.0 {
            return Err(format!(
                "line {}: volume must be positive, found {v}",
                line_no + 1
            ));
        }
        vols.push(v);
        if let Some(columns) = &velocity_columns {
            let v: Vec<f64> = columns.iter().map(|&c| fields[c]).collect();
            velocities.push(D::from_slice(&v));
        }
    }
    Ok(Sampled {
        points,
        volumes: vols,
        corners: Vec::new(),
        velocities: velocity_columns.map(|_| velocities),
    })
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
