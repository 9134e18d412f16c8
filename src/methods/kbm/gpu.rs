//! The Krongauz–Belytschko method on an Eulerian kernel on the GPU (`kbm` with
//! `kernel_frame = "eulerian"`): the passes of `shaders/kbm/eulerian.wgsl` on the points
//! (the particles, then the stress points) of the host's f64 system
//! ([`UlGalerkin`] on [`EulerianPoints`]), which the device's state and lists replace
//! for the outputs.
//!
//! A rate evaluation is a points pass (at each point the Shepard functions, M_q and the
//! corrected gradients among the particles of its list on the current configuration, then
//! L_q, F_q, σ_q and w_q) and a nodes pass (the force gathered over the node's points).
//! The lists are one self-search of all points by the device's cell list
//! ([`CellList`]), from their positions at the start of every `search_every`-th step, as
//! the CPU searches: no list is read back inside a step. A search that needs more room in
//! a part sets the cell list's overflow flag, which the engine reads after each batch: it
//! then grows the lists, searches again from the positions of the last search before the
//! batch, and runs the batch again from its start.

use super::KbmSpec;
use super::eulerian::{EulerianPoints, load_steps};
use crate::boundary::Boundary;
use crate::case::Case;
use crate::core::integrate::{Buf, Evaluation};
use crate::core::kernel::neighbour_radius;
use crate::core::neighbour::Csr;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, GpuEngine, GpuFamily, Method, Start};
use crate::gpu::context::{Gpu, GpuError, Pipeline};
use crate::gpu::layout::{Fields, GpuDim};
use crate::gpu::memory::{Counts, DeviceMemory};
use crate::gpu::neighbour::{CellList, CellParams, Positions, Room};
use crate::gpu::plastic;
use crate::gpu::profile::Scale;
use crate::gpu::program::Stepper;
use crate::gpu::reduction::{self, Reduced, Reduction};
use crate::gpu::reference::{self, DeviceReference, Extras};
use crate::gpu::shaders::{
    self, BOUNDARY, Constants, EIGEN, KERNEL, MECHANICS, OBJECTIVE, PART, PLASTIC_STORE,
    PLASTICITY, REFERENCE, Source, source,
};
use crate::gpu::shell::Shell;
use crate::gpu::{SetupError, check_f32_particles, check_f32_range, check_f32_run};
use crate::interaction::gpu::GpuInteractions;
use crate::methods::cores::galerkin::gpu::{
    self as galerkin, FOLDED_REDUCE, Points, RATE_POINT, STRESS,
};
use crate::methods::cores::galerkin::updated::{MovingPoints, UlGalerkin, UlGalerkinState};
use crate::methods::cores::shared::BySource;
use crate::physics::material::{Material, MaterialModel};
use std::sync::atomic::{AtomicU32, Ordering};

/// The points, nodes, commit and positions passes.
pub const RATES: Source = source!(
    "kbm/eulerian.wgsl",
    [
        KERNEL,
        MECHANICS,
        REFERENCE,
        BOUNDARY,
        EIGEN,
        OBJECTIVE,
        PLASTICITY,
        PLASTIC_STORE,
        RATE_POINT,
        STRESS,
        PART
    ],
    [
        ("y", false),
        ("pts", false),
        ("reference", false),
        ("ext", false),
        ("kin", true),
        ("d", true),
        ("xs", true)
    ]
);

/// The passes of either kernel: the Galerkin passes of the Lagrangian kernel's, then the
/// Eulerian kernel's own.
pub const SHADERS: &[Source] = &[
    galerkin::RATES,
    galerkin::REDUCE,
    galerkin::SMOOTH,
    shaders::CONTACT,
    shaders::LOADS,
    shaders::PRESCRIBED,
    shaders::INTEGRATE,
    RATES,
    FOLDED_REDUCE,
];

/// The host's system of the Eulerian kernel.
type Host<D> = UlGalerkin<D, EulerianPoints<D>>;

