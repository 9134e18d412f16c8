//! Total-Lagrangian SPH on the GPU: the passes of `shaders/tlsph*.wgsl`, the integrator
//! stages of `shaders/integrate.wgsl`, and the set-up (neighbours, corrected gradients)
//! done once. The CPU path (`method::tlsph`) is the reference it is checked against.
//!
//! A whole step, or several, is recorded into one command encoder; the host reads back
//! only when asked (outputs, observers, checks).

use super::context::{Gpu, GpuError};
use super::layout::{Flat, GpuDim};
use super::neighbour;
use super::shaders::{self, Constants, Source};
use crate::boundary::Boundary;
use crate::correction::{self, CorrectionKind};
use crate::integrate::IntegratorKind;
use crate::kernel::Kernel;
use crate::material::{Material, MaterialModel};
use crate::method::BlowUp;
use crate::method::tlsph::{TlState, check_state, snapshot};
use crate::neighbour as neighbour_cpu;
use crate::observe::{Invariants, Snapshot};
use crate::run::Engine;
use crate::scene::{Case, CaseError, discretise};
use bytemuck::{Pod, Zeroable};
use thiserror::Error;

#[derive(Debug, Error)]
pub enum SetupError {
    #[error(transparent)]
    Case(#[from] CaseError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// Offsets (in f32 entries) of the fields in the flat state and kinematics buffers.
/// The state holds u, v, ρ − ρ0 and S; the kinematics H = F − I, P, F⁻ᵀ and ρ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub dim: usize,
    pub rate: bool,
    pub u: usize,
    pub v: usize,
    pub rho: usize,
    pub s: usize,
    /// Flat state length.
    pub len: usize,
    pub kin_f: usize,
    pub kin_p: usize,
    pub kin_fit: usize,
    pub kin_rho: usize,
    pub kin_len: usize,
}

impl Layout {
    pub fn new(n: usize, dim: usize, rate: bool) -> Self {
        let (nd, nt) = (n * dim, n * dim * dim);
        let fields_after_v = if rate { n + nt } else { 0 };
        Self {
            n,
            dim,
            rate,
            u: 0,
            v: nd,
            rho: 2 * nd,
            s: 2 * nd + n,
            len: 2 * nd + fields_after_v,
            kin_f: 0,
            kin_p: nt,
            kin_fit: 2 * nt,
            kin_rho: 3 * nt,
            kin_len: 3 * nt + n,
        }
    }
}

/// The compiled-in constants of a scene's TLSPH passes.
pub fn scene_constants(case: &Case, layout: &Layout) -> Constants {
    let material = Material::new(&case.material);
    let h = case.method.h_over_dx * case.spacing;
    let kernel = Kernel::new(case.method.kernel, h, layout.dim);
    let model = match material.model {
        MaterialModel::Hypoelastic => 0,
        MaterialModel::SaintVenantKirchhoff => 1,
        MaterialModel::NeoHookean => 2,
        MaterialModel::LinearElastic => 3,
        MaterialModel::NearlyIncompressibleNeoHookean => 4,
    };
    let correction = match case.method.correction {
        CorrectionKind::None => 0,
        CorrectionKind::Shepard => 1,
        CorrectionKind::RandlesLibersky | CorrectionKind::Rkpm | CorrectionKind::Cgck => 2,
    };
    let av = case.method.artificial_viscosity;
    let u = |x: usize| x as u32;
    Constants::default()
        .kernel(&kernel)
        .u32("N", u(layout.n))
        .u32("RATE", u32::from(layout.rate))
        .u32("MODEL", model)
        .u32("CORRECTION", correction)
        .f32("RHO0", material.rho0)
        .f32("MU", material.mu)
        .f32("LAMBDA", material.lambda)
        .f32("BULK", material.bulk)
        .f32("H", h)
        .u32("AV", u32::from(av.is_some()))
        .f32("AV_ALPHA", av.map_or(0.0, |a| a.alpha))
        .f32("AV_BETA", av.map_or(0.0, |a| a.beta))
        .f32("AV_ETA", av.map_or(0.0, |a| a.eta))
        .u32("U_OFF", u(layout.u))
        .u32("V_OFF", u(layout.v))
        .u32("RHO_OFF", u(layout.rho))
        .u32("S_OFF", u(layout.s))
        .u32("LEN", u(layout.len))
        .u32("KF_OFF", u(layout.kin_f))
        .u32("KP_OFF", u(layout.kin_p))
        .u32("KFIT_OFF", u(layout.kin_fit))
        .u32("KRHO_OFF", u(layout.kin_rho))
}

/// One of the four state-sized buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Buf {
    Y,
    Stage,
    Rates,
    Acc,
}

