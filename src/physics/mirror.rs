//! Symmetry and skew-symmetry planes closed by mirror (ghost) particles.
//!
//! Every real particle within a kernel support of a plane gets a ghost at its mirror
//! image; near an edge or corner where planes of different normals meet, the composed
//! images are added too, so that every real particle sees a full support. A ghost
//! carries its source's fields through the image M: X' = R X + c with R the reflection
//! (diagonal, entries ±1), and u' = S u with S = σR, σ = −1 for each skew-symmetric
//! plane in the composition. Hence
//!
//! - vectors (u, v, p): v' = σ R v;
//! - reference gradients of a scalar: g' = R g;
//! - two-point tensors that vanish at rest (P, ∇0v): T' = σ R T R;
//! - maps that are the identity at rest (F, H): G' = I + σ R (G − I) R, J' = 1 + σ(J − 1).
//!
//! A symmetric plane is an exact mirror for every isotropic model (σ = 1 gives
//! P(RFR) = R P(F) R); a skew-symmetric plane, u_t = 0 with zero normal traction, is
//! exact for the linear response and its first-order continuation otherwise.
//!
//! Ghosts are indexed after the n real particles: extended index n + k is ghost k.

use crate::core::check::Problem;
use crate::core::neighbour::Csr;
use crate::core::parallel::MIN_CHUNK;
use crate::core::tensor::{Axis, Dim};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::marker::PhantomData;

/// A plane X_k = `at` across which the solution continues as its mirror image: for
/// `symmetric`, u'(X') = R u(X) (normal displacement zero on the plane); for
/// `skew-symmetric`, u'(X') = −R u(X) (tangential displacement zero), R the reflection.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MirrorSpec {
    pub normal: Axis,
    pub at: f64,
    pub kind: MirrorKind,
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum MirrorKind {
    Symmetric,
    SkewSymmetric,
}

/// A composition of reflections in planes of distinct normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Image {
    /// Diagonal of R.
    r: [f64; 3],
    /// −1 per skew-symmetric plane in the composition.
    sigma: f64,
}

impl Image {
    /// R g.
    pub fn reflect<D: Dim>(&self, g: D::V) -> D::V {
        let mut c = [0.0; 3];
        for (k, c) in c.iter_mut().enumerate().take(D::N) {
            *c = self.r[k] * D::comp(g, k);
        }
        D::from_slice(&c[..D::N])
    }

    /// σ R v.
    pub fn vector<D: Dim>(&self, v: D::V) -> D::V {
        self.reflect::<D>(v) * self.sigma
    }

    /// σ R T R.
    pub fn tensor<D: Dim>(&self, t: D::T) -> D::T {
        let r = (0..D::N).fold(D::zero_t(), |acc, k| {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            let e = D::from_slice(&e[..D::N]);
            acc + D::outer(e, e) * self.r[k]
        });
        r * t * r * self.sigma
    }

    /// I + σ R (G − I) R.
    pub fn unit_tensor<D: Dim>(&self, g: D::T) -> D::T {
        D::identity() + self.tensor::<D>(g - D::identity())
    }

    /// σ s: the image of a scalar that changes sign with the stress, as the pressure.
    pub fn scalar(&self, s: f64) -> f64 {
        self.sigma * s
    }

    /// 1 + σ (J − 1).
    pub fn unit_scalar(&self, j: f64) -> f64 {
        1.0 + self.sigma * (j - 1.0)
    }

    /// The sign of ∂/∂X_l under the image: r_l.
    pub fn axis_sign(&self, l: usize) -> f64 {
        self.r[l]
    }
}

/// Read access for the GPU engine (`methods::mixed::gpu`).
#[cfg(feature = "gpu")]
impl Image {
    /// σ: −1 per skew-symmetric plane in the composition.
    pub(crate) fn sign(&self) -> f64 {
        self.sigma
    }
}

/// The mirror images of the real particles of a case.
pub struct Ghosts<D: Dim> {
    /// Number of real particles.
    n: usize,
    /// Source (real particle) and image of every ghost.
    source: Vec<u32>,
    image: Vec<u8>,
    /// Images by plane subset (bit i: `mirror.i`); `None` for subsets with two planes of
    /// the same normal.
    images: Vec<Option<Image>>,
    /// Extended index of the ghost of each (source, plane subset).
    index: HashMap<(u32, u8), u32>,
    /// Reference positions and volumes of the ghosts.
    x0: Vec<D::V>,
    vol: Vec<f64>,
    /// Per plane: its axis, position and the sign of the body's side (+1 above).
    planes: Vec<(usize, f64, f64)>,
    _dim: PhantomData<D>,
}

