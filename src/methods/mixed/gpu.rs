//! Mixed {p, F, H, J} SPH (seed 003: Upwind-SPH, JST-SPH and SUPG-SPH) on the GPU: the
//! passes of
//! `shaders/mixed/` and the integrator program of [`crate::gpu::program`]. The set-up is
//! the CPU reference's own (`MixedSph::new`, f64): the reference configuration and
//! neighbours ([`crate::gpu::reference`]), corrected gradients, the reverse pairs,
//! least-squares and Laplacian weights, the ghost table and SUPG-SPH's stress points are
//! computed once on the host and uploaded in f32. The CPU method is kept for snapshots (σ and the
//! strain energy of a read-back state, in f64).
//!
//! One rate evaluation, all on the device and recorded in one compute pass:
//! ghost motion → [bond-based F^c] → kinematics (P, ∇0v, Ḟ, Ḣ, J̇) → ghost kinematics →
//! [slopes or Laplacians → their ghosts] → forces (T, D(p), D(J)) → [SUPG nodes →
//! stress points → their gather to D(p) and the rates of F, H, J] → [projection sums →
//! solve] → rates of v and u with the boundary conditions. The engine is the
//! [`GpuEngine`] on the family [`MixedDevice`].

use super::compressibility::UNCONVERGED;
use super::gpu_corrector::{CORRECTOR, DeviceCorrector};
use super::system::{Fluxes, MixedSph, MixedState};
use super::{CflWaveSpeed, DeformationGradient, MixedOptions, MixedScheme, Momentum, Stabiliser};
use crate::boundary::Boundary;
use crate::case::Case;
use crate::core::integrate::{Buf, Evaluation, IntegratorKind, PseudoTime, evaluations};
use crate::core::tensor::Dim;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, GpuEngine, GpuFamily, Method, Start};
use crate::gpu::context::{Gpu, GpuError, Pipeline, WORKGROUP};
use crate::gpu::layout::{Fields, GpuDim};
use crate::gpu::memory::{Counts, DeviceMemory};
use crate::gpu::parts::Split;
use crate::gpu::plastic;
use crate::gpu::profile::Scale;
use crate::gpu::program::{StateLayout, Stepper};
use crate::gpu::reduction::{self, Reduced, Reduction};
use crate::gpu::reference::{self, DeviceReference, Extras};
use crate::gpu::shaders::{
    self, BOUNDARY, CONTACT, Constants, EIGEN, INTEGRATE, LOADS, MECHANICS, PART, PLASTIC_STORE,
    PLASTICITY, PRESCRIBED, REFERENCE, Source, Wgsl, source, wgsl,
};
use crate::gpu::shell::Shell;
use crate::gpu::{SetupError, check_f32_particles, check_f32_range, check_f32_run};
use crate::interaction::gpu::GpuInteractions;
use crate::physics::material::MaterialModel;
use crate::reference::build_method;
use encase::ShaderType;

mod evaluator;
mod layout;
mod sources;
mod supg;

use evaluator::{Bound, Evaluator, Passes, StagePoints};
use layout::{EXTRAS, pair_data};
pub use layout::{MixedLayout, Sizes, scene};
pub use sources::{
    BOND, FORCES, GHOSTS, KINEMATICS, MOMENTUM, PLASTIC, REDUCE, SHADERS, SLOPES, SUPG,
};
pub(super) use sources::{IMAGES, MIXED, MOTION};
use supg::{SupgBuffers, SupgStep};

/// The length of the slopes (upwind with reconstruction) or Laplacians (JST) of the
/// extended particles, in floats; zero without either.
fn second_len<D: GpuDim>(layout: &MixedLayout) -> usize {
    let (n, ng) = (layout.n, layout.ghosts);
    if layout.pair.has("ELL") {
        (n + ng) * D::N
    } else if layout.pair.has("LS") {
        (n + ng) * (D::N + 1) * D::N * D::N
    } else {
        0
    }
}

/// The ghost table: the source and the image (r, σ) of every ghost.
fn ghost_table<D: GpuDim>(gpu: &Gpu, cpu: &MixedSph<D>) -> (wgpu::Buffer, wgpu::Buffer) {
    let table = cpu.ghosts().table();
    let ghost_src: Vec<u32> = table.iter().map(|&(s, _)| s).collect();
    let ghost_img: Vec<f32> = table
        .iter()
        .flat_map(|(_, m)| {
            (0..D::N)
                .map(|l| m.axis_sign(l) as f32)
                .chain([m.sign() as f32])
        })
        .collect();
    (
        gpu.storage("ghost sources", &ghost_src),
        gpu.storage("ghost images", &ghost_img),
    )
}

