// Von Mises hyperelastic-plastic return map (seed 003 Algorithm 2; src/plasticity.rs) in
// f32 3 × 3 tensors, and the per-particle history it reads: hist holds 10 floats per real
// particle, [C_p⁻¹]ⁿ by columns then ε_pⁿ. Constants: MU, BULK, YIELD (τ_y⁰), HARDENING
// (H).

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

struct Eigen {
    values: vec3<f32>,
    // Unit eigenvectors, as the columns.
    vectors: mat3x3<f32>,
}

// Eigen-decomposition of a symmetric 3 × 3 tensor by cyclic Jacobi rotations.
fn symmetric_eigen(a: mat3x3<f32>) -> Eigen {
    var m = a;
    var v = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    let ps = array<u32, 3>(0u, 0u, 1u);
    let qs = array<u32, 3>(1u, 2u, 2u);
    for (var sweep = 0u; sweep < 12u; sweep++) {
        let off = m[1][0] * m[1][0] + m[2][0] * m[2][0] + m[2][1] * m[2][1];
        let scale = dot(m[0], m[0]) + dot(m[1], m[1]) + dot(m[2], m[2]);
        // Converged to f32: off-diagonal entries below 3e-7 of the tensor's size change
        // the eigenvalues by 1e-13 of it.
        if off <= 1e-13 * scale {
            break;
        }
        for (var k = 0u; k < 3u; k++) {
            let p = ps[k];
            let q = qs[k];
            let apq = m[q][p];
            if abs(apq) <= 1e-9 * (abs(m[p][p]) + abs(m[q][q])) {
                continue;
            }
            // The rotation J in the (p, q) plane that zeroes m_pq: m ← Jᵀ m J, v ← v J.
            let theta = (m[q][q] - m[p][p]) / (2.0 * apq);
            let t = select(-1.0, 1.0, theta >= 0.0) / (abs(theta) + sqrt(theta * theta + 1.0));
            let c = 1.0 / sqrt(t * t + 1.0);
            let s = t * c;
            let cp = m[p];
            let cq = m[q];
            m[p] = c * cp - s * cq;
            m[q] = s * cp + c * cq;
            for (var col = 0u; col < 3u; col++) {
                let bp = m[col][p];
                let bq = m[col][q];
                m[col][p] = c * bp - s * bq;
                m[col][q] = s * bp + c * bq;
            }
            let vp = v[p];
            let vq = v[q];
            v[p] = c * vp - s * vq;
            v[q] = s * vp + c * vq;
        }
    }
    return Eigen(vec3<f32>(m[0][0], m[1][1], m[2][2]), v);
}

fn inverse3(m: mat3x3<f32>) -> mat3x3<f32> {
    let adj = transpose(mat3x3<f32>(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])));
    return adj * (1.0 / determinant(m));
}

// Σ_i w_i n_i ⊗ n_i over the columns n_i of n.
fn principal(n: mat3x3<f32>, w: vec3<f32>) -> mat3x3<f32> {
    let d = mat3x3<f32>(vec3<f32>(w.x, 0.0, 0.0), vec3<f32>(0.0, w.y, 0.0), vec3<f32>(0.0, 0.0, w.z));
    return n * d * transpose(n);
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
    // (6)–(7)
    let yield_fn = sqrt(1.5) * norm - (YIELD + HARDENING * h.eps_p);
    var dgamma = 0.0;
    var scale = 1.0;
    if yield_fn > 0.0 {
        dgamma = yield_fn / (3.0 * MU + HARDENING);
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
