//! The updated-Lagrangian Galerkin system (seed 000 §5.7 and the UL FEM reference) on the
//! CPU: the weak form ∫ δv·ρ v̇ dΩ = −∫ ∇δv : σ dΩ (eqs 111–117) on the current
//! configuration. At every rate evaluation the points' shape functions N_a(x_q), ∇N_a(x_q)
//! and weights w_q are recomputed from the current node positions ([`MovingPoints`]: the
//! elements of `ul-fem`, the stress points of `ul-weak-form`), on lists from points to
//! nodes fixed at set-up, so that the transposed lists of the per-node gather are fixed
//! too. Then
//!
//! - at each point: L_q = Σ_a v_a ⊗ ∇N_a(x_q), ρ̇_q = −ρ_q tr L_q, the objective Ṡ_q and
//!   σ_q = S_q − p(ρ_q) I (rate model), or σ_q from F_q = (Σ_a X_a ⊗ ∇N_a(x_q))⁻¹ (state
//!   model; the von Mises model returns it from the point's plastic history, committed
//!   at the start of every step from F_q there);
//! - at each node: m_a v̇_a = −Σ_q w_q σ_q ∇N_a(x_q), gathered over the node's points.

use super::contracts::galerkin_accessors;
use super::{
    Fields, Mass, check_points, gather_accelerations, row_sums, smooth_velocities, stress_at_nodes,
    to_nodes,
};
use crate::boundary::{Boundary, OnPatches};
use crate::case::{Case, CaseError};
use crate::core::integrate::OdeSystem;
use crate::core::neighbour::Csr;
use crate::core::parallel::{MIN_CHUNK, particle_state};
use crate::core::quadrature::{Gather, ShapeRow, Shapes};
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::{ScalarField, Snapshot};
use crate::engine::{BlowUp, BoundaryWork, Method, Sizes, Traffic, check_motion};
use crate::interaction::Interactions;
use crate::methods::cores::particles::Surroundings;
use crate::methods::cores::tl::displacement_rates;
use crate::physics::material::{Material, MaterialModel};
use crate::physics::plasticity::{History, Returned, from_mat3};
use crate::reference::{Build, Reference};
use rayon::prelude::*;

/// The state of an updated-Lagrangian Galerkin method whose stress lives at `points`, for
/// `--explain`.
pub fn state(mat: &Material, points: &str) -> String {
    if mat.model.is_rate_based() {
        format!(
            "u, v at the nodes; ρ, S at {points} (rate model: {})",
            mat.rate_model()
        )
    } else if mat.model == MaterialModel::VonMisesPlastic {
        format!(
            "u, v at the nodes; the plastic history C_p⁻¹, ε_p at {points}, committed once per \
             step from F = (Σ_a X_a ⊗ ∇N_a)⁻¹ at the step's start"
        )
    } else {
        format!(
            "u, v at the nodes (state model {:?}: σ from F = (Σ_a X_a ⊗ ∇N_a)⁻¹ at {points}, \
             no ρ or S integrated)",
            mat.model
        )
    }
}

particle_state! {
    /// The integrated state: u, v at the nodes; ρ, S at the points (rate model; empty for
    /// a state model); and, for points that move on their own (the weak form's stress
    /// points), ρ at the nodes and the points' displacements (empty otherwise).
    pub struct UlGalerkinState {
        pub rho: Vec<f64>,
        pub s: Vec<D::T>,
        /// ρ at the nodes, whose volumes m_a/ρ_a the shape functions use.
        pub node_rho: Vec<f64>,
        /// x_q − X_q of the points, advected with the interpolated velocity (eq 169).
        pub point_u: Vec<D::V>,
    }
}

/// Why a point's shape functions cannot be evaluated in a configuration: the quantity that
/// degenerated and its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Degenerate {
    pub quantity: &'static str,
    pub value: f64,
}

/// The nodes as the points see them: reference and current positions, masses, and the
/// state y of that configuration.
pub struct Nodes<'a, D: Dim> {
    pub x0: &'a [D::V],
    pub x: &'a [D::V],
    pub mass: &'a [f64],
    pub y: &'a UlGalerkinState<D>,
}

