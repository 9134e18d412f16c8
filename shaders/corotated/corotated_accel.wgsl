// Corotated total-Lagrangian SPH on the device (seed 000 §5.5), pass 2 of a rate
// evaluation: with FORCE_VARIATIONAL m_i a_i = Σ_j V_i V_j (R_i P̂_i ∇0W_ij −
// R_j P̂_j ∇0W_ji), the reverse gradients GREV copied at set-up from the reverse pairs'
// gradients; with FORCE_REFERENCE_CODE Σ_j V_i V_j ½(R_i + R_j)(P̂_i + P̂_j)
// ∇0W_ij (eqs 154–155 as the reference code writes them); plus Monaghan viscosity along
// ½(R_iF̂_i⁻ᵀ + R_jF̂_j⁻ᵀ)∇0W_ij, boundary conditions (boundary.wgsl) and u̇ = v. One
// invocation per particle; writes only its own particle. Buffers and constants as in
// corotated.wgsl, with ext (the external accelerations, DIM per particle) and the rates
// d = [u̇ | v̇]; AV, AV_ALPHA, AV_BETA, AV_ETA (viscosity.wgsl).

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<f32>;
@group(0) @binding(4) var<storage, read> y: array<f32>;
// The kinematics of the shape-matching pass; this pass writes only the power and
// reactions (boundary.wgsl) and the viscous dissipation (KDIS).
@group(0) @binding(5) var<storage, read_write> kin: array<f32>;
@group(0) @binding(6) var<storage, read> ext: array<f32>;
@group(0) @binding(7) var<storage, read_write> d: array<f32>;

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// ∇0W_ij, and ∇0W_ji for the variational force; X_j − X_i for the viscosity.
// - pair: 1 vector per pair
// - pair: 1 vector per pair, when FORCE == FORCE_VARIATIONAL
// - pair: 1 vector per pair, when AV
// - reference: 2 scalars per item
// v; u for the viscosity.
// - y: 1 vector per item
// - y: 1 vector per item, when AV
// R, P̂ in; R F̂⁻ᵀ and ρ for the viscosity; the power out.
// - kin loads: 2 tensors per item
// - kin loads: 1 scalar + 1 tensor per item, when AV
// - kin stores: 2 scalars per item
// - ext: 1 vector per item
// - d: 2 vectors per item
@compute @workgroup_size(256)
fn accel(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let r_i = mload_kin(KR_OFF + DIM * DIM * i);
    let p_i = mload_kin(KP_OFF + DIM * DIM * i);
    let push_i = mload_kin(KFIT_OFF + DIM * DIM * i);
    let rho_i = kin[KRHO_OFF + i];
    let v_i = vload_y(V_OFF + DIM * i);
    let u_i = vload_y(U_OFF + DIM * i);
    let c_i = sqrt(BULK / rho_i);
    var stress: vecd;
    var viscous: vecd;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let g = vload_pair(PG_OFF + DIM * p);
        let r_j = mload_kin(KR_OFF + DIM * DIM * j);
        let p_j = mload_kin(KP_OFF + DIM * DIM * j);
        if FORCE == FORCE_VARIATIONAL {
            // (R_i P̂_i ∇0W_ij − R_j P̂_j ∇0W_ji) V_j.
            let g_rev = vload_pair(PGREV_OFF + DIM * p);
            stress += (r_i * (p_i * g) - r_j * (p_j * g_rev)) * vol_of(j);
        } else {
            // ½(R_i + R_j)(P̂_i + P̂_j)∇0W_ij V_j (eq 155).
            stress += (r_i + r_j) * ((p_i + p_j) * g) * (0.5 * vol_of(j));
        }
        if AV == 1u {
            let x_ij = u_i - vload_y(U_OFF + DIM * j) - vload_pair(PDX_OFF + DIM * p);
            let rho_j = kin[KRHO_OFF + j];
            let c = 0.5 * (c_i + sqrt(BULK / rho_j));
            let pi = monaghan_pi(x_ij, v_i - vload_y(V_OFF + DIM * j), c, 0.5 * (rho_i + rho_j));
            if pi != 0.0 {
                let along = (push_i + mload_kin(KFIT_OFF + DIM * DIM * j)) * g;
                viscous -= along * (0.5 * RHO0 * vol_of(j) * pi);
            }
        }
    }
    kin[KDIS_OFF + i] = -RHO0 * vol_of(i) * dot(viscous, v_i);
    let a = apply_boundary(i, stress * (1.0 / RHO0) + viscous, v_i, RHO0 * vol_of(i));
    vstore_d(V_OFF + DIM * i, a);
    vstore_d(U_OFF + DIM * i, v_i);
}
