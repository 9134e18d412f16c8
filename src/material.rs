//! Constitutive models: hypoelastic (Jaumann rate + linear EOS), Saint Venant–Kirchhoff
//! and compressible neo-Hookean. In 2D every model is plane strain (F_zz = 1, ε̇_zz = 0).

use crate::scene::MaterialSpec;
use crate::tensor::Dim;
use serde::{Deserialize, Serialize};

/// Constitutive model, as named in case files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MaterialModel {
    /// Rate form (seed 000 §2.2): Ṡ = 2G(ε̇ − ⅓ tr ε̇ I) − Sω + ωS, p = c0²(ρ − ρ0), σ = S − pI.
    Hypoelastic,
    /// S = λ tr(E) I + 2μ E with E = ½(FᵀF − I); P = F S.
    SaintVenantKirchhoff,
    /// P = μ(F − F⁻ᵀ) + λ ln J F⁻ᵀ.
    NeoHookean,
}

impl MaterialModel {
    pub const ALL: [MaterialModel; 3] = [
        Self::Hypoelastic,
        Self::SaintVenantKirchhoff,
        Self::NeoHookean,
    ];

    /// Rate-based models integrate ρ and S; state-based ones evaluate P(F).
    pub fn is_rate_based(self) -> bool {
        self == Self::Hypoelastic
    }
}

/// Isotropic elastic constants derived from (ρ0, E, ν).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub model: MaterialModel,
    pub rho0: f64,
    /// Shear modulus G = μ.
    pub mu: f64,
    /// Lamé λ.
    pub lambda: f64,
    /// Bulk modulus K = λ + 2μ/3.
    pub bulk: f64,
}

impl Material {
    pub fn new(spec: &MaterialSpec) -> Self {
        let (e, nu) = (spec.youngs_modulus, spec.poisson_ratio);
        let mu = e / (2.0 * (1.0 + nu));
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        Self {
            model: spec.model,
            rho0: spec.density,
            mu,
            lambda,
            bulk: lambda + 2.0 * mu / 3.0,
        }
    }

    /// Longitudinal (p-wave) speed of the linearised model, sqrt((λ + 2μ)/ρ0).
    pub fn p_wave_speed(&self) -> f64 {
        ((self.lambda + 2.0 * self.mu) / self.rho0).sqrt()
    }

    /// Pressure of the linear EOS, positive in compression (seed 000 erratum to eq 77).
    pub fn pressure(&self, rho: f64) -> f64 {
        self.bulk / self.rho0 * (rho - self.rho0)
    }

    /// Jaumann deviatoric stress rate Ṡ from the velocity gradient L (eqs 89–92).
    pub fn jaumann_rate<D: Dim>(&self, s: D::T, l: D::T) -> D::T {
        let lt = D::transpose(l);
        let eps_dot = (l + lt) * 0.5;
        let omega = (l - lt) * 0.5;
        let dev = eps_dot - D::identity() * (D::trace(eps_dot) / 3.0);
        dev * (2.0 * self.mu) - s * omega + omega * s
    }

    /// First Piola–Kirchhoff stress P(F) of a state-based model.
    pub fn pk1<D: Dim>(&self, f: D::T) -> D::T {
        match self.model {
            MaterialModel::SaintVenantKirchhoff => {
                let e = (D::transpose(f) * f - D::identity()) * 0.5;
                f * (D::identity() * (self.lambda * D::trace(e)) + e * (2.0 * self.mu))
            }
            MaterialModel::NeoHookean => {
                let f_inv_t = D::transpose(D::inverse(f));
                (f - f_inv_t) * self.mu + f_inv_t * (self.lambda * D::det(f).ln())
            }
            MaterialModel::Hypoelastic => unreachable!("the hypoelastic model is rate-based"),
        }
    }

    /// Strain-energy density per reference volume. For the hypoelastic model this is the
    /// complementary energy of the linearised model, S:S/(4G) + p²/(2K).
    pub fn energy_density<D: Dim>(&self, f: D::T, s: D::T, rho: f64) -> f64 {
        match self.model {
            MaterialModel::Hypoelastic => {
                let p = self.pressure(rho);
                let szz = plane_strain_szz::<D>(s);
                (D::ddot(s, s) + szz * szz) / (4.0 * self.mu) + p * p / (2.0 * self.bulk)
            }
            MaterialModel::SaintVenantKirchhoff => {
                let e = (D::transpose(f) * f - D::identity()) * 0.5;
                0.5 * self.lambda * D::trace(e).powi(2) + self.mu * D::ddot(e, e)
            }
            MaterialModel::NeoHookean => {
                // With F_zz = 1 in plane strain, tr C − 3 = tr₂C − 2: one formula for both.
                let c = D::transpose(f) * f;
                let ln_j = D::det(f).ln();
                0.5 * self.mu * (D::trace(c) - D::N as f64) - self.mu * ln_j
                    + 0.5 * self.lambda * ln_j * ln_j
            }
        }
    }

