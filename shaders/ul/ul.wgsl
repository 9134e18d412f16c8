// The updated-Lagrangian core on the device (src/methods/cores/ul/gpu.rs), shared by the
// Gray–Monaghan and Godunov passes as methods::cores::ul is on the CPU: the bindings, the
// positions pass, the Randles–Libersky correction of L on the current positions, and the
// closing of a particle's rates.
//
// Flat f32 buffers: the state y = [u | v | ρ − ρ0 | S | H = F − I | ε_p] (ε_p with a yield
// stress; ρ as its deviation and F as H, as in tlsph.wgsl, to keep their digits in f32);
// x = X + u of the last positions
// pass (DIM per particle), which the cell list reads; the scheme's per-particle quantities
// kin = [T | R | AIT | RK | H | VOL | C | P | POW] (T: σ/ρ² for Gray–Monaghan, σ for Godunov; R:
// artificial stress; AIT: A⁻ᵀ of the linear correction; RK: C and ∂_k C of RKPM; H: an
// adaptive smoothing length; VOL: m/ρ; C: sound speed or impedance;
// P: pressure; POW: power of supports and loads); the CSR lists offsets/ids of the cell
// list, rebuilt from x before every rate evaluation. The `particle` and `rates` passes run
// a part of the rows at a time (part.wgsl), each part with its own ids, counted from its
// first pair; `offsets` counts over every particle. Scene constants: N, DIM, RHO0, MU,
// BULK, CORRECTION, ADAPTIVE_H and H_CAP, the kernel's, and the field offsets of
// methods::cores::ul::gpu::Layout.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> reference: array<f32>;
@group(0) @binding(3) var<storage, read> y: array<f32>;
@group(0) @binding(4) var<storage, read_write> x: array<f32>;
@group(0) @binding(5) var<storage, read_write> kin: array<f32>;
// External acceleration from tractions and interactions (DIM per particle).
@group(0) @binding(6) var<storage, read> ext: array<f32>;
@group(0) @binding(7) var<storage, read_write> d: array<f32>;
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;

// x = X + u, for the cell list and the pair sums.
// bytes:
// - reference: 1 vector per item
// - y: 1 vector per item
// - x: 1 vector per item
@compute @workgroup_size(256)
fn positions(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = index(gid, nwg);
    if i >= N {
        return;
    }
    vstore_x(DIM * i, x0_of(i) + vload_y(U_OFF + DIM * i));
}

// The pairs of particle i in the bound part's ids: the offsets less the part's first,
// exact within a part however far the offsets over every particle wrap past 2³².
fn pairs_of(i: u32) -> vec2<u32> {
    let base = offsets[part.first];
    return vec2<u32>(offsets[i] - base, offsets[i + 1u] - base);
}

fn x_of(i: u32) -> vecd {
    return vload_x(DIM * i);
}

fn v_of(i: u32) -> vecd {
    return vload_y(V_OFF + DIM * i);
}

fn rho_of(i: u32) -> f32 {
    return RHO0 + y[RHO_OFF + i];
}

fn mass_of(i: u32) -> f32 {
    return RHO0 * vol_of(i);
}

// The smoothing length h_i: KERNEL_H, or the adaptive one of the `smoothing` pass.
fn h_of(i: u32) -> f32 {
    if ADAPTIVE_H == ADAPTIVE_H_FIXED {
        return KERNEL_H;
    }
    return kin[KH_OFF + i];
}

// The smoothing length of the pair (i, j), h_ij = ½(h_i + h_j) (KERNEL_H when fixed).
fn h_pair(i: u32, j: u32) -> f32 {
    return 0.5 * (h_of(i) + h_of(j));
}

// eq 63, the prime space (methods::cores::ul `UlCore::prime_space_lists`, core::neighbourhood
// `prime_space`), 2D: particle i's candidates are its pairs within PS_R2 (the kernel's
// support at the cap, squared), whose images x_ij/|x_ij|² the `smoothing` pass wraps in a
// convex hull. Its PS block in kin is [edges, tolerance, (n_x, n_y, c) per edge], n the
// inward unit normal of an edge and c = n·a at a point a on it, so that an image p lies
// depth(p) = min_e (n_e·p − c_e) inside; no edges (fewer than three candidates, or all on
// a line) take every candidate.

