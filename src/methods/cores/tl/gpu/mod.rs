//! The total-Lagrangian core on the GPU: the passes of `shaders/tl/` (module `scheme`: the
//! pass files, the scheme a method runs on it, the buffers' layout), the
//! integrator program of [`crate::gpu::program`], and the set-up done once: the reference
//! configuration and neighbours uploaded from the host, the pair offsets and corrected
//! gradients derived on the device. The CPU core
//! ([`crate::methods::cores::tl::TlSph`]) is the reference it is checked against.
//!
//! The engine is the [`GpuEngine`] on the family [`TlDevice`]: a rate evaluation is the
//! stress and acceleration passes.

mod scheme;

pub use scheme::{
    ACCEL, DET_F, ForceReads, Frame, HostListing, HostLists, HostModel, Layout, Lists, Outputs,
    POTENTIAL, REDUCE, SHADERS, STRESS, TlScheme, kernel_passes, potential, scene_constants,
    viscosity,
};

use crate::boundary::Boundary;
use crate::case::Case;
use crate::core::correction::{self, CorrectionKind};
use crate::core::integrate::{Buf, Evaluation};
use crate::core::neighbour::Csr;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, GpuEngine, GpuFamily, Start};
use crate::gpu::context::{Gpu, GpuError, Pipeline};
use crate::gpu::layout::{GpuDim, flat_v};
use crate::gpu::memory::{Counts, DeviceMemory};
use crate::gpu::parts::Split;
use crate::gpu::profile::Scale;
use crate::gpu::program::Stepper;
use crate::gpu::reduction::{Reduced, Reduction};
use crate::gpu::reference::DeviceReference;
use crate::gpu::shaders::{self, CORRECTION, PAIR_OFFSETS, Source};
use crate::gpu::shell::Shell;
use crate::gpu::{SetupError, check_f32_particles, check_f32_range, check_f32_run};
use crate::interaction::gpu::GpuInteractions;
use crate::methods::cores::shared::BySource;
use crate::methods::cores::tl::hourglass::hourglass_stiffness;
use crate::methods::cores::tl::{TlState, check_state, snapshot};
use crate::reference::Reference;
use scheme::EXTRAS;

/// The stress and acceleration passes of one rate evaluation, bound to a source state: a
/// bind group a part of the lists.
struct Rates {
    stress: Vec<wgpu::BindGroup>,
    accel: Vec<wgpu::BindGroup>,
}

/// The TLSPH system resident on the GPU.
pub type GpuTlsph<D> = GpuEngine<D, TlDevice<D>>;

/// The total-Lagrangian family on the device: its reference configuration, buffers and
/// passes. The balance's terms the engine does not book besides the work and the
/// dissipation: the hourglass control's work; contact's, which `ext` adds to the loads'
/// power.
pub struct TlDevice<D: GpuDim> {
    /// The host's f64 reference configuration, which the device's was uploaded from.
    reference: Reference<D>,
    /// The weight of each particle's ψ in the strain energy (`TlScheme::unit_weights`).
    energy_weight: Vec<f64>,
    /// The factor on c_p in the CFL step's wave speed (`TlScheme::unit_weights`).
    wave_speed_scale: f64,
    /// What the kinematics' H measures (`TlScheme::frame`).
    frame: Frame<D>,
    /// The quantity of each status slot (`TlScheme::checks`).
    checks: &'static [&'static str],
    /// The model on the host of a scheme with host lists, whose f64 outputs the
    /// snapshots take from the state read back ([`Lists::Host`]).
    host: Option<Box<dyn HostModel<D>>>,
    layout: Layout,
    /// Neighbour pairs of the reference lists.
    pairs: u64,
    /// The parts of the lists ([`crate::gpu::parts`]) and the per-pair data of each.
    split: Split,
    pair: Vec<wgpu::Buffer>,
    status: wgpu::Buffer,
    stress: Pipeline,
    accel: Pipeline,
    /// Rate evaluations of the states in `Y` and in `Stage`.
    rates: BySource<Rates>,
    /// The stress pass that stores all the kinematics (the rate evaluations' store what
    /// the force pass reads, [`TlScheme::reads`]), on `Y` writing into `Acc` (for the
    /// snapshots and the reduction: F at the current state without touching the
    /// integrator's rates), a part each.
    kinematics: Pipeline,
    kinematics_y: Vec<wgpu::BindGroup>,
}

