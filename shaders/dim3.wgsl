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

fn ddot_d(a: matd, b: matd) -> f32 {
    return dot(a[0], b[0]) + dot(a[1], b[1]) + dot(a[2], b[2]);
}

// Integer cell coordinates of a point.
fn cell_coords(x: vecd, origin: vec3<f32>, inv_cell: f32, dims: vec3<u32>) -> vec3<u32> {
    let c = clamp(floor((x - origin) * inv_cell), vec3<f32>(0.0), vec3<f32>(dims - vec3<u32>(1u)));
    return vec3<u32>(c);
}

// A vector as three components (the identity in 3D).
fn pad3(v: vecd) -> vec3<f32> {
    return v;
}
