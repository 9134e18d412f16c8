//! Seeded fuzzing of the readers below the case loader: the expression parser, points
//! files, Gmsh meshes and checkpoints. The same inputs on every machine, so a failure
//! reproduces; each test prints its counts. The case loader itself is fuzzed by
//! `hostile::mutants_of_the_shipped_cases_load_or_are_refused_never_panic_or_hang`.
//!
//! What every input must do: be read, or be refused with a message, within a time limit,
//! without a panic; and what is read must be usable (finite, positive measures; the value
//! the expression means).

use crate::common::{cases_dir, cpu_options, load};
use crate::hostile::{Lcg, mutate};
use meshless::case::{Expression, fnv1a, mesh};
use meshless::run::{Backend, Limits, RunError, check, checkpoint, run};
use meshless::scene::Scene;
use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Runs `f` on a worker thread: Some(its value), or None if it panicked; a hang past
/// `limit` fails the test, naming `what`.
fn guarded<T: Send + 'static>(
    what: String,
    limit: Duration,
    f: impl FnOnce() -> T + Send + 'static,
) -> Option<T> {
    let (sender, receiver) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = sender.send(catch_unwind(AssertUnwindSafe(f)).ok());
    });
    receiver
        .recv_timeout(limit)
        .unwrap_or_else(|_| panic!("{what}: still running after {limit:?}"))
}