/// The points of an updated-Lagrangian Galerkin method, with their shape functions on the
/// current configuration.
pub trait MovingPoints<D: Dim>: Sized + Send + Sync {
    /// Whether the points move on their own (the state's `point_u`), as stress points
    /// do; otherwise the points follow the nodes (elements).
    const OWN_MOTION: bool;

    /// Whether the nodes carry ρ (`node_rho`), as the weak form's particles do for their
    /// volumes m/ρ.
    const NODE_DENSITY: bool = false;

    /// Whether the test functions differ from the trial functions (Petrov–Galerkin): the
    /// shapes then carry test gradients ([`Shapes::test_gradient`]).
    const PETROV_GALERKIN: bool = false;

    /// The typed spec of the points' method.
    type Spec;

    /// The points of a method's spec on the reference configuration.
    fn build(case: &Case, spec: &Self::Spec, reference: &Reference<D>) -> Result<Self, CaseError>;

    /// The fixed lists from every point to the nodes that may reach it.
    fn lists(&self) -> &Csr;

    /// The corners of the elements the frames show on the nodes (2^d per cell, VTK
    /// order); none by default.
    fn cells(&self) -> &[u32] {
        &[]
    }

    /// The reference volume of every point (what the stored energy density is per).
    fn reference_weights(&self) -> &[f64];

    /// The nodal masses.
    fn mass(&self) -> Mass;

    /// N_a(x_q) and ∇N_a(x_q) (and ∇Φ_a(x_q) if Petrov–Galerkin) of point q into its
    /// pairs of the lists (zero for a node that does not reach it in this configuration),
    /// for the nodes at `nodes.x` and state `nodes.y`; returns the point's weight w_q
    /// there.
    fn shapes_at(&self, q: usize, nodes: &Nodes<D>, row: ShapeRow<D>) -> Result<f64, Degenerate>;

    /// New lists from the points to the nodes (at reference positions x0), searched on
    /// the configuration of state y at the start of a step, when the method searches anew then (an Eulerian kernel;
    /// [`Self::lists`] are these lists afterwards);
    /// none keeps the lists (the default).
    fn relist(&mut self, _x0: &[D::V], _y: &UlGalerkinState<D>) -> Option<Csr> {
        None
    }

    /// What the points carry from step to step besides the state (an Eulerian kernel's
    /// last search), for a checkpoint; nothing by default.
    fn save(&self, _out: &mut Vec<f64>) {}

    /// Reads what [`Self::save`] wrote: the lists it implies, when they are not the
    /// lists of the set-up.
    fn load(&mut self, _words: &mut &[f64]) -> Result<Option<Csr>, String> {
        Ok(None)
    }

    /// Bytes [per point, per pair of the lists, per node] that [`Self::shapes_at`] and
    /// [`Self::own_rates`] move beyond the passes every family shares, by the
    /// minimum-traffic model of `meshless bench --roofline`.
    fn shape_traffic(&self) -> [f64; 3];

    /// The rates of `node_rho`, and of `point_u` beyond the core's ẋ_q = Σ_a N_a(x_q) v_a
    /// of points that move on their own ([`Self::OWN_MOTION`]); nothing by default.
    fn own_rates(&mut self, _nodes: &Nodes<D>, _d: &mut UlGalerkinState<D>) -> Result<(), BlowUp> {
        Ok(())
    }

    /// The nodes' own functions that the velocities are smoothed with after a step, at
    /// state `nodes.y`; none by default.
    fn smoothing(&mut self, _nodes: &Nodes<D>) -> Option<&Shapes<D>> {
        None
    }
}

/// An updated-Lagrangian Galerkin system on the CPU (f64, rayon).
pub struct UlGalerkin<D: Dim, P: MovingPoints<D>> {
    x0: Vec<D::V>,
    mass: Vec<f64>,
    body: Vec<u32>,
    v0: Vec<D::V>,
    points: P,
    /// The functions at the points of the last rate evaluation, on the points' lists.
    shapes: Shapes<D>,
    /// w_q of the last rate evaluation.
    weight: Vec<f64>,
    gather: Gather,
    material: Material,
    surroundings: Surroundings<D>,
    /// Current node positions x = X + u of the last rate evaluation.
    x: Vec<D::V>,
    /// σ_q of the last rate evaluation.
    sigma: Vec<D::T>,
    /// The points' plastic history (von Mises); None for the elastic models.
    plastic: Option<History>,
    /// The kinetic energy the last velocity smoothing took out.
    step_end: Exact,
    /// The particles the smoothing's energy counts ([`Reference::counted`]).
    counted: Vec<bool>,
}

