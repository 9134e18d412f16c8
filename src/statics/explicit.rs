//! The static solve of the explicit methods (`run.solve = "static"`): the method's own rate
//! evaluation is the force, f_int(u) = m ⊙ ü(u, v = 0) − f_ext, and the stiffness
//! K = −∂f_int/∂u is formed from it by finite differences, column group by column group.
//!
//! No second implementation of any method's forces: whatever the method computes (TLSPH
//! with or without a correction, the Galerkin points of `kbm`, `efg`, `tl-fem` and
//! `tl-weak-form`) is what is solved. The force on a particle depends on the displacements
//! within two kernel supports of it (its own support and those of its points or
//! neighbours), so the stiffness has the pattern of the pairs within twice the support
//! radius; particles further apart than twice that share no row, and displacing a group of
//! them at once gives all their columns in one force evaluation (Curtis, Powell and Reid's
//! grouping, [`BlockPattern::column_groups`]). The stiffness of a Petrov–Galerkin method
//! (`kbm`) or of a non-symmetric collocation (Randles–Libersky TLSPH) is unsymmetric, so
//! the free system is solved by sparse LU.
//!
//! For the linear-elastic model the force is linear in u, and two Newton iterations reach
//! the discrete equilibrium to round-off (the cantilever of seed 001: a relative residual
//! of 1e-6 after the first, 3e-11 after the second); other state models iterate with this
//! stiffness at every iterate, until `run.tolerance` ([`crate::case::Tolerance`]).
//!
//! A method that knows its stiffness in closed form ([`ClosedForm`]: the total-Lagrangian
//! Galerkin methods on a model with a tangent 𝔸 = ∂P/∂F) assembles it instead, on the
//! exact pattern of the nodes that share a point; a symmetric one (Bubnov–Galerkin) is
//! then solved by sparse Cholesky, with LU where the tangent turns indefinite.

use super::sparse::{BlockPattern, Linear};
use super::{Linearisation, Model, Newton, Setup, Statics};
use crate::case::{Case, CaseError};
use crate::core::kernel::neighbour_radius;
use crate::core::neighbour;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, CpuEngine, Engine, EngineDim, Method};
use crate::reference::{Build, Reference, build_method};

/// A method whose force depends on the displacement alone (a state model), so that a
/// displacement field is a whole state of it.
pub trait AtRest<D: Dim>: Method<D> + Build<D> {
    /// The state with displacement u and velocity v.
    fn moving(&self, u: &[D::V], v: &[D::V]) -> Self::State;
    /// The state with displacement u and velocity zero, whose rates give the force.
    fn at_rest(&self, u: &[D::V]) -> Self::State {
        self.moving(u, &vec![D::zero(); u.len()])
    }
    /// The method's stiffness in closed form for this case, where it has one; the static
    /// solve forms it by finite differences otherwise.
    fn closed_form(&self) -> Option<&dyn ClosedForm<D>> {
        None
    }
    /// Whether any of the method's points reaches particle a: a Galerkin node that is the
    /// corner of no cell is not, so no force depends on its displacement and the
    /// stiffness is singular at its free components.
    fn reached(&self, _a: usize) -> bool {
        true
    }
}

/// A stiffness K = −∂f_int/∂u known in closed form.
pub trait ClosedForm<D: Dim> {
    /// The coupling of K: row b holds b and every particle whose force depends on u_b.
    fn pattern(&self) -> BlockPattern;
    /// Whether K is symmetric.
    fn symmetric(&self) -> bool;
    /// K at u into the values of `pattern` as the blocks of Kᵀ (block (b, a) holds
    /// K_(a,k),(b,l) at [l][k], the LU layout, which is K's own for a symmetric K).
    fn assemble(&self, u: &[D::V], pattern: &BlockPattern, values: &mut [f64]);
    /// The `backend` line's account of K.
    fn describe(&self) -> String;
}