/// The stress pass that stores every field of the kinematics, of source `every`: the
/// rate evaluations' `stress` pipeline (of source `source`) where that stores them all
/// already, named apart in the pass report; else its own.
fn kinematics_pipeline(
    gpu: &Gpu,
    stress: &Pipeline,
    source: &str,
    every: &str,
) -> Result<Pipeline, GpuError> {
    if every == source {
        let mut same = stress.clone();
        same.pass = "tl kinematics (stress)".into();
        Ok(same)
    } else {
        gpu.pipeline("tl kinematics", every, "stress")
    }
}

/// Value of `status[0]` when no particle failed.
const STATUS_OK: u32 = u32::MAX;

impl<D: GpuDim> GpuTlsph<D> {
    /// Uploads the case's reference configuration and initial state, and derives the
    /// reference pair offsets and corrected gradients on the device (the RKPM and CGCK
    /// corrections on the host, in f64), for the method's `scheme` (`tlsph::gpu::scheme`
    /// and the other families' of the same name).
    pub fn new(case: &Case, scheme: TlScheme<D>, gpu: Gpu) -> Result<Self, SetupError> {
        let disc = Reference::<D>::build(case)?;
        check_f32_run(case, &disc.boundary)?;
        check_f32_particles::<D>(case, &disc.x0, &disc.u0, &disc.v0, &disc.body)?;
        let n = disc.len();
        let host = match &scheme.lists {
            Lists::Kernel => None,
            Lists::Host(build) => Some(build(case, &disc)?),
        };
        let csr = host
            .as_ref()
            .map_or_else(|| disc.neighbours(), |d| d.csr.clone());
        let layout = |pairs| {
            let (constrained, rate) = (
                disc.boundary.constrained.len(),
                disc.material.model.is_rate_based(),
            );
            Layout::new(n, constrained, D::N, rate, pairs, &scheme)
        };
        // The per-pair data of one pair, then of the most pairs of a part.
        let pair_bytes = layout(1).pair.bytes();
        let split = Split::fitting(&gpu, &csr, pair_bytes)?;
        let layout = layout(split.capacity());
        let constants = scene_constants(case, &layout, &scheme, false);
        check_f32_range(case, &constants)?;
        gpu.check_size("kinematics buffer", layout.kin.bytes())?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);

        let device = DeviceReference::upload::<D>(
            &gpu,
            &disc.x0,
            &disc.vol,
            &disc.boundary,
            (&csr, &split),
            EXTRAS,
        );
        let set_up = SetUp {
            case,
            gpu: &gpu,
            scheme: &scheme,
            disc: &disc,
            csr: &csr,
            split: &split,
            layout: &layout,
            compose: &compose,
        };
        let (pair, status) = set_up.pair_data(&device, host.as_ref())?;

        let mut y0 = layout.state.zeroed();
        layout.state.write_v::<D>(&mut y0, "U", &disc.u0);
        layout.state.write_v::<D>(&mut y0, "V", &disc.v0);
        let start = Start {
            gpu: &gpu,
            compose: &compose,
            device: &device,
        };
        let (stepper, interactions) =
            start.particles(case, &disc, &layout.state, &y0, || csr.clone())?;
        let kin = gpu.zeroed("kinematics", layout.kin.bytes());

