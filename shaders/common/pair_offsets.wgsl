// Reference pair offsets X_j − X_i, once per total-Lagrangian scene, from positions split
// into f32 high and low parts (X = hi + lo): hi_j − hi_i is exact for nearby points, so
// the offsets keep their digits where a difference of rounded positions would lose |X|/Δx.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> x_hi: array<f32>;
@group(0) @binding(3) var<storage, read> x_lo: array<f32>;
@group(0) @binding(4) var<storage, read_write> dx0: array<f32>;

@compute @workgroup_size(256)
fn pair_offsets(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * 256u;
    if i >= N {
        return;
    }
    let hi_i = vload_x_hi(DIM * i);
    let lo_i = vload_x_lo(DIM * i);
    for (var p = offsets[i]; p < offsets[i + 1u]; p++) {
        let j = ids[p];
        vstore_dx0(DIM * p, (vload_x_hi(DIM * j) - hi_i) + (vload_x_lo(DIM * j) - lo_i));
    }
}
