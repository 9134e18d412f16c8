// Galerkin rates (seed 000 §5.6, §5.7 and its FEM references): one invocation per
// quadrature point for the stress, then one per node for the force, a gather over the
// node's points through the transposed lists; each writes only its own point or node.
// Total-Lagrangian (UL = 0): per pair ∇0N_a(X_q), per entry w_q ∇0N_a(X_q), and the
// points pass writes P_q. Updated-Lagrangian elements (UL = 1, `ul-fem`): per pair the
// parent derivatives ∂N_a/∂ξ at the point and the reference offset X_a − X_first from the
// point's first node, per entry ∂N_a/∂ξ; the points pass evaluates its cell on the current
// node positions, J_q = Σ_a x_a ⊗ ∂N_a/∂ξ, ∇N_a(x_q) = J_q⁻ᵀ ∂N_a/∂ξ and w_q = W_RULE
// det J_q, and writes w_q σ_q J_q⁻ᵀ, so that the same nodes pass gathers −Σ_q w_q σ_q
// ∇N_a(x_q).
//
// Flat f32 buffers: the state y = [u | v (nodes) | ρ − ρ0 | S (points, rate model only)],
// kin = [H = F − I | P (w σ J⁻ᵀ with UL) | ψ (points) | power (nodes)], pair = [∇0N_a
// (∂N_a/∂ξ with UL) | X_a − X_first (UL only)] per point–node pair of the points' CSR
// (offsets, ids), and the reference configuration of the nodes (reference.wgsl; its V is
// m/ρ0, so that RHO0·V is the nodal mass). The gather lists, node → its points: gather =
// [offsets | the point of each entry], and per entry entries = [w_q ∇0N_a(X_q) (∂N_a/∂ξ
// with UL) | w_q N_a(X_q)]. The points' lists and the gather lists are each split into
// parts (part.wgsl: rows part.first + row, with the part's own offsets, ids and per-pair
// data): the points pass runs a part of the points at a time, the nodes pass a part of
// the nodes; the points' plastic history hist (plasticity.wgsl; 13 floats of a dummy for
// the elastic models). Constants: N (nodes), Q (points), DIM, UL, W_RULE, RATE, MODEL,
// RHO0, MU, LAMBDA, BULK, YIELD, HARDENING and the field offsets of
// methods::cores::galerkin::gpu::Layout.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<f32>;
@group(0) @binding(4) var<storage, read> y: array<f32>;
@group(0) @binding(5) var<storage, read_write> kin: array<f32>;
@group(0) @binding(6) var<storage, read_write> d: array<f32>;
@group(0) @binding(7) var<storage, read_write> status: array<atomic<u32>>;
// Written by `commit` only; read by `points` with MODEL_VON_MISES_PLASTIC.
@group(0) @binding(8) var<storage, read_write> hist: array<f32>;
@group(0) @binding(9) var<storage, read> gather: array<u32>;
@group(0) @binding(10) var<storage, read> entries: array<f32>;
// External accelerations of tractions and interactions (DIM per node).
@group(0) @binding(11) var<storage, read> ext: array<f32>;

struct Gradients {
    // Σ_a (u_a − u_first) ⊗ g_a: H = F − I, or J − J0 with UL.
    h: matd,
    // Σ_a (v_a − v_first) ⊗ g_a, with `rate` only: Ḟ, or L J with UL.
    f_dot: matd,
    // J0 = Σ_a (X_a − X_first) ⊗ ∂N_a/∂ξ, with UL only.
    j0: matd,
}

// The sums over the nodes of the point at `row` of the part with g_a its pair's vector
// (∇0N_a(X_q), or ∂N_a/∂ξ with UL), each over differences to the first node, since
// Σ_a g_a = 0, so that a rigid displacement keeps its digits: F_q − I = Σ_a u_a ⊗
// ∇0N_a(X_q) and, with `rate`, Ḟ_q; with UL, J_q − J0_q, J0_q (from the pair's
// X_a − X_first) and, with `rate`, L_q J_q.
fn gradients(row: u32, rate: bool) -> Gradients {
    let p_start = offsets[row];
    let p_end = offsets[row + 1u];
    let first = ids[p_start];
    let u0 = vload_y(U_OFF + DIM * first);
    let v0 = vload_y(V_OFF + DIM * first);
    var out: Gradients;
    for (var p = p_start; p < p_end; p++) {
        let a = ids[p];
        let g = vload_pair(PG_OFF + DIM * p);
        out.h += outer(vload_y(U_OFF + DIM * a) - u0, g);
        if rate {
            out.f_dot += outer(vload_y(V_OFF + DIM * a) - v0, g);
        }
        if UL == 1u {
            out.j0 += outer(vload_pair(PDX_OFF + DIM * p), g);
        }
    }
    return out;
}

// F_q − I of the sums: H, or (J − J0) J0⁻¹ with UL (F = J J0⁻¹).
fn strain(g: Gradients) -> matd {
    if UL == 1u {
        return g.h * inverse_d(g.j0);
    }
    return g.h;
}

