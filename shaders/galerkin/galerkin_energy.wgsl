// The stored energy of node a for reduce.wgsl: its share Σ_q w_q N_a(X_q) ψ_q of the points'
// energies (ψ_q in kin, from the points pass of the same state), so that the nodes' shares
// sum to Σ_q w_q ψ_q (the shape functions of each point sum to one). Bindings past
// reduce.wgsl's own: the part's gather lists, as in galerkin.wgsl.

@group(0) @binding(4) var<storage, read> gather: array<u32>;
@group(0) @binding(5) var<storage, read> entries: array<f32>;

fn strain_energy(a: u32) -> f32 {
    var e = 0.0;
    let row = a - part.first;
    let e_end = gather[row + 1u];
    for (var k = gather[row]; k < e_end; k++) {
        e += kin[KPSI_OFF + gather[GPOINT_OFF + k]] * entries[EWN_OFF + k];
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
