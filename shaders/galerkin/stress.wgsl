// The stress at a Galerkin point (galerkin.wgsl, kbm/eulerian.wgsl): P_q and ψ_q at
// F_q = I + h, with the rate model's ρ̇_q and Ṡ_q. Needs the bindings y, d (the state's
// RHO and S at the points) and, with MODEL_VON_MISES_PLASTIC, hist (plasticity.wgsl).

// P_q and ψ_q at F_q = I + h (with F_q⁻¹ = f_inv): the rate model from ρ_q and S_q,
// writing ρ̇_q and the objective Ṡ_q for L_q (Algorithm 6 steps 2–3); the von Mises model
// from the point's committed history; otherwise P(F_q).
struct Stressed {
    pk: matd,
    psi: f32,
}

fn stressed(q: u32, h: matd, f_inv: matd, l: matd) -> Stressed {
    let f = identity_d() + h;
    let f_inv_t = transpose(f_inv);
    var out: Stressed;
    if RATE == 1u {
        let rho_dev = y[RHO_OFF + q];
        let s = mload_y(S_OFF + DIM * DIM * q);
        d[RHO_OFF + q] = -(RHO0 + rho_dev) * trace_d(l);
        mstore_d(S_OFF + DIM * DIM * q, stress_rate(s, l, f));
        out.pk = (s - identity_d() * pressure(rho_dev)) * f_inv_t * determinant(f);
        out.psi = energy_density(h, s, rho_dev);
    } else if MODEL == MODEL_VON_MISES_PLASTIC {
        let r = return_map(lift3(f, 1.0), history(q));
        out.pk = lower3(r.p);
        out.psi = r.psi;
    } else {
        out.pk = pk1(h, f_inv_t);
        out.psi = energy_density(h, matd(), 0.0);
    }
    return out;
}
