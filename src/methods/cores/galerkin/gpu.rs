//! The Galerkin methods on the GPU (`tl-fem`, `tl-weak-form`, `kbm`, `efg`, and `ul-fem` on
//! the current cells, [`Frame::Current`]): the passes of `shaders/galerkin/`, on the
//! points, shape functions, gather lists and smoothing weights that the host's f64 system
//! ([`TlGalerkin`]) builds once and uploads. A rate evaluation is a points pass (F, P, w ψ
//! and the rate model's rates per quadrature point) and a nodes pass (the force gathered
//! over each node's points, the boundary conditions); the weak form's smoothing is two
//! passes after each step. The engine is the [`GpuEngine`] on the family
//! [`GalerkinDevice`].

use super::updated::{MovingPoints, UlGalerkin};
use super::{GalerkinState, TlGalerkin};
use crate::boundary::Boundary;
use crate::case::Case;
use crate::core::integrate::{Buf, Evaluation};
use crate::core::neighbour::Csr;
use crate::core::quadrature::{QuadraturePoints, Rule, Shapes};
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, GpuEngine, GpuFamily, Method, Start};
use crate::gpu::context::{Gpu, GpuError, Pipeline};
use crate::gpu::layout::{Fields, GpuDim};
use crate::gpu::memory::{Counts, DeviceMemory};
use crate::gpu::parts::{self, PartLists, Split};
use crate::gpu::plastic;
use crate::gpu::profile::Scale;
use crate::gpu::program::Stepper;
use crate::gpu::reduction::{self, Reduced, Reduction};
use crate::gpu::reference::{self, DeviceReference, Extras};
use crate::gpu::shaders::{
    self, BOUNDARY, CONTACT, Compose, Constants, EIGEN, INTEGRATE, LOADS, MECHANICS, OBJECTIVE,
    PART, PLASTIC_STORE, PLASTICITY, PRESCRIBED, REFERENCE, Source, Wgsl, source, wgsl,
};
use crate::gpu::shell::Shell;
use crate::gpu::{SetupError, check_f32_particles, check_f32_range, check_f32_run};
use crate::interaction::gpu::GpuInteractions;
use crate::methods::cores::shared::BySource;
use crate::physics::material::{Material, MaterialModel};

/// The points and nodes passes of one rate evaluation.
pub const RATES: Source = source!(
    "galerkin/galerkin.wgsl",
    [
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
        ("pair", false),
        ("reference", false),
        ("ext", false),
        ("entries", false),
        ("kin", true),
        ("d", true)
    ]
);
/// The stress at a point, which the Galerkin passes on either kernel share.
pub const STRESS: Wgsl = wgsl!("galerkin/stress.wgsl");
/// The rate model at a point (before [`STRESS`]), which the weak form's stress points share.
pub const RATE_POINT: Wgsl = wgsl!("galerkin/rate_point.wgsl");
/// A node's share of the points' stored energy, for the reduction.
const ENERGY: Wgsl = wgsl!("galerkin/galerkin_energy.wgsl");
/// The stored energy of points that move on their own, folded onto the particles, for
/// the reduction.
const FOLDED_ENERGY: Wgsl = wgsl!("galerkin/folded_energy.wgsl");
/// Energies, momenta and checks of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, ENERGY, REFERENCE, PART],
    [("y", false), ("kin", false), ("reference", false)]
);
/// Energies, momenta and checks of a state whose points move on their own.
pub const FOLDED_REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, FOLDED_ENERGY, REFERENCE, PART],
    [("y", false), ("kin", false), ("reference", false)]
);
/// The weak form's velocity smoothing.
pub const SMOOTH: Source = source!(
    "galerkin/galerkin_smooth.wgsl",
    [REFERENCE, PART, SETTLE],
    [("y", true), ("smoothed", true), ("reference", false)]
);

/// The smoothed velocities back into the state but for the prescribed components.
pub const SETTLE: Wgsl = wgsl!("galerkin/settle.wgsl");

/// The passes compiled with a Galerkin scene's constants ([`scene_constants`]).
pub const SHADERS: &[Source] = &[RATES, REDUCE, SMOOTH, CONTACT, LOADS, PRESCRIBED, INTEGRATE];

/// Where the points pass evaluates the points' functions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Frame {
    /// Once, on the reference configuration (the total-Lagrangian methods): the pairs
    /// carry ∇0N_a(X_q), the gather entries w_q ∇0N_a(X_q).
    #[default]
    Reference,
    /// On the current cells at every rate evaluation, with the rule's weight (`ul-fem`):
    /// the pairs carry the parent derivatives ∂N_a/∂ξ at the point and the reference
    /// offset X_a − X_first of the node from the point's first node, the gather entries
    /// ∂N_a/∂ξ, from which the points pass forms J_q, ∇N_a(x_q) = J_q⁻ᵀ ∂N_a/∂ξ and w_q.
    Current(Rule),
}

