//! What a run is checked and reported by: the closed-form solutions of the cases,
//! the energy balance, the observers of the time series and the GPU pass report.

pub mod analytic;
pub mod balance;
pub mod observe;
pub mod passes;
