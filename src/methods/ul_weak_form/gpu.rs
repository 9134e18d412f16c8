//! The updated-Lagrangian weak form on the GPU: the passes of
//! `shaders/ul_weak_form/ul_weak_form.wgsl` on the stress points, candidate lists and
//! particles of the host's f64 system ([`UlGalerkin`] on [`StressPoints`]), whose state the
//! device's replaces for the outputs.
//!
//! A rate evaluation is a points pass (at each stress point its covariance ellipse among
//! its candidates at their current positions, h and the reproducing-kernel coefficients,
//! then L_q, ρ̇_q, Ṡ_q, σ_q, w_q and ẋ_q), a particles pass (each particle's own functions
//! and ρ̇_i) and a nodes pass (the force gathered over the stress points whose candidate
//! the particle is); after each step the particles' own functions at the step's end smooth
//! the velocities. The candidate lists are the host's, fixed at set-up as on the CPU (the
//! particles of a point's body within ±3Δx of it on the reference configuration): the
//! ellipses among them are chosen on the device at every evaluation, so nothing grows and
//! nothing is searched or read back inside a step. Each list is split into parts that fit
//! the device's binding limit ([`crate::gpu::parts`]).

use super::UlWeakFormSpec;
use super::points::StressPoints;
use crate::boundary::Boundary;
use crate::case::Case;
use crate::core::integrate::{Buf, Evaluation};
use crate::core::kernel::{Kernel, KernelKind};
use crate::core::neighbour::Csr;
use crate::core::neighbourhood::AXIS_SCALE;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, GpuEngine, GpuFamily, Method, Start};
use crate::gpu::context::{Gpu, GpuError, Pipeline};
use crate::gpu::layout::{Fields, GpuDim};
use crate::gpu::memory::{Counts, DeviceMemory};
use crate::gpu::parts::{PartLists, Split};
use crate::gpu::profile::Scale;
use crate::gpu::program::Stepper;
use crate::gpu::reduction::{self, Reduced, Reduction};
use crate::gpu::reference::{self, DeviceReference, Extras};
use crate::gpu::shaders::{
    self, BOUNDARY, CONTACT, Constants, EIGEN, INTEGRATE, KERNEL, LOADS, MECHANICS, OBJECTIVE,
    PART, PRESCRIBED, REFERENCE, RKPM, Source, source,
};
use crate::gpu::shell::Shell;
use crate::gpu::{SetupError, check_f32_particles, check_f32_range, check_f32_run};
use crate::interaction::gpu::GpuInteractions;
use crate::methods::cores::galerkin::gpu::{self as galerkin, FOLDED_REDUCE, RATE_POINT, SETTLE};
use crate::methods::cores::galerkin::updated::{MovingPoints, UlGalerkin, UlGalerkinState};
use crate::methods::cores::shared::BySource;
use crate::physics::material::Material;

/// The points, nodes, particles, smoothing and ellipse passes.
pub const RATES: Source = source!(
    "ul_weak_form/ul_weak_form.wgsl",
    [
        KERNEL, MECHANICS, REFERENCE, BOUNDARY, EIGEN, OBJECTIVE, RKPM, RATE_POINT, PART, SETTLE
    ],
    [
        ("y", true),
        ("pts", false),
        ("reference", false),
        ("ext", false),
        ("kin", true),
        ("d", true),
        ("smoothed", true)
    ]
);

/// The passes compiled with the weak form's constants ([`scene_constants`]).
pub const SHADERS: &[Source] = &[RATES, FOLDED_REDUCE, CONTACT, LOADS, PRESCRIBED, INTEGRATE];

/// The host's system.
type Host<D> = UlGalerkin<D, StressPoints<D>>;

/// The flat buffers of a weak-form scene of n particles and q stress points: the state [u
/// | v | ρ − ρ0 (particles) | u | ρ − ρ0 | S (stress points)], the kinematics [T = w σ |
/// C⁻¹ | h | C, ∂C | w0 ψ (stress points) | power (particles)], the stress points'
/// reference positions and weights, and the particles' reference fields.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub q: usize,
    pub dim: usize,
    pub state: Fields,
    pub kin: Fields,
    pub pts: Fields,
    pub reference: Fields,
}

