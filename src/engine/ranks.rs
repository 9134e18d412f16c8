//! The engine of one rank of a distributed run (`docs/distributed.md`): the method's CPU
//! system on the rank's particles (its own and its ghosts, [`Local`]), whose ghosts' rates
//! are replaced by their owners' after every rate evaluation, so that each rank's state
//! of a particle has the bits of the one-rank run's.
//!
//! Rank 0 leads: the driver runs there, and each [`Engine`] call it makes is sent to the
//! other ranks, which serve it ([`Distributed::serve`]) until rank 0's engine is dropped.
//! What the driver reads back is gathered on rank 0 in global order (snapshots, the first
//! blow-up); each rank writes its own piece of a checkpoint ([`PieceStore`]). Sums over particles (energies, powers, reactions)
//! are exact sums ([`Exact`]) of each rank's own particles' shares, added over the ranks
//! without rounding: they have the bits of the one-rank run's, on any number of ranks.

use super::cpu::{AfterRates, BALANCE_WORDS, StepSums};
use super::{BlowUp, CpuEngine, Engine, Failed, Method};
use crate::boundary::Reaction;
use crate::case::CaseError;
use crate::core::integrate::{OdeState, PseudoTime};
use crate::core::neighbour::Csr;
use crate::core::parallel::{ParticleRows, whole_word};
use crate::core::sum::{Exact, Ranks};
use crate::core::tensor::{Dim, Words};
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::{Quadrature, ScalarField, Snapshot};
use crate::distributed::{Collectives, Comm, Local, Partition};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Instant;

mod frames;
use frames::FrameRank;
pub use frames::FrameStore;

/// A rank's engine: rank 0's drives the run as an [`Engine`]; the others serve it.
pub trait Distributed<D: Dim>: Engine<D> {
    /// Whether this is rank 0's engine, which drives the run.
    fn is_leader(&self) -> bool;
    /// Serves rank 0's calls until its engine is dropped (the ranks other than 0).
    fn serve(self: Box<Self>);
}

/// Where the ranks of a distributed run keep their pieces of a checkpoint: the run's
/// files ([`crate::run::checkpoint::Pieces`]).
pub trait PieceStore: Send {
    /// Writes this rank's words of the checkpoint at `step` of a run on `ranks` ranks.
    fn write(&self, step: u64, ranks: usize, words: &[f64]) -> Result<(), String>;
    /// The words rank `rank` of `ranks` wrote at `step`, at most `most` of them.
    fn read(&self, step: u64, rank: usize, ranks: usize, most: u64) -> Result<Vec<f64>, String>;
}

/// What rank 0 holds of the whole run: the reference arrays the driver reads.
pub struct Whole<D: Dim> {
    pub x0: Vec<D::V>,
    /// The method's masses (a Galerkin method's nodal masses).
    pub mass: Vec<f64>,
    pub body: Vec<u32>,
    /// The constrained particles and their masks, by global id.
    pub constrained: Vec<(u32, u8)>,
    /// The corners of the method's elements, shown in the frames (none for a particle
    /// method).
    pub cells: Vec<u32>,
}

/// What a rank knows before its method partitions the run: the ranks, and the ghost
/// layers the method needs along its graph ([`MethodFamily::HALO_LAYERS`](crate::methods::cores::family::MethodFamily::HALO_LAYERS)).
pub struct RankStart<D: Dim> {
    pub comm: Arc<dyn Comm>,
    pub layers: usize,
    /// Where the rank writes and reads its pieces of the checkpoints.
    pub pieces: Box<dyn PieceStore>,
    /// Where it writes its pieces of the frames; None when the run writes no frames.
    pub frames: Option<Box<dyn FrameStore<D>>>,
}

impl<D: Dim> RankStart<D> {
    /// This rank of a run whose particles (a Galerkin method's nodes) are `whole`, split
    /// by recursive coordinate bisection of their reference positions weighted by the
    /// rows of `graph` (a particle's neighbours; the nodes a node shares a point with),
    /// with the ghosts within the method's layers along `graph`. Rank 0 keeps `whole`.
    /// An error names the case `file` when the run has fewer particles than ranks.
    pub fn split(self, graph: &Csr, whole: Whole<D>, file: &Path) -> Result<Rank<D>, CaseError> {
        let partition =
            Partition::bisect::<D>(&whole.x0, graph, self.comm.size()).map_err(|e| {
                CaseError::Ranks {
                    file: file.to_path_buf(),
                    reason: e.to_string(),
                }
            })?;
        let rank = self.comm.rank();
        let local = Local::new(&partition, graph, rank, self.layers);
        let frames = (self.frames).map(|store| FrameRank::new(store, &partition, &whole, rank));
        Ok(Rank {
            local,
            n: whole.x0.len(),
            comm: self.comm,
            whole: (rank == 0).then_some(whole),
            inside: Arc::default(),
            pieces: self.pieces,
            frames,
        })
    }
}

