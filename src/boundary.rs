//! Boundary conditions on regions of the reference configuration.
//!
//! Prescribed velocity components are imposed on the initial state and their rates are
//! set at every evaluation (zero for a constant one), so every integrator keeps them
//! exactly and the displacement of a prescribed component follows u = u0 + ∫ v dt
//! without overwriting. A prescribed velocity under a time law, or released at a time
//! (`until`), is a [`TimedVelocity`]: over each step its rate is the law's mean rate over
//! the step, held through the step's stages, and it is released from the first step whose
//! middle is at or after `until`.
//!
//! Loads that vary in time (a traction with a time law, a pressure) are not constant
//! accelerations here but forces of [`timed_loads`], which the interaction
//! [`crate::interaction::TimedLoads`] scales at every step.

use crate::diagnostics::analytic::ClosedForm;

use crate::case::{Case, CaseError, Condition, Discretised, TimeLaw};
use crate::core::sum::Exact;
use crate::core::tensor::Dim;

mod loads;

pub use loads::{
    ConditionTotal, NodalForces, OnPatches, SurfacePoint, TimedLoad, condition_totals, timed_loads,
};
use loads::{selected, surface_points};

/// The constraints and external loads of a scene, as sparse per-particle lists.
#[derive(Clone, Debug)]
pub struct Boundary<D: Dim> {
    /// (particle, bit mask of constrained velocity components): every component a
    /// condition prescribes at some time.
    pub constrained: Vec<(u32, u8)>,
    /// The mask of the components of each entry of `constrained` held for the whole run
    /// (those of no [`TimedVelocity`]).
    held: Vec<u8>,
    /// The support (index among the case's supports, [`supports`]) that prescribes each
    /// component of each entry of `constrained`: the last condition to set it.
    support_of: Vec<[u16; 3]>,
    /// The number of supports.
    supports: usize,
    /// (particle, prescribed velocity; only the masked components are meaningful; under a
    /// time law, the velocity at law value 1).
    pub prescribed: Vec<(u32, D::V)>,
    /// (particle, bit mask of the constrained components whose displacement is
    /// prescribed (reached at the end time; static path), displacement): a subset of
    /// `constrained`, whose other components have prescribed velocities.
    pub displacement: Vec<(u32, u8, D::V)>,
    /// The points of the constant surface loads (tractions and pressures) and their
    /// forces ([`SurfacePoint`]).
    surface: Vec<SurfacePoint<D>>,
    /// (particle, force) of the constant surface loads, carried to the nodes as the
    /// method that holds the boundary does it ([`Self::use_method`]; each point's force
    /// to the particle whose patch holds it until then), whatever the nodal masses.
    forces: Vec<(u32, D::V)>,
    /// (particle, acceleration g) of the constant body forces.
    gravity: Vec<(u32, D::V)>,
    /// (particle, external acceleration f/m + g) for the nodal forces and masses of the
    /// method that holds the boundary ([`Self::use_method`]; the particle masses ρ0 V0
    /// until then).
    pub external: Vec<(u32, D::V)>,
    /// The prescribed velocities that vary in time, one per condition.
    pub timed: Vec<TimedVelocity>,
    /// (particle, component k, index into `timed`, prescribed velocity at law value 1) of
    /// every component a [`TimedVelocity`] prescribes, by particle and component.
    pub timed_components: Vec<(u32, u8, u32, f64)>,
    /// Each timed velocity over the current step (None: released).
    step: Vec<Option<TimedStep>>,
    /// The number of particles (the device's dense layout).
    #[cfg(feature = "gpu")]
    n: usize,
}

/// What the boundary conditions prescribe at each particle, as they are resolved in case
/// order: a later condition overrides the components an earlier one set.
struct Prescribed<D: Dim> {
    /// The components whose velocity is prescribed, and the velocity.
    mask: Vec<u8>,
    value: Vec<D::V>,
    /// The constant body forces' accelerations g.
    gravity: Vec<D::V>,
    /// The components whose displacement is prescribed, and the displacement.
    dmask: Vec<u8>,
    dvalue: Vec<[f64; 3]>,
    /// The timed velocity of each component (index into `timed`), if one prescribes it.
    timed_of: Vec<[Option<u32>; 3]>,
    /// The support of each component, for the prescribed ones.
    support_of: Vec<[u16; 3]>,
}

