//! Kernel corrections on a fixed particle set: Shepard, Randles–Libersky (CSPM) and RKPM.
//!
//! Every correction yields one gradient vector g_ij per stored pair, used as
//! ⟨∇f⟩_i = Σ_j V_j (f_j − f_i) ⊗ g_ij (seed 000 eqs 10–12, 20–41, 42–59).

use crate::core::kernel::Kernel;
use crate::core::neighbour::Csr;
use crate::core::tensor::Dim;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Kernel correction, as named in case files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CorrectionKind {
    /// Plain kernel gradient ∇W_ij (zero-order consistent in difference form only).
    None,
    /// Shepard-normalised gradient ∇W_ij / Σ_k V_k W_ik (seed 000 eq 27).
    Shepard,
    /// Randles–Libersky / CSPM: A_i⁻ᵀ ∇W_ij with A_i = Σ_j V_j (x_j − x_i) ⊗ ∇W_ij.
    RandlesLibersky,
    /// Reproducing-kernel gradient ∇Ψ_j(x_i) with a linear basis (seed 000 eqs 42–59).
    Rkpm,
    /// Corrected gradient of the corrected kernel (Bonet & Lok 1999; seed 003 §3.2):
    /// L_i ∇W̃_j(x_i) with the Shepard kernel W̃_j = W_j/S, ∇W̃_j = (∇W_j − W_j ∇S/S)/S,
    /// S = Σ_k V_k W_k (self included) and L_i = [Σ_j V_j ∇W̃_j ⊗ (x_j − x_i)]⁻¹.
    Cgck,
}

impl CorrectionKind {
    /// Whether gradients of linear fields are reproduced exactly.
    pub fn is_first_order(self) -> bool {
        matches!(self, Self::RandlesLibersky | Self::Rkpm | Self::Cgck)
    }

    /// Whether the corrected kernel reproduces constants with its own point included,
    /// Σ_j V_j W̃_j = 1, so that its gradients sum to zero over the whole neighbourhood:
    /// V_i ∇W̃_i(x_i) = −Σ_{j≠i} V_j g_ij ([`own_gradients`]).
    pub fn reproduces_constants(self) -> bool {
        matches!(self, Self::Rkpm | Self::Cgck)
    }
}

#[derive(Debug, Error, PartialEq)]
pub enum CorrectionError {
    #[error(
        "the {kind:?} correction matrix of particle {particle} at X = {position:?} is singular \
         (det = {det:e}): it has {neighbours} neighbours, too few or all on one line. Likely \
         causes: a particle apart from its body (a stray row of a points file), a body \
         thinner than the kernel support, or too small an h/dx; check the geometry near X \
         or increase h/dx"
    )]
    Singular {
        kind: CorrectionKind,
        particle: usize,
        /// Its reference position.
        position: [f64; 3],
        neighbours: usize,
        det: f64,
    },
}

/// What every correction reads: the particles' positions x and volumes V, their pairs
/// and the kernel.
struct Cloud<'a, D: Dim> {
    x: &'a [D::V],
    vol: &'a [f64],
    csr: &'a Csr,
    kernel: &'a Kernel,
}

impl<'a, D: Dim> Cloud<'a, D> {
    fn new(x: &'a [D::V], vol: &'a [f64], csr: &'a Csr, kernel: &'a Kernel) -> Self {
        Self {
            x,
            vol,
            csr,
            kernel,
        }
    }

    /// W(|x_i − x_j|).
    fn w(&self, i: usize, j: u32) -> f64 {
        self.kernel
            .w(D::norm2(self.x[i] - self.x[j as usize]).sqrt())
    }

    /// The Shepard sum C_i = Σ_k V_k W_ik, self term included.
    fn shepard_sum(&self, i: usize) -> f64 {
        self.vol[i] * self.kernel.w(0.0)
            + self
                .csr
                .neighbours(i)
                .iter()
                .map(|&j| self.vol[j as usize] * self.w(i, j))
                .sum::<f64>()
    }

    /// ∇W(x_i − x_j) of row i's pairs, into `g`.
    fn plain(&self, i: usize, g: &mut [D::V]) {
        for (g, &j) in g.iter_mut().zip(self.csr.neighbours(i)) {
            *g = self.kernel.grad::<D>(self.x[i] - self.x[j as usize]);
        }
    }

