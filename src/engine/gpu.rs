//! The GPU engine: one [`Engine`] for every family that runs on the device. It holds the
//! [`Shell`] (device, stepper, reduction, work balance, kinematics, checkpoint buffers),
//! the interactions' passes before every step ([`GpuInteractions`]: contact, timed loads
//! and velocities) and the family ([`GpuFamily`]: its layouts and buffers, its passes,
//! how a rate evaluation is recorded and its own checks). The engine records a batch of
//! steps into one command encoder, runs it again from its start when the family asks
//! (lists grown, pseudo steps run out), and reads back only when asked (outputs,
//! observers, checks).

use super::{BlowUp, Engine, Failed};
use crate::boundary::{Boundary, OnPatches, Reaction};
use crate::case::Case;
use crate::core::integrate::{Buf, Evaluation, IntegratorKind, PseudoTime};
use crate::core::neighbour::Csr;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::{Invariants, Snapshot};
use crate::gpu::SetupError;
use crate::gpu::context::{Gpu, GpuError};
use crate::gpu::layout::{Fields, GpuDim};
use crate::gpu::profile::Scale;
use crate::gpu::program::{StateLayout, Stepper};
use crate::gpu::reduction::Reduced;
use crate::gpu::reference::DeviceReference;
use crate::gpu::shaders::Source;
use crate::gpu::shell::Shell;
use crate::interaction::Interactions;
use crate::interaction::gpu::GpuInteractions;
use crate::reference::Reference;

/// What every family's set-up starts from on the device: the device, the composer of
/// its pass files with the scene's constants, and the reference configuration uploaded.
pub struct Start<'a> {
    pub gpu: &'a Gpu,
    pub compose: &'a dyn Fn(&Source) -> String,
    pub device: &'a DeviceReference,
}

impl Start<'_> {
    /// The integrator program from the initial state `y0` (laid out as `state`), and the
    /// interactions' passes on its state `Y`, which read the device's reference
    /// configuration and traction loads.
    pub fn stepper<D: GpuDim>(
        &self,
        integrator: IntegratorKind,
        state: StateLayout,
        y0: &[f32],
        interactions: &Interactions<D>,
        boundary: &Boundary<D>,
    ) -> Result<(Stepper, GpuInteractions), GpuError> {
        let Self {
            gpu,
            compose,
            device,
        } = self;
        let integrate = compose(&crate::gpu::shaders::INTEGRATE);
        let stepper = Stepper::new(gpu, integrator, &integrate, state, y0)?;
        let interactions = GpuInteractions::new(
            gpu,
            interactions,
            boundary,
            compose,
            &device.reference,
            stepper.buffer(Buf::Y),
            device.traction.clone(),
        )?;
        Ok((stepper, interactions))
    }

    /// [`Start::stepper`] from the nodes' displacements and velocities (u, v), every other
    /// field of `state` zero, those from the field `rest` on integrated with their rates.
    pub fn from_motion<D: GpuDim>(
        &self,
        integrator: IntegratorKind,
        (state, rest): (&Fields, &str),
        (u, v): (&[D::V], &[D::V]),
        interactions: &Interactions<D>,
        boundary: &Boundary<D>,
    ) -> Result<(Stepper, GpuInteractions), GpuError> {
        let mut y0 = state.zeroed();
        state.write_v::<D>(&mut y0, "U", u);
        state.write_v::<D>(&mut y0, "V", v);
        let layout = StateLayout::of(state, rest);
        self.stepper(integrator, layout, &y0, interactions, boundary)
    }

    /// [`Start::stepper`] of a family of particles on the host's reference
    /// configuration `disc` of `case`, its state Y laid out as `state` with the rest
    /// density at `RHO`; the interactions' reference neighbours come from `neighbours`.
    pub fn particles<D: GpuDim>(
        &self,
        case: &Case,
        disc: &Reference<D>,
        state: &Fields,
        y0: &[f32],
        neighbours: impl FnOnce() -> Csr,
    ) -> Result<(Stepper, GpuInteractions), SetupError> {
        let (x0, body, mass) = (&disc.x0, &disc.body, &disc.mass);
        let interactions = Interactions::<D>::build(case, x0, body, &OnPatches, mass, neighbours)?;
        let state = StateLayout::of(state, "RHO");
        let integrator = case.method.integrator;
        Ok(self.stepper(integrator, state, y0, &interactions, &disc.boundary)?)
    }
}

