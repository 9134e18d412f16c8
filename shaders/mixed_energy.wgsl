// V_i ψ(F_i, J_i) of a mixed-method particle for reduce.wgsl, from the F − I of the stress,
// bound as `kin` at FS_OFF (the state again, or the bond-based F^c − I), and J − 1
// (det F − 1 when J is not evolved). Constants as in mixed_kinematics.wgsl.
fn strain_energy(i: u32) -> f32 {
    let f = mload_kin(FS_OFF + DIM * DIM * i);
    var j = det_excess(f);
    if EVOLVE_J == 1u {
        j = y[J_OFF + i];
    }
    return vol[i] * energy_density_mixed(f, j);
}

// 1/λ²_min of particle i (seed 002 eqs 31–32: the wave speed the CFL step uses is
// c_p/λ²_min), λ²_min the smallest eigenvalue of C = FᵀF.
fn stretch_factor(i: u32) -> f32 {
    let f = identity_d() + mload_y(F_OFF + DIM * DIM * i);
    return 1.0 / smallest_eigenvalue_sym(transpose(f) * f);
}
