// The images of ghost k (extended index N + k) of the mixed passes (src/physics/mirror.rs), with r
// the diagonal of the reflection R and σ = −1 per skew-symmetric plane: vectors
// v' = σ R v; two-point tensors and the excesses F − I, H − I: T' = σ R T R; the pressure
// p' = σ p. Needs the binding `ghost_img` (r_0 … r_{DIM−1}, σ per ghost).

fn reflection(k: u32) -> vecd {
    return vload_ghost_img((DIM + 1u) * k);
}

fn sigma(k: u32) -> f32 {
    return ghost_img[(DIM + 1u) * k + DIM];
}

fn map_vector(k: u32, v: vecd) -> vecd {
    return reflection(k) * v * sigma(k);
}

// (σ R T R)_kl = σ r_k r_l T_kl.
fn map_tensor(k: u32, t: matd) -> matd {
    let r = reflection(k);
    return hadamard(t, outer(r, r) * sigma(k));
}

fn map_scalar(k: u32, s: f32) -> f32 {
    return sigma(k) * s;
}
