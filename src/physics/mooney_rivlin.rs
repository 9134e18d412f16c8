//! The compressible Mooney–Rivlin rubber of seed 001 (Rabczuk, Belytschko & Xiao) eq 18,
//! the material of its rubber ring (§9.6) and of its material-stability map (Fig. 1):
//!
//! σ = (1/√I3) [(c1 + c2 I1) B − c2 B² − (c1 I3^(1/3) + 2 c2 I3^(2/3) − λ ln I3) I],
//!
//! B = F Fᵀ, I1 = tr B, I3 = det B = J². It is hyperelastic: the Kirchhoff stress of an
//! isotropic W(I1, I2, I3) is τ = 2[(W_1 + I1 W_2) B − W_2 B² + I3 W_3 I], which is
//! J σ of eq 18 for W_1 = c1/2, W_2 = c2/2 and 2 I3 W_3 = −(c1 I3^(1/3) + 2 c2 I3^(2/3)
//! − λ ln I3), so that
//!
//! W = c1/2 (I1 − 3) + c2/2 (I2 − 3) − 3c1/2 (I3^(1/3) − 1) − 3c2/2 (I3^(2/3) − 1)
//!     + λ/4 (ln I3)²,
//!
//! with I2 = ½(I1² − tr B²) and W(I) = 0: the Mooney–Rivlin energy in the invariants of B
//! (not the isochoric ones) with a volumetric part that makes the reference state free of
//! stress. The paper cites Kachanov for it. Linearised at F = I it is isotropic linear
//! elasticity with μ = c1 + c2 and Lamé λ_L = 2λ − ⅔(c1 + c2), so the bulk modulus is
//! K = λ_L + ⅔μ = 2λ. In 2D it is plane strain (F_zz = 1, B_zz = 1).
//!
//! Everything is written in b = B − I and expm1 of the logarithms, so that the terms of
//! order zero cancel analytically (the shaders do the same in f32, `mechanics.wgsl`):
//! J σ = c1 (b − (I3^(1/3) − 1) I) + c2 (b + tr b I + tr b b − b² − 2 (I3^(2/3) − 1) I)
//! + λ ln I3 I.

use crate::core::tensor::Dim;

/// The constants of eq 18 [Pa].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MooneyRivlin {
    pub c1: f64,
    pub c2: f64,
    /// λ of eq 18: half the bulk modulus, not Lamé's λ.
    pub lambda: f64,
}

impl MooneyRivlin {
    /// The shear modulus μ = c1 + c2 and Lamé's λ_L = 2λ − ⅔(c1 + c2) of the model
    /// linearised at F = I.
    pub fn lame(&self) -> (f64, f64) {
        let mu = self.c1 + self.c2;
        (mu, 2.0 * self.lambda - 2.0 / 3.0 * mu)
    }

    /// The Kirchhoff stress τ = J σ of eq 18 at a D tensor F, and in 2D its out-of-plane
    /// component τ_zz (plane strain: b_zz = 0, so τ_zz is the multiple of I alone).
    pub fn kirchhoff<D: Dim>(&self, f: D::T) -> (D::T, f64) {
        let b = f * D::transpose(f) - D::identity();
        let tr_b = D::trace(b);
        let ln_i3 = 2.0 * D::det(f).ln();
        // I3^(1/3) − 1 and I3^(2/3) − 1.
        let (e1, e2) = ((ln_i3 / 3.0).exp_m1(), (2.0 * ln_i3 / 3.0).exp_m1());
        let spherical = self.lambda * ln_i3 - self.c1 * e1 + self.c2 * (tr_b - 2.0 * e2);
        let tau =
            b * (self.c1 + self.c2 * (1.0 + tr_b)) - b * b * self.c2 + D::identity() * spherical;
        (tau, spherical)
    }

    /// First Piola–Kirchhoff stress P = τ F⁻ᵀ.
    pub fn pk1<D: Dim>(&self, f: D::T) -> D::T {
        self.kirchhoff::<D>(f).0 * D::transpose(D::inverse(f))
    }

    /// Out-of-plane Cauchy stress σ_zz = τ_zz / J of a 2D (plane-strain) F.
    pub fn sigma_zz<D: Dim>(&self, f: D::T) -> f64 {
        self.kirchhoff::<D>(f).1 / D::det(f)
    }

