// Commit of the plastic history before every step (MixedSph::begin_step): one invocation
// per real particle returns its evolved F of the step's start state from its history and
// stores the result in its own entries of hist (plastic_store.wgsl). Layout and
// constants: mixed.wgsl, plasticity.wgsl.

@group(0) @binding(0) var<storage, read> y: array<f32>;
@group(0) @binding(1) var<storage, read_write> hist: array<f32>;

// bytes:
// - y: 1 tensor per item
// - hist: 12 scalars per item
@compute @workgroup_size(256)
fn commit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let a = index(gid, nwg);
    if a >= N {
        return;
    }
    let f = lift3(identity_d() + mload_y(F_OFF + DIM * DIM * a), 1.0);
    store_history(a, return_map(f, history(a)));
}
