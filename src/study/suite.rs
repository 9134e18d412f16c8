//! Suite files (`cases/studies/*.toml`): a base case, variants, a sweep and a reference,
//! expanded into the runs of a study.

use crate::case::CaseError;
use crate::core::tensor::Axis;
use crate::scene::Scene;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use thiserror::Error;
use toml::Value;

/// What a suite measures.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum SuiteKind {
    /// Error against wall time over a ladder (spacing, Δt): table and log–log plots.
    Accuracy,
    /// Stable to the end or failed, over a parameter sweep: the stability map.
    Stability,
}

/// What a user of the suite chooses between: its variants (methods, options; the default)
/// or its sweep values (when the variants are scenes and the sweep is the option).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Choice {
    #[default]
    Variants,
    Sweep,
}

/// Compute backend of a run, as named in suite files.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum BackendName {
    Cpu,
    Gpu,
}

impl BackendName {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Cpu => "cpu",
            Self::Gpu => "gpu",
        }
    }
}

pub use crate::diagnostics::analytic::AnalyticSolution;

/// Invariants a suite can measure the drift of.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum InvariantKind {
    /// max over the run of |H(t) − H(0)|/|H(0)|.
    AngularMomentum,
    /// max over the run of |E(t) − W_ext(t) − E(0)|/max(E(0), |W_ext(t)|).
    Energy,
}

/// What the errors of a suite are measured against.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Reference {
    /// Relative L2 errors of velocity and stress at the end time against a closed form.
    Analytic { solution: AnalyticSolution },
    /// Drift of a conserved quantity over the run.
    Invariant { quantity: InvariantKind },
    /// Relative L2 errors against the final state of one run of the suite (a variant at
    /// one sweep value, by default its finest spacing), matched by reference position.
    Converged {
        variant: String,
        /// Sweep value of the reference run (default: the smallest for a spacing ladder,
        /// else the last value).
        at: Option<Value>,
    },
    /// Stability only: no error is measured (invariant drifts are still recorded).
    None,
}

/// One parameter swept over values (a resolution ladder when the key is `spacing`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// Case key, as for `--set`: `spacing`, `method.cfl`, `material.poisson_ratio`, …
    pub key: String,
    /// Values, as TOML values (numbers or strings).
    pub values: Vec<Value>,
}

/// A method configuration: overrides applied after the suite's own.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variant {
    pub name: String,
    /// Base case of this variant (default: the suite's), named as the suite's `case`: a
    /// per-method preset of a benchmark, say.
    pub case: Option<String>,
    #[serde(default)]
    pub set: Vec<String>,
    /// Backends of this variant (default: the suite's).
    pub backends: Option<Vec<BackendName>>,
    /// Published values of the `[history]` column at its `at` times, shown beside this
    /// variant's (the source is the history's `published`).
    #[serde(default)]
    pub published: Vec<f64>,
    /// A smoothing length h [m] held fixed over a spacing ladder: `method.h_over_dx` =
    /// h/spacing at every sweep value (the constant domain of influence of seed 001 §9.1),
    /// instead of a fixed h/Δx. Only with `[sweep] key = "spacing"`.
    pub smoothing_length: Option<f64>,
}

/// A quantity proportional to the simulated time, shown beside failure times: for a
/// column pulled at constant speed v, the stretch λ3 = 100 % · v t / L.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TimeMeasure {
    pub name: String,
    /// Its value per second of simulated time.
    pub per_second: f64,
    pub unit: String,
}

impl TimeMeasure {
    /// "λ3 = 383 %" at time t.
    pub fn at(&self, t: f64) -> String {
        format!("{} = {:.0} {}", self.name, self.per_second * t, self.unit)
    }
}

