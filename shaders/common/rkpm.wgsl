// Reproducing-kernel functions with a linear basis (seed 000 §1.4, eqs 42–59;
// src/core/correction.rs `Rkpm`) at a point x of nodes x_j with volumes V_j, in the basis
// p̂(r) = (1, r/h) scaled by a smoothing length h (f32 keeps the moment matrix's entries of
// one order): M̂ = Σ_j V_j W_j p̂ p̂ᵀ, M̂ C = e₁ and M̂ ∂_k C = −(∂_k M̂) C, so that Ψ_j(x) =
// C·p̂(r_j) W(r_j) with r_j = x − x_j.

// The solution of M y = b for the n × n (n ≤ 4) moment matrix M by Gaussian elimination
// with partial pivoting (src/core/correction.rs `solve_small`); ok = false where a pivot
// is below 1e-6 of M's largest entry (singular in f32).
struct Solved {
    y: array<f32, 4>,
    ok: bool,
}

fn solve_moments(m_in: array<array<f32, 4>, 4>, b_in: array<f32, 4>, n: u32) -> Solved {
    var m = m_in;
    var b = b_in;
    var out: Solved;
    var scale = 0.0;
    for (var a = 0u; a < n; a++) {
        for (var c = 0u; c < n; c++) {
            scale = max(scale, abs(m[a][c]));
        }
    }
    for (var c = 0u; c < n; c++) {
        var p = c;
        for (var r = c + 1u; r < n; r++) {
            if abs(m[r][c]) > abs(m[p][c]) {
                p = r;
            }
        }
        if !(abs(m[p][c]) > 1e-6 * scale) {
            out.ok = false;
            return out;
        }
        let row = m[c];
        m[c] = m[p];
        m[p] = row;
        let bc = b[c];
        b[c] = b[p];
        b[p] = bc;
        for (var r = c + 1u; r < n; r++) {
            let f = m[r][c] / m[c][c];
            for (var k = c; k < n; k++) {
                m[r][k] -= f * m[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    for (var rr = 0u; rr < n; rr++) {
        let r = n - 1u - rr;
        var s = b[r];
        for (var k = r + 1u; k < n; k++) {
            s -= m[r][k] * out.y[k];
        }
        out.y[r] = s / m[r][r];
    }
    out.ok = true;
    return out;
}

// The linear basis p̂(r) = (1, r/h).
fn rkpm_basis(r: vecd, h: f32) -> array<f32, 4> {
    var q: array<f32, 4>;
    q[0] = 1.0;
    for (var k = 0u; k < DIM; k++) {
        q[k + 1u] = r[k] / h;
    }
    return q;
}

// The moment matrix M̂ and its derivatives ∂_k M̂, summed node by node (eqs 55–58).
struct Moments {
    m: array<array<f32, 4>, 4>,
    dm: array<array<array<f32, 4>, 4>, 3>,
}

// Adds the node at offset r with volume v, kernel value w and gradient gw at scale h.
fn add_moments(mo: ptr<function, Moments>, r: vecd, v: f32, w: f32, gw: vecd, h: f32) {
    let q = rkpm_basis(r, h);
    for (var a = 0u; a <= DIM; a++) {
        for (var b = 0u; b <= DIM; b++) {
            (*mo).m[a][b] += v * w * q[a] * q[b];
            for (var k = 0u; k < DIM; k++) {
                var e = 0.0;
                if a == k + 1u {
                    e += q[b];
                }
                if b == k + 1u {
                    e += q[a];
                }
                (*mo).dm[k][a][b] += v * (gw[k] * q[a] * q[b] + w * e / h);
            }
        }
    }
}

// The coefficients C and ∂_k C at a point: ok = false where its nodes do not span the
// linear basis (C = e₁ and ∂C = 0 then, the plain kernel).
struct Rkpm {
    c: vec4<f32>,
    dc: array<vec4<f32>, 3>,
    ok: bool,
}

fn rkpm_solve(mo: Moments) -> Rkpm {
    let n = DIM + 1u;
    var out: Rkpm;
    out.c = vec4<f32>(1.0, 0.0, 0.0, 0.0);
    var e1: array<f32, 4>;
    e1[0] = 1.0;
    let c = solve_moments(mo.m, e1, n);
    if !c.ok {
        return out;
    }
    out.c = vec4<f32>(c.y[0], c.y[1], c.y[2], c.y[3]);
    for (var k = 0u; k < DIM; k++) {
        var rhs: array<f32, 4>;
        for (var a = 0u; a < n; a++) {
            var s = 0.0;
            for (var b = 0u; b < n; b++) {
                s += mo.dm[k][a][b] * out.c[b];
            }
            rhs[a] = -s;
        }
        let dc = solve_moments(mo.m, rhs, n);
        out.dc[k] = vec4<f32>(dc.y[0], dc.y[1], dc.y[2], dc.y[3]);
    }
    out.ok = true;
    return out;
}

// The coefficients into kin from `base`, (DIM + 1)² words: C, then ∂_k C for each k
// (needs the binding kin); and back.
fn rkpm_store(base: u32, k: Rkpm) {
    for (var a = 0u; a <= DIM; a++) {
        kin[base + a] = k.c[a];
        for (var d = 0u; d < DIM; d++) {
            kin[base + (DIM + 1u) * (d + 1u) + a] = k.dc[d][a];
        }
    }
}

fn rkpm_load(base: u32) -> Rkpm {
    var k: Rkpm;
    for (var a = 0u; a <= DIM; a++) {
        k.c[a] = kin[base + a];
        for (var d = 0u; d < DIM; d++) {
            k.dc[d][a] = kin[base + (DIM + 1u) * (d + 1u) + a];
        }
    }
    k.ok = true;
    return k;
}

// Ψ_j = C·p̂(r) W of the node at offset r, from the kernel's value w there.
fn rkpm_value(k: Rkpm, r: vecd, w: f32, h: f32) -> f32 {
    let q = rkpm_basis(r, h);
    var cp = 0.0;
    for (var a = 0u; a <= DIM; a++) {
        cp += k.c[a] * q[a];
    }
    return cp * w;
}

// ∇Ψ_j = (∂_k C·p̂ + C_k/h) W + C·p̂ ∂_k W of the node at offset r (seed 000 §1.4), from the
// kernel's value w and gradient grad there.
fn rkpm_gradient(k: Rkpm, r: vecd, w: f32, grad: vecd, h: f32) -> vecd {
    let q = rkpm_basis(r, h);
    var cp = 0.0;
    for (var a = 0u; a <= DIM; a++) {
        cp += k.c[a] * q[a];
    }
    var g: vecd;
    for (var d = 0u; d < DIM; d++) {
        var dcp = 0.0;
        for (var a = 0u; a <= DIM; a++) {
            dcp += k.dc[d][a] * q[a];
        }
        g[d] = (dcp + k.c[d + 1u] / h) * w + cp * grad[d];
    }
    return g;
}
