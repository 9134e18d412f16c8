//! TLSPH's own scheme on the total-Lagrangian GPU engine of
//! [`crate::methods::cores::tl::gpu`]: the pair force of eq 134, the variational one or
//! the plain one of seed 002 eq 21, with the spec's viscosity and hourglass control.

use super::{TlsphForce, TlsphSpec, ViscosityGradient};
use crate::core::correction::CorrectionKind;
use crate::gpu::layout::GpuDim;
use crate::methods::cores::tl::gpu::{
    ACCEL, DET_F, ForceReads, Frame, Lists, REDUCE, STRESS, TlScheme, viscosity,
};

/// TLSPH's own force: eq 134, the variational form or the plain one, with the spec's
/// viscosity, for a case with the correction `correction`.
pub fn scheme<D: GpuDim>(spec: &TlsphSpec, correction: CorrectionKind) -> TlScheme<D> {
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
                &["REVELES", "VARIATIONAL", "PLAIN"],
                match spec.force {
                    TlsphForce::Reveles => 0,
                    TlsphForce::Variational => 1,
                    TlsphForce::Plain => 2,
                },
            )
            .u32(
                "REPRODUCES_CONSTANTS",
                u32::from(correction.reproduces_constants()),
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
