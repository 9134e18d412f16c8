//! Quadrature points: a second point set beside the particles, for the Galerkin methods
//! (the weak forms and the finite elements of seed 000 §5.6–5.7 and the FEM references).
//!
//! - [`lattice_cells`]: the background cells of lattice bodies, every lattice square
//!   (cube) whose 2^d corners are particles of one body;
//! - [`QuadraturePoints`]: Gauss points in those cells, with their weights w_q; or the
//!   particles themselves (nodal integration), alone or with a stress point at every cell
//!   centre (seed 001 §5.2);
//! - [`SmoothingCells`]: the representative domain of every particle for stabilised
//!   conforming nodal integration (SCNI; Chen, Wu, Yoon and You 2001), with the Gauss
//!   points of its faces;
//! - [`Shapes`]: the nodes (particles) whose shape functions reach each point, as a CSR
//!   from points to nodes, with N_a(x_q) and ∇N_a(x_q) per pair: bilinear (trilinear)
//!   isoparametric functions of the cells, reproducing-kernel (RKPM) or moving
//!   least-squares (MLS) functions, or Shepard functions with the Krongauz–Belytschko
//!   corrected gradient, whose test functions differ from the trial functions; or the
//!   meshfree functions at the particles with gradients smoothed over their smoothing
//!   cells (SCNI);
//! - [`Gather`]: the transposed lists, from each node to its pairs, so that the forces
//!   f_a = −Σ_q w_q P_q ∇N_a(x_q) are gathered per node rather than scattered per point.

use crate::core::tensor::Dim;

use std::collections::HashMap;
use thiserror::Error;

mod shapes;

pub use shapes::{Family, Gather, KbShape, ShapeRow, Shapes, krongauz_belytschko_shapes};

/// The corners of the unit square and cube in VTK order (`VTK_QUAD`, `VTK_HEXAHEDRON`:
/// the lower face counter-clockwise, then the upper face).
const CORNERS: [[i64; 3]; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [1, 1, 0],
    [0, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [1, 1, 1],
    [0, 1, 1],
];

/// Why the cells or the shape functions of a case cannot be built.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum QuadratureError {
    #[error(
        "particle {particle} at {position:?} is not on the lattice of spacing {spacing} of its \
         body (offset {offset:.3e} of a spacing from the nearest lattice point); cells are \
         lattice squares, so give the body a shape sampled on the lattice, or a points file \
         on one"
    )]
    OffLattice {
        particle: usize,
        position: [f64; 3],
        spacing: f64,
        offset: f64,
    },
    #[error(
        "body {body} has no cell: no lattice square (cube) of it has all its corners; a body \
         must be at least two particles across in every direction"
    )]
    NoCell { body: u32 },
    #[error(
        "the corrected shape functions at point {point} at {position:?} (a quadrature \
         point, a particle, or a point on the boundary of the smoothing cell of particle \
         {point}) are singular: {nodes} particles reach it, too few or all on one line; \
         increase h/dx"
    )]
    Singular {
        point: usize,
        position: [f64; 3],
        nodes: usize,
    },
}

/// The background cells: `corners[c * 2^d..(c + 1) * 2^d]` are the particles at the
/// corners of cell c, in VTK order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cells {
    pub corners: Vec<u32>,
    /// The body of every cell.
    pub body: Vec<u32>,
}

impl Cells {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.body.len()
    }

    pub fn is_empty(&self) -> bool {
        self.body.is_empty()
    }

    /// The corners of cell c.
    pub fn of<D: Dim>(&self, c: usize) -> &[u32] {
        let k = 1 << D::N;
        &self.corners[c * k..(c + 1) * k]
    }
}

/// The cylindrical lattice of a tube (`case::Shape::Tube`), whose particles sit at the
/// centres of its cells: the lattice coordinates of a point are ((r − r_in)/Δr − ½,
/// (θ − θ0)/Δθ − ½, (x_a − base_a)/Δz − ½) about the axis a through `base`, integers at
/// the particles. θ turns from the axis after a towards the one after that.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CylindricalFrame {
    pub base: [f64; 3],
    pub axis: usize,
    pub inner: f64,
    pub dr: f64,
    pub theta0: f64,
    /// θ1 − θ0 of the sector.
    pub span: f64,
    pub dtheta: f64,
    pub dz: f64,
}

