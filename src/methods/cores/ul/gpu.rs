//! The updated-Lagrangian core on the GPU: what the Gray–Monaghan and Godunov engines
//! share, as [`super`] is on the CPU. A [`Scheme`] supplies one method's pass file (its
//! `particle` and `rates` entry points, on `shaders/ul/ul.wgsl`) and constants; the core
//! holds the state, the integrator program, the interactions and the neighbour lists.
//!
//! Every rate evaluation records, with no read-back: x = X + u (`positions`), a cell-list
//! rebuild of the lists from x ([`CellList`], per body with contact), the scheme's
//! per-particle pass and its pair gather. The lists live on the device in parts of equal
//! rows, each with room for its share of the pairs in its own ids buffer, so that each
//! fits one storage binding ([`Room`]); the particle pass and the pair gather run a
//! dispatch a part. A rebuild that needs more room in a part sets an overflow flag, which
//! the engine reads (one u32) after each batch of steps: it then grows every part to the
//! most pairs a part needed (with a quarter more, in more parts past the binding limit) and
//! runs the batch again from its start.

use super::{
    FreeSurface, H_CAP, PRIME_SPACE_REACH, SMOOTHING_LENGTH, SURFACE_SHEPARD, SmoothingLength,
    UlState, check_state, snapshot,
};
use crate::boundary::Boundary;
use crate::case::Case;
use crate::core::correction::CorrectionKind;
use crate::core::integrate::{Buf, Evaluation};
use crate::core::neighbour::{Csr, SKIN};
use crate::core::neighbourhood::PRIME_SPACE_TOLERANCE;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::{ScalarField, Snapshot};
use crate::engine::{BlowUp, GpuEngine, GpuFamily, Start};
use crate::gpu::context::{Gpu, GpuError, Pipeline};
use crate::gpu::layout::{Fields, GpuDim};
use crate::gpu::memory::{Counts, DeviceMemory};
use crate::gpu::neighbour::{CellList, CellParams, Positions, Room};
use crate::gpu::parts::Split;
use crate::gpu::profile::Scale;
use crate::gpu::program::Stepper;
use crate::gpu::reduction::{self, Reduced, Reduction};
use crate::gpu::reference::{self, DeviceReference, Extras};
use crate::gpu::shaders::{
    self, Constants, MECHANICS, PART, REFERENCE, Source, Wgsl, source, wgsl,
};
use crate::gpu::shell::Shell;
use crate::gpu::{SetupError, check_f32_particles, check_f32_range, check_f32_run};
use crate::interaction::gpu::GpuInteractions;
use crate::methods::cores::shared::BySource;
use crate::physics::material::Material;
use crate::reference::Reference;

/// The core's bindings, positions pass, correction and closing of the rates, which each
/// scheme's pass file includes last; with the bytes model of `positions` and the blocks
/// `particle_core` and `rates_core` that the schemes' models include (`gpu::bytes`).
pub const CORE: Wgsl = wgsl!("ul/ul.wgsl");
/// The strain energy of the reduction.
const ENERGY: Wgsl = wgsl!("ul/ul_energy.wgsl");
/// Energies, momenta and checks of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, ENERGY, REFERENCE, PART],
    [("y", false), ("kin", false), ("reference", false)]
);
/// The flat buffers of a scheme's pass file.
pub const FLAT: &[(&str, bool)] = &[
    ("y", false),
    ("x", true),
    ("kin", true),
    ("d", true),
    ("reference", false),
    ("ext", false),
];

/// The radial return of S at every step's end, with a yield stress.
pub const RETURN: Source = source!("ul/plastic.wgsl", [MECHANICS], [("y", true)]);

/// One updated-Lagrangian method on the device.
pub struct Scheme {
    /// Its pass file, with [`CORE`] among its function files: entry points `positions`
    /// (the core's), `particle` and `rates`.
    pub passes: Source,
    /// It stores an artificial stress R per particle.
    pub artificial_stress: bool,
    /// It stores the pressure p per particle.
    pub pressure: bool,
    /// Its traction-free treatment of the surface (`cauchy_of` in `shaders/ul/ul.wgsl`).
    pub free_surface: FreeSurface,
    /// Its smoothing length (the `smoothing` pass of `shaders/ul/ul.wgsl`).
    pub smoothing_length: SmoothingLength,
    /// Its own compiled-in constants.
    pub constants: Constants,
}

