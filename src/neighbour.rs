//! Cell-list neighbour search producing compressed sparse row (CSR) neighbour lists.

use crate::tensor::Dim;
use rayon::prelude::*;

/// Neighbour lists in CSR form: the neighbours of particle i are
/// `ids[offsets[i]..offsets[i + 1]]`, sorted ascending, the particle itself excluded.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Csr {
    pub offsets: Vec<usize>,
    pub ids: Vec<u32>,
}

impl Csr {
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Pair index range of particle i.
    #[inline]
    pub fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    /// Neighbour ids of particle i.
    #[inline]
    pub fn neighbours(&self, i: usize) -> &[u32] {
        &self.ids[self.range(i)]
    }

    /// Particle i's neighbours j with their entries of a per-pair field, in CSR order.
    #[inline]
    pub fn pairs<'a, T>(
        &'a self,
        i: usize,
        per_pair: &'a [T],
    ) -> impl Iterator<Item = (usize, &'a T)> + 'a {
        let r = self.range(i);
        self.ids[r.clone()]
            .iter()
            .map(|&j| j as usize)
            .zip(&per_pair[r])
    }

    /// Total number of stored (ordered) pairs.
    pub fn pair_count(&self) -> usize {
        self.ids.len()
    }

    /// One value per pair in CSR order: `row(i)` gives the values of row i's pairs, in
    /// order; the rows run in parallel. The first row (in order) that fails fails all.
    pub fn map_rows<T, E, I>(&self, row: impl Fn(usize) -> Result<I, E> + Sync) -> Result<Vec<T>, E>
    where
        T: Default + Clone + Send,
        E: Send,
        I: IntoIterator<Item = T>,
    {
        self.fill_rows(|i, out| {
            for (o, value) in out.iter_mut().zip(row(i)?) {
                *o = value;
            }
            Ok(())
        })
    }

    /// One value per pair in CSR order: `row(i, values)` writes row i's values in place,
    /// in order; the rows run in parallel. The first row (in order) that fails fails all.
    pub fn fill_rows<T: Default + Clone + Send, E: Send>(
        &self,
        row: impl Fn(usize, &mut [T]) -> Result<(), E> + Sync,
    ) -> Result<Vec<T>, E> {
        let mut out = Vec::new();
        self.fill_rows_into(&mut out, row)?;
        Ok(out)
    }

    /// [`Self::fill_rows`] into `out`, resized to one value per pair: a buffer kept from
    /// one evaluation to the next is written once per evaluation, not zeroed first.
    pub fn fill_rows_into<T: Default + Clone + Send, E: Send>(
        &self,
        out: &mut Vec<T>,
        row: impl Fn(usize, &mut [T]) -> Result<(), E> + Sync,
    ) -> Result<(), E> {
        out.resize(self.pair_count(), T::default());
        split_rows(0, &self.offsets, &mut out[..], MIN_ROWS, &row)
    }

    /// Keeps the lists of the first n particles (their ids may still exceed n).
    pub fn truncate(&mut self, n: usize) {
        self.offsets.truncate(n + 1);
        self.ids.truncate(self.offsets[n]);
    }
}

