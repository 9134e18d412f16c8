// Gray–Monaghan stress-corrected updated-Lagrangian SPH on the device (seed 000 §5.1,
// Algorithm 1, eqs 103–105 and 118–127; methods::gray_monaghan::system on the CPU), on the
// core of ul.wgsl. One invocation per particle, writing only its own particle.
// Scheme constants: AV, AV_ALPHA, AV_BETA, AV_ETA (Monaghan viscosity), AS, AS_EPSILON,
// AS_N, AS_W_DP (artificial stress ε, n and W(Δp)), XSPH, XSPH_EPSILON.

// R = Σ_k R̄_k n_k ⊗ n_k over the principal stresses σ̄_k > 0 (tension), R̄_k = −ε σ̄_k/ρ²
// (eqs 119–125): the eigen-decomposition of σ lifted to 3 × 3 (σ_zz = 0 in 2D adds a zero
// principal value, which is not in tension).
fn artificial_stress(sigma: matd, rho: f32) -> matd {
    let e = symmetric_eigen(lift3(sigma, 0.0));
    var w = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        if e.values[k] > 0.0 {
            w[k] = -AS_EPSILON * e.values[k] / (rho * rho); // eq 122
        }
    }
    return lower3(principal(e.vectors, w));
}

// Steps 1–3: σ/ρ², R, V = m/ρ, c = sqrt(K/ρ) and the correction of L.
// bytes:
// The core's part, and ρ − ρ0, S in; σ/ρ², c (and R) out.
// - include particle_core
// - y: 1 tensor per item
// - kin stores: 1 scalar + 1 tensor per item
// - kin stores: 1 tensor per item, when AS
@compute @workgroup_size(256)
fn particle(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let rho = rho_of(i);
    let sigma = cauchy_of(i);
    mstore_kin(KT_OFF + DIM * DIM * i, sigma * (1.0 / (rho * rho)));
    if AS == 1u {
        mstore_kin(KR_OFF + DIM * DIM * i, artificial_stress(sigma, rho));
    }
    kin[KC_OFF + i] = sqrt(BULK / rho);
    store_common(i);
}

// Steps 4–11: L (eq 105), the stress and artificial-stress accelerations (eq 118), the
// viscosity of approaching pairs (§3.1 step 6), XSPH (eq 127) and ρ̇ = −ρ tr L (eq 104).
// bytes:
// The core's part, and σ/ρ², c (and R) of both particles.
// - include rates_core
// - kin loads: 1 scalar + 1 tensor per item
// - kin loads: 1 tensor per item, when AS
@compute @workgroup_size(256)
fn rates(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let x_i = x_of(i);
    let v_i = v_of(i);
    let rho_i = rho_of(i);
    let t_i = mload_kin(KT_OFF + DIM * DIM * i);
    let c_i = kin[KC_OFF + i];
    let k = corrector_of(i);
    var r_i: matd;
    if AS == 1u {
        r_i = mload_kin(KR_OFF + DIM * DIM * i);
    }
    var l: matd;
    var a: vecd;
    var xsph: vecd;
    let pairs = pairs_of(i);
    for (var p = pairs.x; p < pairs.y; p++) {
        let j = ids[p];
        if !paired(i, j) {
            continue;
        }
        let x_ij = x_i - x_of(j);
        let r = length(x_ij);
        let h = h_pair(i, j);
        let grad = kernel_grad_at(x_ij, h);
        let w = kernel_w_at(r, h);
        let v_ji = v_of(j) - v_i;
        let m_j = mass_of(j);
        l += outer(v_ji, corrected_grad(k, x_ij, w, grad)) * kin[KVOL_OFF + j];
        var t = t_i + mload_kin(KT_OFF + DIM * DIM * j);
        if AS == 1u && w > 0.0 {
            // An adaptive h_ij scales Δp with it: f_ij = w(r/h_ij)/w(Δp/h).
            let f = w / AS_W_DP * (KERNEL_SCALE / kernel_scale_at(h));
            t += (r_i + mload_kin(KR_OFF + DIM * DIM * j)) * pow(f, AS_N);
        }
        a += t * grad * m_j;
        let rho_bar = 0.5 * (rho_i + rho_of(j));
        if AV == 1u {
            let pi = monaghan_pi_at(x_ij, -v_ji, 0.5 * (c_i + kin[KC_OFF + j]), rho_bar, h);
            a -= grad * (m_j * pi);
        }
        if XSPH == 1u {
            xsph += v_ji * (m_j / rho_bar * w);
        }
    }
    close_rates(i, v_i + xsph * XSPH_EPSILON, a, -rho_i * trace_d(l), l);
}