/// The flat buffers of a Galerkin scene of n nodes and q points: the state [u | v | ρ − ρ0
/// | S] (ρ and S at the points, rate model only), the kinematics [H = F − I | P | ψ
/// (points) | power (nodes)], the per-pair gradients ∇0N_a of the points' lists, the
/// gather lists (u32: [offsets | the point of each entry]) with their per-entry data
/// [w_q ∇0Φ_a(X_q) | w_q N_a(X_q)] (Φ_a the test functions), the smoothing weights N_b(X_a)
/// per pair and the nodes' reference fields; and the frame the points' functions are
/// evaluated in.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    pub frame: Frame,
    pub n: usize,
    pub q: usize,
    pub dim: usize,
    pub state: Fields,
    pub kin: Fields,
    pub pair: Fields,
    pub gather: Fields,
    pub entries: Fields,
    pub smooth: Fields,
    pub reference: Fields,
}

/// The sizes of the lists' buffers of a Galerkin scene, each laid out for the largest
/// part of its lists ([`Split`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ListSizes {
    /// Point–node pairs of a part of the points' lists.
    pub pairs: usize,
    /// Nodes and entries of a part of the gather lists.
    pub nodes: usize,
    pub entries: usize,
}

impl ListSizes {
    /// The lists of n nodes and `pairs` point–node pairs in one part each.
    pub fn whole(n: usize, pairs: usize) -> Self {
        Self {
            pairs,
            nodes: n,
            entries: pairs,
        }
    }
}

impl Layout {
    /// n nodes (`constrained` of them with prescribed components), q points, the lists of
    /// `lists`, `smooth_pairs` smoothing pairs.
    pub fn new(
        n: usize,
        constrained: usize,
        q: usize,
        lists: ListSizes,
        smooth_pairs: usize,
        dim: usize,
        rate: bool,
    ) -> Self {
        Self {
            frame: Frame::Reference,
            n,
            q,
            dim,
            state: Fields::new("", dim)
                .vectors("U", true, n)
                .vectors("V", true, n)
                .scalars("RHO", rate, q)
                .tensors("S", rate, q),
            kin: reduction::with_reactions(
                Fields::new("K", dim)
                    .tensors("F", true, q)
                    .tensors("P", true, q)
                    .scalars("PSI", true, q)
                    .scalars("POW", true, n),
                constrained,
            ),
            pair: pair_fields(dim, lists.pairs, Frame::Reference),
            gather: Fields::new("G", dim)
                .scalars("OFFSETS", true, lists.nodes + 1)
                .scalars("POINT", true, lists.entries),
            entries: Fields::new("E", dim)
                .vectors("WG", true, lists.entries)
                .scalars("WN", true, lists.entries),
            smooth: Fields::new("SW", dim).scalars("N", true, smooth_pairs),
            reference: reference::fields(n, constrained, dim, Extras::default()),
        }
    }

    /// The layout with the points' functions evaluated in `frame`.
    pub fn on(self, frame: Frame) -> Self {
        let pairs = self.pair.field("G").count;
        Self {
            frame,
            pair: pair_fields(self.dim, pairs, frame),
            ..self
        }
    }
}

/// The per-pair fields of `pairs` point–node pairs in `frame`: G (∇0N_a(X_q), or ∂N_a/∂ξ)
/// and, on the current cells, DX (X_a − X_first).
fn pair_fields(dim: usize, pairs: usize, frame: Frame) -> Fields {
    Fields::new("P", dim)
        .vectors("G", true, pairs)
        .vectors("DX", frame != Frame::Reference, pairs)
}

/// The compiled-in constants of a Galerkin scene.
pub fn scene_constants(case: &Case, layout: &Layout) -> Constants {
    let u = |x: usize| x as u32;
    let constants = Constants::default()
        .u32("N", u(layout.n))
        .u32("Q", u(layout.q))
        .u32("BODIES", u(case.bodies.len()))
        .material(&Material::new(&case.material))
        .u32("REST_OFF", u(layout.state.offset("RHO")));
    let constants = match layout.frame {
        Frame::Reference => constants.u32("UL", 0).f32("W_RULE", 0.0),
        Frame::Current(rule) => constants
            .u32("UL", 1)
            .f32("W_RULE", rule.weight_in(layout.dim)),
    };
    [
        &layout.state,
        &layout.kin,
        &layout.pair,
        &layout.gather,
        &layout.entries,
        &layout.smooth,
        &layout.reference,
    ]
    .into_iter()
    .fold(constants, |c, fields| fields.constants(c))
}

