//! Recursive coordinate bisection of the reference configuration, and the halos it
//! gives.

use super::Error;
use crate::core::neighbour::Csr;
use crate::core::tensor::Dim;
use std::collections::{BTreeMap, BTreeSet};

/// The work of particle i in a stage: one unit per pair of its row of `lists`, and one
/// for the particle's own update.
pub fn work(lists: &Csr, i: usize) -> u64 {
    lists.neighbours(i).len() as u64 + 1
}

/// The particles split among `ranks` parts: each particle's owner, and each rank's
/// particles in ascending global id.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Partition {
    owner: Vec<u32>,
    owned: Vec<Vec<u32>>,
}

impl Partition {
    /// Recursive coordinate bisection of the reference positions `x`, weighted by
    /// [`work`] over `lists` (the neighbour lists of `x`): a set of particles for n ranks
    /// is sorted along the longest extent of its bounding box (ties between equal
    /// coordinates broken by global id) and cut where the weight of the first side comes
    /// nearest to n_L / n of the set's, n_L = ⌊n/2⌋ the ranks of that side; each side is
    /// split again for its ranks, down to one rank. Every rank gets at least one particle.
    /// Each cut misses its share by at most half a particle's weight, so a rank's weight
    /// lies within ⌈log₂ n⌉ · w_max / 2 of total / n, unless a cut is held back to leave
    /// a side one particle per rank. Deterministic: the same input gives the same partition.
    pub fn bisect<D: Dim>(x: &[D::V], lists: &Csr, ranks: usize) -> Result<Self, Error> {
        assert_eq!(
            x.len(),
            lists.len(),
            "the neighbour lists are those of the positions"
        );
        let particles = x.len();
        if ranks == 0 {
            return Err(Error::NoRanks { particles });
        }
        if ranks > particles {
            return Err(Error::MoreRanksThanParticles { ranks, particles });
        }
        let points: Vec<[f64; 3]> = x.iter().map(|&v| D::to3(v)).collect();
        let weights: Vec<u64> = (0..particles).map(|i| work(lists, i)).collect();
        let mut ids: Vec<u32> = (0..particles as u32).collect();
        let mut owner = vec![0; particles];
        let set = Set {
            points: &points,
            weights: &weights,
        };
        set.split(&mut ids, 0, ranks, &mut owner);
        let mut owned = vec![Vec::new(); ranks];
        for (i, &r) in owner.iter().enumerate() {
            owned[r as usize].push(i as u32);
        }
        Ok(Partition { owner, owned })
    }

    /// The number of ranks.
    pub fn ranks(&self) -> usize {
        self.owned.len()
    }

    /// The rank that owns particle i.
    pub fn owner(&self, i: usize) -> usize {
        self.owner[i] as usize
    }

    /// The particles rank r owns, in ascending global id.
    pub fn owned(&self, r: usize) -> &[u32] {
        &self.owned[r]
    }
}

/// The positions and weights of all particles, which a bisection reads.
struct Set<'a> {
    points: &'a [[f64; 3]],
    weights: &'a [u64],
}

