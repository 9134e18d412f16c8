//! The bytes model of a compute pass, for the pass report (`gpu::profile`): the elements
//! each storage binding moves per item and per neighbour pair. It is written in the WGSL,
//! as a comment directly above the `@compute` entry point it models, so that the composed
//! source of a pass carries its own model ([`pass_model`]). Whether the entry point reads
//! or writes a binding, and the bytes of its element, come from naga's reflection of the
//! WGSL ([`BindingUse`], `gpu::context::Reflection`).
//!
//! # Grammar
//!
//! A model is a run of `//` lines ending on the line above `@compute`, from a line
//! `// bytes:` on. Its lines that start with `// - ` are rows; the others are prose (why a
//! count is what it is), kept beside the rows they explain:
//!
//! ```text
//! // bytes:
//! // - offsets: 1 scalar per item
//! // ∇0W̃_ij, and ∇0W̃_ji for the variational force.
//! // - pair: 1 vector per pair
//! // - pair: 1 vector per pair, when FORCE == FORCE_VARIATIONAL
//! // - kin loads: 1 scalar + 2 tensors per item
//! // - kin stores: 2 scalars per item
//! // - corr: 1 scalar + 1 tensor per item; 2 scalars + 1 tensor per pair
//! // - second: 1 slope per item, when STAB == STAB_UPWIND and RECON
//! // - status: nothing
//! // - include rates_core
//! @compute @workgroup_size(256)
//! fn accel(...)
//! ```
//!
//! A row is `binding[ loads| stores]: amounts[, when conditions]`:
//! - the binding is a storage variable of the entry point; without `loads` or `stores` the
//!   row counts every direction the entry point uses it in (a read-modify-write twice),
//!   with one of them that direction alone, of a binding it reads and writes in other
//!   amounts ([`Part`]);
//! - amounts are `nothing` or `; `-separated `terms per item` and `terms per pair`, terms
//!   `+`-separated `N word` with word `scalar`, `vector` (DIM elements), `tensor` (DIM²),
//!   `slope` (a tensor and its DIM derivatives, (DIM + 1)·DIM²: the mixed methods'
//!   least-squares slopes of v and P) or `modulus` (a fourth-order tensor such as ∂P/∂F,
//!   DIM⁴), each in the singular or plural (`moduli`) ([`Words`]);
//! - conditions are ` and `-separated scene constants: `AV` holds where the constant is 1,
//!   `STAB == STAB_UPWIND` (or `!=`) where two constants, or a constant and a number, are
//!   equal (or not).
//!
//! A row `include name` stands for the rows of the block `// bytes block name:` elsewhere
//! in the composed source (its rows and prose are the `//` lines that follow it): rows
//! that several entry points share, written once in the file that holds their shared
//! code. The composed source names each file it holds on a line `// file: path`
//! ([`FILE`]), so that an error names the file, the entry point and the line.
//!
//! The model counts the compulsory traffic of a pass: every field of a particle it reads
//! or writes, once per item (an invocation: a particle, a ghost, a cell, a flat state
//! entry), whether the item's own or a neighbour's (a gather reads a neighbour's fields
//! from the cache after the first time), and every field indexed by a neighbour pair
//! (ids, gradients, offsets X_j − X_i) once per pair. Loads and stores of one field count
//! once each, a read-modify-write twice.

/// The line before each file of a composed source, followed by its path under `shaders/`.
pub const FILE: &str = "// file: ";
/// The first line of a model.
const HEADER: &str = "// bytes:";
/// The first line of a shared block, followed by its name and a colon.
const BLOCK: &str = "// bytes block ";
/// The start of a row.
const ROW: &str = "// - ";

/// Elements of a binding's array for one item or pair: scalars, DIM-vectors, DIM×DIM
/// tensors and slopes (a tensor and its DIM derivatives, (DIM + 1)·DIM² elements) and
/// moduli (a fourth-order tensor, DIM⁴ elements). An element's bytes are the array's
/// element type's, from the WGSL ([`BindingUse`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Words {
    pub scalars: u32,
    pub vectors: u32,
    pub tensors: u32,
    pub slopes: u32,
    pub moduli: u32,
}

