//! Particle methods, one folder each, and the registry the driver reaches them through.
//!
//! A method is its typed spec (the keys of the case's `[method]` table that it reads, with
//! its defaults), a [`MethodFamily`] implementation on that spec (validation, the
//! `--explain` plan, the CPU and GPU engines, blow-up attribution), its CPU system and its
//! GPU engine. The driver, the command line, validation, benchmarks and studies go through
//! [`MethodSpec`] and [`REGISTRY`] and never name a method: adding one is a folder here
//! and one line in [`registry!`]. A family implements the hooks of [`cores::family`] and imports
//! nothing from this file; the registry hands each hook its typed spec, and [`Runs`]
//! finds a system's spec in a case's method.

pub mod cores;
pub mod corotated;
pub mod dual_support;
pub mod efg;
pub mod fem;
pub mod godunov;
pub mod gray_monaghan;
pub mod kbm;
pub mod mixed;
pub mod potential;
pub mod tlsph;
pub mod ul_fem;
pub mod ul_weak_form;
pub mod weak_form;

pub use crate::engine::{BlowUp, Method};
#[cfg(feature = "gpu")]
pub use cores::family::GpuBuild;
pub use cores::family::{
    COMMON_KEYS, CpuBuild, Feature, KERNEL_KEYS, MethodFamily, Plan, cfl_step, state_model,
};

use crate::case::{Case, CaseError, MethodKeys};
use crate::core::check::Problem;
use crate::core::correction::CorrectionKind;
use crate::core::integrate::IntegratorKind;
use crate::core::kernel::KernelKind;
use crate::core::neighbour::Rebuild;
use crate::core::tensor::Dim;
use crate::engine::{Engine, EngineDim};
use crate::physics::material::Material;
use serde::de::{self, DeserializeSeed, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt;
use std::sync::OnceLock;
use toml::{Table, Value};

/// A method as listed: its name and what its spec declares.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// The name in case files, `meshless list`, summaries and docs.
    pub name: &'static str,
    pub description: &'static str,
    pub keys: &'static [&'static str],
    pub features: &'static [Feature],
    /// When the method's neighbour lists are built.
    pub neighbours: Rebuild,
    /// Whether it reads the kernel keys ([`KERNEL_KEYS`]).
    pub kernel: bool,
    /// Whether it reads `correction` among them.
    pub corrected: bool,
    /// The ghost layers a rank of a distributed run needs; none for a method that does
    /// not run on several ranks ([`MethodFamily::HALO_LAYERS`]).
    pub halo_layers: Option<usize>,
    #[cfg(feature = "gpu")]
    pub shaders: &'static [crate::gpu::shaders::Source],
}

impl Entry {
    const fn of<S: MethodFamily>(name: &'static str) -> Self {
        Self {
            name,
            description: S::DESCRIPTION,
            keys: S::KEYS,
            features: S::FEATURES,
            neighbours: S::NEIGHBOURS,
            kernel: S::KERNEL,
            corrected: S::KERNEL && S::CORRECTED,
            halo_layers: S::HALO_LAYERS,
            #[cfg(feature = "gpu")]
            shaders: S::SHADERS,
        }
    }

    /// Whether the method reads `key` of the `[method]` table.
    pub fn reads(&self, key: &str) -> bool {
        key == "name" || self.reads_common(key) || self.keys.contains(&key)
    }

    /// Whether the method reads `key`, one of the [`COMMON_KEYS`].
    fn reads_common(&self, key: &str) -> bool {
        match key {
            "correction" => self.corrected,
            _ => COMMON_KEYS.contains(&key) && (self.kernel || !KERNEL_KEYS.contains(&key)),
        }
    }
}

