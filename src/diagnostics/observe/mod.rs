//! Observers: energies, momenta, body extents, neck height, the velocity error against a
//! closed form, support reactions, point probes and section forces, sampled into the CSV
//! time series.

mod rings;
mod sections;

use rings::{plastic_strain_spread, ring_spreads, rings};
use sections::{Section, probe_particles};

use crate::boundary::Reaction;
use crate::case::{Case, CaseError, Observer, TimeLaw};
use crate::core::integrate::PseudoTime;
use crate::core::parallel::ordered_reduce;
use crate::core::sum;
use crate::core::tensor::Dim;
use crate::diagnostics::analytic::{AnalyticSolution, ClosedForm, Exact, relative_l2};
use crate::diagnostics::balance::{self, Balance, Booked};
use crate::physics::material::Material;
use crate::physics::pressure::{oscillation, pressures};
use std::collections::BTreeMap;

/// A state as observers and frames read it, from either backend: reference data,
/// displacement, velocity, deformation gradient, Cauchy stress, strain energy, and the
/// fields a method adds of its own.
pub struct Snapshot<'a, D: Dim> {
    pub x0: &'a [D::V],
    pub mass: &'a [f64],
    pub body: &'a [u32],
    pub u: Vec<D::V>,
    pub v: Vec<D::V>,
    pub f: Vec<D::T>,
    /// 3×3 Cauchy stress (2D: plane-strain σ_zz filled in).
    pub sigma: Vec<[[f64; 3]; 3]>,
    /// Σ V0 ψ, exact until read (the ranks of a distributed run add their shares).
    pub strain_energy: sum::Exact,
    /// Per-particle fields of the method's own, written into the frames.
    pub extra: Vec<ScalarField>,
    /// The corners of the method's elements, 2^d per cell in VTK order, which the frames
    /// show as cells on the particles; empty for the particle methods.
    pub cells: &'a [u32],
    /// The points the method integrates at, when they are not the particles with volumes
    /// m/ρ0 and the particles' F (the Galerkin methods).
    pub quadrature: Option<Quadrature<D>>,
}

/// The quadrature points of a method with the displacement and F there: what an error
/// measured with the method's own quadrature sums over (seed 001 §9.1).
pub struct Quadrature<D: Dim> {
    pub x0: Vec<D::V>,
    pub weight: Vec<f64>,
    /// u^h(X_q) = Σ_a N_a(X_q) u_a with the method's shape function values.
    pub u: Vec<D::V>,
    pub f: Vec<D::T>,
    /// The global index of each point on a rank of a distributed run, which holds the
    /// points it counts; empty on one rank, which holds them all in order.
    pub ids: Vec<u32>,
}

/// A per-particle scalar field that a method adds to the frames (the plastic strain ε_p).
#[derive(Clone, Debug, PartialEq)]
pub struct ScalarField {
    /// The field's name in the VTU frames.
    pub name: &'static str,
    pub values: Vec<f64>,
}

impl<D: Dim> Snapshot<'_, D> {
    /// The reference volumes V0 = m/ρ0 of the particles.
    pub fn reference_volumes(&self, rho0: f64) -> Vec<f64> {
        self.mass.iter().map(|m| m / rho0).collect()
    }

    /// The values of the method's own field `name`, if it has one.
    pub fn field(&self, name: &str) -> Option<&[f64]> {
        self.extra
            .iter()
            .find(|f| f.name == name)
            .map(|f| f.values.as_slice())
    }
}

/// The per-particle indicator fields of one output, each evaluated only when a frame, a
/// series row or a run limit needs it: the hourglass indicator η
/// ([`crate::physics::hourglass`]) and the pressure deviation δp ([`crate::physics::pressure`]).
#[derive(Clone, Debug, Default)]
pub struct IndicatorFields {
    pub eta: Option<Vec<f64>>,
    pub pressure_deviation: Option<Vec<f64>>,
}

/// Global invariants of a state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Invariants {
    pub kinetic: f64,
    pub strain: f64,
    /// Σ m v.
    pub linear: [f64; 3],
    /// Σ m x × v about the origin (2D: z component).
    pub angular: [f64; 3],
}