/// The flat buffers of an updated-Lagrangian scene, each described once: the state
/// [u | v | ρ − ρ0 | S | H = F − I | ε_p] (ε_p with a yield stress), the scheme's per-particle quantities
/// [T | R | AIT | RK | H | VOL | C | P | POW] (`shaders/ul/ul.wgsl`) and the reference
/// configuration.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub dim: usize,
    pub state: Fields,
    pub kin: Fields,
    pub reference: Fields,
}

impl Layout {
    /// The layout of n particles, `constrained` of them with prescribed components, for
    /// `case`'s correction and material.
    pub fn new(n: usize, constrained: usize, dim: usize, scheme: &Scheme, case: &Case) -> Self {
        let corrected = case.method.correction == CorrectionKind::RandlesLibersky;
        let reproducing = case.method.correction == CorrectionKind::Rkpm;
        let plastic = Material::new(&case.material).rate_plasticity().is_some();
        let prime = scheme.smoothing_length == SmoothingLength::PrimeSpace;
        Self {
            n,
            dim,
            state: Fields::new("", dim)
                .vectors("U", true, n)
                .vectors("V", true, n)
                .scalars("RHO", true, n)
                .tensors("S", true, n)
                .tensors("F", true, n)
                .scalars("EP", plastic, n),
            kin: reduction::with_reactions(
                Fields::new("K", dim)
                    .tensors("T", true, n)
                    .tensors("R", scheme.artificial_stress, n)
                    .tensors("AIT", corrected, n)
                    .block("RK", reproducing, n, (dim + 1) * (dim + 1))
                    .scalars("H", scheme.adaptive(), n)
                    .block("PS", prime, n, PS_WIDTH)
                    .scalars("VOL", true, n)
                    .scalars("C", true, n)
                    .scalars("P", scheme.pressure, n)
                    .scalars("POW", true, n),
                constrained,
            ),
            reference: reference::fields(n, constrained, dim, Extras::default()),
        }
    }
}

/// The compiled-in constants of a scene's UL passes: the scheme's, the kernel, the
/// material, the correction and the field offsets.
pub fn scene_constants(case: &Case, layout: &Layout, scheme: &Scheme) -> Constants {
    let correction = match case.method.correction {
        CorrectionKind::RandlesLibersky => 1,
        CorrectionKind::Rkpm => 2,
        _ => 0,
    };
    let kernel = case.kernel(layout.dim);
    let constants = scheme
        .constants
        .clone()
        .kernel(&kernel)
        .u32("N", layout.n as u32)
        .u32("BODIES", case.bodies.len() as u32)
        .material(&Material::new(&case.material))
        .choice("CORRECTION", &["NONE", "LINEAR", "REPRODUCING"], correction)
        .u32("PLASTIC", u32::from(layout.state.has("EP")))
        .u32(
            "FREE_SURFACE",
            u32::from(scheme.free_surface == FreeSurface::Projection),
        )
        .f32("SURFACE_SHEPARD", SURFACE_SHEPARD)
        .choice(
            "ADAPTIVE_H",
            &["FIXED", "DENSITY", "CONTINUITY", "PRIME_SPACE"],
            match scheme.smoothing_length {
                SmoothingLength::Fixed => 0,
                SmoothingLength::Density => 1,
                SmoothingLength::Continuity => 2,
                SmoothingLength::PrimeSpace => 3,
            },
        )
        .f32("H_CAP", H_CAP)
        .f32("PS_R2", (H_CAP * kernel.support()).powi(2))
        .f32("PS_TOLERANCE", PRIME_SPACE_TOLERANCE)
        .f32(
            "PS_H_PER_R",
            1.0 / (PRIME_SPACE_REACH * kernel.kind.support_factor()),
        )
        .u32("PS_EDGES", PS_EDGES as u32)
        .u32("PS_WIDTH", PS_WIDTH as u32)
        .u32("REST_OFF", layout.state.offset("RHO") as u32);
    [&layout.state, &layout.kin, &layout.reference]
        .into_iter()
        .fold(constants, |c, fields| fields.constants(c))
}

/// `status` slots: the first particle with a singular correction (det A or the RKPM
/// moment matrix), with ρ ≤ 0, without a fixed point of eqs 60–61, and whose prime-space
/// hull has more than [`PS_EDGES`] edges.
const STATUS_OK: [u32; 4] = [u32::MAX; 4];

