//! Host-side layout of GPU buffers.
//!
//! The solver passes use flat f32 arrays ([`Flat`]: DIM floats per vector, DIM² per
//! column-major tensor). A buffer holding several fields is described once by
//! [`Fields`], which gives the host its offsets and its encode/decode, and the shaders
//! the same offsets as `{PREFIX}{NAME}_OFF` constants.

use super::shaders::Constants;
use crate::core::tensor::{D2, D3, Dim};

/// A dimension whose vectors can be laid out for the GPU.
pub trait GpuDim: Dim + Flat {
    /// The WGSL prelude defining `vecd`, `matd` and the tensor helpers.
    const PRELUDE: &'static str;
}

impl GpuDim for D2 {
    const PRELUDE: &'static str = include_str!("../../shaders/common/dim2.wgsl");
}

impl GpuDim for D3 {
    const PRELUDE: &'static str = include_str!("../../shaders/common/dim3.wgsl");
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

/// One field of a [`Fields`] buffer: `count` items of `width` floats from `offset`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    pub name: &'static str,
    pub offset: usize,
    pub count: usize,
    pub width: usize,
}

/// U, V, RHO and S of a solid's state ([`Fields::read_solid`]).
pub type Solid<D> = (
    Vec<<D as Dim>::V>,
    Vec<<D as Dim>::V>,
    Vec<f64>,
    Vec<<D as Dim>::T>,
);

/// The fields of one flat f32 buffer, laid end to end in the order they are declared.
/// A field declared absent (`present = false`) takes no room but keeps its offset
/// constant, so that a shader compiled for every variant still names it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fields {
    prefix: &'static str,
    dim: usize,
    fields: Vec<Field>,
    len: usize,
}

impl Fields {
    /// An empty buffer whose offset constants are named `{prefix}{NAME}_OFF`.
    pub fn new(prefix: &'static str, dim: usize) -> Self {
        Self {
            prefix,
            dim,
            fields: Vec::new(),
            len: 0,
        }
    }

    /// `count` items of `width` floats, if `present`.
    pub fn block(mut self, name: &'static str, present: bool, count: usize, width: usize) -> Self {
        let count = if present { count } else { 0 };
        self.fields.push(Field {
            name,
            offset: self.len,
            count,
            width,
        });
        self.len += count * width;
        self
    }

    /// `count` scalars.
    pub fn scalars(self, name: &'static str, present: bool, count: usize) -> Self {
        self.block(name, present, count, 1)
    }

    /// `count` DIM-vectors.
    pub fn vectors(self, name: &'static str, present: bool, count: usize) -> Self {
        let dim = self.dim;
        self.block(name, present, count, dim)
    }

    /// `count` column-major DIM×DIM tensors.
    pub fn tensors(self, name: &'static str, present: bool, count: usize) -> Self {
        let dim = self.dim;
        self.block(name, present, count, dim * dim)
    }

    /// The field `name`. Layouts are written in code, so a name it lacks is a bug.
    pub fn field(&self, name: &str) -> &Field {
        self.fields
            .iter()
            .find(|f| f.name == name)
            .unwrap_or_else(|| panic!("layout {} has no field {name}", self.prefix))
    }

    /// The offset of field `name` (f32 entries).
    pub fn offset(&self, name: &str) -> usize {
        self.field(name).offset
    }

    /// Whether field `name` takes room.
    pub fn has(&self, name: &str) -> bool {
        self.field(name).count > 0
    }

    /// Length of the buffer (f32 entries).
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Length in bytes (at least 4: an empty buffer still binds).
    pub fn bytes(&self) -> u64 {
        (self.len.max(1) * 4) as u64
    }

    /// The offset constants `{PREFIX}{NAME}_OFF` of every field and `{PREFIX}LEN`.
    pub fn constants(&self, constants: Constants) -> Constants {
        let p = self.prefix;
        self.fields
            .iter()
            .fold(constants, |c, f| {
                c.u32(&format!("{p}{}_OFF", f.name), f.offset as u32)
            })
            .u32(&format!("{p}LEN"), self.len as u32)
    }

    /// A zeroed host copy of the buffer.
    pub fn zeroed(&self) -> Vec<f32> {
        vec![0.0; self.len]
    }

