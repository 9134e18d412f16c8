// Last passes of a mixed rate evaluation: the angular-momentum projection (seed 003
// Appendix B; mixed.rs `Balance`) and the rates of v and u with the boundary conditions.
//
// The projection balances f_a = D(p_a) − T_a (per unit volume; projecting T and D(p) apart
// and subtracting gives the same, the projection being linear in the field) about the
// points 𝒳_a: f̂_a = f_a + λ × (𝒳_a − c) + μ with the V-weighted centroid c,
// μ = −Σ V f / Σ V and I_c λ = −Σ V (𝒳 − c) × f, I_c = Σ V (|r|² I − r ⊗ r) (eqs B.2–B.5).
//   balance_sums   per particle, a tree reduction per workgroup of Σ V r, Σ V r ⊗ r,
//                  Σ V f and Σ V r × f about the reference centroid X̄ (r = 𝒳 − X̄: small
//                  sums, so that moving them to c loses few digits);
//   balance_solve  one invocation: sums the GROUPS partials (compensated), solves for λ,
//                  μ and c − X̄, written at FPROJ_OFF of force;
//   rates          per particle: ρ0 v̇ = f̂ (eq 38a), boundary conditions (boundary.wgsl),
//                  u̇ = v, and J̇ += D(J).
// Layout and constants: mixed.wgsl.

struct Stage {
    // Δt/2, read when mid = 1.
    half_dt: f32,
    // 1 at the second TVD-RK2 stage: the points are x^n + Δt/2 (v^n + v*).
    mid: u32,
}

@group(0) @binding(0) var<uniform> stage: Stage;
// [T | D(p) | D(J) | projection]: the projection λ, μ, c − X̄ as vec3 padded to four
// floats each at FPROJ_OFF, written by balance_solve.
@group(0) @binding(1) var<storage, read_write> force: array<f32>;
@group(0) @binding(2) var<storage, read> y: array<f32>;
// The state at the start of the step (the TVD-RK2 points).
@group(0) @binding(3) var<storage, read> y0: array<f32>;
@group(0) @binding(4) var<storage, read> reference: array<f32>;
@group(0) @binding(5) var<storage, read_write> partials: array<f32>;
@group(0) @binding(6) var<storage, read> ext: array<f32>;
@group(0) @binding(7) var<storage, read_write> d: array<f32>;
// The kinematics; the rates write only the power (boundary.wgsl).
@group(0) @binding(8) var<storage, read_write> kin: array<f32>;

// vec4 sums per workgroup: (Σ V r, Σ V r_x²), (Σ V r_y², Σ V r_z², Σ V r_x r_y, Σ V r_x r_z),
// (Σ V r_y r_z, Σ V f), (Σ V r × f, 0).
const BALANCED: u32 = 4u;

var<workgroup> tile: array<array<vec4<f32>, BALANCED>, 256>;

// 𝒳_a − X̄ (eq B.1): the stage position, or x^n + Δt/2 (v^n + v*) at the second TVD-RK2
// stage, which makes the step conserve angular momentum.
fn balance_point(a: u32) -> vecd {
    let x = vload_reference(RXREL_OFF + DIM * a);
    if stage.mid == 1u {
        let v_sum = vload_y0(V_OFF + DIM * a) + vload_y(V_OFF + DIM * a);
        return x + vload_y0(U_OFF + DIM * a) + v_sum * stage.half_dt;
    }
    return x + vload_y(U_OFF + DIM * a);
}

fn net_force(a: u32) -> vecd {
    return vload_force(FD_OFF + DIM * a) - vload_force(FT_OFF + DIM * a);
}

