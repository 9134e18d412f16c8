//! Host-side layout of GPU buffers.
//!
//! The solver passes use flat f32 arrays ([`Flat`]: DIM floats per vector, DIM² per
//! column-major tensor). The cell-list build reads typed `array<vecd>` positions
//! ([`GpuDim::HV`]: `vec2<f32>`, or `vec3<f32>` with its 16-byte storage stride).

use super::context::Gpu;
use crate::boundary::Boundary;
use crate::tensor::{D2, D3, Dim};
use bytemuck::Pod;

/// A dimension whose vectors can be laid out for the GPU.
pub trait GpuDim: Dim + Flat {
    /// `vec2<f32>`, or `vec3<f32>` padded to 16 bytes (the stride of `array<vec3<f32>>`).
    type HV: Pod + Send + Sync + Copy;
    /// The WGSL prelude defining `vecd`, `matd` and the tensor helpers.
    const PRELUDE: &'static str;

    fn v(v: Self::V) -> Self::HV;
}

impl GpuDim for D2 {
    type HV = [f32; 2];
    const PRELUDE: &'static str = include_str!("../../shaders/common/dim2.wgsl");

    fn v(v: glam::DVec2) -> [f32; 2] {
        [v.x as f32, v.y as f32]
    }
}

impl GpuDim for D3 {
    type HV = [f32; 4];
    const PRELUDE: &'static str = include_str!("../../shaders/common/dim3.wgsl");

    fn v(v: glam::DVec3) -> [f32; 4] {
        [v.x as f32, v.y as f32, v.z as f32, 0.0]
    }
}

/// Flat f32 layout used by the solver passes: DIM components per vector and DIM² per
/// tensor (column-major), no padding.
pub trait Flat: Dim {
    fn push_v(out: &mut Vec<f32>, v: Self::V);
    fn push_t(out: &mut Vec<f32>, t: Self::T);
    fn read_v(s: &[f32]) -> Self::V;
    fn read_t(s: &[f32]) -> Self::T;
}

impl Flat for D2 {
    fn push_v(out: &mut Vec<f32>, v: glam::DVec2) {
        out.extend([v.x as f32, v.y as f32]);
    }
    fn push_t(out: &mut Vec<f32>, t: glam::DMat2) {
        out.extend(t.to_cols_array().map(|c| c as f32));
    }
    fn read_v(s: &[f32]) -> glam::DVec2 {
        glam::DVec2::new(s[0].into(), s[1].into())
    }
    fn read_t(s: &[f32]) -> glam::DMat2 {
        glam::DMat2::from_cols_array(&[s[0], s[1], s[2], s[3]].map(f64::from))
    }
}

impl Flat for D3 {
    fn push_v(out: &mut Vec<f32>, v: glam::DVec3) {
        out.extend([v.x as f32, v.y as f32, v.z as f32]);
    }
    fn push_t(out: &mut Vec<f32>, t: glam::DMat3) {
        out.extend(t.to_cols_array().map(|c| c as f32));
    }
    fn read_v(s: &[f32]) -> glam::DVec3 {
        glam::DVec3::new(s[0].into(), s[1].into(), s[2].into())
    }
    fn read_t(s: &[f32]) -> glam::DMat3 {
        let mut c = [0.0; 9];
        for (c, s) in c.iter_mut().zip(s) {
            *c = f64::from(*s);
        }
        glam::DMat3::from_cols_array(&c)
    }
}

/// DIM-vectors as one flat f32 array.
pub fn flat_v<D: Flat>(vs: impl IntoIterator<Item = D::V>) -> Vec<f32> {
    let mut out = Vec::new();
    vs.into_iter().for_each(|v| D::push_v(&mut out, v));
    out
}

/// The `mask` (bit k: velocity component k prescribed) and `ext` (external acceleration,
/// DIM per particle) buffers of `shaders/common/boundary.wgsl` for n particles.
pub fn boundary_buffers<D: Flat>(
    gpu: &Gpu,
    boundary: &Boundary<D>,
    n: usize,
) -> (wgpu::Buffer, wgpu::Buffer) {
    let mut mask = vec![0u32; n];
    for &(i, m) in &boundary.constrained {
        mask[i as usize] = u32::from(m);
    }
    let mut ext = vec![D::zero(); n];
    for &(i, a) in &boundary.external {
        ext[i as usize] = a;
    }
    (
        gpu.storage("mask", &mask),
        gpu.storage("ext", &flat_v::<D>(ext)),
    )
}
