//! Godunov SPH on the GPU: its passes (`shaders/godunov/`) on the updated-Lagrangian core
//! of [`crate::methods::ul::gpu`]. The CPU system ([`super::system`]) is the reference it
//! is checked against.

use crate::gpu::profile::{NONE, Traffic, count, joined, loads};
use crate::gpu::shaders::{
    BOUNDARY, CONTACT, Constants, INTEGRATE, KERNEL, LOADS, MECHANICS, PRESCRIBED, REFERENCE,
    Source, source,
};
use crate::methods::ul::gpu::{
    CORE, FLAT, PARTICLE_CORE, POWER, RATES_CORE, REDUCE, STATUS, Scheme, scheme_bytes,
};

/// The core's part of `particle` and the method's: ρ − ρ0, S in; σ, p, Z = ρc out.
const PARTICLE: [Traffic; 10] = joined(
    PARTICLE_CORE,
    [
        count("y", [0, 0, 1], NONE),
        count("kin", [2, 0, 1], NONE),
        STATUS,
    ],
);
/// The core's part of `rates` and the method's: σ, p, Z of both particles.
const RATES: [Traffic; 11] = joined(RATES_CORE, [loads("kin", [2, 0, 1], NONE), POWER]);

/// Per-particle quantities (σ, p, Z, V, the correction) and the Riemann pair gather.
pub const PASSES: Source = source!(
    "godunov/godunov.wgsl",
    [KERNEL, MECHANICS, REFERENCE, BOUNDARY, CORE],
    flat = FLAT,
    &scheme_bytes(&PARTICLE, &RATES)
);

/// The passes of a Godunov scene.
pub const SHADERS: &[Source] = &[PASSES, CONTACT, LOADS, PRESCRIBED, INTEGRATE, REDUCE];

/// The scheme: no constants of its own.
pub fn scheme() -> Scheme {
    Scheme {
        passes: PASSES,
        artificial_stress: false,
        pressure: true,
        constants: Constants::default(),
    }
}
