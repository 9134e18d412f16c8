//! Godunov SPH on the GPU: its passes (`shaders/godunov/`) on the updated-Lagrangian core
//! of [`crate::methods::cores::ul::gpu`]. The CPU system ([`super::system`]) is the reference it
//! is checked against.

use super::GodunovSpec;
use crate::gpu::shaders::{
    BOUNDARY, CONTACT, Constants, EIGEN, INTEGRATE, KERNEL, LOADS, MECHANICS, OBJECTIVE, PART,
    PRESCRIBED, REFERENCE, RKPM, Source, source,
};
use crate::methods::cores::ul::gpu::{CORE, FLAT, REDUCE, RETURN, Scheme};

/// Per-particle quantities (σ, p, Z, V, the correction) and the Riemann pair gather.
pub const PASSES: Source = source!(
    "godunov/godunov.wgsl",
    [
        KERNEL, MECHANICS, REFERENCE, BOUNDARY, EIGEN, OBJECTIVE, PART, RKPM, CORE
    ],
    flat = FLAT
);

/// The passes of a Godunov scene.
pub const SHADERS: &[Source] = &[
    PASSES, CONTACT, LOADS, PRESCRIBED, INTEGRATE, REDUCE, RETURN,
];

/// The scheme of a spec: no constants of its own.
pub fn scheme(spec: &GodunovSpec) -> Scheme {
    Scheme {
        passes: PASSES,
        artificial_stress: false,
        pressure: true,
        free_surface: spec.free_surface,
        smoothing_length: spec.smoothing_length,
        constants: Constants::default(),
    }
}
