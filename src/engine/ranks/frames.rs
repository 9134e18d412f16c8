//! The frames of a distributed run in pieces: each rank writes its own particles (and
//! the elements whose first corner it owns), with the fields a frame derives from each
//! particle's neighbours (the hourglass indicator η, the pressure deviation δp)
//! evaluated on the rank from the state of its neighbours on other ranks, which it
//! receives for the frame ([`FrameRank`]).

use super::{
    Whole, agree, extra_names, put_state_row, set_state_row, state_row_width, zero_snapshot,
};
use crate::core::neighbour::{self, Csr};
use crate::core::parallel::ParticleRows;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::distributed::{Collectives, Comm, Local, Partition};

/// Where the ranks write their pieces of the frames: the run's files
/// ([`crate::run::frames::FramePieces`]).
pub trait FrameStore<D: Dim>: Send {
    /// The reach of the fields derived from the neighbours (the case's kernel support):
    /// a rank receives the state of the particles within it of its own [m].
    fn reach(&self) -> f64;
    /// The derived fields (η, δp) of every particle of `all`, the rank's own and those
    /// within [`Self::reach`] of them; the own particles' values are the run's.
    fn derived(&mut self, all: &Snapshot<D>) -> [Vec<f64>; 2];
    /// Writes the rank's piece of frame `frame` at time t: the points of `piece` with
    /// their global `ids` and `derived` fields, the last `ghosts` of them other ranks'
    /// (corners of the piece's cells). Returns the bytes written.
    fn write(
        &mut self,
        frame: usize,
        t: f64,
        piece: &Snapshot<D>,
        ids: &[u32],
        ghosts: usize,
        derived: [&[f64]; 2],
    ) -> Result<u64, String>;
    /// Rank 0, once every rank has written its piece: the frame's index of the `ranks`
    /// pieces.
    fn index(&mut self, frame: usize, ranks: usize) -> Result<(), String>;
}

/// What a rank holds to write its pieces of the frames: the particles within the reach
/// of its own (and the corners of its cells), their reference arrays, and the piece's
/// points and cells.
pub struct FrameRank<D: Dim> {
    store: Box<dyn FrameStore<D>>,
    /// The rank's own particles and those it receives for a frame.
    local: Local,
    /// The reference arrays of the local particles.
    all: Arrays<D>,
    /// The local indices of the piece's points: the own particles, then the other ranks'
    /// corners of the piece's cells, each ascending.
    points: Vec<u32>,
    /// The reference arrays of the piece's points.
    piece: Arrays<D>,
    /// Their global ids.
    ids: Vec<u32>,
    /// How many of `points` are other ranks'.
    ghosts: usize,
    /// The corners of the cells whose first corner the rank owns, in the run's cell
    /// order, as indices into `points`.
    cells: Vec<u32>,
}

/// The reference arrays of some of the run's particles.
struct Arrays<D: Dim> {
    x0: Vec<D::V>,
    mass: Vec<f64>,
    body: Vec<u32>,
}

impl<D: Dim> Arrays<D> {
    /// Those of the particles `ids` of `whole`.
    fn of(whole: &Whole<D>, ids: &[u32]) -> Self {
        let ids = ids.iter().map(|&g| g as usize);
        Self {
            x0: ids.clone().map(|g| whole.x0[g]).collect(),
            mass: ids.clone().map(|g| whole.mass[g]).collect(),
            body: ids.map(|g| whole.body[g]).collect(),
        }
    }
}

impl<D: Dim> FrameRank<D> {
    /// Rank `rank`'s share of the frames of `whole` split by `partition`.
    pub fn new(
        store: Box<dyn FrameStore<D>>,
        partition: &Partition,
        whole: &Whole<D>,
        rank: usize,
    ) -> Self {
        let lists = neighbour::build::<D>(&whole.x0, store.reach());
        let per_cell = 1 << D::N;
        // The corners of a cell are received with its first corner's neighbours.
        let graph = if whole.cells.is_empty() {
            lists
        } else {
            let mut rows: Vec<Vec<u32>> = (0..lists.len())
                .map(|i| lists.neighbours(i).to_vec())
                .collect();
            for c in whole.cells.chunks_exact(per_cell) {
                rows[c[0] as usize].extend(&c[1..]);
            }
            for row in &mut rows {
                row.sort_unstable();
                row.dedup();
            }
            Csr::from_rows(&rows)
        };
        let local = Local::new(partition, &graph, rank, 1);
        let at = |g: u32| local.ids.binary_search(&g).expect("a corner is local") as u32;
        let cells: Vec<u32> = (whole.cells.chunks_exact(per_cell))
            .filter(|c| partition.owner(c[0] as usize) == rank)
            .flatten()
            .map(|&g| at(g))
            .collect();
        let mut corners: Vec<u32> = (cells.iter().copied())
            .filter(|&i| !local.owned[i as usize])
            .collect();
        corners.sort_unstable();
        corners.dedup();
        let mut points = local.own.clone();
        points.extend(&corners);
        let mut in_piece = vec![u32::MAX; local.len()];
        for (k, &i) in points.iter().enumerate() {
            in_piece[i as usize] = k as u32;
        }
        let ids: Vec<u32> = points.iter().map(|&i| local.ids[i as usize]).collect();
        Self {
            all: Arrays::of(whole, &local.ids),
            piece: Arrays::of(whole, &ids),
            cells: cells.iter().map(|&i| in_piece[i as usize]).collect(),
            ghosts: corners.len(),
            ids,
            store,
            local,
            points,
        }
    }

