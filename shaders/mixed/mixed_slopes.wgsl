// Pass 2 of a mixed rate evaluation, one invocation per real particle. Upwind-SPH with
// reconstruction (MixedSph::slopes): least-squares gradients of v and of P (eq 37),
// 𝒢_a = Σ_b (𝒰_b − 𝒰_a) w_ab with w_ab = M_a⁻¹ N_ab / |d_ab|. JST-SPH
// (MixedSph::laplacians): ∇²v_a = Σ_b ℓ_ab (v_b − v_a) (seed 002 eq 27). The weights are
// per pair: w_ab at PLS_OFF (DIM each), ℓ_ab at PELL_OFF. Layout and constants:
// mixed.wgsl.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> y: array<f32>;
// Slopes (SLOPE per extended particle) or Laplacians (DIM per extended particle).
@group(0) @binding(4) var<storage, read_write> out: array<f32>;
@group(0) @binding(5) var<storage, read> kin: array<f32>;

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// Least-squares weights.
// - pair: 1 vector per pair
// - y: 1 vector per item
// P (and ghosts' v).
// - kin: 1 tensor per item
// - out: 1 slope per item
@compute @workgroup_size(256)
fn slopes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    let v_a = velocity(a);
    let p_a = mload_kin(KP_OFF + DIM * DIM * a);
    var grad_v: matd;
    var grad_p: array<matd, 3>;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let b = ids[p];
        let w = vload_pair(PLS_OFF + DIM * p);
        grad_v += outer(velocity(b) - v_a, w);
        let dp = mload_kin(KP_OFF + DIM * DIM * b) - p_a;
        for (var l = 0u; l < DIM; l++) {
            grad_p[l] += dp * w[l];
        }
    }
    let at = SLOPE * a;
    mstore_out(at, grad_v);
    for (var l = 0u; l < DIM; l++) {
        mstore_out(at + (l + 1u) * DIM * DIM, grad_p[l]);
    }
}

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// Laplacian weights.
// - pair: 1 scalar per pair
// - y: 1 vector per item
// - kin: nothing
// - out: 1 vector per item
@compute @workgroup_size(256)
fn laplacian(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    let v_a = velocity(a);
    var sum: vecd;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        sum += (velocity(ids[p]) - v_a) * pair[PELL_OFF + p];
    }
    vstore_out(DIM * a, sum);
}
