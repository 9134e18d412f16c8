//! The size of each body, estimated without sampling it: its particles, and its
//! neighbour pairs, from the lattice's density, or from the density of the points a
//! points or mesh file actually holds.

use super::file_error;
use super::files::{read_mesh, read_points};
use super::lattice::{TubeLattice, around, lattice_counts, on_vertex_lattice, polar_counts};
use crate::case::{Axis, Case, CaseError, HoleAxis, Lattice, RingLattice, Shape};
use crate::core::tensor::{D2, D3, Dim};
use std::collections::HashMap;
use std::path::Path;

/// The size of a body, estimated without sampling it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySize {
    /// Its particles: the lattice points of its bounding box times the fraction of the
    /// box the shape fills (exact for a box; π/4 of the box for a disk), or the points a
    /// points or mesh file gives (read as the sampler reads them).
    pub particles: f64,
    /// The lattice points the sampler visits to find them (its bounding box's).
    pub visited: f64,
    /// Its neighbour pairs within the kernel's support, κh, each counted from both ends:
    /// on a lattice, those of its bounding box's lattice ([`Grid::node_pairs`], exact for
    /// a box, with the mirror particles of the planes on its faces among the neighbours)
    /// times the fraction the shape fills; for a points or mesh file, from a histogram of
    /// its points ([`histogram_pairs`]), which sees a file denser than `spacing`.
    pub pairs: f64,
    /// The cells between its lattice points, which a Galerkin method integrates over: the
    /// bounding box's cells times the fraction the shape fills (the polar lattice's own);
    /// for a points or mesh file, one a point.
    pub cells: f64,
    /// The pairs of the 2^d points of the two-point Gauss rule in each cell with the
    /// particles within κh of them ([`Grid::cell_pairs`]).
    pub gauss_pairs: f64,
    /// The pairs of the cells' centres with the particles within κh of them.
    pub centre_pairs: f64,
    /// The pairs of its lattice points and of its cells' centres with the lattice points
    /// within [`BOX_HALF`] spacings along every axis (the candidate boxes of
    /// `ul-weak-form`, a point itself included; [`Grid::box_pairs`]).
    pub box_pairs: f64,
    pub centre_box_pairs: f64,
    /// The mirror particles of the planes on its faces ([`Grid::ghosts`]).
    pub ghosts: f64,
}

/// A lattice of `counts` points along each axis at unit spacing, with mirror planes on
/// some of its faces (`mirrored[k]`: the low and high face of axis k), and the support
/// radius `reach` in spacings.
struct Grid {
    counts: Vec<f64>,
    mirrored: Vec<[bool; 2]>,
    /// The offset of the faces from the outer rows, in spacings: 0 on the vertex
    /// lattice, ½ on the cell-centred one.
    inset: f64,
    reach: f64,
}

/// The half-width of the candidate boxes in spacings (`ul-weak-form`'s
/// `points::CANDIDATE_BOX`).
pub const BOX_HALF: f64 = 3.0;

/// The most lattice offsets within a support the pair sums of [`Grid`] visit: past it
/// (h_over_dx in the hundreds), the bulk density alone.
const MOST_OFFSETS: f64 = 1e6;

impl Grid {
    /// The offsets o ∈ ℤ^d of the lattice points within the support of a point at
    /// `origin` (in spacings, within its cell).
    fn offsets(&self, origin: &[f64]) -> Vec<Vec<i64>> {
        let d = self.counts.len();
        let r = self.reach * (1.0 + 1e-9);
        let span = r.ceil() as i64 + 1;
        let side = (2 * span + 1) as usize;
        (0..side.pow(d as u32))
            .map(|j| {
                (0..d)
                    .map(|k| (j / side.pow(k as u32) % side) as i64 - span)
                    .collect::<Vec<i64>>()
            })
            .filter(|o| {
                let q: f64 = o
                    .iter()
                    .zip(origin)
                    .map(|(&o, f)| (o as f64 - f).powi(2))
                    .sum();
                q <= r * r
            })
            .collect()
    }