/// The initial state: at rest in the reference configuration, v = v0, ρ = ρ0, S = 0.
fn initial<D: Dim, P: MovingPoints<D>>(
    material: &Material,
    v0: &[D::V],
    points: usize,
) -> UlGalerkinState<D> {
    let (n, rate) = (v0.len(), material.model.is_rate_based());
    let sized = |on: bool, len: usize| if on { len } else { 0 };
    UlGalerkinState {
        u: vec![D::zero(); n],
        v: v0.to_vec(),
        rho: vec![material.rho0; sized(rate, points)],
        s: vec![D::zero_t(); sized(rate, points)],
        node_rho: vec![material.rho0; sized(P::NODE_DENSITY, n)],
        point_u: vec![D::zero(); sized(P::OWN_MOTION, points)],
    }
}

/// Shapes on `lists`, zero until evaluated (with test gradients for a Petrov–Galerkin
/// method).
fn on_lists<D: Dim, P: MovingPoints<D>>(lists: Csr) -> Shapes<D> {
    let pairs = lists.pair_count();
    let test = if P::PETROV_GALERKIN { pairs } else { 0 };
    Shapes {
        csr: lists,
        n: vec![0.0; pairs],
        grad: vec![D::zero(); pairs],
        test: vec![D::zero(); test],
        family: None,
    }
}

/// N_a(x_q), ∇N_a(x_q) of every point into `shapes` and the weights w_q into `weight`,
/// for the nodes at `nodes.x` and state `nodes.y`; the first point that degenerates, with
/// why.
fn evaluate<D: Dim, P: MovingPoints<D>>(
    points: &P,
    nodes: &Nodes<D>,
    shapes: &mut Shapes<D>,
    weight: &mut [f64],
) -> Result<(), (usize, Degenerate)> {
    shapes.recompute(weight, |q, _, row| points.shapes_at(q, nodes, row))
}

impl<D: Dim, P: MovingPoints<D>> UlGalerkin<D, P> {
    /// The system on the particles of `reference` with the method's points.
    pub fn new(case: &Case, reference: Reference<D>, points: P) -> Result<Self, CaseError> {
        let mut shapes = on_lists::<D, P>(points.lists().clone());
        let gather = shapes.gather(reference.len());
        let Reference {
            x0,
            mass: particle_mass,
            body,
            v0,
            mut boundary,
            material,
            counted,
            ..
        } = reference;
        let y0 = initial::<D, P>(&material, &v0, shapes.len());
        let nodes = Nodes {
            x0: &x0,
            x: &x0,
            mass: &particle_mass,
            y: &y0,
        };
        let mut weight = vec![0.0; shapes.len()];
        evaluate(&points, &nodes, &mut shapes, &mut weight).map_err(|(q, e)| {
            case.invalid(
                "body",
                format!(
                    "{} = {:e} at quadrature point {q} on the reference configuration; the \
                     body is too thin or irregular for the method's points",
                    e.quantity, e.value
                ),
            )
        })?;
        let mass = match points.mass() {
            Mass::Particle => particle_mass,
            Mass::RowSum => row_sums(
                case,
                points.reference_weights(),
                &shapes,
                &gather,
                material.rho0,
            )?,
        };
        // The shape functions of a point reach only its own body's nodes.
        boundary.use_method(&OnPatches, &mass)?;
        let interactions = Interactions::build(case, &x0, &body, &OnPatches, &mass, Csr::default)?;
        let q = shapes.len();
        Ok(Self {
            x: x0.clone(),
            x0,
            mass,
            body,
            v0,
            points,
            shapes,
            weight,
            gather,
            material,
            surroundings: Surroundings::new(boundary, interactions),
            sigma: vec![D::zero_t(); q],
            plastic: material.von_mises().map(|model| History::virgin(model, q)),
            step_end: Exact::default(),
            counted,
        })
    }

