// V_i ψ_i of a TLSPH particle for reduce.wgsl: H = F − I from the stress pass (kin), and S,
// ρ − ρ0 of the rate model from the state. Constants as in tlsph.wgsl.
fn strain_energy(i: u32) -> f32 {
    var s: matd;
    var rho_dev = 0.0;
    if RATE == 1u {
        s = mload_y(S_OFF + DIM * DIM * i);
        rho_dev = y[RHO_OFF + i];
    }
    return vol_of(i) * energy_density(mload_kin(KF_OFF + DIM * DIM * i), s, rho_dev);
}

// TLSPH's CFL step is Δx / (c_p + max |v|) with c_p of the reference configuration
// (methods::cores::tl::gpu): no pair wave speed, and the host does not read this slot.
fn pair_wave_speed(i: u32) -> f32 {
    return 0.0;
}

// The viscous dissipation −m_i a_visc·v_i of the last acceleration pass.
fn viscous_dissipation(i: u32) -> f32 {
    return kin[KDIS_OFF + i];
}
