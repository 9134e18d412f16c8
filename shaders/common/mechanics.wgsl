// Constitutive functions shared by the TLSPH and mixed passes and the reductions
// (src/physics/material.rs in f32). State models are written in H = F − I so that small strains
// keep their digits. Needs the scene constants RHO0, MU, LAMBDA, BULK, MODEL (a choice: MODEL_HYPOELASTIC,
// MODEL_SAINT_VENANT_KIRCHHOFF, …), RATE, OBJECTIVE_RATE (a choice) and the Mooney–Rivlin
// MR_C1, MR_C2, MR_LAMBDA.

// Linear EOS from the density deviation ρ − ρ0, positive in compression.
fn pressure(rho_dev: f32) -> f32 {
    return BULK / RHO0 * rho_dev;
}

// det(I + H) − 1 from the invariants of H.
fn det_excess(h: matd) -> f32 {
    let tr = trace_d(h);
    var e = tr + determinant(h);
    if DIM == 3u {
        e += 0.5 * (tr * tr - trace_d(h * h));
    }
    return e;
}

// ln(1 + x) to f32 precision. The device's log need only be accurate to 2^-21 absolute
// in [0.5, 2] (Vulkan's precision of OpLog; on lavapipe ln J near 1 came out ~5e-8 off,
// whatever the rounding of 1 + x), which near x = 0 leaves no relative precision: for
// |x| < 0.25 the series of 2 atanh(s), s = x/(2 + x), |s| < 0.143, to s^11 (the next term
// is below 1e-11 of the sum), else log(1 + x).
fn log_1p(x: f32) -> f32 {
    if abs(x) < 0.25 {
        let s = x / (2.0 + x);
        let s2 = s * s;
        let odd = 1.0 / 3.0 + s2 * (0.2 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0 + s2 / 11.0)));
        return 2.0 * s * (1.0 + s2 * odd);
    }
    return log(1.0 + x);
}

// x − ln(1 + x) without cancellation: its series for small x.
fn x_minus_log_1p(x: f32) -> f32 {
    if abs(x) < 1e-2 {
        return x * x * (0.5 - x * (1.0 / 3.0 - x * (0.25 - x * 0.2)));
    }
    return x - log_1p(x);
}

// e^y − 1 − y without cancellation: its series for small y.
fn exp_minus_1_minus(y: f32) -> f32 {
    if abs(y) < 1e-2 {
        return y * y * (0.5 + y * (1.0 / 6.0 + y / 24.0));
    }
    return exp(y) - 1.0 - y;
}

// F:F − 3 of the 3D deformation gradient (plane strain: F_zz = 1) from H = F − I.
fn ff_excess(h: matd) -> f32 {
    return 2.0 * trace_d(h) + ddot_d(h, h);
}

// e^y − 1.
fn exp_minus_1(y: f32) -> f32 {
    return exp_minus_1_minus(y) + y;
}

// b = B − I = H + Hᵀ + H Hᵀ with B = F Fᵀ (plane strain: b_zz = 0).
fn left_cauchy_green_excess(h: matd) -> matd {
    return h + transpose(h) + h * transpose(h);
}

// The Kirchhoff stress τ = J σ of the Mooney–Rivlin rubber (seed 001 eq 18;
// src/physics/mooney_rivlin.rs) from H = F − I: with b = B − I and ln I3 = 2 ln J,
// τ = c1 (b − (I3^(1/3) − 1) I) + c2 (b + tr b I + tr b b − b² − 2 (I3^(2/3) − 1) I)
// + λ ln I3 I, every term small at small strain.
fn mooney_rivlin_kirchhoff(h: matd) -> matd {
    let b = left_cauchy_green_excess(h);
    let tr_b = trace_d(b);
    let ln_i3 = 2.0 * log_1p(det_excess(h));
    let spherical = MR_LAMBDA * ln_i3 - MR_C1 * exp_minus_1(ln_i3 / 3.0)
        + MR_C2 * (tr_b - 2.0 * exp_minus_1(2.0 * ln_i3 / 3.0));
    return b * (MR_C1 + MR_C2 * (1.0 + tr_b)) - b * b * MR_C2 + identity_d() * spherical;
}

