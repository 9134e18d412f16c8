//! Monaghan's artificial viscosity (seed 000 §3.1 step 6), which the SPH families share.

use crate::core::check::{Problem, non_negative};
use crate::core::tensor::Dim;
use serde::{Deserialize, Serialize};

/// Monaghan artificial viscosity Π_ij = (−α c̄ μ_ij + β μ_ij²)/ρ̄_ij (seed 000 §3.1 step 6).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ArtificialViscosity {
    pub alpha: f64,
    pub beta: f64,
    #[serde(default = "default_eta")]
    pub eta: f64,
}

fn default_eta() -> f64 {
    0.1
}

impl ArtificialViscosity {
    /// The coefficients must not be negative.
    pub fn validate(&self) -> Result<(), Problem> {
        non_negative("method.artificial_viscosity.alpha", self.alpha)?;
        non_negative("method.artificial_viscosity.beta", self.beta)?;
        non_negative("method.artificial_viscosity.eta", self.eta)
    }

    /// Π_ij of a pair at distance x_ij = x_i − x_j with relative velocity v_ij, mean sound
    /// speed c̄ and mean density ρ̄, smoothing length h: μ_ij = h v_ij·x_ij/(|x_ij|² + η²h²)
    /// for approaching pairs, and zero for separating ones (v_ij·x_ij ≥ 0).
    ///
    /// With one division, as Π = h v·x (−α c̄ d + β h v·x)/(d² ρ̄), d = |x_ij|² + η²h².
    #[inline]
    pub fn pi<D: Dim>(&self, h: f64, x_ij: D::V, v_ij: D::V, c: f64, rho: f64) -> f64 {
        let vx = D::dot(v_ij, x_ij);
        if vx >= 0.0 {
            return 0.0;
        }
        let d = D::norm2(x_ij) + self.eta * self.eta * h * h;
        h * vx * (-self.alpha * c * d + self.beta * h * vx) / (d * d * rho)
    }
}