const PI: f32 = 3.14159265;

// The image x_ij/|x_ij|² of an offset, in the plane.
fn ps_image(x_ij: vecd) -> vec2<f32> {
    let r2 = dot(x_ij, x_ij);
    return vec2<f32>(x_ij[0], x_ij[1]) / r2;
}

// How far image p lies inside particle i's hull (−3.4e38 without edges).
fn ps_depth(i: u32, p: vec2<f32>) -> f32 {
    let base = KPS_OFF + PS_WIDTH * i;
    let edges = u32(kin[base]);
    if edges == 0u {
        return -3.4e38;
    }
    var depth = 3.4e38;
    for (var e = 0u; e < edges; e++) {
        let at = base + 2u + 3u * e;
        depth = min(depth, kin[at] * p.x + kin[at + 1u] * p.y - kin[at + 2u]);
    }
    return depth;
}

// Whether particle i takes the candidate at offset x_ij (within reach): its image within
// the tolerance of the hull's boundary.
fn ps_takes(i: u32, x_ij: vecd) -> bool {
    return ps_depth(i, ps_image(x_ij)) <= kin[KPS_OFF + PS_WIDTH * i + 1u];
}

// Whether the pair (i, j) of the lists interacts: always, but under the prime space only
// within reach and when either particle takes the other.
fn paired(i: u32, j: u32) -> bool {
    if ADAPTIVE_H != ADAPTIVE_H_PRIME_SPACE {
        return true;
    }
    let x_ij = x_of(i) - x_of(j);
    if !(dot(x_ij, x_ij) <= PS_R2) {
        return false;
    }
    return ps_takes(i, x_ij) || ps_takes(j, -x_ij);
}

// Particle i's hull by gift wrapping, from its lowest image (then leftmost), taking at
// each vertex the smallest left turn from the last edge (the farthest of collinear
// images; an image behind, collinear with the edge, is never next), so that every image
// lies left of each edge, until it reaches a vertex again (the start, or one that
// rounding let it reach past the start, which then lies within rounding of an edge): the
// edges counter-clockwise, stored with the tolerance, PS_TOLERANCE of the largest
// image's length. A hull of more than PS_EDGES edges, or a wrap that does not close,
// records the particle in status[3] and takes every candidate. Then h_i: PS_H_PER_R
// times the distance of the farthest candidate taken, capped at H_CAP h (the cap
// without one).
fn prime_space_h(i: u32) -> f32 {
    let xi = x_of(i);
    let pairs = pairs_of(i);
    let base = KPS_OFF + PS_WIDTH * i;
    var count = 0u;
    var scale = 0.0;
    var start = pairs.y;
    var first: vec2<f32>;
    for (var p = pairs.x; p < pairs.y; p++) {
        let x_ij = xi - x_of(ids[p]);
        let r2 = dot(x_ij, x_ij);
        if !(r2 <= PS_R2) || r2 == 0.0 {
            continue;
        }
        count++;
        let img = ps_image(x_ij);
        scale = max(scale, length(img));
        if start == pairs.y || img.y < first.y || (img.y == first.y && img.x < first.x) {
            start = p;
            first = img;
        }
    }
    var edges = 0u;
    if count >= 3u {
        var current = start;
        var tail = first;
        var steps = 0u;
        // The vertices reached after the start: rounding can make the wrap pass the start
        // by a near-collinear image, and it closes on any vertex it reaches again.
        var visited: array<u32, PS_EDGES>;
        var visits = 0u;
        // Below the lowest image every other lies at a left turn from +x.
        var direction = vec2<f32>(1.0, 0.0);
        loop {
            // A hull has at most one vertex per image: more steps are a wrap that rounding
            // keeps from closing.
            steps++;
            if steps > count {
                atomicMin(&status[3], i);
                edges = 0u;
                break;
            }
            // The candidate of the smallest left turn from the last edge's direction, in
            // [−π/2, 3π/2) so that an image behind (a turn of ±π) is never taken; the
            // farther of two at the same turn.
            var next = pairs.y;
            var head: vec2<f32>;
            var best = 3.4e38;
            var best_d2 = 0.0;
            for (var p = pairs.x; p < pairs.y; p++) {
                let x_ij = xi - x_of(ids[p]);
                let r2 = dot(x_ij, x_ij);
                if !(r2 <= PS_R2) || r2 == 0.0 || p == current {
                    continue;
                }
                let img = ps_image(x_ij);
                let w = img - tail;
                let d2 = dot(w, w);
                if d2 == 0.0 {
                    continue;
                }
                var turn = atan2(direction.x * w.y - direction.y * w.x, dot(direction, w));
                if turn < -0.5 * PI {
                    turn += 2.0 * PI;
                }
                if turn < best || (turn == best && d2 > best_d2) {
                    best = turn;
                    best_d2 = d2;
                    next = p;
                    head = img;
                }
            }
            if next == pairs.y {
                break;
            }
            let t = head - tail;
            let length_t = length(t);
            if length_t > 0.0 {
                if edges == PS_EDGES {
                    atomicMin(&status[3], i);
                    edges = 0u;
                    break;
                }
                let n = vec2<f32>(-t.y, t.x) / length_t;
                let e = base + 2u + 3u * edges;
                kin[e] = n.x;
                kin[e + 1u] = n.y;
                kin[e + 2u] = dot(n, tail);
                edges++;
            }
            var closed = next == start;
            for (var v = 0u; v < visits; v++) {
                closed = closed || visited[v] == next;
            }
            if closed {
                break;
            }
            if visits < PS_EDGES {
                visited[visits] = next;
                visits++;
            }
            current = next;
            direction = head - tail;
            tail = head;
        }
    }
    kin[base] = f32(edges);
    kin[base + 1u] = PS_TOLERANCE * scale;
    var farthest = 0.0;
    for (var p = pairs.x; p < pairs.y; p++) {
        let x_ij = xi - x_of(ids[p]);
        let r2 = dot(x_ij, x_ij);
        if r2 <= PS_R2 && r2 > 0.0 && ps_takes(i, x_ij) {
            farthest = max(farthest, sqrt(r2));
        }
    }
    if farthest == 0.0 {
        return H_CAP * KERNEL_H;
    }
    return min(PS_H_PER_R * farthest, H_CAP * KERNEL_H);
}

