//! Checkpoints: the full state of a run after a batch of steps, written every
//! `run.checkpoint_interval` of simulated time (and when a run is interrupted) to
//! `checkpoint.bin` in its output folder, from which `meshless run CASE --resume DIR`
//! continues as if it had not stopped.
//!
//! The file (version 6) is a small header, raw little-endian f64 words and a checksum:
//!
//! | bytes | what |
//! |---|---|
//! | 8 | `MESHCKPT` |
//! | 4 | the version, u32 (5) |
//! | 4 | the header's length H, u32 |
//! | H | the header, UTF-8 `key = value` lines: `case`, `method`, `backend`, `dimension`, `particles` and `fingerprint` (FNV-1a of the case with its end time left out, [`Scene::fingerprint`]); on several ranks also `pieces`, the rank count |
//! | 8 | the number W of words, u64 |
//! | 8 W | the words, f64: the driver's ([`Progress`]: t, step, Δt, the first Δt, E0, the next series sample, checkpoint and frame times, the series' length in bytes, the frame count and each frame's time), then the engine's ([`super::Engine::save`]: the state and what a step carries to the next; on several ranks the balance's words and the step of the pieces, [`Pieces`]) |
//! | 8 | FNV-1a (64 bits) of every byte before it, u64 |
//!
//! A piece of a checkpoint on several ranks has the same framing; its header names the
//! case, method, fingerprint, step, rank and rank count, and its words are the rank's
//! particle count, their global ids, the integrator's flag and each particle's rows.
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
use crate::core::parallel::whole_word;
use crate::engine::ranks::PieceStore;
use crate::output::write_atomically;
use crate::scene::Scene;
use std::io::{BufReader, Read as _, Write};
use std::path::{Path, PathBuf};

