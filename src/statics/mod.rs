//! The static path: equilibrium f_int(u) + λ f_ext = 0 by Newton–Raphson with load steps,
//! behind the driver's [`Engine`] trait (seed 004 §2), for any [`Model`] that gives its
//! internal force and its stiffness K = −∂f_int/∂u on a [`BlockPattern`]: the dual-support
//! energy with its assembled tangent ([`crate::methods::dual_support`]), and the explicit
//! methods through their own force evaluation with K by coloured finite differences
//! ([`explicit`]). A driver step of size Δt is a load step in the pseudo-time of the run:
//! the load factor is λ = t/end_time, tractions and prescribed displacements are scaled by
//! it, prescribed velocities give u = v t.

pub mod explicit;
pub mod newmark;
pub mod sparse;

use crate::boundary::{Boundary, Reaction};
use crate::case::{Case, CaseError};
use crate::core::tensor::Dim;
use crate::diagnostics::balance::Booked;
use crate::diagnostics::observe::Snapshot;
use crate::engine::{BlowUp, Engine, Failed, Iteration};
use newmark::Newmark;
use sparse::{BlockPattern, Fill, FreeSystem, Linear, SolveError, SolveStats};
use std::time::Instant;

/// What the Newton engine solves: a discretisation's internal force and stiffness.
pub trait Model<D: Dim> {
    /// Reference positions X of the particles.
    fn x0(&self) -> &[D::V];
    /// The internal force f_int(u) on every particle (R = f_int + λ f_ext), or the
    /// blow-up that the evaluation met.
    fn force(&mut self, u: &[D::V]) -> Result<Vec<D::V>, BlowUp>;
    /// K = −∂f_int/∂u at u into the d×d block values of `pattern`, row-major blocks (Kᵀ
    /// for [`Linear::Lu`], see there).
    fn stiffness(&mut self, u: &[D::V], pattern: &BlockPattern, values: &mut [f64]);
    /// The first particle of state u with det F ≤ 0 or a non-finite F, as a blow-up.
    fn inadmissible(&mut self, u: &[D::V]) -> Option<BlowUp>;
    /// The state (u, v) as observers and frames read it, with the engine's masses and
    /// bodies.
    fn snapshot<'a>(
        &'a mut self,
        u: &[D::V],
        v: &[D::V],
        mass: &'a [f64],
        body: &'a [u32],
    ) -> Snapshot<'a, D>;
    /// The `backend` line's account of the stiffness (how it is formed).
    fn describe(&self) -> String {
        String::new()
    }
}

/// Newton's linear step without an assembled stiffness: K(u) Δu = R solved from the
/// model's tangent by products alone (the GPU's matrix-free Krylov solve of dual-support
/// SPH, [`crate::methods::dual_support::krylov`]).
pub trait MatrixFree<D: Dim, S> {
    /// Solves K(u) Δu = r for `model` at displacement u, r and Δu on the free components
    /// (`free[a·d + k]` is the free index of component k of particle a, None where it is
    /// prescribed).
    fn solve(
        &mut self,
        model: &mut S,
        u: &[D::V],
        free: &[Option<u32>],
        r: &[f64],
    ) -> Result<(Vec<f64>, SolveStats), SolveError>;
    /// The `backend` line's account of the solver on `unknowns` unknowns.
    fn describe(&self, unknowns: usize) -> String;
    /// The device it solves on and what scales its passes' bytes, for the pass report
    /// (`--profile`).
    #[cfg(feature = "gpu")]
    fn device(&mut self) -> Option<(&crate::gpu::Gpu, crate::gpu::profile::Scale)>;
}

/// How Newton's linear step is formed and solved.
pub enum Linearisation<D: Dim, S> {
    /// K assembled on the pattern by [`Model::stiffness`], solved by the sparse solver.
    Assembled(BlockPattern, Linear),
    /// K never formed ([`MatrixFree`]).
    MatrixFree(Box<dyn MatrixFree<D, S>>),
}

/// The linear step of an engine, built on its free numbering.
enum Step<D: Dim, S> {
    Assembled(Box<Assembled>),
    MatrixFree(Box<dyn MatrixFree<D, S>>),
}

/// The assembled tangent's pattern, values and sparse solver.
struct Assembled {
    pattern: BlockPattern,
    values: Vec<f64>,
    system: FreeSystem,
    /// Non-zeros of the Cholesky factor and of the tangent's lower triangle.
    fill: Fill,
}

