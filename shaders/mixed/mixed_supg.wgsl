// SUPG-SPH's passes (seed 003 §1; MixedSph::supg, src/methods/mixed/system/supg.rs;
// docs/methods/mixed.md "SUPG-SPH"), after the forces and before the projection:
//   supg_nodes   per extended particle e: what the stress points interpolate, F − I,
//                ∇0v (the Ḟ of the kinematics), Ḣ, J̇, H − I, J − 1, q = −T with the
//                components its supports hold set to zero, P, u and v; a ghost takes its
//                source's through its image (mixed_images.wgsl);
//   supg_points  per stress point s, with its cell's corners b, N_b = N_b(X_s) and
//                G_b = G_b(X_s): R_F = Σ N_b Ḟ_b − ∇0v_s (R_H, R_J likewise),
//                F^st = F_s − τ_F Δt R_F + ξ_F (∇0x_s − F_s) (H^st, J^st likewise, or
//                cof F^st and det F^st where H, J are not evolved), ΔP_s = P(F^st) − P(F_s)
//                and Δv_s = τ_p Δt/ρ0 (Σ_b P_b G_b − Σ_b N_b q_b); det F^st or J^st ≤ 0
//                records the real particle nearest the point in status[2];
//   supg_gather  per real particle a: D_a += −(1/V_a) Σ w_s ΔP_s G_a(X_s) and
//                L_a = −(1/V_a) Σ w_s Δv_s ⊗ G_a(X_s), added to the rates the kinematics
//                wrote: Ḟ += L, Ḣ += F × L, J̇ += H : L.
// `points` holds the rows of the points, offsets (NS + 1) then the corners' extended ids
// (real, then ghosts); `shapes` per row entry N_b and G_b, and per point its weight w_s
// (the reference volume it carries); `gather` the lists of the real particles, offsets
// (N + 1) then (s, q, b) per entry: the point, its row entry q, and the corner b, a or a
// ghost of a whose image maps the point's terms to a (G_a(X_M(s)) = R G_b(X_s)). In the
// bytes models a pair is a row entry: the points and the gather are dispatched with the
// row entries' share of the neighbour lists' pairs. Layout and constants: mixed.wgsl;
// NS points, TAU_F, TAU_P, XI_F.

struct SupgStep {
    // Δt of the step.
    dt: f32,
}

@group(0) @binding(0) var<uniform> supg: SupgStep;
@group(0) @binding(1) var<storage, read> y: array<f32>;
@group(0) @binding(2) var<storage, read_write> d: array<f32>;
@group(0) @binding(3) var<storage, read> kin: array<f32>;
@group(0) @binding(4) var<storage, read_write> force: array<f32>;
@group(0) @binding(5) var<storage, read> reference: array<f32>;
@group(0) @binding(6) var<storage, read> ghost_src: array<u32>;
// r_0 … r_{DIM−1}, σ per ghost.
@group(0) @binding(7) var<storage, read> ghost_img: array<f32>;
@group(0) @binding(8) var<storage, read_write> nodes: array<f32>;
@group(0) @binding(9) var<storage, read> points: array<u32>;
@group(0) @binding(10) var<storage, read> shapes: array<f32>;
@group(0) @binding(11) var<storage, read_write> terms: array<f32>;
@group(0) @binding(12) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read> gather: array<u32>;