    /// The method's points.
    pub fn points(&self) -> &P {
        &self.points
    }

    /// The method's points, to give them lists searched elsewhere (the device's).
    pub fn points_mut(&mut self) -> &mut P {
        &mut self.points
    }

    /// The functions at the points of the last rate evaluation.
    pub fn shapes(&self) -> &Shapes<D> {
        &self.shapes
    }

    /// w_q of the last rate evaluation.
    pub fn weights(&self) -> &[f64] {
        &self.weight
    }

    /// σ_q of the last rate evaluation.
    pub fn stresses(&self) -> &[D::T] {
        &self.sigma
    }

    /// Evaluates the points' functions on `lists` from now on, with their transposed
    /// lists for the gather (the points' own lists are set apart).
    pub fn use_lists(&mut self, lists: Csr) {
        self.shapes = on_lists::<D, P>(lists);
        self.gather = self.shapes.gather(self.x0.len());
    }

    pub fn material(&self) -> &Material {
        &self.material
    }

    pub fn boundary(&self) -> &Boundary<D> {
        &self.surroundings.boundary
    }

    pub fn interactions(&self) -> &Interactions<D> {
        &self.surroundings.interactions
    }

    /// The points' plastic history (von Mises); None for the elastic models.
    pub fn plastic_mut(&mut self) -> Option<&mut History> {
        self.plastic.as_mut()
    }

    /// x = X + u.
    fn positions(&self, y: &UlGalerkinState<D>) -> Vec<D::V> {
        let mut x = Vec::with_capacity(self.x0.len());
        self.positions_into(y, &mut x);
        x
    }

    /// x = X + u, into `x`.
    fn positions_into(&self, y: &UlGalerkinState<D>, x: &mut Vec<D::V>) {
        x.clear();
        x.extend(self.x0.iter().zip(&y.u).map(|(&x0, &u)| x0 + u));
    }

    /// A point that degenerated, as a blow-up at the first node of its list.
    fn degenerate(&self, q: usize, e: Degenerate) -> BlowUp {
        let node = self.shapes.csr.ids[self.shapes.csr.offsets[q]] as usize;
        let what = format!("{} at quadrature point {q} next to it", e.quantity);
        BlowUp::at::<D>(&self.x0, node, &what, e.value)
    }

    /// The first point or node with ρ ≤ 0 (the volumes m/ρ need ρ > 0).
    fn check_densities(&self, y: &UlGalerkinState<D>) -> Result<(), BlowUp> {
        let bad = |r: &f64| r.is_nan() || *r <= 0.0;
        if let Some(q) = y.rho.par_iter().position_first(bad) {
            return Err(self.degenerate(
                q,
                Degenerate {
                    quantity: "density",
                    value: y.rho[q],
                },
            ));
        }
        if let Some(i) = y.node_rho.par_iter().position_first(bad) {
            return Err(BlowUp::at::<D>(&self.x0, i, "density", y.node_rho[i]));
        }
        Ok(())
    }

    /// F_q = (Σ_a X_a ⊗ ∇N_a(x_q))⁻¹: the inverse of the gradient of the reference
    /// positions on the current configuration.
    fn point_f(&self, shapes: &Shapes<D>, q: usize) -> D::T {
        D::inverse(shapes.gradient(q, &self.x0))
    }

