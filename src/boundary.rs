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

use crate::analytic::ClosedForm;
use crate::neighbour;
use crate::scene::{Case, CaseError, Condition, Discretised, Surface, TimeLaw};
use crate::tensor::Dim;

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

/// The force a support applies to hold the components it prescribes,
/// R = Σ m (a_prescribed − a) over them, and its power R·v, at a rate evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reaction {
    pub force: [f64; 3],
    pub power: f64,
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
        let mut mask = vec![0u8; disc.x0.len()];
        let mut value = vec![D::zero(); disc.x0.len()];
        let mut surface = Vec::new();
        let mut gravity = vec![D::zero(); disc.x0.len()];
        let mut dmask = vec![0u8; disc.x0.len()];
        let mut dvalue = vec![[0.0; 3]; disc.x0.len()];
        // The timed velocity of each component (index into `timed`), if one prescribes it.
        let mut timed_of = vec![[None::<u32>; 3]; disc.x0.len()];
        // The support of each component, for the prescribed ones.
        let mut support_of = vec![[0u16; 3]; disc.x0.len()];
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
                match &bc.condition {
                    Condition::Fixed => {
                        mask[i] = (1 << D::N) - 1;
                        dmask[i] = 0;
                        value[i] = D::zero();
                        timed_of[i] = [None; 3];
                        support_of[i] = [s; 3];
                    }
                    Condition::Velocity { vx, vy, vz, .. } => {
                        let mut v = D::to3(value[i]);
                        for (k, c) in [vx, vy, vz].iter().enumerate().take(D::N) {
                            if let Some(c) = c {
                                mask[i] |= 1 << k;
                                dmask[i] &= !(1 << k);
                                v[k] = *c;
                                timed_of[i][k] = this_timed;
                                support_of[i][k] = s;
                            }
                        }
                        value[i] = D::from_slice(&v);
                    }
                    Condition::Symmetry { normal } => {
                        let k = normal.index();
                        mask[i] |= 1 << k;
                        dmask[i] &= !(1 << k);
                        let mut v = D::to3(value[i]);
                        v[k] = 0.0;
                        value[i] = D::from_slice(&v);
                        timed_of[i][k] = None;
                        support_of[i][k] = s;
                    }
                    Condition::BodyForce { acceleration, .. } => {
                        gravity[i] += D::from_slice(acceleration);
                    }
                    // Their points, above.
                    Condition::Traction { .. }
                    | Condition::SolutionTraction { .. }
                    | Condition::Pressure { .. } => {}
                    Condition::Displacement { ux, uy, uz } => {
                        for (k, c) in [ux, uy, uz].iter().enumerate().take(D::N) {
                            if let Some(c) = c {
                                mask[i] |= 1 << k;
                                dmask[i] |= 1 << k;
                                dvalue[i][k] = *c;
                                timed_of[i][k] = None;
                                support_of[i][k] = s;
                            }
                        }
                    }
                    Condition::SolutionDisplacement {
                        solution,
                        components,
                    } => {
                        let u = ClosedForm::of(solution, &case.material)
                            .displacement3(D::to3(disc.x0[i]));
                        for k in components.iter().map(|a| a.index()) {
                            mask[i] |= 1 << k;
                            dmask[i] |= 1 << k;
                            dvalue[i][k] = u[k];
                            timed_of[i][k] = None;
                            support_of[i][k] = s;
                        }
                    }
                }
            }
        }
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
        reactions: &mut Vec<Reaction>,
    ) -> f64 {
        for &(i, g) in &self.external {
            a[i as usize] += g;
        }
        reactions.clear();
        reactions.resize(self.supports, Reaction::default());
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
        reactions.iter().map(|r| r.power).sum()
    }

    /// The index in `constrained` of constrained particle i.
    fn slot(&self, i: u32) -> usize {
        self.constrained
            .binary_search_by_key(&i, |c| c.0)
            .expect("a timed component's particle is constrained")
    }

    /// Books the reaction force and power on component k of the particle in `slot` to the
    /// support that prescribes it.
    fn book(&self, reactions: &mut [Reaction], slot: usize, k: usize, force: f64, power: f64) {
        let reaction = &mut reactions[usize::from(self.support_of[slot][k])];
        reaction.force[k] += force;
        reaction.power += power;
    }

    /// The supports' reactions from the reaction force and its power on each component of
    /// every constrained particle (`force` and `power`, by entry of `constrained`; zero on
    /// the components it does not prescribe).
    pub fn reactions(&self, force: &[D::V], power: &[D::V]) -> Vec<Reaction> {
        let mut reactions = vec![Reaction::default(); self.supports];
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
        reactions
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
    pub fn external_power(&self, v: &[D::V], mass: &[f64]) -> f64 {
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
impl<D: Dim> crate::interaction::gpu::GpuInteraction for Boundary<D> {
    /// `shaders/common/prescribed.wgsl`: one invocation per particle sets the rates of
    /// its timed components held over the step and its mask in `reference`,
    /// from the step's (held, rate) of every timed velocity (`steps`, written by the host
    /// for every step it records).
    fn pass(
        &self,
        gpu: &crate::gpu::context::Gpu,
        compose: &dyn Fn(&crate::gpu::shaders::Source) -> String,
        on: &crate::interaction::gpu::Bindings,
    ) -> Result<crate::interaction::gpu::Pass, crate::gpu::GpuError> {
        // Per particle: the mask held for the whole run, 1 + g per component, v_p.
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
        let pipeline = gpu.pipeline(
            "timed velocities",
            &compose(&crate::gpu::shaders::PRESCRIBED),
            "timed_velocities",
        )?;
        let timed = gpu.storage("timed velocities", &dense);
        let steps = gpu.zeroed("timed velocities' steps", 8 * self.timed.len() as u64);
        let bind = gpu.bind(
            &pipeline,
            &[
                ("timed", &timed),
                ("steps", &steps),
                ("reference", on.reference),
            ],
        )?;
        Ok(crate::interaction::gpu::Pass {
            pipeline,
            bind,
            params: None,
            step_values: Some(crate::interaction::gpu::StepValues {
                target: steps,
                values: Box::new({
                    let timed = self.timed.clone();
                    move |t, dt| {
                        timed
                            .iter()
                            .flat_map(|v| match v.over_step(t, dt) {
                                Some(step) => [1.0, step.rate as f32],
                                None => [0.0, 0.0],
                            })
                            .collect()
                    }
                }),
            }),
        })
    }
}

/// The face a traction region loads: the axes along it, and the extent its particles'
/// patches are clipped to, the named shapes' bounds (and the region's own, where it sets
/// them) along those axes. On a vertex lattice the edge and corner particles then carry
/// half and a quarter of a patch, on a cell-centred one whole patches, and on either the
/// patches tile the face the case names. A body without a named extent (a points file, a
/// mesh) extends Δx/2 past its particles, as a sample of cell centres does (a mesh's
/// centroids, the shipped irregular points files).
struct Face {
    along: Vec<usize>,
    bounds: ([f64; 3], [f64; 3]),
    half: f64,
}

impl Face {
    /// The face of boundary condition b's region, whose particles are `particles`: normal
    /// to the condition's `normal` if it has one, else to the axis along which the
    /// particles spread least.
    fn of<D: Dim>(case: &Case, b: usize, particles: &[usize], x0: &[D::V], body: &[u32]) -> Self {
        let spread = neighbour::bounding_box(particles.iter().map(|&i| D::to3(x0[i])));
        let normal = match &case.boundaries[b].condition {
            Condition::SolutionTraction { normal, .. } => {
                (0..D::N).find(|&k| normal[k] != 0.0).unwrap_or(0)
            }
            _ => (0..D::N)
                .min_by(|&j, &k| {
                    (spread.1[j] - spread.0[j]).total_cmp(&(spread.1[k] - spread.0[k]))
                })
                .unwrap_or(0),
        };
        let mut bodies: Vec<usize> = particles.iter().map(|&i| body[i] as usize).collect();
        bodies.sort_unstable();
        bodies.dedup();
        let half = 0.5 * case.spacing;
        let mut bounds = bodies
            .iter()
            .map(|&b| {
                case.bodies[b].geometry.extent(D::N).unwrap_or_else(|| {
                    let (lo, hi) = neighbour::bounding_box(
                        (0..x0.len())
                            .filter(|&i| body[i] as usize == b)
                            .map(|i| D::to3(x0[i])),
                    );
                    (lo.map(|c| c - half), hi.map(|c| c + half))
                })
            })
            .fold(
                ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
                |acc, (lo, hi)| {
                    (
                        std::array::from_fn(|k| acc.0[k].min(lo[k])),
                        std::array::from_fn(|k| acc.1[k].max(hi[k])),
                    )
                },
            );
        let region = &case.boundaries[b].region;
        let limits = [
            (region.x_min, region.x_max),
            (region.y_min, region.y_max),
            (region.z_min, region.z_max),
        ];
        for (k, (lo, hi)) in limits.into_iter().enumerate() {
            if let Some(lo) = lo {
                bounds.0[k] = bounds.0[k].max(lo);
            }
            if let Some(hi) = hi {
                bounds.1[k] = bounds.1[k].min(hi);
            }
        }
        Self {
            along: (0..D::N).filter(|&k| k != normal).collect(),
            bounds,
            half,
        }
    }

    /// The patch of the particle at reference position x.
    fn patch<D: Dim>(&self, x: D::V) -> Patch<'_> {
        Patch {
            centre: D::to3(x),
            face: self,
        }
    }
}

/// The patch of a face that a particle carries the traction of: Δx wide in each
/// direction of the face, centred at the particle, clipped to the face's bounds.
struct Patch<'a> {
    centre: [f64; 3],
    face: &'a Face,
}