        let stress_source = compose(&scheme.stress);
        let stress = gpu.pipeline("tl stress", &stress_source, "stress")?;
        let every = scene_constants(case, &layout, &scheme, true);
        let stress_every = shaders::compose::<D>(&scheme.stress, &every);
        let kinematics = kinematics_pipeline(&gpu, &stress, &stress_source, &stress_every)?;
        let accel = gpu.pipeline("tl accel", &compose(&scheme.accel), "accel")?;
        let table = |k: usize, y, d| -> [(&str, &wgpu::Buffer); 10] {
            let [offsets, ids, part] = device.lists[k].table();
            [
                offsets,
                ids,
                part,
                ("pair", &pair[k]),
                ("reference", &device.reference),
                ("kin", &kin),
                ("status", &status),
                ("ext", interactions.ext()),
                ("y", y),
                ("d", d),
            ]
        };
        // A bind group of `pipeline` a part, on the state y and the rates d.
        let by_part = |pipeline: &Pipeline, y, d| -> Result<Vec<wgpu::BindGroup>, GpuError> {
            (0..pair.len())
                .map(|k| gpu.bind(pipeline, &table(k, y, d)))
                .collect()
        };
        let rates = BySource::bind(&stepper, |y, d| -> Result<Rates, GpuError> {
            Ok(Rates {
                stress: by_part(&stress, y, d)?,
                accel: by_part(&accel, y, d)?,
            })
        })?;
        let (y, rates_d) = (stepper.buffer(Buf::Y), stepper.buffer(Buf::Rates));
        let tables = (0..pair.len()).map(|k| table(k, y, rates_d).to_vec());
        let reduce = compose(&scheme.reduce);
        let reduction = Reduction::by_part(&gpu, &reduce, &split, tables.collect())?;
        let kinematics_y = by_part(&kinematics, y, stepper.buffer(Buf::Acc))?;
        let (energy_weight, wave_speed_scale) = match scheme.unit_weights {
            Some(scale) => (vec![1.0; n], scale(&disc.vol)),
            None => (disc.vol.clone(), 1.0),
        };
        let unbooked = unbooked(case, &scheme, host.as_ref());
        let shell = Shell::new(gpu, stepper, reduction, kin, &layout.kin, unbooked);
        let family = TlDevice {
            pairs: csr.pair_count() as u64,
            reference: disc,
            energy_weight,
            wave_speed_scale,
            frame: scheme.frame,
            checks: scheme.checks,
            host: host.map(|h| h.model),
            layout,
            split,
            pair,
            status,
            stress,
            accel,
            rates,
            kinematics,
            kinematics_y,
        };
        Ok(Self::assemble(shell, interactions, family))
    }
}

impl<D: GpuDim> GpuTlsph<D> {
    /// The buffers [`Self::new`] makes for `case` under `scheme` on `counts`, from the same
    /// layout (the constrained particles' reaction slots, a surface's few words each, left
    /// out).
    pub fn memory(case: &Case, scheme: &TlScheme<D>, counts: &Counts) -> DeviceMemory {
        DeviceMemory::of(counts, |m| {
            let (n, pairs) = (counts.n(), counts.pair_count());
            let rate = case.material.model.is_rate_based();
            let layout = Layout::new(n, 0, D::N, rate, pairs, scheme);
            DeviceReference::memory(m, &layout.reference, n, D::N, n, pairs);
            m.fields("per-pair data", &layout.pair);
            m.words("status", scheme.checks.len().max(1) as f64);
            Stepper::memory(m, case.method.integrator, layout.state.len());
            m.fields("kinematics", &layout.kin);
            Reduction::memory(m, n);
            GpuInteractions::memory(m, case, n, D::N);
        })
    }
}

/// The balance's terms the engine does not book besides the work and the dissipation,
/// zero where the case has none: the hourglass control's work (the scheme's or its host
/// lists'); contact's, which `ext` adds to the loads' power.
fn unbooked<D: GpuDim>(case: &Case, scheme: &TlScheme<D>, host: Option<&HostLists<D>>) -> Booked {
    let host_hourglass = host.is_some_and(|h| h.hourglass);
    Booked {
        hourglass_work: (scheme.hourglass.is_none() && !host_hourglass).then_some(0.0),
        contact_energy: case.contact.is_none().then_some(0.0),
        ..Booked::default()
    }
}

/// What the set-up of the per-pair data reads: the case, its scheme, its reference
/// configuration and lists, the layout and the passes' composer.
struct SetUp<'a, D: GpuDim> {
    case: &'a Case,
    gpu: &'a Gpu,
    scheme: &'a TlScheme<D>,
    disc: &'a Reference<D>,
    csr: &'a Csr,
    split: &'a Split,
    layout: &'a Layout,
    compose: &'a dyn Fn(&Source) -> String,
}