/// The buffers the passes write besides the state and its rates.
struct Scratch {
    kin: wgpu::Buffer,
    force: wgpu::Buffer,
    status: wgpu::Buffer,
    /// The projection's partial sums, per workgroup.
    partials: wgpu::Buffer,
    /// The slopes or Laplacians of the extended particles (4 bytes without either).
    second: wgpu::Buffer,
    /// The plastic history (plasticity.wgsl; 13 floats of a dummy for elastic models).
    hist: wgpu::Buffer,
}

impl Scratch {
    /// The buffers [`Self::new`] makes.
    fn memory(m: &mut DeviceMemory, layout: &MixedLayout, plastic: bool) {
        let n = layout.n;
        m.fields("kinematics", &layout.kin);
        m.fields("forces", &layout.force);
        m.words("status", STATUS_OK.len() as f64);
        let groups = (n as u64).div_ceil(u64::from(WORKGROUP)).max(1);
        m.words("balance partials", (groups * 16) as f64);
        m.words("plastic history", plastic::words(plastic, n) as f64);
    }

    fn new<D: GpuDim>(gpu: &Gpu, layout: &MixedLayout, plastic: bool) -> Result<Self, GpuError> {
        let n = layout.n;
        let (gx, gy) = gpu.groups(n as u32);
        gpu.check_size("kinematics buffer", layout.kin.bytes())?;
        let second = second_len::<D>(layout) as u64 * 4;
        gpu.check_size("slope buffer", second)?;
        Ok(Self {
            kin: gpu.zeroed("kinematics", layout.kin.bytes()),
            force: gpu.zeroed("forces", layout.force.bytes()),
            status: gpu.storage("status", &STATUS_OK),
            partials: gpu.zeroed("balance partials", u64::from(gx * gy) * 16 * 4),
            hist: plastic::upload(gpu, "plastic history", plastic, n),
            second: gpu.zeroed("slopes or Laplacians", second),
        })
    }
}

/// Values of `status` when no particle failed: det F, J, and SUPG-SPH's det F^st or J^st.
const STATUS_OK: [u32; 3] = [u32::MAX; 3];

/// The mixed system resident on the GPU.
pub type GpuMixed<D> = GpuEngine<D, MixedDevice<D>>;

/// The mixed family on the device: the CPU set-up, the buffers and the passes. The
/// shell's checkpoints hold the plastic history too. The balance's terms the engine does
/// not book besides the work of supports and loads: the stabilisation's dissipation; the
/// plastic work, committed on the device; contact's, which `ext` adds to the loads' power.
pub struct MixedDevice<D: GpuDim> {
    cpu: MixedSph<D>,
    layout: MixedLayout,
    evaluator: Evaluator,
    /// The `Stage` uniform of the mid-step points (Δt/2 rewritten when Δt changes).
    mid_points: wgpu::Buffer,
    dt: f64,
    force: wgpu::Buffer,
    status: wgpu::Buffer,
    /// The plastic history (plasticity.wgsl; 13 floats of a dummy for elastic models).
    hist: wgpu::Buffer,
    /// The commit of the plastic history before every step (mixed_plastic.wgsl).
    commit: Option<(Pipeline, wgpu::BindGroup)>,
    /// SUPG-SPH's stress points and terms.
    supg: Option<SupgBuffers>,
}

impl<D: GpuDim> GpuMixed<D> {
    /// The buffers [`Self::new`] makes for `case` under `spec` on `counts`, from the same
    /// layout ([`Sizes::of_case`]).
    pub fn memory(case: &Case, spec: &dyn MixedScheme, counts: &Counts) -> DeviceMemory {
        DeviceMemory::of(counts, |m| {
            let sizes = Sizes::of_case(case, spec, counts);
            let layout = MixedLayout::new(&sizes, D::N);
            let (n, ghosts) = (sizes.n, sizes.ghosts);
            DeviceReference::memory(m, &layout.reference, n, D::N, n, sizes.pairs);
            m.fields("per-pair data", &layout.pair);
            m.words("slopes or Laplacians", second_len::<D>(&layout) as f64);
            m.words("ghost sources", ghosts as f64);
            m.words("ghost images", (ghosts * (D::N + 1)) as f64);
            let plastic = case.material.model == MaterialModel::VonMisesPlastic;
            Scratch::memory(m, &layout, plastic);
            Stepper::memory(m, case.method.integrator, layout.state.len());
            for label in ["stage points", "mid-step points"] {
                m.add(label, StagePoints::bytes() as f64);
            }
            m.fields("corrector", &layout.corr);
            if sizes.ac {
                DeviceCorrector::memory(m, n, layout.state.bytes());
            }
            SupgBuffers::memory(m, &layout, &sizes);
            Reduction::memory(m, n);
            GpuInteractions::memory(m, case, n, D::N);
        })
    }