/// One recorded operation of a step.
#[derive(Clone, Copy, Debug)]
enum Op {
    /// Rates of the state in the buffer into `Rates`.
    Rates(Buf),
    Copy(Buf, Buf),
    /// out = a·out + b·x, with b = b_dt·Δt + b_const.
    Blend {
        out: Buf,
        x: Buf,
        a: f64,
        b_dt: f64,
        b_const: f64,
    },
    /// v += (b_dt·Δt)·(rate of v).
    Kick {
        out: Buf,
        b_dt: f64,
    },
    /// u += (b_dt·Δt)·v; ρ, S += (b_dt·Δt)·rates.
    Drift {
        out: Buf,
        b_dt: f64,
    },
}

/// The passes of one GPU step, in order, as `meshless run --explain` prints them.
pub fn describe_step(kind: IntegratorKind) -> Vec<String> {
    program(kind)
        .into_iter()
        .map(|op| match op {
            Op::Rates(src) => format!(
                "rates of {src:?}: stress pass (F, P, ρ̇, Ṡ) + acceleration pass (a, u̇ = v, BCs)"
            ),
            Op::Copy(a, b) => format!("copy {a:?} → {b:?}"),
            Op::Blend {
                out,
                x,
                a,
                b_dt,
                b_const,
            } => {
                let b = if b_dt != 0.0 {
                    format!("{b_dt:.4}·Δt")
                } else {
                    format!("{b_const:.4}")
                };
                format!("{out:?} = {a:.4}·{out:?} + {b}·{x:?}")
            }
            Op::Kick { out, b_dt } => format!("kick: v({out:?}) += {b_dt}·Δt·a"),
            Op::Drift { out, b_dt } => {
                format!("drift: u({out:?}) += {b_dt}·Δt·v, ρ, S += {b_dt}·Δt·rates")
            }
        })
        .collect()
}

