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

use crate::correction;
use crate::kernel::Kernel;
use crate::neighbour::{self, Csr, Rows, split_rows};
use crate::tensor::Dim;
use rayon::prelude::*;
use std::collections::HashMap;
use thiserror::Error;

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

/// The cells of the bodies: those `given` by their generator (a polar ring's, a mesh's
/// read at its vertices), then for every other body each square (cube) of the lattice of
/// spacing Δx whose 2^d corners are particles of the body. A body's lattice is anchored at its smallest coordinates; a
/// particle off it is an error, as is a body without a cell.
pub fn lattice_cells<D: Dim>(
    x0: &[D::V],
    body: &[u32],
    spacing: f64,
    given: &Cells,
) -> Result<Cells, QuadratureError> {
    let bodies = body.iter().map(|&b| b as usize + 1).max().unwrap_or(0);
    let mut generated = vec![false; bodies];
    for &b in &given.body {
        generated[b as usize] = true;
    }
    let on_lattice = |b: u32| !generated[b as usize];
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
        let mut at = [0i64; 3];
        for k in 0..D::N {
            let s = (x[k] - origin[b as usize][k]) / spacing;
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
        index.insert((b, at), i as u32);
        lattice_index.push(Some(at));
    }
    let mut cells = given.clone();
    let corners = &CORNERS[..1 << D::N];
    for (base, &b) in lattice_index.iter().zip(body) {
        let Some(base) = base else { continue };
        let found: Option<Vec<u32>> = corners
            .iter()
            .map(|c| index.get(&(b, [base[0] + c[0], base[1] + c[1], base[2] + c[2]])))
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
        match self {
            Self::Centre => f64::from(1 << D::N),
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

/// Shape functions at the quadrature points: the nodes of point q are
/// `csr.neighbours(q)`, with N_a(x_q) in `n` and ∇N_a(x_q) in `grad`, one per pair in
/// CSR order, so that a nodal field interpolates as f(x_q) = Σ_a N_a(x_q) f_a (for RKPM,
/// N_a = V_a Ψ_a of seed 000 eq 43) and its gradient is Σ_a f_a ⊗ ∇N_a(x_q).
///
/// A Petrov–Galerkin method tests with other functions than it interpolates with: their
/// gradients ∇Φ_a(x_q), which the forces −Σ_q w_q P_q ∇Φ_a(x_q) use, are then in `test`
/// ([`Shapes::test_gradient`]); empty for a Bubnov–Galerkin method, whose test functions
/// are the trial functions.
#[derive(Clone, Debug)]
pub struct Shapes<D: Dim> {
    pub csr: Csr,
    pub n: Vec<f64>,
    pub grad: Vec<D::V>,
    pub test: Vec<D::V>,
    /// The meshfree functions these are, which any point near the nodes has; None for
    /// functions that live on cells (the isoparametric ones) or on a moving configuration.
    pub family: Option<Family>,
}

impl<D: Dim> Default for Shapes<D> {
    fn default() -> Self {
        Self {
            csr: Csr::default(),
            n: Vec::new(),
            grad: Vec::new(),
            test: Vec::new(),
            family: None,
        }
    }
}

/// The meshfree functions of the total-Lagrangian Galerkin methods, on the reference
/// positions of their nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// [`Shapes::reproducing`].
    Reproducing,
    /// [`Shapes::moving_least_squares`].
    MovingLeastSquares,
    /// [`Shapes::krongauz_belytschko`].
    KrongauzBelytschko,
}

impl Family {
    /// The family's functions at the points `at` (of bodies `at_body`) over the particles
    /// x (volumes V, bodies `body`) within the kernel's support of each point.
    pub fn at<D: Dim>(
        self,
        at: &[D::V],
        at_body: &[u32],
        x: &[D::V],
        vol: &[f64],
        body: &[u32],
        kernel: &Kernel,
    ) -> Result<Shapes<D>, QuadratureError> {
        match self {
            Self::Reproducing => Shapes::reproducing(at, at_body, x, vol, body, kernel),
            Self::MovingLeastSquares => Shapes::moving_least_squares(at, at_body, x, body, kernel),
            Self::KrongauzBelytschko => Shapes::krongauz_belytschko(at, at_body, x, body, kernel),
        }
    }
}

impl<D: Dim> Shapes<D> {
    /// The isoparametric functions of each point's cell: ∇N_a = J⁻ᵀ ∂N_a/∂ξ.
    pub fn isoparametric(cells: &Cells, points: &QuadraturePoints<D>, x0: &[D::V]) -> Self {
        let k = 1 << D::N;
        let mut shapes = Self {
            csr: Csr {
                offsets: (0..=points.len()).map(|q| q * k).collect(),
                ids: Vec::with_capacity(points.len() * k),
            },
            n: vec![0.0; points.len() * k],
            grad: vec![D::zero(); points.len() * k],
            test: Vec::new(),
            family: None,
        };
        for (q, &k) in points.parent.iter().enumerate() {
            let corners = cells.of::<D>(points.cell[q] as usize);
            shapes.csr.ids.extend(corners);
            let r = shapes.csr.range(q);
            isoparametric_shapes::<D>(
                corners,
                x0,
                &points.rule[k as usize],
                &mut shapes.n[r.clone()],
                &mut shapes.grad[r],
            );
        }
        shapes
    }

    /// Reproducing-kernel functions with a linear basis (seed 000 §1.4) of the particles x
    /// (volumes V) of the point's body within the kernel's support of each point y_q (of
    /// body `at_body[q]`): N_a = V_a Ψ_a. A particle at the point itself is one of its
    /// nodes.
    pub fn reproducing(
        at: &[D::V],
        at_body: &[u32],
        x: &[D::V],
        vol: &[f64],
        body: &[u32],
        kernel: &Kernel,
    ) -> Result<Self, QuadratureError> {
        let reach = crate::reference::neighbour_radius(kernel);
        let csr = neighbour::between::<D>(at, x, reach, Some((at_body, body)));
        let rows = csr.map_rows(|q| {
            let nodes = csr.neighbours(q);
            let shapes = correction::reproducing_shapes::<D>(at[q], nodes, x, vol, kernel).ok_or(
                QuadratureError::Singular {
                    point: q,
                    position: D::to3(at[q]),
                    nodes: nodes.len(),
                },
            )?;
            Ok(nodes
                .iter()
                .zip(shapes)
                .map(|(&j, (psi, grad))| (vol[j as usize] * psi, grad * vol[j as usize])))
        })?;
        let (n, grad) = rows.into_iter().unzip();
        Ok(Self {
            csr,
            n,
            grad,
            test: Vec::new(),
            family: Some(Family::Reproducing),
        })
    }

    /// Moving least-squares functions with a linear basis (seed 001 eqs 37–42), Φ_a(X) =
    /// pᵀ(X) A⁻¹(X) p(X_a) W(X − X_a), A = Σ_a p(X_a) pᵀ(X_a) W(X − X_a), of the particles
    /// within the kernel's support of each point: the reproducing-kernel functions with
    /// unit weights in place of the volumes, so that a boundary particle's smaller volume
    /// does not weaken its function.
    pub fn moving_least_squares(
        at: &[D::V],
        at_body: &[u32],
        x: &[D::V],
        body: &[u32],
        kernel: &Kernel,
    ) -> Result<Self, QuadratureError> {
        let shapes = Self::reproducing(at, at_body, x, &vec![1.0; x.len()], body, kernel)?;
        Ok(Self {
            family: Some(Family::MovingLeastSquares),
            ..shapes
        })
    }

    /// Krongauz–Belytschko functions (seed 001 §3.2) of the particles within the kernel's
    /// support of each point X_q: the Shepard functions W^S_a = W_a / Σ_b W_b (eq 28) as
    /// values and test functions, and the corrected trial gradient G_a = M⁻¹ ∇W^S_a (eqs
    /// 27, 31) with M = Σ_a ∇W^S_a ⊗ (X_a − X_q), which makes Σ_a X_a ⊗ G_a = I (eq 29).
    pub fn krongauz_belytschko(
        at: &[D::V],
        at_body: &[u32],
        x: &[D::V],
        body: &[u32],
        kernel: &Kernel,
    ) -> Result<Self, QuadratureError> {
        let reach = crate::reference::neighbour_radius(kernel);
        let csr = neighbour::between::<D>(at, x, reach, Some((at_body, body)));
        let rows = csr.map_rows(|q| {
            let nodes = csr.neighbours(q);
            krongauz_belytschko_shapes::<D>(at[q], nodes, x, kernel).ok_or(
                QuadratureError::Singular {
                    point: q,
                    position: D::to3(at[q]),
                    nodes: nodes.len(),
                },
            )
        })?;
        let mut shapes = Self {
            csr,
            family: Some(Family::KrongauzBelytschko),
            ..Self::default()
        };
        for (n, grad, test) in rows {
            shapes.n.push(n);
            shapes.grad.push(grad);
            shapes.test.push(test);
        }
        Ok(shapes)
    }

    /// Stabilised conforming nodal integration (SCNI; Chen, Wu, Yoon and You 2001) of the
    /// moving least-squares functions ([`Self::moving_least_squares`]): at every particle
    /// X_L, a point of weight A_L (the area of its cell in `cells`), the values Φ_a(X_L)
    /// and the smoothed gradients b̃_a(X_L) = (1/A_L) ∮_{Γ_L} Φ_a n dΓ, by the Gauss points
    /// of the cell's faces. Its nodes are the particles of its body whose support reaches
    /// X_L or one of those points. The faces inside a body cancel, so Σ_L A_L b̃_a(X_L) is
    /// the boundary quadrature of ∮_Γ Φ_a n dΓ (the integration constraint) and a linear
    /// field's gradient is exact.
    pub fn smoothed_moving_least_squares(
        cells: &SmoothingCells,
        x: &[D::V],
        body: &[u32],
        kernel: &Kernel,
    ) -> Result<Self, QuadratureError> {
        let unit = vec![1.0; x.len()];
        let values = |y: D::V, nodes: &[u32]| {
            let shapes = correction::reproducing_shapes::<D>(y, nodes, x, &unit, kernel)?;
            Some(shapes.into_iter().map(|(phi, _)| phi).collect())
        };
        let rows = smoothed_rows::<D>(cells, x, body, kernel, values)?;
        Ok(Self::from_rows(
            Family::MovingLeastSquares,
            rows.into_iter().map(|row| (row, Vec::new())),
        ))
    }

    /// SCNI of the Krongauz–Belytschko functions ([`Self::krongauz_belytschko`]): at every
    /// particle X_L the Shepard values W^S_a(X_L), the smoothed test gradients ∇̃W^S_a =
    /// (1/A_L) ∮_{Γ_L} W^S_a n dΓ, and the trial gradients corrected as eq 31 corrects the
    /// pointwise ones, G̃_a = M̃⁻¹ ∇̃W^S_a with M̃ = Σ_a ∇̃W^S_a ⊗ (X_a − X_L), so that
    /// Σ_a X_a ⊗ G̃_a = I (Σ_a ∇̃W^S_a = (1/A_L) ∮ n dΓ = 0 allows the shift by X_L).
    pub fn smoothed_krongauz_belytschko(
        cells: &SmoothingCells,
        x: &[D::V],
        body: &[u32],
        kernel: &Kernel,
    ) -> Result<Self, QuadratureError> {
        let values = |y: D::V, nodes: &[u32]| {
            let shepard = shepard_functions::<D>(y, nodes, x, kernel)?;
            Some(shepard.into_iter().map(|(w, _)| w).collect())
        };
        let rows = smoothed_rows::<D>(cells, x, body, kernel, values)?;
        let rows =
            rows.into_iter()
                .enumerate()
                .map(|(l, mut row)| {
                    let corrected = corrected_gradients::<D>(x[l], &row.nodes, x, &row.grad)
                        .ok_or(QuadratureError::Singular {
                            point: l,
                            position: D::to3(x[l]),
                            nodes: row.nodes.len(),
                        })?;
                    let test = std::mem::replace(&mut row.grad, corrected);
                    Ok((row, test))
                })
                .collect::<Result<Vec<_>, _>>()?;
        Ok(Self::from_rows(Family::KrongauzBelytschko, rows))
    }

    /// The shapes of `family` on rows of nodes with their values, trial gradients and
    /// (empty for a Bubnov–Galerkin method) test gradients, one row per point in order.
    fn from_rows(
        family: Family,
        rows: impl IntoIterator<Item = (SmoothedRow<D>, Vec<D::V>)>,
    ) -> Self {
        let mut shapes = Self {
            csr: Csr {
                offsets: vec![0],
                ids: Vec::new(),
            },
            family: Some(family),
            ..Self::default()
        };
        for (row, test) in rows {
            shapes.csr.ids.extend(&row.nodes);
            shapes.csr.offsets.push(shapes.csr.ids.len());
            shapes.n.extend(row.n);
            shapes.grad.extend(row.grad);
            shapes.test.extend(test);
        }
        shapes
    }

    /// ∇Φ_a(x_q) of pair p: the test function's gradient (the trial function's for a
    /// Bubnov–Galerkin method).
    #[inline]
    pub fn test_gradient(&self, p: usize) -> D::V {
        self.test_gradients()[p]
    }

    /// ∇Φ_a(x_q) of every pair ([`Self::test_gradient`]).
    #[inline]
    pub fn test_gradients(&self) -> &[D::V] {
        if self.test.is_empty() {
            &self.grad
        } else {
            &self.test
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.csr.len()
    }

    pub fn is_empty(&self) -> bool {
        self.csr.is_empty()
    }

    /// The interpolant f(x_q) = Σ_a N_a(x_q) f_a of a nodal field f at every point.
    pub fn interpolate<T>(&self, f: &[T]) -> Vec<T>
    where
        T: Copy + Send + Sync + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
    {
        (0..self.len())
            .into_par_iter()
            .with_min_len(MIN_ROWS)
            .map(|q| {
                let mut r = self.csr.range(q);
                let first = r.next().expect("every point has nodes");
                r.fold(f[self.csr.ids[first] as usize] * self.n[first], |s, p| {
                    s + f[self.csr.ids[p] as usize] * self.n[p]
                })
            })
            .collect()
    }

    /// The gradient Σ_a f_a ⊗ ∇N_a(x_q) of a nodal field f at point q.
    #[inline]
    pub fn gradient(&self, q: usize, f: &[D::V]) -> D::T {
        let pairs = self.csr.pairs(q, &self.grad);
        pairs.fold(D::zero_t(), |g, (a, &grad)| g + D::outer(f[a], grad))
    }

    /// The node whose shape function is largest at point q.
    pub fn strongest_node(&self, q: usize) -> usize {
        let p = self
            .csr
            .range(q)
            .max_by(|&a, &b| self.n[a].total_cmp(&self.n[b]))
            .expect("every point has nodes");
        self.csr.ids[p] as usize
    }

    /// Recomputes the values on the same lists, every point in parallel: `at(q, nodes,
    /// row)` writes N_a(x_q), ∇N_a(x_q) (and the test gradients ∇Φ_a(x_q) of a
    /// Petrov–Galerkin method; the row's `test` is empty otherwise) of point q's nodes into
    /// its pairs and returns a value of the point (its weight), written to `weight[q]`
    /// (dropped if `weight` is empty). Every point is computed; the first point (in order)
    /// that fails fails all, with its index.
    pub fn recompute<E: Send>(
        &mut self,
        weight: &mut [f64],
        at: impl Fn(usize, &[u32], ShapeRow<D>) -> Result<f64, E> + Sync + Send,
    ) -> Result<(), (usize, E)> {
        debug_assert!(weight.is_empty() || weight.len() == self.len());
        let csr = &self.csr;
        let rows = PointRows {
            shapes: ShapeRow {
                n: &mut self.n,
                grad: &mut self.grad,
                test: &mut self.test,
            },
            weight,
        };
        split_rows(0, &csr.offsets, rows, MIN_ROWS, &|q, row: PointRows<D>| {
            let value = at(q, csr.neighbours(q), row.shapes).map_err(|e| (q, e))?;
            if let [w] = row.weight {
                *w = value;
            }
            Ok(())
        })
    }

    /// The transposed lists, for the per-node gather.
    pub fn gather(&self, nodes: usize) -> Gather {
        let mut offsets = vec![0usize; nodes + 1];
        for &a in &self.csr.ids {
            offsets[a as usize + 1] += 1;
        }
        for a in 0..nodes {
            offsets[a + 1] += offsets[a];
        }
        let mut cursor = offsets[..nodes].to_vec();
        let mut point = vec![0u32; self.csr.ids.len()];
        let mut pair = vec![0u32; self.csr.ids.len()];
        for q in 0..self.len() {
            for p in self.csr.range(q) {
                let a = self.csr.ids[p] as usize;
                point[cursor[a]] = q as u32;
                pair[cursor[a]] = p as u32;
                cursor[a] += 1;
            }
        }
        Gather {
            offsets,
            point,
            pair,
        }
    }
}

/// One point's functions in [`Shapes::recompute`]: N_a, ∇N_a and (Petrov–Galerkin
/// methods only, else empty) ∇Φ_a of its nodes.
pub struct ShapeRow<'a, D: Dim> {
    pub n: &'a mut [f64],
    pub grad: &'a mut [D::V],
    pub test: &'a mut [D::V],
}

/// One node's Krongauz–Belytschko functions at a point: (W^S_a, G_a, ∇W^S_a).
pub type KbShape<D> = (f64, <D as Dim>::V, <D as Dim>::V);

/// The Krongauz–Belytschko functions at y of the particles `nodes` of x, per node in
/// order (see [`Shapes::krongauz_belytschko`]); none where the kernels sum to zero or M
/// is singular (|det M| ≤ 1e-10 of its scale).
pub fn krongauz_belytschko_shapes<D: Dim>(
    y: D::V,
    nodes: &[u32],
    x: &[D::V],
    kernel: &Kernel,
) -> Option<Vec<KbShape<D>>> {
    let shepard = shepard_functions::<D>(y, nodes, x, kernel)?;
    let test: Vec<D::V> = shepard.iter().map(|s| s.1).collect();
    let trial = corrected_gradients::<D>(y, nodes, x, &test)?;
    Some(
        shepard
            .into_iter()
            .zip(trial)
            .map(|((w, g), trial)| (w, trial, g))
            .collect(),
    )
}

/// The Shepard functions W^S_a = W_a / Σ_b W_b (seed 001 eq 28) at y of the particles
/// `nodes` of x and their gradients, per node in order; none where the kernels sum to zero.
fn shepard_functions<D: Dim>(
    y: D::V,
    nodes: &[u32],
    x: &[D::V],
    kernel: &Kernel,
) -> Option<Vec<(f64, D::V)>> {
    let kernels: Vec<(f64, D::V)> = nodes
        .iter()
        .map(|&a| {
            let r = y - x[a as usize];
            (kernel.w(D::norm2(r).sqrt()), kernel.grad::<D>(r))
        })
        .collect();
    let sum: f64 = kernels.iter().map(|k| k.0).sum();
    if sum <= 0.0 {
        return None;
    }
    let grad_sum = kernels.iter().fold(D::zero(), |s, k| s + k.1);
    // ∇W^S_a = (∇W_a − W^S_a Σ_b ∇W_b) / Σ_b W_b.
    Some(
        kernels
            .iter()
            .map(|&(w, g)| (w / sum, (g - grad_sum * (w / sum)) * (1.0 / sum)))
            .collect(),
    )
}

/// The Krongauz–Belytschko correction (seed 001 eqs 27, 31) of gradients g_a at y that
/// sum to zero: G_a = M⁻¹ g_a with M = Σ_a g_a ⊗ (X_a − y) (eq 31 with the shift that Σ_a
/// g_a = 0 allows), so that Σ_a X_a ⊗ G_a = I; none where M is singular (|det M| ≤ 1e-10
/// of its scale).
fn corrected_gradients<D: Dim>(
    y: D::V,
    nodes: &[u32],
    x: &[D::V],
    g: &[D::V],
) -> Option<Vec<D::V>> {
    let m = nodes.iter().zip(g).fold(D::zero_t(), |m, (&a, &g)| {
        m + D::outer(g, x[a as usize] - y)
    });
    let scale = D::ddot(m, m).sqrt() / (D::N as f64).sqrt();
    if D::det(m).abs() <= 1e-10 * scale.powi(D::N as i32) {
        return None;
    }
    let a = D::inverse(m);
    Some(g.iter().map(|&g| a * g).collect())
}

/// One point's row of [`Shapes`] under SCNI: its nodes, their values at the particle and
/// their smoothed gradients.
struct SmoothedRow<D: Dim> {
    nodes: Vec<u32>,
    n: Vec<f64>,
    grad: Vec<D::V>,
}

/// The SCNI rows of the particles x of `cells` (see [`Shapes::smoothed_moving_least_squares`]):
/// per particle L, its nodes (the particles of its body whose support reaches X_L or a
/// boundary point of its cell), `values(X_L)` and (1/A_L) Σ_g values(Y_g) n_g w_g over the
/// cell's boundary points Y_g. `values(y, nodes)` gives the functions of the nodes at y,
/// none where they are singular; the first particle (in order) whose functions fail
/// fails all.
fn smoothed_rows<D: Dim>(
    cells: &SmoothingCells,
    x: &[D::V],
    body: &[u32],
    kernel: &Kernel,
    values: impl Fn(D::V, &[u32]) -> Option<Vec<f64>> + Sync,
) -> Result<Vec<SmoothedRow<D>>, QuadratureError> {
    let reach = crate::reference::neighbour_radius(kernel);
    let candidates = neighbour::between::<D>(x, x, reach + cells.reach(), Some((body, body)));
    let volumes = cells.volumes::<D>();
    let rows: Vec<Result<SmoothedRow<D>, QuadratureError>> = (0..x.len())
        .into_par_iter()
        .with_min_len(MIN_ROWS)
        .map(|l| {
            let boundary = cells.boundary_points::<D>(l);
            let reaches = |a: u32, y: D::V| kernel.w(D::norm2(y - x[a as usize]).sqrt()) > 0.0;
            let nodes: Vec<u32> = candidates
                .neighbours(l)
                .iter()
                .copied()
                .filter(|&a| reaches(a, x[l]) || boundary.iter().any(|&(y, _)| reaches(a, y)))
                .collect();
            let singular = |y: D::V| QuadratureError::Singular {
                point: l,
                position: D::to3(y),
                nodes: nodes.len(),
            };
            let n = values(x[l], &nodes).ok_or_else(|| singular(x[l]))?;
            let mut grad = vec![D::zero(); nodes.len()];
            for &(y, nw) in &boundary {
                let phi = values(y, &nodes).ok_or_else(|| singular(y))?;
                for (g, phi) in grad.iter_mut().zip(phi) {
                    *g += nw * phi;
                }
            }
            let inverse = 1.0 / volumes[l];
            grad.iter_mut().for_each(|g| *g = *g * inverse);
            Ok(SmoothedRow { nodes, n, grad })
        })
        .collect();
    rows.into_iter().collect()
}

/// Rows a task of the parallel loops over points handles at least.
const MIN_ROWS: usize = 64;

/// The fields [`Shapes::recompute`] writes, for a range of points: their functions'
/// rows, and per point `weight` (empty if dropped).
struct PointRows<'a, D: Dim> {
    shapes: ShapeRow<'a, D>,
    weight: &'a mut [f64],
}

impl<D: Dim> Rows for ShapeRow<'_, D> {
    fn split_at(self, _rows: usize, pairs: usize) -> (Self, Self) {
        let (n, n_rest) = self.n.split_at_mut(pairs);
        let (grad, grad_rest) = self.grad.split_at_mut(pairs);
        let (test, test_rest) = self.test.split_at_mut(pairs.min(self.test.len()));
        (
            Self { n, grad, test },
            Self {
                n: n_rest,
                grad: grad_rest,
                test: test_rest,
            },
        )
    }
}