// bytes:
// Per workgroup, 16 partial sums (not counted).
// - reference: 1 scalar + 1 vector per item
// - y: 2 vectors per item
// - y0: 2 vectors per item
// - force: 2 vectors per item
// - partials: nothing
@compute @workgroup_size(256)
fn balance_sums(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let a = index(gid, nwg);
    var q: array<vec4<f32>, BALANCED>;
    if a < N {
        let w = vol_of(a);
        let r = pad3(balance_point(a));
        let f = pad3(net_force(a)) * w;
        let rw = r * w;
        q[0] = vec4<f32>(rw, rw.x * r.x);
        q[1] = vec4<f32>(rw.y * r.y, rw.z * r.z, rw.x * r.y, rw.x * r.z);
        q[2] = vec4<f32>(rw.y * r.z, f);
        q[3] = vec4<f32>(cross(r, f), 0.0);
    }
    tile[lid] = q;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if lid < stride {
            for (var k = 0u; k < BALANCED; k++) {
                tile[lid][k] += tile[lid + stride][k];
            }
        }
        workgroupBarrier();
    }
    if lid == 0u {
        let group = group_index(wid, nwg);
        for (var k = 0u; k < BALANCED; k++) {
            for (var c = 0u; c < 4u; c++) {
                partials[4u * (group * BALANCED + k) + c] = tile[0][k][c];
            }
        }
    }
}

// bytes:
// One item: the partial sums of every workgroup in (not counted), the rotation,
// translation and centre of the projection out.
// - partials: nothing
// - force: 9 scalars per item
@compute @workgroup_size(1)
fn balance_solve() {
    // Kahan summation of the per-workgroup partials.
    var s: array<vec4<f32>, BALANCED>;
    var carry: array<vec4<f32>, BALANCED>;
    for (var g = 0u; g < GROUPS; g++) {
        for (var k = 0u; k < BALANCED; k++) {
            let at = 4u * (g * BALANCED + k);
            let x = vec4<f32>(partials[at], partials[at + 1u], partials[at + 2u], partials[at + 3u]);
            let term = x - carry[k];
            let next = s[k] + term;
            carry[k] = (next - s[k]) - term;
            s[k] = next;
        }
    }
    let c = s[0].xyz / TOTAL_VOL;
    // Σ V r ⊗ r about c.
    let rr = mat3x3<f32>(
        s[0].w, s[1].z, s[1].w,
        s[1].z, s[1].x, s[2].x,
        s[1].w, s[2].x, s[1].y,
    ) - outer3(c, c) * TOTAL_VOL;
    let inertia = mat3x3<f32>(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0) * (rr[0][0] + rr[1][1] + rr[2][2]) - rr;
    let net = s[2].yzw;
    let moment = s[3].xyz - cross(c, net);
    store_projection(0u, -solve_inertia(inertia, moment));
    store_projection(1u, -net / TOTAL_VOL);
    store_projection(2u, c);
}

// λ (k = 0), μ (1) or c − X̄ (2) of the projection.
fn store_projection(k: u32, x: vec3<f32>) {
    for (var c = 0u; c < 3u; c++) {
        force[FPROJ_OFF + 4u * k + c] = x[c];
    }
}

fn projection(k: u32) -> vec3<f32> {
    let o = FPROJ_OFF + 4u * k;
    return vec3<f32>(force[o], force[o + 1u], force[o + 2u]);
}

fn outer3(a: vec3<f32>, b: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(a * b.x, a * b.y, a * b.z);
}

// bytes:
// T, D(p); D(J) with H kept.
// - force: 2 vectors per item
// - force: 1 scalar per item, when KIN_H
// - y: 1 vector per item
// - y: 1 vector per item, when PROJECTION
// - y0: 2 vectors per item, when PROJECTION
// - reference: 2 scalars per item
// - reference: 1 vector per item, when PROJECTION
// - ext: 1 vector per item
// - kin: 1 scalar per item
// - d stores: 2 vectors per item
// - d: 1 scalar per item, when KIN_H
@compute @workgroup_size(256)
fn rates(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let a = index(gid, nwg);
    if a >= N {
        return;
    }
    var f = net_force(a);
    if PROJECTION == 1u {
        let r = pad3(balance_point(a)) - projection(2u);
        f += unpad(cross(projection(0u), r) + projection(1u));
    }
    let v_a = vload_y(V_OFF + DIM * a);
    vstore_d(V_OFF + DIM * a, apply_boundary(a, f * (1.0 / RHO0), v_a, RHO0 * vol_of(a)));
    vstore_d(U_OFF + DIM * a, v_a);
    if KIN_H == 1u {
        d[J_OFF + a] += force[FJ_OFF + a];
    }
}