/// The operations of one step of each integrator (same schemes as `crate::integrate`).
fn program(kind: IntegratorKind) -> Vec<Op> {
    use Buf::*;
    let axpy = |out, x, b_dt| Op::Blend {
        out,
        x,
        a: 1.0,
        b_dt,
        b_const: 0.0,
    };
    let mix = |out, x, a: f64, b: f64| Op::Blend {
        out,
        x,
        a,
        b_dt: 0.0,
        b_const: b,
    };
    match kind {
        IntegratorKind::Rk4 => vec![
            Op::Rates(Y),
            Op::Copy(Y, Acc),
            axpy(Acc, Rates, 1.0 / 6.0),
            Op::Copy(Y, Stage),
            axpy(Stage, Rates, 0.5),
            Op::Rates(Stage),
            axpy(Acc, Rates, 1.0 / 3.0),
            Op::Copy(Y, Stage),
            axpy(Stage, Rates, 0.5),
            Op::Rates(Stage),
            axpy(Acc, Rates, 1.0 / 3.0),
            Op::Copy(Y, Stage),
            axpy(Stage, Rates, 1.0),
            Op::Rates(Stage),
            axpy(Acc, Rates, 1.0 / 6.0),
            Op::Copy(Acc, Y),
        ],
        IntegratorKind::TvdRk2 => vec![
            Op::Rates(Y),
            Op::Copy(Y, Stage),
            axpy(Stage, Rates, 1.0),
            Op::Rates(Stage),
            axpy(Stage, Rates, 1.0),
            mix(Y, Stage, 0.5, 0.5),
        ],
        IntegratorKind::SspRk3 => vec![
            Op::Rates(Y),
            Op::Copy(Y, Stage),
            axpy(Stage, Rates, 1.0),
            Op::Rates(Stage),
            axpy(Stage, Rates, 1.0),
            mix(Stage, Y, 0.25, 0.75),
            Op::Rates(Stage),
            axpy(Stage, Rates, 1.0),
            mix(Y, Stage, 1.0 / 3.0, 2.0 / 3.0),
        ],
        // The rates of the previous evaluation (or of the priming pass) start the step.
        IntegratorKind::Leapfrog => vec![
            Op::Kick { out: Y, b_dt: 0.5 },
            Op::Drift { out: Y, b_dt: 1.0 },
            Op::Copy(Y, Stage),
            Op::Kick {
                out: Stage,
                b_dt: 0.5,
            },
            Op::Rates(Stage),
            Op::Kick { out: Y, b_dt: 0.5 },
        ],
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Coefficients {
    a: f32,
    b: f32,
}

/// A recorded op with its GPU resources.
enum Recorded {
    Rates {
        stress: wgpu::BindGroup,
        accel: wgpu::BindGroup,
    },
    Copy(Buf, Buf),
    Pass {
        pipeline: usize,
        bind: wgpu::BindGroup,
        coefficients: wgpu::Buffer,
        invocations: u32,
        op: Op,
    },
}

/// The TLSPH system resident on the GPU.
pub struct GpuTlsph<D: GpuDim> {
    gpu: Gpu,
    layout: Layout,
    material: Material,
    integrator: IntegratorKind,
    /// y, stage, rates, acc.
    states: [wgpu::Buffer; 4],
    kin: wgpu::Buffer,
    grad: wgpu::Buffer,
    status: wgpu::Buffer,
    stress: wgpu::ComputePipeline,
    accel: wgpu::ComputePipeline,
    /// blend, kick, drift.
    stages: [wgpu::ComputePipeline; 3],
    steps: Vec<Recorded>,
    /// Leapfrog only: rates primed at the current state.
    primed: bool,
    dt: f64,
    x0: Vec<D::V>,
    mass: Vec<f64>,
    body: Vec<u32>,
    vol: Vec<f64>,
    /// Rates of the state in `Y` alone (leapfrog priming, cross-checks).
    rates_y: Recorded,
    /// The stress pass on `Y` writing into `Acc` (for snapshots: F at the current state
    /// without touching the integrator's rates).
    kinematics_y: wgpu::BindGroup,
    reduce: wgpu::ComputePipeline,
    reduce_bind: wgpu::BindGroup,
    partials: wgpu::Buffer,
    /// The reduction of the current state, until the next advance.
    reduced: Option<Reduced>,
    constrained: Vec<(u32, u8)>,
    /// Simulated time advanced so far, and the work balance of supports and loads.
    time: f64,
    work: f64,
    last_power: (f64, f64),
}

/// Value of `status[0]` when no particle failed.
const STATUS_OK: u32 = u32::MAX;

impl<D: GpuDim> GpuTlsph<D> {
    /// Discretises the case, builds neighbours and corrected gradients, and uploads the
    /// initial state.
    pub fn new(case: &Case, gpu: Gpu) -> Result<Self, SetupError> {
        let disc = discretise::<D>(case)?;
        let material = Material::new(&case.material);
        let n = disc.x0.len();
        let layout = Layout::new(n, D::N, material.model.is_rate_based());
        let constants = scene_constants(case, &layout);
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);
        let h = case.method.h_over_dx * case.spacing;
        let kernel = Kernel::new(case.method.kernel, h, D::N);
        let mass: Vec<f64> = disc.vol.iter().map(|v| v * material.rho0).collect();
        let boundary = Boundary::build(case, &disc, &mass)?;

        // Neighbours on the GPU from f32 positions; the 1e-5 margin keeps lattice pairs lying
        // exactly on the support on both sides of the f32 rounding (their W and ∇W vanish).
        let typed: Vec<D::HV> = disc.x0.iter().map(|&x| D::v(x)).collect();
        let x_typed = gpu.storage("x0 (cell list)", &typed);
        let (lo, hi) = neighbour_cpu::bounding_box(disc.x0.iter().map(|&x| D::to3(x)));
        let csr = neighbour::build::<D>(
            &gpu,
            &x_typed,
            lo,
            hi,
            n as u32,
            kernel.support() * (1.0 + 1e-5),
        )?;
        let pairs = u64::from(csr.pairs);
        gpu.check_size("per-pair gradient buffer", pairs * D::N as u64 * 4)?;
        gpu.check_size("kinematics buffer", layout.kin_len as u64 * 4)?;
        let (offsets, ids) = (csr.offsets.clone(), csr.ids.clone());
        let flat_v = |vs: &[D::V]| {
            let mut out = Vec::with_capacity(vs.len() * D::N);
            vs.iter().for_each(|&v| D::push_v(&mut out, v));
            out
        };
        // X = hi + lo in f32 pairs, for exact pair offsets (see pair_offsets.wgsl).
        let x_hi = flat_v(&disc.x0);
        let x_lo: Vec<f32> = disc
            .x0
            .iter()
            .flat_map(|&x| D::to3(x).into_iter().take(D::N))
            .zip(&x_hi)
            .map(|(x, &h)| (x - f64::from(h)) as f32)
            .collect();
        let (x_hi, x_lo) = (gpu.storage("x hi", &x_hi), gpu.storage("x lo", &x_lo));
        let dx0 = gpu.zeroed("dx0", pairs * D::N as u64 * 4);
        let pipeline = gpu.pipeline(
            "pair offsets",
            &compose(&shaders::PAIR_OFFSETS),
            "pair_offsets",
        );
        let bind = gpu.bind(&pipeline, &[&offsets, &ids, &x_hi, &x_lo, &dx0]);
        dispatch(&gpu, &pipeline, &bind, n as u32);
        let vol32: Vec<f32> = disc.vol.iter().map(|&v| v as f32).collect();
        let vol = gpu.storage("vol", &vol32);
        let status = gpu.storage("status", &[STATUS_OK]);
        let host_solved = matches!(
            case.method.correction,
            CorrectionKind::Rkpm | CorrectionKind::Cgck
        );
        let grad = if host_solved {
            // The RKPM and CGCK corrections run once on the host (f64) and are uploaded.
            let g = correction::gradients::<D>(
                case.method.correction,
                &disc.x0,
                &disc.vol,
                &neighbour::read_lists(&gpu, &csr),
                &kernel,
            )
            .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
            gpu.storage("grad", &flat_v(&g))
        } else {
            let grad = gpu.zeroed("grad", pairs * D::N as u64 * 4);
            let pipeline = gpu.pipeline("correction", &compose(&shaders::CORRECTION), "correct");
            let bind = gpu.bind(&pipeline, &[&offsets, &ids, &dx0, &vol, &grad, &status]);
            dispatch(&gpu, &pipeline, &bind, n as u32);
            if let Some(i) = read_status(&gpu, &status) {
                return Err(case
                    .invalid(
                        "method.h_over_dx",
                        format!(
                            "the Randles–Libersky matrix of particle {i} is singular on the GPU \
                             (f32): too few neighbours; increase h/dx"
                        ),
                    )
                    .into());
            }
            grad
        };

        let mut mask = vec![0u32; n];
        for &(i, m) in &boundary.constrained {
            mask[i as usize] = u32::from(m);
        }
        let mut ext = vec![D::zero(); n];
        for &(i, a) in &boundary.external {
            ext[i as usize] = a;
        }
        let mask = gpu.storage("mask", &mask);
        let ext = gpu.storage("ext", &flat_v(&ext));

        let mut v0 = disc.v0.clone();
        boundary.impose_initial(&mut v0);
        let y0 = initial_state::<D>(&layout, &v0);
        let states = [
            gpu.storage("y", &y0),
            gpu.zeroed("stage", layout.len as u64 * 4),
            gpu.zeroed("rates", layout.len as u64 * 4),
            gpu.zeroed("acc", layout.len as u64 * 4),
        ];
        let kin = gpu.zeroed("kinematics", layout.kin_len as u64 * 4);
        let power = gpu.zeroed("power", n as u64 * 4);

        let stress = gpu.pipeline("tlsph stress", &compose(&shaders::TLSPH_STRESS), "stress");
        let accel = gpu.pipeline("tlsph accel", &compose(&shaders::TLSPH_ACCEL), "accel");
        let integrate = compose(&shaders::INTEGRATE);
        let stages = ["blend", "kick", "drift"].map(|e| gpu.pipeline(e, &integrate, e));

        let rates = |src: Buf| {
            let s = &states[src as usize];
            Recorded::Rates {
                stress: gpu.bind(
                    &stress,
                    &[
                        &offsets,
                        &ids,
                        &grad,
                        &vol,
                        s,
                        &kin,
                        &states[Buf::Rates as usize],
                        &status,
                    ],
                ),
                accel: gpu.bind(
                    &accel,
                    &[
                        &offsets,
                        &ids,
                        &grad,
                        &vol,
                        &dx0,
                        s,
                        &kin,
                        &mask,
                        &ext,
                        &states[Buf::Rates as usize],
                        &power,
                    ],
                ),
            }
        };
        let reduce = gpu.pipeline("reduce", &compose(&shaders::REDUCE), "reduce");
        let (gx, gy) = gpu.groups(n as u32);
        let partials = gpu.zeroed("partials", u64::from(gx * gy) * REDUCED as u64 * 4);
        let reduce_bind = gpu.bind(
            &reduce,
            &[
                &states[Buf::Y as usize],
                &kin,
                &vol,
                &x_hi,
                &power,
                &partials,
            ],
        );
        let rates_y = rates(Buf::Y);
        let kinematics_y = gpu.bind(
            &stress,
            &[
                &offsets,
                &ids,
                &grad,
                &vol,
                &states[Buf::Y as usize],
                &kin,
                &states[Buf::Acc as usize],
                &status,
            ],
        );
        let mut steps = Vec::new();
        for op in program(case.method.integrator) {
            steps.push(match op {
                Op::Rates(src) => rates(src),
                Op::Copy(a, b) => Recorded::Copy(a, b),
                Op::Blend { out, x, .. } => {
                    pass(&gpu, &states, &stages[0], 0, op, out, x, layout.len)
                }
                Op::Kick { out, .. } => pass(
                    &gpu,
                    &states,
                    &stages[1],
                    1,
                    op,
                    out,
                    Buf::Rates,
                    layout.n * D::N,
                ),
                Op::Drift { out, .. } => pass(
                    &gpu,
                    &states,
                    &stages[2],
                    2,
                    op,
                    out,
                    Buf::Rates,
                    layout.n * D::N + (layout.len - layout.rho),
                ),
            });
        }
        Ok(Self {
            gpu,
            layout,
            material,
            integrator: case.method.integrator,
            states,
            kin,
            grad,
            status,
            stress,
            accel,
            stages,
            steps,
            primed: false,
            dt: f64::NAN,
            x0: disc.x0,
            mass,
            body: disc.body,
            vol: disc.vol,
            rates_y,
            kinematics_y,
            reduce,
            reduce_bind,
            partials,
            reduced: None,
            constrained: boundary.constrained.clone(),
            time: 0.0,
            work: 0.0,
            last_power: (0.0, 0.0),
        })
    }
}

/// A blend/kick/drift pass with its own coefficient buffer, bound to `out` and `x`.
#[allow(clippy::too_many_arguments)]
fn pass(
    gpu: &Gpu,
    states: &[wgpu::Buffer; 4],
    pipeline: &wgpu::ComputePipeline,
    index: usize,
    op: Op,
    out: Buf,
    x: Buf,
    invocations: usize,
) -> Recorded {
    let coefficients = gpu.uniform("coefficients", &Coefficients { a: 1.0, b: 0.0 });
    let bind = gpu.bind(
        pipeline,
        &[&coefficients, &states[out as usize], &states[x as usize]],
    );
    Recorded::Pass {
        pipeline: index,
        bind,
        coefficients,
        invocations: invocations as u32,
        op,
    }
}

fn dispatch(gpu: &Gpu, pipeline: &wgpu::ComputePipeline, bind: &wgpu::BindGroup, n: u32) {
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        gpu.dispatch(&mut pass, pipeline, bind, n);
    }
    gpu.queue.submit([encoder.finish()]);
}

