// The pseudo-time corrector of artificial compressibility (seed 003 eqs 52–58;
// compressibility.rs `Corrector`, which documents the choices) for one stage, after the
// predictor's rate evaluation. The iterate is the increment (w, δp) = (v − v^int, p − p^n)
// of the CPU's (v, p): the same equations,
//
//   ∂w/∂τ = −T[δp H^n]/ρ0 − w/Δt,
//   ∂δp/∂τ = γ (c + H^n : ∇0w − δp/(κΔt) + η ℒ[δp]),  c = H^n : ∇0v^int + η ℒ[p^n],
//
// whose varying terms are small, so that their f32 rounding stays far below the
// tolerance: an iterate v of |v| carries ε|v| of rounding into every pseudo step, which
// the slow modes of the iteration accumulate (the twisting column on 8 × 48 × 8 at ν = 0.5
// stalled at 2.4e-6 of the scale that way, against the default tolerance 1e-6; in this
// form it takes the CPU's pseudo steps). The corrector's stress δp H^n and the rate
// ṗ = δp/Δt keep their digits for the same reason.
//
//   start           per particle: v^int = v^n + Δt v̇ (the predictor's stage end, loads and
//                   supports included), the iterate w = 0, δp = Δt ṗ, and p^n, H^n of the
//                   stage state; per workgroup max(|v^int|², |v^n|²);
//   constraint      per particle: the constant part c of the pressure equation;
//   begin           one invocation: the velocity scale; opens the iteration;
//   residual        per particle: R = (∂w/∂τ, ∂δp/∂τ) of the iterate, and per workgroup
//                   the largest residual as a velocity, max(Δt |∂w/∂τ|, Δx |∂δp/∂τ|/γ);
//   check           one invocation: stops the iteration when that residual is within
//                   TOLERANCE of the scale, at MAX_ITERATIONS (failure: the particle and
//                   the residual are kept) or at the budget of pseudo steps recorded
//                   (the host runs the steps again with a larger one); else counts a
//                   pseudo step;
//   euler           y1 = y + Δτ R(y);
//   residual_stage  R(y1);
//   average         y ← ½(y + y1 + Δτ R(y1)): one TVD-RK2 step in τ;
//   correct         T_a += T_a[δp H^n] of the converged iterate (the rates pass then
//                   projects and applies it with the predictor's forces), ṗ = δp/Δt.
//
// The passes after `begin` run indirectly from `args`, which `check` sets to zero
// workgroups once the iteration stops: nothing is read back per step. Those that read the
// lists (constraint, residual, residual_stage, correct) run a part of the lists at a time
// (part.wgsl); parts start at workgroup boundaries, so the residual's per-workgroup
// partials are those of the unsplit lists. Ghost neighbours
// take their source's values through its image (mixed_images.wgsl). Layout and constants:
// mixed.wgsl, and the corrector's fields C*_OFF of methods::mixed::gpu::MixedLayout.

struct Tau {
    // Δt of the step, Δτ, γ, η = α Δt/ρ0 and 1/(κ Δt) (0 at ν = 0.5).
    dt: f32,
    dtau: f32,
    gamma: f32,
    eta: f32,
    relax: f32,
    // Pseudo steps recorded per stage.
    budget: u32,
}

@group(0) @binding(0) var<uniform> tau: Tau;
@group(0) @binding(1) var<storage, read> offsets: array<u32>;
@group(0) @binding(2) var<storage, read> ids: array<u32>;
// G_ab, G_ba and the Laplacian weights ℓ_ab of eq 58 at PBL_OFF.
@group(0) @binding(3) var<storage, read> pair: array<f32>;
// The stage state and its rates (after the predictor's rates pass).
@group(0) @binding(4) var<storage, read> y: array<f32>;
@group(0) @binding(5) var<storage, read_write> d: array<f32>;
@group(0) @binding(6) var<storage, read> kin: array<f32>;
// [w | δp | w1 | δp1 | R_w | R_δp | v^int | p^n | H^n | c] of the real particles.
@group(0) @binding(7) var<storage, read_write> corr: array<f32>;
@group(0) @binding(8) var<storage, read> ghost_src: array<u32>;
@group(0) @binding(9) var<storage, read> ghost_img: array<f32>;
@group(0) @binding(10) var<storage, read> reference: array<f32>;
// The words below, then per workgroup a maximum and its particle.
@group(0) @binding(11) var<storage, read_write> control: array<u32>;
// The workgroup counts (x, y, z) of the indirect passes: over every particle, then over
// each part of the lists; while the stage iterates, those of `groups`, else zero.
@group(0) @binding(12) var<storage, read_write> args: array<u32>;
@group(0) @binding(13) var<storage, read_write> force: array<f32>;
@group(0) @binding(14) var<storage, read> groups: array<u32>;

