// Von Mises hyperelastic-plastic return map (seed 003 Algorithm 2; src/physics/plasticity.rs) in
// f32 3 × 3 tensors, with Johnson and Cook's yield stress, and the per-point history it
// reads: hist holds 12 floats per point, [C_p⁻¹]ⁿ by columns, ε_pⁿ, the temperature rise
// ΔTⁿ and the step Δt the point's returns are over, then (after the last point) the Δt of
// the steps being recorded (src/gpu/plastic.rs). Constants: MU, BULK and the yield
// stress's YIELD (τ_y⁰), HARDENING (H, negative for linear softening), HARDENING_EXPONENT
// (n), RATE_COEFFICIENT (C), REFERENCE_RATE (ε̇0), THERMAL_EXPONENT (m), THERMAL_SPAN
// (T_m − T_r, 0 without thermal softening), HEATING (χ/(ρ0 c_p)). Needs eigen.wgsl.

struct History {
    cp_inv: mat3x3<f32>,
    eps_p: f32,
    heat: f32,
    dt: f32,
}

fn history(a: u32) -> History {
    let o = 12u * a;
    let cp_inv = mat3x3<f32>(
        vec3<f32>(hist[o], hist[o + 1u], hist[o + 2u]),
        vec3<f32>(hist[o + 3u], hist[o + 4u], hist[o + 5u]),
        vec3<f32>(hist[o + 6u], hist[o + 7u], hist[o + 8u]),
    );
    return History(cp_inv, hist[o + 9u], hist[o + 10u], hist[o + 11u]);
}

fn inverse3(m: mat3x3<f32>) -> mat3x3<f32> {
    let adj = transpose(mat3x3<f32>(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])));
    return adj * (1.0 / determinant(m));
}

// The strain factor τ_s = max(τ_y⁰ + H ε_p^n, 0) and its derivative in ε_p
// (Hardening::strain_factor).
fn strain_factor(e: f32) -> vec2<f32> {
    var s = YIELD + HARDENING * e;
    var ds = HARDENING;
    if HARDENING_EXPONENT != 1.0 {
        let power = select(0.0, pow(e, HARDENING_EXPONENT), e > 0.0);
        s = YIELD + HARDENING * power;
        ds = select(0.0, HARDENING * HARDENING_EXPONENT * power / e, e > 0.0);
    }
    if s <= 0.0 {
        return vec2<f32>(0.0);
    }
    return vec2<f32>(s, ds);
}

// The rate factor 1 + C ln max(Δγ/(ε̇0 Δt), 1) and its derivative in Δγ; none at Δt = 0
// (Hardening::rate_factor).
fn rate_factor(dgamma: f32, dt: f32) -> vec2<f32> {
    if RATE_COEFFICIENT > 0.0 && dt > 0.0 && dgamma > REFERENCE_RATE * dt {
        return vec2<f32>(1.0 + RATE_COEFFICIENT * log(dgamma / (REFERENCE_RATE * dt)), RATE_COEFFICIENT / dgamma);
    }
    return vec2<f32>(1.0, 0.0);
}

// The thermal factor 1 − T*^m (Hardening::thermal_factor).
fn thermal_factor(heat: f32) -> f32 {
    if THERMAL_SPAN > 0.0 {
        return 1.0 - pow(clamp(heat / THERMAL_SPAN, 0.0, 1.0), THERMAL_EXPONENT);
    }
    return 1.0;
}

// The plastic multiplier Δγ: the root of q̄ − 3μΔγ − τ_s(ε_pⁿ + Δγ) R(Δγ/Δt) Θ(ΔT) in
// [0, q̄/(3μ)] (Hardening::multiplier): closed for the linear law without a rate term,
// else Newton's method kept in the bracket, to 1e-6 of it.
fn multiplier(q_trial: f32, h: History) -> f32 {
    let theta = thermal_factor(h.heat);
    if HARDENING_EXPONENT == 1.0 && (RATE_COEFFICIENT == 0.0 || h.dt <= 0.0) {
        let linear_yield = theta * (YIELD + HARDENING * h.eps_p);
        return min((q_trial - linear_yield) / (3.0 * MU + theta * HARDENING), q_trial / (3.0 * MU));
    }
    var lo = 0.0;
    var hi = q_trial / (3.0 * MU);
    var dgamma = 0.5 * hi;
    for (var it = 0u; it < 64u; it++) {
        let tau_s = strain_factor(h.eps_p + dgamma);
        let r = rate_factor(dgamma, h.dt);
        let g = q_trial - 3.0 * MU * dgamma - theta * tau_s.x * r.x;
        if g > 0.0 {
            lo = dgamma;
        } else {
            hi = dgamma;
        }
        let newton = dgamma + g / (3.0 * MU + theta * (tau_s.y * r.x + tau_s.x * r.y));
        var next = 0.5 * (lo + hi);
        if newton > lo && newton < hi {
            next = newton;
        }
        if abs(next - dgamma) <= 1e-6 * hi || hi - lo <= 1e-6 * hi {
            return next;
        }
        dgamma = next;
    }
    return dgamma;
}

struct Returned {
    // First Piola–Kirchhoff stress.
    p: mat3x3<f32>,
    cp_inv: mat3x3<f32>,
    eps_p: f32,
    // Stored Hencky energy per reference volume.
    psi: f32,
}

// Algorithm 2 at F from the history [C_p⁻¹]ⁿ, ε_pⁿ, ΔTⁿ over its Δt (numbers are its
// steps).
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
    // (6)–(7)
    let q_trial = sqrt(1.5) * norm;
    let yield_fn = q_trial - thermal_factor(h.heat) * strain_factor(h.eps_p).x;
    var dgamma = 0.0;
    var scale = 1.0;
    if yield_fn > 0.0 {
        dgamma = multiplier(q_trial, h);
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

// The plastic work per reference volume of a return of Δγ from h (Hardening::work):
// R(Δγ/Δt) Θ(ΔT) ∫_0^Δγ τ_s(ε_pⁿ + γ) dγ by the 4-point Gauss–Legendre rule.
fn plastic_work(h: History, dgamma: f32) -> f32 {
    if dgamma <= 0.0 {
        return 0.0;
    }
    let x = vec4<f32>(0.06943184, 0.33000948, 0.66999052, 0.93056816);
    let w = vec4<f32>(0.17392742, 0.32607258, 0.32607258, 0.17392742);
    var sum = 0.0;
    for (var k = 0u; k < 4u; k++) {
        sum += w[k] * strain_factor(h.eps_p + x[k] * dgamma).x;
    }
    return rate_factor(dgamma, h.dt).x * thermal_factor(h.heat) * sum * dgamma;
}
