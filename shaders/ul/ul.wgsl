// The updated-Lagrangian core on the device (src/methods/cores/ul/gpu.rs), shared by the
// Gray–Monaghan and Godunov passes as methods::cores::ul is on the CPU: the bindings, the
// positions pass, the Randles–Libersky correction of L on the current positions, and the
// closing of a particle's rates.
//
// Flat f32 buffers: the state y = [u | v | ρ − ρ0 | S | H = F − I | ε_p] (ε_p with a yield
// stress; ρ as its deviation and F as H, as in tlsph.wgsl, to keep their digits in f32);
// x = X + u of the last positions
// pass (DIM per particle), which the cell list reads; the scheme's per-particle quantities
// kin = [T | R | AIT | VOL | C | P | POW] (T: σ/ρ² for Gray–Monaghan, σ for Godunov; R:
// artificial stress; AIT: A⁻ᵀ of the correction; VOL: m/ρ; C: sound speed or impedance;
// P: pressure; POW: power of supports and loads); the CSR lists offsets/ids of the cell
// list, rebuilt from x before every rate evaluation. The `particle` and `rates` passes run
// a part of the rows at a time (part.wgsl), each part with its own ids, counted from its
// first pair; `offsets` counts over every particle. Scene constants: N, DIM, RHO0, MU,
// BULK, CORRECTION, the kernel's, and the field offsets of methods::cores::ul::gpu::Layout.

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

// σ = S − p I with p = c0²(ρ − ρ0).
fn cauchy_of(i: u32) -> matd {
    return mload_y(S_OFF + DIM * DIM * i) - identity_d() * pressure(y[RHO_OFF + i]);
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
        let x_ij = xi - x_of(j);
        a += outer(-x_ij, kernel_grad(x_ij)) * (mass_of(j) / rho_of(j));
    }
    let det = determinant(a);
    if !(abs(det) > 1e-10) {
        atomicMin(&status[0], i);
        return identity_d();
    }
    return transpose(inverse_d(a));
}

// The particle's V = m/ρ and correction into kin, which every scheme's particle pass
// writes; ρ ≤ 0 (or NaN) records the particle in status[1].
// bytes block particle_core:
// The core's part of a scheme's `particle` pass: V = m/ρ (m from the reference volume, ρ
// from the state), the linear correction's A⁻ᵀ (a gather over x), the failure flags (det A,
// ρ > 0).
// - reference: 1 scalar per item
// - y: 1 scalar per item
// - kin: 1 scalar per item
// - kin: 1 tensor per item, when CORRECTION == CORRECTION_LINEAR
// - offsets: 1 scalar per item, when CORRECTION == CORRECTION_LINEAR
// - ids: 1 scalar per pair, when CORRECTION == CORRECTION_LINEAR
// - x: 1 vector per item, when CORRECTION == CORRECTION_LINEAR
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
}

fn ait_of(i: u32) -> matd {
    if CORRECTION == CORRECTION_LINEAR {
        return mload_kin(KAIT_OFF + DIM * DIM * i);
    }
    return identity_d();
}

// Writes the rates of particle i from its scheme's ẋ, a, ρ̇ and L: prescribed velocity
// components take ẋ = v and v̇ = 0 (after the external accelerations, boundary.wgsl),
// Ṡ by the objective rate, Ḣ = Ḟ = L F, and ε̇_p = 0 with a yield stress (plastic.wgsl
// returns S at the step's end).
// bytes block rates_core:
// The core's part of a scheme's `rates` pass: the row, x, the state (v, ρ, S, F), V, A⁻ᵀ,
// the boundary conditions (V and mask, ext, the power of supports and loads into kin) and
// the rates (u̇, v̇, ρ̇, Ṡ, Ḟ).
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// - x: 1 vector per item
// - y: 1 scalar + 1 vector + 2 tensors per item
// - kin loads: 1 scalar per item
// - kin loads: 1 tensor per item, when CORRECTION == CORRECTION_LINEAR
// - reference: 2 scalars per item
// - ext: 1 vector per item
// - d: 1 scalar + 2 vectors + 2 tensors per item
// - d: 1 scalar per item, when PLASTIC
// - kin stores: 1 scalar per item
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
