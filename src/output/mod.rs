//! Result files: VTK particle frames with a ParaView time index, CSV time
//! series and a JSON run summary.
//!
//! Files that are rewritten whole (frames, the index, the summary) are written
//! to a fresh temporary sibling and renamed into place, so a process that dies
//! mid-write never leaves a truncated file under the final name. No output
//! follows a link: a temporary file is created with a name of its own that must
//! not exist yet (`O_CREAT | O_EXCL`, which refuses a planted symlink too), and
//! the rename replaces whatever entry the final name has (a symlink planted
//! there is replaced, its target untouched). The CSV series is created the same
//! way and then appended to through its open handle.

#[cfg(test)]
pub(crate) mod scratch;
pub mod series;
pub mod summary;
pub mod vtu;

pub use series::SeriesWriter;
pub use summary::{CheckResult, RunSummary, write_summary};
pub use vtu::{Field, FieldData, Mesh, PieceArrays, PvdIndex, write_pvtu, write_vtu};

use std::ffi::OsString;
use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `path` by running `write` on a buffered fresh temporary sibling
/// ([`create_temporary`]) and renaming it over `path` once everything is flushed.
///
/// On any error the temporary file is removed and `path` is left untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let (file, tmp) = create_temporary(path)?;
    let result = (|| {
        let mut writer = BufWriter::new(file);
        write(&mut writer)?;
        writer.flush()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        // Best effort: the original error is the one worth reporting.
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Temporary names made by this process so far (with the process id, unique across
/// the runs and threads writing into one folder).
static TEMPORARIES: AtomicU64 = AtomicU64::new(0);

/// Creates a new, empty temporary sibling of `path` (`.<name>.<pid>-<k>.tmp`) that did
/// not exist before: created with `create_new`, so neither a file nor a symlink that is
/// already there under that name is opened; a name taken is skipped for the next one.
fn create_temporary(path: &Path) -> io::Result<(File, PathBuf)> {
    create_temporary_with(path, "")
}

/// [`create_temporary`] with `tail` appended to the name (`.png` for a writer that reads
/// the format from the extension).
pub(crate) fn create_temporary_with(path: &Path, tail: &str) -> io::Result<(File, PathBuf)> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("`{}` does not name a file", path.display()),
        )
    })?;
    let mut last = None;
    for _ in 0..64 {
        let mut tmp_name = OsString::from(".");
        tmp_name.push(name);
        let k = TEMPORARIES.fetch_add(1, Ordering::Relaxed);
        tmp_name.push(format!(".{}-{k}.tmp{tail}", std::process::id()));
        let tmp = path.with_file_name(tmp_name);
        match fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
        {
            Ok(file) => return Ok((file, tmp)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| io::Error::other("no temporary name left")))
}

/// Opens `path` for reading if it is a regular file: never a FIFO or a device, whose
/// opening or reading could block the run, nor a link (the entry itself is checked, so
/// no output read follows one).
pub fn open_regular(path: &Path) -> io::Result<File> {
    let meta = fs::symlink_metadata(path)?;
    if !meta.is_file() {
        return Err(invalid_input(format!(
            "`{}` is not a regular file (a link, FIFO, device or folder); remove it",
            path.display()
        )));
    }
    File::open(path)
}

/// The text of the regular file `path` ([`open_regular`]), of at most `cap` bytes.
pub fn read_regular(path: &Path, cap: u64) -> io::Result<String> {
    use std::io::Read;
    let mut text = String::new();
    open_regular(path)?
        .take(cap + 1)
        .read_to_string(&mut text)?;
    if text.len() as u64 > cap {
        return Err(invalid_input(format!(
            "`{}` is longer than {cap} bytes, more than this run writes there",
            path.display()
        )));
    }
    Ok(text)
}

