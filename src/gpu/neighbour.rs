//! GPU neighbour search: a cell list (counting sort with u32 atomics) and CSR neighbour
//! lists, built once per total-Lagrangian scene from the reference positions.
//!
//! The lists equal those of [`crate::neighbour::build`] (self excluded, |x_i − x_j| ≤ radius,
//! ids ascending), up to the f32 rounding of the positions: a pair whose distance lies
//! within the f32 rounding of its coordinates (about 1e-7·|x|, i.e. 1e-6 of the radius
//! and more for coordinates far from the origin) of the radius may be classified
//! differently. Lattice ties (pairs at exactly 2 dx, say) need a relative margin on the
//! radius of that size (1e-5 is safe for |x| up to a few hundred radii); 1 + 1e-9 is not.
//!
//! Passes (`shaders/common/cell_list.wgsl`, `shaders/common/scan.wgsl`), recorded in two command
//! encoders: bin particles into cells and count per cell → exclusive scan of the counts →
//! scatter into cell order → count neighbours per particle → exclusive scan into offsets
//! (n + 1 entries) → read back the pair count (the only readback) → allocate `ids` → fill
//! and sort each particle's slice.

use super::context::{Gpu, GpuError, Pipeline, WORKGROUP};
use super::layout::GpuDim;
use super::shaders::{CELL_LIST, Constants, SCAN, compose};
use crate::tensor::D2;
use bytemuck::{Pod, Zeroable};

/// Entries scanned by one workgroup of `scan_blocks` (two per invocation).
pub const SCAN_BLOCK: u32 = 2 * WORKGROUP;

/// Most cells along one axis. Past it the cell grows: f32 cell coordinates of magnitude
/// up to this bound keep an error far below one cell (see [`CellParams::new`]).
const MAX_CELLS_PER_AXIS: f64 = 65_536.0;

/// Neighbour lists on the GPU: the neighbours of particle i are
/// `ids[offsets[i]..offsets[i + 1]]`, sorted ascending.
pub struct GpuCsr {
    /// `array<u32>`, n + 1 entries; the last is `pairs`.
    pub offsets: wgpu::Buffer,
    /// `array<u32>`, `pairs` entries (at least 4 bytes, so an empty list still binds).
    pub ids: wgpu::Buffer,
    /// Total number of ordered pairs.
    pub pairs: u32,
}

/// The uniform `CellParams` of `cell_list.wgsl` (48 bytes: `origin` is a vec3 at offset 0
/// and `dims` a vec3 at offset 16, each followed by a 4-byte scalar in its tail).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct CellParams {
    pub origin: [f32; 3],
    pub inv_cell: f32,
    pub dims: [u32; 3],
    pub n: u32,
    pub radius2: f32,
    pub ncells: u32,
    pub _pad: [u32; 2],
}

impl CellParams {
    /// The grid over the box `lo..hi` for `n` points in `dim` dimensions and a search
    /// `radius`, or `TooLarge` when its cell array exceeds the device limits.
    ///
    /// The cell edge is the radius, enlarged (which never drops a pair, it only adds
    /// candidates) in these cases:
    /// - past [`MAX_CELLS_PER_AXIS`] cells along an axis, or more than max(8 n, 4096)
    ///   cells in all (a sparse cloud), the cell grows until the grid fits;
    /// - always by the factor 1 + 1e-5 + (cells per axis)·2⁻²¹, so that f32 rounding of
    ///   the cell coordinates (relative error ≲ 3·2⁻²⁴ of a coordinate up to the number
    ///   of cells per axis) cannot put two points that pass the f32 distance test more
    ///   than one cell apart.
    pub fn new(
        gpu: &Gpu,
        dim: usize,
        lo: [f64; 3],
        hi: [f64; 3],
        n: u32,
        radius: f64,
    ) -> Result<Self, GpuError> {
        let mut extent = [0.0f64; 3];
        for k in 0..dim {
            extent[k] = (hi[k] - lo[k]).max(0.0);
        }
        let cells_along = |cell: f64, k: usize| {
            if k < dim {
                (extent[k] / cell).floor() + 1.0
            } else {
                1.0
            }
        };
        let count = |cell: f64| (0..3).map(|k| cells_along(cell, k)).product::<f64>();
        let widest = extent.iter().copied().fold(0.0, f64::max);
        let mut cell = radius.max(widest / (MAX_CELLS_PER_AXIS - 1.0));
        let cap = (8.0 * f64::from(n)).max(4096.0);
        while count(cell) > cap {
            cell *= (count(cell) / cap).powf(1.0 / dim as f64).max(1.01);
        }
        let axis_max = (0..dim).map(|k| cells_along(cell, k)).fold(1.0, f64::max);
        cell *= 1.0 + 1e-5 + axis_max * 2f64.powi(-21);

        let dims = [0, 1, 2].map(|k| cells_along(cell, k) as u64);
        let ncells = dims.iter().product::<u64>();
        gpu.check_size("cell list", (ncells + 1) * 4)?;
        let mut origin = [0.0f32; 3];
        for k in 0..dim {
            origin[k] = lo[k] as f32;
        }
        Ok(Self {
            origin,
            inv_cell: (1.0 / cell) as f32,
            dims: dims.map(|d| d as u32),
            n,
            radius2: (radius * radius) as f32,
            ncells: ncells as u32,
            _pad: [0; 2],
        })
    }
}