// Words of `control`: 1 while the stage iterates; its pseudo steps; the velocity scale
// (f32 bits); the step's pseudo steps and largest final residual over the scale (f32
// bits), cleared at each step; the pseudo steps since the host last read them; 1 when a
// stage reached the budget; the first particle that failed to converge at MAX_ITERATIONS
// (u32::MAX: none) and its residual (f32 bits); the most pseudo steps a stage took.
const RUN: u32 = 0u;
const ITERATIONS: u32 = 1u;
const SCALE: u32 = 2u;
const STEP_ITERATIONS: u32 = 3u;
const STEP_RESIDUAL: u32 = 4u;
const TOTAL: u32 = 5u;
const EXHAUSTED: u32 = 6u;
const FAILED: u32 = 7u;
const FAILED_RESIDUAL: u32 = 8u;
const MOST: u32 = 9u;
const PARTIALS: u32 = 10u;

var<workgroup> best: array<f32, 256>;
var<workgroup> who: array<u32, 256>;

// The largest `value` of the workgroup and its particle, into partial `group` unless the
// workgroup holds no particle (`keep` false: past a part's rows, where the next part's
// workgroups write).
fn workgroup_max(lid: u32, group: u32, keep: bool, value: f32, particle: u32) {
    best[lid] = value;
    who[lid] = particle;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if lid < stride && best[lid + stride] > best[lid] {
            best[lid] = best[lid + stride];
            who[lid] = who[lid + stride];
        }
        workgroupBarrier();
    }
    if lid == 0u && keep {
        control[PARTIALS + 2u * group] = bitcast<u32>(best[0]);
        control[PARTIALS + 2u * group + 1u] = who[0];
    }
}

// The largest partial and its particle; a partial that is not finite comes first.
fn largest_partial() -> vec2<u32> {
    var r = 0.0;
    var worst = 0u;
    for (var g = 0u; g < GROUPS; g++) {
        let s = bitcast<f32>(control[PARTIALS + 2u * g]);
        if !(s <= 3.4e38) {
            return vec2<u32>(bitcast<u32>(s), control[PARTIALS + 2u * g + 1u]);
        }
        if s > r {
            r = s;
            worst = control[PARTIALS + 2u * g + 1u];
        }
    }
    return vec2<u32>(bitcast<u32>(r), worst);
}

// bytes:
// v and p^n; F or H.
// - y: 1 scalar + 1 vector + 1 tensor per item
// - kin: 1 tensor per item, when BOND
// - d: 1 scalar + 1 vector per item
// v^int, w, δp, p^n, H^n; per workgroup a maximum (not counted).
// - corr: 2 scalars + 2 vectors + 1 tensor per item
// - control: nothing
@compute @workgroup_size(256)
fn start(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let a = index(gid, nwg);
    var speed2 = 0.0;
    if a < N {
        let v_n = vload_y(V_OFF + DIM * a);
        let v_int = v_n + vload_d(V_OFF + DIM * a) * tau.dt;
        vstore_corr(CVI_OFF + DIM * a, v_int);
        vstore_corr(CV_OFF + DIM * a, vecd(0.0));
        corr[CQ_OFF + a] = tau.dt * d[PRES_OFF + a];
        corr[CPN_OFF + a] = y[PRES_OFF + a];
        mstore_corr(CHN_OFF + DIM * DIM * a, identity_d() + h_excess(a, stress_excess(a)));
        speed2 = max(dot(v_int, v_int), dot(v_n, v_n));
    }
    workgroup_max(lid, group_index(wid, nwg), true, speed2, a);
}

// bytes:
// One item: the partials in (not counted), the scale and the workgroup counts out (those
// of the parts not counted).
// - control stores: 3 scalars per item
// - groups: 3 scalars per item
// - args: 3 scalars per item
@compute @workgroup_size(1)
fn begin() {
    control[SCALE] = bitcast<u32>(sqrt(bitcast<f32>(largest_partial().x)));
    control[ITERATIONS] = 0u;
    control[RUN] = 1u;
    let words = arrayLength(&args);
    for (var k = 0u; k < words; k++) {
        args[k] = groups[k];
    }
}

// A vector, a tensor and a scalar of extended particle b: its own, or for a ghost its
// source's images.
struct Extended {
    v: vecd,
    t: matd,
    s: f32,
}

