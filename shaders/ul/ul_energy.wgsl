// V_i ψ_i of an updated-Lagrangian particle for reduce.wgsl: the complementary energy of
// the hypoelastic model from S and ρ − ρ0 of the state, per reference volume, as
// methods::tlsph::system::stress_fields on the CPU. Constants as in ul.wgsl.
fn strain_energy(i: u32) -> f32 {
    let s = mload_y(S_OFF + DIM * DIM * i);
    return vol_of(i) * energy_density(mload_y(F_OFF + DIM * DIM * i), s, y[RHO_OFF + i]);
}

// The UL methods' CFL step is Δx / (c_p + max |v|): no pair wave speed.
fn pair_wave_speed(i: u32) -> f32 {
    return 0.0;
}

// The method does not separate its dissipation: no viscous power in the reduction.
fn viscous_dissipation(i: u32) -> f32 {
    return 0.0;
}
