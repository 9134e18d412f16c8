//! `meshless bench`: throughput of a case on a backend at several sizes, in
//! particle-steps per second, measured over whole steps after a warm-up.

use crate::run::{Backend, Engine, EngineDim, RunError, engine};
use crate::scene::{Case, discretise};
use crate::tensor::{D2, D3};
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
}

impl BenchRow {
    pub const HEADER: &'static str = "case,backend,particles,steps,setup_s,seconds,particle_steps_per_s,rate_evaluations_per_s,neighbour_share";

    pub fn csv(&self) -> String {
        format!(
            "{},{},{},{},{:.6},{:.6},{:.6e},{:.6e},{}",
            self.case,
            self.backend.replace(',', ";"),
            self.particles,
            self.steps,
            self.setup_seconds,
            self.seconds,
            self.particle_steps_per_second,
            self.rate_evaluations_per_second,
            self.neighbour_share
                .map_or(String::new(), |s| format!("{s:.4}"))
        )
    }
}

/// Overrides that rescale a case to about `particles` particles: the spacing scales with
/// (N0/N)^(1/d), rounded to a whole divisor (finer) or multiple (coarser) of the case's
/// own, so that lattices anchored at the bodies' corners keep points on the bounds the
/// case's regions select (a grip at the far end of a strip); a fixed Δt scales with the
/// spacing (same Courant number).
pub fn resize(case: &Case, particles: f64) -> Result<Vec<String>, RunError> {
    let n0 = match case.dimension {
        2 => discretise::<D2>(case)?.x0.len(),
        _ => discretise::<D3>(case)?.x0.len(),
    } as f64;
    let exact = (n0 / particles).powf(1.0 / f64::from(case.dimension));
    let factor = if exact < 1.0 {
        1.0 / (1.0 / exact).round()
    } else {
        exact.round()
    };
    let mut set = vec![format!("spacing={:e}", case.spacing * factor)];
    if let Some(dt) = case.method.dt {
        set.push(format!("method.dt={:e}", dt * factor));
    }
    Ok(set)
}

/// Measures `steps` steps of a case after one warm-up step.
pub fn measure(case: &Case, backend: Backend, steps: u32) -> Result<BenchRow, RunError> {
    match case.dimension {
        2 => measure_dim::<D2>(case, backend, steps),
        _ => measure_dim::<D3>(case, backend, steps),
    }
}

fn measure_dim<D: EngineDim>(
    case: &Case,
    backend: Backend,
    steps: u32,
) -> Result<BenchRow, RunError> {
    let started = Instant::now();
    time_steps::<D, _>(case, engine::<D>(case, backend)?, started, steps)
}

/// Steps per submission when timing (one command encoder each on the GPU).
const CHUNK: u32 = 100;

fn time_steps<D: EngineDim, E: Engine<D>>(
    case: &Case,
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
    })
}

fn blow_up(case: &Case, cause: crate::methods::BlowUp) -> RunError {
    RunError::Benchmark(format!("benchmark of `{}` blew up: {cause}", case.name))
}