// The source of extended particle b.
fn source_of(b: u32) -> u32 {
    if b >= N {
        return ghost_src[b - N];
    }
    return b;
}

fn image(b: u32, e: Extended) -> Extended {
    if b >= N {
        let k = b - N;
        return Extended(map_vector(k, e.v), map_tensor(k, e.t), map_scalar(k, e.s));
    }
    return e;
}

// w, δp H^n and δp of extended particle b in the iterate at v_at, q_at of corr.
fn extended(b: u32, v_at: u32, q_at: u32) -> Extended {
    let s = source_of(b);
    let q = corr[q_at + s];
    return image(b, Extended(vload_corr(v_at + DIM * s), mload_corr(CHN_OFF + DIM * DIM * s) * q, q));
}

// v^int and p^n of extended particle b.
fn stage_end(b: u32) -> Extended {
    let s = source_of(b);
    return image(b, Extended(vload_corr(CVI_OFF + DIM * s), matd(), corr[CPN_OFF + s]));
}

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// - pair: 1 vector per pair
// - pair: 1 scalar per pair, when PSEUDO_VISCOSITY
// The particle's and its neighbours' v^int and p^n, its H^n.
// - corr loads: 1 scalar + 1 vector + 1 tensor per item; 1 scalar + 1 vector per pair
// - ghost_src: nothing
// - ghost_img: nothing
// - corr stores: 1 scalar per item
@compute @workgroup_size(256)
fn constraint(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    let e_a = stage_end(a);
    let h_a = mload_corr(CHN_OFF + DIM * DIM * a);
    var div = 0.0;
    var lap = 0.0;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let e_b = stage_end(ids[p]);
        div += dot(e_b.v - e_a.v, h_a * vload_pair(PG_OFF + DIM * p));
        if PSEUDO_VISCOSITY == 1u {
            lap += pair[PBL_OFF + p] * (e_b.s - e_a.s);
        }
    }
    corr[CC_OFF + a] = div + tau.eta * lap;
}

// T_a[δp H^n] of the iterate at v_at, q_at (eq 21 or seed 002 eq 22, as the forces pass).
fn corrector_force(a: u32, v_at: u32, q_at: u32) -> vecd {
    let dp_a = extended(a, v_at, q_at).t;
    var t: vecd;
    let row = a - part.first;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let e_b = extended(ids[p], v_at, q_at);
        t += pair_force(dp_a, e_b.t, vload_pair(PG_OFF + DIM * p), vload_pair(PGR_OFF + DIM * p));
    }
    return t;
}

// The pseudo-time rates of real particle a at the iterate v_at, q_at into R_w, R_δp
// (eqs 52, 53–54, 58 with the divergence of eq 21). Returns the residual as a velocity,
// max(Δt |∂w/∂τ|, Δx |∂δp/∂τ|/γ).
// bytes block pseudo_rates:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// - pair: 2 vectors per pair
// - pair: 1 scalar per pair, when PSEUDO_VISCOSITY
// The particle's iterate, c and H^n; the neighbours' iterate and H^n (w, δp and H^n of a
// neighbour; the ghost maps of ghost neighbours not counted).
// - corr loads: 2 scalars + 1 vector + 1 tensor per item; 1 scalar + 1 vector + 1 tensor per pair
// - ghost_src: nothing
// - ghost_img: nothing
// - reference: 1 scalar per item
// - corr stores: 1 scalar + 1 vector per item
fn pseudo_rates(a: u32, v_at: u32, q_at: u32) -> f32 {
    let e_a = extended(a, v_at, q_at);
    let h_a = mload_corr(CHN_OFF + DIM * DIM * a);
    var t: vecd;
    var div = 0.0;
    var lap = 0.0;
    let row = a - part.first;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let e_b = extended(ids[p], v_at, q_at);
        let g_ab = vload_pair(PG_OFF + DIM * p);
        let g_ba = vload_pair(PGR_OFF + DIM * p);
        t += pair_force(e_a.t, e_b.t, g_ab, g_ba);
        // H_a : (w_b − w_a) ⊗ V_b g_ab.
        div += dot(e_b.v - e_a.v, h_a * g_ab);
        if PSEUDO_VISCOSITY == 1u {
            lap += pair[PBL_OFF + p] * (e_b.s - e_a.s);
        }
    }
    var r_v = t * (-1.0 / RHO0) - e_a.v * (1.0 / tau.dt);
    let held = mask_of(a);
    for (var k = 0u; k < DIM; k++) {
        if ((held >> k) & 1u) != 0u {
            r_v[k] = 0.0;
        }
    }
    let q = corr[q_at + a];
    let r_q = tau.gamma * (corr[CC_OFF + a] + div - q * tau.relax + tau.eta * lap);
    vstore_corr(CRV_OFF + DIM * a, r_v);
    corr[CRQ_OFF + a] = r_q;
    return max(length(r_v) * tau.dt, abs(r_q) * SPACING / tau.gamma);
}