/// The first failed particle recorded in a status buffer, if any.
fn read_status(gpu: &Gpu, status: &wgpu::Buffer) -> Option<usize> {
    let s: Vec<u32> = gpu.read(status);
    (s[0] != STATUS_OK).then_some(s[0] as usize)
}

/// Flat initial state: u = 0, v = v0, ρ − ρ0 = 0, S = 0.
fn initial_state<D: Flat>(layout: &Layout, v0: &[D::V]) -> Vec<f32> {
    let mut y = vec![0.0f32; layout.len];
    let mut v = Vec::with_capacity(layout.n * D::N);
    v0.iter().for_each(|&x| D::push_v(&mut v, x));
    y[layout.v..layout.v + v.len()].copy_from_slice(&v);
    y
}

impl<D: GpuDim> GpuTlsph<D> {
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub fn reference(&self) -> &[D::V] {
        &self.x0
    }

    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    pub fn body(&self) -> &[u32] {
        &self.body
    }

    pub fn volume(&self) -> &[f64] {
        &self.vol
    }

    pub fn material(&self) -> &Material {
        &self.material
    }

    /// Rewrites the stage coefficients when the step size changes.
    fn set_dt(&mut self, dt: f64) {
        if dt == self.dt {
            return;
        }
        self.dt = dt;
        for rec in &self.steps {
            if let Recorded::Pass {
                coefficients, op, ..
            } = rec
            {
                let (a, b) = match *op {
                    Op::Blend {
                        a, b_dt, b_const, ..
                    } => (a, b_dt * dt + b_const),
                    Op::Kick { b_dt, .. } | Op::Drift { b_dt, .. } => (1.0, b_dt * dt),
                    Op::Rates(_) | Op::Copy(..) => unreachable!("only passes carry coefficients"),
                };
                let c = Coefficients {
                    a: a as f32,
                    b: b as f32,
                };
                self.gpu
                    .queue
                    .write_buffer(coefficients, 0, bytemuck::bytes_of(&c));
            }
        }
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, rec: &Recorded) {
        let n = self.layout.n as u32;
        match rec {
            Recorded::Rates { stress, accel } => {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                self.gpu.dispatch(&mut pass, &self.stress, stress, n);
                self.gpu.dispatch(&mut pass, &self.accel, accel, n);
            }
            Recorded::Copy(a, b) => {
                let size = self.layout.len as u64 * 4;
                encoder.copy_buffer_to_buffer(
                    &self.states[*a as usize],
                    0,
                    &self.states[*b as usize],
                    0,
                    size,
                );
            }
            Recorded::Pass {
                pipeline,
                bind,
                invocations,
                ..
            } => {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                self.gpu
                    .dispatch(&mut pass, &self.stages[*pipeline], bind, *invocations);
            }
        }
    }

