//! A per-particle hourglass (zero-energy mode) indicator for the VTU frames: how far the
//! current bonds of a particle are from its own affine map F_a,
//! η_a = Σ_b W_ab |F_a X_ab − x_ab| / Σ_b W_ab |X_ab|, the kernel-weighted mean of
//! Ganzenmüller's (2015) error vectors over the bond lengths. η vanishes for every
//! affine motion (rigid rotations included), is O(Δx |∇F|) for a smooth one and O(1)
//! when neighbours oscillate about the particle's F, as in an hourglass mode.

use crate::core::kernel::Kernel;
use crate::core::neighbour::{self, Csr};
use crate::core::tensor::Dim;
use rayon::prelude::*;

/// Neighbours within the method's kernel support and their weights W_ab |X_ab| on the
/// reference configuration, normalised per particle.
pub struct HourglassIndicator {
    csr: Csr,
    w: Vec<f64>,
}

impl HourglassIndicator {
    pub fn new<D: Dim>(kernel: &Kernel, x0: &[D::V]) -> Self {
        let csr = neighbour::build::<D>(x0, kernel.support());
        let w = (0..csr.len())
            .into_par_iter()
            .flat_map_iter(|a| {
                let bond = |q: usize| {
                    let r = D::norm2(x0[csr.ids[q] as usize] - x0[a]).sqrt();
                    (kernel.w(r), r)
                };
                let norm: f64 = csr
                    .range(a)
                    .map(|q| {
                        let (w, r) = bond(q);
                        w * r
                    })
                    .sum();
                csr.range(a)
                    .map(move |q| bond(q).0 / norm)
                    .collect::<Vec<_>>()
            })
            .collect();
        Self { csr, w }
    }

    /// η_a of every particle for displacements u and deformation gradients F.
    pub fn of<D: Dim>(&self, x0: &[D::V], u: &[D::V], f: &[D::T]) -> Vec<f64> {
        (0..self.csr.len())
            .into_par_iter()
            .map(|a| {
                self.csr
                    .range(a)
                    .map(|q| {
                        let b = self.csr.ids[q] as usize;
                        let x_ab = x0[b] - x0[a];
                        let mismatch = f[a] * x_ab - (x_ab + u[b] - u[a]);
                        self.w[q] * D::norm2(mismatch).sqrt()
                    })
                    .sum()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tensor::D2;
    use crate::scene::Scene;
    use glam::{DMat2, DVec2};

    fn plate() -> (Scene, Vec<DVec2>) {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/swinging-plate.toml");
        let case = Scene::load(&path, &["spacing=0.1".to_string()]).unwrap();
        let dx = case.spacing;
        let x0 = (0..100)
            .map(|k| DVec2::new((k % 10) as f64, (k / 10) as f64) * dx)
            .collect();
        (case, x0)
    }

    #[test]
    fn vanishes_for_affine_motion_and_flags_a_checkerboard() {
        let (case, x0) = plate();
        let hg = HourglassIndicator::new::<D2>(&case.kernel(2), &x0);
        // Rotation by 1 rad with stretch and translation: η is round-off (1e-14).
        let f = DMat2::from_angle(1.0) * DMat2::from_cols_array(&[1.5, 0.2, -0.1, 0.7]);
        let u: Vec<DVec2> = x0
            .iter()
            .map(|&x| f * x - x + DVec2::new(3.0, -1.0))
            .collect();
        let eta = hg.of::<D2>(&x0, &u, &vec![f; x0.len()]);
        assert!(
            eta.iter().all(|&e| e < 1e-14),
            "affine: max η {:e}",
            eta.iter().fold(0.0_f64, |m, &e| m.max(e))
        );
        // A checkerboard of ±δ along x with F = I: the four nearest neighbours sit 2δ
        // off, the diagonal and second ones (same colour) 0, so η ≈ δ/Δx (measured minimum
        // 0.96 δ/Δx); asserted above δ/(2Δx). A smooth
        // field of the same amplitude, u = δ sin(πX/L) with F from its gradient, is
        // O(δ Δx/L²) smaller.
        let delta = 1e-3;
        let dx = case.spacing;
        let checker: Vec<DVec2> = (0..x0.len())
            .map(|k| {
                DVec2::X
                    * if (k % 10 + k / 10) % 2 == 0 {
                        delta
                    } else {
                        -delta
                    }
            })
            .collect();
        let eta = hg.of::<D2>(&x0, &checker, &vec![DMat2::IDENTITY; x0.len()]);
        let min = eta.iter().fold(f64::INFINITY, |m, &e| m.min(e));
        assert!(min > 0.5 * delta / dx, "checkerboard: min η {min:e}");
        let l = 0.9;
        let k = std::f64::consts::PI / l;
        let smooth: Vec<DVec2> = x0
            .iter()
            .map(|x| DVec2::X * delta * (k * x.x).sin())
            .collect();
        let grad: Vec<DMat2> = x0
            .iter()
            .map(|x| DMat2::IDENTITY + D2::outer(DVec2::X, DVec2::X * delta * k * (k * x.x).cos()))
            .collect();
        let eta = hg.of::<D2>(&x0, &smooth, &grad);
        let max = eta.iter().fold(0.0_f64, |m, &e| m.max(e));
        assert!(max < 0.05 * min, "smooth: max η {max:e} against {min:e}");
    }
}
