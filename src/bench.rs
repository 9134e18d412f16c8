//! `meshless bench`: throughput of a case on a backend at several sizes, in
//! particle-steps per second, measured over whole steps after a warm-up.

use crate::case::discretise;
use crate::core::tensor::{D2, D3};
use crate::diagnostics::passes::PassReport;
use crate::engine::{Engine, EngineDim, StepTraffic};
use crate::run::{Backend, RunError, engine, with_threads};
use crate::scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub case: String,
    pub backend: String,
    pub particles: usize,
    pub steps: u32,
    /// Set-up time (discretisation, neighbours, corrected gradients, uploads) [s].
    pub setup_seconds: f64,
    /// Time of the measured steps [s].
    pub seconds: f64,
    pub particle_steps_per_second: f64,
    /// Particle-steps/s times the rate evaluations per step of the integrator.
    pub rate_evaluations_per_second: f64,
    /// The share of the measured steps' time spent keeping the neighbour lists up to date
    /// (`Engine::neighbour_seconds`), for the methods whose lists follow the particles.
    pub neighbour_share: Option<f64>,
    /// On the GPU, the pass report of further steps run with profiling on.
    pub passes: Option<PassReport>,
    /// On the CPU, what a step moves by the method's traffic model (`Engine::traffic`).
    pub traffic: Option<StepTraffic>,
    /// On the CPU, the pairs per particle a rate evaluation loops over
    /// (`Engine::pairs_per_particle`).
    pub pairs_per_particle: Option<f64>,
    /// On the GPU, the bytes of the device buffers the engine made by the end of its
    /// warm-up step ([`crate::gpu::Gpu::allocated`]).
    pub device_bytes: Option<u64>,
}

impl BenchRow {
    /// The bandwidth the model's bytes reach at the measured throughput [bytes/s].
    pub fn modelled_bandwidth(&self) -> Option<f64> {
        self.traffic
            .map(|t| t.bytes_per_particle * self.particle_steps_per_second)
    }

    /// The time per neighbour pair of one rate evaluation [s], for comparing methods and
    /// dimensions whose pair counts differ.
    pub fn seconds_per_pair(&self) -> Option<f64> {
        self.pairs_per_particle
            .map(|pairs| 1.0 / (self.rate_evaluations_per_second * pairs))
    }

    /// The device bytes per particle.
    pub fn device_bytes_per_particle(&self) -> Option<f64> {
        (self.device_bytes).map(|b| b as f64 / self.particles.max(1) as f64)
    }

    pub const HEADER: &'static str = "case,backend,particles,steps,setup_s,seconds,particle_steps_per_s,rate_evaluations_per_s,neighbour_share,pairs_per_particle,ns_per_pair,bytes_per_particle_step,device_bytes";

    pub fn csv(&self) -> String {
        format!(
            "{},{},{},{},{:.6},{:.6},{:.6e},{:.6e},{},{},{},{},{}",
            self.case,
            self.backend.replace(',', ";"),
            self.particles,
            self.steps,
            self.setup_seconds,
            self.seconds,
            self.particle_steps_per_second,
            self.rate_evaluations_per_second,
            self.neighbour_share
                .map_or(String::new(), |s| format!("{s:.4}")),
            self.pairs_per_particle
                .map_or(String::new(), |p| format!("{p:.2}")),
            self.seconds_per_pair()
                .map_or(String::new(), |s| format!("{:.3}", s * 1e9)),
            self.traffic
                .map_or(String::new(), |t| format!("{:.0}", t.bytes_per_particle)),
            self.device_bytes.map_or(String::new(), |b| b.to_string())
        )
    }
}

/// A size to run a case at: about a number of particles, or the most the memory holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Size {
    About(f64),
    /// [`crate::run::budget::largest`]: the most particles the memory and the particle
    /// cap hold by the estimate, with a tenth kept free.
    Largest,
}

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "largest" => Ok(Self::Largest),
            n => match n.parse::<f64>() {
                Ok(n) if n.is_finite() && n >= 1.0 => Ok(Self::About(n)),
                _ => Err(format!(
                    "`{n}` is no size: give a particle count (at least 1, e.g. 1e5) or \
                     `largest` (the most the memory holds)"
                )),
            },
        }
    }
}

/// Overrides that rescale a case to about `particles` particles, or at most that many
/// where `at_most`: the spacing scales with (N0/N)^(1/d), rounded (towards the coarser
/// where `at_most`) to a whole divisor (finer) or multiple (coarser) of the case's own,
/// so that lattices anchored at the bodies' corners keep points on the bounds the case's
/// regions select (a grip at the far end of a strip); a fixed Δt scales with the spacing
/// (same Courant number).
pub fn resize(case: &Scene, particles: f64, at_most: bool) -> Result<Vec<String>, RunError> {
    let n0 = match case.dimension {
        2 => discretise::<D2>(case)?.x0.len(),
        _ => discretise::<D3>(case)?.x0.len(),
    } as f64;
    let exact = (n0 / particles).powf(1.0 / f64::from(case.dimension));
    let factor = match (exact < 1.0, at_most) {
        (true, false) => 1.0 / (1.0 / exact).round(),
        (true, true) => 1.0 / (1.0 / exact).floor(),
        (false, false) => exact.round(),
        (false, true) => exact.ceil(),
    };
    let mut set = vec![format!("spacing={:e}", case.spacing * factor)];
    if let Some(dt) = case.method.dt {
        set.push(format!("method.dt={:e}", dt * factor));
    }
    Ok(set)
}

