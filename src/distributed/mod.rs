//! Domain decomposition for distributed runs of the total-Lagrangian methods (what
//! exists and what is missing: `docs/distributed.md`).
//!
//! A total-Lagrangian method keeps its neighbour graph in the reference configuration,
//! so the particles are split among the ranks once: [`Partition`] bisects the reference
//! positions, weighted by each particle's pairs, and [`Halo`] lists the particles a rank
//! receives from each other rank (its ghosts) and those it sends. The launcher check
//! [`no_mpi_launcher`] keeps a build without MPI from running one copy of a case per
//! process when started by `mpirun`. It uses only the core (`tests/it/layers.rs`).

mod comm;
mod local;
#[cfg(feature = "mpi")]
pub mod mpi;
mod partition;
#[cfg(test)]
mod tests;

pub use comm::{Collectives, Comm, Threads};
pub use local::Local;
pub use partition::{Halo, Partition, within, work};

/// What is wrong with a decomposition or with the way the program was started.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Error {
    /// A partition into no parts.
    NoRanks { particles: usize },
    /// Fewer particles than ranks: some rank would own none.
    MoreRanksThanParticles { ranks: usize, particles: usize },
    /// An MPI launcher started this build, which has no MPI, on several processes.
    NoMpi { variable: &'static str, size: u64 },
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::NoRanks { particles } => write!(
                f,
                "0 ranks for {particles} particles: run on at least 1 rank"
            ),
            Error::MoreRanksThanParticles { ranks, particles } => write!(
                f,
                "{ranks} ranks for {particles} particles: run on at most {particles} ranks"
            ),
            Error::NoMpi { variable, size } => write!(
                f,
                "{variable}={size}: an MPI launcher started {size} processes, but this build \
                 of meshless has no MPI and would run {size} independent copies of the case. \
                 Run it as one process (without mpirun or mpiexec), or build with MPI for \
                 distributed runs (`cargo build --release --features mpi`, README)"
            ),
        }
    }
}

impl std::error::Error for Error {}

/// The environment variables in which MPI launchers give the number of processes they
/// started: Open MPI's world size, the PMI world size of MPICH's and Intel MPI's Hydra,
/// and MPICH's count of the processes on this node (more than one there means more than
/// one in all). A batch system's task count (`SLURM_NTASKS`) is not among them: a batch
/// script that runs the program once sees it too.
pub const LAUNCHER_SIZES: [&str; 3] = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "MPI_LOCALNRANKS"];

/// The processes an MPI launcher started, when more than one: the first of
/// [`LAUNCHER_SIZES`] that `env` gives as a number above 1, and its value. `env` looks a
/// variable up (`|k| std::env::var(k).ok()` for the process's own); a value that is not
/// a number is no launcher's and is passed over.
pub fn launcher_size(env: impl Fn(&str) -> Option<String>) -> Option<(&'static str, u64)> {
    LAUNCHER_SIZES.into_iter().find_map(|variable| {
        let size = env(variable).and_then(|v| v.trim().parse::<u64>().ok());
        size.filter(|&n| n > 1).map(|n| (variable, n))
    })
}

/// Refuses a start by an MPI launcher on more than one process in a build without MPI
/// ([`launcher_size`]).
pub fn no_mpi_launcher(env: impl Fn(&str) -> Option<String>) -> Result<(), Error> {
    match launcher_size(env) {
        Some((variable, size)) => Err(Error::NoMpi { variable, size }),
        None => Ok(()),
    }
}

/// The variables in which MPI launchers give the number of ranks on this machine:
/// MPICH's and Open MPI's.
pub const LAUNCHER_LOCAL_SIZES: [&str; 2] = ["MPI_LOCALNRANKS", "OMPI_COMM_WORLD_LOCAL_SIZE"];

/// The ranks the launcher started on this machine (`size` when it does not say).
pub fn ranks_on_node(env: impl Fn(&str) -> Option<String>, size: usize) -> usize {
    (LAUNCHER_LOCAL_SIZES.into_iter())
        .find_map(|v| env(v).and_then(|n| n.trim().parse().ok()))
        .unwrap_or(size)
}