    /// Records `steps` steps of size `dt` into one command encoder and submits them.
    pub fn advance_steps(&mut self, dt: f64, steps: u32) {
        self.time += dt * f64::from(steps);
        self.reduced = None;
        self.set_dt(dt);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        if self.integrator == IntegratorKind::Leapfrog && !self.primed {
            self.record(&mut encoder, &self.rates_y);
            self.primed = true;
        }
        for _ in 0..steps {
            for rec in &self.steps {
                self.record(&mut encoder, rec);
            }
        }
        self.gpu.queue.submit([encoder.finish()]);
    }

    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> TlState<D> {
        let flat: Vec<f32> = self.gpu.read(&self.states[Buf::Y as usize]);
        let mut y = self.decode(&flat);
        y.rho.iter_mut().for_each(|r| *r += self.material.rho0);
        y
    }

    /// Decodes a flat state or rate buffer (the density entry is ρ − ρ0, or ρ̇).
    fn decode(&self, flat: &[f32]) -> TlState<D> {
        let l = &self.layout;
        let (d, t) = (D::N, D::N * D::N);
        let vecs = |off: usize| (0..l.n).map(|i| D::read_v(&flat[off + d * i..])).collect();
        TlState {
            u: vecs(l.u),
            v: vecs(l.v),
            rho: if l.rate {
                flat[l.rho..l.rho + l.n].iter().map(|&r| r.into()).collect()
            } else {
                Vec::new()
            },
            s: if l.rate {
                (0..l.n).map(|i| D::read_t(&flat[l.s + t * i..])).collect()
            } else {
                Vec::new()
            },
        }
    }