/// Bounding box (lower and upper corner) of points padded to three components.
pub fn bounding_box(points: impl IntoIterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// Uniform grid of cubic cells of edge `cell` over the bounding box of the points,
/// with particles counting-sorted by cell. Its buffers are kept from one sort to the next.
#[derive(Clone, Debug, Default)]
struct CellGrid {
    origin: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    /// `start[c]..start[c + 1]` indexes `sorted` for cell c.
    start: Vec<usize>,
    sorted: Vec<u32>,
    /// The cell of every point.
    cell_of: Vec<usize>,
    /// The next free slot of every cell while sorting.
    cursor: Vec<usize>,
}

impl CellGrid {
    /// Sorts the points into cells of at least `min_cell`, enlarged (which only adds
    /// candidates) while the grid would hold more than max(8n, 4096) cells, so sparse
    /// clouds stay in memory.
    fn sort(&mut self, points: &[[f64; 3]], min_cell: f64, dim: usize) {
        let (lo, hi) = bounding_box(points.iter().copied());
        let budget = (8 * points.len()).max(4096) as f64;
        let count = |cell: f64| {
            (0..dim)
                .map(|k| ((hi[k] - lo[k]) / cell).floor() + 1.0)
                .product::<f64>()
        };
        let mut cell = min_cell;
        while count(cell) > budget {
            cell *= 2.0;
        }
        self.origin = lo;
        self.cell = cell;
        self.dims = [1; 3];
        for k in 0..dim {
            self.dims[k] = (((hi[k] - lo[k]) / cell).floor() as usize) + 1;
        }
        let cells = self.dims.iter().product::<usize>();
        self.start.clear();
        self.start.resize(cells + 1, 0);
        self.cell_of.clear();
        for p in points {
            let c = self.cell_index(p);
            self.cell_of.push(c);
            self.start[c + 1] += 1;
        }
        for c in 0..cells {
            self.start[c + 1] += self.start[c];
        }
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.start[..cells]);
        self.sorted.clear();
        self.sorted.resize(points.len(), 0);
        for (i, &c) in self.cell_of.iter().enumerate() {
            self.sorted[self.cursor[c]] = i as u32;
            self.cursor[c] += 1;
        }
    }

    fn coords(&self, p: &[f64; 3]) -> [usize; 3] {
        let mut c = [0usize; 3];
        for k in 0..3 {
            let f = ((p[k] - self.origin[k]) / self.cell).floor().max(0.0) as usize;
            c[k] = f.min(self.dims[k] - 1);
        }
        c
    }

    fn cell_index(&self, p: &[f64; 3]) -> usize {
        let c = self.coords(p);
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Calls `f(j)` for every point in the 3^d block of cells around `p`.
    fn for_each_candidate(&self, p: &[f64; 3], mut f: impl FnMut(u32)) {
        let c = self.coords(p);
        let range = |k: usize| c[k].saturating_sub(1)..=(c[k] + 1).min(self.dims[k] - 1);
        for z in range(2) {
            for y in range(1) {
                let row = (z * self.dims[1] + y) * self.dims[0];
                let xs = range(0);
                let (a, b) = (row + xs.start(), row + xs.end());
                for &j in &self.sorted[self.start[a]..self.start[b + 1]] {
                    f(j);
                }
            }
        }
    }
}

/// The search radius: one for every particle, or one each (a per-particle smoothing
/// length). A pair is within reach when its distance is at most the larger of its two
/// radii, so every list holds the pair in both directions.
#[derive(Clone, Copy, Debug)]
pub enum Reach<'a> {
    Uniform(f64),
    PerParticle(&'a [f64]),
}

impl Reach<'_> {
    /// The largest radius (the cell size of the search grid).
    fn largest(&self) -> f64 {
        match self {
            Self::Uniform(r) => *r,
            Self::PerParticle(r) => r.iter().copied().fold(0.0, f64::max),
        }
    }

    /// The squared radius of the pair (i, j).
    fn squared(&self, i: usize, j: usize) -> f64 {
        match self {
            Self::Uniform(r) => r * r,
            Self::PerParticle(r) => {
                let r = r[i].max(r[j]);
                r * r
            }
        }
    }
}

/// All pairs (i, j), i ≠ j, with |x_i − x_j| ≤ radius.
pub fn build<D: Dim>(x: &[D::V], radius: f64) -> Csr {
    build_within::<D>(x, Reach::Uniform(radius), None)
}

/// The first pair within `radius` that `counts`: the smallest i with a particle j ≠ i
/// within it for which `counts(i, j)`, and the smallest such j. One pass over the
/// candidates, without lists: the checks for coincident particles and overlapping bodies.
pub fn first_pair<D: Dim>(
    x: &[D::V],
    radius: f64,
    counts: impl Fn(usize, usize) -> bool + Sync,
) -> Option<(usize, u32)> {
    let points: Vec<[f64; 3]> = x.iter().map(|&p| D::to3(p)).collect();
    if points.is_empty() {
        return None;
    }
    let mut grid = CellGrid::default();
    grid.sort(&points, radius, D::N);
    (0..x.len())
        .into_par_iter()
        .with_min_len(MIN_ROWS)
        .find_map_first(|i| {
            let mut nearest: Option<u32> = None;
            grid.for_each_candidate(&points[i], |j| {
                let close = D::norm2(x[i] - x[j as usize]) <= radius * radius;
                if j as usize != i && close && counts(i, j as usize) {
                    nearest = Some(nearest.map_or(j, |k| k.min(j)));
                }
            });
            nearest.map(|j| (i, j))
        })
}