    /// The stored energy W(F) per reference volume (module docs), in b = B − I:
    /// I1 − 3 = tr b, I2 − 3 = 2 tr b + ½((tr b)² − b:b).
    pub fn energy<D: Dim>(&self, f: D::T) -> f64 {
        let b = f * D::transpose(f) - D::identity();
        let tr_b = D::trace(b);
        let ln_i3 = 2.0 * D::det(f).ln();
        let (e1, e2) = ((ln_i3 / 3.0).exp_m1(), (2.0 * ln_i3 / 3.0).exp_m1());
        let i2 = 2.0 * tr_b + 0.5 * (tr_b * tr_b - D::ddot(b, b));
        0.5 * self.c1 * (tr_b - 3.0 * e1)
            + 0.5 * self.c2 * (i2 - 3.0 * e2)
            + 0.25 * self.lambda * ln_i3 * ln_i3
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tensor::{D2, D3};
    use glam::{DMat2, DMat3, DVec3};

    /// The paper's rubber (seed 001 §2.3, §9.6).
    const RUBBER: MooneyRivlin = MooneyRivlin {
        c1: 1.265e5,
        c2: 1.012e4,
        lambda: 1.012e7,
    };

    fn norm3(m: DMat3) -> f64 {
        D3::ddot(m, m).sqrt()
    }

    /// Eq 18 as printed, with B, B², I1, I3 formed directly from a 3 × 3 F.
    fn printed(m: &MooneyRivlin, f: DMat3) -> DMat3 {
        let b = f * f.transpose();
        let (i1, i3) = (D3::trace(b), b.determinant());
        let iso = m.c1 * i3.powf(1.0 / 3.0) + 2.0 * m.c2 * i3.powf(2.0 / 3.0) - m.lambda * i3.ln();
        (b * (m.c1 + m.c2 * i1) - b * b * m.c2 - DMat3::IDENTITY * iso) * (1.0 / i3.sqrt())
    }

    fn sample_f() -> DMat3 {
        DMat3::from_cols_array(&[1.3, 0.2, -0.1, 0.15, 0.8, 0.05, -0.2, 0.1, 1.1])
    }

    #[test]
    fn the_stress_is_eq_18_and_vanishes_at_the_identity() {
        // The regrouped form against the printed one on a large strain: both f64, the
        // terms of eq 18 are ~λ |ln I3| ~ 1e6 Pa, so round-off leaves ~1e-9 of them.
        let f = sample_f();
        let (tau, _) = RUBBER.kirchhoff::<D3>(f);
        let sigma = tau * (1.0 / f.determinant());
        let reference = printed(&RUBBER, f);
        assert!(
            norm3(sigma - reference) < 1e-9 * norm3(reference),
            "{sigma} vs {reference}"
        );
        // σ(I) = 0 exactly: b = 0 and ln I3 = 0 make every term zero.
        assert_eq!(RUBBER.kirchhoff::<D3>(DMat3::IDENTITY).0, DMat3::ZERO);
        assert_eq!(RUBBER.kirchhoff::<D2>(DMat2::IDENTITY), (DMat2::ZERO, 0.0));
        assert_eq!(RUBBER.energy::<D3>(DMat3::IDENTITY), 0.0);
    }

    #[test]
    fn the_stress_is_objective() {
        // σ(RF) = R σ(F) Rᵀ: B(RF) = R B Rᵀ and the invariants are unchanged. Round-off of
        // a rotation and a few products: 1e-12 of |σ|.
        let f = sample_f();
        let r = DMat3::from_axis_angle(DVec3::new(1.0, -2.0, 0.5).normalize(), 1.1);
        let (rotated, _) = RUBBER.kirchhoff::<D3>(r * f);
        let (tau, _) = RUBBER.kirchhoff::<D3>(f);
        let expected = r * tau * r.transpose();
        assert!(norm3(rotated - expected) < 1e-12 * norm3(tau));
        // 2D: an in-plane rotation, and the out-of-plane stress unchanged.
        let f2 = DMat2::from_cols_array(&[1.2, 0.1, -0.3, 0.9]);
        let r2 = DMat2::from_angle(0.7);
        let (t2, zz) = RUBBER.kirchhoff::<D2>(f2);
        let (t2r, zzr) = RUBBER.kirchhoff::<D2>(r2 * f2);
        let e = t2r - r2 * t2 * r2.transpose();
        assert!(D2::ddot(e, e).sqrt() < 1e-12 * D2::ddot(t2, t2).sqrt());
        assert!((zzr - zz).abs() < 1e-12 * zz.abs());
        // A pure rotation is free of stress and energy (round-off of R Rᵀ = I, ~1e-16,
        // times λ = 1e7: 1e-8 Pa).
        assert!(norm3(RUBBER.kirchhoff::<D3>(r).0) < 1e-7);
        assert!(RUBBER.energy::<D3>(r).abs() < 1e-7);
    }

    #[test]
    fn small_strains_are_linear_elasticity_with_the_derived_constants() {
        // F = I + ε G with a fixed G of O(1): P = λ_L tr ε I + 2μ ε + O(ε²) with
        // ε = sym(F − I). The second-order terms are ~(λ + c1 + c2)·ε² against a first order
        // of (λ_L + 2μ)·ε, a relative 2ε–4ε; at ε = 1e-6 a bound of 1e-5 relative of
        // (λ_L + 2μ) ε leaves that margin, and the f64 round-off (1e-16 of b over 1e-6)
        // is far below it.
        let (mu, lambda_l) = RUBBER.lame();
        assert!((mu - 1.3662e5).abs() < 1.0);
        assert!((lambda_l - 2.0149e7).abs() < 1e3);
        let eps = 1e-6;
        let g = DMat3::from_cols_array(&[0.3, -0.5, 0.2, 0.7, -0.4, 0.1, 0.6, 0.25, 0.9]);
        let f = DMat3::IDENTITY + g * eps;
        let strain = (g + g.transpose()) * (0.5 * eps);
        let linear = DMat3::IDENTITY * (lambda_l * D3::trace(strain)) + strain * (2.0 * mu);
        let p = RUBBER.pk1::<D3>(f);
        let scale = (lambda_l + 2.0 * mu) * eps;
        assert!(norm3(p - linear) < 1e-5 * scale, "{p} vs {linear}");
        // Plane strain: σ_zz = λ_L tr ε.
        let g2 = DMat2::from_cols_array(&[0.3, -0.5, 0.7, -0.4]);
        let f2 = DMat2::IDENTITY + g2 * eps;
        let tr = D2::trace(g2) * eps;
        assert!((RUBBER.sigma_zz::<D2>(f2) - lambda_l * tr).abs() < 1e-5 * scale);
    }

    #[test]
    fn pk1_is_the_derivative_of_the_energy() {
        // Central differences of W with step δ = 1e-6 on O(0.3) strains: truncation
        // ~δ² W''' ~ 1e-12 λ, round-off ~1e-16 W/δ ~ 1e-10 λ·|ln I3|²; a bound of 1e-7 λ.
        check_derivative::<D3>(sample_f());
        check_derivative::<D2>(DMat2::from_cols_array(&[1.25, 0.1, -0.2, 0.85]));
    }

    fn check_derivative<D: Dim>(f: D::T) {
        let p = RUBBER.pk1::<D>(f);
        let delta = 1e-6;
        for k in 0..D::N {
            for l in 0..D::N {
                let mut e = [0.0; 3];
                e[k] = delta;
                let mut n = [0.0; 3];
                n[l] = 1.0;
                let df = D::outer(D::from_slice(&e), D::from_slice(&n));
                let fd = (RUBBER.energy::<D>(f + df) - RUBBER.energy::<D>(f - df)) / (2.0 * delta);
                assert!(
                    (fd - D::entry(p, k, l)).abs() < 1e-7 * RUBBER.lambda,
                    "{}D P_{k}{l}: {fd} vs {}",
                    D::N,
                    D::entry(p, k, l)
                );
            }
        }
    }

    #[test]
    fn plane_strain_is_the_3d_model_with_f_zz_one() {
        // The 2D F embedded with F_zz = 1 in 3D gives the same in-plane τ, τ_zz and W
        // (1e-12 relative: the same operations in another order).
        let f2 = DMat2::from_cols_array(&[1.25, 0.1, -0.2, 0.85]);
        let f3 = DMat3::from_cols(f2.x_axis.extend(0.0), f2.y_axis.extend(0.0), DVec3::Z);
        let (t2, zz) = RUBBER.kirchhoff::<D2>(f2);
        let (t3, _) = RUBBER.kirchhoff::<D3>(f3);
        for k in 0..2 {
            for l in 0..2 {
                assert!((D2::entry(t2, k, l) - t3.col(l)[k]).abs() < 1e-12 * norm3(t3));
            }
        }
        assert!((zz - t3.col(2).z).abs() < 1e-12 * norm3(t3));
        let (w2, w3) = (RUBBER.energy::<D2>(f2), RUBBER.energy::<D3>(f3));
        assert!((w2 - w3).abs() < 1e-12 * w3.abs());
    }
}
