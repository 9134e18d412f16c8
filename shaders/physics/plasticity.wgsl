// Von Mises hyperelastic-plastic return map (seed 003 Algorithm 2; src/physics/plasticity.rs) in
// f32 3 × 3 tensors, and the per-particle history it reads: hist holds 10 floats per real
// particle, [C_p⁻¹]ⁿ by columns then ε_pⁿ. Constants: MU, BULK, YIELD (τ_y⁰), HARDENING
// (H, negative for softening). Needs eigen.wgsl.

struct History {
    cp_inv: mat3x3<f32>,
    eps_p: f32,
}

fn history(a: u32) -> History {
    let o = 10u * a;
    let cp_inv = mat3x3<f32>(
        vec3<f32>(hist[o], hist[o + 1u], hist[o + 2u]),
        vec3<f32>(hist[o + 3u], hist[o + 4u], hist[o + 5u]),
        vec3<f32>(hist[o + 6u], hist[o + 7u], hist[o + 8u]),
    );
    return History(cp_inv, hist[o + 9u]);
}

fn inverse3(m: mat3x3<f32>) -> mat3x3<f32> {
    let adj = transpose(mat3x3<f32>(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])));
    return adj * (1.0 / determinant(m));
}

struct Returned {
    // First Piola–Kirchhoff stress.
    p: mat3x3<f32>,
    cp_inv: mat3x3<f32>,
    eps_p: f32,
    // Stored Hencky energy per reference volume.
    psi: f32,
}

// Algorithm 2 at F from the history [C_p⁻¹]ⁿ, ε_pⁿ (numbers are its steps).
fn return_map(f: mat3x3<f32>, h: History) -> Returned {
    // (1)–(2)
    let j = determinant(f);
    let ln_j = log(j);
    let p = BULK * ln_j / j;
    // (3)–(5)
    let e = symmetric_eigen(f * h.cp_inv * transpose(f));
    let ln_stretch = 0.5 * log(e.values);
    let tau_trial = 2.0 * MU * ln_stretch - vec3<f32>(2.0 / 3.0 * MU * ln_j);
    let norm = length(tau_trial);
    // (6)–(7) with τ_y = max(τ_y⁰ + H ε_p, 0): a softening H < 0 stops at zero yield
    // stress, where Δγ = q̄/(3μ) (Hardening::multiplier in src/physics/plasticity.rs).
    let q_trial = sqrt(1.5) * norm;
    let linear_yield = YIELD + HARDENING * h.eps_p;
    let yield_fn = q_trial - max(linear_yield, 0.0);
    var dgamma = 0.0;
    var scale = 1.0;
    if yield_fn > 0.0 {
        dgamma = min((q_trial - linear_yield) / (3.0 * MU + HARDENING), q_trial / (3.0 * MU));
        scale = sqrt(2.0 / 3.0) * norm;
    }
    // (8), (10)–(13)
    let ln_elastic = ln_stretch - tau_trial * (dgamma / scale);
    let tau_dev = tau_trial * (1.0 - 2.0 * MU * dgamma / scale);
    let tau = principal(e.vectors, tau_dev + vec3<f32>(j * p));
    let f_inv = inverse3(f);
    let b_e = principal(e.vectors, exp(2.0 * ln_elastic));
    let dev = ln_elastic - vec3<f32>(ln_j / 3.0);
    return Returned(
        tau * transpose(f_inv),
        f_inv * b_e * transpose(f_inv),
        h.eps_p + dgamma,
        MU * dot(dev, dev) + 0.5 * BULK * ln_j * ln_j,
    );
}