/// All pairs (i, j), i ≠ j, within reach, and with `body` only pairs of one body
/// (body[i] = body[j]: the per-body lists of a method that keeps bodies apart for
/// contact).
pub fn build_within<D: Dim>(x: &[D::V], reach: Reach, body: Option<&[u32]>) -> Csr {
    let mut csr = Csr::default();
    CellList::default().build::<D>(x, reach, body, &mut csr);
    csr
}

/// The lists from a second point set to the particles: for every point q the particles j
/// with |y_q − x_j| ≤ radius and, with `body` = (the points' bodies, the particles'), of
/// the point's body; sorted ascending. A particle at the point itself is kept (the point
/// is not one of the particles).
pub fn between<D: Dim>(
    points: &[D::V],
    x: &[D::V],
    radius: f64,
    body: Option<(&[u32], &[u32])>,
) -> Csr {
    let nodes: Vec<[f64; 3]> = x.iter().map(|&p| D::to3(p)).collect();
    let mut grid = CellGrid::default();
    if !nodes.is_empty() {
        grid.sort(&nodes, radius, D::N);
    }
    let mut csr = Csr::default();
    gather_rows(points.len(), &mut Vec::new(), &mut csr, |q, found| {
        if nodes.is_empty() {
            return;
        }
        let start = found.len();
        grid.for_each_candidate(&D::to3(points[q]), |j| {
            let same_body = body.is_none_or(|(bq, bx)| bq[q] == bx[j as usize]);
            if same_body && D::norm2(points[q] - x[j as usize]) <= radius * radius {
                found.push(j);
            }
        });
        found[start..].sort_unstable();
    });
    csr
}

/// The cell-list search with its buffers, which a method that rebuilds its lists keeps:
/// a build into lists as large as an earlier one allocates nothing.
#[derive(Clone, Debug, Default)]
pub struct CellList {
    points: Vec<[f64; 3]>,
    grid: CellGrid,
    /// The ids found by each chunk of rows of [`gather_rows`].
    found: Vec<Vec<u32>>,
}

/// Rows a task of the parallel fills handles at least, and the rows of a chunk of
/// [`gather_rows`].
const MIN_ROWS: usize = 256;

impl CellList {
    /// Writes into `out` the lists of [`build_within`], in one pass over the candidates
    /// ([`gather_rows`]).
    pub fn build<D: Dim>(&mut self, x: &[D::V], reach: Reach, body: Option<&[u32]>, out: &mut Csr) {
        self.points.clear();
        self.points.extend(x.iter().map(|&p| D::to3(p)));
        if !x.is_empty() {
            self.grid.sort(&self.points, reach.largest(), D::N);
        }
        let (grid, points) = (&self.grid, &self.points);
        let same_body = |i: usize, j: usize| body.is_none_or(|b| b[i] == b[j]);
        gather_rows(x.len(), &mut self.found, out, |i, found| {
            let start = found.len();
            grid.for_each_candidate(&points[i], |j| {
                let k = j as usize;
                if k != i && same_body(i, k) && D::norm2(x[i] - x[k]) <= reach.squared(i, k) {
                    found.push(j);
                }
            });
            found[start..].sort_unstable();
        });
    }
}

/// Lists of `rows` rows into `out`, `row(i, found)` pushing row i's ids onto `found` in
/// the order the lists keep: chunks of [`MIN_ROWS`] rows run in parallel, each into a
/// buffer of `chunks` (kept from one build to the next) while it counts its rows; the
/// counts' prefix sum gives the offsets, and every row is then copied into place. One
/// pass over the candidates, not one to count and one to fill.
fn gather_rows(
    rows: usize,
    chunks: &mut Vec<Vec<u32>>,
    out: &mut Csr,
    row: impl Fn(usize, &mut Vec<u32>) + Sync,
) {
    let Csr { offsets, ids } = out;
    offsets.clear();
    offsets.resize(rows + 1, 0);
    chunks.resize_with(rows.div_ceil(MIN_ROWS), Vec::new);
    offsets[1..]
        .par_chunks_mut(MIN_ROWS)
        .zip(chunks.par_iter_mut())
        .enumerate()
        .for_each(|(c, (counts, found))| {
            found.clear();
            for (k, count) in counts.iter_mut().enumerate() {
                let before = found.len();
                row(c * MIN_ROWS + k, found);
                *count = found.len() - before;
            }
        });
    for i in 0..rows {
        offsets[i + 1] += offsets[i];
    }
    ids.clear();
    ids.resize(offsets[rows], 0);
    let offsets = &*offsets;
    let Ok(()) = split_rows(0, offsets, &mut ids[..], MIN_ROWS, &|i, dst: &mut [u32]| {
        let base = offsets[i / MIN_ROWS * MIN_ROWS];
        let found = &chunks[i / MIN_ROWS];
        dst.copy_from_slice(&found[offsets[i] - base..offsets[i + 1] - base]);
        Ok::<(), std::convert::Infallible>(())
    });
}

