//! TLSPH from the elastic potential on the GPU: its force pass (`shaders/potential/`) on
//! the total-Lagrangian engine of [`crate::methods::cores::tl::gpu`], whose stress pass gives
//! F and P = ∂ψ/∂F. The CPU system ([`super::system`]) is the reference it is checked
//! against.

use super::system::unit_weight_wave_speed_scale;
use super::{PotentialForce, PotentialSpec};
use crate::gpu::layout::GpuDim;
use crate::gpu::shaders::{
    BOUNDARY, CONTACT, CORRECTION, INTEGRATE, MECHANICS, PAIR_OFFSETS, REFERENCE,
    REVERSE_GRADIENTS, Source, VISCOSITY, Wgsl, source, wgsl,
};
use crate::methods::cores::tl::gpu::{
    self as tl, DET_F, Frame, Lists, STRESS, TlScheme, viscosity,
};

/// The strain energy of the reduction (V_i ψ_i, or ψ_i for the reference code's force).
const ENERGY: Wgsl = wgsl!("potential/potential_energy.wgsl");

/// The reverse gradients (set-up) and the symmetrised forces of eq 148 with viscosity.
pub const ACCEL: Source = source!(
    "potential/potential.wgsl",
    [BOUNDARY, REFERENCE, VISCOSITY, REVERSE_GRADIENTS],
    // The buffers of TLSPH's force pass: it runs on TLSPH's engine.
    flat = tl::ACCEL.flat
);
/// Energies, momenta and checks of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, ENERGY, REFERENCE],
    [("y", false), ("kin", false), ("reference", false)]
);

/// The passes of an elastic-potential scene.
pub const SHADERS: &[Source] = &[
    STRESS,
    ACCEL,
    CONTACT,
    CORRECTION,
    INTEGRATE,
    PAIR_OFFSETS,
    REDUCE,
];

/// The potential's force with the spec's constants; the reference code's force weighs
/// each ψ_i by 1, with its CFL scale.
pub fn scheme<D: GpuDim>(spec: &PotentialSpec) -> TlScheme<D> {
    let reference_code = spec.force == PotentialForce::ReferenceCode;
    TlScheme {
        stress: STRESS,
        accel: ACCEL,
        reduce: REDUCE,
        reverse: true,
        hourglass: None,
        lists: Lists::Kernel,
        constants: viscosity(spec.artificial_viscosity.as_ref())
            .choice(
                "FORCE",
                &["CONSISTENT", "REFERENCE_CODE"],
                usize::from(reference_code),
            )
            .u32("HOURGLASS_DS", 0),
        unit_weights: reference_code.then_some(unit_weight_wave_speed_scale as fn(&[f64]) -> f64),
        kin_tensors: &[],
        frame: Frame::Reference,
        checks: DET_F,
    }
}