/// The flat buffers of an Eulerian-kernel scene of n particles and q points (the
/// particles first): the state [u | v (particles) | u (stress points) | ρ − ρ0 | S (points,
/// rate model only)], the kinematics [T = w σ / S | t = T ∇S / S | w0 ψ (points) | power
/// (particles)], the points' reference positions and weights, and the particles'
/// reference fields.
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
    /// n particles (`constrained` of them with prescribed components) and q ≥ n points.
    pub fn new(n: usize, constrained: usize, q: usize, dim: usize, rate: bool) -> Self {
        Self {
            n,
            q,
            dim,
            state: Fields::new("", dim)
                .vectors("U", true, n)
                .vectors("V", true, n)
                .vectors("PU", true, q - n)
                .scalars("RHO", rate, q)
                .tensors("S", rate, q),
            kin: reduction::with_reactions(
                Fields::new("K", dim)
                    .tensors("T", true, q)
                    .vectors("TS", true, q)
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

/// The compiled-in constants of an Eulerian-kernel scene.
pub fn scene_constants(case: &Case, layout: &Layout) -> Constants {
    let u = |x: usize| x as u32;
    let constants = Constants::default()
        .u32("N", u(layout.n))
        .u32("Q", u(layout.q))
        .u32("BODIES", u(case.bodies.len()))
        .material(&Material::new(&case.material))
        .kernel(&case.kernel(layout.dim))
        .u32("REST_OFF", u(layout.state.offset("PU")));
    [&layout.state, &layout.kin, &layout.pts, &layout.reference]
        .into_iter()
        .fold(constants, |c, fields| fields.constants(c))
}

/// The pairs of the points' first lists within the kernel support on the reference
/// configuration (the search's skin left out): what the counts of a case estimate
/// ([`Points`]).
fn reference_pairs<D: GpuDim>(points: &EulerianPoints<D>) -> usize {
    let (lists, x0) = (points.lists(), &points.points().x0);
    let reach = neighbour_radius(points.kernel());
    (0..lists.len())
        .map(|q| {
            let within = |&&a: &&u32| D::norm2(x0[a as usize] - x0[q]) <= reach * reach;
            lists.neighbours(q).iter().filter(within).count()
        })
        .sum()
}

/// The room of the device's lists for `pairs` point–particle pairs within the kernel
/// support of n particles and q points: the search also finds the stress points, q/n
/// times as many pairs, and twice that, for the skin and as compression adds neighbours
/// (a search that needs more grows them).
fn room_for(pairs: usize, n: usize, q: usize) -> u64 {
    (2.0 * pairs.max(q) as f64 * q as f64 / n.max(1) as f64).ceil() as u64
}

/// `status` when no point failed: [M singular, det F ≤ 0, ρ ≤ 0].
const STATUS_OK: [u32; 3] = [u32::MAX; 3];

/// The bind groups of one rate evaluation on a source state, a part of the lists each.
struct Bound {
    points: Vec<wgpu::BindGroup>,
    nodes: Vec<wgpu::BindGroup>,
}

/// The device's lists and the passes bound to them.
struct Lists {
    cells: CellList,
    rates: BySource<Bound>,
    /// The points pass on `Y` writing its rates into `Acc` (the kinematics of a reduction).
    points_y: Vec<wgpu::BindGroup>,
    /// The commit of the plastic history on `Y`.
    commit: Vec<wgpu::BindGroup>,
}

/// The pipelines of `shaders/kbm/eulerian.wgsl`.
struct Passes {
    points: Pipeline,
    nodes: Pipeline,
    positions: Pipeline,
    commit: Option<Pipeline>,
}

/// The Krongauz–Belytschko method on an Eulerian kernel resident on the GPU.
pub type GpuEulerianKbm<D> = GpuEngine<D, EulerianDevice<D>>;

/// The Eulerian kernel's family on the device: the host's system, the buffers, the passes
/// and the device's lists. The shell's checkpoints hold the plastic history too. The
/// balance's terms the engine does not book besides the work of supports and loads: the
/// plastic work, committed on the device; contact's, which `ext` adds to the loads' power.
pub struct EulerianDevice<D: GpuDim> {
    /// The host's f64 system the device's set-up was uploaded from; outputs are computed
    /// from the state and the lists read back.
    host: Host<D>,
    layout: Layout,
    device: DeviceReference,
    /// [X_q | w0_q] of every point.
    pts: wgpu::Buffer,
    kin_ext: (wgpu::Buffer, wgpu::Buffer),
    status: wgpu::Buffer,
    /// The points' plastic history (13 floats of a dummy for the elastic models).
    hist: wgpu::Buffer,
    /// `hist` at the start of the batch, whose steps commit it, to run the batch again.
    hist_start: wgpu::Buffer,
    /// The points' positions at the last search, which the cell list reads.
    searched: wgpu::Buffer,
    /// `searched` at the start of the batch, to search again after the lists grew.
    searched_start: wgpu::Buffer,
    /// The body of every point, for lists within a body (several bodies).
    body: Option<wgpu::Buffer>,
    grid: CellParams,
    passes: Passes,
    /// The positions pass on `Y`.
    positions: wgpu::BindGroup,
    /// Bound once the engine's buffers exist, and again when they grow.
    lists: Option<Lists>,
    /// `Y` at the start of the batch, to run it again after the lists grew.
    start: wgpu::Buffer,
    search_every: u32,
    /// Steps begun since the last search, as the host records them.
    steps: AtomicU32,
    /// `steps` at the start of the batch.
    steps_start: u32,
}

impl<D: GpuDim> GpuEulerianKbm<D> {
    /// The buffers [`Self::new`] makes for `case` on `counts` with the integration
    /// `points` (the constrained particles' reaction slots, a surface's few words each,
    /// left out). Lists that grow past their room are made again, larger.
    pub fn memory(case: &Case, counts: &Counts, points: &Points) -> DeviceMemory {
        DeviceMemory::of(counts, |m| {
            let n = counts.n();
            let (q, pairs) = (Counts::whole(points.points), Counts::whole(points.pairs));
            let rate = case.material.model.is_rate_based();
            let layout = Layout::new(n, 0, q.max(n), D::N, rate);
            DeviceReference::memory(m, &layout.reference, n, D::N, 0, 0);
            m.fields("points", &layout.pts);
            m.words("status", STATUS_OK.len() as f64);
            m.fields("kinematics", &layout.kin);
            let plastic = case.material.model == MaterialModel::VonMisesPlastic;
            for label in ["plastic history", "plastic history at the batch start"] {
                m.words(label, plastic::words(plastic, q) as f64);
            }
            for label in [
                "positions of the last search",
                "positions at the batch start",
            ] {
                m.words(label, (q * D::N) as f64);
            }
            if case.bodies.len() > 1 {
                m.words("bodies", q as f64);
            }
            m.fields("state at the batch start", &layout.state);
            Stepper::memory(m, case.method.integrator, layout.state.len());
            let ncells = CellParams::cells_of(case, D::N, q, case.kernel(D::N).support());
            CellList::memory(m, q as u64, D::N, ncells, room_for(pairs, n, q));
            Reduction::memory(m, n);
            GpuInteractions::memory(m, case, n, D::N);
        })
    }

    /// Builds the host system of the case and uploads it with the initial state, and
    /// searches the first lists on the device from the reference configuration.
    pub fn new(case: &Case, spec: &KbmSpec, gpu: Gpu) -> Result<Self, SetupError> {
        let host: Host<D> = crate::reference::build_method(case, spec)?;
        check_f32_run(case, host.boundary())?;
        let y0_host = host.initial_state();
        let x0 = Method::reference(&host);
        check_f32_particles::<D>(case, x0, &y0_host.u, &y0_host.v, Method::body(&host))?;
        let points = host.points().points();
        let (n, q) = (x0.len(), points.len());
        let rate = host.material().model.is_rate_based();
        let layout = Layout::new(n, host.boundary().constrained.len(), q, D::N, rate);
        let constants = scene_constants(case, &layout);
        check_f32_range(case, &constants)?;
        gpu.check_size("kinematics buffer", layout.kin.bytes())?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);

        let (device, pts) = galerkin::upload_moving(&gpu, &host, points, &layout.pts);
        let status = gpu.storage("status", &STATUS_OK);
        let kin = gpu.zeroed("kinematics", layout.kin.bytes());
        let plastic = host.material().model == MaterialModel::VonMisesPlastic;
        let hist = plastic::upload(&gpu, "plastic history", plastic, q);
        let hist_start = plastic::upload(&gpu, "plastic history at the batch start", plastic, q);
        let position_bytes = (q * D::N * 4) as u64;
        let searched = gpu.zeroed("positions of the last search", position_bytes);
        let searched_start = gpu.zeroed("positions at the batch start", position_bytes);
        let body = (case.bodies.len() > 1).then(|| gpu.storage("bodies", &points.body));

        let start = Start {
            gpu: &gpu,
            compose: &compose,
            device: &device,
        };
        let (stepper, interactions) = start.from_motion(
            case.method.integrator,
            (&layout.state, "PU"),
            (&y0_host.u, &y0_host.v),
            host.interactions(),
            host.boundary(),
        )?;
        let text = compose(&RATES);
        let passes = Passes {
            points: gpu.pipeline("eulerian kbm points", &text, "points")?,
            nodes: gpu.pipeline("eulerian kbm nodes", &text, "nodes")?,
            positions: gpu.pipeline("eulerian kbm positions", &text, "positions")?,
            commit: match plastic {
                true => Some(gpu.pipeline("eulerian kbm plastic commit", &text, "commit")?),
                false => None,
            },
        };
        let y = stepper.buffer(Buf::Y);
        let positions = gpu.bind(
            &passes.positions,
            &[("pts", &pts), ("y", y), ("xs", &searched)],
        )?;
        let reduction = Reduction::new(
            &gpu,
            &compose(&FOLDED_REDUCE),
            &[("y", y), ("kin", &kin), ("reference", &device.reference)],
            n,
        )?;
        let grid = CellParams::around::<D>(&gpu, &points.x0, host.points().kernel().support())?;
        let pairs = reference_pairs(host.points());
        let room = Room::fitting(&gpu, q as u32, room_for(pairs, n, q))?;
        let state_bytes = layout.state.bytes();
        let unbooked = Booked {
            dissipated: Some(0.0),
            plastic_work: (!plastic).then_some(0.0),
            contact_energy: case.contact.is_none().then_some(0.0),
            ..Booked::default()
        };
        let shell = Shell::new(gpu, stepper, reduction, kin.clone(), &layout.kin, unbooked)
            .save_also("plastic history", &hist)
            .save_also("positions of the last search", &searched);
        let search_every = host.points().search_every();
        let mut family = EulerianDevice {
            host,
            layout,
            device,
            pts,
            kin_ext: (kin, interactions.ext().clone()),
            status,
            hist,
            hist_start,
            searched,
            searched_start,
            body,
            grid,
            passes,
            positions,
            lists: None,
            start: shell.gpu.zeroed("state at the batch start", state_bytes),
            search_every,
            steps: AtomicU32::new(0),
            steps_start: 0,
        };
        family.search(&shell, room, true)?;
        Ok(Self::assemble(shell, interactions, family))
    }
}

impl<D: GpuDim> EulerianDevice<D> {
    /// Lists laid out as `room` says and the passes bound to them.
    fn bind_lists(&self, shell: &Shell, room: Room) -> Result<Lists, GpuError> {
        let gpu = &shell.gpu;
        let at = Positions {
            x: &self.searched,
            offset: 0,
            n: self.layout.q as u32,
            body: self.body.as_ref(),
        };
        let cells = CellList::new::<D>(gpu, at, &self.grid, room, 0.0)?;
        let (kin, ext) = &self.kin_ext;
        let per_part = |pipeline: &Pipeline, y, d| -> Result<Vec<wgpu::BindGroup>, GpuError> {
            let table: [(&str, &wgpu::Buffer); 9] = [
                ("offsets", &cells.offsets),
                ("pts", &self.pts),
                ("y", y),
                ("kin", kin),
                ("d", d),
                ("status", &self.status),
                ("hist", &self.hist),
                ("reference", &self.device.reference),
                ("ext", ext),
            ];
            (cells.parts.iter())
                .map(|part| {
                    let bindings: Vec<_> = table.iter().copied().chain(part.table()).collect();
                    gpu.bind(pipeline, &bindings)
                })
                .collect()
        };
        let p = &self.passes;
        let rates = BySource::bind(&shell.stepper, |y, d| -> Result<Bound, GpuError> {
            Ok(Bound {
                points: per_part(&p.points, y, d)?,
                nodes: per_part(&p.nodes, y, d)?,
            })
        })?;
        let (y, acc) = (shell.stepper.buffer(Buf::Y), shell.stepper.buffer(Buf::Acc));
        let commit = match &p.commit {
            Some(pipeline) => per_part(pipeline, y, acc)?,
            None => Vec::new(),
        };
        Ok(Lists {
            points_y: per_part(&p.points, y, acc)?,
            cells,
            rates,
            commit,
        })
    }

    fn lists(&self) -> &Lists {
        self.lists
            .as_ref()
            .expect("the lists are bound when the engine is built")
    }

    /// Records the positions of the points in `Y` into `searched` and a search from them.
    fn record_search(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            let q = self.layout.q as u32;
            gpu.dispatch(&mut pass, &self.passes.positions, &self.positions, q);
        }
        self.lists().cells.record(gpu, encoder);
    }

    /// Lists with room `room` searched from the positions in `searched` (those of `Y`
    /// first with `from_y`), grown until a search fits.
    fn search(&mut self, shell: &Shell, room: Room, from_y: bool) -> Result<(), GpuError> {
        let (gpu, q) = (&shell.gpu, self.layout.q as u32);
        let mut room = room;
        let mut from_y = from_y;
        loop {
            self.lists = Some(self.bind_lists(shell, room)?);
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            match from_y {
                true => self.record_search(gpu, &mut encoder),
                false => self.lists().cells.record(gpu, &mut encoder),
            }
            gpu.queue.submit([encoder.finish()]);
            from_y = false;
            match self.lists().cells.overflow(gpu) {
                None => return Ok(()),
                Some(needed) => room = Room::fitting(gpu, q, room.grown(q, needed))?,
            }
        }
    }

    /// Records one rate evaluation: the points and nodes passes on `bound`.
    fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, bound: &Bound) {
        let cells = &self.lists().cells;
        let mut pass = encoder.begin_compute_pass(&Default::default());
        cells.dispatch(gpu, &mut pass, &self.passes.points, &bound.points);
        cells.dispatch(gpu, &mut pass, &self.passes.nodes, &bound.nodes);
    }

    /// The device's lists read back, as the host's lists from each point to the
    /// particles: the ids below n, with the point itself when it is a particle.
    fn device_lists(&self, gpu: &Gpu) -> Csr {
        let searched = self.lists().cells.lists(gpu);
        let n = self.layout.n as u32;
        let mut lists = Csr {
            offsets: vec![0],
            ids: Vec::new(),
        };
        for q in 0..searched.offsets.len() - 1 {
            let row = searched.neighbours(q).iter().copied();
            let own = (q < n as usize).then_some(q as u32);
            let mut particles: Vec<u32> = row.chain(own).filter(|&a| a < n).collect();
            particles.sort_unstable();
            lists.ids.extend(particles);
            lists.offsets.push(lists.ids.len());
        }
        lists
    }

    /// Decodes a flat state (`rho0` = ρ0: the density is stored as ρ − ρ0) or rate buffer
    /// (`rho0` = 0) into the host's state, the particles' displacements as their points'.
    fn decode(&self, flat: &[f32], rho0: f64) -> UlGalerkinState<D> {
        let l = &self.layout.state;
        let u = l.read_v::<D>(flat, "U");
        let point_u = [u.clone(), l.read_v::<D>(flat, "PU")].concat();
        UlGalerkinState {
            u,
            v: l.read_v::<D>(flat, "V"),
            rho: l.read_s(flat, "RHO", rho0),
            s: l.read_t::<D>(flat, "S", D::zero_t()),
            node_rho: Vec::new(),
            point_u,
        }
    }

    /// The particle next to point q: itself, or a stress point's first listed particle.
    fn next_to(&self, q: usize) -> usize {
        match q < self.layout.n {
            true => q,
            false => {
                let csr = &self.host.shapes().csr;
                csr.neighbours(q).first().map_or(0, |&a| a as usize)
            }
        }
    }
}

