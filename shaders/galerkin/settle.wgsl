// The smoothed velocities back into the state after a step (galerkin_smooth.wgsl,
// ul_weak_form/ul_weak_form.wgsl), but for the prescribed components, which keep their
// values. Needs the bindings reference, smoothed (DIM per node) and y (writable).

// bytes:
// Items: nodes.
// - reference: 1 scalar per item
// - smoothed: 1 vector per item
// - y: 1 vector per item
@compute @workgroup_size(256)
fn settle(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let a = index(gid, nwg);
    if a >= N {
        return;
    }
    let m = mask_of(a);
    for (var k = 0u; k < DIM; k++) {
        if ((m >> k) & 1u) == 0u {
            y[V_OFF + DIM * a + k] = smoothed[DIM * a + k];
        }
    }
}
