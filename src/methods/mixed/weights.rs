//! Per-pair weights of the mixed methods, computed once on the reference configuration:
//! the least-squares reconstruction weights of Upwind-SPH and the Laplacian weights of
//! JST-SPH.

use crate::core::correction::{Small, solve_small};
use crate::core::neighbour::Csr;
use crate::core::tensor::Dim;
use rayon::prelude::*;

/// One value per CSR pair (i, j).
pub(super) fn pair_map<T: Send>(csr: &Csr, f: impl Fn(usize, usize) -> T + Sync) -> Vec<T> {
    (0..csr.len())
        .into_par_iter()
        .flat_map_iter(|i| csr.neighbours(i).iter().map(move |&j| (i, j as usize)))
        .map(|(i, j)| f(i, j))
        .collect()
}

/// Least-squares weights M_a⁻¹ N_ab / |d_ab| with M_a = Σ_b N_ab ⊗ N_ab (eq 37), so that
/// 𝒢_a = Σ_b (𝒰_b − 𝒰_a) M_a⁻¹ N_ab / |d_ab|. Err(particle) where M_a is singular.
pub(super) fn least_squares_weights<D: Dim>(
    x0: &[D::V],
    csr: &Csr,
    normal: &[D::V],
) -> Result<Vec<D::V>, usize> {
    csr.map_rows(|a| {
        let mut m = D::zero_t();
        for q in csr.range(a) {
            m += D::outer(normal[q], normal[q]);
        }
        let det = D::det(m);
        if det.is_nan() || det.abs() <= 1e-8 {
            return Err(a);
        }
        let m_inv = D::inverse(m);
        Ok(csr.range(a).map(move |q| {
            let d = D::norm2(x0[csr.ids[q] as usize] - x0[a]).sqrt();
            m_inv * normal[q] * (1.0 / d)
        }))
    })
}

/// Brookshaw Laplacian weights w_ab = 2 V_b N_ab · ∇̃W̃_b(X_a)/|X_ab| (seed 003 eq 55).
pub(super) fn brookshaw_weights<D: Dim>(
    x0: &[D::V],
    vol: &[f64],
    pairs: &[(usize, usize)],
    grad: &[D::V],
    normal: &[D::V],
) -> Vec<f64> {
    pairs
        .par_iter()
        .zip(grad.par_iter().zip(normal))
        .map(|(&(a, b), (&g, &n))| 2.0 * vol[b] * D::dot(n, g) / D::norm2(x0[b] - x0[a]).sqrt())
        .collect()
}