/// An expression tree, printed fully parenthesised so that its text has one reading.
enum Tree {
    Number(f64, Notation),
    Variable(usize),
    Negate(Box<Tree>),
    Binary(char, Box<Tree>, Box<Tree>),
    Call(&'static str, fn(f64) -> f64, Box<Tree>),
}

/// How a literal is written: each is a form `f64::from_str` reads back exactly.
#[derive(Clone, Copy)]
enum Notation {
    Shortest,
    Exponent,
    UpperExponent,
    LeadingPoint,
}

const VARIABLES: [&str; 4] = ["x", "y", "z", "t"];
/// A function of one argument, as the parser names it.
type Function = (&'static str, fn(f64) -> f64);

const FUNCTIONS: [Function; 6] = [
    ("sin", f64::sin),
    ("cos", f64::cos),
    ("exp", f64::exp),
    ("sqrt", f64::sqrt),
    ("abs", f64::abs),
    ("tanh", f64::tanh),
];

impl Tree {
    fn random(rng: &mut Lcg, depth: usize) -> Tree {
        let leaf = depth == 0 || rng.below(4) == 0;
        match (leaf, rng.below(5)) {
            (true, 0 | 1) => Tree::Variable(rng.below(VARIABLES.len())),
            (true, _) => {
                // Literals over twenty decades, some with many digits.
                let mantissa = (rng.below(1_000_000) + 1) as f64 / 1000.0;
                let value = mantissa * 10f64.powi(rng.below(21) as i32 - 10);
                let notation = *rng.pick(&[
                    Notation::Shortest,
                    Notation::Exponent,
                    Notation::UpperExponent,
                    Notation::LeadingPoint,
                ]);
                Tree::Number(value, notation)
            }
            (false, 0) => Tree::Negate(Box::new(Tree::random(rng, depth - 1))),
            (false, 1) => {
                let (name, f) = *rng.pick(&FUNCTIONS);
                Tree::Call(name, f, Box::new(Tree::random(rng, depth - 1)))
            }
            (false, _) => Tree::Binary(
                *rng.pick(&['+', '-', '*', '/', '^']),
                Box::new(Tree::random(rng, depth - 1)),
                Box::new(Tree::random(rng, depth - 1)),
            ),
        }
    }

    fn text(&self) -> String {
        match self {
            Tree::Number(v, Notation::Shortest) => format!("{v}"),
            Tree::Number(v, Notation::Exponent) => format!("{v:e}"),
            Tree::Number(v, Notation::UpperExponent) => {
                let e = format!("{v:e}").replace('e', "E");
                if e.contains("E-") {
                    e
                } else {
                    e.replace('E', "E+")
                }
            }
            Tree::Number(v, Notation::LeadingPoint) => {
                // v/10^k written as .digits e k, for a v ≥ 1 as well.
                let s = format!("{v:e}");
                let (m, e) = s.split_once('e').unwrap();
                let digits = m.replace('.', "");
                let e: i32 = e.parse().unwrap();
                format!(".{digits}e{}", e + 1)
            }
            Tree::Variable(k) => VARIABLES[*k].to_string(),
            Tree::Negate(a) => format!("(-{})", a.text()),
            Tree::Binary(op, a, b) => format!("({} {op} {})", a.text(), b.text()),
            Tree::Call(name, _, a) => format!("{name}({})", a.text()),
        }
    }

    /// The value by the tree itself, the operations in the order the text states them.
    fn value(&self, at: &[f64]) -> f64 {
        match self {
            Tree::Number(v, _) => *v,
            Tree::Variable(k) => at[*k],
            Tree::Negate(a) => -a.value(at),
            Tree::Binary(op, a, b) => {
                let (a, b) = (a.value(at), b.value(at));
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    '/' => a / b,
                    _ => a.powf(b),
                }
            }
            Tree::Call(_, f, a) => f(a.value(at)),
        }
    }
}

#[test]
fn expressions_mean_what_their_text_says_and_garbage_is_refused() {
    // 3,000 random trees up to depth 6, with literals in four notations: each parses, and
    // at three points its value is the tree's own bit for bit (the same f64 operations in
    // the same order, so any difference is a misreading: a literal, a precedence, a sign).
    // Then 3,000 mutants of their texts (a character deleted, doubled, swapped for an
    // operator, a bracket or a letter, or the text cut): each parses or is refused with a
    // message naming a character, none panics, and each takes under 2 s (a parse is linear
    // in the length; the longest text here is a few hundred characters).
    let mut rng = Lcg(0xe4_7e55);
    let none = BTreeMap::new();
    let (mut exact, mut mutants_read, mut refused) = (0, 0, 0);
    let mut texts = Vec::new();
    for k in 0..3000 {
        let tree = Tree::random(&mut rng, 6);
        let text = tree.text();
        let e = Expression::parse(&text, &VARIABLES, "x, y, z, t", &none)
            .unwrap_or_else(|m| panic!("tree {k}: {m}"));
        for _ in 0..3 {
            let at: Vec<f64> = (0..4)
                .map(|_| rng.below(2001) as f64 / 1000.0 - 1.0)
                .collect();
            let (got, want) = (e.at(&at), tree.value(&at));
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "tree {k}: `{text}` at {at:?} is {got:e}, the tree gives {want:e}"
            );
        }
        exact += 1;
        texts.push(text);
    }
    const SPLICE: &[char] = &[
        '(', ')', '+', '-', '*', '/', '^', 'e', 'E', '.', ' ', 'q', '9',
    ];
    for (k, text) in texts.iter().enumerate() {
        let mut chars: Vec<char> = text.chars().collect();
        for _ in 0..=rng.below(3) {
            let at = rng
                .below(chars.len().max(1))
                .min(chars.len().saturating_sub(1));
            match rng.below(4) {
                0 if !chars.is_empty() => {
                    chars.remove(at);
                }
                1 if !chars.is_empty() => chars.insert(at, chars[at]),
                2 if !chars.is_empty() => chars[at] = *rng.pick(SPLICE),
                _ => chars.truncate(at),
            }
        }
        let text: String = chars.into_iter().collect();
        let what = format!("mutant {k}: `{text}`");
        let started = Instant::now();
        let parsed = guarded(what.clone(), Duration::from_secs(20), move || {
            Expression::parse(&text, &VARIABLES, "x, y, z, t", &BTreeMap::new()).map(|_| ())
        })
        .unwrap_or_else(|| panic!("{what}: the parser panicked"));
        assert!(started.elapsed() < Duration::from_secs(2), "{what}: slow");
        match parsed {
            Ok(()) => mutants_read += 1,
            Err(m) => {
                assert!(
                    m.contains("character") || m.contains("empty"),
                    "{what}: {m}"
                );
                refused += 1;
            }
        }
    }
    eprintln!(
        "expressions: {exact} trees read exactly; 3000 mutants: {mutants_read} read, {refused} \
         refused, 0 panics, 0 hangs"
    );
}

/// The shipped case with a points body, and its points file.
fn points_case() -> (std::path::PathBuf, String, String) {
    let file = cases_dir().join("plate-compression-2d.toml");
    let text = std::fs::read_to_string(&file).unwrap();
    let points =
        std::fs::read_to_string(cases_dir().join("points/plate-irregular-20.csv")).unwrap();
    (file, text, points)
}

