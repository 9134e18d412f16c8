//! `[method]`: the keys every method reads, and what loading resolved of the method.

use crate::core::correction::CorrectionKind;
use crate::core::integrate::IntegratorKind;
use crate::core::kernel::KernelKind;
use serde::Serialize;

/// The `[method]` keys every method reads, and what the registry ([`crate::methods`])
/// resolved of the named method at load, for the layers below it. The method's own keys
/// are its typed spec, which the driver holds beside the case ([`crate::scene::Scene`])
/// and hands to the method's hooks.
///
/// It serializes as the common keys of the `[method]` table a case file gives.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MethodKeys {
    /// The method's case-file name (serialized by the method's spec).
    #[serde(skip)]
    pub name: &'static str,
    pub kernel: KernelKind,
    /// Smoothing length over particle spacing (1 for a method without a kernel, whose
    /// smoothing length nothing reads).
    pub h_over_dx: f64,
    pub correction: CorrectionKind,
    pub integrator: IntegratorKind,
    /// Fixed time step [s]; exactly one of `dt` and `cfl` is given.
    pub dt: Option<f64>,
    /// Courant number of the adaptive step (each method states its signal speed).
    pub cfl: Option<f64>,
    /// Whether the method is static by default: a run solves for equilibrium unless
    /// `run.solve = "dynamic"`.
    #[serde(skip)]
    pub static_default: bool,
    /// Whether the method integrates over the cells between the particles of a lattice,
    /// so that its boxes and cylinders are sampled on the vertex lattice
    /// (`MethodFamily::lattice_cells`).
    #[serde(skip)]
    pub lattice_cells: bool,
}