/// The integration points of a Galerkin method and their pairs with the nodes, from the
/// counts of a case before it is built ([`Counts`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Points {
    pub points: f64,
    pub pairs: f64,
    /// The pairs of the velocity smoothing at the nodes (0 without it).
    pub smoothing: f64,
}

impl Points {
    /// The finite elements: 2^d Gauss points in each cell, each with its 2^d corners.
    pub fn elements(counts: &Counts, dim: usize) -> Self {
        let points = f64::from(1u32 << dim) * counts.cells;
        Self {
            points,
            pairs: f64::from(1u32 << dim) * points,
            smoothing: 0.0,
        }
    }

    /// 2^d Gauss points in each cell, each with the nodes within its support.
    pub fn gauss(counts: &Counts, dim: usize) -> Self {
        Self {
            points: f64::from(1u32 << dim) * counts.cells,
            pairs: counts.gauss_pairs,
            smoothing: 0.0,
        }
    }

    /// The particles, each with the nodes within its support and itself (the smoothed
    /// integration's dilated supports, about 1.5–1.8 times as many pairs, not counted).
    pub fn nodal(counts: &Counts) -> Self {
        Self {
            points: counts.particles,
            pairs: counts.pairs + counts.particles,
            smoothing: 0.0,
        }
    }

    /// The particles and a stress point at the centre of every cell.
    pub fn stress_points(counts: &Counts) -> Self {
        let nodal = Self::nodal(counts);
        Self {
            points: nodal.points + counts.cells,
            pairs: nodal.pairs + counts.centre_pairs,
            smoothing: 0.0,
        }
    }

    /// With the velocity smoothing at the nodes (each with the nodes within its support
    /// and itself).
    pub fn smoothed(self, counts: &Counts) -> Self {
        Self {
            smoothing: counts.pairs + counts.particles,
            ..self
        }
    }
}

/// The points and nodes passes bound to a source state, a bind group a part of their
/// lists.
struct Rates {
    points: Vec<wgpu::BindGroup>,
    nodes: Vec<wgpu::BindGroup>,
}

/// The weak form's smoothing passes, bound to the state and their scratch: the smoothing
/// a part of its lists at a time, with a bind group a part.
struct SmoothPasses {
    split: Split,
    smooth: (Pipeline, Vec<wgpu::BindGroup>),
    settle: (Pipeline, wgpu::BindGroup),
}

/// The nodes' reference with V = m/ρ0, so that RHO0·V is the nodal mass, and the lists
/// of the host's shape functions in the parts of `split`.
fn upload_nodes<D: GpuDim>(gpu: &Gpu, host: &TlGalerkin<D>, split: &Split) -> DeviceReference {
    let rho0 = host.material().rho0;
    let mass_volume: Vec<f64> = host.mass().iter().map(|m| m / rho0).collect();
    DeviceReference::upload::<D>(
        gpu,
        host.reference(),
        &mass_volume,
        host.boundary(),
        (&host.shapes().csr, split),
        Extras::default(),
    )
}

/// The upload of an updated-Lagrangian host whose points move on their own (`kbm` on an
/// Eulerian kernel, `ul-weak-form`): the particles' reference with V = m/ρ0 and no lists
/// (the family's own hold the pairs), and the points' [X_q | w0_q] laid out as `pts`.
pub fn upload_moving<D: GpuDim, P: MovingPoints<D>>(
    gpu: &Gpu,
    host: &UlGalerkin<D, P>,
    points: &QuadraturePoints<D>,
    pts: &Fields,
) -> (DeviceReference, wgpu::Buffer) {
    let rho0 = host.material().rho0;
    let mass_volume: Vec<f64> = Method::mass(host).iter().map(|m| m / rho0).collect();
    let no_lists = Csr::default();
    let device = DeviceReference::upload::<D>(
        gpu,
        Method::reference(host),
        &mass_volume,
        host.boundary(),
        (&no_lists, &Split::whole(&no_lists)),
        Extras::default(),
    );
    let mut flat = pts.zeroed();
    pts.write_v::<D>(&mut flat, "X", &points.x0);
    pts.write_s(&mut flat, "W", &points.weight, 0.0);
    (device, gpu.storage("points", &flat))
}

/// The parts of a scene's lists, each split on its own ([`crate::gpu::parts`]).
struct Splits {
    points: Split,
    gather: Split,
    /// The weak form's smoothing lists, if it smooths.
    smooth: Option<Split>,
}