impl CylindricalFrame {
    /// The lattice coordinates of x. θ is taken within half a turn of the middle of the
    /// sector, so that the images of the particles across a mirror plane on either edge
    /// continue the rays.
    fn coordinates(&self, x: [f64; 3]) -> [f64; 3] {
        use std::f64::consts::{PI, TAU};
        let a = self.axis;
        let (u, w) = ((a + 1) % 3, (a + 2) % 3);
        let (du, dw) = (x[u] - self.base[u], x[w] - self.base[w]);
        let mid = 0.5 * self.span;
        let theta = mid + (dw.atan2(du) - self.theta0 - mid + PI).rem_euclid(TAU) - PI;
        [
            (du.hypot(dw) - self.inner) / self.dr - 0.5,
            theta / self.dtheta - 0.5,
            (x[a] - self.base[a]) / self.dz - 0.5,
        ]
    }

    /// n_θ where the rays close the circle (their index wraps round), else None.
    fn rays(&self) -> Option<i64> {
        let n = (std::f64::consts::TAU / self.dtheta).round();
        ((self.span - std::f64::consts::TAU).abs() < 1e-9).then_some(n as i64)
    }
}

/// The cells of the bodies: those `given` by their generator (a polar ring's, a mesh's
/// read at its vertices), then for every other body each square (cube) of its lattice
/// whose 2^d corners are particles of the body: the tube's cylindrical lattice of
/// `tubes[b]` where it is given (cells of the particles at their corners, not centres),
/// else the lattice of spacing Δx anchored at the body's smallest coordinates. A particle
/// off its lattice is an error, as is a body without a cell.
pub fn lattice_cells<D: Dim>(
    x0: &[D::V],
    body: &[u32],
    spacing: f64,
    given: &Cells,
    tubes: &[Option<CylindricalFrame>],
) -> Result<Cells, QuadratureError> {
    let bodies = body.iter().map(|&b| b as usize + 1).max().unwrap_or(0);
    let mut generated = vec![false; bodies];
    for &b in &given.body {
        generated[b as usize] = true;
    }
    let on_lattice = |b: u32| !generated[b as usize];
    let tube = |b: u32| tubes.get(b as usize).and_then(Option::as_ref);
    // The lattice index a body's corner is kept under: a closed tube's rays wrap round.
    let key = |b: u32, mut at: [i64; 3]| {
        if let Some(n) = tube(b).and_then(CylindricalFrame::rays) {
            at[1] = at[1].rem_euclid(n);
        }
        (b, at)
    };
    let mut origin = vec![[f64::INFINITY; 3]; bodies];
    for (&x, &b) in x0.iter().zip(body).filter(|(_, b)| on_lattice(**b)) {
        let x = D::to3(x);
        for k in 0..D::N {
            origin[b as usize][k] = origin[b as usize][k].min(x[k]);
        }
    }
    let mut index = HashMap::with_capacity(x0.len());
    let mut lattice_index = Vec::with_capacity(x0.len());
    for (i, (&x, &b)) in x0.iter().zip(body).enumerate() {
        if !on_lattice(b) {
            lattice_index.push(None);
            continue;
        }
        let x = D::to3(x);
        let coordinates = match tube(b) {
            Some(frame) => frame.coordinates(x),
            None => std::array::from_fn(|k| (x[k] - origin[b as usize][k]) / spacing),
        };
        let mut at = [0i64; 3];
        for k in 0..D::N {
            let s = coordinates[k];
            let offset = (s - s.round()).abs();
            if offset > 1e-6 {
                return Err(QuadratureError::OffLattice {
                    particle: i,
                    position: x,
                    spacing,
                    offset,
                });
            }
            at[k] = s.round() as i64;
        }
        index.insert(key(b, at), i as u32);
        lattice_index.push(Some(at));
    }
    let mut cells = given.clone();
    let corners = &CORNERS[..1 << D::N];
    for (base, &b) in lattice_index.iter().zip(body) {
        let Some(base) = base else { continue };
        let found: Option<Vec<u32>> = corners
            .iter()
            .map(|c| index.get(&key(b, [base[0] + c[0], base[1] + c[1], base[2] + c[2]])))
            .map(|j| j.copied())
            .collect();
        if let Some(found) = found {
            cells.corners.extend(found);
            cells.body.push(b);
        }
    }
    for b in 0..bodies as u32 {
        if !cells.body.contains(&b) {
            return Err(QuadratureError::NoCell { body: b });
        }
    }
    Ok(cells)
}