/// Brookshaw weights w_ab corrected to ℓ_ab = w_ab (1 + λ_a·X_ab + μ_a |X_ab|²), with
/// λ_a, μ_a such that Σ_b ℓ_ab X_ab = 0 and Σ_b ℓ_ab |X_ab|² = 2d: Σ_b ℓ_ab (f_b − f_a)
/// is then exact for linear fields and for |X|². Seed 002 names the Bonet–Kulasegaram
/// corrected Laplacian without giving it; this is the smallest correction with its
/// stated properties. Err(a) names a particle whose correction is singular.
pub(super) fn correct_laplacian<D: Dim>(
    x0: &[D::V],
    csr: &Csr,
    w: &[f64],
) -> Result<Vec<f64>, usize> {
    let n = D::N + 1;
    csr.map_rows(|a| {
        let basis = move |q: usize| {
            let x = x0[csr.ids[q] as usize] - x0[a];
            let mut p = [0.0; 4];
            for (k, c) in p.iter_mut().enumerate().take(D::N) {
                *c = D::comp(x, k);
            }
            p[D::N] = D::norm2(x);
            p
        };
        let mut m: Small = [[0.0; 4]; 4];
        let mut rhs = [0.0; 4];
        rhs[D::N] = 2.0 * D::N as f64;
        for q in csr.range(a) {
            let p = basis(q);
            for k in 0..n {
                rhs[k] -= w[q] * p[k];
                for l in 0..n {
                    m[k][l] += w[q] * p[k] * p[l];
                }
            }
        }
        let c = solve_small(m, rhs, n).ok_or(a)?;
        Ok(csr.range(a).map(move |q| {
            let p = basis(q);
            w[q] * (1.0 + (0..n).map(|k| c[k] * p[k]).sum::<f64>())
        }))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::correction::{self, CorrectionKind};
    use crate::core::kernel::{Kernel, KernelKind};
    use crate::core::neighbour;
    use crate::core::tensor::D3;
    use glam::DVec3;

    /// Σ_b ℓ_ab X_ab and Σ_b ℓ_ab |X_ab|² − 2d of every particle, and the smallest
    /// symmetrised weight ℓ_ab + ℓ_ba, for the weights of the JST Laplacian on a
    /// cell-centred 4 × 4 × 6 block with free surfaces (CGCK, cubic spline, h/Δx = 1.1:
    /// the bending column's set-up).
    fn laplacian_moments(corrected: bool) -> (f64, f64, f64) {
        let dx = 0.2;
        let x0: Vec<DVec3> = (0..96)
            .map(|k| DVec3::new((k % 4) as f64, (k / 4 % 4) as f64, (k / 16) as f64) * dx)
            .collect();
        let vol = vec![dx * dx * dx; x0.len()];
        let kernel = Kernel::new(KernelKind::CubicSpline, 1.1 * dx, 3);
        let csr = neighbour::build::<D3>(&x0, kernel.support());
        let grad =
            correction::gradients::<D3>(CorrectionKind::Cgck, &x0, &vol, &csr, &kernel).unwrap();
        let normal = pair_map(&csr, |a, b| (x0[b] - x0[a]).normalize());
        let pairs = pair_map(&csr, |a, b| (a, b));
        let mut ell = brookshaw_weights::<D3>(&x0, &vol, &pairs, &grad, &normal);
        if corrected {
            ell = correct_laplacian::<D3>(&x0, &csr, &ell).unwrap();
        }
        let (mut first, mut second, mut min_sym) = (0.0_f64, 0.0_f64, f64::INFINITY);
        for a in 0..csr.len() {
            let (mut m1, mut m2) = (DVec3::ZERO, 0.0);
            for q in csr.range(a) {
                let b = csr.ids[q] as usize;
                let x_ab = x0[b] - x0[a];
                m1 += x_ab * ell[q];
                m2 += ell[q] * x_ab.length_squared();
                let q_ba = csr.range(b).find(|&p| csr.ids[p] as usize == a).unwrap();
                min_sym = min_sym.min(ell[q] + ell[q_ba]);
            }
            first = first.max(m1.length());
            second = second.max((m2 - 6.0).abs());
        }
        (first, second, min_sym)
    }

    #[test]
    fn brookshaw_weights_are_positive_and_exact_for_the_square_of_x() {
        // Σ_b ℓ_ab |X_ab|² = 2 Σ_b V_b X_ab·∇̃W̃_b(X_a) = 2 tr I = 2d at every particle,
        // boundaries included, because the corrected gradient is exact for linear fields
        // (round-off of O(30) terms of O(1): 1e-12). The first moment is not zero at the
        // free surfaces (the Laplacian of a linear field is not zero there), and every
        // symmetrised weight is positive, so −Σ s_ab (f_b − f_a)² ≤ 0: the bi-Laplacian
        // dissipation cannot put energy in.
        let (first, second, min_sym) = laplacian_moments(false);
        assert!(second < 1e-12, "|Σ ℓ|X|² − 2d| = {second:e}");
        assert!(first > 1.0, "|Σ ℓ X| = {first:e} at the free surface");
        assert!(min_sym > 0.0, "smallest ℓ_ab + ℓ_ba = {min_sym:e}");
    }

    #[test]
    fn corrected_weights_are_exact_for_linear_fields_and_change_sign() {
        // The correction zeroes the first moment and keeps the second at 2d (round-off
        // of the 5 × 5 solve: 1e-10), at the price of weights of both signs at the free
        // surfaces, where the bi-Laplacian dissipation then has no definite sign.
        let (first, second, min_sym) = laplacian_moments(true);
        assert!(first < 1e-10, "|Σ ℓ X| = {first:e}");
        assert!(second < 1e-10, "|Σ ℓ|X|² − 2d| = {second:e}");
        assert!(min_sym < 0.0, "smallest ℓ_ab + ℓ_ba = {min_sym:e}");
    }
}