    /// σ_q at every point; ρ̇_q and Ṡ_q for the rate model.
    fn point_stresses(&mut self, y: &UlGalerkinState<D>, d: &mut UlGalerkinState<D>) {
        let (mat, shapes) = (self.material, &self.shapes);
        let mut sigma = std::mem::take(&mut self.sigma);
        let each = sigma.par_iter_mut().enumerate();
        if mat.model.is_rate_based() {
            each.zip(d.rho.par_iter_mut().zip(d.s.par_iter_mut()))
                .with_min_len(MIN_CHUNK)
                .for_each(|((q, sigma), (rho_dot, s_dot))| {
                    // L_q = Σ_a v_a ⊗ ∇N_a(x_q) (UL FEM step 4; Algorithm 7 step 6).
                    let l = shapes.gradient(q, &y.v);
                    *rho_dot = -y.rho[q] * D::trace(l);
                    *s_dot = mat.stress_rate::<D>(y.s[q], l, self.point_f(shapes, q));
                    *sigma = y.s[q] - D::identity() * mat.pressure(y.rho[q]);
                });
        } else {
            let plastic = self.plastic.as_ref();
            each.with_min_len(MIN_CHUNK).for_each(|(q, sigma)| {
                let f = self.point_f(shapes, q);
                let p = match plastic {
                    Some(pl) => from_mat3::<D>(pl.returned::<D>(q, f).p),
                    None => mat.pk1::<D>(f),
                };
                *sigma = p * D::transpose(f) * (1.0 / D::det(f));
            });
        }
        self.sigma = sigma;
    }

    /// Algorithm 2 of seed 003 at every point at F_q of `shapes` from the committed
    /// history, with those F_q; None for the elastic models.
    fn returned_all(&self, shapes: &Shapes<D>) -> Option<(Vec<D::T>, Vec<Returned>)> {
        let pl = self.plastic.as_ref()?;
        Some(
            (0..shapes.len())
                .into_par_iter()
                .with_min_len(MIN_CHUNK)
                .map(|q| {
                    let f = self.point_f(shapes, q);
                    (f, pl.returned::<D>(q, f))
                })
                .unzip(),
        )
    }

    /// The functions and weights at the points for state y, or the point that
    /// degenerates there.
    fn evaluated(&self, y: &UlGalerkinState<D>) -> Result<(Shapes<D>, Vec<f64>), BlowUp> {
        let x = self.positions(y);
        let nodes = Nodes {
            x0: &self.x0,
            x: &x,
            mass: &self.mass,
            y,
        };
        let mut shapes = self.shapes.clone();
        let mut weight = vec![0.0; shapes.len()];
        evaluate(&self.points, &nodes, &mut shapes, &mut weight)
            .map_err(|(q, e)| self.degenerate(q, e))?;
        Ok((shapes, weight))
    }

    /// The functions and weights at the points for state y (those of the last rate
    /// evaluation if y's cannot be evaluated: a state `check_finite` refuses before any
    /// output reads it, but which a failure report may still show).
    fn shapes_of(&self, y: &UlGalerkinState<D>) -> (Shapes<D>, Vec<f64>) {
        self.evaluated(y)
            .unwrap_or_else(|_| (self.shapes.clone(), self.weight.clone()))
    }

    /// F, σ and ε_p (plastic models) at the nodes and the stored energy Σ_q w0_q ψ_q, for
    /// state y.
    fn node_fields(&self, y: &UlGalerkinState<D>) -> Fields<D> {
        let (shapes, weight) = self.shapes_of(y);
        let (f, r) = match self.returned_all(&shapes) {
            Some((f, r)) => (f, Some(r)),
            None => {
                let f = (0..shapes.len())
                    .into_par_iter()
                    .map(|q| self.point_f(&shapes, q))
                    .collect();
                (f, None)
            }
        };
        let w0 = self.points.reference_weights();
        let r = self.plastic.as_ref().zip(r.as_deref());
        let at = Fields::<D>::at_points(&self.material, f, r, (&y.rho, &y.s), w0);
        Fields {
            f: to_nodes(&self.gather, &shapes, &weight, &at.f, D::identity()),
            sigma: stress_at_nodes(&self.gather, &shapes, &weight, at.sigma),
            energy: at.energy,
            plastic: (at.plastic.into_iter())
                .map(|(name, e)| (name, to_nodes(&self.gather, &shapes, &weight, &e, 0.0)))
                .collect(),
        }
    }
}

impl<D: Dim, P: MovingPoints<D>> OdeSystem for UlGalerkin<D, P> {
    type State = UlGalerkinState<D>;
    type Error = BlowUp;

