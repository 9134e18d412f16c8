#!/usr/bin/env bash
# The whole test suite: formatting, lints, then every test in release mode (the numerical
# tests integrate thousands of steps and are written for optimised builds).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo fmt --all -- --check
cargo clippy --release --all-targets -- -D warnings
cargo test --release
