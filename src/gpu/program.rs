//! The integrator's program of one GPU step, shared by the GPU engines: the operations of
//! each scheme ([`crate::core::integrate::program`], which the CPU interprets) on four
//! state-sized flat buffers, the stage passes of `shaders/common/integrate.wgsl` with their
//! coefficients, and the recording of whole steps, with the method's rate evaluations,
//! into one command encoder.

use super::context::{Gpu, GpuError, Pipeline};
use super::layout::Fields;
use super::memory::DeviceMemory;
use crate::core::integrate::{Buf, Evaluation, IntegratorKind, Op, program, uses};
use encase::ShaderType;

/// A flat state of n particles: u at 0 and v at n·DIM (DIM each), then the fields that
/// are integrated with their rates, from `rest` to `len` (f32 entries).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StateLayout {
    pub n: usize,
    pub dim: usize,
    pub rest: usize,
    pub len: usize,
}

impl StateLayout {
    /// The layout of a state buffer with the fields `state`: the vectors U and V first,
    /// the fields integrated with their rates from the field `rest` on.
    pub fn of(state: &Fields, rest: &str) -> Self {
        let u = state.field("U");
        Self {
            n: u.count,
            dim: u.width,
            rest: state.offset(rest),
            len: state.len(),
        }
    }
}

/// The uniform `Coefficients` of `integrate.wgsl`.
#[derive(Clone, Copy, Debug, ShaderType)]
struct Coefficients {
    a: f32,
    b: f32,
}

/// A recorded operation with its GPU resources.
enum Recorded {
    Rates(Evaluation),
    /// from, to.
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
    /// y, stage (one word for a scheme without it), rates, acc.
    states: [wgpu::Buffer; 4],
    /// blend (in place), blend from another buffer, kick, drift.
    stages: [Pipeline; 4],
    steps: Vec<Recorded>,
    dt: f64,
    /// Leapfrog only: rates primed at the current state.
    primed: bool,
}

/// The bytes of the buffer `Stage` of a program `ops` on states of `bytes`: a state only
/// where the scheme uses it (not the leapfrog). The engines bind it as their second
/// evaluation source either way, which a scheme without it never runs: one word then.
/// `Acc` is the engines' scratch for the rates of `Y` that outputs read, so every scheme
/// has it.
fn stage_bytes(ops: &[Op], bytes: u64) -> u64 {
    if uses(ops, Buf::Stage) { bytes } else { 4 }
}

impl Stepper {
    /// The buffers [`Self::new`] makes for a state of `len` words under `kind`: `y`,
    /// `stage`, `rates`, `acc`, and the coefficients of each blend, kick and drift.
    pub fn memory(memory: &mut DeviceMemory, kind: IntegratorKind, len: usize) {
        let ops = program(kind);
        let bytes = len.max(1) as u64 * 4;
        for (label, b) in [
            ("y", bytes),
            ("stage", stage_bytes(&ops, bytes)),
            ("rates", bytes),
            ("acc", bytes),
        ] {
            memory.add(label, b as f64);
        }
        let passes = ops
            .iter()
            .filter(|op| !matches!(op, Op::Rates { .. } | Op::Copy { .. }))
            .count();
        let uniform = super::context::uniform_bytes(&Coefficients { a: 1.0, b: 0.0 }).len();
        memory.add("coefficients", (passes * uniform) as f64);
    }

