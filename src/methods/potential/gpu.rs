//! TLSPH from the elastic potential on the GPU: the force pass of `shaders/potential/`
//! ([`POTENTIAL`], which the core holds, as dual-support SPH runs it too) on the
//! total-Lagrangian engine of [`crate::methods::cores::tl::gpu`], whose stress pass gives
//! F and P = ∂ψ/∂F, and the reduction of its strain energy. The CPU system
//! ([`super::system`]) is the reference it is checked against.

use super::system::unit_weight_wave_speed_scale;
use super::{PotentialForce, PotentialSpec};
use crate::gpu::layout::GpuDim;
use crate::gpu::reduction;
use crate::gpu::shaders::{MECHANICS, PART, REFERENCE, Source, Wgsl, wgsl};
use crate::methods::cores::tl::gpu::{self as tl, Lists, POTENTIAL, STRESS, TlScheme};

/// The strain energy of the reduction (V_i ψ_i, or ψ_i for the reference code's force).
const ENERGY: Wgsl = wgsl!("potential/potential_energy.wgsl");

/// Energies, momenta and checks of a state.
pub const REDUCE: Source = reduction::pass(&[MECHANICS, ENERGY, REFERENCE, PART]);

/// The passes of an elastic-potential scene: TLSPH's stress pass and the potential's
/// force pass ([`POTENTIAL`]).
pub const SHADERS: &[Source] = &tl::kernel_passes(STRESS, POTENTIAL, REDUCE);

/// The potential's force with the spec's viscosity on the reference neighbours; the
/// reference code's force weighs each ψ_i by 1, with its CFL scale.
pub fn scheme<D: GpuDim>(spec: &PotentialSpec) -> TlScheme<D> {
    let unit_weights = (spec.force == PotentialForce::ReferenceCode)
        .then_some(unit_weight_wave_speed_scale as fn(&[f64]) -> f64);
    let av = spec.artificial_viscosity.as_ref();
    tl::potential(REDUCE, Lists::Kernel, av, unit_weights, false)
}
