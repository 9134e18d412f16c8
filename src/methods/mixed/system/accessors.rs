//! Read access to the reference set-up, for the GPU engine.

use super::*;
use crate::boundary::Boundary;

/// Read access to the reference set-up, for the GPU engine ([`crate::methods::mixed::gpu`]).
#[cfg(feature = "gpu")]
impl<D: Dim> MixedSph<D> {
    pub(crate) fn ghosts(&self) -> &Ghosts<D> {
        &self.ghosts
    }

    /// Reference positions and volumes of the real particles, then the ghosts.
    pub(crate) fn extended_reference(&self) -> (&[D::V], &[f64]) {
        (&self.x0, &self.vol)
    }

    /// g_ab and g_ba, CSR order.
    pub(crate) fn pair_gradients(&self) -> (&[D::V], &[D::V]) {
        (&self.grad, &self.grad_rev)
    }

    /// Least-squares weights M_a⁻¹ N_ab / |d_ab|, CSR order.
    pub(crate) fn ls_weights(&self) -> &[D::V] {
        &self.ls
    }

    /// Upwind-SPH: whether p and P are reconstructed to the mid-pair.
    pub(crate) fn reconstruction(&self) -> bool {
        matches!(
            self.stabilisation,
            Stabilisation::Upwind {
                reconstruction: true
            }
        )
    }

    /// JST-SPH: the coefficients and the per-pair ℓ_ab and s_ab.
    pub(crate) fn jst(&self) -> Option<(crate::methods::mixed::Jst, &[f64], &[f64])> {
        match &self.stabilisation {
            Stabilisation::Jst {
                coefficients,
                ell,
                s,
            } => Some((*coefficients, ell, s)),
            Stabilisation::Upwind { .. } | Stabilisation::Supg { .. } => None,
        }
    }

    /// The bond-based F: w_ab = V_b W̃_b(X_a) / |X_ab|² per pair, CSR order.
    pub(crate) fn bond_weights(&self) -> Option<&[f64]> {
        self.bond_weights.as_deref()
    }

    /// Whether the bond F is eq 38's purely kinematic one.
    pub(crate) fn kinematic_bond(&self) -> bool {
        self.kinematic_bond
    }

    pub(crate) fn momentum(&self) -> Momentum {
        self.momentum
    }

    pub(crate) fn material(&self) -> &Material {
        &self.material
    }

    pub(crate) fn conserved(&self) -> Conserved {
        self.conserved
    }

    pub(crate) fn projection(&self) -> bool {
        self.projection
    }

    /// The plastic history, for the GPU engine to replace by its own before a snapshot.
    pub(crate) fn plastic_mut(&mut self) -> Option<&mut History> {
        self.plastic.as_mut()
    }

    /// The pseudo-time corrector of artificial compressibility; None without.
    pub(in crate::methods::mixed) fn corrector(&self) -> Option<&Corrector<D>> {
        self.compressibility.as_ref()
    }

    pub(crate) fn cfl_wave_speed(&self) -> CflWaveSpeed {
        self.cfl_wave_speed
    }

    pub(crate) fn boundary(&self) -> &Boundary<D> {
        &self.surroundings.boundary
    }

    pub(crate) fn interactions(&self) -> &Interactions<D> {
        &self.surroundings.interactions
    }

    pub(crate) fn smoothing_length(&self) -> f64 {
        self.h
    }
}