impl Layout {
    /// n particles (`constrained` of them with prescribed components) and q stress points.
    pub fn new(n: usize, constrained: usize, q: usize, dim: usize) -> Self {
        Self {
            n,
            q,
            dim,
            state: Fields::new("", dim)
                .vectors("U", true, n)
                .vectors("V", true, n)
                .scalars("NRHO", true, n)
                .vectors("PU", true, q)
                .scalars("RHO", true, q)
                .tensors("S", true, q),
            kin: reduction::with_reactions(
                Fields::new("K", dim)
                    .tensors("T", true, q)
                    .tensors("CI", true, q)
                    .scalars("H", true, q)
                    .scalars("RK", true, (dim + 1) * (dim + 1) * q)
                    .scalars("E", true, q)
                    .scalars("POW", true, n),
                constrained,
            ),
            pts: Fields::new("Q", dim)
                .vectors("X", true, q)
                .scalars("W", true, q),
            reference: reference::fields(n, constrained, dim, Extras::default()),
        }
    }
}

/// The compiled-in constants of a weak-form scene: the cubic spline (its h is each point's
/// own; KERNEL_H = 1.5 Δx only scales it) and the ellipse's axis scale.
pub fn scene_constants(case: &Case, layout: &Layout) -> Constants {
    let u = |x: usize| x as u32;
    let spline = Kernel::new(KernelKind::CubicSpline, 1.5 * case.spacing, layout.dim);
    let constants = Constants::default()
        .u32("N", u(layout.n))
        .u32("Q", u(layout.q))
        .u32("BODIES", u(case.bodies.len()))
        .material(&Material::new(&case.material))
        .kernel(&spline)
        .f32("AXIS_SCALE", AXIS_SCALE)
        .u32("REST_OFF", u(layout.state.offset("NRHO")));
    [&layout.state, &layout.kin, &layout.pts, &layout.reference]
        .into_iter()
        .fold(constants, |c, fields| fields.constants(c))
}

/// `status` when nothing failed: [stress point degenerate, stress point ρ ≤ 0, particle
/// degenerate, particle ρ ≤ 0].
const STATUS_OK: [u32; 4] = [u32::MAX; 4];

/// A list on the device: its parts and their buffers.
struct Lists {
    split: Split,
    parts: Vec<PartLists>,
}

impl Lists {
    fn upload(gpu: &Gpu, csr: &Csr) -> Result<Self, GpuError> {
        let split = Split::fitting(gpu, csr, size_of::<u32>() as u64)?;
        let parts = PartLists::upload(gpu, csr, &split);
        Ok(Self { split, parts })
    }

    /// A bind group of `pipeline` per part, with the buffers of `table`.
    fn bind(
        &self,
        gpu: &Gpu,
        pipeline: &Pipeline,
        table: &[(&str, &wgpu::Buffer)],
    ) -> Result<Vec<wgpu::BindGroup>, GpuError> {
        (self.parts.iter())
            .map(|part| {
                let bindings: Vec<_> = table.iter().copied().chain(part.table()).collect();
                gpu.bind(pipeline, &bindings)
            })
            .collect()
    }
}

/// The bind groups of one rate evaluation on a source state, a part of a list each.
struct Bound {
    points: Vec<wgpu::BindGroup>,
    particles: Vec<wgpu::BindGroup>,
    nodes: Vec<wgpu::BindGroup>,
}

/// The pipelines of `shaders/ul_weak_form/ul_weak_form.wgsl`.
struct Passes {
    points: Pipeline,
    particles: Pipeline,
    nodes: Pipeline,
    smooth: Pipeline,
    settle: Pipeline,
}

/// The updated-Lagrangian weak form resident on the GPU.
pub type GpuUlWeakForm<D> = GpuEngine<D, WeakFormDevice<D>>;

/// The weak form's family on the device: the host's system, the buffers, the lists and the
/// passes. The balance's terms the engine does not book besides the work of supports and
/// loads: the velocity smoothing's dissipation; contact's, which `ext` adds to the loads'
/// power.
pub struct WeakFormDevice<D: GpuDim> {
    /// The host's f64 system the device's set-up was uploaded from; outputs are computed
    /// from the state read back.
    host: Host<D>,
    layout: Layout,
    /// The constants the passes are compiled with.
    constants: Constants,
    device: DeviceReference,
    /// [X_q | w0_q] of every stress point.
    pts: wgpu::Buffer,
    status: wgpu::Buffer,
    /// From every stress point to its candidates, from every particle to the stress points
    /// it is a candidate of, and from every particle to its own candidates.
    candidates: Lists,
    transposed: Lists,
    own: Lists,
    passes: Passes,
    rates: BySource<Bound>,
    /// The points pass on `Y` writing its rates into `Acc` (the kinematics of a reduction).
    points_y: Vec<wgpu::BindGroup>,
    /// The smoothing on `Y`, a bind group a part of the own lists, and the settle.
    smooth: Option<(Vec<wgpu::BindGroup>, wgpu::BindGroup)>,
}