    /// ∇W_j(x_i) / Σ_k V_k W_k(x_i) of row i's pairs (self term in the sum), into `g`.
    fn shepard(&self, i: usize, g: &mut [D::V]) {
        let c = self.shepard_sum(i);
        self.plain(i, g);
        for g in g {
            *g = *g * (1.0 / c);
        }
    }

    /// ∇W̃_j(x_i) of the Shepard kernel W̃_j = W_j/S (Bonet & Lok 1999 eq 4.14, with the
    /// W_j factor on ∇S that seed 002 eq 13 drops) of row i's pairs, into `g`; returns the
    /// own term ∇W̃_i(x_i) = −W(0) ∇S/S².
    fn shepard_kernel_gradients(&self, i: usize, g: &mut [D::V]) -> D::V {
        let (x, vol, kernel) = (self.x, self.vol, self.kernel);
        let mut s = vol[i] * kernel.w(0.0);
        let mut grad_s = D::zero();
        for &j in self.csr.neighbours(i) {
            let r = x[i] - x[j as usize];
            s += vol[j as usize] * kernel.w(D::norm2(r).sqrt());
            grad_s += kernel.grad::<D>(r) * vol[j as usize];
        }
        for (g, &j) in g.iter_mut().zip(self.csr.neighbours(i)) {
            let r = x[i] - x[j as usize];
            let w = kernel.w(D::norm2(r).sqrt());
            *g = (kernel.grad::<D>(r) - grad_s * (w / s)) * (1.0 / s);
        }
        grad_s * (-kernel.w(0.0) / (s * s))
    }

    /// g ← L_i g with L_i = [Σ_j V_j g_j ⊗ (x_j − x_i)]⁻¹, so that
    /// Σ_j V_j (x_j − x_i) ⊗ L_i g_j = I, in place on row i's gradients; returns L_i.
    fn linear_correction(
        &self,
        kind: CorrectionKind,
        i: usize,
        g: &mut [D::V],
    ) -> Result<D::T, CorrectionError> {
        let (x, vol) = (self.x, self.vol);
        let mut a = D::zero_t();
        for (&j, &g) in self.csr.neighbours(i).iter().zip(&*g) {
            a += D::outer(x[j as usize] - x[i], g) * vol[j as usize];
        }
        let det = D::det(a);
        if det.is_nan() || det.abs() <= 1e-10 {
            return Err(self.singular(kind, i, det));
        }
        let a_inv_t = D::transpose(D::inverse(a));
        for g in g {
            *g = a_inv_t * *g;
        }
        Ok(a_inv_t)
    }

    /// The correction `kind` of particle i failed: its matrix has determinant `det`.
    fn singular(&self, kind: CorrectionKind, i: usize, det: f64) -> CorrectionError {
        CorrectionError::Singular {
            kind,
            particle: i,
            position: D::to3(self.x[i]),
            neighbours: self.csr.neighbours(i).len(),
            det,
        }
    }

    /// The reproducing-kernel coefficients of particle i, its own term included in the
    /// moments.
    fn coefficients(&self, i: usize) -> Result<Rkpm<D>, CorrectionError> {
        let (x, vol) = (self.x, self.vol);
        let own = std::iter::once((D::zero(), vol[i]));
        let others = self
            .csr
            .neighbours(i)
            .iter()
            .map(|&j| (x[i] - x[j as usize], vol[j as usize]));
        Rkpm::at(own.chain(others), self.kernel)
            .ok_or_else(|| self.singular(CorrectionKind::Rkpm, i, 0.0))
    }

    /// ∇Ψ_j(x_i) of the reproducing kernel of row i's pairs, into `g`.
    fn rkpm(&self, i: usize, g: &mut [D::V]) -> Result<(), CorrectionError> {
        let at = self.coefficients(i)?;
        for (g, &j) in g.iter_mut().zip(self.csr.neighbours(i)) {
            *g = at.shape(self.x[i] - self.x[j as usize], self.kernel).1;
        }
        Ok(())
    }
}

/// Shepard sums C_i = Σ_k V_k W_ik, self term included.
pub fn shepard_sums<D: Dim>(x: &[D::V], vol: &[f64], csr: &Csr, kernel: &Kernel) -> Vec<f64> {
    let cloud = Cloud::<D>::new(x, vol, csr, kernel);
    (0..x.len())
        .into_par_iter()
        .map(|i| cloud.shepard_sum(i))
        .collect()
}

