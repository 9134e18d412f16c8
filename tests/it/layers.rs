//! The layer order of `src/`: a module uses only modules declared below it, so that the
//! core and the physics read without the methods, the methods without the driver, and a
//! new method family touches its own folder and the registry. The test reads every
//! `crate::` path of the library's code (comments and unit-test modules left out) and
//! fails on any that points up the order, naming the files.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The folders of `src/` whose modules are each a module of [`ORDER`].
const GROUPS: &[&str] = &["core", "physics", "diagnostics"];

/// The modules from the bottom up, in layers. Within a layer too a module uses only the
/// ones before it. A module of `core/`, `physics/` and `diagnostics/` is a module of its
/// own (`core/kernel`), and so are a core of `methods/cores/` (`methods/cores/tl`) and a
/// `methods/<family>` folder; `methods` is the registry (`methods/mod.rs`).
const ORDER: &[(&str, &[&str])] = &[
    (
        "core maths, kernels and neighbours",
        &[
            "core/check",
            "core/tensor",
            "core/kernel",
            "core/neighbour",
            "core/hull",
            "core/neighbourhood",
            "core/correction",
            "core/quadrature",
            "core/integrate",
            "core/parallel",
            "core/sum",
        ],
    ),
    (
        "domain decomposition of the reference configuration",
        &["distributed"],
    ),
    (
        "physics",
        &[
            "physics/mooney_rivlin",
            "physics/plasticity",
            "physics/material",
            "physics/pressure",
            "physics/viscosity",
            "physics/hourglass",
            "physics/mirror",
            "diagnostics/analytic",
            "diagnostics/balance",
        ],
    ),
    (
        "the case: its schema and the sampling of its bodies",
        &["case"],
    ),
    (
        "reference state, observers, GPU machinery, loads and contact",
        &[
            "diagnostics/passes",
            "boundary",
            "reference",
            "diagnostics/observe",
            "gpu",
            "interaction",
        ],
    ),
    (
        "engine contracts and the static solver",
        &["engine", "statics"],
    ),
    (
        "method cores",
        &[
            "methods/cores/family",
            "methods/cores/shared",
            "methods/cores/particles",
            "methods/cores/tl",
            "methods/cores/ul",
            "methods/cores/galerkin",
        ],
    ),
    (
        "method families",
        &[
            "methods/tlsph",
            "methods/potential",
            "methods/corotated",
            "methods/dual_support",
            "methods/gray_monaghan",
            "methods/godunov",
            "methods/mixed",
            "methods/weak_form",
            "methods/fem",
            "methods/ul_weak_form",
            "methods/ul_fem",
            "methods/kbm",
            "methods/efg",
        ],
    ),
    (
        "registry, case files, output, driver, benchmarks and studies",
        &["methods", "scene", "output", "run", "bench", "study"],
    ),
];

/// The module a file of `src/` belongs to, or None for the crate roots, the `mod.rs`
/// files that only declare a folder's modules, and unit-test files.
fn module_of(file: &Path, src: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).ok()?;
    let parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    match parts.as_slice() {
        [root] if root == "lib" || root == "main" => None,
        [.., last] if last == "tests" => None,
        [group, last] if GROUPS.contains(&group.as_str()) && last == "mod" => None,
        [group, module, ..] if GROUPS.contains(&group.as_str()) => {
            Some(format!("{group}/{module}"))
        }
        [methods, cores, last] if methods == "methods" && cores == "cores" && last == "mod" => None,
        [methods, cores, core, ..] if methods == "methods" && cores == "cores" => {
            Some(format!("methods/cores/{core}"))
        }
        [methods, family, ..] if methods == "methods" && family != "mod" => {
            Some(format!("methods/{family}"))
        }
        [first, ..] => Some(first.clone()),
        [] => None,
    }
}

/// The code of a file without its comments and its unit-test module.
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines()
        .map(|line| match line.find("//") {
            Some(i) => &line[..i],
            None => line,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The first three segments of every path that starts with `crate::` in `code` (empty
/// where the path is shorter), with the groups of a `use crate::{a::b, c::{d, e}}` spread
/// out.
fn crate_paths(code: &str) -> Vec<[String; 3]> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        tree(rest, &[], &mut out);
    }
    out
}

/// Reads one use-tree at the start of `text` under the segments `prefix`: an identifier
/// followed by `::` and a tree, or a brace group of trees.
fn tree(text: &str, prefix: &[String], out: &mut Vec<[String; 3]>) {
    let text = text.trim_start();
    if let Some(group) = text.strip_prefix('{') {
        let mut depth = 0;
        let mut start = 0;
        for (i, c) in group.char_indices() {
            match c {
                '{' => depth += 1,
                '}' if depth == 0 => {
                    tree(&group[start..i], prefix, out);
                    return;
                }
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    tree(&group[start..i], prefix, out);
                    start = i + 1;
                }
                _ => {}
            }
        }
        return;
    }
    let end = text
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(text.len());
    let ident = &text[..end];
    if ident.is_empty() || ident == "self" {
        if !prefix.is_empty() {
            out.push(padded(prefix));
        }
        return;
    }
    let mut path = prefix.to_vec();
    path.push(ident.to_string());
    if path.len() == 3 {
        out.push(padded(&path));
        return;
    }
    match text[end..].trim_start().strip_prefix("::") {
        Some(next) => tree(next, &path, out),
        None => out.push(padded(&path)),
    }
}

