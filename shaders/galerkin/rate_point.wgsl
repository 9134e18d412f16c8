// The rate model at a Galerkin point (stress.wgsl, ul_weak_form/ul_weak_form.wgsl): ρ̇_q =
// −ρ_q tr L_q and the objective Ṡ_q into d (Algorithm 6 steps 2–3), and σ_q = S_q − p(ρ_q) I
// and ψ_q of the state's ρ_q and S_q at F_q = I + h. Needs the bindings y and d.

struct RatePoint {
    sigma: matd,
    psi: f32,
}

fn rate_point(q: u32, h: matd, l: matd) -> RatePoint {
    let rho_dev = y[RHO_OFF + q];
    let s = mload_y(S_OFF + DIM * DIM * q);
    d[RHO_OFF + q] = -(RHO0 + rho_dev) * trace_d(l);
    mstore_d(S_OFF + DIM * DIM * q, stress_rate(s, l, identity_d() + h));
    return RatePoint(s - identity_d() * pressure(rho_dev), energy_density(h, s, rho_dev));
}