impl<D: Dim> Prescribed<D> {
    /// Nothing prescribed at n particles.
    fn new(n: usize) -> Self {
        Self {
            mask: vec![0u8; n],
            value: vec![D::zero(); n],
            gravity: vec![D::zero(); n],
            dmask: vec![0u8; n],
            dvalue: vec![[0.0; 3]; n],
            timed_of: vec![[None::<u32>; 3]; n],
            support_of: vec![[0u16; 3]; n],
        }
    }

    /// Applies `condition` to particle i at reference position x0: its support s and,
    /// for a timed velocity, its index `timed`. Surface loads have their points instead.
    fn hold(
        &mut self,
        case: &Case,
        x0: D::V,
        i: usize,
        condition: &Condition,
        s: u16,
        timed: Option<u32>,
    ) {
        match condition {
            Condition::Fixed {} => {
                self.mask[i] = (1 << D::N) - 1;
                self.dmask[i] = 0;
                self.value[i] = D::zero();
                self.timed_of[i] = [None; 3];
                self.support_of[i] = [s; 3];
            }
            Condition::Velocity { vx, vy, vz, .. } => {
                let mut v = D::to3(self.value[i]);
                for (k, c) in [vx, vy, vz].iter().enumerate().take(D::N) {
                    if let Some(c) = c {
                        self.mask[i] |= 1 << k;
                        self.dmask[i] &= !(1 << k);
                        v[k] = *c;
                        self.timed_of[i][k] = timed;
                        self.support_of[i][k] = s;
                    }
                }
                self.value[i] = D::from_slice(&v);
            }
            Condition::Symmetry { normal } => {
                let k = normal.index();
                self.mask[i] |= 1 << k;
                self.dmask[i] &= !(1 << k);
                let mut v = D::to3(self.value[i]);
                v[k] = 0.0;
                self.value[i] = D::from_slice(&v);
                self.timed_of[i][k] = None;
                self.support_of[i][k] = s;
            }
            Condition::BodyForce { acceleration, .. } => {
                self.gravity[i] += D::from_slice(acceleration);
            }
            // Their points, above.
            Condition::Traction { .. }
            | Condition::SolutionTraction { .. }
            | Condition::Pressure { .. } => {}
            Condition::Displacement { ux, uy, uz } => {
                for (k, c) in [ux, uy, uz].iter().enumerate().take(D::N) {
                    if let Some(c) = c {
                        self.mask[i] |= 1 << k;
                        self.dmask[i] |= 1 << k;
                        self.dvalue[i][k] = *c;
                        self.timed_of[i][k] = None;
                        self.support_of[i][k] = s;
                    }
                }
            }
            Condition::SolutionDisplacement {
                solution,
                components,
            } => {
                let u = ClosedForm::of(solution, &case.material).displacement3(D::to3(x0));
                for k in components.iter().map(|a| a.index()) {
                    self.mask[i] |= 1 << k;
                    self.dmask[i] |= 1 << k;
                    self.dvalue[i][k] = u[k];
                    self.timed_of[i][k] = None;
                    self.support_of[i][k] = s;
                }
            }
        }
    }
}

/// The force a support applies to hold the components it prescribes,
/// R = Σ m (a_prescribed − a) over them, and its power R·v, at a rate evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reaction {
    pub force: [f64; 3],
    pub power: f64,
}

/// A support's [`Reaction`] as exact sums over its particles' components, which the
/// ranks of a distributed run add without rounding.
#[derive(Clone, Debug, Default)]
pub struct ReactionSum {
    pub force: [Exact; 3],
    pub power: Exact,
}

impl ReactionSum {
    /// The reaction, each sum rounded once.
    pub fn value(&self) -> Reaction {
        Reaction {
            force: self.force.each_ref().map(Exact::value),
            power: self.power.value(),
        }
    }
}

