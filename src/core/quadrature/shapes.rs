//! Shape functions at the quadrature points ([`Shapes`]) and their transposed lists
//! ([`Gather`]).

use super::{Cells, QuadratureError, QuadraturePoints, SmoothingCells, isoparametric_shapes};
use crate::core::correction;
use crate::core::kernel::Kernel;
use crate::core::neighbour::{self, Csr, Rows, split_rows};
use crate::core::tensor::Dim;
use rayon::prelude::*;

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
        let (csr, rows) = Self::rows_within(at, at_body, x, body, kernel, |y, nodes| {
            let shapes = correction::reproducing_shapes::<D>(y, nodes, x, vol, kernel)?;
            let scaled = nodes.iter().zip(shapes);
            Some(
                scaled
                    .map(|(&j, (psi, grad))| (vol[j as usize] * psi, grad * vol[j as usize]))
                    .collect(),
            )
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

    /// The lists of the nodes (positions x, bodies `body`) within the kernel's support of
    /// each point y_q (of body `at_body[q]`), and the values `row(y_q, nodes)` of every
    /// pair in CSR order; a point whose row is None is singular.
    fn rows_within<T: Default + Clone + Send>(
        at: &[D::V],
        at_body: &[u32],
        x: &[D::V],
        body: &[u32],
        kernel: &Kernel,
        row: impl Fn(D::V, &[u32]) -> Option<Vec<T>> + Sync,
    ) -> Result<(Csr, Vec<T>), QuadratureError> {
        let reach = crate::core::kernel::neighbour_radius(kernel);
        let csr = neighbour::between::<D>(at, x, reach, Some((at_body, body)));
        let rows = csr.map_rows(|q| {
            let nodes = csr.neighbours(q);
            row(at[q], nodes).ok_or(QuadratureError::Singular {
                point: q,
                position: D::to3(at[q]),
                nodes: nodes.len(),
            })
        })?;
        Ok((csr, rows))
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
        let (csr, rows) = Self::rows_within(at, at_body, x, body, kernel, |y, nodes| {
            krongauz_belytschko_shapes::<D>(y, nodes, x, kernel)
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

    /// The functions at the points `points` (ascending) on the nodes renumbered by `at`
    /// (`u32::MAX`: a node left out, whose pairs are dropped): a rank's share of a
    /// distributed run.
    pub fn restrict(&self, points: &[u32], at: &[u32]) -> Self {
        let mut out = Self {
            family: self.family,
            ..Self::default()
        };
        out.csr.offsets.push(0);
        for &q in points {
            for p in self.csr.range(q as usize) {
                let a = at[self.csr.ids[p] as usize];
                if a == u32::MAX {
                    continue;
                }
                out.csr.ids.push(a);
                out.n.push(self.n[p]);
                out.grad.push(self.grad[p]);
                if !self.test.is_empty() {
                    out.test.push(self.test[p]);
                }
            }
            out.csr.offsets.push(out.csr.ids.len());
        }
        out
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
    let reach = crate::core::kernel::neighbour_radius(kernel);
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