    /// Builds the CPU set-up of the case and uploads it with the initial state.
    pub fn new(
        case: &Case,
        spec: &(dyn MixedScheme + 'static),
        gpu: Gpu,
    ) -> Result<Self, SetupError> {
        let plastic = plastic_on_device(case, spec.options())?;
        let cpu: MixedSph<D> = build_method(case, spec)?;
        let split = split_lists(&gpu, &cpu)?;
        let (layout, constants) = scene(case, spec.options(), &cpu, split.capacity());
        check_f32(case, &cpu, &constants)?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);
        let n = layout.n;
        let (x0, vol) = cpu.extended_reference();
        let device = DeviceReference::upload::<D>(
            &gpu,
            &x0[..n],
            &vol[..n],
            cpu.boundary(),
            (cpu.neighbours(), &split),
            EXTRAS,
        );
        let pair: Vec<_> = (pair_data(&cpu, &layout.pair, &split))
            .map(|data| gpu.storage("per-pair data", &data))
            .collect();
        let (ghost_src, ghost_img) = ghost_table(&gpu, &cpu);
        let supg = SupgBuffers::upload(&gpu, &cpu, &layout)?;

        let scratch = Scratch::new::<D>(&gpu, &layout, plastic)?;
        let corr = gpu.zeroed("corrector", layout.corr.bytes());

        let start = Start {
            gpu: &gpu,
            compose: &compose,
            device: &device,
        };
        let (stepper, interactions) = start.stepper(
            case.method.integrator,
            StateLayout::of(&layout.state, "F"),
            &layout.encode(&cpu.initial_state()),
            cpu.interactions(),
            cpu.boundary(),
        )?;

        let passes = Passes::new(&gpu, &layout, &compose)?;

        let stage_points = StagePoints::uniform(&gpu, "stage points", 0);
        let mid_points = StagePoints::uniform(&gpu, "mid-step points", 1);
        let integrator = case.method.integrator;
        let mut evaluator = Evaluator::new(passes, &layout, &cpu, (integrator, split.clone()));
        let keys = evaluator.keys(integrator);
        let y_start = stepper.buffer(Buf::Y);
        // Every buffer of the passes by binding name, with the lists and per-pair data of
        // part k, the state `y` an evaluation reads and the balance points of its stage.
        let table = |k: usize, y, points| -> Vec<(&str, &wgpu::Buffer)> {
            let [offsets, ids, part] = device.lists[k].table();
            let supg = supg.iter().flat_map(SupgBuffers::table);
            [
                offsets,
                ids,
                part,
                ("reference", &device.reference),
                ("pair", &pair[k]),
                ("ghost_src", &ghost_src),
                ("ghost_img", &ghost_img),
                ("field", &scratch.kin),
                ("kin", &scratch.kin),
                ("second", &scratch.second),
                ("out", &scratch.second),
                ("force", &scratch.force),
                ("status", &scratch.status),
                ("hist", &scratch.hist),
                ("partials", &scratch.partials),
                ("corr", &corr),
                ("ext", interactions.ext()),
                ("y0", y_start),
                ("d", stepper.buffer(Buf::Rates)),
                ("stage", points),
                ("y", y),
            ]
            .into_iter()
            .chain(supg)
            .collect()
        };
        // The tables of every part.
        let tables = |y, points| -> Vec<Vec<(&str, &wgpu::Buffer)>> {
            (0..split.parts.len())
                .map(|k| table(k, y, points))
                .collect()
        };
        let commit = plastic
            .then(|| plastic_commit(&gpu, &compose(&PLASTIC), &table(0, y_start, &stage_points)))
            .transpose()?;
        let p = &evaluator.passes;
        let corrector = cpu
            .corrector()
            .map(|c| {
                let (source, sizes) = (compose(&CORRECTOR), (n, layout.state.bytes()));
                let t = tables(y_start, &stage_points);
                DeviceCorrector::new(&gpu, &source, c, sizes, &split, &t)
            })
            .transpose()?;
        let bind = |(src, mid): (Buf, bool)| -> Result<Bound, GpuError> {
            let points = if mid { &mid_points } else { &stage_points };
            let t = tables(stepper.buffer(src), points);
            let second = (second_len::<D>(&layout) > 0).then_some(&scratch.second);
            Bound::new(&gpu, p, &t, second, corrector.as_ref())
        };
        evaluator.bound = keys
            .into_iter()
            .map(|k| Ok((k, bind(k)?)))
            .collect::<Result<_, GpuError>>()?;
        evaluator.corrector = corrector;
        let reduce = compose(&REDUCE);
        let reduction = Reduction::by_part(&gpu, &reduce, &split, tables(y_start, &stage_points))?;
        let unbooked = unbooked(case, plastic);
        let shell = Shell::new(gpu, stepper, reduction, scratch.kin, &layout.kin, unbooked)
            .save_also("plastic history", &scratch.hist);
        let family = MixedDevice {
            cpu,
            layout,
            evaluator,
            mid_points,
            dt: f64::NAN,
            force: scratch.force,
            status: scratch.status,
            hist: scratch.hist,
            commit,
            supg,
        };
        Ok(Self::assemble(shell, interactions, family))
    }
}