/// Where a rank's engine stands in the run: its particles, the other ranks, the run's
/// particle count and, on rank 0, the whole run's reference arrays.
pub struct Rank<D: Dim> {
    pub local: Local,
    pub comm: Arc<dyn Comm>,
    pub n: usize,
    pub whole: Option<Whole<D>>,
    /// Wall time the rank's system spends in its own collectives and exchanges inside
    /// its rate evaluations ([`Peers`]) [s].
    pub inside: Arc<Mutex<f64>>,
    /// Where the rank writes and reads its pieces of the checkpoints.
    pub pieces: Box<dyn PieceStore>,
    /// Its share of the frames, when the run writes them.
    pub frames: Option<FrameRank<D>>,
}

impl<D: Dim> Rank<D> {
    /// The other ranks as the rank's system sees them
    /// ([`Reference::ranks`](crate::reference::Reference::ranks)).
    pub fn peers(&self) -> Peers {
        Peers {
            comm: self.comm.clone(),
            local: self.local.clone(),
            seconds: self.inside.clone(),
        }
    }
}

/// The calls rank 0 sends, as the first word of a message.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Call {
    Advance = 1,
    MaxSignalSpeed,
    Booked,
    Reactions,
    Check,
    Snapshot,
    Save,
    Restore,
    SavePieces,
    RestorePieces,
    Frame,
    End,
}

impl Call {
    const ALL: [Call; 12] = [
        Call::Advance,
        Call::MaxSignalSpeed,
        Call::Booked,
        Call::Reactions,
        Call::Check,
        Call::Snapshot,
        Call::Save,
        Call::Restore,
        Call::SavePieces,
        Call::RestorePieces,
        Call::Frame,
        Call::End,
    ];

    fn of(word: f64) -> Call {
        Self::ALL
            .into_iter()
            .find(|&c| c as u8 as f64 == word)
            .expect("rank 0 sends the calls of this build")
    }
}

/// The hook after each rate evaluation: the ghosts' rates from their owners, and the
/// first blow-up of the step, kept (a rank that stopped would leave the others waiting
/// for its rows). After a step whose end changes the state, the ghosts' state from their
/// owners. At the end of the step the ranks agree on the first blow-up and add their
/// shares of the step's sums, in one collective.
struct Exchange {
    local: Local,
    comm: Arc<dyn Comm>,
    /// Whether the method's end of a step changes the state
    /// ([`Method::step_end_changes_state`]).
    step_end: bool,
    /// The number of particles of the run.
    n: usize,
    /// The rate evaluations of the current step so far.
    stage: usize,
    /// The first blow-up of the current step and its evaluation.
    failure: Option<(usize, BlowUp)>,
    /// The key of the run's first blow-up in the step (evaluation · n + global id), or
    /// none: every rank's, agreed at the end of the step.
    first: Option<usize>,
    /// Wall time in the exchanges so far ([`Engine::halo_seconds`]) [s].
    seconds: f64,
    /// Wall time in the system's own collectives and exchanges, inside its rate
    /// evaluations ([`Rank::inside`]) [s].
    inside: Arc<Mutex<f64>>,
}

impl Exchange {
    /// The key of this rank's first blow-up of the step: by evaluation, then global id.
    fn key(&self) -> Option<usize> {
        (self.failure.as_ref())
            .map(|(stage, b)| stage * self.n + self.local.ids[b.particle] as usize)
    }
}

impl<S: ParticleRows> AfterRates<S> for Exchange {
    fn after_rates(&mut self, d: &mut S, result: Result<(), BlowUp>) -> Result<(), BlowUp> {
        if let (Err(b), None) = (result, &self.failure) {
            self.failure = Some((self.stage, b));
        }
        self.stage += 1;
        let started = Instant::now();
        self.local.refresh(self.comm.as_ref(), d);
        self.seconds += started.elapsed().as_secs_f64();
        Ok(())
    }

    fn after_step(&mut self, y: &mut S) {
        if self.step_end {
            let started = Instant::now();
            self.local.refresh(self.comm.as_ref(), y);
            self.seconds += started.elapsed().as_secs_f64();
        }
    }

    fn sums(&mut self, shares: StepSums<Exact>) -> StepSums<f64> {
        let key = self.key().map_or(f64::INFINITY, |k| k as f64);
        let mut words = vec![key];
        words.extend(shares.iter().flat_map(Exact::words));
        let started = Instant::now();
        let all = self.comm.all_gather(words);
        self.seconds += started.elapsed().as_secs_f64();
        let first = all.iter().map(|w| w[0]).fold(f64::INFINITY, f64::min);
        self.first = first.is_finite().then_some(first as usize);
        let total = sum_over_ranks(&all, 1, shares.len());
        std::array::from_fn(|k| total[k].value())
    }
}