/// A constrained degree of freedom and its value u(t).
#[derive(Clone, Copy, Debug)]
struct Prescribed {
    dof: usize,
    /// u = velocity · t + displacement · t/end_time.
    velocity: f64,
    displacement: f64,
}

/// Why Newton stopped without converging.
struct Stalled {
    iterations: u32,
    residual: f64,
    particle: usize,
    reason: String,
    /// The iterations ran out after the relative residual had fallen below
    /// [`ROUND_OFF_DROP`] of its first value and then stopped falling (the last iteration
    /// left it above a tenth of the smallest before it): Newton converged as far as
    /// round-off lets it, and a smaller load step would not get further (its floor
    /// relative to its smaller load is higher), so the step is not cut.
    at_round_off: bool,
}

/// The fall of the relative residual within a load step beyond which a step whose
/// residual then stops falling is taken to have stalled at round-off, rather than to have
/// left Newton's region of convergence (a residual that grows or stays near its first
/// value, which cutting the step cures) or to be still converging.
const ROUND_OFF_DROP: f64 = 1e-6;

/// Newton settings.
#[derive(Clone, Copy, Debug)]
pub struct Newton {
    /// Stop when |R| ≤ this × the force scale ([`crate::case::Tolerance`]).
    pub residual_tolerance: f64,
    /// … or when |Δu| ≤ this × |u|.
    pub increment_tolerance: f64,
    /// Iterations of a load step before it is cut in half.
    pub max_iterations: u32,
    /// Halvings of a load step before the run fails.
    pub max_cuts: u32,
    /// Where `max_iterations` comes from, for the message of a stalled step.
    pub max_iterations_key: &'static str,
    /// Where the two tolerances come from (`run.tolerance.residual` and
    /// `run.tolerance.increment`), for the message of a stalled step.
    pub tolerance_keys: [&'static str; 2],
}

impl Newton {
    /// The settings of a case's `run.tolerance` with these iteration limits.
    pub fn of(case: &Case, max_iterations: u32, max_cuts: u32, key: &'static str) -> Self {
        Self {
            residual_tolerance: case.run.tolerance.residual(),
            increment_tolerance: case.run.tolerance.increment(),
            max_iterations,
            max_cuts,
            max_iterations_key: key,
            tolerance_keys: ["run.tolerance.residual", "run.tolerance.increment"],
        }
    }
}

/// The static engine of a model (CPU, f64).
pub struct Statics<D: Dim, S: Model<D>> {
    pub model: S,
    mass: Vec<f64>,
    body: Vec<u32>,
    boundary: Boundary<D>,
    /// Every constrained component, in the order of `boundary.constrained`.
    prescribed: Vec<Prescribed>,
    /// External forces of the full load (tractions).
    load: Vec<D::V>,
    step: Step<D, S>,
    /// Number of free degrees of freedom.
    unknowns: usize,
    /// Free index of every degree of freedom (a·d + k), None where prescribed.
    free: Vec<Option<u32>>,
    newton: Newton,
    end_time: f64,
    /// The converged state and its (pseudo-)time.
    pub u: Vec<D::V>,
    t: f64,
    /// The forces of loads and supports on the body at the converged state: −f_int, or
    /// M a − [(1 + α) f_int(u_{n+1}) − α f_int(u_n)] in an implicit run.
    reaction: Vec<D::V>,
    /// The inertia of an implicit run; None for a static one.
    inertia: Option<Inertia<D>>,
    work: f64,
    load_step: u64,
    log: Vec<Iteration>,
}

/// The motion of an implicit run ([`newmark`]): its scheme, and the velocities,
/// accelerations and internal forces of the converged state.
struct Inertia<D: Dim> {
    scheme: Newmark,
    v: Vec<D::V>,
    a: Vec<D::V>,
    /// f_int(u_n), the old end of HHT's average.
    f_int: Vec<D::V>,
}

impl<D: Dim> Inertia<D> {
    /// a_{n+1} of the displacement `u` from the converged state `u_n` (eq of
    /// [`Newmark::acceleration`], per particle).
    fn acceleration(&self, dt: f64, u: &[D::V], u_n: &[D::V]) -> Vec<D::V> {
        let s = self.scheme;
        (0..u.len())
            .map(|i| {
                let predicted = u_n[i] + self.v[i] * dt + self.a[i] * (dt * dt * (0.5 - s.beta));
                (u[i] - predicted) * s.mass_factor(dt)
            })
            .collect()
    }

