//! JSON summary of a finished, failed or interrupted run.

use std::collections::BTreeMap;
use std::io::{self, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::write_atomically;

/// What a run did and how fast, written once at its end.
///
/// JSON has no NaN or infinity: every non-finite number (in the scalar fields
/// and in `final_invariants`) is written as `null` and read back as NaN, so a
/// summary of a diverged run still writes and parses.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// Case name.
    pub case: String,
    /// The GPU pass report of a run with `--profile` (not written to the file).
    #[serde(skip)]
    pub passes: Option<crate::diagnostics::passes::PassReport>,
    /// The version of meshless that ran it.
    #[serde(default)]
    pub version: String,
    /// The case file and the `--set` overrides applied to it, in order.
    #[serde(default)]
    pub case_file: String,
    #[serde(default)]
    pub overrides: Vec<String>,
    /// The case as run: the file with the overrides and every default resolved.
    #[serde(default)]
    pub resolved_case: serde_json::Value,
    /// Particle method.
    pub method: String,
    /// Compute backend: `cpu`, or `gpu: ` and the adapter's name and API.
    pub backend: String,
    /// Spatial dimension (2 or 3).
    pub dimension: u32,
    /// Number of particles.
    pub particles: usize,
    /// Time steps taken.
    pub steps: u64,
    /// Last time step size.
    #[serde(with = "non_finite_as_null")]
    pub dt_last: f64,
    /// Simulated time reached.
    #[serde(with = "non_finite_as_null")]
    pub end_time: f64,
    /// Wall-clock duration of the run.
    #[serde(with = "non_finite_as_null")]
    pub wall_seconds: f64,
    /// Throughput: particles times steps per wall-clock second.
    #[serde(with = "non_finite_as_null")]
    pub particle_steps_per_second: f64,
    /// Of a distributed run: the wall time rank 0 spent in the exchanges with the other
    /// ranks during the steps, waiting for them included (`Engine::halo_seconds`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub halo_seconds: Option<f64>,
    /// `"running"` (written when the run starts), `"completed"`, `"failed"` or
    /// `"interrupted"`.
    pub status: String,
    /// Why the run failed, if it did.
    #[serde(default)]
    pub failure: Option<String>,
    /// Conserved or monitored quantities at the end of the run.
    #[serde(with = "non_finite_values_as_null")]
    pub final_invariants: BTreeMap<String, f64>,
    /// The energy balance's terms booked by the end and its residue over its scale
    /// (`crate::diagnostics::balance`: `external_work`, `dissipated`, `hourglass_work`, `plastic_work`,
    /// `contact_energy`, `energy_residue`); null for a term the engine does not book.
    #[serde(default, with = "non_finite_values_as_null")]
    pub energy_balance: BTreeMap<String, f64>,
    /// The case's documented checks (`[[output.check]]`) on the series written.
    #[serde(default)]
    pub checks: Vec<CheckResult>,
}

/// A case's check evaluated on a run's series.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct CheckResult {
    pub label: String,
    pub column: String,
    /// `end`, `min`, `max` or `drift`.
    pub statistic: String,
    #[serde(with = "non_finite_as_null")]
    pub value: f64,
    pub expected: Option<[f64; 2]>,
    pub source: Option<String>,
    /// Whether the value lies in the expected range (none without one).
    pub within: Option<bool>,
}

impl std::fmt::Display for CheckResult {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} ({} of {})",
            self.label, self.value, self.statistic, self.column
        )?;
        if let (Some([lo, hi]), Some(within)) = (self.expected, self.within) {
            let verdict = if within { "within" } else { "OUTSIDE" };
            write!(f, "; expected {lo} to {hi}")?;
            if let Some(source) = &self.source {
                write!(f, " ({source})")?;
            }
            write!(f, ": {verdict}")?;
        }
        Ok(())
    }
}

/// Blanks after the JSON of a `"running"` summary [bytes]: room on the disk that its final
/// version, a few kilobytes longer at most (the invariants, the energy balance, the checks
/// and the failure), can take in place when the disk is full.
const RESERVE: usize = 64 << 10;

/// Writes `summary` to `path` as pretty-printed JSON, atomically. Where the new copy does
/// not fit (a full disk), it overwrites the old one in place instead, within the room the
/// running summary reserved ([`RESERVE`]), so that a run that fails for want of space
/// still ends with its summary saying why.
pub fn write_summary(path: &Path, summary: &RunSummary) -> io::Result<()> {
    let mut text = serde_json::to_vec_pretty(summary)?;
    text.push(b'\n');
    if summary.status == "running" {
        text.resize(text.len() + RESERVE, b' ');
    }
    write_atomically(path, |w| w.write_all(&text))
        .or_else(|error| overwrite_within(path, &text).map_err(|_| error))
}

/// Writes `text` over the regular file `path` from its start and cuts the file after it,
/// when `text` is no longer than the file: the write then needs no new room on the disk.
fn overwrite_within(path: &Path, text: &[u8]) -> io::Result<()> {
    let meta = std::fs::symlink_metadata(path)?;
    if !meta.is_file() || meta.len() < text.len() as u64 {
        return Err(io::ErrorKind::StorageFull.into());
    }
    let mut file = std::fs::OpenOptions::new().write(true).open(path)?;
    file.write_all(text)?;
    file.set_len(text.len() as u64)?;
    file.sync_data()
}