/// The uniform `ScanParams` of `scan.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ScanParams {
    n: u32,
    _pad: [u32; 3],
}

/// The pipelines of the exclusive prefix sum.
pub struct Scan {
    blocks: Pipeline,
    add: Pipeline,
}

/// One dispatch: pipeline, bind group, workgroup counts.
struct Step {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    groups: (u32, u32),
}

impl Step {
    fn encode(&self, pass: &mut wgpu::ComputePass) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
    }
}

/// The recorded dispatches of one exclusive scan of a given buffer (with its block-sum
/// buffers), ready to encode into a compute pass.
pub struct ScanPlan {
    steps: Vec<Step>,
}

impl Scan {
    /// Compiles the scan (it does not depend on the dimension; the 2D prelude is unused).
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let text = compose::<D2>(&SCAN, &Constants::default());
        Ok(Self {
            blocks: gpu.pipeline("scan_blocks", &text, "scan_blocks")?,
            add: gpu.pipeline("add_block_sums", &text, "add_block_sums")?,
        })
    }

    /// An exclusive scan of the first `n` u32 of `data`, in place: one level per factor
    /// of [`SCAN_BLOCK`] (block scans from the bottom up, add-backs from the top down).
    pub fn plan(&self, gpu: &Gpu, data: &wgpu::Buffer, n: u32) -> Result<ScanPlan, GpuError> {
        let mut scans = Vec::new();
        let mut adds = Vec::new();
        let mut level = data.clone();
        let mut len = n;
        loop {
            let blocks = len.div_ceil(SCAN_BLOCK).max(1);
            let sums = gpu.zeroed("scan block sums", u64::from(blocks) * 4);
            let params = gpu.uniform(
                "scan params",
                &ScanParams {
                    n: len,
                    _pad: [0; 3],
                },
            );
            let table = [("scan", &params), ("data", &level), ("block_sums", &sums)];
            scans.push(Step {
                pipeline: self.blocks.raw.clone(),
                bind: gpu.bind(&self.blocks, &table)?,
                groups: gpu.groups(blocks * WORKGROUP),
            });
            if blocks == 1 {
                // The single block's sum is the total: nothing to add back at this level.
                break;
            }
            adds.push(Step {
                pipeline: self.add.raw.clone(),
                bind: gpu.bind(&self.add, &table)?,
                groups: gpu.groups(len),
            });
            level = sums;
            len = blocks;
        }
        adds.reverse();
        scans.extend(adds);
        Ok(ScanPlan { steps: scans })
    }
}

impl ScanPlan {
    pub fn encode(&self, pass: &mut wgpu::ComputePass) {
        for step in &self.steps {
            step.encode(pass);
        }
    }
}

/// Exclusive prefix sum of the first `n` u32 of `data`, in place (wrapping), submitted to
/// the queue at once.
pub fn exclusive_scan(gpu: &Gpu, data: &wgpu::Buffer, n: u32) -> Result<(), GpuError> {
    let plan = Scan::new(gpu)?.plan(gpu, data, n)?;
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        plan.encode(&mut pass);
    }
    gpu.queue.submit([encoder.finish()]);
    Ok(())
}

