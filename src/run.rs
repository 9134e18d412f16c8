//! The run driver: sets up a case, integrates it to the end time with observers, frames
//! and blow-up detection, and writes the summary.

use crate::integrate::Integrator;
use crate::material::von_mises;
use crate::method::tlsph::Tlsph;
use crate::method::{BlowUp, Method};
use crate::observe::{Clock, Invariants, Observers};
use crate::output::{
    Field, FieldData, PvdIndex, RunSummary, SeriesWriter, write_summary, write_vtu,
};
use crate::scene::{Case, CaseError, MethodName, discretise};
use crate::tensor::{D2, D3, Dim};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;
use thiserror::Error;

/// Compute backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// Rayon, f64: the reference path.
    Cpu,
    /// wgpu/WGSL compute shaders, f32.
    Gpu,
    /// The GPU when an adapter is found, else the CPU.
    Auto,
}

/// Run-time options that are not part of the scene.
#[derive(Clone, Debug)]
pub struct RunOptions {
    pub out_dir: PathBuf,
    pub backend: Backend,
    /// Show a progress bar on the terminal.
    pub progress: bool,
    /// Write VTU frames (the time series and summary are always written).
    pub frames: bool,
}

#[derive(Debug, Error)]
pub enum RunError {
    #[error(transparent)]
    Case(#[from] CaseError),
    #[error("output: {0}")]
    Io(#[from] std::io::Error),
    #[error("backend: {0}")]
    Backend(String),
    #[error(
        "blow-up at step {step}, t = {time:e} s: {cause}; outputs up to the last good frame are in {}",
        out_dir.display()
    )]
    BlowUp {
        step: u64,
        time: f64,
        cause: BlowUp,
        out_dir: PathBuf,
    },
}

/// Runs a case to its end time; returns the summary (also written as `summary.json`).
pub fn run(case: &Case, opts: &RunOptions) -> Result<RunSummary, RunError> {
    if opts.backend == Backend::Gpu {
        return Err(RunError::Backend(
            "the GPU backend is not part of this build yet; use --backend cpu or auto".into(),
        ));
    }
    match case.dimension {
        2 => run_dim::<D2>(case, opts),
        _ => run_dim::<D3>(case, opts),
    }
}

/// Builds the method of a case.
pub fn build_method<D: Dim>(case: &Case) -> Result<Tlsph<D>, CaseError> {
    let disc = discretise::<D>(case)?;
    match case.method.name {
        MethodName::Tlsph => Tlsph::new(case, disc),
    }
}

/// Time-step size: fixed, or from the CFL number.
fn time_step<D: Dim, M: Method<D>>(case: &Case, method: &M, y: &M::State) -> f64 {
    match (case.method.dt, case.method.cfl) {
        (Some(dt), _) => dt,
        (None, Some(cfl)) => cfl * case.spacing / method.max_signal_speed(y),
        (None, None) => unreachable!("validation requires dt or cfl"),
    }
}

/// Steps between blow-up checks when the series is sampled more rarely.
const CHECK_EVERY: u64 = 100;

