// The updated-Lagrangian weak form (seed 000 §5.7, Algorithm 7; the CPU's
// src/methods/ul_weak_form/ on the updated-Lagrangian Galerkin system): one stress point
// per lattice cell, moved with the interpolated velocity (eq 169), and particles carrying
// ρ. At every rate evaluation each stress point and each particle evaluates
// reproducing-kernel functions N_j = V_j Ψ_j (V_j = m_j/ρ_j, rkpm.wgsl) on its
// covariance-ellipse neighbourhood (seed 000 §1.5, eq 64): among the candidates of its
// list (the particles of its body within ±3Δx of it on the reference configuration, fixed
// at set-up, ascending), C = (1/n) Σ_j r_j ⊗ r_j and h = max_j |r_j| / 2 over all of them
// (r_j = x − x_j), the neighbours those with r_j · C⁻¹ r_j ≤ AXIS_SCALE², with the cubic
// spline of that h.
//
// Passes: `points` (at each stress point its functions, L_q = Σ_j (v_j − v_o) ⊗ ∇N_j,
// F_q⁻¹ = Σ_j (X_j − X_o) ⊗ ∇N_j, ρ̇_q, Ṡ_q, σ_q = S_q − p I and w_q = w0_q ρ0/ρ_q,
// ẋ_q = Σ_j N_j v_j; then C_q⁻¹, h_q, the coefficients and T_q = w_q σ_q into kin),
// `nodes` (each particle j gathers −Σ_q T_q ∇N_j(x_q) over the stress points it is a
// candidate of, the transposed lists, its function at each from the point's stored
// ellipse and coefficients, so that no pair slot is shared between passes), `particles`
// (the particle's own functions: ρ̇_i = −ρ_i Σ_j (v_j − v_i) · ∇N_j(x_i)), and after each
// step `smooth_own` (v_i ← Σ_j N_j(x_i) v_j with its own functions at the step's end) and
// `settle` (settle.wgsl). `ellipses` writes, for a read-back, which candidates of each
// stress point its ellipse keeps. Each invocation writes only its own point or particle.
//
// Flat f32 buffers: the state y = [u | v | ρ − ρ0 (particles) | u | ρ − ρ0 | S (stress
// points)], pts = [X_q | w0_q], kin = [T | C⁻¹ | h | C, ∂_k C ((DIM + 1)² each) | w0 ψ
// (stress points) | power (particles)], the particles' reference configuration
// (reference.wgsl; its V is m/ρ0). The lists bound are a part of the stress points' or of
// the particles' (part.wgsl). status = [first stress point whose functions degenerate,
// whose ρ ≤ 0; first particle whose own functions degenerate, whose ρ ≤ 0]. Constants: N,
// Q, DIM, RATE, OBJECTIVE_RATE, RHO0, MU, LAMBDA, BULK, AXIS_SCALE, the kernel's (cubic
// spline) and the field offsets of methods::ul_weak_form::gpu::Layout.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pts: array<f32>;
// Written by `settle` only.
@group(0) @binding(3) var<storage, read_write> y: array<f32>;
@group(0) @binding(4) var<storage, read_write> kin: array<f32>;
@group(0) @binding(5) var<storage, read_write> d: array<f32>;
@group(0) @binding(6) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read> reference: array<f32>;
// External accelerations of tractions and interactions (DIM per particle).
@group(0) @binding(8) var<storage, read> ext: array<f32>;
@group(0) @binding(9) var<storage, read_write> smoothed: array<f32>;
// 1 where the ellipse keeps the candidate of the pair, 0 where not (`ellipses`).
@group(0) @binding(10) var<storage, read_write> kept: array<u32>;

// Where a point's functions are evaluated: its reference position and displacement, so
// that the offsets to the particles keep their digits far from the origin.
struct Centre {
    x0: vecd,
    u: vecd,
}

fn stress_point(q: u32) -> Centre {
    return Centre(vload_pts(QX_OFF + DIM * q), vload_y(PU_OFF + DIM * q));
}

