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