/// The layout of the host's scene, whose lists' buffers each hold a part of the points'
/// lists, of the gather lists and of the smoothing lists, in parts that fit the binding
/// limit of `gpu`.
fn layout_of<D: GpuDim>(
    gpu: &Gpu,
    host: &TlGalerkin<D>,
    frame: Frame,
) -> Result<(Layout, Splits), GpuError> {
    let per_pair = pair_fields(D::N, 1, frame).bytes();
    let points_split = Split::fitting(gpu, &host.shapes().csr, per_pair)?;
    let gather_split = Split::fitting(gpu, &gather_csr(host), (4 * (D::N + 1)) as u64)?;
    let smooth = (host.smoothing())
        .map(|s| Split::fitting(gpu, &s.csr, 4))
        .transpose()?;
    let lists = ListSizes {
        pairs: points_split.capacity(),
        nodes: (gather_split.parts.iter())
            .map(|p| p.rows)
            .max()
            .unwrap_or(0),
        entries: gather_split.capacity(),
    };
    let layout = Layout::new(
        host.reference().len(),
        host.boundary().constrained.len(),
        host.points().len(),
        lists,
        smooth.as_ref().map_or(0, Split::capacity),
        D::N,
        host.material().model.is_rate_based(),
    )
    .on(frame);
    let splits = Splits {
        points: points_split,
        gather: gather_split,
        smooth,
    };
    Ok((layout, splits))
}

/// The per-pair vectors of the host's points' lists in `frame`: ∇0N_a(X_q), or ∂N_a/∂ξ at
/// the point.
fn pair_gradients<D: GpuDim>(host: &TlGalerkin<D>, frame: Frame) -> Vec<D::V> {
    let shapes = host.shapes();
    match frame {
        Frame::Reference => shapes.grad.clone(),
        Frame::Current(_) => (0..shapes.len())
            .flat_map(|q| {
                let corners = shapes.csr.range(q).len();
                (0..corners).map(move |c| host.points().parent_gradient(q, c))
            })
            .collect(),
    }
}

/// The per-pair vectors `grad` ([`pair_gradients`]) of each part of `split` of the
/// points' lists, and on the current cells the reference offsets X_a − X_first (f64
/// differences, so that a small cell keeps its digits in f32).
fn pair_buffers<D: GpuDim>(
    gpu: &Gpu,
    layout: &Layout,
    host: &TlGalerkin<D>,
    grad: &[D::V],
    split: &Split,
) -> Vec<wgpu::Buffer> {
    let whole = layout.pair.resized(grad.len());
    let mut flat = whole.zeroed();
    whole.write_v::<D>(&mut flat, "G", grad);
    if whole.has("DX") {
        let (csr, x0) = (&host.shapes().csr, host.reference());
        let offsets: Vec<D::V> = (0..csr.offsets.len() - 1)
            .flat_map(|q| {
                let ids = &csr.ids[csr.range(q)];
                let first = x0[ids[0] as usize];
                ids.iter().map(move |&a| x0[a as usize] - first)
            })
            .collect();
        whole.write_v::<D>(&mut flat, "DX", &offsets);
    }
    (split.parts.iter())
        .map(|p| layout.pair.items_of(&whole, &flat, p.start, p.pairs))
        .map(|data| gpu.storage("per-pair shape functions", &data))
        .collect()
}

/// The gather lists of the host as neighbour lists: node a's entries, each naming its
/// point.
fn gather_csr<D: GpuDim>(host: &TlGalerkin<D>) -> Csr {
    let gather = host.gather();
    Csr {
        offsets: gather.offsets.clone(),
        ids: gather.point.clone(),
    }
}

/// A part of the gather lists on the device: its lists (offsets from its first entry,
/// then the point of every entry), its entries' weighted test gradients w_q ∇Φ_a(X_q)
/// (the parent derivatives ∂N_a/∂ξ in [`Frame::Current`]) and values w_q N_a(X_q) of the
/// host's shape functions, and its uniform `part`.
struct GatherPart {
    lists: wgpu::Buffer,
    entries: wgpu::Buffer,
    part: wgpu::Buffer,
}

