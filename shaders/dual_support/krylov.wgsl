// The matrix-free Newton step of dual-support SPH on the device (seed 004 §2;
// methods::dual_support::krylov): Jacobi-preconditioned conjugate gradients on K Δu = R,
// with the product K p formed from the force pass's gather (no assembled K), and every
// scalar of the iteration (ρ = r·z, α, β, |r|²) computed and kept on the device, so that
// the host reads back only a few words per batch of iterations.
//
// The product. With δH_i = Σ_{j∈S_i} (p_j − p_i) ⊗ g_ij the change of F_i along p
// (eq 12) and δP_i = 𝔸_i : δH_i (𝔸_i = ∂P/∂F at the Newton state, from the host),
// K p = −δf, where δf is the internal force of eq 18 with P → δP and the hourglass force
// of eq 28 with (u, H) → (p, δH); both are linear in (P, u, H), so this is the tangent of
// eqs 39–41 and 29 applied to p. Pair form on the union lists S_a ∪ S'_a (as
// potential.wgsl): δf_a = Σ_j [V_a δP_a g_aj − V_j δP_j g_ja]
//   + Σ_j [(k_aj + k_ja)(p_j − p_a) − (k_aj δH_a + k_ja δH_j) X_aj],
// with g_aj = 0 for j ∉ S_a and k_aj = 2 V_a c_a w_aj.
//
// Buffers: the lists and per-pair data of the part of the rows a dispatch of `strain` or
// `product` runs on (part.wgsl): lists = the part's union CSR lists, part.rows + 1
// offsets counted from its first pair, then the ids; per pair k of the part, g = g_ij,
// grev = g_ji (DIM each) and hg = [X_j − X_i | k_ij | k_ji] (DIM + 2), apart so that no
// pair buffer outgrows a binding before the others; tangent = V_i 𝔸_i per
// particle, DIM⁴ words, [(k·DIM + J)·DIM² + l·DIM + L] = V_i ∂P_kJ/∂F_lL; inv_diag = 1/K_kk
// per degree of freedom, 0 where it is prescribed (z, p, x and r stay 0 there, so the
// prescribed rows of K p never enter); the CG vectors x, r, p, q = K p (DIM per particle);
// lin = [δH | V δP] per particle (DIM² each, V δP at LP_OFF); partials = two sums per
// workgroup; scalars = [ρ, α, β, |r|², stop threshold, state, iterations, p·Kp] with
// state 0 running, 1 converged, 2 p·Kp ≤ 0 (not positive definite).
// Constants: N, NDOF = N·DIM, LP_OFF, HOURGLASS, GROUPS_N = ⌈N/256⌉ (the workgroups of
// particles, whose partials `product` writes a part at a time) and GROUPS_DOF (the
// workgroups of the degree-of-freedom passes).

@group(0) @binding(0) var<storage, read> lists: array<u32>;
@group(0) @binding(1) var<storage, read> g: array<f32>;
@group(0) @binding(2) var<storage, read> grev: array<f32>;
@group(0) @binding(3) var<storage, read> hg: array<f32>;
@group(0) @binding(4) var<storage, read> tangent: array<f32>;
@group(0) @binding(5) var<storage, read> inv_diag: array<f32>;
@group(0) @binding(6) var<storage, read_write> x: array<f32>;
@group(0) @binding(7) var<storage, read_write> r: array<f32>;
@group(0) @binding(8) var<storage, read_write> p: array<f32>;
@group(0) @binding(9) var<storage, read_write> q: array<f32>;
@group(0) @binding(10) var<storage, read_write> lin: array<f32>;
@group(0) @binding(11) var<storage, read_write> partials: array<f32>;
@group(0) @binding(12) var<storage, read_write> scalars: array<f32>;

const RHO: u32 = 0u;
const ALPHA: u32 = 1u;
const BETA: u32 = 2u;
const RR: u32 = 3u;
const THRESHOLD: u32 = 4u;
const STATE: u32 = 5u;
const ITERATIONS: u32 = 6u;
const PQ: u32 = 7u;
const RUNNING: f32 = 0.0;
const CONVERGED: f32 = 1.0;
const INDEFINITE: f32 = 2.0;

var<workgroup> sum_a: array<f32, 256>;
var<workgroup> sum_b: array<f32, 256>;

