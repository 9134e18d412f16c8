//! Constitutive models: hypoelastic (an objective rate + linear EOS), Saint Venant–Kirchhoff,
//! compressible neo-Hookean, linear elastic, polyconvex nearly incompressible
//! neo-Hookean, the compressible Mooney–Rivlin rubber of seed 001 eq 18
//! ([`crate::physics::mooney_rivlin`]) and von Mises hyperelastic-plastic ([`crate::physics::plasticity`]).
//! In 2D every model is plane strain (F_zz = 1, ε̇_zz = 0) unless the case asks for plane
//! stress (σ_zz = 0), which the models that are linear in their strain measure take
//! exactly through λ* = 2λμ/(λ + 2μ) in place of λ. The models are described in
//! docs/materials.md.

mod objective;
mod spec;

pub use objective::rotation_spin;
pub use spec::{MaterialSpec, ObjectiveRate, Plane};

use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::physics::mooney_rivlin::MooneyRivlin;
use crate::physics::plasticity::{Hardening, Returned, VonMises, from_mat3, to_mat3};
use glam::DMat3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Constitutive model, as named in case files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MaterialModel {
    /// Rate form (seed 000 §2.2): S̊ = 2G(ε̇ − ⅓ tr ε̇ I) with the objective rate S̊ of
    /// [`ObjectiveRate`] (Jaumann: Ṡ = 2G(ε̇ − ⅓ tr ε̇ I) − Sω + ωS), p = c0²(ρ − ρ0),
    /// σ = S − pI.
    Hypoelastic,
    /// S = λ tr(E) I + 2μ E with E = ½(FᵀF − I); P = F S.
    SaintVenantKirchhoff,
    /// P = μ(F − F⁻ᵀ) + λ ln J F⁻ᵀ.
    NeoHookean,
    /// Small-strain linear elasticity, P = λ tr(ε) I + 2μ ε with ε = sym(F − I): the model
    /// the analytic swinging plate/cube solves.
    LinearElastic,
    /// Polyconvex nearly incompressible neo-Hookean in {F, H, J} (seed 003 via Lee et al.
    /// 2016 eqs 11–12): ψ = μ/2 J^(−2/3) F:F − 3μ/2 + κ/2 (J − 1)²,
    /// P = μ J^(−2/3) F + [κ(J − 1) − μ/3 J^(−5/3) F:F] H.
    NearlyIncompressibleNeoHookean,
    /// Von Mises hyperelastic-plastic with linear isotropic hardening (seed 003 Algorithm
    /// 2, [`crate::physics::plasticity`]): Hencky elasticity, radial return. Its stress depends on
    /// the history C_p⁻¹, ε_p, which the mixed methods carry; as a function of F alone
    /// (`pk1`) it is the response from the virgin state.
    VonMisesPlastic,
    /// The compressible Mooney–Rivlin rubber of seed 001 eq 18 with the constants c1, c2,
    /// λ ([`crate::physics::mooney_rivlin`]): hyperelastic, μ = c1 + c2, λ_L = 2λ − ⅔(c1 + c2).
    MooneyRivlin,
}

impl MaterialModel {
    pub const ALL: [MaterialModel; 7] = [
        Self::Hypoelastic,
        Self::SaintVenantKirchhoff,
        Self::NeoHookean,
        Self::LinearElastic,
        Self::NearlyIncompressibleNeoHookean,
        Self::VonMisesPlastic,
        Self::MooneyRivlin,
    ];

    /// Rate-based models integrate ρ and S; state-based ones evaluate P(F).
    pub fn is_rate_based(self) -> bool {
        self == Self::Hypoelastic
    }

    /// Whether P reads the area map H and the volume map J of the mixed formulations
    /// (seed 003 eq 1) beside F: only the polyconvex model does.
    pub fn reads_h_and_j(self) -> bool {
        self == Self::NearlyIncompressibleNeoHookean
    }

    /// The models `which` selects as case files name them, quoted and joined ("`a`, `b`
    /// or `c`"), for messages.
    pub fn names_where(which: impl Fn(Self) -> bool) -> String {
        let names: Vec<String> = Self::ALL
            .iter()
            .filter(|&&m| which(m))
            .map(|m| format!("`{}`", crate::core::check::toml_name(m)))
            .collect();
        match names.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            _ => names.concat(),
        }
    }

    /// Whether the model takes its elastic constants from c1, c2 and λ (eq 18) rather
    /// than from E and ν.
    pub fn reads_mooney_rivlin_constants(self) -> bool {
        self == Self::MooneyRivlin
    }

    /// The models whose plane-stress response is their plane-strain one with λ*: those
    /// linear in their strain measure (E, ε, or the rate ε̇).
    pub const PLANE_STRESS: [MaterialModel; 3] = [
        Self::Hypoelastic,
        Self::SaintVenantKirchhoff,
        Self::LinearElastic,
    ];
}

