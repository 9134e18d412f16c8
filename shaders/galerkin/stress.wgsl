// The stress at a Galerkin point (galerkin.wgsl, kbm/eulerian.wgsl): P_q and ψ_q at
// F_q = I + h, with the rate model's ρ̇_q and Ṡ_q (rate_point.wgsl). Needs the bindings y,
// d (the state's RHO and S at the points) and, with MODEL_VON_MISES_PLASTIC, hist
// (plasticity.wgsl).

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
        let r = rate_point(q, h, l);
        out.pk = r.sigma * f_inv_t * determinant(f);
        out.psi = r.psi;
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
