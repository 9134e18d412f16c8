//! The energy balance of a run, the one definition the series (the `energy` observer),
//! the summary and the studies read:
//!
//!   E_kin + E_stored + D_art + W_hg + W_p + E_contact − W_ext = E_0
//!
//! with E_kin = Σ ½ m |v|², E_stored the method's stored (strain) energy Σ V0 ψ (the
//! elastic part of ψ for a plastic material), D_art the energy the artificial
//! dissipation took (artificial viscosity, the stabilisation of a mixed method, the
//! Riemann solver's velocity jump, a velocity smoothing), W_hg the work of the hourglass
//! control, W_p the plastic work Σ_q w_q ∫ τ_y dε̄_p (the hardening energy ½ H ε̄_p²
//! included: it is not in E_stored), E_contact the work of the bodies against the
//! contact forces and W_ext the work of supports and loads. The powers are integrated
//! over every step by the engine (trapezoidal, as the work of the supports), the
//! plastic work at the commit of the plastic history.
//!
//! The residue R = E_kin + E_stored + D_art + W_hg + W_p + E_contact − W_ext − E_0 is
//! zero but for the integrator's error and what a method does not book. It is reported
//! as the column `energy_residue` = R / S with the scale S = E_0 + E_kin + E_stored +
//! |W_ext|: the energy present or put in at that time (0 when S = 0, a body at rest and
//! unloaded). (`energy_error` is the `solution-error` observer's energy-norm error.)
//!
//! A term an engine does not book on its backend is `None`: its column is NaN, and the
//! residue leaves it out (so it contains that term). The list per method and backend is
//! in docs/verification.md, "The energy balance".

use std::collections::BTreeMap;

/// The terms an engine books beside the kinetic and stored energy, so far in a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Booked {
    /// W_ext: the work of supports and loads (and of contact where `contact_energy` is
    /// not booked apart).
    pub external_work: f64,
    /// D_art: the energy taken by the artificial dissipation.
    pub dissipated: Option<f64>,
    /// W_hg: the work done against the hourglass control.
    pub hourglass_work: Option<f64>,
    /// W_p: the plastic work.
    pub plastic_work: Option<f64>,
    /// E_contact: the work done against the contact forces.
    pub contact_energy: Option<f64>,
}

impl Booked {
    /// The work of supports and loads and no other term booked (an engine that books
    /// none of them, as a static one).
    pub fn external(external_work: f64) -> Self {
        Self {
            external_work,
            dissipated: None,
            hourglass_work: None,
            plastic_work: None,
            contact_energy: None,
        }
    }

    /// D_art + W_hg + W_p + E_contact over the terms booked.
    fn internal(&self) -> f64 {
        [
            self.dissipated,
            self.hourglass_work,
            self.plastic_work,
            self.contact_energy,
        ]
        .iter()
        .flatten()
        .sum()
    }
}

impl Default for Booked {
    /// Nothing done yet: every term booked and zero.
    fn default() -> Self {
        Self {
            external_work: 0.0,
            dissipated: Some(0.0),
            hourglass_work: Some(0.0),
            plastic_work: Some(0.0),
            contact_energy: Some(0.0),
        }
    }
}

/// The series columns of the `energy` observer, in the order of [`Balance::row`].
pub const COLUMNS: [&str; 9] = [
    "kinetic_energy",
    "strain_energy",
    "total_energy",
    "external_work",
    "dissipated",
    "hourglass_work",
    "plastic_work",
    "contact_energy",
    "energy_residue",
];

/// The balance at one time of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Balance {
    pub kinetic: f64,
    pub stored: f64,
    pub booked: Booked,
    /// E_0 = E_kin + E_stored of the initial state.
    pub e0: f64,
}

impl Balance {
    /// R = E_kin + E_stored + D_art + W_hg + W_p + E_contact − W_ext − E_0, over the
    /// booked terms.
    pub fn residue(&self) -> f64 {
        self.kinetic + self.stored + self.booked.internal() - self.booked.external_work - self.e0
    }

    /// S = E_0 + E_kin + E_stored + |W_ext|.
    pub fn scale(&self) -> f64 {
        self.e0 + self.kinetic.abs() + self.stored.abs() + self.booked.external_work.abs()
    }

    /// R / S (0 when S = 0 and R = 0; NaN for a non-finite term).
    pub fn relative_residue(&self) -> f64 {
        let (r, s) = (self.residue(), self.scale());
        if s == 0.0 && r == 0.0 { 0.0 } else { r / s }
    }

    /// The values of [`COLUMNS`]; NaN for a term not booked.
    pub fn row(&self) -> [f64; 9] {
        let b = &self.booked;
        let or_nan = |t: Option<f64>| t.unwrap_or(f64::NAN);
        [
            self.kinetic,
            self.stored,
            self.kinetic + self.stored,
            b.external_work,
            or_nan(b.dissipated),
            or_nan(b.hourglass_work),
            or_nan(b.plastic_work),
            or_nan(b.contact_energy),
            self.relative_residue(),
        ]
    }

    /// The columns besides the energies of the state (which the summary's invariants
    /// name), for the run summary.
    pub fn named(&self) -> BTreeMap<String, f64> {
        COLUMNS
            .iter()
            .zip(self.row())
            .skip(3)
            .map(|(k, v)| (k.to_string(), v))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A body at rest whose supports did 10 J of work, 6 J of it stored, 3 J taken by
    /// the viscosity and 0.5 J by plasticity: R = −0.5 J over S = 16 J.
    #[test]
    fn the_residue_sums_the_booked_terms_and_leaves_out_the_others() {
        let balance = Balance {
            kinetic: 0.0,
            stored: 6.0,
            booked: Booked {
                external_work: 10.0,
                dissipated: Some(3.0),
                hourglass_work: Some(0.0),
                plastic_work: Some(0.5),
                contact_energy: None,
            },
            e0: 0.0,
        };
        assert_eq!(balance.residue(), -0.5);
        assert_eq!(balance.relative_residue(), -0.5 / 16.0);
        let row = balance.row();
        assert!(row[7].is_nan(), "contact is not booked: NaN");
        assert_eq!(row[8], -0.5 / 16.0);
        assert_eq!(balance.named()["plastic_work"], 0.5);
        let at_rest = Balance {
            kinetic: 0.0,
            stored: 0.0,
            booked: Booked::default(),
            e0: 0.0,
        };
        assert_eq!(at_rest.relative_residue(), 0.0);
    }
}