/// Storage of rows that splits at a row boundary: per-pair values, or several fields of
/// the same rows together (see [`split_rows`]).
pub(crate) trait Rows: Send + Sized {
    /// The first `rows` rows, which hold `pairs` pairs, and the rest.
    fn split_at(self, rows: usize, pairs: usize) -> (Self, Self);
}

impl<T: Send> Rows for &mut [T] {
    fn split_at(self, _rows: usize, pairs: usize) -> (Self, Self) {
        self.split_at_mut(pairs)
    }
}

/// Calls `fill(i, row)` for every row of `values` (rows `first..` with the offsets
/// `offsets`, which start at the first row's), splitting the rows in halves in parallel
/// down to `min_rows`. Every row is filled; the error is the first row's (in order) that
/// failed.
pub(crate) fn split_rows<V: Rows, E: Send>(
    first: usize,
    offsets: &[usize],
    values: V,
    min_rows: usize,
    fill: &(impl Fn(usize, V) -> Result<(), E> + Sync),
) -> Result<(), E> {
    let rows = offsets.len() - 1;
    if rows <= min_rows {
        let mut rest = values;
        let mut first_error = Ok(());
        for r in 0..rows {
            let (row, tail) = rest.split_at(1, offsets[r + 1] - offsets[r]);
            rest = tail;
            first_error = first_error.and(fill(first + r, row));
        }
        return first_error;
    }
    let mid = rows / 2;
    let (a, b) = values.split_at(mid, offsets[mid] - offsets[0]);
    let (a, b) = rayon::join(
        || split_rows(first, &offsets[..=mid], a, min_rows, fill),
        || split_rows(first + mid, &offsets[mid..], b, min_rows, fill),
    );
    a.and(b)
}

/// When a method's neighbour lists are built: the method declares it
/// ([`crate::methods::MethodFamily::NEIGHBOURS`]) and holds its lists as [`Neighbours`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rebuild {
    /// Once, on the reference configuration (total-Lagrangian methods).
    Once,
    /// From the current positions at every rate evaluation (updated-Lagrangian methods).
    EveryStage,
    /// From the current positions, each reach widened by the skin [`SKIN`]·reach, and
    /// again only once some particle has moved more than half the smallest skin since: the
    /// lists then hold every pair within reach of the current positions (and pairs up to
    /// the skin beyond, whose kernel terms vanish), in the order `EveryStage` gives them.
    OnDrift,
}

/// The skin of [`Rebuild::OnDrift`], a fraction of each particle's reach.
pub const SKIN: f64 = 0.1;

/// A method's neighbour lists, kept by its [`Rebuild`] policy: the reach of every
/// particle, the body masks, and the cell list that rebuilds them with its buffers.
#[derive(Clone, Debug)]
pub struct Neighbours {
    rebuild: Rebuild,
    /// The reach of every particle, widened by the skin with [`Rebuild::OnDrift`].
    reach: Vec<f64>,
    body: Option<Vec<u32>>,
    search: CellList,
    lists: Csr,
    /// [`Rebuild::OnDrift`]: the positions of the last build (DIM floats each, as 3D).
    built_at: Vec<[f64; 3]>,
    /// [`Rebuild::OnDrift`]: the largest displacement since the last build that keeps its
    /// lists complete (half the smallest skin).
    drift: f64,
    /// Wall time of [`Self::update`] since the lists were made (drift checks and rebuilds).
    seconds: f64,
}