impl<D: GpuDim> GpuUlWeakForm<D> {
    /// The buffers [`Self::new`] makes for `case` on `counts` (a stress point per cell;
    /// the constrained particles' reaction slots, a surface's few words each, left out).
    pub fn memory(case: &Case, counts: &Counts) -> DeviceMemory {
        DeviceMemory::of(counts, |m| {
            let n = counts.n();
            let q = Counts::whole(counts.cells);
            let layout = Layout::new(n, 0, q, D::N);
            DeviceReference::memory(m, &layout.reference, n, D::N, 0, 0);
            m.fields("points", &layout.pts);
            m.words("status", STATUS_OK.len() as f64);
            m.fields("kinematics", &layout.kin);
            // The candidate lists, their transpose and the particles' own.
            m.words("neighbour offsets", (q + 1 + 2 * (n + 1)) as f64);
            m.words(
                "neighbour ids",
                2.0 * counts.centre_box_pairs + counts.box_pairs,
            );
            m.words("smoothed velocities", (n * D::N) as f64);
            Stepper::memory(m, case.method.integrator, layout.state.len());
            Reduction::memory(m, n);
            GpuInteractions::memory(m, case, n, D::N);
        })
    }

    /// Builds the host system of the case and uploads it with the initial state and the
    /// candidate lists.
    pub fn new(case: &Case, spec: &UlWeakFormSpec, gpu: Gpu) -> Result<Self, SetupError> {
        let host: Host<D> = crate::reference::build_method(case, spec)?;
        check_f32_run(case, host.boundary())?;
        let y0_host = host.initial_state();
        let x0 = Method::reference(&host);
        check_f32_particles::<D>(case, x0, &y0_host.u, &y0_host.v, Method::body(&host))?;
        let points = host.points().points();
        let (n, q) = (x0.len(), points.len());
        let layout = Layout::new(n, host.boundary().constrained.len(), q, D::N);
        let constants = scene_constants(case, &layout);
        check_f32_range(case, &constants)?;
        gpu.check_size("kinematics buffer", layout.kin.bytes())?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);

        let (device, pts) = galerkin::upload_moving(&gpu, &host, points, &layout.pts);
        let status = gpu.storage("status", &STATUS_OK);
        let kin = gpu.zeroed("kinematics", layout.kin.bytes());
        let gather = host.shapes().gather(n);
        let transposed = Csr {
            offsets: gather.offsets,
            ids: gather.point,
        };
        let candidates = Lists::upload(&gpu, host.points().lists())?;
        let transposed = Lists::upload(&gpu, &transposed)?;
        let own = Lists::upload(&gpu, &host.points().particle_functions().csr)?;

        let start = Start {
            gpu: &gpu,
            compose: &compose,
            device: &device,
        };
        let (stepper, interactions) = start.from_motion(
            case.method.integrator,
            (&layout.state, "NRHO"),
            (&y0_host.u, &y0_host.v),
            host.interactions(),
            host.boundary(),
        )?;
        let text = compose(&RATES);
        let pipeline = |entry: &str| gpu.pipeline(&format!("ul-weak-form {entry}"), &text, entry);
        let passes = Passes {
            points: pipeline("points")?,
            particles: pipeline("particles")?,
            nodes: pipeline("nodes")?,
            smooth: pipeline("smooth_own")?,
            settle: pipeline("settle")?,
        };
        let smoothed = gpu.zeroed("smoothed velocities", (n * D::N * 4) as u64);
        let table = |y, d| -> [(&str, &wgpu::Buffer); 8] {
            [
                ("pts", &pts),
                ("y", y),
                ("kin", &kin),
                ("d", d),
                ("status", &status),
                ("reference", &device.reference),
                ("ext", interactions.ext()),
                ("smoothed", &smoothed),
            ]
        };
        let rates = BySource::bind(&stepper, |y, d| -> Result<Bound, GpuError> {
            Ok(Bound {
                points: candidates.bind(&gpu, &passes.points, &table(y, d))?,
                particles: own.bind(&gpu, &passes.particles, &table(y, d))?,
                nodes: transposed.bind(&gpu, &passes.nodes, &table(y, d))?,
            })
        })?;
        let (y, acc) = (stepper.buffer(Buf::Y), stepper.buffer(Buf::Acc));
        let points_y = candidates.bind(&gpu, &passes.points, &table(y, acc))?;
        let smooth = match spec.smoothing {
            true => Some((
                own.bind(&gpu, &passes.smooth, &table(y, acc))?,
                gpu.bind(&passes.settle, &table(y, acc))?,
            )),
            false => None,
        };
        let reduction = Reduction::new(
            &gpu,
            &compose(&FOLDED_REDUCE),
            &[("y", y), ("kin", &kin), ("reference", &device.reference)],
            n,
        )?;
        let unbooked = Booked {
            dissipated: smooth.is_none().then_some(0.0),
            plastic_work: Some(0.0),
            contact_energy: case.contact.is_none().then_some(0.0),
            ..Booked::default()
        };
        let shell = Shell::new(gpu, stepper, reduction, kin, &layout.kin, unbooked);
        let family = WeakFormDevice {
            host,
            layout,
            constants,
            device,
            pts,
            status,
            candidates,
            transposed,
            own,
            passes,
            rates,
            points_y,
            smooth,
        };
        Ok(Self::assemble(shell, interactions, family))
    }
}