/// The most edges of a particle's prime-space hull on the device: a lattice's has 4, a
/// disordered interior 5–8, a face more (its face particles' images lie near one line).
const PS_EDGES: usize = 24;

/// The floats of a particle's prime-space hull in `kin`: its edge count, its tolerance,
/// and each edge's inward normal and offset.
const PS_WIDTH: usize = 2 + 3 * PS_EDGES;

impl Scheme {
    /// Whether each particle has its own smoothing length.
    pub fn adaptive(&self) -> bool {
        self.smoothing_length != SmoothingLength::Fixed
    }

    /// The reach of the lists in units of the kernel's support: H_CAP with an adaptive
    /// smoothing length, whose h_ij may reach H_CAP h.
    fn reach_factor(&self) -> f64 {
        if self.adaptive() { H_CAP } else { 1.0 }
    }
}

/// The pipelines of one rate evaluation.
struct Passes {
    positions: Pipeline,
    /// With an adaptive smoothing length.
    smoothing: Option<Pipeline>,
    particle: Pipeline,
    rates: Pipeline,
}

/// The bind groups of one rate evaluation on a source state: the smoothing (with an
/// adaptive h), particle and pair passes', a part of the lists each.
struct Bound {
    positions: wgpu::BindGroup,
    smoothing: Vec<wgpu::BindGroup>,
    particle: Vec<wgpu::BindGroup>,
    rates: Vec<wgpu::BindGroup>,
}

/// The neighbour lists on the device and the rate evaluations bound to them (on the
/// states in `Y` and in `Stage`).
struct Lists {
    cells: CellList,
    rates: BySource<Bound>,
}

/// An updated-Lagrangian system resident on the GPU.
pub type GpuUl<D> = GpuEngine<D, UlDevice<D>>;

/// The updated-Lagrangian family on the device: the reference configuration, the buffers,
/// the scheme's passes and the device's neighbour lists. The balance's terms the engine
/// does not book besides the work of supports and loads: the artificial viscosity's or
/// the Riemann solver's dissipation; contact's, which `ext` adds to the loads' power.
pub struct UlDevice<D: GpuDim> {
    /// The host's f64 reference configuration, which the device's was uploaded from.
    reference: Reference<D>,
    layout: Layout,
    device: DeviceReference,
    /// x = X + u of the last positions pass.
    x: wgpu::Buffer,
    status: wgpu::Buffer,
    /// The interactions' `ext`, which the rates pass reads.
    ext: wgpu::Buffer,
    /// The body of each particle for per-body lists (with contact).
    body: Option<wgpu::Buffer>,
    /// The kernel support the lists reach ([`Scheme::reach_factor`]).
    reach: f64,
    grid: CellParams,
    passes: Passes,
    /// The radial return at every step's end on `Y`, with a yield stress.
    plastic_return: Option<(Pipeline, wgpu::BindGroup)>,
    /// Bound once the engine's buffers exist, and again when they grow.
    lists: Option<Lists>,
    /// `Y` at the start of the batch, to run it again after the lists grew.
    start: wgpu::Buffer,
    /// Neighbour builds of the lists that growth replaced, less those of
    /// [`GpuUl::time_rebuild`].
    builds_before: i64,
    /// One build timed alone, the first time the builds' time is asked for: the same
    /// factor for every later estimate, so that the estimates only grow.
    rebuild_seconds: Option<f64>,
}

/// The room of the device's lists for `pairs` reference pairs of `n` particles: twice
/// them, as compression adds neighbours, and a build that needs more grows the lists;
/// H_CAP^d times that for the reach of an adaptive smoothing length.
fn capacity<D: GpuDim>(scheme: &Scheme, pairs: usize, n: usize) -> u64 {
    let widened = scheme.reach_factor().powi(D::N as i32);
    (2.0 * pairs.max(n) as f64 * widened).ceil() as u64
}

