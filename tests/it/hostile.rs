//! Hostile input, kept fixed: the malformed-case corpus of `tests/cases/bad/` and a
//! seeded mutation test over the shipped cases, both through the path `meshless check`
//! takes (load, validate, estimate the resources, build the engine on the CPU), in
//! process. No input may panic, hang or do anything but load or exit with 2.

use crate::common::{cases_dir, toml_files};
use meshless::run::{Backend, Limits, RunError, check};
use meshless::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// What `meshless check` does with one case file, in process.
#[derive(Debug)]
enum Outcome {
    /// Loaded and built.
    Ran,
    /// Refused: the exit code and the message.
    Refused(u8, String),
    Panicked(String),
    /// Still running at the time limit.
    Hung,
}

/// The check of one case text (as the file `file`, which anchors relative points files),
/// on a worker thread with a time limit.
fn outcome(text: String, file: PathBuf, limits: Limits, time_limit: Duration) -> Outcome {
    let (sender, receiver) = mpsc::channel();
    std::thread::spawn(move || {
        let result = std::panic::catch_unwind(|| {
            Scene::from_toml(&text, &file, &[])
                .map_err(RunError::from)
                .and_then(|case| check(&case, Backend::Cpu, &limits))
        });
        let _ = sender.send(match result {
            Ok(Ok(_)) => Outcome::Ran,
            Ok(Err(e)) => Outcome::Refused(e.exit_code(), e.to_string()),
            Err(panic) => Outcome::Panicked(
                panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default(),
            ),
        });
    });
    receiver.recv_timeout(time_limit).unwrap_or(Outcome::Hung)
}

/// The `# expect: exit N, key `K`` header line of a corpus file.
fn expectation(text: &str, file: &Path) -> (u8, String) {
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("# expect: exit "))
        .unwrap_or_else(|| panic!("{}: no `# expect:` line", file.display()));
    let (code, key) = line
        .split_once(", key `")
        .expect("`, key `K`` after the code");
    (
        code.trim().parse().expect("an exit code"),
        key.trim_end_matches('`').to_string(),
    )
}

#[test]
fn every_malformed_case_is_refused_with_its_file_and_key() {
    // Each file of the corpus breaks one thing of a valid case (its header says what and
    // the key the message must name): exit code 2 with the file and the key, within
    // 20 s (most take microseconds; the resource refusals must not start the work).
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/cases/bad");
    let files = toml_files(&dir);
    let (mut rejected, mut panicked, mut hung, mut ran, mut wrong) = (0, 0, 0, 0, Vec::new());
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let (code, key) = expectation(&text, file);
        let limit = Duration::from_secs(20);
        match outcome(text, file.clone(), Limits::default(), limit) {
            Outcome::Refused(c, message) => {
                let names_file = message.contains(&file.display().to_string());
                if c == code && names_file && message.contains(&key) {
                    rejected += 1;
                } else {
                    wrong.push(format!("{}: exit {c}: {message}", file.display()));
                }
            }
            Outcome::Panicked(m) => {
                panicked += 1;
                wrong.push(format!("{}: panicked: {m}", file.display()));
            }
            Outcome::Hung => {
                hung += 1;
                wrong.push(format!("{}: hung", file.display()));
            }
            Outcome::Ran => {
                ran += 1;
                wrong.push(format!("{}: ran anyway", file.display()));
            }
        }
    }
    eprintln!(
        "malformed-case corpus: {} cases: {rejected} rejected with file and key, {panicked} \
         panicked, {hung} hung, {ran} ran anyway",
        files.len()
    );
    assert!(files.len() >= 60, "the corpus has {} cases", files.len());
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// A deterministic generator (64-bit LCG, Knuth's constants; the high bits).
pub(crate) struct Lcg(pub(crate) u64);

impl Lcg {
    pub(crate) fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 33) % n as u64) as usize
    }

    pub(crate) fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// Values a mutant puts in place of a number: the edges of f64 and f32, zero, signs,
/// tiny and huge steps and spacings, a NaN and an integer.
const EXTREMES: &[&str] = &[
    "0.0",
    "-0.0",
    "-1.0",
    "1e-300",
    "1e300",
    "nan",
    "inf",
    "-inf",
    "1e39",
    "1e-46",
    "1e154",
    "3",
    "0.5",
    "2.0",
    "1e-12",
    "1e-6",
    "4294967296",
];

