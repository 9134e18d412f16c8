// Monaghan artificial viscosity (seed 000 §3.1 step 6; ArtificialViscosity::pi on the
// CPU): Π_ij = (−α c̄ μ_ij + β μ_ij²)/ρ̄_ij with μ_ij = h v_ij·x_ij/(|x_ij|² + η²h²) for
// approaching pairs (v_ij·x_ij < 0), and 0 for separating ones. Constants AV_ALPHA,
// AV_BETA, AV_ETA and the kernel's KERNEL_H (`monaghan_pi_at`: a pair's own h).

fn monaghan_pi(x_ij: vecd, v_ij: vecd, c_bar: f32, rho_bar: f32) -> f32 {
    return monaghan_pi_at(x_ij, v_ij, c_bar, rho_bar, KERNEL_H);
}

fn monaghan_pi_at(x_ij: vecd, v_ij: vecd, c_bar: f32, rho_bar: f32, h: f32) -> f32 {
    let vx = dot(v_ij, x_ij);
    if vx >= 0.0 {
        return 0.0;
    }
    let mu = h * vx / (dot(x_ij, x_ij) + AV_ETA * AV_ETA * h * h);
    return (-AV_ALPHA * c_bar * mu + AV_BETA * mu * mu) / rho_bar;
}
