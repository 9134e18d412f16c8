//! [`TlGalerkin`] as an ODE system, a static problem and a method: its rates, its
//! stiffness, its state and accessors.

use super::*;
use crate::reference::Build;

/// The `Method` members that the total- and updated-Lagrangian Galerkin cores give
/// alike: the particles' accessors, the reference positions, the signal speed c_p +
/// max |v|, the pairs of the shape functions' lists and the dissipation of the velocity
/// smoothing.
macro_rules! galerkin_accessors {
    ($state:ty) => {
        $crate::methods::cores::particles::particle_accessors!($state);

        fn reference(&self) -> &[D::V] {
            &self.x0
        }

        fn signal_speed_terms(&self, y: &$state) -> [f64; 2] {
            $crate::methods::cores::particles::signal_speed_terms::<D>(&self.material, &y.v)
        }

        fn pairs(&self) -> usize {
            self.shapes.csr.pair_count()
        }

        /// The kinetic energy the last velocity smoothing took out.
        fn step_end_dissipation(&self) -> $crate::core::sum::Exact {
            self.step_end.clone()
        }
    };
}
pub(super) use galerkin_accessors;

impl<D: Dim> OdeSystem for TlGalerkin<D> {
    type State = GalerkinState<D>;
    type Error = BlowUp;

    fn rates(&mut self, _t: f64, y: &Self::State, d: &mut Self::State) -> Result<(), BlowUp> {
        self.point_stresses(y, d);
        if let Some(b) = self.first_inadmissible() {
            return Err(b);
        }
        self.accelerations(&mut d.v);
        displacement_rates::<D>(&mut d.u, &y.v);
        self.surroundings.close(&y.v, &self.mass, &mut d.v);
        Ok(())
    }

    /// The tractions' and interactions' step, and the plastic history committed from the
    /// state at the step's start (F at the points is taken for a plastic model only).
    fn begin_step(&mut self, t: f64, dt: f64, y: &GalerkinState<D>) {
        self.surroundings.begin_step(t, dt, &self.x0, &y.u, &y.v);
        if self.plastic.is_some()
            && let Some(committed) = self.returned_all(&self.point_f(y))
            && let Some(pl) = self.plastic.as_mut()
        {
            pl.commit(&committed, &self.points.weight, dt);
        }
    }

    /// The weak form's velocity smoothing, then the prescribed velocities again.
    fn end_step(&mut self, _t: f64, y: &mut GalerkinState<D>) {
        if let Some(shapes) = &self.smoothing {
            let boundary = &self.surroundings.boundary;
            self.step_end =
                smooth_velocities(shapes, boundary, &self.mass, &self.counted, &mut y.v);
        }
    }
}

impl<D: Dim> AtRest<D> for TlGalerkin<D> {
    /// u and v at the nodes (ρ and S of a rate model, which a static or implicit run
    /// refuses, as initially).
    fn moving(&self, u: &[D::V], v: &[D::V]) -> GalerkinState<D> {
        self.initial_state().moving(u, v)
    }

    /// The closed form on a model with a tangent (every model a static run accepts but
    /// the Mooney–Rivlin and polyconvex ones).
    fn closed_form(&self) -> Option<&dyn ClosedForm<D>> {
        self.material
            .model
            .has_tangent()
            .then_some(self as &dyn ClosedForm<D>)
    }

    /// Whether a point reaches node a (for the isoparametric functions: whether it is
    /// the corner of a cell).
    fn reached(&self, a: usize) -> bool {
        !self.gather.is_orphan(a)
    }
}

impl<D: Dim> ClosedForm<D> for TlGalerkin<D> {
    /// Row b: b and the nodes of every point of b.
    fn pattern(&self) -> BlockPattern {
        let (gather, shapes) = (&self.gather, &self.shapes);
        BlockPattern::from_rows(
            (0..self.x0.len())
                .into_par_iter()
                .map(|b| {
                    let mut row: Vec<u32> = gather
                        .range(b)
                        .flat_map(|e| {
                            let q = gather.point[e] as usize;
                            shapes.csr.ids[shapes.csr.range(q)].iter().copied()
                        })
                        .chain([b as u32])
                        .collect();
                    row.sort_unstable();
                    row.dedup();
                    row
                })
                .collect(),
        )
    }