impl<D: Dim> Rows for PointRows<'_, D> {
    fn split_at(self, rows: usize, pairs: usize) -> (Self, Self) {
        let (shapes, shapes_rest) = self.shapes.split_at(rows, pairs);
        let (weight, weight_rest) = self.weight.split_at_mut(rows.min(self.weight.len()));
        (
            Self { shapes, weight },
            Self {
                shapes: shapes_rest,
                weight: weight_rest,
            },
        )
    }
}

/// From each node a to the pairs (q, p) of [`Shapes`] that hold it, in ascending q:
/// `point[offsets[a]..offsets[a + 1]]` and the pair indices `pair[…]` alike.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Gather {
    pub offsets: Vec<usize>,
    pub point: Vec<u32>,
    pub pair: Vec<u32>,
}

impl Gather {
    /// The entries of node a.
    pub fn range(&self, a: usize) -> std::ops::Range<usize> {
        self.offsets[a]..self.offsets[a + 1]
    }

    /// Whether node a is reached by no point.
    pub fn is_orphan(&self, a: usize) -> bool {
        self.offsets[a] == self.offsets[a + 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::KernelKind;
    use crate::tensor::{D2, D3};
    use glam::{DVec2, DVec3};

    /// Particles of an nx × ny lattice of spacing dx from the origin.
    fn lattice(nx: usize, ny: usize, dx: f64) -> Vec<DVec2> {
        (0..ny)
            .flat_map(|j| (0..nx).map(move |i| DVec2::new(i as f64 * dx, j as f64 * dx)))
            .collect()
    }

    #[test]
    fn a_rectangle_has_its_lattice_squares_as_cells() {
        // (nx − 1)(ny − 1) cells, each of area dx²: the 2×2 Gauss weights sum to the
        // rectangle's area to round-off.
        let (nx, ny, dx) = (5, 4, 0.25);
        let x = lattice(nx, ny, dx);
        let cells = lattice_cells::<D2>(&x, &vec![0; x.len()], dx, &Cells::default()).unwrap();
        assert_eq!(cells.len(), (nx - 1) * (ny - 1));
        for c in 0..cells.len() {
            let k = cells.of::<D2>(c);
            // Counter-clockwise: the signed area of the corner polygon is dx².
            let area: f64 = (0..4)
                .map(|a| x[k[a] as usize].perp_dot(x[k[(a + 1) % 4] as usize]))
                .sum::<f64>()
                / 2.0;
            assert!((area - dx * dx).abs() < 1e-14, "cell {c}: area {area}");
        }
        let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
        let total: f64 = points.weight.iter().sum();
        let area = ((nx - 1) * (ny - 1)) as f64 * dx * dx;
        assert!((total - area).abs() < 1e-13 * area);
        let centres = QuadraturePoints::<D2>::new(&cells, &x, Rule::Centre);
        assert!((centres.weight.iter().sum::<f64>() - area).abs() < 1e-13 * area);
    }

    #[test]
    fn particles_off_the_lattice_and_bodies_without_cells_are_refused() {
        let dx = 0.1;
        let mut x = lattice(3, 3, dx);
        x[4].x += 0.3 * dx;
        let err = lattice_cells::<D2>(&x, &[0; 9], dx, &Cells::default()).unwrap_err();
        assert!(
            matches!(err, QuadratureError::OffLattice { particle: 4, .. }),
            "{err}"
        );
        let line = lattice(4, 1, dx);
        let err = lattice_cells::<D2>(&line, &[0; 4], dx, &Cells::default()).unwrap_err();
        assert_eq!(err, QuadratureError::NoCell { body: 0 });
    }

    #[test]
    fn isoparametric_gradients_reproduce_linear_fields_in_a_distorted_cell() {
        // N_a partition unity and ∇N_a of a linear field f = a + b·x is b exactly, in a
        // quadrilateral that is no parallelogram (J varies over the cell). Round-off: 1e-13.
        let x = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.1),
            DVec2::new(1.2, 0.9),
            DVec2::new(-0.1, 1.0),
        ];
        let cells = Cells {
            corners: vec![0, 1, 2, 3],
            body: vec![0],
        };
        let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
        let shapes = Shapes::isoparametric(&cells, &points, &x);
        let b = DVec2::new(0.7, -1.3);
        let f: Vec<f64> = x.iter().map(|p| 2.0 + b.dot(*p)).collect();
        for q in 0..points.len() {
            let r = shapes.csr.range(q);
            let sum: f64 = shapes.n[r.clone()].iter().sum();
            assert!((sum - 1.0).abs() < 1e-14);
            let value: f64 = r
                .clone()
                .map(|p| shapes.n[p] * f[shapes.csr.ids[p] as usize])
                .sum();
            assert!((value - 2.0 - b.dot(points.x0[q])).abs() < 1e-13);
            let grad = r.fold(DVec2::ZERO, |g, p| {
                g + shapes.grad[p] * f[shapes.csr.ids[p] as usize]
            });
            assert!((grad - b).length() < 1e-13, "point {q}: {grad}");
        }
    }

