// The deviatoric stress rate of the rate model under its objective rate, in f32
// (src/physics/material/mod.rs `stress_rate` and objective.rs `rotation_spin`). Needs MU,
// OBJECTIVE_RATE (a choice: OBJECTIVE_RATE_JAUMANN, …) and eigen.wgsl.

// The spin Ω = Ṙ Rᵀ of the rotation of F = R U at Ḟ = L F: Ω = W − Σ_{i≠j} (λ_i − λ_j)/
// (λ_i + λ_j) (n_i · D n_j) n_i ⊗ n_j with λ_i², n_i the eigenpairs of B = F Fᵀ.
fn rotation_spin(f: matd, l: matd) -> matd {
    let f3 = lift3(f, 1.0);
    let l3 = lift3(l, 0.0);
    let e = symmetric_eigen(f3 * transpose(f3));
    let stretch = sqrt(max(e.values, vec3<f32>(0.0)));
    let n = e.vectors;
    let d = transpose(n) * ((l3 + transpose(l3)) * 0.5) * n;
    var skew = mat3x3<f32>();
    for (var j = 0u; j < 3u; j++) {
        for (var i = 0u; i < 3u; i++) {
            skew[j][i] = (stretch[i] - stretch[j]) / (stretch[i] + stretch[j]) * d[j][i];
        }
    }
    return lower3((l3 - transpose(l3)) * 0.5 - n * skew * transpose(n));
}

// Ṡ from L at a point with deformation gradient F: the objective rate S̊ equated to
// 2μ dev D (seed 000 eq 91; Jaumann: eq 92).
fn stress_rate(s: matd, l: matd, f: matd) -> matd {
    let lt = transpose(l);
    let d = (l + lt) * 0.5;
    let tr_d = trace_d(d);
    let elastic = (d - identity_d() * (tr_d / 3.0)) * (2.0 * MU);
    if OBJECTIVE_RATE == OBJECTIVE_RATE_TRUESDELL {
        return elastic + l * s + s * lt - s * tr_d;
    }
    var omega = (l - lt) * 0.5;
    if OBJECTIVE_RATE == OBJECTIVE_RATE_GREEN_NAGHDI {
        omega = rotation_spin(f, l);
    }
    return elastic - s * omega + omega * s;
}
