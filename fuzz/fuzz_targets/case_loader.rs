//! Any bytes as a case file: parsed, validated, estimated and built on the CPU as
//! `meshless check` does, with at most 2,000 particles (a larger case is refused, as
//! `--max-particles 2000` would). It may be refused; it must not panic, hang or run
//! out of memory. Seed it with the shipped cases (README.md, "Fuzzing").
#![no_main]

use libfuzzer_sys::fuzz_target;
use meshless::run::{Backend, Limits, check};
use meshless::scene::Scene;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let limits = Limits {
        max_particles: 2000.0,
        max_steps: Limits::MAX_STEPS,
    };
    if let Ok(case) = Scene::from_toml(text, Path::new("fuzz/case.toml"), &[]) {
        let _ = check(&case, Backend::Cpu, &limits);
    }
});