/// Measures `steps` steps of a case after one warm-up step, on the case's threads as
/// `run` has them ([`with_threads`]).
pub fn measure(case: &Scene, backend: Backend, steps: u32) -> Result<BenchRow, RunError> {
    with_threads(case, || match case.dimension {
        2 => measure_dim::<D2>(case, backend, steps),
        _ => measure_dim::<D3>(case, backend, steps),
    })?
}

fn measure_dim<D: EngineDim>(
    case: &Scene,
    backend: Backend,
    steps: u32,
) -> Result<BenchRow, RunError> {
    let started = Instant::now();
    time_steps::<D, _>(case, engine::<D>(case, backend)?, started, steps)
}

/// Steps per submission when timing (one command encoder each on the GPU).
const CHUNK: u32 = 100;

fn time_steps<D: EngineDim, E: Engine<D>>(
    case: &Scene,
    mut engine: E,
    started: Instant,
    steps: u32,
) -> Result<BenchRow, RunError> {
    let dt = match (case.method.dt, case.method.cfl) {
        (Some(dt), _) => dt,
        (_, Some(cfl)) => cfl * case.spacing / engine.max_signal_speed(),
        _ => unreachable!("validated"),
    };
    engine
        .advance(0.0, dt, 1)
        .map_err(|f| blow_up(case, f.cause))?;
    engine.finish();
    let setup_seconds = started.elapsed().as_secs_f64();
    #[cfg(feature = "gpu")]
    let device_bytes = engine.device().map(|(gpu, _)| gpu.allocated());
    #[cfg(not(feature = "gpu"))]
    let device_bytes = None;
    let neighbours_before = engine.neighbour_seconds();
    let timer = Instant::now();
    let mut done = 0;
    while done < steps {
        let chunk = CHUNK.min(steps - done);
        engine
            .advance(f64::from(done + 1) * dt, dt, chunk)
            .map_err(|f| blow_up(case, f.cause))?;
        done += chunk;
    }
    engine.finish();
    let seconds = timer.elapsed().as_secs_f64();
    let neighbour_share = engine
        .neighbour_seconds()
        .zip(neighbours_before)
        .map(|(after, before)| (after - before) / seconds);
    engine.check().map_err(|cause| blow_up(case, cause))?;
    #[cfg(feature = "gpu")]
    let passes = profile(&mut engine, dt, f64::from(steps + 1) * dt, CHUNK.min(steps))
        .map_err(|f| blow_up(case, f.cause))?;
    // No pass report without the GPU backend.
    #[cfg(not(feature = "gpu"))]
    let passes = None;
    let n = engine.reference().len();
    let rate = n as f64 * f64::from(steps) / seconds;
    Ok(BenchRow {
        case: case.name.clone(),
        backend: engine.backend(),
        particles: n,
        steps,
        setup_seconds,
        seconds,
        particle_steps_per_second: rate,
        rate_evaluations_per_second: rate * case.method.integrator.stages() as f64,
        neighbour_share,
        passes,
        traffic: engine.traffic(),
        pairs_per_particle: engine.pairs_per_particle(),
        device_bytes,
    })
}

/// The machine's memory bandwidth by the STREAM triad a = b + s·c on arrays of 2²⁵
/// doubles each (256 MB, far beyond the caches) on rayon's threads: the best of five
/// passes, counting 24 bytes per element as STREAM does [bytes/s].
pub fn triad_bandwidth() -> f64 {
    const N: usize = 1 << 25;
    let (b, c) = (vec![1.0; N], vec![2.0; N]);
    let mut a = vec![0.0; N];
    (0..5)
        .map(|k| {
            let s = f64::from(k);
            let timer = Instant::now();
            a.par_iter_mut()
                .with_min_len(1 << 14)
                .zip(&b)
                .zip(&c)
                .for_each(|((a, &b), &c)| *a = b + s * c);
            let seconds = timer.elapsed().as_secs_f64();
            std::hint::black_box(&a);
            24.0 * N as f64 / seconds
        })
        .fold(0.0, f64::max)
}

/// The pass report of `steps` further steps from time `t`, run with profiling on, on a
/// GPU engine; none on the CPU.
#[cfg(feature = "gpu")]
fn profile<D: EngineDim, E: Engine<D>>(
    engine: &mut E,
    dt: f64,
    t: f64,
    steps: u32,
) -> Result<Option<PassReport>, crate::engine::Failed> {
    let Some(builds) = engine.device().map(|(gpu, scale)| {
        gpu.profile(true);
        scale.indirect
    }) else {
        return Ok(None);
    };
    let timer = Instant::now();
    engine.advance(t, dt, steps)?;
    engine.finish();
    let wall = timer.elapsed().as_secs_f64();
    let particles = engine.reference().len();
    let (gpu, mut scale) = engine.device().expect("a GPU engine");
    scale.indirect = scale
        .indirect
        .zip(builds)
        .map(|(after, before)| after - before);
    let report = PassReport {
        particles,
        ..gpu.pass_report(scale, steps, wall)
    };
    gpu.profile(false);
    Ok(Some(report))
}

fn blow_up(case: &Scene, cause: crate::engine::BlowUp) -> RunError {
    RunError::Benchmark(format!("benchmark of `{}` blew up: {cause}", case.name))
}
