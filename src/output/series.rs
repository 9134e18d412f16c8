//! CSV time series written one row at a time.

use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::path::Path;

use super::{create_temporary, format_f64, invalid_input};

/// Why a column of a series file cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ColumnError {
    #[error("{file}: no column `{column}` (the columns are {columns})")]
    NoColumn {
        file: String,
        column: String,
        columns: String,
    },
    #[error("{0}")]
    Unreadable(String),
}

/// The longest series file read back [bytes]: 4 GiB, rows of a few hundred bytes at
/// every step of millions.
const SERIES_CAP: u64 = 4 << 30;

/// Column `column` of a series file against its `time` column, one (t, value) per row.
pub fn read_column(path: &Path, column: &str) -> Result<Vec<(f64, f64)>, ColumnError> {
    let file = path.display().to_string();
    let text = super::read_regular(path, SERIES_CAP)
        .map_err(|e| ColumnError::Unreadable(format!("{file}: {e}")))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let find = |name: &str| {
        header
            .iter()
            .position(|c| *c == name)
            .ok_or_else(|| ColumnError::NoColumn {
                file: file.clone(),
                column: name.to_string(),
                columns: header.join(", "),
            })
    };
    let (kt, kc) = (find("time")?, find(column)?);
    lines
        .enumerate()
        .map(|(row, line)| {
            let fields: Vec<&str> = line.split(',').collect();
            let value = |k: usize| {
                fields
                    .get(k)
                    .and_then(|f| f.trim().parse::<f64>().ok())
                    .ok_or_else(|| {
                        ColumnError::Unreadable(format!(
                            "{file}: row {}: no number in column {k}",
                            row + 2
                        ))
                    })
            };
            Ok((value(kt)?, value(kc)?))
        })
        .collect()
}

/// A CSV file with a header line and one row of numbers per call.
///
/// Every row is flushed as soon as it is written, so rows already reported
/// survive a crash or an interrupt; a row that cannot be written whole (a full
/// disk) is cut off again, so the file ends with the last whole row. Numbers
/// are written with enough digits to parse back to the same `f64` (non-finite
/// values as `NaN`, `inf`, `-inf`).
#[derive(Debug)]
pub struct SeriesWriter {
    /// Written one whole row per call (no buffer to flush).
    out: File,
    columns: usize,
    line: String,
    /// Bytes of whole lines written.
    len: u64,
}

