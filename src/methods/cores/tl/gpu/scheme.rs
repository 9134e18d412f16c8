//! The pass files of the total-Lagrangian GPU engine, the scheme a method runs on it
//! ([`TlScheme`]: TLSPH's, the elastic potential's, corotated TLSPH's and
//! dual-support SPH's in their folders, each supplying its own hooks: host-built lists,
//! outputs in a rotated frame, the CFL scale of a unit-weight energy), the elastic
//! potential's force pass and scheme, which two families run ([`POTENTIAL`],
//! [`potential`]), and the layout of its buffers with the constants compiled from them.

use crate::case::{Case, CaseError};
use crate::core::correction::CorrectionKind;
use crate::core::neighbour::Csr;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::gpu::layout::{Fields, GpuDim};
use crate::gpu::reduction;
use crate::gpu::reference::{self, Extras};
use crate::gpu::shaders::{
    BOUNDARY, CONTACT, CORRECTION, Constants, EIGEN, INTEGRATE, LOADS, MECHANICS, OBJECTIVE,
    PAIR_OFFSETS, PART, PRESCRIBED, REFERENCE, Source, VISCOSITY, Wgsl, source, wgsl,
};
use crate::methods::cores::tl::{self, TlState};
use crate::physics::material::Material;
use crate::physics::viscosity::ArtificialViscosity;
use crate::reference::Reference;

/// Strain energy densities of the TLSPH models, for the reduction.
const ENERGY: Wgsl = wgsl!("tl/tlsph_energy.wgsl");

/// F, P (and ρ̇, Ṡ of the rate model) per particle.
pub const STRESS: Source = source!(
    "tl/tlsph.wgsl",
    [MECHANICS, EIGEN, OBJECTIVE, REFERENCE, PART],
    [
        ("y", false),
        ("pair", false),
        ("reference", false),
        ("d", true),
        ("kin", true)
    ]
);
/// Accelerations, artificial viscosity, boundary conditions.
pub const ACCEL: Source = source!(
    "tl/tlsph_accel.wgsl",
    [BOUNDARY, REFERENCE, VISCOSITY, PART],
    [
        ("y", false),
        ("pair", false),
        ("reference", false),
        ("ext", false),
        ("kin", true),
        ("d", true)
    ]
);
/// Energies, momenta and checks of a state.
pub const REDUCE: Source = reduction::pass(&[MECHANICS, ENERGY, REFERENCE, PART]);
/// The symmetrised forces of eq 148 from Σ_i w_i ψ(F_i) with viscosity and boundary
/// conditions: the elastic potential's force pass
/// (`shaders/potential/`) on TLSPH's buffers, which dual-support SPH runs too.
pub const POTENTIAL: Source = source!(
    "potential/potential.wgsl",
    [BOUNDARY, REFERENCE, VISCOSITY, PART],
    flat = ACCEL.flat
);

/// The passes compiled with a TLSPH scene's constants ([`scene_constants`]).
pub const SHADERS: &[Source] = &[
    STRESS,
    ACCEL,
    CONTACT,
    LOADS,
    PRESCRIBED,
    CORRECTION,
    INTEGRATE,
    PAIR_OFFSETS,
    REDUCE,
];

/// The force of one total-Lagrangian method on this engine: TLSPH's own, another method's
/// on the same stress pass (the elastic potential's), or a method's with its own
/// per-particle pass (corotated TLSPH's shape matching).
pub struct TlScheme<D: GpuDim> {
    /// Its per-particle pass file (entry point `stress`): [`STRESS`], or the method's own.
    /// It writes the kinematics H, P, F⁻ᵀ and ρ (and its own `kin_tensors`) and records
    /// failed particles in `status` (slot k for the quantity `checks[k]`).
    pub stress: Source,
    /// Its acceleration pass file (entry point `accel`).
    pub accel: Source,
    /// Its reduction (`reduce`, with the method's strain energy).
    pub reduce: Source,
    /// The set-up copies ∇0W̃_ji of every pair (i, j) into the pair data (field GREV) from
    /// the gradient of the reverse pair, for a force pass that reads both.
    pub reverse: bool,
    /// The hourglass control's α: the host fills its stiffness κ_ij into the pair data
    /// (field HGK), which the acceleration pass reads.
    pub hourglass: Option<f64>,
    /// Where the pair lists and gradients come from.
    pub lists: Lists<D>,
    /// Its own compiled-in constants.
    pub constants: Constants,
    /// Some where its force derives from Σ_i ψ_i rather than Σ_i V_i ψ_i (the reference
    /// code's potential force): the strain energy weighs each ψ_i by 1, and the factor on
    /// c_p in the wave speed of the CFL step is this function of the volumes V_i.
    pub unit_weights: Option<fn(&[f64]) -> f64>,
    /// Per-particle tensors its stress pass keeps in the kinematics besides H, P and F⁻ᵀ
    /// (field `K{name}`: corotated TLSPH's rotation R).
    pub kin_tensors: &'static [&'static str],
    /// What the kinematics' H = F − I is the excess of, for the outputs.
    pub frame: Frame<D>,
    /// The quantities whose failure the stress pass records, one status slot each (the
    /// first particle, by `atomicMin`), as a blow-up names them.
    pub checks: &'static [&'static str],
    /// The kinematics besides P its force pass reads, which the stress pass of a rate
    /// evaluation writes.
    pub reads: ForceReads,
}

