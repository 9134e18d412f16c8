//! TLSPH's own scheme on the total-Lagrangian GPU engine of
//! [`crate::methods::cores::tl::gpu`]: the pair force of eq 134 or the variational
//! one, with the spec's viscosity and hourglass control.

use super::{TlsphForce, TlsphSpec, ViscosityGradient};
use crate::gpu::layout::GpuDim;
use crate::methods::cores::tl::gpu::{
    ACCEL, DET_F, ForceReads, Frame, Lists, REDUCE, STRESS, TlScheme, viscosity,
};

/// TLSPH's own force: eq 134, or the variational form, with the spec's viscosity.
pub fn scheme<D: GpuDim>(spec: &TlsphSpec) -> TlScheme<D> {
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
        unit_weights: None,
        kin_tensors: &[],
        frame: Frame::Reference,
        checks: DET_F,
        reads: ForceReads {
            h: spec.hourglass.is_some(),
            viscosity: spec.artificial_viscosity.is_some(),
        },
    }
}