impl Invariants {
    pub fn total_energy(&self) -> f64 {
        self.kinetic + self.strain
    }

    pub fn of<D: Dim>(snap: &Snapshot<D>) -> Self {
        let (x0, u, v, m) = (snap.x0, &snap.u, &snap.v, snap.mass);
        let add3 = |a: [f64; 3], b: [f64; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
        let (kinetic, linear, angular) = ordered_reduce(
            m.len(),
            || (0.0, [0.0; 3], [0.0; 3]),
            |i| {
                let p = v[i] * m[i];
                (0.5 * D::dot(p, v[i]), D::to3(p), D::cross3(x0[i] + u[i], p))
            },
            |a, b| (a.0 + b.0, add3(a.1, b.1), add3(a.2, b.2)),
        );
        Self {
            kinetic,
            strain: snap.strain_energy.value(),
            linear,
            angular,
        }
    }

    /// Named values for the run summary.
    pub fn named<D: Dim>(&self) -> BTreeMap<String, f64> {
        let mut out = BTreeMap::new();
        out.insert("kinetic_energy".into(), self.kinetic);
        out.insert("strain_energy".into(), self.strain);
        out.insert("total_energy".into(), self.total_energy());
        for (axis, p) in AXES.iter().zip(self.linear).take(D::N) {
            out.insert(format!("linear_momentum_{axis}"), p);
        }
        for k in angular_components::<D>() {
            out.insert(format!("angular_momentum_{}", AXES[k]), self.angular[k]);
        }
        out
    }
}

const AXES: [&str; 3] = ["x", "y", "z"];

fn angular_components<D: Dim>() -> std::ops::Range<usize> {
    if D::N == 2 { 2..3 } else { 0..3 }
}

/// Where a run stands: time, step count, last step size, the terms of the energy balance
/// the engine booked so far ([`crate::diagnostics::balance`]) and the initial energy E_0.
#[derive(Clone, Copy, Debug, Default)]
pub struct Clock {
    pub t: f64,
    pub step: u64,
    pub dt: f64,
    pub booked: Booked,
    pub e0: f64,
    /// The pseudo-time iterations of artificial compressibility (zero without).
    pub pseudo_time: PseudoTime,
}

/// The series columns an engine adds besides the observers'.
#[derive(Clone, Copy, Debug, Default)]
pub struct EngineColumns {
    /// The pseudo-time iterations of artificial compressibility: `pseudo_iterations` (of
    /// the last step, over its stages), `pseudo_iterations_total` and `pseudo_residual`
    /// (the largest of the last step's stages, over the velocity scale).
    pub pseudo_time: bool,
}

/// The observers of a run and the columns they fill.
pub struct Observers {
    list: Vec<Observer>,
    probes: Vec<usize>,
    /// Material columns of free particles (neck height).
    columns: Vec<Vec<usize>>,
    bodies: usize,
    /// The closed form of the `velocity-error` observer, and ρ0 (volumes are m/ρ0).
    exact: Option<(Exact, f64)>,
    /// The rings of the `ring-symmetry` observer, each in order of reference angle.
    rings: Vec<Vec<usize>>,
    /// The stress below which a ring's mean σ_θθ is round-off: 1e-9 of the p-wave
    /// modulus λ + 2μ.
    stress_floor: f64,
    /// Whether the material has a plastic history (`ring-symmetry` then measures ε_p).
    plastic: bool,
    /// The closed form of the `solution-error` observer, and the material.
    solution: Option<(ClosedForm, Material)>,
    /// The closed form of the `front-oscillation` observer, and the margin about its
    /// jumps [m].
    front: Option<(Exact, f64)>,
    /// The number of supports the `reaction` observer writes.
    supports: usize,
    /// The named loads the `reaction` observer writes: each one's total force at law value
    /// 1 and its time law.
    applied: Vec<([f64; 3], TimeLaw)>,
    /// The end time of a static run, whose loads scale with t/end_time.
    static_end: Option<f64>,
    /// The columns the engine adds.
    engine: EngineColumns,
    sections: Vec<Section>,
    /// ρ0, for the volumes m/ρ0 of the sections.
    rho0: f64,
    names: Vec<String>,
}

/// The series columns of observer `obs` into `names`, and for `reaction` the named loads'
/// total forces at law value 1 with their time laws into `applied`.
fn observer_columns<D: Dim>(
    case: &Case,
    obs: &Observer,
    snap: &Snapshot<D>,
    names: &mut Vec<String>,
    applied: &mut Vec<([f64; 3], TimeLaw)>,
) -> Result<(), CaseError> {
    match obs {
        Observer::Energy => names.extend(balance::COLUMNS.map(String::from)),
        Observer::LinearMomentum => {
            names.extend((0..D::N).map(|k| format!("momentum_{}", AXES[k])))
        }
        Observer::AngularMomentum => {
            names.extend(angular_components::<D>().map(|k| format!("angular_momentum_{}", AXES[k])))
        }
        Observer::Extent => {
            for b in &case.bodies {
                names.extend((0..D::N).map(|k| format!("{}.extent_{}", b.name, AXES[k])));
            }
        }
        Observer::NeckHeight => names.push("neck_height".into()),
        Observer::Hourglass => names.push("hourglass_max".into()),
        Observer::VelocityError(_) => names.push("velocity_error".into()),
        Observer::RingSymmetry => {
            names.extend(["hoop_stress_spread", "hoop_gap_spread"].map(String::from));
            if Material::new(&case.material).hardening.is_some() {
                names.push("plastic_strain_spread".into());
            }
        }
        Observer::SolutionError => {
            names.extend(["displacement_error", "energy_error"].map(String::from))
        }
        Observer::FrontOscillation(_) => names.extend(
            [
                "ahead_oscillation",
                "behind_oscillation",
                "plateau_oscillation",
            ]
            .map(String::from),
        ),
        Observer::PressureOscillation => names.push("pressure_oscillation".into()),
        Observer::Reaction => {
            for (_, name) in crate::boundary::supports(case) {
                names.extend((0..D::N).map(|k| format!("{name}.reaction_{}", AXES[k])));
                names.push(format!("{name}.power"));
            }
            let totals =
                crate::boundary::condition_totals::<D>(case, snap.x0, snap.body, snap.mass)?;
            for (bc, total) in case.boundaries.iter().zip(totals) {
                let (Some(name), Some(force)) = (&bc.name, total.force) else {
                    continue;
                };
                names.extend((0..D::N).map(|k| format!("{name}.applied_force_{}", AXES[k])));
                applied.push((force, bc.condition.law().clone()));
            }
        }
    }
    Ok(())
}

impl Observers {
    /// Observers of a case over the particles of `snap` (reference positions, bodies and
    /// the method's masses), of which `constrained` have prescribed velocity components,
    /// on an engine that adds the columns `engine`.
    pub fn new<D: Dim>(
        case: &Case,
        snap: &Snapshot<D>,
        constrained: &[(u32, u8)],
        engine: EngineColumns,
    ) -> Result<Self, CaseError> {
        let x0 = snap.x0;
        let mut applied = Vec::new();
        let mut names = vec!["time".to_string(), "step".to_string(), "dt".to_string()];
        let mut list = case.output.observers.clone();
        list.sort();
        list.dedup();
        for obs in &list {
            observer_columns(case, obs, snap, &mut names, &mut applied)?;
        }
        let rings = if list.contains(&Observer::RingSymmetry) {
            rings::<D>(case, x0)?
        } else {
            Vec::new()
        };
        // The closed form of the observer that `pick` selects, if the list has it.
        let exact_of = |pick: fn(&Observer) -> Option<AnalyticSolution>| {
            list.iter()
                .find_map(pick)
                .map(|s| Exact::of(s, case).map_err(|m| case.invalid("output.observers", m)))
                .transpose()
        };
        let front = exact_of(|o| match o {
            Observer::FrontOscillation(s) => Some(*s),
            _ => None,
        })?
        .map(|e| (e, FRONT_MARGIN * case.smoothing_length()));
        let exact = exact_of(|o| match o {
            Observer::VelocityError(s) => Some(*s),
            _ => None,
        })?
        .map(|e| (e, case.material.density));
        let solution = if list.contains(&Observer::SolutionError) {
            let closed = solution_of(case).ok_or_else(|| {
                case.invalid(
                    "output.observers",
                    "`solution-error` measures against the closed form of a \
                     `solution-displacement` boundary condition, and the case has none",
                )
            })?;
            Some((closed, Material::new(&case.material)))
        } else {
            None
        };
        let probes = probe_particles::<D>(case, x0, &mut names)?;
        for section in &case.sections {
            names.extend((0..D::N).map(|k| format!("{}.force_{}", section.name, AXES[k])));
        }
        if engine.pseudo_time {
            names.extend(
                [
                    "pseudo_iterations",
                    "pseudo_iterations_total",
                    "pseudo_residual",
                ]
                .map(String::from),
            );
        }
        for (k, check) in case.output.checks.iter().enumerate() {
            if !names.contains(&check.column) {
                return Err(case.invalid(
                    format!("output.check.{k}.column"),
                    format!(
                        "no series column `{}`; this case's columns are {} (add an observer to \
                         output.observers for more)",
                        check.column,
                        names.join(", ")
                    ),
                ));
            }
        }
        let columns = if list.contains(&Observer::NeckHeight) {
            free_columns::<D>(case, x0, constrained)
        } else {
            Vec::new()
        };
        Ok(Self {
            list,
            probes,
            columns,
            bodies: case.bodies.len(),
            exact,
            rings,
            stress_floor: {
                let mat = crate::physics::material::Material::new(&case.material);
                1e-9 * (mat.lambda + 2.0 * mat.mu)
            },
            plastic: Material::new(&case.material).hardening.is_some(),
            solution,
            front,
            supports: crate::boundary::supports(case).len(),
            applied,
            static_end: case.is_static().then_some(case.run.end_time),
            engine,
            sections: case
                .sections
                .iter()
                .enumerate()
                .map(|(k, s)| Section::new::<D>(k, s, case, x0, snap.body))
                .collect::<Result<_, _>>()?,
            rho0: case.material.density,
            names,
        })
    }

