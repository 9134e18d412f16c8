//! Checkpoints: the full state of a run after a batch of steps, written every
//! `run.checkpoint_interval` of simulated time (and when a run is interrupted) to
//! `checkpoint.bin` in its output folder, from which `meshless run CASE --resume DIR`
//! continues as if it had not stopped.
//!
//! The file (version 5) is a small header, raw little-endian f64 words and a checksum:
//!
//! | bytes | what |
//! |---|---|
//! | 8 | `MESHCKPT` |
//! | 4 | the version, u32 (5) |
//! | 4 | the header's length H, u32 |
//! | H | the header, UTF-8 `key = value` lines: `case`, `method`, `backend`, `dimension`, `particles` and `fingerprint` (FNV-1a of the case with its end time left out, [`Scene::fingerprint`]) |
//! | 8 | the number W of words, u64 |
//! | 8 W | the words, f64: the driver's ([`Progress`]: t, step, Δt, the first Δt, E0, the next series sample, checkpoint and frame times, the series' length in bytes, the frame count and each frame's time), then the engine's ([`super::Engine::save`]: the state and what a step carries to the next) |
//! | 8 | FNV-1a (64 bits) of every byte before it, u64 |
//!
//! A checkpoint is refused, naming what differs, when its case, method, backend kind
//! (CPU or GPU), dimension or particle count is not this run's. It is read in chunks of
//! bounded size, and nothing is allocated for its words before their count has been
//! checked against the file's length and against the words this run's engine saves; the
//! checksum is verified, and the driver's words are checked (a finite time from 0 to the
//! end time, a step count that is zero exactly at t = 0, finite positive steps, frame
//! times in order up to t), before anything is restored.

use super::RunError;
use crate::case::{FNV_OFFSET, fnv1a_extend};
use crate::output::write_atomically;
use crate::scene::Scene;
use std::io::{BufReader, Read, Write};
use std::path::Path;

/// The checkpoint's file name in a run's output folder.
pub const FILE: &str = "checkpoint.bin";
const MAGIC: &[u8; 8] = b"MESHCKPT";
const VERSION: u32 = 5;
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

impl Progress {
    /// What makes the progress impossible for a run that ends at `end_time`, if anything.
    fn implausible(&self, end_time: f64) -> Option<String> {
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if !(self.t.is_finite() && (0.0..=end_time).contains(&self.t)) {
            return Some(format!(
                "its time t = {} is not in [0, run.end_time = {end_time}] s; to go on past \
                 the end, raise run.end_time",
                self.t
            ));
        }
        if (self.step == 0) != (self.t == 0.0) {
            return Some(format!(
                "its step count {} does not fit its time t = {}",
                self.step, self.t
            ));
        }
        if !(positive(self.dt) && positive(self.dt_first) && self.e0.is_finite()) {
            return Some(format!(
                "its Δt = {}, first Δt = {} or E0 = {} is not finite and positive",
                self.dt, self.dt_first, self.e0
            ));
        }
        let in_order = self.frames.windows(2).all(|w| w[0] <= w[1]);
        if !in_order || self.frames.iter().any(|&f| !(0.0..=self.t).contains(&f)) {
            return Some(format!(
                "its frame times are not in order from 0 to t = {}",
                self.t
            ));
        }
        None
    }
}

/// A count stored as an f64 word, if it is one.
fn whole(x: f64) -> Option<u64> {
    (x >= 0.0 && x.fract() == 0.0 && x < 2f64.powi(53)).then_some(x as u64)
}

/// What identifies the run a checkpoint belongs to.
fn header(case: &Scene, backend: &str, particles: usize) -> Vec<(&'static str, String)> {
    vec![
        ("case", case.name.clone()),
        ("method", case.method.name.to_string()),
        ("backend", backend_kind(backend).to_string()),
        ("dimension", case.dimension.to_string()),
        ("particles", particles.to_string()),
        ("fingerprint", format!("{:016x}", case.fingerprint())),
    ]
}

/// "cpu" or "gpu": a checkpoint may move between adapters, and between rank counts
/// ("cpu on 3 ranks" writes the words of the run on one).
fn backend_kind(backend: &str) -> &str {
    backend.split([':', ' ']).next().unwrap_or(backend)
}

/// Writes the checkpoint of a run atomically into `dir`.
pub fn write(
    dir: &Path,
    case: &Scene,
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
        let mut hash = FNV_OFFSET;
        let mut put = |bytes: &[u8]| {
            hash = fnv1a_extend(hash, bytes);
            w.write_all(bytes)
        };
        put(MAGIC)?;
        put(&VERSION.to_le_bytes())?;
        put(&(text.len() as u32).to_le_bytes())?;
        put(text.as_bytes())?;
        put(&(words.len() as u64).to_le_bytes())?;
        for x in &words {
            put(&x.to_le_bytes())?;
        }
        w.write_all(&hash.to_le_bytes())
    })
    .map_err(super::output_error(&path))
}

