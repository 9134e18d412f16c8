//! Case files: loading `cases/*.toml` with `--set` overrides, and validation.
//!
//! A case is parsed completely and validated before anything runs; every error names
//! the file, the key and what is allowed. The schema the file is read into is
//! [`crate::case`]; this module adds what needs the method registry: `load` reads a file,
//! applies the overrides of `overrides` and parts the `[method]` table into the keys the
//! case keeps and the method's typed spec, which the [`Scene`] holds beside the case;
//! `validate` checks the result, each method its own keys.

mod load;
mod overrides;
pub(crate) mod validate;

use crate::case::{Case, CaseError, fnv1a};
use crate::core::tensor::Dim;
use crate::engine::{CpuEngine, Method};
use crate::methods::{MethodSpec, MethodTable, Runs};
use crate::reference::Build;
use std::ops::{Deref, DerefMut};

/// A loaded case with its method's typed spec: what the driver holds. It dereferences to
/// the [`Case`] every layer reads; the spec reaches the method's hooks through the
/// registry ([`MethodSpec`]).
#[derive(Clone, Debug)]
pub struct Scene {
    pub case: Case,
    /// The method's own keys, typed.
    pub spec: MethodSpec,
    /// Keys of other methods found in the `[method]` table (well-typed for those
    /// methods), which validation reports with the methods that read them.
    pub foreign: Vec<String>,
}

impl Scene {
    /// The scene of a case read with the registry's `[method]` table.
    fn new(case: Case<MethodTable>) -> Self {
        let keys = case.method.keys.clone();
        let (case, table) = case.with_method(keys);
        Self {
            case,
            spec: table.spec,
            foreign: table.foreign,
        }
    }

    /// The case with its whole `[method]` table, the method's own keys with the common
    /// ones, as the run's summary records it.
    pub fn resolved(&self) -> Case<MethodTable> {
        let table = MethodTable {
            keys: self.case.method.clone(),
            spec: self.spec.clone(),
            foreign: Vec::new(),
        };
        self.case.clone().with_method(table).0
    }

    /// A hash of everything in the case (the method's keys with it) but its end time: a
    /// checkpoint of a run of this case, or of the same case run longer, has it.
    pub fn fingerprint(&self) -> u64 {
        let mut case = self.resolved();
        case.run.end_time = 0.0;
        fnv1a(toml::to_string(&case).unwrap_or_default().as_bytes())
    }

    /// The p-wave speed that sets the CFL step: the material's, or that of the method's
    /// own (a mixed method's artificial compressibility).
    pub fn step_wave_speed(&self) -> f64 {
        self.spec
            .step_wave_speed(&crate::physics::material::Material::new(&self.material))
    }
}

impl Deref for Scene {
    type Target = Case;
    fn deref(&self) -> &Case {
        &self.case
    }
}

impl DerefMut for Scene {
    fn deref_mut(&mut self) -> &mut Case {
        &mut self.case
    }
}

/// Builds the CPU system `M` of a scene's method on its reference configuration; an
/// error if the method does not run `M`.
pub fn build_method<D: Dim, M: Build<D>>(scene: &Scene) -> Result<M, CaseError>
where
    M::Spec: Runs,
{
    let spec = M::Spec::spec_of(&scene.spec).ok_or_else(|| {
        scene.invalid(
            "method.name",
            format!(
                "{} does not run `{}`",
                std::any::type_name::<M>(),
                scene.method.name
            ),
        )
    })?;
    crate::reference::build_method::<D, M>(scene, spec)
}

/// The CPU engine of the system `M` of a scene's method, stepped by the case's
/// integrator; an error if the method does not run `M`.
pub fn cpu_engine<D: Dim, M: Method<D> + Build<D>>(
    scene: &Scene,
) -> Result<CpuEngine<D, M>, CaseError>
where
    M::Spec: Runs,
{
    Ok(CpuEngine::with(
        build_method(scene)?,
        scene.method.integrator,
    ))
}