    /// Whether a row needs the supports' reactions.
    pub fn need_reactions(&self) -> bool {
        self.list.contains(&Observer::Reaction)
    }

    pub fn column_names(&self) -> &[String] {
        &self.names
    }

    /// Whether a row needs the hourglass indicator η of every particle.
    pub fn need_hourglass(&self) -> bool {
        self.list.contains(&Observer::Hourglass)
    }

    /// Whether a row needs the pressure deviation δp of every particle.
    pub fn need_pressure_deviation(&self) -> bool {
        self.list.contains(&Observer::PressureOscillation)
    }

    /// One row of the time series; `fields` holds the hourglass indicator of every
    /// particle when [`Self::need_hourglass`] and the pressure deviation when
    /// [`Self::need_pressure_deviation`], and `reactions` the supports' reactions at the
    /// last rate evaluation, when [`Self::need_reactions`] (NaN before the first step,
    /// which has none).
    pub fn sample<D: Dim>(
        &self,
        snap: &Snapshot<D>,
        inv: &Invariants,
        clock: &Clock,
        fields: &IndicatorFields,
        reactions: &[Reaction],
    ) -> Vec<f64> {
        let (x0, u, v) = (snap.x0, &snap.u, &snap.v);
        let mut row = vec![clock.t, clock.step as f64, clock.dt];
        for obs in &self.list {
            match obs {
                Observer::Energy => row.extend(
                    Balance {
                        kinetic: inv.kinetic,
                        stored: inv.strain,
                        booked: clock.booked,
                        e0: clock.e0,
                    }
                    .row(),
                ),
                Observer::LinearMomentum => row.extend(&inv.linear[..D::N]),
                Observer::AngularMomentum => {
                    row.extend(angular_components::<D>().map(|k| inv.angular[k]))
                }
                Observer::Extent => {
                    let mut lo = vec![[f64::INFINITY; 3]; self.bodies];
                    let mut hi = vec![[f64::NEG_INFINITY; 3]; self.bodies];
                    for (i, &b) in snap.body.iter().enumerate() {
                        let x = D::to3(x0[i] + u[i]);
                        for k in 0..3 {
                            lo[b as usize][k] = lo[b as usize][k].min(x[k]);
                            hi[b as usize][k] = hi[b as usize][k].max(x[k]);
                        }
                    }
                    for b in 0..self.bodies {
                        row.extend((0..D::N).map(|k| hi[b][k] - lo[b][k]));
                    }
                }
                Observer::NeckHeight => {
                    let height = |col: &Vec<usize>| {
                        let ys = col.iter().map(|&i| D::comp(x0[i] + u[i], 1));
                        ys.clone().fold(f64::NEG_INFINITY, f64::max)
                            - ys.fold(f64::INFINITY, f64::min)
                    };
                    row.push(
                        self.columns
                            .iter()
                            .map(height)
                            .fold(f64::INFINITY, f64::min),
                    );
                }
                Observer::Hourglass => row.push(
                    fields
                        .eta
                        .as_ref()
                        .expect("η is computed when the hourglass observer is on")
                        .iter()
                        .fold(0.0, |a: f64, &b| a.max(b)),
                ),
                Observer::PressureOscillation => {
                    let deviation = fields
                        .pressure_deviation
                        .as_ref()
                        .expect("δp is computed when the pressure-oscillation observer is on");
                    let volume = snap.reference_volumes(self.rho0);
                    row.push(oscillation(deviation, &pressures(&snap.sigma), &volume));
                }
                Observer::VelocityError(_) => row.push(self.velocity_error(snap, clock.t)),
                Observer::RingSymmetry => {
                    row.extend(ring_spreads(&self.rings, snap, self.stress_floor));
                    if self.plastic {
                        row.push(plastic_strain_spread(&self.rings, snap));
                    }
                }
                Observer::SolutionError => row.extend(match &self.solution {
                    Some((closed, mat)) => solution_errors(snap, closed, mat),
                    None => [f64::NAN; 2],
                }),
                Observer::FrontOscillation(_) => row.extend(self.front_oscillation(snap, clock.t)),
                Observer::Reaction => {
                    let unknown = Reaction {
                        force: [f64::NAN; 3],
                        power: f64::NAN,
                    };
                    let known = clock.step > 0 && reactions.len() == self.supports;
                    let shown = match known {
                        true => reactions,
                        false => &vec![unknown; self.supports][..],
                    };
                    for r in shown {
                        row.extend(&r.force[..D::N]);
                        row.push(r.power);
                    }
                    for (force, law) in &self.applied {
                        let factor = match self.static_end {
                            Some(end) => clock.t / end,
                            None => law.at(clock.t),
                        };
                        row.extend(force[..D::N].iter().map(|f| f * factor));
                    }
                }
            }
        }
        for &i in &self.probes {
            row.extend((0..D::N).map(|k| D::comp(u[i], k)));
            row.extend((0..D::N).map(|k| D::comp(v[i], k)));
        }
        for section in &self.sections {
            row.extend(&section.force(snap, self.rho0)[..D::N]);
        }
        if self.engine.pseudo_time {
            let p = clock.pseudo_time;
            row.extend([p.step as f64, p.total as f64, p.residual]);
        }
        row
    }