/// Reads the checkpoint in `dir` of a run of `case` on `backend` with `particles`
/// particles, whose engine saves at most `engine_words` words: the driver's progress and
/// the engine's words.
pub fn read(
    dir: &Path,
    case: &Scene,
    backend: &str,
    particles: usize,
    engine_words: usize,
) -> Result<(Progress, Vec<f64>), RunError> {
    let path = dir.join(FILE);
    let refuse = |message: String| RunError::Checkpoint {
        path: path.clone(),
        message,
    };
    let mut file = Hashed::open(&path).map_err(|e| refuse(format!("cannot read it: {e}")))?;
    let torn = |e: std::io::Error| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => {
            refuse("it ends early (a torn or foreign file)".into())
        }
        _ => refuse(format!("cannot read it: {e}")),
    };
    if &file.array::<8>().map_err(torn)? != MAGIC {
        return Err(refuse("it is not a meshless checkpoint".into()));
    }
    let version = u32::from_le_bytes(file.array().map_err(torn)?);
    if version != VERSION {
        return Err(refuse(format!(
            "it has version {version}; this meshless reads version {VERSION}"
        )));
    }
    let length = u32::from_le_bytes(file.array().map_err(torn)?);
    if length > HEADER_CAP {
        return Err(refuse("its header is too long (a foreign file)".into()));
    }
    let mut text = vec![0; length as usize];
    file.fill(&mut text).map_err(torn)?;
    let text = String::from_utf8(text)
        .map_err(|_| refuse("its header is not UTF-8 (a foreign file)".into()))?;
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
    let count = u64::from_le_bytes(file.array().map_err(torn)?);
    let held = file.left().saturating_sub(8);
    if count.checked_mul(8) != Some(held) {
        return Err(refuse(format!(
            "it announces {count} words but holds {held} bytes of them"
        )));
    }
    // The driver's words name the frame count; with the engine's they bound the whole.
    let mut words = Vec::new();
    file.words(count.min(10) as usize, &mut words)
        .map_err(torn)?;
    let frames = words.get(9).copied().and_then(whole);
    let step = words.get(1).copied().and_then(whole);
    let most = match (frames, step) {
        (Some(frames), Some(step)) if frames <= step + 2 => 10 + frames + engine_words as u64,
        _ => 0,
    };
    if count > most || count < 10 {
        return Err(refuse(format!(
            "it holds {count} words, more than the 10 of the driver, its frames (at most \
             one per step and the first) and the {engine_words} an engine of this run \
             saves: the file is damaged"
        )));
    }
    words
        .try_reserve_exact(count as usize - words.len())
        .map_err(|_| refuse(format!("its {count} words do not fit in memory")))?;
    file.words(count as usize - words.len(), &mut words)
        .map_err(torn)?;
    let sum = file.hash;
    if u64::from_le_bytes(file.array().map_err(torn)?) != sum {
        return Err(refuse(
            "its checksum does not match its contents: the file is damaged; resume from \
             a copy, or run again without --resume"
                .into(),
        ));
    }
    let (progress, engine) = Progress::from_words(&words)
        .ok_or_else(|| refuse("its driver state is malformed".into()))?;
    if let Some(why) = progress.implausible(case.run.end_time) {
        return Err(refuse(why));
    }
    Ok((progress, engine.to_vec()))
}

/// The bytes read per chunk of words.
const CHUNK: usize = 1 << 20;

/// A checkpoint file being read, with the FNV-1a hash of the bytes read so far.
struct Hashed {
    reader: BufReader<std::fs::File>,
    left: u64,
    hash: u64,
}

impl Hashed {
    /// Opens a regular file ([`crate::output::open_regular`]).
    fn open(path: &Path) -> std::io::Result<Self> {
        let file = crate::output::open_regular(path)?;
        Ok(Self {
            left: file.metadata()?.len(),
            reader: BufReader::new(file),
            hash: FNV_OFFSET,
        })
    }

    /// The bytes not read yet.
    fn left(&self) -> u64 {
        self.left
    }

    fn fill(&mut self, buf: &mut [u8]) -> std::io::Result<()> {
        self.reader.read_exact(buf)?;
        self.left = self.left.saturating_sub(buf.len() as u64);
        self.hash = fnv1a_extend(self.hash, buf);
        Ok(())
    }

    fn array<const N: usize>(&mut self) -> std::io::Result<[u8; N]> {
        let mut buf = [0; N];
        self.fill(&mut buf)?;
        Ok(buf)
    }

    /// Appends the next `n` f64 words to `out`, read in chunks of [`CHUNK`] bytes.
    fn words(&mut self, n: usize, out: &mut Vec<f64>) -> std::io::Result<()> {
        let end = out.len() + n;
        let mut buf = vec![0; CHUNK];
        while out.len() < end {
            let bytes = &mut buf[..(8 * (end - out.len())).min(CHUNK)];
            self.fill(bytes)?;
            out.extend(
                bytes
                    .chunks_exact(8)
                    .map(|b| f64::from_le_bytes(b.try_into().expect("eight bytes"))),
            );
        }
        Ok(())
    }
}
