// Prescribed velocities that vary in time (src/boundary.rs, `TimedVelocity`), run before
// every step. For every particle with a timed component, the components held over the
// step get their rate v_p·rate_g in the particle's slot of the field RATE of `reference`
// (slot_of(i), reference.wgsl) and bits k and k + 4 of its mask there (k: prescribed;
// k + 4: its rate is RATE's, boundary.wgsl); the released ones are left free. `timed`
// holds, per particle, 1 + 2 DIM floats: the mask of its components held for the whole
// run, then per component 1 + the index g of its timed velocity (0: none), then v_p (the
// velocity at law value 1). `steps` holds per timed velocity g the step's (held: 0 or 1,
// rate), which the host writes for every step it records. Scene constants N, DIM,
// RMASK_OFF, RSLOT_OFF and RRATE_OFF.

@group(0) @binding(0) var<storage, read> timed: array<f32>;
@group(0) @binding(1) var<storage, read> steps: array<f32>;
@group(0) @binding(2) var<storage, read_write> reference: array<f32>;

// bytes:
// - timed: 1 scalar + 2 vectors per item
// - steps: nothing
// - reference loads: 1 scalar per item
// - reference stores: 1 scalar + 1 vector per item
@compute @workgroup_size(256)
fn timed_velocities(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = index(gid, nwg);
    if i >= N {
        return;
    }
    let base = (1u + 2u * DIM) * i;
    var mask = u32(timed[base]);
    var any = false;
    let s = u32(reference[RSLOT_OFF + i]);
    for (var k = 0u; k < DIM; k++) {
        let g = u32(timed[base + 1u + k]);
        if g == 0u {
            continue;
        }
        any = true;
        if steps[2u * (g - 1u)] != 0.0 {
            mask |= (1u << k) | (1u << (k + 4u));
            reference[RRATE_OFF + DIM * s + k] = timed[base + 1u + DIM + k] * steps[2u * (g - 1u) + 1u];
        }
    }
    if any {
        reference[RMASK_OFF + i] = f32(mask);
    }
}