/// The kinematics besides P (and a scheme's own tensors) that a force pass reads: H (an
/// hourglass control), and F⁻ᵀ and ρ (a viscosity). The stress pass of a rate evaluation
/// stores these alone; the one the outputs and the reduction read stores them all
/// ([`scene_constants`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ForceReads {
    pub h: bool,
    pub viscosity: bool,
}

/// The passes of a scheme on the reference neighbours with contact and without loads
/// (the elastic potential's, corotated TLSPH's): its `stress`, `accel` and `reduce`, and
/// the core's set-up and integrators.
pub const fn kernel_passes(stress: Source, accel: Source, reduce: Source) -> [Source; 7] {
    [
        stress,
        accel,
        CONTACT,
        CORRECTION,
        INTEGRATE,
        PAIR_OFFSETS,
        reduce,
    ]
}

/// The elastic potential's force ([`POTENTIAL`]) on TLSPH's stress pass, with the
/// reduction `reduce`, on `lists`, with the viscosity `av`: the reference code's force
/// where `unit_weights` is some (its CFL scale, [`TlScheme::unit_weights`]), else the
/// consistent one; `dual_support_hourglass`, dual-support SPH's hourglass term (eq 28)
/// of the stiffnesses of the host's lists.
pub fn potential<D: GpuDim>(
    reduce: Source,
    lists: Lists<D>,
    av: Option<&ArtificialViscosity>,
    unit_weights: Option<fn(&[f64]) -> f64>,
    dual_support_hourglass: bool,
) -> TlScheme<D> {
    TlScheme {
        stress: STRESS,
        accel: POTENTIAL,
        reduce,
        reverse: true,
        hourglass: None,
        lists,
        constants: viscosity(av)
            .choice(
                "FORCE",
                &["CONSISTENT", "REFERENCE_CODE"],
                usize::from(unit_weights.is_some()),
            )
            .u32("HOURGLASS_DS", u32::from(dual_support_hourglass)),
        unit_weights,
        kin_tensors: &[],
        frame: Frame::Reference,
        checks: DET_F,
        reads: ForceReads {
            h: dual_support_hourglass,
            viscosity: av.is_some(),
        },
    }
}

/// The pair lists and corrected gradients of a scheme.
pub enum Lists<D: GpuDim> {
    /// The reference neighbours within the kernel's support and the case's correction.
    Kernel,
    /// Lists and pair data the scheme's family builds on the host from the case and its
    /// reference configuration (dual-support SPH's supports and dual-supports).
    Host(HostListing<D>),
}

/// The builder of a scheme's host lists ([`Lists::Host`]).
pub type HostListing<D> = Box<dyn Fn(&Case, &Reference<D>) -> Result<HostLists<D>, CaseError>>;

/// Pair lists built on the host with their per-pair data: the gradients written into
/// field G, the hourglass stiffnesses of both sides of every pair (fields HGK and HGKR),
/// and the host's model the snapshots take their f64 outputs from.
pub struct HostLists<D: GpuDim> {
    pub csr: Csr,
    /// The gradients of every pair, in `csr` order.
    pub g: Vec<D::V>,
    /// The hourglass stiffness k_ij of every pair and k_ji of its reverse.
    pub hgk: Vec<f32>,
    pub hgk_rev: Vec<f32>,
    /// Some stiffness is not zero: the hourglass force does work.
    pub hourglass: bool,
    pub model: Box<dyn HostModel<D>>,
}

/// The host's f64 model of a scheme with host lists, which the snapshots come from.
pub trait HostModel<D: GpuDim> {
    /// The snapshot of state y (its u and v) of the reference configuration r.
    fn snapshot<'a>(&'a self, y: TlState<D>, r: &'a Reference<D>) -> Snapshot<'a, D>;
}

/// What the kinematics' H = F − I measures, for snapshots.
pub enum Frame<D: GpuDim> {
    /// The deformation gradient F itself.
    Reference,
    /// The corotated gradient F̂ in the frame of the kinematics' rotation R (field `KR`):
    /// F = R F̂ (seed 000 §5.5); the family's outputs of the material, the volumes, R and
    /// F̂.
    Corotated(Outputs<D>),
}