impl<D: GpuDim> GpuUl<D> {
    /// The buffers [`Self::new`] makes for `case` under `scheme` on `counts`, from the same
    /// layout and rules (the cell grid over the bodies' boxes; the constrained particles'
    /// reaction slots, a surface's few words each, left out). Lists that grow past their
    /// room are made again, larger.
    pub fn memory(case: &Case, scheme: &Scheme, counts: &Counts) -> DeviceMemory {
        DeviceMemory::of(counts, |m| {
            let n = counts.n();
            let layout = Layout::new(n, 0, D::N, scheme, case);
            DeviceReference::memory(m, &layout.reference, n, D::N, 0, 0);
            Stepper::memory(m, case.method.integrator, layout.state.len());
            m.words("positions x", (n * D::N) as f64);
            m.fields("per-particle quantities", &layout.kin);
            m.words("status", STATUS_OK.len() as f64);
            if case.contact.is_some() {
                m.words("bodies", n as f64);
            }
            m.fields("state at the batch start", &layout.state);
            let support = scheme.reach_factor() * case.kernel(D::N).support();
            let ncells = CellParams::cells_of(case, D::N, n, support);
            let room = capacity::<D>(scheme, counts.pair_count(), n);
            CellList::memory(m, n as u64, D::N, ncells, room);
            Reduction::memory(m, n);
            GpuInteractions::memory(m, case, n, D::N);
        })
    }

    /// Uploads the case's reference configuration and initial state and compiles the
    /// scheme's passes.
    pub fn new(case: &Case, gpu: Gpu, scheme: &Scheme) -> Result<Self, SetupError> {
        let disc = Reference::<D>::build(case)?;
        check_f32_run(case, &disc.boundary)?;
        check_f32_particles::<D>(case, &disc.x0, &disc.u0, &disc.v0, &disc.body)?;
        let n = disc.len();
        let layout = Layout::new(n, disc.boundary.constrained.len(), D::N, scheme, case);
        let constants = scene_constants(case, &layout, scheme);
        check_f32_range(case, &constants)?;
        gpu.check_size("kinematics buffer", layout.kin.bytes())?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);

        // The lists come from the device's cell list, not from the host.
        let device = DeviceReference::upload::<D>(
            &gpu,
            &disc.x0,
            &disc.vol,
            &disc.boundary,
            (&Csr::default(), &Split::whole(&Csr::default())),
            Extras::default(),
        );
        let mut y0 = layout.state.zeroed();
        layout.state.write_v::<D>(&mut y0, "V", &disc.v0);
        let per_body = case.contact.is_some();
        let start = Start {
            gpu: &gpu,
            compose: &compose,
            device: &device,
        };
        let (stepper, interactions) =
            start.particles(case, &disc, &layout.state, &y0, || disc.neighbours())?;
        let x = gpu.zeroed("positions x", (n * D::N) as u64 * 4);
        let kin = gpu.zeroed("per-particle quantities", layout.kin.bytes());
        let status = gpu.storage("status", &STATUS_OK);
        let body = per_body.then(|| gpu.storage("bodies", &disc.body));
        let text = compose(&scheme.passes);
        let passes = Passes {
            positions: gpu.pipeline("ul positions", &text, "positions")?,
            smoothing: match scheme.adaptive() {
                true => Some(gpu.pipeline("ul smoothing length", &text, "smoothing")?),
                false => None,
            },
            particle: gpu.pipeline("ul particle", &text, "particle")?,
            rates: gpu.pipeline("ul rates", &text, "rates")?,
        };
        let plastic_return = match layout.state.has("EP") {
            true => {
                let pipeline =
                    gpu.pipeline("ul radial return", &compose(&RETURN), "plastic_return")?;
                let bind = gpu.bind(&pipeline, &[("y", stepper.buffer(Buf::Y))])?;
                Some((pipeline, bind))
            }
            false => None,
        };
        let reach = scheme.reach_factor() * disc.kernel.support();
        let grid = CellParams::around::<D>(&gpu, &disc.x0, reach)?;
        let reduction = Reduction::new(
            &gpu,
            &compose(&REDUCE),
            &[
                ("y", stepper.buffer(Buf::Y)),
                ("kin", &kin),
                ("reference", &device.reference),
            ],
            n,
        )?;
        let start = gpu.zeroed("state at the batch start", layout.state.bytes());
        let pairs = capacity::<D>(scheme, disc.neighbours().pair_count(), n);
        let room = Room::fitting(&gpu, n as u32, pairs)?;
        let unbooked = Booked {
            dissipated: None,
            contact_energy: case.contact.is_none().then_some(0.0),
            plastic_work: plastic_return.is_none().then_some(0.0),
            ..Booked::default()
        };
        let shell = Shell::new(gpu, stepper, reduction, kin, &layout.kin, unbooked);
        let mut family = UlDevice {
            reference: disc,
            layout,
            device,
            x,
            status,
            ext: interactions.ext().clone(),
            body,
            reach,
            grid,
            passes,
            plastic_return,
            lists: None,
            start,
            builds_before: 0,
            rebuild_seconds: None,
        };
        family.lists = Some(family.bind_lists(&shell, room)?);
        Ok(Self::assemble(shell, interactions, family))
    }
}

