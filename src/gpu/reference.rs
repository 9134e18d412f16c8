//! The reference configuration on the device, uploaded the same way by every GPU engine
//! from the host's f64 set-up ([`crate::reference::Reference`]): one flat buffer
//! `reference` (`shaders/setup/reference.wgsl`), the CSR neighbour lists, and the
//! traction loads.

use super::context::Gpu;
use super::layout::{Fields, Flat, flat_v};
use super::memory::DeviceMemory;
use super::parts::{PartLists, Split};
use crate::boundary::Boundary;
use crate::core::neighbour::Csr;

/// Which optional fields of the `reference` buffer an engine's passes read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Extras {
    /// The lo part of X = hi + lo (exact reference pair offsets, pair_offsets.wgsl).
    pub lo: bool,
    /// X − X̄ about the volume-weighted centroid (the mixed methods' projection).
    pub centred: bool,
}

/// The fields of the `reference` buffer of n particles, `constrained` of them with
/// prescribed components: X (f32 hi part), X lo, X − X̄, V, the boundary mask (an f32
/// integer, bit k for velocity component k), the slot of a constrained particle (its index
/// in `Boundary::constrained`, an f32 integer), and per slot the rates of its timed
/// components over the current step (`prescribed.wgsl`).
pub fn fields(n: usize, constrained: usize, dim: usize, extras: Extras) -> Fields {
    Fields::new("R", dim)
        .vectors("X", true, n)
        .vectors("XLO", extras.lo, n)
        .vectors("XREL", extras.centred, n)
        .scalars("VOL", true, n)
        .scalars("MASK", true, n)
        .scalars("SLOT", true, n)
        .vectors("RATE", true, constrained)
}

/// The most constrained particles whose slots an f32 integer holds exactly: 2^24.
pub const MAX_SLOTS: usize = 1 << 24;

/// The reference configuration and the neighbour lists, resident on the device.
pub struct DeviceReference {
    pub fields: Fields,
    pub reference: wgpu::Buffer,
    /// The neighbour lists, a part each ([`super::parts`]).
    pub lists: Vec<PartLists>,
    /// External accelerations of the traction loads (DIM per particle).
    pub traction: wgpu::Buffer,
}

impl DeviceReference {
    /// The buffers [`Self::upload`] makes: the reference configuration of `n` particles
    /// in `dim` dimensions laid out as `fields`, their tractions, and lists of `rows` rows
    /// and `pairs` pairs in one part (a method whose lists live elsewhere uploads none: 0
    /// and 0).
    pub fn memory(
        memory: &mut DeviceMemory,
        fields: &Fields,
        n: usize,
        dim: usize,
        rows: usize,
        pairs: usize,
    ) {
        memory.fields("reference", fields);
        memory.words("traction", (n * dim) as f64);
        // The offsets of no rows are one word, as an empty list's ids.
        memory.words("neighbour offsets", (rows + 1) as f64);
        memory.words("neighbour ids", pairs as f64);
        memory.add("list part", 8.0);
    }

    /// Uploads positions `x0`, volumes `vol`, the boundary conditions and the neighbour
    /// lists `csr` of the particles in the parts of `split` (f64 on the host, rounded
    /// once to f32).
    pub fn upload<D: Flat>(
        gpu: &Gpu,
        x0: &[D::V],
        vol: &[f64],
        boundary: &Boundary<D>,
        (csr, split): (&Csr, &Split),
        extras: Extras,
    ) -> Self {
        let n = x0.len();
        let fields = fields(n, boundary.constrained.len(), D::N, extras);
        let mut flat = fields.zeroed();
        let hi = flat_v::<D>(x0.iter().copied());
        fields.write_v::<D>(&mut flat, "X", x0);
        if extras.lo {
            let lo: Vec<D::V> = x0
                .iter()
                .zip(hi.chunks_exact(D::N))
                .map(|(&x, h)| x - D::read_v(h))
                .collect();
            fields.write_v::<D>(&mut flat, "XLO", &lo);
        }
        if extras.centred {
            let total: f64 = vol.iter().sum();
            let centroid =
                x0.iter().zip(vol).fold(D::zero(), |c, (&x, &v)| c + x * v) * (1.0 / total);
            let centred: Vec<D::V> = x0.iter().map(|&x| x - centroid).collect();
            fields.write_v::<D>(&mut flat, "XREL", &centred);
        }
        fields.write_s(&mut flat, "VOL", vol, 0.0);
        let mut mask = vec![0.0; n];
        for &(i, m) in &boundary.constrained {
            mask[i as usize] = f64::from(m);
        }
        fields.write_s(&mut flat, "MASK", &mask, 0.0);
        let mut slot = vec![0.0; n];
        for (s, &(i, _)) in boundary.constrained.iter().enumerate() {
            slot[i as usize] = s as f64;
        }
        fields.write_s(&mut flat, "SLOT", &slot, 0.0);
        let mut ext = vec![D::zero(); n];
        for &(i, a) in &boundary.external {
            ext[i as usize] = a;
        }
        Self {
            reference: gpu.storage("reference", &flat),
            lists: PartLists::upload(gpu, csr, split),
            traction: gpu.storage("traction", &flat_v::<D>(ext)),
            fields,
        }
    }
}