/// A column of the runs' time series (`series.csv`) drawn against time, one line per run:
/// y = `scale` × column, x = `x_scale` × t; or against another column (`x_column`):
/// x = `x_scale` × that column (a stress–strain curve from a reaction and a grip's
/// displacement, say).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct History {
    /// Column of `series.csv`: `angular_momentum_z`, `neck_height`, `left.extent_y`, …
    pub column: String,
    /// Label of the y axis (of column × scale).
    pub label: String,
    #[serde(default = "unit_scale")]
    pub scale: f64,
    /// Label of the x axis (of t, or of `x_column`, × x_scale).
    #[serde(default = "time_label")]
    pub x_label: String,
    #[serde(default = "unit_scale")]
    pub x_scale: f64,
    /// The column on the x axis instead of the time.
    pub x_column: Option<String>,
    /// Times [s] at which the column is tabulated, per run (linear interpolation between
    /// the rows around each): seed 001's errors at the rod's return times, say. Empty: the
    /// table gives the first, smallest, largest and last values instead.
    #[serde(default)]
    pub at: Vec<f64>,
    /// Where the variants' `published` values at those times come from (a paper's table).
    pub published: Option<String>,
}

/// A field drawn on the particles' current positions at the end of every run, or at its
/// failure: one panel per run, y = `scale` × field. The positions are projected on the
/// x–y plane, or with `view` seen from that direction.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Picture {
    pub field: PictureField,
    /// Label of the colour scale (of field × scale).
    pub label: String,
    #[serde(default = "unit_scale")]
    pub scale: f64,
    /// The direction towards the eye of an orthographic view (a 3D body), z up on the
    /// page (y where the view is along z); None: the x–y plane.
    pub view: Option<[f64; 3]>,
    /// The coordinate planes through the origin the particles are also mirrored across
    /// (a model's symmetry planes), so that the picture shows the whole body.
    #[serde(default)]
    pub reflect: Vec<Axis>,
}

/// The fields a picture draws.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum PictureField {
    /// σ_θθ = e_θ·σ e_θ about the centroid of the current positions (in-plane).
    HoopStress,
    /// The equivalent plastic strain ε_p (`von-mises-plastic`).
    PlasticStrain,
    /// The pressure p = −tr σ/3.
    Pressure,
}

/// What a suite's advice ranks its candidates by (`[advice] measure`).
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Measure {
    /// The relative L2 error of v at the end (an analytic or converged reference).
    Velocity,
    /// The relative L2 error of P at the end (an analytic or converged reference).
    Stress,
    /// max |H(t) − H(0)|/|H(0)| over the run.
    AngularMomentum,
    /// The energy balance's largest residue over its scale.
    Energy,
    /// The `[history]` column: its last value's magnitude, or with `against` the relative
    /// L2 distance of the curve from that variant's at the same sweep value.
    History,
    /// No error measures the job: stable furthest into the sweep, then the cheapest.
    Stability,
}

impl Measure {
    /// The values of `[advice] measure`, as a suite file writes them.
    pub const NAMES: &'static str =
        "velocity, stress, angular-momentum, energy, history, stability";
}

/// What a suite's advice weighs (`[advice]`): the measure of the job, the wall time a user
/// would spend on one run, and the variants a user may be advised to use.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Advice {
    pub measure: Measure,
    /// With `measure = "history"`: the variant whose curve the others are measured against.
    pub against: Option<String>,
    /// Wall time of one run [s] that a user would spend on the job on the measuring machine.
    pub budget: f64,
    /// The sweep value at which an error measure compares the candidates (a sweep of the
    /// job's difficulty: the hardest value); without it, every run of the sweep (a
    /// resolution ladder) competes.
    pub at: Option<Value>,
    /// Variants that may be advised; the others are evidence (no contact, a deliberately
    /// broken setting, a stand-in material), shown but never advised.
    pub candidates: Vec<String>,
    /// The suite compares settings of one method: its advice also gives each setting's
    /// effect (as `choice = "sweep"` does).
    #[serde(default)]
    pub settings: bool,
}

fn unit_scale() -> f64 {
    1.0
}

fn time_label() -> String {
    "t [s]".into()
}