impl<D: Dim> Ghosts<D> {
    /// Ghosts of the real particles x0 (volumes vol, spacing Δx) within `radius` of the
    /// `planes`. Errors name the plane when a particle lies on it, when the body lies on
    /// both of its sides, or when a particle is within `radius` of two parallel planes.
    pub fn build(
        planes: &[MirrorSpec],
        spacing: f64,
        x0: &[D::V],
        vol: &[f64],
        radius: f64,
    ) -> Result<Self, Problem> {
        let tol = 1e-6 * spacing;
        // Signed distance of every particle to every plane, oriented into the body.
        let mut dist = vec![Vec::with_capacity(x0.len()); planes.len()];
        let mut sides = Vec::with_capacity(planes.len());
        for (i, plane) in planes.iter().enumerate() {
            let key = format!("mirror.{i}.at");
            let k = plane.normal.index();
            let signed: Vec<f64> = x0.iter().map(|&x| D::comp(x, k) - plane.at).collect();
            if let Some(a) = signed.iter().position(|s| s.abs() <= tol) {
                return Err((
                    key,
                    format!(
                        "particle {a} at {:?} lies on the plane; ghosts need the plane to pass \
                         between particles: give the box `lattice = \"cell-centred\"` or move \
                         the plane by Δx/2",
                        D::to3(x0[a])
                    ),
                ));
            }
            let below = signed.iter().filter(|s| **s < 0.0).count();
            if below != 0 && below != signed.len() {
                return Err((
                    key,
                    format!(
                        "the particles lie on both sides of the plane {} = {} ({below} below, \
                         {} above); a mirror plane must bound the body",
                        ["x", "y", "z"][k],
                        plane.at,
                        signed.len() - below
                    ),
                ));
            }
            dist[i] = signed.iter().map(|s| s.abs()).collect();
            let side = if below == 0 { 1.0 } else { -1.0 };
            sides.push((k, plane.at, side));
        }
        for (i, p) in planes.iter().enumerate() {
            for (j, q) in planes.iter().enumerate().skip(i + 1) {
                let both = (0..x0.len()).find(|&a| dist[i][a] < radius && dist[j][a] < radius);
                if let (true, Some(a)) = (p.normal == q.normal, both) {
                    return Err((
                        format!("mirror.{j}.at"),
                        format!(
                            "particle {a} is within a kernel support ({radius}) of both \
                             mirror.{i} and mirror.{j}; parallel mirror planes must be more \
                             than two supports apart"
                        ),
                    ));
                }
            }
        }
        let images: Vec<Option<Image>> = (0..1usize << planes.len())
            .map(|mask| {
                let mut image = Image {
                    r: [1.0; 3],
                    sigma: 1.0,
                };
                for (_, plane) in planes
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| mask >> i & 1 == 1)
                {
                    let k = plane.normal.index();
                    if image.r[k] < 0.0 {
                        return None;
                    }
                    image.r[k] = -1.0;
                    if plane.kind == MirrorKind::SkewSymmetric {
                        image.sigma = -image.sigma;
                    }
                }
                Some(image)
            })
            .collect();
        let n = x0.len();
        let mut ghosts = Self {
            n,
            source: Vec::new(),
            image: Vec::new(),
            images,
            index: HashMap::new(),
            x0: Vec::new(),
            vol: Vec::new(),
            planes: sides,
            _dim: PhantomData,
        };
        for mask in 1..ghosts.images.len() {
            if ghosts.images[mask].is_none() {
                continue;
            }
            let in_mask = |i: &usize| mask >> i & 1 == 1;
            for a in 0..n {
                if !(0..planes.len())
                    .filter(in_mask)
                    .all(|i| dist[i][a] < radius)
                {
                    continue;
                }
                let mut x = D::to3(x0[a]);
                for i in (0..planes.len()).filter(in_mask) {
                    let k = planes[i].normal.index();
                    x[k] = 2.0 * planes[i].at - x[k];
                }
                ghosts
                    .index
                    .insert((a as u32, mask as u8), (n + ghosts.source.len()) as u32);
                ghosts.source.push(a as u32);
                ghosts.image.push(mask as u8);
                ghosts.x0.push(D::from_slice(&x[..D::N]));
                ghosts.vol.push(vol[a]);
            }
        }
        Ok(ghosts)
    }

    pub fn is_empty(&self) -> bool {
        self.source.is_empty()
    }

    /// The number of real particles.
    pub fn real(&self) -> usize {
        self.n
    }

    /// The real particle an extended index stands for, and the image it passes through
    /// (None for a real particle).
    pub fn origin(&self, extended: usize) -> (usize, Option<Image>) {
        match extended.checked_sub(self.n) {
            None => (extended, None),
            Some(k) => (self.source[k] as usize, self.images[self.image[k] as usize]),
        }
    }

    /// The signed distance of a point from every plane, positive on the body's side.
    pub fn depths(&self, x: D::V) -> impl Iterator<Item = f64> + '_ {
        (self.planes.iter()).map(move |&(k, at, side)| (D::comp(x, k) - at) * side)
    }

    /// Real then ghost reference positions and volumes.
    pub fn extend_reference(&self, x0: &[D::V], vol: &[f64]) -> (Vec<D::V>, Vec<f64>) {
        (
            x0.iter().chain(&self.x0).copied().collect(),
            vol.iter().chain(&self.vol).copied().collect(),
        )
    }

    /// A per-particle pass over real particles and ghosts: values[a] = real(a) for the
    /// n real particles (in parallel), then every ghost's entry as the image of its
    /// source's through `map`.
    pub fn fill<T: Copy + Send + Sync>(
        &self,
        values: &mut [T],
        real: impl Fn(usize) -> T + Sync,
        map: impl Fn(&Image, T) -> T + Sync,
    ) {
        let (reals, ghost) = values.split_at_mut(self.n);
        reals
            .par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(a, v)| *v = real(a));
        ghost.par_iter_mut().enumerate().for_each(|(k, g)| {
            let image = self.images[self.image[k] as usize].expect("ghost images are valid");
            *g = map(&image, reals[self.source[k] as usize]);
        });
    }

    /// For every pair (a, b) of the real rows of `csr`: the pair whose per-pair reference
    /// data give (b, a), and the image they pass through. For a real b that is (b, a)
    /// itself; for a ghost b = M(c) it is (c, M(a)) in c's row, since the extended cloud
    /// is symmetric under M within a support of the plane. Err(a) where that pair is
    /// missing (a neighbour exactly at the support radius, found on one side only).
    pub fn reverse_pairs(&self, csr: &Csr) -> Result<Vec<(u32, Option<Image>)>, usize> {
        debug_assert_eq!(csr.len(), self.n, "the real rows only");
        csr.map_rows(|a| {
            csr.neighbours(a)
                .iter()
                .map(|&b| {
                    let (row, partner, image) = match (b as usize).checked_sub(self.n) {
                        None => (b as usize, a as u32, None),
                        Some(k) => {
                            let mask = self.image[k];
                            let partner = *self.index.get(&(a as u32, mask)).ok_or(a)?;
                            let image = self.images[mask as usize];
                            (self.source[k] as usize, partner, image)
                        }
                    };
                    let back = csr.neighbours(row).binary_search(&partner).map_err(|_| a)?;
                    Ok(((csr.offsets[row] + back) as u32, image))
                })
                .collect::<Result<Vec<_>, _>>()
        })
    }
}