impl Patch<'_> {
    /// The points of 2-point Gauss rules in each direction of the face over the patch
    /// (exact for tractions quadratic in X), each with its share t(X) dA of ∫ t dA, held
    /// by `particle`.
    fn points<D: Dim>(
        &self,
        particle: usize,
        t: impl Fn([f64; 3]) -> [f64; 3],
    ) -> Vec<SurfacePoint<D>> {
        let Face {
            along,
            bounds: face,
            half,
        } = self.face;
        let half = *half;
        let bounds: Vec<(f64, f64)> = along
            .iter()
            .map(|&k| {
                let lo = (self.centre[k] - half).max(face.0[k]);
                let hi = (self.centre[k] + half).min(face.1[k]);
                (lo, hi.max(lo))
            })
            .collect();
        // A region one particle thick along a direction of the face: a full patch there.
        let bounds: Vec<(f64, f64)> = bounds
            .iter()
            .zip(along)
            .map(|(&(lo, hi), &k)| {
                if hi - lo < 1e-12 * half {
                    (self.centre[k] - half, self.centre[k] + half)
                } else {
                    (lo, hi)
                }
            })
            .collect();
        let area: f64 = bounds.iter().map(|(lo, hi)| hi - lo).product();
        let gauss = 0.5 / 3f64.sqrt();
        let count = 1usize << along.len();
        let centre = self.centre;
        (0..count)
            .map(|corner| {
                let mut p = centre;
                for (bit, (&k, &(lo, hi))) in along.iter().zip(&bounds).enumerate() {
                    let s = if corner & (1 << bit) != 0 {
                        gauss
                    } else {
                        -gauss
                    };
                    p[k] = 0.5 * (lo + hi) + s * (hi - lo);
                }
                let tp = t(p);
                SurfacePoint {
                    particle: particle as u32,
                    x: D::from_slice(&p[..D::N]),
                    force: D::from_slice(&tp[..D::N]) * (area / count as f64),
                }
            })
            .collect()
    }
}

