//! The plastic history on the device (`shaders/physics/plasticity.wgsl`): the 12 floats of
//! [`History::VIRGIN_F32`] per point (one dummy point for an elastic model), then the Δt
//! of the steps being recorded, which each commit stores as the step its point's next
//! returns are over (the host's [`History::dt`]).

use super::Gpu;
use crate::physics::plasticity::History;

/// The floats of the history of `points` points (of one dummy point unless `plastic`).
pub fn words(plastic: bool, points: usize) -> usize {
    History::VIRGIN_F32.len() * if plastic { points } else { 1 } + 1
}

/// The history of `points` virgin points (of one dummy point unless `plastic`).
pub fn upload(gpu: &Gpu, label: &str, plastic: bool, points: usize) -> wgpu::Buffer {
    let mut virgin = History::VIRGIN_F32.repeat(if plastic { points } else { 1 });
    virgin.push(0.0);
    gpu.storage(label, &virgin)
}

/// Writes the Δt of the steps of the batch about to be recorded, after the points.
pub fn set_step(gpu: &Gpu, hist: &wgpu::Buffer, dt: f64) {
    let slot = hist.size() - 4;
    gpu.queue
        .write_buffer(hist, slot, bytemuck::bytes_of(&(dt as f32)));
}
