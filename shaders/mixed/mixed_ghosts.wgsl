// Ghost fills of the mixed passes (src/physics/mirror.rs): ghost k (extended index N + k) takes its
// source's fields through its image (mixed_images.wgsl); slopes ∂P'/∂X'_l =
// r_l σ R (∂P/∂X_l) R. One invocation per ghost.

// bytes block ghost_map:
// A ghost's source particle and its image (reflection and sign); an item is a ghost. The
// gathers read a ghost's values once each, counted here, not in the gathers.
// - ghost_src: 1 scalar per item
// - ghost_img: 1 scalar + 1 vector per item
@group(0) @binding(0) var<storage, read> ghost_src: array<u32>;
// r_0 … r_{DIM−1}, σ per ghost.
@group(0) @binding(1) var<storage, read> ghost_img: array<f32>;
// The field filled: the kinematics (the ghost motion [u | v] at KGM_OFF, or in place P
// and H), or in place the slopes or Laplacians of the extended particles.
@group(0) @binding(2) var<storage, read_write> field: array<f32>;
@group(0) @binding(3) var<storage, read> y: array<f32>;

// bytes:
// - include ghost_map
// - y: 2 vectors per item
// - field: 2 vectors per item
@compute @workgroup_size(256)
fn ghost_motion(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k >= NG {
        return;
    }
    let s = ghost_src[k];
    vstore_field(KGM_OFF + DIM * k, map_vector(k, vload_y(U_OFF + DIM * s)));
    vstore_field(KGM_OFF + DIM * (NG + k), map_vector(k, vload_y(V_OFF + DIM * s)));
}

// bytes:
// - include ghost_map
// - field loads: 1 tensor per item
// - field stores: 1 tensor per item
// - field loads: 1 tensor per item, when KIN_H
// - field stores: 1 tensor per item, when KIN_H
@compute @workgroup_size(256)
fn ghost_kin(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k >= NG {
        return;
    }
    let s = ghost_src[k];
    let g = N + k;
    mstore_field(KP_OFF + DIM * DIM * g, map_tensor(k, mload_field(KP_OFF + DIM * DIM * s)));
    if KIN_H == 1u {
        mstore_field(KH_OFF + DIM * DIM * g, map_tensor(k, mload_field(KH_OFF + DIM * DIM * s)));
    }
}

// bytes:
// - include ghost_map
// - field loads: 1 slope per item
// - field stores: 1 slope per item
@compute @workgroup_size(256)
fn ghost_slopes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k >= NG {
        return;
    }
    let s = SLOPE * ghost_src[k];
    let g = SLOPE * (N + k);
    let r = reflection(k);
    mstore_field(g, map_tensor(k, mload_field(s)));
    for (var l = 0u; l < DIM; l++) {
        let at = (l + 1u) * DIM * DIM;
        mstore_field(g + at, map_tensor(k, mload_field(s + at)) * r[l]);
    }
}

// bytes:
// - include ghost_map
// - field loads: 1 vector per item
// - field stores: 1 vector per item
@compute @workgroup_size(256)
fn ghost_laplacian(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k >= NG {
        return;
    }
    vstore_field(DIM * (N + k), map_vector(k, vload_field(DIM * ghost_src[k])));
}
