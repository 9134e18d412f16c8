//! Interactions on the device: passes recorded before every step. The engine copies the
//! traction loads into its `ext` buffer, then each pass adds its particles'
//! accelerations there, and the rate passes add `ext` (`shaders/interaction/boundary.wgsl`).
//!
//! A pass may take values that change from step to step (the law values of the timed
//! loads): the host keeps the time of the next step it records (set by the engine at the
//! start of every batch, and advanced by Δt with each recorded step), writes the step's
//! values into a staging buffer as it records the step (each step its own slot, so the
//! writes of a whole batch land before its command buffer runs) and records a copy of
//! them into the pass's buffer before the pass. Nothing is read back.

use super::Interactions;
use crate::boundary::Boundary;
use crate::case::Case;
use crate::core::tensor::Dim;
use crate::gpu::context::{Gpu, GpuError, Pipeline};
use crate::gpu::memory::DeviceMemory;
use crate::gpu::shaders::Compose;
use std::cell::{Cell, RefCell};

/// The engine buffers an interaction pass binds.
pub struct Bindings<'a> {
    /// The reference configuration (`gpu::reference`: X at `RX_OFF`).
    pub reference: &'a wgpu::Buffer,
    /// The state at the start of the step, u at `U_OFF`.
    pub y: &'a wgpu::Buffer,
    /// External accelerations, DIM floats a particle: the passes add to it.
    pub ext: &'a wgpu::Buffer,
}

/// A compiled and bound pass of one interaction.
pub struct Pass {
    pub pipeline: Pipeline,
    pub bind: wgpu::BindGroup,
    /// Its uniform, rewritten from Δt before the steps are recorded, and the uniform's
    /// value for a step of size Δt.
    pub params: Option<(wgpu::Buffer, Uniform)>,
    /// Values written for every step it runs in.
    pub step_values: Option<StepValues>,
}

/// The bytes of a pass's uniform for a step of size Δt (see
/// [`crate::gpu::context::uniform_bytes`]).
pub type Uniform = Box<dyn Fn(f64) -> Vec<u8> + Send + Sync>;

/// Values a pass reads that change from step to step.
pub struct StepValues {
    /// The storage buffer the pass reads them from.
    pub target: wgpu::Buffer,
    /// The values of the step from t to t + Δt.
    pub values: Box<dyn Fn(f64, f64) -> Vec<f32> + Send + Sync>,
}

/// Staging buffers for the step values of the batch being recorded: slots taken in
/// order, a new buffer when one is full; all free again at the next batch.
#[derive(Default)]
struct Staging {
    buffers: Vec<wgpu::Buffer>,
    /// The buffer and byte offset of the next slot.
    at: (usize, u64),
}

impl Staging {
    /// Bytes of one staging buffer (more if a slot needs it).
    const CHUNK: u64 = 1 << 16;

    /// A slot of `bytes` for the batch being recorded.
    fn slot(&mut self, gpu: &Gpu, bytes: u64) -> (&wgpu::Buffer, u64) {
        let (mut k, mut offset) = self.at;
        if k < self.buffers.len() && offset + bytes > self.buffers[k].size() {
            (k, offset) = (k + 1, 0);
        }
        if k == self.buffers.len() {
            self.buffers
                .push(gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("step values (staging)"),
                    size: bytes.max(Self::CHUNK),
                    usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }));
        }
        self.at = (k, offset + bytes);
        (&self.buffers[k], offset)
    }
}

/// An interaction that runs on the device.
pub trait GpuInteraction {
    /// Compiles its pass with the engine's scene constants (`compose`) and binds it.
    fn pass(&self, gpu: &Gpu, compose: Compose<'_>, on: &Bindings) -> Result<Pass, GpuError>;
}

/// The device passes of a scene's interactions, for one engine.
pub struct GpuInteractions {
    passes: Vec<Pass>,
    /// Whether an interaction adds to `ext` (which is then a buffer of its own).
    adds: bool,
    /// The traction loads, copied into `ext` before the passes add to it.
    traction: wgpu::Buffer,
    ext: wgpu::Buffer,
    /// The time of the next step recorded, and the step size.
    time: Cell<f64>,
    dt: Cell<f64>,
    staging: RefCell<Staging>,
}

impl GpuInteractions {
    /// The buffers [`Self::new`] and the interactions' passes make for the `n` particles
    /// of `case` in `dim` dimensions: the timed loads' accelerations, one DIM-vector a
    /// particle for each load, and the contact's body of each particle, with the `ext`
    /// buffer they add to (the hulls, law values and timed velocities take a few words).
    pub fn memory(memory: &mut DeviceMemory, case: &Case, n: usize, dim: usize) {
        let loads = case
            .boundaries
            .iter()
            .filter(|b| b.condition.is_timed_load())
            .count();
        if loads > 0 {
            memory.words("timed loads", (loads * n * dim) as f64);
        }
        if case.contact.is_some() {
            memory.words("body", n as f64);
        }
        if loads > 0 || case.contact.is_some() {
            memory.words("ext (traction + interactions)", (n * dim) as f64);
        }
    }

