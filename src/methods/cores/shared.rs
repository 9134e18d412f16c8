//! What the method cores take from a case: the CPU engine of a system built on it, and
//! the reference neighbours and gradients of the total-Lagrangian methods; on the GPU,
//! the bindings of a rate evaluation on each state an integrator evaluates
//! ([`BySource`]).

use crate::case::{Case, CaseError};
use crate::core::correction;
#[cfg(feature = "gpu")]
use crate::core::integrate::{Buf, Evaluation};
use crate::core::kernel;
use crate::core::neighbour::Csr;
use crate::core::parallel::ParticleRows;
use crate::core::tensor::Dim;
use crate::distributed::Collectives;
use crate::engine::ranks::{Rank, RankEngine, RankStart, Whole};
use crate::engine::{CpuEngine, EngineDim, Method};
use crate::methods::cores::family::RankBuild;
use crate::reference::{Build, Reference, build_method};
use rayon::prelude::*;
use std::sync::Arc;

impl<D: Dim, M: Method<D> + Build<D>> CpuEngine<D, M> {
    /// The engine of the system `M` of a method's spec built on a case, stepped by the
    /// case's integrator.
    pub fn new(case: &Case, spec: &M::Spec) -> Result<Self, CaseError> {
        Ok(Self::with(
            build_method::<D, M>(case, spec)?,
            case.method.integrator,
        ))
    }
}

/// The engine of one rank of a distributed run of a particle method: the run's
/// `reference` split along its neighbour lists, and the system `M` of the method's spec
/// built on the rank's particles ([`Reference::restrict`]).
pub fn rank_engine<D: EngineDim, M: Method<D> + Build<D> + 'static>(
    case: &Case,
    spec: &M::Spec,
    reference: Reference<D>,
    start: RankStart<D>,
) -> RankBuild<D>
where
    M::State: ParticleRows,
{
    let whole = Whole {
        x0: reference.x0.clone(),
        mass: reference.mass.clone(),
        body: reference.body.clone(),
        constrained: reference.boundary.constrained.clone(),
        cells: Vec::new(),
    };
    let rank = start.split(&reference.neighbours(), whole, &case.file)?;
    let part = reference.restrict(&rank.local, Arc::new(rank.peers()));
    drop(reference);
    engine_on_rank(case, M::build(case, spec, part), rank)
}

/// The engine of a rank whose system's set-up ended in `method`. Every rank learns
/// whether all could set up, so that none waits for one that stopped.
pub fn engine_on_rank<D: EngineDim, M: Method<D> + 'static>(
    case: &Case,
    method: Result<M, CaseError>,
    rank: Rank<D>,
) -> RankBuild<D>
where
    M::State: ParticleRows,
{
    let failed = (rank.comm).all_gather(vec![f64::from(u8::from(method.is_err()))]);
    let method = method?;
    if let Some(rank) = failed.iter().position(|w| w[0] != 0.0) {
        return Err(CaseError::OtherRank {
            file: case.file.clone(),
            rank,
        });
    }
    let engine = CpuEngine::with(method, case.method.integrator);
    let engine = RankEngine::new(engine, rank).map_err(|e| case.invalid("method.name", e))?;
    Ok(Box::new(engine))
}

/// The kernel support of a case, with the margin of [`crate::core::kernel::neighbour_radius`].
pub(crate) fn neighbour_radius<D: Dim>(case: &Case) -> f64 {
    kernel::neighbour_radius(&case.kernel(D::N))
}

/// Corrected gradients g_ij on the neighbour lists `csr` of the reference positions x0
/// (and volumes) of a total-Lagrangian method, computed once.
pub(crate) fn reference_gradients<D: Dim>(
    case: &Case,
    x0: &[D::V],
    vol: &[f64],
    csr: &Csr,
) -> Result<Vec<D::V>, CaseError> {
    correction::gradients::<D>(case.method.correction, x0, vol, csr, &case.kernel(D::N))
        .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))
}

/// Each row's corrected gradient of its own kernel at its own reference position,
/// ∇0W̃_i(X_i), with the case's correction and kernel ([`correction::own_gradients`]).
pub(crate) fn own_gradients<D: Dim>(
    case: &Case,
    x0: &[D::V],
    vol: &[f64],
    csr: &Csr,
) -> Result<Vec<D::V>, CaseError> {
    correction::own_gradients::<D>(case.method.correction, x0, vol, csr, &case.kernel(D::N))
        .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))
}

/// For every pair (i, j) in CSR order, the index of the pair (j, i) in j's row. Lists
/// that are not symmetric (a neighbour at the kernel support, by round-off) name the
/// particle and the key to change.
pub fn reverse_pairs(case: &Case, csr: &Csr) -> Result<Vec<u32>, CaseError> {
    if csr.pair_count() > u32::MAX as usize {
        return Err(case.invalid(
            "spacing",
            format!(
                "{} neighbour pairs: the reverse pairs are indexed in u32, 4,294,967,295 at \
                 most; use a coarser spacing",
                csr.pair_count()
            ),
        ));
    }
    csr.map_rows(|i| {
        csr.neighbours(i)
            .iter()
            .map(|&j| {
                let row = j as usize;
                let back = csr.neighbours(row).binary_search(&(i as u32));
                back.map(|k| (csr.offsets[row] + k) as u32).map_err(|_| i)
            })
            .collect::<Result<Vec<_>, _>>()
    })
    .map_err(|i| {
        case.invalid(
            "method.h_over_dx",
            format!(
                "particle {i} has a neighbour at the kernel support that does not list it \
                 back; change h/dx slightly"
            ),
        )
    })
}

/// ∇0W̃_ji (j's corrected gradient, evaluated at i) for every pair (i, j), in CSR order:
/// the second gradient of a pair force that derives from Σ_i V_i ψ(F_i) (seed 000 eq 148).
pub(crate) fn reverse_gradients<D: Dim>(
    case: &Case,
    csr: &Csr,
    grad: &[D::V],
) -> Result<Vec<D::V>, CaseError> {
    let rev = reverse_pairs(case, csr)?;
    Ok(rev.par_iter().map(|&q| grad[q as usize]).collect())
}

/// A core's bindings `R` of one rate evaluation on each state an integrator evaluates
/// rates of: the state in `Y` and the stage state in `Stage`, both writing into `Rates`.
#[cfg(feature = "gpu")]
pub struct BySource<R>([R; 2]);

#[cfg(feature = "gpu")]
impl<R> BySource<R> {
    /// `bind(y, d)` with y the state in `Y`, then in `Stage`, and d the rates in `Rates`.
    pub fn bind<'a, E>(
        stepper: &'a crate::gpu::program::Stepper,
        bind: impl Fn(&'a wgpu::Buffer, &'a wgpu::Buffer) -> Result<R, E>,
    ) -> Result<Self, E> {
        let d = stepper.buffer(Buf::Rates);
        let y = bind(stepper.buffer(Buf::Y), d)?;
        Ok(Self([y, bind(stepper.buffer(Buf::Stage), d)?]))
    }

    /// The bindings on the state in `Y`.
    pub fn on_y(&self) -> &R {
        &self.0[0]
    }

    /// The bindings on the source state of evaluation e.
    pub fn of(&self, e: Evaluation) -> &R {
        &self.0[usize::from(e.src != Buf::Y)]
    }
}