// bytes:
// A ghost reads its source's fields and image.
// - ghost_src: 1 scalar per item
// - ghost_img: 1 scalar + 1 vector per item
// u, v, F; H and J where evolved.
// - y: 2 vectors + 1 tensor per item
// - y: 1 tensor per item, when EVOLVE_H
// - y: 1 scalar per item, when EVOLVE_J
// ∇0v; Ḣ and J̇ where evolved.
// - d: 1 tensor per item
// - d: 1 tensor per item, when EVOLVE_H
// - d: 1 scalar per item, when EVOLVE_J
// - kin: 1 tensor per item
// - force: 1 vector per item
// - reference: 1 scalar per item
// - nodes: 3 vectors + 3 tensors per item
// - nodes: 2 tensors per item, when EVOLVE_H
// - nodes: 2 scalars per item, when EVOLVE_J
@compute @workgroup_size(256)
fn supg_nodes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let e = index(gid, nwg);
    if e >= N + NG {
        return;
    }
    var a = e;
    if e >= N {
        a = ghost_src[e - N];
    }
    var f = mload_y(F_OFF + DIM * DIM * a);
    var grad_v = mload_d(F_OFF + DIM * DIM * a);
    var q = -vload_force(FT_OFF + DIM * a);
    let held = mask_of(a);
    for (var k = 0u; k < DIM; k++) {
        if ((held >> k) & 1u) != 0u {
            q[k] = 0.0;
        }
    }
    var p = mload_kin(KP_OFF + DIM * DIM * a);
    var u = vload_y(U_OFF + DIM * a);
    var v = vload_y(V_OFF + DIM * a);
    var h: matd;
    var h_dot: matd;
    var j = 0.0;
    var j_dot = 0.0;
    if EVOLVE_H == 1u {
        h = mload_y(H_OFF + DIM * DIM * a);
        h_dot = mload_d(H_OFF + DIM * DIM * a);
    }
    if EVOLVE_J == 1u {
        j = y[J_OFF + a];
        j_dot = d[J_OFF + a];
    }
    if e >= N {
        let k = e - N;
        f = map_tensor(k, f);
        grad_v = map_tensor(k, grad_v);
        q = map_vector(k, q);
        p = map_tensor(k, p);
        u = map_vector(k, u);
        v = map_vector(k, v);
        h = map_tensor(k, h);
        h_dot = map_tensor(k, h_dot);
        j = map_scalar(k, j);
        j_dot = map_scalar(k, j_dot);
    }
    mstore_nodes(SNF_OFF + DIM * DIM * e, f);
    mstore_nodes(SNGV_OFF + DIM * DIM * e, grad_v);
    vstore_nodes(SNQ_OFF + DIM * e, q);
    mstore_nodes(SNP_OFF + DIM * DIM * e, p);
    vstore_nodes(SNU_OFF + DIM * e, u);
    vstore_nodes(SNV_OFF + DIM * e, v);
    if EVOLVE_H == 1u {
        mstore_nodes(SNH_OFF + DIM * DIM * e, h);
        mstore_nodes(SNHD_OFF + DIM * DIM * e, h_dot);
    }
    if EVOLVE_J == 1u {
        nodes[SNJ_OFF + e] = j;
        nodes[SNJD_OFF + e] = j_dot;
    }
}

// bytes:
// - points: 1 scalar per item; 1 scalar per pair
// N_b, G_b per corner; w_s is the gather's.
// - shapes: 1 scalar + 1 vector per pair
// The corners' nodes, as a gather's neighbours: once per item.
// - nodes: 3 vectors + 3 tensors per item
// - nodes: 2 tensors per item, when EVOLVE_H
// - nodes: 2 scalars per item, when EVOLVE_J
// ΔP, Δv.
// - terms: 1 vector + 1 tensor per item
// Read only for a point that fails.
// - ghost_src: nothing
// - status: nothing
@compute @workgroup_size(256)
fn supg_points(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let s = index(gid, nwg);
    if s >= NS {
        return;
    }
    // Interpolated excesses F − I, H − I, J − 1 and rates; the gradients at the point.
    var f: matd;
    var h: matd;
    var j = 0.0;
    var f_dot: matd;
    var h_dot: matd;
    var j_dot = 0.0;
    var q_s: vecd;
    var div_p: vecd;
    var grad_v: matd;
    var grad_u: matd;
    var nearest = 0u;
    var n_max = -1.0;
    let end = points[s + 1u];
    for (var q = points[s]; q < end; q++) {
        let b = points[NS + 1u + q];
        let n = shapes[SSN_OFF + q];
        let g = vload_shapes(SSG_OFF + DIM * q);
        f += mload_nodes(SNF_OFF + DIM * DIM * b) * n;
        f_dot += mload_nodes(SNGV_OFF + DIM * DIM * b) * n;
        q_s += vload_nodes(SNQ_OFF + DIM * b) * n;
        div_p += mload_nodes(SNP_OFF + DIM * DIM * b) * g;
        grad_v += outer(vload_nodes(SNV_OFF + DIM * b), g);
        grad_u += outer(vload_nodes(SNU_OFF + DIM * b), g);
        if EVOLVE_H == 1u {
            h += mload_nodes(SNH_OFF + DIM * DIM * b) * n;
            h_dot += mload_nodes(SNHD_OFF + DIM * DIM * b) * n;
        }
        if EVOLVE_J == 1u {
            j += nodes[SNJ_OFF + b] * n;
            j_dot += nodes[SNJD_OFF + b] * n;
        }
        if n > n_max {
            n_max = n;
            nearest = b;
        }
    }
    let tau_f = TAU_F * supg.dt;
    // F^st = F − τ_F (Ḟ − ∇0v) + ξ_F (∇0x − F), with ∇0x − I = ∇0u.
    let f_st = f - (f_dot - grad_v) * tau_f + (grad_u - f) * XI_F;
    var h_st = cof_excess(f_st);
    if EVOLVE_H == 1u {
        let r_h = h_dot - cof_rate(f, grad_v);
        h_st = h - r_h * tau_f + (cof_excess(grad_u) - h) * XI_F;
    } else {
        h = cof_excess(f);
    }
    var j_st = det_excess(f_st);
    if EVOLVE_J == 1u {
        let r_j = j_dot - ddot_d(identity_d() + h, grad_v);
        j_st = j - r_j * tau_f + (det_excess(grad_u) - j) * XI_F;
    } else {
        j = det_excess(f);
    }
    mstore_terms(STDP_OFF + DIM * DIM * s, pk1_mixed(f_st, h_st, j_st) - pk1_mixed(f, h, j));
    vstore_terms(STDV_OFF + DIM * s, (div_p - q_s) * (TAU_P * supg.dt / RHO0));
    if !(min(det_excess(f_st), j_st) > -1.0) {
        var a = nearest;
        if a >= N {
            a = ghost_src[a - N];
        }
        atomicMin(&status[2], a);
    }
}

