// Corrected reference kernel gradients, once per total-Lagrangian scene: one invocation
// per particle writes the gradients of its own pairs (CSR order).
// CORRECTION: CORRECTION_NONE (∇W), CORRECTION_SHEPARD (∇W / Σ_k V_k W_ik) or
// CORRECTION_LINEAR (Randles–Libersky, A_i⁻ᵀ ∇W with A_i = Σ_j V_j (X_j − X_i) ⊗ ∇W_ij).
// A singular A_i is reported through status[0]. Reads the reference pair offsets
// X_j − X_i at PDX_OFF of `pair` (pair_offsets.wgsl: exact to f32 rounding, so that mirror
// pairs stay exactly opposite) and writes the gradients at PG_OFF (DIM per pair).

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read_write> pair: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<f32>;
@group(0) @binding(4) var<storage, read_write> status: array<atomic<u32>>;

@compute @workgroup_size(256)
fn correct(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    var a: matd;
    var shepard = vol_of(i) * kernel_w(0.0);
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let x_ij = -vload_pair(PDX_OFF + DIM * p);
        a += outer(-x_ij, kernel_grad(x_ij)) * vol_of(j);
        shepard += vol_of(j) * kernel_w(length(x_ij));
    }
    var m = identity_d();
    if CORRECTION == CORRECTION_SHEPARD {
        m = identity_d() * (1.0 / shepard);
    } else if CORRECTION == CORRECTION_LINEAR {
        if !(abs(determinant(a)) > 1e-6) {
            atomicMin(&status[0], i);
        }
        m = transpose(inverse_d(a));
    }
    for (var p = offsets[row]; p < p_end; p++) {
        let x_ij = -vload_pair(PDX_OFF + DIM * p);
        vstore_pair(PG_OFF + DIM * p, m * kernel_grad(x_ij));
    }
}
