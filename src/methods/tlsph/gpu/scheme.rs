//! The pass files of the total-Lagrangian GPU engine, the schemes of the methods it runs
//! (TLSPH's own here; the elastic potential's, corotated TLSPH's and dual-support SPH's
//! in their folders) and the layout of its buffers with the constants compiled from them.

use super::super::{TlsphForce, ViscosityGradient};
use crate::case::Case;
use crate::correction::CorrectionKind;
use crate::gpu::layout::Fields;
use crate::gpu::reduction;
use crate::gpu::reference::{self, Extras};
use crate::gpu::shaders::{
    BOUNDARY, CONTACT, CORRECTION, Constants, INTEGRATE, LOADS, MECHANICS, PAIR_OFFSETS,
    PRESCRIBED, REFERENCE, REVERSE_GRADIENTS, Source, VISCOSITY, Wgsl, source, wgsl,
};
use crate::material::Material;

/// Strain energy densities of the TLSPH models, for the reduction.
const ENERGY: Wgsl = wgsl!("tlsph/tlsph_energy.wgsl");

/// F, P (and ρ̇, Ṡ of the rate model) per particle.
pub const STRESS: Source = source!(
    "tlsph/tlsph.wgsl",
    [MECHANICS, REFERENCE],
    [
        ("y", false),
        ("pair", false),
        ("reference", false),
        ("d", true),
        ("kin", true)
    ]
);
/// Accelerations, artificial viscosity, boundary conditions; the reverse gradients of
/// the variational force (set-up).
pub const ACCEL: Source = source!(
    "tlsph/tlsph_accel.wgsl",
    [BOUNDARY, REFERENCE, VISCOSITY, REVERSE_GRADIENTS],
    [
        ("y", false),
        ("pair", true),
        ("reference", false),
        ("ext", false),
        ("kin", true),
        ("d", true)
    ]
);
/// Energies, momenta and checks of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, ENERGY, REFERENCE],
    [("y", false), ("kin", false), ("reference", false)]
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
pub struct TlScheme {
    /// Its per-particle pass file (entry point `stress`): [`STRESS`], or the method's own.
    /// It writes the kinematics H, P, F⁻ᵀ and ρ (and its own `kin_tensors`) and records
    /// failed particles in `status` (slot k for the quantity `checks[k]`).
    pub stress: Source,
    /// Its acceleration pass file (entry point `accel`).
    pub accel: Source,
    /// Its reduction (`reduce`, with the method's strain energy).
    pub reduce: Source,
    /// The pass file's set-up entry `reverse_gradients` fills ∇0W̃_ji of every pair (i, j)
    /// into the pair data (field GREV) from the index of the reverse pair (`rev`).
    pub reverse: bool,
    /// The hourglass control's α: the host fills its stiffness κ_ij into the pair data
    /// (field HGK), which the acceleration pass reads.
    pub hourglass: Option<f64>,
    /// Where the pair lists and gradients come from.
    pub lists: Lists,
    /// Its own compiled-in constants.
    pub constants: Constants,
    /// Its force derives from Σ_i ψ_i rather than Σ_i V_i ψ_i (the reference code's
    /// potential force): the strain energy weighs each ψ_i by 1 and the wave speed of the
    /// CFL step is c_p/√V_min.
    pub unit_weights: bool,
    /// Per-particle tensors its stress pass keeps in the kinematics besides H, P and F⁻ᵀ
    /// (field `K{name}`: corotated TLSPH's rotation R).
    pub kin_tensors: &'static [&'static str],
    /// What the kinematics' H = F − I is the excess of, for the outputs.
    pub frame: Frame,
    /// The quantities whose failure the stress pass records, one status slot each (the
    /// first particle, by `atomicMin`), as a blow-up names them.
    pub checks: &'static [&'static str],
}

/// The pair lists and corrected gradients of a scheme.
#[derive(Clone, Debug, PartialEq)]
pub enum Lists {
    /// The reference neighbours within the kernel's support and the case's correction.
    Kernel,
    /// Dual-support SPH's ([`crate::methods::dual_support::gpu::lists`]): the supports
    /// and dual-supports S_i ∪ S'_i with each particle's own h, g_ij/V_j (zero where
    /// j ∉ S_i), the hourglass stiffnesses of both sides of every pair (fields HGK and
    /// HGKR), and the host's model for the outputs.
    DualSupport(crate::methods::dual_support::DualSupportSpec),
}

/// What the kinematics' H = F − I measures, for snapshots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Frame {
    /// The deformation gradient F itself.
    Reference,
    /// The corotated gradient F̂ in the frame of the kinematics' rotation R (field `KR`):
    /// F = R F̂ (seed 000 §5.5).
    Corotated,
}

/// The failure TLSPH's stress pass records (slot 0).
pub const DET_F: &[&str] = &["det F (f32, GPU)"];

/// TLSPH's own force: eq 134, or the variational form, with the spec's viscosity.
pub fn scheme(spec: &super::super::TlsphSpec) -> TlScheme {
    let variational = spec.force == TlsphForce::Variational;
    TlScheme {
        stress: STRESS,
        accel: ACCEL,
        reduce: REDUCE,
        reverse: variational,
        hourglass: spec.hourglass,
        lists: Lists::Kernel,
        constants: viscosity(spec.artificial_viscosity.as_ref())
            .u32("HOURGLASS", u32::from(spec.hourglass.is_some()))
            .choice(
                "AV_GRADIENT",
                &["PUSHED_FORWARD", "REFERENCE"],
                usize::from(spec.viscosity_gradient == ViscosityGradient::Reference),
            )
            .choice(
                "FORCE",
                &["REVELES", "VARIATIONAL"],
                usize::from(variational),
            ),
        unit_weights: false,
        kin_tensors: &[],
        frame: Frame::Reference,
        checks: DET_F,
    }
}

/// The constants AV, AV_ALPHA, AV_BETA and AV_ETA of a Monaghan viscosity, if any.
pub fn viscosity(av: Option<&super::super::ArtificialViscosity>) -> Constants {
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
    pub fn new(
        n: usize,
        constrained: usize,
        dim: usize,
        rate: bool,
        pairs: usize,
        scheme: &TlScheme,
    ) -> Self {
        let dual = matches!(scheme.lists, Lists::DualSupport(_));
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
                .scalars("HGK", scheme.hourglass.is_some() || dual, pairs)
                .scalars("HGKR", dual, pairs),
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

/// The compiled-in constants of a scene's TLSPH passes with the scheme's own.
pub fn scene_constants(case: &Case, layout: &Layout, scheme: &TlScheme) -> Constants {
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
        .u32("PAIRS", u(layout.pair.field("G").count))
        .u32("BODIES", u(case.bodies.len()))
        .material(&material)
        .choice("CORRECTION", &["NONE", "SHEPARD", "LINEAR"], correction)
        .u32("REST_OFF", u(layout.state.offset("RHO")));
    [&layout.state, &layout.kin, &layout.pair, &layout.reference]
        .into_iter()
        .fold(constants, |c, fields| fields.constants(c))
}