/// A study suite.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Suite {
    /// Letters, digits, - and _: names the output folder and plot files.
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// The job a user picks a method for, named in the report's recommendations.
    #[serde(default)]
    pub job: String,
    pub kind: SuiteKind,
    /// What the report's recommendation chooses between.
    #[serde(default)]
    pub choice: Choice,
    /// Base case: a shipped case name or a path relative to the suite file.
    pub case: String,
    /// Overrides applied to every run (before the variant's and the sweep's).
    #[serde(default)]
    pub set: Vec<String>,
    #[serde(default = "default_backends")]
    pub backends: Vec<BackendName>,
    pub sweep: Sweep,
    #[serde(rename = "variant")]
    pub variants: Vec<Variant>,
    pub reference: Reference,
    /// Shown beside every failure time.
    pub failure_measure: Option<TimeMeasure>,
    /// A series column plotted against time for every run.
    pub history: Option<History>,
    /// A field drawn on the particles at the end of every run.
    pub picture: Option<Picture>,
    /// Part of `meshless study all` (the published report); such a suite needs `[advice]`.
    #[serde(default)]
    pub report: bool,
    /// A paper-scale suite that `meshless study all` does not run: its section of the
    /// report is drawn from the results it already has, and it is run by its own name.
    #[serde(default)]
    pub long: bool,
    /// How the report's advice ranks the variants.
    pub advice: Option<Advice>,
    /// The suite file.
    #[serde(skip)]
    pub file: PathBuf,
}

fn default_backends() -> Vec<BackendName> {
    vec![BackendName::Cpu]
}

#[derive(Debug, Error)]
pub enum SuiteError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: {message}")]
    Invalid { file: PathBuf, message: String },
    #[error(transparent)]
    Case(#[from] CaseError),
}

/// One run of a suite: a variant on a backend at one sweep value.
#[derive(Clone, Debug)]
pub struct PlannedRun {
    /// Stable id: a hash of the resolved case and the backend (or of the overrides when the
    /// case does not validate).
    pub id: String,
    pub variant: String,
    pub backend: BackendName,
    /// The sweep value as written in tables (`0.05`, `rk4`).
    pub value: String,
    /// Numeric sweep value (NaN for strings).
    pub number: f64,
    /// All overrides of the run, in order.
    pub overrides: Vec<String>,
    /// The resolved case, or why it is invalid.
    pub case: Result<Box<Scene>, String>,
}

