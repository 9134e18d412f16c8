//! `[run]`: the end time, how the run advances, and the limits that stop it.

use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// Simulated end time [s] (of the static path: the pseudo-time of the full load).
    pub end_time: f64,
    /// How the run advances: `dynamic`, integrating in time, or `static`, solving for
    /// equilibrium at every load step of `method.dt` ([`crate::statics`]). Absent: the
    /// method's own (static for the static-only methods, dynamic for the others).
    #[serde(default)]
    pub solve: Option<Solve>,
    /// Newton's convergence tolerances of a static run, `{ residual = …, increment = … }`
    /// (each optional; the defaults and the force scale: [`crate::statics::Tolerance`]).
    #[serde(default, skip_serializing_if = "crate::statics::Tolerance::is_unset")]
    pub tolerance: crate::statics::Tolerance,
    /// Stop as failed when the total energy exceeds this factor times the initial
    /// energy plus the work done by boundary conditions.
    #[serde(default = "default_energy_growth")]
    pub energy_growth_limit: f64,
    /// Stop as failed when the hourglass indicator η of a particle exceeds this, checked
    /// at every series sample (see [`crate::hourglass`]).
    #[serde(default)]
    pub hourglass_limit: Option<f64>,
    /// Stop as failed when the CFL step falls below this fraction of the first step
    /// (a collapse of the step: the run would crawl rather than end).
    #[serde(default)]
    pub min_step_ratio: Option<f64>,
    /// Simulated time between checkpoints [s] (`checkpoint.bin` in the output folder,
    /// from which `--resume` continues); absent: none.
    #[serde(default)]
    pub checkpoint_interval: Option<f64>,
    /// CPU threads of the run (a pool of its own); absent: every core. A study sweeps it
    /// to measure the parallel speed-up.
    #[serde(default)]
    pub threads: Option<usize>,
}

/// `run.solve`.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Solve {
    Dynamic,
    Static,
}

fn default_energy_growth() -> f64 {
    10.0
}