/// The `count` exact sums each rank sent as words (from word `skip` on), added over the
/// ranks.
fn sum_over_ranks(all: &[Vec<f64>], skip: usize, count: usize) -> Vec<Exact> {
    let mut total = vec![Exact::default(); count];
    for w in all {
        for (t, sum) in total.iter_mut().zip(w[skip..].chunks_exact(Exact::WORDS)) {
            t.merge(&Exact::from_words(sum));
        }
    }
    total
}

/// The other ranks as a rank's system sees them inside a rate evaluation ([`Ranks`]):
/// its sums completed and its ghosts refreshed over `comm`, one collective or exchange
/// per call.
pub struct Peers {
    comm: Arc<dyn Comm>,
    local: Local,
    /// The wall time in these calls so far [s].
    seconds: Arc<Mutex<f64>>,
}

impl Peers {
    /// The words of every rank, in rank order, timed.
    fn all_gather(&self, words: Vec<f64>) -> Vec<Vec<f64>> {
        let started = Instant::now();
        let all = self.comm.all_gather(words);
        *self.seconds.lock().expect("a rank's clock") += started.elapsed().as_secs_f64();
        all
    }
}

impl Ranks for Peers {
    fn add_others(&self, sums: &mut [Exact]) {
        let words = sums.iter().flat_map(Exact::words).collect();
        let all = self.all_gather(words);
        let total = sum_over_ranks(&all, 0, sums.len());
        sums.clone_from_slice(&total);
    }

    fn max(&self, values: &mut [f64]) {
        for w in self.all_gather(values.to_vec()) {
            values.iter_mut().zip(w).for_each(|(v, w)| *v = v.max(w));
        }
    }

    fn worst(&self, particle: usize, size: f64) -> (bool, f64) {
        let gid = f64::from(self.local.ids[particle]);
        let all = self.all_gather(vec![size, gid]);
        // As one rank's scan in particle order: the larger, then the lower global id.
        let later = |a: &[f64], b: &[f64]| b[0] > a[0] || (b[0] == a[0] && b[1] < a[1]);
        let winner = (1..all.len()).fold(0, |w, r| if later(&all[w], &all[r]) { r } else { w });
        (winner == self.comm.rank(), all[winner][0])
    }

    fn refresh(&self, put: &dyn Fn(&[u32], &mut Vec<f64>), take: &mut dyn FnMut(&[u32], &[f64])) {
        let started = Instant::now();
        self.local.refresh_rows(self.comm.as_ref(), put, take);
        *self.seconds.lock().expect("a rank's clock") += started.elapsed().as_secs_f64();
    }
}

/// The rows of a rank's quadrature points (those it counts): global index, X, w, u^h
/// and F.
fn point_words<D: Dim>(q: &Quadrature<D>) -> Vec<f64> {
    let mut words = Vec::new();
    for (k, &id) in q.ids.iter().enumerate() {
        words.push(f64::from(id));
        q.x0[k].put(&mut words);
        words.push(q.weight[k]);
        q.u[k].put(&mut words);
        q.f[k].put(&mut words);
    }
    words
}

/// The quadrature points of the whole run from every rank's [`point_words`], in global
/// order.
fn gathered_points<D: Dim>(all: &[Vec<f64>]) -> Quadrature<D> {
    let (lv, lt) = (D::V::LEN, D::T::LEN);
    let row = 2 + 2 * lv + lt;
    let count = all.iter().map(|w| w.len() / row).sum();
    let mut q = Quadrature {
        x0: vec![D::zero(); count],
        weight: vec![0.0; count],
        u: vec![D::zero(); count],
        f: vec![D::zero_t(); count],
        ids: Vec::new(),
    };
    for w in all.iter().flat_map(|w| w.chunks_exact(row)) {
        let k = w[0] as usize;
        q.x0[k] = D::V::take(&w[1..]);
        q.weight[k] = w[1 + lv];
        q.u[k] = D::V::take(&w[2 + lv..]);
        q.f[k] = D::T::take(&w[2 + 2 * lv..]);
    }
    q
}

/// Every rank's `result`: Ok on all, or the first rank's error, naming the rank (on
/// every rank, so that none goes on alone).
fn agree(comm: &dyn Comm, result: Result<(), String>) -> Result<(), String> {
    let mine = match &result {
        Ok(()) => Vec::new(),
        Err(e) => e.bytes().map(f64::from).collect(),
    };
    let all = comm.all_gather(mine);
    match all.iter().position(|w| !w.is_empty()) {
        None => Ok(()),
        Some(r) if r == comm.rank() => result,
        Some(r) => {
            let bytes: Vec<u8> = all[r].iter().map(|&b| b as u8).collect();
            Err(format!("rank {r}: {}", String::from_utf8_lossy(&bytes)))
        }
    }
}

/// The words of a CPU engine's checkpoint ([`CpuEngine::save`]) of a method without a
/// history besides its state (those that run on several ranks): the balance's, the
/// state and, once the leapfrog is primed, its rates.
struct Saved<S> {
    balance: Vec<f64>,
    y: S,
    rates: Option<S>,
}