// Sums a and b over the workgroup (a tree in workgroup memory); the totals in sum_a[0]
// and sum_b[0]. Called in uniform control flow.
fn workgroup_sums(lid: u32, a: f32, b: f32) {
    sum_a[lid] = a;
    sum_b[lid] = b;
    workgroupBarrier();
    for (var half = 128u; half > 0u; half = half >> 1u) {
        if lid < half {
            sum_a[lid] += sum_a[lid + half];
            sum_b[lid] += sum_b[lid + half];
        }
        workgroupBarrier();
    }
}

// The workgroup's sums of a and b into its partials (workgroup w of the dispatch).
// Called in uniform control flow.
fn store_sums(lid: u32, wid: vec3<u32>, nwg: vec3<u32>, a: f32, b: f32) {
    workgroup_sums(lid, a, b);
    if lid == 0u {
        let w = group_index(wid, nwg);
        partials[2u * w] = sum_a[0];
        partials[2u * w + 1u] = sum_b[0];
    }
}

// The workgroup's sum of a into the partial of its workgroup of particles: the part's
// first workgroup (parts start at a workgroup) plus its own; none for a workgroup past
// the part's rows (a 2D dispatch's last row). Called in uniform control flow.
fn store_particle_sums(lid: u32, wid: vec3<u32>, nwg: vec3<u32>, a: f32) {
    workgroup_sums(lid, a, 0.0);
    let w = group_index(wid, nwg);
    if lid == 0u && w * 256u < part.rows {
        let slot = part.first / 256u + w;
        partials[2u * slot] = sum_a[0];
        partials[2u * slot + 1u] = 0.0;
    }
}

// One workgroup: the sums of the partials of `groups` workgroups (a: even words, b: odd).
fn total_partials(lid: u32, groups: u32) {
    var a = 0.0;
    var b = 0.0;
    for (var k = lid; k < groups; k += 256u) {
        a += partials[2u * k];
        b += partials[2u * k + 1u];
    }
    workgroup_sums(lid, a, b);
}

// Per particle: δH_i and V_i δP_i = V_i 𝔸_i : δH_i along the direction p.
// bytes:
// - lists: 1 scalar per item; 1 scalar per pair
// - g: 1 vector per pair
// - tangent: 1 modulus per item
// - p: 1 vector per item
// - lin: 2 tensors per item
@compute @workgroup_size(256)
fn strain(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let ids = part.rows + 1u;
    let p_i = vload_p(DIM * i);
    var dh: matd;
    let p_end = lists[row + 1u];
    for (var k = lists[row]; k < p_end; k++) {
        dh += outer(vload_p(DIM * lists[ids + k]) - p_i, vload_g(DIM * k));
    }
    // (V δP)_kJ = Σ_lL V 𝔸[kJ][lL] δH_lL; matd is column-major, m[col][row].
    var dp: matd;
    let base = DIM * DIM * DIM * DIM * i;
    for (var row = 0u; row < DIM; row++) {
        for (var col = 0u; col < DIM; col++) {
            var s = 0.0;
            let a = base + (row * DIM + col) * DIM * DIM;
            for (var l = 0u; l < DIM; l++) {
                for (var m = 0u; m < DIM; m++) {
                    s += tangent[a + l * DIM + m] * dh[m][l];
                }
            }
            dp[col][row] = s;
        }
    }
    mstore_lin(DIM * DIM * i, dh);
    mstore_lin(LP_OFF + DIM * DIM * i, dp);
}

// Per particle: q_a = (K p)_a, and the workgroup's sum of p·q (p is 0 on the prescribed
// components, so only the free rows enter).
// bytes:
// - lists: 1 scalar per item; 1 scalar per pair
// - g: 1 vector per pair
// - grev: 1 vector per pair
// k_ij, k_ji and X_j − X_i with the hourglass term.
// - hg: 2 scalars + 1 vector per pair, when HOURGLASS
// - lin: 2 tensors per item
// - p: 1 vector per item
// - q: 1 vector per item
// - partials: nothing
@compute @workgroup_size(256)
fn product(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let row = index(gid, nwg);
    var pq = 0.0;
    if row < part.rows {
        let a = part.first + row;
        let ids = part.rows + 1u;
        let vdp_a = mload_lin(LP_OFF + DIM * DIM * a);
        let dh_a = mload_lin(DIM * DIM * a);
        let p_a = vload_p(DIM * a);
        var df: vecd;
        let p_end = lists[row + 1u];
        for (var k = lists[row]; k < p_end; k++) {
            let j = lists[ids + k];
            df += vdp_a * vload_g(DIM * k) - mload_lin(LP_OFF + DIM * DIM * j) * vload_grev(DIM * k);
            if HOURGLASS == 1u {
                let k_aj = hg[(DIM + 2u) * k + DIM];
                let k_ja = hg[(DIM + 2u) * k + DIM + 1u];
                df += (vload_p(DIM * j) - p_a) * (k_aj + k_ja)
                    - (dh_a * k_aj + mload_lin(DIM * DIM * j) * k_ja) * vload_hg((DIM + 2u) * k);
            }
        }
        let kp = -df;
        vstore_q(DIM * a, kp);
        pq = dot(p_a, kp);
    }
    store_particle_sums(lid, wid, nwg, pq);
}