#[test]
fn mutated_points_files_are_read_or_refused_by_name() {
    // 600 mutants of a shipped points file (numbers swapped for the edges of f64 and
    // f32, NaN and infinities; rows deleted, doubled or cut), each under the shipped case
    // that reads it, through `meshless check`'s path on the CPU: each builds, or is
    // refused with exit 2 and a message naming the points file; none panics or hangs.
    let (_, case_text, points) = points_case();
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("points")).unwrap();
    let case_file = dir.path().join("plate.toml");
    std::fs::write(&case_file, &case_text).unwrap();
    let csv = dir.path().join("points/plate-irregular-20.csv");
    let mut rng = Lcg(0x9017_7500);
    let (mut built, mut refused) = (0, 0);
    for k in 0..600 {
        let mut mutant = points.clone();
        for _ in 0..=rng.below(3) {
            mutant = mutate(&mutant, &mut rng);
        }
        std::fs::write(&csv, &mutant).unwrap();
        let (text, file) = (case_text.clone(), case_file.clone());
        let what = format!("points mutant {k}");
        let outcome = guarded(what.clone(), Duration::from_secs(20), move || {
            Scene::from_toml(&text, &file, &[])
                .map_err(RunError::from)
                .and_then(|case| check(&case, Backend::Cpu, &Limits::default()))
                .map(|_| ())
        })
        .unwrap_or_else(|| panic!("{what} panicked:\n{mutant}"));
        match outcome {
            Ok(()) => built += 1,
            Err(e) => {
                let message = e.to_string();
                assert_eq!(e.exit_code(), 2, "{what}: {message}");
                assert!(message.contains("plate.toml"), "{what}: {message}");
                refused += 1;
            }
        }
    }
    eprintln!("points files: 600 mutants: {built} built, {refused} refused, 0 panics, 0 hangs");
    assert!(
        built > 20 && refused > 100,
        "{built} built, {refused} refused"
    );
}

/// A 3 × 2 grid of unit squares as Gmsh 2.2 (quadrangles) and 4.1 (triangles) text.
fn meshes() -> [String; 2] {
    let nodes: Vec<(usize, f64, f64)> = (0..12)
        .map(|n| (n + 1, (n % 4) as f64, (n / 4) as f64))
        .collect();
    let node_lines: String = nodes
        .iter()
        .map(|(t, x, y)| format!("{t} {x} {y} 0\n"))
        .collect();
    let quads: Vec<[usize; 4]> = (0..2)
        .flat_map(|j| {
            (0..3).map(move |i| [4 * j + i + 1, 4 * j + i + 2, 4 * j + i + 6, 4 * j + i + 5])
        })
        .collect();
    let v22: String = quads
        .iter()
        .enumerate()
        .map(|(e, [a, b, c, d])| format!("{} 3 2 1 1 {a} {b} {c} {d}\n", e + 1))
        .collect();
    let v22 = format!(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n12\n{node_lines}$EndNodes\n$Elements\n6\n\
         {v22}$EndElements\n"
    );
    let tags: String = (1..=12).map(|t| format!("{t}\n")).collect();
    let coords: String = nodes
        .iter()
        .map(|(_, x, y)| format!("{x} {y} 0\n"))
        .collect();
    let triangles: String = quads
        .iter()
        .enumerate()
        .map(|(e, [a, b, c, d])| format!("{} {a} {b} {c}\n{} {a} {c} {d}\n", 2 * e + 1, 2 * e + 2))
        .collect();
    let v41 = format!(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 12 1 12\n2 1 0 12\n{tags}{coords}\
         $EndNodes\n$Elements\n1 12 1 12\n2 1 2 12\n{triangles}$EndElements\n"
    );
    [v22, v41]
}