impl<D: GpuDim> UlDevice<D> {
    /// Neighbour lists laid out as `room` says and the rate evaluations bound to them.
    fn bind_lists(&self, shell: &Shell, room: Room) -> Result<Lists, GpuError> {
        let n = self.layout.n as u32;
        let at = Positions {
            x: &self.x,
            offset: 0,
            n,
            body: self.body.as_ref(),
        };
        let drift = 0.5 * SKIN * self.reach;
        let cells = CellList::new::<D>(&shell.gpu, at, &self.grid, room, drift)?;
        let rates = BySource::bind(&shell.stepper, |y, d| -> Result<Bound, GpuError> {
            let table: [(&str, &wgpu::Buffer); 8] = [
                ("offsets", &cells.offsets),
                ("reference", &self.device.reference),
                ("y", y),
                ("x", &self.x),
                ("kin", &shell.kin),
                ("ext", &self.ext),
                ("d", d),
                ("status", &self.status),
            ];
            let per_part = |pipeline: &Pipeline| -> Result<Vec<wgpu::BindGroup>, GpuError> {
                (cells.parts.iter())
                    .map(|part| {
                        let bindings: Vec<_> = table.iter().copied().chain(part.table()).collect();
                        shell.gpu.bind(pipeline, &bindings)
                    })
                    .collect()
            };
            let p = &self.passes;
            Ok(Bound {
                positions: shell.gpu.bind(&p.positions, &table)?,
                smoothing: match &p.smoothing {
                    Some(pipeline) => per_part(pipeline)?,
                    None => Vec::new(),
                },
                particle: per_part(&p.particle)?,
                rates: per_part(&p.rates)?,
            })
        })?;
        Ok(Lists { cells, rates })
    }

    /// Makes the device's lists anew with room for `pairs` pairs, in as many parts as the
    /// binding limit needs (a rebuild that needs more grows them again).
    fn grow(&mut self, shell: &Shell, pairs: u64) -> Result<(), GpuError> {
        let room = Room::fitting(&shell.gpu, self.layout.n as u32, pairs)?;
        self.builds_before += i64::from(self.lists().cells.builds(&shell.gpu));
        self.lists = Some(self.bind_lists(shell, room)?);
        Ok(())
    }

    fn lists(&self) -> &Lists {
        self.lists
            .as_ref()
            .expect("the lists are bound when the engine is built")
    }

    /// The neighbour builds the device ran for the steps so far (reads one u32 back).
    fn builds(&self, gpu: &Gpu) -> i64 {
        self.builds_before + i64::from(self.lists().cells.builds(gpu))
    }

    /// The wall time of one neighbour rebuild (positions pass and cell list) from the
    /// current state, timed alone over `REPEATS` rebuilds in one submission [s].
    fn time_rebuild(&mut self, gpu: &Gpu) -> f64 {
        const REPEATS: u32 = 20;
        self.builds_before -= i64::from(REPEATS);
        let lists = self.lists();
        let bound = lists.rates.on_y();
        gpu.wait();
        let started = std::time::Instant::now();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        for _ in 0..REPEATS {
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                let n = self.layout.n as u32;
                gpu.dispatch(&mut pass, &self.passes.positions, &bound.positions, n);
            }
            lists.cells.record(gpu, &mut encoder);
        }
        gpu.queue.submit([encoder.finish()]);
        gpu.wait();
        started.elapsed().as_secs_f64() / f64::from(REPEATS)
    }

    /// Decodes a flat state (`rho0` = ρ0 and `f0` = I: ρ and F are stored as ρ − ρ0 and
    /// F − I) or rate buffer (`rho0` = 0, `f0` = 0).
    fn decode(&self, flat: &[f32], rho0: f64, f0: D::T) -> UlState<D> {
        let l = &self.layout.state;
        let (u, v, rho, s) = l.read_solid::<D>(flat, rho0);
        let f = l.read_t::<D>(flat, "F", f0);
        let eps_p = l.read_s(flat, "EP", 0.0);
        UlState {
            u,
            v,
            rho,
            s,
            f,
            eps_p,
        }
    }

    /// A state read back.
    fn decode_state(&self, flat: &[f32]) -> UlState<D> {
        self.decode(flat, self.reference.material.rho0, D::identity())
    }
}