impl<S: OdeState + ParticleRows> Saved<S> {
    /// The words of an engine whose state has the fields of `template`.
    fn split(template: &S, words: &[f64]) -> Result<Self, String> {
        let (balance, mut rest) = words
            .split_at_checked(BALANCE_WORDS)
            .ok_or("the checkpoint holds no engine state")?;
        let mut y = template.clone();
        y.load(&mut rest)?;
        let (&flag, mut after) = rest.split_first().ok_or("no integrator flag")?;
        let rates = match flag == 1.0 {
            true => {
                let mut rates = template.clone();
                rates.load(&mut after)?;
                Some(rates)
            }
            false => None,
        };
        if !after.is_empty() {
            return Err(format!(
                "{} words are left over after the engine's state",
                after.len()
            ));
        }
        Ok(Self {
            balance: balance.to_vec(),
            y,
            rates,
        })
    }

    /// n particles of zero state (and rates, if `primed`) with the fields of `template`.
    fn zeros(template: &S, n: usize, balance: Vec<f64>, primed: bool) -> Self {
        Self {
            balance,
            y: template.zeros_like(n),
            rates: primed.then(|| template.zeros_like(n)),
        }
    }

    /// Appends the rows of the particles `ids`: each one's state, then its rates.
    fn rows(&self, ids: &[u32], out: &mut Vec<f64>) {
        for &i in ids {
            self.y.rows(&[i], out);
            if let Some(rates) = &self.rates {
                rates.rows(&[i], out);
            }
        }
    }

    /// Overwrites the particles `ids` with the rows of [`Self::rows`].
    fn set_rows(&mut self, ids: &[u32], mut words: &[f64]) {
        for &i in ids {
            words = self.y.set_rows(&[i], words);
            if let Some(rates) = &mut self.rates {
                words = rates.set_rows(&[i], words);
            }
        }
    }

    /// The words [`Self::split`] reads.
    fn join(self) -> Vec<f64> {
        let mut out = self.balance;
        self.y.save(&mut out);
        out.push(f64::from(u8::from(self.rates.is_some())));
        if let Some(rates) = self.rates {
            rates.save(&mut out);
        }
        out
    }
}

/// The exact sums of `sums` over the ranks, on rank 0 (none on the others).
fn gathered_sums(comm: &dyn Comm, sums: &[&Exact]) -> Option<Vec<Exact>> {
    let words = sums.iter().flat_map(|s| s.words()).collect();
    Some(sum_over_ranks(&comm.gather(words)?, 0, sums.len()))
}

/// The words of particle i's state in a snapshot, as the ranks send them: u, v, F, σ
/// (9 words) and the method's extra fields.
fn put_state_row<D: Dim>(s: &Snapshot<D>, i: usize, out: &mut Vec<f64>) {
    s.u[i].put(out);
    s.v[i].put(out);
    s.f[i].put(out);
    out.extend(s.sigma[i].iter().flatten());
    out.extend(s.extra.iter().map(|e| e.values[i]));
}

/// The words of [`put_state_row`] with `extra` extra fields.
fn state_row_width<D: Dim>(extra: usize) -> usize {
    2 * D::V::LEN + D::T::LEN + 9 + extra
}

/// Sets particle i's state in `s` from the words of [`put_state_row`].
fn set_state_row<D: Dim>(s: &mut Snapshot<D>, i: usize, w: &[f64]) {
    let (lv, lt) = (D::V::LEN, D::T::LEN);
    s.u[i] = D::V::take(w);
    s.v[i] = D::V::take(&w[lv..]);
    s.f[i] = D::T::take(&w[2 * lv..]);
    let sigma = &w[2 * lv + lt..];
    for (k, r) in s.sigma[i].iter_mut().enumerate() {
        r.copy_from_slice(&sigma[3 * k..3 * k + 3]);
    }
    for (e, &x) in s.extra.iter_mut().zip(&w[2 * lv + lt + 9..]) {
        e.values[i] = x;
    }
}

/// The names of a snapshot's extra fields.
fn extra_names<D: Dim>(s: &Snapshot<D>) -> Vec<&'static str> {
    s.extra.iter().map(|e| e.name).collect()
}

/// A snapshot of n particles of zero state on the reference arrays given, with the
/// extra fields `names`, no cells and no quadrature points.
fn zero_snapshot<'a, D: Dim>(
    x0: &'a [D::V],
    mass: &'a [f64],
    body: &'a [u32],
    names: &[&'static str],
    n: usize,
) -> Snapshot<'a, D> {
    Snapshot {
        x0,
        mass,
        body,
        u: vec![D::zero(); n],
        v: vec![D::zero(); n],
        f: vec![D::zero_t(); n],
        sigma: vec![[[0.0; 3]; 3]; n],
        strain_energy: Exact::default(),
        extra: (names.iter())
            .map(|&name| ScalarField {
                name,
                values: vec![0.0; n],
            })
            .collect(),
        cells: &[],
        quadrature: None,
    }
}