/// The Gauss rule per cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// One point at the cell centre, weight 2^d (the stress points of seed 000 §5.7).
    Centre,
    /// 2^d points at ξ_k = ±1/√3, weight 1 each (exact for the bilinear stiffness).
    Gauss2,
}

impl Rule {
    /// The weight of each point in the parent cell [−1, 1]^d, so that w_q = weight·det J.
    pub fn weight<D: Dim>(self) -> f64 {
        self.weight_in(D::N)
    }

    /// [`Self::weight`] in dimension `dim`.
    pub fn weight_in(self, dim: usize) -> f64 {
        match self {
            Self::Centre => f64::from(1 << dim),
            Self::Gauss2 => 1.0,
        }
    }
}

/// Quadrature points in the cells, in the reference configuration.
#[derive(Clone, Debug)]
pub struct QuadraturePoints<D: Dim> {
    /// Positions X_q.
    pub x0: Vec<D::V>,
    /// Weights w_q = (Gauss weight)·det J(ξ_q): the reference volume each point carries.
    pub weight: Vec<f64>,
    /// The cell of every point (empty for points not in cells: particles, stress points).
    pub cell: Vec<u32>,
    /// The body of every point.
    pub body: Vec<u32>,
    /// The parent points of the rule with their functions, one per point of a cell.
    pub rule: Vec<Parent>,
    /// Which of the rule's parent points each point is (empty as `cell`).
    pub parent: Vec<u8>,
    /// How many of the first points are the particles themselves, in their order: all of
    /// them for nodal and stress-point integration, none for Gauss points.
    pub particles: usize,
}

impl<D: Dim> QuadraturePoints<D> {
    /// ∂N_a/∂ξ of corner `corner` of point q's cell at the point's parent point (points in
    /// cells only).
    pub fn parent_gradient(&self, q: usize, corner: usize) -> D::V {
        let dn = self.rule[self.parent[q] as usize].dn[corner];
        D::from_slice(&dn[..D::N])
    }

    /// The points of `rule` in every cell, mapped isoparametrically from the parent cell.
    pub fn new(cells: &Cells, x0: &[D::V], rule: Rule) -> Self {
        let parents: Vec<[f64; 3]> = match rule {
            Rule::Centre => vec![[0.0; 3]],
            Rule::Gauss2 => {
                let g = 1.0 / 3f64.sqrt();
                CORNERS[..1 << D::N]
                    .iter()
                    .map(|c| c.map(|s| if s == 0 { -g } else { g }))
                    .map(|mut xi| {
                        xi[D::N..].fill(0.0);
                        xi
                    })
                    .collect()
            }
        };
        let gauss_weight = rule.weight::<D>();
        let mut points = Self {
            x0: Vec::new(),
            weight: Vec::new(),
            cell: Vec::new(),
            body: Vec::new(),
            rule: parents.into_iter().map(Parent::at::<D>).collect(),
            parent: Vec::new(),
            particles: 0,
        };
        for c in 0..cells.len() {
            let corners = cells.of::<D>(c);
            for (k, parent) in points.rule.iter().enumerate() {
                let x = corners
                    .iter()
                    .zip(&parent.n)
                    .fold(D::zero(), |s, (&a, &na)| s + x0[a as usize] * na);
                let j = jacobian::<D>(corners, x0, &parent.dn);
                points.x0.push(x);
                points.weight.push(gauss_weight * D::det(j));
                points.cell.push(c as u32);
                points.body.push(cells.body[c]);
                points.parent.push(k as u8);
            }
        }
        points
    }

    /// The particles as points with their volumes as weights: nodal integration (seed 001
    /// eq 59, ∫ f dΩ0 ≈ Σ_J f(X_J) V_J^0). No point lies in a cell.
    pub fn at_particles(x0: &[D::V], vol: &[f64], body: &[u32]) -> Self {
        Self {
            x0: x0.to_vec(),
            weight: vol.to_vec(),
            cell: Vec::new(),
            body: body.to_vec(),
            rule: Vec::new(),
            parent: Vec::new(),
            particles: x0.len(),
        }
    }