    /// Whether the offset sums stay within [`MOST_OFFSETS`].
    fn summable(&self) -> bool {
        (2.0 * self.reach + 3.0).powi(self.counts.len() as i32) <= MOST_OFFSETS
    }

    /// The pairs of lattice points within the support, each counted from both ends: for
    /// an offset o, Π_k of the points along axis k that have a neighbour o_k away, all of
    /// them where the face o_k points to has a mirror plane (its images stand in).
    fn node_pairs(&self) -> f64 {
        let origin = vec![0.0; self.counts.len()];
        self.offsets(&origin)
            .iter()
            .filter(|o| o.iter().any(|&c| c != 0))
            .map(|o| {
                (0..o.len())
                    .map(|k| {
                        let side = usize::from(o[k] > 0);
                        if o[k] != 0 && self.mirrored[k][side] {
                            self.counts[k]
                        } else {
                            (self.counts[k] - o[k].abs() as f64).max(0.0)
                        }
                    })
                    .product::<f64>()
            })
            .sum()
    }

    /// The pairs of the points at `origins` (in spacings within each cell) of every cell
    /// with the lattice points within the support: a cell c along an axis of N = n − 1
    /// cells has the point c + o on the lattice for N + 1 − o cells when o ≥ 1, N + o when
    /// o ≤ 0.
    fn cell_pairs(&self, origins: &[Vec<f64>]) -> f64 {
        origins
            .iter()
            .map(|f| {
                self.offsets(f)
                    .iter()
                    .map(|o| {
                        (0..o.len())
                            .map(|k| {
                                let cells = (self.counts[k] - 1.0).max(0.0);
                                let along = if o[k] >= 1 {
                                    cells + 1.0 - o[k] as f64
                                } else {
                                    cells + o[k] as f64
                                };
                                along.max(0.0)
                            })
                            .product::<f64>()
                    })
                    .sum::<f64>()
            })
            .sum()
    }

    /// The pairs of the lattice points (or, with `centres`, of the cells' centres) with
    /// the lattice points at most [`BOX_HALF`] away along every axis, a point itself
    /// included: the product over the axes of the pairs along each, Σ_o (n − |o|) over
    /// |o| ≤ 3 from the points of an axis of n, Σ_o (N + 1 − o) for o = 1..3 and (N + o)
    /// for o = −2..0 from the N = n − 1 centres (the point c + o of centre c + ½).
    fn box_pairs(&self, centres: bool) -> f64 {
        let half = BOX_HALF as i64;
        let offsets = match centres {
            true => 1 - half..=half,
            false => -half..=half,
        };
        self.counts
            .iter()
            .map(|&n| {
                let cells = (n - 1.0).max(0.0);
                (offsets.clone())
                    .map(|o| match (centres, o >= 1) {
                        (false, _) => n - o.abs() as f64,
                        (true, true) => cells + 1.0 - o as f64,
                        (true, false) => cells + o as f64,
                    })
                    .map(|along| along.max(0.0))
                    .sum::<f64>()
            })
            .product()
    }

    /// The mirror particles: the images of the points within the support of a set of
    /// mirrored faces of distinct axes, one for every such set (a face's, an edge's, a
    /// corner's), Π_k (n_k + f_k r_k) − Π_k n_k with f_k the mirrored faces of axis k and
    /// r_k its rows within the support of a face.
    fn ghosts(&self) -> f64 {
        let rows = (self.reach - self.inset).max(0.0).ceil();
        let (mut with, mut without) = (1.0, 1.0);
        for (k, &n) in self.counts.iter().enumerate() {
            let faces = self.mirrored[k].iter().filter(|&&m| m).count() as f64;
            with *= n + faces * rows.min(n);
            without *= n;
        }
        with - without
    }
}

