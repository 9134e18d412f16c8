// Total-Lagrangian SPH rates (seed 000 §5.3), one invocation per particle of a part of
// the lists (part.wgsl), gathering over its CSR neighbours and writing only its own
// particle.
//
// Buffers are flat f32 arrays in structure-of-arrays segments: the state y = [u | v | ρ − ρ0 | S]
// (ρ and S only for the rate model; the density is stored as its deviation so that the
// pressure c0²(ρ − ρ0) keeps its digits in f32, as u = x − X does for positions), the
// per-particle kinematics kin = [H = F − I | P | F⁻ᵀ | ρ | power] (H, not F, for the same
// reason), the per-pair data pair = [∇0W̃ | X_j − X_i] (DIM each per pair) and the
// reference configuration (reference.wgsl). Constitutive functions: mechanics.wgsl.
// Scene constants: N, DIM, RATE, MODEL, RHO0, MU, LAMBDA, BULK, AV, AV_ALPHA, AV_BETA,
// AV_ETA (viscosity.wgsl), and the field offsets of methods::cores::tl::gpu::Layout (U_OFF, V_OFF, RHO_OFF,
// S_OFF; KF_OFF, KP_OFF, KFIT_OFF, KRHO_OFF, KPOW_OFF; PG_OFF, PDX_OFF), and KEEP_H,
// KEEP_AV: which kinematics besides P the pass stores.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<f32>;
@group(0) @binding(4) var<storage, read> y: array<f32>;
@group(0) @binding(5) var<storage, read_write> kin: array<f32>;
@group(0) @binding(6) var<storage, read_write> d: array<f32>;
@group(0) @binding(7) var<storage, read_write> status: array<atomic<u32>>;

// Pass 1: F = I + Σ V_j (u_j − u_i) ⊗ ∇0W̃_ij (eq 137), P, and ρ̇, Ṡ of the rate model.
// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// ∇0W̃_ij.
// - pair: 1 vector per pair
// V_j.
// - reference: 1 scalar per item
// u; v (for Ḟ), ρ − ρ0 and S of the rate model.
// - y: 1 vector per item
// - y: 1 scalar + 1 vector + 1 tensor per item, when RATE
// P; H where the force pass or the outputs read it (KEEP_H); F⁻ᵀ and ρ where the
// viscosity or the outputs read them (KEEP_AV).
// - kin: 1 tensor per item
// - kin: 1 tensor per item, when KEEP_H
// - kin: 1 scalar + 1 tensor per item, when KEEP_AV
// - d: 1 scalar + 1 tensor per item, when RATE
// - status: nothing
@compute @workgroup_size(256)
fn stress(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let ui = vload_y(U_OFF + DIM * i);
    let vi = vload_y(V_OFF + DIM * i);
    var h: matd;
    var f_dot: matd;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let g = vload_pair(PG_OFF + DIM * p);
        let w = vol_of(j);
        h += outer(vload_y(U_OFF + DIM * j) - ui, g) * w;
        if RATE == 1u {
            f_dot += outer(vload_y(V_OFF + DIM * j) - vi, g) * w;
        }
    }
    let f = identity_d() + h;
    let jac = determinant(f);
    if !(jac > 0.0) {
        atomicMin(&status[0], i);
    }
    let f_inv = inverse_d(f);
    let f_inv_t = transpose(f_inv);
    var p: matd;
    var rho: f32;
    if RATE == 1u {
        let l = f_dot * f_inv;
        let rho_dev = y[RHO_OFF + i];
        rho = RHO0 + rho_dev;
        let s = mload_y(S_OFF + DIM * DIM * i);
        d[RHO_OFF + i] = -rho * trace_d(l);
        mstore_d(S_OFF + DIM * DIM * i, stress_rate(s, l, f));
        p = (s - identity_d() * pressure(rho_dev)) * f_inv_t * jac;
    } else {
        rho = RHO0 / jac;
        p = pk1(h, f_inv_t);
    }
    mstore_kin(KP_OFF + DIM * DIM * i, p);
    if KEEP_H == 1u {
        mstore_kin(KF_OFF + DIM * DIM * i, h);
    }
    if KEEP_AV == 1u {
        mstore_kin(KFIT_OFF + DIM * DIM * i, f_inv_t);
        kin[KRHO_OFF + i] = rho;
    }
}