impl Words {
    /// The elements of these words in dimension `dim`.
    pub const fn elements(self, dim: u32) -> u64 {
        let d2 = dim * dim;
        (self.scalars
            + self.vectors * dim
            + self.tensors * d2
            + self.slopes * (dim + 1) * d2
            + self.moduli * d2 * d2) as u64
    }

    /// `terms` (`2 vectors + 1 tensor`) added to these words.
    fn add(&mut self, terms: &str) -> Result<(), String> {
        for term in terms.split(" + ") {
            let (n, word) = term.trim().split_once(' ').ok_or_else(|| {
                format!("`{term}` is not `N word` (word: scalar, vector, tensor, slope, modulus)")
            })?;
            let n: u32 = n
                .parse()
                .map_err(|_| format!("`{n}` in `{term}` is not a count"))?;
            let slot = match word {
                "scalar" | "scalars" => &mut self.scalars,
                "vector" | "vectors" => &mut self.vectors,
                "tensor" | "tensors" => &mut self.tensors,
                "slope" | "slopes" => &mut self.slopes,
                "modulus" | "moduli" => &mut self.moduli,
                _ => {
                    return Err(format!(
                        "`{word}` is not a word (scalar, vector, tensor, slope, modulus, or \
                         their plurals)"
                    ));
                }
            };
            *slot += n;
        }
        Ok(())
    }
}

/// How a pass uses a binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    Read,
    Write,
    /// Read and written (a read-modify-write, or an atomic).
    ReadWrite,
}

impl Access {
    pub const fn reads(self) -> bool {
        matches!(self, Self::Read | Self::ReadWrite)
    }

    pub const fn writes(self) -> bool {
        matches!(self, Self::Write | Self::ReadWrite)
    }
}

/// How an entry point uses a storage binding, by naga's reflection of its WGSL: the
/// access, and the bytes of an element of its array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BindingUse {
    pub access: Access,
    pub element_bytes: u32,
}

/// The directions of a binding a [`Traffic`] counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Every direction the entry point uses it in (a read-modify-write twice).
    Used,
    /// Its loads alone (`loads`), of a binding the entry point reads and writes in other
    /// amounts.
    Loads,
    /// Its stores alone (`stores`), likewise.
    Stores,
}

/// One row of a model: a storage binding's traffic in a pass, elements per item and per
/// neighbour pair, counted once per direction of `part`, in the scene variants where
/// every condition of `when` holds. Whether the binding is read or written, and its
/// element type, are the WGSL's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Traffic {
    pub binding: String,
    pub part: Part,
    pub item: Words,
    pub pair: Words,
    pub when: Vec<String>,
    /// `file:line` of the row.
    pub at: String,
}

impl Traffic {
    /// The row `text` (after `// - `) at `at`.
    fn parse(text: &str, at: &str) -> Result<Self, String> {
        let (head, rest) = text
            .split_once(':')
            .ok_or("a row is `binding[ loads| stores]: amounts[, when conditions]`")?;
        let (binding, part) = match head.trim().split_once(' ') {
            None => (head.trim(), Part::Used),
            Some((b, "loads")) => (b, Part::Loads),
            Some((b, "stores")) => (b, Part::Stores),
            Some((_, other)) => {
                return Err(format!("`{other}` is not a part (loads, stores)"));
            }
        };
        if binding.is_empty() || !binding.chars().all(|c| c.is_alphanumeric() || c == '_') {
            return Err(format!("`{binding}` is not a binding name"));
        }
        let (amounts, when) = match rest.split_once(", when ") {
            Some((a, w)) => (a, w.split(" and ").map(|c| c.trim().to_string()).collect()),
            None => (rest, Vec::new()),
        };
        let (mut item, mut pair) = (Words::default(), Words::default());
        let amounts = amounts.trim();
        if amounts != "nothing" {
            for amount in amounts.split("; ") {
                let (terms, words) = if let Some(t) = amount.strip_suffix(" per item") {
                    (t, &mut item)
                } else if let Some(t) = amount.strip_suffix(" per pair") {
                    (t, &mut pair)
                } else {
                    return Err(format!(
                        "`{amount}` is neither `terms per item` nor `terms per pair` \
                         (or the row is `nothing`)"
                    ));
                };
                words.add(terms)?;
            }
        }
        Ok(Self {
            binding: binding.into(),
            part,
            item,
            pair,
            when,
            at: at.into(),
        })
    }