// eq 62 at density ρ, capped at H_CAP h: h (ρ0/ρ)^(1/d) (methods::cores::ul
// `UlCore::continuity_h`).
fn continuity_h(rho: f32) -> f32 {
    return min(KERNEL_H * pow(RHO0 / rho, 1.0 / f32(DIM)), H_CAP * KERNEL_H);
}

// eqs 60–61 at particle i: the fixed point of h = min(η (m_i/⟨ρ⟩)^(1/d), H_CAP h) with
// ⟨ρ⟩ = Σ_j W(x_ij, h) m_j over the particle and its list, η = h (ρ0/m_i)^(1/d), from
// `start`, by the Newton steps of core::neighbourhood `density_smoothing_length` (the
// plain step where the slope is below 0.1 or the step leaves a factor of two), to 1e-6 of
// h in f32; at most 50 steps, after which (or with ⟨ρ⟩ ≤ 0) status[2] records the particle.
fn density_h(i: u32, start: f32) -> f32 {
    let d = f32(DIM);
    let xi = x_of(i);
    let m_i = mass_of(i);
    let eta = KERNEL_H * pow(RHO0 / m_i, 1.0 / d);
    let h_max = H_CAP * KERNEL_H;
    let pairs = pairs_of(i);
    var h = min(start, h_max);
    for (var it = 0u; it < 50u; it++) {
        let w0 = kernel_w_at(0.0, h);
        var rho = m_i * w0;
        var rho_h = -m_i * d * w0 / h;
        for (var p = pairs.x; p < pairs.y; p++) {
            let j = ids[p];
            let r = length(xi - x_of(j));
            let w = kernel_w_at(r, h);
            rho += mass_of(j) * w;
            rho_h -= mass_of(j) * (d * w + r * kernel_dw_at(r, h)) / h;
        }
        if !(rho > 0.0) {
            break;
        }
        let aim = eta * pow(m_i / rho, 1.0 / d);
        var next = h_max;
        if aim < h_max {
            let slope = 1.0 + aim / d * rho_h / rho;
            let newton = h - (h - aim) / slope;
            next = aim;
            if slope > 0.1 && newton > 0.5 * h && newton < 2.0 * h {
                next = min(newton, h_max);
            }
        }
        if abs(next - h) <= 1e-6 * h {
            return next;
        }
        h = next;
    }
    atomicMin(&status[2], i);
    return h;
}