    #[test]
    fn hexahedra_weights_and_gradients() {
        // A 3 × 3 × 3 lattice: 8 cubes, Gauss weights summing to the volume, and
        // trilinear gradients exact for a linear field.
        let dx = 0.5;
        let x: Vec<DVec3> = (0..27)
            .map(|i| DVec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * dx)
            .collect();
        let cells = lattice_cells::<D3>(&x, &[0; 27], dx, &Cells::default()).unwrap();
        assert_eq!(cells.len(), 8);
        let points = QuadraturePoints::<D3>::new(&cells, &x, Rule::Gauss2);
        assert_eq!(points.len(), 64);
        assert!((points.weight.iter().sum::<f64>() - 1.0).abs() < 1e-13);
        let shapes = Shapes::isoparametric(&cells, &points, &x);
        let b = DVec3::new(0.3, -0.2, 1.1);
        for q in 0..points.len() {
            let grad = shapes.csr.range(q).fold(DVec3::ZERO, |g, p| {
                g + shapes.grad[p] * b.dot(x[shapes.csr.ids[p] as usize])
            });
            assert!((grad - b).length() < 1e-13);
        }
    }

    #[test]
    fn reproducing_functions_reproduce_linear_fields_at_every_point() {
        // Seed 000 checklist item 4 at the quadrature points: Σ_j V_j Ψ_j = 1,
        // Σ_j V_j Ψ_j x_j = x_q and Σ_j V_j ∇Ψ_j ⊗ x_j = I (N_j = V_j Ψ_j) at every Gauss
        // point, boundary
        // cells included (the moment conditions, eqs 44–45). Round-off of sums of O(30)
        // terms of O(1): 1e-12.
        let dx = 0.1;
        let x = lattice(9, 7, dx);
        let vol = vec![dx * dx; x.len()];
        let body = vec![0; x.len()];
        let cells = lattice_cells::<D2>(&x, &body, dx, &Cells::default()).unwrap();
        let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
        let kernel = Kernel::new(KernelKind::CubicSpline, 1.5 * dx, 2);
        let shapes =
            Shapes::<D2>::reproducing(&points.x0, &points.body, &x, &vol, &body, &kernel).unwrap();
        for q in 0..points.len() {
            let (mut unity, mut first, mut grad) = (0.0, DVec2::ZERO, glam::DMat2::ZERO);
            for p in shapes.csr.range(q) {
                let j = shapes.csr.ids[p] as usize;
                unity += shapes.n[p];
                first += x[j] * shapes.n[p];
                grad += D2::outer(shapes.grad[p], x[j]);
            }
            assert!((unity - 1.0).abs() < 1e-12, "point {q}: Σ V Ψ = {unity}");
            assert!((first - points.x0[q]).length() < 1e-12 * dx * 10.0);
            assert!((grad - glam::DMat2::IDENTITY).abs_diff_eq(glam::DMat2::ZERO, 1e-11));
        }
    }

