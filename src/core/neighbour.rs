//! Cell-list neighbour search producing compressed sparse row (CSR) neighbour lists.

use crate::core::tensor::Dim;
use rayon::prelude::*;

/// Neighbour lists in CSR form: the neighbours of particle i are
/// `ids[offsets[i]..offsets[i + 1]]`, sorted ascending, the particle itself excluded.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Csr {
    pub offsets: Vec<usize>,
    pub ids: Vec<u32>,
}

impl Csr {
    /// The lists of `rows`, in order.
    pub fn from_rows(rows: &[Vec<u32>]) -> Self {
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0);
        for row in rows {
            offsets.push(offsets[offsets.len() - 1] + row.len());
        }
        Self {
            offsets,
            ids: rows.concat(),
        }
    }

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

/// The room a rebuild for a grown reach leaves above it ([`Neighbours::update_reaching`]
/// with [`Rebuild::OnDrift`]), a fraction of the reach: a reach that grows a little at
/// every step then rebuilds once per 5 % of growth.
pub const HEADROOM: f64 = 0.05;

/// A method's neighbour lists, kept by its [`Rebuild`] policy: the reach of every
/// particle, the body masks, and the cell list that rebuilds them with its buffers.
#[derive(Clone, Debug)]
pub struct Neighbours {
    rebuild: Rebuild,
    /// The reach the lists hold every pair within (at the current positions, while no
    /// particle has drifted past [`Self::drift`]).
    covered: Vec<f64>,
    /// The reach of every particle at the last build: [`Self::covered`] widened by the
    /// skin with [`Rebuild::OnDrift`].
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
        let mut n = Self {
            rebuild,
            covered: Vec::new(),
            reach: Vec::new(),
            body,
            search: CellList::default(),
            lists: Csr::default(),
            built_at: Vec::new(),
            drift: 0.0,
            seconds: 0.0,
        };
        n.cover(reach.iter().copied());
        n.rebuild::<D>(x);
        n
    }

    /// Sets the reach the next build covers, and the skin and drift limit around it.
    fn cover(&mut self, reach: impl Iterator<Item = f64>) {
        self.covered.clear();
        self.covered.extend(reach);
        let widen = if self.rebuild == Rebuild::OnDrift {
            1.0 + SKIN
        } else {
            1.0
        };
        self.reach.clear();
        self.reach.extend(self.covered.iter().map(|r| r * widen));
        self.drift = 0.5 * SKIN * self.covered.iter().copied().fold(f64::INFINITY, f64::min);
    }

    /// [`Self::update`] for particles whose reach changes (an adaptive smoothing length):
    /// the lists are rebuilt, each particle reaching `need` (with [`HEADROOM`] above it
    /// under [`Rebuild::OnDrift`]), whenever the policy asks for a rebuild or some
    /// particle needs more than the lists cover. Returns whether it rebuilt.
    pub fn update_reaching<D: Dim>(&mut self, x: &[D::V], need: &[f64]) -> bool {
        let started = std::time::Instant::now();
        let short = need.iter().zip(&self.covered).any(|(n, c)| n > c);
        let rebuilt = short || self.due::<D>(x);
        if rebuilt {
            let room = if self.rebuild == Rebuild::OnDrift {
                1.0 + HEADROOM
            } else {
                1.0
            };
            self.cover(need.iter().map(|n| n * room));
            self.rebuild::<D>(x);
        }
        self.seconds += started.elapsed().as_secs_f64();
        rebuilt
    }

    /// The reach of every particle that the current lists cover.
    pub fn covered(&self) -> &[f64] {
        &self.covered
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
        let due = self.due::<D>(x);
        if due {
            self.rebuild::<D>(x);
        }
        due
    }

    /// Whether the policy asks for a rebuild at positions x.
    fn due<D: Dim>(&self, x: &[D::V]) -> bool {
        match self.rebuild {
            Rebuild::Once => false,
            Rebuild::EveryStage => true,
            Rebuild::OnDrift => {
                let moved = |(p, q): (&D::V, &[f64; 3])| {
                    let p = D::to3(*p);
                    let d2: f64 = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum();
                    d2.is_nan() || d2 > self.drift * self.drift
                };
                x.iter().zip(&self.built_at).any(moved)
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
mod tests;
