//! What a method family gives the driver: the [`MethodFamily`] hooks its typed spec
//! implements, with what they return ([`Plan`], [`CpuBuild`], [`GpuBuild`]) and the
//! scene [`Feature`]s they declare. A family imports these and the cores below, never the
//! registry ([`crate::methods`]) that lists the families.

use crate::case::{Case, CaseError};
use crate::core::check::Problem;
use crate::core::neighbour::Rebuild;
use crate::core::tensor::Dim;
use crate::engine::ranks::{Distributed, RankStart};
use crate::engine::{Engine, EngineDim};
use crate::physics::material::Material;
use crate::physics::viscosity::ArtificialViscosity;
use crate::reference::Reference;

/// The `[method]` keys that only the methods with a kernel read.
pub const KERNEL_KEYS: &[&str] = &["kernel", "h_over_dx", "correction"];

/// The keys of `[method]` that every method reads (the [`KERNEL_KEYS`] only those with a
/// kernel).
pub const COMMON_KEYS: &[&str] = &[
    "kernel",
    "h_over_dx",
    "correction",
    "integrator",
    "dt",
    "cfl",
];

/// Scene features a method may or may not run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// Penalty contact between bodies (`[contact]`).
    Contact,
    /// Symmetry planes closed by ghost particles (`[[mirror]]`).
    MirrorPlanes,
    /// A material with a plastic history (`von-mises-plastic`).
    Plasticity,
    /// A yield stress on the rate model (`hypoelastic` with `yield_stress`): the radial
    /// return of S at every step's end.
    RatePlasticity,
    /// The static solve of `run.solve = "static"` ([`crate::statics`]).
    StaticSolve,
    /// The static solve on the GPU as well (`--backend gpu`).
    GpuStaticSolve,
    /// Static by default: a run solves for equilibrium load step by load step unless
    /// `run.solve = "dynamic"`.
    StaticDefault,
    /// An initial displacement (`body.initial_displacement`): the deformation gradient
    /// follows from the displacement, so the state starts deformed.
    InitialDisplacement,
}

/// What a run of a method does, for `meshless run --explain`.
#[derive(Clone, Debug, Default)]
pub struct Plan {
    /// What is built once on the reference configuration.
    pub once: String,
    /// The integrated state.
    pub state: String,
    /// The adaptive step rule, for `method.cfl`.
    pub cfl_step: String,
    /// One rate evaluation (the GPU passes, or the CPU's gathers).
    pub rates: String,
    /// Per-particle quantities checked besides finiteness (`det F`, `J`).
    pub checked: &'static str,
    /// A remark on the host checks, if any.
    pub check_note: String,
    /// What this scene leaves out of the method.
    pub left_out: Vec<&'static str>,
}

/// The `--explain` line of the step Δt = cfl·Δx/(c_p + max|v|) that most methods take.
pub fn cfl_step(mat: &Material) -> String {
    format!(
        "Δt = cfl·Δx/(c_p + max|v|), c_p = {:.1} m/s",
        mat.p_wave_speed()
    )
}

/// The checks of a method's optional Monaghan viscosity (`method.artificial_viscosity`).
pub fn check_viscosity(av: Option<&ArtificialViscosity>) -> Result<(), Problem> {
    av.map_or(Ok(()), ArtificialViscosity::validate)
}

/// What the plan of a method with an optional Monaghan viscosity leaves out for it: the
/// viscosity, when it has none.
pub fn left_out_viscosity(av: Option<&ArtificialViscosity>) -> Vec<&'static str> {
    match av {
        Some(_) => Vec::new(),
        None => vec!["artificial viscosity"],
    }
}

/// A method's CPU engine for a case, or the case's error ([`MethodFamily::cpu_engine`]).
pub type CpuBuild<D> = Result<Box<dyn Engine<D>>, CaseError>;

/// A method's GPU engine for a case, or why it could not be set up
/// ([`MethodFamily::gpu_engine`]).
#[cfg(feature = "gpu")]
pub type GpuBuild<D> = Result<Box<dyn Engine<D>>, crate::gpu::SetupError>;

/// The engine of one rank of a distributed run for a case, or the case's error
/// ([`MethodFamily::rank_engine`]).
pub type RankBuild<D> = Result<Box<dyn Distributed<D>>, CaseError>;