fn particle(i: u32) -> Centre {
    return Centre(x0_of(i), vload_y(U_OFF + DIM * i));
}

// r_j = x − x_j of particle j from the centre.
fn offset(c: Centre, j: u32) -> vecd {
    return (c.x0 - x0_of(j)) + (c.u - vload_y(U_OFF + DIM * j));
}

// V_j = m_j/ρ_j (the reference's V is m/ρ0).
fn volume(j: u32) -> f32 {
    return vol_of(j) * RHO0 / (RHO0 + y[NRHO_OFF + j]);
}

// The range of the pairs of the bound part's row in its ids (its offsets count from the
// part's first pair).
fn pairs_of(row: u32) -> vec2<u32> {
    return vec2<u32>(offsets[row], offsets[row + 1u]);
}

// A point's neighbourhood and functions: its ellipse's C⁻¹ and h, and the coefficients;
// fail = 0, or 1 where the candidates span no ellipse (|det C| ≤ 1e-6 of its scale, the
// f32 form of the CPU's 1e-12), 2 where the particles in it do not span the linear basis.
struct Functions {
    c_inv: matd,
    h: f32,
    rk: Rkpm,
    fail: u32,
}

// Whether the particle at offset r lies in the ellipse of C⁻¹ (boundary included).
fn inside(c_inv: matd, r: vecd) -> bool {
    return dot(r, c_inv * r) <= AXIS_SCALE * AXIS_SCALE;
}

// The functions at the centre of the candidates in `range` (§1.4–1.5).
fn functions(c: Centre, range: vec2<u32>) -> Functions {
    var out: Functions;
    var cov: matd;
    var reach = 0.0;
    for (var p = range.x; p < range.y; p++) {
        let r = offset(c, ids[p]);
        cov += outer(r, r);
        reach = max(reach, dot(r, r));
    }
    cov = cov * (1.0 / f32(range.y - range.x));
    let scale = pow(trace_d(cov) / f32(DIM), f32(DIM));
    if !(determinant(cov) > 1e-6 * scale) {
        out.fail = 1u;
        return out;
    }
    out.c_inv = inverse_d(cov);
    out.h = sqrt(reach) / 2.0;
    var mo: Moments;
    for (var p = range.x; p < range.y; p++) {
        let j = ids[p];
        let r = offset(c, j);
        if inside(out.c_inv, r) {
            let w = kernel_w_at(length(r), out.h);
            add_moments(&mo, r, volume(j), w, kernel_grad_at(r, out.h), out.h);
        }
    }
    out.rk = rkpm_solve(mo);
    if !out.rk.ok {
        out.fail = 2u;
    }
    return out;
}

// N_j and ∇N_j of a particle of volume v at offset r inside the ellipse of f.
struct Shape {
    n: f32,
    grad: vecd,
}

fn shape_of(f: Functions, r: vecd, v: f32) -> Shape {
    let w = kernel_w_at(length(r), f.h);
    let g = rkpm_gradient(f.rk, r, w, kernel_grad_at(r, f.h), f.h);
    return Shape(v * rkpm_value(f.rk, r, w, f.h), g * v);
}

// Stress point q's ellipse and coefficients into kin, and back.
fn store_functions(q: u32, f: Functions) {
    mstore_kin(KCI_OFF + DIM * DIM * q, f.c_inv);
    kin[KH_OFF + q] = f.h;
    rkpm_store(KRK_OFF + (DIM + 1u) * (DIM + 1u) * q, f.rk);
}

fn load_functions(q: u32) -> Functions {
    var f: Functions;
    f.c_inv = mload_kin(KCI_OFF + DIM * DIM * q);
    f.h = kin[KH_OFF + q];
    f.rk = rkpm_load(KRK_OFF + (DIM + 1u) * (DIM + 1u) * q);
    return f;
}

