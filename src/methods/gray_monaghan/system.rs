//! Gray–Monaghan stress-corrected updated-Lagrangian SPH on the CPU (seed 000 §5.1,
//! Algorithm 1, eqs 103–105 and 118–127): the pair scheme of the updated-Lagrangian core
//! ([`crate::methods::cores::ul`]).
//!
//! The momentum equation (eq 118) uses the plain, antisymmetric kernel gradient ∇W_ij, so
//! the pair forces (stress, artificial stress and artificial viscosity) conserve linear
//! momentum; the case's correction (`none`, the paper's, or `randles-libersky`) acts on the
//! velocity gradient L_i of eq 105, which feeds ρ̇, Ṡ and Ḟ.

use super::{ArtificialStress, GrayMonaghanSpec};
use crate::case::{Case, CaseError};
use crate::core::neighbour::Rebuild;
use crate::core::tensor::Dim;
use crate::methods::cores::family::MethodFamily;
use crate::methods::cores::ul::{
    CoreKeys, PairRates, PairScheme, PairSums, UlCore, UlSph, UlState,
};
use crate::physics::plasticity::{symmetric_eigen, to_mat3};
use crate::physics::viscosity::ArtificialViscosity;

/// f^n, by repeated squaring for the integer exponents of every seed set-up (n = 4): the
/// products of `f64::powi`, here inline in the pair loop, where `powi` with an exponent
/// known only at run time is a library call per pair.
fn power(f: f64, n: f64) -> f64 {
    if n.fract() != 0.0 || n.abs() > 16.0 {
        return f.powf(n);
    }
    let (mut base, mut e, mut product) = (f, n.abs() as u32, 1.0);
    loop {
        if e & 1 == 1 {
            product *= base;
        }
        e >>= 1;
        if e == 0 {
            break;
        }
        base *= base;
    }
    if n < 0.0 { 1.0 / product } else { product }
}

/// The Gray–Monaghan system on the CPU (f64, rayon).
pub type GrayMonaghan<D> = UlSph<D, Scheme>;

/// Per-particle quantities of one rate evaluation (Algorithm 1 steps 1–3).
#[derive(Clone, Copy, Debug)]
pub struct Particle<D: Dim> {
    /// σ_i/ρ_i² with σ = S − p I.
    sigma_rho2: D::T,
    /// Artificial stress R_i (eqs 119–125); zero without it.
    r: D::T,
    /// V_i = m_i/ρ_i.
    vol: f64,
    /// Sound speed c_i = sqrt(K/ρ_i).
    c: f64,
}

/// The artificial stress R of a particle with Cauchy stress σ and density ρ (eqs
/// 119–125, with the errata of seed 000 §8): R = Σ_k R̄_k n_k ⊗ n_k over the principal
/// stresses σ̄_k with directions n_k, where R̄_k = −ε σ̄_k/ρ² for σ̄_k > 0 (tension) and 0
/// otherwise. In 2D n_1 = (c, s), n_2 = (−s, c) with θ of tan 2θ = 2σ_xy/(σ_xx − σ_yy)
/// (eq 119) in closed form; in 3D the directions are the Jacobi eigenvectors of σ.
pub fn artificial_stress<D: Dim>(sigma: D::T, rho: f64, epsilon: f64) -> D::T {
    let (values, directions) = principal_stresses::<D>(sigma);
    let mut r = D::zero_t();
    for k in 0..D::N {
        if values[k] > 0.0 {
            let n = directions[k];
            r += D::outer(n, n) * (-epsilon * values[k] / (rho * rho)); // eq 122
        }
    }
    r
}

/// Principal stresses σ̄_k and their unit directions n_k (the first D::N entries).
pub fn principal_stresses<D: Dim>(sigma: D::T) -> ([f64; 3], [D::V; 3]) {
    if D::N == 2 {
        let (sxx, syy, sxy) = (
            D::entry(sigma, 0, 0),
            D::entry(sigma, 1, 1),
            D::entry(sigma, 0, 1),
        );
        // eq 119 without trigonometry: cos 2θ and sin 2θ from d = sqrt((σ_xx − σ_yy)² + 4σ_xy²);
        // θ = 0 for an isotropic stress (d = 0), as atan2(0, 0) = 0.
        let d = ((sxx - syy).powi(2) + 4.0 * sxy * sxy).sqrt();
        let (c, s) = if d == 0.0 {
            (1.0, 0.0)
        } else {
            let (cos2, sin2) = ((sxx - syy) / d, 2.0 * sxy / d);
            let s = ((1.0 - cos2) / 2.0).max(0.0).sqrt();
            (
                ((1.0 + cos2) / 2.0).max(0.0).sqrt(),
                if sin2 < 0.0 { -s } else { s },
            )
        };
        let bar_xx = c * c * sxx + 2.0 * c * s * sxy + s * s * syy; // eq 120
        let bar_yy = s * s * sxx - 2.0 * c * s * sxy + c * c * syy; // eq 121 (erratum: −2csσ_xy)
        let n1 = D::from_slice(&[c, s]);
        let n2 = D::from_slice(&[-s, c]);
        ([bar_xx, bar_yy, 0.0], [n1, n2, D::zero()])
    } else {
        let (values, vectors) = symmetric_eigen(to_mat3::<D>(sigma, 0.0));
        let n = |k: usize| D::from_slice(&vectors.col(k).to_array());
        (values.to_array(), [n(0), n(1), n(2)])
    }
}