/// Per-pair corrected gradients g_ij in CSR order.
pub fn gradients<D: Dim>(
    kind: CorrectionKind,
    x: &[D::V],
    vol: &[f64],
    csr: &Csr,
    kernel: &Kernel,
) -> Result<Vec<D::V>, CorrectionError> {
    let cloud = Cloud::<D>::new(x, vol, csr, kernel);
    csr.fill_rows(|i, g| match kind {
        CorrectionKind::None => {
            cloud.plain(i, g);
            Ok(())
        }
        CorrectionKind::Shepard => {
            cloud.shepard(i, g);
            Ok(())
        }
        CorrectionKind::RandlesLibersky => {
            cloud.plain(i, g);
            cloud.linear_correction(kind, i, g).map(drop)
        }
        CorrectionKind::Cgck => {
            cloud.shepard_kernel_gradients(i, g);
            cloud.linear_correction(kind, i, g).map(drop)
        }
        CorrectionKind::Rkpm => cloud.rkpm(i, g),
    })
}

/// Each row's corrected gradient of its own kernel at its own position, ∇W̃_i(x_i): the
/// j = i term of a sum over the whole neighbourhood (seed 002 eq 21), which the pair lists
/// leave out. Zero for `none`, `shepard` and `randles-libersky`, whose gradients scale
/// ∇W(0) = 0; RKPM's ∇Ψ_i(x_i), and the CGCK's L_i ∇W̃_i(x_i) = −L_i W(0) ∇S_i/S_i². Where
/// the kernel reproduces constants ([`CorrectionKind::reproduces_constants`]) it is
/// −(1/V_i) Σ_j V_j g_ij.
pub fn own_gradients<D: Dim>(
    kind: CorrectionKind,
    x: &[D::V],
    vol: &[f64],
    csr: &Csr,
    kernel: &Kernel,
) -> Result<Vec<D::V>, CorrectionError> {
    let cloud = Cloud::<D>::new(x, vol, csr, kernel);
    (0..csr.len())
        .into_par_iter()
        .map(|i| match kind {
            CorrectionKind::None | CorrectionKind::Shepard | CorrectionKind::RandlesLibersky => {
                Ok(D::zero())
            }
            CorrectionKind::Rkpm => Ok(cloud.coefficients(i)?.shape(D::zero(), kernel).1),
            CorrectionKind::Cgck => {
                let mut g = vec![D::zero(); csr.neighbours(i).len()];
                let own = cloud.shepard_kernel_gradients(i, &mut g);
                Ok(cloud.linear_correction(kind, i, &mut g)? * own)
            }
        })
        .collect()
}

/// Per-pair weights V_j W̃_j(x_i) of the corrected kernel in CSR order (rows of `csr`,
/// which may be fewer than the points its ids refer to): the
/// reproducing kernel with a linear basis for RKPM (W̃¹, seed 002 eqs 6–8: Σ V W̃ = 1 and
/// Σ V W̃ (x_i − x_j) = 0, self term included), the Shepard kernel W_j / Σ_k V_k W_k
/// (W̃⁰, seed 002 eq 10) for the other corrections.
pub fn kernel_weights<D: Dim>(
    kind: CorrectionKind,
    x: &[D::V],
    vol: &[f64],
    csr: &Csr,
    kernel: &Kernel,
) -> Result<Vec<f64>, CorrectionError> {
    let cloud = Cloud::<D>::new(x, vol, csr, kernel);
    csr.map_rows(|i| {
        if kind != CorrectionKind::Rkpm {
            let s = cloud.shepard_sum(i);
            return Ok(csr
                .neighbours(i)
                .iter()
                .map(|&j| vol[j as usize] * cloud.w(i, j) / s)
                .collect::<Vec<_>>());
        }
        let at = cloud.coefficients(i)?;
        Ok(csr
            .neighbours(i)
            .iter()
            .map(|&j| vol[j as usize] * at.value(x[i] - x[j as usize], cloud.w(i, j)))
            .collect::<Vec<_>>())
    })
}

/// Dense square matrix of order n ≤ 4 (the RKPM moment matrix, n = d + 1).
pub(crate) type Small = [[f64; 4]; 4];