/// A family's outputs (F, σ, the strain energy) from the material, the volumes V_i, the
/// rotations R_i and the corotated gradients F̂_i.
pub type Outputs<D> = fn(&Material, &[f64], &[<D as Dim>::T], &[<D as Dim>::T]) -> tl::Fields<D>;

/// The failure TLSPH's stress pass records (slot 0).
pub const DET_F: &[&str] = &["det F (f32, GPU)"];

/// The constants AV, AV_ALPHA, AV_BETA and AV_ETA of a Monaghan viscosity, if any.
pub fn viscosity(av: Option<&ArtificialViscosity>) -> Constants {
    Constants::default()
        .u32("AV", u32::from(av.is_some()))
        .f32("AV_ALPHA", av.map_or(0.0, |a| a.alpha))
        .f32("AV_BETA", av.map_or(0.0, |a| a.beta))
        .f32("AV_ETA", av.map_or(0.0, |a| a.eta))
}

/// The flat buffers of a TLSPH scene, each described once ([`Fields`]): the state
/// [u | v | ρ − ρ0 | S] (ρ and S for the rate model only), the kinematics
/// [H = F − I | P | F⁻ᵀ | ρ | power | viscous dissipation | the scheme's own tensors |
/// the constrained particles' reactions], the per-pair data
/// [∇0W̃ | X_j − X_i | ∇0W̃_ji for the schemes that read it] and the reference
/// configuration.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub dim: usize,
    pub rate: bool,
    pub state: Fields,
    pub kin: Fields,
    pub pair: Fields,
    pub reference: Fields,
}

impl Layout {
    /// The layout of n particles, `constrained` of them with prescribed components, and
    /// `pairs` neighbour pairs.
    pub fn new<D: GpuDim>(
        n: usize,
        constrained: usize,
        dim: usize,
        rate: bool,
        pairs: usize,
        scheme: &TlScheme<D>,
    ) -> Self {
        let host = matches!(scheme.lists, Lists::Host(_));
        let kin = Fields::new("K", dim)
            .tensors("F", true, n)
            .tensors("P", true, n)
            .tensors("FIT", true, n)
            .scalars("RHO", true, n)
            .scalars("POW", true, n)
            .scalars("DIS", true, n);
        let kin = scheme
            .kin_tensors
            .iter()
            .fold(kin, |k, &name| k.tensors(name, true, n));
        let kin = reduction::with_reactions(kin, constrained);
        Self {
            n,
            dim,
            rate,
            state: Fields::new("", dim)
                .vectors("U", true, n)
                .vectors("V", true, n)
                .scalars("RHO", rate, n)
                .tensors("S", rate, n),
            kin,
            pair: Fields::new("P", dim)
                .vectors("G", true, pairs)
                .vectors("DX", true, pairs)
                .vectors("GREV", scheme.reverse, pairs)
                .scalars("HGK", scheme.hourglass.is_some() || host, pairs)
                .scalars("HGKR", host, pairs),
            reference: reference::fields(n, constrained, dim, EXTRAS),
        }
    }
}

/// The reference fields the TLSPH passes read besides X and V: the lo part of X, for the
/// exact pair offsets.
pub(super) const EXTRAS: Extras = Extras {
    lo: true,
    centred: false,
};

/// The compiled-in constants of a scene's TLSPH passes with the scheme's own: those of
/// its rate evaluations, whose stress pass stores the kinematics the force pass reads
/// (KEEP_H, KEEP_AV from [`TlScheme::reads`]), or with `every`, those of the stress pass
/// the outputs and the reduction read, which stores them all.
pub fn scene_constants<D: GpuDim>(
    case: &Case,
    layout: &Layout,
    scheme: &TlScheme<D>,
    every: bool,
) -> Constants {
    let material = Material::new(&case.material);
    let kernel = case.kernel(layout.dim);
    let correction = match case.method.correction {
        CorrectionKind::None => 0,
        CorrectionKind::Shepard => 1,
        CorrectionKind::RandlesLibersky | CorrectionKind::Rkpm | CorrectionKind::Cgck => 2,
    };
    let u = |x: usize| x as u32;
    let constants = scheme
        .constants
        .clone()
        .kernel(&kernel)
        .u32("N", u(layout.n))
        .u32("BODIES", u(case.bodies.len()))
        .material(&material)
        .choice("CORRECTION", &["NONE", "SHEPARD", "LINEAR"], correction)
        .u32("REST_OFF", u(layout.state.offset("RHO")))
        .u32("KEEP_H", u32::from(every || scheme.reads.h))
        .u32("KEEP_AV", u32::from(every || scheme.reads.viscosity));
    [&layout.state, &layout.kin, &layout.pair, &layout.reference]
        .into_iter()
        .fold(constants, |c, fields| fields.constants(c))
}