impl<D: GpuDim> WeakFormDevice<D> {
    /// Records one rate evaluation: the points, particles and nodes passes on `bound`.
    fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, bound: &Bound) {
        let p = &self.passes;
        let mut pass = encoder.begin_compute_pass(&Default::default());
        (self.candidates.split).dispatch(gpu, &mut pass, &p.points, &bound.points);
        (self.own.split).dispatch(gpu, &mut pass, &p.particles, &bound.particles);
        (self.transposed.split).dispatch(gpu, &mut pass, &p.nodes, &bound.nodes);
    }

    /// Decodes a flat state (`rho0` = ρ0: the densities are stored as ρ − ρ0) or rate
    /// buffer (`rho0` = 0) into the host's state.
    fn decode(&self, flat: &[f32], rho0: f64) -> UlGalerkinState<D> {
        let l = &self.layout.state;
        UlGalerkinState {
            u: l.read_v::<D>(flat, "U"),
            v: l.read_v::<D>(flat, "V"),
            rho: l.read_s(flat, "RHO", rho0),
            s: l.read_t::<D>(flat, "S", D::zero_t()),
            node_rho: l.read_s(flat, "NRHO", rho0),
            point_u: l.read_v::<D>(flat, "PU"),
        }
    }

    /// The particle next to stress point q: its first candidate.
    fn next_to(&self, q: usize) -> usize {
        let lists = self.host.points().lists();
        lists.neighbours(q).first().map_or(0, |&a| a as usize)
    }
}

impl<D: GpuDim> GpuUlWeakForm<D> {
    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> UlGalerkinState<D> {
        let rho0 = self.family.host.material().rho0;
        self.family.decode(&self.shell.read_state(), rho0)
    }

    /// Replaces the state (to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &UlGalerkinState<D>) {
        let l = &self.family.layout.state;
        let rho0 = self.family.host.material().rho0;
        let mut flat = l.zeroed();
        l.write_v::<D>(&mut flat, "U", &y.u);
        l.write_v::<D>(&mut flat, "V", &y.v);
        l.write_s(&mut flat, "NRHO", &y.node_rho, rho0);
        l.write_v::<D>(&mut flat, "PU", &y.point_u);
        l.write_s(&mut flat, "RHO", &y.rho, rho0);
        l.write_t::<D>(&mut flat, "S", &y.s, D::zero_t());
        self.shell.set_state(&flat);
    }

    /// The rates of a given state, read back.
    pub fn rates(&mut self, y: &UlGalerkinState<D>) -> UlGalerkinState<D> {
        self.set_state(y);
        let gpu = self.gpu();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        self.family
            .record(gpu, &mut encoder, self.family.rates.on_y());
        gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = gpu.read(self.shell.stepper.buffer(Buf::Rates));
        self.family.decode(&d, 0.0)
    }

    /// The candidates each stress point's ellipse keeps in the current state, as the
    /// device chooses them (read back, a part of the lists at a time).
    pub fn ellipses(&self) -> Result<Csr, GpuError> {
        let (gpu, family) = (self.gpu(), &self.family);
        let text = shaders::compose::<D>(&RATES, &family.constants);
        let pipeline = gpu.pipeline("ul-weak-form ellipses", &text, "ellipses")?;
        let lists = family.host.points().lists();
        let mut kept = Csr {
            offsets: vec![0],
            ids: Vec::new(),
        };
        let y = self.shell.stepper.buffer(Buf::Y);
        let candidates = &family.candidates;
        for (part, buffers) in candidates.split.parts.iter().zip(&candidates.parts) {
            let flags = gpu.zeroed("kept candidates", (part.pairs.max(1) * 4) as u64);
            let table = [
                ("pts", &family.pts),
                ("y", y),
                ("reference", &family.device.reference),
                ("kept", &flags),
            ];
            let bindings: Vec<_> = table.into_iter().chain(buffers.table()).collect();
            let bind = gpu.bind(&pipeline, &bindings)?;
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                gpu.dispatch(&mut pass, &pipeline, &bind, part.rows as u32);
            }
            gpu.queue.submit([encoder.finish()]);
            let flags: Vec<u32> = gpu.read(&flags);
            for q in part.first..part.first + part.rows {
                let range = lists.range(q);
                let at = range.start - part.start;
                let row = &lists.ids[range.clone()];
                let inside = row.iter().zip(&flags[at..at + range.len()]);
                kept.ids
                    .extend(inside.filter(|&(_, &k)| k == 1).map(|(&j, _)| j));
                kept.offsets.push(kept.ids.len());
            }
        }
        Ok(kept)
    }

    /// The host's system, which the device's set-up came from.
    pub fn host(&self) -> &Host<D> {
        &self.family.host
    }

    /// The parts the candidate, transposed and own lists are split into.
    pub fn parts(&self) -> [usize; 3] {
        let f = &self.family;
        [&f.candidates, &f.transposed, &f.own].map(|l| l.split.parts.len())
    }
}