    fn rates(&mut self, _t: f64, y: &Self::State, d: &mut Self::State) -> Result<(), BlowUp> {
        self.check_densities(y)?;
        let mut x = std::mem::take(&mut self.x);
        self.positions_into(y, &mut x);
        self.x = x;
        let mut shapes = std::mem::take(&mut self.shapes);
        self.weight.resize(shapes.len(), 0.0);
        let nodes = Nodes {
            x0: &self.x0,
            x: &self.x,
            mass: &self.mass,
            y,
        };
        let evaluated = evaluate(&self.points, &nodes, &mut shapes, &mut self.weight);
        self.shapes = shapes;
        evaluated.map_err(|(q, e)| self.degenerate(q, e))?;
        self.point_stresses(y, d);
        gather_accelerations(
            &self.gather,
            &self.shapes,
            &self.weight,
            &self.sigma,
            &self.mass,
            &mut d.v,
        );
        displacement_rates::<D>(&mut d.u, &y.v);
        let nodes = Nodes {
            x0: &self.x0,
            x: &self.x,
            mass: &self.mass,
            y,
        };
        if P::OWN_MOTION {
            d.point_u = self.shapes.interpolate(&y.v);
        }
        self.points.own_rates(&nodes, d)?;
        self.surroundings.close(&y.v, &self.mass, &mut d.v);
        Ok(())
    }

    /// The points' new lists if they search anew, the plastic history committed from the
    /// state at the step's start (kept if its functions cannot be evaluated: the next rate
    /// evaluation reports why), then the interactions.
    fn begin_step(&mut self, t: f64, dt: f64, y: &UlGalerkinState<D>) {
        if let Some(lists) = self.points.relist(&self.x0, y) {
            self.use_lists(lists);
        }
        if self.plastic.is_some()
            && let Ok((shapes, _)) = self.evaluated(y)
            && let Some((_, committed)) = self.returned_all(&shapes)
            && let Some(pl) = self.plastic.as_mut()
        {
            pl.commit(&committed, self.points.reference_weights(), dt);
        }
        self.surroundings.begin_step(t, dt, &self.x0, &y.u, &y.v);
    }

    /// The weak form's velocity smoothing with the nodes' functions at the step's end,
    /// then the prescribed velocities again. If those functions cannot be evaluated the
    /// velocities stay as they are, and the next rate evaluation reports the cause.
    fn end_step(&mut self, _t: f64, y: &mut UlGalerkinState<D>) {
        let x = self.positions(y);
        let nodes = Nodes {
            x0: &self.x0,
            x: &x,
            mass: &self.mass,
            y,
        };
        if let Some(shapes) = self.points.smoothing(&nodes) {
            let boundary = &self.surroundings.boundary;
            self.step_end =
                smooth_velocities(shapes, boundary, &self.mass, &self.counted, &mut y.v);
        }
    }
}

impl<D: Dim, P: MovingPoints<D>> Build<D> for UlGalerkin<D, P> {
    type Spec = P::Spec;

    fn build(case: &Case, spec: &P::Spec, reference: Reference<D>) -> Result<Self, CaseError> {
        let points = P::build(case, spec, &reference)?;
        Self::new(case, reference, points)
    }
}

impl<D: Dim, P: MovingPoints<D>> Method<D> for UlGalerkin<D, P> {
    fn initial_state(&self) -> UlGalerkinState<D> {
        initial::<D, P>(&self.material, &self.v0, self.shapes.len())
    }

    galerkin_accessors!(UlGalerkinState<D>);

    /// The points' plastic history, then what the points carry between steps (an
    /// Eulerian kernel's last search).
    fn save_history(&self, out: &mut Vec<f64>) {
        History::save(self.plastic.as_ref(), out);
        self.points.save(out);
    }

    fn load_history(&mut self, words: &mut &[f64]) -> Result<(), String> {
        History::load(self.plastic.as_mut(), words)?;
        if let Some(lists) = self.points.load(words)? {
            self.use_lists(lists);
        }
        Ok(())
    }

    /// F at the nodes, projected from F_q = (Σ_a X_a ⊗ ∇N_a(x_q))⁻¹.
    fn deformation_gradient(&self, y: &UlGalerkinState<D>) -> Vec<D::T> {
        self.node_fields(y).f
    }