/// Builds the CSR neighbour lists of the `n` points in `x` (`array<vecd>`, uploaded with
/// `D::v`): all pairs i ≠ j with |x_i − x_j| ≤ `radius`, ids ascending. `lo`/`hi` is the
/// bounding box of the points (computed by the caller; points outside it are still found,
/// only less efficiently). Reads back one u32 (the pair count) to size `ids`.
///
/// Panics if `radius` is not positive and finite or `x` holds fewer than `n` vectors.
pub fn build<D: GpuDim>(
    gpu: &Gpu,
    x: &wgpu::Buffer,
    lo: [f64; 3],
    hi: [f64; 3],
    n: u32,
    radius: f64,
) -> Result<GpuCsr, GpuError> {
    assert!(
        radius.is_finite() && radius > 0.0,
        "neighbour radius must be positive, got {radius}"
    );
    let stride = std::mem::size_of::<D::HV>() as u64;
    assert!(
        x.size() >= u64::from(n) * stride,
        "positions buffer holds {} bytes, fewer than {n} vectors of {stride} bytes",
        x.size()
    );
    let n_bytes = u64::from(n) * 4;
    gpu.check_size("neighbour list", n_bytes + 4)?;
    let offsets = gpu.zeroed("neighbour offsets", n_bytes + 4);
    if n == 0 {
        return Ok(GpuCsr {
            offsets,
            ids: gpu.zeroed("neighbour ids", 4),
            pairs: 0,
        });
    }
    let params = CellParams::new(gpu, D::N, lo, hi, n, radius)?;
    let ncells = params.ncells;
    let uniform = gpu.uniform("cell list params", &params);
    let cell = gpu.zeroed("particle cells", n_bytes);
    let cell_start = gpu.zeroed("cell start", (u64::from(ncells) + 1) * 4);
    let cursor = gpu.zeroed("cell cursor", u64::from(ncells) * 4);
    let sorted = gpu.zeroed("cell-sorted particles", n_bytes);
    // count_neighbours shares its loop with the fill and so binds `ids` statically.
    let no_ids = gpu.zeroed("neighbour ids (count pass)", 4);
    let total = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("neighbour pair count"),
        size: 4,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });

    let text = compose::<D>(&CELL_LIST, &Constants::default());
    let pipeline = |entry: &str| gpu.pipeline(entry, &text, entry);
    let (bin, scatter, count, fill) = (
        pipeline("bin_particles")?,
        pipeline("scatter")?,
        pipeline("count_neighbours")?,
        pipeline("fill_neighbours")?,
    );
    let scan = Scan::new(gpu)?;
    let scan_cells = scan.plan(gpu, &cell_start, ncells + 1)?;
    let scan_offsets = scan.plan(gpu, &offsets, n + 1)?;
    let per_particle = gpu.groups(n);
    // The passes of cell_list.wgsl use different subsets of its bindings.
    let table = |ids| -> [(&str, &wgpu::Buffer); 8] {
        [
            ("params", &uniform),
            ("x", x),
            ("cell", &cell),
            ("cell_start", &cell_start),
            ("cursor", &cursor),
            ("sorted", &sorted),
            ("offsets", &offsets),
            ("ids", ids),
        ]
    };
    let step = |pipeline: &Pipeline, ids| -> Result<Step, GpuError> {
        Ok(Step {
            pipeline: pipeline.raw.clone(),
            bind: gpu.bind(pipeline, &table(ids))?,
            groups: per_particle,
        })
    };
    let (bin, scatter, count) = (
        step(&bin, &no_ids)?,
        step(&scatter, &no_ids)?,
        step(&count, &no_ids)?,
    );

    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.clear_buffer(&cell_start, 0, None);
    encoder.clear_buffer(&offsets, 0, None);
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        bin.encode(&mut pass);
        scan_cells.encode(&mut pass);
    }
    encoder.copy_buffer_to_buffer(&cell_start, 0, &cursor, 0, u64::from(ncells) * 4);
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        scatter.encode(&mut pass);
        count.encode(&mut pass);
        scan_offsets.encode(&mut pass);
    }
    encoder.copy_buffer_to_buffer(&offsets, n_bytes, &total, 0, 4);
    gpu.queue.submit([encoder.finish()]);

    let slice = total.slice(..);
    slice.map_async(wgpu::MapMode::Read, |r| {
        r.expect("mapping the neighbour pair count")
    });
    gpu.wait();
    let pairs = {
        let view = slice
            .get_mapped_range()
            .expect("mapped range of the neighbour pair count");
        bytemuck::pod_read_unaligned::<u32>(&view)
    };
    total.unmap();

    let ids_bytes = u64::from(pairs) * 4;
    gpu.check_size("neighbour list", ids_bytes)?;
    let ids = gpu.zeroed("neighbour ids", ids_bytes);
    if pairs > 0 {
        let fill = step(&fill, &ids)?;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            fill.encode(&mut pass);
        }
        gpu.queue.submit([encoder.finish()]);
    }
    Ok(GpuCsr {
        offsets,
        ids,
        pairs,
    })
}

/// Reads GPU lists back into the CPU type (waits for the queue).
pub fn read_lists(gpu: &Gpu, csr: &GpuCsr) -> crate::neighbour::Csr {
    let entries = (csr.offsets.size() / 4) as usize;
    let mut offsets: Vec<u32> = gpu.read(&csr.offsets);
    offsets.truncate(entries);
    let mut ids: Vec<u32> = gpu.read(&csr.ids);
    ids.truncate(csr.pairs as usize);
    crate::neighbour::Csr {
        offsets: offsets.into_iter().map(|o| o as usize).collect(),
        ids,
    }
}