    /// The directions counted of a binding the entry point uses as `used`; Err: the
    /// entry point does not use it so.
    fn times(&self, entry: &str, used: Option<Access>) -> Result<u64, String> {
        let (at, binding) = (&self.at, &self.binding);
        let used = used.ok_or_else(|| {
            format!(
                "{at}: the bytes model of `{entry}` counts `{binding}`, a binding the entry \
                 point does not use"
            )
        })?;
        let (reads, writes) = match self.part {
            Part::Used => (used.reads(), used.writes()),
            Part::Loads => (true, false),
            Part::Stores => (false, true),
        };
        if (reads && !used.reads()) || (writes && !used.writes()) {
            return Err(format!(
                "{at}: the bytes model of `{entry}` counts the {} of `{binding}`, which the \
                 entry point does not make",
                if reads { "loads" } else { "stores" }
            ));
        }
        Ok(u64::from(reads) + u64::from(writes))
    }
}

/// The bytes model of one entry point: its storage bindings' traffic.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PassBytes {
    pub entry: String,
    pub traffic: Vec<Traffic>,
}

/// A pass's model in one compiled variant: bytes per item and per neighbour pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cost {
    pub item: u64,
    pub pair: u64,
}

impl PassBytes {
    /// The bytes per item and per pair in the variant whose scene constants `constant`
    /// gives by name (None: no such constant, or not an integer) and whose entry point
    /// uses each storage binding as `binding` gives by name (None: not at all);
    /// dimension from `DIM`. Err: a condition names no constant, or a row names a
    /// binding, or a direction of one, that the entry point does not use.
    pub fn cost(
        &self,
        constant: impl Fn(&str) -> Option<i64>,
        binding: impl Fn(&str) -> Option<BindingUse>,
    ) -> Result<Cost, String> {
        let dim = constant("DIM").ok_or("the pass has no constant DIM")? as u32;
        let value = |at: &str, side: &str| -> Result<i64, String> {
            let side = side.trim();
            side.parse::<i64>()
                .ok()
                .or_else(|| constant(side))
                .ok_or_else(|| {
                    format!(
                        "{at}: the bytes model of `{}` names `{side}`, not a constant",
                        self.entry
                    )
                })
        };
        let holds = |at: &str, condition: &str| -> Result<bool, String> {
            match condition.split_once("==") {
                Some((a, b)) => Ok(value(at, a)? == value(at, b)?),
                None => match condition.split_once("!=") {
                    Some((a, b)) => Ok(value(at, a)? != value(at, b)?),
                    None => Ok(value(at, condition)? == 1),
                },
            }
        };
        let mut cost = Cost { item: 0, pair: 0 };
        for t in &self.traffic {
            let used = binding(&t.binding);
            let times = t.times(&self.entry, used.map(|u| u.access))?;
            let mut counted = true;
            for condition in &t.when {
                counted &= holds(&t.at, condition)?;
            }
            if counted {
                let bytes = times * u64::from(used.map_or(0, |u| u.element_bytes));
                cost.item += bytes * t.item.elements(dim);
                cost.pair += bytes * t.pair.elements(dim);
            }
        }
        Ok(cost)
    }
}

