//! Corotated TLSPH on the GPU: its shape-matching pass and its force pass
//! (`shaders/corotated/`) on the total-Lagrangian engine of [`crate::methods::cores::tl::gpu`].
//! The CPU system ([`super::system`]) is the reference it is checked against.

use super::{CorotatedForce, CorotatedSpec, outputs};
use crate::gpu::layout::GpuDim;
use crate::gpu::shaders::{
    BOUNDARY, KERNEL, MECHANICS, PART, REFERENCE, Source, VISCOSITY, source,
};
use crate::methods::cores::tl::gpu::{
    self as tl, ForceReads, Frame, Lists, REDUCE, TlScheme, viscosity,
};

/// Per particle: shape matching A_i and its rotation R_i (eq 151), the corotated gradient
/// F̂_i (eqs 152–153), P̂_i = P(F̂_i), R_i F̂_i⁻ᵀ and ρ0/det F̂_i.
pub const STRESS: Source = source!(
    "corotated/corotated.wgsl",
    [KERNEL, MECHANICS, REFERENCE, PART],
    [
        ("y", false),
        ("pair", false),
        ("reference", false),
        ("kin", true)
    ]
);
/// The forces R_i P̂_i ∇0W_ij − R_j P̂_j ∇0W_ji (variational) or
/// ½(R_i + R_j)(P̂_i + P̂_j)∇0W_ij (eqs 154–155 as the reference code writes them) with
/// viscosity, boundary conditions.
pub const ACCEL: Source = source!(
    "corotated/corotated_accel.wgsl",
    [BOUNDARY, REFERENCE, VISCOSITY, PART],
    // The buffers of TLSPH's force pass: it runs on TLSPH's engine.
    flat = tl::ACCEL.flat
);

/// The passes of a corotated scene (the strain energy Σ V ψ(F̂) is TLSPH's reduction of
/// the kinematics' H, here F̂ − I).
pub const SHADERS: &[Source] = &tl::kernel_passes(STRESS, ACCEL, REDUCE);

/// What the shape-matching pass records: det F̂ ≤ 0 (slot 0), and A_i without a rotation
/// as its polar factor (slot 1: singular in 2D; det A_i ≤ 0 or no convergence in 3D).
const CHECKS: &[&str] = &[
    "det F̂ (f32, GPU)",
    "det R (shape matching: A_i has no rotation as its polar factor; f32, GPU)",
];

/// Corotated TLSPH with the spec's force and viscosity: its own per-particle pass, which
/// keeps R_i in the kinematics (`KR`) beside F̂_i − I, P̂_i, R_i F̂_i⁻ᵀ and ρ_i; the
/// variational force reads the reverse gradients ∇0W_ji (field GREV); its outputs are
/// those of R_i and F̂_i ([`outputs`]).
pub fn scheme<D: GpuDim>(spec: &CorotatedSpec) -> TlScheme<D> {
    let variational = spec.force == CorotatedForce::Variational;
    TlScheme {
        stress: STRESS,
        accel: ACCEL,
        reduce: REDUCE,
        reverse: variational,
        hourglass: None,
        lists: Lists::Kernel,
        constants: viscosity(spec.artificial_viscosity.as_ref()).choice(
            "FORCE",
            &["REFERENCE_CODE", "VARIATIONAL"],
            usize::from(variational),
        ),
        unit_weights: None,
        kin_tensors: &["R"],
        frame: Frame::Corotated(outputs::<D>),
        checks: CHECKS,
        reads: ForceReads {
            h: false,
            viscosity: spec.artificial_viscosity.is_some(),
        },
    }
}
