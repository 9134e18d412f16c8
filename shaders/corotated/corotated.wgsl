// Corotated total-Lagrangian SPH on the device (seed 000 §5.5, Algorithm 5;
// methods::corotated::system on the CPU), pass 1 of a rate evaluation: one invocation per
// particle, gathering over its CSR neighbours and writing only its own particle.
//
// Buffers as in tl/tlsph.wgsl: the state y = [u | v], the per-pair data
// pair = [∇0W_ij | X_j − X_i], the reference configuration (reference.wgsl) and the
// kinematics kin = [Ĥ = F̂ − I | P̂ | R F̂⁻ᵀ | ρ | power | R], of which this pass writes all
// but the power. status[0] receives the first particle with det F̂ ≤ 0, status[1] the
// first whose A_i has no rotation as its polar factor. Constants: the kernel's
// (kernel.wgsl), the material's (mechanics.wgsl), N and the field offsets of
// methods::cores::tl::gpu::Layout (U_OFF; KF_OFF, KP_OFF, KFIT_OFF, KRHO_OFF, KR_OFF; PG_OFF,
// PDX_OFF).

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<f32>;
@group(0) @binding(4) var<storage, read> y: array<f32>;
@group(0) @binding(5) var<storage, read_write> kin: array<f32>;
@group(0) @binding(6) var<storage, read_write> status: array<atomic<u32>>;

// Most iterations of the 3D polar decomposition (the CPU's; scaled Newton converges in
// under ten for condition numbers up to 1e16).
const POLAR_ITERATIONS: u32 = 50u;
// |ΔR|² of a converged Newton step in f32: |ΔR| ≤ 1e-5 leaves an error of O(|ΔR|²), below
// the round-off of O(1) entries, and stays well above the iteration's own round-off
// (~1e-7 per entry), so it is reached.
const POLAR_TOLERANCE: f32 = 1e-10;

// R of the polar decomposition A = R U (eq 151), as methods::corotated::rotation: in 2D
// the closed form (cos θ, sin θ) = (A_xx + A_yy, A_yx − A_xy)/n, n the length of that
// vector; in 3D Newton's iteration R ← ½(γR + γ⁻¹R⁻ᵀ) with Higham's scaling
// γ = (|R⁻¹|/|R|)^½ from A/|A| (the polar factor does not depend on the scale, and f32
// keeps its range). The zero tensor when A has none (n = 0 in 2D; det A ≤ 0 or no
// convergence in 3D).
fn polar_rotation(a: matd) -> matd {
    var r = matd();
    if DIM == 2u {
        // Column-major: a[l][k] = A_kl.
        let cs = vec2<f32>(a[0][0] + a[1][1], a[0][1] - a[1][0]);
        let n = length(cs);
        if n > 0.0 && n <= 3.0e38 {
            let e0 = unpad(vec3<f32>(1.0, 0.0, 0.0));
            let e1 = unpad(vec3<f32>(0.0, 1.0, 0.0));
            r = identity_d() * (cs.x / n) + (outer(e1, e0) - outer(e0, e1)) * (cs.y / n);
        }
    } else {
        let size = sqrt(ddot_d(a, a));
        if size > 0.0 && size <= 3.0e38 && determinant(a * (1.0 / size)) > 0.0 {
            var x = a * (1.0 / size);
            for (var k = 0u; k < POLAR_ITERATIONS; k++) {
                let x_inv_t = transpose(inverse_d(x));
                let gamma = sqrt(sqrt(ddot_d(x_inv_t, x_inv_t) / ddot_d(x, x)));
                let next = (x * gamma + x_inv_t * (1.0 / gamma)) * 0.5;
                let step = next - x;
                x = next;
                if ddot_d(step, step) <= POLAR_TOLERANCE {
                    r = x;
                    break;
                }
            }
        }
    }
    return r;
}

// bytes:
// - offsets: 1 scalar per item
// Both loops over a row: the second reads it from the cache.
// - ids: 1 scalar per pair
// X_j − X_i, ∇0W̃_ij.
// - pair: 2 vectors per pair
// - reference: 1 scalar per item
// u.
// - y: 1 vector per item
// P̂ and R; F̂ − I where the outputs read it (KEEP_H); R F̂⁻ᵀ and ρ where the viscosity
// or the outputs read them (KEEP_AV).
// - kin: 2 tensors per item
// - kin: 1 tensor per item, when KEEP_H
// - kin: 1 scalar + 1 tensor per item, when KEEP_AV
// - status: nothing
@compute @workgroup_size(256)
fn stress(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let u_i = vload_y(U_OFF + DIM * i);
    // Shape matching A_i = Σ_j m_j W_ij (x_j − x_i) ⊗ (X_j − X_i) (eq 151).
    var a: matd;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let dx = vload_pair(PDX_OFF + DIM * p);
        let x_ji = vload_y(U_OFF + DIM * j) - u_i + dx;
        a += outer(x_ji, dx) * (RHO0 * vol_of(j) * kernel_w(length(dx)));
    }
    let r = polar_rotation(a);
    if !(determinant(r) > 0.0) {
        atomicMin(&status[1], i);
    }
    // F̂_i = I + Σ_j V_j û_ij ⊗ ∇0W_ij with û_ij = R_iᵀ(x_j − x_i) − (X_j − X_i)
    // (eqs 152–153), summed as Ĥ = F̂ − I.
    let r_t = transpose(r);
    var h: matd;
    for (var p = offsets[row]; p < p_end; p++) {
        let j = ids[p];
        let dx = vload_pair(PDX_OFF + DIM * p);
        let u_hat = r_t * (vload_y(U_OFF + DIM * j) - u_i + dx) - dx;
        h += outer(u_hat, vload_pair(PG_OFF + DIM * p)) * vol_of(j);
    }
    let f_hat = identity_d() + h;
    let jac = determinant(f_hat);
    if !(jac > 0.0) {
        atomicMin(&status[0], i);
    }
    let f_inv_t = transpose(inverse_d(f_hat));
    if KEEP_H == 1u {
        mstore_kin(KF_OFF + DIM * DIM * i, h);
    }
    // P̂_i = P(F̂_i), the material's first Piola–Kirchhoff stress in the rotated frame.
    mstore_kin(KP_OFF + DIM * DIM * i, pk1(h, f_inv_t));
    if KEEP_AV == 1u {
        // R_i F̂_i⁻ᵀ = F_i⁻ᵀ: the push-forward of ∇0W_ij along which the viscosity acts.
        mstore_kin(KFIT_OFF + DIM * DIM * i, r * f_inv_t);
        kin[KRHO_OFF + i] = RHO0 / jac;
    }
    mstore_kin(KR_OFF + DIM * DIM * i, r);
}