/// Isotropic elastic constants derived from (ρ0, E, ν), or from (c1, c2, λ) of the
/// Mooney–Rivlin model, whose μ and λ are those of its linearisation at F = I.
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
    /// Yield stress and hardening of `von-mises-plastic`.
    pub hardening: Option<Hardening>,
    /// The constants of `mooney-rivlin`.
    pub mooney_rivlin: Option<MooneyRivlin>,
    /// σ_zz = 0 in 2D (λ and K are then the plane-stress λ* and λ* + 2μ/3).
    pub plane_stress: bool,
    /// The objective rate of the rate model.
    pub objective_rate: ObjectiveRate,
}

impl Material {
    pub fn new(spec: &MaterialSpec) -> Self {
        let mooney_rivlin = spec.mooney_rivlin();
        let (mu, lambda_3d) = match mooney_rivlin {
            Some(m) => m.lame(),
            None => {
                let (e, nu) = spec.youngs_and_poisson();
                (
                    e / (2.0 * (1.0 + nu)),
                    e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
                )
            }
        };
        let plane_stress = spec.plane == Plane::Stress;
        // σ_zz = 0 eliminates ε_zz = −λ tr ε/(λ + 2μ) from the in-plane response, whose
        // λ becomes λ* = 2λμ/(λ + 2μ) = Eν/(1 − ν²).
        let lambda = if plane_stress {
            2.0 * lambda_3d * mu / (lambda_3d + 2.0 * mu)
        } else {
            lambda_3d
        };
        Self {
            plane_stress,
            model: spec.model,
            rho0: spec.density,
            mu,
            lambda,
            bulk: lambda + 2.0 * mu / 3.0,
            hardening: spec.hardening(),
            mooney_rivlin,
            objective_rate: spec.objective_rate.unwrap_or_default(),
        }
    }

    /// The constants of a `mooney-rivlin` material.
    fn rubber(&self) -> &MooneyRivlin {
        self.mooney_rivlin
            .as_ref()
            .expect("validation gives a mooney-rivlin material its c1, c2 and λ")
    }

    /// The von Mises model of a `von-mises-plastic` material.
    pub fn von_mises(&self) -> Option<VonMises> {
        let hyperelastic = self.model == MaterialModel::VonMisesPlastic;
        self.hardening
            .filter(|_| hyperelastic)
            .map(|hardening| VonMises {
                mu: self.mu,
                bulk: self.bulk,
                hardening,
            })
    }

    /// Algorithm 2 from the virgin state (C_p⁻¹ = I, ε_p = 0) at a D tensor F.
    fn virgin<D: Dim>(&self, f: D::T) -> Returned {
        let model = self
            .von_mises()
            .expect("validation gives a von-mises-plastic material its hardening");
        model.return_map(to_mat3::<D>(f, 1.0), DMat3::IDENTITY, 0.0, 0.0, 0.0)
    }

    /// Longitudinal (p-wave) speed of the linearised model, sqrt((λ + 2μ)/ρ0).
    pub fn p_wave_speed(&self) -> f64 {
        ((self.lambda + 2.0 * self.mu) / self.rho0).sqrt()
    }

    /// Shear (s-wave) speed sqrt(μ/ρ0).
    pub fn s_wave_speed(&self) -> f64 {
        (self.mu / self.rho0).sqrt()
    }

    /// The rate model's state and laws, for `--explain`: "<rate> rate + linear EOS".
    pub fn rate_model(&self) -> String {
        format!("{} rate + linear EOS", self.objective_rate.describe())
    }

    /// Pressure of the linear EOS, positive in compression (seed 000 erratum to eq 77).
    pub fn pressure(&self, rho: f64) -> f64 {
        self.bulk / self.rho0 * (rho - self.rho0)
    }

    /// The deviatoric stress rate Ṡ of the rate model from the velocity gradient L at a
    /// point with deformation gradient F: its objective rate S̊ equated to 2μ dev D
    /// (eq 91; Jaumann: eq 92).
    pub fn stress_rate<D: Dim>(&self, s: D::T, l: D::T, f: D::T) -> D::T {
        let lt = D::transpose(l);
        let d = (l + lt) * 0.5;
        let tr_d = D::trace(d);
        let elastic = (d - D::identity() * (tr_d / 3.0)) * (2.0 * self.mu);
        let corotational = |omega: D::T| elastic - s * omega + omega * s;
        match self.objective_rate {
            ObjectiveRate::Jaumann => corotational((l - lt) * 0.5),
            ObjectiveRate::GreenNaghdi => corotational(rotation_spin::<D>(f, l)),
            ObjectiveRate::Truesdell => elastic + l * s + s * lt - s * tr_d,
        }
    }

