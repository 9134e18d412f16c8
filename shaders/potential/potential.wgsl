// Total-Lagrangian SPH from the elastic potential on the device (seed 000 §5.4, eq 148
// symmetrised; methods::potential::system on the CPU), on the stress pass of tlsph.wgsl
// (P = ∂ψ/∂F in kin, with H = F − I for the hourglass force and F⁻ᵀ, ρ0/J for the
// viscosity). Buffers as in tlsph.wgsl, with the per-pair data
// pair = [∇0W̃ | X_j − X_i | ∇0W̃_ji]. Scheme constants: FORCE (FORCE_CONSISTENT: weights V_i V_j on both terms;
// FORCE_REFERENCE_CODE: V_i and V_j, seed 000 §3.4), AV, AV_ALPHA, AV_BETA, AV_ETA, and
// HOURGLASS_DS: dual-support SPH's hourglass force (seed 004 eq 28 with its sign
// corrected; methods::dual_support::model), on its lists S_i ∪ S'_i with
// ∇0W̃_ij = g_ij/V_j (zero where j ∉ S_i) and the stiffnesses k_ij = 2 V_i c_i w_ij (HGK)
// and k_ji (HGKR) of both sides of every pair.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<f32>;
@group(0) @binding(4) var<storage, read> y: array<f32>;
// The kinematics of the stress pass; this pass writes only the power and reactions
// (boundary.wgsl) and the viscous dissipation (KDIS).
@group(0) @binding(5) var<storage, read_write> kin: array<f32>;
@group(0) @binding(6) var<storage, read> ext: array<f32>;
@group(0) @binding(7) var<storage, read_write> d: array<f32>;
// m_i a_i = Σ_j [w_ij P_i ∇0W̃_ij − w_ji P_j ∇0W̃_ji] (eq 148 symmetrised) plus Monaghan
// viscosity along ½(F_i⁻ᵀ ∇0W̃_ij − F_j⁻ᵀ ∇0W̃_ji), the dual-support hourglass force
// Σ_j [(k_ij + k_ji)(u_j − u_i) − (k_ij H_i + k_ji H_j) X_ij], boundary conditions and
// u̇ = v.
// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// ∇0W̃_ij and the reverse ∇0W̃_ji; X_j − X_i for the viscosity and dual-support SPH's
// hourglass force (read once per pair by either).
// - pair: 2 vectors per pair
// - pair: 1 vector per pair, when AV
// - pair: 1 vector per pair, when HOURGLASS_DS and AV == 0
// k_ij, k_ji of the hourglass force.
// - pair: 2 scalars per pair, when HOURGLASS_DS
// - reference: 2 scalars per item
// v; u for the viscosity and the hourglass force.
// - y: 1 vector per item
// - y: 1 vector per item, when AV
// - y: 1 vector per item, when HOURGLASS_DS and AV == 0
// P in; ρ and F⁻ᵀ for the viscosity; the power out.
// - kin loads: 1 tensor per item
// - kin loads: 1 scalar + 1 tensor per item, when AV
// H for the hourglass force.
// - kin loads: 1 tensor per item, when HOURGLASS_DS
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
    let p_i = mload_kin(KP_OFF + DIM * DIM * i);
    let rho_i = kin[KRHO_OFF + i];
    let fit_i = mload_kin(KFIT_OFF + DIM * DIM * i);
    let v_i = vload_y(V_OFF + DIM * i);
    let u_i = vload_y(U_OFF + DIM * i);
    let c_i = sqrt(BULK / rho_i);
    let m_i = RHO0 * vol_of(i);
    let h_i = mload_kin(KF_OFF + DIM * DIM * i);
    var force: vecd;
    var viscous: vecd;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let g = vload_pair(PG_OFF + DIM * p);
        let g_rev = vload_pair(PGREV_OFF + DIM * p);
        var w_ij = vol_of(i) * vol_of(j);
        var w_ji = w_ij;
        if FORCE == FORCE_REFERENCE_CODE {
            w_ij = vol_of(i);
            w_ji = vol_of(j);
        }
        force += p_i * g * w_ij
            - mload_kin(KP_OFF + DIM * DIM * j) * g_rev * w_ji;
        if HOURGLASS_DS == 1u {
            let k_ij = pair[PHGK_OFF + p];
            let k_ji = pair[PHGKR_OFF + p];
            let h_j = mload_kin(KF_OFF + DIM * DIM * j);
            force += (vload_y(U_OFF + DIM * j) - u_i) * (k_ij + k_ji)
                - (h_i * k_ij + h_j * k_ji) * vload_pair(PDX_OFF + DIM * p);
        }
        if AV == 1u {
            let x_ij = u_i - vload_y(U_OFF + DIM * j) - vload_pair(PDX_OFF + DIM * p);
            let rho_j = kin[KRHO_OFF + j];
            let c = 0.5 * (c_i + sqrt(BULK / rho_j));
            let pi = monaghan_pi(x_ij, v_i - vload_y(V_OFF + DIM * j), c, 0.5 * (rho_i + rho_j));
            if pi != 0.0 {
                let dir = fit_i * g - mload_kin(KFIT_OFF + DIM * DIM * j) * g_rev;
                viscous -= dir * (0.5 * RHO0 * vol_of(j) * pi);
            }
        }
    }
    kin[KDIS_OFF + i] = -m_i * dot(viscous, v_i);
    let a = apply_boundary(i, force * (1.0 / m_i) + viscous, v_i, m_i);
    vstore_d(V_OFF + DIM * i, a);
    vstore_d(U_OFF + DIM * i, v_i);
}