/// Solves M y = b for n ≤ 4 by Gaussian elimination with partial pivoting.
/// Returns None when M is singular relative to its scale.
pub(crate) fn solve_small(mut m: Small, mut b: [f64; 4], n: usize) -> Option<[f64; 4]> {
    let scale = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    for c in 0..n {
        let p = (c..n).max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))?;
        if m[p][c].is_nan() || m[p][c].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(c, p);
        b.swap(c, p);
        for r in c + 1..n {
            let f = m[r][c] / m[c][c];
            let pivot_row = m[c];
            for (mk, pk) in m[r][c..n].iter_mut().zip(&pivot_row[c..n]) {
                *mk -= f * pk;
            }
            b[r] -= f * b[c];
        }
    }
    let mut y = [0.0; 4];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| m[r][k] * y[k]).sum();
        y[r] = (b[r] - s) / m[r][r];
    }
    Some(y)
}

/// Linear basis p(r) = (1, r) of the reproducing kernel, r = x_i − x_j.
fn linear_basis<D: Dim>(r: D::V) -> [f64; 4] {
    let mut p = [0.0; 4];
    p[0] = 1.0;
    for k in 0..D::N {
        p[k + 1] = D::comp(r, k);
    }
    p
}

/// The reproducing-kernel coefficients at a point x: C = M⁻¹ e₁ and ∂_k C (seed 000
/// eqs 55–59), from the nodes' offsets r_j = x − x_j, volumes V_j, and kernel values
/// W(r_j) and gradients ∇W(r_j), so that Ψ_j(x) = C·p(r_j) W(r_j). None when the moment
/// matrix is singular.
fn rkpm_coefficients<D: Dim>(
    nodes: impl Iterator<Item = (D::V, f64, f64, D::V)>,
) -> Option<([f64; 4], [[f64; 4]; 3])> {
    let n = D::N + 1;
    let basis = linear_basis::<D>;
    // Moment matrix M and its derivatives ∂_k M (eqs 55–58).
    let mut m: Small = [[0.0; 4]; 4];
    let mut dm: [Small; 3] = [[[0.0; 4]; 4]; 3];
    for (r, v, w, gw) in nodes {
        let p = basis(r);
        for a in 0..n {
            for b in 0..n {
                m[a][b] += v * w * p[a] * p[b];
                for (k, dmk) in dm.iter_mut().enumerate().take(D::N) {
                    let e = |c: usize| if c == k + 1 { 1.0 } else { 0.0 };
                    dmk[a][b] +=
                        v * (D::comp(gw, k) * p[a] * p[b] + w * (e(a) * p[b] + p[a] * e(b)));
                }
            }
        }
    }
    let c = solve_small(m, [1.0, 0.0, 0.0, 0.0], n)?;
    // ∂_k C = −M⁻¹ (∂_k M) C (eq 59).
    let mut dc = [[0.0; 4]; 3];
    for k in 0..D::N {
        let mut rhs = [0.0; 4];
        for a in 0..n {
            rhs[a] = -(0..n).map(|b| dm[k][a][b] * c[b]).sum::<f64>();
        }
        dc[k] = solve_small(m, rhs, n)?;
    }
    Some((c, dc))
}

/// RKPM shape functions with a linear basis at a point y (not one of the nodes) from the
/// nodes x_j with volumes V_j that reach it: Ψ_j(y) and ∇Ψ_j(y) of every node, in the
/// order given (seed 000 eqs 42–59). None when the nodes do not span the linear basis at
/// y (fewer than d + 1 of them, or all on one line or plane).
pub fn reproducing_shapes<D: Dim>(
    y: D::V,
    nodes: &[u32],
    x: &[D::V],
    vol: &[f64],
    kernel: &Kernel,
) -> Option<Vec<(f64, D::V)>> {
    let offsets: Vec<(D::V, f64)> = nodes
        .iter()
        .map(|&j| (y - x[j as usize], vol[j as usize]))
        .collect();
    reproducing_shapes_of::<D>(&offsets, kernel)
}

/// [`reproducing_shapes`] from the nodes' offsets r_j = y − x_j and volumes V_j.
pub fn reproducing_shapes_of<D: Dim>(
    nodes: &[(D::V, f64)],
    kernel: &Kernel,
) -> Option<Vec<(f64, D::V)>> {
    let at = Rkpm::<D>::at(nodes.iter().copied(), kernel)?;
    Some(nodes.iter().map(|&(r, _)| at.shape(r, kernel)).collect())
}