impl<D: GpuDim> GpuEulerianKbm<D> {
    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> UlGalerkinState<D> {
        let rho0 = self.family.host.material().rho0;
        self.family.decode(&self.shell.read_state(), rho0)
    }

    /// Replaces the state (to cross-check rates on a given state; the lists stay).
    pub fn set_state(&mut self, y: &UlGalerkinState<D>) {
        let (l, n) = (&self.family.layout.state, self.family.layout.n);
        let mut flat = l.zeroed();
        l.write_v::<D>(&mut flat, "U", &y.u);
        l.write_v::<D>(&mut flat, "V", &y.v);
        l.write_v::<D>(&mut flat, "PU", &y.point_u[n..]);
        l.write_s(&mut flat, "RHO", &y.rho, self.family.host.material().rho0);
        l.write_t::<D>(&mut flat, "S", &y.s, D::zero_t());
        self.shell.set_state(&flat);
    }

    /// The rates of a given state on the current lists, read back (a particle's ẋ is its
    /// u̇ = v).
    pub fn rates(&mut self, y: &UlGalerkinState<D>) -> UlGalerkinState<D> {
        self.set_state(y);
        let gpu = self.gpu();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        self.family
            .record(gpu, &mut encoder, self.family.lists().rates.on_y());
        gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = gpu.read(self.shell.stepper.buffer(Buf::Rates));
        self.family.decode(&d, 0.0)
    }

