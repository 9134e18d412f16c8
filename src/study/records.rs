//! Per-run results of a study: one CSV row per run, rewritten atomically after each run.

use std::io::Write;
use std::path::Path;

/// How a run ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// Reached the end time.
    Ok,
    /// Stopped by the blow-up checks: time, step, particle and the failed quantity.
    Failed {
        time: f64,
        step: u64,
        particle: usize,
        quantity: String,
    },
    /// Did not run: invalid case, no adapter, output error or a panic.
    Error,
}

impl Status {
    pub fn name(&self) -> &'static str {
        match self {
            Self::Ok => "ok",
            Self::Failed { .. } => "failed",
            Self::Error => "error",
        }
    }
}

/// The result of one run.
#[derive(Clone, Debug, PartialEq)]
pub struct RunRecord {
    pub id: String,
    pub suite: String,
    pub case: String,
    pub variant: String,
    /// `cpu` or `gpu: <adapter>`.
    pub backend: String,
    pub sweep_key: String,
    pub sweep_value: String,
    pub spacing: f64,
    pub particles: usize,
    pub steps: u64,
    pub dt_last: f64,
    /// Simulated time reached.
    pub time: f64,
    /// Engine set-up plus time loop [s].
    pub wall_seconds: f64,
    /// Relative L2 error of the velocity at the end (NaN when not measured).
    pub error_velocity: f64,
    /// Relative L2 error of the first Piola–Kirchhoff stress at the end.
    pub error_stress: f64,
    /// max |H(t) − H(0)|/|H(0)| over the run.
    pub drift_angular_momentum: f64,
    /// max |E(t) − W_ext(t) − E(0)|/max(E(0), |W_ext|) over the run.
    pub drift_energy: f64,
    pub status: Status,
    /// Why a run failed or did not run (empty when ok).
    pub reason: String,
    /// CPU model and thread count of the machine that measured it.
    pub machine: String,
    /// The build that measured it ([`this_build`]: its commit and solver hash); empty for a
    /// record written before builds were recorded.
    pub build: String,
    /// The UTC date it was measured (YYYY-MM-DD); empty as `build`.
    pub date: String,
}

pub const HEADER: [&str; 27] = [
    "id",
    "suite",
    "case",
    "variant",
    "backend",
    "sweep_key",
    "sweep_value",
    "spacing",
    "particles",
    "steps",
    "dt_last",
    "time",
    "wall_seconds",
    "error_velocity",
    "error_stress",
    "drift_angular_momentum",
    "drift_energy",
    "status",
    "fail_time",
    "fail_step",
    "fail_particle",
    "fail_quantity",
    "reason",
    "machine",
    "version",
    "build",
    "date",
];

/// The columns of the records written before the build and date were.
const OLD_COLUMNS: usize = 25;

fn num(x: f64) -> String {
    if x.is_nan() {
        String::new()
    } else {
        format!("{x:e}")
    }
}

fn parse_num(s: &str) -> f64 {
    if s.is_empty() {
        f64::NAN
    } else {
        s.parse().unwrap_or(f64::NAN)
    }
}

/// A CSV field, quoted when it holds a comma, quote or line break.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

impl RunRecord {
    /// The record of a run that has measured nothing yet (an `error` until it says
    /// otherwise): its id, suite, variant, backend, sweep key and value, and machine.
    pub fn unmeasured(
        id: String,
        suite: String,
        variant: String,
        backend: String,
        (sweep_key, sweep_value): (String, String),
        machine: String,
    ) -> Self {
        Self {
            id,
            suite,
            case: String::new(),
            variant,
            backend,
            sweep_key,
            sweep_value,
            spacing: f64::NAN,
            particles: 0,
            steps: 0,
            dt_last: f64::NAN,
            time: f64::NAN,
            wall_seconds: f64::NAN,
            error_velocity: f64::NAN,
            error_stress: f64::NAN,
            drift_angular_momentum: f64::NAN,
            drift_energy: f64::NAN,
            status: Status::Error,
            reason: String::new(),
            machine,
            build: this_build(),
            date: today(),
        }
    }

    /// The commit of the build that measured it (the first word of `build`).
    pub fn build_commit(&self) -> &str {
        self.build.split_whitespace().next().unwrap_or("")
    }

    /// The solver hash of the build that measured it (the second word of `build`).
    pub fn solver(&self) -> &str {
        self.build.split_whitespace().nth(1).unwrap_or("")
    }

