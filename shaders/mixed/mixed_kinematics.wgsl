// Pass 1 of a mixed rate evaluation (MixedSph::kinematics), one invocation per real
// particle: P(F, H, J) (mechanics.wgsl) and ∇0v_a = Σ_b V_b (v_b − v_a) ⊗ g_ab, and from
// them the rates Ḟ = ∇0v, Ḣ = F × ∇0v and J̇ = H : ∇0v (eqs 39b–d; the rates pass adds
// D(J)). Under artificial compressibility (AC = 1) P takes the evolved pressure p of the
// state and ṗ = κ̃ H : ∇0v is the predictor's (mixed_corrector.wgsl corrects it). P, and H = cof F and J = det F where they are not evolved, take the F of the
// stress (stress_excess: the evolved F or the bond-based F^c); Ḣ takes the evolved F. det F ≤ 0 records the
// particle in status[0], J ≤ 0 in status[1] (u32 atomicMin). The von Mises model
// (MODEL 5) returns F from the particle's history instead (plasticity.wgsl). Layout and
// constants: mixed.wgsl.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
// G_b(X_a) = V_b g_ab per pair at PG_OFF (DIM each).
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> y: array<f32>;
@group(0) @binding(4) var<storage, read_write> kin: array<f32>;
@group(0) @binding(5) var<storage, read_write> d: array<f32>;
@group(0) @binding(6) var<storage, read_write> status: array<atomic<u32>>;
// The plastic history (plasticity.wgsl), read with MODEL 5 only.
@group(0) @binding(7) var<storage, read> hist: array<f32>;

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// ∇0W̃_ab.
// - pair: 1 vector per pair
// v, F; H, J and p where evolved; ghosts' v and the bond-based F^c from kin.
// - y: 1 vector + 1 tensor per item
// - y: 1 tensor per item, when EVOLVE_H
// - y: 1 scalar per item, when EVOLVE_J
// - y: 1 scalar per item, when AC
// - kin loads: 1 tensor per item, when BOND
// - hist: 12 scalars per item, when MODEL == MODEL_VON_MISES_PLASTIC
// P (and H).
// - kin stores: 1 tensor per item
// - kin stores: 1 tensor per item, when KIN_H
// Ḟ, Ḣ, J̇, ṗ.
// - d: 1 tensor per item
// - d: 1 tensor per item, when EVOLVE_H
// - d: 1 scalar per item, when EVOLVE_J
// - d: 1 scalar per item, when AC
// - status: nothing
@compute @workgroup_size(256)
fn kinematics(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    let v_a = velocity(a);
    var grad_v: matd;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        grad_v += outer(velocity(ids[p]) - v_a, vload_pair(PG_OFF + DIM * p));
    }
    let f = stress_excess(a);
    let h = h_excess(a, f);
    let det_f = det_excess(f);
    var j = det_f;
    if EVOLVE_J == 1u {
        j = y[J_OFF + a];
    }
    if !(1.0 + det_f > 0.0) {
        atomicMin(&status[0], a);
    }
    if !(1.0 + j > 0.0) {
        atomicMin(&status[1], a);
    }
    if MODEL == MODEL_VON_MISES_PLASTIC {
        let returned = return_map(lift3(identity_d() + f, 1.0), history(a));
        mstore_kin(KP_OFF + DIM * DIM * a, lower3(returned.p));
    } else if AC == 1u {
        mstore_kin(KP_OFF + DIM * DIM * a, pk1_pressure(f, h, j, y[PRES_OFF + a]));
    } else {
        mstore_kin(KP_OFF + DIM * DIM * a, pk1_mixed(f, h, j));
    }
    if KIN_H == 1u {
        mstore_kin(KH_OFF + DIM * DIM * a, h);
    }
    mstore_d(F_OFF + DIM * DIM * a, grad_v);
    if EVOLVE_H == 1u {
        mstore_d(H_OFF + DIM * DIM * a, cof_rate(mload_y(F_OFF + DIM * DIM * a), grad_v));
    }
    if EVOLVE_J == 1u {
        d[J_OFF + a] = ddot_d(identity_d() + h, grad_v);
    }
    if AC == 1u {
        // eq 51d without D(J): the predictor's ṗ = κ̃ H : ∇0v (BULK is κ̃).
        d[PRES_OFF + a] = BULK * ddot_d(identity_d() + h, grad_v);
    }
}