fn run_dim<D: Dim>(case: &Case, opts: &RunOptions) -> Result<RunSummary, RunError> {
    let mut method = build_method::<D>(case)?;
    let mut y = method.initial_state();
    let mut integrator = Integrator::new(case.method.integrator, &y);
    let observers = Observers::new::<D, _>(case, &method)?;

    std::fs::create_dir_all(&opts.out_dir)?;
    let mut series =
        SeriesWriter::create(&opts.out_dir.join("series.csv"), observers.column_names())?;
    let mut frames = Frames::new(case, opts)?;

    let n = method.reference().len();
    let t_end = case.run.end_time;
    let inv0 = Invariants::of::<D, _>(&method, &y);
    let mut clock = Clock {
        dt: time_step::<D, _>(case, &method, &y),
        ..Clock::default()
    };
    let progress = progress_bar(opts.progress, case);
    let started = Instant::now();

    series.write_row(&observers.sample::<D, _>(&method, &y, &inv0, &clock))?;
    frames.write::<D, _>(&method, &y, 0.0, true)?;
    let series_every = case.output.series_interval.unwrap_or(0.0);
    let mut next_sample = series_every;
    let mut last_power = 0.0;

    let failure = loop {
        let Clock { t, step, .. } = clock;
        if t >= t_end * (1.0 - 1e-12) {
            break None;
        }
        let dt = time_step::<D, _>(case, &method, &y).min(t_end - t);
        if let Err(cause) = integrator.step(&mut method, t, dt, &mut y) {
            break Some(cause);
        }
        // Trapezoidal work of the supports and loads, from the powers of successive steps.
        let power = method.boundary_power();
        clock = Clock {
            t: t + dt,
            step: step + 1,
            dt,
            external_work: clock.external_work + 0.5 * (last_power + power) * dt,
        };
        last_power = power;
        let (t, step) = (clock.t, clock.step);

        let sample = t + 0.5 * dt >= next_sample || t >= t_end * (1.0 - 1e-12);
        if sample || step % CHECK_EVERY == 0 {
            if let Err(cause) = method.check_finite(&y) {
                break Some(cause);
            }
            let inv = Invariants::of::<D, _>(&method, &y);
            let bound =
                case.run.energy_growth_limit * (inv0.total_energy() + clock.external_work.max(0.0));
            if inv.total_energy() > bound && bound > 0.0 {
                break Some(energy_blow_up::<D, _>(
                    &method,
                    &y,
                    inv.total_energy(),
                    bound,
                ));
            }
            if sample {
                series.write_row(&observers.sample::<D, _>(&method, &y, &inv, &clock))?;
                next_sample = t + series_every;
            }
        }
        frames.write::<D, _>(&method, &y, t, t >= t_end * (1.0 - 1e-12))?;
        if step % 64 == 0 {
            progress.set_position((t / t_end * 1000.0) as u64);
            let rate = (n as f64 * step as f64) / started.elapsed().as_secs_f64();
            progress.set_message(format!(
                "step {step}, t = {t:.4e} s, {rate:.3e} particle-steps/s"
            ));
        }
    };
    progress.finish_and_clear();

    let Clock { t, step, dt, .. } = clock;
    let wall = started.elapsed().as_secs_f64();
    let inv = Invariants::of::<D, _>(&method, &y);
    let summary = RunSummary {
        case: case.name.clone(),
        method: format!("{:?}", case.method.name).to_lowercase(),
        backend: "cpu".into(),
        dimension: case.dimension,
        particles: n,
        steps: step,
        dt_last: dt,
        end_time: t,
        wall_seconds: wall,
        particle_steps_per_second: n as f64 * step as f64 / wall.max(1e-12),
        status: if failure.is_some() {
            "failed"
        } else {
            "completed"
        }
        .into(),
        failure: failure
            .as_ref()
            .map(|c| format!("step {}, t = {t:e} s: {c}", step + 1)),
        final_invariants: inv.named::<D>(),
    };
    write_summary(&opts.out_dir.join("summary.json"), &summary)?;
    match failure {
        Some(cause) => Err(RunError::BlowUp {
            step: step + 1,
            time: t,
            cause,
            out_dir: opts.out_dir.clone(),
        }),
        None => Ok(summary),
    }
}

/// Energy-growth failure, attributed to the particle with the largest kinetic energy.
fn energy_blow_up<D: Dim, M: Method<D>>(
    method: &M,
    y: &M::State,
    energy: f64,
    bound: f64,
) -> BlowUp {
    let (v, m) = (method.velocity(y), method.mass());
    let i = (0..m.len())
        .max_by(|&a, &b| (m[a] * D::norm2(v[a])).total_cmp(&(m[b] * D::norm2(v[b]))))
        .unwrap_or(0);
    BlowUp {
        particle: i,
        position: D::to3(method.reference()[i]),
        quantity: format!("total energy (bound {bound:e}, fastest particle shown)"),
        value: energy,
    }
}

fn progress_bar(show: bool, case: &Case) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix} [{elapsed_precise}] {wide_bar} {percent}% eta {eta} {msg}",
        )
        .expect("static progress template is valid"),
    );
    bar.set_prefix(case.name.clone());
    bar
}

