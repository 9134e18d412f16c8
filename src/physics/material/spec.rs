//! The `[material]` table of a case: the constitutive model and its constants, which
//! [`super::Material`] is built from.

use super::MaterialModel;
use crate::physics::mooney_rivlin::MooneyRivlin;
use crate::physics::plasticity::{Hardening, RateSensitivity, Thermal};
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub model: MaterialModel,
    /// Reference density ρ0 [kg/m³].
    pub density: f64,
    /// Young's modulus E [Pa]: every model but `mooney-rivlin`.
    pub youngs_modulus: Option<f64>,
    /// Poisson ratio ν: every model but `mooney-rivlin`.
    pub poisson_ratio: Option<f64>,
    /// `von-mises-plastic`: initial yield stress τ_y⁰ [Pa] (Johnson–Cook's A).
    pub yield_stress: Option<f64>,
    /// `von-mises-plastic`: isotropic hardening modulus H [Pa]: τ_y = τ_y⁰ + H ε_p^n
    /// (Johnson–Cook's B), negative for linear softening (down to τ_y = 0).
    pub hardening_modulus: Option<f64>,
    /// `von-mises-plastic`: the hardening exponent n (1 when absent: linear hardening).
    pub hardening_exponent: Option<f64>,
    /// `von-mises-plastic`: Johnson–Cook's strain-rate coefficient C (none when absent).
    pub strain_rate_coefficient: Option<f64>,
    /// `von-mises-plastic` with `strain_rate_coefficient`: the reference strain rate ε̇0
    /// [1/s] (1 when absent).
    pub reference_strain_rate: Option<f64>,
    /// `von-mises-plastic`: Johnson–Cook's thermal-softening exponent m; with it,
    /// `melting_temperature` and `specific_heat` the plastic work heats the material.
    pub thermal_softening_exponent: Option<f64>,
    /// The melting temperature T_m [K] of the thermal softening.
    pub melting_temperature: Option<f64>,
    /// The room (initial) temperature T_r [K] of the thermal softening (293.15 when
    /// absent).
    pub room_temperature: Option<f64>,
    /// The specific heat c_p [J/(kg K)] of the adiabatic heating.
    pub specific_heat: Option<f64>,
    /// The Taylor–Quinney fraction χ of the plastic work that heats the material (0.9
    /// when absent).
    pub taylor_quinney: Option<f64>,
    /// `mooney-rivlin`: c1 of seed 001 eq 18 [Pa].
    pub c1: Option<f64>,
    /// `mooney-rivlin`: c2 of seed 001 eq 18 [Pa].
    pub c2: Option<f64>,
    /// `mooney-rivlin`: λ of seed 001 eq 18 [Pa], half the bulk modulus (not Lamé's λ,
    /// which is 2λ − ⅔(c1 + c2)).
    pub lambda: Option<f64>,
    /// What the out-of-plane direction of a 2D scene holds fixed.
    #[serde(default)]
    pub plane: Plane,
    /// The objective rate of a rate model's deviatoric stress (Jaumann when absent).
    pub objective_rate: Option<ObjectiveRate>,
}

impl MaterialSpec {
    /// An isotropic elastic material of `model` with E and ν: plane strain, no yield
    /// stress, the default objective rate; what a `[material]` table with those four keys
    /// gives.
    pub fn elastic(
        model: MaterialModel,
        density: f64,
        youngs_modulus: f64,
        poisson_ratio: f64,
    ) -> Self {
        Self {
            model,
            density,
            youngs_modulus: Some(youngs_modulus),
            poisson_ratio: Some(poisson_ratio),
            yield_stress: None,
            hardening_modulus: None,
            hardening_exponent: None,
            strain_rate_coefficient: None,
            reference_strain_rate: None,
            thermal_softening_exponent: None,
            melting_temperature: None,
            room_temperature: None,
            specific_heat: None,
            taylor_quinney: None,
            c1: None,
            c2: None,
            lambda: None,
            plane: Plane::Strain,
            objective_rate: None,
        }
    }