impl<D: GpuDim> GpuFamily<D> for WeakFormDevice<D> {
    fn reference(&self) -> &[D::V] {
        Method::reference(&self.host)
    }

    fn boundary(&self) -> &Boundary<D> {
        self.host.boundary()
    }

    /// The stress points' candidate pairs (the transposed lists hold as many, the own
    /// lists about as many).
    fn scale(&self, _gpu: &Gpu) -> Scale {
        Scale {
            pairs: self.host.points().lists().pair_count() as u64,
            indirect: None,
        }
    }

    fn record_rates(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation) {
        self.record(gpu, encoder, self.rates.of(e));
    }

    /// With the velocity smoothing.
    fn ends_steps(&self) -> bool {
        self.smooth.is_some()
    }

    /// The velocity smoothing with the particles' own functions at the step's end.
    fn end_step(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        if let Some((smooth, settle)) = &self.smooth {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            (self.own.split).dispatch(gpu, &mut pass, &self.passes.smooth, smooth);
            gpu.dispatch(&mut pass, &self.passes.settle, settle, self.layout.n as u32);
        }
    }

    /// The points pass on the current state (its kinematics).
    fn before_reduction(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>) {
        (self.candidates.split).dispatch(gpu, pass, &self.passes.points, &self.points_y);
    }

    fn signal_speed(&self, reduced: &Reduced) -> f64 {
        self.host.material().p_wave_speed() + reduced.max_speed
    }

    /// The first stress point or particle whose density or functions failed so far.
    fn flagged(&self, gpu: &Gpu) -> Result<(), BlowUp> {
        let s: Vec<u32> = gpu.read(&self.status);
        let functions = "the ellipse or RKPM moment matrix (singular: too few particles in \
                         the ellipse, or all on one line)";
        let x0 = Method::reference(&self.host);
        // A density first: the volumes m/ρ of every function it reaches follow from it.
        for (k, quantity) in [(1, "density"), (0, functions)] {
            if s[k] != u32::MAX {
                let q = s[k] as usize;
                let what = format!("{quantity} (f32, GPU) at quadrature point {q} next to it");
                return Err(BlowUp::at::<D>(x0, self.next_to(q), &what, 0.0));
            }
            if s[k + 2] != u32::MAX {
                let what = format!("{quantity} (f32, GPU) at the particle");
                return Err(BlowUp::at::<D>(x0, s[k + 2] as usize, &what, 0.0));
            }
        }
        Ok(())
    }

    fn check_state(&self, flat: &[f32]) -> Result<(), BlowUp> {
        let y = self.decode(flat, self.host.material().rho0);
        self.host.check_finite(&y)
    }

    /// The host's outputs (nodal F and σ, Σ_q w0_q ψ_q in f64) of the state read back.
    fn snapshot(&mut self, shell: &Shell) -> Snapshot<'_, D> {
        let y = self.decode(&shell.read_state(), self.host.material().rho0);
        self.host.snapshot(&y)
    }
}