/// The engine of one rank: the method on its particles, an integrator and the exchange.
pub struct RankEngine<D: Dim, M: Method<D>> {
    engine: CpuEngine<D, M>,
    exchange: Exchange,
    /// The number of particles of the run.
    n: usize,
    /// Rank 0's view of the whole run; none on the others.
    whole: Option<Whole<D>>,
    /// The global ids each rank owns, in rank order (rank 0; none on the others): where
    /// the rows gathered from each rank go.
    owned: Vec<Vec<u32>>,
    /// Where the rank keeps its pieces of the checkpoints.
    pieces: Box<dyn PieceStore>,
    /// Its share of the frames, when the run writes them.
    frames: Option<FrameRank<D>>,
}

/// A blow-up as words: its global particle, value and quantity (one word per byte).
fn blow_up_words(gid: u32, b: &BlowUp) -> Vec<f64> {
    let mut w = vec![f64::from(gid), b.value];
    w.extend(b.quantity.bytes().map(f64::from));
    w
}

/// The blow-up of [`blow_up_words`] at its reference position in `x0` (global).
fn blow_up_of<D: Dim>(w: &[f64], x0: &[D::V]) -> BlowUp {
    let quantity: Vec<u8> = w[2..].iter().map(|&c| c as u8).collect();
    BlowUp::at::<D>(x0, w[0] as usize, &String::from_utf8_lossy(&quantity), w[1])
}

