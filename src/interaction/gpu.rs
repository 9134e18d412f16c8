//! Interactions on the device: passes recorded before every step. The engine copies the
//! traction loads into its `ext` buffer, then each pass adds its particles'
//! accelerations there, and the rate passes add `ext` (`shaders/common/boundary.wgsl`).

use super::Interactions;
use crate::gpu::context::{Gpu, GpuError, Pipeline};
use crate::gpu::shaders::Source;
use crate::tensor::Dim;

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
    /// Its uniform, rewritten from Δt before the steps are recorded.
    pub params: wgpu::Buffer,
    /// The uniform's value for a step of size Δt.
    pub uniform: Box<dyn Fn(f64) -> [f32; 4] + Send + Sync>,
}

/// An interaction that runs on the device.
pub trait GpuInteraction {
    /// Compiles its pass with the engine's scene constants (`compose`) and binds it.
    fn pass(
        &self,
        gpu: &Gpu,
        compose: &dyn Fn(&Source) -> String,
        on: &Bindings,
    ) -> Result<Pass, GpuError>;
}

/// The device passes of a scene's interactions, for one engine.
pub struct GpuInteractions {
    passes: Vec<Pass>,
    /// The traction loads, copied into `ext` before the passes add to it.
    traction: wgpu::Buffer,
    ext: wgpu::Buffer,
}

impl GpuInteractions {
    /// The passes of `interactions` on the engine's `reference` and state `y`; `traction`
    /// holds the loads, and the `ext` the rate passes read is [`GpuInteractions::ext`]:
    /// `traction` itself when no pass writes.
    pub fn new<D: Dim>(
        gpu: &Gpu,
        interactions: &Interactions<D>,
        compose: &dyn Fn(&Source) -> String,
        reference: &wgpu::Buffer,
        y: &wgpu::Buffer,
        traction: wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        let mut passes = interactions.gpu_passes().peekable();
        let ext = if passes.peek().is_some() {
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
        let passes = passes
            .map(|p| p.pass(gpu, compose, &on))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            passes,
            traction,
            ext,
        })
    }

    /// The external accelerations the rate passes add.
    pub fn ext(&self) -> &wgpu::Buffer {
        &self.ext
    }

    /// Writes the passes' uniforms for steps of size dt.
    pub fn set_step(&self, gpu: &Gpu, dt: f64) {
        for p in &self.passes {
            gpu.queue
                .write_buffer(&p.params, 0, bytemuck::cast_slice(&(p.uniform)(dt)));
        }
    }

    /// Records the work before a step: `ext` = traction, then every pass over n particles.
    pub fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, n: u32) {
        if self.passes.is_empty() {
            return;
        }
        encoder.copy_buffer_to_buffer(&self.traction, 0, &self.ext, 0, self.traction.size());
        let mut pass = encoder.begin_compute_pass(&Default::default());
        for p in &self.passes {
            gpu.dispatch(&mut pass, &p.pipeline, &p.bind, n);
        }
    }
}
