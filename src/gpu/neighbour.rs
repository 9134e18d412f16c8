//! GPU neighbour search: a cell list (counting sort with u32 atomics) and CSR neighbour
//! lists, rebuilt on the device from the current positions as often as a method's
//! neighbours change, with per-body masks.
//!
//! The lists equal those of [`crate::core::neighbour::build`] (self excluded, |x_i − x_j| ≤ radius,
//! ids ascending), up to the f32 rounding of the positions: a pair whose distance lies
//! within the f32 rounding of its coordinates (about 1e-7·|x|, i.e. 1e-6 of the radius
//! and more for coordinates far from the origin) of the radius may be classified
//! differently. Lattice ties (pairs at exactly 2 dx, say) need a relative margin on the
//! radius of that size (1e-5 is safe for |x| up to a few hundred radii); 1 + 1e-9 is not.
//!
//! Passes (`shaders/setup/cell_list.wgsl`, `shaders/setup/scan.wgsl`), recorded into one
//! command encoder: bin particles into cells and count per cell → exclusive scan of the
//! counts → scatter into cell order → count neighbours per particle → exclusive scan into
//! offsets (n + 1 entries) → fill and sort each particle's slice, up to the capacity of
//! `ids`; a build that needs more records the pair count in an overflow flag, which the
//! owner reads when it checks the run (the only readback) to grow the lists.

use super::context::{Gpu, GpuError, Pipeline, Vec3, WORKGROUP};
use super::layout::GpuDim;
use super::memory::DeviceMemory;
use super::profile::{IndirectRuns, Scale};
use super::shaders::{CELL_LIST, Constants, SCAN, compose};
use crate::case::Case;
use crate::core::neighbour::{SKIN, bounding_box};
use crate::core::tensor::D2;
use encase::ShaderType;
use std::sync::atomic::{AtomicU64, Ordering};

/// Entries scanned by one workgroup of `scan_blocks` (two per invocation).
pub const SCAN_BLOCK: u32 = 2 * WORKGROUP;

/// Most cells along one axis. Past it the cell grows: f32 cell coordinates of magnitude
/// up to this bound keep an error far below one cell (see [`CellParams::new`]).
const MAX_CELLS_PER_AXIS: f64 = 65_536.0;

/// The uniform `CellParams` of `cell_list.wgsl`.
#[derive(Clone, Copy, Debug, PartialEq, ShaderType)]
pub struct CellParams {
    pub origin: Vec3<f32>,
    pub inv_cell: f32,
    pub dims: Vec3<u32>,
    pub n: u32,
    pub radius2: f32,
    pub ncells: u32,
    /// The square of the displacement since the last build that keeps the lists complete
    /// (set by [`CellList::new`]).
    pub drift2: f32,
    /// The dispatches of a build (set by [`CellList::new`]).
    pub dispatches: u32,
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
        let (cell, dims) = Self::cells(dim, lo, hi, n, radius);
        let ncells = dims.iter().product::<u64>();
        gpu.check_size("cell list", (ncells + 1) * 4)?;
        let mut origin = [0.0f32; 3];
        for k in 0..dim {
            origin[k] = lo[k] as f32;
        }
        Ok(Self {
            origin: Vec3(origin),
            inv_cell: (1.0 / cell) as f32,
            dims: Vec3(dims.map(|d| d as u32)),
            n,
            radius2: (radius * radius) as f32,
            ncells: ncells as u32,
            drift2: 0.0,
            dispatches: 0,
        })
    }

    /// The cell edge and the cells along each axis of the grid of [`Self::new`].
    pub fn cells(dim: usize, lo: [f64; 3], hi: [f64; 3], n: u32, radius: f64) -> (f64, [u64; 3]) {
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
        (cell, [0, 1, 2].map(|k| cells_along(cell, k) as u64))
    }
}

/// The radius a cell list searches for a kernel `support`: widened by the skin [`SKIN`]
/// (the lists are rebuilt once a particle has moved half of it, as on the CPU) and by a
/// relative margin of 1e-5 for f32 ties at lattice distances (see the module's doc).
pub fn search_radius(support: f64) -> f64 {
    support * (1.0 + SKIN) * (1.0 + 1e-5)
}