/// The Gauss points of the two-point rule in a unit cell of `d` dimensions.
fn gauss_points(d: usize) -> Vec<Vec<f64>> {
    let g = 0.5 / 3f64.sqrt();
    (0..1usize << d)
        .map(|j| {
            (0..d)
                .map(|k| if j >> k & 1 == 0 { 0.5 - g } else { 0.5 + g })
                .collect()
        })
        .collect()
}

impl Grid {
    /// The size of a body this grid samples, of which the shape fills `fraction`, found
    /// among `visited` lattice points. In f64: a spacing of 1e-300 gives 1e600 → ∞, never
    /// a wrapped count; ∞ · 0 (an infinite lattice of a zero fraction) counts as ∞.
    fn size(&self, fraction: f64, visited: f64) -> BodySize {
        let finite = |count: f64| if count.is_nan() { f64::INFINITY } else { count };
        let d = self.counts.len();
        let points: f64 = self.counts.iter().product();
        let cells: f64 = self.counts.iter().map(|c| (c - 1.0).max(0.0)).product();
        let (gauss, centre) = (gauss_points(d), vec![vec![0.5; d]]);
        let (pairs, gauss_pairs, centre_pairs) = if self.summable() {
            (
                self.node_pairs(),
                self.cell_pairs(&gauss),
                self.cell_pairs(&centre),
            )
        } else {
            // The bulk's lattice points within the support, the ball's volume.
            let ball = match d {
                2 => std::f64::consts::PI * self.reach.powi(2),
                _ => 4.0 / 3.0 * std::f64::consts::PI * self.reach.powi(3),
            };
            let around = ball.floor() + 1.0;
            (
                points * ball.floor(),
                gauss.len() as f64 * cells * around,
                cells * around,
            )
        };
        BodySize {
            particles: finite(points * fraction),
            visited,
            pairs: finite(pairs * fraction),
            cells: finite(cells * fraction),
            gauss_pairs: finite(gauss_pairs * fraction),
            centre_pairs: finite(centre_pairs * fraction),
            box_pairs: finite(self.box_pairs(false) * fraction),
            centre_box_pairs: finite(self.box_pairs(true) * fraction),
            ghosts: finite(self.ghosts() * fraction),
        }
    }
}

/// The mirror planes of `case` on the faces of the box [lo, hi] of `d` dimensions.
fn mirrored(case: &Case, lo: &[f64], hi: &[f64], d: usize) -> Vec<[bool; 2]> {
    (0..d)
        .map(|k| {
            let on = |face: f64| {
                case.mirrors
                    .iter()
                    .any(|m| m.normal.index() == k && (m.at - face).abs() < 0.5 * case.spacing)
            };
            [on(lo[k]), on(hi[k])]
        })
        .collect()
}

/// A curved section's lattice points along each of its axes: its diameter's spacings,
/// the lattice points of its box less one (but along `axis`, which it runs through).
fn across(counts: Vec<f64>, axis: Option<usize>) -> Vec<f64> {
    (0..counts.len())
        .map(|k| match Some(k) == axis {
            true => counts[k],
            false => (counts[k] - 1.0).max(1.0),
        })
        .collect()
}

/// A [`Shape::Tube`]'s size on its lattice, across the wall, around the angles and along
/// the axis: a mirror plane not normal to the axis may close the angles' faces, one
/// normal to it the end faces.
fn tube_size(case: &Case, shape: &Shape, axis: Axis, reach: f64) -> BodySize {
    let tube = TubeLattice::of(shape, case.spacing).expect("a tube has its lattice");
    let (lo, hi) = shape.extent(3).expect("a tube has its box");
    let a = axis.index();
    let around = case.mirrors.iter().any(|m| m.normal.index() != a);
    let lattice = Grid {
        counts: tube.counts().to_vec(),
        mirrored: vec![[false; 2], [around; 2], mirrored(case, &lo, &hi, 3)[a]],
        inset: 0.5,
        reach,
    };
    BodySize {
        cells: 0.0,
        ..lattice.size(1.0, tube.total())
    }
}

