//! The case: the schema of `cases/*.toml` and the sampling of its bodies into particles.
//!
//! This is the data every layer reads: one file per section of the case (`material`,
//! `body` with `fields`, `boundary`, `run`, `output`), the [`Case`] that gathers them, and
//! `geometry`, which samples the bodies into particles. Loading a file (with `--set`
//! overrides) and validating it are the case files' module, [`crate::scene`]; every error
//! names the file, the key and what is allowed ([`CaseError`]).

mod body;
mod boundary;
mod error;
mod exact;
mod expression;
mod fields;
mod geometry;
pub mod mesh;
mod method;
mod output;
pub(crate) mod polygon;
mod run;

pub use crate::core::tensor::Axis;
pub use crate::diagnostics::analytic::Solution;
pub use crate::physics::material::{MaterialSpec, Plane};
pub use crate::physics::mirror::{MirrorKind, MirrorSpec};
pub use body::{
    BodySpec, ContactSpec, Hole, HoleAxis, Lattice, MeshNodes, RingLattice, Shape,
    VOLUME_TOLERANCE, VelocityNoise, Volumes,
};
pub use boundary::{BoundarySpec, Condition, Region, Surface, TimeLaw};
pub use error::{CaseError, parse_bytes};
pub use expression::Expression;
pub(crate) use fields::linear_field;
pub use fields::{DisplacementField, VelocityField};
pub(crate) use geometry::read_capped;
pub use geometry::{
    BOX_HALF, BodySize, Discretised, PARTICLE_ID_LIMIT, discretise, estimate_particles, tube_frames,
};
pub use method::MethodKeys;
pub use output::{CheckSpec, Observer, OutputSpec, ProbeSpec, SectionSpec, Statistic};
pub use run::{RunSpec, Solve, Tolerance};

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A complete, validated scene description, with `M` the `[method]` table: the
/// [`MethodKeys`] every layer reads. Loading ([`crate::scene`]) reads the file with the
/// registry's table in its place, which holds the method's typed spec as well, and then
/// parts the two ([`Case::with_method`]).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Case<M = MethodKeys> {
    /// Scene name, used for output file names.
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// 2 (plane strain) or 3.
    pub dimension: u32,
    /// Particle spacing Δx of the lattices that sample every body.
    pub spacing: f64,
    pub material: MaterialSpec,
    pub method: M,
    #[serde(rename = "body")]
    pub bodies: Vec<BodySpec>,
    #[serde(default, rename = "boundary")]
    pub boundaries: Vec<BoundarySpec>,
    /// Symmetry and skew-symmetry planes, closed by mirror (ghost) particles.
    #[serde(default, rename = "mirror")]
    pub mirrors: Vec<MirrorSpec>,
    pub run: RunSpec,
    #[serde(default)]
    pub output: OutputSpec,
    #[serde(default, rename = "probe")]
    pub probes: Vec<ProbeSpec>,
    /// Section-force observers: the resultant of P·N across a reference plane.
    #[serde(default, rename = "section", skip_serializing_if = "Vec::is_empty")]
    pub sections: Vec<SectionSpec>,
    /// Penalty contact between the bodies (2D).
    pub contact: Option<ContactSpec>,
    /// The case file, named in errors; relative paths inside it are relative to its folder.
    #[serde(skip)]
    pub file: PathBuf,
    /// What loading changed beyond the file and the overrides (keys dropped by a change
    /// of method), for the command line to show.
    #[serde(skip)]
    pub notes: Vec<String>,
    /// The `--set` overrides applied to the file, in order.
    #[serde(skip)]
    pub overrides: Vec<String>,
}

/// `Case::with_method`, over the fields other than `method` (named once, here).
macro_rules! with_method {
    ($($field:ident),*) => {
        /// This case with the `[method]` table `method` in place of its own, and its own.
        pub fn with_method<N>(self, method: N) -> (Case<N>, M) {
            let Self { method: own, $($field),* } = self;
            (Case { method, $($field),* }, own)
        }
    };
}

impl<M> Case<M> {
    pub fn dim(&self) -> usize {
        self.dimension as usize
    }

    with_method!(
        name,
        description,
        dimension,
        spacing,
        material,
        bodies,
        boundaries,
        mirrors,
        run,
        output,
        probes,
        sections,
        contact,
        file,
        notes,
        overrides
    );

    /// Folder that relative paths in the case are resolved against.
    pub fn base_dir(&self) -> &Path {
        self.file.parent().unwrap_or(Path::new("."))
    }

    /// An error about `key` in this case's file.
    pub fn invalid(&self, key: impl Into<String>, message: impl Into<String>) -> CaseError {
        CaseError::Invalid {
            file: self.file.clone(),
            key: key.into(),
            message: message.into(),
        }
    }
}

impl Case {
    /// Whether the run solves for static equilibrium load step by load step: `run.solve
    /// = "static"`, or a static-only method.
    pub fn is_static(&self) -> bool {
        match self.run.solve {
            Some(solve) => solve == Solve::Static,
            None => self.method.static_default,
        }
    }

    /// Whether the run integrates in time by implicit Newmark/HHT-α steps (`run.solve =
    /// "implicit"`).
    pub fn is_implicit(&self) -> bool {
        self.run.solve == Some(Solve::Implicit)
    }

    /// Whether the run is solved by Newton's method on a model's residual and tangent
    /// ([`crate::statics`]): a static run or an implicit one.
    pub fn solves_by_newton(&self) -> bool {
        self.is_static() || self.is_implicit()
    }

    /// The smoothing length h = h_over_dx · Δx.
    pub fn smoothing_length(&self) -> f64 {
        self.method.h_over_dx * self.spacing
    }

    /// The case's kernel in `dim` dimensions.
    pub fn kernel(&self, dim: usize) -> crate::core::kernel::Kernel {
        crate::core::kernel::Kernel::new(self.method.kernel, self.smoothing_length(), dim)
    }
}

/// 64-bit FNV-1a: a hash that stays the same across Rust versions and platforms.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    fnv1a_extend(FNV_OFFSET, bytes)
}

/// FNV-1a's starting value.
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// The FNV-1a hash `h` of some bytes extended by `bytes`: a change of any one byte
/// changes the hash, as each byte's step is a bijection of the state.
pub fn fnv1a_extend(h: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(h, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}
