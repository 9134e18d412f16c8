//! Artificial compressibility on the GPU: the pseudo-time corrector of every stage
//! (`shaders/mixed/mixed_corrector.wgsl`), after the predictor's rate evaluation, as the
//! CPU's [`super::compressibility::Corrector`] does it.
//!
//! The iteration runs on the device without a read-back: its passes are dispatched
//! indirectly, and the check that ends it sets their workgroup counts to zero. A step's
//! command buffer holds a budget of pseudo steps per stage. The budget starts at
//! [`FIRST_BUDGET`] and follows twice the most a stage took, read back once per batch of
//! steps. When a stage reaches it without converging, the batch runs again from its
//! start with a larger budget, up to `max_iterations`: the result is the one of an
//! unlimited budget. The passes that read the neighbour lists run a part of them at a
//! time ([`crate::gpu::parts`]).

use super::compressibility::{Corrector, Unconverged};
use super::gpu::{IMAGES, MIXED, MOTION};
use crate::core::integrate::PseudoTime;
use crate::core::tensor::Dim;
use crate::gpu::context::{Gpu, GpuError, Pipeline, WORKGROUP};
use crate::gpu::memory::DeviceMemory;
use crate::gpu::parts::Split;
use crate::gpu::profile::IndirectRuns;
use crate::gpu::shaders::{PART, REFERENCE, Source, source};
use encase::ShaderType;

/// The corrector's passes.
pub const CORRECTOR: Source = source!(
    "mixed/mixed_corrector.wgsl",
    [MIXED, MOTION, IMAGES, REFERENCE, PART],
    [
        ("pair", false),
        ("y", false),
        ("d", true),
        ("kin", false),
        ("corr", true),
        ("ghost_img", false),
        ("reference", false),
        ("force", true)
    ]
);

/// Pseudo steps recorded per stage before the first read-back.
const FIRST_BUDGET: u32 = 64;

/// The factor on the budget when a stage ran out of it: each rerun records up to this
/// many times the pseudo steps of the last, and `max_iterations` is reached after a few.
const BUDGET_GROWTH: u32 = 4;

/// The words of `control` (mixed_corrector.wgsl): the step's pseudo steps and residual
/// are cleared at each step, the words from [`TOTAL`] on are read back after a batch.
const STEP_ITERATIONS: u64 = 3;
const TOTAL: u64 = 5;
const FAILED: u64 = 7;
const PARTIALS: u64 = 10;
/// The bytes of an indirect dispatch's workgroup counts, and of the failure flags saved
/// at the batch start.
const ARGS_BYTES: u64 = 12;
const FLAGS_BYTES: u64 = 16;

/// The uniform `Tau` of mixed_corrector.wgsl.
#[derive(Clone, Copy, Debug, Default, ShaderType)]
struct Tau {
    dt: f32,
    dtau: f32,
    gamma: f32,
    eta: f32,
    relax: f32,
    budget: u32,
}

/// A pass of the corrector with its bind group, or one a part of the lists for a pass
/// that reads them.
struct Pass {
    pipeline: Pipeline,
    binds: Vec<wgpu::BindGroup>,
    by_part: bool,
}

/// The corrector's pipelines, buffers and bind groups.
pub(super) struct DeviceCorrector {
    /// The start, which binds the stage state ([`Self::bind_start`]).
    start: Pipeline,
    constraint: Pass,
    begin: Pass,
    residual: Pass,
    residual_stage: Pass,
    check: Pass,
    euler: Pass,
    average: Pass,
    correct: Pass,
    tau: wgpu::Buffer,
    control: wgpu::Buffer,
    /// The workgroup counts of the indirect passes: over every particle, then a part
    /// each.
    args: wgpu::Buffer,
    /// The state at the start of a batch, and the failure flags (the kinematics'
    /// `status`, then [`FAILED`] and its residual), for running it again.
    saved_state: wgpu::Buffer,
    saved_flags: wgpu::Buffer,
    /// The particles and the lists' share of a pass over every particle, then the rows
    /// and the share of the pairs of each part of the lists.
    whole: (u32, f64),
    parts: Vec<(u32, f64)>,
    budget: u32,
    max_iterations: u32,
    pub stats: PseudoTime,
    /// Pseudo steps run (discarded runs included) and recorded, for the pass report.
    pub runs: IndirectRuns,
}

impl DeviceCorrector {
    /// The buffers [`Self::new`] makes for `n` particles and a state of `state_bytes`,
    /// on lists in one part.
    pub fn memory(m: &mut DeviceMemory, n: usize, state_bytes: u64) {
        let groups = (n as u64).div_ceil(u64::from(WORKGROUP)).max(1);
        let tau = crate::gpu::context::uniform_bytes(&Tau::default()).len();
        m.add("pseudo-time constants", tau as f64);
        m.words("corrector control", (PARTIALS + 2 * groups) as f64);
        for label in ["corrector workgroups", "corrector workgroups when running"] {
            m.add(label, (2 * ARGS_BYTES) as f64);
        }
        m.add("state at the batch start", state_bytes as f64);
        m.add("failure flags at the batch start", FLAGS_BYTES as f64);
    }

