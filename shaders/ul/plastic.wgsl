// The radial return that closes every step of an updated-Lagrangian method whose rate
// model has a yield stress (src/physics/material/mod.rs `radial_return`; seed 000
// App. 9.1): with q = sqrt(3/2 S:S), S_zz of plane strain included, beyond
// τ_y = max(τ_y⁰ + H ε_p, 0), Δε_p = min((q − τ_y⁰ − H ε_p)/(3μ + H), q/(3μ)) and S is
// scaled by 1 − 3μΔε_p/q; ε_p takes Δε_p. Each particle reads and writes its own S and ε_p
// of the state y = [u | v | ρ − ρ0 | S | H = F − I | ε_p] (methods::cores::ul::gpu::Layout).
// Scene constants: N, DIM, MU, YIELD, HARDENING, the rate and the field offsets.

@group(0) @binding(0) var<storage, read_write> y: array<f32>;

// bytes:
// ρ, S and ε_p read; S and ε_p written (only past the yield surface, counted always).
// - y loads: 2 scalars + 1 tensor per item
// - y stores: 1 scalar + 1 tensor per item
@compute @workgroup_size(256)
fn plastic_return(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = index(gid, nwg);
    if i >= N {
        return;
    }
    let s = mload_y(S_OFF + DIM * DIM * i);
    let szz = plane_strain_szz(s, y[RHO_OFF + i]);
    let q = sqrt(1.5 * (ddot_d(s, s) + szz * szz));
    let eps_p = y[EP_OFF + i];
    if q <= max(YIELD + HARDENING * eps_p, 0.0) {
        return;
    }
    let d_eps = min((q - YIELD - HARDENING * eps_p) / (3.0 * MU + HARDENING), q / (3.0 * MU));
    mstore_y(S_OFF + DIM * DIM * i, s * (1.0 - 3.0 * MU * d_eps / q));
    y[EP_OFF + i] = eps_p + d_eps;
}