    /// Replaces the state (e.g. to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &TlState<D>) {
        let l = &self.layout;
        let mut flat = vec![0.0f32; l.len];
        let mut put_v = |off: usize, vs: &[D::V]| {
            let mut tmp = Vec::with_capacity(vs.len() * D::N);
            vs.iter().for_each(|&v| D::push_v(&mut tmp, v));
            flat[off..off + tmp.len()].copy_from_slice(&tmp);
        };
        put_v(l.u, &y.u);
        put_v(l.v, &y.v);
        if l.rate {
            for (k, &r) in y.rho.iter().enumerate() {
                flat[l.rho + k] = (r - self.material.rho0) as f32;
            }
            let mut tmp = Vec::with_capacity(l.n * D::N * D::N);
            y.s.iter().for_each(|&s| D::push_t(&mut tmp, s));
            flat[l.s..l.s + tmp.len()].copy_from_slice(&tmp);
        }
        self.gpu.queue.write_buffer(
            &self.states[Buf::Y as usize],
            0,
            bytemuck::cast_slice(&flat),
        );
        self.primed = false;
        self.reduced = None;
    }

    /// Rates of a given state: (dy/dt, F, P) per particle, read back.
    pub fn rates(&mut self, y: &TlState<D>) -> (TlState<D>, Vec<D::T>, Vec<D::T>) {
        self.set_state(y);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.record(&mut encoder, &self.rates_y);
        self.gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = self.gpu.read(&self.states[Buf::Rates as usize]);
        let (f, p) = self.kinematics();
        (self.decode(&d), f, p)
    }

    /// The corrected reference gradients, in CSR order.
    pub fn gradients(&self) -> Vec<D::V> {
        let g: Vec<f32> = self.gpu.read(&self.grad);
        g.chunks_exact(D::N).map(D::read_v).collect()
    }

    /// F and P of the last rate evaluation (the GPU keeps H = F − I; I is added in f64).
    pub fn kinematics(&self) -> (Vec<D::T>, Vec<D::T>) {
        let kin: Vec<f32> = self.gpu.read(&self.kin);
        let l = &self.layout;
        let t = D::N * D::N;
        let tensor = |off: usize, i: usize| D::read_t(&kin[off + t * i..]);
        let f = (0..l.n)
            .map(|i| D::identity() + tensor(l.kin_f, i))
            .collect();
        let p = (0..l.n).map(|i| tensor(l.kin_p, i)).collect();
        (f, p)
    }

    /// The first particle whose det F ≤ 0 (or NaN) in any evaluation so far.
    pub fn failed_particle(&self) -> Option<usize> {
        read_status(&self.gpu, &self.status)
    }
}