// At every stress point of the bound part (Algorithm 7 steps 1–7 and 11): its functions
// (degenerate ones flag the point), L_q and F_q⁻¹ over differences to its first candidate
// o (Σ_j ∇N_j = 0), ρ̇_q, Ṡ_q, σ_q (rate_point.wgsl), w_q = w0_q ρ0/ρ_q (ρ_q ≤ 0 flags the
// point) and ẋ_q = v_o + Σ_j N_j (v_j − v_o) (Σ_j N_j = 1) into d; C_q⁻¹, h_q, the
// coefficients, T_q = w_q σ_q and w0_q ψ_q into kin.
// bytes:
// Items: stress points; pairs: the candidates of their lists, whose ids are read three
// times (the ellipse, the moments, the functions) and their particles' fields once.
// - offsets: 1 scalar per item
// - ids: 3 scalars per pair
// X_q, w0_q, u_q, ρ_q and S_q; X, u, V and ρ of each candidate, and its v.
// - pts: 1 vector + 1 scalar per item
// - y: 1 vector + 1 scalar + 1 tensor per item; 2 vectors + 1 scalar per pair
// - reference: 1 vector + 1 scalar per pair
// T, C⁻¹, h, the coefficients and w0 ψ.
// - kin: 2 scalars + 3 tensors + 2 vectors + 1 scalar per item
// ẋ_q, ρ̇_q and Ṡ_q.
// - d: 1 vector + 1 scalar + 1 tensor per item
// - status: nothing
@compute @workgroup_size(256)
fn points(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let q = part.first + row;
    let c = stress_point(q);
    let range = pairs_of(row);
    let f = functions(c, range);
    if f.fail != 0u {
        atomicMin(&status[0], q);
        return;
    }
    let o = ids[range.x];
    let v_o = vload_y(V_OFF + DIM * o);
    let x0_o = x0_of(o);
    var l: matd;
    var f_inv: matd;
    var x_dot: vecd;
    for (var p = range.x; p < range.y; p++) {
        let j = ids[p];
        let r = offset(c, j);
        if inside(f.c_inv, r) {
            let s = shape_of(f, r, volume(j));
            let dv = vload_y(V_OFF + DIM * j) - v_o;
            l += outer(dv, s.grad);
            f_inv += outer(x0_of(j) - x0_o, s.grad);
            x_dot += dv * s.n;
        }
    }
    vstore_d(PU_OFF + DIM * q, v_o + x_dot);
    let rho = RHO0 + y[RHO_OFF + q];
    if !(rho > 0.0) {
        atomicMin(&status[1], q);
    }
    let st = rate_point(q, inverse_d(f_inv) - identity_d(), l);
    mstore_kin(KT_OFF + DIM * DIM * q, st.sigma * (pts[QW_OFF + q] * RHO0 / rho));
    kin[KE_OFF + q] = pts[QW_OFF + q] * st.psi;
    store_functions(q, f);
}

// m_j v̇_j = −Σ_q T_q ∇N_j(x_q) over the stress points of particle j's row in the bound
// part of the transposed lists (those outside whose ellipse it lies skipped), the boundary
// conditions (boundary.wgsl) and u̇ = v.
// bytes:
// Items: particles; pairs: the entries of their transposed lists.
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// X_q, u_q, T_q, C_q⁻¹, h_q and the coefficients of each point; X, u, V, ρ, v of the
// particle.
// - pts: 1 vector per pair
// - y: 1 vector per pair
// - kin loads: 2 tensors + 1 scalar + 1 tensor + 2 vectors + 1 scalar per pair
// - kin stores: 1 scalar per item
// - reference: 1 vector + 2 scalars per item
// - y: 2 vectors + 1 scalar per item
// - ext: 1 vector per item
// - d: 2 vectors per item
@compute @workgroup_size(256)
fn nodes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let j = part.first + row;
    let v_j = volume(j);
    var force: vecd;
    let range = pairs_of(row);
    for (var p = range.x; p < range.y; p++) {
        let q = ids[p];
        let r = offset(stress_point(q), j);
        let f = load_functions(q);
        if inside(f.c_inv, r) {
            force -= mload_kin(KT_OFF + DIM * DIM * q) * shape_of(f, r, v_j).grad;
        }
    }
    let m = RHO0 * vol_of(j);
    let v = vload_y(V_OFF + DIM * j);
    vstore_d(V_OFF + DIM * j, apply_boundary(j, force * (1.0 / m), v, m));
    vstore_d(U_OFF + DIM * j, v);
}