impl Suite {
    /// Reads a suite file and checks its names and reference.
    pub fn load(path: &Path) -> Result<Suite, SuiteError> {
        let text = std::fs::read_to_string(path).map_err(|source| SuiteError::Read {
            file: path.to_path_buf(),
            source,
        })?;
        let invalid = |message: String| SuiteError::Invalid {
            file: path.to_path_buf(),
            message,
        };
        let mut suite: Suite = toml::from_str(&text).map_err(|e| invalid(e.to_string()))?;
        suite.file = path.to_path_buf();
        let good_name = |s: &str| {
            !s.is_empty()
                && s.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        };
        if !good_name(&suite.name) {
            return Err(invalid(format!(
                "`name = {:?}`: use letters, digits, - and _",
                suite.name
            )));
        }
        if suite.variants.is_empty() || suite.sweep.values.is_empty() {
            return Err(invalid(
                "a suite needs at least one [[variant]] and one sweep value".into(),
            ));
        }
        let mut names: Vec<&str> = suite.variants.iter().map(|v| v.name.as_str()).collect();
        if let Some(bad) = names.iter().find(|n| !good_name(n)) {
            return Err(invalid(format!(
                "variant `{bad}`: use letters, digits, - and _"
            )));
        }
        if let Some(h) = &suite.history
            && !(h.scale.is_finite() && h.x_scale.is_finite() && h.scale != 0.0 && h.x_scale > 0.0)
        {
            return Err(invalid(format!(
                "[history]: `scale` must be finite and non-zero and `x_scale` finite and \
                 positive (got {} and {})",
                h.scale, h.x_scale
            )));
        }
        if let Some(p) = &suite.picture
            && !(p.scale.is_finite()
                && p.scale != 0.0
                && p.view
                    .is_none_or(|v| v.iter().all(|c| c.is_finite()) && v.iter().any(|&c| c != 0.0)))
        {
            return Err(invalid(format!(
                "[picture]: `scale` must be finite and non-zero (got {}) and `view` a finite, \
                 non-zero direction (got {:?})",
                p.scale, p.view
            )));
        }
        if let Some(h) = &suite.history
            && h.x_column.is_some()
            && !h.at.is_empty()
        {
            return Err(invalid(
                "[history]: `at` tabulates the column at times, which the x axis of \
                 `x_column` does not show; give one of them"
                    .into(),
            ));
        }
        if let Some(h) = &suite.history
            && let Some(t) = h.at.iter().find(|t| !(t.is_finite() && **t >= 0.0))
        {
            return Err(invalid(format!(
                "[history] `at`: {t} is not a time; give finite times ≥ 0 in seconds"
            )));
        }
        let at = suite.history.as_ref().map_or(0, |h| h.at.len());
        let source = suite
            .history
            .as_ref()
            .is_some_and(|h| h.published.is_some());
        if let Some(v) = suite
            .variants
            .iter()
            .find(|v| !v.published.is_empty() && (v.published.len() != at || !source))
        {
            return Err(invalid(format!(
                "variant `{}`: `published` gives {} values; it needs a [history] with as many \
                 `at` times ({at}) and a `published` source",
                v.name,
                v.published.len()
            )));
        }
        if let Some(v) = suite.variants.iter().find(|v| {
            v.smoothing_length
                .is_some_and(|h| suite.sweep.key != "spacing" || !(h.is_finite() && h > 0.0))
        }) {
            return Err(invalid(format!(
                "variant `{}`: `smoothing_length` holds h fixed over a spacing ladder; it \
                 needs `[sweep] key = \"spacing\"` (here `{}`) and a finite h > 0",
                v.name, suite.sweep.key
            )));
        }
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(invalid(format!("variant `{}` is listed twice", w[0])));
        }
        if let Reference::Converged { variant, at } = &suite.reference {
            if !names.contains(&variant.as_str()) {
                return Err(invalid(format!(
                    "reference variant `{variant}` is not one of the variants {names:?}"
                )));
            }
            if at
                .as_ref()
                .is_some_and(|at| !suite.sweep.values.contains(at))
            {
                return Err(invalid(
                    "reference `at` is not one of the sweep values".into(),
                ));
            }
        }
        suite.check_advice().map_err(invalid)?;
        Ok(suite)
    }

    /// `[advice]`: present on a reported suite, its measure one the suite records, its
    /// `against` and candidates variants of the suite, its budget a positive time.
    fn check_advice(&self) -> Result<(), String> {
        let Some(a) = &self.advice else {
            return match self.report {
                true => Err(format!(
                    "`report = true` needs an [advice] table: `measure` (one of {}), `budget` \
                     (seconds) and `candidates` (variant names)",
                    Measure::NAMES
                )),
                false => Ok(()),
            };
        };
        let is_variant = |name: &str| self.variants.iter().any(|v| v.name == name);
        let variants = || {
            let names: Vec<&str> = self.variants.iter().map(|v| v.name.as_str()).collect();
            names.join(", ")
        };
        let fields = matches!(
            self.reference,
            Reference::Analytic { .. } | Reference::Converged { .. }
        );
        if matches!(a.measure, Measure::Velocity | Measure::Stress) && !fields {
            return Err(format!(
                "[advice] `measure = {:?}` is measured against an analytic or converged \
                 [reference], which this suite does not have; use one of {}",
                format!("{:?}", a.measure).to_lowercase(),
                "angular-momentum, energy, history, stability"
            ));
        }
        if a.measure == Measure::History && self.history.is_none() {
            return Err("[advice] `measure = \"history\"` needs a [history] column".into());
        }
        match &a.against {
            Some(_) if a.measure != Measure::History => {
                return Err(
                    "[advice] `against` names the curve of `measure = \"history\"` only".into(),
                );
            }
            Some(v) if !is_variant(v) => {
                return Err(format!(
                    "[advice] `against = {v:?}` is not a variant; use one of {}",
                    variants()
                ));
            }
            _ => {}
        }
        if let Some(at) = &a.at {
            if a.measure == Measure::Stability {
                return Err(
                    "[advice] `at` picks the sweep value an error measure compares \
                            the candidates at; `measure = \"stability\"` has none"
                        .into(),
                );
            }
            if !self.sweep.values.contains(at) {
                return Err(format!(
                    "[advice] `at = {at}` is not one of the sweep values of `{}`",
                    self.sweep.key
                ));
            }
        }
        if !(a.budget.is_finite() && a.budget > 0.0) {
            return Err(format!(
                "[advice] `budget = {}`: give the wall time of one run in seconds, finite and \
                 positive",
                a.budget
            ));
        }
        if a.candidates.is_empty() {
            return Err(
                "[advice] `candidates` is empty: name the variants a user may be \
                        advised to use"
                    .into(),
            );
        }
        if let Some(c) = a.candidates.iter().find(|c| !is_variant(c)) {
            return Err(format!(
                "[advice] `candidates`: `{c}` is not a variant; use names of {}",
                variants()
            ));
        }
        let mut names: Vec<&String> = a.candidates.iter().collect();
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("[advice] `candidates`: `{}` is listed twice", w[0]));
        }
        Ok(())
    }

    /// The base case file of a variant: its own `case`, else the suite's.
    pub fn case_path(&self, variant: &Variant) -> PathBuf {
        let case = variant.case.as_deref().unwrap_or(&self.case);
        let dir = self.file.parent().unwrap_or(Path::new("."));
        if case.ends_with(".toml") || case.contains('/') {
            return dir.join(case);
        }
        let shipped = dir.join("..").join(format!("{case}.toml"));
        if shipped.exists() {
            shipped
        } else {
            Path::new("cases").join(format!("{case}.toml"))
        }
    }

    /// The sweep value the converged reference is taken at.
    pub fn reference_value(&self) -> Option<(&str, String)> {
        let Reference::Converged { variant, at } = &self.reference else {
            return None;
        };
        let value = match at {
            Some(v) => v.clone(),
            None if self.sweep.key == "spacing" => self
                .sweep
                .values
                .iter()
                .min_by(|a, b| number(a).total_cmp(&number(b)))
                .cloned()?,
            None => self.sweep.values.last().cloned()?,
        };
        Some((variant, label(&value)))
    }

    /// Every run, variant by variant, backend by backend, in sweep order; the converged
    /// reference run (if any) first.
    pub fn plan(&self) -> Vec<PlannedRun> {
        let mut runs = Vec::new();
        for variant in &self.variants {
            let path = self.case_path(variant);
            let backends = variant.backends.as_ref().unwrap_or(&self.backends);
            for &backend in backends {
                for value in &self.sweep.values {
                    let fixed_h = variant
                        .smoothing_length
                        .map(|h| format!("method.h_over_dx={}", h / number(value)));
                    let overrides: Vec<String> = self
                        .set
                        .iter()
                        .chain(&variant.set)
                        .cloned()
                        .chain([format!("{}={}", self.sweep.key, value)])
                        .chain(fixed_h)
                        .collect();
                    let case = Scene::load(&path, &overrides).map_err(|e| e.to_string());
                    let identity = match &case {
                        Ok(c) => toml::to_string(&c.resolved()).unwrap_or_else(|e| e.to_string()),
                        Err(_) => format!("{}\n{}", path.display(), overrides.join("\n")),
                    };
                    runs.push(PlannedRun {
                        id: format!(
                            "{:016x}",
                            fnv1a(format!("{identity}\nbackend={}", backend.as_str()).as_bytes())
                        ),
                        variant: variant.name.clone(),
                        backend,
                        value: label(value),
                        number: number(value),
                        overrides,
                        case: case.map(Box::new),
                    });
                }
            }
        }
        let reference = self.reference_value().and_then(|(variant, value)| {
            runs.iter()
                .position(|r| r.variant == variant && r.value == value)
        });
        if let Some(k) = reference {
            let run = runs.remove(k);
            runs.insert(0, run);
        }
        runs
    }
}