    /// Test and trial functions are the same but for `kbm`.
    fn symmetric(&self) -> bool {
        self.shapes.test.is_empty()
    }

    /// K_(a,k),(b,l) = Σ_q w_q ∇0Φ_a,J 𝔸_q[kJ][lL] ∇0N_b,L: the derivative of
    /// f_a = −Σ_q w_q P_q ∇0Φ_a(X_q) (seed 000 eq 156) with F_q = I + Σ_b u_b ⊗ ∇0N_b(X_q),
    /// the material stiffness Bᵀ𝔸B of total-Lagrangian FEM. Row b is gathered by node b
    /// over its points, so no two threads write one value.
    fn assemble(&self, u: &[D::V], pattern: &BlockPattern, values: &mut [f64]) {
        let d = D::N;
        let bs = d * d;
        let (gather, shapes, weight) = (&self.gather, &self.shapes, &self.points.weight);
        let tangents: Vec<_> = (0..self.points.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|q| {
                let f = D::identity() + shapes.gradient(q, u);
                self.material.tangent::<D>(f)
            })
            .collect();
        pattern
            .rows_mut(values, bs)
            .into_par_iter()
            .for_each(|(b, cols, row)| {
                row.fill(0.0);
                for e in gather.range(b) {
                    let q = gather.point[e] as usize;
                    let grad_b = D::to3(shapes.grad[gather.pair[e] as usize]);
                    let tan = &tangents[q];
                    // t[k][l][J] = w_q Σ_L 𝔸[kJ][lL] ∇0N_b,L.
                    let mut t = [[[0.0; 3]; 3]; 3];
                    for (k, tk) in t.iter_mut().enumerate().take(d) {
                        for (l, tl) in tk.iter_mut().enumerate().take(d) {
                            for (j, tj) in tl.iter_mut().enumerate().take(d) {
                                *tj = weight[q]
                                    * (0..d)
                                        .map(|m| tan[3 * k + j][3 * l + m] * grad_b[m])
                                        .sum::<f64>();
                            }
                        }
                    }
                    for p in shapes.csr.range(q) {
                        let a = shapes.csr.ids[p];
                        let col = cols
                            .binary_search(&a)
                            .expect("the pattern holds the nodes of every point");
                        let test_a = D::to3(shapes.test_gradient(p));
                        let block = &mut row[col * bs..(col + 1) * bs];
                        for l in 0..d {
                            for k in 0..d {
                                block[l * d + k] +=
                                    (0..d).map(|j| t[k][l][j] * test_a[j]).sum::<f64>();
                            }
                        }
                    }
                }
            });
    }

    fn describe(&self) -> String {
        format!(
            "closed-form stiffness Σ_q w_q ∇Φ_a·𝔸_q·∇N_b on the nodes sharing a point ({})",
            if self.symmetric() {
                "symmetric"
            } else {
                "unsymmetric: Petrov–Galerkin"
            }
        )
    }
}

/// The spec of a total-Lagrangian Galerkin method (`tl-fem`, `tl-weak-form`, `kbm`,
/// `efg`), which chooses the points and shape functions of its system.
pub trait TlSystem<D: Dim> {
    /// The method's system on the reference configuration.
    fn system(&self, case: &Case, reference: Reference<D>) -> Result<TlGalerkin<D>, CaseError>;
}

impl<D: Dim> Build<D> for TlGalerkin<D> {
    type Spec = dyn TlSystem<D>;

    /// Built through the method's spec, which chooses the points and shape functions.
    fn build(
        case: &Case,
        spec: &dyn TlSystem<D>,
        reference: Reference<D>,
    ) -> Result<Self, CaseError> {
        spec.system(case, reference)
    }
}

impl<D: Dim> Method<D> for TlGalerkin<D> {
    fn initial_state(&self) -> GalerkinState<D> {
        let rate = self.material.model.is_rate_based();
        let stresses = if rate { self.points.len() } else { 0 };
        GalerkinState::initial(&self.u0, &self.v0, self.material.rho0, stresses)
    }

