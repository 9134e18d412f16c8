//! Von Mises hyperelastic-plastic model with linear isotropic hardening or softening
//! (seed 003 Appendix A, Algorithm 2): Hencky (logarithmic) elastic strains, a radial
//! return in the principal Kirchhoff stresses, and the internal variables C_p⁻¹ and ε_p
//! ([`History`]: per particle for the mixed methods, per quadrature point for the
//! Galerkin ones), which the methods commit once per step from the state at its start
//! (the paper leaves the stages open). The algorithm works in 3 × 3 tensors; a 2D (plane-strain) F
//! enters with F_zz = 1.
//!
//! A negative modulus H softens (seed 001 §9.5: H = −E/10). The yield stress
//! τ_y = τ_y⁰ + H ε_p then stops at zero, at ε_p = τ_y⁰/|H|: from there on the material
//! carries no deviatoric stress (a fluid under pressure). The return solves
//! q̄ − 3μΔγ − τ_y(ε_pⁿ + Δγ) = 0 with the trial equivalent stress q̄: on the linear
//! branch Δγ = (q̄ − τ_y⁰ − H ε_pⁿ)/(3μ + H) (Algorithm 2 step 7), on the zero branch
//! Δγ = q̄/(3μ); both are roots of decreasing functions whose smaller one is the
//! left-hand side, so its root is the smaller of the two, which for H ≥ 0 is always the
//! linear one. It needs 3μ + H > 0, which validation requires.

use crate::core::parallel::{load_field, load_word, save_field};
use crate::core::tensor::Dim;
use glam::{DMat3, DVec3};

/// The frame and snapshot field of the equivalent plastic strain ε_p.
pub const PLASTIC_STRAIN: &str = "plastic_strain";

/// Yield stress and hardening of the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hardening {
    /// Initial yield stress τ_y⁰ [Pa].
    pub yield_stress: f64,
    /// Linear isotropic hardening modulus H [Pa]: τ_y = τ_y⁰ + H ε_p, negative for
    /// softening, down to τ_y = 0.
    pub modulus: f64,
}

impl Hardening {
    /// The yield stress τ_y(ε_p) = max(τ_y⁰ + H ε_p, 0).
    pub fn yield_stress_at(&self, eps_p: f64) -> f64 {
        (self.yield_stress + self.modulus * eps_p).max(0.0)
    }

    /// The plastic multiplier Δγ of a return from the trial equivalent stress q̄ =
    /// sqrt(3/2 τ̄':τ̄') beyond yield at ε_pⁿ (module docs).
    pub fn multiplier(&self, mu: f64, q_trial: f64, eps_p: f64) -> f64 {
        let linear =
            (q_trial - (self.yield_stress + self.modulus * eps_p)) / (3.0 * mu + self.modulus);
        linear.min(q_trial / (3.0 * mu))
    }
}

/// Shear and bulk moduli with the hardening.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VonMises {
    pub mu: f64,
    pub bulk: f64,
    pub hardening: Hardening,
}

/// The outcome of Algorithm 2 for one particle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Returned {
    /// First Piola–Kirchhoff stress P = τ F⁻ᵀ (step 11).
    pub p: DMat3,
    /// [C_p⁻¹]ⁿ⁺¹ = F⁻¹ b_e Fᵀ⁻¹ (step 13).
    pub cp_inv: DMat3,
    /// ε_pⁿ⁺¹ = ε_pⁿ + Δγ (step 14).
    pub eps_p: f64,
    /// Stored (Hencky) energy per reference volume, μ Σ (ln λ_e,i − ⅓ ln J)² + κ/2 (ln J)².
    pub psi: f64,
}