/// The parts of `split` of the gather lists, with the per-pair vectors `grad` of the
/// points' lists in `layout.frame`.
fn gather_buffers<D: GpuDim>(
    gpu: &Gpu,
    layout: &Layout,
    host: &TlGalerkin<D>,
    grad: &[D::V],
    split: &Split,
) -> Vec<GatherPart> {
    let (shapes, points, gather) = (host.shapes(), host.points(), host.gather());
    let (weighted, values): (Vec<D::V>, Vec<f64>) = (0..gather.point.len())
        .map(|e| {
            let (q, p) = (gather.point[e] as usize, gather.pair[e] as usize);
            let w = points.weight[q];
            let test = match layout.frame {
                Frame::Reference => shapes.test_gradient(p) * w,
                Frame::Current(_) => grad[p],
            };
            (test, w * shapes.n[p])
        })
        .unzip();
    let whole = layout.entries.resized(gather.point.len());
    let mut flat = whole.zeroed();
    whole.write_v::<D>(&mut flat, "WG", &weighted);
    whole.write_s(&mut flat, "WN", &values, 0.0);
    (split.parts.iter())
        .map(|p| {
            let mut lists = vec![0u32; layout.gather.len()];
            let offsets = &gather.offsets[p.first..=p.first + p.rows];
            for (to, &o) in lists.iter_mut().zip(offsets) {
                *to = (o - p.start) as u32;
            }
            let at = layout.gather.offset("POINT");
            lists[at..at + p.pairs].copy_from_slice(&gather.point[p.start..p.start + p.pairs]);
            let entries = layout.entries.items_of(&whole, &flat, p.start, p.pairs);
            GatherPart {
                lists: gpu.storage("gather lists", &lists),
                entries: gpu.storage("gather entries", &entries),
                part: parts::uniform(gpu, p.first, p.rows),
            }
        })
        .collect()
}

impl SmoothPasses {
    /// The buffers [`Self::new`] makes for `n` nodes with the smoothing of `layout`.
    fn memory(m: &mut DeviceMemory, layout: &Layout, n: usize, pairs: usize) {
        m.words("smoothing offsets", (n + 1) as f64);
        m.words("smoothing ids", pairs as f64);
        m.fields("smoothing weights", &layout.smooth);
        m.words("smoothed velocities", (n * layout.dim) as f64);
    }