impl<D: Dim, M: Method<D>> RankEngine<D, M>
where
    M::State: ParticleRows,
{
    /// The engine of a rank: `engine` on the rank's particles. An error for a method that
    /// keeps a history besides its state, which a checkpoint of several ranks does not
    /// gather yet.
    pub fn new(engine: CpuEngine<D, M>, rank: Rank<D>) -> Result<Self, String> {
        let Rank {
            local,
            comm,
            n,
            whole,
            inside,
            pieces,
            frames,
        } = rank;
        let mut history = Vec::new();
        engine.method.save_history(&mut history);
        if !history.is_empty() {
            return Err(
                "a method that keeps a history besides its state (a plastic \
                        material's) does not run on several ranks yet"
                    .into(),
            );
        }
        let mine: Vec<f64> = (local.own.iter())
            .map(|&i| f64::from(local.ids[i as usize]))
            .collect();
        let owned = (comm.gather(mine).unwrap_or_default().iter())
            .map(|w| w.iter().map(|&g| g as u32).collect())
            .collect();
        Ok(Self {
            owned,
            exchange: Exchange {
                step_end: engine.method.step_end_changes_state(),
                local,
                comm,
                n,
                stage: 0,
                failure: None,
                first: None,
                seconds: 0.0,
                inside,
            },
            engine,
            n,
            whole,
            pieces,
            frames,
        })
    }

    fn comm(&self) -> &dyn Comm {
        self.exchange.comm.as_ref()
    }

    fn local(&self) -> &Local {
        &self.exchange.local
    }

    /// Rank 0 sends a call and its arguments to the others.
    fn send(&self, call: Call, args: &[f64]) {
        let mut words = vec![call as u8 as f64];
        words.extend_from_slice(args);
        self.comm().broadcast(&mut words);
    }

    /// `steps` steps from t; every rank stops after the first step on which any failed
    /// (Err: the steps completed before it), and rank 0 gets the blow-up one rank would
    /// have found first: in the earliest rate evaluation, at the lowest global id.
    fn advance_all(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), (u32, Option<BlowUp>)> {
        for k in 0..steps {
            let ex = &mut self.exchange;
            (ex.stage, ex.failure, ex.first) = (0, None, None);
            let t_k = t + f64::from(k) * dt;
            self.engine
                .advance_hooked(t_k, dt, 1, ex)
                .expect("the exchange keeps every blow-up for the agreement");
            let ex = &self.exchange;
            if let Some(first) = ex.first {
                let mine = match &ex.failure {
                    Some((_, b)) if ex.key() == Some(first) => {
                        blow_up_words(ex.local.ids[b.particle], b)
                    }
                    _ => Vec::new(),
                };
                let cause = self.comm().gather(mine).map(|all| {
                    let w = all.iter().find(|w| !w.is_empty()).expect("a rank failed");
                    blow_up_of::<D>(w, &self.whole().x0)
                });
                return Err((k, cause));
            }
        }
        Ok(())
    }

    /// The run's signal speed: each of the method's terms the largest of the ranks',
    /// then added as one rank adds them.
    fn max_signal_speed_all(&self) -> f64 {
        let terms = self.engine.method.signal_speed_terms(&self.engine.y);
        let all = self.comm().all_gather(terms.to_vec());
        let largest = |k: usize| all.iter().map(|w| w[k]).fold(f64::NEG_INFINITY, f64::max);
        largest(0) + largest(1)
    }

    /// The first non-finite particle of the run, on rank 0: the lowest global id among
    /// the ranks' first.
    fn check_all(&mut self) -> Result<(), BlowUp> {
        let mine = match self.engine.check() {
            Err(b) => blow_up_words(self.local().ids[b.particle], &b),
            Ok(()) => Vec::new(),
        };
        let Some(all) = self.comm().gather(mine) else {
            return Ok(());
        };
        let whole = self.whole.as_ref().expect("rank 0 holds the whole run");
        let first = all
            .iter()
            .filter(|w| !w.is_empty())
            .min_by(|a, b| a[0].total_cmp(&b[0]));
        first.map_or(Ok(()), |w| Err(blow_up_of::<D>(w, &whole.x0)))
    }

    /// The snapshot's rows of this rank's own particles (u, v, F, σ, the extra fields)
    /// and of its quadrature points, if the method has them, gathered on rank 0 in global
    /// order, and the strain energy summed over the ranks.
    fn snapshot_all(&mut self) -> Option<Snapshot<'_, D>> {
        let (words, names, energy, points) = {
            let local = &self.exchange.local;
            let s = self.engine.snapshot();
            let mut words = Vec::new();
            for &i in &local.own {
                put_state_row(&s, i as usize, &mut words);
            }
            let points = s.quadrature.as_ref().map(point_words::<D>);
            (words, extra_names(&s), s.strain_energy, points)
        };
        let comm = self.exchange.comm.as_ref();
        let strain_energy = gathered_sums(comm, &[&energy]).map(|mut s| s.remove(0));
        let points = points.and_then(|w| comm.gather(w));
        let all = comm.gather(words)?;
        let whole = self.whole.as_ref().expect("rank 0 holds the whole run");
        let mut g = zero_snapshot(&whole.x0, &whole.mass, &whole.body, &names, self.n);
        g.strain_energy = strain_energy.expect("rank 0 gathers");
        g.cells = &whole.cells;
        g.quadrature = points.map(|all| gathered_points::<D>(&all));
        let width = state_row_width::<D>(names.len());
        for (ids, words) in self.owned.iter().zip(&all) {
            for (&gid, w) in ids.iter().zip(words.chunks_exact(width)) {
                set_state_row(&mut g, gid as usize, w);
            }
        }
        Some(g)
    }

    /// The engine's checkpoint words as one rank's would be (rank 0; none on the others):
    /// the integrated powers (the run's, on every rank), the state and the integrator's
    /// rates by global id.
    fn save_all(&mut self) -> Option<Vec<f64>> {
        let words = self.engine.save();
        let saved = Saved::split(&self.engine.y, &words).expect("the engine's own words");
        let local = &self.exchange.local;
        let mut rows = Vec::new();
        saved.rows(&local.own, &mut rows);
        let all = self.exchange.comm.gather(rows)?;
        let mut whole = Saved::zeros(&self.engine.y, self.n, saved.balance, saved.rates.is_some());
        for (ids, words) in self.owned.iter().zip(&all) {
            whole.set_rows(ids, words);
        }
        Some(whole.join())
    }

    /// Continues from one rank's checkpoint words, `words` on rank 0 (any number of
    /// ranks wrote them): each rank takes its particles' rows and the integrated powers.
    fn restore_all(&mut self, words: &[f64]) -> Result<(), String> {
        let result = self.restore_local(words);
        agree(self.comm(), result)
    }

    fn restore_local(&mut self, words: &[f64]) -> Result<(), String> {
        let template = self.engine.y.zeros_like(self.n);
        let whole = Saved::split(&template, words)?;
        let local = &self.exchange.local;
        let mut rows = Vec::new();
        whole.rows(&local.ids, &mut rows);
        let primed = whole.rates.is_some();
        let mut mine = Saved::zeros(&self.engine.y, local.len(), whole.balance, primed);
        let every: Vec<u32> = (0..local.len() as u32).collect();
        mine.set_rows(&every, &rows);
        self.engine.restore(&mine.join())
    }

    /// This rank's piece of the checkpoint at `step`: the number of particles it owns,
    /// their global ids, their rows of the state and, once the leapfrog is primed, of its
    /// rates after a flag; every rank learns whether all wrote theirs. Rank 0 gets the
    /// words of the checkpoint file (the balance's and the step) and the rank count.
    fn save_pieces_all(&mut self, step: u64) -> Result<(Vec<f64>, usize), String> {
        let words = self.engine.save();
        let saved = Saved::split(&self.engine.y, &words).expect("the engine's own words");
        let local = &self.exchange.local;
        let mut piece = vec![local.own.len() as f64];
        piece.extend(local.own.iter().map(|&i| f64::from(local.ids[i as usize])));
        piece.push(f64::from(u8::from(saved.rates.is_some())));
        saved.rows(&local.own, &mut piece);
        let ranks = self.comm().size();
        let written = self.pieces.write(step, ranks, &piece);
        agree(self.comm(), written)?;
        let mut file = saved.balance;
        file.push(step as f64);
        Ok((file, ranks))
    }

    /// Continues from a checkpoint in pieces that `ranks` ranks wrote (any number), whose
    /// file holds `words` (the balance's and the step): each rank reads every piece and
    /// takes the rows of its particles, own and ghosts, by global id.
    fn restore_pieces_all(&mut self, ranks: usize, words: &[f64]) -> Result<(), String> {
        let result = self.restore_pieces_local(ranks, words);
        agree(self.comm(), result)
    }

    fn restore_pieces_local(&mut self, ranks: usize, words: &[f64]) -> Result<(), String> {
        let (balance, step) = match words {
            [balance @ .., step] if balance.len() == BALANCE_WORDS => (balance, *step),
            _ => return Err("its engine words do not name a step of pieces".into()),
        };
        let step = whole_word(step).ok_or("its step of pieces is not a count")?;
        let local = &self.exchange.local;
        let mut width = Vec::new();
        self.engine.y.rows(&[0], &mut width);
        let row = width.len();
        let most = (2 + (1 + 2 * row) * self.n) as u64;
        let mut mine: Option<Saved<M::State>> = None;
        let mut seen = vec![false; local.len()];
        for rank in 0..ranks {
            let piece = self.pieces.read(step, rank, ranks, most)?;
            let bad = |why: &str| format!("the piece of rank {rank} is malformed: {why}");
            let (&m, rest) = piece.split_first().ok_or_else(|| bad("it is empty"))?;
            let m = whole_word(m)
                .filter(|&c| c <= self.n as u64)
                .ok_or_else(|| bad("its particle count"))? as usize;
            let (gids, rest) = rest.split_at_checked(m).ok_or_else(|| bad("its ids"))?;
            let (&flag, rows) = rest.split_first().ok_or_else(|| bad("its flag"))?;
            let primed = flag == 1.0;
            let per = if primed { 2 * row } else { row };
            if !(flag == 0.0 || primed) || rows.len() != m * per {
                return Err(bad("its rows"));
            }
            let mine = mine.get_or_insert_with(|| {
                Saved::zeros(&self.engine.y, local.len(), balance.to_vec(), primed)
            });
            if mine.rates.is_some() != primed {
                return Err(bad("its flag differs from rank 0's"));
            }
            for (&g, words) in gids.iter().zip(rows.chunks_exact(per)) {
                let g = whole_word(g)
                    .filter(|&c| c < self.n as u64)
                    .ok_or_else(|| bad("a global id"))?;
                if let Ok(i) = local.ids.binary_search(&(g as u32)) {
                    if std::mem::replace(&mut seen[i], true) {
                        return Err(bad("a particle it holds twice"));
                    }
                    mine.set_rows(&[i as u32], words);
                }
            }
        }
        let missing = seen.iter().filter(|&&s| !s).count();
        match mine {
            Some(mine) if missing == 0 => self.engine.restore(&mine.join()),
            _ => Err(format!(
                "the pieces lack {missing} of this rank's {} particles",
                local.len()
            )),
        }
    }

    /// Every rank writes its piece of frame `frame` at time t, and rank 0 the frame's
    /// index; returns the bytes written.
    fn frame_all(&mut self, frame: usize, t: f64) -> Result<u64, String> {
        let frames = (self.frames.as_mut()).ok_or("the run was started without frames")?;
        let state = self.engine.snapshot();
        let ex = &self.exchange;
        frames.write(ex.comm.as_ref(), &ex.local, state, frame, t)
    }

    /// The balance's terms: the integrated powers and the steps' ends are the run's on
    /// every rank; the plastic work, each rank's share, is added over the ranks (zero for
    /// the methods that run on several ranks).
    fn booked_all(&mut self) -> Booked {
        let share = [self.engine.method.plastic_work(&self.engine.y)];
        let s = self.comm().sum(&share);
        self.engine.booked_with(s[0])
    }

    /// The supports' reactions, their exact sums added over the ranks (rank 0; none on
    /// the others).
    fn reactions_all(&mut self) -> Option<Vec<Reaction>> {
        let mine = &self.engine.method.boundary_work().reactions;
        let sums: Vec<&Exact> = mine
            .iter()
            .flat_map(|r| r.force.iter().chain([&r.power]))
            .collect();
        let total = gathered_sums(self.exchange.comm.as_ref(), &sums)?;
        let reaction = |w: &[Exact]| Reaction {
            force: [w[0].value(), w[1].value(), w[2].value()],
            power: w[3].value(),
        };
        Some(total.chunks_exact(4).map(reaction).collect())
    }

    fn whole(&self) -> &Whole<D> {
        self.whole.as_ref().expect("rank 0 drives the run")
    }
}