impl SeriesWriter {
    /// Creates `path` with the header line: written to a fresh temporary
    /// sibling and renamed over `path` (which replaces a file or a symlink
    /// there, and never follows it); rows are then appended through the open
    /// file.
    ///
    /// Column names are written as given; they must be non-empty and must not
    /// contain commas, quotes or line breaks.
    pub fn create(path: &Path, columns: &[String]) -> io::Result<Self> {
        if columns.is_empty() {
            return Err(invalid_input(
                "a CSV series needs at least one column".into(),
            ));
        }
        if let Some(bad) = columns
            .iter()
            .find(|c| c.is_empty() || c.contains([',', '"', '\n', '\r']))
        {
            return Err(invalid_input(format!(
                "CSV column name {bad:?} is empty or contains a comma, quote or line break"
            )));
        }
        let header = format!("{}\n", columns.join(","));
        let (mut out, tmp) = create_temporary(path)?;
        let created = out
            .write_all(header.as_bytes())
            .and_then(|()| std::fs::rename(&tmp, path));
        if let Err(e) = created {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        Ok(Self {
            out,
            columns: columns.len(),
            line: String::new(),
            len: header.len() as u64,
        })
    }

    /// Continues the series at `path` after its first `len` bytes (the rows up to a
    /// checkpoint; later rows are dropped): the kept bytes, whose header must name
    /// `columns`, are copied into a fresh file renamed over `path`, as for
    /// [`Self::create`].
    pub fn resume(path: &Path, columns: &[String], len: u64) -> io::Result<Self> {
        use std::io::Read;
        let mut kept = Vec::new();
        super::open_regular(path)?
            .take(len)
            .read_to_end(&mut kept)?;
        let header = format!("{}\n", columns.join(","));
        if kept.len() as u64 != len || !kept.starts_with(header.as_bytes()) {
            return Err(invalid_input(format!(
                "`{}` does not hold the {len} bytes of series (header `{}`) the checkpoint \
                 counts",
                path.display(),
                header.trim_end()
            )));
        }
        let mut series = Self::create(path, columns)?;
        series.out.write_all(&kept[header.len()..])?;
        series.len = len;
        Ok(series)
    }

    /// Bytes written: the header and the whole rows.
    pub fn bytes(&self) -> u64 {
        self.len
    }

    /// Number of columns in each row.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// Writes one row and flushes it to the file.
    pub fn write_row(&mut self, values: &[f64]) -> io::Result<()> {
        if values.len() != self.columns {
            return Err(invalid_input(format!(
                "CSV row has {} values but the series has {} columns",
                values.len(),
                self.columns
            )));
        }
        self.line.clear();
        for (i, &value) in values.iter().enumerate() {
            if i > 0 {
                self.line.push(',');
            }
            self.line.push_str(&format_f64(value));
        }
        self.line.push('\n');
        if let Err(e) = self.out.write_all(self.line.as_bytes()) {
            // Cut the file back to its last whole row (best effort: the write error is
            // the one to report).
            let _ = self.out.set_len(self.len);
            let _ = self.out.seek(SeekFrom::Start(self.len));
            return Err(e);
        }
        self.len += self.line.len() as u64;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[cfg(unix)]
    use crate::output::scratch::Planted;
    use crate::output::scratch::scratch;
    use std::fs;

    fn names(columns: &[&str]) -> Vec<String> {
        columns.iter().map(|c| c.to_string()).collect()
    }

    fn parse_rows(text: &str) -> Vec<Vec<f64>> {
        text.lines()
            .skip(1)
            .map(|line| line.split(',').map(|v| v.parse().unwrap()).collect())
            .collect()
    }

    #[test]
    fn csv_writes_header_and_rows_bit_exact() {
        let (_dir, path) = scratch("energy.csv");
        let rows = [
            [0.0, 1.0, -0.0],
            [1e-9, 1.0 / 3.0, 6.022_140_76e23],
            [0.1 + 0.2, -1e300, f64::INFINITY],
        ];

        let mut series =
            SeriesWriter::create(&path, &names(&["time", "kinetic", "E [J]"])).unwrap();
        assert_eq!(series.columns(), 3);
        for row in &rows {
            series.write_row(row).unwrap();
        }
        drop(series);

        let text = fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().next(), Some("time,kinetic,E [J]"));
        assert!(text.ends_with('\n'));
        let read = parse_rows(&text);
        assert_eq!(read.len(), rows.len());
        for (got, want) in read.iter().zip(&rows) {
            let got: Vec<u64> = got.iter().map(|x| x.to_bits()).collect();
            let want: Vec<u64> = want.iter().map(|x| x.to_bits()).collect();
            assert_eq!(got, want);
        }
        assert_eq!(text.lines().nth(1), Some("0,1,-0"));
    }

    #[test]
    fn csv_rejects_wrong_row_length() {
        let (_dir, path) = scratch("s.csv");
        let mut series = SeriesWriter::create(&path, &names(&["a", "b"])).unwrap();

        for bad in [&[1.0][..], &[1.0, 2.0, 3.0], &[]] {
            let err = series.write_row(bad).unwrap_err();
            assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
        }
        series.write_row(&[1.0, 2.0]).unwrap();

        assert_eq!(fs::read_to_string(&path).unwrap(), "a,b\n1,2\n");
    }

    #[test]
    fn csv_rejects_bad_column_names() {
        let (_dir, path) = scratch("s.csv");

        for columns in [
            names(&["a,b"]),
            names(&["\"a\""]),
            names(&["a\nb"]),
            names(&["t", ""]),
            Vec::new(),
        ] {
            let err = SeriesWriter::create(&path, &columns).unwrap_err();
            assert_eq!(err.kind(), io::ErrorKind::InvalidInput, "{columns:?}");
        }
        assert!(!path.exists());
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_planted_as_the_series_is_replaced_not_followed() {
        let planted = Planted::new("series.csv");
        let mut series = SeriesWriter::create(&planted.path, &names(&["t"])).unwrap();
        series.write_row(&[1.0]).unwrap();
        planted.assert_replaced();
        assert_eq!(fs::read_to_string(&planted.path).unwrap(), "t\n1\n");
    }

    #[test]
    fn csv_rows_reach_disk_without_flush_or_drop() {
        let (_dir, path) = scratch("s.csv");
        let mut series = SeriesWriter::create(&path, &names(&["t", "x"])).unwrap();
        series.write_row(&[0.0, 1.5]).unwrap();
        series.write_row(&[0.5, -2.0]).unwrap();

        // Skipping the destructor models a process that dies right here.
        std::mem::forget(series);

        assert_eq!(fs::read_to_string(&path).unwrap(), "t,x\n0,1.5\n0.5,-2\n");
    }
}