/// The per-step commit of the plastic history (`source`), bound to the buffers `table`.
fn plastic_commit(
    gpu: &Gpu,
    source: &str,
    table: &[(&str, &wgpu::Buffer)],
) -> Result<(Pipeline, wgpu::BindGroup), GpuError> {
    let pipeline = gpu.pipeline("plastic commit", source, "commit")?;
    let bind = gpu.bind(&pipeline, table)?;
    Ok((pipeline, bind))
}

/// The neighbour lists of the scene set up in `cpu` in parts whose per-pair data fit the
/// binding limit of `gpu`.
fn split_lists<D: GpuDim>(gpu: &Gpu, cpu: &MixedSph<D>) -> Result<Split, GpuError> {
    let one = Sizes {
        pairs: 1,
        ..Sizes::of_system(cpu)
    };
    let pair_bytes = MixedLayout::new(&one, D::N).pair.bytes();
    Split::fitting(gpu, cpu.neighbours(), pair_bytes)
}

/// Refuses a scene whose constants, run or initial particles f32 does not carry.
fn check_f32<D: GpuDim>(
    case: &Case,
    cpu: &MixedSph<D>,
    constants: &Constants,
) -> Result<(), SetupError> {
    check_f32_range(case, constants)?;
    check_f32_run(case, cpu.boundary())?;
    let y0 = cpu.initial_state();
    check_f32_particles::<D>(case, cpu.reference(), &y0.u, &y0.v, cpu.body())?;
    Ok(())
}

/// Whether the plastic history is committed on the device; an error for the bond-based F
/// with plasticity, which the GPU does not run.
fn plastic_on_device(case: &Case, options: &MixedOptions) -> Result<bool, SetupError> {
    let plastic = case.material.model == MaterialModel::VonMisesPlastic;
    if plastic && options.deformation_gradient != DeformationGradient::Evolved {
        return Err(case
            .invalid(
                "method.deformation_gradient",
                "the GPU commits the plastic history from the evolved F; the bond-based F \
                 with `von-mises-plastic` runs with --backend cpu",
            )
            .into());
    }
    Ok(plastic)
}

/// The balance's terms besides the work of supports and loads, as the shell of
/// [`GpuMixed`] holds them.
fn unbooked(case: &Case, plastic: bool) -> Booked {
    Booked {
        dissipated: None,
        plastic_work: (!plastic).then_some(0.0),
        contact_energy: case.contact.is_none().then_some(0.0),
        ..Booked::default()
    }
}

impl<D: GpuDim> MixedDevice<D> {
    /// Writes Δt/2 into the uniform of the mid-step balance points, and Δt into
    /// SUPG-SPH's, when Δt changes.
    fn set_dt(&mut self, gpu: &Gpu, dt: f64) {
        if dt != self.dt {
            self.dt = dt;
            let points = StagePoints {
                half_dt: (0.5 * dt) as f32,
                mid: 1,
            };
            gpu.write_uniform(&self.mid_points, &points);
            if let Some(s) = &self.supg {
                gpu.write_uniform(&s.step, &SupgStep { dt: dt as f32 });
            }
        }
    }