// The adaptive smoothing length of each particle into kin (methods::cores::ul
// `UlCore::positions`), after the lists' build and before the scheme's particle pass:
// eq 62 from ρ, or eqs 60–61 over the lists from it.
// bytes:
// ρ and h; eqs 60–61 read the lists, x and m over the Newton steps (taken as one).
// - y: 1 scalar per item
// - kin stores: 1 scalar per item
// - reference: 1 scalar per item, when ADAPTIVE_H == ADAPTIVE_H_DENSITY
// - offsets: 1 scalar per item, when ADAPTIVE_H == ADAPTIVE_H_DENSITY
// - ids: 1 scalar per pair, when ADAPTIVE_H == ADAPTIVE_H_DENSITY
// - x: 1 vector per item, when ADAPTIVE_H == ADAPTIVE_H_DENSITY
// - reference loads: 1 scalar per pair, when ADAPTIVE_H == ADAPTIVE_H_DENSITY
// The prime space's hull: the list read once for the candidates, once per vertex (about
// six) and once for the farthest taken; the hull's count, tolerance and edges stored, and
// read back per pair.
// - offsets: 1 scalar per item, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE
// - ids: 8 scalars per pair, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE
// - x: 1 vector per item, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE
// - x loads: 8 vectors per pair, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE
// - kin stores: 20 scalars per item, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE
// - kin loads: 20 scalars per pair, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE
// - status: nothing
@compute @workgroup_size(256)
fn smoothing(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    var h = continuity_h(rho_of(i));
    if ADAPTIVE_H == ADAPTIVE_H_DENSITY {
        h = density_h(i, h);
    }
    if ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE {
        h = prime_space_h(i);
    }
    kin[KH_OFF + i] = h;
}

// σ = S − p I with p = c0²(ρ − ρ0); with FREE_SURFACE, σ·n = 0 projected at a surface
// particle, σ ← (I − n⊗n) σ (I − n⊗n), where its Shepard sum S_i = V_i W(0) + Σ_j V_j W_ij
// is below SURFACE_SHEPARD and n = −∇S_i/|∇S_i| (methods::cores::ul `UlCore::cauchy`).
fn cauchy_of(i: u32) -> matd {
    let sigma = mload_y(S_OFF + DIM * DIM * i) - identity_d() * pressure(y[RHO_OFF + i]);
    if FREE_SURFACE != 1u {
        return sigma;
    }
    let xi = x_of(i);
    var s = mass_of(i) / rho_of(i) * kernel_w_at(0.0, h_of(i));
    var g: vecd;
    let pairs = pairs_of(i);
    for (var p = pairs.x; p < pairs.y; p++) {
        let j = ids[p];
        if !paired(i, j) {
            continue;
        }
        let x_ij = xi - x_of(j);
        let v = mass_of(j) / rho_of(j);
        let h = h_pair(i, j);
        s += v * kernel_w_at(length(x_ij), h);
        g += kernel_grad_at(x_ij, h) * v;
    }
    let norm = length(g);
    if !(s < SURFACE_SHEPARD && norm > 0.0) {
        return sigma;
    }
    let n = g * (-1.0 / norm);
    let proj = identity_d() - outer(n, n);
    return proj * sigma * proj;
}

// A_i⁻ᵀ of the Randles–Libersky correction of L_i on the current positions, A_i =
// Σ_j V_j (x_j − x_i) ⊗ ∇W_ij with V_j = m_j/ρ_j (seed 000 §1.3); I without a correction.
// A singular A_i (|det| ≤ 1e-10, as on the CPU) records the particle in status.
fn correction_of(i: u32) -> matd {
    if CORRECTION != CORRECTION_LINEAR {
        return identity_d();
    }
    let xi = x_of(i);
    var a: matd;
    let pairs = pairs_of(i);
    for (var p = pairs.x; p < pairs.y; p++) {
        let j = ids[p];
        if !paired(i, j) {
            continue;
        }
        let x_ij = xi - x_of(j);
        a += outer(-x_ij, kernel_grad_at(x_ij, h_pair(i, j))) * (mass_of(j) / rho_of(j));
    }
    let det = determinant(a);
    if !(abs(det) > 1e-10) {
        atomicMin(&status[0], i);
        return identity_d();
    }
    return transpose(inverse_d(a));
}

