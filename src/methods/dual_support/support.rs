//! Supports and dual-supports with a smoothing length per particle, and the corrected
//! kernel gradients of the reference configuration (seed 004 eqs 5–13), built once.

use crate::core::kernel::{Kernel, KernelKind, neighbour_radius};
use crate::core::neighbour::{Csr, Reach, build_within};
use crate::core::tensor::Dim;
use rayon::prelude::*;
use thiserror::Error;

/// A particle whose correction matrix L_i cannot be inverted.
#[derive(Clone, Debug, Error, PartialEq)]
#[error(
    "particle {particle} at {position:?} has {neighbours} neighbour(s) in its support of \
     radius {radius:e} m and a singular correction matrix L_i (|det L_i| = {det:e}): it needs \
     at least dimension-many non-collinear neighbours; raise method.h_over_dx or \
     method.smoothing_length"
)]
pub struct SingularCorrection {
    pub particle: usize,
    pub position: [f64; 3],
    pub neighbours: usize,
    pub radius: f64,
    pub det: f64,
}

/// The reference configuration of the dual-support method: per particle the support S_i
/// (the particles within its own radius, self excluded, eq 5), the dual-support S'_i (the
/// particles whose radius holds i, eq 6), and per pair (i, j ∈ S_i) the fixed kernel data.
pub struct Support<D: Dim> {
    /// Reference positions X.
    pub x0: Vec<D::V>,
    /// Reference volumes V.
    pub vol: Vec<f64>,
    /// Smoothing length h_i of every particle (the kernel's h; its support radius is
    /// the kernel's support factor times h_i).
    pub h: Vec<f64>,
    /// S_i as CSR rows; pair slot p = (i, j) is owned by i.
    pub lists: Csr,
    /// g_ij = L_i⁻¹ ∇W_i(X_ij) V_j per pair (eqs 9–10): F_i = I + Σ_j u_ij ⊗ g_ij.
    pub g: Vec<D::V>,
    /// w_ij = W′_i(X_ij) V_j / |X_ij| (≤ 0) per pair: the hourglass weight of eq 21.
    pub w: Vec<f64>,
    /// L_i = Σ_j V_j ∇W_i(X_ij) ⊗ X_ij (eq 11), ≈ −I inside a body.
    pub l: Vec<D::T>,
    /// g_i0 = −Σ_j g_ij: the gradient weight of the particle itself in F_i.
    pub g_self: Vec<D::V>,
    /// S'_a as CSR rows: the owners i with a ∈ S_i.
    pub dual: Csr,
    /// For every entry of `dual`, the pair slot (i, a) in `lists`.
    pub dual_slot: Vec<u32>,
}

