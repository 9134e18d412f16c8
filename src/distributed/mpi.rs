//! The MPI transport (feature `mpi`: rsmpi on the system's MPICH or Open MPI): the
//! processes an MPI launcher started, as the ranks of one run.
//!
//! A rank waits by polling and yielding its core, never in a blocking MPI call: MPICH's
//! blocking calls spin, and ranks oversubscribed on fewer cores (3 ranks on 2) would
//! take the cores the working ranks need.

use super::comm::Comm;
use mpi::environment::Universe;
use mpi::point_to_point::MatchedReceiveVec;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// MPI, initialised for the ranks of a run; dropping it finalises MPI, which waits for
/// every rank to drop it.
pub struct Mpi {
    _universe: Universe,
}

impl Mpi {
    /// MPI initialised for calls from one thread at a time, and a panic hook that aborts
    /// every rank (a panicking rank would otherwise leave the others waiting for it, and
    /// its own MPI_Finalize would wait for them); None if MPI was initialised before.
    pub fn init() -> Option<Self> {
        let (universe, _) = mpi::initialize_with_threading(mpi::Threading::Serialized)?;
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            previous(info);
            if mpi::environment::is_initialized() && !mpi::environment::is_finalized() {
                SimpleCommunicator::world().abort(101);
            }
        }));
        Some(Self {
            _universe: universe,
        })
    }

    /// This process as a rank of the world communicator.
    pub fn world(&self) -> World {
        let world = SimpleCommunicator::world();
        World {
            rank: world.rank() as usize,
            size: world.size() as usize,
        }
    }
}

/// One rank of the world communicator.
pub struct World {
    rank: usize,
    size: usize,
}

impl Comm for World {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn exchange(&self, out: Vec<(usize, Vec<f64>)>, from: &[usize]) -> Vec<Vec<f64>> {
        let world = SimpleCommunicator::world();
        mpi::request::scope(|scope| {
            let mut sends: Vec<_> = out
                .iter()
                .map(|(r, words)| {
                    world
                        .process_at_rank(*r as i32)
                        .immediate_send(scope, &words[..])
                })
                .collect();
            let received = from
                .iter()
                .map(|&s| {
                    let source = world.process_at_rank(s as i32);
                    loop {
                        if let Some(probed) = source.immediate_matched_probe() {
                            break probed.matched_receive_vec::<f64>().0;
                        }
                        std::thread::yield_now();
                    }
                })
                .collect();
            while let Some(send) = sends.pop() {
                match send.test() {
                    Ok(_) => {}
                    Err(pending) => {
                        sends.push(pending);
                        std::thread::yield_now();
                    }
                }
            }
            received
        })
    }
}
