//! The cores the method families are built on: the total-Lagrangian particle
//! core ([`tl`], with its GPU engine), the updated-Lagrangian one ([`ul`]), the
//! Galerkin one ([`galerkin`]), the hooks a family implements ([`family`]) and the
//! pieces the particle methods share ([`shared`], [`particles`]). A core imports no
//! family (`tests/it/layers.rs`).

pub mod family;
pub mod galerkin;
pub mod particles;
pub mod shared;
pub mod tl;
pub mod ul;