    /// The passes of `interactions` on the engine's `reference` and state `y`, then the
    /// timed velocities of `boundary` (which write their rates into `reference`);
    /// `traction` holds the loads, and the `ext` the rate passes read is
    /// [`GpuInteractions::ext`]: `traction` itself when no interaction adds to it.
    pub fn new<D: Dim>(
        gpu: &Gpu,
        interactions: &Interactions<D>,
        boundary: &Boundary<D>,
        compose: Compose<'_>,
        reference: &wgpu::Buffer,
        y: &wgpu::Buffer,
        traction: wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        let timed: Option<&dyn GpuInteraction> =
            (!boundary.timed.is_empty()).then_some(boundary as &dyn GpuInteraction);
        let adds = interactions.gpu_passes().next().is_some();
        let ext = if adds {
            // The loads alone until the first step's passes add to them.
            let ext = gpu.zeroed("ext (traction + interactions)", traction.size());
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(&traction, 0, &ext, 0, traction.size());
            gpu.queue.submit([encoder.finish()]);
            ext
        } else {
            traction.clone()
        };
        let on = Bindings {
            reference,
            y,
            ext: &ext,
        };
        let passes = interactions
            .gpu_passes()
            .chain(timed)
            .map(|p| p.pass(gpu, compose, &on))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            passes,
            adds,
            traction,
            ext,
            time: Cell::new(0.0),
            dt: Cell::new(0.0),
            staging: RefCell::default(),
        })
    }

    /// The time of the next step recorded.
    pub fn time(&self) -> f64 {
        self.time.get()
    }

    /// Sets the time of the next step recorded (the engine's, at the start of a batch:
    /// the clock otherwise advances by Δt with every step recorded from t = 0).
    pub fn set_time(&self, t: f64) {
        self.time.set(t);
    }

    /// The external accelerations the rate passes add.
    pub fn ext(&self) -> &wgpu::Buffer {
        &self.ext
    }

    /// Writes the passes' uniforms for steps of size dt, before a batch of steps is
    /// recorded (the staging slots of the previous batch are free again: it was
    /// submitted).
    pub fn set_step(&self, gpu: &Gpu, dt: f64) {
        self.dt.set(dt);
        self.staging.borrow_mut().at = (0, 0);
        for (params, uniform) in self.passes.iter().filter_map(|p| p.params.as_ref()) {
            gpu.queue.write_buffer(params, 0, &uniform(dt));
        }
    }

    /// Records the work before a step: the step's values of the passes that take them,
    /// `ext` = traction (when an interaction adds to it), then every pass over n particles;
    /// the clock moves on by Δt.
    pub fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, n: u32) {
        if self.passes.is_empty() {
            return;
        }
        let (t, dt) = (self.time.get(), self.dt.get());
        for feed in self.passes.iter().filter_map(|p| p.step_values.as_ref()) {
            let values = (feed.values)(t, dt);
            let bytes: &[u8] = bytemuck::cast_slice(&values);
            let mut staging = self.staging.borrow_mut();
            let (buffer, offset) = staging.slot(gpu, bytes.len() as u64);
            gpu.queue.write_buffer(buffer, offset, bytes);
            encoder.copy_buffer_to_buffer(buffer, offset, &feed.target, 0, bytes.len() as u64);
        }
        self.time.set(t + dt);
        if self.adds {
            encoder.copy_buffer_to_buffer(&self.traction, 0, &self.ext, 0, self.traction.size());
        }
        let mut pass = encoder.begin_compute_pass(&Default::default());
        for p in &self.passes {
            gpu.dispatch(&mut pass, &p.pipeline, &p.bind, n);
        }
    }
}

impl<D: Dim> GpuInteraction for Boundary<D> {
    /// `shaders/interaction/prescribed.wgsl`: one invocation per particle sets the rates of
    /// its timed components held over the step and its mask in `reference`, from the
    /// step's (held, rate) of every timed velocity (`steps`, written by the host for every
    /// step it records).
    fn pass(&self, gpu: &Gpu, compose: Compose<'_>, on: &Bindings) -> Result<Pass, GpuError> {
        let pipeline = gpu.pipeline(
            "timed velocities",
            &compose(&crate::gpu::shaders::PRESCRIBED),
            "timed_velocities",
        )?;
        let timed = gpu.storage("timed velocities", &self.timed_table());
        let steps = gpu.zeroed("timed velocities' steps", 8 * self.timed.len() as u64);
        let bind = gpu.bind(
            &pipeline,
            &[
                ("timed", &timed),
                ("steps", &steps),
                ("reference", on.reference),
            ],
        )?;
        Ok(Pass {
            pipeline,
            bind,
            params: None,
            step_values: Some(StepValues {
                target: steps,
                values: self.timed_step_values(),
            }),
        })
    }
}