/// The supports of a case, the boundary conditions that prescribe motion, in case order:
/// (index among the case's boundary conditions, name).
pub fn supports(case: &Case) -> Vec<(usize, String)> {
    case.boundaries
        .iter()
        .enumerate()
        .filter(|(_, b)| b.condition.is_support())
        .map(|(k, b)| (k, b.name(k)))
        .collect()
}

/// A prescribed velocity v_p·law(t) held while t < `until` (for the whole run without
/// it), its components free from then on.
#[derive(Clone, Debug, PartialEq)]
pub struct TimedVelocity {
    pub law: TimeLaw,
    pub until: Option<f64>,
}

/// A [`TimedVelocity`] over one step, on the component with v_p at law value 1: the
/// rate v_p·`rate` held through the step's stages, and v_p·`value` at the step's end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimedStep {
    pub rate: f64,
    pub value: f64,
}

impl TimedVelocity {
    /// Whether the condition holds over the step from t to t + Δt: its middle before
    /// `until` (so the release is off by Δt/2 at most).
    pub fn holds(&self, t: f64, dt: f64) -> bool {
        self.until.is_none_or(|until| t + 0.5 * dt < until)
    }

    /// The condition over the step from t to t + Δt (Δt > 0), None once released: the
    /// mean rate (law(t + Δt) − law(t))/Δt, which every integrator (its weights summing
    /// to one) turns into v_p·law(t + Δt) at the step's end from v_p·law(t) at its start,
    /// at jumps of a table as well.
    pub fn over_step(&self, t: f64, dt: f64) -> Option<TimedStep> {
        self.holds(t, dt).then(|| {
            let value = self.law.at(t + dt);
            TimedStep {
                rate: (value - self.law.at(t)) / dt,
                value,
            }
        })
    }

    /// The condition at the start t = 0, before any step: held at law(0), no rate.
    fn at_start(&self) -> Option<TimedStep> {
        self.until
            .is_none_or(|until| until > 0.0)
            .then(|| TimedStep {
                rate: 0.0,
                value: self.law.at(0.0),
            })
    }
}

impl<D: Dim> Boundary<D> {
    /// Resolves the case's boundary conditions to particles.
    pub fn build(case: &Case, disc: &Discretised<D>, mass: &[f64]) -> Result<Self, CaseError> {
        let mut at = Prescribed::<D>::new(disc.x0.len());
        let mut surface = Vec::new();
        let supports = supports(case);
        let support = |b: usize| supports.iter().position(|s| s.0 == b).unwrap_or(0) as u16;
        let mut timed = Vec::new();
        for (b, bc) in case.boundaries.iter().enumerate() {
            let particles = selected::<D>(case, b, &disc.x0, &disc.body)?;
            if bc.condition.is_timed_load() {
                // Forces of `timed_loads`.
                continue;
            }
            // The timed velocity this condition is, if it is one.
            let this_timed = match &bc.condition {
                Condition::Velocity { law, until, .. } if bc.condition.is_timed_velocity() => {
                    timed.push(TimedVelocity {
                        law: law.clone(),
                        until: *until,
                    });
                    Some(timed.len() as u32 - 1)
                }
                _ => None,
            };
            surface.extend(surface_points::<D>(
                case, b, &particles, &disc.x0, &disc.body,
            )?);
            let s = support(b);
            for i in particles {
                at.hold(case, disc.x0[i], i, &bc.condition, s, this_timed);
            }
        }
        let Prescribed {
            mask,
            value,
            gravity,
            dmask,
            dvalue,
            timed_of,
            support_of,
        } = at;
        let constrained: Vec<u32> = (0..mask.len() as u32)
            .filter(|&i| mask[i as usize] != 0)
            .collect();
        let timed_mask = |i: usize| {
            (0..D::N)
                .filter(|&k| timed_of[i][k].is_some())
                .fold(0u8, |m, k| m | 1 << k)
        };
        let timed_components = constrained
            .iter()
            .flat_map(|&i| {
                let (timed_of, v) = (timed_of[i as usize], D::to3(value[i as usize]));
                (0..D::N).filter_map(move |k| timed_of[k].map(|g| (i, k as u8, g, v[k])))
            })
            .collect();
        let mut boundary = Self {
            displacement: constrained
                .iter()
                .filter(|&&i| dmask[i as usize] != 0)
                .map(|&i| {
                    let i = i as usize;
                    (i as u32, dmask[i], D::from_slice(&dvalue[i]))
                })
                .collect(),
            prescribed: constrained
                .iter()
                .map(|&i| (i, value[i as usize]))
                .collect(),
            held: constrained
                .iter()
                .map(|&i| mask[i as usize] & !timed_mask(i as usize))
                .collect(),
            support_of: constrained
                .iter()
                .map(|&i| support_of[i as usize])
                .collect(),
            supports: supports.len(),
            constrained: constrained.iter().map(|&i| (i, mask[i as usize])).collect(),
            surface,
            forces: Vec::new(),
            gravity: summed::<D>(
                gravity.len(),
                gravity.into_iter().enumerate().map(|(i, g)| (i as u32, g)),
            ),
            external: Vec::new(),
            step: timed.iter().map(TimedVelocity::at_start).collect(),
            timed,
            timed_components,
            #[cfg(feature = "gpu")]
            n: disc.x0.len(),
        };
        boundary.use_method(&OnPatches, mass)?;
        Ok(boundary)
    }

