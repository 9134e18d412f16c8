// Reference pair offsets X_j − X_i, once per total-Lagrangian scene, from positions split
// into f32 high and low parts (X = hi + lo): hi_j − hi_i is exact for nearby points, so
// the offsets keep their digits where a difference of rounded positions would lose |X|/Δx.
// Writes the per-pair field at PDX_OFF (DIM per pair) of `pair`.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> reference: array<f32>;
@group(0) @binding(3) var<storage, read_write> pair: array<f32>;

@compute @workgroup_size(256)
fn pair_offsets(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let hi_i = x0_of(i);
    let lo_i = vload_reference(RXLO_OFF + DIM * i);
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let lo_j = vload_reference(RXLO_OFF + DIM * j);
        vstore_pair(PDX_OFF + DIM * p, (x0_of(j) - hi_i) + (lo_j - lo_i));
    }
}
