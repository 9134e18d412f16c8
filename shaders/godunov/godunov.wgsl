// Godunov SPH on the device (seed 000 §5.2, Algorithm 2, eqs 128–133 in the clean form of
// the spec notes §3.2; methods::godunov::system on the CPU), on the core of ul.wgsl. Every
// pair is an acoustic Riemann problem along n_ij = x_ij/r_ij with impedances Z = ρ c: its
// contact velocity u* enters the continuity equation and its traction t* (t*_ji = −t*_ij)
// the momentum equation. One invocation per particle, writing only its own particle.

// Steps 1–2: σ, p, Z = ρ sqrt(K/ρ), V = m/ρ and the correction of L.
// bytes:
// The core's part, and ρ − ρ0, S in; σ, p, Z = ρc out.
// - include particle_core
// - y: 1 tensor per item
// - kin stores: 2 scalars + 1 tensor per item
@compute @workgroup_size(256)
fn particle(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let i = part.first + row;
    let rho = rho_of(i);
    mstore_kin(KT_OFF + DIM * DIM * i, cauchy_of(i));
    kin[KP_OFF + i] = pressure(y[RHO_OFF + i]);
    kin[KC_OFF + i] = rho * sqrt(BULK / rho);
    store_common(i);
}

// Steps 3–7: L (eq 105), ρ̇ with the Riemann velocity (eqs 131, 133) and v̇ with the
// Riemann traction on the axis e = −n (eq 132).
// bytes:
// The core's part, and σ, p, Z of both particles.
// - include rates_core
// - kin loads: 2 scalars + 1 tensor per item
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
    let sigma_i = mload_kin(KT_OFF + DIM * DIM * i);
    let p_i = kin[KP_OFF + i];
    let z_i = kin[KC_OFF + i];
    let k = corrector_of(i);
    var l: matd;
    var rho_dot = 0.0;
    var a: vecd;
    let pairs = pairs_of(i);
    for (var p = pairs.x; p < pairs.y; p++) {
        let j = ids[p];
        if !paired(i, j) {
            continue;
        }
        let x_ij = x_i - x_of(j);
        let r = length(x_ij);
        let h = h_pair(i, j);
        if r <= 1e-6 * h {
            // Coincident particles: no axis for the Riemann problem, and ∇W_ij = 0.
            continue;
        }
        let n = x_ij * (1.0 / r);
        let dw = kernel_dw_at(r, h);
        let v_j = v_of(j);
        let vol_j = kin[KVOL_OFF + j];
        let z_j = kin[KC_OFF + j];
        l += outer(v_j - v_i, corrected_grad(k, x_ij, kernel_w_at(r, h), n * dw)) * vol_j;
        let u_i = dot(v_i, n);
        let u_j = dot(v_j, n);
        let u_star = (z_i * u_i + z_j * u_j - p_i + kin[KP_OFF + j]) / (z_i + z_j);
        rho_dot += 2.0 * rho_i * vol_j * (u_i - u_star) * dw;
        let e = -n;
        let sigma_j = mload_kin(KT_OFF + DIM * DIM * j);
        let t_star = ((sigma_j * e) * z_i + (sigma_i * e) * z_j + (v_j - v_i) * (z_i * z_j)) / (z_i + z_j);
        a -= t_star * (2.0 / rho_i * vol_j * dw);
    }
    close_rates(i, v_i, a, rho_dot, l);
}
