//! The series callback (`series.csv`: a row of the observers at each sample) and the
//! files around a run: the earlier run's files cleared, the summary's checks.

use super::batch::{Batch, Callback, Needs};
use super::progress::ITERATIONS;
use super::{RunError, checkpoint, output_error};
use crate::core::check::toml_name;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::{Clock, Observers};
use crate::engine::BlowUp;
use crate::output::series::read_column;
use crate::output::{CheckResult, SeriesWriter};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// `series.csv`: a row of the observers every `output.series_interval` (every batch
/// without one) and at the end.
pub(super) struct Series {
    observers: Observers,
    writer: SeriesWriter,
    path: PathBuf,
    every: f64,
    /// The time of the next row.
    next: f64,
}

impl Series {
    /// A new `series.csv` in `dir`, or, resumed, the one there cut to `resumed`'s length
    /// and its next sample time.
    pub(super) fn new(
        case: &Scene,
        dir: &Path,
        observers: Observers,
        resumed: Option<&checkpoint::Progress>,
    ) -> Result<Self, RunError> {
        let path = dir.join("series.csv");
        let columns = observers.column_names();
        let (writer, next) = match resumed {
            Some(p) => (
                SeriesWriter::resume(&path, columns, p.series_bytes),
                p.next_sample,
            ),
            None => (SeriesWriter::create(&path, columns), 0.0),
        };
        Ok(Self {
            writer: writer.map_err(output_error(&path))?,
            observers,
            path,
            every: case.output.series_interval.unwrap_or(0.0),
            next,
        })
    }

    pub(super) fn path(&self) -> &Path {
        &self.path
    }

    /// Whether a row is due after a step of `clock.dt` that ends at `clock.t` (the last
    /// batch always writes one).
    fn due(&self, clock: &Clock, last: bool) -> bool {
        clock.t + 0.5 * clock.dt >= self.next || last
    }
}

impl<D: Dim> Callback<D> for Series {
    fn next_time(&self) -> f64 {
        self.next
    }

    fn needs(&self, clock: &Clock, last: bool) -> Needs {
        let sample = self.due(clock, last);
        Needs {
            state: sample,
            row: sample,
            reactions: sample && self.observers.need_reactions(),
            ..Needs::default()
        }
    }

    fn after_batch(&mut self, batch: &mut Batch<D>) -> Result<Option<BlowUp>, RunError> {
        let clock = &batch.clock;
        if !self.due(clock, batch.last) {
            return Ok(None);
        }
        let (Some((snap, reactions)), Some(fields)) = (batch.state(), batch.fields()) else {
            return Ok(None);
        };
        let row = self
            .observers
            .sample(snap, &batch.inv, clock, fields, reactions);
        self.writer
            .write_row(&row)
            .map_err(output_error(&self.path))?;
        self.next = clock.t + self.every;
        Ok(None)
    }

    fn save(&self, at: &mut checkpoint::Progress) {
        at.next_sample = self.next;
        at.series_bytes = self.writer.bytes();
    }
}

/// The largest PVD index read back [bytes]: a few hundred bytes a frame.
const INDEX_CAP: u64 = 256 << 20;

/// Removes what an earlier run of the case `name` wrote into `dir`, and nothing else:
/// the summary, the series, the checkpoint with its pieces and the iteration log (one
/// run's files a folder), and the case's PVD index (`<name>.pvd`) with the frames it
/// lists under the case's name (`<name>_*.vtu`, or `<name>_*.pvtu` with the folder of
/// its pieces), so that no stale file of it is left beside the new run's. Another case's
/// index and frames in the folder stay. Only a regular file is read as the index: a FIFO
/// there is never waited on.
pub(super) fn clear_previous_run(dir: &Path, name: &str) -> Result<(), RunError> {
    let remove = |path: &Path| match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(output_error(path)(e)),
        _ => Ok(()),
    };
    for file in ["summary.json", "series.csv", checkpoint::FILE, ITERATIONS] {
        remove(&dir.join(file))?;
    }
    let pieces = dir.join(checkpoint::PIECES_DIR);
    match std::fs::remove_dir_all(&pieces) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(output_error(&pieces)(e))?,
        _ => {}
    }
    let index = dir.join(format!("{name}.pvd"));
    let text = match std::fs::symlink_metadata(&index) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(output_error(&index)(e)),
        // A link, FIFO or device under the index's name: removed (the entry, not what it
        // points to), never read.
        Ok(meta) if !meta.is_file() => return remove(&index),
        Ok(_) => crate::output::read_regular(&index, INDEX_CAP).map_err(output_error(&index))?,
    };
    let ours = |frame: &Path| {
        // A name in this folder (no path) of one of the case's frames.
        frame.components().count() == 1
            && frame.extension().is_some_and(|e| e == "vtu" || e == "pvtu")
            && frame
                .to_str()
                .is_some_and(|f| f.strip_prefix(name).is_some_and(|r| r.starts_with('_')))
    };
    for frame in text
        .split("file=\"")
        .skip(1)
        .filter_map(|t| t.split('"').next())
        .map(Path::new)
        .filter(|f| ours(f))
    {
        remove(&dir.join(frame))?;
        // The folder of a frame's pieces, when it is one (not a link).
        let pieces = dir.join(frame.with_extension(""));
        if frame.extension().is_some_and(|e| e == "pvtu")
            && std::fs::symlink_metadata(&pieces).is_ok_and(|m| m.is_dir())
        {
            std::fs::remove_dir_all(&pieces).map_err(output_error(&pieces))?;
        }
    }
    remove(&index)
}

/// The case's checks on the series written so far; a check whose column cannot be read
/// has the value NaN.
pub(super) fn evaluate_checks(case: &Scene, series: &Path) -> Vec<CheckResult> {
    case.output
        .checks
        .iter()
        .map(|c| {
            let values: Vec<f64> = read_column(series, &c.column)
                .map(|rows| rows.into_iter().map(|(_, v)| v).collect())
                .unwrap_or_default();
            let value = c.statistic.of(&values);
            CheckResult {
                label: c.label.clone(),
                column: c.column.clone(),
                statistic: toml_name(&c.statistic),
                value,
                expected: c.expected,
                source: c.source.clone(),
                within: c.expected.map(|[lo, hi]| value >= lo && value <= hi),
            }
        })
        .collect()
}