impl VonMises {
    /// Algorithm 2 at deformation gradient f from the internal variables [C_p⁻¹]ⁿ, ε_pⁿ.
    pub fn return_map(&self, f: DMat3, cp_inv: DMat3, eps_p: f64) -> Returned {
        let mu = self.mu;
        // (1)–(2)
        let j = f.determinant();
        let ln_j = j.ln();
        let p = self.bulk * ln_j / j;
        // (3)–(4): b̄_e = F C_p⁻¹ Fᵀ = Σ λ̄² n̄ ⊗ n̄.
        let (eig, n) = symmetric_eigen(f * cp_inv * f.transpose());
        let ln_stretch = eig.to_array().map(|e| 0.5 * e.ln());
        // (5) τ̄'_ii = 2μ ln λ̄_i − ⅔ μ ln J.
        let tau_trial = ln_stretch.map(|l| 2.0 * mu * l - 2.0 / 3.0 * mu * ln_j);
        let norm = tau_trial.iter().map(|t| t * t).sum::<f64>().sqrt();
        // (6) f = sqrt(3/2 τ̄':τ̄') − τ_y(ε_p).
        let q_trial = (1.5f64).sqrt() * norm;
        let yield_fn = q_trial - self.hardening.yield_stress_at(eps_p);
        // (7) Δγ = f / (3μ + H) (or q̄/(3μ) once τ_y reaches zero), ν_i = τ̄'_ii /
        // sqrt(2/3 τ̄':τ̄').
        let (dgamma, scale) = if yield_fn > 0.0 {
            let dgamma = self.hardening.multiplier(mu, q_trial, eps_p);
            (dgamma, (2.0f64 / 3.0).sqrt() * norm)
        } else {
            (0.0, 1.0)
        };
        let nu = tau_trial.map(|t| t / scale);
        // (8) ln λ_e = ln λ̄ − Δγ ν; (10) τ'_ii = (1 − 2μΔγ / sqrt(2/3 τ̄':τ̄')) τ̄'_ii.
        let ln_elastic: [f64; 3] = std::array::from_fn(|i| ln_stretch[i] - dgamma * nu[i]);
        let tau_dev = tau_trial.map(|t| (1.0 - 2.0 * mu * dgamma / scale) * t);
        let principal = |v: [f64; 3]| {
            (0..3).fold(DMat3::ZERO, |m, i| {
                m + DMat3::from_cols(
                    n.col(i) * n.col(i).x,
                    n.col(i) * n.col(i).y,
                    n.col(i) * n.col(i).z,
                ) * v[i]
            })
        };
        // (10)–(11)
        let tau = principal(tau_dev.map(|t| t + j * p));
        let f_inv = f.inverse();
        // (12)–(13)
        let b_e = principal(ln_elastic.map(|l| (2.0 * l).exp()));
        let psi = mu
            * ln_elastic
                .iter()
                .map(|l| (l - ln_j / 3.0).powi(2))
                .sum::<f64>()
            + 0.5 * self.bulk * ln_j * ln_j;
        Returned {
            p: tau * f_inv.transpose(),
            cp_inv: f_inv * b_e * f_inv.transpose(),
            eps_p: eps_p + dgamma,
            psi,
        }
    }
}

/// The internal variables C_p⁻¹ and ε_p of a von Mises material at its material points
/// (particles, or the quadrature points of a Galerkin method) at the start of the
/// current step, and the plastic work done up to then. A method commits them once per
/// step from the state at its start, and evaluates the stress of every stage from them.
///
/// The plastic work is W_p = Σ_q w_q ∫ τ_y dε̄_p over the reference weights w_q, the
/// hardening's ½ H ε̄_p² included (the stored energy is the elastic ψ of [`Returned`]
/// alone). Within a step the history is fixed, and the returned stress P(F) derives
/// from a potential Φ(F) = ψ_vol + ∫_0^q̄ q(s)/(3μ) ds of the trial equivalent stress
/// q̄ (the return is radial and q(s) its equivalent stress), which exceeds the elastic ψ
/// of the returned state by Δγ ½(τ_y(ε̄_pⁿ) + τ_y(ε̄_pⁿ⁺¹)) (on the linear branch of
/// τ_y, and on its zero branch; a step that reaches τ_y = 0 is approximated by the same
/// trapezoid). So the work of the stresses over a step is Δψ plus that plastic work,
/// and the balance closes with it up to the integrator's error.
#[derive(Clone, Debug, PartialEq)]
pub struct History {
    pub model: VonMises,
    pub cp_inv: Vec<DMat3>,
    pub eps_p: Vec<f64>,
    /// W_p up to the start of the current step.
    pub work: f64,
}

impl History {
    /// n virgin points: C_p⁻¹ = I, ε_p = 0.
    pub fn virgin(model: VonMises, n: usize) -> Self {
        Self {
            model,
            cp_inv: vec![DMat3::IDENTITY; n],
            eps_p: vec![0.0; n],
            work: 0.0,
        }
    }