/// The size of each body of a case.
pub fn estimate_particles(case: &Case) -> Result<Vec<BodySize>, CaseError> {
    let dx = case.spacing;
    let half = 0.5 * dx;
    let box_of = |lo: &[f64], hi: &[f64]| lattice_counts(lo, hi, dx);
    let annulus =
        |inner: f64, outer: f64| std::f64::consts::FRAC_PI_4 * (1.0 - (inner / outer).powi(2));
    let d = case.dim();
    let reach = case.method.kernel.support_factor() * case.method.h_over_dx;
    case.bodies
        .iter()
        .enumerate()
        .map(|(b, spec)| {
            // The methods that integrate over cells sample on the vertex lattice.
            let vertex = on_vertex_lattice(&spec.geometry, case.method.lattice_cells);
            let geometry = vertex.as_ref().unwrap_or(&spec.geometry);
            let grid = |counts: Vec<f64>, inset: f64| {
                let (lo, hi) = geometry.extent(d).expect("a lattice shape has its box");
                Grid {
                    counts,
                    mirrored: mirrored(case, &lo, &hi, d),
                    inset,
                    reach,
                }
            };
            let size = match geometry {
                Shape::Box {
                    min,
                    max,
                    lattice: Lattice::CellCentred,
                    ..
                } => {
                    let lo: Vec<f64> = min.iter().map(|m| m + half).collect();
                    let hi: Vec<f64> = max.iter().map(|m| m - half).collect();
                    let counts = box_of(&lo, &hi);
                    let visited = counts.iter().product();
                    grid(counts, 0.5).size(1.0, visited)
                }
                Shape::Box { min, max, .. } => {
                    let counts = box_of(min, max);
                    let visited = counts.iter().product();
                    grid(counts, 0.0).size(1.0, visited)
                }
                Shape::Disk { center, radius, .. } => {
                    let (lo, hi) = around(center, *radius);
                    let counts = box_of(&lo, &hi);
                    let visited = counts.iter().product();
                    grid(across(counts, None), 0.0).size(annulus(0.0, *radius), visited)
                }
                Shape::Ring {
                    inner_radius,
                    outer_radius,
                    lattice: RingLattice::Polar,
                    sectors,
                    ..
                } => {
                    let (n_r, n_theta) = polar_counts(*inner_radius, *outer_radius, dx, *sectors);
                    let counts = vec![n_r + 1.0, n_theta];
                    let polar = Grid {
                        mirrored: vec![[false; 2]; 2],
                        counts,
                        inset: 0.0,
                        reach,
                    };
                    BodySize {
                        cells: n_r * n_theta,
                        ..polar.size(1.0, (n_r + 1.0) * n_theta)
                    }
                }
                Shape::Tube { axis, .. } => tube_size(case, geometry, *axis, reach),
                Shape::Ring {
                    center,
                    inner_radius,
                    outer_radius,
                    ..
                } => {
                    let (lo, hi) = around(center, *outer_radius);
                    let counts = box_of(&lo, &hi);
                    let visited = counts.iter().product();
                    let fraction = annulus(*inner_radius, *outer_radius);
                    grid(across(counts, None), 0.0).size(fraction, visited)
                }
                Shape::Cylinder {
                    radius,
                    inner_radius,
                    axis,
                    lattice,
                    ..
                } => {
                    let (lo, hi) = geometry.extent(3).expect("a cylinder has its box");
                    let counts = box_of(&lo, &hi);
                    let visited = counts.iter().product();
                    // Cell-centred, a point less along the axis too.
                    let (counts, inset) = match lattice {
                        Lattice::CellCentred => (across(counts, None), 0.5),
                        Lattice::Vertex => (across(counts, Some(axis.index())), 0.0),
                    };
                    let fraction = annulus(*inner_radius, *radius);
                    grid(counts, inset).size(fraction, visited)
                }
                Shape::Polygon { vertices, .. } => {
                    let (lo, hi) = crate::case::polygon::bounds(vertices);
                    let bounding: f64 = (0..2).map(|k| hi[k] - lo[k]).product();
                    let counts = box_of(&lo, &hi);
                    let visited = counts.iter().product();
                    let fraction = crate::case::polygon::area(vertices) / bounding;
                    grid(counts, 0.0).size(fraction, visited)
                }
                Shape::Points { file } | Shape::Mesh { file, .. } => {
                    file_size(case, b, &spec.geometry, file, reach)?
                }
            };
            Ok(drilled(size, spec, d, dx, reach))
        })
        .collect()
}

