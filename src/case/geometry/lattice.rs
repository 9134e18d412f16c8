//! The shapes sampled on the lattice of spacing Δx, and the polar lattice of a ring.

use super::files::{read_mesh, read_points};
use super::{Sampled, file_error};
use crate::case::polygon;
use crate::case::{BodySpec, Case, CaseError, Lattice, RingLattice, Shape, Volumes};
use crate::core::quadrature::CylindricalFrame;
use crate::core::tensor::Dim;

/// The particles of body `b` as its shape's generator makes them.
pub(super) fn sample<D: Dim>(
    case: &Case,
    b: usize,
    spec: &BodySpec,
) -> Result<Sampled<D>, CaseError> {
    let dx = case.spacing;
    let cell = dx.powi(D::N as i32);
    let lattice_of = |lo: &[f64], hi: &[f64], inside: &dyn Fn(&[f64]) -> bool| {
        on_lattice::<D>(case, spec, (lo, hi), inside)
    };
    // The methods that integrate over the lattice's cells take the vertex lattice, whose
    // cells span the shape ([`crate::methods::MethodFamily::lattice_cells`]).
    let vertex = on_vertex_lattice(&spec.geometry, case.method.lattice_cells);
    let geometry = vertex.as_ref().unwrap_or(&spec.geometry);
    Ok(match geometry {
        Shape::Ring {
            center,
            inner_radius,
            outer_radius,
            lattice: RingLattice::Polar,
            sectors,
            ..
        } => polar::<D>(case, spec, center, (*inner_radius, *outer_radius), *sectors)?,
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
                halve_on_faces::<D>(&points, &mut vol, (min, max), dx);
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
        Shape::Tube { base, axis, .. } => {
            let tube = TubeLattice::of(geometry, dx).expect("a tube has its lattice");
            tube.sample::<D>(case, spec, base, *axis)?
        }
        Shape::Polygon { vertices, volumes } => {
            let (lo, hi) = polygon::bounds(vertices);
            let tol = 1e-9 * dx;
            let (points, vol) = lattice_of(&lo, &hi, &|p| polygon::contains(vertices, p, tol))?;
            (points, to_named_volume(geometry, *volumes, D::N, vol)).into()
        }
        Shape::Points { file } => {
            let path = case.base_dir().join(file);
            read_points::<D>(&path, cell).map_err(|m| file_error(case, b, &path, m))?
        }
        Shape::Mesh { file, nodes } => {
            let path = case.base_dir().join(file);
            read_mesh::<D>(&path, *nodes).map_err(|m| file_error(case, b, &path, m))?
        }
    })
}

/// The lattice points lo + i·Δx of body `spec` that satisfy `inside`, each with the volume
/// Δx^d; refused where the lattice has more points than particle ids.
fn on_lattice<D: Dim>(
    case: &Case,
    spec: &BodySpec,
    (lo, hi): (&[f64], &[f64]),
    inside: &dyn Fn(&[f64]) -> bool,
) -> Result<(Vec<D::V>, Vec<f64>), CaseError> {
    let dx = case.spacing;
    let cell = dx.powi(D::N as i32);
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
    Ok((points, vol))
}

/// The shape on the vertex lattice where a method that integrates over the lattice's
/// cells samples a cell-centred box or cylinder; None where the shape is sampled as given.
pub(super) fn on_vertex_lattice(shape: &Shape, cells: bool) -> Option<Shape> {
    match shape {
        Shape::Box {
            min,
            max,
            lattice: Lattice::CellCentred,
            ..
        } if cells => Some(Shape::Box {
            min: min.clone(),
            max: max.clone(),
            volumes: None,
            lattice: Lattice::Vertex,
        }),
        Shape::Cylinder {
            base,
            axis,
            radius,
            inner_radius,
            length,
            lattice: Lattice::CellCentred,
            volumes,
        } if cells => Some(Shape::Cylinder {
            base: base.clone(),
            axis: *axis,
            radius: *radius,
            inner_radius: *inner_radius,
            length: *length,
            lattice: Lattice::Vertex,
            volumes: *volumes,
        }),
        _ => None,
    }
}