/// A point of a loaded surface of the reference configuration: the particle whose patch
/// of the surface holds it, its position X, and the force t dA of its share of the patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint<D: Dim> {
    pub particle: u32,
    pub x: D::V,
    pub force: D::V,
}

/// How a method carries the forces of its loaded surfaces to its nodes: the nodal forces
/// f_a = Σ_q Φ_a(X_q) f_q of its functions Φ_a at the surface points, ∫ Φ_a t dΓ.
pub trait NodalForces<D: Dim> {
    /// The (node, force) of the points' forces; a node may come more than once.
    fn spread(&self, points: &[SurfacePoint<D>]) -> Result<Vec<(u32, D::V)>, CaseError>;
}

/// Each point's force to the particle whose patch holds it: the tributary forces of the
/// collocation methods, and the consistent forces of bilinear elements on a vertex
/// lattice (their functions integrate to the patches under a traction constant along
/// the face).
pub struct OnPatches;

impl<D: Dim> NodalForces<D> for OnPatches {
    fn spread(&self, points: &[SurfacePoint<D>]) -> Result<Vec<(u32, D::V)>, CaseError> {
        Ok(points.iter().map(|p| (p.particle, p.force)).collect())
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

/// A load of [`timed_loads`]: one boundary condition's time law and the accelerations it
/// gives its particles at law value 1.
#[derive(Clone, Debug)]
pub struct TimedLoad<D: Dim> {
    pub law: TimeLaw,
    /// (particle, acceleration), by particle.
    pub accelerations: Vec<(u32, D::V)>,
}

/// The loads of a case that vary in time, one per condition: its time law and the
/// (particle, acceleration) of every particle it loads, from the discretisation, the way
/// the method carries surface forces to its nodes (`nodal`) and its nodal masses. A
/// traction with a time law has the points of the particles' patches of the face, as a
/// constant one does ([`Face`]), a pressure those of the particles' arcs of the circle
/// ([`pressure_points`]); a force's acceleration is f/m. A body force gives its
/// acceleration g to each particle of its region.
pub fn timed_loads<D: Dim>(
    case: &Case,
    disc: &Discretised<D>,
    nodal: &dyn NodalForces<D>,
    mass: &[f64],
) -> Result<Vec<TimedLoad<D>>, CaseError> {
    let (x0, body) = (&disc.x0[..], &disc.body[..]);
    let mut loads = Vec::new();
    let per_mass = |points: Vec<SurfacePoint<D>>| -> Result<Vec<(u32, D::V)>, CaseError> {
        let forces = summed::<D>(mass.len(), nodal.spread(&points)?);
        Ok(forces
            .into_iter()
            .map(|(i, f)| (i, f * (1.0 / mass[i as usize])))
            .collect())
    };
    for (b, bc) in case.boundaries.iter().enumerate() {
        if !bc.condition.is_timed_load() {
            continue;
        }
        let (law, accelerations): (&TimeLaw, Vec<(u32, D::V)>) = match &bc.condition {
            Condition::Traction { law, .. } | Condition::Pressure { law, .. } => {
                let particles = selected::<D>(case, b, x0, body)?;
                let points = surface_points::<D>(case, b, &particles, x0, body)?;
                (law, per_mass(points)?)
            }
            Condition::BodyForce { acceleration, law } => {
                let g = D::from_slice(acceleration);
                let particles = selected::<D>(case, b, x0, body)?;
                (law, particles.into_iter().map(|i| (i as u32, g)).collect())
            }
            _ => unreachable!("the timed loads are tractions, pressures and body forces"),
        };
        loads.push(TimedLoad {
            law: law.clone(),
            accelerations,
        });
    }
    Ok(loads)
}

/// The surface points of boundary condition b over its particles: the points of their
/// patches of the face for a traction, constant or timed, or a closed-form solution's
/// traction ([`Face`]), those of their arcs for a pressure ([`pressure_points`]); none for
/// the other conditions.
fn surface_points<D: Dim>(
    case: &Case,
    b: usize,
    particles: &[usize],
    x0: &[D::V],
    body: &[u32],
) -> Result<Vec<SurfacePoint<D>>, CaseError> {
    let on_face = |t: &dyn Fn([f64; 3]) -> [f64; 3]| {
        let face = Face::of::<D>(case, b, particles, x0, body);
        particles
            .iter()
            .flat_map(|&i| face.patch::<D>(x0[i]).points(i, t))
            .collect()
    };
    Ok(match &case.boundaries[b].condition {
        Condition::Traction { traction, .. } => {
            let t: [f64; 3] = std::array::from_fn(|k| traction.get(k).copied().unwrap_or(0.0));
            on_face(&|_| t)
        }
        Condition::SolutionTraction { solution, normal } => {
            let closed = ClosedForm::of(solution, &case.material);
            on_face(&|x| {
                let s = closed.stress3(x);
                std::array::from_fn(|r| (0..D::N).map(|c| s[r][c] * normal[c]).sum())
            })
        }
        Condition::Pressure { .. } => pressure_points::<D>(case, b, x0, body)?,
        _ => Vec::new(),
    })
}

/// The surface points of boundary condition b, a pressure p on a circle of radius R: each
/// particle within Δx of it on the body's side holds the point of the circle at its
/// angle, X = c + R n, with the force p R Δθ n, Δθ half the angle between its neighbours
/// along the circle (so that the shares sum to 2πR) and n the reference normal into the
/// body, ±(X − c)/|X − c| (a midpoint rule over its arc).
fn pressure_points<D: Dim>(
    case: &Case,
    b: usize,
    x0: &[D::V],
    body: &[u32],
) -> Result<Vec<SurfacePoint<D>>, CaseError> {
    let Condition::Pressure {
        pressure,
        center,
        radius,
        surface,
        ..
    } = &case.boundaries[b].condition
    else {
        unreachable!("boundary condition {b} is a pressure")
    };
    // Within Δx of the circle on the body's side, with a round-off margin on both ends (a
    // lattice point on the circle, a layer Δx off it).
    let (dx, tol) = (case.spacing, 1e-9 * case.spacing);
    let on_circle: Vec<usize> = selected::<D>(case, b, x0, body)?
        .into_iter()
        .filter(|&i| {
            let r = D::norm2(x0[i] - D::from_slice(center)).sqrt();
            match surface {
                Surface::Inner => r >= radius - tol && r < radius + dx - tol,
                Surface::Outer => r <= radius + tol && r > radius - dx + tol,
            }
        })
        .collect();
    let sign = match surface {
        Surface::Inner => 1.0,
        Surface::Outer => -1.0,
    };
    let c = D::from_slice(center);
    Ok(pressure_shares::<D>(case, b, x0, &on_circle, center)?
        .into_iter()
        .map(|(i, dtheta, radial)| SurfacePoint {
            particle: i as u32,
            x: c + radial * *radius,
            force: radial * (sign * pressure * radius * dtheta),
        })
        .collect())
}

/// The particles `on_circle` about `center` by angle, each with its share Δθ of the
/// circle (half the angle to each neighbour along it) and its radial unit vector
/// (X − c)/|X − c|. The shares of a whole circle sum to 2π; a circle that the particles
/// leave open (a gap wider than a quarter turn, as under a region that cuts it) is refused,
/// as is one with fewer than three particles.
fn pressure_shares<D: Dim>(
    case: &Case,
    b: usize,
    x0: &[D::V],
    on_circle: &[usize],
    center: &[f64],
) -> Result<Vec<(usize, f64, D::V)>, CaseError> {
    let key = format!("boundary.{b}.condition");
    if on_circle.len() < 3 {
        return Err(case.invalid(
            key,
            format!(
                "the pressure's circle has {} particle(s) within Δx of it on the body's \
                 side; check `center`, `radius` and `surface` against the body",
                on_circle.len()
            ),
        ));
    }
    let c = D::from_slice(center);
    let mut by_angle: Vec<(f64, usize)> = on_circle
        .iter()
        .map(|&i| {
            let d = D::to3(x0[i] - c);
            (d[1].atan2(d[0]), i)
        })
        .collect();
    by_angle.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = by_angle.len();
    let tau = std::f64::consts::TAU;
    // gap[k]: the angle from particle k to the next one round the circle.
    let gap: Vec<f64> = (0..n)
        .map(|k| (by_angle[(k + 1) % n].0 - by_angle[k].0).rem_euclid(tau))
        .collect();
    let widest = gap.iter().copied().fold(0.0, f64::max);
    if widest > tau / 4.0 {
        return Err(case.invalid(
            key,
            format!(
                "the pressure's particles leave a gap of {widest:.3} rad on the circle; a \
                 pressure acts on a whole circle: let the region take every particle along it"
            ),
        ));
    }
    Ok((0..n)
        .map(|k| {
            let (_, i) = by_angle[k];
            let r = x0[i] - c;
            let share = 0.5 * (gap[(k + n - 1) % n] + gap[k]);
            (i, share, r * (1.0 / D::norm2(r).sqrt()))
        })
        .collect())
}

/// The particles of boundary condition b's region among those at reference positions x0
/// with bodies `body`; an error if it selects none.
fn selected<D: Dim>(
    case: &Case,
    b: usize,
    x0: &[D::V],
    body: &[u32],
) -> Result<Vec<usize>, CaseError> {
    let region = &case.boundaries[b].region;
    let tol = 0.25 * case.spacing;
    let of_body = region
        .body
        .as_ref()
        .and_then(|name| case.bodies.iter().position(|b| &b.name == name));
    let bounds = [
        (region.x_min, region.x_max),
        (region.y_min, region.y_max),
        (region.z_min, region.z_max),
    ];
    let inside: Vec<usize> = (0..x0.len())
        .filter(|&i| of_body.is_none_or(|b| body[i] as usize == b))
        .filter(|&i| {
            let p = D::to3(x0[i]);
            bounds.iter().zip(p).all(|(&(lo, hi), c)| {
                lo.is_none_or(|lo| c >= lo - tol) && hi.is_none_or(|hi| c <= hi + tol)
            })
        })
        .collect();
    if inside.is_empty() {
        return Err(case.invalid(
            format!("boundary.{b}.region"),
            "selects no particle; check the bounds against the bodies' reference positions",
        ));
    }
    Ok(inside)
}

/// What one boundary condition acts on: its region's particles and, for a load (a
/// traction, pressure, body force or a solution's traction), the total force it applies
/// at law value 1, the sum of its particles' forces (∫ t dA over their patches of the
/// face, p R Δθ n along a circle, m g on the masses given).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConditionTotal {
    pub particles: usize,
    pub force: Option<[f64; 3]>,
}

/// The [`ConditionTotal`] of every boundary condition of a case, in case order, on the
/// particles at reference positions x0 with bodies `body` and nodal masses `mass` (which
/// only a body force's total depends on): for `--explain`, and the applied-force columns
/// of the named loads in the series.
pub fn condition_totals<D: Dim>(
    case: &Case,
    x0: &[D::V],
    body: &[u32],
    mass: &[f64],
) -> Result<Vec<ConditionTotal>, CaseError> {
    let sum = |forces: &mut dyn Iterator<Item = D::V>| {
        let total = forces.fold(D::zero(), |a, f| a + f);
        Some(D::to3(total))
    };
    (0..case.boundaries.len())
        .map(|b| {
            let particles = selected::<D>(case, b, x0, body)?;
            let force = match &case.boundaries[b].condition {
                Condition::BodyForce { acceleration, .. } => {
                    let g = D::from_slice(acceleration);
                    sum(&mut particles.iter().map(|&i| g * mass[i]))
                }
                Condition::Traction { .. }
                | Condition::SolutionTraction { .. }
                | Condition::Pressure { .. } => {
                    let points = surface_points::<D>(case, b, &particles, x0, body)?;
                    sum(&mut points.iter().map(|p| p.force))
                }
                _ => None,
            };
            Ok(ConditionTotal {
                particles: particles.len(),
                force,
            })
        })
        .collect()
}