    /// The yield stress and hardening of a rate model given a `yield_stress`, whose
    /// deviatoric stress each step's end returns to the von Mises surface
    /// ([`Self::radial_return`]); None for an elastic rate model and the state models.
    pub fn rate_plasticity(&self) -> Option<Hardening> {
        self.hardening.filter(|_| self.model.is_rate_based())
    }

    /// The radial return of a rate model's deviatoric stress S at equivalent plastic
    /// strain ε_p (Wilkins 1964; the "very simple plasticity" of Gray, Monaghan and Swift
    /// 2001 that seed 000 App. 9.1 re-creates): with q = sqrt(3/2 S:S) (S_zz of plane
    /// strain included) beyond τ_y(ε_p) = τ_y⁰ + H ε_p, Δε_p = (q − τ_y)/(3μ + H) and S is
    /// scaled by 1 − 3μΔε_p/q, onto the yield surface τ_y(ε_p + Δε_p). Returns the new S
    /// and Δε_p; None inside the surface or for an elastic material. At H = 0 the scale
    /// is τ_y⁰/q, the reference code's sqrt(τ_y²/(3 J2)).
    pub fn radial_return<D: Dim>(&self, s: D::T, rho: f64, eps_p: f64) -> Option<(D::T, f64)> {
        let hardening = self.rate_plasticity()?;
        let szz = self.plane_strain_szz::<D>(s, rho);
        let q = (1.5 * (D::ddot(s, s) + szz * szz)).sqrt();
        if q <= hardening.flow_stress(eps_p, 0.0, 0.0) {
            return None;
        }
        let d_eps = hardening.multiplier(self.mu, q, eps_p, 0.0, 0.0);
        Some((s * (1.0 - 3.0 * self.mu * d_eps / q), d_eps))
    }

    /// S_zz of a 2D plane-strain rate model, which the in-plane S does not carry: −tr S
    /// under a corotational rate, which keeps S traceless; under Truesdell's, Ṡ_zz =
    /// −tr D (2μ/3 + S_zz) with tr D = −ρ̇/ρ integrates to (2μ/3)(ρ/ρ0 − 1). Zero in 3D.
    fn plane_strain_szz<D: Dim>(&self, s: D::T, rho: f64) -> f64 {
        match (D::N, self.objective_rate) {
            (2, ObjectiveRate::Truesdell) => 2.0 * self.mu / 3.0 * (rho / self.rho0 - 1.0),
            (2, _) => -D::trace(s),
            _ => 0.0,
        }
    }