    /// (1 + α) f_int(u) − α f_int(u_n) − M a(u): the residual G less the loads, with
    /// the acceleration a(u).
    fn effective(
        &self,
        dt: f64,
        f_int: &[D::V],
        u: &[D::V],
        u_n: &[D::V],
        mass: &[f64],
    ) -> (Vec<D::V>, Vec<D::V>) {
        let alpha = self.scheme.alpha;
        let a = self.acceleration(dt, u, u_n);
        let effective = (0..u.len())
            .map(|i| f_int[i] * (1.0 + alpha) - self.f_int[i] * alpha - a[i] * mass[i])
            .collect();
        (effective, a)
    }

    /// Moves the state to a step's converged u, of acceleration a (from
    /// [`Self::effective`]) and internal force f_int: a, v and f_int. Returns the forces
    /// of loads and supports that G balances, M a − [(1 + α) f_int(u) − α f_int(u_n)].
    fn advance(&mut self, dt: f64, a: Vec<D::V>, f_int: Vec<D::V>, mass: &[f64]) -> Vec<D::V> {
        let s = self.scheme;
        let applied = (0..a.len())
            .map(|i| a[i] * mass[i] - f_int[i] * (1.0 + s.alpha) + self.f_int[i] * s.alpha)
            .collect();
        for (i, a) in a.into_iter().enumerate() {
            self.v[i] = self.v[i] + (self.a[i] * (1.0 - s.gamma) + a * s.gamma) * dt;
            self.a[i] = a;
        }
        self.f_int = f_int;
        applied
    }
}

/// The parts of a static engine besides its model.
pub struct Setup<'a, D: Dim, S> {
    pub mass: Vec<f64>,
    pub body: Vec<u32>,
    /// The initial displacements and velocities (an implicit run's start).
    pub u0: Vec<D::V>,
    pub v0: Vec<D::V>,
    pub boundary: &'a Boundary<D>,
    pub linearisation: Linearisation<D, S>,
    pub newton: Newton,
}

impl<D: Dim, S: Model<D>> Statics<D, S> {
    /// The engine of `model`: the prescribed components of the boundary conditions, the
    /// loads and the free system of the pattern, built once. `key` names the case key
    /// that chose the linear solver, for its errors.
    pub fn with_model(
        case: &Case,
        model: S,
        setup: Setup<'_, D, S>,
        key: &str,
    ) -> Result<Self, CaseError> {
        let Setup {
            mass,
            body,
            u0,
            v0,
            boundary,
            linearisation,
            newton,
        } = setup;
        let n = mass.len();
        let d = D::N;
        let mut free = vec![Some(0u32); n * d];
        let mut prescribed = Vec::new();
        let velocity = |i: u32| {
            boundary
                .prescribed
                .iter()
                .find(|&&(p, _)| p == i)
                .map_or(D::zero(), |&(_, v)| v)
        };
        for &(i, mask) in &boundary.constrained {
            let (dmask, du) = boundary
                .displacement
                .iter()
                .find(|&&(p, _, _)| p == i)
                .map_or((0, D::zero()), |&(_, m, u)| (m, u));
            let v = velocity(i);
            for k in 0..d {
                if mask & (1 << k) == 0 {
                    continue;
                }
                let dof = i as usize * d + k;
                free[dof] = None;
                prescribed.push(if dmask & (1 << k) != 0 {
                    Prescribed {
                        dof,
                        velocity: 0.0,
                        displacement: D::comp(du, k),
                    }
                } else {
                    Prescribed {
                        dof,
                        velocity: D::comp(v, k),
                        displacement: 0.0,
                    }
                });
            }
        }
        for (next, f) in free.iter_mut().flatten().enumerate() {
            *f = next as u32;
        }
        let load = boundary.external_forces(&mass);
        let unknowns = free.iter().flatten().count();
        let step = match linearisation {
            Linearisation::Assembled(pattern, linear) => {
                let (system, fill) = FreeSystem::new(&pattern, d, &free, linear)
                    .map_err(|e| case.invalid(key, e.to_string()))?;
                Step::Assembled(Box::new(Assembled {
                    values: vec![0.0; pattern.blocks() * d * d],
                    pattern,
                    system,
                    fill,
                }))
            }
            Linearisation::MatrixFree(solver) => Step::MatrixFree(solver),
        };
        let mut inertia = case.is_implicit().then(|| Inertia {
            scheme: Newmark::hht(case.run.hht_alpha.unwrap_or(0.0)),
            v: v0,
            a: vec![D::zero(); n],
            f_int: Vec::new(),
        });
        if let Some(inertia) = &mut inertia {
            if matches!(step, Step::MatrixFree(_)) {
                return Err(case.invalid(
                    "run.solve",
                    "the implicit solve adds the mass to an assembled tangent, and this solve \
                     is matrix-free: run it on the CPU (--backend cpu)",
                ));
            }
            // The prescribed components move at their velocities, without acceleration.
            for p in &prescribed {
                Self::set(&mut inertia.v, p.dof, p.velocity);
            }
        }
        let mut engine = Self {
            model,
            mass,
            body,
            boundary: boundary.clone(),
            prescribed,
            load,
            step,
            unknowns,
            free,
            newton,
            end_time: case.run.end_time,
            u: u0,
            t: 0.0,
            reaction: vec![D::zero(); n],
            inertia,
            work: 0.0,
            load_step: 0,
            log: Vec::new(),
        };
        engine.start().map_err(|b| {
            case.invalid(
                "run.solve",
                format!(
                    "the implicit solve's initial force has {} = {:e} at particle {} (X = \
                     {:?}): the initial displacement is not admissible",
                    b.quantity, b.value, b.particle, b.position
                ),
            )
        })?;
        Ok(engine)
    }

