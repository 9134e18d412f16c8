//! The shell every GPU engine stands in: the device, the integrator's program and its
//! state buffers ([`Stepper`]), the reduction of a state ([`Reduction`]), the work balance
//! of supports and loads ([`WorkBalance`]), the balance's terms the engine does not book,
//! and the kinematics buffer from which the supports' reactions are read. It gives what
//! the engines' `Engine` contracts share: the backend's name, the reduction of the current
//! state, the work, the reactions, read-back of the state and the checkpoint words (the
//! work balance, the state and the engine's other saved buffers). A family keeps its
//! layouts, its passes and the recording of its rate evaluations.

use super::context::Gpu;
use super::layout::{Fields, Flat};
use super::program::Stepper;
use super::reduction::{self, Reduced, Reduction, WorkBalance};
use crate::boundary::{Boundary, Reaction};
use crate::core::integrate::Buf;
use crate::diagnostics::balance::Booked;

/// The parts of a GPU engine that are not its family's (see the module's doc).
pub struct Shell {
    pub gpu: Gpu,
    pub stepper: Stepper,
    pub reduction: Reduction,
    pub work: WorkBalance,
    /// The balance's terms besides the work (and, where the engine books it, the
    /// dissipation): zero where the case has none, None where it has them and the engine
    /// does not book them.
    pub unbooked: Booked,
    /// The kinematics, whose fields end with the reactions ([`reduction::with_reactions`]).
    pub kin: wgpu::Buffer,
    kin_fields: Fields,
    /// The buffers a checkpoint holds after the state, by name (the plastic history).
    saved: Vec<(&'static str, wgpu::Buffer)>,
}

impl Shell {
    /// The shell of an engine whose kinematics `kin` have the fields `kin_fields`; the
    /// work balance starts at zero and checkpoints hold the state alone.
    pub fn new(
        gpu: Gpu,
        stepper: Stepper,
        reduction: Reduction,
        kin: wgpu::Buffer,
        kin_fields: &Fields,
        unbooked: Booked,
    ) -> Self {
        Self {
            gpu,
            stepper,
            reduction,
            work: WorkBalance::default(),
            unbooked,
            kin,
            kin_fields: kin_fields.clone(),
            saved: Vec::new(),
        }
    }

    /// Checkpoints hold `buffer` after the state (and the buffers saved before it).
    pub fn save_also(mut self, name: &'static str, buffer: &wgpu::Buffer) -> Self {
        self.saved.push((name, buffer.clone()));
        self
    }

    /// `Engine::backend`: the adapter's name.
    pub fn backend(&self) -> String {
        format!("gpu: {}", self.gpu.name())
    }

    /// The reduction of the current state, `before` recording the passes it needs first
    /// (cached until the state changes).
    pub fn reduced(&mut self, before: impl FnOnce(&Gpu, &mut wgpu::ComputePass<'_>)) -> Reduced {
        let Self { gpu, reduction, .. } = self;
        reduction.get(gpu, |pass| before(gpu, pass))
    }

    /// The work of supports and loads up to now, trapezoidal over the intervals between
    /// calls (the driver calls it at every check), given their power now.
    pub fn external_work(&mut self, power: f64) -> f64 {
        self.work.update(power)
    }

    /// `Engine::booked` of an engine that books the work alone.
    pub fn booked(&mut self, power: f64) -> Booked {
        Booked {
            external_work: self.external_work(power),
            ..self.unbooked
        }
    }

    /// The supports' reactions at the last rate evaluation, booked to those of `boundary`.
    pub fn reactions<D: Flat>(&self, boundary: &Boundary<D>) -> Vec<Reaction> {
        reduction::reactions(&self.gpu, &self.kin, &self.kin_fields, boundary)
    }

    /// The flat state `Y` read back (waits for the queue).
    pub fn read_state(&self) -> Vec<f32> {
        self.gpu.read(self.stepper.buffer(Buf::Y))
    }

    /// A new flat state `Y` (the reduction's cache forgotten).
    pub fn set_state(&mut self, flat: &[f32]) {
        self.stepper.set_state(&self.gpu, flat);
        self.reduction.invalidate();
    }

    /// `Engine::save`: the work balance, the state and the saved buffers (f32).
    pub fn save(&self) -> Vec<f64> {
        let mut buffers = vec![self.stepper.buffer(Buf::Y)];
        buffers.extend(self.saved.iter().map(|(_, b)| b));
        super::save_buffers(&self.gpu, &self.work, &buffers)
    }

    /// `Engine::restore`: what [`Self::save`] wrote.
    pub fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        let mut buffers = vec![("state", self.stepper.buffer(Buf::Y))];
        buffers.extend(self.saved.iter().map(|(name, b)| (*name, b)));
        self.work = super::load_buffers(&self.gpu, words, &buffers)?;
        self.stepper.state_replaced();
        self.reduction.invalidate();
        Ok(())
    }
}