    /// The lists of the last search from each point to the particles, read back.
    pub fn lists(&self) -> Csr {
        self.family.device_lists(self.gpu())
    }

    /// The host's system, which the device's set-up came from.
    pub fn host(&self) -> &Host<D> {
        &self.family.host
    }

    /// The pairs of the last search (reads them back).
    pub fn pairs(&self) -> u64 {
        self.family.lists().cells.pairs(self.gpu())
    }

    /// The parts the device's lists are split into.
    pub fn parts(&self) -> usize {
        self.family.lists().cells.parts.len()
    }

    /// Room for pairs in the device's lists, every part's together.
    pub fn capacity(&self) -> u64 {
        let cells = &self.family.lists().cells;
        cells.room().total(self.family.layout.q as u32)
    }

    /// Makes the device's lists anew with room for `pairs` pairs and searches them again
    /// from the positions of the last search (a search that needs more grows them).
    pub fn set_capacity(&mut self, pairs: u64) -> Result<(), GpuError> {
        let room = Room::fitting(self.gpu(), self.family.layout.q as u32, pairs)?;
        self.family.search(&self.shell, room, false)
    }
}

impl<D: GpuDim> GpuFamily<D> for EulerianDevice<D> {
    fn reference(&self) -> &[D::V] {
        Method::reference(&self.host)
    }