/// The CPU engine of an explicit method: the static or implicit solve of this module when
/// the case asks for one (`run.solve = "static"` or `"implicit"`), the method with its
/// integrator otherwise.
pub fn cpu_engine<D: EngineDim, M: AtRest<D> + 'static>(
    case: &Case,
    spec: &M::Spec,
) -> Result<Box<dyn Engine<D>>, CaseError> {
    Ok(if case.solves_by_newton() {
        Box::new(Statics::<D, Explicit<D, M>>::new(case, spec)?)
    } else {
        Box::new(CpuEngine::with(
            build_method::<D, M>(case, spec)?,
            case.method.integrator,
        ))
    })
}

/// Newton iterations of a load step before it is cut in half.
const MAX_ITERATIONS: u32 = 20;
/// Halvings of a load step before the run fails.
const MAX_CUTS: u32 = 6;
/// The finite-difference step of the stiffness columns, per spacing: a strain of 1e-6,
/// where the round-off of a force of the scale of the loads stays below 1e-9 of the
/// difference and the truncation error of a nonlinear model is O(1e-6) relative.
const STEP_PER_SPACING: f64 = 1e-6;

/// An explicit method seen as a static model.
pub struct Explicit<D: Dim, M: AtRest<D>> {
    pub method: M,
    /// The rates of the last force evaluation.
    rates: M::State,
    /// The external forces f + m g, m ⊙ the accelerations the rate evaluation adds (the
    /// full load).
    external: Vec<D::V>,
    groups: Vec<Vec<u32>>,
    step: f64,
}

impl<D: Dim, M: AtRest<D>> Statics<D, Explicit<D, M>> {
    /// The method on the case's reference configuration, the stiffness's pattern and
    /// column groups, and the free system (sparse LU).
    pub fn new(case: &Case, spec: &M::Spec) -> Result<Self, CaseError> {
        let mut reference = Reference::<D>::build(case)?;
        let boundary = reference.boundary.clone();
        // The method keeps the loads but not the constraints, which the engine holds: its
        // rate evaluation then gives the force on every component, so that the reactions
        // of the prescribed components, and the work of the supports, are known.
        reference.boundary.constrained.clear();
        reference.boundary.prescribed.clear();
        reference.boundary.displacement.clear();
        let (u0, v0) = (reference.u0.clone(), reference.v0.clone());
        let method = M::build(case, spec, reference)?;
        let (x0, mass) = (method.reference(), method.mass());
        let full = (1u8 << D::N) - 1;
        let mut held = vec![0u8; x0.len()];
        for &(i, mask) in &boundary.constrained {
            held[i as usize] = mask;
        }
        // A static stiffness is singular at a particle no force depends on and under a free
        // rigid motion; an implicit step's mass term M/(β Δt²) holds both.
        if !case.is_implicit() {
            if let Some(a) = (0..x0.len()).find(|&a| held[a] != full && !method.reached(a)) {
                return Err(unreached(case, &method, a));
            }
            let bodies: Vec<&str> = case.bodies.iter().map(|b| b.name.as_str()).collect();
            rigid_motions_held::<D>(x0, method.body(), &bodies, &boundary.constrained)
                .map_err(|m| case.invalid("boundary", m))?;
        }
        let (pattern, linear, groups) = match method.closed_form() {
            Some(k) if k.symmetric() => (k.pattern(), Linear::Cholesky, Vec::new()),
            Some(k) => (k.pattern(), Linear::Lu, Vec::new()),
            None => {
                let pattern = difference_pattern::<D>(case, x0);
                let groups = pattern.column_groups();
                (pattern, Linear::Lu, groups)
            }
        };
        let external = boundary.external_forces(mass);
        let setup = Setup {
            mass: mass.to_vec(),
            body: method.body().to_vec(),
            u0,
            v0,
            boundary: &boundary,
            linearisation: Linearisation::Assembled(pattern, linear),
            newton: Newton::of(case, MAX_ITERATIONS, MAX_CUTS, "the static solve's limit"),
        };
        let model = Explicit {
            rates: method.initial_state(),
            method,
            external,
            groups,
            step: STEP_PER_SPACING * case.spacing,
        };
        Self::with_model(case, model, setup, "run.solve")
    }
}