impl<D: GpuDim> Engine<D> for GpuTlsph<D> {
    fn backend(&self) -> String {
        format!("gpu: {}", self.gpu.name())
    }

    fn reference(&self) -> &[D::V] {
        &self.x0
    }

    fn constrained(&self) -> &[(u32, u8)] {
        &self.constrained
    }

    fn advance(&mut self, _t: f64, dt: f64, steps: u32) -> Result<(), BlowUp> {
        self.advance_steps(dt, steps);
        Ok(())
    }

    fn max_signal_speed(&mut self) -> f64 {
        self.material.p_wave_speed() + self.reduction().max_speed
    }

    /// Trapezoidal over the intervals between calls (the driver calls it at every check).
    fn external_work(&mut self) -> f64 {
        let power = self.reduction().power;
        let (t_last, p_last) = self.last_power;
        self.work += 0.5 * (p_last + power) * (self.time - t_last);
        self.last_power = (self.time, power);
        self.work
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        if let Some(i) = self.failed_particle() {
            return Err(BlowUp {
                particle: i,
                position: D::to3(self.x0[i]),
                quantity: "det F (f32, GPU)".into(),
                value: 0.0,
            });
        }
        if self.reduction().non_finite {
            return check_state(&self.x0, &self.state());
        }
        Ok(())
    }