    /// sqrt(Σ V |v − v_ex|²)/sqrt(Σ V |v_ex|²) with V = m/ρ0, over every component.
    fn velocity_error<D: Dim>(&self, snap: &Snapshot<D>, t: f64) -> f64 {
        let Some((exact, rho0)) = &self.exact else {
            return f64::NAN;
        };
        let w = snap.reference_volumes(*rho0);
        let v: Vec<f64> = snap
            .v
            .iter()
            .flat_map(|&v| D::to3(v)[..D::N].to_vec())
            .collect();
        let v_ex: Vec<f64> = snap
            .x0
            .iter()
            .flat_map(|&x| exact.velocity(D::to3(x), t)[..D::N].to_vec())
            .collect();
        relative_l2(&w, &v, &v_ex)
    }
}

/// The relative displacement and energy errors of [`Observer::SolutionError`] against
/// `closed` over the snapshot's quadrature points (the particles with V = m/ρ0 and their F
/// where the method has no points of its own), with ψ of `mat`.
pub fn solution_errors<D: Dim>(
    snap: &Snapshot<D>,
    closed: &ClosedForm,
    mat: &Material,
) -> [f64; 2] {
    let particles;
    let (x0, weight, u, f) = match &snap.quadrature {
        Some(q) => (&q.x0[..], &q.weight[..], &q.u[..], &q.f[..]),
        None => {
            particles = snap.reference_volumes(mat.rho0);
            (snap.x0, &particles[..], &snap.u[..], &snap.f[..])
        }
    };
    let psi = |h: D::T| mat.energy_density::<D>(D::identity() + h, D::zero_t(), mat.rho0);
    let [mut du, mut ua, mut de, mut ea] = [0.0; 4];
    for q in 0..x0.len() {
        let x = D::to3(x0[q]);
        let exact = D::from_slice(&closed.displacement3(x)[..D::N]);
        let g = closed.displacement_gradient3(x);
        let grad = (0..D::N)
            .flat_map(|k| (0..D::N).map(move |l| (k, l)))
            .fold(D::zero_t(), |t, (k, l)| {
                t + D::outer(unit::<D>(k), unit::<D>(l)) * g[k][l]
            });
        du += weight[q] * D::norm2(u[q] - exact);
        ua += weight[q] * D::norm2(exact);
        de += weight[q] * psi(f[q] - D::identity() - grad);
        ea += weight[q] * psi(grad);
    }
    [(du / ua).sqrt(), (de / ea).sqrt()]
}

/// The unit vector along axis k.
fn unit<D: Dim>(k: usize) -> D::V {
    let mut e = [0.0; 3];
    e[k] = 1.0;
    D::from_slice(&e)
}

/// The closed form of a case's first `solution-displacement` condition.
pub fn solution_of(case: &Case) -> Option<ClosedForm> {
    case.boundaries.iter().find_map(|b| match &b.condition {
        crate::case::Condition::SolutionDisplacement { solution, .. } => {
            Some(ClosedForm::of(solution, &case.material))
        }
        _ => None,
    })
}

/// The margin about the jumps of a closed form that the `front-oscillation` observer
/// leaves out, in smoothing lengths h: 4h, twice the support radius of the cubic spline
/// (2h), the width over which one kernel smears a jump on either side.
pub const FRONT_MARGIN: f64 = 4.0;

impl Observers {
    /// [ahead, behind, plateau] oscillations of the `front-oscillation` observer, over
    /// the particles farther than the margin from every jump (0 where there is none): the
    /// largest |v·d|/V where the closed form is at rest and the nearest jump runs towards
    /// the particle (ahead of the pulse) or away from it (behind), and the largest
    /// |(v − v_ex)·d|/V where it moves.
    fn front_oscillation<D: Dim>(&self, snap: &Snapshot<D>, t: f64) -> [f64; 3] {
        let Some((exact, margin)) = &self.front else {
            return [f64::NAN; 3];
        };
        let d = exact.velocity_direction();
        let axial = |w: [f64; 3]| -> f64 { (0..3).map(|k| w[k] * d[k]).sum() };
        let mut worst = [0.0f64; 3];
        for (&x, &v) in snap.x0.iter().zip(&snap.v) {
            let x = D::to3(x);
            let Some((amplitude, distance)) = exact.front_distance(x, t) else {
                return [f64::NAN; 3];
            };
            if distance <= *margin {
                continue;
            }
            let v_ex = axial(exact.velocity(x, t));
            let k = if v_ex != 0.0 {
                2
            } else if exact.ahead(x, t, distance, *margin) {
                0
            } else {
                1
            };
            worst[k] = worst[k].max((axial(D::to3(v)) - v_ex).abs() / amplitude.abs());
        }
        worst
    }
}

/// Particles grouped by reference x (one group per lattice column), leaving out columns
/// that contain a constrained particle.
fn free_columns<D: Dim>(case: &Case, x0: &[D::V], constrained: &[(u32, u8)]) -> Vec<Vec<usize>> {
    let key = |i: usize| (D::comp(x0[i], 0) / case.spacing).round() as i64;
    let mut groups: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
    for i in 0..x0.len() {
        groups.entry(key(i)).or_default().push(i);
    }
    for &(i, _) in constrained {
        groups.remove(&key(i as usize));
    }
    groups.into_values().collect()
}
