// The Krongauz–Belytschko method on an Eulerian kernel (seed 001 §2.2, Table 2; the CPU's
// src/methods/kbm/eulerian.rs on the updated-Lagrangian Galerkin system): the kernel
// W(x − x_a, h0) of the current positions, so that every rate evaluation recomputes at
// each point q, among the particles of its list, the Shepard functions W^S_a = W_a / S_q
// (S_q = Σ_a W_a(x_q), eq 28), their gradients g_a = ∇W^S_a, M_q = Σ_a g_a ⊗ (x_a − x_q) and
// the trial gradients G_a = M_q⁻¹ g_a (eqs 27, 31), with L_q = Σ_a v_a ⊗ G_a and
// F_q⁻¹ = Σ_a X_a ⊗ G_a. Each node a then gathers over the points of its own list
// f_a = −Σ_q w_q σ_q ∇W^S_a(x_q) = −Σ_q (T_q ∇W_a(x_q) − W_a(x_q) t_q) with the point's
// T_q = w_q σ_q / S_q and t_q = T_q ∇S_q / S_q, so that it needs no slot of the point's
// rows. Each invocation writes only its own point or node.
//
// The points are the particles (0 ≤ q < N) and the stress points (N ≤ q < Q), which move
// with the Shepard interpolant of the velocities. The lists are one self-search of all
// points within the kernel support widened by the skin (cell_list.wgsl, ids ascending,
// self excluded), made from the positions `xs` that `positions` writes every
// `search_every` steps: the particles of a point's list are the ids below N, a prefix of
// it, with the point itself when it is a particle; a node's points are itself and its
// whole list, the transposed lists, since the search is symmetric.
//
// Flat f32 buffers: the state y = [u | v (particles) | u (stress points) | ρ − ρ0 | S
// (points, rate model only)], pts = [X_q | w0_q] of every point, kin = [T | t | w0 ψ
// (points) | power (particles)], the particles' reference configuration (reference.wgsl;
// its V is m/ρ0) and the points' plastic history hist (plasticity.wgsl; 13 floats of a
// dummy for the elastic models). status = [first point whose M is singular, whose
// det F ≤ 0, whose ρ ≤ 0]. Constants: N, Q, DIM, RATE, MODEL, RHO0, MU, LAMBDA, BULK,
// YIELD, HARDENING, the kernel's and the field offsets of methods::kbm::gpu::Layout.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pts: array<f32>;
@group(0) @binding(3) var<storage, read> y: array<f32>;
@group(0) @binding(4) var<storage, read_write> kin: array<f32>;
@group(0) @binding(5) var<storage, read_write> d: array<f32>;
@group(0) @binding(6) var<storage, read_write> status: array<atomic<u32>>;
// Written by `commit` only; read by `points` with MODEL_VON_MISES_PLASTIC.
@group(0) @binding(7) var<storage, read_write> hist: array<f32>;
@group(0) @binding(8) var<storage, read> reference: array<f32>;
// External accelerations of tractions and interactions (DIM per particle).
@group(0) @binding(9) var<storage, read> ext: array<f32>;
// The points' positions at the last search, DIM per point.
@group(0) @binding(10) var<storage, read_write> xs: array<f32>;

// The displacement of point p: its particle's, or a stress point's own.
fn displacement(p: u32) -> vecd {
    if p < N {
        return vload_y(U_OFF + DIM * p);
    }
    return vload_y(PU_OFF + DIM * (p - N));
}

// X_p of point p.
fn x0_at(p: u32) -> vecd {
    return vload_pts(QX_OFF + DIM * p);
}

// x_p − x_o of two points, from their reference offset and their displacements, so that
// a body far from the origin keeps its digits.
fn offset(p: u32, o: u32) -> vecd {
    return (x0_at(p) - x0_at(o)) + (displacement(p) - displacement(o));
}

// The range of point i's pairs in the bound part's ids: the offsets less the part's first,
// exact within a part however far the offsets over every point wrap past 2³².
fn pairs_of(i: u32) -> vec2<u32> {
    let base = offsets[part.first];
    return vec2<u32>(offsets[i] - base, offsets[i + 1u] - base);
}