    /// The first particles whose det F ≤ 0, whose J ≤ 0 (or NaN), and (SUPG-SPH) nearest
    /// a stress point whose det F^st or J^st ≤ 0, in any evaluation.
    fn failed_particles(&self, gpu: &Gpu) -> [Option<usize>; 3] {
        let s: Vec<u32> = gpu.read(&self.status);
        [0, 1, 2].map(|k| (s[k] != STATUS_OK[k]).then_some(s[k] as usize))
    }
}

impl<D: GpuDim> GpuMixed<D> {
    /// The CPU reference of the same scene (its set-up is the one uploaded).
    pub fn cpu(&self) -> &MixedSph<D> {
        &self.family.cpu
    }

    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> MixedState<D> {
        self.family.layout.decode(&self.shell.read_state(), true)
    }

    /// Replaces the state (e.g. to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &MixedState<D>) {
        let flat = self.family.layout.encode(y);
        self.shell.set_state(&flat);
    }

    /// Sets the step Δt the next [`Self::rates`] take: SUPG-SPH's τ_F Δt and τ_p Δt.
    pub fn set_step(&mut self, dt: f64) {
        self.family.set_dt(&self.shell.gpu, dt);
    }

    /// Rates of a given state (balanced about its own positions), read back. Under
    /// artificial compressibility the corrector takes the Δt of the last step, and
    /// SUPG-SPH the Δt of [`Self::set_step`] or of the last step.
    pub fn rates(&mut self, y: &MixedState<D>) -> MixedState<D> {
        self.set_state(y);
        self.evaluate(Evaluation {
            src: Buf::Y,
            index: 0,
        })
    }

    /// Rates at the second stage of a TVD-RK2 step of size `dt` from `start` (y^n), of the
    /// stage state y*, read back: with the projection they balance about
    /// x^n + Δt/2 (v^n + v*).
    pub fn second_stage_rates(
        &mut self,
        start: &MixedState<D>,
        stage: &MixedState<D>,
        dt: f64,
    ) -> MixedState<D> {
        assert_eq!(
            self.shell.stepper.kind(),
            IntegratorKind::TvdRk2,
            "the scene's integrator must be TVD-RK2"
        );
        self.set_state(start);
        let flat = self.family.layout.encode(stage);
        self.shell.gpu.queue.write_buffer(
            self.shell.stepper.buffer(Buf::Stage),
            0,
            bytemuck::cast_slice(&flat),
        );
        self.family.set_dt(&self.shell.gpu, dt);
        self.evaluate(Evaluation {
            src: Buf::Stage,
            index: 1,
        })
    }

    /// Records one evaluation alone and reads its rates back.
    fn evaluate(&mut self, e: Evaluation) -> MixedState<D> {
        let gpu = &self.shell.gpu;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        self.family.evaluator.record(gpu, &mut encoder, e);
        gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = gpu.read(self.shell.stepper.buffer(Buf::Rates));
        self.family.layout.decode(&d, false)
    }

    /// P of the real particles at the last rate evaluation.
    pub fn first_piola(&self) -> Vec<D::T> {
        let kin: Vec<f32> = self.shell.gpu.read(&self.shell.kin);
        let layout = &self.family.layout;
        let mut p = layout.kin.read_t::<D>(&kin, "P", D::zero_t());
        p.truncate(layout.n);
        p
    }

    /// T, D(p) and D(J) of the last rate evaluation, before the projection (D(J) is zero
    /// where the scene does not evolve J or is JST-SPH: nothing reads it there).
    pub fn fluxes(&self) -> Fluxes<D> {
        let f: Vec<f32> = self.shell.gpu.read(&self.family.force);
        let l = &self.family.layout.force;
        Fluxes {
            t: l.read_v::<D>(&f, "T"),
            d: l.read_v::<D>(&f, "D"),
            dj: l.read_s(&f, "J", 0.0),
        }
    }

    /// The first particles whose det F ≤ 0, whose J ≤ 0 (or NaN), and (SUPG-SPH) nearest
    /// a stress point whose det F^st or J^st ≤ 0, in any evaluation.
    pub fn failed_particles(&self) -> [Option<usize>; 3] {
        self.family.failed_particles(&self.shell.gpu)
    }

    /// The parts the neighbour lists are split into.
    pub fn split(&self) -> &Split {
        &self.family.evaluator.split
    }
}