    /// σ at the nodes, projected from the points.
    fn cauchy_stress(&self, y: &UlGalerkinState<D>) -> Vec<[[f64; 3]; 3]> {
        self.node_fields(y).sigma
    }

    /// Σ_q w0_q ψ_q.
    fn strain_energy(&self, y: &UlGalerkinState<D>) -> Exact {
        self.node_fields(y).energy
    }

    /// The committed plastic work and the current step's, over the reference weights.
    fn plastic_work(&self, y: &UlGalerkinState<D>) -> f64 {
        let Some(pl) = &self.plastic else {
            return 0.0;
        };
        let (shapes, _) = self.shapes_of(y);
        self.returned_all(&shapes).map_or(0.0, |(_, r)| {
            pl.work_at(&r, self.points.reference_weights())
        })
    }

    fn snapshot<'a>(&'a self, y: &UlGalerkinState<D>) -> Snapshot<'a, D> {
        let fields = self.node_fields(y);
        Snapshot {
            x0: &self.x0,
            mass: &self.mass,
            body: &self.body,
            u: y.u.clone(),
            v: y.v.clone(),
            f: fields.f,
            sigma: fields.sigma,
            strain_energy: fields.energy,
            extra: (fields.plastic.into_iter())
                .map(|(name, values)| ScalarField { name, values })
                .collect(),
            cells: self.points.cells(),
            quadrature: None,
        }
    }

    /// x = X + u (with ρ > 0 checked first); the functions recomputed at the points (the
    /// ids read, N and ∇N (∇Φ) written per pair, w per point, x gathered per node, and
    /// what each family's points read, [`MovingPoints::shape_traffic`]); the point pass
    /// reads the ids and ∇N of every pair, v (or X) at the nodes and ρ, S of the rate
    /// model (or the plastic history) and writes σ (and ρ̇, Ṡ); the gather reads the
    /// point and pair ids and ∇Φ of every pair, σ and w of the points and m, and writes a;
    /// then u̇ = v and the points' own rates. The bytes of the points count per particle
    /// by points per particle.
    fn traffic(&self) -> Option<Traffic> {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let rate = self.material.model.is_rate_based();
        let plastic = Sizes::plastic_history(self.plastic.is_some());
        let node_rho = if P::NODE_DENSITY { f } else { 0 };
        let per_node = node_rho + 3 * v + v + v + (f + v) + 2 * v;
        let stress = if rate { 2 * f + 3 * t } else { t + plastic };
        let per_point = if rate { f } else { 0 } + f + stress + (t + f);
        let test = if P::PETROV_GALERKIN { v } else { 0 };
        let per_pair = (id + f + v + test) + (id + v) + (2 * id + v);
        let [own_point, own_pair, own_node] = self.points.shape_traffic();
        let points = self.shapes.len() as f64 / self.x0.len().max(1) as f64;
        let state_point = if rate { f + t } else { 0 } + if P::OWN_MOTION { v } else { 0 };
        Some(Traffic {
            per_particle: (per_node as f64 + own_node) + points * (per_point as f64 + own_point),
            per_pair: per_pair as f64 + own_pair,
            state: (2 * v + node_rho) as f64 + points * state_point as f64,
            velocity: v as f64,
        })
    }

    /// Finite motion, ρ and S; then positive densities and points whose functions can
    /// be evaluated.
    fn check_finite(&self, y: &UlGalerkinState<D>) -> Result<(), BlowUp> {
        check_motion::<D>(&self.x0, &y.u, &y.v)?;
        let node = |q: usize| self.shapes.csr.ids[self.shapes.csr.offsets[q]] as usize;
        check_points::<D>(&self.x0, node, &y.rho, &y.s)?;
        if let Some(q) = y.point_u.par_iter().position_first(|&u| !D::is_finite_v(u)) {
            let what = format!("displacement |u| of quadrature point {q} next to it");
            let value = D::norm2(y.point_u[q]).sqrt();
            return Err(BlowUp::at::<D>(&self.x0, node(q), &what, value));
        }
        self.check_densities(y)?;
        self.evaluated(y).map(|_| ())
    }
}