// W of the Mooney–Rivlin rubber (src/physics/mooney_rivlin.rs), with ℓ = ln J:
// W = c1/2 (I1 − 3 − 3(I3^(1/3) − 1)) + c2/2 (I2 − 3 − 3(I3^(2/3) − 1)) + λ ℓ², regrouped
// so that the first-order terms cancel analytically: with a = I1 − 3 − 2ℓ = H:H +
// 2((x − ln(1 + x)) − q) (x = J − 1, q = x − tr H) and g(y) = e^y − 1 − y,
// I1 − 3 − 3(I3^(1/3) − 1) = a − 3 g(⅔ℓ) and, as I2 − 3 = 2 tr b + ½((tr b)² − b:b),
// I2 − 3 − 3(I3^(2/3) − 1) = 2a + ½((tr b)² − b:b) − 3 g(4ℓ/3).
fn mooney_rivlin_energy(h: matd) -> f32 {
    let x = det_excess(h);
    let ln_j = log_1p(x);
    let a = ddot_d(h, h) + 2.0 * (x_minus_log_1p(x) - (x - trace_d(h)));
    let b = left_cauchy_green_excess(h);
    let tr_b = trace_d(b);
    let first = a - 3.0 * exp_minus_1_minus(2.0 / 3.0 * ln_j);
    let second = 2.0 * a + 0.5 * (tr_b * tr_b - ddot_d(b, b)) - 3.0 * exp_minus_1_minus(4.0 / 3.0 * ln_j);
    return 0.5 * MR_C1 * first + 0.5 * MR_C2 * second + MR_LAMBDA * ln_j * ln_j;
}

// First Piola–Kirchhoff stress of the state models: E = ½(H + Hᵀ + HᵀH) for SVK;
// F − F⁻ᵀ = H + Hᵀ F⁻ᵀ for neo-Hookean; ε = sym H for linear elasticity; for the
// polyconvex model F − ⅓F:F F⁻ᵀ = (H + Hᵀ F⁻ᵀ) − ⅓(F:F − 3) F⁻ᵀ; τ F⁻ᵀ for the
// Mooney–Rivlin rubber.
fn pk1(h: matd, f_inv_t: matd) -> matd {
    let f = identity_d() + h;
    if MODEL == MODEL_MOONEY_RIVLIN {
        return mooney_rivlin_kirchhoff(h) * f_inv_t;
    }
    if MODEL == MODEL_SAINT_VENANT_KIRCHHOFF {
        let e = (h + transpose(h) + transpose(h) * h) * 0.5;
        return f * (identity_d() * (LAMBDA * trace_d(e)) + e * (2.0 * MU));
    }
    if MODEL == MODEL_LINEAR_ELASTIC {
        let eps = (h + transpose(h)) * 0.5;
        return identity_d() * (LAMBDA * trace_d(eps)) + eps * (2.0 * MU);
    }
    let f_minus_f_inv_t = h + transpose(h) * f_inv_t;
    let x = det_excess(h);
    if MODEL == MODEL_NEARLY_INCOMPRESSIBLE_NEO_HOOKEAN {
        let j = 1.0 + x;
        let iso = f_minus_f_inv_t - f_inv_t * (ff_excess(h) / 3.0);
        return iso * (MU * exp(-2.0 / 3.0 * log_1p(x))) + f_inv_t * (BULK * x * j);
    }
    return f_minus_f_inv_t * MU + f_inv_t * (LAMBDA * log_1p(x));
}

// P(F, H, J) of the mixed formulations (seed 003 eq 1; Material::pk1_mixed) from the
// excesses f = F − I, h = H − I, j = J − 1. Only the polyconvex model reads H and J
// apart from F: P = μ J^(−2/3) [F − ⅓ F:F J⁻¹ H] + κ (J − 1) H, where the bracket is
// f − h − c H with c = (⅓(F:F − 3) − j)/J, every term small at small strain.
fn pk1_mixed(f: matd, h: matd, j: f32) -> matd {
    if MODEL != MODEL_NEARLY_INCOMPRESSIBLE_NEO_HOOKEAN {
        var f_inv_t = identity_d();
        if MODEL == MODEL_NEO_HOOKEAN || MODEL == MODEL_MOONEY_RIVLIN {
            f_inv_t = transpose(inverse_d(identity_d() + f));
        }
        return pk1(f, f_inv_t);
    }
    return pk1_pressure(f, h, j, BULK * j);
}