impl<D: Dim, M: Method<D>> Engine<D> for RankEngine<D, M>
where
    M::State: ParticleRows,
{
    fn backend(&self) -> String {
        format!("cpu on {} ranks", self.comm().size())
    }

    fn reference(&self) -> &[D::V] {
        &self.whole().x0
    }

    fn constrained(&self) -> &[(u32, u8)] {
        &self.whole().constrained
    }

    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        self.send(Call::Advance, &[t, dt, f64::from(steps)]);
        self.advance_all(t, dt, steps)
            .map_err(|(completed, cause)| Failed {
                completed,
                cause: cause.expect("rank 0 gathers the blow-up"),
            })
    }

    fn halo_seconds(&mut self) -> Option<f64> {
        let inside = *self.exchange.inside.lock().expect("a rank's clock");
        Some(self.exchange.seconds + inside)
    }

    /// Rank 0's counts: every rank iterates until the residual over all of them
    /// converges, so all count the same iterations and residuals.
    fn pseudo_time(&mut self) -> Option<PseudoTime> {
        self.engine.pseudo_time()
    }

    fn max_signal_speed(&mut self) -> f64 {
        self.send(Call::MaxSignalSpeed, &[]);
        self.max_signal_speed_all()
    }

    fn external_work(&mut self) -> f64 {
        self.booked().external_work
    }

    fn reactions(&mut self) -> Vec<Reaction> {
        self.send(Call::Reactions, &[]);
        self.reactions_all().expect("rank 0 gathers the reactions")
    }

    fn booked(&mut self) -> Booked {
        self.send(Call::Booked, &[]);
        self.booked_all()
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        self.send(Call::Check, &[]);
        self.check_all()
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        self.send(Call::Snapshot, &[]);
        self.snapshot_all().expect("rank 0 gathers the snapshot")
    }

    fn save(&mut self) -> Vec<f64> {
        self.send(Call::Save, &[]);
        self.save_all().expect("rank 0 gathers the checkpoint")
    }

    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        self.send(Call::Restore, words);
        self.restore_all(words)
    }

    fn save_pieces(&mut self, step: u64) -> Option<Result<(Vec<f64>, usize), String>> {
        self.send(Call::SavePieces, &[step as f64]);
        Some(self.save_pieces_all(step))
    }

    /// The words of one rank's checkpoint of the whole run (of [`Self::save`]) before the
    /// leapfrog is primed, without gathering them.
    fn checkpoint_words(&mut self) -> usize {
        let mut state = Vec::new();
        self.engine.y.zeros_like(self.n).save(&mut state);
        BALANCE_WORDS + state.len() + 1
    }

    fn restore_pieces(&mut self, ranks: usize, words: &[f64]) -> Result<(), String> {
        let mut args = vec![ranks as f64];
        args.extend_from_slice(words);
        self.send(Call::RestorePieces, &args);
        self.restore_pieces_all(ranks, words)
    }

    fn writes_frame_pieces(&self) -> bool {
        self.frames.is_some()
    }

    fn write_frame_pieces(&mut self, frame: usize, t: f64) -> Result<u64, String> {
        self.send(Call::Frame, &[frame as f64, t]);
        self.frame_all(frame, t)
    }
}

