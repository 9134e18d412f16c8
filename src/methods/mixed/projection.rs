//! The angular-momentum-preserving projection of seed 003 Appendix B.

use crate::core::parallel::MIN_CHUNK;
use crate::core::sum::{Exact, Ranks, par_sums};
use crate::core::tensor::Dim;
use rayon::prelude::*;

/// The balance of a per-volume force field f_a about the points 𝒳_a (seed 003 eqs
/// B.2–B.5): f̂_a = f_a + λ × (𝒳_a − c) + μ removes its net force and moment. With the
/// V-weighted centroid c the 6×6 system of eq B.4 decouples into μ = −Σ V f / Σ V and
/// I_c λ = −Σ V r × f, I_c = Σ V (|r|² I − r ⊗ r), r = 𝒳 − c; c and I_c⁻¹ depend on the
/// points only and serve every field projected about them.
///
/// The sums are exact ([`Exact`]) over the counted particles, completed over the ranks
/// that share them: the projection has the same bits on any number of threads or ranks.
pub struct Balance<'a, D: Dim> {
    points: &'a [D::V],
    vol: &'a [f64],
    counted: &'a [bool],
    ranks: &'a dyn Ranks,
    total_vol: f64,
    centroid: D::V,
    /// I_c⁻¹ (2D: only the zz entry, 1/Σ V |r|², is used).
    inertia_inv: glam::DMat3,
}

/// The exact sums of the K components of map(a) over the counted particles a, completed
/// over the ranks.
fn sums<const K: usize>(
    counted: &[bool],
    ranks: &dyn Ranks,
    map: impl Fn(usize) -> [f64; K] + Sync,
) -> [f64; K] {
    let mut s = par_sums(
        counted.len(),
        |a| if counted[a] { map(a) } else { [0.0; K] },
    );
    ranks.add_others(&mut s);
    s.each_ref().map(Exact::value)
}

impl<'a, D: Dim> Balance<'a, D> {
    pub fn new(
        points: &'a [D::V],
        vol: &'a [f64],
        counted: &'a [bool],
        ranks: &'a dyn Ranks,
    ) -> Self {
        let [total_vol, vx, vy, vz] = sums(counted, ranks, |a| {
            let x = D::to3(points[a]);
            [vol[a], vol[a] * x[0], vol[a] * x[1], vol[a] * x[2]]
        });
        let centroid = D::from_slice(&[vx, vy, vz]) * (1.0 / total_vol);
        // Σ V (|r|² I − r ⊗ r): xx, yy, zz, xy, xz, yz.
        let [xx, yy, zz, xy, xz, yz] = sums(counted, ranks, |a| {
            let [x, y, z] = D::to3(points[a] - centroid);
            let v = vol[a];
            [
                v * (y * y + z * z),
                v * (x * x + z * z),
                v * (x * x + y * y),
                -v * x * y,
                -v * x * z,
                -v * y * z,
            ]
        });
        let inertia_inv = if D::N == 2 {
            glam::DMat3::from_diagonal(glam::DVec3::new(0.0, 0.0, 1.0 / zz))
        } else {
            glam::DMat3::from_cols_array(&[xx, xy, xz, xy, yy, yz, xz, yz, zz]).inverse()
        };
        Self {
            points,
            vol,
            counted,
            ranks,
            total_vol,
            centroid,
            inertia_inv,
        }
    }

    /// Projects f in place.
    pub fn project(&self, f: &mut [D::V]) {
        let (points, vol, c) = (self.points, self.vol, self.centroid);
        let [fx, fy, fz, mx, my, mz] = sums(self.counted, self.ranks, |a| {
            let [x, y, z] = D::to3(f[a] * vol[a]);
            let [u, v, w] = D::cross3(points[a] - c, f[a]);
            [x, y, z, u * vol[a], v * vol[a], w * vol[a]]
        });
        let mu = D::from_slice(&[fx, fy, fz]) * (-1.0 / self.total_vol);
        let lambda = -(self.inertia_inv * glam::DVec3::new(mx, my, mz));
        f.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(points)
            .for_each(|(f, &x)| {
                let turn = lambda.cross(glam::DVec3::from_array(D::to3(x - c)));
                *f += D::from_slice(&turn.to_array()) + mu;
            });
    }
}