impl<D: GpuDim> GpuFamily<D> for MixedDevice<D> {
    fn reference(&self) -> &[D::V] {
        self.cpu.reference()
    }

    fn boundary(&self) -> &Boundary<D> {
        self.cpu.boundary()
    }

    fn scale(&self, _gpu: &Gpu) -> Scale {
        Scale {
            pairs: self.cpu.neighbours().pair_count() as u64,
            indirect: self.evaluator.corrector.as_ref().map(|c| c.runs),
        }
    }

    fn record_rates(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation) {
        self.evaluator.record(gpu, encoder, e);
    }

    /// Δt/2 of the mid-step points; under artificial compressibility the corrector's
    /// pseudo steps for the batch, and the state and failure flags at its start saved.
    fn begin_batch(
        &mut self,
        gpu: &Gpu,
        stepper: &Stepper,
        encoder: &mut wgpu::CommandEncoder,
        dt: f64,
        steps: u32,
    ) {
        self.set_dt(gpu, dt);
        plastic::set_step(gpu, &self.hist, dt);
        if let (Some(c), Some(cpu)) = (&mut self.evaluator.corrector, self.cpu.corrector()) {
            c.record_batch(u64::from(steps) * evaluations(stepper.kind()).len() as u64);
            c.set_dt(gpu, dt, cpu);
            c.save(encoder, stepper.buffer(Buf::Y), &self.status);
        }
    }

    /// The commit of the plastic history and the corrector's start of a step.
    fn begin_step(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        if let Some((pipeline, bind)) = &self.commit {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            gpu.dispatch(&mut pass, pipeline, bind, self.layout.n as u32);
        }
        if let Some(c) = &self.evaluator.corrector {
            c.begin_step(encoder);
        }
    }

    /// Under artificial compressibility, when a stage ran out of the pseudo steps recorded
    /// for it ([`DeviceCorrector`]): the state and flags at the batch's start put back.
    fn again(&mut self, shell: &mut Shell) -> Result<bool, GpuError> {
        let Some(corrector) = self.evaluator.corrector.as_mut() else {
            return Ok(false);
        };
        if corrector.finish_batch(&shell.gpu) {
            return Ok(false);
        }
        corrector.restore_flags(&shell.gpu, &self.status);
        shell
            .stepper
            .restart_from(&shell.gpu, corrector.saved_state());
        Ok(true)
    }

    /// With the bond-based F the strain energy reads F^c − I of the state, recorded first.
    fn before_reduction(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>) {
        let evaluator = &self.evaluator;
        if evaluator.passes.bond.is_some() {
            evaluator.record_motion(gpu, pass, evaluator.bound((Buf::Y, false)));
        }
    }

    /// As the CPU's MixedSph::max_signal_speed (seed 002 eqs 31–32).
    fn signal_speed(&self, reduced: &Reduced) -> f64 {
        reduced.pair_wave_speed + reduced.max_speed
    }

    fn flagged(&self, gpu: &Gpu) -> Result<(), BlowUp> {
        let x0 = self.cpu.reference();
        if let Some(c) = &self.evaluator.corrector
            && let Some(u) = c.unconverged(gpu)
        {
            let quantity = format!("{UNCONVERGED}; f32 on the GPU");
            return Err(BlowUp::at::<D>(x0, u.particle, &quantity, u.residual));
        }
        for (failed, quantity) in self.failed_particles(gpu).into_iter().zip([
            "det F (f32, GPU)",
            "J (f32, GPU)",
            "det F^st at a stress point (f32, GPU)",
        ]) {
            if let Some(i) = failed {
                return Err(BlowUp::at::<D>(x0, i, quantity, 0.0));
            }
        }
        Ok(())
    }

    fn check_state(&self, flat: &[f32]) -> Result<(), BlowUp> {
        self.cpu.check_finite(&self.layout.decode(flat, true))
    }

    fn pseudo_time(&self) -> Option<PseudoTime> {
        self.evaluator.corrector.as_ref().map(|c| c.stats)
    }

    fn snapshot(&mut self, shell: &Shell) -> Snapshot<'_, D> {
        let y = self.layout.decode(&shell.read_state(), true);
        if let Some(history) = self.cpu.plastic_mut() {
            history.read_f32(&shell.gpu.read::<f32>(&self.hist));
        }
        self.cpu.snapshot(&y)
    }
}