// P(F, H, J) of the polyconvex model with the pressure p given (Material::pk1_with_pressure):
// κ(J − 1) in pk1_mixed, the evolved pressure of artificial compressibility (seed 003 eq
// 42) in the corrector's passes.
fn pk1_pressure(f: matd, h: matd, j: f32, p: f32) -> matd {
    let hh = identity_d() + h;
    let c = (ff_excess(f) / 3.0 - j) / (1.0 + j);
    return (f - h - hh * c) * (MU * exp(-2.0 / 3.0 * log_1p(j))) + hh * p;
}

// S_zz of a 2D plane-strain rate model, which the in-plane S does not carry
// (src/physics/material/mod.rs `plane_strain_szz`): −tr S under a corotational rate,
// (2μ/3)(ρ/ρ0 − 1) under Truesdell's; zero in 3D.
fn plane_strain_szz(s: matd, rho_dev: f32) -> f32 {
    if DIM == 3u {
        return 0.0;
    }
    if OBJECTIVE_RATE == OBJECTIVE_RATE_TRUESDELL {
        return 2.0 * MU / 3.0 * rho_dev / RHO0;
    }
    return -trace_d(s);
}

// Strain-energy density per reference volume. Rate model: the complementary energy
// S:S/(4G) + p²/(2K) (with S_zz = −tr S in 2D). Neo-Hookean: ψ = μ/2 (tr C − DIM) − μ ln J
// + λ/2 ln²J regrouped so the first-order terms cancel analytically: with J − 1 = x =
// tr H + q, tr C − DIM = 2 tr H + H:H and tr H − ln J = (x − ln(1 + x)) − q.
fn energy_density(h: matd, s: matd, rho_dev: f32) -> f32 {
    if RATE == 1u {
        let szz = plane_strain_szz(s, rho_dev);
        let p = pressure(rho_dev);
        return (ddot_d(s, s) + szz * szz) / (4.0 * MU) + p * p / (2.0 * BULK);
    }
    if MODEL == MODEL_SAINT_VENANT_KIRCHHOFF {
        let e = (h + transpose(h) + transpose(h) * h) * 0.5;
        let tr = trace_d(e);
        return 0.5 * LAMBDA * tr * tr + MU * ddot_d(e, e);
    }
    if MODEL == MODEL_LINEAR_ELASTIC {
        let eps = (h + transpose(h)) * 0.5;
        let tr = trace_d(eps);
        return 0.5 * LAMBDA * tr * tr + MU * ddot_d(eps, eps);
    }
    if MODEL == MODEL_MOONEY_RIVLIN {
        return mooney_rivlin_energy(h);
    }
    let x = det_excess(h);
    if MODEL == MODEL_NEARLY_INCOMPRESSIBLE_NEO_HOOKEAN {
        return polyconvex_energy(h, x);
    }
    let q = x - trace_d(h);
    let ln_j = log_1p(x);
    return 0.5 * MU * ddot_d(h, h) + MU * (x_minus_log_1p(x) - q) + 0.5 * LAMBDA * ln_j * ln_j;
}

// ψ = μ/2 (J^(−2/3) F:F − 3) + κ/2 (J − 1)² of the polyconvex model from H = F − I and
// x = J − 1 (det F − 1, or the evolved J of a mixed method). With y = −⅔ ln J and
// q = x − tr H: J^(−2/3) F:F − 3 = 3(e^y − 1 − y) + (F:F − 3 − 2 ln J) + (e^y − 1)(F:F − 3)
// and F:F − 3 − 2 ln J = H:H + 2((x − ln(1 + x)) − q).
fn polyconvex_energy(h: matd, x: f32) -> f32 {
    return isochoric_energy(h, x) + 0.5 * BULK * x * x;
}

// The isochoric part μ/2 (J^(−2/3) F:F − 3) of polyconvex_energy.
fn isochoric_energy(h: matd, x: f32) -> f32 {
    let q = x - trace_d(h);
    let y = -2.0 / 3.0 * log_1p(x);
    let a = ff_excess(h);
    let g = exp_minus_1_minus(y);
    return 0.5 * MU * (3.0 * g + ddot_d(h, h) + 2.0 * (x_minus_log_1p(x) - q) + (g + y) * a);
}

// ψ(F, J) of the mixed formulations (Material::energy_density_mixed) from f = F − I and
// j = J − 1: only the polyconvex model reads J apart from F.
fn energy_density_mixed(f: matd, j: f32) -> f32 {
    if MODEL == MODEL_NEARLY_INCOMPRESSIBLE_NEO_HOOKEAN {
        return polyconvex_energy(f, j);
    }
    return energy_density(f, matd(), 0.0);
}
