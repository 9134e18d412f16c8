//! The build's identity, for the study records (docs/studies.md, "Staleness"): the commit
//! it was built from (`MESHLESS_COMMIT`, "unknown" outside a git checkout) and a hash of
//! the solver's sources (`MESHLESS_SOLVER`): every file under `src/` but the studies and the
//! command line, the shaders and `Cargo.lock`, FNV-1a over their paths and contents in
//! path order. Two builds with the same hash compute the same results.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The files below `dir`, recursively.
fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            files(&path, out);
        } else {
            out.push(path);
        }
    }
}

fn main() {
    for watched in ["src", "shaders", "Cargo.lock", ".git/HEAD", ".git/refs"] {
        // A path that does not exist would rerun this script at every build.
        if Path::new(watched).exists() {
            println!("cargo:rerun-if-changed={watched}");
        }
    }
    let mut paths = Vec::new();
    files(Path::new("src"), &mut paths);
    files(Path::new("shaders"), &mut paths);
    paths.push(PathBuf::from("Cargo.lock"));
    paths.retain(|p| !p.starts_with("src/study") && p != Path::new("src/main.rs"));
    paths.sort();
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for path in &paths {
        let name = path.to_string_lossy().replace('\\', "/");
        let text = std::fs::read(path).unwrap_or_default();
        for byte in name.bytes().chain([0]).chain(text) {
            hash = (hash ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    println!("cargo:rustc-env=MESHLESS_SOLVER={hash:016x}");
    let commit = Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=MESHLESS_COMMIT={commit}");
}