    /// The passes of the velocity smoothing with the functions `s` at the nodes, on the
    /// parts of `split` of their lists, bound to the state `y` and the nodes' `reference`.
    fn new<D: GpuDim>(
        gpu: &Gpu,
        layout: &Layout,
        (s, split): (&Shapes<D>, Split),
        compose: Compose<'_>,
        reference: &wgpu::Buffer,
        y: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        let whole = layout.smooth.resized(s.csr.pair_count());
        let mut w = whole.zeroed();
        whole.write_s(&mut w, "N", &s.n, 0.0);
        let source = compose(&SMOOTH);
        let smooth = gpu.pipeline("smooth velocities", &source, "smooth_velocities")?;
        let settle = gpu.pipeline("settle", &source, "settle")?;
        let smoothed = gpu.zeroed("smoothed velocities", (layout.n * D::N * 4) as u64);
        let table = [("reference", reference), ("y", y), ("smoothed", &smoothed)];
        let lists = PartLists::upload(gpu, &s.csr, &split);
        let binds = (split.parts.iter().zip(&lists))
            .map(|(p, part)| {
                let weights = layout.smooth.items_of(&whole, &w, p.start, p.pairs);
                let weights = gpu.storage("smoothing weights", &weights);
                let [offsets, ids, uniform] = part.table().map(|(_, b)| b);
                let names = ["smooth_offsets", "smooth_ids", "part", "smooth_weights"];
                let bound: Vec<(&str, &wgpu::Buffer)> = (table.iter().copied())
                    .chain(names.into_iter().zip([offsets, ids, uniform, &weights]))
                    .collect();
                gpu.bind(&smooth, &bound)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let settle_bind = gpu.bind(&settle, &table)?;
        Ok(Self {
            split,
            smooth: (smooth, binds),
            settle: (settle, settle_bind),
        })
    }
}

/// Value of `status[0]` when no point failed.
const STATUS_OK: u32 = u32::MAX;

/// A Galerkin system resident on the GPU.
pub type GpuGalerkin<D> = GpuEngine<D, GalerkinDevice<D>>;

/// The Galerkin family on the device: the host's system, the buffers and
/// the passes. The shell's checkpoints hold the plastic history too. The balance's terms
/// the engine does not book besides the work of supports and loads: the velocity
/// smoothing's dissipation; the plastic work, committed on the device; contact's, which
/// `ext` adds to the loads' power.
pub struct GalerkinDevice<D: GpuDim> {
    /// The host's f64 system the device's set-up was uploaded from; outputs are computed
    /// from the state read back.
    host: TlGalerkin<D>,
    layout: Layout,
    /// The parts of the points' lists and of the gather lists ([`crate::gpu::parts`]).
    points_split: Split,
    gather_split: Split,
    status: wgpu::Buffer,
    points: Pipeline,
    nodes: Pipeline,
    /// Rate evaluations of the states in `Y` and in `Stage`.
    rates: BySource<Rates>,
    /// The points pass on `Y` writing its rates into `Acc` (kinematics for a reduction
    /// without touching the integrator's rates).
    points_y: Vec<wgpu::BindGroup>,
    smooth: Option<SmoothPasses>,
    /// The points' plastic history (plasticity.wgsl; 13 floats of a dummy for the elastic
    /// models).
    hist: wgpu::Buffer,
    /// The commit of the plastic history before every step (`commit` of galerkin.wgsl).
    commit: Option<(Pipeline, Vec<wgpu::BindGroup>)>,
}

impl<D: GpuDim> GpuGalerkin<D> {
    /// The buffers [`Self::in_frame`] makes for `case` on `counts` with the integration
    /// `points` in `frame`, from the same layout (the constrained nodes' reaction slots, a
    /// surface's few words each, left out).
    pub fn memory(case: &Case, counts: &Counts, points: &Points, frame: Frame) -> DeviceMemory {
        DeviceMemory::of(counts, |m| {
            let n = counts.n();
            let (q, pairs) = (Counts::whole(points.points), Counts::whole(points.pairs));
            let smoothing = Counts::whole(points.smoothing);
            let rate = case.material.model.is_rate_based();
            let lists = ListSizes::whole(n, pairs);
            let layout = Layout::new(n, 0, q, lists, smoothing, D::N, rate).on(frame);
            DeviceReference::memory(m, &layout.reference, n, D::N, q, pairs);
            m.fields("per-pair shape functions", &layout.pair);
            m.fields("gather lists", &layout.gather);
            m.fields("gather entries", &layout.entries);
            m.words("status", 1.0);
            m.fields("kinematics", &layout.kin);
            let plastic = case.material.model == MaterialModel::VonMisesPlastic;
            m.words("plastic history", plastic::words(plastic, q) as f64);
            Stepper::memory(m, case.method.integrator, layout.state.len());
            if smoothing > 0 {
                SmoothPasses::memory(m, &layout, n, smoothing);
            }
            Reduction::memory(m, n);
            GpuInteractions::memory(m, case, n, D::N);
        })
    }

    /// Builds the host system of the case and uploads it with the initial state, its
    /// points' functions evaluated once on the reference configuration.
    pub fn new(
        case: &Case,
        spec: &(dyn super::TlSystem<D> + 'static),
        gpu: Gpu,
    ) -> Result<Self, SetupError> {
        Self::in_frame(case, spec, Frame::Reference, gpu)
    }

    /// Builds the host system of the case and uploads it with the initial state, its
    /// points' functions evaluated in `frame`: [`Frame::Current`] takes the host's cells
    /// for elements whose Gauss points follow the current node positions (`ul-fem`).
    pub fn in_frame(
        case: &Case,
        spec: &(dyn super::TlSystem<D> + 'static),
        frame: Frame,
        gpu: Gpu,
    ) -> Result<Self, SetupError> {
        let host: TlGalerkin<D> = crate::reference::build_method(case, spec)?;
        check_f32_run(case, host.boundary())?;
        let y0_host = host.initial_state();
        check_f32_particles::<D>(case, host.reference(), &y0_host.u, &y0_host.v, host.body())?;
        let q = host.points().len();
        let smoothing = host.smoothing();
        let (layout, splits) = layout_of(&gpu, &host, frame)?;
        let (points_split, gather_split) = (splits.points, splits.gather);
        let constants = scene_constants(case, &layout);
        check_f32_range(case, &constants)?;
        gpu.check_size("kinematics buffer", layout.kin.bytes())?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);

        let device = upload_nodes(&gpu, &host, &points_split);
        let grad = pair_gradients(&host, frame);
        let pair = pair_buffers::<D>(&gpu, &layout, &host, &grad, &points_split);
        let gather = gather_buffers(&gpu, &layout, &host, &grad, &gather_split);
        let status = gpu.storage("status", &[STATUS_OK]);
        let kin = gpu.zeroed("kinematics", layout.kin.bytes());
        let plastic = host.plastic().is_some();
        let hist = plastic::upload(&gpu, "plastic history", plastic, q);

        let start = Start {
            gpu: &gpu,
            compose: &compose,
            device: &device,
        };
        let (stepper, interactions) = start.from_motion(
            case.method.integrator,
            (&layout.state, "RHO"),
            (&y0_host.u, &y0_host.v),
            host.interactions(),
            host.boundary(),
        )?;

        let rates_source = compose(&RATES);
        let points_pipeline = gpu.pipeline("galerkin points", &rates_source, "points")?;
        let nodes_pipeline = gpu.pipeline("galerkin nodes", &rates_source, "nodes")?;
        // The buffers of the passes on the state y and the rates d, with part k of the
        // points' lists or of the gather lists.
        let table = |y, d| -> Vec<(&str, &wgpu::Buffer)> {
            vec![
                ("reference", &device.reference),
                ("y", y),
                ("kin", &kin),
                ("d", d),
                ("status", &status),
                ("ext", interactions.ext()),
                ("hist", &hist),
            ]
        };
        let points_table = |k: usize, y, d| {
            let t = [("pair", &pair[k])]
                .into_iter()
                .chain(device.lists[k].table());
            [table(y, d), t.collect()].concat()
        };
        let nodes_table = |k: usize, y, d| {
            let g = &gather[k];
            let t = [
                ("gather", &g.lists),
                ("entries", &g.entries),
                ("part", &g.part),
            ];
            [table(y, d), t.to_vec()].concat()
        };
        let bind_points = |pipeline: &Pipeline, y, d| -> Result<Vec<_>, GpuError> {
            (0..pair.len())
                .map(|k| gpu.bind(pipeline, &points_table(k, y, d)))
                .collect()
        };
        let rates = BySource::bind(&stepper, |y, d| -> Result<Rates, GpuError> {
            Ok(Rates {
                points: bind_points(&points_pipeline, y, d)?,
                nodes: (0..gather.len())
                    .map(|k| gpu.bind(&nodes_pipeline, &nodes_table(k, y, d)))
                    .collect::<Result<_, GpuError>>()?,
            })
        })?;
        let (y, rates_d) = (stepper.buffer(Buf::Y), stepper.buffer(Buf::Rates));
        let commit = plastic
            .then(|| -> Result<_, GpuError> {
                let pipeline = gpu.pipeline("galerkin plastic commit", &rates_source, "commit")?;
                let binds = bind_points(&pipeline, y, rates_d)?;
                Ok((pipeline, binds))
            })
            .transpose()?;
        let points_y = bind_points(&points_pipeline, y, stepper.buffer(Buf::Acc))?;
        let nodes_y = (0..gather.len()).map(|k| nodes_table(k, y, rates_d));
        let reduce = compose(&REDUCE);
        let reduction = Reduction::by_part(&gpu, &reduce, &gather_split, nodes_y.collect())?;
        let smooth = (smoothing.zip(splits.smooth))
            .map(|s| SmoothPasses::new(&gpu, &layout, s, &compose, &device.reference, y))
            .transpose()?;
        let unsmoothed = smooth.is_none();
        let unbooked = Booked {
            dissipated: unsmoothed.then_some(0.0),
            plastic_work: (!plastic).then_some(0.0),
            contact_energy: case.contact.is_none().then_some(0.0),
            ..Booked::default()
        };
        let shell = Shell::new(gpu, stepper, reduction, kin, &layout.kin, unbooked)
            .save_also("plastic history", &hist);
        let family = GalerkinDevice {
            host,
            layout,
            points_split,
            gather_split,
            status,
            points: points_pipeline,
            nodes: nodes_pipeline,
            rates,
            points_y,
            smooth,
            hist,
            commit,
        };
        Ok(Self::assemble(shell, interactions, family))
    }
}

impl<D: GpuDim> GalerkinDevice<D> {
    /// Records one rate evaluation: the points and nodes passes on `rates`.
    fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, rates: &Rates) {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        (self.points_split).dispatch(gpu, &mut pass, &self.points, &rates.points);
        (self.gather_split).dispatch(gpu, &mut pass, &self.nodes, &rates.nodes);
    }

    /// Decodes a flat state (`rho0` = ρ0: the density is stored as ρ − ρ0) or rate buffer
    /// (`rho0` = 0).
    fn decode(&self, flat: &[f32], rho0: f64) -> GalerkinState<D> {
        let l = &self.layout.state;
        GalerkinState {
            u: l.read_v::<D>(flat, "U"),
            v: l.read_v::<D>(flat, "V"),
            rho: l.read_s(flat, "RHO", rho0),
            s: l.read_t::<D>(flat, "S", D::zero_t()),
        }
    }
}

impl<D: GpuDim> GpuGalerkin<D> {
    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> GalerkinState<D> {
        let rho0 = self.family.host.material().rho0;
        self.family.decode(&self.shell.read_state(), rho0)
    }

    /// Replaces the state (to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &GalerkinState<D>) {
        let l = &self.family.layout.state;
        let mut flat = l.zeroed();
        l.write_v::<D>(&mut flat, "U", &y.u);
        l.write_v::<D>(&mut flat, "V", &y.v);
        l.write_s(&mut flat, "RHO", &y.rho, self.family.host.material().rho0);
        l.write_t::<D>(&mut flat, "S", &y.s, D::zero_t());
        self.shell.set_state(&flat);
    }

    /// The rates of a given state, read back, and the force tensor at every point: P_q,
    /// or w_q σ_q J_q⁻ᵀ in [`Frame::Current`].
    pub fn rates(&mut self, y: &GalerkinState<D>) -> (GalerkinState<D>, Vec<D::T>) {
        self.set_state(y);
        let gpu = self.gpu();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        self.family
            .record(gpu, &mut encoder, self.family.rates.on_y());
        gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = gpu.read(self.shell.stepper.buffer(Buf::Rates));
        let kin: Vec<f32> = gpu.read(&self.shell.kin);
        let p = self.family.layout.kin.read_t::<D>(&kin, "P", D::zero_t());
        (self.family.decode(&d, 0.0), p)
    }

    /// The host's system, which the device's set-up came from.
    pub fn host(&self) -> &TlGalerkin<D> {
        &self.family.host
    }

    /// The parts the points' lists and the gather lists are split into.
    pub fn splits(&self) -> (&Split, &Split) {
        (&self.family.points_split, &self.family.gather_split)
    }

    /// The parts the weak form's smoothing lists are split into, if it smooths.
    pub fn smoothing_split(&self) -> Option<&Split> {
        self.family.smooth.as_ref().map(|s| &s.split)
    }
}

impl<D: GpuDim> GpuFamily<D> for GalerkinDevice<D> {
    fn reference(&self) -> &[D::V] {
        self.host.reference()
    }