    /// An implicit run's initial state: f_int(u0) and the accelerations a0 = (f_int +
    /// f_ext)/m of the free components (zero on the prescribed ones), with the reaction
    /// M a0 − f_int.
    fn start(&mut self) -> Result<(), BlowUp> {
        let Some(inertia) = &mut self.inertia else {
            return Ok(());
        };
        let f_int = self.model.force(&self.u)?;
        let d = D::N;
        for (i, a) in inertia.a.iter_mut().enumerate() {
            let (f, load) = (D::to3(f_int[i]), D::to3(self.load[i]));
            let mut c = [0.0; 3];
            for k in 0..d {
                if self.free[i * d + k].is_some() {
                    c[k] = (f[k] + load[k]) / self.mass[i];
                }
            }
            *a = D::from_slice(&c[..d]);
        }
        self.reaction = (0..f_int.len())
            .map(|i| inertia.a[i] * self.mass[i] - f_int[i])
            .collect();
        inertia.f_int = f_int;
        Ok(())
    }

    /// Number of free degrees of freedom.
    pub fn unknowns(&self) -> usize {
        self.unknowns
    }

    /// Solves K(u) Δu = r on the free components by the linear step of `model`; with
    /// `inertia` = ((s, c), M) the tangent is s K + c M with the lumped masses M (an
    /// implicit step: s = 1 + α, c = 1/(β Δt²)).
    fn solve_step(
        step: &mut Step<D, S>,
        model: &mut S,
        free: &[Option<u32>],
        u: &[D::V],
        r: &[f64],
        inertia: Option<((f64, f64), &[f64])>,
    ) -> Result<(Vec<f64>, SolveStats), SolveError> {
        match step {
            Step::Assembled(a) => {
                model.stiffness(u, &a.pattern, &mut a.values);
                if let Some(((scale, c), mass)) = inertia {
                    let d = D::N;
                    a.values.iter_mut().for_each(|k| *k *= scale);
                    for (row, &m) in mass.iter().enumerate() {
                        let Ok(k) = a.pattern.row(row).binary_search(&(row as u32)) else {
                            continue;
                        };
                        let block = (a.pattern.offsets[row] + k) * d * d;
                        for l in 0..d {
                            a.values[block + l * d + l] += c * m;
                        }
                    }
                }
                a.system.solve(&a.system.gather(&a.values), r)
            }
            Step::MatrixFree(solver) => solver.solve(model, u, free, r),
        }
    }

    fn set(u: &mut [D::V], dof: usize, value: f64) {
        let (i, k) = (dof / D::N, dof % D::N);
        let mut c = D::to3(u[i]);
        c[k] = value;
        u[i] = D::from_slice(&c);
    }

    /// u + the free components of du.
    fn add_free(&self, u: &mut [D::V], du: &[f64]) {
        for (dof, f) in self.free.iter().enumerate() {
            if let Some(q) = f {
                let (i, k) = (dof / D::N, dof % D::N);
                let mut c = D::to3(u[i]);
                c[k] += du[*q as usize];
                u[i] = D::from_slice(&c);
            }
        }
    }