// The correction of particle i's velocity gradient, loaded once per particle for its
// pairs: A⁻ᵀ of the Randles–Libersky correction, or the RKPM coefficients C and ∂_k C.
struct Corrector {
    ait: matd,
    rk: Rkpm,
}

// The RKPM coefficients at x_i from its pairs and itself on the current positions
// (rkpm.wgsl, scaled by KERNEL_H), with V_j = m_j/ρ_j. A moment matrix the neighbours do not span records the particle in
// status[0] and leaves the plain gradients (C = e₁, ∂C = 0).
fn reproducing_of(i: u32) -> Corrector {
    let xi = x_of(i);
    var mo: Moments;
    let pairs = pairs_of(i);
    // The self pair (r = 0: W(0), ∇W = 0) and then the neighbours.
    for (var p = pairs.x; p <= pairs.y; p++) {
        var j = i;
        if p < pairs.y {
            j = ids[p];
            if !paired(i, j) {
                continue;
            }
        }
        let r = xi - x_of(j);
        let h = h_pair(i, j);
        let v = mass_of(j) / rho_of(j);
        add_moments(&mo, r, v, kernel_w_at(length(r), h), kernel_grad_at(r, h), KERNEL_H);
    }
    var out: Corrector;
    out.ait = identity_d();
    out.rk = rkpm_solve(mo);
    if !out.rk.ok {
        atomicMin(&status[0], i);
    }
    return out;
}

// The particle's V = m/ρ and correction into kin, which every scheme's particle pass
// writes; ρ ≤ 0 (or NaN) records the particle in status[1].
// bytes block particle_core:
// The core's part of a scheme's `particle` pass: V = m/ρ (m from the reference volume, ρ
// from the state), the linear correction's A⁻ᵀ (a gather over x), the failure flags (det A,
// ρ > 0).
// - reference: 1 scalar per item
// - y: 1 scalar per item
// - kin stores: 1 scalar per item
// - kin stores: 1 tensor per item, when CORRECTION == CORRECTION_LINEAR
// - offsets: 1 scalar per item, when CORRECTION == CORRECTION_LINEAR
// - ids: 1 scalar per pair, when CORRECTION == CORRECTION_LINEAR
// - x: 1 vector per item, when CORRECTION == CORRECTION_LINEAR
// The RKPM moments over the pairs and the particle itself, and C, ∂C into kin.
// - kin stores: 1 tensor + 2 vectors + 1 scalar per item, when CORRECTION == CORRECTION_REPRODUCING
// - offsets: 1 scalar per item, when CORRECTION == CORRECTION_REPRODUCING
// - ids: 1 scalar per pair, when CORRECTION == CORRECTION_REPRODUCING
// - x: 1 vector per item, when CORRECTION == CORRECTION_REPRODUCING
// The Shepard sum and its gradient of a traction-free surface (`cauchy_of`).
// - offsets: 1 scalar per item, when FREE_SURFACE
// - ids: 1 scalar per pair, when FREE_SURFACE
// - x: 1 vector per item, when FREE_SURFACE
// An adaptive h_j in the pair sums of the correction and the surface.
// - kin loads: 1 scalar per pair, when ADAPTIVE_H != ADAPTIVE_H_FIXED and CORRECTION != CORRECTION_NONE
// - kin loads: 1 scalar per pair, when ADAPTIVE_H != ADAPTIVE_H_FIXED and FREE_SURFACE
// The prime space's test of each pair: both hulls (about six edges each).
// - kin loads: 40 scalars per pair, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE and CORRECTION != CORRECTION_NONE
// - kin loads: 40 scalars per pair, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE and FREE_SURFACE
// - status: nothing
fn store_common(i: u32) {
    let rho = rho_of(i);
    if !(rho > 0.0) {
        atomicMin(&status[1], i);
    }
    kin[KVOL_OFF + i] = mass_of(i) / rho;
    if CORRECTION == CORRECTION_LINEAR {
        mstore_kin(KAIT_OFF + DIM * DIM * i, correction_of(i));
    }
    if CORRECTION == CORRECTION_REPRODUCING {
        rkpm_store(KRK_OFF + (DIM + 1u) * (DIM + 1u) * i, reproducing_of(i).rk);
    }
}