    /// Algorithm 2 for point a at the deformation gradient f (F_zz = 1 in 2D) from its
    /// committed history.
    pub fn returned<D: Dim>(&self, a: usize, f: D::T) -> Returned {
        self.model
            .return_map(to_mat3::<D>(f, 1.0), self.cp_inv[a], self.eps_p[a])
    }

    /// W_p up to a state whose points returned `returned` from this history: the
    /// committed work plus Σ_q w_q Δγ_q ½(τ_y(ε̄_pⁿ) + τ_y(ε̄_pⁿ⁺¹)) with Δγ_q = ε̄_pⁿ⁺¹ −
    /// ε̄_pⁿ, over the reference weights w_q of the points.
    pub fn work_at(&self, returned: &[Returned], weight: &[f64]) -> f64 {
        let hardening = &self.model.hardening;
        let step: f64 = (returned.iter().zip(&self.eps_p).zip(weight))
            .map(|((r, &eps_n), &w)| {
                let tau = hardening.yield_stress_at(eps_n) + hardening.yield_stress_at(r.eps_p);
                w * (r.eps_p - eps_n) * 0.5 * tau
            })
            .sum();
        self.work + step
    }

    /// Takes the returned variables of every point as the new history, and books the
    /// step's plastic work ([`Self::work_at`], reference weights w_q).
    pub fn commit(&mut self, returned: &[Returned], weight: &[f64]) {
        self.work = self.work_at(returned, weight);
        (self.cp_inv, self.eps_p) = returned.iter().map(|r| (r.cp_inv, r.eps_p)).unzip();
    }

    /// A virgin point in the device's layout (`plasticity.wgsl`): C_p⁻¹ by columns, then ε_p.
    pub const VIRGIN_F32: [f32; 10] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

    /// Replaces the history by one read back from the device (10 floats per point, as
    /// [`Self::VIRGIN_F32`]).
    pub fn read_f32(&mut self, flat: &[f32]) {
        (self.cp_inv, self.eps_p) = flat
            .chunks_exact(10)
            .map(|h| {
                let m: [f64; 9] = std::array::from_fn(|k| f64::from(h[k]));
                (DMat3::from_cols_array(&m), f64::from(h[9]))
            })
            .unzip();
    }

    /// Appends C_p⁻¹, ε_p and W_p of a history, if any, to a checkpoint.
    pub fn save(history: Option<&Self>, out: &mut Vec<f64>) {
        if let Some(h) = history {
            save_field(&h.cp_inv, out);
            save_field(&h.eps_p, out);
            out.push(h.work);
        }
    }

    /// Reads what [`Self::save`] wrote.
    pub fn load(history: Option<&mut Self>, words: &mut &[f64]) -> Result<(), String> {
        match history {
            Some(h) => {
                load_field(&mut h.cp_inv, "C_p⁻¹", words)?;
                load_field(&mut h.eps_p, "ε_p", words)?;
                h.work = load_word(words, "the plastic work")?;
                Ok(())
            }
            None => Ok(()),
        }
    }
}

impl Returned {
    /// The Cauchy stress σ = J⁻¹ P Fᵀ at the deformation gradient f it was returned at
    /// (3 × 3; F_zz = 1 in 2D, so σ_zz is the plane-strain one).
    pub fn cauchy<D: Dim>(&self, f: D::T) -> [[f64; 3]; 3] {
        let f3 = to_mat3::<D>(f, 1.0);
        (self.p * f3.transpose() * (1.0 / f3.determinant()))
            .transpose()
            .to_cols_array_2d()
    }
}

/// A 2D (plane-strain, F_zz = 1) or 3D tensor as a 3 × 3 one.
pub fn to_mat3<D: Dim>(t: D::T, zz: f64) -> DMat3 {
    let mut m = D::to3x3(t);
    if D::N == 2 {
        m[2][2] = zz;
    }
    DMat3::from_cols_array_2d(&m).transpose()
}

/// The in-plane block of a 3 × 3 tensor as a D tensor.
pub fn from_mat3<D: Dim>(m: DMat3) -> D::T {
    let e = |k: usize| {
        let mut v = [0.0; 3];
        v[k] = 1.0;
        D::from_slice(&v[..D::N])
    };
    let mut t = D::zero_t();
    for k in 0..D::N {
        for l in 0..D::N {
            t += D::outer(e(k), e(l)) * m.col(l)[k];
        }
    }
    t
}