    /// The yield stress of a `von-mises-plastic` material (Johnson–Cook's law, linear
    /// unless its exponent, rate or thermal keys are given), or the linear one of a rate
    /// model given `yield_stress` (perfectly plastic unless hardened); None otherwise.
    pub fn hardening(&self) -> Option<Hardening> {
        let yield_stress = self.yield_stress?;
        let modulus = self.hardening_modulus;
        match self.model {
            MaterialModel::Hypoelastic => {
                Some(Hardening::linear(yield_stress, modulus.unwrap_or(0.0)))
            }
            MaterialModel::VonMisesPlastic => Some(Hardening {
                exponent: self.hardening_exponent.unwrap_or(1.0),
                rate: self
                    .strain_rate_coefficient
                    .map(|coefficient| RateSensitivity {
                        coefficient,
                        reference: self.reference_strain_rate.unwrap_or(1.0),
                    }),
                thermal: match (
                    self.thermal_softening_exponent,
                    self.melting_temperature,
                    self.specific_heat,
                ) {
                    (Some(exponent), Some(melting), Some(c_p)) => Some(Thermal {
                        exponent,
                        room: self.room_temperature.unwrap_or(Self::ROOM_TEMPERATURE),
                        melting,
                        heating: self.taylor_quinney.unwrap_or(Self::TAYLOR_QUINNEY)
                            / (self.density * c_p),
                    }),
                    _ => None,
                },
                ..Hardening::linear(yield_stress, modulus?)
            }),
            _ => None,
        }
    }

    /// The room temperature when `room_temperature` is absent [K].
    pub const ROOM_TEMPERATURE: f64 = 293.15;

    /// The Taylor–Quinney fraction when `taylor_quinney` is absent: 0.9, the value
    /// Taylor and Quinney (1934) measured for metals at large strain and the common
    /// default.
    pub const TAYLOR_QUINNEY: f64 = 0.9;

    /// The constants of a `mooney-rivlin` material (None for the other models).
    pub fn mooney_rivlin(&self) -> Option<MooneyRivlin> {
        match (self.model, self.c1, self.c2, self.lambda) {
            (MaterialModel::MooneyRivlin, Some(c1), Some(c2), Some(lambda)) => {
                Some(MooneyRivlin { c1, c2, lambda })
            }
            _ => None,
        }
    }

    /// Young's modulus and Poisson's ratio (E, ν): as given, or for `mooney-rivlin` those
    /// of its linearisation at F = I (μ = c1 + c2, λ_L = 2λ − ⅔μ). The closed-form
    /// solutions of linear elasticity take them. NaN where validation would refuse the
    /// case.
    pub fn youngs_and_poisson(&self) -> (f64, f64) {
        match self.mooney_rivlin() {
            Some(m) => {
                let (mu, lambda) = m.lame();
                (
                    mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu),
                    lambda / (2.0 * (lambda + mu)),
                )
            }
            None => (
                self.youngs_modulus.unwrap_or(f64::NAN),
                self.poisson_ratio.unwrap_or(f64::NAN),
            ),
        }
    }
}

/// The objective rate S̊ that the rate model equates to 2μ dev D (seed 000 §4.1, eq 91).
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum ObjectiveRate {
    /// S̊ = Ṡ + S W − W S with the spin W = ½(L − Lᵀ) (eqs 89–90).
    #[default]
    Jaumann,
    /// S̊ = Ṡ + S Ω − Ω S with the spin Ω = Ṙ Rᵀ of the rotation of F = R U.
    GreenNaghdi,
    /// S̊ = Ṡ − L S − S Lᵀ + tr(D) S: S is then the stress beyond the EOS pressure, and
    /// need not stay traceless.
    Truesdell,
}

impl ObjectiveRate {
    /// The rate's name in prose, for `--explain`.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Jaumann => "Jaumann",
            Self::GreenNaghdi => "Green–Naghdi",
            Self::Truesdell => "Truesdell",
        }
    }
}

/// The out-of-plane assumption of a 2D scene.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Plane {
    /// F_zz = 1 (ε_zz = 0): a slice of a long body.
    #[default]
    Strain,
    /// σ_zz = 0: a thin sheet, as the seed-000 reference code's SVK and small-strain
    /// models are.
    Stress,
}
