//! meshless: particle methods for solids under very large deformation.
//!
//! The CPU path (rayon, f64) is the reference implementation of every method.

pub mod analytic;
pub mod bench;
pub mod boundary;
pub mod contact;
pub mod correction;
pub mod gpu;
pub mod hourglass;
pub mod integrate;
pub mod kernel;
pub mod material;
pub mod method;
pub mod mirror;
pub mod neighbour;
pub mod observe;
pub mod output;
pub mod plasticity;
pub mod run;
pub mod scene;
pub mod study;
pub mod tensor;