/// The reproducing-kernel coefficients C and ∂_k C at a point, which give every node's
/// function there ([`Rkpm::shape`]).
#[derive(Clone, Copy, Debug)]
pub struct Rkpm<D: Dim> {
    c: [f64; 4],
    dc: [[f64; 4]; 3],
    dim: std::marker::PhantomData<D>,
}

impl<D: Dim> Rkpm<D> {
    /// The coefficients at a point from its nodes' offsets r_j and volumes V_j; None when
    /// they do not span the linear basis there.
    pub fn at(nodes: impl Iterator<Item = (D::V, f64)>, kernel: &Kernel) -> Option<Self> {
        Self::weighted(
            nodes.map(|(r, v)| (r, v, kernel.w(D::norm2(r).sqrt()), kernel.grad::<D>(r))),
        )
    }

    /// [`Self::at`] with each node's own kernel value W(r_j) and gradient ∇W(r_j) (a
    /// smoothing length per pair): nodes `(r_j, V_j, W, ∇W)`.
    pub fn weighted(nodes: impl Iterator<Item = (D::V, f64, f64, D::V)>) -> Option<Self> {
        let (c, dc) = rkpm_coefficients::<D>(nodes)?;
        Some(Self {
            c,
            dc,
            dim: std::marker::PhantomData,
        })
    }

    /// Ψ_j and ∇Ψ_j of the node at offset r_j.
    pub fn shape(&self, r: D::V, kernel: &Kernel) -> (f64, D::V) {
        let w = kernel.w(D::norm2(r).sqrt());
        (self.value(r, w), self.gradient(r, w, kernel.grad::<D>(r)))
    }

    /// Ψ_j = C·p(r_j) W(r_j) from the kernel's value w = W(r_j).
    pub fn value(&self, r: D::V, w: f64) -> f64 {
        let p = linear_basis::<D>(r);
        (0..=D::N).map(|a| self.c[a] * p[a]).sum::<f64>() * w
    }

