//! The GPU pass report of a profiled run (`--profile`, `meshless bench`): per pass, the
//! dispatches, device time and bytes moved over the profiled steps, the achieved
//! bandwidth and its fraction of the adapter's copy bandwidth. `gpu::profile` fills it;
//! the driver prints it and the summary and the benchmarks carry it.

/// One pass of a [`PassReport`]: totals over the profiled steps.
#[derive(Clone, Debug, PartialEq)]
pub struct PassRow {
    /// `label (entry point)`.
    pub pass: String,
    /// Dispatches recorded.
    pub dispatches: u64,
    /// Dispatches that ran: all of them, except the indirect dispatches of a neighbour
    /// build that was not due.
    pub runs: u64,
    /// Device time of its dispatches, where the adapter has timestamp queries [s].
    pub seconds: Option<f64>,
    /// Bytes moved by its bytes model (`gpu::bytes`), where its entry point has one.
    pub bytes: Option<u64>,
}

/// The GPU pass report: per pass, time, bytes moved, achieved bandwidth and its fraction
/// of the adapter's copy bandwidth, over `steps` steps timed together (`gpu::profile`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PassReport {
    pub adapter: String,
    pub particles: usize,
    pub steps: u32,
    /// Wall time of the profiled steps, submission to completion [s].
    pub wall_seconds: f64,
    /// The adapter's copy bandwidth (bytes read plus written per second).
    pub copy_bandwidth: f64,
    pub rows: Vec<PassRow>,
    /// Why a column is empty (an adapter without timestamp queries).
    pub note: Option<String>,
}

impl PassReport {
    /// Bytes of every pass with a model, per step.
    pub fn bytes_per_step(&self) -> f64 {
        let total: u64 = self.rows.iter().filter_map(|r| r.bytes).sum();
        total as f64 / f64::from(self.steps.max(1))
    }

    /// Device time of every pass, per step [s] (None without timestamps).
    pub fn seconds_per_step(&self) -> Option<f64> {
        let total: Option<f64> = self.rows.iter().map(|r| r.seconds).sum();
        total.map(|t| t / f64::from(self.steps.max(1)))
    }
}

impl std::fmt::Display for PassReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let steps = f64::from(self.steps.max(1));
        writeln!(
            f,
            "Passes of {} steps on {} (wall {:.3} ms per step; copy bandwidth {:.2} GB/s):",
            self.steps,
            self.adapter,
            1e3 * self.wall_seconds / steps,
            self.copy_bandwidth * 1e-9
        )?;
        writeln!(
            f,
            "| pass | dispatches per step | µs per step | bytes per step | GB/s | of copy bandwidth |"
        )?;
        writeln!(f, "|---|---|---|---|---|---|")?;
        let dash = || "–".to_string();
        for r in &self.rows {
            let rate = r.seconds.zip(r.bytes).map(|(s, b)| b as f64 / s);
            writeln!(
                f,
                "| {} | {} | {} | {} | {} | {} |",
                r.pass,
                format!("{:.2}", r.runs as f64 / steps)
                    .trim_end_matches('0')
                    .trim_end_matches('.'),
                r.seconds
                    .map_or_else(dash, |s| format!("{:.1}", 1e6 * s / steps)),
                r.bytes
                    .map_or_else(dash, |b| format!("{:.0}", b as f64 / steps)),
                rate.map_or_else(dash, |g| format!("{:.2}", g * 1e-9)),
                rate.map_or_else(dash, |g| format!("{:.3}", g / self.copy_bandwidth)),
            )?;
        }
        let bytes = self.bytes_per_step();
        // The bandwidth of the passes with a model, over their own time.
        let modelled: f64 = self
            .rows
            .iter()
            .filter(|r| r.bytes.is_some())
            .filter_map(|r| r.seconds)
            .sum::<f64>()
            / steps;
        match self.seconds_per_step() {
            Some(t) => writeln!(
                f,
                "| all passes | | {:.1} | {bytes:.0} | {:.2} | {:.3} |",
                1e6 * t,
                bytes / modelled * 1e-9,
                bytes / modelled / self.copy_bandwidth
            )?,
            None => writeln!(f, "| all passes | | – | {bytes:.0} | – | – |")?,
        }
        write!(
            f,
            "The model's bytes at the copy bandwidth bound the throughput to {:.3e} \
             particle-steps/s ({:.0} bytes per particle-step)",
            self.copy_bandwidth / bytes * self.particles as f64,
            bytes / self.particles as f64
        )?;
        if let Some(note) = &self.note {
            write!(f, "\nnote: {note}")?;
        }
        Ok(())
    }
}