    fn boundary(&self) -> &Boundary<D> {
        self.host.boundary()
    }

    fn scale(&self, _gpu: &Gpu) -> Scale {
        Scale {
            pairs: self.host.shapes().csr.pair_count() as u64,
            indirect: None,
        }
    }

    fn record_rates(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation) {
        self.record(gpu, encoder, self.rates.of(e));
    }

    /// The step the plastic history's commits take.
    fn begin_batch(
        &mut self,
        gpu: &Gpu,
        _stepper: &Stepper,
        _encoder: &mut wgpu::CommandEncoder,
        dt: f64,
        _steps: u32,
    ) {
        plastic::set_step(gpu, &self.hist, dt);
    }

    /// The commit of the plastic history.
    fn begin_step(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        if let Some((pipeline, binds)) = &self.commit {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            (self.points_split).dispatch(gpu, &mut pass, pipeline, binds);
        }
    }

    /// With the weak form's smoothing.
    fn ends_steps(&self) -> bool {
        self.smooth.is_some()
    }

    /// The weak form's velocity smoothing.
    fn end_step(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        if let Some(s) = &self.smooth {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            s.split.dispatch(gpu, &mut pass, &s.smooth.0, &s.smooth.1);
            let (pipeline, bind) = &s.settle;
            gpu.dispatch(&mut pass, pipeline, bind, self.layout.n as u32);
        }
    }

