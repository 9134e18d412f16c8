//! The GPU backend: wgpu compute shaders (WGSL) on storage buffers, f32.

pub mod context;
pub mod layout;
pub mod neighbour;
pub mod shaders;

pub use context::{Gpu, GpuError};
pub use layout::GpuDim;
pub mod tlsph;