    /// R = f_int + λ f_ext on the free components, |R| and |R| over the force scale
    /// √(|λ f_ext|² + |r|² + |f_int|²) of [`crate::case::Tolerance`], r the reactions on the prescribed
    /// components (zero where the scale is).
    fn residual(&self, f_int: &[D::V], lambda: f64) -> (Vec<f64>, f64, f64) {
        let d = D::N;
        let mut r = vec![0.0; self.unknowns];
        let (mut load, mut support, mut internal) = (0.0, 0.0, 0.0);
        for (a, (&fi, &fe)) in f_int.iter().zip(&self.load).enumerate() {
            let (fi, fe) = (D::to3(fi), D::to3(fe));
            for k in 0..d {
                let total = fi[k] + fe[k] * lambda;
                load += (fe[k] * lambda).powi(2);
                internal += fi[k] * fi[k];
                match self.free[a * d + k] {
                    Some(q) => r[q as usize] = total,
                    None => support += total * total,
                }
            }
        }
        let norm = r.iter().map(|x| x * x).sum::<f64>().sqrt();
        let scale = (load + support + internal).sqrt();
        let relative = if scale > 0.0 { norm / scale } else { 0.0 };
        (r, norm, relative)
    }

    /// The particle, of `particles`, with the largest residual |R_a| on its free
    /// components (`free`: the unknown of each component).
    fn worst_particle(free: &[Option<u32>], particles: usize, r: &[f64]) -> usize {
        let d = D::N;
        let n = |i: usize| {
            (0..d)
                .filter_map(|k| free[i * d + k].map(|q| r[q as usize].powi(2)))
                .sum::<f64>()
        };
        (0..particles)
            .max_by(|&a, &b| n(a).total_cmp(&n(b)))
            .unwrap_or(0)
    }

    /// Solves for equilibrium at pseudo-time t from the current state (Newton–Raphson):
    /// the prescribed components are moved to their values at t, then K Δu = R on the
    /// free components until |R| ≤ residual_tolerance · (force scale) or
    /// |Δu| ≤ increment_tolerance · |u| ([`crate::case::Tolerance`]). Returns the iterations, or why
    /// it stalled.
    ///
    /// In an implicit run t is time, the loads are whole (λ = 1), the residual is
    /// [`newmark`]'s G and the tangent (1 + α) K + M/(β Δt²); Newton starts from
    /// u_n + Δt v_n + ½ Δt² a_n, which moves the prescribed components at their velocity.
    fn solve_at(&mut self, t: f64) -> Result<u32, Stalled> {
        let dt = t - self.t;
        let lambda = if self.inertia.is_some() {
            1.0
        } else {
            t / self.end_time
        };
        let mut u = self.first_iterate(t, lambda);
        let shift = self.inertia.as_ref().map(|i| {
            let s = i.scheme;
            (1.0 + s.alpha, s.mass_factor(dt))
        });
        let mut increment = 0.0;
        let mut stats = SolveStats::default();
        // The smallest relative residual and relative increment met, for the message of
        // a step that does not converge.
        let (mut best_residual, mut best_increment) = (f64::INFINITY, f64::INFINITY);
        let mut first_residual = f64::NAN;
        for iteration in 0..=self.newton.max_iterations {
            let f_int = self.model.force(&u).map_err(|b| Stalled {
                iterations: iteration,
                residual: f64::NAN,
                particle: b.particle,
                reason: format!("{} = {:e}", b.quantity, b.value),
                at_round_off: false,
            })?;
            let (effective, a) = match &self.inertia {
                Some(inertia) => {
                    let (effective, a) = inertia.effective(dt, &f_int, &u, &self.u, &self.mass);
                    (effective, Some(a))
                }
                None => (f_int.clone(), None),
            };
            let (r, norm, relative) = self.residual(&effective, lambda);
            self.log.push(Iteration {
                load_step: self.load_step,
                time: t,
                iteration,
                residual: norm,
                relative_residual: relative,
                increment,
                linear_iterations: stats.iterations as u32,
                solve_seconds: stats.seconds,
                indefinite: stats.indefinite,
            });
            let worst = || Self::worst_particle(&self.free, self.mass.len(), &r);
            if !norm.is_finite() {
                return Err(Stalled {
                    iterations: iteration,
                    residual: norm,
                    particle: worst(),
                    reason: "the residual is not finite".into(),
                    at_round_off: false,
                });
            }
            let u_norm = u.iter().map(|&v| D::norm2(v)).sum::<f64>().sqrt();
            // The smallest relative residual before this iterate's.
            let earlier_best = best_residual;
            best_residual = best_residual.min(relative);
            if iteration == 0 {
                first_residual = relative;
            }
            if iteration > 0 {
                best_increment = best_increment.min(if u_norm > 0.0 {
                    increment / u_norm
                } else {
                    f64::INFINITY
                });
            }
            if relative <= self.newton.residual_tolerance
                || (iteration > 0 && increment <= self.newton.increment_tolerance * u_norm)
            {
                self.accept(u, f_int, a, dt);
                return Ok(iteration);
            }
            if iteration == self.newton.max_iterations {
                let [residual_key, increment_key] = self.newton.tolerance_keys;
                return Err(Stalled {
                    iterations: iteration,
                    residual: norm,
                    particle: worst(),
                    reason: format!(
                        "no convergence in {} = {} iterations: the relative residual |R|/(force \
                         scale) fell to {best_residual:.1e}, not to {residual_key} = {:e}, and \
                         |Δu|/|u| to {best_increment:.1e}, not to {increment_key} = {:e}; a \
                         residual that stops falling is at the round-off of this load (about \
                         1e-15 ÷ the strain): give a larger {residual_key}",
                        self.newton.max_iterations_key,
                        self.newton.max_iterations,
                        self.newton.residual_tolerance,
                        self.newton.increment_tolerance,
                    ),
                    at_round_off: best_residual <= ROUND_OFF_DROP * first_residual
                        && relative > 0.1 * earlier_best,
                });
            }
            let started = Instant::now();
            let inertia = shift.map(|s| (s, &self.mass[..]));
            let solved =
                Self::solve_step(&mut self.step, &mut self.model, &self.free, &u, &r, inertia);
            let (du, s) = solved.map_err(|e| Stalled {
                iterations: iteration,
                residual: norm,
                particle: worst(),
                reason: e.to_string(),
                at_round_off: false,
            })?;
            stats = SolveStats {
                seconds: started.elapsed().as_secs_f64(),
                ..s
            };
            self.add_free(&mut u, &du);
            increment = du.iter().map(|x| x * x).sum::<f64>().sqrt();
            if let Some(b) = self.model.inadmissible(&u) {
                return Err(Stalled {
                    iterations: iteration + 1,
                    residual: norm,
                    particle: b.particle,
                    reason: "det F ≤ 0 after the update".into(),
                    at_round_off: false,
                });
            }
        }
        unreachable!("the loop returns at max_iterations")
    }

