//! What the Galerkin methods share (seed 000 §2.6, §5.6, §5.7 and the FEM references;
//! seed 001 §4–5): nodes (the particles) carry u and v, quadrature points carry the stress,
//! and the weak form with a lumped mass gives each node a force gathered over its points
//! ([`crate::core::quadrature::Gather`], [`gather_accelerations`]), so that every node writes
//! only its own rate.
//!
//! - [`TlGalerkin`], total-Lagrangian (`tl-fem`, `tl-weak-form`, `kbm`, `efg`): ∫ δu·ρ0 ü
//!   dΩ0 = −∫ ∇0δu : P dΩ0 (seed 000 eq 156, seed 001 eq 44), F_q = I + Σ_a u_a ⊗
//!   ∇0N_a(X_q) and P_q from the material at fixed points with shape functions computed
//!   once, m_a ü_a = −Σ_q w_q P_q ∇0Φ_a(X_q) with the test functions Φ_a (the trial
//!   functions N_a but for the Petrov–Galerkin `kbm`);
//! - [`updated::UlGalerkin`], updated-Lagrangian (`ul-fem`, `ul-weak-form`): ∫ δv·ρ v̇ dΩ =
//!   −∫ ∇δv : σ dΩ (eq 117) with shape functions and weights recomputed on the current
//!   configuration at every rate evaluation, m_a v̇_a = −Σ_q w_q σ_q ∇N_a(x_q).
//!
//! The methods differ in their points (Gauss points of cells, the particles themselves,
//! or the particles with stress points), their shape functions (bilinear elements,
//! reproducing-kernel, moving least-squares or Krongauz–Belytschko functions) and in what
//! follows a step (the weak forms' velocity smoothing, [`smooth_velocities`]). What their
//! `MethodFamily` hooks share is here too: the total-Lagrangian ones' [`FEATURES`], the
//! frame of their plan ([`tl_plan`]) and their engines ([`cpu_engine`], [`gpu_engine`]);
//! the updated-Lagrangian ones' state text ([`updated::state`]).

pub mod updated;

#[cfg(feature = "gpu")]
pub mod gpu;

mod contracts;

pub use contracts::TlSystem;

