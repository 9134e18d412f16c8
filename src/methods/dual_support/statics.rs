//! The static engine: Newton–Raphson with load steps on the dual-support energy (seed 004
//! §2), behind the driver's [`Engine`] trait. A driver step of size Δt is a load step in
//! the pseudo-time of the run: the load factor is t/end_time, tractions and prescribed
//! displacements are scaled by it, prescribed velocities give u = v t.

use super::DualSupportSpec;
use super::model::DualSupport;
use super::sparse::{BlockPattern, CgSettings, Fill, FreeSystem, SolveStats};
use crate::methods::BlowUp;
use crate::observe::{ScalarField, Snapshot};
use crate::reference::Reference;
use crate::run::{Engine, Failed, Iteration};
use crate::scene::{Case, CaseError};
use crate::tensor::Dim;
use rayon::prelude::*;
use std::time::Instant;

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
}

/// Newton settings of the spec.
#[derive(Clone, Copy, Debug)]
struct Newton {
    residual_tolerance: f64,
    increment_tolerance: f64,
    max_iterations: u32,
    max_cuts: u32,
}

/// The static dual-support engine (CPU, f64).
pub struct Statics<D: Dim> {
    pub model: DualSupport<D>,
    mass: Vec<f64>,
    body: Vec<u32>,
    constrained: Vec<(u32, u8)>,
    prescribed: Vec<Prescribed>,
    /// External forces of the full load (tractions).
    load: Vec<D::V>,
    pattern: BlockPattern,
    values: Vec<f64>,
    system: FreeSystem,
    /// Free index of every degree of freedom (a·d + k), None where prescribed.
    free: Vec<Option<u32>>,
    newton: Newton,
    end_time: f64,
    /// The converged state and its pseudo-time.
    pub u: Vec<D::V>,
    t: f64,
    /// −f_int at the converged state: the forces of loads and supports on the body.
    reaction: Vec<D::V>,
    work: f64,
    load_step: u64,
    log: Vec<Iteration>,
    /// Non-zeros of the Cholesky factor and of the tangent's lower triangle.
    pub fill: Fill,
}

impl<D: Dim> Statics<D> {
    /// Builds supports, the tangent's pattern and the free system once.
    pub fn new(case: &Case, spec: &DualSupportSpec) -> Result<Self, CaseError> {
        let mut reference = Reference::<D>::build(case)?;
        reference.h = spec.smoothing_lengths::<D>(case, &reference)?;
        let Reference {
            x0,
            vol,
            mass,
            body,
            boundary,
            material,
            h,
            ..
        } = reference;
        let support = super::support::Support::<D>::new(x0, vol, h, case.method.kernel)
            .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
        let model = DualSupport::new(support, material, spec.hourglass);
        let n = model.len();
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
        let mut load = vec![D::zero(); n];
        for &(i, a) in &boundary.external {
            load[i as usize] += a * mass[i as usize];
        }
        let pattern = BlockPattern::new(&model.support);
        let values = vec![0.0; pattern.blocks() * d * d];
        let cg = CgSettings {
            tolerance: spec.linear_tolerance,
            max_iterations: spec.linear_max_iterations as usize,
        };
        let (system, fill) = FreeSystem::new(&pattern, d, &free, spec.solver, cg)
            .map_err(|e| case.invalid("method.solver", e.to_string()))?;
        Ok(Self {
            model,
            mass,
            body,
            constrained: boundary.constrained.clone(),
            prescribed,
            load,
            pattern,
            values,
            system,
            free,
            newton: Newton {
                residual_tolerance: spec.residual_tolerance,
                increment_tolerance: spec.increment_tolerance,
                max_iterations: spec.max_iterations,
                max_cuts: spec.max_cuts,
            },
            end_time: case.run.end_time,
            u: vec![D::zero(); n],
            t: 0.0,
            reaction: vec![D::zero(); n],
            work: 0.0,
            load_step: 0,
            log: Vec::new(),
            fill,
        })
    }

    /// Number of free degrees of freedom.
    pub fn unknowns(&self) -> usize {
        self.system.n
    }

    fn set(u: &mut [D::V], dof: usize, value: f64) {
        let (i, k) = (dof / D::N, dof % D::N);
        let mut c = D::to3(u[i]);
        c[k] = value;
        u[i] = D::from_slice(&c);
    }