    fn boundary(&self) -> &Boundary<D> {
        self.host.boundary()
    }

    /// The pairs of the last search (read back), and the searches run and recorded so far.
    fn scale(&self, gpu: &Gpu) -> Scale {
        self.lists().cells.scale(gpu)
    }

    fn record_rates(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation) {
        self.record(gpu, encoder, self.lists().rates.of(e));
    }

    /// Keeps `Y`, the plastic history, the positions of the last search and the steps
    /// since it, to run the batch again after the lists grew.
    fn begin_batch(
        &mut self,
        gpu: &Gpu,
        stepper: &Stepper,
        encoder: &mut wgpu::CommandEncoder,
        dt: f64,
        _steps: u32,
    ) {
        plastic::set_step(gpu, &self.hist, dt);
        let bytes = self.layout.state.bytes();
        encoder.copy_buffer_to_buffer(stepper.buffer(Buf::Y), 0, &self.start, 0, bytes);
        for (from, to) in [
            (&self.searched, &self.searched_start),
            (&self.hist, &self.hist_start),
        ] {
            encoder.copy_buffer_to_buffer(from, 0, to, 0, from.size());
        }
        self.steps_start = self.steps.load(Ordering::Relaxed);
    }

    /// Every `search_every` steps the search from the step's start, as on the CPU
    /// (`EulerianPoints::relist`); then the commit of the plastic history.
    fn begin_step(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        let steps = self.steps.load(Ordering::Relaxed) + 1;
        if steps >= self.search_every {
            self.steps.store(0, Ordering::Relaxed);
            self.record_search(gpu, encoder);
        } else {
            self.steps.store(steps, Ordering::Relaxed);
        }
        if let Some(pipeline) = &self.passes.commit {
            let lists = self.lists();
            let mut pass = encoder.begin_compute_pass(&Default::default());
            lists
                .cells
                .dispatch(gpu, &mut pass, pipeline, &lists.commit);
        }
    }