/// A line of a composed source: its text and `file:line`.
struct Line<'a> {
    text: &'a str,
    at: String,
}

/// The lines of a composed source, each with the file ([`FILE`]) and line it comes from.
fn located(source: &str) -> Vec<Line<'_>> {
    let mut file = "the composed source";
    let mut number = 0;
    source
        .lines()
        .map(|text| {
            number += 1;
            if let Some(path) = text.strip_prefix(FILE) {
                file = path.trim();
                number = 0;
            }
            Line {
                text,
                at: format!("shaders/{file}:{number}"),
            }
        })
        .collect()
}

/// The name of the entry point declared from line `k` (`@compute … fn name(`), if it is
/// one.
fn entry_at(lines: &[Line], k: usize) -> Option<String> {
    if !lines[k].text.trim_start().starts_with("@compute") {
        return None;
    }
    let rest = lines[k..]
        .iter()
        .take(3)
        .map(|l| l.text)
        .collect::<Vec<_>>();
    let rest = rest.join(" ");
    let (_, after) = rest.split_once("fn ")?;
    let name: String = after
        .trim_start()
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    Some(name)
}

/// The bytes model of entry point `entry` of a composed pass: the model above its
/// `@compute`, None if there is none. Err (naming the file, the entry point and the line):
/// a malformed row, an unknown or nested include, or a model of this source that is
/// above no entry point.
pub fn pass_model(source: &str, entry: &str) -> Result<Option<PassBytes>, String> {
    let lines = located(source);
    let mut model = None;
    for (k, line) in lines.iter().enumerate() {
        if line.text.trim_end() != HEADER {
            continue;
        }
        let end = (k..lines.len())
            .find(|&l| !lines[l].text.starts_with("//"))
            .unwrap_or(lines.len());
        let Some(name) = (end < lines.len()).then(|| entry_at(&lines, end)).flatten() else {
            return Err(format!(
                "{}: a bytes model that is not directly above an `@compute` entry point",
                line.at
            ));
        };
        if name == entry {
            model = Some(PassBytes {
                entry: name,
                traffic: rows(&lines, k + 1..end, entry, true)?,
            });
        }
    }
    Ok(model)
}

/// The rows of lines `range` of a model of `entry`, with the blocks they include (where
/// `include` is allowed: not in a block).
fn rows(
    lines: &[Line],
    range: std::ops::Range<usize>,
    entry: &str,
    include: bool,
) -> Result<Vec<Traffic>, String> {
    let mut traffic = Vec::new();
    for line in &lines[range] {
        let Some(row) = line.text.strip_prefix(ROW) else {
            continue;
        };
        let error = |e: String| format!("{}: the bytes model of `{entry}`: {e}", line.at);
        match row.trim().strip_prefix("include ") {
            Some(name) if include => traffic.extend(block(lines, name.trim(), entry, &line.at)?),
            Some(_) => return Err(error("a block includes no other block".into())),
            None => traffic.push(Traffic::parse(row, &line.at).map_err(error)?),
        }
    }
    Ok(traffic)
}

/// The rows of the block `name` of the composed source, for a model of `entry` that
/// includes it at `at`.
fn block(lines: &[Line], name: &str, entry: &str, at: &str) -> Result<Vec<Traffic>, String> {
    let header = format!("{BLOCK}{name}:");
    let mut found = lines
        .iter()
        .enumerate()
        .filter(|(_, l)| l.text.trim_end() == header);
    let Some((k, _)) = found.next() else {
        return Err(format!(
            "{at}: the bytes model of `{entry}` includes `{name}`, but no line `{header}` \
             declares that block"
        ));
    };
    if let Some((_, again)) = found.next() {
        return Err(format!("{}: a second block `{name}`", again.at));
    }
    let end = (k + 1..lines.len())
        .find(|&l| !lines[l].text.starts_with("//"))
        .unwrap_or(lines.len());
    rows(lines, k + 1..end, entry, false)
}
