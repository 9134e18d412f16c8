// The hooks of reduce.wgsl for dual-support SPH (methods::dual_support on the CPU): the
// energy its force derives from, V_i ψ(F_i) plus the hourglass energy of i's support,
// Σ_j ½ k_ij |e_ij|² with e_ij = (u_j − u_i) − H_i X_ij and k_ij = 2 V_i c_i w_ij (pair
// field HGK; zero where j ∉ S_i) (seed 004 eq 21), over the part's lists (part.wgsl). F
// from the stress pass's kin.
fn strain_energy(i: u32) -> f32 {
    let h_i = mload_kin(KF_OFF + DIM * DIM * i);
    let u_i = vload_y(U_OFF + DIM * i);
    var hourglass = 0.0;
    let row = i - part.first;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let e = vload_y(U_OFF + DIM * j) - u_i - h_i * vload_pair(PDX_OFF + DIM * p);
        hourglass += 0.5 * pair[PHGK_OFF + p] * dot(e, e);
    }
    return vol_of(i) * energy_density(h_i, matd(), 0.0) + hourglass;
}

// The CFL step is Δx / (c_p + max |v|): no pair wave speed.
fn pair_wave_speed(i: u32) -> f32 {
    return 0.0;
}

// No viscosity.
fn viscous_dissipation(i: u32) -> f32 {
    return 0.0;
}

// The part's lists S_i ∪ S'_i and the pair data of the force pass.
@group(0) @binding(4) var<storage, read> offsets: array<u32>;
@group(0) @binding(5) var<storage, read> ids: array<u32>;
@group(0) @binding(6) var<storage, read> pair: array<f32>;