// ρ̇_i = −ρ_i Σ_j (v_j − v_i) · ∇N_j(x_i) with particle i's own functions (Algorithm 7
// steps 6 and 9); degenerate functions or ρ_i ≤ 0 flag the particle.
// bytes:
// Items: particles; pairs: the candidates of their own lists, whose ids are read three
// times and their particles' fields once.
// - offsets: 1 scalar per item
// - ids: 3 scalars per pair
// - reference: 1 vector per item; 1 vector + 1 scalar per pair
// - y: 2 vectors + 1 scalar per item; 2 vectors + 1 scalar per pair
// - d: 1 scalar per item
// - status: nothing
@compute @workgroup_size(256)
fn particles(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let c = particle(i);
    let range = pairs_of(row);
    let f = functions(c, range);
    if f.fail != 0u {
        atomicMin(&status[2], i);
        return;
    }
    let rho = RHO0 + y[NRHO_OFF + i];
    if !(rho > 0.0) {
        atomicMin(&status[3], i);
    }
    let v_i = vload_y(V_OFF + DIM * i);
    var div_v = 0.0;
    for (var p = range.x; p < range.y; p++) {
        let j = ids[p];
        let r = offset(c, j);
        if inside(f.c_inv, r) {
            div_v += dot(vload_y(V_OFF + DIM * j) - v_i, shape_of(f, r, volume(j)).grad);
        }
    }
    d[NRHO_OFF + i] = -rho * div_v;
}

// The velocity smoothing after a step (seed 000 §5.6): v_i + Σ_j N_j(x_i) (v_j − v_i)
// (Σ_j N_j = 1) with particle i's own functions at the step's end into `smoothed`; a
// particle whose functions degenerate keeps its velocity (the next rate evaluation flags
// it).
// bytes:
// Items: particles; pairs: the candidates of their own lists, whose ids are read three
// times and their particles' fields once.
// - offsets: 1 scalar per item
// - ids: 3 scalars per pair
// - reference: 1 vector per item; 1 vector + 1 scalar per pair
// - y: 2 vectors per item; 2 vectors + 1 scalar per pair
// - smoothed: 1 vector per item
@compute @workgroup_size(256)
fn smooth_own(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let c = particle(i);
    let range = pairs_of(row);
    let f = functions(c, range);
    let v_i = vload_y(V_OFF + DIM * i);
    var v = v_i;
    if f.fail == 0u {
        for (var p = range.x; p < range.y; p++) {
            let j = ids[p];
            let r = offset(c, j);
            if inside(f.c_inv, r) {
                v += (vload_y(V_OFF + DIM * j) - v_i) * shape_of(f, r, volume(j)).n;
            }
        }
    }
    vstore_smoothed(DIM * i, v);
}

// Which candidates of each stress point of the bound part its ellipse keeps, 1 or 0 per
// pair of the part (0 throughout where the functions degenerate), for a read-back.
// bytes:
// Items: stress points; pairs: the candidates of their lists, read three times.
// - offsets: 1 scalar per item
// - ids: 3 scalars per pair
// - pts: 1 vector per item
// - y: 1 vector per item; 1 vector + 1 scalar per pair
// - reference: 1 vector + 1 scalar per pair
// - kept: 1 scalar per pair
@compute @workgroup_size(256)
fn ellipses(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let q = part.first + row;
    let c = stress_point(q);
    let range = pairs_of(row);
    let f = functions(c, range);
    for (var p = range.x; p < range.y; p++) {
        kept[p] = select(0u, 1u, f.fail == 0u && inside(f.c_inv, offset(c, ids[p])));
    }
}
