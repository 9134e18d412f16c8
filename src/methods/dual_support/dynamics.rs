//! The explicit dynamic variant of dual-support SPH (`run.solve = "dynamic"`): the same
//! energy, variational force and hourglass control as the static method ([`super::model`]),
//! integrated in time with a lumped mass, m_i ü_i = f_i^int + f_i^ext with
//! f^int = −∂(E_strain + E_hg)/∂u (eq 18, eq 28). The force is the gradient of an energy,
//! so with a symplectic integrator the stored energy E_strain + E_hg plus the kinetic
//! energy is conserved but for the integrator's error, and Σ_i f_i^int = 0 to round-off.
//! The state is u and v, as for total-Lagrangian SPH ([`TlState`]).

use super::DualSupportSpec;
use super::model::DualSupport;
use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::parallel::MIN_CHUNK;
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, Sizes, Traffic};
use crate::methods::cores::tl::{TlCore, TlScheme, TlSph, TlState, displacement_rates};
use crate::reference::Reference;
use rayon::prelude::*;

/// Dual-support SPH integrated in time on the CPU (f64, rayon).
pub type DualSupportDynamics<D> = TlSph<D, DynamicsScheme<D>>;

/// The force of dual-support SPH on the total-Lagrangian core.
pub struct DynamicsScheme<D: Dim> {
    pub model: DualSupport<D>,
    /// The displacement gradients H = F − I of the last stress pass.
    h: Vec<D::T>,
    /// The power against the hourglass control at the last rate evaluation.
    hourglass_power: Exact,
}

impl<D: Dim> TlScheme<D> for DynamicsScheme<D> {
    /// Smoothing lengths, supports and dual-supports on the reference configuration.
    type Spec = DualSupportSpec;

    fn new(
        case: &Case,
        spec: &DualSupportSpec,
        reference: &Reference<D>,
    ) -> Result<Self, CaseError> {
        Ok(Self {
            model: spec.model(case, reference)?,
            h: Vec::new(),
            hourglass_power: Exact::default(),
        })
    }

    /// The supports' lists.
    fn lists(&self) -> &Csr {
        &self.model.support.lists
    }

    /// H = F − I of every particle; det F > 0.
    fn stresses(
        &mut self,
        _core: &TlCore<D>,
        y: &TlState<D>,
        _d: &mut TlState<D>,
    ) -> Option<BlowUp> {
        self.h = self.model.displacement_gradients(&y.u);
        self.model.first_inadmissible(&self.h)
    }

    /// u̇ = v, v̇ = f^int/m.
    fn forces(&mut self, core: &mut TlCore<D>, y: &TlState<D>, d: &mut TlState<D>) {
        let f = self.model.internal_force_at(&y.u, &self.h, true);
        self.hourglass_power = self.model.hourglass_power(&y.v);
        d.v.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(f.par_iter().zip(&core.mass))
            .for_each(|(a, (&f, &m))| *a = f * (1.0 / m));
        displacement_rates::<D>(&mut d.u, &y.v);
    }

    fn deformation_gradient(&self, _core: &TlCore<D>, y: &TlState<D>) -> Vec<D::T> {
        self.model.deformation_gradients(&y.u)
    }

    fn snapshot<'a>(&'a self, core: &'a TlCore<D>, y: &TlState<D>) -> Snapshot<'a, D> {
        let (mass, body) = (&core.mass, &core.body);
        self.model
            .snapshot(y.u.clone(), y.v.clone(), mass, body, false)
    }

    /// E_strain alone: the hourglass energy is booked as the work against the hourglass
    /// control ([`Self::hourglass_power`]; its density is also a field of the frames).
    fn strain_energy(&self, _core: &TlCore<D>, y: &TlState<D>) -> Exact {
        self.model.energies(&y.u).strain
    }

    /// −Σ f^hg·v at the last rate evaluation: its integral is the hourglass energy E_hg
    /// gained since the start, as the force derives from it (eq 21).
    fn hourglass_power(&self, _core: &TlCore<D>) -> Exact {
        self.hourglass_power.clone()
    }

    /// Pass 1 reads u and the ids and g_ij of every pair and writes H = F − I; the det F
    /// check reads H; pass 2 reads H and V and writes V P; the force gather reads V P,
    /// g_i0, the ids and pair slots of the dual-support and g_ij through the slot, and
    /// writes f, evaluating each pair's hourglass term at both ends (X, u, H, V and c of
    /// the owner; the ids and w_ij of every pair, in each direction); the last passes
    /// write a = f/m (reading m) and u̇ = v.
    fn traffic(&self, _core: &TlCore<D>) -> Traffic {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let gather = t + 2 * v + (2 * v + t + 2 * f);
        let per_particle = (v + t) + t + (2 * t + f) + gather + (2 * v + f) + 2 * v;
        let per_pair = (id + v) + (2 * id + v) + 2 * (id + f);
        Traffic {
            per_particle: per_particle as f64,
            per_pair: per_pair as f64,
            state: (2 * v) as f64,
            velocity: v as f64,
        }
    }
}