/// The methods: one line each, `"case-file name" => Variant(spec type)`.
macro_rules! registry {
    ($($name:literal => $variant:ident($spec:ty)),* $(,)?) => {
        /// The method of a case with its own keys, tagged by `name` in case files.
        #[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
        #[serde(tag = "name")]
        pub enum MethodSpec {
            $(#[serde(rename = $name)] $variant($spec)),*
        }

        /// Every method, in the order `meshless list` shows them.
        pub static REGISTRY: &[Entry] = &[$(Entry::of::<$spec>($name)),*];

        /// The case-file names of the methods.
        const NAMES: &[&str] = &[$($name),*];

        impl MethodSpec {
            /// The registry entry of this method.
            pub fn entry(&self) -> &'static Entry {
                let name = match self {
                    $(Self::$variant(_) => $name),*
                };
                entry(name).expect("every spec is registered")
            }

            pub fn validate(&self, case: &Case) -> Result<(), Problem> {
                match self {
                    $(Self::$variant(s) => s.validate(case)),*
                }
            }

            pub fn plan(&self, case: &Case, gpu: bool) -> Plan {
                match self {
                    $(Self::$variant(s) => s.plan(case, gpu)),*
                }
            }

            pub fn cpu_engine<D: EngineDim>(
                &self,
                case: &Case,
            ) -> Result<Box<dyn Engine<D>>, CaseError> {
                match self {
                    $(Self::$variant(s) => s.cpu_engine::<D>(case)),*
                }
            }

            pub fn rank_engine<D: EngineDim>(
                &self,
                case: &Case,
                reference: crate::reference::Reference<D>,
                start: crate::engine::ranks::RankStart<D>,
            ) -> crate::methods::cores::family::RankBuild<D> {
                match self {
                    $(Self::$variant(s) => s.rank_engine::<D>(case, reference, start)),*
                }
            }

            #[cfg(feature = "gpu")]
            pub fn gpu_engine<D: EngineDim>(
                &self,
                case: &Case,
                gpu: crate::gpu::Gpu,
            ) -> Result<Box<dyn Engine<D>>, crate::gpu::SetupError> {
                match self {
                    $(Self::$variant(s) => s.gpu_engine::<D>(case, gpu)),*
                }
            }

            #[cfg(feature = "gpu")]
            pub fn device_memory<D: EngineDim>(
                &self,
                case: &Case,
                counts: &crate::gpu::memory::Counts,
            ) -> Option<crate::gpu::memory::DeviceMemory> {
                match self {
                    $(Self::$variant(s) => s.device_memory::<D>(case, counts)),*
                }
            }

            pub fn gpu_refusal(&self, case: &Case) -> Option<&'static str> {
                match self {
                    $(Self::$variant(s) => s.gpu_refusal(case)),*
                }
            }

            pub fn smoothing_lengths<D: Dim>(
                &self,
                case: &Case,
                reference: &crate::reference::Reference<D>,
            ) -> Result<Option<Vec<f64>>, CaseError> {
                match self {
                    $(Self::$variant(s) => s.smoothing_lengths::<D>(case, reference)),*
                }
            }

            pub fn searches_current_configuration(&self) -> bool {
                match self {
                    $(Self::$variant(s) => s.searches_current_configuration()),*
                }
            }

            pub fn stretch_signal_speed<D: Dim>(&self, c_p: f64, f: D::T) -> f64 {
                match self {
                    $(Self::$variant(s) => s.stretch_signal_speed::<D>(c_p, f)),*
                }
            }

            pub fn lattice_cells(&self) -> bool {
                match self {
                    $(Self::$variant(s) => s.lattice_cells()),*
                }
            }

            pub fn warning(&self, case: &Case) -> Option<String> {
                match self {
                    $(Self::$variant(s) => s.warning(case)),*
                }
            }

            pub fn step_wave_speed(&self, mat: &Material) -> f64 {
                match self {
                    $(Self::$variant(s) => s.step_wave_speed(mat)),*
                }
            }

            pub fn accepts_incompressible(&self) -> bool {
                match self {
                    $(Self::$variant(s) => s.accepts_incompressible()),*
                }
            }
        }

        $(impl Runs for $spec {
            fn spec_of(method: &MethodSpec) -> Option<&Self> {
                match method {
                    MethodSpec::$variant(s) => Some(s),
                    _ => None,
                }
            }
        })*
    };
}

registry! {
    "tlsph" => Tlsph(tlsph::TlsphSpec),
    "upwind-sph" => UpwindSph(mixed::UpwindSpec),
    "jst-sph" => JstSph(mixed::JstSpec),
    "supg-sph" => SupgSph(mixed::SupgSpec),
    "tl-potential" => TlPotential(potential::PotentialSpec),
    "corotated-tlsph" => CorotatedTlsph(corotated::CorotatedSpec),
    "gray-monaghan-sph" => GrayMonaghanSph(gray_monaghan::GrayMonaghanSpec),
    "godunov-sph" => GodunovSph(godunov::GodunovSpec),
    "dual-support-sph" => DualSupportSph(dual_support::DualSupportSpec),
    "tl-weak-form" => TlWeakForm(weak_form::WeakFormSpec),
    "tl-fem" => TlFem(fem::FemSpec),
    "ul-weak-form" => UlWeakForm(ul_weak_form::UlWeakFormSpec),
    "ul-fem" => UlFem(ul_fem::UlFemSpec),
    "kbm" => Kbm(kbm::KbmSpec),
    "efg" => Efg(efg::EfgSpec),
}

/// The registry entry of a case-file method name.
pub fn entry(name: &str) -> Option<&'static Entry> {
    REGISTRY.iter().find(|e| e.name == name)
}