// What point q's functions give: S_q, ∇S_q, L_q, F_q⁻¹, ẋ_q = Σ_a W^S_a v_a, and whether
// the kernels reach it and M_q is regular.
struct KbPoint {
    s: f32,
    grad_s: vecd,
    l: matd,
    f_inv: matd,
    x_dot: vecd,
    regular: bool,
}

// The point's particle a of the range: itself first when it is a particle (k = 0), then
// the ids below N of its list (ascending, so that the first id at or past N ends them).
fn particle(q: u32, own: u32, k: u32, range: vec2<u32>) -> u32 {
    if k < own {
        return q;
    }
    let at = range.x + k - own;
    if at >= range.y {
        return Q;
    }
    return ids[at];
}

// The Krongauz–Belytschko functions at point q on the current configuration (eqs 27–32),
// summed as L_q = (Σ_a (v_a − v_o) ⊗ g_a) M_q⁻ᵀ and F_q⁻¹ = (Σ_a (X_a − X_o) ⊗ g_a) M_q⁻ᵀ
// over differences to its first particle o, since Σ_a g_a = 0; M_q singular (|det M_q| ≤
// 1e-10 of its scale, as on the CPU) or no kernel reaching the point leaves it irregular.
fn kb_point(q: u32) -> KbPoint {
    let range = pairs_of(q);
    let own = select(0u, 1u, q < N);
    var out: KbPoint;
    let o = particle(q, own, 0u, range);
    if o >= N {
        return out;
    }
    for (var k = 0u; ; k++) {
        let a = particle(q, own, k, range);
        if a >= N {
            break;
        }
        let r = offset(q, a);
        out.s += kernel_w(length(r));
        out.grad_s += kernel_grad(r);
    }
    if !(out.s > 0.0) {
        return out;
    }
    let v_o = vload_y(V_OFF + DIM * o);
    var m: matd;
    var b_v: matd;
    var b_x: matd;
    for (var k = 0u; ; k++) {
        let a = particle(q, own, k, range);
        if a >= N {
            break;
        }
        let r = offset(q, a);
        let w_s = kernel_w(length(r)) / out.s;
        // ∇W^S_a = (∇W_a − W^S_a ∇S) / S (eq 28).
        let g = (kernel_grad(r) - out.grad_s * w_s) * (1.0 / out.s);
        let v = vload_y(V_OFF + DIM * a);
        m += outer(g, -r);
        b_v += outer(v - v_o, g);
        b_x += outer(x0_at(a) - x0_at(o), g);
        out.x_dot += v * w_s;
    }
    var scale2 = 0.0;
    for (var c = 0u; c < DIM; c++) {
        scale2 += dot(m[c], m[c]);
    }
    var scale_d = scale2 / f32(DIM);
    if DIM == 3u {
        scale_d *= sqrt(scale_d);
    }
    if !(abs(determinant(m)) > 1e-10 * scale_d) {
        return out;
    }
    let a_t = transpose(inverse_d(m));
    out.l = b_v * a_t;
    out.f_inv = b_x * a_t;
    out.regular = true;
    return out;
}