    /// The program of `kind` on a state starting at `y0`; `integrate` is
    /// `shaders/common/integrate.wgsl` composed with the scene's constants (N, DIM, U_OFF, V_OFF,
    /// REST_OFF, LEN of `layout`, [`StateLayout::of`] the state's fields).
    pub fn new(
        gpu: &Gpu,
        kind: IntegratorKind,
        integrate: &str,
        layout: StateLayout,
        y0: &[f32],
    ) -> Result<Self, GpuError> {
        let bytes = layout.len as u64 * 4;
        let ops = program(kind);
        let stage = stage_bytes(&ops, bytes);
        let states = [
            gpu.storage("y", y0),
            gpu.zeroed("stage", stage),
            gpu.zeroed("rates", bytes),
            gpu.zeroed("acc", bytes),
        ];
        let stages = [
            gpu.pipeline("blend", integrate, "blend")?,
            gpu.pipeline("blend", integrate, "blend_from")?,
            gpu.pipeline("kick", integrate, "kick")?,
            gpu.pipeline("drift", integrate, "drift")?,
        ];
        let (nd, rest) = (layout.n * layout.dim, layout.len - layout.rest);
        let mut index = 0;
        let steps = ops
            .into_iter()
            .map(|op| {
                let (pipeline, out, from, x, invocations) = match op {
                    Op::Rates { src, .. } => {
                        index += 1;
                        return Ok(Recorded::Rates(Evaluation {
                            src,
                            index: index - 1,
                        }));
                    }
                    Op::Copy { from, to } => return Ok(Recorded::Copy(from, to)),
                    Op::Blend { out, from, x, .. } if from == out => (0, out, from, x, layout.len),
                    Op::Blend { out, from, x, .. } => (1, out, from, x, layout.len),
                    Op::Kick { out, .. } => (2, out, out, Buf::Rates, nd),
                    Op::Drift { out, .. } => (3, out, out, Buf::Rates, nd + rest),
                };
                let coefficients = gpu.uniform("coefficients", &Coefficients { a: 1.0, b: 0.0 });
                let bind = gpu.bind(
                    &stages[pipeline],
                    &[
                        ("c", &coefficients),
                        ("out", &states[out as usize]),
                        ("x", &states[x as usize]),
                        ("base", &states[from as usize]),
                    ],
                )?;
                Ok(Recorded::Pass {
                    pipeline,
                    bind,
                    coefficients,
                    invocations: invocations as u32,
                    op,
                })
            })
            .collect::<Result<_, GpuError>>()?;
        Ok(Self {
            kind,
            layout,
            states,
            stages,
            steps,
            dt: f64::NAN,
            primed: false,
        })
    }

    pub fn kind(&self) -> IntegratorKind {
        self.kind
    }

    pub fn buffer(&self, b: Buf) -> &wgpu::Buffer {
        &self.states[b as usize]
    }

    /// After the state buffer was written directly (a checkpoint restored): the
    /// leapfrog's rates are evaluated again before its next step.
    pub fn state_replaced(&mut self) {
        self.primed = false;
    }

    /// Replaces the state in `Y` (the leapfrog primes its rates again).
    pub fn set_state(&mut self, gpu: &Gpu, flat: &[f32]) {
        gpu.queue
            .write_buffer(self.buffer(Buf::Y), 0, bytemuck::cast_slice(flat));
        self.primed = false;
    }

    /// Replaces the state in `Y` by a copy of `from` (a state saved before steps that are
    /// to run again); the leapfrog primes its rates again.
    pub fn restart_from(&mut self, gpu: &Gpu, from: &wgpu::Buffer) {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let bytes = self.layout.len as u64 * 4;
        encoder.copy_buffer_to_buffer(from, 0, self.buffer(Buf::Y), 0, bytes);
        gpu.queue.submit([encoder.finish()]);
        self.state_replaced();
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
                    Op::Blend { a, b, .. } => (a, b.at(dt)),
                    Op::Kick { h, .. } | Op::Drift { h, .. } => (1.0, h.times(dt)),
                    Op::Rates { .. } | Op::Copy { .. } => {
                        unreachable!("only passes carry coefficients")
                    }
                };
                let c = Coefficients {
                    a: a as f32,
                    b: b as f32,
                };
                gpu.write_uniform(coefficients, &c);
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
        for _ in 0..steps {
            begin_step(encoder);
            // As on the CPU: the leapfrog's first rates after the first step's preparation.
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

super::context::wgsl_twin_test!(coefficients_match_wgsl: Coefficients = "Coefficients" in super::shaders::INTEGRATE.text);
