//! Godunov SPH on the CPU (seed 000 §5.2, Algorithm 2, eqs 128–133, in the clean form of
//! the spec notes §3.2): the pair scheme of the updated-Lagrangian core
//! ([`crate::methods::cores::ul`]).
//!
//! Every pair (i, j) is an acoustic Riemann problem along n_ij = x_ij/r_ij with impedances
//! Z = ρ c, c = sqrt(K/ρ). Its contact velocity u* replaces the mean normal velocity in the
//! continuity equation and its traction t* the mean traction in the momentum equation;
//! t*_ji = −t*_ij, so the pair forces conserve linear momentum. The velocity gradient of
//! the stress rate is eq 105 with the case's correction (`none`, the paper's, or
//! `randles-libersky`).

use super::GodunovSpec;
use crate::case::{Case, CaseError};
use crate::core::neighbour::Rebuild;
use crate::core::tensor::Dim;
use crate::methods::cores::family::MethodFamily;
use crate::methods::cores::ul::{
    CoreKeys, PairRates, PairScheme, PairSums, UlCore, UlSph, UlState,
};

/// The Godunov SPH system on the CPU (f64, rayon).
pub type Godunov<D> = UlSph<D, Scheme>;

/// The acoustic Riemann contact velocity of the normal velocities u_i, u_j and pressures
/// p_i, p_j (p positive in compression) of two states with impedances Z_i, Z_j along
/// n_ij, which points from j to i (seed 000 eq 133 in the form of the spec notes §3.2):
/// u* = (Z_i u_i + Z_j u_j − p_i + p_j)/(Z_i + Z_j).
pub fn contact_velocity(z_i: f64, u_i: f64, p_i: f64, z_j: f64, u_j: f64, p_j: f64) -> f64 {
    (z_i * u_i + z_j * u_j - p_i + p_j) / (z_i + z_j)
}

/// The acoustic Riemann traction of the tractions t_i = σ_i e, t_j = σ_j e on the pair's
/// axis e = (x_j − x_i)/r_ij and the velocities v_i, v_j, component by component
/// (seed 000 eq 132; spec notes §3.2):
/// t* = [Z_i t_j + Z_j t_i + Z_i Z_j (v_j − v_i)]/(Z_i + Z_j).
pub fn contact_traction<D: Dim>(
    z_i: f64,
    t_i: D::V,
    v_i: D::V,
    z_j: f64,
    t_j: D::V,
    v_j: D::V,
) -> D::V {
    (t_j * z_i + t_i * z_j + (v_j - v_i) * (z_i * z_j)) * (1.0 / (z_i + z_j))
}

/// Per-particle quantities of one rate evaluation (Algorithm 2 steps 1–2).
#[derive(Clone, Copy, Debug)]
pub struct Particle<D: Dim> {
    /// σ = S − p I.
    sigma: D::T,
    /// p = c0²(ρ − ρ0).
    p: f64,
    /// Impedance Z = ρ c with c = sqrt(K/ρ).
    z: f64,
    /// V_i = m_i/ρ_i.
    vol: f64,
}

/// The pair sums of Algorithm 2.
pub struct Scheme;

impl<D: Dim> PairScheme<D> for Scheme {
    type Particle = Particle<D>;
    const REBUILD: Rebuild = GodunovSpec::NEIGHBOURS;

    type Spec = GodunovSpec;

    fn new(_case: &Case, _spec: &GodunovSpec, _core: &UlCore<D>) -> Result<Self, CaseError> {
        Ok(Self)
    }

    fn core_keys(spec: &GodunovSpec) -> CoreKeys {
        CoreKeys {
            free_surface: spec.free_surface,
            smoothing_length: spec.smoothing_length,
        }
    }

    fn particle(&self, core: &UlCore<D>, i: usize, y: &UlState<D>) -> Particle<D> {
        let rho = y.rho[i];
        let p = core.material.pressure(rho);
        Particle {
            sigma: core.cauchy(i, y),
            p,
            z: rho * (core.material.bulk / rho).sqrt(),
            vol: core.mass[i] / rho,
        }
    }

    /// Steps 3–7 for particle i.
    fn rates_of(&self, sums: &PairSums<D, Particle<D>>, i: usize) -> PairRates<D> {
        let y = sums.y;
        let pi = sums.particles[i];
        let (vi, rho_i) = (y.v[i], y.rho[i]);
        let mut l = D::zero_t();
        let mut rho_dot = 0.0;
        let mut a = D::zero();
        let mut jump = D::zero();
        for (j, pj, x_ij, r, kernel) in sums.pairs(i) {
            if r <= 1e-12 * kernel.h {
                // Coincident particles: no axis for the Riemann problem, and ∇W_ij = 0.
                continue;
            }
            let n = x_ij * (1.0 / r);
            let dw = kernel.dw_dr(r);
            let g = pi.correction.gradient(x_ij, kernel.w(r), n * dw);
            l += D::outer(y.v[j] - vi, g) * pj.vol; // eq 105
            // Continuity with the Riemann velocity (eqs 131, 133).
            let (u_i, u_j) = (D::dot(vi, n), D::dot(y.v[j], n));
            let u_star = contact_velocity(pi.z, u_i, pi.p, pj.z, u_j, pj.p);
            rho_dot += 2.0 * rho_i * pj.vol * (u_i - u_star) * dw;
            // Momentum with the Riemann traction (eq 132), on the axis e = −n.
            let e = -n;
            let t_star = contact_traction::<D>(pi.z, pi.sigma * e, vi, pj.z, pj.sigma * e, y.v[j]);
            let scale = 2.0 / rho_i * pj.vol * dw;
            a -= t_star * scale;
            // The dissipative part of t*, Z_i Z_j/(Z_i + Z_j) (v_j − v_i), booked apart.
            jump -= (y.v[j] - vi) * (pi.z * pj.z / (pi.z + pj.z) * scale);
        }
        PairRates {
            x_dot: vi,
            v_dot: a,
            v_dot_dissipative: jump,
            rho_dot,
            l,
        }
    }
}
