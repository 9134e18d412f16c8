//! The core: the vocabulary of checks, small tensors, smoothing kernels, neighbour
//! lists, kernel corrections, quadrature points, deterministic parallel loops, exact sums
//! and the explicit time integrators. It knows no material, case, method or device: every
//! other layer builds on it (`tests/it/layers.rs`).

pub mod check;
pub mod correction;
pub mod hull;
pub mod integrate;
pub mod kernel;
pub mod neighbour;
pub mod neighbourhood;
pub mod parallel;
pub mod quadrature;
pub mod sum;
pub mod tensor;