// bytes:
// - gather: 1 scalar per item; 3 scalars per pair
// G_b per entry; the points' w_s, terms and ghost images, as a gather's neighbours: once
// per item.
// - shapes: 1 scalar per item; 1 vector per pair
// - terms: 1 vector + 1 tensor per item
// - ghost_img: 1 scalar + 1 vector per item
// V_a.
// - reference: 1 scalar per item
// D(p) += the points'.
// - force: 1 vector per item
// F (and H where evolved) for Ḣ and J̇.
// - y: 1 tensor per item
// - y: 1 tensor per item, when EVOLVE_H
// Ḟ; Ḣ and J̇ where evolved.
// - d: 1 tensor per item
// - d: 1 tensor per item, when EVOLVE_H
// - d: 1 scalar per item, when EVOLVE_J
@compute @workgroup_size(256)
fn supg_gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let a = index(gid, nwg);
    if a >= N {
        return;
    }
    var d_a: vecd;
    var l: matd;
    let end = gather[a + 1u];
    for (var k = gather[a]; k < end; k++) {
        let at = N + 1u + 3u * k;
        let s = gather[at];
        let q = gather[at + 1u];
        let b = gather[at + 2u];
        var dp = mload_terms(STDP_OFF + DIM * DIM * s);
        var dv = vload_terms(STDV_OFF + DIM * s);
        var g = vload_shapes(SSG_OFF + DIM * q);
        if b >= N {
            let m = b - N;
            dp = map_tensor(m, dp);
            dv = map_vector(m, dv);
            g = reflection(m) * g;
        }
        let w = shapes[SSW_OFF + s];
        d_a -= dp * g * w;
        l -= outer(dv, g) * w;
    }
    let inv_vol = 1.0 / vol_of(a);
    l = l * inv_vol;
    vstore_force(FD_OFF + DIM * a, vload_force(FD_OFF + DIM * a) + d_a * inv_vol);
    let at = F_OFF + DIM * DIM * a;
    mstore_d(at, mload_d(at) + l);
    let f = mload_y(at);
    if EVOLVE_H == 1u {
        let at_h = H_OFF + DIM * DIM * a;
        mstore_d(at_h, mload_d(at_h) + cof_rate(f, l));
    }
    if EVOLVE_J == 1u {
        d[J_OFF + a] += ddot_d(identity_d() + h_excess(a, f), l);
    }
}