    /// The passes of `source` (mixed_corrector.wgsl composed with the scene's constants)
    /// for `n` particles and a state of `state_bytes`, with the other buffers of the mixed
    /// passes by binding name in `tables`, one a part of `split` (its lists and per-pair
    /// data).
    pub fn new<D: Dim>(
        gpu: &Gpu,
        source: &str,
        cpu: &Corrector<D>,
        (n, state_bytes): (usize, u64),
        split: &Split,
        tables: &[Vec<(&str, &wgpu::Buffer)>],
    ) -> Result<Self, GpuError> {
        let pipeline = |entry: &str| gpu.pipeline(&format!("corrector {entry}"), source, entry);
        let (gx, gy) = gpu.groups(n as u32);
        let tau = gpu.uniform("pseudo-time constants", &Tau::default());
        let control_words = PARTIALS as usize + 2 * (gx * gy) as usize;
        let mut words = vec![0u32; control_words];
        words[FAILED as usize] = u32::MAX;
        let control = gpu.storage("corrector control", &words);
        let parts: Vec<(u32, f64)> = (split.shares())
            .map(|(rows, share)| (rows as u32, share))
            .collect();
        let counts: Vec<u32> = [n as u32]
            .into_iter()
            .chain(parts.iter().map(|p| p.0))
            .flat_map(|items| {
                let (x, y) = gpu.groups(items);
                [x, y, 1]
            })
            .collect();
        let groups = gpu.storage("corrector workgroups when running", &counts);
        let args = gpu.indirect("corrector workgroups", 4 * counts.len() as u64);
        let saved_state = gpu.zeroed("state at the batch start", state_bytes);
        let saved_flags = gpu.zeroed("failure flags at the batch start", FLAGS_BYTES);
        let own = [
            ("tau", &tau),
            ("control", &control),
            ("args", &args),
            ("groups", &groups),
        ];
        let full: Vec<Vec<_>> = (tables.iter())
            .map(|t| [t.as_slice(), &own].concat())
            .collect();
        // A pass over every particle binds the first part's table, whose lists it does
        // not read.
        let pass = |entry: &str, by_part: bool| -> Result<Pass, GpuError> {
            let pipeline = pipeline(entry)?;
            let tables = if by_part { &full[..] } else { &full[..1] };
            let binds = (tables.iter())
                .map(|t| gpu.bind(&pipeline, t))
                .collect::<Result<_, GpuError>>()?;
            Ok(Pass {
                pipeline,
                binds,
                by_part,
            })
        };
        Ok(Self {
            constraint: pass("constraint", true)?,
            begin: pass("begin", false)?,
            residual: pass("residual", true)?,
            residual_stage: pass("residual_stage", true)?,
            check: pass("check", false)?,
            euler: pass("euler", false)?,
            average: pass("average", false)?,
            correct: pass("correct", true)?,
            start: pipeline("start")?,
            tau,
            control,
            args,
            saved_state,
            saved_flags,
            whole: (n as u32, 1.0),
            parts,
            budget: FIRST_BUDGET.min(cpu.max_iterations()),
            max_iterations: cpu.max_iterations(),
            stats: PseudoTime::default(),
            runs: IndirectRuns {
                ran: 0,
                recorded: 0,
            },
        })
    }

    /// The bind group of `start` for the stage state and rates in `table`.
    pub fn bind_start(
        &self,
        gpu: &Gpu,
        table: &[(&str, &wgpu::Buffer)],
    ) -> Result<wgpu::BindGroup, GpuError> {
        let mut full = table.to_vec();
        full.extend([("tau", &self.tau), ("control", &self.control)]);
        gpu.bind(&self.start, &full)
    }

    /// Writes the constants of a stage of size `dt` (those of the CPU's corrector `cpu`)
    /// and the budget into `tau`.
    pub fn set_dt<D: Dim>(&self, gpu: &Gpu, dt: f64, cpu: &Corrector<D>) {
        let gamma = cpu.gamma(dt);
        let t = Tau {
            dt: dt as f32,
            dtau: cpu.pseudo_step(dt, gamma) as f32,
            gamma: gamma as f32,
            eta: cpu.eta(dt) as f32,
            relax: (1.0 / (cpu.kappa() * dt)) as f32,
            budget: self.budget,
        };
        gpu.write_uniform(&self.tau, &t);
    }

    /// Records the copies of the state `y` and the failure flags (`status`) at the start
    /// of a batch.
    pub fn save(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        y: &wgpu::Buffer,
        status: &wgpu::Buffer,
    ) {
        encoder.copy_buffer_to_buffer(y, 0, &self.saved_state, 0, self.saved_state.size());
        encoder.copy_buffer_to_buffer(status, 0, &self.saved_flags, 0, 8);
        encoder.copy_buffer_to_buffer(&self.control, 4 * FAILED, &self.saved_flags, 8, 8);
    }

    /// The state saved at the start of the batch.
    pub fn saved_state(&self) -> &wgpu::Buffer {
        &self.saved_state
    }