/// Eigenvalues and unit eigenvectors (the columns) of a symmetric 3 × 3 matrix, by cyclic
/// Jacobi rotations to a relative off-diagonal of 1e-15.
pub fn symmetric_eigen(a: DMat3) -> (DVec3, DMat3) {
    let mut m = a.to_cols_array_2d();
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let scale = m.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    for _sweep in 0..16 {
        let off = m[0][1].powi(2) + m[0][2].powi(2) + m[1][2].powi(2);
        if off.sqrt() <= 1e-15 * scale {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if m[p][q] == 0.0 {
                continue;
            }
            // The rotation in the (p, q) plane that zeroes m_pq.
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // m ← Jᵀ m J and v ← v J with J the rotation.
            let rotate_columns = |row: &mut [f64; 3]| {
                let (xp, xq) = (row[p], row[q]);
                row[p] = c * xp - s * xq;
                row[q] = s * xp + c * xq;
            };
            m.iter_mut().for_each(rotate_columns);
            v.iter_mut().for_each(rotate_columns);
            let (rp, rq) = (m[p], m[q]);
            m[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            m[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
        }
    }
    // v holds the eigenvectors as columns in row-major form.
    let cols = DMat3::from_cols_array_2d(&v).transpose();
    (DVec3::new(m[0][0], m[1][1], m[2][2]), cols)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tensor::D3;

    fn max_abs(m: DMat3) -> f64 {
        m.to_cols_array().iter().fold(0.0, |a, x| a.max(x.abs()))
    }

    fn copper() -> VonMises {
        // The seed-003 Taylor bar: E = 117 GPa, ν = 0.35, τ_y⁰ = 0.4 GPa, H = 0.1 GPa.
        let (e, nu) = (117e9, 0.35);
        let mu = e / (2.0 * (1.0 + nu));
        VonMises {
            mu,
            bulk: e / (3.0 * (1.0 - 2.0 * nu)),
            hardening: Hardening {
                yield_stress: 0.4e9,
                modulus: 0.1e9,
            },
        }
    }

    #[test]
    fn the_work_of_the_stress_over_a_step_is_the_stored_and_the_plastic_work() {
        // Within a step the history is fixed and the returned P(F) derives from a
        // potential, so ∫ P : dF along a path from the committed state F_n to F is
        // ψ(F) − ψ(F_n) plus History::work_at's increment Δγ ½(τ_y(ε_pⁿ) + τ_y(ε_pⁿ⁺¹)).
        // Copper committed at a shear of 1 % (beyond yield: ε_p > 0, C_p ≠ I), then a
        // path to a shear of 2 % with a stretch of 0.5 %, by 4000 midpoint sub-steps: the
        // rule's error is O(N⁻²) of the path's work, ~1e-8 of it; bound 1e-6 of the
        // step's plastic work.
        let shear = |g: f64, e: f64| {
            DMat3::from_cols(
                DVec3::new(1.0 + e, 0.0, 0.0),
                DVec3::new(g, 1.0, 0.0),
                DVec3::Z,
            )
        };
        let (f_n, f) = (shear(0.01, 0.0), shear(0.02, 0.005));
        let mut history = History::virgin(copper(), 1);
        history.commit(&[history.returned::<D3>(0, f_n)], &[1.0]);
        assert!(history.eps_p[0] > 0.0 && history.work > 0.0);
        let steps = 4000;
        let df = (f - f_n) * (1.0 / f64::from(steps));
        let work: f64 = (0..steps)
            .map(|k| {
                let at = f_n + (f - f_n) * ((f64::from(k) + 0.5) / f64::from(steps));
                let p = history.returned::<D3>(0, at).p;
                (0..3).map(|c| p.col(c).dot(df.col(c))).sum::<f64>()
            })
            .sum();
        let (start, end) = (history.returned::<D3>(0, f_n), history.returned::<D3>(0, f));
        let plastic = history.work_at(&[end], &[1.0]) - history.work;
        let expected = end.psi - start.psi + plastic;
        eprintln!(
            "∫ P:dF {work:e}, Δψ {:e}, ΔW_p {plastic:e}",
            end.psi - start.psi
        );
        assert!(plastic > 0.0, "the step must flow: {plastic:e} of {work:e}");
        assert!(
            (work - expected).abs() < 1e-6 * plastic,
            "∫ P:dF = {work:e}, Δψ + ΔW_p = {expected:e}"
        );
    }

    /// The steel of seed 001 §9.5: E = 2e11 Pa, H = −E/10, σ_Y(0) = 1e10 Pa; ν is not
    /// given there, 0.3 is taken.
    fn softening_steel() -> VonMises {
        let (e, nu) = (2e11, 0.3);
        VonMises {
            mu: e / (2.0 * (1.0 + nu)),
            bulk: e / (3.0 * (1.0 - 2.0 * nu)),
            hardening: Hardening {
                yield_stress: 1e10,
                modulus: -e / 10.0,
            },
        }
    }

    #[test]
    fn uniaxial_strain_follows_the_closed_form_with_hardening_and_softening() {
        // F = diag(e^ε, 1, 1), ε from 0 to 1 in 200 increments, the history committed after
        // each. The principal frame is fixed, so the return in logarithmic strains is exact
        // and the path has a closed form: the elastic log strain is ε(1, 0, 0) − ε_p(1, −½,
        // −½), its equivalent Kirchhoff stress q = 2με − 3μ ε_p, and on yield q = τ_y(ε_p),
        // so ε_p = (2με − τ_y⁰)/(3μ + H) on the linear branch; once τ_y⁰ + H ε_p reaches
        // zero (softening) the deviator vanishes and ε_p = ⅔ε. Then τ_xx = κ ε + ⅔ q and
        // τ_yy = κ ε − ⅓ q. Round-off: ~1e-16 relative per logarithm and product (the
        // eigen-decomposition of a diagonal matrix is exact), over 200 committed steps at
        // most 1e-13 of the stresses (~1e11 Pa): 1e-2 Pa; bounds 1e-9 τ_y⁰ (≥ 0.4 Pa) and
        // 1e-9 for ε_p.
        for m in [softening_steel(), copper()] {
            let (mu, kappa, hard) = (m.mu, m.bulk, m.hardening);
            let (mut cp_inv, mut eps_p) = (DMat3::IDENTITY, 0.0);
            let mut saturated = false;
            for k in 1..=200 {
                let eps = k as f64 / 200.0;
                let f = DMat3::from_diagonal(DVec3::new(eps.exp(), 1.0, 1.0));
                let r = m.return_map(f, cp_inv, eps_p);
                (cp_inv, eps_p) = (r.cp_inv, r.eps_p);
                let linear =
                    ((2.0 * mu * eps - hard.yield_stress) / (3.0 * mu + hard.modulus)).max(0.0);
                let expected_eps_p = if hard.yield_stress + hard.modulus * linear > 0.0 {
                    linear
                } else {
                    saturated = true;
                    2.0 * eps / 3.0
                };
                // The equivalent stress: elastic 2με below yield, τ_y(ε_p) beyond.
                let q = if expected_eps_p > 0.0 {
                    hard.yield_stress_at(expected_eps_p)
                } else {
                    2.0 * mu * eps
                };
                let tau = r.p * f.transpose();
                let (xx, yy) = (kappa * eps + 2.0 / 3.0 * q, kappa * eps - q / 3.0);
                let tol = 1e-9 * hard.yield_stress;
                assert!(
                    (eps_p - expected_eps_p).abs() < 1e-9,
                    "H = {}: ε = {eps}: ε_p {eps_p} vs {expected_eps_p}",
                    hard.modulus
                );
                assert!(
                    (tau.col(0).x - xx).abs() < tol && (tau.col(1).y - yy).abs() < tol,
                    "H = {}: ε = {eps}: τ_xx {} vs {xx}, τ_yy {} vs {yy}",
                    hard.modulus,
                    tau.col(0).x,
                    tau.col(1).y
                );
            }
            // The steel's yield stress reaches zero at ε_p = 0.5 (ε = 0.75) within the path;
            // the copper keeps hardening.
            assert_eq!(saturated, m.hardening.modulus < 0.0);
        }
        // The softening lowers the stress past yield: the steel's τ_y at ε_p = 0.25 is
        // 1e10 − 2e10 · 0.25 = 5e9 Pa.
        assert_eq!(softening_steel().hardening.yield_stress_at(0.25), 5e9);
        assert_eq!(softening_steel().hardening.yield_stress_at(0.9), 0.0);
    }

    #[test]
    fn jacobi_finds_the_eigenpairs_of_a_rotated_diagonal() {
        // A = R diag(3, 1e-3, 2) Rᵀ: A n_i = λ_i n_i and RᵀR = I to round-off (1e-14).
        let r = DMat3::from_euler(glam::EulerRot::XYZ, 0.4, -1.2, 2.5);
        let a = r * DMat3::from_diagonal(DVec3::new(3.0, 1e-3, 2.0)) * r.transpose();
        let (eig, n) = symmetric_eigen(a);
        let mut sorted = eig.to_array();
        sorted.sort_by(f64::total_cmp);
        assert!(
            (DVec3::from_array(sorted) - DVec3::new(1e-3, 2.0, 3.0))
                .abs()
                .max_element()
                < 1e-14
        );
        for i in 0..3 {
            let residual = a * n.col(i) - n.col(i) * eig[i];
            assert!(
                residual.length() < 1e-14,
                "eigenpair {i}: residual {residual}"
            );
        }
        assert!(max_abs(n.transpose() * n - DMat3::IDENTITY) < 1e-14);
    }

    #[test]
    fn below_yield_the_response_is_hencky_elastic() {
        // Uniaxial strain 1.001 (σ_yy ≈ 188 MPa, equivalent stress 87 MPa < 400 MPa): no
        // plastic flow, C_p⁻¹ stays I,
        // and τ = 2μ dev ln V + κ ln J I exactly (round-off 1e-9 relative).
        let m = copper();
        let f = DMat3::from_diagonal(DVec3::new(1.0, 1.001, 1.0));
        let r = m.return_map(f, DMat3::IDENTITY, 0.0);
        assert_eq!(r.eps_p, 0.0);
        assert!(max_abs(r.cp_inv - DMat3::IDENTITY) < 1e-15);
        let ln = 1.001f64.ln();
        let tau_yy = 2.0 * m.mu * (ln - ln / 3.0) + m.bulk * ln;
        let p_yy = tau_yy / 1.001;
        assert!(
            (r.p.col(1).y / p_yy - 1.0).abs() < 1e-9,
            "P_yy {} vs {p_yy}",
            r.p.col(1).y
        );
    }

    #[test]
    fn the_return_lands_on_the_hardened_yield_surface() {
        // A shear far beyond yield: after the return the equivalent Kirchhoff stress
        // sqrt(3/2 τ':τ') equals τ_y⁰ + H ε_pⁿ⁺¹ (the consistency condition, exact in the
        // principal frame: round-off 1e-9 relative), the plastic flow keeps det C_p⁻¹ = 1
        // (isochoric, 1e-12), and a second return from the committed variables at the same
        // F is elastic (Δγ = 0).
        let m = copper();
        let f = DMat3::from_cols_array_2d(&[[1.0, 0.05, 0.0], [0.0, 1.0, 0.0], [0.01, 0.0, 0.999]]);
        let r = m.return_map(f, DMat3::IDENTITY, 0.0);
        assert!(r.eps_p > 0.0, "a shear of 5 % must yield copper");
        let tau = r.p * f.transpose();
        let dev = tau - DMat3::IDENTITY * (tau.col(0).x + tau.col(1).y + tau.col(2).z) / 3.0;
        let equivalent = (1.5 * dev.to_cols_array().iter().map(|x| x * x).sum::<f64>()).sqrt();
        let yield_now = m.hardening.yield_stress + m.hardening.modulus * r.eps_p;
        assert!(
            (equivalent / yield_now - 1.0).abs() < 1e-9,
            "{equivalent} vs {yield_now}"
        );
        assert!((r.cp_inv.determinant() - 1.0).abs() < 1e-12);
        let again = m.return_map(f, r.cp_inv, r.eps_p);
        assert!((again.eps_p - r.eps_p).abs() < 1e-12 * r.eps_p);
        assert!(max_abs(again.p - r.p) < 1e-6 * max_abs(r.p));
    }
}