// bytes:
// Per workgroup a maximum (not counted).
// - include pseudo_rates
// - control: nothing
@compute @workgroup_size(256)
fn residual(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let row = index(gid, nwg);
    let a = part.first + row;
    var size = 0.0;
    if row < part.rows {
        size = pseudo_rates(a, CV_OFF, CQ_OFF);
    }
    // Parts start at workgroup boundaries (src/gpu/parts.rs): the unsplit run's partials.
    let group = group_index(wid, nwg);
    workgroup_max(lid, part.first / 256u + group, group * 256u < part.rows, size, a);
}

// bytes:
// - include pseudo_rates
@compute @workgroup_size(256)
fn residual_stage(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row < part.rows {
        pseudo_rates(part.first + row, CV1_OFF, CQ1_OFF);
    }
}

// Ends the stage's iteration: no more workgroups for the indirect passes.
fn stop() {
    control[RUN] = 0u;
    let words = arrayLength(&args);
    for (var k = 0u; k < words; k++) {
        args[k] = 0u;
    }
}

// bytes:
// One item: the partials in (not counted), the decision out.
// - control: 8 scalars per item
// - args: 3 scalars per item
@compute @workgroup_size(1)
fn check() {
    if control[RUN] == 0u {
        return;
    }
    let largest = largest_partial();
    let r = bitcast<f32>(largest.x);
    let scale = bitcast<f32>(control[SCALE]);
    let relative = select(r, r / scale, scale > 0.0);
    let iterations = control[ITERATIONS];
    if r <= TOLERANCE * scale {
        stop();
        control[STEP_ITERATIONS] += iterations;
        control[TOTAL] += iterations;
        control[STEP_RESIDUAL] = bitcast<u32>(max(bitcast<f32>(control[STEP_RESIDUAL]), relative));
        control[MOST] = max(control[MOST], iterations);
        return;
    }
    if iterations == MAX_ITERATIONS || !(r <= 3.4e38) {
        stop();
        if control[FAILED] == 0xffffffffu {
            control[FAILED] = largest.y;
            control[FAILED_RESIDUAL] = bitcast<u32>(relative);
        }
        return;
    }
    if iterations == tau.budget {
        stop();
        control[EXHAUSTED] = 1u;
        return;
    }
    control[ITERATIONS] = iterations + 1u;
}

// bytes:
// - corr loads: 2 scalars + 2 vectors per item
// - corr stores: 1 scalar + 1 vector per item
@compute @workgroup_size(256)
fn euler(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let a = index(gid, nwg);
    if a >= N {
        return;
    }
    let h = tau.dtau;
    vstore_corr(CV1_OFF + DIM * a, vload_corr(CV_OFF + DIM * a) + vload_corr(CRV_OFF + DIM * a) * h);
    corr[CQ1_OFF + a] = corr[CQ_OFF + a] + corr[CRQ_OFF + a] * h;
}

// bytes:
// - corr loads: 3 scalars + 3 vectors per item
// - corr stores: 1 scalar + 1 vector per item
@compute @workgroup_size(256)
fn average(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let a = index(gid, nwg);
    if a >= N {
        return;
    }
    let h = tau.dtau;
    let v = vload_corr(CV_OFF + DIM * a) + vload_corr(CV1_OFF + DIM * a) + vload_corr(CRV_OFF + DIM * a) * h;
    vstore_corr(CV_OFF + DIM * a, v * 0.5);
    corr[CQ_OFF + a] = 0.5 * (corr[CQ_OFF + a] + corr[CQ1_OFF + a] + corr[CRQ_OFF + a] * h);
}

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// - pair: 2 vectors per pair
// - corr: 1 scalar + 1 tensor per item; 2 scalars + 1 tensor per pair
// - ghost_src: nothing
// - ghost_img: nothing
// - force: 1 vector per item
// - d: 1 scalar per item
@compute @workgroup_size(256)
fn correct(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    let t = vload_force(FT_OFF + DIM * a) + corrector_force(a, CV_OFF, CQ_OFF);
    vstore_force(FT_OFF + DIM * a, t);
    d[PRES_OFF + a] = corr[CQ_OFF + a] / tau.dt;
}
