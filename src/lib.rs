//! meshless: particle methods for solids under very large deformation.
//!
//! The CPU path (rayon, f64) is the reference implementation of every method. Cargo
//! features: `gpu` (the wgpu/WGSL backend), `study` (`meshless study`: suites, plots,
//! the report) and `cli` (the command line); all on by default, and the library without
//! them is the CPU path alone.

#![deny(clippy::too_many_lines)]

pub mod bench;
pub mod boundary;
pub mod case;
pub mod core;
pub mod diagnostics;
pub mod distributed;
pub mod engine;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod interaction;
pub mod methods;
pub mod output;
pub mod physics;
pub mod reference;
pub mod run;
pub mod scene;
pub mod statics;
#[cfg(feature = "study")]
pub mod study;