impl<D: GpuDim> SetUp<'_, D> {
    /// The per-pair data of each part and the status buffer: X_j − X_i, the corrected
    /// gradients (on the device, or the host's RKPM and CGCK or host lists'), the
    /// hourglass stiffnesses and the reverse gradients of the schemes that read them.
    fn pair_data(
        &self,
        device: &DeviceReference,
        host: Option<&HostLists<D>>,
    ) -> Result<(Vec<wgpu::Buffer>, wgpu::Buffer), SetupError> {
        let Self {
            case,
            gpu,
            scheme,
            disc,
            csr,
            split,
            layout,
            compose,
        } = self;
        let pair: Vec<wgpu::Buffer> = (split.parts.iter())
            .map(|_| gpu.zeroed("per-pair data", layout.pair.bytes()))
            .collect();
        let status = gpu.storage("status", &vec![STATUS_OK; scheme.checks.len().max(1)]);
        let table = |k: usize| -> Vec<(&str, &wgpu::Buffer)> {
            let [offsets, ids, part] = device.lists[k].table();
            vec![
                offsets,
                ids,
                part,
                ("reference", &device.reference),
                ("pair", &pair[k]),
                ("status", &status),
            ]
        };
        // X_j − X_i, then (but for the host's RKPM and CGCK) the corrected gradients.
        let offsets_pass = (compose(&PAIR_OFFSETS), "pair_offsets");
        let correct_pass = (compose(&CORRECTION), "correct");
        let host_solved = host.is_some()
            || matches!(
                case.method.correction,
                CorrectionKind::Rkpm | CorrectionKind::Cgck
            );
        let passes = if host_solved {
            vec![offsets_pass]
        } else {
            vec![offsets_pass, correct_pass]
        };
        run_once(gpu, &passes, split, &table)?;
        // Writes a per-pair field of every pair, in CSR order, into each part's buffer.
        let write_pair = |field: &str, values: &[f32]| {
            let width = layout.pair.field(field).width;
            let at = (layout.pair.offset(field) * 4) as u64;
            for (part, buffer) in split.parts.iter().zip(&pair) {
                let own = &values[part.start * width..(part.start + part.pairs) * width];
                gpu.queue
                    .write_buffer(buffer, at, bytemuck::cast_slice(own));
            }
        };
        if let Some(h) = host {
            write_pair("G", &flat_v::<D>(h.g.clone()));
            write_pair("HGK", &h.hgk);
            write_pair("HGKR", &h.hgk_rev);
        } else if host_solved {
            let g = correction::gradients::<D>(
                case.method.correction,
                &disc.x0,
                &disc.vol,
                csr,
                &disc.kernel,
            )
            .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
            write_pair("G", &flat_v::<D>(g));
        } else if let Some((i, _)) = read_status(gpu, &status) {
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
        if let Some(alpha) = scheme.hourglass {
            let kappa = hourglass_stiffness::<D>(case, alpha, &disc.x0, &disc.vol, csr);
            let kappa: Vec<f32> = kappa.into_iter().map(|k| k as f32).collect();
            write_pair("HGK", &kappa);
        }
        if scheme.reverse {
            // ∇0W̃_ji of every pair (i, j): the gradient of the pair (j, i), copied.
            let rev = crate::methods::cores::shared::reverse_pairs(case, csr)?;
            let g = pair_field(gpu, layout, split, &pair, "G");
            let width = layout.pair.field("G").width;
            let reverse: Vec<f32> = (rev.iter())
                .flat_map(|&q| {
                    g[q as usize * width..(q as usize + 1) * width]
                        .iter()
                        .copied()
                })
                .collect();
            write_pair("GREV", &reverse);
        }
        Ok((pair, status))
    }
}

/// The per-pair field `name` of every pair in CSR order, read back from each part's
/// buffer of `pair` (flat: the field's width a pair).
fn pair_field(
    gpu: &Gpu,
    layout: &Layout,
    split: &Split,
    pair: &[wgpu::Buffer],
    name: &str,
) -> Vec<f32> {
    let field = layout.pair.field(name);
    let at = (field.offset * 4) as u64;
    (split.parts.iter().zip(pair))
        .flat_map(|(part, buffer)| {
            gpu.read_range::<f32>(buffer, at, (part.pairs * field.width * 4) as u64)
        })
        .collect()
}

