//! A pressure-oscillation indicator for the VTU frames and the time series: how far each
//! particle's pressure p = −tr σ/3 is from the linear fit of the pressure over its
//! reference neighbourhood,
//! δp_a = p_a − Σ_b Ψ_b(X_a) p_b,
//! with Ψ the reproducing kernel with a linear basis on the case's kernel (self included;
//! [`crate::core::correction::reproducing_shapes`]), and over the body the number
//! ‖δp‖ / ‖p‖ = sqrt(Σ_a V_a δp_a²) / sqrt(Σ_a V_a p_a²).
//! δp vanishes for every pressure field linear in X (up to boundaries), is O(Δx² |∇∇p|)
//! for a smooth one and O(|p|) for a checkerboard, the spurious pressure mode of seed 003
//! §7.2 that D(J) removes.

use crate::core::correction::reproducing_shapes;
use crate::core::kernel::Kernel;
use crate::core::neighbour::{self, Csr, Reach};
use crate::core::tensor::Dim;
use rayon::prelude::*;

/// The linear-fit weights Ψ_b(X_a) of every particle: its own first, then its
/// neighbours' in list order.
pub struct PressureFit {
    csr: Csr,
    own: Vec<f64>,
    psi: Vec<f64>,
}

impl PressureFit {
    /// The weights on reference positions x0 of particles of bodies `body`; neighbours
    /// are of one body only. A particle whose neighbours do not span a linear field (too
    /// few, or all on a line) is its own fit, δp = 0.
    pub fn new<D: Dim>(kernel: &Kernel, x0: &[D::V], body: &[u32]) -> Self {
        let csr = neighbour::build_within::<D>(x0, Reach::Uniform(kernel.support()), Some(body));
        let unit = vec![1.0; x0.len()];
        let rows: Vec<(f64, Vec<f64>)> = (0..x0.len())
            .into_par_iter()
            .map(|a| {
                let mut nodes = vec![a as u32];
                nodes.extend_from_slice(csr.neighbours(a));
                match reproducing_shapes::<D>(x0[a], &nodes, x0, &unit, kernel) {
                    Some(shapes) => (shapes[0].0, shapes[1..].iter().map(|s| s.0).collect()),
                    None => (1.0, vec![0.0; nodes.len() - 1]),
                }
            })
            .collect();
        let own = rows.iter().map(|r| r.0).collect();
        let psi = rows.into_iter().flat_map(|r| r.1).collect();
        Self { csr, own, psi }
    }

    /// δp_a of every particle for the pressures p.
    pub fn deviation(&self, p: &[f64]) -> Vec<f64> {
        (0..self.csr.len())
            .into_par_iter()
            .map(|a| {
                let fit = self.own[a] * p[a]
                    + self
                        .csr
                        .range(a)
                        .map(|q| self.psi[q] * p[self.csr.ids[q] as usize])
                        .sum::<f64>();
                p[a] - fit
            })
            .collect()
    }
}

/// p = −tr σ/3 of every particle.
pub fn pressures(sigma: &[[[f64; 3]; 3]]) -> Vec<f64> {
    sigma
        .iter()
        .map(|s| -(s[0][0] + s[1][1] + s[2][2]) / 3.0)
        .collect()
}

/// ‖δp‖ / ‖p‖ with the volumes V: 0 where p vanishes everywhere.
pub fn oscillation(deviation: &[f64], p: &[f64], volume: &[f64]) -> f64 {
    let norm = |f: &[f64]| {
        f.iter()
            .zip(volume)
            .map(|(x, v)| v * x * x)
            .sum::<f64>()
            .sqrt()
    };
    let scale = norm(p);
    match scale > 0.0 {
        true => norm(deviation) / scale,
        false => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tensor::D2;
    use crate::scene::Scene;
    use glam::DVec2;

    fn plate(n: usize) -> (Scene, Vec<DVec2>) {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/swinging-plate.toml");
        let case = Scene::load(&path, &["spacing=0.1".to_string()]).unwrap();
        let dx = case.spacing;
        let x0 = (0..n * n)
            .map(|k| DVec2::new((k % n) as f64, (k / n) as f64) * dx)
            .collect();
        (case, x0)
    }

    #[test]
    fn vanishes_for_a_linear_pressure_and_flags_a_checkerboard() {
        let n = 12;
        let (case, x0) = plate(n);
        let fit = PressureFit::new::<D2>(&case.kernel(2), &x0, &vec![0; x0.len()]);
        let volume = vec![1.0; x0.len()];
        // Linear in X, boundary included: the reproducing kernel is exact for it, so δp is
        // the round-off of the moment-matrix solve and of O(10) products, asserted below
        // 1e-12 of ‖p‖.
        let linear: Vec<f64> = x0
            .iter()
            .map(|x| 1e6 * (1.0 + 3.0 * x.x - 2.0 * x.y))
            .collect();
        let d = fit.deviation(&linear);
        assert!(
            oscillation(&d, &linear, &volume) < 1e-12,
            "linear: {:e}",
            oscillation(&d, &linear, &volume)
        );
        // A checkerboard on a uniform pressure: p = p0 (1 + (−1)^(i+j)/2). The fit
        // averages the two colours, so |δp| ≈ p0/2 wherever the neighbourhood is
        // balanced; over the field ‖δp‖/‖p‖ is O(1) (asserted above 0.25).
        let checker: Vec<f64> = (0..x0.len())
            .map(|k| 1.0 + if (k % n + k / n) % 2 == 0 { 0.5 } else { -0.5 })
            .collect();
        let d = fit.deviation(&checker);
        let measured = oscillation(&d, &checker, &volume);
        assert!(measured > 0.25, "checkerboard: {measured}");
        // A smooth field of the same amplitude, p = 1 + sin(πX/L)/2 over L = 1.1 m, is
        // O(Δx²/L²) of it: asserted below a tenth of the checkerboard's.
        let k = std::f64::consts::PI / 1.1;
        let smooth: Vec<f64> = x0.iter().map(|x| 1.0 + 0.5 * (k * x.x).sin()).collect();
        let d = fit.deviation(&smooth);
        let smooth = oscillation(&d, &smooth, &volume);
        assert!(
            smooth < 0.1 * measured,
            "smooth: {smooth} against {measured}"
        );
    }

    #[test]
    fn keeps_bodies_apart_and_reads_zero_without_pressure() {
        // Two bodies side by side at different uniform pressures: each fit sees its own
        // body only, so δp is round-off (it would be O(1) at the interface otherwise).
        let n = 8;
        let (case, x0) = plate(n);
        let body: Vec<u32> = x0.iter().map(|x| (x.x > 0.35) as u32).collect();
        let fit = PressureFit::new::<D2>(&case.kernel(2), &x0, &body);
        let p: Vec<f64> = body.iter().map(|&b| 1.0 + 9.0 * b as f64).collect();
        let d = fit.deviation(&p);
        assert!(d.iter().all(|x| x.abs() < 1e-12), "{d:?}");
        assert_eq!(
            oscillation(&d, &vec![0.0; p.len()], &vec![1.0; p.len()]),
            0.0
        );
    }
}