/// What the driver needs from a method. Implemented by the method's typed spec.
pub trait MethodFamily: Sized {
    /// One line for `meshless list`.
    const DESCRIPTION: &'static str;
    /// The `[method]` keys this method reads besides [`COMMON_KEYS`].
    const KEYS: &'static [&'static str];
    /// The scene features it runs.
    const FEATURES: &'static [Feature];
    /// When its neighbour lists are built: once on the reference configuration
    /// (total-Lagrangian), or from the current positions at every rate evaluation
    /// (updated-Lagrangian).
    const NEIGHBOURS: Rebuild = Rebuild::Once;
    /// Whether it has a kernel, and so reads [`KERNEL_KEYS`] (`h_over_dx` then required);
    /// the finite elements have none.
    const KERNEL: bool = true;
    /// Whether its kernel gradients take `method.correction` (false for a kernel method
    /// that builds its own consistent functions: moving least squares, reproducing or
    /// Krongauz–Belytschko functions, dual-support corrections).
    const CORRECTED: bool = true;
    /// The ghost layers a rank of a distributed run needs to evaluate its own particles'
    /// rates, along the graph the method partitions: the pair loops a rate evaluation
    /// chains over the neighbour lists (a neighbour's F, then its stress in the force,
    /// make two); one along the nodes a Galerkin node shares a point with. None for a
    /// method that does not run on several ranks.
    const HALO_LAYERS: Option<usize> = None;
    /// The GPU passes it compiles with a scene's constants.
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source];

    /// Checks of the case that concern this method (its keys, model, correction); by
    /// default none.
    fn validate(&self, _case: &Case) -> Result<(), Problem> {
        Ok(())
    }

    /// The method's part of the run plan; `gpu` selects the GPU passes.
    fn plan(&self, case: &Case, gpu: bool) -> Plan;

    /// The CPU reference engine (f64, rayon).
    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D>;

    /// The GPU engine (wgpu, f32).
    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D>;

    /// The buffers its GPU engine makes for `case` on `counts`, field by field, computed
    /// before any is made ([`crate::gpu::memory`]); None for a method without a GPU engine.
    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        _case: &Case,
        _counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        None
    }

    /// The engine of one rank of a distributed run: the method partitions the whole
    /// run's `reference` along its graph ([`RankStart::split`]) and sets up its CPU system on
    /// the rank's share; only a method with [`Self::HALO_LAYERS`] has one.
    fn rank_engine<D: EngineDim>(
        &self,
        case: &Case,
        _reference: Reference<D>,
        _start: RankStart<D>,
    ) -> RankBuild<D> {
        Err(case.invalid(
            "method.name",
            format!(
                "`{}` does not run on several ranks; run it on one",
                case.method.name
            ),
        ))
    }

    /// The smoothing length of every particle, where the method sets its own (the
    /// dual-support method's per-particle rules): a distributed run builds its halo on the
    /// lists of these, which reach every pair the method's supports hold. None: the
    /// case's kernel h ([`Reference::h`]).
    fn smoothing_lengths<D: Dim>(
        &self,
        _case: &Case,
        _reference: &Reference<D>,
    ) -> Result<Option<Vec<f64>>, CaseError> {
        Ok(None)
    }

    /// Why this spec has no GPU engine for `case`, as a phrase after the method's name
    /// (a key or the material that selects a variant the CPU alone runs), or None.
    fn gpu_refusal(&self, _case: &Case) -> Option<&'static str> {
        None
    }

    /// Whether this spec searches neighbours on the current configuration
    /// ([`Self::NEIGHBOURS`] other than once, unless a key selects such a variant).
    fn searches_current_configuration(&self) -> bool {
        Self::NEIGHBOURS != Rebuild::Once
    }

    /// The stretch-dependent part of a particle's signal speed in the method's CFL step
    /// (beyond |v|), with c_p the linear p-wave speed and F the particle's deformation
    /// gradient: it names the particle a collapse of the step is attributed to. By default
    /// none: the step Δt = cfl·Δx/(c_p + max|v|) of most methods does not depend on the
    /// stretch.
    fn stretch_signal_speed<D: Dim>(&self, _c_p: f64, _f: D::T) -> f64 {
        0.0
    }

    /// Whether this spec integrates over the cells between the particles of a lattice
    /// (elements, Gauss points or stress points of the cells): its boxes and cylinders
    /// are then sampled on the vertex lattice whatever `lattice` says, so that the cells
    /// span the shape the case names (on a cell-centred lattice they would stop Δx/2
    /// inside every face).
    fn lattice_cells(&self) -> bool {
        false
    }
    /// The p-wave speed that sets the method's CFL step: by default the material's
    /// ([`cfl_step`]).
    fn step_wave_speed(&self, mat: &Material) -> f64 {
        mat.p_wave_speed()
    }

    /// Whether the method accepts an incompressible material (ν = 0.5).
    fn accepts_incompressible(&self) -> bool {
        false
    }

    /// A warning for a combination of keys that runs but is known to give wrong answers
    /// on standard problems, with the reason and the key that fixes it; said at the start
    /// of every run and by `meshless check`.
    fn warning(&self, _case: &Case) -> Option<String> {
        None
    }
}

/// The check of a method that evaluates P = ∂ψ/∂F: the material must be a state model.
pub fn state_model(case: &Case) -> Result<(), Problem> {
    if case.material.model.is_rate_based() {
        return crate::core::check::fail(
            "material.model",
            format!(
                "`{}` evaluates the stress from F: use a state model ({}), not {}",
                case.method.name,
                crate::physics::material::MaterialModel::names_where(|m| !m.is_rate_based()
                    && m != crate::physics::material::MaterialModel::VonMisesPlastic),
                crate::core::check::toml_name(&case.material.model)
            ),
        );
    }
    Ok(())
}