/// An exclusive lock on the output folder `dir`, held until the returned handle drops
/// (or the process dies: the operating system releases it, so `--resume` after a kill
/// finds the folder free). Err(WouldBlock) when another process holds it.
#[cfg(unix)]
pub fn lock_folder(dir: &Path) -> io::Result<File> {
    let folder = File::open(dir)?;
    match folder.try_lock() {
        Ok(()) => Ok(folder),
        Err(fs::TryLockError::WouldBlock) => Err(io::ErrorKind::WouldBlock.into()),
        Err(fs::TryLockError::Error(e)) => Err(e),
    }
}

/// Elsewhere no lock is taken: a folder cannot be opened as a file there.
#[cfg(not(unix))]
pub fn lock_folder(dir: &Path) -> io::Result<()> {
    fs::metadata(dir).map(|_| ())
}

/// The bytes free to an unprivileged writer on the file system of `dir`; None where the
/// system does not say.
#[cfg(unix)]
pub fn free_bytes(dir: &Path) -> Option<u64> {
    let stat = rustix::fs::statvfs(dir).ok()?;
    Some(stat.f_bavail.saturating_mul(stat.f_frsize))
}

/// Elsewhere the free space is not looked up.
#[cfg(not(unix))]
pub fn free_bytes(_dir: &Path) -> Option<u64> {
    None
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
    #[cfg(unix)]
    use scratch::Planted;
    use scratch::scratch;

    #[test]
    fn atomic_write_replaces_file_and_leaves_no_tmp() {
        let (dir, path) = scratch("out.txt");
        fs::write(&path, "old").unwrap();

        write_atomically(&path, |w| w.write_all(b"new contents")).unwrap();

        assert_eq!(fs::read_to_string(&path).unwrap(), "new contents");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn atomic_write_failure_keeps_old_file_and_removes_tmp() {
        let (dir, path) = scratch("out.txt");
        fs::write(&path, "old").unwrap();

        let err = write_atomically(&path, |w| {
            w.write_all(b"half a fra")?;
            Err(io::Error::other("simulated failure"))
        })
        .unwrap_err();

        assert_eq!(err.to_string(), "simulated failure");
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn temporaries_are_fresh_siblings_and_planted_links_are_not_followed() {
        // The final name and the next temporary name are both symlinks to a file outside
        // the folder: the write replaces the link at the final name, skips the taken
        // temporary name, and the target keeps its contents.
        let planted = Planted::new("summary.json");
        let next = TEMPORARIES.load(Ordering::Relaxed);
        for k in next..next + 8 {
            let taken = planted
                .dir
                .path()
                .join(format!(".summary.json.{}-{k}.tmp", std::process::id()));
            std::os::unix::fs::symlink(&planted.target, taken).unwrap();
        }
        write_atomically(&planted.path, |w| w.write_all(b"new")).unwrap();
        planted.assert_replaced();
        assert_eq!(fs::read_to_string(&planted.path).unwrap(), "new");
        assert!(create_temporary(Path::new("/")).is_err());
    }

    #[test]
    fn concurrent_writers_into_one_folder_do_not_collide() {
        // Four threads rewrite the same two names 50 times each: every write succeeds,
        // each file holds one writer's whole text, and no temporary is left.
        let dir = tempfile::tempdir().unwrap();
        std::thread::scope(|scope| {
            for w in 0..4 {
                let dir = dir.path();
                scope.spawn(move || {
                    for k in 0..50 {
                        let name = ["summary.json", "series.csv"][k % 2];
                        let text = format!("writer {w} write {k} ").repeat(100);
                        write_atomically(&dir.join(name), |f| f.write_all(text.as_bytes()))
                            .unwrap();
                    }
                });
            }
        });
        let mut names: Vec<String> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, ["series.csv", "summary.json"]);
        for name in names {
            let text = fs::read_to_string(dir.path().join(name)).unwrap();
            let unit = &text[..text.len() / 100];
            assert!(unit.starts_with("writer "), "{unit}");
            assert_eq!(text, unit.repeat(100));
        }
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