/// What a family gives the [`GpuEngine`]: its reference configuration, the recording of
/// its passes, and the hooks where the families differ (each with the default of a
/// family that has nothing there).
pub trait GpuFamily<D: GpuDim> {
    /// The engine books the viscous dissipation the reduction gives besides the work.
    const BOOKS_DISSIPATION: bool = false;

    /// The particles or nodes, which the interactions' passes run over: one per
    /// reference position.
    fn nodes(&self) -> u32 {
        self.reference().len() as u32
    }

    /// The reference positions of the particles or nodes.
    fn reference(&self) -> &[D::V];

    /// The boundary conditions the reactions are booked to.
    fn boundary(&self) -> &Boundary<D>;

    /// What scales the passes' bytes in the pass report (the pairs of the lists, the
    /// indirect runs the device made).
    fn scale(&self, gpu: &Gpu) -> Scale;

    /// Records one rate evaluation.
    fn record_rates(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation);

    /// Before the steps of a batch (each time it runs) are recorded into `encoder`.
    fn begin_batch(
        &mut self,
        _gpu: &Gpu,
        _stepper: &Stepper,
        _encoder: &mut wgpu::CommandEncoder,
        _dt: f64,
        _steps: u32,
    ) {
    }

    /// Records the family's work before a step, after the interactions' (the commit of a
    /// plastic history).
    fn begin_step(&self, _gpu: &Gpu, _encoder: &mut wgpu::CommandEncoder) {}

    /// Whether [`Self::end_step`] records anything: the steps are then recorded one by
    /// one, each followed by it.
    fn ends_steps(&self) -> bool {
        false
    }

    /// Records the family's work after each step (a velocity smoothing).
    fn end_step(&self, _gpu: &Gpu, _encoder: &mut wgpu::CommandEncoder) {}

    /// After a batch was submitted: whether it must run again from its start (the family
    /// then put back its state at the start). Err: it cannot run again.
    fn again(&mut self, _shell: &mut Shell) -> Result<bool, GpuError> {
        Ok(false)
    }

    /// Records the passes the reduction of the current state needs first.
    fn before_reduction(&self, _gpu: &Gpu, _pass: &mut wgpu::ComputePass<'_>) {}

    /// The signal speed of the CFL step, given the reduction of the current state.
    fn signal_speed(&self, reduced: &Reduced) -> f64;

    /// The failures the passes flagged on the device since the start.
    fn flagged(&self, gpu: &Gpu) -> Result<(), BlowUp>;

    /// The check of a state read back (flat), when the reduction found a non-finite value.
    fn check_state(&self, flat: &[f32]) -> Result<(), BlowUp>;

    /// The snapshot of the current state.
    fn snapshot(&mut self, shell: &Shell) -> Snapshot<'_, D>;

    /// [`Engine::pseudo_time`].
    fn pseudo_time(&self) -> Option<PseudoTime> {
        None
    }

    /// [`Engine::neighbour_seconds`].
    fn neighbour_seconds(&mut self, _shell: &Shell) -> Option<f64> {
        None
    }

    /// What the family keeps on the host from step to step (an Eulerian kernel's steps
    /// since its search), for a checkpoint, before the shell's words; nothing by default.
    fn save(&self, _out: &mut Vec<f64>) {}

    /// Restores the shell from the words after what [`Self::save`] wrote, and the family
    /// from those words and the restored buffers.
    fn restore(&mut self, shell: &mut Shell, words: &[f64]) -> Result<(), String> {
        shell.restore(words)
    }
}

/// A family's system resident on the GPU (see the module's doc).
pub struct GpuEngine<D: GpuDim, F: GpuFamily<D>> {
    pub shell: Shell,
    /// Passes before every step (contact, timed loads and velocities) and the `ext` they
    /// write, which the rates read.
    pub interactions: GpuInteractions,
    pub family: F,
    dim: std::marker::PhantomData<D>,
}

impl<D: GpuDim, F: GpuFamily<D>> GpuEngine<D, F> {
    /// The engine of `family` in `shell`, with its `interactions`.
    pub fn assemble(shell: Shell, interactions: GpuInteractions, family: F) -> Self {
        Self {
            shell,
            interactions,
            family,
            dim: std::marker::PhantomData,
        }
    }

    pub fn gpu(&self) -> &Gpu {
        &self.shell.gpu
    }