/// Words a mutant puts in place of a string: other shapes, models, methods, kernels.
const WORDS: &[&str] = &[
    "\"box\"",
    "\"disk\"",
    "\"ring\"",
    "\"points\"",
    "\"cylinder\"",
    "\"tlsph\"",
    "\"upwind-sph\"",
    "\"godunov-sph\"",
    "\"von-mises-plastic\"",
    "\"mooney-rivlin\"",
    "\"quintic\"",
    "\"\"",
    "\"/dev/zero\"",
    "\"../../x\"",
    "[]",
    "{}",
];

/// One mutation of a case's text: a number or a string replaced, a line deleted or
/// repeated, the text cut short, or a byte inserted.
pub(crate) fn mutate(text: &str, rng: &mut Lcg) -> String {
    let lines: Vec<&str> = text.lines().collect();
    if lines.is_empty() {
        return format!("{text}=");
    }
    let at = rng.below(lines.len());
    let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    match rng.below(6) {
        0 | 1 => {
            // Replace the k-th number of a line that has one.
            let numbers: Vec<(usize, usize)> = number_spans(&out[at]);
            if let Some(&(a, b)) = numbers.get(rng.below(numbers.len().max(1))) {
                let value: &str = rng.pick::<&str>(EXTREMES);
                out[at].replace_range(a..b, value);
            }
        }
        2 => {
            if let Some(a) = out[at].find('"')
                && let Some(b) = out[at][a + 1..].find('"')
            {
                let word: &str = rng.pick::<&str>(WORDS);
                out[at].replace_range(a..a + b + 2, word);
            }
        }
        3 => {
            out.remove(at);
        }
        4 => out.insert(at, out[at].clone()),
        _ => {
            let cut = rng.below(text.len());
            let mut cut_text = text.as_bytes()[..cut].to_vec();
            cut_text.push(*rng.pick(b"=[{\"#.,\n0"));
            return String::from_utf8_lossy(&cut_text).into_owned();
        }
    }
    out.join("\n")
}

/// Byte ranges of the numbers on a line (digits with sign, point and exponent), outside
/// comments.
fn number_spans(line: &str) -> Vec<(usize, usize)> {
    let code = line.split('#').next().unwrap_or("");
    let bytes = code.as_bytes();
    let mut spans = Vec::new();
    let mut k = 0;
    while k < bytes.len() {
        let starts = bytes[k].is_ascii_digit()
            && (k == 0 || !(bytes[k - 1].is_ascii_alphanumeric() || bytes[k - 1] == b'_'));
        if starts {
            let a = if k > 0 && bytes[k - 1] == b'-' {
                k - 1
            } else {
                k
            };
            let mut b = k;
            while b < bytes.len()
                && (bytes[b].is_ascii_digit()
                    || matches!(bytes[b], b'.' | b'e' | b'E' | b'-' | b'+'))
            {
                b += 1;
            }
            spans.push((a, b));
            k = b;
        } else {
            k += 1;
        }
    }
    spans
}

#[test]
fn mutants_of_the_shipped_cases_load_or_are_refused_never_panic_or_hang() {
    // 3,000 mutants (seeded: the same ones on every machine) of the shipped cases, one to
    // three mutations each. Each must load and build, or be refused with exit 2, within
    // 20 s; none may panic. Particles are capped at 3,000 (a mutant past it is refused
    // with exit 2, as `--max-particles 3000` would), so that the engines the valid
    // mutants build stay small and the test takes well under a minute.
    const MUTANTS: usize = 3000;
    let shipped: Vec<(PathBuf, String)> = toml_files(&cases_dir())
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (p, text)
        })
        .collect();
    let limits = Limits {
        max_particles: 3000.0,
        ..Limits::default()
    };
    let mut rng = Lcg(0x5eed_2022);
    let started = Instant::now();
    let (mut ran, mut refused, mut failures) = (0, 0, Vec::new());
    for k in 0..MUTANTS {
        let (file, text) = rng.pick(&shipped);
        let mut mutant = text.clone();
        for _ in 0..=rng.below(3) {
            mutant = mutate(&mutant, &mut rng);
        }
        match outcome(
            mutant.clone(),
            file.clone(),
            limits,
            Duration::from_secs(20),
        ) {
            Outcome::Ran => ran += 1,
            Outcome::Refused(2, _) => refused += 1,
            other => failures.push(format!(
                "mutant {k} of {}: {other:?}\n{mutant}",
                file.display()
            )),
        }
    }
    eprintln!(
        "{MUTANTS} mutants of {} shipped cases in {:.1} s: {ran} loaded and built, {refused} \
         refused with exit 2, {} panicked, hung or exited otherwise",
        shipped.len(),
        started.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    // The mutations reach past the parser: some mutants are valid cases.
    assert!(ran > 100, "only {ran} mutants loaded");
}
