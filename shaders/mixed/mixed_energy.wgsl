// The hooks of reduce.wgsl for a mixed method. Constants as in mixed.wgsl.

// V_i ψ(F_i, J_i) of a mixed-method particle, from the F − I of the stress
// (stress_excess, mixed_motion.wgsl: the evolved F, or the bond-based F^c − I), and J − 1
// (det F − 1 when J is not evolved), with the evolved pressure under artificial
// compressibility; for the von Mises model the Hencky energy of the
// returned elastic stretches.
fn strain_energy(i: u32) -> f32 {
    let f = stress_excess(i);
    if MODEL == MODEL_VON_MISES_PLASTIC {
        return vol_of(i) * return_map(lift3(identity_d() + f, 1.0), history(i)).psi;
    }
    var j = det_excess(f);
    if AC == 1u {
        // ψ = ψ_iso + p²/(2κ): no volumetric energy at κ = ∞ (INV_BULK = 1/κ = 0).
        let p = y[PRES_OFF + i];
        return vol_of(i) * (isochoric_energy(f, j) + 0.5 * INV_BULK * p * p);
    }
    if EVOLVE_J == 1u {
        j = y[J_OFF + i];
    }
    return vol_of(i) * energy_density_mixed(f, j);
}

// The part's neighbour lists (CSR over the real rows; ids ≥ N are ghosts), for the pair
// rate.
@group(0) @binding(4) var<storage, read> offsets: array<u32>;
@group(0) @binding(5) var<storage, read> ids: array<u32>;
// The plastic history (plasticity.wgsl), read with MODEL_VON_MISES_PLASTIC only.
@group(0) @binding(6) var<storage, read> hist: array<f32>;

// λ_i, the smallest principal stretch of particle i: the square root of the smallest
// eigenvalue of C = FᵀF; 1 when the step takes C_p^Lin for every pair (PAIR_STRETCH = 0).
fn smallest_stretch(i: u32) -> f32 {
    if PAIR_STRETCH == 0u {
        return 1.0;
    }
    let f = identity_d() + mload_y(F_OFF + DIM * DIM * i);
    return sqrt(smallest_eigenvalue_sym(transpose(f) * f));
}

// Δx max_j C_p,ij / r_ij over the real neighbours j of particle i (seed 002 eqs 31–32,
// MixedSph::pair_wave_speed on the CPU, which says why ghosts do not count), r_ij the
// current distance.
fn pair_wave_speed(i: u32) -> f32 {
    let x_i = x0_of(i) + vload_y(U_OFF + DIM * i);
    let lambda_i = smallest_stretch(i);
    var fastest = 0.0;
    let row = i - part.first;
    let q_end = offsets[row + 1u];
    for (var q = offsets[row]; q < q_end; q++) {
        let j = ids[q];
        if j < N {
            let r_ij = length(x0_of(j) + vload_y(U_OFF + DIM * j) - x_i);
            // eq 32: C_p,ij = C_p^Lin / λ^Ave_ij, λ^Ave_ij = ½(λ_i + λ_j).
            let c_ij = C_P / (0.5 * (lambda_i + smallest_stretch(j)));
            fastest = max(fastest, c_ij / r_ij);
        }
    }
    return SPACING * fastest;
}

// The method does not separate its dissipation: no viscous power in the reduction.
fn viscous_dissipation(i: u32) -> f32 {
    return 0.0;
}
