//! The dual-support energy as a model of the static Newton engine ([`crate::statics`]):
//! the variational force and its assembled tangent (seed 004 §2), on the pattern of the
//! elements {i} ∪ S_i.

use super::DualSupportSpec;
use super::model::DualSupport;
use super::support::Support;
use crate::case::{Case, CaseError};
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::engine::BlowUp;
use crate::reference::Reference;
use crate::statics::sparse::{BlockPattern, CgSettings, Linear};
use crate::statics::{Linearisation, Model, Newton, Setup};
use rayon::prelude::*;

/// The static dual-support engine (CPU, f64).
pub type Statics<D> = crate::statics::Statics<D, DualSupport<D>>;

/// The coupling of the dual-support tangent: row a holds every node of every element
/// holding a (a itself and S'_a), two hops through the supports.
pub fn pattern<D: Dim>(s: &Support<D>) -> BlockPattern {
    BlockPattern::from_rows(
        (0..s.len())
            .into_par_iter()
            .map(|a| {
                let mut row: Vec<u32> = s
                    .elements_of(a)
                    .flat_map(|(i, _)| s.nodes(i))
                    .map(|n| n as u32)
                    .collect();
                row.sort_unstable();
                row.dedup();
                row
            })
            .collect(),
    )
}

impl<D: Dim> crate::statics::Statics<D, DualSupport<D>> {
    /// Builds supports, the tangent's pattern and the free system once (the CPU's
    /// assembled tangent and `method.solver`).
    pub fn new(case: &Case, spec: &DualSupportSpec) -> Result<Self, CaseError> {
        let reference = Reference::<D>::build(case)?;
        let model = spec.model(case, &reference)?;
        let cg = CgSettings {
            tolerance: spec.linear_tolerance,
            max_iterations: spec.linear_max_iterations as usize,
        };
        let linearisation =
            Linearisation::Assembled(pattern(&model.support), Linear::from((spec.solver, cg)));
        Self::on(case, spec, reference, model, linearisation)
    }

    /// The engine of `model` on `reference` with Newton's linear step `linearisation`.
    pub fn on(
        case: &Case,
        spec: &DualSupportSpec,
        reference: Reference<D>,
        model: DualSupport<D>,
        linearisation: Linearisation<D, DualSupport<D>>,
    ) -> Result<Self, CaseError> {
        let Reference {
            mass,
            body,
            boundary,
            u0,
            v0,
            ..
        } = reference;
        let setup = Setup {
            mass,
            body,
            u0,
            v0,
            boundary: &boundary,
            linearisation,
            newton: spec.newton(case),
        };
        Self::with_model(case, model, setup, "method.solver")
    }
}

impl DualSupportSpec {
    /// Newton's settings: `run.tolerance`, or this method's older keys for it where given
    /// (named in the message of a stalled step), and its iteration limits.
    pub fn newton(&self, case: &Case) -> Newton {
        let mut newton = Newton::of(
            case,
            self.max_iterations,
            self.max_cuts,
            "method.max_iterations",
        );
        if let Some(v) = self.residual_tolerance {
            newton.residual_tolerance = v;
            newton.tolerance_keys[0] = "method.residual_tolerance";
        }
        if let Some(v) = self.increment_tolerance {
            newton.increment_tolerance = v;
            newton.tolerance_keys[1] = "method.increment_tolerance";
        }
        newton
    }
}

impl<D: Dim> Model<D> for DualSupport<D> {
    fn x0(&self) -> &[D::V] {
        &self.support.x0
    }

    /// −∂E/∂u with the hourglass term (eq 18, eq 28).
    fn force(&mut self, u: &[D::V]) -> Result<Vec<D::V>, BlowUp> {
        Ok(self.internal_force(u, true))
    }

    /// The assembled tangent ∂²E/∂u² (eqs 39–41, 29).
    fn stiffness(&mut self, u: &[D::V], pattern: &BlockPattern, values: &mut [f64]) {
        let tangents = self.tangents(u);
        DualSupport::stiffness(self, &tangents, pattern, values);
    }

    fn inadmissible(&mut self, u: &[D::V]) -> Option<BlowUp> {
        self.first_inadmissible(&self.displacement_gradients(u))
    }

    /// The strain energy Σ V ψ alone: the hourglass energy is a field of its own.
    fn snapshot<'a>(
        &'a mut self,
        u: &[D::V],
        v: &[D::V],
        mass: &'a [f64],
        body: &'a [u32],
    ) -> Snapshot<'a, D> {
        DualSupport::snapshot(self, u.to_vec(), v.to_vec(), mass, body, false)
    }
}