    /// The particles, then a stress point at the centre of every cell (seed 001 §5.2),
    /// weighted by the Voronoi diagram of both together (eq 65): on a lattice the stress
    /// point's cell is half its square (cube) and each of the 2^d corners gets a 2^(d+1)-th,
    /// so a particle weighs half its particle-only Voronoi volume (Δx²/2 inside, Δx²/4 on
    /// an edge and Δx²/8 at a corner in 2D) and the weights sum to the cells' volume. A
    /// particle that is no cell's corner weighs nothing. No point lies in a cell.
    pub fn with_stress_points(cells: &Cells, x0: &[D::V], body: &[u32]) -> Self {
        let centres = Self::new(cells, x0, Rule::Centre);
        let corners = 1 << D::N;
        let mut weight = vec![0.0; x0.len()];
        for (c, &volume) in centres.weight.iter().enumerate() {
            for &a in cells.of::<D>(c) {
                weight[a as usize] += volume / f64::from(2 * corners);
            }
        }
        weight.extend(centres.weight.iter().map(|v| v / 2.0));
        Self {
            x0: x0.iter().chain(&centres.x0).copied().collect(),
            weight,
            cell: Vec::new(),
            body: body.iter().chain(&centres.body).copied().collect(),
            rule: Vec::new(),
            parent: Vec::new(),
            particles: x0.len(),
        }
    }

    /// The points `keep` (ascending): a rank's share of a distributed run.
    pub fn restrict(&self, keep: &[u32]) -> Self {
        fn rows<T: Copy>(all: &[T], keep: &[u32]) -> Vec<T> {
            match all.is_empty() {
                true => Vec::new(),
                false => keep.iter().map(|&q| all[q as usize]).collect(),
            }
        }
        Self {
            x0: rows(&self.x0, keep),
            weight: rows(&self.weight, keep),
            cell: rows(&self.cell, keep),
            body: rows(&self.body, keep),
            rule: self.rule.clone(),
            parent: rows(&self.parent, keep),
            particles: keep
                .iter()
                .filter(|&&q| (q as usize) < self.particles)
                .count(),
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.x0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x0.is_empty()
    }
}

/// The smoothing cells of stabilised conforming nodal integration (Chen, Wu, Yoon and You
/// 2001): the representative domain Ω_L of every particle L, the box [lo_L, hi_L], here
/// the Δx square (cube) about the particle clipped to the box of its body; on a vertex
/// lattice these are the tributary cells whose areas the particles carry as volumes, on
/// a cell-centred one the lattice's own cells. Cells of neighbouring particles share
/// whole faces, so the faces inside a body cancel in Σ_L ∮_{Γ_L}.
#[derive(Clone, Debug, Default)]
pub struct SmoothingCells {
    pub lo: Vec<[f64; 3]>,
    pub hi: Vec<[f64; 3]>,
}

impl SmoothingCells {
    /// The cells of particles x (bodies `body`) on a lattice of spacing Δx, each clipped to
    /// its body's box `boxes[body] = (min, max)` (padded with zeros past d).
    pub fn clipped<D: Dim>(
        x: &[D::V],
        body: &[u32],
        spacing: f64,
        boxes: &[([f64; 3], [f64; 3])],
    ) -> Self {
        let (lo, hi) = x
            .iter()
            .zip(body)
            .map(|(&x, &b)| {
                let (min, max) = boxes[b as usize];
                let x = D::to3(x);
                let (mut lo, mut hi) = ([0.0; 3], [0.0; 3]);
                for k in 0..D::N {
                    lo[k] = (x[k] - spacing / 2.0).max(min[k]);
                    hi[k] = (x[k] + spacing / 2.0).min(max[k]);
                }
                (lo, hi)
            })
            .unzip();
        Self { lo, hi }
    }

    /// Number of cells (particles).
    pub fn len(&self) -> usize {
        self.lo.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lo.is_empty()
    }

    /// A_L, the area (volume) of every cell: the weight of its particle as a point.
    pub fn volumes<D: Dim>(&self) -> Vec<f64> {
        self.lo
            .iter()
            .zip(&self.hi)
            .map(|(lo, hi)| (0..D::N).map(|k| hi[k] - lo[k]).product())
            .collect()
    }