    /// Records `steps` steps of size `dt` from the interactions' clock into one command
    /// encoder and submits them, again from their start while the family asks
    /// ([`GpuFamily::again`]).
    pub fn advance_steps(&mut self, dt: f64, steps: u32) -> Result<(), GpuError> {
        self.shell.reduction.invalidate();
        let start = self.interactions.time();
        loop {
            // The steps run again from their start time too.
            self.interactions.set_time(start);
            self.interactions.set_step(&self.shell.gpu, dt);
            self.record_batch(dt, steps);
            if !self.family.again(&mut self.shell)? {
                break;
            }
        }
        self.shell.work.advance(dt, steps);
        Ok(())
    }

    /// Records the steps of one batch and submits them.
    fn record_batch(&mut self, dt: f64, steps: u32) {
        let Self {
            shell: Shell { gpu, stepper, .. },
            interactions,
            family,
            ..
        } = self;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        family.begin_batch(gpu, stepper, &mut encoder, dt, steps);
        let family = &*family;
        let n = family.nodes();
        let (batches, per_batch) = match family.ends_steps() {
            true => (steps, 1),
            false => (1, steps),
        };
        for _ in 0..batches {
            stepper.record(
                gpu,
                &mut encoder,
                dt,
                per_batch,
                |encoder, e| family.record_rates(gpu, encoder, e),
                |encoder| {
                    interactions.record(gpu, encoder, n);
                    family.begin_step(gpu, encoder);
                },
            );
            family.end_step(gpu, &mut encoder);
        }
        gpu.queue.submit([encoder.finish()]);
    }

    /// The reduction of the current state (cached until the state changes).
    pub fn reduced(&mut self) -> Reduced {
        let Self { shell, family, .. } = self;
        shell.reduced(|gpu, pass| family.before_reduction(gpu, pass))
    }
}

impl<D: GpuDim, F: GpuFamily<D>> Engine<D> for GpuEngine<D, F> {
    fn backend(&self) -> String {
        self.shell.backend()
    }

    fn device(&mut self) -> Option<(&Gpu, Scale)> {
        let scale = self.family.scale(&self.shell.gpu);
        Some((&self.shell.gpu, scale))
    }

    fn reference(&self) -> &[D::V] {
        self.family.reference()
    }

    fn constrained(&self) -> &[(u32, u8)] {
        &self.family.boundary().constrained
    }

    /// Err only where the family's lists could not grow.
    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        self.interactions.set_time(t);
        self.advance_steps(dt, steps).map_err(|e| Failed {
            completed: 0,
            cause: BlowUp {
                particle: 0,
                position: [0.0; 3],
                quantity: format!("neighbour lists (GPU): {e}"),
                value: f64::NAN,
            },
        })
    }

    fn max_signal_speed(&mut self) -> f64 {
        let r = self.reduced();
        self.family.signal_speed(&r)
    }

    /// Trapezoidal over the intervals between calls (the driver calls it at every check).
    fn external_work(&mut self) -> f64 {
        let power = self.reduced().power;
        self.shell.external_work(power)
    }

    /// The work and, where the family books it, the viscous dissipation, trapezoidal over
    /// the intervals between calls.
    fn booked(&mut self) -> Booked {
        let r = self.reduced();
        let booked = self.shell.booked(r.power);
        match F::BOOKS_DISSIPATION {
            true => Booked {
                dissipated: Some(self.shell.work.update_dissipation(r.viscous_dissipation)),
                ..booked
            },
            false => booked,
        }
    }

    fn reactions(&mut self) -> Vec<Reaction> {
        self.shell.reactions(self.family.boundary())
    }

    fn pseudo_time(&mut self) -> Option<PseudoTime> {
        self.family.pseudo_time()
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        self.family.flagged(&self.shell.gpu)?;
        if self.reduced().non_finite {
            return self.family.check_state(&self.shell.read_state());
        }
        Ok(())
    }

    fn invariants(&mut self) -> Invariants {
        self.reduced().invariants
    }

    fn finish(&mut self) {
        self.shell.gpu.wait();
    }

    fn neighbour_seconds(&mut self) -> Option<f64> {
        self.family.neighbour_seconds(&self.shell)
    }

    /// What the family keeps on the host, then the work balance, the state buffer and
    /// the saved buffers (f32).
    fn save(&mut self) -> Vec<f64> {
        let mut out = Vec::new();
        self.family.save(&mut out);
        out.extend(self.shell.save());
        out
    }

    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        self.family.restore(&mut self.shell, words)
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        self.family.snapshot(&self.shell)
    }
}