/// The checkpoint's file name in a run's output folder.
pub const FILE: &str = "checkpoint.bin";
const MAGIC: &[u8; 8] = b"MESHCKPT";
const VERSION: u32 = 7;
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
        let n = whole_word(n)? as usize;
        (rest.len() >= n).then(|| {
            let progress = Self {
                t,
                step: whole_word(step)?,
                dt,
                dt_first,
                e0,
                next_sample,
                next_checkpoint,
                series_bytes: whole_word(series)?,
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

/// Writes the checkpoint of a run atomically into `dir`: the driver's `progress` and the
/// `engine`'s words, which on several ranks name the `pieces` (the ranks' files,
/// [`Pieces`]) rather than hold the state.
pub fn write(
    dir: &Path,
    case: &Scene,
    backend: &str,
    particles: usize,
    progress: &Progress,
    engine: &[f64],
    pieces: Option<usize>,
) -> Result<(), RunError> {
    let mut lines = header(case, backend, particles);
    if let Some(ranks) = pieces {
        lines.push((PIECES, ranks.to_string()));
    }
    let mut words = progress.words();
    words.extend(engine);
    let path = dir.join(FILE);
    write_framed(&path, &lines, &words).map_err(super::output_error(&path))
}

/// Writes `words` under the header `lines` atomically to `path`, framed as a checkpoint:
/// magic, version, header, word count, words and checksum; the file is on the disk
/// before it takes the name, and its folder's entry after where the platform allows.
fn write_framed(path: &Path, lines: &[(&str, String)], words: &[f64]) -> std::io::Result<()> {
    let text: String = lines.iter().map(|(k, v)| format!("{k} = {v}\n")).collect();
    write_atomically(path, |w| {
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
        for x in words {
            put(&x.to_le_bytes())?;
        }
        w.write_all(&hash.to_le_bytes())?;
        w.flush()?;
        w.get_ref().sync_all()
    })?;
    // Best effort: not every platform syncs a folder.
    let folder = path.parent().expect("a checkpoint lies in a folder");
    let _ = std::fs::File::open(folder).and_then(|f| f.sync_all());
    Ok(())
}

/// What [`read`] found: the driver's progress, the engine's words, and the rank count
/// of a checkpoint in pieces ([`Pieces`]).
pub struct Read {
    pub progress: Progress,
    pub engine: Vec<f64>,
    pub pieces: Option<usize>,
}

/// Reads the checkpoint in `dir` of a run of `case` on `backend` with `particles`
/// particles, whose engine saves at most `engine_words` words.
pub fn read(
    dir: &Path,
    case: &Scene,
    backend: &str,
    particles: usize,
    engine_words: usize,
) -> Result<Read, RunError> {
    let path = dir.join(FILE);
    let refuse = |message: String| RunError::Checkpoint {
        path: path.clone(),
        message,
    };
    let mut file = Framed::open(&path).map_err(refuse)?;
    file.belongs(&header(case, backend, particles))
        .map_err(refuse)?;
    let pieces = match file.value(PIECES) {
        None => None,
        Some(ranks) => Some(
            (ranks.parse().ok())
                .filter(|&r: &usize| r > 0)
                .ok_or_else(|| refuse(format!("its {PIECES} = {ranks} is not a rank count")))?,
        ),
    };
    // The driver's words name the frame count; with the engine's they bound the whole.
    let count = file.count;
    let mut words = file.words(count.min(10)).map_err(refuse)?;
    let frames = words.get(9).copied().and_then(whole_word);
    let step = words.get(1).copied().and_then(whole_word);
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
    words.extend(file.words(count - words.len() as u64).map_err(refuse)?);
    file.verify().map_err(refuse)?;
    let (progress, engine) = Progress::from_words(&words)
        .ok_or_else(|| refuse("its driver state is malformed".into()))?;
    if let Some(why) = progress.implausible(case.run.end_time) {
        return Err(refuse(why));
    }
    Ok(Read {
        progress,
        engine: engine.to_vec(),
        pieces,
    })
}

/// The header key of a checkpoint in pieces: the number of ranks that wrote them.
const PIECES: &str = "pieces";
/// The folder of the pieces in a run's output folder: one folder per step.
pub const PIECES_DIR: &str = "checkpoint.pieces";

/// The pieces of the checkpoints of a run on several ranks
/// ([`crate::engine::ranks::PieceStore`]): each rank writes its own particles' words
/// into `checkpoint.pieces/<step>/rank-<r>.bin`, framed as a checkpoint, and rank 0 then
/// writes `checkpoint.bin`, which names the step and the rank count. A run stopped
/// while the ranks write leaves the last `checkpoint.bin` and the folder it names
/// intact; a later checkpoint removes the folders of the other steps
/// ([`prune_pieces`]).
pub struct Pieces {
    dir: PathBuf,
    /// The case's name, method and fingerprint, which every piece carries.
    case: Vec<(&'static str, String)>,
    rank: usize,
}

impl Pieces {
    /// The pieces of rank `rank` of a run of `case` writing into `dir`.
    pub fn new(dir: &Path, case: &Scene, rank: usize) -> Self {
        let case = header(case, "cpu", 0)
            .into_iter()
            .filter(|(k, _)| ["case", "method", "fingerprint"].contains(k))
            .collect();
        Self {
            dir: dir.to_path_buf(),
            case,
            rank,
        }
    }

    fn path(&self, step: u64, rank: usize) -> PathBuf {
        (self.dir.join(PIECES_DIR))
            .join(format!("{step:012}"))
            .join(format!("rank-{rank:05}.bin"))
    }

    fn header(&self, step: u64, rank: usize, ranks: usize) -> Vec<(&'static str, String)> {
        let mut lines = self.case.clone();
        lines.push(("step", step.to_string()));
        lines.push(("rank", rank.to_string()));
        lines.push(("ranks", ranks.to_string()));
        lines
    }
}

impl PieceStore for Pieces {
    fn write(&self, step: u64, ranks: usize, words: &[f64]) -> Result<(), String> {
        let path = self.path(step, self.rank);
        let folder = path.parent().expect("a piece lies in its step's folder");
        std::fs::create_dir_all(folder)
            .and_then(|()| write_framed(&path, &self.header(step, self.rank, ranks), words))
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    fn read(&self, step: u64, rank: usize, ranks: usize, most: u64) -> Result<Vec<f64>, String> {
        let path = self.path(step, rank);
        let refuse = |why: String| format!("{}: {why}", path.display());
        let mut file = Framed::open(&path).map_err(refuse)?;
        file.belongs(&self.header(step, rank, ranks))
            .map_err(refuse)?;
        if file.count > most {
            return Err(refuse(format!(
                "it holds {} words, more than the {most} of a rank's share: the file is \
                 damaged",
                file.count
            )));
        }
        let words = file.words(file.count).map_err(refuse)?;
        file.verify().map_err(refuse)?;
        Ok(words)
    }
}

/// Removes the folders of pieces in `dir` of every step but `keep` (those of earlier
/// checkpoints, or of one whose writing stopped): folders named by a step, not links,
/// in a `checkpoint.pieces` that is itself a folder; one that cannot be removed stays.
pub fn prune_pieces(dir: &Path, keep: u64) {
    let pieces = dir.join(PIECES_DIR);
    let folder = |path: &Path| std::fs::symlink_metadata(path).is_ok_and(|m| m.is_dir());
    if !folder(&pieces) {
        return;
    }
    let Ok(steps) = std::fs::read_dir(&pieces) else {
        return;
    };
    let keep = format!("{keep:012}");
    for step in steps.flatten() {
        let name = step.file_name();
        let name = name.to_string_lossy();
        let a_step = name.len() == 12 && name.bytes().all(|b| b.is_ascii_digit());
        if a_step && name != keep && folder(&step.path()) {
            let _ = std::fs::remove_dir_all(step.path());
        }
    }
}

/// A checkpoint file opened past its header, with its word count checked against its
/// length; its words are read with [`Self::words`], then [`Self::verify`] checks the
/// checksum. Errors are messages about the file.
struct Framed {
    file: Hashed,
    text: String,
    count: u64,
}

impl Framed {
    fn open(path: &Path) -> Result<Self, String> {
        let mut file = Hashed::open(path).map_err(|e| format!("cannot read it: {e}"))?;
        let torn = |e: std::io::Error| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => "it ends early (a torn or foreign file)".into(),
            _ => format!("cannot read it: {e}"),
        };
        if &file.array::<8>().map_err(torn)? != MAGIC {
            return Err("it is not a meshless checkpoint".into());
        }
        let version = u32::from_le_bytes(file.array().map_err(torn)?);
        if version != VERSION {
            return Err(format!(
                "it has version {version}; this meshless reads version {VERSION}"
            ));
        }
        let length = u32::from_le_bytes(file.array().map_err(torn)?);
        if length > HEADER_CAP {
            return Err("its header is too long (a foreign file)".into());
        }
        let mut text = vec![0; length as usize];
        file.fill(&mut text).map_err(torn)?;
        let text =
            String::from_utf8(text).map_err(|_| "its header is not UTF-8 (a foreign file)")?;
        let count = u64::from_le_bytes(file.array().map_err(torn)?);
        let held = file.left().saturating_sub(8);
        if count.checked_mul(8) != Some(held) {
            return Err(format!(
                "it announces {count} words but holds {held} bytes of them"
            ));
        }
        Ok(Self { file, text, count })
    }

    /// The header's value of `key`, if it has one.
    fn value(&self, key: &str) -> Option<&str> {
        (self.text.lines())
            .find_map(|l| l.strip_prefix(key)?.trim_start().strip_prefix('='))
            .map(str::trim)
    }

    /// Refuses a file whose header differs from `expected` in a key.
    fn belongs(&self, expected: &[(&str, String)]) -> Result<(), String> {
        for (key, expected) in expected {
            let found = self.value(key).unwrap_or("(none)");
            if found != expected {
                let what = if *key == "fingerprint" {
                    "the case's keys differ (only run.end_time may change between a run and \
                     its resumption)"
                        .to_string()
                } else {
                    format!("its {key} is {found}, this run's is {expected}")
                };
                return Err(format!(
                    "it belongs to another run: {what}; resume with the case, --set \
                     overrides, method and backend of the run that wrote it"
                ));
            }
        }
        Ok(())
    }

    /// The next `n` words.
    fn words(&mut self, n: u64) -> Result<Vec<f64>, String> {
        let mut words = Vec::new();
        words
            .try_reserve_exact(n as usize)
            .map_err(|_| format!("its {n} words do not fit in memory"))?;
        (self.file.words(n as usize, &mut words))
            .map_err(|_| "it ends early (a torn or foreign file)".to_string())?;
        Ok(words)
    }

    /// Checks the checksum after the last word.
    fn verify(mut self) -> Result<(), String> {
        let sum = self.file.hash;
        let stored = (self.file.array())
            .map_err(|_| "it ends early (a torn or foreign file)".to_string())?;
        if u64::from_le_bytes(stored) != sum {
            return Err(
                "its checksum does not match its contents: the file is damaged; \
                        resume from a copy, or run again without --resume"
                    .into(),
            );
        }
        Ok(())
    }
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