impl<D: Dim> Support<D> {
    /// Supports of radius `kind.support_factor() · h_i` on the reference positions x0 with
    /// volumes `vol`.
    pub fn new(
        x0: Vec<D::V>,
        vol: Vec<f64>,
        h: Vec<f64>,
        kind: KernelKind,
    ) -> Result<Self, SingularCorrection> {
        let kernels: Vec<Kernel> = h.iter().map(|&h| Kernel::new(kind, h, D::N)).collect();
        let reach: Vec<f64> = kernels.iter().map(neighbour_radius).collect();
        // Pairs within the larger radius of the two; each row keeps those within its own.
        let both = build_within::<D>(&x0, Reach::PerParticle(&reach), None);
        let rows: Vec<Vec<u32>> = (0..x0.len())
            .into_par_iter()
            .map(|i| {
                let r2 = reach[i] * reach[i];
                both.neighbours(i)
                    .iter()
                    .copied()
                    .filter(|&j| D::norm2(x0[j as usize] - x0[i]) <= r2)
                    .collect()
            })
            .collect();
        let lists = csr_of(&rows);
        // ∇W_i(X_ij) = W′(|X_ij|; h_i) X_ij/|X_ij| with X_ij = X_j − X_i (eq 9).
        let pair = |i: usize, j: usize| {
            let x_ij = x0[j] - x0[i];
            let r = D::norm2(x_ij).sqrt();
            let dw = kernels[i].dw_dr(r);
            (x_ij, dw / r)
        };
        let l: Vec<D::T> = (0..x0.len())
            .into_par_iter()
            .map(|i| {
                lists.neighbours(i).iter().fold(D::zero_t(), |acc, &j| {
                    let (x_ij, dw_r) = pair(i, j as usize);
                    acc + D::outer(x_ij * (dw_r * vol[j as usize]), x_ij)
                })
            })
            .collect();
        // Singular relative to L_i's own size: |det L| ≤ 1e-8 (|L|_F/√d)^d, so a support
        // that barely reaches its neighbours (W′ ≈ 0 there: seed 004 §6.4's n = 0.9 at a
        // corner) is not mistaken for a degenerate one; L ≈ −I inside gives the scale 1.
        let singular = |l: D::T| {
            let scale = (D::ddot(l, l) / D::N as f64).powf(0.5 * D::N as f64);
            let det = D::det(l).abs();
            det.is_nan() || det <= 1e-8 * scale
        };
        if let Some(i) = (0..x0.len())
            .into_par_iter()
            .find_first(|&i| singular(l[i]))
        {
            return Err(SingularCorrection {
                particle: i,
                position: D::to3(x0[i]),
                neighbours: lists.neighbours(i).len(),
                radius: kernels[i].support(),
                det: D::det(l[i]).abs(),
            });
        }
        let l_inv: Vec<D::T> = l.par_iter().map(|&l| D::inverse(l)).collect();
        let per_pair: Vec<(Vec<D::V>, Vec<f64>)> = (0..x0.len())
            .into_par_iter()
            .map(|i| {
                lists
                    .neighbours(i)
                    .iter()
                    .map(|&j| {
                        let vj = vol[j as usize];
                        let (x_ij, dw_r) = pair(i, j as usize);
                        (l_inv[i] * (x_ij * (dw_r * vj)), dw_r * vj)
                    })
                    .unzip()
            })
            .collect();
        let (mut g, mut w) = (Vec::new(), Vec::new());
        for (gi, wi) in per_pair {
            g.extend(gi);
            w.extend(wi);
        }
        let g_self = (0..x0.len())
            .into_par_iter()
            .map(|i| -lists.range(i).fold(D::zero(), |acc, p| acc + g[p]))
            .collect();
        let (dual, dual_slot) = transpose(&lists);
        Ok(Self {
            x0,
            vol,
            h,
            lists,
            g,
            w,
            l,
            g_self,
            dual,
            dual_slot,
        })
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x0.is_empty()
    }

    /// The local nodes of particle i's "element": i itself, then S_i.
    pub fn nodes(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        std::iter::once(i).chain(self.lists.neighbours(i).iter().map(|&j| j as usize))
    }

    /// The gradient weight of local node k of particle i (k = 0: i itself).
    pub fn weight(&self, i: usize, k: usize) -> D::V {
        if k == 0 {
            self.g_self[i]
        } else {
            self.g[self.lists.offsets[i] + k - 1]
        }
    }

    /// The particles whose element holds a, with a's local index in it: (a, 0), then
    /// (i, slot − offset + 1) for every i ∈ S'_a.
    pub fn elements_of(&self, a: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        std::iter::once((a, 0)).chain(self.dual.range(a).map(move |q| {
            let i = self.dual.ids[q] as usize;
            (i, self.dual_slot[q] as usize - self.lists.offsets[i] + 1)
        }))
    }

    /// H_i = F_i − I = Σ_j u_ij ⊗ g_ij (eq 12 written in displacements, so that strains of
    /// 1e-7 keep their digits).
    pub fn displacement_gradient(&self, u: &[D::V], i: usize) -> D::T {
        let pairs = self.lists.pairs(i, &self.g);
        pairs.fold(D::zero_t(), |acc, (j, &g)| acc + D::outer(u[j] - u[i], g))
    }
}

/// CSR lists from rows.
fn csr_of(rows: &[Vec<u32>]) -> Csr {
    let mut offsets = Vec::with_capacity(rows.len() + 1);
    offsets.push(0);
    for r in rows {
        offsets.push(offsets.last().copied().unwrap_or(0) + r.len());
    }
    Csr {
        offsets,
        ids: rows.concat(),
    }
}

/// The transpose of directed lists (row a: the owners i with a in row i, ascending), and
/// for each of its entries the slot of the pair (i, a) in `lists`.
fn transpose(lists: &Csr) -> (Csr, Vec<u32>) {
    let n = lists.len();
    let mut count = vec![0usize; n + 1];
    for &j in &lists.ids {
        count[j as usize + 1] += 1;
    }
    for k in 0..n {
        count[k + 1] += count[k];
    }
    let offsets = count.clone();
    let mut ids = vec![0u32; lists.ids.len()];
    let mut slot = vec![0u32; lists.ids.len()];
    for i in 0..n {
        for p in lists.range(i) {
            let a = lists.ids[p] as usize;
            ids[count[a]] = i as u32;
            slot[count[a]] = p as u32;
            count[a] += 1;
        }
    }
    (Csr { offsets, ids }, slot)
}