impl Neighbours {
    /// The lists of positions x, each particle reaching `reach`, and with `body` only
    /// pairs of one body.
    pub fn new<D: Dim>(
        rebuild: Rebuild,
        x: &[D::V],
        reach: Vec<f64>,
        body: Option<Vec<u32>>,
    ) -> Self {
        let widen = if rebuild == Rebuild::OnDrift {
            1.0 + SKIN
        } else {
            1.0
        };
        let drift = 0.5 * SKIN * reach.iter().copied().fold(f64::INFINITY, f64::min);
        let mut n = Self {
            rebuild,
            reach: reach.iter().map(|r| r * widen).collect(),
            body,
            search: CellList::default(),
            lists: Csr::default(),
            built_at: Vec::new(),
            drift,
            seconds: 0.0,
        };
        n.rebuild::<D>(x);
        n
    }

    /// At a rate evaluation with positions x: rebuilds the lists if the policy asks for
    /// it; returns whether it did.
    pub fn update<D: Dim>(&mut self, x: &[D::V]) -> bool {
        let started = std::time::Instant::now();
        let rebuilt = self.follow::<D>(x);
        self.seconds += started.elapsed().as_secs_f64();
        rebuilt
    }

    /// Wall time spent in [`Self::update`] since the lists were made [s].
    pub fn seconds(&self) -> f64 {
        self.seconds
    }

    fn follow<D: Dim>(&mut self, x: &[D::V]) -> bool {
        match self.rebuild {
            Rebuild::Once => false,
            Rebuild::EveryStage => {
                self.rebuild::<D>(x);
                true
            }
            Rebuild::OnDrift => {
                let moved = |(p, q): (&D::V, &[f64; 3])| {
                    let p = D::to3(*p);
                    let d2: f64 = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum();
                    d2.is_nan() || d2 > self.drift * self.drift
                };
                let rebuild = x.iter().zip(&self.built_at).any(moved);
                if rebuild {
                    self.rebuild::<D>(x);
                }
                rebuild
            }
        }
    }

    fn rebuild<D: Dim>(&mut self, x: &[D::V]) {
        let reach = Reach::PerParticle(&self.reach);
        self.search
            .build::<D>(x, reach, self.body.as_deref(), &mut self.lists);
        if self.rebuild == Rebuild::OnDrift {
            self.built_at.clear();
            self.built_at.extend(x.iter().map(|&p| D::to3(p)));
        }
    }

    /// The current lists.
    pub fn lists(&self) -> &Csr {
        &self.lists
    }