/// The pair sums of Algorithm 1 with the case's constants.
pub struct Scheme {
    av: Option<ArtificialViscosity>,
    /// The artificial stress with W(Δp) of the case's kernel, Δp the particle spacing
    /// (eq 118's f_ij = W_ij/W(Δp)).
    stress: Option<(ArtificialStress, f64)>,
    xsph: Option<f64>,
}

impl<D: Dim> PairScheme<D> for Scheme {
    type Particle = Particle<D>;
    const REBUILD: Rebuild = GrayMonaghanSpec::NEIGHBOURS;

    type Spec = GrayMonaghanSpec;

    fn new(case: &Case, spec: &GrayMonaghanSpec, core: &UlCore<D>) -> Result<Self, CaseError> {
        Ok(Self {
            av: spec.artificial_viscosity,
            stress: spec
                .artificial_stress
                .map(|s| (s, core.kernel.w(case.spacing))),
            xsph: spec.xsph,
        })
    }

    fn core_keys(spec: &GrayMonaghanSpec) -> CoreKeys {
        CoreKeys {
            free_surface: spec.free_surface,
            smoothing_length: spec.smoothing_length,
        }
    }

    fn particle(&self, core: &UlCore<D>, i: usize, y: &UlState<D>) -> Particle<D> {
        let rho = y.rho[i];
        let sigma = core.cauchy(i, y); // σ = S − pI
        Particle {
            sigma_rho2: sigma * (1.0 / (rho * rho)),
            r: self.stress.map_or(D::zero_t(), |(s, _)| {
                artificial_stress::<D>(sigma, rho, s.epsilon)
            }),
            vol: core.mass[i] / rho,
            c: (core.material.bulk / rho).sqrt(),
        }
    }

    /// Steps 4–11 for particle i.
    fn rates_of(&self, sums: &PairSums<D, Particle<D>>, i: usize) -> PairRates<D> {
        let (core, y) = (sums.core, sums.y);
        let pi = sums.particles[i];
        let (vi, rho_i) = (y.v[i], y.rho[i]);
        let mut l = D::zero_t();
        let mut a = D::zero();
        let mut xsph = D::zero();
        let mut viscous = D::zero();
        for (j, pj, x_ij, r, kernel) in sums.pairs(i) {
            let h = kernel.h;
            let grad = kernel.grad::<D>(x_ij);
            let w = kernel.w(r);
            let v_ji = y.v[j] - vi;
            l += D::outer(v_ji, pi.correction.gradient(x_ij, w, grad)) * pj.vol; // eq 105
            let mut t = pi.sigma_rho2 + pj.sigma_rho2;
            if let Some((s, w_dp)) = self.stress {
                // eq 118; an adaptive h_ij scales Δp with it: f_ij = w(r/h_ij)/w(Δp/h).
                let f = w / w_dp * (core.kernel.scale() / kernel.scale());
                t += (pi.r + pj.r) * power(f, s.n);
            }
            a += t * grad * core.mass[j];
            let rho_bar = 0.5 * (rho_i + y.rho[j]);
            if let Some(av) = &self.av {
                let vx = -D::dot(v_ji, x_ij);
                if vx < 0.0 {
                    // Monaghan viscosity for approaching pairs (seed 000 §3.1 step 6).
                    let mu = h * vx / (r * r + av.eta * av.eta * h * h);
                    let c = 0.5 * (pi.c + pj.c);
                    let pi_ij = (-av.alpha * c * mu + av.beta * mu * mu) / rho_bar;
                    viscous -= grad * (core.mass[j] * pi_ij);
                }
            }
            if self.xsph.is_some() {
                xsph += v_ji * (core.mass[j] / rho_bar * w); // eq 127
            }
        }
        PairRates {
            x_dot: vi + xsph * self.xsph.unwrap_or(0.0),
            v_dot: a + viscous,
            v_dot_dissipative: viscous,
            rho_dot: -rho_i * D::trace(l), // eq 104
            l,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::power;

    /// The inline squaring gives `powi`'s products bit for bit, and `powf` elsewhere.
    #[test]
    fn power_is_powi_for_integer_exponents_and_powf_otherwise() {
        for k in 0..200 {
            let f = 0.01 + 0.0173 * k as f64;
            for n in -16..=16 {
                let n = n as f64;
                assert_eq!(power(f, n).to_bits(), f.powi(n as i32).to_bits(), "{f}^{n}");
            }
            for n in [2.5, -0.5, 17.0] {
                assert_eq!(power(f, n).to_bits(), f.powf(n).to_bits(), "{f}^{n}");
            }
        }
    }
}
