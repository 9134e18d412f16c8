// Two dimensions (plane strain): vectors and tensors are 2-component.
alias vecd = vec2<f32>;
alias matd = mat2x2<f32>;
const DIM: u32 = 2u;

fn identity_d() -> matd {
    return matd(1.0, 0.0, 0.0, 1.0);
}

// (a ⊗ b)_kl = a_k b_l: column l is a * b_l.
fn outer(a: vecd, b: vecd) -> matd {
    return matd(a * b.x, a * b.y);
}

fn trace_d(m: matd) -> f32 {
    return m[0][0] + m[1][1];
}

fn inverse_d(m: matd) -> matd {
    return matd(m[1][1], -m[0][1], -m[1][0], m[0][0]) * (1.0 / determinant(m));
}

// The smallest eigenvalue of a symmetric tensor (tensor::smallest_stretch_squared on
// the CPU).
fn smallest_eigenvalue_sym(c: matd) -> f32 {
    let half_gap = 0.5 * (c[0][0] - c[1][1]);
    return 0.5 * trace_d(c) - sqrt(half_gap * half_gap + c[1][0] * c[1][0]);
}

fn ddot_d(a: matd, b: matd) -> f32 {
    return dot(a[0], b[0]) + dot(a[1], b[1]);
}

// Entry-wise product.
fn hadamard(a: matd, b: matd) -> matd {
    return matd(a[0] * b[0], a[1] * b[1]);
}

// Cofactor (the in-plane block of cof F under plane strain, F_zz = 1); linear in 2D.
fn cof_d(m: matd) -> matd {
    return matd(m[1][1], -m[1][0], -m[0][1], m[0][0]);
}

// cof(I + A) − I = cof A.
fn cof_excess(a: matd) -> matd {
    return cof_d(a);
}

// d cof F/dt = cof Ḟ (plane strain: the in-plane block of F × Ḟ).
fn cof_rate(a: matd, f_dot: matd) -> matd {
    return cof_d(f_dot);
}

// Integer cell coordinates of a point, padded to three (z = 0).
fn cell_coords(x: vecd, origin: vec3<f32>, inv_cell: f32, dims: vec3<u32>) -> vec3<u32> {
    let c = clamp(floor((x - origin.xy) * inv_cell), vec2<f32>(0.0), vec2<f32>(dims.xy - vec2<u32>(1u)));
    return vec3<u32>(u32(c.x), u32(c.y), 0u);
}

// A vector padded to three components (z = 0), and back.
fn pad3(v: vecd) -> vec3<f32> {
    return vec3<f32>(v, 0.0);
}

fn unpad(v: vec3<f32>) -> vecd {
    return v.xy;
}

// Solves I λ = m for an inertia tensor of in-plane points: only λ_z = m_z / I_zz.
fn solve_inertia(i: mat3x3<f32>, m: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0, 0.0, m.z / i[2][2]);
}

// The plane-strain 3 × 3 tensor of an in-plane one, with the given zz entry.
fn lift3(m: matd, zz: f32) -> mat3x3<f32> {
    return mat3x3<f32>(vec3<f32>(m[0], 0.0), vec3<f32>(m[1], 0.0), vec3<f32>(0.0, 0.0, zz));
}

// The in-plane block of a 3 × 3 tensor.
fn lower3(m: mat3x3<f32>) -> matd {
    return matd(m[0].xy, m[1].xy);
}
