//! CSV time series written one row at a time.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use super::{format_f64, invalid_input};

/// A CSV file with a header line and one row of numbers per call.
///
/// Every row is flushed as soon as it is written, so rows already reported
/// survive a crash or an interrupt. Numbers are written with enough digits to
/// parse back to the same `f64` (non-finite values as `NaN`, `inf`, `-inf`).
#[derive(Debug)]
pub struct SeriesWriter {
    out: BufWriter<File>,
    columns: usize,
    line: String,
}

impl SeriesWriter {
    /// Creates (or truncates) `path` and writes the header line.
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
        let mut out = BufWriter::new(File::create(path)?);
        writeln!(out, "{}", columns.join(","))?;
        out.flush()?;
        Ok(Self {
            out,
            columns: columns.len(),
            line: String::new(),
        })
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
        self.out.write_all(self.line.as_bytes())?;
        self.out.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("energy.csv");
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
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");
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
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");

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

    #[test]
    fn csv_rows_reach_disk_without_flush_or_drop() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");
        let mut series = SeriesWriter::create(&path, &names(&["t", "x"])).unwrap();
        series.write_row(&[0.0, 1.5]).unwrap();
        series.write_row(&[0.5, -2.0]).unwrap();

        // Skipping the destructor models a process that dies right here.
        std::mem::forget(series);

        assert_eq!(fs::read_to_string(&path).unwrap(), "t,x\n0,1.5\n0.5,-2\n");
    }
}
