//! The integrator's program of one GPU step, shared by the GPU engines: the operations of
//! each scheme (the same as `crate::integrate`) on four state-sized flat buffers, the stage
//! passes of `shaders/common/integrate.wgsl` with their coefficients, and the recording of whole
//! steps, with the method's rate evaluations, into one command encoder.

use super::context::Gpu;
use crate::integrate::IntegratorKind;
use bytemuck::{Pod, Zeroable};

/// One of the four state-sized buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Buf {
    Y,
    Stage,
    Rates,
    Acc,
}

/// One rate evaluation of a step: of the state in `src` into `Rates`, the `index`-th of
/// the step. The leapfrog's priming evaluation (rates of `Y` before its first step) has
/// index 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Evaluation {
    pub src: Buf,
    pub index: usize,
}

/// One operation of a step.
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
    /// u += (b_dt·Δt)·v; every field after v += (b_dt·Δt)·rates.
    Drift {
        out: Buf,
        b_dt: f64,
    },
}

/// The operations of one step, in order, as `meshless run --explain` prints them;
/// `rates` describes one rate evaluation of the method.
pub fn describe_step(kind: IntegratorKind, rates: &str) -> Vec<String> {
    program(kind)
        .into_iter()
        .map(|op| match op {
            Op::Rates(src) => format!("rates of {src:?}: {rates}"),
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
                format!("drift: u({out:?}) += {b_dt}·Δt·v, fields after v += {b_dt}·Δt·rates")
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

/// The rate evaluations of one step, in order.
pub fn evaluations(kind: IntegratorKind) -> Vec<Evaluation> {
    program(kind)
        .into_iter()
        .filter_map(|op| match op {
            Op::Rates(src) => Some(src),
            _ => None,
        })
        .enumerate()
        .map(|(index, src)| Evaluation { src, index })
        .collect()
}

/// A flat state of n particles: u at 0 and v at n·DIM (DIM each), then the fields that
/// are integrated with their rates, from `rest` to `len` (f32 entries).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StateLayout {
    pub n: usize,
    pub dim: usize,
    pub rest: usize,
    pub len: usize,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Coefficients {
    a: f32,
    b: f32,
}

/// A recorded operation with its GPU resources.
enum Recorded {
    Rates(Evaluation),
    Copy(Buf, Buf),
    Pass {
        pipeline: usize,
        bind: wgpu::BindGroup,
        coefficients: wgpu::Buffer,
        invocations: u32,
        op: Op,
    },
}

/// The state buffers and the recorded program of an integrator.
pub struct Stepper {
    kind: IntegratorKind,
    layout: StateLayout,
    /// y, stage, rates, acc.
    states: [wgpu::Buffer; 4],
    /// blend, kick, drift.
    stages: [wgpu::ComputePipeline; 3],
    steps: Vec<Recorded>,
    dt: f64,
    /// Leapfrog only: rates primed at the current state.
    primed: bool,
}

impl Stepper {
    /// The program of `kind` on a state starting at `y0`; `integrate` is
    /// `shaders/common/integrate.wgsl` composed with the scene's constants (N, DIM, U_OFF, V_OFF,
    /// REST_OFF, LEN of `layout`).
    pub fn new(
        gpu: &Gpu,
        kind: IntegratorKind,
        integrate: &str,
        layout: StateLayout,
        y0: &[f32],
    ) -> Self {
        let bytes = layout.len as u64 * 4;
        let states = [
            gpu.storage("y", y0),
            gpu.zeroed("stage", bytes),
            gpu.zeroed("rates", bytes),
            gpu.zeroed("acc", bytes),
        ];
        let stages = ["blend", "kick", "drift"].map(|e| gpu.pipeline(e, integrate, e));
        let (nd, rest) = (layout.n * layout.dim, layout.len - layout.rest);
        let mut index = 0;
        let steps = program(kind)
            .into_iter()
            .map(|op| {
                let (pipeline, out, x, invocations) = match op {
                    Op::Rates(src) => {
                        index += 1;
                        return Recorded::Rates(Evaluation {
                            src,
                            index: index - 1,
                        });
                    }
                    Op::Copy(a, b) => return Recorded::Copy(a, b),
                    Op::Blend { out, x, .. } => (0, out, x, layout.len),
                    Op::Kick { out, .. } => (1, out, Buf::Rates, nd),
                    Op::Drift { out, .. } => (2, out, Buf::Rates, nd + rest),
                };
                let coefficients = gpu.uniform("coefficients", &Coefficients { a: 1.0, b: 0.0 });
                let bind = gpu.bind(
                    &stages[pipeline],
                    &[&coefficients, &states[out as usize], &states[x as usize]],
                );
                Recorded::Pass {
                    pipeline,
                    bind,
                    coefficients,
                    invocations: invocations as u32,
                    op,
                }
            })
            .collect();
        Self {
            kind,
            layout,
            states,
            stages,
            steps,
            dt: f64::NAN,
            primed: false,
        }
    }

    pub fn kind(&self) -> IntegratorKind {
        self.kind
    }

    pub fn buffer(&self, b: Buf) -> &wgpu::Buffer {
        &self.states[b as usize]
    }

    /// Replaces the state in `Y` (the leapfrog primes its rates again).
    pub fn set_state(&mut self, gpu: &Gpu, flat: &[f32]) {
        gpu.queue
            .write_buffer(self.buffer(Buf::Y), 0, bytemuck::cast_slice(flat));
        self.primed = false;
    }

    /// Rewrites the stage coefficients when the step size changes.
    fn set_dt(&mut self, gpu: &Gpu, dt: f64) {
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
                gpu.queue
                    .write_buffer(coefficients, 0, bytemuck::bytes_of(&c));
            }
        }
    }

    /// Records `steps` steps of size `dt` into `encoder`; `rates` records one rate
    /// evaluation of the method (into `Rates`), `begin_step` what runs before each step.
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        dt: f64,
        steps: u32,
        mut rates: impl FnMut(&mut wgpu::CommandEncoder, Evaluation),
        mut begin_step: impl FnMut(&mut wgpu::CommandEncoder),
    ) {
        self.set_dt(gpu, dt);
        if self.kind == IntegratorKind::Leapfrog && !self.primed {
            rates(
                encoder,
                Evaluation {
                    src: Buf::Y,
                    index: 0,
                },
            );
            self.primed = true;
        }
        for _ in 0..steps {
            begin_step(encoder);
            for rec in &self.steps {
                match rec {
                    Recorded::Rates(e) => rates(encoder, *e),
                    Recorded::Copy(a, b) => encoder.copy_buffer_to_buffer(
                        self.buffer(*a),
                        0,
                        self.buffer(*b),
                        0,
                        self.layout.len as u64 * 4,
                    ),
                    Recorded::Pass {
                        pipeline,
                        bind,
                        invocations,
                        ..
                    } => {
                        let mut pass = encoder.begin_compute_pass(&Default::default());
                        gpu.dispatch(&mut pass, &self.stages[*pipeline], bind, *invocations);
                    }
                }
            }
        }
    }
}
