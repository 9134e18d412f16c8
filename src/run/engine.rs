//! The factory that builds a case's engine ([`crate::engine::Engine`]) through its
//! method's spec, on the backend the run asks for.

use super::{Backend, RunError};
use crate::engine::{Engine, EngineDim};
#[cfg(feature = "gpu")]
use crate::gpu::{Gpu, SetupError};
use crate::scene::Scene;

/// The engine a case runs on: the GPU when `backend` asks for it (or `auto` finds an
/// adapter and the method has a GPU engine), the CPU otherwise; the method's spec builds
/// them. A static run (`run.solve = "static"`) is on the CPU only.
pub fn engine<D: EngineDim>(
    case: &Scene,
    backend: Backend,
) -> Result<Box<dyn Engine<D>>, RunError> {
    let spec = &case.spec;
    let backend = match (backend, super::cpu_only(case)) {
        (Backend::Gpu, Some(why)) => {
            return Err(RunError::Backend(format!(
                "{}: {why}; use --backend cpu (--backend auto picks the CPU for it)",
                case.file.display()
            )));
        }
        (Backend::Auto, Some(why)) => {
            eprintln!("note: --backend auto: {why}; running on the CPU (rayon, f64)");
            Backend::Cpu
        }
        (backend, _) => backend,
    };
    match gpu(backend)? {
        #[cfg(feature = "gpu")]
        Some(gpu) => spec.gpu_engine::<D>(case, gpu).map_err(|e| match e {
            SetupError::Case(c) => RunError::Case(c),
            SetupError::Gpu(g) => RunError::Backend(g.to_string()),
        }),
        _ => Ok(spec.cpu_engine::<D>(case)?),
    }
}

/// The GPU a backend choice asks for: none for `cpu`, an error for `gpu` without an
/// adapter, and for `auto` the adapter [`crate::gpu::context::auto_adapter`] picks.
#[cfg(feature = "gpu")]
fn gpu(backend: Backend) -> Result<Option<Gpu>, RunError> {
    Ok(match backend {
        Backend::Cpu => None,
        Backend::Gpu => Some(Gpu::new().map_err(|e| RunError::Backend(e.to_string()))?),
        Backend::Auto => {
            // A malformed setting is the user's to mend, whichever backend runs.
            crate::gpu::context::binding_env().map_err(|e| RunError::Backend(e.to_string()))?;
            match crate::gpu::context::auto_adapter() {
                Ok(_) => Gpu::new()
                    .inspect_err(|e| eprintln!("note: {e}; running on the CPU (rayon, f64)"))
                    .ok(),
                Err(why) => {
                    eprintln!("note: --backend auto: {why}; running on the CPU (rayon, f64)");
                    None
                }
            }
        }
    })
}

/// Without the GPU backend: the CPU for `cpu` and `auto`, an error for `gpu`.
#[cfg(not(feature = "gpu"))]
fn gpu(backend: Backend) -> Result<Option<std::convert::Infallible>, RunError> {
    match backend {
        Backend::Gpu => Err(RunError::Backend(
            "this build has no GPU backend (cargo feature `gpu`); use --backend cpu".into(),
        )),
        Backend::Cpu | Backend::Auto => Ok(None),
    }
}