/// The box `lo..hi` of `dim` dimensions widened on every side by a fifth of its extent
/// and `radius`.
pub fn widened(
    (mut lo, mut hi): ([f64; 3], [f64; 3]),
    dim: usize,
    radius: f64,
) -> ([f64; 3], [f64; 3]) {
    for k in 0..dim {
        let margin = 0.2 * (hi[k] - lo[k]) + radius;
        lo[k] -= margin;
        hi[k] += margin;
    }
    (lo, hi)
}

impl CellParams {
    /// The grid over the box of the reference positions `x0`, [`widened`] by the search
    /// radius of a kernel `support` ([`search_radius`]): points that leave it are binned
    /// in the nearest cell, which keeps every pair.
    pub fn around<D: GpuDim>(gpu: &Gpu, x0: &[D::V], support: f64) -> Result<Self, GpuError> {
        let radius = search_radius(support);
        let (lo, hi) = widened(bounding_box(x0.iter().map(|&x| D::to3(x))), D::N, radius);
        let n = x0.len().min(u32::MAX as usize) as u32;
        Self::new(gpu, D::N, lo, hi, n, radius)
    }

    /// The cells of the grid [`Self::around`] makes for `n` points in the bodies' boxes of
    /// `case` (`n` where a body's box is not known before it is built).
    pub fn cells_of(case: &Case, dim: usize, n: usize, support: f64) -> u64 {
        let radius = search_radius(support);
        let boxes = case.bodies.iter().map(|b| b.geometry.extent(dim));
        boxes.collect::<Option<Vec<_>>>().map_or(n as u64, |boxes| {
            let corners = boxes.iter().flat_map(|&(lo, hi)| [lo, hi]);
            let (lo, hi) = widened(bounding_box(corners), dim, radius);
            let points = n.min(u32::MAX as usize) as u32;
            let (_, dims) = Self::cells(dim, lo, hi, points, radius);
            dims.iter().product()
        })
    }
}

/// The uniform `ScanParams` of `scan.wgsl`.
#[derive(Clone, Copy, Debug, ShaderType)]
struct ScanParams {
    n: u32,
}

/// The pipelines of the exclusive prefix sum.
pub struct Scan {
    blocks: Pipeline,
    add: Pipeline,
}

/// One dispatch: pipeline, bind group, workgroup counts, and the items and share of the
/// pairs (by rows) of its bytes model.
struct Step {
    pipeline: Pipeline,
    bind: wgpu::BindGroup,
    groups: (u32, u32),
    items: u32,
    share: f64,
}

impl Step {
    fn encode(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass) {
        let items = u64::from(self.items);
        gpu.dispatch_groups(pass, &self.pipeline, &self.bind, self.groups, items);
    }

    /// The dispatch with the workgroup counts at entry `k` of `args`.
    fn encode_indirect(
        &self,
        gpu: &Gpu,
        pass: &mut wgpu::ComputePass,
        args: &wgpu::Buffer,
        k: usize,
    ) {
        let at = (args, 12 * k as u64);
        let work = (u64::from(self.items), self.share);
        gpu.dispatch_indirect(pass, &self.pipeline, &self.bind, at, work);
    }
}

/// The recorded dispatches of one exclusive scan of a given buffer (with its block-sum
/// buffers), ready to encode into a compute pass.
pub struct ScanPlan {
    steps: Vec<Step>,
}

impl Scan {
    /// The block sums of each level of a scan of `n` entries, from the bottom up: one
    /// a block of [`SCAN_BLOCK`], down to a single block.
    fn levels(n: u64) -> Vec<u64> {
        let mut levels = Vec::new();
        let mut len = n;
        loop {
            let blocks = len.div_ceil(u64::from(SCAN_BLOCK)).max(1);
            levels.push(blocks);
            if blocks == 1 {
                return levels;
            }
            len = blocks;
        }
    }

