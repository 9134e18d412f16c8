//! Helpers shared by the mixed-method test files: shipped cases and random states.

use meshless::method::Method;
use meshless::method::mixed::{MixedSph, MixedState};
use meshless::scene::Case;
use meshless::tensor::Dim;
use std::path::Path;

/// A shipped case with `--set` overrides.
pub fn load(name: &str, overrides: &[&str]) -> Case {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(format!("{name}.toml"));
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Case::load(&path, &overrides).unwrap()
}

/// Deterministic numbers in [−1, 1) (64-bit LCG).
pub fn noise(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// A tensor with entries scale × noise.
pub fn random_tensor<D: Dim>(seed: &mut u64, scale: f64) -> D::T {
    let mut t = D::zero_t();
    for k in 0..D::N {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        let row: Vec<f64> = (0..D::N).map(|_| scale * noise(seed)).collect();
        t += D::outer(D::from_slice(&e), D::from_slice(&row));
    }
    t
}

/// A random admissible state: |v| ~ 1 m/s, |u| ~ 1 cm, F = I + 5 % noise,
/// H = cof F + `h_noise` noise, J = det F + 1 %.
pub fn random_state<D: Dim>(m: &MixedSph<D>, seed: &mut u64, h_noise: f64) -> MixedState<D> {
    let mut y = m.initial_state();
    let vec = |seed: &mut u64, s: f64| {
        D::from_slice(&(0..D::N).map(|_| s * noise(seed)).collect::<Vec<_>>())
    };
    for a in 0..y.v.len() {
        y.v[a] = vec(seed, 1.0);
        y.u[a] = vec(seed, 0.01);
        y.f[a] = D::identity() + random_tensor::<D>(seed, 0.05);
        if !y.h.is_empty() {
            y.h[a] = D::cof(y.f[a]) + random_tensor::<D>(seed, h_noise);
        }
        if !y.j.is_empty() {
            y.j[a] = D::det(y.f[a]) * (1.0 + 0.01 * noise(seed));
        }
    }
    y
}