/// The tributary volumes of a box's vertex lattice: halved on every face a particle lies
/// on.
fn halve_on_faces<D: Dim>(points: &[D::V], vol: &mut [f64], (min, max): (&[f64], &[f64]), dx: f64) {
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

/// A ring on its polar lattice ([`polar_ring`]), refused where it has more particles than
/// ids.
fn polar<D: Dim>(
    case: &Case,
    spec: &BodySpec,
    center: &[f64],
    (inner_radius, outer_radius): (f64, f64),
    sectors: Option<u32>,
) -> Result<Sampled<D>, CaseError> {
    let dx = case.spacing;
    let (n_r, n_theta) = polar_counts(inner_radius, outer_radius, dx, sectors);
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
    Ok(polar_ring::<D>(
        center,
        (inner_radius, outer_radius),
        (n_r as usize, n_theta as usize),
    ))
}

/// The cylindrical lattice of a [`Shape::Tube`]: n_r × n_θ × n_z cells of the wall, the
/// sector and the length, each count in f64 so that a vanishing spacing gives a huge
/// one, never a wrapped one.
pub(super) struct TubeLattice {
    inner: f64,
    dr: f64,
    theta0: f64,
    dtheta: f64,
    dz: f64,
    counts: [f64; 3],
}

impl TubeLattice {
    /// The lattice of a tube at spacing Δx; None for the other shapes.
    pub(super) fn of(shape: &Shape, dx: f64) -> Option<Self> {
        let Shape::Tube {
            inner_radius,
            radius,
            length,
            angles,
            sectors,
            ..
        } = shape
        else {
            return None;
        };
        let (inner, outer, length) = (*inner_radius, *radius, *length);
        let (angles, sectors) = (*angles, *sectors);
        let [theta0, theta1] = angles.unwrap_or([0.0, 360.0]).map(f64::to_radians);
        let mid = 0.5 * (inner + outer);
        let mut counts = [outer - inner, (theta1 - theta0) * mid, length]
            .map(|span| (span / dx).round().max(1.0));
        if let Some(n) = sectors {
            counts[1] = f64::from(n);
        }
        Some(Self {
            inner,
            dr: (outer - inner) / counts[0],
            theta0,
            dtheta: (theta1 - theta0) / counts[1],
            dz: length / counts[2],
            counts,
        })
    }

    /// The lattice about the axis through `base`.
    pub(super) fn frame(&self, base: &[f64], axis: crate::case::Axis) -> CylindricalFrame {
        CylindricalFrame {
            base: std::array::from_fn(|k| base[k]),
            axis: axis.index(),
            inner: self.inner,
            dr: self.dr,
            theta0: self.theta0,
            span: self.dtheta * self.counts[1],
            dtheta: self.dtheta,
            dz: self.dz,
        }
    }

    /// n_r, n_θ and n_z.
    pub(super) fn counts(&self) -> [f64; 3] {
        self.counts
    }

    pub(super) fn total(&self) -> f64 {
        self.counts.iter().product()
    }

    /// The cell centres about the axis through `base`, each with its cell's volume;
    /// refused where the lattice has more points than particle ids.
    fn sample<D: Dim>(
        &self,
        case: &Case,
        spec: &BodySpec,
        base: &[f64],
        axis: crate::case::Axis,
    ) -> Result<Sampled<D>, CaseError> {
        if self.total() > PARTICLE_ID_LIMIT {
            return Err(case.invalid(
                "spacing",
                format!(
                    "{:e} samples body `{}` on a tube's lattice of {:.3e} points, more than \
                     the {PARTICLE_ID_LIMIT:.0} particle ids hold; increase `spacing`",
                    case.spacing,
                    spec.name,
                    self.total()
                ),
            ));
        }
        let a = axis.index();
        let (u, w) = ((a + 1) % 3, (a + 2) % 3);
        let [n_r, n_theta, n_z] = self.counts.map(|n| n as usize);
        let mut points = Vec::with_capacity(n_r * n_theta * n_z);
        let mut volumes = Vec::with_capacity(points.capacity());
        for k in 0..n_z {
            for j in 0..n_theta {
                let (sin, cos) = (self.theta0 + (j as f64 + 0.5) * self.dtheta).sin_cos();
                for i in 0..n_r {
                    let (r0, r1) = (
                        self.inner + i as f64 * self.dr,
                        self.inner + (i + 1) as f64 * self.dr,
                    );
                    let r = 0.5 * (r0 + r1);
                    let mut p = [base[0], base[1], base[2]];
                    p[a] += (k as f64 + 0.5) * self.dz;
                    p[u] += r * cos;
                    p[w] += r * sin;
                    points.push(D::from_slice(&p));
                    volumes.push(0.5 * (r1 * r1 - r0 * r0) * self.dtheta * self.dz);
                }
            }
        }
        Ok(Sampled {
            points,
            volumes,
            corners: Vec::new(),
            velocities: None,
        })
    }
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
pub(super) fn polar_counts(inner: f64, outer: f64, dx: f64, sectors: Option<u32>) -> (f64, f64) {
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

pub(super) fn around(center: &[f64], r: f64) -> (Vec<f64>, Vec<f64>) {
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
pub(super) fn lattice_counts(lo: &[f64], hi: &[f64], dx: f64) -> Vec<f64> {
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