    fn to_fields(&self) -> Vec<String> {
        let (ft, fs, fp, fq) = match &self.status {
            Status::Failed {
                time,
                step,
                particle,
                quantity,
            } => (
                num(*time),
                step.to_string(),
                particle.to_string(),
                quantity.clone(),
            ),
            _ => Default::default(),
        };
        vec![
            self.id.clone(),
            self.suite.clone(),
            self.case.clone(),
            self.variant.clone(),
            self.backend.clone(),
            self.sweep_key.clone(),
            self.sweep_value.clone(),
            num(self.spacing),
            self.particles.to_string(),
            self.steps.to_string(),
            num(self.dt_last),
            num(self.time),
            num(self.wall_seconds),
            num(self.error_velocity),
            num(self.error_stress),
            num(self.drift_angular_momentum),
            num(self.drift_energy),
            self.status.name().to_string(),
            ft,
            fs,
            fp,
            fq,
            self.reason.clone(),
            self.machine.clone(),
            env!("CARGO_PKG_VERSION").to_string(),
            self.build.clone(),
            self.date.clone(),
        ]
    }

    fn from_fields(f: &[String]) -> Option<Self> {
        if f.len() != HEADER.len() && f.len() != OLD_COLUMNS {
            return None;
        }
        let column = |k: usize| f.get(k).cloned().unwrap_or_default();
        let status = match f[17].as_str() {
            "ok" => Status::Ok,
            "failed" => Status::Failed {
                time: parse_num(&f[18]),
                step: f[19].parse().ok()?,
                particle: f[20].parse().ok()?,
                quantity: f[21].clone(),
            },
            _ => Status::Error,
        };
        Some(Self {
            id: f[0].clone(),
            suite: f[1].clone(),
            case: f[2].clone(),
            variant: f[3].clone(),
            backend: f[4].clone(),
            sweep_key: f[5].clone(),
            sweep_value: f[6].clone(),
            spacing: parse_num(&f[7]),
            particles: f[8].parse().unwrap_or(0),
            steps: f[9].parse().unwrap_or(0),
            dt_last: parse_num(&f[10]),
            time: parse_num(&f[11]),
            wall_seconds: parse_num(&f[12]),
            error_velocity: parse_num(&f[13]),
            error_stress: parse_num(&f[14]),
            drift_angular_momentum: parse_num(&f[15]),
            drift_energy: parse_num(&f[16]),
            status,
            reason: f[22].clone(),
            machine: f[23].clone(),
            build: column(25),
            date: column(26),
        })
    }

    /// `cpu` or `gpu`, without the adapter name (`gpu: <adapter>`) or the static solve's
    /// linear solver (`cpu; <solver>`).
    pub fn backend_kind(&self) -> &str {
        self.backend.split([':', ';']).next().unwrap_or("").trim()
    }

    /// The line of a plot or a row of the stability map: variant, with the backend when
    /// it is not the CPU.
    pub fn line(&self) -> String {
        match self.backend_kind() {
            "cpu" => self.variant.clone(),
            b => format!("{} ({b})", self.variant),
        }
    }
}

/// Splits CSV text into records of fields (RFC 4180 quoting).
fn parse_csv(text: &str) -> Vec<Vec<String>> {
    let mut rows = Vec::new();
    let mut row = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            (true, '"') => quoted = false,
            (true, c) => cur.push(c),
            (false, '"') => quoted = true,
            (false, ',') => row.push(std::mem::take(&mut cur)),
            (false, '\r') => {}
            (false, '\n') => {
                row.push(std::mem::take(&mut cur));
                rows.push(std::mem::take(&mut row));
            }
            (false, c) => cur.push(c),
        }
    }
    if !cur.is_empty() || !row.is_empty() {
        row.push(cur);
        rows.push(row);
    }
    rows
}

/// Reads the records of a results file (none when it does not exist); rows that do not
/// parse are dropped, so such runs are done again.
pub fn read(path: &Path) -> std::io::Result<Vec<RunRecord>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    Ok(parse_csv(&text)
        .iter()
        .skip(1)
        .filter_map(|f| RunRecord::from_fields(f))
        .collect())
}

/// Writes all records to `path` through a temporary file and a rename.
pub fn write(path: &Path, records: &[RunRecord]) -> std::io::Result<()> {
    crate::output::write_atomically(path, |w| {
        writeln!(w, "{}", HEADER.join(","))?;
        for r in records {
            let fields: Vec<String> = r.to_fields().iter().map(|s| field(s)).collect();
            writeln!(w, "{}", fields.join(","))?;
        }
        Ok(())
    })
}

/// This build: its commit and the hash of its solver sources (`build.rs`), as
/// `"<commit> <solver>"`.
pub fn this_build() -> String {
    format!("{} {}", env!("MESHLESS_COMMIT"), env!("MESHLESS_SOLVER"))
}