    /// The rate model at a point with deformation gradient F, its rate Ḟ, density ρ and
    /// deviatoric stress S (seed 000 Algorithms 3 and 6, step 3): L = Ḟ F⁻¹, ρ̇ = −ρ tr L,
    /// Ṡ of the objective rate, and P = J σ F⁻ᵀ with σ = S − p(ρ) I.
    pub fn rate_response<D: Dim>(
        &self,
        f: D::T,
        f_dot: D::T,
        rho: f64,
        s: D::T,
    ) -> RateResponse<D> {
        let f_inv = D::inverse(f);
        let l = f_dot * f_inv;
        let f_inv_t = D::transpose(f_inv);
        let sigma = s - D::identity() * self.pressure(rho);
        RateResponse {
            pk1: sigma * f_inv_t * D::det(f),
            f_inv_t,
            rho_dot: -rho * D::trace(l),
            s_dot: self.stress_rate::<D>(s, l, f),
        }
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
            MaterialModel::LinearElastic => {
                let eps = small_strain::<D>(f);
                D::identity() * (self.lambda * D::trace(eps)) + eps * (2.0 * self.mu)
            }
            MaterialModel::NearlyIncompressibleNeoHookean => {
                self.pk1_mixed::<D>(f, D::cof(f), D::det(f))
            }
            MaterialModel::VonMisesPlastic => from_mat3::<D>(self.virgin::<D>(f).p),
            MaterialModel::MooneyRivlin => self.rubber().pk1::<D>(f),
            MaterialModel::Hypoelastic => unreachable!("the hypoelastic model is rate-based"),
        }
    }

    /// P(F, H, J) of the mixed formulations, where H and J may be evolved independently
    /// of F (seed 003 eq 1). Only the polyconvex model reads H and J; the others are
    /// functions of F alone.
    pub fn pk1_mixed<D: Dim>(&self, f: D::T, h: D::T, j: f64) -> D::T {
        if !self.model.reads_h_and_j() {
            return self.pk1::<D>(f);
        }
        self.pk1_with_pressure::<D>(f, h, j, self.bulk * (j - 1.0))
    }

    /// P(F, H, J) of the polyconvex nearly incompressible neo-Hookean model with the
    /// pressure p given, for the pressure p = κ(J − 1) or the evolved pressure of
    /// artificial compressibility (seed 003 eq 42): μJ^{-2/3}F + [p − (μ/3)J^{-5/3}(F:F)]H.
    pub fn pk1_with_pressure<D: Dim>(&self, f: D::T, h: D::T, j: f64, p: f64) -> D::T {
        let ff = full_ddot::<D>(f);
        let j23 = j.powf(-2.0 / 3.0);
        f * (self.mu * j23) + h * (p - self.mu / 3.0 * j23 / j * ff)
    }

    /// The isochoric strain-energy density ½μ(J^{-2/3} F:F − 3) of the polyconvex model.
    pub fn isochoric_energy_density<D: Dim>(&self, f: D::T, j: f64) -> f64 {
        0.5 * self.mu * (j.powf(-2.0 / 3.0) * full_ddot::<D>(f) - 3.0)
    }

    /// σ_zz of the polyconvex model in plane strain with the pressure p: P_zz F_zz / J
    /// with F_zz = 1 and H_zz = J; zero in 3D.
    pub fn sigma_zz_with_pressure<D: Dim>(&self, f: D::T, p: f64) -> f64 {
        if D::N == 3 {
            return 0.0;
        }
        let j = D::det(f);
        let j23 = j.powf(-2.0 / 3.0);
        (self.mu * j23 + j * (p - self.mu / 3.0 * j23 / j * full_ddot::<D>(f))) / j
    }

    /// Strain-energy density ψ(F, J) of the mixed formulations (J evolved or det F).
    pub fn energy_density_mixed<D: Dim>(&self, f: D::T, j: f64) -> f64 {
        if self.model != MaterialModel::NearlyIncompressibleNeoHookean {
            return self.energy_density::<D>(f, D::zero_t(), self.rho0);
        }
        self.isochoric_energy_density::<D>(f, j) + 0.5 * self.bulk * (j - 1.0).powi(2)
    }

    /// π = ∂ψ/∂J of [`Self::energy_density_mixed`] at F and J: −(μ/3)J^{-5/3}(F:F) +
    /// κ(J − 1) for the polyconvex model (the coefficient of H in its P, seed 003 eq 1);
    /// zero for the others, whose ψ does not read J.
    pub fn energy_density_mixed_dj<D: Dim>(&self, f: D::T, j: f64) -> f64 {
        if self.model != MaterialModel::NearlyIncompressibleNeoHookean {
            return 0.0;
        }
        -self.mu / 3.0 * j.powf(-5.0 / 3.0) * full_ddot::<D>(f) + self.bulk * (j - 1.0)
    }

    /// Strain-energy density per reference volume. For the hypoelastic model this is the
    /// complementary energy of the linearised model, S:S/(4G) + p²/(2K).
    pub fn energy_density<D: Dim>(&self, f: D::T, s: D::T, rho: f64) -> f64 {
        match self.model {
            MaterialModel::Hypoelastic => {
                let p = self.pressure(rho);
                let szz = self.plane_strain_szz::<D>(s, rho);
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
            MaterialModel::LinearElastic => {
                let eps = small_strain::<D>(f);
                0.5 * self.lambda * D::trace(eps).powi(2) + self.mu * D::ddot(eps, eps)
            }
            MaterialModel::NearlyIncompressibleNeoHookean => {
                self.energy_density_mixed::<D>(f, D::det(f))
            }
            MaterialModel::VonMisesPlastic => self.virgin::<D>(f).psi,
            MaterialModel::MooneyRivlin => self.rubber().energy::<D>(f),
        }
    }

    /// Out-of-plane Cauchy stress σ_zz of a 2D (plane-strain) particle; zero in 3D, where
    /// σ carries all components.
    pub fn sigma_zz<D: Dim>(&self, f: D::T, s: D::T, rho: f64) -> f64 {
        if D::N == 3 || self.plane_stress {
            return 0.0;
        }
        let j = D::det(f);
        match self.model {
            MaterialModel::Hypoelastic => self.plane_strain_szz::<D>(s, rho) - self.pressure(rho),
            MaterialModel::SaintVenantKirchhoff => {
                let e = (D::transpose(f) * f - D::identity()) * 0.5;
                self.lambda * D::trace(e) / j
            }
            MaterialModel::NeoHookean => self.lambda * j.ln() / j,
            MaterialModel::LinearElastic => self.lambda * D::trace(small_strain::<D>(f)),
            MaterialModel::NearlyIncompressibleNeoHookean => {
                self.sigma_zz_with_pressure::<D>(f, self.bulk * (j - 1.0))
            }
            MaterialModel::VonMisesPlastic => {
                let f3 = to_mat3::<D>(f, 1.0);
                (self.virgin::<D>(f).p * f3.transpose()).col(2).z / j
            }
            MaterialModel::MooneyRivlin => self.rubber().sigma_zz::<D>(f),
        }
    }
}