    #[test]
    fn stress_point_weights_are_the_joint_voronoi_cells() {
        // Seed 001 §5.2 (spec [D]): particles and cell-centre stress points of a square
        // lattice form a lattice rotated by 45°, whose Voronoi cells are diamonds of
        // Δx²/2, cut to Δx²/4 on an edge and Δx²/8 at a corner. Exact in binary: 1e-15.
        let (nx, ny, dx) = (5, 4, 0.5);
        let x = lattice(nx, ny, dx);
        let body = vec![0; x.len()];
        let cells = lattice_cells::<D2>(&x, &body, dx, &Cells::default()).unwrap();
        let points = QuadraturePoints::<D2>::with_stress_points(&cells, &x, &body);
        assert_eq!(points.len(), nx * ny + (nx - 1) * (ny - 1));
        assert_eq!(points.particles, nx * ny);
        let cell = dx * dx;
        for (q, (&w, &y)) in points.weight.iter().zip(&points.x0).enumerate() {
            let on_edges = if q < nx * ny {
                [y.x, y.y]
                    .iter()
                    .zip([(nx - 1) as f64 * dx, (ny - 1) as f64 * dx])
                    .filter(|(c, end)| **c == 0.0 || **c == *end)
                    .count()
            } else {
                0
            };
            let expected = cell / 2.0 / f64::from(1 << on_edges);
            assert!((w - expected).abs() < 1e-15, "point {q} at {y}: weight {w}");
        }
        let area = ((nx - 1) * (ny - 1)) as f64 * cell;
        assert!((points.weight.iter().sum::<f64>() - area).abs() < 1e-14);
        // In 3D the joint cells (a body-centred lattice's truncated octahedra) weigh
        // Δx³/2 and the weights sum to the volume.
        let x3: Vec<DVec3> = (0..27)
            .map(|i| DVec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * dx)
            .collect();
        let cells = lattice_cells::<D3>(&x3, &[0; 27], dx, &Cells::default()).unwrap();
        let points = QuadraturePoints::<D3>::with_stress_points(&cells, &x3, &[0; 27]);
        assert_eq!(points.weight[13], dx.powi(3) / 2.0);
        assert!((points.weight.iter().sum::<f64>() - 8.0 * dx.powi(3)).abs() < 1e-14);
    }