/// Read access for the GPU engine (`methods::mixed::gpu`).
#[cfg(feature = "gpu")]
impl<D: Dim> Ghosts<D> {
    /// Source (real particle) and image of every ghost, in extended order.
    pub(crate) fn table(&self) -> Vec<(u32, Image)> {
        (self.n..self.n + self.source.len())
            .map(|g| match self.origin(g) {
                (s, Some(m)) => (s as u32, m),
                (_, None) => unreachable!("ghost images are valid"),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tensor::D3;
    use glam::{DMat3, DVec3};

    fn corner() -> Image {
        // Symmetric in x, skew-symmetric in z.
        Image {
            r: [-1.0, 1.0, -1.0],
            sigma: -1.0,
        }
    }

    #[test]
    fn images_map_fields_like_the_continued_solution() {
        let m = corner();
        let v = DVec3::new(1.0, 2.0, 3.0);
        assert_eq!(m.vector::<D3>(v), DVec3::new(1.0, -2.0, 3.0));
        assert_eq!(m.reflect::<D3>(v), DVec3::new(-1.0, 2.0, -3.0));
        // u' = S u(M⁻¹X') with u = A X gives ∇u' = S A R: the tensor map of ∇u.
        let a = DMat3::from_cols_array(&[1., 2., 3., 4., 5., 6., 7., 8., 9.]);
        let s = DMat3::from_diagonal(DVec3::new(1.0, -1.0, 1.0));
        let r = DMat3::from_diagonal(DVec3::new(-1.0, 1.0, -1.0));
        assert_eq!(m.tensor::<D3>(a), s * a * r);
        assert_eq!(
            m.unit_tensor::<D3>(DMat3::IDENTITY + a),
            DMat3::IDENTITY + s * a * r
        );
        assert_eq!(m.unit_scalar(1.25), 0.75);
    }
}
