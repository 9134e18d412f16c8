// Cell list and CSR neighbour lists: all pairs (i, j), i ≠ j, with |x_i − x_j|² ≤ radius²
// (and, with MASKED = 1, body[i] = body[j]), each particle's ids sorted ascending (the same
// lists as src/core/neighbour.rs). Positions are read from a flat f32 buffer, DIM floats per
// particle from POS_OFF (a state's displacement or position field, or positions alone).
// The rows are split into parts (src/gpu/neighbour.rs, `Room`), each with its own `ids`
// counted from the part's first pair; `offsets` counts over every particle (wrapping past
// 2³²). A part's lists fill its `ids` up to its length, the capacity; past it `overflow[0]`
// receives the most pairs a part needs, and the host grows the parts. Nothing is read back
// to rebuild.
//
// A build is due when check_drift finds a particle that moved more than sqrt(drift2)
// since the last one (or the host forces one); `arm` then sets the workgroup counts of the
// build's dispatches, which are all indirect, so nothing comes back to the host to decide.
// Passes, in order (the scans of scan.wgsl between them):
//   clear_counts      cell_start and offsets to zero
//   bin_particles     cell id of each particle, and per-cell counts (atomicAdd)
//   (scan of counts → cell_start, n + …)
//   copy_cursor       cursor = cell_start
//   scatter           particle ids into cell-sorted order (atomic cursors)
//   count_neighbours  offsets[i] = number of neighbours of i
//   (scan of offsets over n + 1 entries: offsets[n] = number of pairs)
//   fill_neighbours   ids[offsets[i]..offsets[i + 1]] = neighbours of i, sorted; one
//                     dispatch a part of the rows (part.wgsl), each with its own ids
//   save_built        the positions of this build, for the next drift check
// Each invocation writes only its own particle's entries (plus the u32 atomic counters).

struct CellParams {
    // Grid origin (lower corner of the bounding box; z = 0 in 2D).
    origin: vec3<f32>,
    // 1 / cell edge.
    inv_cell: f32,
    // Cells per axis (z = 1 in 2D).
    dims: vec3<u32>,
    // Number of particles.
    n: u32,
    radius2: f32,
    // dims.x * dims.y * dims.z.
    ncells: u32,
    // Square of the displacement since the last build that keeps the lists complete.
    drift2: f32,
    // Dispatches of a build (3 entries each in `args` and `full`).
    dispatches: u32,
}

@group(0) @binding(0) var<uniform> params: CellParams;
@group(0) @binding(1) var<storage, read> x: array<f32>;
// Cell id of each particle.
@group(0) @binding(2) var<storage, read_write> cell: array<u32>;
// Counts per cell, then (after the scan) the first sorted slot of each cell; ncells + 1.
@group(0) @binding(3) var<storage, read_write> cell_start: array<atomic<u32>>;
// Next free sorted slot of each cell (a copy of cell_start).
@group(0) @binding(4) var<storage, read_write> cursor: array<atomic<u32>>;
// Particle ids in cell order.
@group(0) @binding(5) var<storage, read_write> sorted: array<u32>;
// Neighbour counts, then (after the scan) CSR offsets; n + 1.
@group(0) @binding(6) var<storage, read_write> offsets: array<u32>;
// CSR neighbour ids of the part (fill_neighbours).
@group(0) @binding(7) var<storage, read_write> ids: array<u32>;
// The body of each particle (read with MASKED = 1).
@group(0) @binding(8) var<storage, read> body: array<u32>;
// The most pairs of a part, where they exceed the capacity of its `ids` (atomicMax).
@group(0) @binding(9) var<storage, read_write> overflow: array<atomic<u32>>;
// The positions of the last build, DIM floats per particle.
@group(0) @binding(10) var<storage, read_write> built: array<f32>;
// [0]: a build is due (set by check_drift, or by the host to force one); [1]: builds so far.
@group(0) @binding(11) var<storage, read_write> due: array<atomic<u32>>;
// Workgroup counts (x, y, z) of the dispatches of a build: `full` when one is due, else 0.
@group(0) @binding(12) var<storage, read_write> args: array<u32>;
@group(0) @binding(13) var<storage, read> full: array<u32>;

fn position(i: u32) -> vecd {
    return vload_x(POS_OFF + DIM * i);
}

fn cell_of(p: vecd) -> vec3<u32> {
    return cell_coords(p, params.origin, params.inv_cell, params.dims);
}

fn cell_id(c: vec3<u32>) -> u32 {
    return (c.z * params.dims.y + c.y) * params.dims.x + c.x;
}

// bytes:
// - x: 1 vector per item
// - cell: 1 scalar per item
// - cell_start: 1 scalar per item
@compute @workgroup_size(256)
fn bin_particles(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = index(gid, nwg);
    if i >= params.n {
        return;
    }
    let c = cell_id(cell_of(position(i)));
    cell[i] = c;
    atomicAdd(&cell_start[c], 1u);
}

// bytes:
// - cell: 1 scalar per item
// - cursor: 1 scalar per item
// - sorted: 1 scalar per item
@compute @workgroup_size(256)
fn scatter(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = index(gid, nwg);
    if i >= params.n {
        return;
    }
    let slot = atomicAdd(&cursor[cell[i]], 1u);
    sorted[slot] = i;
}