    /// Solves for equilibrium at pseudo-time t from the current state (Newton–Raphson):
    /// the prescribed components are moved to their values at t, then K Δu = R on the
    /// free components until |R| ≤ residual_tolerance · (force scale) or
    /// |Δu| ≤ increment_tolerance · |u|. Returns the iterations, or why it stalled.
    fn solve_at(&mut self, t: f64) -> Result<u32, Stalled> {
        let d = D::N;
        let lambda = t / self.end_time;
        let mut u = self.u.clone();
        for p in &self.prescribed {
            Self::set(&mut u, p.dof, p.velocity * t + p.displacement * lambda);
        }
        if let Some(predicted) = self.predict(&u) {
            u = predicted;
        }
        let mut increment = 0.0;
        let mut stats = SolveStats::default();
        for iteration in 0..=self.newton.max_iterations {
            let f_int = self.model.internal_force(&u, true);
            let mut r = vec![0.0; self.system.n];
            let mut scale = 0.0;
            for (a, (&fi, &fe)) in f_int.iter().zip(&self.load).enumerate() {
                let (fi, fe) = (D::to3(fi), D::to3(fe));
                for k in 0..d {
                    let total = fi[k] + fe[k] * lambda;
                    scale += fi[k] * fi[k] + (fe[k] * lambda).powi(2);
                    if let Some(q) = self.free[a * d + k] {
                        r[q as usize] = total;
                    }
                }
            }
            let norm = r.iter().map(|x| x * x).sum::<f64>().sqrt();
            let scale = scale.sqrt();
            let relative = if scale > 0.0 { norm / scale } else { 0.0 };
            self.log.push(Iteration {
                load_step: self.load_step,
                time: t,
                iteration,
                residual: norm,
                relative_residual: relative,
                increment,
                linear_iterations: stats.iterations as u32,
                solve_seconds: stats.seconds,
            });
            let worst = || {
                (0..self.model.len())
                    .max_by(|&a, &b| {
                        let n = |i: usize| {
                            (0..d)
                                .filter_map(|k| self.free[i * d + k].map(|q| r[q as usize].powi(2)))
                                .sum::<f64>()
                        };
                        n(a).total_cmp(&n(b))
                    })
                    .unwrap_or(0)
            };
            if !norm.is_finite() {
                return Err(Stalled {
                    iterations: iteration,
                    residual: norm,
                    particle: worst(),
                    reason: "the residual is not finite".into(),
                });
            }
            let u_norm = u.iter().map(|&v| D::norm2(v)).sum::<f64>().sqrt();
            if relative <= self.newton.residual_tolerance
                || (iteration > 0 && increment <= self.newton.increment_tolerance * u_norm)
            {
                self.u = u;
                self.reaction = f_int.iter().map(|&f| -f).collect();
                return Ok(iteration);
            }
            if iteration == self.newton.max_iterations {
                return Err(Stalled {
                    iterations: iteration,
                    residual: norm,
                    particle: worst(),
                    reason: format!(
                        "no convergence in method.max_iterations = {} iterations",
                        self.newton.max_iterations
                    ),
                });
            }
            let started = Instant::now();
            let tangents = self.model.tangents(&u);
            self.model
                .stiffness(&tangents, &self.pattern, &mut self.values);
            let k = self.system.gather(&self.values);
            let (du, s) = self.system.solve(&k, &r).map_err(|e| Stalled {
                iterations: iteration,
                residual: norm,
                particle: worst(),
                reason: e.to_string(),
            })?;
            stats = SolveStats {
                iterations: s.iterations,
                seconds: started.elapsed().as_secs_f64(),
            };
            for (dof, f) in self.free.iter().enumerate() {
                if let Some(q) = f {
                    let (i, k) = (dof / d, dof % d);
                    let mut c = D::to3(u[i]);
                    c[k] += du[*q as usize];
                    u[i] = D::from_slice(&c);
                }
            }
            increment = du.iter().map(|x| x * x).sum::<f64>().sqrt();
            if let Some(i) = self.inadmissible(&u) {
                return Err(Stalled {
                    iterations: iteration + 1,
                    residual: norm,
                    particle: i,
                    reason: "det F ≤ 0 after the update".into(),
                });
            }
        }
        unreachable!("the loop returns at max_iterations")
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
        let (f0, f1) = (
            self.model.internal_force(&self.u, true),
            self.model.internal_force(&probe, true),
        );
        let mut r = vec![0.0; self.system.n];
        for (a, (&x0, &x1)) in f0.iter().zip(&f1).enumerate() {
            let (x0, x1) = (D::to3(x0), D::to3(x1));
            for k in 0..d {
                if let Some(q) = self.free[a * d + k] {
                    r[q as usize] = (x1[k] - x0[k]) / eps;
                }
            }
        }
        let tangents = self.model.tangents(&self.u);
        self.model
            .stiffness(&tangents, &self.pattern, &mut self.values);
        let k = self.system.gather(&self.values);
        let (du, _) = self.system.solve(&k, &r).ok()?;
        let mut u = moved.to_vec();
        for (dof, f) in self.free.iter().enumerate() {
            if let Some(q) = f {
                let (i, c) = (dof / d, dof % d);
                let mut v = D::to3(u[i]);
                v[c] += du[*q as usize];
                u[i] = D::from_slice(&v);
            }
        }
        (du.iter().all(|x| x.is_finite()) && self.inadmissible(&u).is_none()).then_some(u)
    }

