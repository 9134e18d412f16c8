//! The GPU backend: wgpu compute shaders (WGSL) on storage buffers, f32.

pub mod context;
pub mod layout;
pub mod mixed;
pub mod neighbour;
pub mod program;
pub mod reduction;
pub mod shaders;
pub mod tlsph;

pub use context::{Gpu, GpuError};
pub use layout::GpuDim;
