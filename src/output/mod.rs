//! Result files: VTK particle frames with a ParaView time index, CSV time
//! series and a JSON run summary.
//!
//! Files that are rewritten whole (frames, the index, the summary) are written
//! to a temporary sibling and renamed into place, so a process that dies
//! mid-write never leaves a truncated file under the final name.

pub mod series;
pub mod summary;
pub mod vtu;

pub use series::SeriesWriter;
pub use summary::{RunSummary, write_summary};
pub use vtu::{Field, FieldData, PvdIndex, write_vtu};

use std::ffi::OsString;
use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `path` by running `write` on a buffered temporary sibling
/// (`<name>.tmp`) and renaming it over `path` once everything is flushed.
///
/// On any error the temporary file is removed and `path` is left untouched.
fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = tmp_path(path)?;
    let result = File::create(&tmp).and_then(|file| {
        let mut writer = BufWriter::new(file);
        write(&mut writer)?;
        writer.flush()?;
        fs::rename(&tmp, path)
    });
    if result.is_err() {
        // Best effort: the original error is the one worth reporting.
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// `dir/name` -> `dir/name.tmp`.
fn tmp_path(path: &Path) -> io::Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("`{}` does not name a file", path.display()),
        )
    })?;
    let mut tmp_name = OsString::from(name);
    tmp_name.push(".tmp");
    Ok(path.with_file_name(tmp_name))
}

/// Formats `x` so that it parses back to the same bits, in plain notation for
/// moderate magnitudes and in scientific notation otherwise
/// (`0.25`, `1e-9`, `6.02214076e23`, `NaN`, `inf`).
fn format_f64(x: f64) -> String {
    let magnitude = x.abs();
    if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&magnitude) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

fn invalid_input(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_file_and_leaves_no_tmp() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        fs::write(&path, "old").unwrap();

        write_atomically(&path, |w| w.write_all(b"new contents")).unwrap();

        assert_eq!(fs::read_to_string(&path).unwrap(), "new contents");
        assert!(!dir.path().join("out.txt.tmp").exists());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn atomic_write_failure_keeps_old_file_and_removes_tmp() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        fs::write(&path, "old").unwrap();

        let err = write_atomically(&path, |w| {
            w.write_all(b"half a fra")?;
            Err(io::Error::other("simulated failure"))
        })
        .unwrap_err();

        assert_eq!(err.to_string(), "simulated failure");
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");
        assert!(!dir.path().join("out.txt.tmp").exists());
    }

    #[test]
    fn tmp_path_appends_suffix_to_file_name() {
        let tmp = tmp_path(Path::new("/a/b/frame_0001.vtu")).unwrap();
        assert_eq!(tmp, Path::new("/a/b/frame_0001.vtu.tmp"));
        assert!(tmp_path(Path::new("/")).is_err());
    }

    #[test]
    fn format_f64_round_trips_bit_exact() {
        let values = [
            0.0,
            -0.0,
            1.0,
            -0.25,
            0.1,
            1.0 / 3.0,
            1e-4,
            9.999e-5,
            1e15,
            123_456_789.123_456_78,
            6.022_140_76e23,
            -1.6e-19,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for x in values {
            let text = format_f64(x);
            let back: f64 = text.parse().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{x:?} -> {text}");
            assert!(text.len() <= 24, "{x:?} -> {text} is not compact");
        }
        assert!(format_f64(f64::NAN).parse::<f64>().unwrap().is_nan());
        assert_eq!(format_f64(0.5), "0.5");
        assert_eq!(format_f64(1e-9), "1e-9");
    }
}
