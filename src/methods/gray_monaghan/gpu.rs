//! Gray–Monaghan SPH on the GPU: its passes (`shaders/gray_monaghan/`) on the
//! updated-Lagrangian core of [`crate::methods::cores::ul::gpu`]. The CPU system
//! ([`super::system`]) is the reference it is checked against.

use super::GrayMonaghanSpec;
use crate::case::Case;
use crate::gpu::shaders::{
    BOUNDARY, CONTACT, Constants, EIGEN, INTEGRATE, KERNEL, LOADS, MECHANICS, OBJECTIVE, PART,
    PRESCRIBED, REFERENCE, RKPM, Source, VISCOSITY, source,
};
use crate::methods::cores::ul::gpu::{CORE, FLAT, REDUCE, RETURN, Scheme};

/// Per-particle quantities (σ/ρ², R, c, V, the correction) and the pair gather.
pub const PASSES: Source = source!(
    "gray_monaghan/gray_monaghan.wgsl",
    [
        KERNEL, MECHANICS, REFERENCE, BOUNDARY, EIGEN, OBJECTIVE, VISCOSITY, PART, RKPM, CORE
    ],
    flat = FLAT
);

/// The passes of a Gray–Monaghan scene.
pub const SHADERS: &[Source] = &[
    PASSES, CONTACT, LOADS, PRESCRIBED, INTEGRATE, REDUCE, RETURN,
];

/// The scheme of a case with the spec's constants: viscosity, artificial stress with
/// W(Δp) at Δp = the spacing, XSPH.
pub fn scheme(case: &Case, spec: &GrayMonaghanSpec) -> Scheme {
    let av = spec.artificial_viscosity;
    let stress = spec.artificial_stress;
    let w_dp = case.kernel(case.dim()).w(case.spacing);
    let constants = Constants::default()
        .u32("AV", u32::from(av.is_some()))
        .f32("AV_ALPHA", av.map_or(0.0, |a| a.alpha))
        .f32("AV_BETA", av.map_or(0.0, |a| a.beta))
        .f32("AV_ETA", av.map_or(0.0, |a| a.eta))
        .u32("AS", u32::from(stress.is_some()))
        .f32("AS_EPSILON", stress.map_or(0.0, |s| s.epsilon))
        .f32("AS_N", stress.map_or(0.0, |s| s.n))
        .f32("AS_W_DP", if stress.is_some() { w_dp } else { 1.0 })
        .u32("XSPH", u32::from(spec.xsph.is_some()))
        .f32("XSPH_EPSILON", spec.xsph.unwrap_or(0.0));
    Scheme {
        passes: PASSES,
        artificial_stress: stress.is_some(),
        pressure: false,
        free_surface: spec.free_surface,
        smoothing_length: spec.smoothing_length,
        constants,
    }
}
