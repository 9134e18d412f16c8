// Eigen-decomposition of symmetric 3 × 3 tensors in f32 (src/physics/plasticity.rs
// `symmetric_eigen` on the CPU), and tensors from principal values.

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

// Σ_i w_i n_i ⊗ n_i over the columns n_i of n.
fn principal(n: mat3x3<f32>, w: vec3<f32>) -> mat3x3<f32> {
    let d = mat3x3<f32>(vec3<f32>(w.x, 0.0, 0.0), vec3<f32>(0.0, w.y, 0.0), vec3<f32>(0.0, 0.0, w.z));
    return n * d * transpose(n);
}