// Visits the candidates of the 3^DIM cells around particle i. Counts the neighbours;
// with `fill`, also inserts them into ids[first..end) in ascending order (insertion sort
// over the particle's own slice; lists are short). Count and fill run this same code,
// so they select the same set.
fn gather(i: u32, fill: bool, first: u32, end: u32) -> u32 {
    let xi = position(i);
    let c = cell_of(xi);
    let lo = max(c, vec3<u32>(1u)) - vec3<u32>(1u);
    let hi = min(c + vec3<u32>(1u), params.dims - vec3<u32>(1u));
    // In 2D the z range is the single layer 0 (dims.z = 1); DIM makes that explicit.
    var z_hi = hi.z;
    if DIM == 2u {
        z_hi = 0u;
    }
    var count = 0u;
    for (var z = lo.z; z <= z_hi; z++) {
        for (var y = lo.y; y <= hi.y; y++) {
            // Cells lo.x..=hi.x of a row are contiguous, so are their sorted particles.
            let row = (z * params.dims.y + y) * params.dims.x;
            let s = atomicLoad(&cell_start[row + lo.x]);
            let e = atomicLoad(&cell_start[row + hi.x + 1u]);
            for (var k = s; k < e; k++) {
                let j = sorted[k];
                let d = position(j) - xi;
                if j == i || dot(d, d) > params.radius2 {
                    continue;
                }
                if MASKED == 1u && body[j] != body[i] {
                    continue;
                }
                if fill && first + count < end {
                    var slot = first + count;
                    loop {
                        if slot == first || ids[slot - 1u] < j {
                            break;
                        }
                        ids[slot] = ids[slot - 1u];
                        slot -= 1u;
                    }
                    ids[slot] = j;
                }
                count += 1u;
            }
        }
    }
    return count;
}

// bytes:
// The cell starts, the sorted ids and a candidate's position are counted once per item,
// however many neighbours' searches read them.
// - x: 1 vector per item
// - cell_start: 1 scalar per item
// - sorted: 1 scalar per item
// - body: 1 scalar per item, when MASKED
// - offsets: 1 scalar per item
// The search it shares with `fill_neighbours` fills ids there only.
// - ids: nothing
@compute @workgroup_size(256)
fn count_neighbours(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = index(gid, nwg);
    if i >= params.n {
        return;
    }
    offsets[i] = gather(i, false, 0u, 0u);
}

// bytes:
// The ids of a row are sorted in place as they are found: read and written.
// The cell starts, the sorted ids and a candidate's position are counted once per item,
// however many neighbours' searches read them.
// - x: 1 vector per item
// - cell_start: 1 scalar per item
// - sorted: 1 scalar per item
// - body: 1 scalar per item, when MASKED
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// - overflow: nothing
@compute @workgroup_size(256)
fn fill_neighbours(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    // The part's ids count from its first pair; the differences of the offsets, which
    // wrap past 2³² pairs in all, are exact within a part.
    let base = offsets[part.first];
    let first = offsets[i] - base;
    let end = offsets[i + 1u] - base;
    let capacity = arrayLength(&ids);
    if row == 0u {
        let pairs = offsets[part.first + part.rows] - base;
        if pairs > capacity {
            atomicMax(&overflow[0], pairs);
        }
    }
    if end < first {
        // The part's pairs pass 2³²: it needs more than any part can hold.
        atomicMax(&overflow[0], 0xffffffffu);
    }
    _ = gather(i, true, first, min(end, capacity));
}

// bytes:
// - x: 1 vector per item
// - built: 1 vector per item
// - due: nothing
@compute @workgroup_size(256)
fn check_drift(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = index(gid, nwg);
    if i >= params.n {
        return;
    }
    let p = position(i);
    var d2 = 0.0;
    for (var k = 0u; k < DIM; k++) {
        let e = p[k] - built[DIM * i + k];
        d2 += e * e;
    }
    // Written so that a NaN position asks for a build too.
    if !(d2 <= params.drift2) {
        atomicMax(&due[0], 1u);
    }
}

// bytes:
// One item: 3 workgroup counts of each of a build's dispatches (12 with one
// level of each scan).
// - due: 2 scalars per item
// - full: 36 scalars per item
// - args: 36 scalars per item
@compute @workgroup_size(1)
fn arm() {
    let build = atomicLoad(&due[0]) != 0u;
    let entries = 3u * params.dispatches;
    for (var k = 0u; k < entries; k++) {
        args[k] = select(0u, full[k], build);
    }
    if build {
        atomicAdd(&due[1], 1u);
    }
    atomicStore(&due[0], 0u);
}

// bytes:
// - cell_start: 1 scalar per item
// - offsets: 1 scalar per item
@compute @workgroup_size(256)
fn clear_counts(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = index(gid, nwg);
    if i <= params.ncells {
        atomicStore(&cell_start[i], 0u);
    }
    if i <= params.n {
        offsets[i] = 0u;
    }
}

// bytes:
// - cell_start: 1 scalar per item
// - cursor: 1 scalar per item
@compute @workgroup_size(256)
fn copy_cursor(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let c = index(gid, nwg);
    if c < params.ncells {
        atomicStore(&cursor[c], atomicLoad(&cell_start[c]));
    }
}

// bytes:
// - x: 1 vector per item
// - built: 1 vector per item
@compute @workgroup_size(256)
fn save_built(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = index(gid, nwg);
    if i >= params.n {
        return;
    }
    let p = position(i);
    for (var k = 0u; k < DIM; k++) {
        built[DIM * i + k] = p[k];
    }
}