/// Up to three segments, padded with empty ones.
fn padded(path: &[String]) -> [String; 3] {
    std::array::from_fn(|i| path.get(i).cloned().unwrap_or_default())
}

/// The module a path's first segments name: `core/kernel` and the like,
/// `methods/cores/<core>`, `methods/<family>` where that is a module, else the first
/// segment.
fn target(path: &[String; 3], modules: &BTreeSet<String>) -> String {
    if GROUPS.contains(&path[0].as_str()) {
        return format!("{}/{}", path[0], path[1]);
    }
    if path[0] == "methods" && path[1] == "cores" {
        return format!("methods/cores/{}", path[2]);
    }
    let family = format!("methods/{}", path[1]);
    if path[0] == "methods" && modules.contains(&family) {
        family
    } else {
        path[0].clone()
    }
}

/// The rank of every module in [`ORDER`].
fn ranks() -> BTreeMap<&'static str, usize> {
    let all = ORDER
        .iter()
        .flat_map(|(_, modules)| modules.iter().copied());
    all.enumerate().map(|(i, m)| (m, i)).collect()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The imports against the order in `files` (module and code): (from, to) → the files.
fn upward_imports(
    files: &[(String, String, String)],
    ranks: &BTreeMap<&'static str, usize>,
) -> BTreeMap<(String, String), BTreeSet<String>> {
    let modules: BTreeSet<String> = files.iter().map(|(m, _, _)| m.clone()).collect();
    let mut found: BTreeMap<(String, String), BTreeSet<String>> = BTreeMap::new();
    for (from, name, code) in files {
        for path in crate_paths(code) {
            let to = target(&path, &modules);
            let (Some(&a), Some(&b)) = (ranks.get(from.as_str()), ranks.get(to.as_str())) else {
                continue;
            };
            if b > a {
                found
                    .entry((from.clone(), to))
                    .or_default()
                    .insert(name.clone());
            }
        }
    }
    found
}

/// Every library file of `src/`: (module, file name, code).
fn library() -> Vec<(String, String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    files
        .iter()
        .filter_map(|f| {
            let module = module_of(f, &src)?;
            let name = f.strip_prefix(&src).unwrap().display().to_string();
            Some((module, name, code(&std::fs::read_to_string(f).unwrap())))
        })
        .collect()
}

#[test]
fn every_module_has_its_place_in_the_order() {
    let ranks = ranks();
    assert_eq!(
        ranks.len(),
        ORDER.iter().map(|(_, m)| m.len()).sum::<usize>(),
        "a module is declared twice"
    );
    let modules: BTreeSet<String> = library().into_iter().map(|(m, _, _)| m).collect();
    let placed: BTreeSet<String> = ranks.keys().map(|m| m.to_string()).collect();
    let unplaced: Vec<_> = modules.difference(&placed).collect();
    let gone: Vec<_> = placed.difference(&modules).collect();
    assert!(
        unplaced.is_empty() && gone.is_empty(),
        "modules without a place in ORDER: {unplaced:?}; places without a module: {gone:?}"
    );
}

#[test]
fn modules_import_only_down_the_order() {
    let upward: Vec<String> = upward_imports(&library(), &ranks())
        .iter()
        .map(|((a, b), files)| format!("{a} → {b} ({files:?})"))
        .collect();
    assert!(
        upward.is_empty(),
        "imports against the layer order (tests/it/layers.rs, ORDER): {upward:#?}"
    );
}

#[test]
fn a_planted_upward_import_is_found() {
    // The checker itself: the kernel using the driver, in each form a path takes, is
    // found; its use of the tensors below it is not.
    let ranks = ranks();
    for text in [
        "use crate::run::Engine;",
        "use crate::{core::tensor::Dim, run::{Engine, drive}};",
        "fn f() { crate::run::drive(); }",
        "use crate::{\n    core::tensor::Dim,\n    run::Engine,\n};",
    ] {
        let files = [(kernel(), "core/kernel.rs".to_string(), code(text))];
        let found = upward_imports(&files, &ranks);
        let edges: Vec<_> = found.keys().collect();
        assert_eq!(edges, [&(kernel(), "run".to_string())], "{text}");
    }
    // A core using a family, beside a use of a core below it, is found too (the family
    // is a module of the library: it has a file).
    for text in [
        "use crate::methods::tlsph::TlsphSpec;",
        "use crate::methods::{cores::shared, tlsph::TlsphSpec};",
    ] {
        let files = [
            (core(), "methods/cores/tl/mod.rs".to_string(), code(text)),
            (
                "methods/tlsph".to_string(),
                "methods/tlsph/mod.rs".to_string(),
                String::new(),
            ),
        ];
        let found = upward_imports(&files, &ranks);
        let edges: Vec<_> = found.keys().collect();
        assert_eq!(edges, [&(core(), "methods/tlsph".to_string())], "{text}");
    }
    let comment = code("// see crate::run::drive\nuse crate::core::tensor::Dim;");
    let files = [(kernel(), "core/kernel.rs".to_string(), comment)];
    assert!(upward_imports(&files, &ranks).is_empty());
}

/// The module of the kernel, in the planted imports.
fn kernel() -> String {
    "core/kernel".to_string()
}

/// The module of the total-Lagrangian core, in the planted imports.
fn core() -> String {
    "methods/cores/tl".to_string()
}