/// The first elasticity tensor 𝔸 = ∂P/∂F as a 9×9 matrix on F flattened row-major
/// (F_aB at 3a + B, seed 004 eq 32): the tangent of the implicit path. In 2D (plane
/// strain, F_zz = 1) the entries of in-plane components are the 2D tangent.
pub type Tangent = [[f64; 9]; 9];

impl MaterialModel {
    /// Whether [`Material::tangent`] has the model's tangent 𝔸 = ∂P/∂F.
    pub fn has_tangent(self) -> bool {
        matches!(
            self,
            Self::SaintVenantKirchhoff
                | Self::NeoHookean
                | Self::LinearElastic
                | Self::NearlyIncompressibleNeoHookean
        )
    }
}

impl Material {
    /// 𝔸 = ∂P/∂F of a model with [`MaterialModel::has_tangent`] (seed 004 §5 with the
    /// corrections of its note §3: the linear-elastic matrix of eq 45 rebuilt from
    /// 𝔸_aBbC = λ δ_aB δ_bC + μ(δ_ab δ_BC + δ_aC δ_Bb), and the compressible neo-Hookean
    /// eq 52 with its missing (−μ/J) J_FF term).
    pub fn tangent<D: Dim>(&self, f: D::T) -> Tangent {
        let f = plane_strain_f::<D>(f);
        let fl: [f64; 9] = std::array::from_fn(|k| f[k / 3][k % 3]);
        let (mu, lambda) = (self.mu, self.lambda);
        let delta = |i: usize, j: usize| if i == j { 1.0 } else { 0.0 };
        let j = det3(&f);
        let j_f = cofactor3(&f);
        let j_ff = cofactor_derivative3(&f);
        let outer = |a: &[f64; 9], b: &[f64; 9]| -> Tangent {
            std::array::from_fn(|r| std::array::from_fn(|c| a[r] * b[c]))
        };
        let mut out = [[0.0; 9]; 9];
        let mut add = |m: &Tangent, s: f64| {
            for (o, r) in out.iter_mut().zip(m) {
                for (o, v) in o.iter_mut().zip(r) {
                    *o += s * v;
                }
            }
        };
        let identity: Tangent = std::array::from_fn(|r| std::array::from_fn(|c| delta(r, c)));
        match self.model {
            MaterialModel::LinearElastic => {
                let a: Tangent = std::array::from_fn(|r| {
                    std::array::from_fn(|c| {
                        let (a, bb, b, cc) = (r / 3, r % 3, c / 3, c % 3);
                        lambda * delta(a, bb) * delta(b, cc)
                            + mu * (delta(a, b) * delta(bb, cc) + delta(a, cc) * delta(bb, b))
                    })
                });
                add(&a, 1.0);
            }
            MaterialModel::NeoHookean => {
                // Eq 52 corrected: μ I + ((λ ln J − μ)/J) J_FF + ((λ − λ ln J + μ)/J²) J_F ⊗ J_F.
                let ln_j = j.ln();
                add(&identity, mu);
                add(&j_ff, (lambda * ln_j - mu) / j);
                add(&outer(&j_f, &j_f), (lambda - lambda * ln_j + mu) / (j * j));
            }
            MaterialModel::NearlyIncompressibleNeoHookean => {
                // Eq 48 with κ the bulk modulus.
                let ff: f64 = fl.iter().map(|v| v * v).sum();
                let kappa = self.bulk;
                let j53 = j.powf(5.0 / 3.0);
                add(&identity, mu * j.powf(-2.0 / 3.0));
                add(&outer(&fl, &j_f), -2.0 * mu / (3.0 * j53));
                add(&outer(&j_f, &fl), -2.0 * mu / (3.0 * j53));
                add(
                    &outer(&j_f, &j_f),
                    kappa + 5.0 * mu * ff / (9.0 * j.powf(8.0 / 3.0)),
                );
                add(&j_ff, kappa * (j - 1.0) - mu * ff / (3.0 * j53));
            }
            MaterialModel::SaintVenantKirchhoff => {
                // 𝔸_aBbC = δ_ab S_BC + F_aA ℂ_ABCD F_bD, ℂ = λ I⊗I + 2μ 𝕀ˢʸᵐ.
                let e: [[f64; 3]; 3] = std::array::from_fn(|a| {
                    std::array::from_fn(|b| {
                        0.5 * ((0..3).map(|k| f[k][a] * f[k][b]).sum::<f64>() - delta(a, b))
                    })
                });
                let tr = e[0][0] + e[1][1] + e[2][2];
                let s = |a: usize, b: usize| lambda * tr * delta(a, b) + 2.0 * mu * e[a][b];
                let a: Tangent = std::array::from_fn(|r| {
                    std::array::from_fn(|c| {
                        let (a, bb, b, cc) = (r / 3, r % 3, c / 3, c % 3);
                        // F_aA ℂ_ABCD F_bD = λ F_aB F_bC + μ (F_aC F_bB + (F Fᵀ)_ab δ_BC).
                        let ftf = (0..3).map(|k| f[a][k] * f[b][k]).sum::<f64>();
                        delta(a, b) * s(bb, cc)
                            + lambda * f[a][bb] * f[b][cc]
                            + mu * (f[a][cc] * f[b][bb] + ftf * delta(bb, cc))
                    })
                });
                add(&a, 1.0);
            }
            MaterialModel::Hypoelastic
            | MaterialModel::VonMisesPlastic
            | MaterialModel::MooneyRivlin => {
                unreachable!("validation admits models with a tangent only")
            }
        }
        out
    }
}