    /// Writes the rank's piece of frame `frame` at time t from `state`, that of the
    /// rank's system (whose own particles, `system.own`, are this rank's, in the same
    /// order), and, on rank 0, the frame's index; every rank learns whether all wrote
    /// theirs. Returns the bytes the ranks wrote.
    pub fn write(
        &mut self,
        comm: &dyn Comm,
        system: &Local,
        state: Snapshot<D>,
        frame: usize,
        t: f64,
    ) -> Result<u64, String> {
        let written = self.write_piece(comm, system, state, frame, t);
        let bytes = *written.as_ref().unwrap_or(&0) as f64;
        agree(comm, written.map(|_| ()))?;
        let bytes = comm.sum(&[bytes])[0] as u64;
        if comm.rank() == 0 {
            self.store.index(frame, comm.size())?;
        }
        Ok(bytes)
    }

    fn write_piece(
        &mut self,
        comm: &dyn Comm,
        system: &Local,
        state: Snapshot<D>,
        frame: usize,
        t: f64,
    ) -> Result<u64, String> {
        // The rows of the own particles, then those within reach from their owners (each
        // copy of the state dropped once read: a frame's memory is the rank's).
        let names = extra_names(&state);
        let mut rows = Rows::new(self.local.len(), state_row_width::<D>(names.len()));
        let mut row = Vec::with_capacity(rows.width);
        for (&i, &k) in system.own.iter().zip(&self.local.own) {
            debug_assert_eq!(system.ids[i as usize], self.local.ids[k as usize]);
            row.clear();
            put_state_row(&state, i as usize, &mut row);
            rows.set_rows(&[k], &row);
        }
        drop(state);
        self.local.refresh(comm, &mut rows);
        let every: Vec<u32> = (0..self.local.len() as u32).collect();
        let [eta, deviation] = self
            .store
            .derived(&unpack(&rows, &every, &self.all, &names));
        // The own particles' derived fields, then the ghost corners' from their owners.
        let mut derived = Rows::new(self.local.len(), 2);
        for &k in &self.local.own {
            derived.set_rows(&[k], &[eta[k as usize], deviation[k as usize]]);
        }
        drop((eta, deviation));
        self.local.refresh(comm, &mut derived);
        let mut piece = unpack(&rows, &self.points, &self.piece, &names);
        piece.cells = &self.cells;
        let field = |c: usize| -> Vec<f64> {
            (self.points.iter())
                .map(|&k| derived.words[2 * k as usize + c])
                .collect()
        };
        let (eta, deviation) = (field(0), field(1));
        (self.store).write(frame, t, &piece, &self.ids, self.ghosts, [&eta, &deviation])
    }
}

/// The snapshot of the local particles `which` from their `rows`, with the reference
/// arrays `at` (of the same particles) and the extra fields `names`.
fn unpack<'a, D: Dim>(
    rows: &Rows,
    which: &[u32],
    at: &'a Arrays<D>,
    names: &[&'static str],
) -> Snapshot<'a, D> {
    let mut s = zero_snapshot(&at.x0, &at.mass, &at.body, names, which.len());
    for (k, &i) in which.iter().enumerate() {
        set_state_row(&mut s, k, rows.row(i));
    }
    s
}

/// Rows of equal width, one a local particle, in one array.
struct Rows {
    width: usize,
    words: Vec<f64>,
}

impl Rows {
    /// n rows of zeros.
    fn new(n: usize, width: usize) -> Self {
        Self {
            width,
            words: vec![0.0; n * width],
        }
    }

    fn row(&self, i: u32) -> &[f64] {
        let at = i as usize * self.width;
        &self.words[at..at + self.width]
    }
}

impl ParticleRows for Rows {
    fn rows(&self, ids: &[u32], out: &mut Vec<f64>) {
        for &i in ids {
            out.extend_from_slice(self.row(i));
        }
    }

    fn set_rows<'w>(&mut self, ids: &[u32], mut words: &'w [f64]) -> &'w [f64] {
        for &i in ids {
            let at = i as usize * self.width;
            let (row, rest) = words.split_at(self.width);
            self.words[at..at + self.width].copy_from_slice(row);
            words = rest;
        }
        words
    }

    fn zeros_like(&self, n: usize) -> Self {
        Self::new(n, self.width)
    }
}