fn finite_or_none(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// An `f64` that is written as `null` when non-finite and read as NaN from `null`.
mod non_finite_as_null {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
        super::finite_or_none(*x).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}

/// [`non_finite_as_null`] applied to every value of a map.
mod non_finite_values_as_null {
    use std::collections::BTreeMap;

    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(map: &BTreeMap<String, f64>, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(map.iter().map(|(k, &v)| (k, super::finite_or_none(v))))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<BTreeMap<String, f64>, D::Error> {
        let map = BTreeMap::<String, Option<f64>>::deserialize(d)?;
        Ok(map
            .into_iter()
            .map(|(k, v)| (k, v.unwrap_or(f64::NAN)))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::scratch::scratch;
    use std::fs;

    fn sample() -> RunSummary {
        RunSummary {
            passes: None,
            case: "taylor_bar".into(),
            version: "0.1.0".into(),
            case_file: "cases/taylor-bar.toml".into(),
            overrides: vec!["run.end_time=4e-5".into()],
            resolved_case: serde_json::json!({ "name": "taylor_bar", "spacing": 1e-4 }),
            method: "tlsph".into(),
            backend: "cpu".into(),
            dimension: 3,
            particles: 12_345,
            steps: 9_876_543_210,
            dt_last: 1.234_567_890_123_456_7e-8,
            end_time: 8.0e-5,
            wall_seconds: 12.5,
            particle_steps_per_second: 1.0 / 3.0 * 1e9,
            halo_seconds: Some(0.25),
            status: "completed".into(),
            failure: None,
            energy_balance: BTreeMap::new(),
            final_invariants: BTreeMap::from([
                ("energy_total".to_string(), 0.1 + 0.2),
                ("momentum_x".to_string(), -1e-300),
            ]),
            checks: vec![CheckResult {
                label: "radius of the impact end".into(),
                column: "bar.extent_x".into(),
                statistic: "end".into(),
                value: 0.00695,
                expected: Some([0.00689, 0.007]),
                source: Some("paper Table 2".into()),
                within: Some(true),
            }],
        }
    }

    #[test]
    fn summary_round_trips_through_json() {
        let (dir, path) = scratch("summary.json");
        let mut summary = sample();
        write_summary(&path, &summary).unwrap();

        let text = fs::read_to_string(&path).unwrap();
        assert!(
            text.contains("\n  \"case\": \"taylor_bar\",\n"),
            "not pretty: {text}"
        );
        let back: RunSummary = serde_json::from_str(&text).unwrap();
        // f64 fields compare exactly: serde_json round-trips f64 bit for bit.
        assert_eq!(back, summary);

        summary.status = "failed".into();
        summary.failure = Some("particle 17: negative Jacobian".into());
        write_summary(&path, &summary).unwrap();
        let back: RunSummary = serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(back, summary);

        assert!(!dir.path().join("summary.json.tmp").exists());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_running_summary_reserves_the_room_its_failure_takes_in_place() {
        let (_dir, path) = scratch("summary.json");
        let mut summary = sample();
        summary.status = "running".into();
        write_summary(&path, &summary).unwrap();
        let reserved = fs::metadata(&path).unwrap().len();
        let back: RunSummary = serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(
            back, summary,
            "the blanks after the JSON are white space it allows"
        );

        // The failed summary, with a long reason, fits within the running one's bytes:
        // written in place (what a full disk leaves), it reads back whole.
        summary.status = "failed".into();
        summary.failure = Some("output frame_000017.vtu: No space left on device; ".repeat(20));
        let mut text = serde_json::to_vec_pretty(&summary).unwrap();
        text.push(b'\n');
        overwrite_within(&path, &text).unwrap();
        assert!(fs::metadata(&path).unwrap().len() < reserved);
        let back: RunSummary = serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(back, summary);

        // A text longer than the file is refused, the file left as it was.
        let long = vec![b' '; reserved as usize + 1];
        let before = fs::read(&path).unwrap();
        assert!(overwrite_within(&path, &long).is_err());
        assert_eq!(fs::read(&path).unwrap(), before);
    }

    #[test]
    fn summary_writes_non_finite_as_null_and_reads_nan() {
        let (_dir, path) = scratch("summary.json");
        let mut summary = sample();
        summary.status = "failed".into();
        summary.dt_last = f64::NAN;
        summary.particle_steps_per_second = f64::INFINITY;
        summary
            .final_invariants
            .insert("energy_total".into(), f64::NEG_INFINITY);
        summary.final_invariants.insert("mass".into(), f64::NAN);

        write_summary(&path, &summary).unwrap();
        let text = fs::read_to_string(&path).unwrap();
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert!(json["dt_last"].is_null());
        assert!(json["particle_steps_per_second"].is_null());
        assert!(json["final_invariants"]["energy_total"].is_null());
        assert!(json["final_invariants"]["mass"].is_null());
        assert_eq!(
            json["final_invariants"]["momentum_x"].as_f64(),
            Some(-1e-300)
        );
        assert_eq!(json["end_time"].as_f64(), Some(8.0e-5));

        let back: RunSummary = serde_json::from_str(&text).unwrap();
        assert!(back.dt_last.is_nan());
        assert!(back.particle_steps_per_second.is_nan());
        assert!(back.final_invariants["energy_total"].is_nan());
        assert!(back.final_invariants["mass"].is_nan());
        assert_eq!(back.final_invariants["momentum_x"], -1e-300);
        assert_eq!(back.end_time, 8.0e-5);
    }
}
