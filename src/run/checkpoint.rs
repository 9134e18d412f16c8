//! Checkpoints: the full state of a run after a batch of steps, written every
//! `run.checkpoint_interval` of simulated time (and when a run is interrupted) to
//! `checkpoint.bin` in its output folder, from which `meshless run CASE --resume DIR`
//! continues as if it had not stopped.
//!
//! The file (version 3) is a small header and raw little-endian f64 words:
//!
//! | bytes | what |
//! |---|---|
//! | 8 | `MESHCKPT` |
//! | 4 | the version, u32 (3) |
//! | 4 | the header's length H, u32 |
//! | H | the header, UTF-8 `key = value` lines: `case`, `method`, `backend`, `dimension`, `particles` and `fingerprint` (FNV-1a of the case with its end time left out, [`Case::fingerprint`]) |
//! | 8 | the number W of words, u64 |
//! | 8 W | the words, f64: the driver's ([`Progress`]: t, step, Δt, the first Δt, E0, the next series sample, checkpoint and frame times, the series' length in bytes, the frame count and each frame's time), then the engine's ([`super::Engine::save`]: the state and what a step carries to the next) |
//!
//! A checkpoint is refused, naming what differs, when its case, method, backend kind
//! (CPU or GPU), dimension or particle count is not this run's.

use super::RunError;
use crate::output::write_atomically;
use crate::scene::Case;
use std::io::Write;
use std::path::Path;

/// The checkpoint's file name in a run's output folder.
pub const FILE: &str = "checkpoint.bin";
const MAGIC: &[u8; 8] = b"MESHCKPT";
const VERSION: u32 = 3;
/// The largest header read (a header names a case and a method: a few hundred bytes).
const HEADER_CAP: u32 = 1 << 16;

/// Where the driver stands after a batch: everything besides the engine it needs to go on.
#[derive(Clone, Debug, PartialEq)]
pub struct Progress {
    pub t: f64,
    pub step: u64,
    pub dt: f64,
    pub dt_first: f64,
    /// Total energy of the initial state (the blow-up bound's E0).
    pub e0: f64,
    pub next_sample: f64,
    pub next_checkpoint: f64,
    /// Bytes of `series.csv` written (the rows up to t).
    pub series_bytes: u64,
    pub next_frame: f64,
    /// Times of the frames written, in order.
    pub frames: Vec<f64>,
}

impl Progress {
    fn words(&self) -> Vec<f64> {
        let mut out = vec![
            self.t,
            self.step as f64,
            self.dt,
            self.dt_first,
            self.e0,
            self.next_sample,
            self.next_checkpoint,
            self.series_bytes as f64,
            self.next_frame,
            self.frames.len() as f64,
        ];
        out.extend(&self.frames);
        out
    }

    /// The progress at the front of `words`, and the engine's words after it.
    fn from_words(words: &[f64]) -> Option<(Self, &[f64])> {
        let (
            &[
                t,
                step,
                dt,
                dt_first,
                e0,
                next_sample,
                next_checkpoint,
                series,
                next_frame,
                n,
            ],
            rest,
        ) = words.split_first_chunk::<10>()?;
        let n = whole(n)? as usize;
        (rest.len() >= n).then(|| {
            let progress = Self {
                t,
                step: whole(step)?,
                dt,
                dt_first,
                e0,
                next_sample,
                next_checkpoint,
                series_bytes: whole(series)?,
                next_frame,
                frames: rest[..n].to_vec(),
            };
            Some((progress, &rest[n..]))
        })?
    }
}

/// A count stored as an f64 word, if it is one.
fn whole(x: f64) -> Option<u64> {
    (x >= 0.0 && x.fract() == 0.0 && x < 2f64.powi(53)).then_some(x as u64)
}

/// What identifies the run a checkpoint belongs to.
fn header(case: &Case, backend: &str, particles: usize) -> Vec<(&'static str, String)> {
    vec![
        ("case", case.name.clone()),
        ("method", case.method.name().to_string()),
        ("backend", backend_kind(backend).to_string()),
        ("dimension", case.dimension.to_string()),
        ("particles", particles.to_string()),
        ("fingerprint", format!("{:016x}", case.fingerprint())),
    ]
}

/// "cpu" or "gpu" (a checkpoint may move between adapters).
fn backend_kind(backend: &str) -> &str {
    backend.split(':').next().unwrap_or(backend)
}