    fn invariants(&mut self) -> Invariants {
        self.reduction().invariants
    }

    fn finish(&mut self) {
        self.gpu
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("waiting for the GPU queue");
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            let n = self.layout.n as u32;
            self.gpu
                .dispatch(&mut pass, &self.stress, &self.kinematics_y, n);
        }
        self.gpu.queue.submit([encoder.finish()]);
        let y = self.state();
        let (f, _) = self.kinematics();
        snapshot(
            &self.material,
            &self.x0,
            &self.mass,
            &self.body,
            &self.vol,
            y,
            f,
        )
    }
}

/// Values per workgroup written by `reduce.wgsl`.
const REDUCED: usize = 11;

/// The GPU reduction of one state, summed on the host.
#[derive(Clone, Copy, Debug)]
struct Reduced {
    invariants: Invariants,
    /// Power of supports and loads.
    power: f64,
    max_speed: f64,
    non_finite: bool,
}

impl<D: GpuDim> GpuTlsph<D> {
    /// Stress pass on the current state (F into the kinematics) and the reduction; reads
    /// back REDUCED values per workgroup only.
    fn reduction(&mut self) -> Reduced {
        if let Some(r) = self.reduced {
            return r;
        }
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            let n = self.layout.n as u32;
            self.gpu
                .dispatch(&mut pass, &self.stress, &self.kinematics_y, n);
            self.gpu
                .dispatch(&mut pass, &self.reduce, &self.reduce_bind, n);
        }
        self.gpu.queue.submit([encoder.finish()]);
        let partials: Vec<f32> = self.gpu.read(&self.partials);
        let mut q = [0.0f64; REDUCED];
        for group in partials.chunks_exact(REDUCED) {
            for (k, &v) in group.iter().enumerate() {
                q[k] = if k == 9 {
                    q[k].max(f64::from(v))
                } else {
                    q[k] + f64::from(v)
                };
            }
        }
        let r = Reduced {
            invariants: Invariants {
                kinetic: q[0],
                strain: q[1],
                linear: [q[2], q[3], q[4]],
                angular: [q[5], q[6], q[7]],
            },
            power: q[8],
            max_speed: q[9].sqrt(),
            non_finite: q[10] != 0.0 || !q[..10].iter().all(|x| x.is_finite()),
        };
        self.reduced = Some(r);
        r
    }
}