    /// The first particle with det F ≤ 0 or a non-finite F.
    fn inadmissible(&self, u: &[D::V]) -> Option<usize> {
        let f = self.model.deformation_gradients(u);
        f.par_iter()
            .position_first(|&f| !D::is_finite_t(f) || D::det(f) <= 0.0 || D::det(f).is_nan())
    }
}

impl<D: Dim> Engine<D> for Statics<D> {
    /// The converged state: its pseudo-time, load-step count, work, u and the reactions.
    fn save(&mut self) -> Vec<f64> {
        let mut out = vec![self.t, self.load_step as f64, self.work];
        crate::methods::shared::save_field(&self.u, &mut out);
        crate::methods::shared::save_field(&self.reaction, &mut out);
        out
    }

    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        let (&[t, load_step, work], mut rest) = words
            .split_first_chunk()
            .ok_or("the checkpoint holds no static state")?;
        crate::methods::shared::load_field(&mut self.u, "u", &mut rest)?;
        crate::methods::shared::load_field(&mut self.reaction, "reaction", &mut rest)?;
        if !rest.is_empty() {
            return Err(format!(
                "{} words are left over after the static state",
                rest.len()
            ));
        }
        (self.t, self.load_step, self.work) = (t, load_step as u64, work);
        Ok(())
    }

    /// "cpu", with the linear solver, its size and (direct) the fill of the factor.
    fn backend(&self) -> String {
        let Fill { factor, lower } = self.fill;
        if factor > 0 {
            format!(
                "cpu; sparse Cholesky of {} unknowns, factor {factor} non-zeros ({:.1}× the \
                 tangent's lower triangle, {lower})",
                self.system.n,
                factor as f64 / lower.max(1) as f64
            )
        } else {
            format!("cpu; conjugate gradients on {} unknowns", self.system.n)
        }
    }

    fn reference(&self) -> &[D::V] {
        &self.model.support.x0
    }

    fn constrained(&self) -> &[(u32, u8)] {
        &self.constrained
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
                    Err(_) if cuts < self.newton.max_cuts => {
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
                                &self.model.support.x0,
                                stalled.particle,
                                &format!(
                                    "Newton residual |R| at load factor {:.6} after {} \
                                     iteration(s) and {cuts} cut(s) of the load step to \
                                     {h:e} s ({}); the largest residual is at this particle",
                                    (self.t + h) / self.end_time,
                                    stalled.iterations,
                                    stalled.reason
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

    fn check(&mut self) -> Result<(), BlowUp> {
        let x0 = &self.model.support.x0;
        if let Some(i) = self.u.iter().position(|&u| !D::is_finite_v(u)) {
            return Err(BlowUp::at::<D>(
                x0,
                i,
                "displacement |u|",
                D::norm2(self.u[i]).sqrt(),
            ));
        }
        if let Some(i) = self.inadmissible(&self.u) {
            let f = self.model.deformation_gradients(&self.u);
            return Err(BlowUp::at::<D>(x0, i, "det F", D::det(f[i])));
        }
        Ok(())
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        let model = &self.model;
        let f = model.deformation_gradients(&self.u);
        let material = &model.material;
        let sigma = f
            .par_iter()
            .map(|&f| {
                let mut s = D::to3x3(material.pk1::<D>(f) * D::transpose(f) * (1.0 / D::det(f)));
                if D::N == 2 {
                    s[2][2] = material.sigma_zz::<D>(f, D::zero_t(), material.rho0);
                }
                s
            })
            .collect();
        let energies = model.energies(&self.u);
        let hourglass = model.hourglass_densities(&self.u);
        Snapshot {
            x0: &model.support.x0,
            mass: &self.mass,
            body: &self.body,
            u: self.u.clone(),
            v: vec![D::zero(); self.u.len()],
            f,
            sigma,
            strain_energy: energies.strain,
            extra: vec![
                ScalarField {
                    name: "hourglass_energy_density",
                    values: hourglass,
                },
                // The frames' smoothing length: this method's own, per particle.
                ScalarField {
                    name: "smoothing_length",
                    values: model.support.h.clone(),
                },
            ],
            cells: &[],
        }
    }

    fn iterations(&mut self) -> Vec<Iteration> {
        std::mem::take(&mut self.log)
    }
}
