// Total-Lagrangian SPH accelerations (seed 000 eq 134; with FORCE_VARIATIONAL the pair
// force P_i ∇0W̃_ij − P_j ∇0W̃_ji from the reverse gradients GREV, which the set-up copies
// from the reverse pairs' gradients; with FORCE_PLAIN seed 002 eq 21, P_j ∇0W̃_ij and i's
// own term, −P_i ∇0W̃_ij per pair where the kernel REPRODUCES_CONSTANTS, else none) with
// Monaghan viscosity along the
// pushed-forward gradient F_i⁻ᵀ ∇0W̃_ij (or ∇0W̃_ij unmapped, AV_GRADIENT_REFERENCE: the
// paper's form), with HOURGLASS the hourglass control −κ_ij δ_ij e_ij of every bond
// (src/methods/tlsph/system.rs, `hourglass_acceleration`; κ_ij in the pair field HGK),
// boundary conditions (boundary.wgsl), and u̇ = v.
// One invocation per particle; writes only its own particle. Layout and constants as in
// tlsph.wgsl.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<f32>;
@group(0) @binding(4) var<storage, read> y: array<f32>;
// The kinematics of the stress pass; this pass writes only the power and reactions
// (boundary.wgsl) and the viscous dissipation (KDIS).
@group(0) @binding(5) var<storage, read_write> kin: array<f32>;
// External acceleration from tractions and interactions (DIM per particle).
@group(0) @binding(6) var<storage, read> ext: array<f32>;
@group(0) @binding(7) var<storage, read_write> d: array<f32>;

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// ∇0W̃_ij, and ∇0W̃_ji for the variational force; X_j − X_i for the viscosity and the
// hourglass control (read once per pair by either).
// - pair: 1 vector per pair
// - pair: 1 vector per pair, when FORCE == FORCE_VARIATIONAL
// - pair: 1 vector per pair, when AV
// - pair: 1 vector per pair, when HOURGLASS and AV == 0
// κ_ij and H (of both particles) for the hourglass control.
// - pair: 1 scalar per pair, when HOURGLASS
// - kin loads: 1 tensor per item, when HOURGLASS
// V, the boundary mask.
// - reference: 2 scalars per item
// v; u for the viscosity and the hourglass control.
// - y: 1 vector per item
// - y: 1 vector per item, when AV
// - y: 1 vector per item, when HOURGLASS and AV == 0
// P in; F⁻ᵀ and ρ for the viscosity; the power of supports and loads and the viscous
// dissipation out.
// - kin loads: 1 tensor per item
// - kin loads: 1 scalar + 1 tensor per item, when AV
// - kin stores: 2 scalars per item
// - ext: 1 vector per item
// u̇ = v, v̇.
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
    let f_inv_t = mload_kin(KFIT_OFF + DIM * DIM * i);
    let v_i = vload_y(V_OFF + DIM * i);
    let u_i = vload_y(U_OFF + DIM * i);
    let c_i = sqrt(BULK / rho_i);
    let h_i = mload_kin(KF_OFF + DIM * DIM * i);
    var stress: vecd;
    var viscous: vecd;
    var hourglass: vecd;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let g = vload_pair(PG_OFF + DIM * p);
        let p_j = mload_kin(KP_OFF + DIM * DIM * j);
        var flux = (p_i + p_j) * g;
        if FORCE == FORCE_VARIATIONAL {
            flux = p_i * g - p_j * vload_pair(PGREV_OFF + DIM * p);
        } else if FORCE == FORCE_PLAIN && REPRODUCES_CONSTANTS == 1u {
            // Seed 002 eq 21: i's own term V_i P_i ∇0W̃_i(X_i) = −P_i Σ_j V_j ∇0W̃_ij.
            flux = (p_j - p_i) * g;
        } else if FORCE == FORCE_PLAIN {
            // The own gradient ∇W(0) = 0 of a kernel that does not reproduce constants.
            flux = p_j * g;
        }
        stress += flux * vol_of(j);
        if HOURGLASS == 1u {
            // γ_ij = ½(H_i + H_j) X_ij − (u_j − u_i), δ_ij = ½ γ_ij·e_ij.
            let dx0 = vload_pair(PDX_OFF + DIM * p);
            let du = vload_y(U_OFF + DIM * j) - u_i;
            let e = normalize(dx0 + du);
            let gamma = 0.5 * ((h_i + mload_kin(KF_OFF + DIM * DIM * j)) * dx0) - du;
            hourglass -= e * (0.5 * pair[PHGK_OFF + p] * dot(gamma, e));
        }
        if AV == 1u {
            let x_ij = u_i - vload_y(U_OFF + DIM * j) - vload_pair(PDX_OFF + DIM * p);
            let rho_j = kin[KRHO_OFF + j];
            let c = 0.5 * (c_i + sqrt(BULK / rho_j));
            let pi = monaghan_pi(x_ij, v_i - vload_y(V_OFF + DIM * j), c, 0.5 * (rho_i + rho_j));
            if pi != 0.0 {
                var along = f_inv_t * g;
                if AV_GRADIENT == AV_GRADIENT_REFERENCE {
                    along = g;
                }
                viscous -= along * (RHO0 * vol_of(j) * pi);
            }
        }
    }
    kin[KDIS_OFF + i] = -RHO0 * vol_of(i) * dot(viscous, v_i);
    let a = apply_boundary(i, stress * (1.0 / RHO0) + viscous + hourglass, v_i, RHO0 * vol_of(i));
    vstore_d(V_OFF + DIM * i, a);
    vstore_d(U_OFF + DIM * i, v_i);
}
