// The weak form's velocity smoothing after a step (seed 000 §5.6): v_a ← Σ_b N_b(X_a) v_b
// with N_b = V_b Ψ_b over the particles' own reproducing-kernel lists (a itself
// included), into `smoothed` (`smooth_velocities`), then back into the state but for the
// prescribed components, which keep their values (`settle`, settle.wgsl). Weights:
// smooth_weights = [N per pair]. The lists and weights bound to `smooth_velocities` are
// those of a part of the nodes (part.wgsl), the offsets counted from its first pair.
// Constants: N, DIM,
// V_OFF, SWN_OFF and the reference fields.

@group(0) @binding(0) var<storage, read> smooth_offsets: array<u32>;
@group(0) @binding(1) var<storage, read> smooth_ids: array<u32>;
@group(0) @binding(2) var<storage, read> smooth_weights: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<f32>;
@group(0) @binding(4) var<storage, read_write> y: array<f32>;
@group(0) @binding(5) var<storage, read_write> smoothed: array<f32>;

// bytes:
// Items: nodes; pairs: counted as the point–node pairs (the smoothing lists are about
// as long).
// - smooth_offsets: 1 scalar per item
// - smooth_ids: 1 scalar per pair
// - smooth_weights: 1 scalar per pair
// - y: 1 vector per pair
// - smoothed: 1 vector per item
@compute @workgroup_size(256)
fn smooth_velocities(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    var v: vecd;
    let p_end = smooth_offsets[row + 1u];
    for (var p = smooth_offsets[row]; p < p_end; p++) {
        v += vload_y(V_OFF + DIM * smooth_ids[p]) * smooth_weights[SWN_OFF + p];
    }
    vstore_smoothed(DIM * a, v);
}
