// The weight of particle i's ψ in the strain energy for reduce.wgsl: V_i for the
// consistent force, 1 for the reference code's (the energy its force derives from for
// uniform volumes; methods::potential::system). F from the stress pass's kin.
fn strain_energy(i: u32) -> f32 {
    var weight = vol_of(i);
    if FORCE == FORCE_REFERENCE_CODE {
        weight = 1.0;
    }
    return weight * energy_density(mload_kin(KF_OFF + DIM * DIM * i), matd(), 0.0);
}

// The potential's CFL step is Δx / (c_p + max |v|) (of the stiffer material for the
// reference code's force, on the host): no pair wave speed.
fn pair_wave_speed(i: u32) -> f32 {
    return 0.0;
}

// The viscous dissipation −m_i a_visc·v_i of the last acceleration pass.
fn viscous_dissipation(i: u32) -> f32 {
    return kin[KDIS_OFF + i];
}