/// Writes the checkpoint of a run atomically into `dir`.
pub fn write(
    dir: &Path,
    case: &Case,
    backend: &str,
    particles: usize,
    progress: &Progress,
    engine: &[f64],
) -> Result<(), RunError> {
    let path = dir.join(FILE);
    let text: String = header(case, backend, particles)
        .iter()
        .map(|(k, v)| format!("{k} = {v}\n"))
        .collect();
    let mut words = progress.words();
    words.extend(engine);
    write_atomically(&path, |w| {
        w.write_all(MAGIC)?;
        w.write_all(&VERSION.to_le_bytes())?;
        w.write_all(&(text.len() as u32).to_le_bytes())?;
        w.write_all(text.as_bytes())?;
        w.write_all(&(words.len() as u64).to_le_bytes())?;
        for x in &words {
            w.write_all(&x.to_le_bytes())?;
        }
        Ok(())
    })
    .map_err(super::output_error(&path))
}

/// Reads the checkpoint in `dir` of a run of `case` on `backend` with `particles`
/// particles: the driver's progress and the engine's words.
pub fn read(
    dir: &Path,
    case: &Case,
    backend: &str,
    particles: usize,
) -> Result<(Progress, Vec<f64>), RunError> {
    let path = dir.join(FILE);
    let refuse = |message: String| RunError::Checkpoint {
        path: path.clone(),
        message,
    };
    let bytes = read_capped(&path).map_err(|e| refuse(format!("cannot read it: {e}")))?;
    let mut rest = bytes.as_slice();
    let mut take = |n: usize| -> Result<&[u8], RunError> {
        if rest.len() < n {
            return Err(refuse("it ends early (a torn or foreign file)".into()));
        }
        let (head, tail) = rest.split_at(n);
        rest = tail;
        Ok(head)
    };
    if take(8)? != MAGIC {
        return Err(refuse("it is not a meshless checkpoint".into()));
    }
    let u32_of = |b: &[u8]| u32::from_le_bytes(b.try_into().expect("four bytes"));
    let version = u32_of(take(4)?);
    if version != VERSION {
        return Err(refuse(format!(
            "it has version {version}; this meshless reads version {VERSION}"
        )));
    }
    let length = u32_of(take(4)?);
    if length > HEADER_CAP {
        return Err(refuse("its header is too long (a foreign file)".into()));
    }
    let text = std::str::from_utf8(take(length as usize)?)
        .map_err(|_| refuse("its header is not UTF-8 (a foreign file)".into()))?
        .to_string();
    for (key, expected) in header(case, backend, particles) {
        let found = text
            .lines()
            .find_map(|l| l.strip_prefix(key)?.trim_start().strip_prefix('='))
            .map(str::trim)
            .unwrap_or("(none)");
        if found != expected {
            let what = if key == "fingerprint" {
                "the case's keys differ (only run.end_time may change between a run and its \
                 resumption)"
                    .to_string()
            } else {
                format!("its {key} is {found}, this run's is {expected}")
            };
            return Err(refuse(format!(
                "it belongs to another run: {what}; resume with the case, --set overrides, \
                 method and backend of the run that wrote it"
            )));
        }
    }
    let count = u64::from_le_bytes(take(8)?.try_into().expect("eight bytes"));
    if count.checked_mul(8) != Some(rest.len() as u64) {
        return Err(refuse(format!(
            "it announces {count} words but holds {} bytes of them",
            rest.len()
        )));
    }
    let words: Vec<f64> = rest
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().expect("eight bytes")))
        .collect();
    let (progress, engine) = Progress::from_words(&words)
        .ok_or_else(|| refuse("its driver state is malformed".into()))?;
    Ok((progress, engine.to_vec()))
}

/// The largest checkpoint read: 64 GiB (a run of ten million particles in 3D holds
/// about 3 GB of state).
const FILE_CAP: u64 = 64 << 30;

/// A regular file of at most [`FILE_CAP`] bytes, read whole.
fn read_capped(path: &Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() || meta.len() > FILE_CAP {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file of at most 64 GiB",
        ));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    std::fs::File::open(path)?
        .take(FILE_CAP)
        .read_to_end(&mut bytes)?;
    Ok(bytes)
}
