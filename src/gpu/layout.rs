//! Host-side layout of GPU buffers: f32 vectors and tensors in WGSL storage layout.
//!
//! 2D: `vec2<f32>` (8 bytes) and `mat2x2<f32>` (16 bytes). 3D: `vec3<f32>` has a stride
//! of 16 bytes in storage arrays and `mat3x3<f32>` is three 16-byte columns (48 bytes).

use crate::tensor::{D2, D3, Dim};
use bytemuck::Pod;

/// A dimension whose vectors and tensors can be laid out for the GPU.
pub trait GpuDim: Dim {
    /// `vec2<f32>` or padded `vec3<f32>`.
    type HV: Pod + Send + Sync + Copy;
    /// `mat2x2<f32>` or padded `mat3x3<f32>` (column-major).
    type HT: Pod + Send + Sync + Copy;
    /// The WGSL prelude defining `vecd`, `matd` and the tensor helpers.
    const PRELUDE: &'static str;

    fn v(v: Self::V) -> Self::HV;
    fn t(t: Self::T) -> Self::HT;
    fn v_back(v: Self::HV) -> Self::V;
    fn t_back(t: Self::HT) -> Self::T;
}

impl GpuDim for D2 {
    type HV = [f32; 2];
    type HT = [f32; 4];
    const PRELUDE: &'static str = include_str!("../../shaders/dim2.wgsl");

    fn v(v: glam::DVec2) -> [f32; 2] {
        [v.x as f32, v.y as f32]
    }
    fn t(t: glam::DMat2) -> [f32; 4] {
        t.to_cols_array().map(|c| c as f32)
    }
    fn v_back(v: [f32; 2]) -> glam::DVec2 {
        glam::DVec2::new(v[0] as f64, v[1] as f64)
    }
    fn t_back(t: [f32; 4]) -> glam::DMat2 {
        glam::DMat2::from_cols_array(&t.map(f64::from))
    }
}

impl GpuDim for D3 {
    type HV = [f32; 4];
    type HT = [f32; 12];
    const PRELUDE: &'static str = include_str!("../../shaders/dim3.wgsl");

    fn v(v: glam::DVec3) -> [f32; 4] {
        [v.x as f32, v.y as f32, v.z as f32, 0.0]
    }
    fn t(t: glam::DMat3) -> [f32; 12] {
        let c = t.to_cols_array();
        let mut out = [0.0f32; 12];
        for col in 0..3 {
            for row in 0..3 {
                out[4 * col + row] = c[3 * col + row] as f32;
            }
        }
        out
    }
    fn v_back(v: [f32; 4]) -> glam::DVec3 {
        glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
    }
    fn t_back(t: [f32; 12]) -> glam::DMat3 {
        let mut c = [0.0f64; 9];
        for col in 0..3 {
            for row in 0..3 {
                c[3 * col + row] = t[4 * col + row] as f64;
            }
        }
        glam::DMat3::from_cols_array(&c)
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
