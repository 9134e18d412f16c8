//! The angular-momentum-preserving projection of seed 003 Appendix B.

use crate::core::parallel::MIN_CHUNK;
use crate::core::tensor::Dim;
use rayon::prelude::*;

/// The per-chunk partial sums of a projection, kept by its owner so that projecting
/// allocates nothing once they have their size.
pub struct Sums<D: Dim> {
    inertia: Vec<glam::DMat3>,
    moments: Vec<(D::V, glam::DVec3)>,
}

impl<D: Dim> Default for Sums<D> {
    fn default() -> Self {
        Self {
            inertia: Vec::new(),
            moments: Vec::new(),
        }
    }
}

/// The sum of map(0..n) in fixed chunks of [`MIN_CHUNK`], folded in order (the chunks
/// and order of `parallel::ordered_reduce`, so the same bits), the chunks' sums kept in
/// `chunks`.
fn reduce_in<T: Copy + Send>(
    chunks: &mut Vec<T>,
    n: usize,
    identity: impl Fn() -> T + Sync,
    map: impl Fn(usize) -> T + Sync,
    add: impl Fn(T, T) -> T + Sync,
) -> T {
    chunks.resize_with(n.div_ceil(MIN_CHUNK), &identity);
    chunks.par_iter_mut().enumerate().for_each(|(c, sum)| {
        *sum = (c * MIN_CHUNK..n.min((c + 1) * MIN_CHUNK))
            .map(&map)
            .fold(identity(), &add);
    });
    chunks.iter().fold(identity(), |x, &y| add(x, y))
}

/// The balance of a per-volume force field f_a about the points 𝒳_a (seed 003 eqs
/// B.2–B.5): f̂_a = f_a + λ × (𝒳_a − c) + μ removes its net force and moment. With the
/// V-weighted centroid c the 6×6 system of eq B.4 decouples into μ = −Σ V f / Σ V and
/// I_c λ = −Σ V r × f, I_c = Σ V (|r|² I − r ⊗ r), r = 𝒳 − c; c and I_c⁻¹ depend on the
/// points only and serve every field projected about them.
pub struct Balance<'a, D: Dim> {
    points: &'a [D::V],
    vol: &'a [f64],
    total_vol: f64,
    centroid: D::V,
    /// I_c⁻¹ (2D: only the zz entry, 1/Σ V |r|², is used).
    inertia_inv: glam::DMat3,
}

impl<'a, D: Dim> Balance<'a, D> {
    pub fn new(points: &'a [D::V], vol: &'a [f64], sums: &mut Sums<D>) -> Self {
        let total_vol: f64 = vol.iter().sum();
        let centroid = points
            .iter()
            .zip(vol)
            .fold(D::zero(), |c, (&x, &v)| c + x * v)
            * (1.0 / total_vol);
        let inertia = reduce_in(
            &mut sums.inertia,
            points.len(),
            || glam::DMat3::ZERO,
            |a| {
                let r = glam::DVec3::from_array(D::to3(points[a] - centroid));
                (glam::DMat3::IDENTITY * r.length_squared()
                    - glam::DMat3::from_cols(r * r.x, r * r.y, r * r.z))
                    * vol[a]
            },
            |x, y| x + y,
        );
        let inertia_inv = if D::N == 2 {
            glam::DMat3::from_diagonal(glam::DVec3::new(0.0, 0.0, 1.0 / inertia.z_axis.z))
        } else {
            inertia.inverse()
        };
        Self {
            points,
            vol,
            total_vol,
            centroid,
            inertia_inv,
        }
    }

    /// Projects f in place.
    pub fn project(&self, f: &mut [D::V], sums: &mut Sums<D>) {
        let (points, vol, c) = (self.points, self.vol, self.centroid);
        let (net, moment) = reduce_in(
            &mut sums.moments,
            f.len(),
            || (D::zero(), glam::DVec3::ZERO),
            |a| {
                let m = glam::DVec3::from_array(D::cross3(points[a] - c, f[a]));
                (f[a] * vol[a], m * vol[a])
            },
            |x, y| (x.0 + y.0, x.1 + y.1),
        );
        let mu = net * (-1.0 / self.total_vol);
        let lambda = -(self.inertia_inv * moment);
        f.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(points)
            .for_each(|(f, &x)| {
                let turn = lambda.cross(glam::DVec3::from_array(D::to3(x - c)));
                *f += D::from_slice(&turn.to_array()) + mu;
            });
    }
}