    /// The lists, for a method that keeps them alone.
    pub fn into_lists(self) -> Csr {
        self.lists
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tensor::{D2, D3};
    use glam::DVec2;

    /// Deterministic pseudo-random numbers in [0, 1) (64-bit LCG), so tests need no RNG crate.
    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// n pseudo-random points in the box [0, extent_k], k < D::N, drawn from `seed`.
    fn cloud<D: Dim>(n: usize, extent: &[f64], seed: &mut u64) -> Vec<D::V> {
        (0..n)
            .map(|_| D::from_slice(&extent.iter().map(|e| lcg(seed) * e).collect::<Vec<_>>()))
            .collect()
    }

    fn brute<D: Dim>(x: &[D::V], radius: f64) -> Vec<Vec<u32>> {
        (0..x.len())
            .map(|i| {
                (0..x.len() as u32)
                    .filter(|&j| {
                        j as usize != i && D::norm2(x[i] - x[j as usize]) <= radius * radius
                    })
                    .collect()
            })
            .collect()
    }

    fn check<D: Dim>(x: &[D::V], radius: f64) {
        let csr = build::<D>(x, radius);
        let reference = brute::<D>(x, radius);
        assert_eq!(csr.len(), x.len());
        for (i, expected) in reference.iter().enumerate() {
            assert_eq!(csr.neighbours(i), expected.as_slice(), "particle {i}");
        }
    }

    #[test]
    fn cell_list_equals_brute_force_2d() {
        let mut s = 7;
        let random = cloud::<D2>(600, &[3.0, 1.0], &mut s);
        check::<D2>(&random, 0.13);
        let lattice: Vec<DVec2> = (0..400)
            .map(|k| DVec2::new((k % 20) as f64 * 0.1, (k / 20) as f64 * 0.1))
            .collect();
        // Radius exactly on lattice distances (2 dx): ties must be included on both sides.
        check::<D2>(&lattice, 0.2);
    }

    #[test]
    fn cell_list_equals_brute_force_3d() {
        let mut s = 11;
        let random = cloud::<D3>(700, &[1.0, 2.0, 1.0], &mut s);
        check::<D3>(&random, 0.21);
    }

    #[test]
    fn per_particle_reach_and_body_masks_equal_brute_force() {
        // Random radii between 0.05 and 0.2 (a pair within the larger of its two radii)
        // and three bodies: the lists are the brute-force ones, and symmetric.
        let mut s = 5;
        let x = cloud::<D2>(500, &[2.0, 1.0], &mut s);
        let radius: Vec<f64> = (0..x.len()).map(|_| 0.05 + 0.15 * lcg(&mut s)).collect();
        let body: Vec<u32> = (0..x.len() as u32).map(|i| i % 3).collect();
        for mask in [None, Some(body.as_slice())] {
            let csr = build_within::<D2>(&x, Reach::PerParticle(&radius), mask);
            for i in 0..x.len() {
                let expected: Vec<u32> = (0..x.len() as u32)
                    .filter(|&j| {
                        let j = j as usize;
                        let r = radius[i].max(radius[j]);
                        j != i
                            && mask.is_none_or(|b| b[i] == b[j])
                            && (x[i] - x[j]).length_squared() <= r * r
                    })
                    .collect();
                assert_eq!(csr.neighbours(i), expected.as_slice(), "particle {i}");
                for &j in csr.neighbours(i) {
                    assert!(csr.neighbours(j as usize).contains(&(i as u32)));
                }
            }
        }
        // Equal radii give the uniform search's lists.
        let uniform = vec![0.13; x.len()];
        assert_eq!(
            build_within::<D2>(&x, Reach::PerParticle(&uniform), None),
            build::<D2>(&x, 0.13)
        );
    }

    #[test]
    fn a_rebuild_reuses_its_buffers_and_follows_the_particles() {
        // Particles shuffled by up to twice the radius between rebuilds: every rebuild
        // gives the brute-force lists of the current positions, and once the lists have
        // reached their largest size the rebuilds allocate nothing (the pair buffer stays
        // where it is: the first rebuild is of the cloud squeezed to half its size, with
        // about four times the pairs of any later one). `Once` keeps the first lists
        // whatever the particles do.
        let mut s = 23;
        let x0 = cloud::<D2>(500, &[2.0, 1.0], &mut s);
        let radius = 0.1;
        let reach = vec![radius; x0.len()];
        let mut every = Neighbours::new::<D2>(Rebuild::EveryStage, &x0, reach.clone(), None);
        let once = Neighbours::new::<D2>(Rebuild::Once, &x0, reach, None);
        let mut kept = once.clone();
        let squeezed: Vec<DVec2> = x0.iter().map(|&p| p * 0.5).collect();
        every.update::<D2>(&squeezed);
        let capacity = every.lists().ids.capacity();
        let pairs = every.lists().ids.as_ptr();
        for _ in 0..4 {
            let x: Vec<DVec2> = x0
                .iter()
                .map(|&p| p + DVec2::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5) * 4.0 * radius)
                .collect();
            assert!(every.update::<D2>(&x));
            let expected = brute::<D2>(&x, radius);
            for (i, e) in expected.iter().enumerate() {
                assert_eq!(every.lists().neighbours(i), e.as_slice(), "particle {i}");
            }
            assert!(every.lists().pair_count() <= capacity);
            assert_eq!(every.lists().ids.as_ptr(), pairs, "the pair buffer moved");
            assert!(!kept.update::<D2>(&x));
            assert_eq!(kept.lists(), once.lists());
        }
    }

