//! `[output]` (frames, series, observers, checks), `[[probe]]` and `[[section]]`.

use super::Axis;
use serde::{Deserialize, Serialize};

/// Observers written to the CSV time series.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "kebab-case")]
pub enum Observer {
    /// Kinetic, strain and total energy.
    Energy,
    /// Σ m v.
    LinearMomentum,
    /// Σ m x × v about the origin.
    AngularMomentum,
    /// Current bounding-box size of every body along each axis.
    Extent,
    /// Smallest current height (y-extent) over the material columns of free particles.
    NeckHeight,
    /// Largest hourglass indicator η over the particles.
    Hourglass,
    /// The relative L2 error of the velocity against a closed form at the row's time,
    /// sqrt(Σ V |v − v_ex|²)/sqrt(Σ V |v_ex|²) over the particles, all components (column
    /// `velocity_error`); in case files `{ velocity-error = "free-rod" }`.
    VelocityError(crate::diagnostics::analytic::AnalyticSolution),
    /// How far a ring is from rotational symmetry (2D): the particles grouped into rings
    /// of equal reference radius about the reference centroid (those of a polar lattice),
    /// the largest spread of σ_θθ around a ring, std over the largest |mean| of a ring
    /// (column `hoop_stress_spread`), and of the current gaps between neighbours on a ring,
    /// std over mean (column `hoop_gap_spread`). Both are zero under a rotationally
    /// symmetric motion and grow where particles cluster. With `von-mises-plastic`, also
    /// the largest std over mean of ε_p around a ring, the mean at least 1e-3 (column
    /// `plastic_strain_spread`), which grows where the plastic strain localises.
    RingSymmetry,
    /// The relative errors against the closed form of the case's `solution-displacement`
    /// condition, with the method's own quadrature (seed 001 eqs 71–74): of the
    /// displacement, sqrt(Σ_q w_q |u^h − u_a|²)/sqrt(Σ_q w_q |u_a|²) (column
    /// `displacement_error`), and in energy, sqrt(Σ_q w_q ψ(I + ∇u^h − ∇u_a))/sqrt(Σ_q w_q
    /// ψ(I + ∇u_a)) (column `energy_error`; for the linear-elastic model ψ(I + H) =
    /// ½ ε:C:ε, so this is the energy norm sqrt(½ ∫ (P:Fᵀ of the difference)) of eq 74).
    SolutionError,
    /// Oscillations about a closed form with jumps (`driven-rod`) away from them, relative
    /// to its amplitude V, over the particles farther than
    /// [`crate::diagnostics::observe::FRONT_MARGIN`] smoothing lengths along its axis d from every jump:
    /// the largest |v·d|/V where the closed form is at rest and the nearest jump runs
    /// towards the particle (column `ahead_oscillation`: ahead of the pulse) or away from
    /// it (`behind_oscillation`), and the largest |(v − v_ex)·d|/V where it moves
    /// (`plateau_oscillation`); in case files `{ front-oscillation = "driven-rod" }`.
    FrontOscillation(crate::diagnostics::analytic::AnalyticSolution),
    /// The force each support (a boundary condition that prescribes motion) applies to
    /// hold its prescribed components, and its power, at the last rate evaluation:
    /// R = Σ m (a_prescribed − a) over the components it holds, columns
    /// `<name>.reaction_x`, … and `<name>.power` (R·v), with `<name>` the condition's
    /// `name` (default `boundary<k>`); and for every load with a `name` (a traction,
    /// pressure, body force or a solution's traction), the total external force it applies
    /// at the row's time, `<name>.applied_force_x`, …: the sum of its particles' forces
    /// (a body force's on the method's masses) times its time law at t, or times the load
    /// factor t/end_time on the static path.
    Reaction,
    /// How much of the pressure is a spurious oscillation: ‖δp‖/‖p‖ over the particles,
    /// δp the deviation of each particle's pressure from the linear fit over its
    /// neighbours (column `pressure_oscillation`; [`crate::physics::pressure`]). The frames carry
    /// δp as `pressure_deviation` whether or not the observer is on.
    PressureOscillation,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Time between VTU frames [s]; frames at t = 0 and at the end are always written.
    /// Absent: only those two.
    pub frame_interval: Option<f64>,
    /// Time between rows of the CSV time series [s]; absent: every step.
    pub series_interval: Option<f64>,
    #[serde(default = "default_observers")]
    pub observers: Vec<Observer>,
    /// The case's documented checks, evaluated on the series at the end of a run.
    #[serde(default, rename = "check")]
    pub checks: Vec<CheckSpec>,
}

/// A number a run of the case is checked by: a statistic of one series column, printed at
/// the end of the run and kept in `summary.json`, with the range it is expected in.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CheckSpec {
    /// What the number is, in words.
    pub label: String,
    /// The series column it is taken from.
    pub column: String,
    pub statistic: Statistic,
    /// The range [lo, hi] it is expected in, if any.
    pub expected: Option<[f64; 2]>,
    /// Where the expected range comes from (a paper's table, a closed form).
    pub source: Option<String>,
}

/// A statistic of a series column c(t).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Statistic {
    /// c at the last row.
    End,
    Min,
    Max,
    /// max_t |c(t) − c(0)| / |c(0)|.
    Drift,
}

impl Statistic {
    /// The statistic of the values c(t) in row order; NaN without rows.
    pub fn of(self, c: &[f64]) -> f64 {
        let (Some(&first), Some(&last)) = (c.first(), c.last()) else {
            return f64::NAN;
        };
        match self {
            Self::End => last,
            Self::Min => c.iter().copied().fold(f64::INFINITY, f64::min),
            Self::Max => c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            Self::Drift => c.iter().map(|x| (x - first).abs()).fold(0.0, f64::max) / first.abs(),
        }
    }
}

fn default_observers() -> Vec<Observer> {
    vec![Observer::Energy]
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            frame_interval: None,
            series_interval: None,
            observers: default_observers(),
            checks: Vec::new(),
        }
    }
}

/// A point probe: the particle nearest to `position` in the reference configuration.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    pub name: String,
    pub position: Vec<f64>,
}

/// A section of the reference configuration, the plane X·e_normal = `at` (within one
/// body if `body` is given), across which the series gives the resultant force ∫ P·N dA
/// (columns `<name>.force_x`, …; N = e_normal, the force the material at larger X·N
/// exerts on the rest). Per particle, V P·N times the hat weight
/// max(0, 1 − |X·N − at|/Δx)/Δx, which sums to one over the rows of a lattice, so a
/// uniform P gives ∫ P·N dA exactly wherever the plane lies between rows.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SectionSpec {
    pub name: String,
    pub normal: Axis,
    pub at: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::Statistic;

    #[test]
    fn statistics_of_a_series_column() {
        let c = [2.0, 3.0, 1.0, 2.5];
        assert_eq!(Statistic::End.of(&c), 2.5);
        assert_eq!(Statistic::Min.of(&c), 1.0);
        assert_eq!(Statistic::Max.of(&c), 3.0);
        // max |c − c(0)| = 1 (at 3 and at 1), over |c(0)| = 2.
        assert_eq!(Statistic::Drift.of(&c), 0.5);
        assert!(Statistic::End.of(&[]).is_nan());
    }
}
