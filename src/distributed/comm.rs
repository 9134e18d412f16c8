//! The messages between the ranks of a distributed run: [`Comm`], one exchange of words
//! between a rank and the others, and the collectives a run needs, built on it in a fixed
//! order (so that every rank gets the same bits whatever the transport). [`Threads`] is
//! the transport of ranks that are threads of one process (tests, and trying a
//! decomposition on one machine); the MPI transport is `mpi::World` (feature `mpi`).

use std::collections::VecDeque;
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, Sender, channel};

/// The ranks of a run as one rank sees them.
pub trait Comm: Send + Sync {
    /// This rank, 0 ≤ rank < size.
    fn rank(&self) -> usize;
    /// The number of ranks.
    fn size(&self) -> usize;
    /// Sends each (rank, words) of `out`, then receives one message from each rank of
    /// `from` in that order. Messages between two ranks arrive in the order they were
    /// sent; no rank waits for another to receive.
    fn exchange(&self, out: Vec<(usize, Vec<f64>)>, from: &[usize]) -> Vec<Vec<f64>>;
}

/// The collectives of a run, on any [`Comm`]: every rank calls the same ones in the same
/// order.
pub trait Collectives: Comm {
    /// Every rank's words on rank 0, in rank order; None on the others.
    fn gather(&self, words: Vec<f64>) -> Option<Vec<Vec<f64>>> {
        if self.rank() == 0 {
            let others: Vec<usize> = (1..self.size()).collect();
            let mut all = vec![words];
            all.extend(self.exchange(Vec::new(), &others));
            Some(all)
        } else {
            self.exchange(vec![(0, words)], &[]);
            None
        }
    }

    /// Rank 0's words on every rank (the others' `words` are replaced).
    fn broadcast(&self, words: &mut Vec<f64>) {
        if self.rank() == 0 {
            let out = (1..self.size()).map(|r| (r, words.clone())).collect();
            self.exchange(out, &[]);
        } else {
            *words = self.exchange(Vec::new(), &[0]).remove(0);
        }
    }

    /// Every rank's words on every rank, in rank order.
    fn all_gather(&self, words: Vec<f64>) -> Vec<Vec<f64>> {
        let all = self.gather(words);
        let mut flat = match &all {
            Some(parts) => {
                let mut flat: Vec<f64> = parts.iter().map(|p| p.len() as f64).collect();
                flat.extend(parts.iter().flatten());
                flat
            }
            None => Vec::new(),
        };
        self.broadcast(&mut flat);
        let (lengths, mut rest) = flat.split_at(self.size());
        lengths
            .iter()
            .map(|&n| {
                let (part, tail) = rest.split_at(n as usize);
                rest = tail;
                part.to_vec()
            })
            .collect()
    }

    /// The sums of each component of `x` over the ranks, added in rank order.
    fn sum(&self, x: &[f64]) -> Vec<f64> {
        let all = self.all_gather(x.to_vec());
        let mut total = all[0].clone();
        for part in &all[1..] {
            for (t, p) in total.iter_mut().zip(part) {
                *t += p;
            }
        }
        total
    }

    /// The largest x of the ranks.
    fn max(&self, x: f64) -> f64 {
        let all = self.all_gather(vec![x]);
        all.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max)
    }
}

impl<C: Comm + ?Sized> Collectives for C {}

/// What one thread-rank receives from each other rank.
struct Inbox {
    channel: Receiver<(usize, Vec<f64>)>,
    /// Messages that arrived before the rank asked for their sender's.
    early: Vec<VecDeque<Vec<f64>>>,
}

/// A rank of a run whose ranks are threads of one process, joined by channels.
pub struct Threads {
    rank: usize,
    to: Vec<Sender<(usize, Vec<f64>)>>,
    inbox: Mutex<Inbox>,
}

impl Threads {
    /// The n ranks of a run on n threads; give each to its own thread.
    pub fn ranks(n: usize) -> Vec<Threads> {
        let (to, from): (Vec<_>, Vec<_>) = (0..n).map(|_| channel()).unzip();
        from.into_iter()
            .enumerate()
            .map(|(rank, channel)| Threads {
                rank,
                to: to.clone(),
                inbox: Mutex::new(Inbox {
                    channel,
                    early: vec![VecDeque::new(); n],
                }),
            })
            .collect()
    }
}

impl Comm for Threads {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.to.len()
    }

    fn exchange(&self, out: Vec<(usize, Vec<f64>)>, from: &[usize]) -> Vec<Vec<f64>> {
        for (r, words) in out {
            // A rank that has ended drops its receiver; a send to it is lost, as in MPI
            // after the peer's exit, and the run has failed already.
            let _ = self.to[r].send((self.rank, words));
        }
        let mut inbox = self.inbox.lock().expect("one thread per rank");
        from.iter()
            .map(|&s| {
                loop {
                    if let Some(words) = inbox.early[s].pop_front() {
                        break words;
                    }
                    let (sender, words) = inbox
                        .channel
                        .recv()
                        .expect("every rank holds a sender to every rank while it runs");
                    inbox.early[sender].push_back(words);
                }
            })
            .collect()
    }
}