    /// Newton's first iterate at (pseudo-)time t with load factor λ: Newmark's predictor
    /// in an implicit run; else the prescribed components moved to their values at t and
    /// the free ones predicted linearly ([`Self::predict`]).
    fn first_iterate(&mut self, t: f64, lambda: f64) -> Vec<D::V> {
        let mut u = self.u.clone();
        if let Some(inertia) = &self.inertia {
            let dt = t - self.t;
            for (i, u) in u.iter_mut().enumerate() {
                *u = *u + inertia.v[i] * dt + inertia.a[i] * (0.5 * dt * dt);
            }
            return u;
        }
        for p in &self.prescribed {
            Self::set(&mut u, p.dof, p.velocity * t + p.displacement * lambda);
        }
        self.predict(&u).unwrap_or(u)
    }

    /// Takes the converged u of a step of dt with its internal force (and in an implicit
    /// run its acceleration a): the reactions −f_int, or in an implicit run Newmark's v
    /// and a and the forces that G balances.
    fn accept(&mut self, u: Vec<D::V>, f_int: Vec<D::V>, a: Option<Vec<D::V>>, dt: f64) {
        match &mut self.inertia {
            Some(inertia) => {
                let a = a.unwrap_or_else(|| inertia.acceleration(dt, &u, &self.u));
                self.reaction = inertia.advance(dt, a, f_int, &self.mass);
            }
            None => self.reaction = f_int.iter().map(|&f| -f).collect(),
        }
        self.u = u;
    }