/// Compiles the entry points `(source, entry)`, binds them a part each from `table(k)`
/// and runs them once, in order, over each part's particles (set-up passes), in one
/// compute pass.
fn run_once<'a>(
    gpu: &Gpu,
    passes: &[(String, &str)],
    split: &Split,
    table: &dyn Fn(usize) -> Vec<(&'a str, &'a wgpu::Buffer)>,
) -> Result<(), GpuError> {
    let mut bound = Vec::new();
    for (source, entry) in passes {
        let pipeline = gpu.pipeline(entry, source, entry)?;
        let binds = (0..split.parts.len())
            .map(|k| gpu.bind(&pipeline, &table(k)))
            .collect::<Result<Vec<_>, _>>()?;
        bound.push((pipeline, binds));
    }
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        for (pipeline, binds) in &bound {
            split.dispatch(gpu, &mut pass, pipeline, binds);
        }
    }
    gpu.queue.submit([encoder.finish()]);
    Ok(())
}

/// The first failed particle recorded in a status buffer, if any, and its slot: the
/// lowest particle of any slot, the later slot on a tie.
fn read_status(gpu: &Gpu, status: &wgpu::Buffer) -> Option<(usize, usize)> {
    let s: Vec<u32> = gpu.read(status);
    let (slot, &i) = s.iter().enumerate().rev().min_by_key(|&(_, &i)| i)?;
    (i != STATUS_OK).then_some((i as usize, slot))
}

impl<D: GpuDim> TlDevice<D> {
    /// Records one rate evaluation: the stress and acceleration passes on `rates`.
    fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, rates: &Rates) {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        self.split
            .dispatch(gpu, &mut pass, &self.stress, &rates.stress);
        self.split
            .dispatch(gpu, &mut pass, &self.accel, &rates.accel);
    }

    /// Decodes a flat state (`rho0` = ρ0: the density is stored as ρ − ρ0) or rate
    /// buffer (`rho0` = 0).
    fn decode(&self, flat: &[f32], rho0: f64) -> TlState<D> {
        let (u, v, rho, s) = self.layout.state.read_solid::<D>(flat, rho0);
        TlState { u, v, rho, s }
    }

    /// F of a kinematics buffer read back (the GPU keeps H = F − I; I is added in f64).
    fn deformation_gradient(&self, kin: &[f32]) -> Vec<D::T> {
        self.layout.kin.read_t::<D>(kin, "F", D::identity())
    }
}

impl<D: GpuDim> GpuTlsph<D> {
    pub fn layout(&self) -> &Layout {
        &self.family.layout
    }

    /// The host's reference configuration of the scene.
    pub fn reference(&self) -> &Reference<D> {
        &self.family.reference
    }

    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> TlState<D> {
        let rho0 = self.family.reference.material.rho0;
        self.family.decode(&self.shell.read_state(), rho0)
    }