// Total-Lagrangian: F_q = I + Σ_a u_a ⊗ ∇0N_a(X_q), L_q = Ḟ_q F_q⁻¹ and P_q, ψ_q
// ([`stressed`]); det F_q ≤ 0 flags the point. Updated-Lagrangian elements (UL FEM steps
// 1 and 4): J_q and det J_q of the current cell (det J_q ≤ 0, an inverted element, flags
// the point), L_q = Σ_a v_a ⊗ ∇N_a(x_q) = (Σ_a v_a ⊗ ∂N_a/∂ξ) J_q⁻¹, F_q = J_q J0_q⁻¹ (the
// inverse of Σ_a X_a ⊗ ∇N_a(x_q)), σ_q = P_q F_qᵀ / det F_q and the force tensor
// w_q σ_q J_q⁻ᵀ.
// bytes:
// Items: points; pairs: the point–node pairs, which are also the nodes' gather entries.
// - offsets: 1 scalar per item
// - ids: 1 scalar per item; 1 scalar per pair
// ∇0N_a (∂N_a/∂ξ with UL), and X_a − X_first with UL.
// - pair: 1 vector per pair
// - pair: 1 vector per pair, when UL
// u of the first node and of every node; v too, ρ − ρ0 and S, for the
// rate model.
// - y: 1 vector per item; 1 vector per pair
// - y: 1 scalar + 1 vector + 1 tensor per item; 1 vector per pair, when RATE
// The committed C_p⁻¹ and ε_p of a von Mises point.
// - hist: 12 scalars per item, when MODEL == MODEL_VON_MISES_PLASTIC
// H, P, ψ.
// - kin: 1 scalar + 2 tensors per item
// - d: 1 scalar + 1 tensor per item, when RATE
// - status: nothing
@compute @workgroup_size(256)
fn points(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let q = part.first + row;
    let grads = gradients(row, RATE == 1u);
    let h = strain(grads);
    let f = identity_d() + h;
    if UL == 1u {
        let j = grads.j0 + grads.h;
        let det_j = determinant(j);
        if !(det_j > 0.0) {
            atomicMin(&status[0], q);
        }
        let j_inv = inverse_d(j);
        let st = stressed(q, h, inverse_d(f), grads.f_dot * j_inv);
        let sigma = st.pk * transpose(f) * (1.0 / determinant(f));
        mstore_kin(KP_OFF + DIM * DIM * q, sigma * transpose(j_inv) * (W_RULE * det_j));
        kin[KPSI_OFF + q] = st.psi;
    } else {
        if !(determinant(f) > 0.0) {
            atomicMin(&status[0], q);
        }
        let f_inv = inverse_d(f);
        let st = stressed(q, h, f_inv, grads.f_dot * f_inv);
        mstore_kin(KP_OFF + DIM * DIM * q, st.pk);
        kin[KPSI_OFF + q] = st.psi;
    }
    mstore_kin(KF_OFF + DIM * DIM * q, h);
}

// The commit of the plastic history before every step (TlGalerkin::begin_step): one
// invocation per point returns its F of the step's start state from its history and
// stores the result in its own entries of hist (plastic_store.wgsl).
// bytes:
// Items: points; pairs: the point–node pairs.
// - offsets: 1 scalar per item
// - ids: 1 scalar per item; 1 scalar per pair
// - pair: 1 vector per pair
// - pair: 1 vector per pair, when UL
// - y: 1 vector per item; 1 vector per pair
// - hist: 12 scalars per item
@compute @workgroup_size(256)
fn commit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let q = part.first + row;
    let f = identity_d() + strain(gradients(row, false));
    store_history(q, return_map(lift3(f, 1.0), history(q)));
}

// ü_a = −(1/m_a) Σ_q w_q P_q ∇0N_a(X_q) (Algorithm 6 step 4; with UL, −(1/m_a) Σ_q
// (w_q σ_q J_q⁻ᵀ) ∂N_a/∂ξ(ξ_q) = −(1/m_a) Σ_q w_q σ_q ∇N_a(x_q), UL FEM step 4), the
// boundary conditions (boundary.wgsl) and u̇ = v.
// bytes:
// Items: nodes; pairs: the point–node pairs, the nodes' gather entries.
// The row end, and the point of every entry.
// - gather: 1 scalar per item; 1 scalar per pair
// w_q ∇0N_a(X_q) (∂N_a/∂ξ with UL).
// - entries: 1 vector per pair
// P_q (w_q σ_q J_q⁻ᵀ with UL) in; the power out.
// - kin loads: 1 tensor per pair
// - kin stores: 1 scalar per item
// V and the mask.
// - reference: 2 scalars per item
// - y: 1 vector per item
// - ext: 1 vector per item
// - d: 2 vectors per item
@compute @workgroup_size(256)
fn nodes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    var force: vecd;
    let e_end = gather[row + 1u];
    for (var e = gather[row]; e < e_end; e++) {
        let q = gather[GPOINT_OFF + e];
        force -= mload_kin(KP_OFF + DIM * DIM * q) * vload_entries(EWG_OFF + DIM * e);
    }
    let m = RHO0 * vol_of(a);
    let v = vload_y(V_OFF + DIM * a);
    vstore_d(V_OFF + DIM * a, apply_boundary(a, force * (1.0 / m), v, m));
    vstore_d(U_OFF + DIM * a, v);
}