    /// Σ_a N_a = 1, Σ_a ∇N_a = 0 (trial and test) and Σ_a X_a ⊗ ∇N_a = I at every point
    /// of `shapes`, to `tol`.
    fn check_linear_completeness(shapes: &Shapes<D2>, at: &[DVec2], x: &[DVec2], tol: f64) {
        for (q, &y) in at.iter().enumerate() {
            let (mut unity, mut first) = (0.0, DVec2::ZERO);
            let (mut trial, mut test) = (DVec2::ZERO, DVec2::ZERO);
            let mut grad = glam::DMat2::ZERO;
            for p in shapes.csr.range(q) {
                let a = shapes.csr.ids[p] as usize;
                unity += shapes.n[p];
                first += (x[a] - y) * shapes.n[p];
                trial += shapes.grad[p];
                test += shapes.test_gradient(p);
                grad += D2::outer(x[a], shapes.grad[p]);
            }
            assert!((unity - 1.0).abs() < tol, "point {q}: Σ N = {unity}");
            assert!(trial.length() < tol && test.length() < tol, "point {q}");
            let off = (grad - glam::DMat2::IDENTITY).abs().to_cols_array();
            assert!(off.iter().all(|&e| e < tol), "point {q}: Σ X ⊗ ∇N = {grad}");
            // Only the MLS values reproduce X itself; Shepard values do not at a boundary.
            if shapes.test.is_empty() {
                assert!(first.length() < tol, "point {q}: Σ N (X − y) = {first}");
            }
        }
    }

