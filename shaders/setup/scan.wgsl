// Exclusive prefix sum of an array<u32> of arbitrary length (u32, wrapping).
//
// One level: `scan_blocks` scans each block of SCAN_BLOCK = 512 entries in place (one
// workgroup of 256 invocations, two entries each, in workgroup memory) and writes the
// block's total to `block_sums`. The host scans `block_sums` the same way, level by
// level, until one block remains, then `add_block_sums` adds each scanned block sum
// back to its block, from the top level down. Dispatches may be 2D (past 65,535
// workgroups); blocks and entries are flattened with num_workgroups.

struct ScanParams {
    // Number of entries scanned at this level.
    n: u32,
}

const SCAN_BLOCK: u32 = 512u;

@group(0) @binding(0) var<uniform> scan: ScanParams;
@group(0) @binding(1) var<storage, read_write> data: array<u32>;
@group(0) @binding(2) var<storage, read_write> block_sums: array<u32>;

var<workgroup> tile: array<u32, 512>;
var<workgroup> partial: array<u32, 256>;

// bytes:
// - data: 2 scalars per item
// The block sums (one per 512 entries) are not counted.
// - block_sums: nothing
@compute @workgroup_size(256)
fn scan_blocks(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = group_index(wid, nwg);
    // Uniform per workgroup: the padding groups of a 2D dispatch leave before any barrier.
    if block >= (scan.n + SCAN_BLOCK - 1u) / SCAN_BLOCK {
        return;
    }
    let first = block * SCAN_BLOCK;

    // Coalesced load; entries past n read as 0.
    var lo = 0u;
    var hi = 0u;
    if first + lid < scan.n {
        lo = data[first + lid];
    }
    if first + 256u + lid < scan.n {
        hi = data[first + 256u + lid];
    }
    tile[lid] = lo;
    tile[lid + 256u] = hi;
    workgroupBarrier();

    // Each invocation owns the pair (2 lid, 2 lid + 1); Hillis–Steele scan of pair sums.
    let a = tile[2u * lid];
    let s = a + tile[2u * lid + 1u];
    partial[lid] = s;
    workgroupBarrier();
    for (var offset = 1u; offset < 256u; offset = offset << 1u) {
        var t = 0u;
        if lid >= offset {
            t = partial[lid - offset];
        }
        workgroupBarrier();
        partial[lid] = partial[lid] + t;
        workgroupBarrier();
    }
    let before = partial[lid] - s;
    tile[2u * lid] = before;
    tile[2u * lid + 1u] = before + a;
    workgroupBarrier();

    if first + lid < scan.n {
        data[first + lid] = tile[lid];
    }
    if first + 256u + lid < scan.n {
        data[first + 256u + lid] = tile[lid + 256u];
    }
    if lid == 255u {
        block_sums[block] = partial[255];
    }
}

// data[i] += block_sums[i / SCAN_BLOCK], with block_sums already scanned.
// bytes:
// - data: 1 scalar per item
// The block sums (one per 512 entries) are not counted.
// - block_sums: nothing
@compute @workgroup_size(256)
fn add_block_sums(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let i = index(gid, nwg);
    if i >= scan.n {
        return;
    }
    data[i] = data[i] + block_sums[i / SCAN_BLOCK];
}