impl<D: Dim, M: Method<D>> Distributed<D> for RankEngine<D, M>
where
    M::State: ParticleRows,
{
    fn is_leader(&self) -> bool {
        self.whole.is_some()
    }

    fn serve(mut self: Box<Self>) {
        loop {
            let mut words = Vec::new();
            self.comm().broadcast(&mut words);
            let args = &words[1..];
            match Call::of(words[0]) {
                Call::Advance => {
                    // Rank 0 reports the failure; this rank only stops.
                    let _ = self.advance_all(args[0], args[1], args[2] as u32);
                }
                Call::MaxSignalSpeed => {
                    self.max_signal_speed_all();
                }
                Call::Booked => {
                    self.booked_all();
                }
                Call::Reactions => {
                    self.reactions_all();
                }
                Call::Check => {
                    let _ = self.check_all();
                }
                Call::Snapshot => {
                    self.snapshot_all();
                }
                Call::Save => {
                    self.save_all();
                }
                Call::Restore => {
                    let _ = self.restore_all(args);
                }
                Call::SavePieces => {
                    let _ = self.save_pieces_all(args[0] as u64);
                }
                Call::RestorePieces => {
                    let _ = self.restore_pieces_all(args[0] as usize, &args[1..]);
                }
                Call::Frame => {
                    let _ = self.frame_all(args[0] as usize, args[1]);
                }
                Call::End => return,
            }
        }
    }
}

impl<D: Dim, M: Method<D>> Drop for RankEngine<D, M> {
    /// Rank 0's engine ends the others' service.
    fn drop(&mut self) {
        if self.whole.is_some() {
            let mut words = vec![Call::End as u8 as f64];
            self.exchange.comm.broadcast(&mut words);
        }
    }
}