    /// The linearised predictor of a load step that moves prescribed components: with
    /// δ the move of the prescribed components from the converged state u₀ to `moved`,
    /// K_ff Δu_f = (∂f_int/∂u)δ on the free components (the directional derivative by a
    /// forward difference of 1e-7 δ), so that the free particles follow the prescribed
    /// ones to first order instead of being left behind: a top row moved by several
    /// spacings in one increment (seed 004 §6.5) otherwise inverts the particles next to
    /// it in the first Newton iterate. None when nothing prescribed moves, the solve
    /// fails or the predicted state has det F ≤ 0 (Newton then starts from `moved`).
    fn predict(&mut self, moved: &[D::V]) -> Option<Vec<D::V>> {
        let d = D::N;
        let delta: Vec<D::V> = moved.iter().zip(&self.u).map(|(&a, &b)| a - b).collect();
        let size = delta.iter().map(|&v| D::norm2(v)).sum::<f64>().sqrt();
        if size == 0.0 {
            return None;
        }
        let eps = 1e-7;
        let probe: Vec<D::V> = self
            .u
            .iter()
            .zip(&delta)
            .map(|(&u, &v)| u + v * eps)
            .collect();
        let u0 = self.u.clone();
        let (f0, f1) = (self.model.force(&u0).ok()?, self.model.force(&probe).ok()?);
        let mut r = vec![0.0; self.unknowns];
        for (a, (&x0, &x1)) in f0.iter().zip(&f1).enumerate() {
            let (x0, x1) = (D::to3(x0), D::to3(x1));
            for k in 0..d {
                if let Some(q) = self.free[a * d + k] {
                    r[q as usize] = (x1[k] - x0[k]) / eps;
                }
            }
        }
        let solved = Self::solve_step(&mut self.step, &mut self.model, &self.free, &u0, &r, None);
        let (du, _) = solved.ok()?;
        let mut u = moved.to_vec();
        self.add_free(&mut u, &du);
        (du.iter().all(|x| x.is_finite()) && self.model.inadmissible(&u).is_none()).then_some(u)
    }
}