    #[test]
    fn drift_lists_hold_every_pair_in_reach_and_rebuild_only_past_the_skin() {
        // Particles moved in small random steps: after every update the drift lists hold
        // each pair within the radius of the current positions (brute force), with the
        // extra pairs no farther than radius·(1 + SKIN) + 2·drift; the lists are rebuilt
        // only when some particle moved more than half the skin since the last build.
        let mut s = 29;
        let mut x = cloud::<D2>(400, &[2.0, 1.0], &mut s);
        let radius = 0.1;
        let mut drift = Neighbours::new::<D2>(Rebuild::OnDrift, &x, vec![radius; 400], None);
        let mut since = vec![DVec2::ZERO; x.len()];
        let (mut rebuilds, mut kept) = (0, 0);
        for _ in 0..60 {
            for (p, m) in x.iter_mut().zip(&mut since) {
                let step = DVec2::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5) * 0.002;
                *p += step;
                *m += step;
            }
            let far = since.iter().any(|m| m.length() > 0.5 * SKIN * radius);
            let rebuilt = drift.update::<D2>(&x);
            assert_eq!(
                rebuilt, far,
                "rebuilt exactly when a particle left the skin"
            );
            if rebuilt {
                since.iter_mut().for_each(|m| *m = DVec2::ZERO);
                rebuilds += 1;
            } else {
                kept += 1;
            }
            for (i, within) in brute::<D2>(&x, radius).iter().enumerate() {
                let listed = drift.lists().neighbours(i);
                assert!(within.iter().all(|j| listed.contains(j)), "particle {i}");
                assert!(listed.windows(2).all(|w| w[0] < w[1]), "sorted ids");
            }
        }
        assert!(
            rebuilds > 2 && kept > 10,
            "{rebuilds} rebuilds, {kept} kept"
        );
    }

    #[test]
    fn sparse_clouds_use_a_bounded_grid() {
        // Two clusters 1e6 radii apart: a grid of radius-sized cells would need 1e12 cells.
        let mut s = 3;
        let x: Vec<DVec2> = (0..400)
            .map(|k| {
                let shift = if k % 2 == 0 { 0.0 } else { 1e5 };
                DVec2::new(shift + lcg(&mut s), lcg(&mut s))
            })
            .collect();
        check::<D2>(&x, 0.1);
    }

    #[test]
    fn interior_lattice_counts_match_the_seed() {
        // Seed 000 §1.1: inside r ≤ 2h with h/dx = 1.3 an interior particle has 21 points
        // (self included), with h/dx = 1.7 it has 37.
        let x: Vec<DVec2> = (0..441)
            .map(|k| DVec2::new((k % 21) as f64, (k / 21) as f64))
            .collect();
        let centre = 220;
        assert_eq!(build::<D2>(&x, 2.6).neighbours(centre).len() + 1, 21);
        assert_eq!(build::<D2>(&x, 3.4).neighbours(centre).len() + 1, 37);
    }

    #[test]
    fn the_first_pair_is_the_brute_force_first_pair() {
        // A random cloud with a few points repeated: the first pair, in row order then
        // neighbour order, of the brute-force lists, and none without the repeats.
        let mut s = 11;
        let mut x = cloud::<D2>(2000, &[1.0, 1.0], &mut s);
        let any = |_: usize, _: usize| true;
        assert_eq!(first_pair::<D2>(&x, 1e-9, any), None);
        x[1700] = x[1500];
        x[900] = x[1900];
        x[1200] = x[900];
        let radius = 1e-9;
        let expected = brute::<D2>(&x, radius)
            .iter()
            .enumerate()
            .find_map(|(i, row)| row.first().map(|&j| (i, j)));
        assert_eq!(expected, Some((900, 1200)));
        assert_eq!(first_pair::<D2>(&x, radius, any), expected);
        // Of the pairs that count: with (900, 1200) left out, the next in row order.
        let not_900 = |i: usize, j: usize| i != 900 && j != 900;
        assert_eq!(first_pair::<D2>(&x, radius, not_900), Some((1200, 1900)));
    }

    #[test]
    fn rows_fill_in_place_and_the_first_failing_row_fails_all() {
        // Rows enough to split across threads (more than MIN_ROWS): every value lands in
        // its pair's slot, and of two failing rows the error names the first.
        let x: Vec<DVec2> = (0..4000)
            .map(|k| DVec2::new((k % 63) as f64, (k / 63) as f64))
            .collect();
        let csr = build::<D2>(&x, 1.5);
        let ids = csr
            .fill_rows(|i, out: &mut [u32]| {
                out.copy_from_slice(csr.neighbours(i));
                Ok::<(), usize>(())
            })
            .unwrap();
        assert_eq!(ids, csr.ids);
        let mapped = csr
            .map_rows(|i| Ok::<_, usize>(csr.neighbours(i).iter().map(move |&j| j + i as u32)))
            .unwrap();
        let expected: Vec<u32> = (0..csr.len())
            .flat_map(|i| csr.neighbours(i).iter().map(move |&j| j + i as u32))
            .collect();
        assert_eq!(mapped, expected);
        let failed = csr.fill_rows(|i, _: &mut [u32]| match i {
            3500 | 700 => Err(i),
            _ => Ok(()),
        });
        assert_eq!(failed, Err(700));
    }
}