    /// The Gauss points of the boundary Γ_L of cell l, 2 per edge in 2D and 2×2 per face in
    /// 3D (exact for the linear fields the patch test needs), each with n w: the outward
    /// unit normal times the point's weight (its share of the face's length or area).
    pub fn boundary_points<D: Dim>(&self, l: usize) -> Vec<(D::V, D::V)> {
        let (lo, hi) = (self.lo[l], self.hi[l]);
        let g = 1.0 / 3f64.sqrt();
        let others = 1 << (D::N - 1);
        let mut points = Vec::with_capacity(2 * D::N * others);
        for k in 0..D::N {
            for (side, sign) in [(lo[k], -1.0), (hi[k], 1.0)] {
                for corner in 0..others {
                    let (mut y, mut n) = ([0.0; 3], [0.0; 3]);
                    let mut weight = 1.0;
                    y[k] = side;
                    for (bit, j) in (0..D::N).filter(|&j| j != k).enumerate() {
                        let (mid, half) = ((lo[j] + hi[j]) / 2.0, (hi[j] - lo[j]) / 2.0);
                        let xi = if corner >> bit & 1 == 0 { -g } else { g };
                        y[j] = mid + xi * half;
                        weight *= half;
                    }
                    n[k] = sign * weight;
                    points.push((D::from_slice(&y[..D::N]), D::from_slice(&n[..D::N])));
                }
            }
        }
        points
    }

    /// The largest distance from a particle to a point of its cell's boundary, bounded by
    /// the cell's diagonal.
    fn reach(&self) -> f64 {
        self.lo
            .iter()
            .zip(&self.hi)
            .map(|(lo, hi)| (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt())
            .fold(0.0, f64::max)
    }
}

/// The isoparametric shape functions N_a(ξ) = Π_k (1 + ξ_a,k ξ_k)/2 of the 2^d corners
/// and their parent derivatives ∂N_a/∂ξ_k, in the first 2^d entries (the rest are zero).
fn isoparametric<D: Dim>(xi: [f64; 3]) -> ([f64; 8], [[f64; 3]; 8]) {
    let sign = |c: i64| if c == 0 { -1.0 } else { 1.0 };
    let factor = |c: &[i64; 3], k: usize| 0.5 * (1.0 + sign(c[k]) * xi[k]);
    let (mut n, mut dn) = ([0.0; 8], [[0.0; 3]; 8]);
    for ((c, n), d) in CORNERS[..1 << D::N].iter().zip(&mut n).zip(&mut dn) {
        *n = (0..D::N).map(|k| factor(c, k)).product();
        for (k, dk) in d.iter_mut().enumerate().take(D::N) {
            *dk = 0.5
                * sign(c[k])
                * (0..D::N)
                    .filter(|&l| l != k)
                    .map(|l| factor(c, l))
                    .product::<f64>();
        }
    }
    (n, dn)
}

/// A parent point ξ of a rule with the isoparametric functions N_a(ξ) and their parent
/// derivatives ∂N_a/∂ξ there, which depend on ξ alone: a rule tabulates them once for all
/// its cells.
#[derive(Clone, Copy, Debug)]
pub struct Parent {
    n: [f64; 8],
    dn: [[f64; 3]; 8],
}

impl Parent {
    fn at<D: Dim>(xi: [f64; 3]) -> Self {
        let (n, dn) = isoparametric::<D>(xi);
        Self { n, dn }
    }
}

/// J = ∂X/∂ξ = Σ_a X_a ⊗ ∂N_a/∂ξ.
fn jacobian<D: Dim>(corners: &[u32], x0: &[D::V], dn: &[[f64; 3]]) -> D::T {
    corners.iter().zip(dn).fold(D::zero_t(), |j, (&a, d)| {
        j + D::outer(x0[a as usize], D::from_slice(&d[..D::N]))
    })
}

/// The isoparametric functions of a cell with corners at x, at a parent point: N_a into
/// `n` and ∇N_a = J⁻ᵀ ∂N_a/∂ξ into `grad`, in corner order; returns det J (∇N_a are not
/// finite when it vanishes).
pub fn isoparametric_shapes<D: Dim>(
    corners: &[u32],
    x: &[D::V],
    parent: &Parent,
    n: &mut [f64],
    grad: &mut [D::V],
) -> f64 {
    let j = jacobian::<D>(corners, x, &parent.dn);
    let j_inv_t = D::transpose(D::inverse(j));
    n.copy_from_slice(&parent.n[..n.len()]);
    for (g, d) in grad.iter_mut().zip(&parent.dn) {
        *g = j_inv_t * D::from_slice(&d[..D::N]);
    }
    D::det(j)
}

#[cfg(test)]
mod tests;
