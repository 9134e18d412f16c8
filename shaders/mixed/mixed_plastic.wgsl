// Commit of the plastic history before every step (MixedSph::begin_step): one invocation
// per real particle returns its evolved F of the step's start state from its history and
// stores the result in its own entries of hist. Layout and constants: mixed.wgsl,
// plasticity.wgsl.

@group(0) @binding(0) var<storage, read> y: array<f32>;
@group(0) @binding(1) var<storage, read_write> hist: array<f32>;

@compute @workgroup_size(256)
fn commit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let a = index(gid, nwg);
    if a >= N {
        return;
    }
    let f = lift3(identity_d() + mload_y(F_OFF + DIM * DIM * a), 1.0);
    let r = return_map(f, history(a));
    let o = 10u * a;
    for (var c = 0u; c < 3u; c++) {
        hist[o + 3u * c] = r.cp_inv[c].x;
        hist[o + 3u * c + 1u] = r.cp_inv[c].y;
        hist[o + 3u * c + 2u] = r.cp_inv[c].z;
    }
    hist[o + 9u] = r.eps_p;
}