/// The solver hash of this build.
pub fn this_solver() -> &'static str {
    env!("MESHLESS_SOLVER")
}

/// Today's UTC date, YYYY-MM-DD (days since 1970 to the civil calendar, Hinnant's
/// algorithm).
pub fn today() -> String {
    let seconds = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    civil_date((seconds / 86_400) as i64)
}

/// The proleptic Gregorian date of day `days` after 1970-01-01.
fn civil_date(days: i64) -> String {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

/// CPU model and thread count of this machine, for the record.
pub fn machine() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.split_whitespace().collect::<Vec<_>>().join(" "))
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    format!("{model}, {} threads", rayon::current_num_threads())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::scratch::scratch;

    #[test]
    fn records_round_trip_with_quoted_reasons() {
        let (_dir, path) = scratch("results.csv");
        let rec = RunRecord {
            id: "00ff".into(),
            suite: "s".into(),
            case: "c".into(),
            variant: "v".into(),
            backend: "gpu: NVIDIA, \"H100\"".into(),
            sweep_key: "spacing".into(),
            sweep_value: "0.05".into(),
            spacing: 0.05,
            particles: 441,
            steps: 12,
            dt_last: 1e-6,
            time: 0.1,
            wall_seconds: 0.5,
            error_velocity: 0.01,
            error_stress: f64::NAN,
            drift_angular_momentum: 1e-7,
            drift_energy: 2e-3,
            status: Status::Failed {
                time: 0.1,
                step: 12,
                particle: 7,
                quantity: "det F".into(),
            },
            reason: "det F = -1e0 at particle 7,\nline two".into(),
            machine: "x".into(),
            build: "0123456789ab 00ff00ff00ff00ff".into(),
            date: "2026-11-29".into(),
        };
        write(&path, &[rec.clone(), rec.clone()]).unwrap();
        let back = read(&path).unwrap();
        assert_eq!(back.len(), 2);
        assert!(back[0].error_stress.is_nan());
        let mut a = back[0].clone();
        a.error_stress = 0.0;
        let mut b = rec;
        b.error_stress = 0.0;
        assert_eq!(a, b);
    }

    /// The record of a run of variant `v` on the CPU at spacing 0.05, before it measures.
    fn unmeasured() -> RunRecord {
        RunRecord::unmeasured(
            "0".into(),
            "s".into(),
            "v".into(),
            "cpu".into(),
            ("spacing".into(), "0.05".into()),
            String::new(),
        )
    }

    #[test]
    fn records_of_before_the_build_column_still_read() {
        // A row of the 25 columns written before `build` and `date`: read, with both
        // empty, so a study resumes from it (and `--stale` counts it as another solver's).
        let (_dir, path) = scratch("results.csv");
        let old = "id,suite,case,variant,backend,sweep_key,sweep_value,spacing,particles,steps,\
                   dt_last,time,wall_seconds,error_velocity,error_stress,\
                   drift_angular_momentum,drift_energy,status,fail_time,fail_step,\
                   fail_particle,fail_quantity,reason,machine,version\n\
                   a1,s,c,v,cpu,spacing,0.1,1e-1,10,5,1e-3,1e-2,2e0,1e-2,,,,ok,,,,,,m,0.1.0\n";
        std::fs::write(&path, old).unwrap();
        let back = read(&path).unwrap();
        assert_eq!(back.len(), 1);
        assert_eq!((back[0].build.as_str(), back[0].date.as_str()), ("", ""));
        assert_eq!(back[0].solver(), "");
        let fresh = unmeasured();
        assert_eq!(fresh.solver(), this_solver());
    }

    #[test]
    fn civil_dates_of_known_days() {
        // 1970-01-01 is day 0; 2000-03-01 follows a leap day (day 11,017); 2026-11-29 is
        // day 20,786.
        assert_eq!(civil_date(0), "1970-01-01");
        assert_eq!(civil_date(11_016), "2000-02-29");
        assert_eq!(civil_date(11_017), "2000-03-01");
        assert_eq!(civil_date(20_786), "2026-11-29");
        assert_eq!(civil_date(-1), "1969-12-31");
    }

    #[test]
    fn a_line_names_the_backend_kind_only_off_the_cpu() {
        let mut rec = unmeasured();
        for (backend, line) in [
            ("cpu", "v"),
            (
                "cpu; sparse LU of 96 unknowns; stiffness by finite differences",
                "v",
            ),
            (
                "gpu: llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)",
                "v (gpu)",
            ),
        ] {
            rec.backend = backend.into();
            assert_eq!(rec.line(), line, "backend {backend}");
        }
    }
}