    /// Replaces the state (e.g. to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &TlState<D>) {
        let (l, rho0) = (
            &self.family.layout.state,
            self.family.reference.material.rho0,
        );
        let mut flat = l.zeroed();
        l.write_solid::<D>(&mut flat, (&y.u, &y.v), (&y.rho, rho0), &y.s);
        self.shell.set_state(&flat);
    }

    /// Rates of a given state: (dy/dt, F, P) per particle, read back.
    pub fn rates(&mut self, y: &TlState<D>) -> (TlState<D>, Vec<D::T>, Vec<D::T>) {
        self.set_state(y);
        let gpu = self.gpu();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        self.family
            .record(gpu, &mut encoder, self.family.rates.on_y());
        {
            // F of the state: the kinematics the rate evaluation did not store.
            let mut pass = encoder.begin_compute_pass(&Default::default());
            self.family.before_reduction(gpu, &mut pass);
        }
        gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = gpu.read(self.shell.stepper.buffer(Buf::Rates));
        let (f, p) = self.kinematics();
        (self.family.decode(&d, 0.0), f, p)
    }

    /// The corrected reference gradients, in CSR order.
    pub fn gradients(&self) -> Vec<D::V> {
        let f = &self.family;
        let g = pair_field(self.gpu(), &f.layout, &f.split, &f.pair, "G");
        g.chunks_exact(D::N).map(D::read_v).collect()
    }

    /// The parts the neighbour lists are split into.
    pub fn split(&self) -> &Split {
        &self.family.split
    }

    /// F and P of the last kinematics pass, which stores them all ([`Self::rates`] runs it
    /// after the rate evaluation; the GPU keeps H = F − I; I is added in f64); the
    /// corotated F̂ and P̂ of a [`Frame::Corotated`] scheme.
    pub fn kinematics(&self) -> (Vec<D::T>, Vec<D::T>) {
        let kin: Vec<f32> = self.gpu().read(&self.shell.kin);
        let p = self.family.layout.kin.read_t::<D>(&kin, "P", D::zero_t());
        (self.family.deformation_gradient(&kin), p)
    }

    /// A per-particle tensor of the scheme's own (`TlScheme::kin_tensors`) of the last
    /// rate evaluation: corotated TLSPH's rotations R.
    pub fn kin_tensor(&self, name: &str) -> Vec<D::T> {
        let kin: Vec<f32> = self.gpu().read(&self.shell.kin);
        self.family.layout.kin.read_t::<D>(&kin, name, D::zero_t())
    }

    /// The first particle whose stress pass failed (det F ≤ 0 or NaN, or the scheme's
    /// other checks) in any evaluation so far.
    pub fn failed_particle(&self) -> Option<usize> {
        read_status(self.gpu(), &self.family.status).map(|(i, _)| i)
    }
}

impl<D: GpuDim> GpuFamily<D> for TlDevice<D> {
    /// The viscous dissipation of the artificial viscosity.
    const BOOKS_DISSIPATION: bool = true;

    fn reference(&self) -> &[D::V] {
        &self.reference.x0
    }

    fn boundary(&self) -> &Boundary<D> {
        &self.reference.boundary
    }

    fn scale(&self, _gpu: &Gpu) -> Scale {
        Scale {
            pairs: self.pairs,
            indirect: None,
        }
    }

    fn record_rates(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation) {
        self.record(gpu, encoder, self.rates.of(e));
    }

    /// The stress pass on the current state (F into the kinematics).
    fn before_reduction(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>) {
        self.split
            .dispatch(gpu, pass, &self.kinematics, &self.kinematics_y);
    }

    fn signal_speed(&self, reduced: &Reduced) -> f64 {
        self.wave_speed_scale * self.reference.material.p_wave_speed() + reduced.max_speed
    }

    fn flagged(&self, gpu: &Gpu) -> Result<(), BlowUp> {
        match read_status(gpu, &self.status) {
            Some((i, slot)) => Err(BlowUp {
                particle: i,
                position: D::to3(self.reference.x0[i]),
                quantity: self.checks[slot].into(),
                value: 0.0,
            }),
            None => Ok(()),
        }
    }

    fn check_state(&self, flat: &[f32]) -> Result<(), BlowUp> {
        let y = self.decode(flat, self.reference.material.rho0);
        check_state(&self.reference.x0, &y)
    }

    fn snapshot(&mut self, shell: &Shell) -> Snapshot<'_, D> {
        let gpu = &shell.gpu;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            self.before_reduction(gpu, &mut pass);
        }
        gpu.queue.submit([encoder.finish()]);
        let y = self.decode(&shell.read_state(), self.reference.material.rho0);
        let r = &self.reference;
        if let Some(model) = &self.host {
            return model.snapshot(y, r);
        }
        let kin: Vec<f32> = gpu.read(&shell.kin);
        let f = self.deformation_gradient(&kin);
        if let Frame::Corotated(outputs) = &self.frame {
            let rot = self.layout.kin.read_t::<D>(&kin, "R", D::zero_t());
            let fields = outputs(&r.material, &r.vol, &rot, &f);
            return fields.snapshot(&r.x0, &r.mass, &r.body, y);
        }
        snapshot(
            &r.material,
            (&r.x0, &r.mass, &r.body),
            &self.energy_weight,
            y,
            f,
            None,
        )
    }
}