impl<D: GpuDim> GpuUl<D> {
    /// The host's reference configuration of the scene.
    pub fn reference(&self) -> &Reference<D> {
        &self.family.reference
    }

    /// The wall time of one neighbour rebuild (positions pass and cell list) from the
    /// current state [s].
    pub fn time_rebuild(&mut self) -> f64 {
        self.family.time_rebuild(&self.shell.gpu)
    }

    /// The neighbour builds the device ran for the steps so far (reads one u32 back).
    pub fn builds(&self) -> i64 {
        self.family.builds(&self.shell.gpu)
    }

    /// Makes the device's lists anew with room for `pairs` pairs (a rebuild that needs
    /// more grows them again).
    pub fn set_capacity(&mut self, pairs: u64) -> Result<(), GpuError> {
        self.family.grow(&self.shell, pairs)
    }

    /// Room for pairs in the device's lists, every part's together.
    pub fn capacity(&self) -> u64 {
        let cells = &self.family.lists().cells;
        cells.room().total(self.family.layout.n as u32)
    }

    /// How the device's lists are laid out: the rows of a part and its room.
    pub fn room(&self) -> Room {
        self.family.lists().cells.room()
    }

    /// The lists of the last rate evaluation, read back.
    pub fn neighbours(&self) -> Csr {
        self.family.lists().cells.lists(&self.shell.gpu)
    }

    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> UlState<D> {
        self.family.decode_state(&self.shell.read_state())
    }

    /// Replaces the state (e.g. to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &UlState<D>) {
        let (l, rho0) = (
            &self.family.layout.state,
            self.family.reference.material.rho0,
        );
        let mut flat = l.zeroed();
        l.write_solid::<D>(&mut flat, (&y.u, &y.v), (&y.rho, rho0), &y.s);
        l.write_t::<D>(&mut flat, "F", &y.f, D::identity());
        if l.has("EP") {
            l.write_s(&mut flat, "EP", &y.eps_p, 0.0);
        }
        self.shell.set_state(&flat);
    }

    /// The rates of a given state, read back (the lists are built from its positions).
    pub fn rates(&mut self, y: &UlState<D>) -> UlState<D> {
        self.set_state(y);
        let gpu = self.gpu();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let e = Evaluation {
            src: Buf::Y,
            index: 0,
        };
        self.family.record_rates(gpu, &mut encoder, e);
        gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = gpu.read(self.shell.stepper.buffer(Buf::Rates));
        self.family.decode(&d, 0.0, D::zero_t())
    }
}

impl<D: GpuDim> GpuFamily<D> for UlDevice<D> {
    fn reference(&self) -> &[D::V] {
        &self.reference.x0
    }

    fn boundary(&self) -> &Boundary<D> {
        &self.reference.boundary
    }

    /// The pairs of the last build (read back), and the builds run and recorded so far.
    fn scale(&self, gpu: &Gpu) -> Scale {
        self.lists().cells.scale(gpu)
    }