/// Every GPU pass file: the shared ones and each method's, once each.
#[cfg(feature = "gpu")]
pub fn shaders() -> Vec<crate::gpu::shaders::Source> {
    let mut all = crate::gpu::shaders::SHARED.to_vec();
    for source in REGISTRY.iter().flat_map(|e| e.shaders) {
        if !all.contains(source) {
            all.push(*source);
        }
    }
    all
}

/// `a`, `b` and `c`: method names as a message lists them.
pub fn quoted(names: impl IntoIterator<Item = &'static str>) -> String {
    names
        .into_iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The methods that run a scene feature.
pub fn supporting(feature: Feature) -> impl Iterator<Item = &'static str> {
    REGISTRY
        .iter()
        .filter(move |e| e.features.contains(&feature))
        .map(|e| e.name)
}

/// The `[method]` table of a case: the keys every method reads, and the method's spec.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct MethodTable {
    /// The common keys, with what the registry resolves of the method for the layers
    /// below it.
    #[serde(flatten)]
    pub keys: MethodKeys,
    #[serde(flatten)]
    pub spec: MethodSpec,
    /// Keys of other methods found in the table (well-typed for those methods), which
    /// validation reports with the methods that read them.
    #[serde(skip)]
    pub foreign: Vec<String>,
}

/// The spec a system is built from ([`crate::reference::Build::Spec`]), as a case's
/// method holds it.
pub trait Runs {
    /// The spec in `method`, or None for a method that does not run the system.
    fn spec_of(method: &MethodSpec) -> Option<&Self>;
}

impl Runs for dyn mixed::MixedScheme {
    fn spec_of(method: &MethodSpec) -> Option<&Self> {
        match method {
            MethodSpec::UpwindSph(s) => Some(s),
            MethodSpec::JstSph(s) => Some(s),
            MethodSpec::SupgSph(s) => Some(s),
            _ => None,
        }
    }
}

impl<D: Dim> Runs for dyn cores::galerkin::TlSystem<D> {
    fn spec_of(method: &MethodSpec) -> Option<&Self> {
        match method {
            MethodSpec::TlFem(s) => Some(s),
            MethodSpec::TlWeakForm(s) => Some(s),
            MethodSpec::Kbm(s) => Some(s),
            MethodSpec::Efg(s) => Some(s),
            _ => None,
        }
    }
}

/// The scene features the method `name` runs (none for a name not registered).
pub fn features(name: &str) -> &'static [Feature] {
    entry(name).map_or(&[], |e| e.features)
}

/// The keys every method reads, with their defaults.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CommonKeys {
    #[serde(default = "default_kernel")]
    kernel: KernelKind,
    h_over_dx: Option<f64>,
    #[serde(default = "default_correction")]
    correction: CorrectionKind,
    #[serde(default = "default_integrator")]
    integrator: IntegratorKind,
    dt: Option<f64>,
    cfl: Option<f64>,
}

fn default_kernel() -> KernelKind {
    KernelKind::CubicSpline
}
fn default_correction() -> CorrectionKind {
    CorrectionKind::RandlesLibersky
}
fn default_integrator() -> IntegratorKind {
    IntegratorKind::Rk4
}

/// Every key any method reads, for the unknown-key message.
fn all_keys() -> &'static [&'static str] {
    static KEYS: OnceLock<Vec<&'static str>> = OnceLock::new();
    KEYS.get_or_init(|| {
        let mut keys = vec!["name"];
        keys.extend(COMMON_KEYS);
        for e in REGISTRY {
            for k in e.keys {
                if !keys.contains(k) {
                    keys.push(k);
                }
            }
        }
        keys
    })
}

/// A key of `[method]`: rejected at its own position in the file unless some method
/// reads it.
struct KeySeed;

impl<'de> DeserializeSeed<'de> for KeySeed {
    type Value = String;
    fn deserialize<De: Deserializer<'de>>(self, d: De) -> Result<String, De::Error> {
        let key = String::deserialize(d)?;
        if all_keys().contains(&key.as_str()) {
            Ok(key)
        } else {
            Err(de::Error::unknown_field(&key, all_keys()))
        }
    }
}

/// The method name: rejected at its own position unless registered.
struct NameSeed;

impl<'de> DeserializeSeed<'de> for NameSeed {
    type Value = String;
    fn deserialize<De: Deserializer<'de>>(self, d: De) -> Result<String, De::Error> {
        let name = String::deserialize(d)?;
        if entry(&name).is_some() {
            Ok(name)
        } else {
            Err(de::Error::unknown_variant(&name, NAMES))
        }
    }
}

impl<'de> Deserialize<'de> for MethodTable {
    fn deserialize<De: Deserializer<'de>>(d: De) -> Result<Self, De::Error> {
        d.deserialize_map(TableVisitor)
    }
}