    /// The conditions and loads of the particles a rank owns, in its local indices:
    /// `ids` the global id of each local particle (ascending), `owned` whether the rank
    /// owns it. A ghost's rates come from its owner, constraints included, so a rank
    /// holds the conditions of its own particles only, and its reactions and powers are
    /// its share of the run's.
    pub fn restrict(&self, ids: &[u32], owned: &[bool]) -> Self {
        let local = |g: u32| {
            let i = ids.binary_search(&g).ok().filter(|&i| owned[i])?;
            Some(i as u32)
        };
        let pairs = |all: &[(u32, D::V)]| -> Vec<(u32, D::V)> {
            all.iter()
                .filter_map(|&(g, x)| Some((local(g)?, x)))
                .collect()
        };
        let slots: Vec<(usize, u32)> = (self.constrained.iter().enumerate())
            .filter_map(|(k, &(g, _))| Some((k, local(g)?)))
            .collect();
        Self {
            constrained: slots
                .iter()
                .map(|&(k, i)| (i, self.constrained[k].1))
                .collect(),
            held: slots.iter().map(|&(k, _)| self.held[k]).collect(),
            support_of: slots.iter().map(|&(k, _)| self.support_of[k]).collect(),
            supports: self.supports,
            prescribed: pairs(&self.prescribed),
            displacement: (self.displacement.iter())
                .filter_map(|&(g, mask, u)| Some((local(g)?, mask, u)))
                .collect(),
            surface: (self.surface.iter())
                .filter_map(|&p| {
                    Some(SurfacePoint {
                        particle: local(p.particle)?,
                        ..p
                    })
                })
                .collect(),
            forces: pairs(&self.forces),
            gravity: pairs(&self.gravity),
            external: pairs(&self.external),
            timed: self.timed.clone(),
            timed_components: (self.timed_components.iter())
                .filter_map(|&(g, k, law, vp)| Some((local(g)?, k, law, vp)))
                .collect(),
            step: self.step.clone(),
            #[cfg(feature = "gpu")]
            n: ids.len(),
        }
    }

    /// Sets the nodal forces of the surface loads as the method that holds the boundary
    /// carries them (`nodal`) and the external accelerations f/m + g for its nodal
    /// masses m, so that the loads' forces do not depend on how a method lumps its mass
    /// (a row-sum mass gives a corner node a quarter of a particle's).
    pub fn use_method(
        &mut self,
        nodal: &dyn NodalForces<D>,
        mass: &[f64],
    ) -> Result<(), CaseError> {
        self.forces = summed::<D>(mass.len(), nodal.spread(&self.surface)?);
        let per_mass = self
            .forces
            .iter()
            .map(|&(i, f)| (i, f * (1.0 / mass[i as usize])));
        self.external = summed::<D>(mass.len(), per_mass.chain(self.gravity.iter().copied()));
        Ok(())
    }

