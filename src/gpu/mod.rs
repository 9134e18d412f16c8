//! The GPU backend's shared machinery: wgpu compute shaders (WGSL) on storage buffers,
//! f32. The methods' GPU engines (`methods::<method>::gpu`) stand on it.

pub mod context;
pub mod layout;
pub mod neighbour;
pub mod program;
pub mod reduction;
pub mod reference;
pub mod shaders;

pub use context::{Gpu, GpuError};
pub use layout::GpuDim;

use crate::scene::{Case, CaseError};
use shaders::Constants;
use thiserror::Error;

/// Refuses reference positions and initial velocities beyond the f32 range of the
/// device, naming the body whose geometry or initial velocity gives them.
pub fn check_f32_particles<D: crate::tensor::Dim>(
    case: &Case,
    x0: &[D::V],
    v0: &[D::V],
    body: &[u32],
) -> Result<(), CaseError> {
    let beyond = |v: &D::V| D::to3(*v).iter().any(|&c| !(c as f32).is_finite());
    for (key, what, values) in [
        ("geometry", "position", x0),
        ("initial_velocity", "velocity", v0),
    ] {
        if let Some(i) = values.iter().position(beyond) {
            return Err(case.invalid(
                format!("body.{}.{key}", body[i]),
                format!(
                    "particle {i} has the {what} {:?}, beyond the f32 range (3.4e38) of the \
                     GPU; run with --backend cpu (f64), or express the case in other units",
                    D::to3(values[i])
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses scene constants that f32 cannot hold (a value valid in f64, such as E = 1e39
/// Pa or a density of 1e-46), naming the case key they come from.
pub fn check_f32_range(case: &Case, constants: &Constants) -> Result<(), CaseError> {
    let Some((name, value)) = constants.out_of_f32_range() else {
        return Ok(());
    };
    let key = match name {
        "RHO0" => "material.density",
        "MU" | "LAMBDA" | "BULK" | "C_P" | "C_S" => "material.youngs_modulus",
        "YIELD" => "material.yield_stress",
        "HARDENING" => "material.hardening_modulus",
        "EPS2" | "EPS4" => "method.jst",
        n if n.starts_with("AV_") => "method.artificial_viscosity",
        n if n.starts_with("AS_") => "method.artificial_stress",
        n if n.starts_with("XSPH_") => "method.xsph",
        _ => "spacing",
    };
    Err(case.invalid(
        key,
        format!(
            "gives the GPU constant {name} = {value:e}, which f32 cannot hold (normal f32 \
             magnitudes lie between 1.2e-38 and 3.4e38); run with --backend cpu (f64), or \
             express the case in other units"
        ),
    ))
}

/// Why a GPU engine could not be set up: the case, or the device.
#[derive(Debug, Error)]
pub enum SetupError {
    #[error(transparent)]
    Case(#[from] CaseError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
}