    /// The points pass on the current state (its kinematics).
    fn before_reduction(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>) {
        (self.points_split).dispatch(gpu, pass, &self.points, &self.points_y);
    }

    fn signal_speed(&self, reduced: &Reduced) -> f64 {
        self.host.material().p_wave_speed() + reduced.max_speed
    }

    /// The first point whose points pass failed (det F ≤ 0, det J ≤ 0 of an inverted
    /// element in [`Frame::Current`], or NaN) so far.
    fn flagged(&self, gpu: &Gpu) -> Result<(), BlowUp> {
        let s: Vec<u32> = gpu.read(&self.status);
        if s[0] == STATUS_OK {
            return Ok(());
        }
        let q = s[0] as usize;
        let node = self.host.shapes().strongest_node(q);
        let quantity = match self.layout.frame {
            Frame::Reference => "det F",
            Frame::Current(_) => "det J (an inverted element)",
        };
        Err(BlowUp::at::<D>(
            self.host.reference(),
            node,
            &format!("{quantity} (f32, GPU) at quadrature point {q} next to it"),
            0.0,
        ))
    }

    fn check_state(&self, flat: &[f32]) -> Result<(), BlowUp> {
        let y = self.decode(flat, self.host.material().rho0);
        self.host.check_finite(&y)
    }

    /// The host's outputs (nodal F and σ, Σ_q w_q ψ_q in f64) of the state and the plastic
    /// history read back.
    fn snapshot(&mut self, shell: &Shell) -> Snapshot<'_, D> {
        let y = self.decode(&shell.read_state(), self.host.material().rho0);
        if let Some(history) = self.host.plastic_mut() {
            history.read_f32(&shell.gpu.read::<f32>(&self.hist));
        }
        self.host.snapshot(&y)
    }
}