    #[test]
    fn krongauz_belytschko_gradients_are_linearly_complete_at_every_point() {
        // Seed 001 checklist items 2 and 3 (spec §11): at every particle and stress point
        // of a lattice, corners included, the Shepard functions sum to one with
        // gradients summing to zero, and G_a = M⁻¹ ∇W^S_a reproduces a linear field's
        // gradient (eq 29). Also on a jittered cloud at its particles. Round-off of sums of
        // O(20) terms of O(1/Δx) against 1: 1e-10 · (1/Δx).
        let dx = 0.1;
        let kernel = Kernel::new(KernelKind::CubicSpline, 1.3 * dx, 2);
        let x = lattice(9, 7, dx);
        let body = vec![0; x.len()];
        let cells = lattice_cells::<D2>(&x, &body, dx, &Cells::default()).unwrap();
        let points = QuadraturePoints::<D2>::with_stress_points(&cells, &x, &body);
        let kb = Shapes::<D2>::krongauz_belytschko(&points.x0, &points.body, &x, &body, &kernel)
            .unwrap();
        assert_eq!(kb.test.len(), kb.grad.len());
        check_linear_completeness(&kb, &points.x0, &x, 1e-10 / dx);
        let jittered: Vec<DVec2> = x
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                let s = ((i as f64 * 12.9898).sin() * 43758.5453).fract();
                p + DVec2::new(s, 1.0 - 2.0 * s.abs()) * 0.2 * dx
            })
            .collect();
        let kb =
            Shapes::<D2>::krongauz_belytschko(&jittered, &body, &jittered, &body, &kernel).unwrap();
        check_linear_completeness(&kb, &jittered, &jittered, 1e-10 / dx);
        // The test gradients are the Shepard ones: not corrected, so at a corner they do
        // not reproduce the gradient of X (the paper's "not linearly complete" test
        // functions, which cost global angular momentum).
        let corner = kb.csr.range(0).fold(glam::DMat2::ZERO, |g, p| {
            g + D2::outer(jittered[kb.csr.ids[p] as usize], kb.test[p])
        });
        let off = (corner - glam::DMat2::IDENTITY).abs().to_cols_array();
        assert!(
            off.iter().any(|&e| e > 0.1),
            "Σ X ⊗ ∇W^S = {corner} at a corner"
        );
    }

    #[test]
    fn moving_least_squares_functions_are_those_of_eqs_40_to_42() {
        // Φ_a(X) = pᵀ(X) A⁻¹ p(X_a) W(X − X_a) with A = Σ_a p(X_a) pᵀ(X_a) W(X − X_a),
        // p = (1, X, Y), evaluated here directly (a 3×3 solve) at points between the
        // particles of a lattice whose boundary particles carry other volumes, which the
        // MLS functions must ignore; and linear completeness. Round-off: 1e-12.
        let dx = 0.1;
        let kernel = Kernel::new(KernelKind::CubicSpline, 1.5 * dx, 2);
        let x = lattice(8, 6, dx);
        let body = vec![0; x.len()];
        let at = [
            DVec2::new(0.0, 0.0),
            DVec2::new(0.33, 0.21),
            DVec2::new(0.7, 0.45),
        ];
        let mls = Shapes::<D2>::moving_least_squares(&at, &[0; 3], &x, &body, &kernel).unwrap();
        check_linear_completeness(&mls, &at, &x, 1e-11 / dx);
        for (q, &y) in at.iter().enumerate() {
            let p = |z: DVec2| glam::DVec3::new(1.0, z.x, z.y);
            let w = |a: usize| kernel.w((y - x[a]).length());
            let a_matrix = (0..x.len()).fold(glam::DMat3::ZERO, |m, a| {
                let pa = p(x[a]);
                m + glam::DMat3::from_cols(pa * pa.x, pa * pa.y, pa * pa.z) * w(a)
            });
            let c = a_matrix.inverse() * p(y);
            for k in mls.csr.range(q) {
                let a = mls.csr.ids[k] as usize;
                let phi = c.dot(p(x[a])) * w(a);
                assert!((mls.n[k] - phi).abs() < 1e-12, "point {q}, node {a}");
            }
        }
    }

    #[test]
    fn the_gather_lists_every_pair_once_under_its_node() {
        let dx = 1.0;
        let x = lattice(4, 3, dx);
        let cells = lattice_cells::<D2>(&x, &[0; 12], dx, &Cells::default()).unwrap();
        let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
        let shapes = Shapes::isoparametric(&cells, &points, &x);
        let gather = shapes.gather(x.len());
        let mut seen = vec![false; shapes.csr.ids.len()];
        for a in 0..x.len() {
            for e in gather.range(a) {
                let p = gather.pair[e] as usize;
                assert_eq!(shapes.csr.ids[p] as usize, a);
                assert!(shapes.csr.range(gather.point[e] as usize).contains(&p));
                assert!(!std::mem::replace(&mut seen[p], true));
            }
        }
        assert!(seen.iter().all(|&s| s));
        // A corner node is in one cell (4 points), an interior one in four (16).
        assert_eq!(gather.range(0).len(), 4);
        assert_eq!(gather.range(5).len(), 16);
    }

    #[test]
    fn recompute_writes_each_point_into_its_own_slots_and_fails_at_the_first_point() {
        // Points enough to split across threads (more than MIN_ROWS): each point's values
        // land in its own pairs' slots and its weight in its own entry, the test gradients
        // too (Petrov–Galerkin); of two failing points the error names the first in order.
        let x = lattice(20, 12, 1.0);
        let cells = lattice_cells::<D2>(&x, &[0; 240], 1.0, &Cells::default()).unwrap();
        let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
        let mut shapes = Shapes::isoparametric(&cells, &points, &x);
        shapes.test = vec![DVec2::ZERO; shapes.csr.pair_count()];
        let mut weight = vec![0.0; shapes.len()];
        let written = shapes.recompute(&mut weight, |q, nodes, row| {
            for (k, &a) in nodes.iter().enumerate() {
                row.n[k] = (q * 10 + k) as f64;
                row.grad[k] = DVec2::new(a as f64, q as f64);
                row.test[k] = DVec2::new(q as f64, k as f64);
            }
            Ok::<f64, ()>(-(q as f64))
        });
        assert_eq!(written, Ok(()));
        assert_eq!(weight.len(), shapes.len());
        for (q, &w) in weight.iter().enumerate() {
            assert_eq!(w, -(q as f64));
            for (k, p) in shapes.csr.range(q).enumerate() {
                assert_eq!(shapes.n[p], (q * 10 + k) as f64);
                let a = shapes.csr.ids[p] as f64;
                assert_eq!(shapes.grad[p], DVec2::new(a, q as f64));
                assert_eq!(shapes.test[p], DVec2::new(q as f64, k as f64));
            }
        }
        let failed = shapes.recompute(&mut [], |q, _, _| match q {
            700 | 300 => Err(q),
            _ => Ok(0.0),
        });
        assert_eq!(failed, Err((300, 300)));
    }
}