    /// The external force f + m g on every particle for the nodal masses m: the applied
    /// load of a static solve.
    pub fn external_forces(&self, mass: &[f64]) -> Vec<D::V> {
        let mut load = vec![D::zero(); mass.len()];
        for &(i, f) in &self.forces {
            load[i as usize] += f;
        }
        for &(i, g) in &self.gravity {
            load[i as usize] += g * mass[i as usize];
        }
        load
    }

    /// Sets the timed velocities for the step from t to t + Δt (before it, as the
    /// interactions' `begin_step`).
    pub fn begin_step(&mut self, t: f64, dt: f64) {
        for (step, timed) in self.step.iter_mut().zip(&self.timed) {
            *step = timed.over_step(t, dt);
        }
    }

    /// Overwrites the constrained components of velocities v with the prescribed ones:
    /// those of the timed velocities still held at their values at the end of the
    /// current step (at t = 0 before the first step).
    pub fn impose(&self, v: &mut [D::V]) {
        for (&(i, prescribed), &held) in self.prescribed.iter().zip(&self.held) {
            v[i as usize] = mix::<D>(held, prescribed, v[i as usize]);
        }
        for &(i, k, g, vp) in &self.timed_components {
            if let Some(step) = self.step[g as usize] {
                set_component::<D>(&mut v[i as usize], k, vp * step.value);
            }
        }
    }

    /// Adds external accelerations and sets the constrained components of `a` to their
    /// rates (zero, or a timed velocity's v_p·rate while it holds). Each support's
    /// [`Reaction`] goes to `reactions` (one per support). Returns the power of the
    /// supports, Σ m (a_k,prescribed − a_k) v_k over constrained components (their work
    /// rate on the body).
    pub fn apply(
        &self,
        a: &mut [D::V],
        v: &[D::V],
        mass: &[f64],
        reactions: &mut Vec<ReactionSum>,
    ) -> Exact {
        for &(i, g) in &self.external {
            a[i as usize] += g;
        }
        reactions.clear();
        reactions.resize(self.supports, ReactionSum::default());
        // The reaction m (rate − a_k) on component k of the particle in `slot`.
        let mut hold = |slot: usize, k: usize, rate: f64, a: &mut D::V| {
            let i = self.constrained[slot].0 as usize;
            let force = mass[i] * (rate - D::comp(*a, k));
            self.book(reactions, slot, k, force, force * D::comp(v[i], k));
            set_component::<D>(a, k as u8, rate);
        };
        for (slot, (&(i, _), &held)) in self.constrained.iter().zip(&self.held).enumerate() {
            for k in (0..D::N).filter(|k| held & (1 << k) != 0) {
                hold(slot, k, 0.0, &mut a[i as usize]);
            }
        }
        for &(i, k, g, vp) in &self.timed_components {
            if let Some(step) = self.step[g as usize] {
                let slot = self.slot(i);
                hold(slot, usize::from(k), vp * step.rate, &mut a[i as usize]);
            }
        }
        reactions.iter().map(|r| &r.power).sum()
    }

    /// The index in `constrained` of constrained particle i.
    fn slot(&self, i: u32) -> usize {
        self.constrained
            .binary_search_by_key(&i, |c| c.0)
            .expect("a timed component's particle is constrained")
    }

    /// Books the reaction force and power on component k of the particle in `slot` to the
    /// support that prescribes it.
    fn book(&self, reactions: &mut [ReactionSum], slot: usize, k: usize, force: f64, power: f64) {
        let reaction = &mut reactions[usize::from(self.support_of[slot][k])];
        reaction.force[k].add(force);
        reaction.power.add(power);
    }