impl<D: Dim, S: Model<D>> Engine<D> for Statics<D, S> {
    /// The converged state: its (pseudo-)time, step count, work, u and the reactions,
    /// and an implicit run's v, a and f_int.
    fn save(&mut self) -> Vec<f64> {
        let mut out = vec![self.t, self.load_step as f64, self.work];
        crate::core::parallel::save_field(&self.u, &mut out);
        crate::core::parallel::save_field(&self.reaction, &mut out);
        if let Some(inertia) = &self.inertia {
            for field in [&inertia.v, &inertia.a, &inertia.f_int] {
                crate::core::parallel::save_field(field, &mut out);
            }
        }
        out
    }

    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        let (&[t, load_step, work], mut rest) = words
            .split_first_chunk()
            .ok_or("the checkpoint holds no static state")?;
        crate::core::parallel::load_field(&mut self.u, "u", &mut rest)?;
        crate::core::parallel::load_field(&mut self.reaction, "reaction", &mut rest)?;
        if let Some(inertia) = &mut self.inertia {
            crate::core::parallel::load_field(&mut inertia.v, "v", &mut rest)?;
            crate::core::parallel::load_field(&mut inertia.a, "a", &mut rest)?;
            crate::core::parallel::load_field(&mut inertia.f_int, "f_int", &mut rest)?;
        }
        if !rest.is_empty() {
            return Err(format!(
                "{} words are left over after the static state",
                rest.len()
            ));
        }
        (self.t, self.load_step, self.work) = (t, load_step as u64, work);
        Ok(())
    }

    /// "cpu", with the linear solver, its size and (Cholesky) the fill of the factor; or
    /// the matrix-free solver's account.
    fn backend(&self) -> String {
        let n = self.unknowns;
        let (system, Fill { factor, lower }) = match &self.step {
            Step::Assembled(a) => (&a.system, a.fill),
            Step::MatrixFree(solver) => {
                return format!("{}{}", solver.describe(n), self.model.describe());
            }
        };
        let solver = match system.kind() {
            Linear::Cholesky => format!(
                "sparse Cholesky of {n} unknowns, factor {factor} non-zeros ({:.1}× the \
                 tangent's lower triangle, {lower})",
                factor as f64 / lower.max(1) as f64
            ),
            Linear::Lu => format!("sparse LU of {n} unknowns"),
            Linear::Cg(_) => format!("conjugate gradients on {n} unknowns"),
        };
        format!("cpu; {solver}{}", self.model.describe())
    }

    fn reference(&self) -> &[D::V] {
        self.model.x0()
    }

    fn constrained(&self) -> &[(u32, u8)] {
        &self.boundary.constrained
    }

    /// The supports' reactions at the converged state: the forces of loads and supports
    /// less the loads (at the load factor t/end_time of a static run, whole in an implicit
    /// one) on each prescribed component, whose power is at its (pseudo-)time rate (u =
    /// velocity·t + displacement·t/end_time).
    fn reactions(&mut self) -> Vec<Reaction> {
        let factor = match self.inertia {
            Some(_) => 1.0,
            None => self.t / self.end_time,
        };
        let mut prescribed = self.prescribed.iter();
        let (force, power): (Vec<D::V>, Vec<D::V>) = self
            .boundary
            .constrained
            .iter()
            .map(|&(i, mask)| {
                let f = self.reaction[i as usize] - self.load[i as usize] * factor;
                let (mut r, mut p) = ([0.0; 3], [0.0; 3]);
                for k in (0..D::N).filter(|k| mask & (1 << k) != 0) {
                    let c = prescribed.next().expect("one per constrained component");
                    r[k] = D::comp(f, k);
                    p[k] = r[k] * (c.velocity + c.displacement / self.end_time);
                }
                (D::from_slice(&r[..D::N]), D::from_slice(&p[..D::N]))
            })
            .unzip();
        self.boundary.reactions(&force, &power)
    }

    /// `steps` load steps of size dt; a step whose Newton iteration stalls is cut in
    /// halves (at most `max_cuts` times), each half solved in turn.
    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        for k in 0..steps {
            self.load_step += 1;
            let target = t + f64::from(k + 1) * dt;
            let mut h = target - self.t;
            let mut cuts = 0;
            while self.t < target * (1.0 - 1e-14) {
                let to = (self.t + h).min(target);
                let (u_before, reaction_before) = (self.u.clone(), self.reaction.clone());
                match self.solve_at(to) {
                    Ok(_) => {
                        // Trapezoidal work of loads and supports on the body, Σ f·Δu.
                        self.work += (0..self.u.len())
                            .map(|i| {
                                D::dot(
                                    (reaction_before[i] + self.reaction[i]) * 0.5,
                                    self.u[i] - u_before[i],
                                )
                            })
                            .sum::<f64>();
                        self.t = to;
                    }
                    Err(stalled) if cuts < self.newton.max_cuts && !stalled.at_round_off => {
                        self.u = u_before;
                        self.reaction = reaction_before;
                        h *= 0.5;
                        cuts += 1;
                    }
                    Err(stalled) => {
                        self.u = u_before;
                        self.reaction = reaction_before;
                        return Err(Failed {
                            completed: k,
                            cause: BlowUp::at::<D>(
                                self.model.x0(),
                                stalled.particle,
                                &format!(
                                    "Newton residual |R| at load factor {:.6} after {} \
                                     iteration(s) and {cuts} cut(s) of the load step to \
                                     {h:e} s ({}{}); the largest residual is at this particle",
                                    (self.t + h) / self.end_time,
                                    stalled.iterations,
                                    stalled.reason,
                                    if stalled.at_round_off && cuts < self.newton.max_cuts {
                                        "; not cut, as the residual had fallen by more than \
                                         six decades and stopped falling, and a smaller step \
                                         stalls the same way"
                                    } else {
                                        ""
                                    }
                                ),
                                stalled.residual,
                            ),
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// No wave speed: the static path steps the load by `method.dt`.
    fn max_signal_speed(&mut self) -> f64 {
        0.0
    }

    fn external_work(&mut self) -> f64 {
        self.work
    }

    /// The work of the loads and supports alone: a static solve has no kinetic energy,
    /// and an implicit one books no dissipation (HHT's numerical damping shows in the
    /// balance's residue).
    fn booked(&mut self) -> Booked {
        Booked::external(self.work)
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        if let Some(i) = self.u.iter().position(|&u| !D::is_finite_v(u)) {
            return Err(BlowUp::at::<D>(
                self.model.x0(),
                i,
                "displacement |u|",
                D::norm2(self.u[i]).sqrt(),
            ));
        }
        match self.model.inadmissible(&self.u) {
            Some(b) => Err(b),
            None => Ok(()),
        }
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        let v = match &self.inertia {
            Some(inertia) => inertia.v.clone(),
            None => vec![D::zero(); self.u.len()],
        };
        self.model.snapshot(&self.u, &v, &self.mass, &self.body)
    }

    fn iterations(&mut self) -> Vec<Iteration> {
        std::mem::take(&mut self.log)
    }

    /// The matrix-free solver's device, if it has one.
    #[cfg(feature = "gpu")]
    fn device(&mut self) -> Option<(&crate::gpu::Gpu, crate::gpu::profile::Scale)> {
        match &mut self.step {
            Step::MatrixFree(solver) => solver.device(),
            Step::Assembled(_) => None,
        }
    }
}