    galerkin_accessors!(GalerkinState<D>);

    /// The plastic history C_p⁻¹, ε_p of the points.
    fn save_history(&self, out: &mut Vec<f64>) {
        History::save(self.plastic.as_ref(), out);
    }

    fn load_history(&mut self, words: &mut &[f64]) -> Result<(), String> {
        History::load(self.plastic.as_mut(), words)
    }

    fn step_end_changes_state(&self) -> bool {
        self.smoothing.is_some()
    }

    /// F at the nodes, projected from the points.
    fn deformation_gradient(&self, y: &GalerkinState<D>) -> Vec<D::T> {
        self.projected(&self.point_f(y), D::identity())
    }

    /// σ at the nodes, projected from the points.
    fn cauchy_stress(&self, y: &GalerkinState<D>) -> Vec<[[f64; 3]; 3]> {
        self.stress_at_nodes(self.point_fields(y).sigma)
    }

    /// Σ_q w_q ψ_q.
    fn strain_energy(&self, y: &GalerkinState<D>) -> Exact {
        self.point_fields(y).energy
    }

    /// The committed plastic work and the current step's, over the point weights w_q.
    fn plastic_work(&self, y: &GalerkinState<D>) -> f64 {
        let Some(pl) = &self.plastic else {
            return 0.0;
        };
        self.returned_all(&self.point_f(y))
            .map_or(0.0, |r| pl.work_at(&r, &self.points.weight))
    }

    /// The nodal fields, and the points with u^h(X_q) = Σ_a N_a(X_q) u_a and F_q.
    fn snapshot<'a>(&'a self, y: &GalerkinState<D>) -> Snapshot<'a, D> {
        let fields = self.point_fields(y);
        let quadrature = self.quadrature(y, &fields.f);
        Snapshot {
            x0: &self.x0,
            mass: &self.mass,
            body: &self.body,
            u: y.u.clone(),
            v: y.v.clone(),
            f: self.projected(&fields.f, D::identity()),
            sigma: self.stress_at_nodes(fields.sigma),
            strain_energy: fields.energy,
            extra: (fields.plastic.iter())
                .map(|(name, values)| ScalarField {
                    name,
                    values: self.projected(values, 0.0),
                })
                .collect(),
            cells: &self.cells.corners,
            quadrature: Some(quadrature),
        }
    }

    /// Pass 1 at the points reads the ids and ∇N of every pair and u at the nodes (and v,
    /// ρ, S of the rate model, or C_p⁻¹ and ε_p) and writes F and P (and ρ̇, Ṡ); the det F
    /// check reads F; pass 2 at the nodes reads the gather's point and pair ids and ∇Φ of
    /// every pair, P and w of the points and m, and writes a; the last pass writes u̇ = v.
    /// The bytes of the points count per particle by points per particle. The velocity
    /// smoothing runs after the step, outside the rate evaluation.
    fn traffic(&self) -> Option<Traffic> {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let rate = self.material.model.is_rate_based();
        let plastic = Sizes::plastic_history(self.plastic.is_some());
        let per_node = v + if rate { v } else { 0 } + (f + v) + 2 * v;
        let per_point = 2 * t + if rate { 2 * (f + t) } else { plastic } + t + (t + f);
        let points = self.points.len() as f64 / self.x0.len().max(1) as f64;
        Some(Traffic {
            per_particle: per_node as f64 + points * per_point as f64,
            per_pair: (3 * id + 2 * v) as f64,
            state: (2 * v) as f64 + if rate { points * (f + t) as f64 } else { 0.0 },
            velocity: v as f64,
        })
    }

    fn check_finite(&self, y: &GalerkinState<D>) -> Result<(), BlowUp> {
        check_motion::<D>(&self.x0, &y.u, &y.v)?;
        let node = |q| self.shapes.strongest_node(q);
        check_points::<D>(&self.x0, node, &y.rho, &y.s)
    }
}