/// A sweep value as written in tables: numbers as TOML writes them, strings bare.
pub fn label(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Float(x) if *x != 0.0 && (x.abs() < 1e-3 || x.abs() >= 1e6) => format!("{x:e}"),
        Value::Float(x) => format!("{x}"),
        other => other.to_string(),
    }
}

fn number(v: &Value) -> f64 {
    match v {
        Value::Float(x) => *x,
        Value::Integer(i) => *i as f64,
        _ => f64::NAN,
    }
}

pub use crate::case::fnv1a;

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/studies")
    }

    #[test]
    fn every_reported_suite_declares_its_advice_over_its_own_variants() {
        let mut reported = 0;
        for entry in std::fs::read_dir(shipped()).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "toml") {
                continue;
            }
            let suite = Suite::load(&path).unwrap_or_else(|e| panic!("{e}"));
            if !suite.report {
                continue;
            }
            reported += 1;
            let a = suite
                .advice
                .as_ref()
                .unwrap_or_else(|| panic!("{}: reported without [advice]", path.display()));
            assert!(a.budget > 0.0, "{}: budget {}", suite.name, a.budget);
            assert!(!a.candidates.is_empty(), "{}: no candidates", suite.name);
            for c in a.candidates.iter().chain(&a.against) {
                assert!(
                    suite.variants.iter().any(|v| v.name == *c),
                    "{}: `{c}` is not a variant",
                    suite.name
                );
            }
        }
        assert!(reported >= 30, "{reported} reported suites");
    }

    /// Loads a suite file of `text` and returns its error.
    fn refused(text: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, text).unwrap();
        Suite::load(&path).unwrap_err().to_string()
    }

    const SUITE: &str = r#"