// The correction of particle i's velocity gradient from kin.
fn corrector_of(i: u32) -> Corrector {
    var k: Corrector;
    k.ait = identity_d();
    if CORRECTION == CORRECTION_LINEAR {
        k.ait = mload_kin(KAIT_OFF + DIM * DIM * i);
    }
    if CORRECTION == CORRECTION_REPRODUCING {
        k.rk = rkpm_load(KRK_OFF + (DIM + 1u) * (DIM + 1u) * i);
    }
    return k;
}

// The corrected gradient g_ij of a pair from x_ij = x_i − x_j, W_ij and ∇W_ij (eq 105):
// A_i⁻ᵀ ∇W_ij, or RKPM's ∇Ψ_j(x_i) = (∂_k C·p̂ + C_k/h) W + C·p̂ ∂_k W (seed 000 §1.4).
fn corrected_grad(k: Corrector, x_ij: vecd, w: f32, grad: vecd) -> vecd {
    if CORRECTION != CORRECTION_REPRODUCING {
        return k.ait * grad;
    }
    return rkpm_gradient(k.rk, x_ij, w, grad, KERNEL_H);
}

// Writes the rates of particle i from its scheme's ẋ, a, ρ̇ and L: prescribed velocity
// components take ẋ = v and v̇ = 0 (after the external accelerations, boundary.wgsl),
// Ṡ by the objective rate, Ḣ = Ḟ = L F, and ε̇_p = 0 with a yield stress (plastic.wgsl
// returns S at the step's end).
// bytes block rates_core:
// The core's part of a scheme's `rates` pass: the row, x, the state (v, ρ, S, F), V, A⁻ᵀ
// (or RKPM's C, ∂C),
// the boundary conditions (V and mask, ext, the power of supports and loads into kin) and
// the rates (u̇, v̇, ρ̇, Ṡ, Ḟ).
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// - x: 1 vector per item
// - y: 1 scalar + 1 vector + 2 tensors per item
// - kin loads: 1 scalar per item
// - kin loads: 1 tensor per item, when CORRECTION == CORRECTION_LINEAR
// - kin loads: 1 tensor + 2 vectors + 1 scalar per item, when CORRECTION == CORRECTION_REPRODUCING
// - reference: 2 scalars per item
// - ext: 1 vector per item
// - d: 1 scalar + 2 vectors + 2 tensors per item
// - d: 1 scalar per item, when PLASTIC
// - kin stores: 1 scalar per item
// An adaptive h of the particle and of each neighbour.
// - kin loads: 1 scalar per item, when ADAPTIVE_H != ADAPTIVE_H_FIXED
// - kin loads: 1 scalar per pair, when ADAPTIVE_H != ADAPTIVE_H_FIXED
// The prime space's test of each pair: both hulls (about six edges each).
// - kin loads: 40 scalars per pair, when ADAPTIVE_H == ADAPTIVE_H_PRIME_SPACE
fn close_rates(i: u32, x_dot: vecd, acc: vecd, rho_dot: f32, l: matd) {
    let v_i = v_of(i);
    let a = apply_boundary(i, acc, v_i, mass_of(i));
    var xd = x_dot;
    let m = mask_of(i);
    for (var k = 0u; k < DIM; k++) {
        if ((m >> k) & 1u) != 0u {
            xd[k] = v_i[k];
        }
    }
    vstore_d(U_OFF + DIM * i, xd);
    vstore_d(V_OFF + DIM * i, a);
    d[RHO_OFF + i] = rho_dot;
    let f = identity_d() + mload_y(F_OFF + DIM * DIM * i);
    mstore_d(S_OFF + DIM * DIM * i, stress_rate(mload_y(S_OFF + DIM * DIM * i), l, f));
    mstore_d(F_OFF + DIM * DIM * i, l * f);
    if PLASTIC == 1u {
        d[EP_OFF + i] = 0.0;
    }
}