use crate::boundary::{Boundary, NodalForces, OnPatches, SurfacePoint};
use crate::case::{Case, CaseError, Shape};
use crate::core::integrate::OdeSystem;
use crate::core::neighbour::Csr;
use crate::core::parallel::MIN_CHUNK;
use crate::core::quadrature::{
    Cells, Family, Gather, QuadratureError, QuadraturePoints, Shapes, SmoothingCells,
};
use crate::core::sum::{Exact, par_sum};
use crate::core::tensor::Dim;
use crate::diagnostics::observe::{Quadrature, ScalarField, Snapshot};
use crate::distributed::Local;
use crate::engine::ranks::{RankStart, Whole};
use crate::engine::{
    BlowUp, BoundaryWork, Engine, EngineDim, Method, Sizes, Traffic, check_motion,
};
use crate::interaction::Interactions;
use crate::methods::cores::family::{Feature, Plan, RankBuild, cfl_step};
use crate::methods::cores::particles::{Surroundings, check_stresses};
use crate::methods::cores::shared::engine_on_rank;
use crate::methods::cores::tl::displacement_rates;
use crate::physics::material::{Material, MaterialModel, stress_fields};
use crate::physics::plasticity::{History, Returned, from_mat3};
use crate::reference::Reference;
use crate::statics::explicit::{AtRest, ClosedForm};
use crate::statics::sparse::BlockPattern;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The nodal masses of a Galerkin method (`method.mass`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mass {
    /// The row sums of the consistent mass matrix, m_a = Σ_q w_q ρ0 N_a(X_q): the body's
    /// mass exactly, a quarter cell's at a corner node. Every particle must be a node of
    /// some point.
    #[default]
    RowSum,
    /// The particle's own mass ρ0 V_a, as the seed-000 reference code has it for every
    /// node (eq 163); a lattice body then weighs more than its volume holds (the strip
    /// 1.1025 kg/m instead of 1).
    Particle,
}

/// The CPU engine of a total-Lagrangian Galerkin method (`MethodFamily::cpu_engine` of
/// `tl-fem`, `tl-weak-form`, `kbm` and `efg`): the time stepper, or the static solve.
pub fn cpu_engine<D: EngineDim>(
    case: &Case,
    spec: &(dyn TlSystem<D> + 'static),
) -> Result<Box<dyn Engine<D>>, CaseError> {
    crate::statics::explicit::cpu_engine::<D, TlGalerkin<D>>(case, spec)
}

/// The GPU engine of a total-Lagrangian Galerkin method.
#[cfg(feature = "gpu")]
pub fn gpu_engine<D: EngineDim>(
    case: &Case,
    spec: &(dyn TlSystem<D> + 'static),
    gpu: crate::gpu::Gpu,
) -> Result<Box<dyn Engine<D>>, crate::gpu::SetupError> {
    Ok(Box::new(gpu::GpuGalerkin::<D>::new(case, spec, gpu)?))
}

/// The engine of one rank of a distributed run of a total-Lagrangian Galerkin method:
/// the system built on the whole run (every rank builds the same), split along its
/// [`TlGalerkin::node_graph`], then [`TlGalerkin::restrict`]ed to the rank's nodes. The
/// rate model (ρ and S at the points) and plasticity (a history at the points) are
/// refused: a rank exchanges the nodes' rows only.
pub fn rank_engine<D: EngineDim>(
    case: &Case,
    spec: &(dyn TlSystem<D> + 'static),
    reference: Reference<D>,
    start: RankStart<D>,
) -> RankBuild<D> {
    let system = spec.system(case, reference)?;
    let model = system.material.model;
    if model.is_rate_based() || system.plastic.is_some() {
        return Err(case.invalid(
            "material.model",
            format!(
                "`{}` with the {model:?} model keeps its state at the quadrature points, \
                 which a rank of a distributed run does not exchange yet; run it on one \
                 rank, or with a hyperelastic model",
                case.method.name
            ),
        ));
    }
    let whole = Whole {
        x0: system.x0.clone(),
        mass: system.mass.clone(),
        body: system.body.clone(),
        constrained: system.boundary().constrained.clone(),
        cells: system.cells.corners.clone(),
    };
    let rank = start.split(&system.node_graph(), whole, &case.file)?;
    let part = system.restrict(&rank.local);
    engine_on_rank(case, Ok(part), rank)
}

/// The engine hooks of the [`MethodFamily`](crate::methods::cores::family::MethodFamily) implementation
/// of a total-Lagrangian Galerkin method whose engines do not depend on its keys (`tl-fem`,
/// `tl-weak-form`, `efg`): [`cpu_engine`], [`rank_engine`] and [`gpu_engine`].
macro_rules! tl_galerkin_engines {
    () => {
        fn cpu_engine<D: $crate::engine::EngineDim>(
            &self,
            case: &$crate::case::Case,
        ) -> $crate::methods::cores::family::CpuBuild<D> {
            $crate::methods::cores::galerkin::cpu_engine(case, self)
        }

        fn rank_engine<D: $crate::engine::EngineDim>(
            &self,
            case: &$crate::case::Case,
            reference: $crate::reference::Reference<D>,
            start: $crate::engine::ranks::RankStart<D>,
        ) -> $crate::methods::cores::family::RankBuild<D> {
            $crate::methods::cores::galerkin::rank_engine(case, self, reference, start)
        }

        #[cfg(feature = "gpu")]
        fn gpu_engine<D: $crate::engine::EngineDim>(
            &self,
            case: &$crate::case::Case,
            gpu: $crate::gpu::Gpu,
        ) -> $crate::methods::cores::family::GpuBuild<D> {
            $crate::methods::cores::galerkin::gpu_engine(case, self, gpu)
        }
    };
}
pub(crate) use tl_galerkin_engines;

/// The scene features of the total-Lagrangian Galerkin methods (`tl-fem`, `tl-weak-form`,
/// `kbm`, `efg`).
pub const FEATURES: &[Feature] = &[
    Feature::Contact,
    Feature::Plasticity,
    Feature::StaticSolve,
    Feature::InitialDisplacement,
];

/// The `--explain` plan of a total-Lagrangian Galerkin method on the material of `case`:
/// what it builds `once`, its `rates` and the quantities `checked`, and what it leaves
/// out, `left_out` followed by the rates the material's model does without.
pub fn tl_plan(
    case: &Case,
    once: String,
    rates: String,
    checked: &'static str,
    mut left_out: Vec<&'static str>,
) -> Plan {
    let mat = Material::new(&case.material);
    left_out.push(if mat.model.is_rate_based() {
        "P(F) evaluation"
    } else {
        "continuity and stress rates"
    });
    Plan {
        once,
        state: tl_state(&mat),
        cfl_step: cfl_step(&mat),
        rates,
        checked,
        check_note: String::new(),
        left_out,
    }
}

/// The state of a total-Lagrangian Galerkin method with material `mat`, for `--explain`.
fn tl_state(mat: &Material) -> String {
    if mat.model.is_rate_based() {
        format!(
            "u, v at the nodes; ρ, S at the quadrature points (rate model: {})",
            mat.rate_model()
        )
    } else if mat.model == MaterialModel::VonMisesPlastic {
        "u, v at the nodes; the plastic history C_p⁻¹, ε_p at the quadrature points, committed \
         once per step from the state at its start"
            .into()
    } else {
        format!(
            "u, v at the nodes (state model {:?}: no ρ or S integrated)",
            mat.model
        )
    }
}

/// The particle mass, as a serde default.
pub fn particle_mass() -> Mass {
    Mass::Particle
}

impl Mass {
    /// The rule as case files name it.
    pub fn name(self) -> &'static str {
        match self {
            Self::RowSum => "row-sum",
            Self::Particle => "particle",
        }
    }
}

/// The integrated state: u and v at the nodes; ρ and S at the quadrature points (rate
/// model only, empty otherwise): the fields of the total-Lagrangian state.
pub type GalerkinState<D> = crate::methods::cores::tl::TlState<D>;

/// The particles' own reproducing-kernel functions on their reference positions, N_j(X_i)
/// = V_j Ψ_j(X_i) over the particles of i's body within the kernel's support, i itself
/// included: what the weak form smooths its velocities with after each step
/// ([`smooth_velocities`]).
pub fn smoothing_shapes<D: Dim>(reference: &Reference<D>) -> Result<Shapes<D>, QuadratureError> {
    Shapes::reproducing(
        &reference.x0,
        &reference.body,
        &reference.x0,
        &reference.vol,
        &reference.body,
        &reference.kernel,
    )
}

/// The smoothing cells of stabilised conforming nodal integration (`integration = "scni"`
/// of `efg` and `kbm`): every particle's Δx square (cube) clipped to its body's box. The
/// cells must tile the body the case names, so only boxes without holes take them; any
/// other geometry is refused naming its key (`key` names the integration key).
pub fn smoothing_cells<D: Dim>(
    case: &Case,
    reference: &Reference<D>,
    key: &str,
) -> Result<SmoothingCells, CaseError> {
    let mut boxes = Vec::with_capacity(case.bodies.len());
    for (b, spec) in case.bodies.iter().enumerate() {
        let refuse = |at: String, what: &str| {
            Err(case.invalid(
                at,
                format!(
                    "{key} = \"scni\" smooths the gradients over the Δx cells of a box's \
                     lattice, and body `{}` {what}; use a box (`shape = \"box\"`) without \
                     holes, or another {key}",
                    spec.name
                ),
            ))
        };
        if !spec.holes.is_empty() {
            return refuse(format!("body.{b}.holes"), "has holes");
        }
        match (&spec.geometry, spec.geometry.extent(D::N)) {
            (Shape::Box { .. }, Some(extent)) => boxes.push(extent),
            _ => return refuse(format!("body.{b}.geometry"), "is not a box"),
        }
    }
    Ok(SmoothingCells::clipped::<D>(
        &reference.x0,
        &reference.body,
        case.spacing,
        &boxes,
    ))
}

/// The velocity smoothing after each step of the reproducing-kernel weak forms (seed 000
/// §5.6 and §5.7, the "virtual to actual" conversion): v_i ← Σ_j N_j(x_i) v_j =
/// Σ_j V_j Ψ_j(x_i) v_j with the particles' own functions `shapes` (one point per
/// particle), then the prescribed velocities again. Returns the kinetic energy it took
/// out, ½ Σ m (|v_before|² − |v_after|²) with the nodal masses m over the `counted`
/// particles (a rank's own), which the energy balance books with the artificial
/// dissipation.
pub fn smooth_velocities<D: Dim>(
    shapes: &Shapes<D>,
    boundary: &Boundary<D>,
    mass: &[f64],
    counted: &[bool],
    v: &mut Vec<D::V>,
) -> Exact {
    let smoothed = shapes.interpolate(v);
    let mut next = smoothed;
    boundary.impose(&mut next);
    let taken = par_sum(v.len(), |i| {
        let share = 0.5 * mass[i] * (D::norm2(v[i]) - D::norm2(next[i]));
        if counted[i] { share } else { 0.0 }
    });
    *v = next;
    taken
}

/// a_a = −(1/m_a) Σ_q w_q T_q ∇Φ_a(x_q), gathered per node over its points: the internal
/// force of a Galerkin method with a stress T_q (P_q on the reference points, σ_q on the
/// current ones), point weights w_q and test functions Φ_a, divided by the lumped mass.
pub fn gather_accelerations<D: Dim>(
    gather: &Gather,
    shapes: &Shapes<D>,
    weight: &[f64],
    stress: &[D::T],
    mass: &[f64],
    a: &mut [D::V],
) {
    let test = shapes.test_gradients();
    a.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .enumerate()
        .for_each(|(node, a)| {
            let entries = gather.range(node);
            let entries = gather.point[entries.clone()]
                .iter()
                .zip(&gather.pair[entries]);
            let force = entries.fold(D::zero(), |f, (&q, &p)| {
                let q = q as usize;
                f - stress[q] * test[p as usize] * weight[q]
            });
            *a = force * (1.0 / mass[node]);
        });
}

/// A point field projected to the nodes with the lumped L2 projection
/// g_a = Σ_q w_q N_a(x_q) g_q / Σ_q w_q N_a(x_q); `empty` at a node no point reaches.
pub fn to_nodes<D: Dim, T>(
    gather: &Gather,
    shapes: &Shapes<D>,
    weight: &[f64],
    g: &[T],
    empty: T,
) -> Vec<T>
where
    T: Copy + Send + Sync + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
{
    (0..gather.offsets.len() - 1)
        .into_par_iter()
        .with_min_len(MIN_CHUNK)
        .map(|node| {
            let mut total = 0.0;
            let mut sum: Option<T> = None;
            for e in gather.range(node) {
                let q = gather.point[e] as usize;
                let w = weight[q] * shapes.n[gather.pair[e] as usize];
                total += w;
                sum = Some(sum.map_or(g[q] * w, |s| s + g[q] * w));
            }
            sum.map_or(empty, |s| s * (1.0 / total))
        })
        .collect()
}

/// σ (3×3) at the nodes from σ at the points (zero at a node no point reaches).
pub fn stress_at_nodes<D: Dim>(
    gather: &Gather,
    shapes: &Shapes<D>,
    weight: &[f64],
    sigma: Vec<[[f64; 3]; 3]>,
) -> Vec<[[f64; 3]; 3]> {
    let sigma: Vec<Tensor3> = sigma.into_iter().map(Tensor3).collect();
    to_nodes(gather, shapes, weight, &sigma, Tensor3([[0.0; 3]; 3]))
        .into_iter()
        .map(|s| s.0)
        .collect()
}

/// The first quadrature point whose ρ or S is not finite (`rho`, `s` empty without the
/// rate model), as a blow-up at `node(q)`, the node next to it.
pub fn check_points<D: Dim>(
    x0: &[D::V],
    node: impl Fn(usize) -> usize,
    rho: &[f64],
    s: &[D::T],
) -> Result<(), BlowUp> {
    check_stresses::<D>(rho, s, |q, quantity, value| {
        let what = format!("{quantity} at quadrature point {q} next to it");
        BlowUp::at::<D>(x0, node(q), &what, value)
    })
}

/// A total-Lagrangian Galerkin system on the CPU (f64, rayon).
pub struct TlGalerkin<D: Dim> {
    x0: Vec<D::V>,
    mass: Vec<f64>,
    body: Vec<u32>,
    v0: Vec<D::V>,
    /// Initial displacements.
    u0: Vec<D::V>,
    /// The cells the points lie in, shown in the frames.
    cells: Cells,
    points: QuadraturePoints<D>,
    shapes: Shapes<D>,
    gather: Gather,
    /// The particles' own functions for the velocity smoothing after each step, if any.
    smoothing: Option<Shapes<D>>,
    material: Material,
    surroundings: Surroundings<D>,
    /// The plastic history of the points (von Mises); None for the elastic models.
    plastic: Option<History>,
    /// The kinetic energy the last velocity smoothing took out.
    step_end: Exact,
    /// The nodes the sums count: all of them, or a rank's own ([`Reference::counted`]).
    counted: Vec<bool>,
    /// A rank's share of the points ([`Self::restrict`]); None on one rank.
    share: Option<PointShare>,
    /// F_q and P_q of the last rate evaluation.
    f: Vec<D::T>,
    pk1: Vec<D::T>,
}

/// The points a rank of a distributed run holds ([`TlGalerkin::restrict`]).
struct PointShare {
    /// The global index of each point.
    ids: Vec<u32>,
    /// Whether the rank holds all the point's nodes, so that F_q is the run's; the others
    /// (where the particles are points, those of the outer ghosts) take F = I.
    complete: Vec<bool>,
    /// Whether the rank counts the point, as the owner of its strongest node: in the
    /// stored energy, the det F check and the snapshot's points.
    counted: Vec<bool>,
    /// w_q of the counted points and 0 for the others: the weights of the stored energy.
    energy_weight: Vec<f64>,
}

impl<D: Dim> TlGalerkin<D> {
    /// The system on the particles of `reference` with the quadrature points of `cells`
    /// and their shape functions, nodal masses by `mass`, and a velocity smoothing after
    /// each step if given.
    pub fn new(
        case: &Case,
        mut reference: Reference<D>,
        cells: Cells,
        points: QuadraturePoints<D>,
        shapes: Shapes<D>,
        mass: Mass,
        smoothing: Option<Shapes<D>>,
    ) -> Result<Self, CaseError> {
        let gather = shapes.gather(reference.len());
        let rho0 = reference.material.rho0;
        let mass = match mass {
            Mass::Particle => reference.mass.clone(),
            Mass::RowSum => row_sums(case, &points.weight, &shapes, &gather, rho0)?,
        };
        // The shape functions of a point reach only its own body's nodes: no kernel spans
        // two bodies, whatever their distance.
        let consistent;
        let nodal: &dyn NodalForces<D> = match shapes.family {
            Some(family) => {
                consistent = ConsistentForces {
                    case,
                    family,
                    x0: &reference.x0,
                    vol: &reference.vol,
                    body: &reference.body,
                    kernel: &reference.kernel,
                };
                &consistent
            }
            None => &OnPatches,
        };
        reference.boundary.use_method(nodal, &mass)?;
        let interactions = Interactions::build(
            case,
            &reference.x0,
            &reference.body,
            nodal,
            &mass,
            Csr::default,
        )?;
        let Reference {
            x0,
            body,
            v0,
            u0,
            boundary,
            material,
            counted,
            ..
        } = reference;
        let n = points.len();
        Ok(Self {
            x0,
            mass,
            body,
            v0,
            u0,
            cells,
            points,
            shapes,
            gather,
            smoothing,
            material,
            surroundings: Surroundings::new(boundary, interactions),
            plastic: material.von_mises().map(|model| History::virgin(model, n)),
            step_end: Exact::default(),
            counted,
            share: None,
            f: vec![D::identity(); n],
            pk1: vec![D::zero_t(); n],
        })
    }

    /// The quadrature points.
    pub fn points(&self) -> &QuadraturePoints<D> {
        &self.points
    }

    /// The shape functions at the points.
    pub fn shapes(&self) -> &Shapes<D> {
        &self.shapes
    }

    /// The node-to-point gather lists.
    pub fn gather(&self) -> &Gather {
        &self.gather
    }

    /// The particles' own functions of the velocity smoothing after each step, if the
    /// method has one.
    pub fn smoothing(&self) -> Option<&Shapes<D>> {
        self.smoothing.as_ref()
    }

    /// The points' plastic history (von Mises), committed at the start of the step.
    pub fn plastic(&self) -> Option<&History> {
        self.plastic.as_ref()
    }

    /// The plastic history, for the GPU engine to replace by its own before a snapshot.
    #[cfg(feature = "gpu")]
    pub(crate) fn plastic_mut(&mut self) -> Option<&mut History> {
        self.plastic.as_mut()
    }

    /// P at every point of the last rate evaluation.
    pub fn first_piola(&self) -> &[D::T] {
        &self.pk1
    }

    pub fn material(&self) -> &Material {
        &self.material
    }

    pub fn boundary(&self) -> &Boundary<D> {
        &self.surroundings.boundary
    }

    /// The interactions, with the timed loads carried to the nodes as the constant ones.
    pub fn interactions(&self) -> &Interactions<D> {
        &self.surroundings.interactions
    }

    /// F_q and P_q at every point; ρ̇_q and Ṡ_q for the rate model.
    fn point_stresses(&mut self, y: &GalerkinState<D>, d: &mut GalerkinState<D>) {
        let mat = self.material;
        let (mut f, mut pk1) = (std::mem::take(&mut self.f), std::mem::take(&mut self.pk1));
        let each = f.par_iter_mut().zip(pk1.par_iter_mut()).enumerate();
        if mat.model.is_rate_based() {
            each.zip(d.rho.par_iter_mut().zip(d.s.par_iter_mut()))
                .with_min_len(MIN_CHUNK)
                .for_each(|((q, (f, pk1)), (rho_dot, s_dot))| {
                    *f = self.f_at(q, &y.u);
                    let f_dot = self.shapes.gradient(q, &y.v);
                    let r = mat.rate_response::<D>(*f, f_dot, y.rho[q], y.s[q]);
                    (*pk1, *rho_dot, *s_dot) = (r.pk1, r.rho_dot, r.s_dot);
                });
        } else {
            let plastic = self.plastic.as_ref();
            each.with_min_len(MIN_CHUNK).for_each(|(q, (f, pk1))| {
                *f = self.f_at(q, &y.u);
                *pk1 = match plastic {
                    Some(pl) => from_mat3::<D>(pl.returned::<D>(q, *f).p),
                    None => mat.pk1::<D>(*f),
                };
            });
        }
        (self.f, self.pk1) = (f, pk1);
    }

    /// ü_a = −(1/m_a) Σ_q w_q P_q ∇0Φ_a(X_q) (seed 000 Algorithm 6 step 4, seed 001 eq
    /// 64), gathered per node.
    fn accelerations(&self, a: &mut [D::V]) {
        let (weight, stress) = (&self.points.weight, &self.pk1);
        gather_accelerations(&self.gather, &self.shapes, weight, stress, &self.mass, a);
    }

    /// F_q = I + Σ_a u_a ⊗ ∇0N_a(X_q); I at a point whose nodes a rank does not all
    /// hold.
    fn f_at(&self, q: usize, u: &[D::V]) -> D::T {
        match &self.share {
            Some(share) if !share.complete[q] => D::identity(),
            _ => D::identity() + self.shapes.gradient(q, u),
        }
    }

    /// Whether the sums and checks count point q (a rank's share counts those of its
    /// own strongest nodes).
    fn counts_point(&self, q: usize) -> bool {
        self.share.as_ref().is_none_or(|s| s.counted[q])
    }

    /// The inadmissible point (det F NaN or ≤ 0) whose strongest node comes first, and
    /// the first such point of that node: the point one rank names on any number of
    /// ranks, as each checks the points of its own strongest nodes.
    fn first_inadmissible(&self) -> Option<BlowUp> {
        let (node, q) = (0..self.points.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .filter(|&q| {
                let det = D::det(self.f[q]);
                self.counts_point(q) && (det.is_nan() || det <= 0.0)
            })
            .map(|q| (self.shapes.strongest_node(q), q))
            .min()?;
        let id = self.share.as_ref().map_or(q, |s| s.ids[q] as usize);
        let what = format!("det F at quadrature point {id} next to it");
        Some(BlowUp::at::<D>(&self.x0, node, &what, D::det(self.f[q])))
    }

    /// F at every point of state y.
    pub fn point_f(&self, y: &GalerkinState<D>) -> Vec<D::T> {
        (0..self.points.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|q| self.f_at(q, &y.u))
            .collect()
    }

    /// The points with u^h(X_q) = Σ_a N_a(X_q) u_a of state y and F_q (`f`): all of
    /// them, or those a rank counts, with their global indices.
    fn quadrature(&self, y: &GalerkinState<D>, f: &[D::T]) -> Quadrature<D> {
        let u = self.shapes.interpolate(&y.u);
        let Some(share) = &self.share else {
            return Quadrature {
                x0: self.points.x0.clone(),
                weight: self.points.weight.clone(),
                u,
                f: f.to_vec(),
                ids: Vec::new(),
            };
        };
        let counted: Vec<usize> = (0..self.points.len())
            .filter(|&q| share.counted[q])
            .collect();
        Quadrature {
            x0: counted.iter().map(|&q| self.points.x0[q]).collect(),
            weight: counted.iter().map(|&q| self.points.weight[q]).collect(),
            u: counted.iter().map(|&q| u[q]).collect(),
            f: counted.iter().map(|&q| f[q]).collect(),
            ids: counted.iter().map(|&q| share.ids[q]).collect(),
        }
    }

    /// The graph a distributed run splits the nodes along ([`RankStart::split`]): each node's
    /// neighbours are the nodes it shares a point with, and those its velocity smoothing
    /// reads or is read by. With one layer of ghosts along it a rank holds every point of
    /// its own nodes with all the point's nodes, and every node an own node's smoothing
    /// reads.
    pub fn node_graph(&self) -> Csr {
        let n = self.x0.len();
        let smoothing = self.smoothing.as_ref().map(|s| (s, s.gather(n)));
        let (gather, csr) = (&self.gather, &self.shapes.csr);
        let rows: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|a| {
                let mut row: Vec<u32> = (gather.range(a))
                    .flat_map(|e| csr.neighbours(gather.point[e] as usize).iter().copied())
                    .collect();
                if let Some((s, by)) = &smoothing {
                    row.extend(s.csr.neighbours(a));
                    row.extend(by.range(a).map(|e| by.point[e]));
                }
                row.sort_unstable();
                row.dedup();
                row.retain(|&b| b as usize != a);
                row
            })
            .collect();
        Csr::from_rows(&rows)
    }

    /// A rank's share of the system built on the whole run: its nodes `local` (own and
    /// ghosts, with the boundary of its own); the points that reach an own node and,
    /// where the particles are points, those of all its nodes, in global order, with
    /// their functions on its nodes. With the ghosts of [`Self::node_graph`] every point
    /// of an own node has all its nodes here, and an own node gathers its points in the
    /// one-rank order: its force, mass and smoothed velocity are the one-rank run's. The
    /// interactions are the whole run's, none (contact and timed loads do not run on
    /// several ranks); the rate model and plasticity are refused before
    /// ([`rank_engine`]).
    pub fn restrict(self, local: &Local) -> Self {
        let mut at = vec![u32::MAX; self.x0.len()];
        for (i, &g) in local.ids.iter().enumerate() {
            at[g as usize] = i as u32;
        }
        let held = |g: u32| at[g as usize] != u32::MAX;
        let own = |g: u32| held(g) && local.owned[at[g as usize] as usize];
        let (csr, particles) = (&self.shapes.csr, self.points.particles);
        let keep: Vec<u32> = (0..self.points.len() as u32)
            .filter(|&q| {
                ((q as usize) < particles && held(q))
                    || csr.neighbours(q as usize).iter().any(|&a| own(a))
            })
            .collect();
        let counted: Vec<bool> = (keep.iter())
            .map(|&q| own(self.shapes.strongest_node(q as usize) as u32))
            .collect();
        let share = PointShare {
            complete: (keep.iter())
                .map(|&q| csr.neighbours(q as usize).iter().all(|&a| held(a)))
                .collect(),
            energy_weight: (keep.iter().zip(&counted))
                .map(|(&q, &c)| {
                    if c {
                        self.points.weight[q as usize]
                    } else {
                        0.0
                    }
                })
                .collect(),
            counted,
            ids: keep.clone(),
        };
        let shapes = self.shapes.restrict(&keep, &at);
        let points = self.points.restrict(&keep);
        let smoothing = (self.smoothing).map(|s| s.restrict(&local.ids, &at));
        let rows = |all: &[D::V]| local.ids.iter().map(|&g| all[g as usize]).collect();
        let boundary = self
            .surroundings
            .boundary
            .restrict(&local.ids, &local.owned);
        let q = keep.len();
        Self {
            x0: rows(&self.x0),
            mass: local.ids.iter().map(|&g| self.mass[g as usize]).collect(),
            body: local.ids.iter().map(|&g| self.body[g as usize]).collect(),
            v0: rows(&self.v0),
            u0: rows(&self.u0),
            cells: Cells::default(),
            gather: shapes.gather(local.len()),
            points,
            shapes,
            smoothing,
            material: self.material,
            surroundings: Surroundings::new(boundary, self.surroundings.interactions),
            plastic: None,
            step_end: Exact::default(),
            counted: local.owned.clone(),
            share: Some(share),
            f: vec![D::identity(); q],
            pk1: vec![D::zero_t(); q],
        }
    }

    /// Whether the particles are points (nodal or stress-point integration), so that a
    /// point field is known at the nodes.
    fn nodes_are_points(&self) -> bool {
        self.points.particles == self.x0.len()
    }

    /// A point field at the nodes: its values at the particles where they are points,
    /// else the lumped L2 projection of [`to_nodes`].
    fn projected<T>(&self, g: &[T], empty: T) -> Vec<T>
    where
        T: Copy + Send + Sync + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
    {
        if self.nodes_are_points() {
            g[..self.x0.len()].to_vec()
        } else {
            to_nodes(&self.gather, &self.shapes, &self.points.weight, g, empty)
        }
    }

    /// σ at the nodes from σ at the points, as [`Self::projected`].
    fn stress_at_nodes(&self, mut sigma: Vec<[[f64; 3]; 3]>) -> Vec<[[f64; 3]; 3]> {
        if self.nodes_are_points() {
            sigma.truncate(self.x0.len());
            sigma
        } else {
            stress_at_nodes(&self.gather, &self.shapes, &self.points.weight, sigma)
        }
    }

    /// Algorithm 2 of seed 003 at every point at the deformation gradients f from the
    /// committed history; None for the elastic models.
    fn returned_all(&self, f: &[D::T]) -> Option<Vec<Returned>> {
        let pl = self.plastic.as_ref()?;
        Some(
            f.par_iter()
                .with_min_len(MIN_CHUNK)
                .enumerate()
                .map(|(q, &f)| pl.returned::<D>(q, f))
                .collect(),
        )
    }

    /// F, σ, the stored energy Σ_q w_q ψ_q and ε_p (plastic models) at the points of
    /// state y.
    fn point_fields(&self, y: &GalerkinState<D>) -> Fields<D> {
        let f = self.point_f(y);
        let r = self.returned_all(&f);
        let weight = self
            .share
            .as_ref()
            .map_or(&self.points.weight, |s| &s.energy_weight);
        let r = self.plastic.as_ref().zip(r.as_deref());
        Fields::at_points(&self.material, f, r, (&y.rho, &y.s), weight)
    }
}

/// The consistent nodal forces of a meshfree Galerkin method, f_a = Σ_q Φ_a(X_q) f_q =
/// ∫ Φ_a t dΓ: its (test) functions Φ_a, of `family` on the reference particles, at the
/// points of the loaded surfaces. A point's functions reach the particles of the body
/// whose patch holds it.
struct ConsistentForces<'a, D: Dim> {
    case: &'a Case,
    family: Family,
    x0: &'a [D::V],
    vol: &'a [f64],
    body: &'a [u32],
    kernel: &'a crate::core::kernel::Kernel,
}

impl<D: Dim> NodalForces<D> for ConsistentForces<'_, D> {
    fn spread(&self, points: &[SurfacePoint<D>]) -> Result<Vec<(u32, D::V)>, CaseError> {
        let at: Vec<D::V> = points.iter().map(|p| p.x).collect();
        let at_body: Vec<u32> = points
            .iter()
            .map(|p| self.body[p.particle as usize])
            .collect();
        let shapes = &self
            .family
            .at::<D>(&at, &at_body, self.x0, self.vol, self.body, self.kernel)
            .map_err(|e| {
                let reason = format!("the functions at a point of a loaded surface: {e}");
                self.case.invalid("method.h_over_dx", reason)
            })?;
        Ok(points
            .iter()
            .enumerate()
            .flat_map(|(q, p)| {
                shapes
                    .csr
                    .range(q)
                    .map(move |e| (shapes.csr.ids[e], p.force * shapes.n[e]))
            })
            .collect())
    }
}

/// F, σ and ε_p (plastic models) at the quadrature points or projected to the nodes, and
/// the stored energy.
struct Fields<D: Dim> {
    f: Vec<D::T>,
    sigma: Vec<[[f64; 3]; 3]>,
    /// Σ_q w_q ψ_q.
    energy: Exact,
    /// The plastic history's fields (ε_p, T) of a plastic model.
    plastic: Vec<(&'static str, Vec<f64>)>,
}

impl<D: Dim> Fields<D> {
    /// The fields at points of weights w with deformation gradients f: σ, ψ and ε_p of
    /// the plastic returns r where the model has them, else the material's stresses of f
    /// (with a rate model's ρ and S at the points).
    fn at_points(
        material: &Material,
        f: Vec<D::T>,
        r: Option<(&History, &[Returned])>,
        (rho, s): (&[f64], &[D::T]),
        weight: &[f64],
    ) -> Self {
        match r {
            Some((history, r)) => Self {
                sigma: r.iter().zip(&f).map(|(r, &f)| r.cauchy::<D>(f)).collect(),
                energy: r.iter().zip(weight).map(|(r, w)| w * r.psi).sum(),
                plastic: history.fields(r),
                f,
            },
            None => {
                let (sigma, energy) = stress_fields::<D>(material, &f, s, rho, weight);
                Self {
                    f,
                    sigma,
                    energy,
                    plastic: Vec::new(),
                }
            }
        }
    }
}

/// m_a = ρ0 Σ_q w_q N_a(X_q) with the reference weights w_q and shapes; a particle no
/// point reaches is refused.
pub fn row_sums<D: Dim>(
    case: &Case,
    weight: &[f64],
    shapes: &Shapes<D>,
    gather: &Gather,
    rho0: f64,
) -> Result<Vec<f64>, CaseError> {
    let n = gather.offsets.len() - 1;
    if let Some(a) = (0..n).find(|&a| gather.is_orphan(a)) {
        return Err(case.invalid(
            "method.mass",
            format!(
                "particle {a} is the corner of no cell, so the row-sum mass gives it none; \
                 use `mass = \"particle\"` (it then keeps its particle mass and feels no \
                 internal force) or a geometry whose every particle is a cell corner"
            ),
        ));
    }
    Ok((0..n)
        .map(|a| {
            gather.range(a).fold(0.0, |m, e| {
                let q = gather.point[e] as usize;
                m + rho0 * weight[q] * shapes.n[gather.pair[e] as usize]
            })
        })
        .collect())
}

/// A 3×3 Cauchy stress with the arithmetic of the nodal projection.
#[derive(Clone, Copy, Debug)]
struct Tensor3([[f64; 3]; 3]);

impl std::ops::Add for Tensor3 {
    type Output = Self;
    fn add(mut self, o: Self) -> Self {
        for (r, s) in self.0.iter_mut().zip(o.0) {
            for (a, b) in r.iter_mut().zip(s) {
                *a += b;
            }
        }
        self
    }
}

impl std::ops::Mul<f64> for Tensor3 {
    type Output = Self;
    fn mul(mut self, k: f64) -> Self {
        self.0.iter_mut().flatten().for_each(|a| *a *= k);
        self
    }
}