#[test]
fn mutated_meshes_are_read_with_finite_cells_or_refused() {
    // 2,000 mutants of two small Gmsh files (2.2 and 4.1): the centroid reader and the
    // vertex reader each read a mutant or refuse it with a message; none panics or hangs,
    // and every cell read has a finite centroid and a finite, positive measure (a cell of
    // infinite area would become a particle of infinite volume).
    let originals = meshes();
    for text in &originals {
        let cells = mesh::cells(text, 2).unwrap();
        assert!(
            cells.len() == 6 || cells.len() == 12,
            "{} cells",
            cells.len()
        );
        let area: f64 = cells.iter().map(|c| c.measure).sum();
        assert!((area - 6.0).abs() < 1e-12, "its area is {area}");
    }
    let mut rng = Lcg(0x0e54_0001);
    let (mut read, mut refused) = (0, 0);
    for k in 0..2000 {
        let mut mutant = originals[k % 2].clone();
        for _ in 0..=rng.below(3) {
            mutant = mutate(&mutant, &mut rng);
        }
        let what = format!("mesh mutant {k}");
        let text = mutant.clone();
        let (cells, vertices) = guarded(what.clone(), Duration::from_secs(20), move || {
            (
                mesh::cells(&text, 2),
                mesh::vertex_cells(&text, 2).map(|_| ()),
            )
        })
        .unwrap_or_else(|| panic!("{what} panicked:\n{mutant}"));
        match cells {
            Ok(cells) => {
                for c in &cells {
                    assert!(
                        c.centroid.iter().all(|x| x.is_finite())
                            && c.measure.is_finite()
                            && c.measure > 0.0,
                        "{what}: a cell {c:?}:\n{mutant}"
                    );
                }
                read += 1;
            }
            Err(_) => refused += 1,
        }
        let _ = vertices;
    }
    eprintln!("meshes: 2000 mutants: {read} read, {refused} refused, 0 panics, 0 hangs");
}

#[test]
fn damaged_checkpoints_are_refused_and_never_panic() {
    // A checkpoint of a short run, then 1,000 damaged copies: a bit flipped, bytes
    // overwritten, the file cut or grown. Half keep the damage behind a checksum made to
    // match, so that the reader's checks past the checksum are reached. Every copy whose
    // checksum does not match is refused; none panics, hangs or takes more than 2 s.
    let dir = tempfile::tempdir().unwrap();
    let case = load(
        "spinning-plate",
        &[
            "spacing=0.05",
            "run.end_time=5e-4",
            "run.checkpoint_interval=2.5e-4",
            "output.frame_interval=5e-4",
        ],
    );
    let summary = run(&case, &cpu_options(dir.path(), false)).unwrap();
    let path = dir.path().join("checkpoint.bin");
    let good = std::fs::read(&path).unwrap();
    let particles = summary.particles;
    let read = |bytes: &[u8]| {
        std::fs::write(&path, bytes).unwrap();
        checkpoint::read(dir.path(), &case, "cpu", particles, 1 << 24).map(|_| ())
    };
    read(&good).expect("the undamaged checkpoint reads");
    let mut rng = Lcg(0xc0ff_ee00);
    let (mut refused, mut resealed_read) = (0, 0);
    for k in 0..1000 {
        let mut bytes = good.clone();
        match rng.below(4) {
            0 => bytes[rng.below(good.len())] ^= 1 << rng.below(8),
            1 => {
                let at = rng.below(good.len());
                for b in bytes.iter_mut().skip(at).take(1 + rng.below(16)) {
                    *b = rng.below(256) as u8;
                }
            }
            2 => bytes.truncate(rng.below(good.len())),
            _ => bytes.extend((0..1 + rng.below(64)).map(|_| rng.below(256) as u8)),
        }
        if bytes == good {
            continue;
        }
        let reseal = k % 2 == 1 && bytes.len() > 8;
        if reseal {
            let body = bytes.len() - 8;
            let sum = fnv1a(&bytes[..body]);
            bytes[body..].copy_from_slice(&sum.to_le_bytes());
        }
        let started = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| read(&bytes)))
            .unwrap_or_else(|_| panic!("damaged checkpoint {k} panicked the reader"));
        assert!(started.elapsed() < Duration::from_secs(2), "copy {k}: slow");
        match (outcome, reseal) {
            (Err(_), _) => refused += 1,
            (Ok(()), true) => resealed_read += 1,
            (Ok(()), false) => panic!("damaged checkpoint {k} was read"),
        }
    }
    eprintln!(
        "checkpoints: 1000 damaged copies: {refused} refused, {resealed_read} read (damage \
         behind a matching checksum that the header and driver checks let through), 0 \
         panics, 0 hangs"
    );
}