/// F as a 3×3 row-major array, with F_zz = 1 in 2D (plane strain).
fn plane_strain_f<D: Dim>(f: D::T) -> [[f64; 3]; 3] {
    let mut m = D::to3x3(f);
    if D::N == 2 {
        m[2][2] = 1.0;
    }
    m
}

fn det3(f: &[[f64; 3]; 3]) -> f64 {
    f[0][0] * (f[1][1] * f[2][2] - f[1][2] * f[2][1])
        - f[0][1] * (f[1][0] * f[2][2] - f[1][2] * f[2][0])
        + f[0][2] * (f[1][0] * f[2][1] - f[1][1] * f[2][0])
}

/// ε_abc (Levi-Civita).
fn levi_civita(a: usize, b: usize, c: usize) -> f64 {
    ((a as i64 - b as i64) * (b as i64 - c as i64) * (c as i64 - a as i64)) as f64 / 2.0
}

/// J_F = ∂J/∂F = cof F, flattened row-major (seed 004 eq 37).
fn cofactor3(f: &[[f64; 3]; 3]) -> [f64; 9] {
    std::array::from_fn(|r| {
        let (a, aa) = (r / 3, r % 3);
        let (b, c, bb, cc) = ((a + 1) % 3, (a + 2) % 3, (aa + 1) % 3, (aa + 2) % 3);
        f[b][bb] * f[c][cc] - f[b][cc] * f[c][bb]
    })
}

/// J_FF = ∂²J/∂F∂F, ∂²J/∂F_aA∂F_bB = ε_abc ε_ABC F_cC (seed 004 eq 49).
fn cofactor_derivative3(f: &[[f64; 3]; 3]) -> Tangent {
    std::array::from_fn(|r| {
        std::array::from_fn(|s| {
            let (a, aa, b, bb) = (r / 3, r % 3, s / 3, s % 3);
            let mut v = 0.0;
            for (c, row) in f.iter().enumerate() {
                for (cc, fc) in row.iter().enumerate() {
                    v += levi_civita(a, b, c) * levi_civita(aa, bb, cc) * fc;
                }
            }
            v
        })
    })
}

/// ε = sym(F − I).
fn small_strain<D: Dim>(f: D::T) -> D::T {
    (f + D::transpose(f)) * 0.5 - D::identity()
}

