//! Integration tests of `meshless`, one module per subject, built as one test binary.
//!
//! The CPU modules check the methods, whole runs, case files and the study runner against
//! exact solutions and invariants; the GPU modules validate the WGSL passes with naga and
//! compare them against the f64 CPU reference on whatever adapter wgpu finds (CI installs
//! Mesa's lavapipe). A GPU test without an adapter fails: it does not skip. The helpers
//! the modules share are in `common`. Modules and tests that need the `gpu` or `study`
//! feature are compiled only with it (both are on by default).

mod body_force;
mod case_errors;
mod checkpoint;
mod common;
mod compressibility;
mod contact;
mod corotated_tlsph;
mod distributed;
mod dual_support;
mod dual_support_cases;
mod energy_balance;
#[path = "../support/frames.rs"]
mod frames;
mod free_surface;
mod fuzz;
mod galerkin;
mod godunov;
#[cfg(feature = "gpu")]
mod gpu_dual_support;
#[cfg(feature = "gpu")]
mod gpu_eulerian_kbm;
#[cfg(feature = "gpu")]
mod gpu_galerkin;
#[cfg(feature = "gpu")]
mod gpu_materials;
#[cfg(feature = "gpu")]
mod gpu_mixed;
#[cfg(feature = "gpu")]
mod gpu_neighbours;
#[cfg(feature = "gpu")]
mod gpu_parts;
#[cfg(feature = "gpu")]
mod gpu_profile;
#[cfg(feature = "gpu")]
mod gpu_tlsph;
#[cfg(feature = "gpu")]
mod gpu_ul;
#[cfg(feature = "gpu")]
mod gpu_ul_galerkin;
#[cfg(feature = "gpu")]
mod gpu_ul_weak_form;
mod gradients_1d;
mod gray_monaghan;
mod hostile;
mod hourglass_control;
mod implicit;
mod initial_fields;
mod kbm_efg;
mod layers;
mod loads;
mod mesh_input;
#[cfg(feature = "study")]
mod mixed;
#[cfg(feature = "study")]
mod neighbourhoods;
#[cfg(feature = "gpu")]
mod objective_rates;
#[cfg(feature = "study")]
mod perforated_block;
mod reactions;
mod registry;
mod runs;
mod scni;
mod seed000_disk;
mod seed000_strip;
mod seed001_cantilever;
mod seed001_pulse;
mod seed001_ring;
mod seed001_rod;
mod seed001_steel_ring;
#[cfg(feature = "gpu")]
mod shaders;
mod shapes;
mod static_tolerance;
mod stent;
#[cfg(feature = "study")]
mod study;
mod supg;
mod timed_velocity;
mod tl_potential;
mod tlsph;
mod ul_galerkin;
mod ul_plasticity;
mod verification;