// At every point: its functions (kb_point; a singular M_q flags the point), F_q =
// (Σ_a X_a ⊗ G_a)⁻¹, σ_q and w_q = w0_q ρ0/ρ_q (rate model; ρ_q ≤ 0 flags the point) or
// w0_q det F_q (det F_q ≤ 0 flags it), then T_q = w_q σ_q / S_q, t_q = T_q ∇S_q / S_q and
// w0_q ψ_q into kin; ρ̇_q and Ṡ_q (rate model) and a stress point's ẋ_q into d.
// bytes:
// Items: points; pairs: the pairs of their lists, read twice over the particles (the
// pass stops at a list's first stress point: counting every pair bounds it from above).
// - offsets: 2 scalars per item
// - ids: 2 scalars per pair
// X_q, w0_q and every particle's X.
// - pts: 1 vector + 1 scalar per item; 1 vector per pair
// u (of the point and each particle), v of each particle, ρ − ρ0 and S.
// - y: 1 vector per item; 2 vectors per pair
// - y: 1 scalar + 1 tensor per item, when RATE
// The committed C_p⁻¹ and ε_p of a von Mises point.
// - hist: 12 scalars per item, when MODEL == MODEL_VON_MISES_PLASTIC
// T, t and w0 ψ.
// - kin: 1 scalar + 1 vector + 1 tensor per item
// ẋ of a stress point; ρ̇ and Ṡ.
// - d: 1 vector per item
// - d: 1 scalar + 1 tensor per item, when RATE
// - status: nothing
@compute @workgroup_size(256)
fn points(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let q = part.first + row;
    let p = kb_point(q);
    if q >= N {
        vstore_d(PU_OFF + DIM * (q - N), p.x_dot);
    }
    if !p.regular {
        atomicMin(&status[0], q);
        return;
    }
    let f = inverse_d(p.f_inv);
    let h = f - identity_d();
    let st = stressed(q, h, p.f_inv, p.l);
    let det_f = determinant(f);
    var w = pts[QW_OFF + q];
    if RATE == 1u {
        let rho = RHO0 + y[RHO_OFF + q];
        if !(rho > 0.0) {
            atomicMin(&status[2], q);
        }
        w *= RHO0 / rho;
    } else {
        if !(det_f > 0.0) {
            atomicMin(&status[1], q);
        }
        w *= det_f;
    }
    let t = st.pk * transpose(f) * (w / (det_f * p.s));
    mstore_kin(KT_OFF + DIM * DIM * q, t);
    vstore_kin(KTS_OFF + DIM * q, t * p.grad_s * (1.0 / p.s));
    kin[KE_OFF + q] = pts[QW_OFF + q] * st.psi;
}

// The commit of the plastic history before every step (UlGalerkin::begin_step): one
// invocation per point returns its F of the step's start state from its history and
// stores the result in its own entries of hist (plastic_store.wgsl); a point whose
// functions cannot be evaluated keeps its history, and the next rate evaluation flags it.
// bytes:
// Items: points; pairs: the pairs of their lists, read twice over the particles.
// - offsets: 2 scalars per item
// - ids: 2 scalars per pair
// - pts: 1 vector per item; 1 vector per pair
// - y: 1 vector per item; 2 vectors per pair
// - hist: 12 scalars per item
@compute @workgroup_size(256)
fn commit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let q = part.first + row;
    let p = kb_point(q);
    if p.regular {
        let f = inverse_d(p.f_inv);
        store_history(q, return_map(lift3(f, 1.0), history(q)));
    }
}

// ü_a = −(1/m_a) Σ_q w_q σ_q ∇W^S_a(x_q) over the node's points (itself, where ∇W_a = 0,
// and its list), the boundary conditions (boundary.wgsl) and u̇ = v. The rows of the
// stress points in the bound part are skipped.
// bytes:
// Items: the particles; pairs: the pairs of their lists.
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// X and u of the node and of each point.
// - pts: 1 vector per item; 1 vector per pair
// - y: 1 vector per item; 1 vector per pair
// T and t of each point in; the power out.
// - kin loads: 1 vector per item; 1 tensor + 1 vector per pair
// - kin stores: 1 scalar per item
// V and the mask; v.
// - reference: 2 scalars per item
// - y: 1 vector per item
// - ext: 1 vector per item
// - d: 2 vectors per item
@compute @workgroup_size(256)
fn nodes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    let a = part.first + row;
    if row >= part.rows || a >= N {
        return;
    }
    var force = vload_kin(KTS_OFF + DIM * a) * kernel_w(0.0);
    let range = pairs_of(a);
    for (var k = range.x; k < range.y; k++) {
        let q = ids[k];
        let r = offset(q, a);
        let t = mload_kin(KT_OFF + DIM * DIM * q);
        force -= t * kernel_grad(r) - vload_kin(KTS_OFF + DIM * q) * kernel_w(length(r));
    }
    let m = RHO0 * vol_of(a);
    let v = vload_y(V_OFF + DIM * a);
    vstore_d(V_OFF + DIM * a, apply_boundary(a, force * (1.0 / m), v, m));
    vstore_d(U_OFF + DIM * a, v);
}

// The points' current positions x_p = X_p + u_p into xs, for a search.
// bytes:
// - pts: 1 vector per item
// - y: 1 vector per item
// - xs: 1 vector per item
@compute @workgroup_size(256)
fn positions(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = index(gid, nwg);
    if p >= Q {
        return;
    }
    vstore_xs(DIM * p, x0_at(p) + displacement(p));
}