/// F:F of the 3D deformation gradient (2D plane strain adds F_zz² = 1).
fn full_ddot<D: Dim>(f: D::T) -> f64 {
    D::ddot(f, f) + (3 - D::N) as f64
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

/// What [`Material::rate_response`] gives at a point.
#[derive(Clone, Copy, Debug)]
pub struct RateResponse<D: Dim> {
    /// First Piola–Kirchhoff stress P = J σ F⁻ᵀ.
    pub pk1: D::T,
    /// F⁻ᵀ, which pushes reference gradients forward.
    pub f_inv_t: D::T,
    pub rho_dot: f64,
    /// Ṡ of the objective rate.
    pub s_dot: D::T,
}

/// Cauchy stress (3×3; 2D plane strain fills σ_zz) and strain energy Σ V0 ψ of every
/// particle from F and, for the rate model, S and ρ (empty slices for state models).
/// Shared by the CPU and GPU paths for their outputs.
pub fn stress_fields<D: Dim>(
    mat: &Material,
    f: &[D::T],
    s: &[D::T],
    rho: &[f64],
    vol: &[f64],
) -> (Vec<[[f64; 3]; 3]>, Exact) {
    let rate = mat.model.is_rate_based();
    let per_particle: Vec<([[f64; 3]; 3], f64)> = f
        .par_iter()
        .enumerate()
        .map(|(i, &f)| {
            let (s, rho) = if rate {
                (s[i], rho[i])
            } else {
                (D::zero_t(), mat.rho0 / D::det(f))
            };
            let sigma = if rate {
                s - D::identity() * mat.pressure(rho)
            } else {
                mat.pk1::<D>(f) * D::transpose(f) * (1.0 / D::det(f))
            };
            let mut out = D::to3x3(sigma);
            if D::N == 2 {
                out[2][2] = mat.sigma_zz::<D>(f, s, rho);
            }
            let energy_rho = if rate { rho } else { mat.rho0 };
            (out, vol[i] * mat.energy_density::<D>(f, s, energy_rho))
        })
        .collect();
    let energy = per_particle.iter().map(|p| p.1).sum();
    (per_particle.into_iter().map(|p| p.0).collect(), energy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tensor::{D2, D3};
    use glam::{DMat2, DMat3, DVec3};

    fn spec(model: MaterialModel) -> MaterialSpec {
        let rubber = model.reads_mooney_rivlin_constants();
        let given = |value: f64, read: bool| read.then_some(value);
        MaterialSpec {
            // Read by `von-mises-plastic` only: far above the tests' stresses, so that its
            // response is the Hencky elastic one.
            yield_stress: Some(1e12),
            hardening_modulus: Some(0.0),
            // The Mooney–Rivlin constants with the same linearisation as E = 1e7, ν = 0.4:
            // μ = c1 + c2 = E/(2(1 + ν)) = 3.5714e6 and λ = K/2 = E/(6(1 − 2ν)) = 8.3333e6.
            c1: given(3.2e6, rubber),
            c2: given(1e7 / 2.8 - 3.2e6, rubber),
            lambda: given(1e7 / (3.0 * 0.2) / 2.0, rubber),
            youngs_modulus: given(1e7, !rubber),
            poisson_ratio: given(0.4, !rubber),
            ..MaterialSpec::elastic(model, 1.0, f64::NAN, f64::NAN)
        }
    }

    #[test]
    fn plane_stress_leaves_the_out_of_plane_stress_free() {
        // A uniaxial stretch ε in x with the plane-stress lateral strain −ν ε: the stress is
        // uniaxial, P_xx = E ε and P_yy = 0, to first order (SVK's quadratic terms leave
        // O(ε²) = 1e-12 relative of E at ε = 1e-6; bound 1e-5 E ε), for every model that
        // takes plane stress; the hypoelastic rate gives Ṡ − ṗ I the same ratios.
        let (eps, nu, e) = (1e-6, 0.4, 1e7);
        for model in MaterialModel::PLANE_STRESS {
            let m = Material::new(&MaterialSpec {
                plane: Plane::Stress,
                ..spec(model)
            });
            let f = DMat2::from_diagonal(glam::DVec2::new(1.0 + eps, 1.0 - nu * eps));
            let p = if model.is_rate_based() {
                // Rates per unit time at L = diag(ε, −ν ε): σ̇ = Ṡ − ṗ I with ṗ = −K tr L.
                let l = f - DMat2::IDENTITY;
                let s_dot = m.stress_rate::<D2>(DMat2::ZERO, l, DMat2::IDENTITY);
                s_dot + DMat2::IDENTITY * (m.bulk * l.x_axis.x + m.bulk * l.y_axis.y)
            } else {
                m.pk1::<D2>(f)
            };
            assert!(
                (p.x_axis.x - e * eps).abs() < 1e-5 * e * eps,
                "{model:?}: P = {p}"
            );
            assert!(p.y_axis.y.abs() < 1e-5 * e * eps, "{model:?}: P = {p}");
            assert_eq!(m.sigma_zz::<D2>(f, DMat2::ZERO, 1.0), 0.0);
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
    fn mooney_rivlin_takes_the_constants_of_its_linearisation() {
        // The test spec's c1, c2, λ are those of E = 1e7, ν = 0.4 (seed 000 §0's table):
        // the same μ, λ, K and c_p as the elastic models to round-off, and K = 2λ.
        let rubber = Material::new(&spec(MaterialModel::MooneyRivlin));
        let elastic = Material::new(&spec(MaterialModel::NeoHookean));
        for (a, b) in [
            (rubber.mu, elastic.mu),
            (rubber.lambda, elastic.lambda),
            (rubber.bulk, elastic.bulk),
            (rubber.p_wave_speed(), elastic.p_wave_speed()),
            (rubber.bulk, 2.0 * rubber.mooney_rivlin.unwrap().lambda),
        ] {
            assert!((a - b).abs() < 1e-12 * b, "{a} vs {b}");
        }
        // (E, ν) of the linearisation, which the closed-form solutions take.
        let (e, nu) = spec(MaterialModel::MooneyRivlin).youngs_and_poisson();
        assert!(
            (e - 1e7).abs() < 1e-5 && (nu - 0.4).abs() < 1e-12,
            "{e} {nu}"
        );
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
            MaterialModel::NearlyIncompressibleNeoHookean,
            MaterialModel::LinearElastic,
            MaterialModel::MooneyRivlin,
        ] {
            let m = Material::new(&spec(model));
            // Small-strain elasticity is not objective: it is the one exception.
            if model != MaterialModel::LinearElastic {
                let p = m.pk1::<D3>(q3);
                assert!(D3::ddot(p, p).sqrt() < 1e-8 * m.mu, "{model:?}");
                assert!(m.energy_density::<D3>(q3, DMat3::ZERO, 1.0).abs() < 1e-8 * m.mu);
            }
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
        let f2 = DMat2::from_cols_array(&[1.2, 0.1, 0.2, 0.9]);
        for model in [
            MaterialModel::SaintVenantKirchhoff,
            MaterialModel::NeoHookean,
            MaterialModel::LinearElastic,
            MaterialModel::NearlyIncompressibleNeoHookean,
            MaterialModel::MooneyRivlin,
        ] {
            let m = Material::new(&spec(model));
            check_pk1::<D3>(&m, f0);
            check_pk1::<D2>(&m, f2);
        }
    }

    fn check_pk1<D: Dim>(m: &Material, f0: D::T) {
        let p = m.pk1::<D>(f0);
        for k in 0..D::N {
            for l in 0..D::N {
                let mut e = [0.0; 3];
                e[k] = 1e-7;
                let mut n = [0.0; 3];
                n[l] = 1.0;
                let df = D::outer(D::from_slice(&e), D::from_slice(&n));
                let fd = (m.energy_density::<D>(f0 + df, D::zero_t(), 1.0)
                    - m.energy_density::<D>(f0 - df, D::zero_t(), 1.0))
                    / 2e-7;
                assert!(
                    (fd - D::entry(p, k, l)).abs() < 1e-5 * m.mu,
                    "{:?} {}D P_{k}{l}: {fd} vs {}",
                    m.model,
                    D::N,
                    D::entry(p, k, l)
                );
            }
        }
    }

    #[test]
    fn polyconvex_model_matches_its_classical_form_when_h_and_j_follow_f() {
        // P = μ J^(−2/3)(F − ⅓ F:F F⁻ᵀ) + κ(J − 1) J F⁻ᵀ (seed 003 §E.2) with H = cof F.
        let m = Material::new(&spec(MaterialModel::NearlyIncompressibleNeoHookean));
        let f = DMat3::from_cols_array(&[1.2, 0.1, -0.05, 0.2, 0.9, 0.1, 0.0, -0.1, 1.1]);
        let (j, f_inv_t) = (f.determinant(), f.inverse().transpose());
        let classical = (f - f_inv_t * (D3::ddot(f, f) / 3.0)) * (m.mu * j.powf(-2.0 / 3.0))
            + f_inv_t * (m.bulk * (j - 1.0) * j);
        let e = m.pk1::<D3>(f) - classical;
        assert!(D3::ddot(e, e).sqrt() < 1e-9 * m.mu);
    }

    #[test]
    fn von_mises_of_uniaxial_stress_is_its_magnitude() {
        assert!(
            (von_mises(&[[-3.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]) - 3.0).abs() < 1e-12
        );
        assert!(von_mises(&[[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]).abs() < 1e-12);
    }
}