    /// Out-of-plane Cauchy stress σ_zz of a 2D (plane-strain) particle; zero in 3D, where
    /// σ carries all components.
    pub fn sigma_zz<D: Dim>(&self, f: D::T, s: D::T, rho: f64) -> f64 {
        if D::N == 3 {
            return 0.0;
        }
        let j = D::det(f);
        match self.model {
            MaterialModel::Hypoelastic => plane_strain_szz::<D>(s) - self.pressure(rho),
            MaterialModel::SaintVenantKirchhoff => {
                let e = (D::transpose(f) * f - D::identity()) * 0.5;
                self.lambda * D::trace(e) / j
            }
            MaterialModel::NeoHookean => self.lambda * j.ln() / j,
        }
    }
}

/// S_zz of a traceless 3D deviator whose in-plane part is `s` (2D only).
fn plane_strain_szz<D: Dim>(s: D::T) -> f64 {
    if D::N == 2 { -D::trace(s) } else { 0.0 }
}

/// Von Mises equivalent stress of a 3×3 Cauchy stress, sqrt(3/2 s:s).
pub fn von_mises(sigma: &[[f64; 3]; 3]) -> f64 {
    let mean = (sigma[0][0] + sigma[1][1] + sigma[2][2]) / 3.0;
    let mut s2 = 0.0;
    for (k, row) in sigma.iter().enumerate() {
        for (l, &v) in row.iter().enumerate() {
            let d = if k == l { v - mean } else { v };
            s2 += d * d;
        }
    }
    (1.5 * s2).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tensor::{D2, D3};
    use glam::{DMat2, DMat3, DVec3};

    fn spec(model: MaterialModel) -> MaterialSpec {
        MaterialSpec {
            model,
            density: 1.0,
            youngs_modulus: 1e7,
            poisson_ratio: 0.4,
        }
    }

    #[test]
    fn constants_match_the_seed_table() {
        let m = Material::new(&spec(MaterialModel::Hypoelastic));
        // Seed 000 §0: G = 3.5714e6, K = 1.6667e7, λ = 1.4286e7, c_p = 4629.1 m/s.
        assert!((m.mu - 3.5714e6).abs() < 1e2);
        assert!((m.bulk - 1.6667e7).abs() < 1e3);
        assert!((m.lambda - 1.4286e7).abs() < 1e3);
        assert!((m.p_wave_speed() - 4629.1).abs() < 0.1);
    }

    #[test]
    fn compression_gives_positive_pressure() {
        let m = Material::new(&spec(MaterialModel::Hypoelastic));
        assert!(m.pressure(1.01) > 0.0 && m.pressure(0.99) < 0.0);
    }

    #[test]
    fn state_models_are_stress_free_under_rotation_and_agree_in_small_strain() {
        let q3 = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 2.0).normalize(), 0.7);
        for model in [
            MaterialModel::SaintVenantKirchhoff,
            MaterialModel::NeoHookean,
        ] {
            let m = Material::new(&spec(model));
            let p = m.pk1::<D3>(q3);
            assert!(D3::ddot(p, p).sqrt() < 1e-8 * m.mu, "{model:?}");
            assert!(m.energy_density::<D3>(q3, DMat3::ZERO, 1.0).abs() < 1e-8 * m.mu);
            // Small uniaxial strain ε: P_xx ≈ (λ + 2μ) ε, P_yy ≈ λ ε (plane strain) to O(ε²).
            let eps = 1e-6;
            let f = DMat2::from_cols_array(&[1.0 + eps, 0.0, 0.0, 1.0]);
            let p = m.pk1::<D2>(f);
            assert!((D2::entry(p, 0, 0) / eps - (m.lambda + 2.0 * m.mu)).abs() < 1e-4 * m.mu);
            assert!((D2::entry(p, 1, 1) / eps - m.lambda).abs() < 1e-4 * m.mu);
            assert!((m.sigma_zz::<D2>(f, DMat2::ZERO, 1.0) / eps - m.lambda).abs() < 1e-4 * m.mu);
        }
    }

    #[test]
    fn pk1_is_the_derivative_of_the_energy() {
        // Central differences of ψ(F) with step 1e-7 on O(1) strains: error ~1e-6 relative.
        let f0 = DMat3::from_cols_array(&[1.2, 0.1, -0.05, 0.2, 0.9, 0.1, 0.0, -0.1, 1.1]);
        for model in [
            MaterialModel::SaintVenantKirchhoff,
            MaterialModel::NeoHookean,
        ] {
            let m = Material::new(&spec(model));
            let p = m.pk1::<D3>(f0);
            for k in 0..3 {
                for l in 0..3 {
                    let mut d = [0.0; 9];
                    d[l * 3 + k] = 1e-7;
                    let df = DMat3::from_cols_array(&d);
                    let fd = (m.energy_density::<D3>(f0 + df, DMat3::ZERO, 1.0)
                        - m.energy_density::<D3>(f0 - df, DMat3::ZERO, 1.0))
                        / 2e-7;
                    assert!(
                        (fd - D3::entry(p, k, l)).abs() < 1e-5 * m.mu,
                        "{model:?} P_{k}{l}"
                    );
                }
            }
        }
    }

    #[test]
    fn von_mises_of_uniaxial_stress_is_its_magnitude() {
        assert!(
            (von_mises(&[[-3.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]) - 3.0).abs() < 1e-12
        );
        assert!(von_mises(&[[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]).abs() < 1e-12);
    }
}