    /// Records one rate evaluation on the state in `Y` or `Stage`: positions, the
    /// rebuild of the lists, the scheme's particle and pair passes.
    fn record_rates(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation) {
        let (passes, lists, n) = (&self.passes, self.lists(), self.layout.n as u32);
        let bound = lists.rates.of(e);
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            gpu.dispatch(&mut pass, &passes.positions, &bound.positions, n);
        }
        lists.cells.record_on_drift(gpu, encoder);
        let mut pass = encoder.begin_compute_pass(&Default::default());
        if let Some(smoothing) = &passes.smoothing {
            (lists.cells).dispatch(gpu, &mut pass, smoothing, &bound.smoothing);
        }
        (lists.cells).dispatch(gpu, &mut pass, &passes.particle, &bound.particle);
        (lists.cells).dispatch(gpu, &mut pass, &passes.rates, &bound.rates);
    }

    /// Keeps `Y` in `start`. The batch may run again from its start (lists grown): its
    /// first evaluation builds from its own positions, whatever the lists held.
    fn begin_batch(
        &mut self,
        _gpu: &Gpu,
        stepper: &Stepper,
        encoder: &mut wgpu::CommandEncoder,
        _dt: f64,
        _steps: u32,
    ) {
        let bytes = self.layout.state.bytes();
        encoder.copy_buffer_to_buffer(stepper.buffer(Buf::Y), 0, &self.start, 0, bytes);
        self.lists().cells.force(encoder);
    }

    /// When a rebuild overflowed the lists: grows every part to the pairs the fullest
    /// needed (with a quarter more), clears the flags and puts back the state at the
    /// batch's start.
    fn again(&mut self, shell: &mut Shell) -> Result<bool, GpuError> {
        let cells = &self.lists().cells;
        let Some(needed) = cells.overflow(&shell.gpu) else {
            return Ok(false);
        };
        let pairs = cells.room().grown(self.layout.n as u32, needed);
        self.grow(shell, pairs)?;
        // What the truncated lists flagged is no failure of the batch run again.
        (shell.gpu.queue).write_buffer(&self.status, 0, bytemuck::cast_slice(&STATUS_OK));
        shell.stepper.restart_from(&shell.gpu, &self.start);
        Ok(true)
    }

    /// With a yield stress.
    fn ends_steps(&self) -> bool {
        self.plastic_return.is_some()
    }

    /// The radial return of every particle's S.
    fn end_step(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        if let Some((pipeline, bind)) = &self.plastic_return {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            gpu.dispatch(&mut pass, pipeline, bind, self.layout.n as u32);
        }
    }

    fn signal_speed(&self, reduced: &Reduced) -> f64 {
        self.reference.material.p_wave_speed() + reduced.max_speed
    }

    /// The first particle with a singular correction, and with ρ ≤ 0, since the start.
    fn flagged(&self, gpu: &Gpu) -> Result<(), BlowUp> {
        let s: Vec<u32> = gpu.read(&self.status);
        let correction = match self.layout.kin.has("RK") {
            true => "RKPM moment matrix (f32, GPU)",
            false => "det A (Randles–Libersky, f32, GPU)",
        };
        let quantities = [
            correction,
            "density (f32, GPU)",
            "smoothing length (eqs 60–61 found no fixed point, f32, GPU)",
            "prime-space hull (eq 63: more edges than the device keeps, or a wrap that \
             rounding kept open, f32, GPU; run it on the CPU with --backend cpu)",
        ];
        for (k, quantity) in quantities.into_iter().enumerate() {
            if s[k] != u32::MAX {
                let i = s[k] as usize;
                return Err(BlowUp::at::<D>(&self.reference.x0, i, quantity, 0.0));
            }
        }
        Ok(())
    }

    fn check_state(&self, flat: &[f32]) -> Result<(), BlowUp> {
        check_state(&self.reference.x0, &self.decode_state(flat))
    }

    /// The builds the device ran so far (those its drift checks asked for, and one at the
    /// start of each batch) times one build timed alone, once ([`GpuUl::time_rebuild`]): the
    /// device's passes are not timed one by one inside a step, and the drift checks (one
    /// position read per particle and evaluation) are left out.
    fn neighbour_seconds(&mut self, shell: &Shell) -> Option<f64> {
        let seconds = match self.rebuild_seconds {
            Some(seconds) => seconds,
            None => {
                let seconds = self.time_rebuild(&shell.gpu);
                *self.rebuild_seconds.insert(seconds)
            }
        };
        Some(self.builds(&shell.gpu) as f64 * seconds)
    }

    fn snapshot(&mut self, shell: &Shell) -> Snapshot<'_, D> {
        let y = self.decode_state(&shell.read_state());
        let r = &self.reference;
        let mut snapshot = snapshot(&r.material, &r.x0, &r.mass, &r.body, &r.vol, y);
        if self.layout.kin.has("H") {
            let kin: Vec<f32> = shell.gpu.read(&shell.kin);
            snapshot.extra.push(ScalarField {
                name: SMOOTHING_LENGTH,
                values: self.layout.kin.read_s(&kin, "H", 0.0),
            });
        }
        snapshot
    }
}