    /// When a search overflowed the lists: grows every part to the pairs the fullest
    /// needed (with a quarter more), searches again from the positions of the last search
    /// before the batch, clears the flags, and puts back the state, the plastic history
    /// and the step count at its start.
    fn again(&mut self, shell: &mut Shell) -> Result<bool, GpuError> {
        let cells = &self.lists().cells;
        let Some(needed) = cells.overflow(&shell.gpu) else {
            return Ok(false);
        };
        let q = self.layout.q as u32;
        let room = Room::fitting(&shell.gpu, q, cells.room().grown(q, needed))?;
        let mut encoder = shell.gpu.device.create_command_encoder(&Default::default());
        for (from, to) in [
            (&self.searched_start, &self.searched),
            (&self.hist_start, &self.hist),
        ] {
            encoder.copy_buffer_to_buffer(from, 0, to, 0, from.size());
        }
        shell.gpu.queue.submit([encoder.finish()]);
        self.search(shell, room, false)?;
        // What the truncated lists flagged is no failure of the batch run again.
        (shell.gpu.queue).write_buffer(&self.status, 0, bytemuck::cast_slice(&STATUS_OK));
        self.steps.store(self.steps_start, Ordering::Relaxed);
        shell.stepper.restart_from(&shell.gpu, &self.start);
        Ok(true)
    }