/// The size of body `b` of `case`, a points or mesh `file` of `shape`, for a support of
/// `reach` spacings: its points, their pairs by [`histogram_pairs`], a cell a point, whose
/// Gauss points and centre see the particles a particle sees, and the particle itself.
fn file_size(
    case: &Case,
    b: usize,
    shape: &Shape,
    file: &Path,
    reach: f64,
) -> Result<BodySize, CaseError> {
    let (d, dx) = (case.dim(), case.spacing);
    let path = case.base_dir().join(file);
    let points = match d {
        2 => file_points::<D2>(shape, &path, dx),
        _ => file_points::<D3>(shape, &path, dx),
    }
    .map_err(|m| file_error(case, b, &path, m))?;
    let n = points.len() as f64;
    let pairs = histogram_pairs(&points, d, reach * dx);
    let around = pairs / n.max(1.0) + 1.0;
    Ok(BodySize {
        particles: n,
        visited: n,
        pairs,
        cells: n,
        gauss_pairs: f64::from(1u32 << d) * n * around,
        centre_pairs: n * around,
        box_pairs: n * (2.0 * BOX_HALF + 1.0).powi(d as i32),
        centre_box_pairs: n * (2.0 * BOX_HALF).powi(d as i32),
        ghosts: 0.0,
    })
}

/// A body's size less its holes: the particles, cells and mirror particles scaled by
/// the share of its volume the holes take (a hole along an axis runs through the body's
/// extent along it); the pairs besides lose those that crossed the holes' surfaces
/// (`reach` spacings), ρ² π κh⁴/2 a unit area in 3D and ρ² 4 κh³/3 a unit length in 2D
/// counted from both ends, the pairs across a plane.
fn drilled(
    size: BodySize,
    spec: &crate::case::BodySpec,
    d: usize,
    dx: f64,
    reach: f64,
) -> BodySize {
    let Some((lo, hi)) = spec.geometry.extent(d).filter(|_| !spec.holes.is_empty()) else {
        return size;
    };
    let pi = std::f64::consts::PI;
    // Each hole's volume and surface, in spacings.
    let (volume, surface) = spec.holes.iter().fold((0.0, 0.0), |(v, s), h| {
        let r = h.radius / dx;
        let (dv, ds) = match (d, h.axis) {
            (2, _) => (pi * r * r, 2.0 * pi * r),
            // An oblique hole's length through the body is not known here: it is not
            // subtracted, and the estimate stays an upper bound.
            (_, Some(HoleAxis::Direction(_))) => (0.0, 0.0),
            (_, Some(HoleAxis::Named(a))) => {
                let length = (hi[a.index()] - lo[a.index()]) / dx;
                (pi * r * r * length, 2.0 * pi * r * length)
            }
            _ => (4.0 / 3.0 * pi * r.powi(3), 4.0 * pi * r * r),
        };
        (v + dv, s + ds)
    });
    let kept = (1.0 - volume / size.particles).clamp(0.0, 1.0);
    let crossing = match d {
        2 => 4.0 / 3.0 * reach.powi(3),
        _ => pi / 2.0 * reach.powi(4),
    };
    let pairs = (size.pairs * kept - surface * crossing).max(0.0);
    let paired = if size.pairs > 0.0 {
        pairs / size.pairs
    } else {
        kept
    };
    BodySize {
        particles: size.particles * kept,
        visited: size.visited,
        pairs,
        cells: size.cells * kept,
        gauss_pairs: size.gauss_pairs * paired,
        centre_pairs: size.centre_pairs * paired,
        box_pairs: size.box_pairs * paired,
        centre_box_pairs: size.centre_box_pairs * paired,
        ghosts: size.ghosts * kept,
    }
}

