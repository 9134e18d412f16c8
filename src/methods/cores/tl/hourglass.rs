//! Ganzenmüller's hourglass control of the total-Lagrangian methods (2015, the stiffness
//! form of LAMMPS's SMD package): the pair stiffnesses κ_ij, set up once on the
//! reference configuration (by the CPU scheme and the GPU engine alike), and the
//! acceleration of a bond.

use crate::case::Case;
use crate::core::neighbour::Csr;
use crate::core::tensor::Dim;
use rayon::prelude::*;

/// The stiffness κ_ij = α E V_j W(|X_ij|)/(ρ0 |X_ij|²) of the hourglass control of every
/// pair, in CSR order: the acceleration of i per unit δ_ij ([`hourglass_acceleration`]).
/// m_i κ_ij = α E V_i V_j W/|X_ij|² is symmetric, so the pair forces are equal and
/// opposite.
pub fn hourglass_stiffness<D: Dim>(
    case: &Case,
    alpha: f64,
    x0: &[D::V],
    vol: &[f64],
    csr: &Csr,
) -> Vec<f64> {
    let kernel = &case.kernel(D::N);
    let (e, _) = case.material.youngs_and_poisson();
    let rho0 = case.material.density;
    (0..csr.len())
        .into_par_iter()
        .flat_map_iter(|i| {
            csr.range(i).map(move |p| {
                let j = csr.ids[p] as usize;
                let r0_squared = D::norm2(x0[j] - x0[i]);
                alpha * e * vol[j] * kernel.w(r0_squared.sqrt()) / (rho0 * r0_squared)
            })
        })
        .collect()
}

/// The hourglass control's acceleration of i from its bond to j (Ganzenmüller 2015, the
/// stiffness form of LAMMPS's SMD package): −κ_ij δ_ij e_ij, with the error vector
/// γ_ij = ½(F_i + F_j) X_ij − x_ij = ½(H_i + H_j) X_ij − (u_j − u_i) (H = F − I, which
/// keeps the digits of a small mismatch), e_ij = x_ij/|x_ij| and δ_ij = ½ γ_ij·e_ij. It
/// vanishes when F_i and F_j map the bond exactly, as for every affine motion.
pub fn hourglass_acceleration<D: Dim>(kappa: f64, dx0: D::V, du: D::V, h_sum: D::T) -> D::V {
    let dx = dx0 + du;
    let e = dx * (1.0 / D::norm2(dx).sqrt());
    let gamma = h_sum * dx0 * 0.5 - du;
    e * (-0.5 * kappa * D::dot(gamma, e))
}
