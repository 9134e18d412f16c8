// The stored energy of the reduction (reduce.wgsl) for the Galerkin methods whose points
// move on their own (kbm/eulerian.wgsl, ul_weak_form/ul_weak_form.wgsl): the points'
// w0_q ψ_q (kin, from the points pass of the same state) folded onto the particles,
// particle a summing the points a, a + N, a + 2N, … below Q, so that the particles'
// values sum to Σ_q w0_q ψ_q (a particle's value is that sum's share, no field of its own).

fn strain_energy(a: u32) -> f32 {
    var e = 0.0;
    for (var q = a; q < Q; q += N) {
        e += kin[KE_OFF + q];
    }
    return e;
}

// The CFL step is Δx / (c_p + max |v|): no pair wave speed.
fn pair_wave_speed(a: u32) -> f32 {
    return 0.0;
}

// The method does not separate its dissipation: no viscous power in the reduction.
fn viscous_dissipation(i: u32) -> f32 {
    return 0.0;
}
