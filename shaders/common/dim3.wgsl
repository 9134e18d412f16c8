// Three dimensions: vec3/mat3x3 (storage stride 16 bytes per vector, 48 per tensor).
alias vecd = vec3<f32>;
alias matd = mat3x3<f32>;
const DIM: u32 = 3u;

fn identity_d() -> matd {
    return matd(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
}

// (a ⊗ b)_kl = a_k b_l: column l is a * b_l.
fn outer(a: vecd, b: vecd) -> matd {
    return matd(a * b.x, a * b.y, a * b.z);
}

fn trace_d(m: matd) -> f32 {
    return m[0][0] + m[1][1] + m[2][2];
}

// Rows of the inverse are cross products of the columns, over the determinant.
fn inverse_d(m: matd) -> matd {
    let adj = transpose(matd(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])));
    return adj * (1.0 / determinant(m));
}

// The smallest eigenvalue of a symmetric tensor: the trigonometric solution of the
// characteristic cubic (tensor::smallest_stretch_squared on the CPU), then two Newton
// steps on the cubic, since Vulkan lets acos be off by thousands of ulp (4e-4 relative
// measured on lavapipe, worse near a triple root). Each step is kept within ±0.1 p: near
// a double or triple root the slope vanishes and an unbounded step would follow the f32
// noise of the cubic; the eigenvalues lie within 2p of q, so the result stays within
// 0.2 p of the trigonometric one.
fn smallest_eigenvalue_sym(c: matd) -> f32 {
    let q = trace_d(c) / 3.0;
    let off = c[1][0] * c[1][0] + c[2][0] * c[2][0] + c[2][1] * c[2][1];
    let d = vec3<f32>(c[0][0], c[1][1], c[2][2]) - vec3<f32>(q);
    let p = sqrt((dot(d, d) + 2.0 * off) / 6.0);
    if p == 0.0 {
        return q;
    }
    let b = (c - identity_d() * q) * (1.0 / p);
    let phi = acos(clamp(0.5 * determinant(b), -1.0, 1.0)) / 3.0;
    var l = q + 2.0 * p * cos(phi + 2.0943951);
    // det(C − λI) = ((I1 − λ)λ − I2)λ + I3.
    let i1 = trace_d(c);
    let i2 = 0.5 * (i1 * i1 - trace_d(c * c));
    let i3 = determinant(c);
    for (var k = 0; k < 2; k++) {
        let slope = (2.0 * i1 - 3.0 * l) * l - i2;
        if slope != 0.0 {
            l -= clamp((((i1 - l) * l - i2) * l + i3) / slope, -0.1 * p, 0.1 * p);
        }
    }
    return l;
}

fn ddot_d(a: matd, b: matd) -> f32 {
    return dot(a[0], b[0]) + dot(a[1], b[1]) + dot(a[2], b[2]);
}

// Entry-wise product.
fn hadamard(a: matd, b: matd) -> matd {
    return matd(a[0] * b[0], a[1] * b[1], a[2] * b[2]);
}

// Tensor cross product A × B (seed 003 eq 3): column i is a_j × b_k + b_j × a_k with
// (i, j, k) cyclic, so that cof A = ½ A × A (columns a_j × a_k, as in inverse_d).
fn tensor_cross(a: matd, b: matd) -> matd {
    return matd(
        cross(a[1], b[2]) + cross(b[1], a[2]),
        cross(a[2], b[0]) + cross(b[2], a[0]),
        cross(a[0], b[1]) + cross(b[0], a[1]),
    );
}

// cof(I + A) − I = I × A + ½ A × A, without the cancellation of forming I + A.
fn cof_excess(a: matd) -> matd {
    return tensor_cross(identity_d() + a * 0.5, a);
}

// d cof F/dt = F × Ḟ with F = I + A.
fn cof_rate(a: matd, f_dot: matd) -> matd {
    return tensor_cross(identity_d() + a, f_dot);
}

// Integer cell coordinates of a point.
fn cell_coords(x: vecd, origin: vec3<f32>, inv_cell: f32, dims: vec3<u32>) -> vec3<u32> {
    let c = clamp(floor((x - origin) * inv_cell), vec3<f32>(0.0), vec3<f32>(dims - vec3<u32>(1u)));
    return vec3<u32>(c);
}

// A vector as three components, and back (the identity in 3D).
fn pad3(v: vecd) -> vec3<f32> {
    return v;
}

fn unpad(v: vec3<f32>) -> vecd {
    return v;
}

// Solves I λ = m for an inertia tensor I.
fn solve_inertia(i: mat3x3<f32>, m: vec3<f32>) -> vec3<f32> {
    return inverse_d(i) * m;
}

// The 3 × 3 tensor itself (the 2D prelude pads an in-plane one with zz).
fn lift3(m: matd, zz: f32) -> mat3x3<f32> {
    return m;
}

fn lower3(m: mat3x3<f32>) -> matd {
    return m;
}