/// The error of a static run whose particle a, free in some component, no point of the
/// method reaches (the corner of no cell): its stiffness is singular there, which is no
/// free rigid motion, so the error names the particle and the fixes.
fn unreached<D: Dim, M: AtRest<D>>(case: &Case, method: &M, a: usize) -> CaseError {
    let b = method.body()[a] as usize;
    case.invalid(
        format!("body.{b}.geometry"),
        format!(
            "particle {a} at {:?} of body `{}` is the corner of no cell of `{}` (its lattice \
             squares or cubes leave the shape, as at a round or slanted boundary), so no \
             force depends on its displacement and the static solve's stiffness is singular \
             there; give the body a shape whose every lattice point is a cell corner (a box, a \
             polar ring, a polygon whose edges follow the lattice), or hold the particle with \
             a boundary condition",
            D::to3(method.reference()[a]),
            case.bodies[b].name,
            case.method.name
        ),
    )
}

/// The stiffness's pattern for finite differences: the pairs within two kernel supports.
fn difference_pattern<D: Dim>(case: &Case, x0: &[D::V]) -> BlockPattern {
    let reach = 2.0 * neighbour_radius(&case.kernel(D::N));
    let pairs = neighbour::build::<D>(x0, reach);
    BlockPattern::from_rows(
        (0..x0.len())
            .map(|a| {
                let mut row = pairs.neighbours(a).to_vec();
                row.push(a as u32);
                row.sort_unstable();
                row
            })
            .collect(),
    )
}

impl<D: Dim, M: AtRest<D>> Model<D> for Explicit<D, M> {
    fn x0(&self) -> &[D::V] {
        self.method.reference()
    }

    /// m ⊙ ü(u, 0) − f_ext: the method's rate evaluation at rest (built without the
    /// constraints), less the loads it adds.
    fn force(&mut self, u: &[D::V]) -> Result<Vec<D::V>, BlowUp> {
        let y = self.method.at_rest(u);
        self.method.rates(0.0, &y, &mut self.rates)?;
        let a = self.method.velocity(&self.rates);
        Ok(a.iter()
            .zip(self.method.mass())
            .zip(&self.external)
            .map(|((&a, &m), &f)| a * m - f)
            .collect())
    }

    /// K = −∂f_int/∂u in the method's closed form, or by forward differences of step ε,
    /// one force evaluation per column group and component: block (b, a) holds ∂f_a/∂u_b
    /// transposed, K_(a,k),(b,l) at [l][k] (the LU layout). A force evaluation that fails
    /// leaves NaN, which the solve reports.
    fn stiffness(&mut self, u: &[D::V], pattern: &BlockPattern, values: &mut [f64]) {
        if let Some(k) = self.method.closed_form() {
            k.assemble(u, pattern, values);
            return;
        }
        let d = D::N;
        let bs = d * d;
        let f0 = match self.force(u) {
            Ok(f) => f,
            Err(_) => {
                values.fill(f64::NAN);
                return;
            }
        };
        values.fill(0.0);
        let groups = std::mem::take(&mut self.groups);
        for group in &groups {
            for l in 0..d {
                let mut probe = u.to_vec();
                for &b in group {
                    let mut c = D::to3(probe[b as usize]);
                    c[l] += self.step;
                    probe[b as usize] = D::from_slice(&c);
                }
                let f1 = self
                    .force(&probe)
                    .unwrap_or_else(|_| vec![D::from_slice(&[f64::NAN; 3][..d]); u.len()]);
                for &b in group {
                    let b = b as usize;
                    for q in pattern.offsets[b]..pattern.offsets[b + 1] {
                        let a = pattern.cols[q] as usize;
                        let df = D::to3(f1[a] - f0[a]);
                        for (k, df) in df.iter().enumerate().take(d) {
                            values[q * bs + l * d + k] = -df / self.step;
                        }
                    }
                }
            }
        }
        self.groups = groups;
    }

    fn inadmissible(&mut self, u: &[D::V]) -> Option<BlowUp> {
        self.force(u).err()
    }

