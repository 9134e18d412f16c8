//! A run of one case on several ranks (`docs/distributed.md`). Every rank builds the
//! reference configuration; the method partitions it along its graph and sets up on the
//! rank's own particles with their ghosts; rank 0 drives the run with the driver of a one-rank run, and the others
//! serve its engine ([`crate::engine::ranks`]). The series and the summary are rank 0's,
//! in the one-rank formats; every rank writes its piece of each frame ([`FramePieces`])
//! and of each checkpoint ([`Pieces`]).

use super::checkpoint::Pieces;
use super::frames::FramePieces;
use super::{Backend, RunError, RunOptions, budget, drive::drive};
use crate::case::{CaseError, fnv1a};
use crate::core::tensor::{D2, D3};
use crate::distributed::{Collectives, Comm, Threads};
use crate::engine::ranks::RankStart;
use crate::engine::{Engine, EngineDim};
use crate::output::RunSummary;
use crate::reference::Reference;
use crate::scene::Scene;
use std::sync::Arc;

/// Why a case cannot run on several ranks, or None.
pub fn refusal(case: &Scene, backend: Backend) -> Option<String> {
    let name = case.method.name;
    let why = if case.spec.entry().halo_layers.is_none() {
        let methods = crate::methods::REGISTRY
            .iter()
            .filter(|e| e.halo_layers.is_some())
            .map(|e| format!("`{}`", e.name))
            .collect::<Vec<_>>()
            .join(", ");
        format!("`{name}` does not run on several ranks yet (those that do: {methods})")
    } else if backend == Backend::Gpu {
        "the GPU backend does not run on several ranks yet; use --backend cpu".into()
    } else if case.solves_by_newton() {
        "the static and implicit solves (run.solve = \"static\" or \"implicit\") do not run \
         on several ranks"
            .into()
    } else if case.contact.is_some() {
        "contact ([contact]) does not run on several ranks yet".into()
    } else if case.boundaries.iter().any(|b| b.condition.is_timed_load()) {
        "loads with a time law do not run on several ranks yet".into()
    } else {
        return None;
    };
    Some(format!("{}: {why}", case.file.display()))
}

/// The threads each rank runs: the case's `run.threads`, or the cores shared among the
/// `on_node` ranks of this machine (at least one).
fn threads_per_rank(case: &Scene, on_node: usize) -> usize {
    case.run.threads.unwrap_or_else(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (cores / on_node.max(1)).max(1)
    })
}

/// Runs a case as one rank of `comm`, one of `on_node` ranks on this machine (which share
/// its cores and memory); rank 0 returns the summary, the others None when rank 0 ends
/// the run. Every rank refuses what the others refuse, so that no rank waits for one
/// that has stopped.
pub fn run_rank(
    case: &Scene,
    opts: &RunOptions,
    comm: Arc<dyn Comm>,
    on_node: usize,
) -> Result<Option<RunSummary>, RunError> {
    same_case(case, opts, comm.as_ref())?;
    if let Some(why) = refusal(case, opts.backend) {
        return Err(RunError::Ranks(why));
    }
    budget::check_rank(case, &opts.limits, on_node)?;
    let threads = threads_per_rank(case, on_node);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| RunError::Ranks(format!("cannot start {threads} threads: {e}")))?;
    pool.install(|| match case.dimension {
        2 => rank::<D2>(case, opts, comm),
        _ => rank::<D3>(case, opts, comm),
    })
}

/// Refuses ranks that read different cases (another file, other overrides) or write
/// different outputs (frames on or off).
fn same_case(case: &Scene, opts: &RunOptions, comm: &dyn Comm) -> Result<(), RunError> {
    let hash = fnv1a(format!("{:?} {}", case.case, opts.frames).as_bytes());
    // The hash in two words, each exact in an f64.
    let mine = vec![(hash >> 32) as f64, (hash & 0xffff_ffff) as f64];
    let all = comm.all_gather(mine.clone());
    match all.iter().position(|w| *w != mine) {
        Some(r) => Err(RunError::Ranks(format!(
            "rank {r} read another case than rank {} ({}): give every rank the same case \
             file, --set overrides and --no-frames",
            comm.rank(),
            case.file.display()
        ))),
        None => Ok(()),
    }
}

fn rank<D: EngineDim>(
    case: &Scene,
    opts: &RunOptions,
    comm: Arc<dyn Comm>,
) -> Result<Option<RunSummary>, RunError> {
    let mut reference = Reference::<D>::build(case)?;
    if let Some(h) = case.spec.smoothing_lengths::<D>(case, &reference)? {
        (reference.h, reference.method_lengths) = (h, true);
    }
    let layers = case.spec.entry().halo_layers.expect("refusal checked it");
    let pieces = Box::new(Pieces::new(&opts.out_dir, case, comm.rank()));
    let frames = opts.frames.then(|| {
        let store = FramePieces::new(case, opts, comm.rank(), D::N);
        Box::new(store) as Box<dyn crate::engine::ranks::FrameStore<D>>
    });
    let start = RankStart {
        comm,
        layers,
        pieces,
        frames,
    };
    let engine = case.spec.rank_engine::<D>(case, reference, start)?;
    if engine.is_leader() {
        let engine: Box<dyn Engine<D>> = engine;
        drive::<D, _>(case, opts, engine).map(Some)
    } else {
        engine.serve();
        Ok(None)
    }
}

/// Runs a case on `ranks` ranks that are threads of this process (each with its share of
/// the cores), and returns rank 0's summary: a distributed run without MPI, to try a
/// decomposition on one machine and to test it.
pub fn run_on_threads(
    case: &Scene,
    opts: &RunOptions,
    ranks: usize,
) -> Result<RunSummary, RunError> {
    std::thread::scope(|s| {
        let handles: Vec<_> = Threads::ranks(ranks)
            .into_iter()
            .map(|comm| s.spawn(move || run_rank(case, opts, Arc::new(comm), ranks)))
            .collect();
        let results: Vec<_> = handles
            .into_iter()
            .map(|h| h.join().expect("a rank's thread panicked"))
            .collect();
        // The first rank's own error: the others stop with one that names the rank
        // whose set-up failed.
        let relayed = |e: &RunError| matches!(e, RunError::Case(CaseError::OtherRank { .. }));
        let (mut errors, mut summary) = (Vec::new(), None);
        for result in results {
            match result {
                Ok(s) => summary = summary.or(s),
                Err(e) => errors.push(e),
            }
        }
        if !errors.is_empty() {
            let own = errors.iter().position(|e| !relayed(e)).unwrap_or(0);
            return Err(errors.swap_remove(own));
        }
        Ok(summary.expect("rank 0 returns the summary"))
    })
}
