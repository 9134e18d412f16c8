// The copy bandwidth of an adapter (src/gpu/profile.rs): dst = src over a buffer far
// larger than any cache, 16 bytes per invocation. Needs no scene constants.

@group(0) @binding(0) var<storage, read> src: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> dst: array<vec4<f32>>;

// bytes:
// - src: 1 scalar per item
// - dst: 1 scalar per item
@compute @workgroup_size(256)
fn copy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k < arrayLength(&dst) {
        dst[k] = src[k];
    }
}