    /// The method's own snapshot of the state at rest (its masses and bodies).
    fn snapshot<'a>(
        &'a mut self,
        u: &[D::V],
        v: &[D::V],
        _mass: &'a [f64],
        _body: &'a [u32],
    ) -> Snapshot<'a, D> {
        let y = self.method.moving(u, v);
        self.method.snapshot(&y)
    }

    fn describe(&self) -> String {
        if let Some(k) = self.method.closed_form() {
            return format!("; {}", k.describe());
        }
        format!(
            "; stiffness by finite differences of the method's forces, {} column groups × {} \
             components",
            self.groups.len(),
            D::N
        )
    }
}

/// Whether the constrained components of every body hold its rigid motions (d
/// translations and d(d − 1)/2 rotations): the rigid modes restricted to the
/// constrained components must be linearly independent, else the stiffness is singular.
/// Err names the body and the first free motion.
pub fn rigid_motions_held<D: Dim>(
    x0: &[D::V],
    body: &[u32],
    bodies: &[&str],
    constrained: &[(u32, u8)],
) -> Result<(), String> {
    let d = D::N;
    let names: Vec<&str> = if d == 2 {
        vec!["translation in x", "translation in y", "rotation about z"]
    } else {
        vec![
            "translation in x",
            "translation in y",
            "translation in z",
            "rotation about x",
            "rotation about y",
            "rotation about z",
        ]
    };
    let m = names.len();
    for (b, name) in bodies.iter().enumerate() {
        let members: Vec<usize> = (0..x0.len()).filter(|&i| body[i] as usize == b).collect();
        let centre: Vec<f64> = (0..3)
            .map(|k| members.iter().map(|&i| D::to3(x0[i])[k]).sum::<f64>() / members.len() as f64)
            .collect();
        let extent = members
            .iter()
            .map(|&i| {
                let x = D::to3(x0[i]);
                (0..3)
                    .map(|k| (x[k] - centre[k]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        // The rigid mode r_m at a point r (relative to the centre, over the extent): the
        // unit translations, then e_a × r for the rotation axes a (z only in 2D).
        let mode = |r: [f64; 3], mode: usize, k: usize| -> f64 {
            if mode < d {
                return f64::from(u8::from(mode == k));
            }
            let axis = if d == 2 { 2 } else { mode - d };
            let mut e = [0.0; 3];
            e[axis] = 1.0;
            let cross = [
                e[1] * r[2] - e[2] * r[1],
                e[2] * r[0] - e[0] * r[2],
                e[0] * r[1] - e[1] * r[0],
            ];
            cross[k]
        };
        let mut gram = vec![vec![0.0; m]; m];
        for &(i, mask) in constrained {
            if body[i as usize] as usize != b {
                continue;
            }
            let x = D::to3(x0[i as usize]);
            let r: [f64; 3] = std::array::from_fn(|k| (x[k] - centre[k]) / extent);
            for k in (0..d).filter(|&k| mask & (1 << k) != 0) {
                for (p, row) in gram.iter_mut().enumerate() {
                    for (q, g) in row.iter_mut().enumerate() {
                        *g += mode(r, p, k) * mode(r, q, k);
                    }
                }
            }
        }
        // Gaussian elimination of the (symmetric, semi-definite) Gram matrix: a pivot
        // below 1e-10 of the largest diagonal is a motion the constraints leave free.
        let scale = (0..m).map(|p| gram[p][p]).fold(0.0, f64::max);
        for p in 0..m {
            let pivot = gram[p][p];
            if pivot <= 1e-10 * scale || scale == 0.0 {
                return Err(format!(
                    "a static run needs the prescribed components (`fixed`, `velocity`, \
                     `symmetry`, `displacement`, `solution-displacement`) to hold every rigid \
                     motion of every body, else its stiffness is singular; body `{name}` is \
                     free in {} (and maybe more): prescribe more components",
                    names[p]
                ));
            }
            let top = gram[p].clone();
            for row in gram.iter_mut().skip(p + 1) {
                let s = row[p] / pivot;
                for (g, t) in row.iter_mut().zip(&top).skip(p) {
                    *g -= s * t;
                }
            }
        }
    }
    Ok(())
}
