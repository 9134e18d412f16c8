//! Observers: energies, momenta, body extents, neck height, the velocity error against a
//! closed form and point probes, sampled into the CSV time series.

use crate::analytic::{Exact, relative_l2};
use crate::methods::shared::ordered_reduce;
use crate::scene::{Case, CaseError, Observer};
use crate::tensor::Dim;
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
    pub strain_energy: f64,
    /// Per-particle fields of the method's own, written into the frames.
    pub extra: Vec<ScalarField>,
    /// The corners of the method's elements, 2^d per cell in VTK order, which the frames
    /// show as cells on the particles; empty for the particle methods.
    pub cells: &'a [u32],
}

/// A per-particle scalar field that a method adds to the frames (the plastic strain ε_p).
#[derive(Clone, Debug, PartialEq)]
pub struct ScalarField {
    /// The field's name in the VTU frames.
    pub name: &'static str,
    pub values: Vec<f64>,
}

impl<D: Dim> Snapshot<'_, D> {
    /// The values of the method's own field `name`, if it has one.
    pub fn field(&self, name: &str) -> Option<&[f64]> {
        self.extra
            .iter()
            .find(|f| f.name == name)
            .map(|f| f.values.as_slice())
    }
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
            strain: snap.strain_energy,
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

/// Where a run stands: time, step count, last step size and the work done on the body by
/// supports and loads so far.
#[derive(Clone, Copy, Debug, Default)]
pub struct Clock {
    pub t: f64,
    pub step: u64,
    pub dt: f64,
    pub external_work: f64,
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
    /// The closed form of the `front-oscillation` observer, and the margin about its
    /// jumps [m].
    front: Option<(Exact, f64)>,
    names: Vec<String>,
}

impl Observers {
    /// Observers of a case over particles at reference positions x0, of which
    /// `constrained` have prescribed velocity components.
    pub fn new<D: Dim>(
        case: &Case,
        x0: &[D::V],
        constrained: &[(u32, u8)],
    ) -> Result<Self, CaseError> {
        let mut names = vec!["time".to_string(), "step".to_string(), "dt".to_string()];
        let mut list = case.output.observers.clone();
        list.sort();
        list.dedup();
        for obs in &list {
            match obs {
                Observer::Energy => names.extend(
                    [
                        "kinetic_energy",
                        "strain_energy",
                        "total_energy",
                        "external_work",
                    ]
                    .map(String::from),
                ),
                Observer::LinearMomentum => {
                    names.extend((0..D::N).map(|k| format!("momentum_{}", AXES[k])))
                }
                Observer::AngularMomentum => names.extend(
                    angular_components::<D>().map(|k| format!("angular_momentum_{}", AXES[k])),
                ),
                Observer::Extent => {
                    for b in &case.bodies {
                        names.extend((0..D::N).map(|k| format!("{}.extent_{}", b.name, AXES[k])));
                    }
                }
                Observer::NeckHeight => names.push("neck_height".into()),
                Observer::Hourglass => names.push("hourglass_max".into()),
                Observer::VelocityError(_) => names.push("velocity_error".into()),
                Observer::FrontOscillation(_) => names.extend(
                    [
                        "ahead_oscillation",
                        "behind_oscillation",
                        "plateau_oscillation",
                    ]
                    .map(String::from),
                ),
            }
        }
        let front = list
            .iter()
            .find_map(|o| match o {
                Observer::FrontOscillation(s) => Some(*s),
                _ => None,
            })
            .map(|s| Exact::of(s, case).map_err(|m| case.invalid("output.observers", m)))
            .transpose()?
            .map(|e| (e, FRONT_MARGIN * case.smoothing_length()));
        let exact = list
            .iter()
            .find_map(|o| match o {
                Observer::VelocityError(s) => Some(*s),
                _ => None,
            })
            .map(|s| Exact::of(s, case).map_err(|m| case.invalid("output.observers", m)))
            .transpose()?
            .map(|e| (e, case.material.density));
        let mut probes = Vec::new();
        for (p, probe) in case.probes.iter().enumerate() {
            let target = D::from_slice(&probe.position);
            let nearest = (0..x0.len())
                .min_by(|&a, &b| D::norm2(x0[a] - target).total_cmp(&D::norm2(x0[b] - target)))
                .ok_or_else(|| {
                    case.invalid(format!("probe.{p}.position"), "the scene has no particles")
                })?;
            probes.push(nearest);
            for q in ["u", "v"] {
                names.extend((0..D::N).map(|k| format!("{}.{q}{}", probe.name, AXES[k])));
            }
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
            front,
            names,
        })
    }

    pub fn column_names(&self) -> &[String] {
        &self.names
    }

    /// Whether a row needs the hourglass indicator η of every particle.
    pub fn need_hourglass(&self) -> bool {
        self.list.contains(&Observer::Hourglass)
    }

    /// One row of the time series; `eta` is the hourglass indicator of every particle,
    /// given when [`Self::need_hourglass`].
    pub fn sample<D: Dim>(
        &self,
        snap: &Snapshot<D>,
        inv: &Invariants,
        clock: &Clock,
        eta: Option<&[f64]>,
    ) -> Vec<f64> {
        let (x0, u, v) = (snap.x0, &snap.u, &snap.v);
        let mut row = vec![clock.t, clock.step as f64, clock.dt];
        for obs in &self.list {
            match obs {
                Observer::Energy => row.extend([
                    inv.kinetic,
                    inv.strain,
                    inv.total_energy(),
                    clock.external_work,
                ]),
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
                    eta.expect("η is computed when the hourglass observer is on")
                        .iter()
                        .fold(0.0, |a: f64, &b| a.max(b)),
                ),
                Observer::VelocityError(_) => row.push(self.velocity_error(snap, clock.t)),
                Observer::FrontOscillation(_) => row.extend(self.front_oscillation(snap, clock.t)),
            }
        }
        for &i in &self.probes {
            row.extend((0..D::N).map(|k| D::comp(u[i], k)));
            row.extend((0..D::N).map(|k| D::comp(v[i], k)));
        }
        row
    }

    /// sqrt(Σ V |v − v_ex|²)/sqrt(Σ V |v_ex|²) with V = m/ρ0, over every component.
    fn velocity_error<D: Dim>(&self, snap: &Snapshot<D>, t: f64) -> f64 {
        let Some((exact, rho0)) = &self.exact else {
            return f64::NAN;
        };
        let w: Vec<f64> = snap.mass.iter().map(|m| m / rho0).collect();
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