    /// Puts the failure flags saved at the start of the batch back: a failure in a batch
    /// that runs again is the rerun's to find.
    pub fn restore_flags(&self, gpu: &Gpu, status: &wgpu::Buffer) {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.saved_flags, 0, status, 0, 8);
        encoder.copy_buffer_to_buffer(&self.saved_flags, 8, &self.control, 4 * FAILED, 8);
        gpu.queue.submit([encoder.finish()]);
    }

    /// Clears the step's count and residual (before each step).
    pub fn begin_step(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.control, 4 * STEP_ITERATIONS, Some(8));
    }

    /// Records the corrector of one stage, whose `start` binds its state, into `pass`:
    /// the start and the constant part of the constraint, then the budget's pseudo steps,
    /// each checked, then the force.
    pub fn record(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>, start: &wgpu::BindGroup) {
        let n = self.whole.0;
        // A pass over every particle (its one bind group), or a part of the lists at a
        // time (a bind group each).
        let parts = |p: &Pass| match p.by_part {
            true => &self.parts[..],
            false => std::slice::from_ref(&self.whole),
        };
        let dispatch = |pass: &mut wgpu::ComputePass<'_>, p: &Pass| {
            for (bind, &(rows, share)) in p.binds.iter().zip(parts(p)) {
                gpu.dispatch_part(pass, &p.pipeline, bind, rows, share);
            }
        };
        // The pseudo steps' passes, while the iteration runs: the counts of every
        // particle at `args`' start, then of each part.
        let indirect = |pass: &mut wgpu::ComputePass<'_>, p: &Pass| {
            let at = if p.by_part { ARGS_BYTES } else { 0 };
            for (k, (bind, &(rows, share))) in p.binds.iter().zip(parts(p)).enumerate() {
                let args = (&self.args, at + ARGS_BYTES * k as u64);
                let work = (u64::from(rows), share);
                gpu.dispatch_indirect(pass, &p.pipeline, bind, args, work);
            }
        };
        gpu.dispatch(pass, &self.start, start, n);
        dispatch(pass, &self.constraint);
        gpu.dispatch(pass, &self.begin.pipeline, &self.begin.binds[0], 1);
        let checked = |pass: &mut wgpu::ComputePass<'_>| {
            indirect(pass, &self.residual);
            gpu.dispatch(pass, &self.check.pipeline, &self.check.binds[0], 1);
        };
        checked(pass);
        for _ in 0..self.budget {
            indirect(pass, &self.euler);
            indirect(pass, &self.residual_stage);
            indirect(pass, &self.average);
            checked(pass);
        }
        dispatch(pass, &self.correct);
    }

    /// Books the pseudo steps a batch of `stages` stages records.
    pub fn record_batch(&mut self, stages: u64) {
        self.runs.recorded += stages * u64::from(self.budget);
    }

    /// Reads the batch's report back (waits for the queue) and clears its words. When a
    /// stage ran out of budget, raises the budget [`BUDGET_GROWTH`]-fold (at most to
    /// `max_iterations`) and returns false: the batch runs again. Else books the counts
    /// and sets the next budget, twice the most a stage took.
    pub fn finish_batch(&mut self, gpu: &Gpu) -> bool {
        // Words STEP_ITERATIONS to MOST: the last step's pseudo steps and residual, the
        // total, whether a stage ran out of budget, (FAILED and its residual), the most.
        let w: Vec<u32> = gpu.read_range(&self.control, 4 * STEP_ITERATIONS, 4 * 7);
        let (step, residual, total, exhausted, most) =
            (w[0], f32::from_bits(w[1]), w[2], w[3] != 0, w[6]);
        // TOTAL, EXHAUSTED, and after FAILED and its residual, MOST.
        gpu.queue
            .write_buffer(&self.control, 4 * TOTAL, bytemuck::cast_slice(&[0u32; 2]));
        gpu.queue
            .write_buffer(&self.control, 4 * 9, bytemuck::bytes_of(&0u32));
        self.runs.ran += u64::from(total);
        if exhausted {
            // The stages that ran out of budget are not in the total: at least one did.
            self.runs.ran += u64::from(self.budget);
            self.budget = (BUDGET_GROWTH * self.budget).min(self.max_iterations);
            return false;
        }
        self.stats.step = u64::from(step);
        self.stats.total += u64::from(total);
        self.stats.residual = f64::from(residual);
        self.budget = (2 * most).max(FIRST_BUDGET).min(self.max_iterations);
        true
    }

    /// The first particle whose iteration did not converge within `max_iterations`.
    pub fn unconverged(&self, gpu: &Gpu) -> Option<Unconverged> {
        let w: Vec<u32> = gpu.read_range(&self.control, 4 * FAILED, 8);
        (w[0] != u32::MAX).then(|| Unconverged {
            particle: w[0] as usize,
            residual: f64::from(f32::from_bits(w[1])),
        })
    }
}

crate::gpu::context::wgsl_twin_test!(tau_matches_wgsl: Tau = "Tau" in CORRECTOR.text);
