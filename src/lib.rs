//! meshless: particle methods for solids under very large deformation.
//!
//! The CPU path (rayon, f64) is the reference implementation of every method. Cargo
//! features: `gpu` (the wgpu/WGSL backend), `study` (`meshless study`: suites, plots,
//! the report) and `cli` (the command line); all on by default, and the library without
//! them is the CPU path alone.

#![deny(clippy::too_many_lines)]

pub mod analytic;
pub mod balance;
pub mod bench;
pub mod boundary;
pub mod case;
pub mod check;
pub mod correction;
pub mod engine;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod hourglass;
pub mod integrate;
pub mod interaction;
pub mod kernel;
pub mod material;
pub mod methods;
pub mod mirror;
pub mod mooney_rivlin;
pub mod neighbour;
pub mod observe;
pub mod output;
pub mod parallel;
pub mod passes;
pub mod plasticity;
pub mod pressure;
pub mod quadrature;
pub mod reference;
pub mod run;
pub mod scene;
pub mod statics;
#[cfg(feature = "study")]
pub mod study;
pub mod tensor;
pub mod viscosity;