struct TableVisitor;

impl<'de> Visitor<'de> for TableVisitor {
    type Value = MethodTable;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("the [method] table")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<MethodTable, A::Error> {
        let mut name = None;
        let mut rest = Table::new();
        while let Some(key) = map.next_key_seed(KeySeed)? {
            if key == "name" {
                name = Some(map.next_value_seed(NameSeed)?);
            } else {
                let value: Value = map.next_value()?;
                rest.insert(key, value);
            }
        }
        let name = name.ok_or_else(|| de::Error::missing_field("name"))?;
        MethodTable::split(&name, rest).map_err(de::Error::custom)
    }
}

impl MethodTable {
    /// The table of method `name` from its other keys: the common keys, the method's own
    /// (into its spec) and those of other methods (type-checked against their methods'
    /// specs and kept as `foreign`).
    fn split(name: &str, rest: Table) -> Result<Self, String> {
        let entry = entry(name).expect("the name seed accepts registered names only");
        let (mut common, mut own, mut foreign) = (Table::new(), Table::new(), Vec::new());
        own.insert("name".into(), Value::String(name.into()));
        for (key, value) in rest {
            if COMMON_KEYS.contains(&key.as_str()) && !entry.reads_common(&key) {
                return Err(if entry.kernel {
                    format!(
                        "`{name}` builds its own consistent functions and reads no \
                         `method.{key}`; remove the key"
                    )
                } else {
                    format!("`{name}` has no kernel and reads no `method.{key}`; remove the key")
                });
            }
            if COMMON_KEYS.contains(&key.as_str()) {
                common.insert(key, value);
            } else if entry.keys.contains(&key.as_str()) {
                own.insert(key, value);
            } else {
                let owner = REGISTRY
                    .iter()
                    .find(|e| e.keys.contains(&key.as_str()))
                    .expect("the key seed accepts registered keys only");
                let mut alone = Table::new();
                alone.insert("name".into(), Value::String(owner.name.into()));
                alone.insert(key.clone(), value);
                MethodSpec::deserialize(Value::Table(alone))
                    .map_err(|e| format!("`method.{key}` (a key of `{}`): {e}", owner.name))?;
                foreign.push(key);
            }
        }
        let c = CommonKeys::deserialize(Value::Table(common)).map_err(|e| e.to_string())?;
        let h_over_dx = match c.h_over_dx {
            Some(h) => h,
            None if !entry.kernel => 1.0,
            None => return Err("missing field `h_over_dx`".into()),
        };
        let spec = MethodSpec::deserialize(Value::Table(own)).map_err(|e| e.to_string())?;
        let keys = MethodKeys {
            name: entry.name,
            kernel: c.kernel,
            h_over_dx,
            correction: c.correction,
            integrator: c.integrator,
            dt: c.dt,
            cfl: c.cfl,
            static_default: entry.features.contains(&Feature::StaticDefault),
            lattice_cells: spec.lattice_cells(),
        };
        Ok(Self {
            keys,
            spec,
            foreign,
        })
    }
}

/// Drops from a `[method]` table the keys that method `name` does not read, except those
/// in `kept`; returns the dropped keys. This is what `--set method.name=X` does to the
/// keys of the previous method.
pub fn drop_foreign_keys(table: &mut Table, name: &str, kept: &[String]) -> Vec<String> {
    let Some(entry) = entry(name) else {
        return Vec::new();
    };
    let dropped: Vec<String> = table
        .keys()
        .filter(|k| !entry.reads(k) && !kept.contains(k))
        .cloned()
        .collect();
    for key in &dropped {
        table.remove(key);
    }
    dropped
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_registered_key_is_read_by_its_spec() {
        // Each key a method declares must deserialize into its spec: a key listed but
        // not read would be accepted and ignored.
        for e in REGISTRY {
            for key in e.keys {
                let mut t = Table::new();
                t.insert("name".into(), Value::String(e.name.into()));
                t.insert((*key).into(), Value::String("no such value".into()));
                let err = MethodSpec::deserialize(Value::Table(t))
                    .expect_err("a string where the key wants another value");
                assert!(
                    !err.to_string().contains("unknown field"),
                    "{}: `{key}` is declared but not a field: {err}",
                    e.name
                );
            }
        }
    }

    #[test]
    fn names_are_unique() {
        for (i, a) in REGISTRY.iter().enumerate() {
            assert!(REGISTRY[i + 1..].iter().all(|b| b.name != a.name));
            assert!(
                !COMMON_KEYS.iter().any(|k| a.keys.contains(k)),
                "{}",
                a.name
            );
        }
    }
}