/// VTU frames and their PVD index.
struct Frames {
    index: Option<PvdIndex>,
    dir: PathBuf,
    name: String,
    interval: Option<f64>,
    next: f64,
    count: usize,
}

impl Frames {
    fn new(case: &Case, opts: &RunOptions) -> std::io::Result<Self> {
        let index = if opts.frames {
            Some(PvdIndex::create(&opts.out_dir, &case.name)?)
        } else {
            None
        };
        Ok(Self {
            index,
            dir: opts.out_dir.clone(),
            name: case.name.clone(),
            interval: case.output.frame_interval,
            next: 0.0,
            count: 0,
        })
    }

    /// Writes a frame when one is due (or `force`).
    fn write<D: Dim, M: Method<D>>(
        &mut self,
        method: &M,
        y: &M::State,
        t: f64,
        force: bool,
    ) -> std::io::Result<()> {
        let Some(index) = &mut self.index else {
            return Ok(());
        };
        let due = self.interval.is_some_and(|_| t >= self.next * (1.0 - 1e-9));
        if !(due || force) {
            return Ok(());
        }
        let file = format!("{}_{:06}.vtu", self.name, self.count);
        write_frame::<D, M>(&self.dir.join(&file), method, y, t)?;
        index.push(t, &file)?;
        self.count += 1;
        if let Some(dt) = self.interval {
            while self.next <= t * (1.0 + 1e-9) {
                self.next += dt;
            }
        }
        Ok(())
    }
}

/// One VTU frame: current positions with u, v, F, σ, von Mises stress, J and body.
pub fn write_frame<D: Dim, M: Method<D>>(
    path: &Path,
    method: &M,
    y: &M::State,
    t: f64,
) -> std::io::Result<()> {
    let (x0, u, v) = (
        method.reference(),
        method.displacement(y),
        method.velocity(y),
    );
    let points: Vec<[f64; 3]> = x0.iter().zip(u).map(|(&x, &u)| D::to3(x + u)).collect();
    let uu: Vec<[f64; 3]> = u.iter().map(|&a| D::to3(a)).collect();
    let vv: Vec<[f64; 3]> = v.iter().map(|&a| D::to3(a)).collect();
    let f = method.deformation_gradient(y);
    let jac: Vec<f64> = f.iter().map(|&f| D::det(f)).collect();
    let f9: Vec<[f64; 9]> = f.iter().map(|&f| flatten(pad_f::<D>(f))).collect();
    let sigma = method.cauchy_stress(y);
    let vm: Vec<f64> = sigma.iter().map(von_mises).collect();
    let s9: Vec<[f64; 9]> = sigma.iter().map(|s| flatten(*s)).collect();
    let body: Vec<i32> = method.body().iter().map(|&b| b as i32).collect();
    let fields = [
        Field {
            name: "u",
            data: FieldData::Vector(&uu),
        },
        Field {
            name: "v",
            data: FieldData::Vector(&vv),
        },
        Field {
            name: "F",
            data: FieldData::Tensor(&f9),
        },
        Field {
            name: "sigma",
            data: FieldData::Tensor(&s9),
        },
        Field {
            name: "von_mises",
            data: FieldData::Scalar(&vm),
        },
        Field {
            name: "J",
            data: FieldData::Scalar(&jac),
        },
        Field {
            name: "body",
            data: FieldData::Int(&body),
        },
    ];
    write_vtu(path, &points, &fields, t)
}

/// F as 3×3; in plane strain F_zz = 1.
fn pad_f<D: Dim>(f: D::T) -> [[f64; 3]; 3] {
    let mut m = D::to3x3(f);
    if D::N == 2 {
        m[2][2] = 1.0;
    }
    m
}

fn flatten(m: [[f64; 3]; 3]) -> [f64; 9] {
    let mut out = [0.0; 9];
    for k in 0..3 {
        out[3 * k..3 * k + 3].copy_from_slice(&m[k]);
    }
    out
}