impl Set<'_> {
    /// Gives the particles `ids` to the `n` ranks from `first`.
    fn split(&self, ids: &mut [u32], first: usize, n: usize, owner: &mut [u32]) {
        if n == 1 {
            for &i in ids.iter() {
                owner[i as usize] = first as u32;
            }
            return;
        }
        let axis = self.longest_axis(ids);
        ids.sort_unstable_by(|&a, &b| {
            let (pa, pb) = (self.points[a as usize][axis], self.points[b as usize][axis]);
            pa.total_cmp(&pb).then(a.cmp(&b))
        });
        let n_left = n / 2;
        let k = self.cut(ids, n_left, n);
        let (left, right) = ids.split_at_mut(k);
        self.split(left, first, n_left, owner);
        self.split(right, first + n_left, n - n_left, owner);
    }

    /// The axis of the longest extent of the particles `ids` (the first of equal ones).
    fn longest_axis(&self, ids: &[u32]) -> usize {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &i in ids {
            for (k, &c) in self.points[i as usize].iter().enumerate() {
                lo[k] = lo[k].min(c);
                hi[k] = hi[k].max(c);
            }
        }
        (0..3).fold(0, |best, k| {
            if hi[k] - lo[k] > hi[best] - lo[best] {
                k
            } else {
                best
            }
        })
    }

    /// The number of sorted particles `ids` that go to the first n_L of n ranks: the
    /// cut whose prefix weight W_k comes nearest to W · n_L / n (compared exactly as
    /// |W_k · n − W · n_L|; the first of equal ones), leaving each side at least one
    /// particle per rank.
    fn cut(&self, ids: &[u32], n_left: usize, n: usize) -> usize {
        let total: u64 = ids.iter().map(|&i| self.weights[i as usize]).sum();
        let target = i128::from(total) * n_left as i128;
        let miss = |prefix: u64| (i128::from(prefix) * n as i128 - target).abs();
        let mut prefix: u64 = ids[..n_left]
            .iter()
            .map(|&i| self.weights[i as usize])
            .sum();
        let (mut best, mut best_miss) = (n_left, miss(prefix));
        for k in n_left + 1..=ids.len() - (n - n_left) {
            prefix += self.weights[ids[k - 1] as usize];
            if miss(prefix) < best_miss {
                (best, best_miss) = (k, miss(prefix));
            }
        }
        best
    }
}

/// The particles within `layers` hops of a set along the lists (the set itself included),
/// ascending.
pub fn within(lists: &Csr, set: &[u32], layers: usize) -> Vec<u32> {
    let mut reached: BTreeSet<u32> = set.iter().copied().collect();
    let mut front: Vec<u32> = set.to_vec();
    for _ in 0..layers {
        let mut next = Vec::new();
        for &i in &front {
            for &j in lists.neighbours(i as usize) {
                if reached.insert(j) {
                    next.push(j);
                }
            }
        }
        front = next;
    }
    reached.into_iter().collect()
}

/// What rank `rank` exchanges with the others: the ghosts it receives (the particles
/// other ranks own within `layers` hops of its own along the lists) and the particles it
/// sends (its own within `layers` hops of another rank's), each grouped by the other rank
/// and sorted by global id. Rank r's `receive[s]` is rank s's `send[r]`. One layer holds
/// the neighbours a pair loop reads; a rate evaluation that chains k pair loops (a
/// neighbour's F, then its stress in the force) reads k layers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Halo {
    pub rank: usize,
    pub layers: usize,
    pub receive: BTreeMap<usize, Vec<u32>>,
    pub send: BTreeMap<usize, Vec<u32>>,
}

impl Halo {
    /// The halo of `rank` in `partition` of the particles of `lists`, `layers` deep.
    pub fn new(partition: &Partition, lists: &Csr, rank: usize, layers: usize) -> Self {
        assert!(
            rank < partition.ranks(),
            "rank {rank} of a partition into {} ranks",
            partition.ranks()
        );
        let by_owner = |ids: Vec<u32>, keep: &dyn Fn(usize) -> bool| {
            let mut m: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
            for j in ids {
                let s = partition.owner(j as usize);
                if keep(s) {
                    m.entry(s).or_default().push(j);
                }
            }
            m
        };
        let receive = by_owner(within(lists, partition.owned(rank), layers), &|s| s != rank);
        let mut send = BTreeMap::new();
        for s in (0..partition.ranks()).filter(|&s| s != rank) {
            let ids = within(lists, partition.owned(s), layers);
            if let Some(mine) = by_owner(ids, &|o| o == rank).remove(&rank) {
                send.insert(s, mine);
            }
        }
        Halo {
            rank,
            layers,
            receive,
            send,
        }
    }

    /// The particles rank `rank` holds: its own and its ghosts, ascending; their
    /// positions in this list are the rank's local indices.
    pub fn local(&self, partition: &Partition) -> Vec<u32> {
        let mut ids: Vec<u32> = partition.owned(self.rank).to_vec();
        ids.extend(self.receive.values().flatten());
        ids.sort_unstable();
        ids
    }
}