    /// The supports' reactions from the reaction force and its power on each component of
    /// every constrained particle (`force` and `power`, by entry of `constrained`; zero on
    /// the components it does not prescribe).
    pub fn reactions(&self, force: &[D::V], power: &[D::V]) -> Vec<Reaction> {
        let mut reactions = vec![ReactionSum::default(); self.supports];
        for (slot, (&(_, mask), (&f, &p))) in self
            .constrained
            .iter()
            .zip(force.iter().zip(power))
            .enumerate()
        {
            for k in (0..D::N).filter(|k| mask & (1 << k) != 0) {
                self.book(&mut reactions, slot, k, D::comp(f, k), D::comp(p, k));
            }
        }
        reactions.iter().map(ReactionSum::value).collect()
    }

    /// (particle, mask of the components prescribed over the current step) of every
    /// constrained particle: the released components of the timed velocities left out.
    pub fn held_now(&self) -> impl Iterator<Item = (u32, u8)> + '_ {
        let mut timed = self.timed_components.iter().peekable();
        self.constrained
            .iter()
            .zip(&self.held)
            .map(move |(&(i, _), &held)| {
                let mut mask = held;
                while let Some(&(_, k, g, _)) = timed.next_if(|c| c.0 == i) {
                    if self.step[g as usize].is_some() {
                        mask |= 1 << k;
                    }
                }
                (i, mask)
            })
    }

    /// Power of the external loads (tractions and body forces), Σ m a_ext · v, for the
    /// masses of [`Self::use_method`].
    pub fn external_power(&self, v: &[D::V], mass: &[f64]) -> Exact {
        self.external
            .iter()
            .map(|&(i, g)| mass[i as usize] * D::dot(g, v[i as usize]))
            .sum()
    }
}

/// Sets component k of x to c.
fn set_component<D: Dim>(x: &mut D::V, k: u8, c: f64) {
    let mut y = D::to3(*x);
    y[k as usize] = c;
    *x = D::from_slice(&y[..D::N]);
}

#[cfg(feature = "gpu")]
impl<D: Dim> Boundary<D> {
    /// The timed velocities as `shaders/interaction/prescribed.wgsl` reads them, per particle
    /// (a stride of 1 + 2·DIM): the mask held for the whole run, 1 + g per component (g
    /// the timed velocity's index, 0 for a component none holds), the prescribed velocity
    /// v_p at law value 1.
    pub fn timed_table(&self) -> Vec<f32> {
        let stride = 1 + 2 * D::N;
        let mut dense = vec![0f32; stride * self.n];
        for (&(i, _), &held) in self.constrained.iter().zip(&self.held) {
            dense[stride * i as usize] = f32::from(held);
        }
        for &(i, k, g, vp) in &self.timed_components {
            let base = stride * i as usize + 1 + k as usize;
            dense[base] = (g + 1) as f32;
            dense[base + D::N] = vp as f32;
        }
        dense
    }

    /// The values of the step from t to t + Δt of every timed velocity: (1, its rate over
    /// the step) while held, (0, 0) once released.
    pub fn timed_step_values(&self) -> Box<dyn Fn(f64, f64) -> Vec<f32> + Send + Sync> {
        let timed = self.timed.clone();
        Box::new(move |t, dt| {
            timed
                .iter()
                .flat_map(|v| match v.over_step(t, dt) {
                    Some(step) => [1.0, step.rate as f32],
                    None => [0.0, 0.0],
                })
                .collect()
        })
    }
}

/// The non-zero sums, by particle in ascending order, of (particle, value) entries over
/// n particles.
fn summed<D: Dim>(n: usize, entries: impl IntoIterator<Item = (u32, D::V)>) -> Vec<(u32, D::V)> {
    let mut total = vec![D::zero(); n];
    for (i, v) in entries {
        total[i as usize] += v;
    }
    (0..n as u32)
        .filter(|&i| total[i as usize] != D::zero())
        .map(|i| (i, total[i as usize]))
        .collect()
}

/// Components of `on` where `mask` is set, of `off` elsewhere.
fn mix<D: Dim>(mask: u8, on: D::V, off: D::V) -> D::V {
    let (a, b) = (D::to3(on), D::to3(off));
    let c: Vec<f64> = (0..D::N)
        .map(|k| if mask & (1 << k) != 0 { a[k] } else { b[k] })
        .collect();
    D::from_slice(&c)
}