// Per degree of freedom, from x = 0 and r = b (the host's): p = z = r/diag; partials of
// r·z and r·r.
// bytes:
// - inv_diag: 1 scalar per item
// - r: 1 scalar per item
// - p: 1 scalar per item
// - x: 1 scalar per item
// - partials: nothing
@compute @workgroup_size(256)
fn start(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let k = index(gid, nwg);
    var rz = 0.0;
    var rr = 0.0;
    if k < NDOF {
        let z = inv_diag[k] * r[k];
        p[k] = z;
        x[k] = 0.0;
        rz = r[k] * z;
        rr = r[k] * r[k];
    }
    store_sums(lid, wid, nwg, rz, rr);
}

// One workgroup: ρ = r·z and |r|² of the start; the stop threshold (tolerance², from the
// host) times |b|².
// bytes:
// - partials: 2 scalars per item
// - scalars: nothing
@compute @workgroup_size(256)
fn begin(@builtin(local_invocation_index) lid: u32) {
    total_partials(lid, GROUPS_DOF);
    if lid == 0u {
        scalars[RHO] = sum_a[0];
        scalars[RR] = sum_b[0];
        scalars[THRESHOLD] *= sum_b[0];
        scalars[STATE] = select(RUNNING, CONVERGED, sum_b[0] == 0.0);
        scalars[ITERATIONS] = 0.0;
    }
}

// One workgroup: α = ρ/(p·Kp), or 0 once stopped; p·Kp ≤ 0 stops as not positive
// definite.
// bytes:
// - partials: 2 scalars per item
// - scalars: nothing
@compute @workgroup_size(256)
fn alpha(@builtin(local_invocation_index) lid: u32) {
    total_partials(lid, GROUPS_N);
    if lid == 0u {
        let pq = sum_a[0];
        scalars[PQ] = pq;
        var a = 0.0;
        if scalars[STATE] == RUNNING {
            if pq > 0.0 {
                a = scalars[RHO] / pq;
            } else {
                scalars[STATE] = INDEFINITE;
            }
        }
        scalars[ALPHA] = a;
    }
}

// Per degree of freedom: x += α p, r −= α q on the free components; partials of r·z and
// r·r with z = r/diag.
// bytes:
// - scalars: nothing
// - x: 1 scalar per item
// - r: 1 scalar per item
// - p: 1 scalar per item
// - q: 1 scalar per item
// - inv_diag: 1 scalar per item
// - partials: nothing
@compute @workgroup_size(256)
fn update(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let k = index(gid, nwg);
    var rz = 0.0;
    var rr = 0.0;
    if k < NDOF {
        let a = scalars[ALPHA];
        x[k] += a * p[k];
        let r_k = select(0.0, r[k] - a * q[k], inv_diag[k] != 0.0);
        r[k] = r_k;
        rz = r_k * inv_diag[k] * r_k;
        rr = r_k * r_k;
    }
    store_sums(lid, wid, nwg, rz, rr);
}

// One workgroup: the iteration's |r|², its stop test, and β = ρ_new/ρ.
// bytes:
// - partials: 2 scalars per item
// - scalars: nothing
@compute @workgroup_size(256)
fn beta(@builtin(local_invocation_index) lid: u32) {
    total_partials(lid, GROUPS_DOF);
    if lid == 0u {
        var b = 0.0;
        if scalars[STATE] == RUNNING {
            scalars[ITERATIONS] += 1.0;
            scalars[RR] = sum_b[0];
            if sum_b[0] <= scalars[THRESHOLD] {
                scalars[STATE] = CONVERGED;
            } else {
                b = sum_a[0] / scalars[RHO];
                scalars[RHO] = sum_a[0];
            }
        }
        scalars[BETA] = b;
    }
}

// Per degree of freedom: p = z + β p.
// bytes:
// - scalars: nothing
// - inv_diag: 1 scalar per item
// - r: 1 scalar per item
// - p: 1 scalar per item
@compute @workgroup_size(256)
fn direction(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k < NDOF {
        p[k] = inv_diag[k] * r[k] + scalars[BETA] * p[k];
    }
}