/// The positions of a points or mesh body, as the sampler reads them.
fn file_points<D: Dim>(shape: &Shape, path: &Path, dx: f64) -> Result<Vec<[f64; 3]>, String> {
    let sampled = match shape {
        Shape::Mesh { nodes, .. } => read_mesh::<D>(path, *nodes)?,
        _ => read_points::<D>(path, dx.powi(D::N as i32))?,
    };
    Ok(sampled.points.into_iter().map(D::to3).collect())
}

/// The neighbour pairs among `points` (ordered, each pair twice, as the lists hold them)
/// within `radius`, estimated from a histogram of cells of half the radius: the points of
/// two cells c and c + o are taken as spread evenly over each, so that a pair of them is
/// within the radius with the probability w_o that a midpoint rule of [`QUADRATURE`]^d
/// points a cell gives, and the pairs are Σ_c n_c (Σ_o w_o n_{c+o} − w_0), over the 5^d
/// offsets o that can hold a neighbour. Linear in the points, with memory for the
/// occupied cells only; it sees a file denser than `spacing`, and a body's edges at the
/// resolution of its cells.
pub(super) fn histogram_pairs(points: &[[f64; 3]], d: usize, radius: f64) -> f64 {
    let side = 0.5 * radius;
    let cell = |x: &[f64; 3]| -> [i64; 3] {
        let mut c = [0; 3];
        for k in 0..d {
            c[k] = (x[k] / side).floor() as i64;
        }
        c
    };
    let mut counts: HashMap<[i64; 3], f64> = HashMap::new();
    for x in points {
        *counts.entry(cell(x)).or_default() += 1.0;
    }
    let weights = offset_weights(d);
    counts
        .iter()
        .map(|(c, &n)| {
            let near: f64 = weights
                .iter()
                .filter_map(|(o, w)| {
                    let n = counts.get(&[c[0] + o[0], c[1] + o[1], c[2] + o[2]])?;
                    Some(w * n)
                })
                .sum();
            n * (near - weights[weights.len() / 2].1).max(0.0)
        })
        .sum()
}

/// The midpoint rule's points along each side of a cell in [`offset_weights`].
const QUADRATURE: usize = 6;

/// For each offset o ∈ {−2, …, 2}^d of cells of half a radius, in lexicographic order (so
/// o = 0 is the middle entry), the probability that a point spread evenly over cell 0 and
/// one over cell o are within the radius (of 1: two cell sides).
fn offset_weights(d: usize) -> Vec<([i64; 3], f64)> {
    let m = QUADRATURE;
    let nodes: Vec<[f64; 3]> = (0..m.pow(d as u32))
        .map(|q| {
            let mut p = [0.0; 3];
            for (k, p) in p.iter_mut().enumerate().take(d) {
                *p = ((q / m.pow(k as u32) % m) as f64 + 0.5) / m as f64;
            }
            p
        })
        .collect();
    (0..5i64.pow(d as u32))
        .map(|j| {
            let mut o = [0i64; 3];
            for (k, o) in o.iter_mut().enumerate().take(d) {
                *o = j / 5i64.pow((d - 1 - k) as u32) % 5 - 2;
            }
            let within = nodes
                .iter()
                .flat_map(|a| nodes.iter().map(move |b| (a, b)))
                .filter(|(a, b)| {
                    // In cell sides: within two sides.
                    let r2: f64 = (0..d).map(|k| (b[k] + o[k] as f64 - a[k]).powi(2)).sum();
                    r2 < 4.0
                })
                .count();
            (o, within as f64 / nodes.len().pow(2) as f64)
        })
        .collect()
}