    /// The points pass on the current state (its kinematics).
    fn before_reduction(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>) {
        let lists = self.lists();
        (lists.cells).dispatch(gpu, pass, &self.passes.points, &lists.points_y);
    }

    fn signal_speed(&self, reduced: &Reduced) -> f64 {
        self.host.material().p_wave_speed() + reduced.max_speed
    }

    /// The first point whose points pass failed so far: M singular, det F ≤ 0 or ρ ≤ 0.
    fn flagged(&self, gpu: &Gpu) -> Result<(), BlowUp> {
        let s: Vec<u32> = gpu.read(&self.status);
        let quantities = [
            "M (singular: too few particles in the kernel support, or all on one line)",
            "det F",
            "density",
        ];
        for (k, quantity) in quantities.into_iter().enumerate() {
            if s[k] != u32::MAX {
                let q = s[k] as usize;
                let what = format!("{quantity} (f32, GPU) at quadrature point {q} next to it");
                return Err(BlowUp::at::<D>(
                    Method::reference(&self.host),
                    self.next_to(q),
                    &what,
                    0.0,
                ));
            }
        }
        Ok(())
    }

    fn check_state(&self, flat: &[f32]) -> Result<(), BlowUp> {
        let y = self.decode(flat, self.host.material().rho0);
        self.host.check_finite(&y)
    }

    /// The steps since the last search.
    fn save(&self, out: &mut Vec<f64>) {
        out.push(f64::from(self.steps.load(Ordering::Relaxed)));
    }

    /// The steps since the last search, the shell's buffers (the positions of that
    /// search among them), and its lists searched again from those positions.
    fn restore(&mut self, shell: &mut Shell, words: &[f64]) -> Result<(), String> {
        let mut rest = words;
        let steps = load_steps(&mut rest, self.search_every)?;
        shell.restore(rest)?;
        self.steps.store(steps, Ordering::Relaxed);
        let room = self.lists().cells.room();
        self.search(shell, room, false).map_err(|e| e.to_string())
    }

    /// The host's outputs (nodal F and σ, Σ_q w0_q ψ_q in f64) of the state, the lists and
    /// the plastic history read back.
    fn snapshot(&mut self, shell: &Shell) -> Snapshot<'_, D> {
        let y = self.decode(&shell.read_state(), self.host.material().rho0);
        let lists = self.device_lists(&shell.gpu);
        self.host.points_mut().set_lists(lists.clone());
        self.host.use_lists(lists);
        if let Some(history) = self.host.plastic_mut() {
            history.read_f32(&shell.gpu.read::<f32>(&self.hist));
        }
        self.host.snapshot(&y)
    }
}