name = "s"
kind = "accuracy"
case = "c"
sweep = { key = "spacing", values = [0.1] }
reference = { type = "none" }
[[variant]]
name = "a"
[[variant]]
name = "b"
"#;

    #[test]
    fn a_bad_advice_is_refused_naming_the_file_and_the_key() {
        let e = refused(&format!("report = true\n{SUITE}"));
        assert!(
            e.contains("bad.toml") && e.contains("[advice]") && e.contains("stability"),
            "{e}"
        );
        let with = |advice: &str| refused(&format!("advice = {{ {advice} }}\n{SUITE}"));
        let e = with(r#"measure = "velocity", budget = 1.0, candidates = ["a"]"#);
        assert!(
            e.contains("bad.toml") && e.contains("`measure = \"velocity\"`"),
            "{e}"
        );
        let e = with(r#"measure = "energy", budget = 1.0, candidates = ["a", "z"]"#);
        assert!(
            e.contains("`z` is not a variant") && e.contains("a, b"),
            "{e}"
        );
        let e = with(r#"measure = "energy", budget = 0.0, candidates = ["a"]"#);
        assert!(e.contains("`budget = 0`"), "{e}");
        let e = with(r#"measure = "history", budget = 1.0, candidates = ["a"]"#);
        assert!(e.contains("needs a [history]"), "{e}");
        let e = with(r#"measure = "energy", against = "a", budget = 1.0, candidates = ["a"]"#);
        assert!(e.contains("`against`"), "{e}");
        let e = with(r#"measure = "size", budget = 1.0, candidates = ["a"]"#);
        assert!(e.contains("bad.toml") && e.contains("stability"), "{e}");
    }

    #[test]
    fn a_picture_without_a_direction_or_scale_is_refused() {
        let with = |picture: &str| {
            refused(&format!(
                "picture = {{ field = \"pressure\", label = \"p\", {picture} }}\n{SUITE}"
            ))
        };
        for bad in [
            "view = [0.0, 0.0, 0.0]",
            "view = [1.0, nan, 0.0]",
            "scale = 0.0",
        ] {
            let e = with(bad);
            assert!(
                e.contains("bad.toml") && e.contains("[picture]"),
                "{bad}: {e}"
            );
        }
        let e = with(r#"reflect = ["w"]"#);
        assert!(e.contains("bad.toml") && e.contains("`x`"), "{e}");
    }
}