    /// ∇Ψ_j: ∂_k Ψ_j = (∂_k C·p + C_k) W + C·p ∂_k W (seed 000 §1.4), from the kernel's
    /// value w and gradient ∇W at r_j.
    pub fn gradient(&self, r: D::V, w: f64, grad_w: D::V) -> D::V {
        let (n, p) = (D::N + 1, linear_basis::<D>(r));
        let cp: f64 = (0..n).map(|a| self.c[a] * p[a]).sum();
        let mut g = [0.0; 3];
        for (k, gk) in g.iter_mut().enumerate().take(D::N) {
            let dcp: f64 = (0..n).map(|a| self.dc[k][a] * p[a]).sum();
            *gk = (dcp + self.c[k + 1]) * w + cp * D::comp(grad_w, k);
        }
        D::from_slice(&g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::kernel::KernelKind;
    use crate::core::neighbour;
    use crate::core::tensor::{D2, D3};
    use glam::{DMat2, DMat3, DVec2, DVec3};

    fn jitter(k: usize, amp: f64) -> f64 {
        // Deterministic perturbation in [−amp, amp].
        let s = ((k as f64 * 12.9898).sin() * 43758.5453).fract().abs();
        amp * (2.0 * s - 1.0)
    }

    #[test]
    fn corrected_kernels_are_partitions_of_unity() {
        // Σ_j V_j W̃_j(x_i) = 1 with the self term V_i W̃_i(x_i) (eq 5a) for both kernels;
        // RKPM's W̃¹ also has Σ_j V_j W̃_j (x_i − x_j) = 0 (eq 5b), Shepard's does not at
        // the boundary. Jittered 12×12 lattice, boundary included; round-off of O(k) sums
        // of O(1) terms: 1e-12.
        let (dx, x, vol, kernel, csr) = jittered_cloud();
        let shepard = shepard_sums::<D2>(&x, &vol, &csr, &kernel);
        for kind in [CorrectionKind::Rkpm, CorrectionKind::Cgck] {
            let w = kernel_weights::<D2>(kind, &x, &vol, &csr, &kernel).unwrap();
            let mut worst_moment = 0.0f64;
            for i in 0..x.len() {
                // The self weight V_i W̃_i(x_i), computed independently of the pair list.
                let own = vol[i]
                    * kernel.w(0.0)
                    * match kind {
                        CorrectionKind::Rkpm => Cloud::<D2>::new(&x, &vol, &csr, &kernel)
                            .coefficients(i)
                            .unwrap()
                            .value(DVec2::ZERO, 1.0),
                        _ => 1.0 / shepard[i],
                    };
                let pairs = csr.range(i);
                let total = own + w[pairs.clone()].iter().sum::<f64>();
                assert!(
                    (total - 1.0).abs() < 1e-12,
                    "{kind:?} particle {i}: Σ V W̃ = {total}"
                );
                let moment = pairs.fold(DVec2::ZERO, |m, q| {
                    m + (x[i] - x[csr.ids[q] as usize]) * w[q]
                });
                worst_moment = worst_moment.max(moment.length() / dx);
            }
            match kind {
                CorrectionKind::Rkpm => {
                    assert!(worst_moment < 1e-12, "W̃¹ first moment {worst_moment:e}")
                }
                _ => assert!(worst_moment > 1e-3, "Shepard first moment {worst_moment:e}"),
            }
        }
    }

    #[test]
    fn own_gradients_close_the_sum_of_a_kernel_that_reproduces_constants() {
        // Σ_j V_j ∇W̃_j(x_i) = ∇(Σ_j V_j W̃_j) = 0 over the whole neighbourhood, self
        // included, for RKPM and the CGCK: the own term computed on its own (RKPM's
        // ∇Ψ_i(x_i), the CGCK's L_i ∇W̃_i(x_i)) closes the pairs' sum to round-off (1e-12 of
        // Σ_j V_j |g_ij|), and is not small at the boundary (> 1e-2 of it). The other
        // corrections' own term is zero.
        let (_, x, vol, kernel, csr) = jittered_cloud();
        for kind in [CorrectionKind::Rkpm, CorrectionKind::Cgck] {
            let g = gradients::<D2>(kind, &x, &vol, &csr, &kernel).unwrap();
            let own = own_gradients::<D2>(kind, &x, &vol, &csr, &kernel).unwrap();
            let corner_share = |i: usize| {
                let pairs = csr.range(i);
                let v = |q: usize| vol[csr.ids[q] as usize];
                let sum = pairs.clone().fold(own[i] * vol[i], |s, q| s + g[q] * v(q));
                let scale: f64 = pairs.map(|q| g[q].length() * v(q)).sum();
                (sum.length() / scale, (own[i] * vol[i]).length() / scale)
            };
            for i in 0..x.len() {
                let (closure, _) = corner_share(i);
                assert!(
                    closure < 1e-12,
                    "{kind:?} particle {i}: |Σ V g| = {closure:e}"
                );
            }
            let (_, corner) = corner_share(0);
            assert!(
                corner > 1e-2,
                "{kind:?}: the corner's own term is {corner:e} of the sum"
            );
        }
        for kind in [
            CorrectionKind::None,
            CorrectionKind::Shepard,
            CorrectionKind::RandlesLibersky,
        ] {
            let own = own_gradients::<D2>(kind, &x, &vol, &csr, &kernel).unwrap();
            assert!(own.iter().all(|g| *g == DVec2::ZERO), "{kind:?}");
        }
    }

    /// A 12 × 12 lattice of Δx = 0.1 jittered by 0.2Δx, its volumes, the cubic spline at
    /// h = 1.3Δx and its neighbour lists.
    fn jittered_cloud() -> (f64, Vec<DVec2>, Vec<f64>, Kernel, Csr) {
        let dx = 0.1;
        let x = lattice2(12, dx, 0.2);
        let vol = vec![dx * dx; x.len()];
        let kernel = Kernel::new(KernelKind::CubicSpline, 1.3 * dx, 2);
        let csr = neighbour::build::<D2>(&x, kernel.support());
        (dx, x, vol, kernel, csr)
    }

    fn lattice2(n: usize, dx: f64, amp: f64) -> Vec<DVec2> {
        (0..n * n)
            .map(|k| {
                let (a, b) = ((k % n) as f64, (k / n) as f64);
                DVec2::new(
                    a * dx + jitter(2 * k, amp * dx),
                    b * dx + jitter(2 * k + 1, amp * dx),
                )
            })
            .collect()
    }

    /// Max over particles of |Σ_j V_j (f_j − f_i) ⊗ g_ij − A| for f = A x + b.
    fn linear_error<D: Dim>(x: &[D::V], vol: &[f64], csr: &Csr, g: &[D::V], a: D::T) -> f64 {
        let f = |p: D::V| a * p + D::from_slice(&[0.3, -0.2, 0.1]);
        (0..x.len())
            .map(|i| {
                let mut grad = D::zero_t();
                for (p, &j) in csr.range(i).zip(csr.neighbours(i)) {
                    grad += D::outer(f(x[j as usize]) - f(x[i]), g[p]) * vol[j as usize];
                }
                let e = grad - a;
                D::ddot(e, e).sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// The first-order corrections (Randles–Libersky, RKPM, CGCK) reproduce the gradient
    /// of a linear field f = A x + b at every particle.
    fn assert_linear_exact<D: Dim>(
        x: &[D::V],
        vol: &[f64],
        csr: &Csr,
        kernel: &Kernel,
        a: D::T,
        what: &str,
    ) {
        for kind in [
            CorrectionKind::RandlesLibersky,
            CorrectionKind::Rkpm,
            CorrectionKind::Cgck,
        ] {
            let g = gradients::<D>(kind, x, vol, csr, kernel).unwrap();
            // Exact up to round-off of O(N) sums of O(1/dx) terms: 1e-10 relative to |A| ~ 3.
            let e = linear_error::<D>(x, vol, csr, &g, a);
            assert!(e < 1e-10, "{kind:?} {what}: error {e:e}");
        }
    }

    #[test]
    fn first_order_corrections_reproduce_linear_fields_in_2d() {
        let a = DMat2::from_cols_array(&[0.7, -1.3, 2.1, 0.4]);
        for amp in [0.0, 0.2] {
            let dx = 0.1;
            let x = lattice2(12, dx, amp);
            let vol = vec![dx * dx; x.len()];
            for kernel_kind in KernelKind::ALL {
                let kernel = Kernel::new(kernel_kind, 1.3 * dx, 2);
                let csr = neighbour::build::<D2>(&x, kernel.support());
                let what = format!("{kernel_kind:?} jitter {amp}");
                assert_linear_exact::<D2>(&x, &vol, &csr, &kernel, a, &what);
                // The plain gradient is not first-order: it must fail at the boundary.
                let g = gradients::<D2>(CorrectionKind::None, &x, &vol, &csr, &kernel).unwrap();
                assert!(linear_error::<D2>(&x, &vol, &csr, &g, a) > 0.1);
            }
        }
    }

    #[test]
    fn first_order_corrections_reproduce_linear_fields_in_3d() {
        let n = 6;
        let dx = 0.2;
        let x: Vec<DVec3> = (0..n * n * n)
            .map(|k| {
                let p = DVec3::new((k % n) as f64, ((k / n) % n) as f64, (k / (n * n)) as f64) * dx;
                p + DVec3::new(
                    jitter(3 * k, 0.15 * dx),
                    jitter(3 * k + 1, 0.15 * dx),
                    jitter(3 * k + 2, 0.15 * dx),
                )
            })
            .collect();
        let vol = vec![dx * dx * dx; x.len()];
        let kernel = Kernel::new(KernelKind::WendlandC2, 1.3 * dx, 3);
        let csr = neighbour::build::<D3>(&x, kernel.support());
        let a = DMat3::from_cols_array(&[0.7, -1.3, 2.1, 0.4, 0.5, -0.6, 0.9, 0.2, -1.1]);
        assert_linear_exact::<D3>(&x, &vol, &csr, &kernel, a, "Wendland C2");
    }

    #[test]
    fn isolated_particle_is_reported() {
        let x = vec![DVec2::ZERO, DVec2::new(10.0, 0.0)];
        let vol = vec![1.0; 2];
        let kernel = Kernel::new(KernelKind::CubicSpline, 1.0, 2);
        let csr = neighbour::build::<D2>(&x, kernel.support());
        let err =
            gradients::<D2>(CorrectionKind::RandlesLibersky, &x, &vol, &csr, &kernel).unwrap_err();
        assert!(matches!(
            err,
            CorrectionError::Singular {
                particle: 0,
                neighbours: 0,
                ..
            }
        ));
        // The message says where the particle is and what usually causes it.
        let shown = err.to_string();
        assert!(
            shown.contains("particle 0 at X = [0.0, 0.0, 0.0]") && shown.contains("points file"),
            "{shown}"
        );
    }
}