    /// The buffers [`Self::plan`] makes for `n` entries, and its dispatches.
    fn memory(m: &mut DeviceMemory, n: u64) -> usize {
        let levels = Self::levels(n);
        for &blocks in &levels {
            m.words("scan block sums", blocks as f64);
            m.add("scan params", ScanParams::min_size().get() as f64);
        }
        2 * levels.len() - 1
    }

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
        for blocks in Self::levels(u64::from(n)) {
            // At most n: a u32.
            let blocks = blocks as u32;
            let sums = gpu.zeroed("scan block sums", u64::from(blocks) * 4);
            let params = gpu.uniform("scan params", &ScanParams { n: len });
            let table = [("scan", &params), ("data", &level), ("block_sums", &sums)];
            scans.push(Step {
                pipeline: self.blocks.clone(),
                bind: gpu.bind(&self.blocks, &table)?,
                groups: gpu.groups(blocks * WORKGROUP),
                items: blocks * WORKGROUP,
                share: 1.0,
            });
            if blocks == 1 {
                // The single block's sum is the total: nothing to add back at this level.
                break;
            }
            adds.push(Step {
                pipeline: self.add.clone(),
                bind: gpu.bind(&self.add, &table)?,
                groups: gpu.groups(len),
                items: len,
                share: 1.0,
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
    pub fn encode(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass) {
        for step in &self.steps {
            step.encode(gpu, pass);
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
        plan.encode(gpu, &mut pass);
    }
    gpu.queue.submit([encoder.finish()]);
    Ok(())
}

/// The constants of `cell_list.wgsl`: positions from `offset` floats in, pairs only
/// within a body if `masked`.
pub fn constants(offset: usize, masked: bool) -> Constants {
    Constants::default()
        .u32("POS_OFF", offset as u32)
        .u32("MASKED", u32::from(masked))
}

/// Where a [`CellList`] reads the positions, and which pairs it keeps.
#[derive(Clone, Copy)]
pub struct Positions<'a> {
    /// Flat f32 buffer: DIM floats per particle from `offset` floats in (a state's
    /// position or displacement field, or positions alone at 0).
    pub x: &'a wgpu::Buffer,
    pub offset: usize,
    pub n: u32,
    /// The body of each particle: pairs only within a body (per-body masks).
    pub body: Option<&'a wgpu::Buffer>,
}

/// How a [`CellList`]'s ids are laid out: parts of `rows` consecutive particles (the last
/// part takes the rest), each with its own ids buffer of room for `pairs` pairs, so that
/// each fits one storage binding however many pairs the scene has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Room {
    /// The rows of every part but the last: all of them, or a multiple of the workgroup.
    pub rows: u32,
    /// The pairs each part's ids hold.
    pub pairs: u32,
}

impl Room {
    /// Room for `pairs` pairs of `n` particles in ids buffers of at most `limit` bytes: one
    /// part while they fit; past it, the fewest parts of equal rows (a multiple of the
    /// workgroup) with room each for their rows' share of the pairs. Err: the bytes of the
    /// share of one workgroup of particles, which alone passes the limit.
    pub fn plan(n: u32, pairs: u64, limit: u64) -> Result<Self, u64> {
        let (n64, words, pairs) = (u64::from(n.max(1)), limit / 4, pairs.max(1));
        if pairs <= words {
            return Ok(Self {
                rows: n.max(1),
                pairs: pairs as u32,
            });
        }
        let block = u64::from(WORKGROUP);
        let share = |rows: u64| (pairs * rows).div_ceil(n64);
        // The most rows whose share fits, in whole workgroups.
        let most = words * n64 / pairs / block * block;
        if most == 0 {
            return Err(4 * share(block));
        }
        let parts = n64.div_ceil(most);
        let rows = n64.div_ceil(parts).div_ceil(block) * block;
        Ok(Self {
            rows: rows as u32,
            pairs: share(rows) as u32,
        })
    }

    /// [`Self::plan`] for the binding limit of `gpu`. Err names the bytes of the ids of
    /// one workgroup of particles, which alone pass it.
    pub fn fitting(gpu: &Gpu, n: u32, pairs: u64) -> Result<Self, GpuError> {
        let limit = gpu.binding_limit();
        Self::plan(n, pairs, limit).map_err(|needed| GpuError::TooLarge {
            adapter: gpu.name(),
            what: "neighbour list part (the pairs of one workgroup of particles)",
            needed,
            limit,
        })
    }

    /// The pairs of every part's room together.
    pub fn total(&self, n: u32) -> u64 {
        u64::from(self.pairs) * self.parts(n).len() as u64
    }

    /// The first row and the rows of each part, for `n` particles.
    pub fn parts(&self, n: u32) -> Vec<(u32, u32)> {
        let rows = self.rows.max(1);
        (0..n.div_ceil(rows).max(1))
            .map(|k| (k * rows, rows.min(n - (k * rows).min(n))))
            .collect()
    }

    /// The pairs to plan for after a build needed `needed` pairs in its fullest part: the
    /// share of that need, with a quarter more, over every row.
    pub fn grown(&self, n: u32, needed: u32) -> u64 {
        let per_part = u64::from(needed) + u64::from(needed) / 4;
        (per_part * u64::from(n.max(1))).div_ceil(u64::from(self.rows.max(1)))
    }
}

/// One part of a [`CellList`]'s rows: its ids, counted from its first pair, and its
/// uniform `part` (`shaders/common/part.wgsl`).
pub struct ListPart {
    pub first: u32,
    pub rows: u32,
    pub ids: wgpu::Buffer,
    pub uniform: wgpu::Buffer,
}

impl ListPart {
    /// The bindings `ids` and `part` of this part.
    pub fn table(&self) -> [(&'static str, &wgpu::Buffer); 2] {
        [("ids", &self.ids), ("part", &self.uniform)]
    }
}

/// A neighbour build resident on the device: the cell list's buffers and passes for n
/// particles, allocated once and recorded into an encoder as often as the particles move,
/// without reading anything back. The lists are CSR: `offsets` (n + 1 entries, over every
/// particle) and the ids of each part of the rows ([`Room`]), filled up to the part's
/// room; a build that needs more pairs in a part than its room records the most a part
/// needs ([`CellList::overflow`]) and the owner makes a larger one.
///
/// Every dispatch of a build is indirect: [`CellList::record`] forces a build, and
/// [`CellList::record_on_drift`] builds only when a particle has moved more than the drift
/// distance since the last build (a check on the device sets the workgroup counts), so
/// that lists searched with a skin stay complete without a build at every evaluation.
pub struct CellList {
    /// n + 1 entries: the pairs of the rows before each, modulo 2³² (a part's are exact
    /// as differences).
    pub offsets: wgpu::Buffer,
    pub parts: Vec<ListPart>,
    room: Room,
    n: u32,
    overflow: wgpu::Buffer,
    /// [a build is due, builds so far].
    due: wgpu::Buffer,
    /// A u32 1, copied into `due` to force a build.
    one: wgpu::Buffer,
    /// The workgroup counts of `build`'s dispatches for the build at hand.
    args: wgpu::Buffer,
    check: Step,
    arm: Step,
    /// clear, bin, (scan of cells), copy cursor, scatter, count, (scan of offsets), fill
    /// (a part each), save the positions.
    build: Vec<Step>,
    /// Builds recorded so far, due or not.
    recorded: AtomicU64,
}

impl CellList {
    /// The buffers [`Self::new`] makes for `n` particles in `dim` dimensions on a grid of
    /// `ncells` cells, with room for `capacity` pairs in all (the parts' rounding left
    /// out).
    pub fn memory(m: &mut DeviceMemory, n: u64, dim: usize, ncells: u64, capacity: u64) {
        let n_words = n.max(1) as f64;
        m.words("particle cells", n_words);
        m.words("cell start", ncells as f64 + 1.0);
        m.words("cell cursor", ncells as f64);
        m.words("cell-sorted particles", n_words);
        m.words("neighbour offsets", n_words + 1.0);
        m.words("neighbour ids", capacity.max(1) as f64);
        for label in ["neighbour overflow", "bodies (unmasked)", "one"] {
            m.words(label, 1.0);
        }
        m.words("positions of the last build", n_words * dim as f64);
        m.words("build due", 2.0);
        // The passes of a build besides the scans': 7.
        let dispatches = 7 + Scan::memory(m, ncells + 1) + Scan::memory(m, n + 1);
        for label in ["build workgroups", "build workgroups due"] {
            m.words(label, 3.0 * dispatches as f64);
        }
        m.add("cell list params", CellParams::min_size().get() as f64);
    }

    /// The passes over `grid` (a box the particles may leave: a particle outside is put in
    /// the nearest cell, which keeps every pair and only adds candidates) with the ids laid
    /// out as `room` says.
    pub fn new<D: GpuDim>(
        gpu: &Gpu,
        at: Positions,
        grid: &CellParams,
        room: Room,
        drift: f64,
    ) -> Result<Self, GpuError> {
        let n = at.n;
        let room = Room {
            pairs: room.pairs.max(1),
            ..room
        };
        let n_bytes = u64::from(n.max(1)) * 4;
        gpu.check_size("neighbour list", u64::from(room.pairs) * 4)?;
        let ncells = grid.ncells;
        let cell = gpu.zeroed("particle cells", n_bytes);
        let cell_start = gpu.zeroed("cell start", (u64::from(ncells) + 1) * 4);
        let cursor = gpu.zeroed("cell cursor", u64::from(ncells) * 4);
        let sorted = gpu.zeroed("cell-sorted particles", n_bytes);
        let offsets = gpu.zeroed("neighbour offsets", n_bytes + 4);
        let parts: Vec<ListPart> = (room.parts(n).into_iter())
            .map(|(first, rows)| ListPart {
                first,
                rows,
                ids: gpu.zeroed("neighbour ids", u64::from(room.pairs) * 4),
                uniform: super::parts::uniform(gpu, first as usize, rows as usize),
            })
            .collect();
        let overflow = gpu.zeroed("neighbour overflow", 4);
        let unmasked = gpu.zeroed("bodies (unmasked)", 4);
        let built = gpu.zeroed("positions of the last build", n_bytes * D::N as u64);
        let due = gpu.storage("build due", &[1u32, 0]);
        let one = gpu.storage("one", &[1u32]);

        let scan = Scan::new(gpu)?;
        let [scan_cells, scan_offsets] = [
            scan.plan(gpu, &cell_start, ncells + 1)?,
            scan.plan(gpu, &offsets, n + 1)?,
        ];
        let text = compose::<D>(&CELL_LIST, &constants(at.offset, at.body.is_some()));
        // clear, bin, copy, scatter, count, a fill a part, save, and the scans'.
        let dispatches = 6 + parts.len() + scan_cells.steps.len() + scan_offsets.steps.len();
        let params = CellParams {
            drift2: (drift * drift) as f32,
            dispatches: dispatches as u32,
            ..*grid
        };
        let uniform = gpu.uniform("cell list params", &params);
        let table = [
            ("params", &uniform),
            ("x", at.x),
            ("cell", &cell),
            ("cell_start", &cell_start),
            ("cursor", &cursor),
            ("sorted", &sorted),
            ("offsets", &offsets),
            ("body", at.body.unwrap_or(&unmasked)),
            ("overflow", &overflow),
            ("built", &built),
            ("due", &due),
        ];
        // A pass over `items` with the bindings `extra` besides the table's, booked with
        // `share` of the pairs.
        let step = |entry: &str, items: u32, extra: &[(&str, &wgpu::Buffer)], share: f64| {
            let pipeline = gpu.pipeline(entry, &text, entry)?;
            let bindings: Vec<_> = table.iter().chain(extra).copied().collect();
            Ok::<_, GpuError>(Step {
                bind: gpu.bind(&pipeline, &bindings)?,
                pipeline,
                groups: gpu.groups(items),
                items,
                share,
            })
        };
        // Every pass of a build binds the first part and runs over every row;
        // `fill_neighbours` binds its own part and runs over its rows, with their share of
        // the pairs.
        let first = parts[0].table();
        let cleared = n.max(ncells) + 1;
        let mut build = vec![
            step("clear_counts", cleared, &first, 1.0)?,
            step("bin_particles", n, &first, 1.0)?,
        ];
        build.extend(scan_cells.steps);
        for entry in ["copy_cursor", "scatter", "count_neighbours"] {
            let items = if entry == "copy_cursor" { ncells } else { n };
            build.push(step(entry, items, &first, 1.0)?);
        }
        build.extend(scan_offsets.steps);
        for part in &parts {
            let share = f64::from(part.rows) / f64::from(n.max(1));
            build.push(step("fill_neighbours", part.rows, &part.table(), share)?);
        }
        build.push(step("save_built", n, &first, 1.0)?);
        // The groups of every dispatch of a build, in order, 3 u32 each: `arm` copies them
        // into `args` when a build is due.
        let full: Vec<u32> = (build.iter())
            .flat_map(|s| [s.groups.0, s.groups.1, 1])
            .collect();
        let full = gpu.storage("build workgroups", &full);
        let args = gpu.indirect("build workgroups due", full.size());
        debug_assert_eq!(build.len(), dispatches);
        let counts = [("args", &args), ("full", &full)];
        Ok(Self {
            check: step("check_drift", n, &counts, 1.0)?,
            arm: step("arm", 1, &counts, 1.0)?,
            offsets,
            parts,
            room,
            n,
            overflow,
            due,
            one,
            args,
            build,
            recorded: AtomicU64::new(0),
        })
    }

    /// Records a build from the current positions.
    pub fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        self.force(encoder);
        self.record_due(gpu, encoder, false);
    }

    /// Makes the next [`Self::record_on_drift`] build, whatever the drift.
    pub fn force(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_buffer_to_buffer(&self.one, 0, &self.due, 0, 4);
    }

    /// Records a build from the current positions if a particle has moved more than the
    /// drift distance since the last build (decided on the device).
    pub fn record_on_drift(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        self.record_due(gpu, encoder, true);
    }

    /// The drift check (with `check`), then the build's dispatches with the workgroup
    /// counts `arm` sets: all of them when a build is due, none otherwise.
    fn record_due(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, check: bool) {
        if self.n == 0 {
            return;
        }
        self.recorded.fetch_add(1, Ordering::Relaxed);
        let mut pass = encoder.begin_compute_pass(&Default::default());
        if check {
            self.check.encode(gpu, &mut pass);
        }
        self.arm.encode(gpu, &mut pass);
        for (k, step) in self.build.iter().enumerate() {
            step.encode_indirect(gpu, &mut pass, &self.args, k);
        }
    }

    /// The builds recorded and run so far (reads one u32 back).
    pub fn builds(&self, gpu: &Gpu) -> u32 {
        let due: Vec<u32> = gpu.read(&self.due);
        due[1]
    }

    /// The builds recorded so far, due or not (what [`Self::builds`] counts those that ran
    /// of).
    pub fn recorded(&self) -> u64 {
        self.recorded.load(Ordering::Relaxed)
    }

    /// Records one dispatch of `pipeline` a part, over its rows, with the part's bind
    /// group of `binds` (bound with [`ListPart::table`]). The pass report books each
    /// dispatch its share of the rows: the device's lists are not read back to count
    /// a part's pairs.
    pub fn dispatch(
        &self,
        gpu: &Gpu,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        binds: &[wgpu::BindGroup],
    ) {
        let rows = f64::from(self.n.max(1));
        let parts = (self.parts.iter()).map(|p| (p.rows, f64::from(p.rows) / rows));
        gpu.dispatch_parts(pass, pipeline, binds, parts);
    }

    /// What scales the passes on these lists in the pass report: the pairs of the last
    /// build and the builds run and recorded so far (reads them back).
    pub fn scale(&self, gpu: &Gpu) -> Scale {
        let builds = IndirectRuns {
            ran: u64::from(self.builds(gpu)),
            recorded: self.recorded(),
        };
        Scale {
            pairs: self.pairs(gpu),
            indirect: Some(builds),
        }
    }

    /// How the ids are laid out.
    pub fn room(&self) -> Room {
        self.room
    }

    /// The most pairs a part needed beyond its room in a build since the lists were made,
    /// if any (reads one u32 back; u32::MAX: a part's pairs passed 2³²).
    pub fn overflow(&self, gpu: &Gpu) -> Option<u32> {
        let needed: Vec<u32> = gpu.read(&self.overflow);
        (needed[0] > 0).then_some(needed[0])
    }

    /// The pairs of the last build (reads the offsets back).
    pub fn pairs(&self, gpu: &Gpu) -> u64 {
        let offsets: Vec<u32> = gpu.read(&self.offsets);
        (self.parts.iter())
            .map(|p| {
                let (first, end) = (p.first as usize, (p.first + p.rows) as usize);
                u64::from(offsets[end].wrapping_sub(offsets[first]))
            })
            .sum()
    }

    /// The lists of the last build, read back (waits for the queue); a part past its room
    /// keeps the pairs it held.
    pub fn lists(&self, gpu: &Gpu) -> crate::core::neighbour::Csr {
        let offsets: Vec<u32> = gpu.read(&self.offsets);
        let mut csr = crate::core::neighbour::Csr {
            offsets: vec![0],
            ids: Vec::new(),
        };
        for part in &self.parts {
            let ids: Vec<u32> = gpu.read(&part.ids);
            let base = offsets[part.first as usize];
            for i in part.first..part.first + part.rows {
                let local =
                    |i: u32| (offsets[i as usize].wrapping_sub(base) as usize).min(ids.len());
                csr.ids.extend(&ids[local(i)..local(i + 1)]);
                csr.offsets.push(csr.ids.len());
            }
        }
        csr
    }
}

/// Builds the CSR neighbour lists of the particles `at` once: all pairs i ≠ j with
/// |x_i − x_j| ≤ `radius` (within a body, with per-body masks), ids ascending. `lo`/`hi`
/// is their bounding box. Starts with room for 64 pairs per particle and, if a build
/// overflows, builds again with the room it asked for (one readback each).
///
/// Panics if `radius` is not positive and finite or `x` holds fewer than `n` positions.
pub fn build<D: GpuDim>(
    gpu: &Gpu,
    at: Positions,
    lo: [f64; 3],
    hi: [f64; 3],
    radius: f64,
) -> Result<CellList, GpuError> {
    assert!(
        radius.is_finite() && radius > 0.0,
        "neighbour radius must be positive, got {radius}"
    );
    let floats = (at.offset + at.n as usize * D::N) as u64;
    assert!(
        at.x.size() >= floats * 4,
        "positions buffer holds {} bytes, fewer than {floats} floats",
        at.x.size()
    );
    let grid = CellParams::new(gpu, D::N, lo, hi, at.n, radius)?;
    let mut room = Room::fitting(gpu, at.n, u64::from(at.n) * 64)?;
    loop {
        let list = CellList::new::<D>(gpu, at, &grid, room, 0.0)?;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        list.record(gpu, &mut encoder);
        gpu.queue.submit([encoder.finish()]);
        match list.overflow(gpu) {
            None => return Ok(list),
            Some(needed) => room = Room::fitting(gpu, at.n, room.grown(at.n, needed))?,
        }
    }
}

super::context::wgsl_twin_test!(cell_params_match_wgsl: CellParams = "CellParams" in CELL_LIST.text);
super::context::wgsl_twin_test!(scan_params_match_wgsl: ScanParams = "ScanParams" in SCAN.text);

#[cfg(test)]
mod tests {
    use super::Room;

    #[test]
    fn room_is_one_part_while_the_pairs_fit_and_equal_rows_past_it() {
        // 400,000 pairs of 4 B fit one 2 MiB binding: one part of every row.
        let whole = Room::plan(10_000, 400_000, 2 << 20).unwrap();
        assert_eq!(
            whole,
            Room {
                rows: 10_000,
                pairs: 400_000
            }
        );
        assert_eq!(whole.parts(10_000), [(0, 10_000)]);
        // Past 1 MiB (262,144 ids): at most 6,400 rows (25 workgroups) a part, so 2 parts,
        // of 5,000 rows rounded up to 20 workgroups, each with its rows' share of the pairs.
        let split = Room::plan(10_000, 400_000, 1 << 20).unwrap();
        assert_eq!(
            split,
            Room {
                rows: 5120,
                pairs: 204_800
            }
        );
        assert_eq!(split.parts(10_000), [(0, 5120), (5120, 4880)]);
        assert_eq!(split.total(10_000), 409_600);
        // A build whose fullest part needed 300,000 pairs: a quarter more, over every row.
        assert_eq!(split.grown(10_000, 300_000), 732_422);
        // One workgroup's share, 2.56e6 pairs, passes 1,024 ids: refused with its bytes.
        assert_eq!(Room::plan(1000, 10_000_000, 4096), Err(10_240_000));
    }
}
