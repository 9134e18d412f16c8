//! The GPU backend's shared machinery: wgpu compute shaders (WGSL) on storage buffers,
//! f32. The methods' GPU engines (`methods::<method>::gpu`) stand on it.

pub mod context;
pub mod layout;
pub mod neighbour;
pub mod program;
pub mod reduction;
pub mod shaders;

pub use context::{Gpu, GpuError};
pub use layout::GpuDim;

use crate::scene::CaseError;
use thiserror::Error;

/// Why a GPU engine could not be set up: the case, or the device.
#[derive(Debug, Error)]
pub enum SetupError {
    #[error(transparent)]
    Case(#[from] CaseError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
}