    /// The same fields, each present one holding `count` items: a per-pair layout for
    /// another number of pairs.
    pub fn resized(&self, count: usize) -> Self {
        (self.fields.iter()).fold(Self::new(self.prefix, self.dim), |l, f| {
            l.block(f.name, f.count > 0, count, f.width)
        })
    }

    /// A host copy of a buffer of this layout holding items `start..start + count` of
    /// each field of `flat`, laid out as `whole` (the same fields, more items).
    pub fn items_of(&self, whole: &Fields, flat: &[f32], start: usize, count: usize) -> Vec<f32> {
        let mut out = self.zeroed();
        for (f, w) in self.fields.iter().zip(&whole.fields) {
            let (from, len) = (w.offset + start * w.width, count * w.width);
            if f.count > 0 {
                out[f.offset..][..len].copy_from_slice(&flat[from..][..len]);
            }
        }
        out
    }

    /// Writes items of `width` floats each into field `name`, item k from `put(k, out)`.
    fn write<T>(&self, flat: &mut [f32], name: &str, items: &[T], put: impl Fn(&mut Vec<f32>, &T)) {
        let f = self.field(name);
        assert_eq!(items.len(), f.count, "field {name} holds {} items", f.count);
        let mut out = Vec::with_capacity(f.count * f.width);
        items.iter().for_each(|t| put(&mut out, t));
        flat[f.offset..f.offset + out.len()].copy_from_slice(&out);
    }

    /// Writes scalars less `rest` (J − 1, ρ − ρ0, …) into field `name`.
    pub fn write_s(&self, flat: &mut [f32], name: &str, values: &[f64], rest: f64) {
        self.write(flat, name, values, |o, &x| o.push((x - rest) as f32));
    }

    /// Writes vectors into field `name`.
    pub fn write_v<D: Flat>(&self, flat: &mut [f32], name: &str, values: &[D::V]) {
        self.write(flat, name, values, |o, &v| D::push_v(o, v));
    }

    /// Writes tensors less `rest` (F − I, …), formed in f64, into field `name`.
    pub fn write_t<D: Flat>(&self, flat: &mut [f32], name: &str, values: &[D::T], rest: D::T) {
        self.write(flat, name, values, |o, &t| D::push_t(o, t - rest));
    }

    /// Writes the fields that TL and UL states share: displacement U, velocity V, density
    /// RHO (less ρ0) and deviatoric stress S.
    pub fn write_solid<D: Flat>(
        &self,
        flat: &mut [f32],
        (u, v): (&[D::V], &[D::V]),
        (rho, rho0): (&[f64], f64),
        s: &[D::T],
    ) {
        self.write_v::<D>(flat, "U", u);
        self.write_v::<D>(flat, "V", v);
        self.write_s(flat, "RHO", rho, rho0);
        self.write_t::<D>(flat, "S", s, D::zero_t());
    }

    /// The items of field `name`, each read from its slice of `flat`.
    fn read<T>(&self, flat: &[f32], name: &str, get: impl Fn(&[f32]) -> T) -> Vec<T> {
        let f = self.field(name);
        flat[f.offset..f.offset + f.count * f.width]
            .chunks_exact(f.width.max(1))
            .map(get)
            .collect()
    }

    /// The scalars of field `name` plus `rest`.
    pub fn read_s(&self, flat: &[f32], name: &str, rest: f64) -> Vec<f64> {
        self.read(flat, name, |s| rest + f64::from(s[0]))
    }

    /// The vectors of field `name`.
    pub fn read_v<D: Flat>(&self, flat: &[f32], name: &str) -> Vec<D::V> {
        self.read(flat, name, D::read_v)
    }

    /// The fields of [`Fields::write_solid`], read back: U, V, RHO (plus ρ0) and S.
    pub fn read_solid<D: Flat>(&self, flat: &[f32], rho0: f64) -> Solid<D> {
        let u = self.read_v::<D>(flat, "U");
        let v = self.read_v::<D>(flat, "V");
        let s = self.read_t::<D>(flat, "S", D::zero_t());
        (u, v, self.read_s(flat, "RHO", rho0), s)
    }

    /// The tensors of field `name` plus `rest`.
    pub fn read_t<D: Flat>(&self, flat: &[f32], name: &str, rest: D::T) -> Vec<D::T> {
        self.read(flat, name, |s| rest + D::read_t(s))
    }
}
