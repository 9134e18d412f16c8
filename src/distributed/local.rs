//! A rank's particles ([`Local`]): its own and its ghosts in ascending global id, which
//! are its local indices, and the exchange that keeps the ghosts' rows equal to their
//! owners'.

use super::comm::Comm;
use super::partition::{Halo, Partition};
use crate::core::neighbour::Csr;
use crate::core::parallel::ParticleRows;

/// The particles one rank holds and what it exchanges with the others, in local indices.
#[derive(Clone, Debug)]
pub struct Local {
    pub rank: usize,
    /// The global id of each local particle, ascending: a rank's lists, built on its
    /// particles, keep the global order of every row.
    pub ids: Vec<u32>,
    /// Whether the rank owns each local particle (the others are ghosts).
    pub owned: Vec<bool>,
    /// The local indices of the particles the rank owns, ascending.
    pub own: Vec<u32>,
    /// (rank s, local indices of the ghosts s owns), by s, each ascending.
    pub receive: Vec<(usize, Vec<u32>)>,
    /// (rank s, local indices of the particles s holds as ghosts), by s, each ascending.
    pub send: Vec<(usize, Vec<u32>)>,
}

impl Local {
    /// Rank `rank`'s particles of `partition` with the ghosts of `layers` layers along
    /// the global lists.
    pub fn new(partition: &Partition, lists: &Csr, rank: usize, layers: usize) -> Self {
        let halo = Halo::new(partition, lists, rank, layers);
        let ids = halo.local(partition);
        let local = |g: &u32| ids.binary_search(g).expect("a halo particle is local") as u32;
        let to_local = |m: &std::collections::BTreeMap<usize, Vec<u32>>| {
            m.iter()
                .map(|(&s, g)| (s, g.iter().map(local).collect()))
                .collect()
        };
        let owned: Vec<bool> = ids
            .iter()
            .map(|&g| partition.owner(g as usize) == rank)
            .collect();
        Self {
            rank,
            own: (0..ids.len() as u32)
                .filter(|&i| owned[i as usize])
                .collect(),
            receive: to_local(&halo.receive),
            send: to_local(&halo.send),
            owned,
            ids,
        }
    }

    /// The number of local particles.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Overwrites the ghosts' rows of `state` with their owners' rows.
    pub fn refresh<S: ParticleRows>(&self, comm: &dyn Comm, state: &mut S) {
        let state = std::cell::RefCell::new(state);
        self.refresh_rows(
            comm,
            &|ids, out| state.borrow().rows(ids, out),
            &mut |ids, words| {
                let rest = state.borrow_mut().set_rows(ids, words);
                debug_assert!(rest.is_empty(), "a ghost's rows are its owner's");
            },
        );
    }

    /// Overwrites the ghosts' rows with their owners': `put(ids, out)` appends the rows
    /// of the local particles `ids`, `take(ids, words)` overwrites them with `words`.
    pub fn refresh_rows(
        &self,
        comm: &dyn Comm,
        put: &dyn Fn(&[u32], &mut Vec<f64>),
        take: &mut dyn FnMut(&[u32], &[f64]),
    ) {
        let out = self
            .send
            .iter()
            .map(|(s, ids)| {
                let mut words = Vec::new();
                put(ids, &mut words);
                (*s, words)
            })
            .collect();
        let from: Vec<usize> = self.receive.iter().map(|r| r.0).collect();
        for ((_, ids), words) in self.receive.iter().zip(comm.exchange(out, &from)) {
            take(ids, &words);
        }
    }
}
