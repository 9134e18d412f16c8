// V_i ψ(F_i, J_i) of a mixed-method particle for reduce.wgsl, from the state's F − I and
// J − 1 (det F − 1 when J is not evolved). Constants as in mixed_kinematics.wgsl.
fn strain_energy(i: u32) -> f32 {
    let f = mload_y(F_OFF + DIM * DIM * i);
    var j = det_excess(f);
    if EVOLVE_J == 1u {
        j = y[J_OFF + i];
    }
    return vol[i] * energy_density_mixed(f, j);
}
