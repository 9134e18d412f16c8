//! Case files: the schema of `cases/*.toml`, loading with `--set` overrides, and validation.
//!
//! A case is parsed completely and validated before anything runs; every error names
//! the file, the key and what is allowed.

mod geometry;
mod overrides;
mod validate;

pub use geometry::{Discretised, discretise};

use crate::correction::CorrectionKind;
use crate::integrate::IntegratorKind;
use crate::kernel::KernelKind;
use crate::material::MaterialModel;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A complete, validated scene description.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// Scene name, used for output file names.
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// 2 (plane strain) or 3.
    pub dimension: u32,
    /// Particle spacing Δx of the lattices that sample every body.
    pub spacing: f64,
    pub material: MaterialSpec,
    pub method: MethodSpec,
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
    /// Penalty contact between the bodies (2D, TLSPH).
    pub contact: Option<ContactSpec>,
    /// The case file, named in errors; relative paths inside it are relative to its folder.
    #[serde(skip)]
    pub file: PathBuf,
}

/// Penalty contact of seed 000 §5.8: every body is a master to every other, its boundary
/// the convex hull of its reference particles.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// α of eq 178, f = −α m (d·n) n / Δt²: the fraction of a penetration removed in one
    /// step (the seed uses 0.1).
    pub penalty: f64,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub model: MaterialModel,
    /// Reference density ρ0 [kg/m³].
    pub density: f64,
    /// Young's modulus E [Pa].
    pub youngs_modulus: f64,
    /// Poisson ratio ν.
    pub poisson_ratio: f64,
    /// `von-mises-plastic`: initial yield stress τ_y⁰ [Pa].
    pub yield_stress: Option<f64>,
    /// `von-mises-plastic`: linear isotropic hardening modulus H [Pa].
    pub hardening_modulus: Option<f64>,
}

/// Particle method, as named in case files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodName {
    /// Total-Lagrangian SPH after Reveles (seed 000 §5.3).
    Tlsph,
    /// Mixed {p, F, H, J} total-Lagrangian SPH with the acoustic Riemann (upwind)
    /// stabilisation of seed 003.
    UpwindSph,
    /// Mixed {p, F, H, J} total-Lagrangian SPH with Jameson–Schmidt–Turkel dissipation on
    /// p (Lee et al. 2016, seed 002 eqs 26–28).
    JstSph,
}

impl MethodName {
    pub const ALL: [MethodName; 3] = [Self::Tlsph, Self::UpwindSph, Self::JstSph];

    pub fn describe(self) -> &'static str {
        match self {
            Self::Tlsph => {
                "total-Lagrangian SPH (Reveles; seed 000 §5.3): corrected reference kernel, \
                 rate- or state-based stress, Monaghan artificial viscosity"
            }
            Self::UpwindSph => {
                "mixed {p, F, H, J} total-Lagrangian SPH with the acoustic Riemann (upwind) \
                 stabilisation on p and J, linear reconstruction and the angular-momentum \
                 projection (Lee et al. 2018; seed 003)"
            }
            Self::JstSph => {
                "mixed {p, F, H, J} total-Lagrangian SPH with Jameson–Schmidt–Turkel \
                 dissipation on p (Lee et al. 2016; seed 002 eqs 26–28)"
            }
        }
    }

    /// The name in case files.
    pub fn key(self) -> &'static str {
        match self {
            Self::Tlsph => "tlsph",
            Self::UpwindSph => "upwind-sph",
            Self::JstSph => "jst-sph",
        }
    }

    /// Whether the method evolves the mixed conservation variables {p, F, H, J}.
    pub fn is_mixed(self) -> bool {
        matches!(self, Self::UpwindSph | Self::JstSph)
    }
}

/// Which geometric conservation laws a mixed method evolves besides p and F (seed 003 §6);
/// the others are computed from F (H = cof F, J = det F).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
pub enum Conserved {
    #[serde(rename = "p-F")]
    PF,
    #[serde(rename = "p-F-J")]
    PFJ,
    #[serde(rename = "p-F-H-J")]
    PFHJ,
}

impl Conserved {
    pub const ALL: [Conserved; 3] = [Self::PF, Self::PFJ, Self::PFHJ];

    pub fn evolves_h(self) -> bool {
        self == Self::PFHJ
    }

    pub fn evolves_j(self) -> bool {
        self != Self::PF
    }
}

/// JST dissipation: coefficients ε⁽²⁾ (Laplacian) and ε⁽⁴⁾ (bi-Laplacian), and the
/// discrete Laplacian both are built on.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Jst {
    #[serde(default)]
    pub eps2: f64,
    #[serde(default = "default_eps4")]
    pub eps4: f64,
    #[serde(default)]
    pub laplacian: JstLaplacian,
}

/// The discrete Laplacian ∇²f_a = Σ_b ℓ_ab (f_b − f_a) of the JST dissipation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum JstLaplacian {
    /// Brookshaw weights corrected to be exact for linear fields and |X|² (the properties
    /// seed 002 states); near free surfaces the weights grow and change sign, and a
    /// large ε⁽⁴⁾ then needs a smaller CFL number.
    #[default]
    Corrected,
    /// ℓ_ab = 2 V_b N_ab·∇̃W̃_b(X_a)/|X_ab| (seed 003 eq 55, Morris et al.): positive
    /// symmetrised weights, but the Laplacian of a linear field is not zero at free
    /// surfaces, so rigid and bending motion is damped there.
    Brookshaw,
}

fn default_eps4() -> f64 {
    0.125
}

impl Default for Jst {
    fn default() -> Self {
        Self {
            eps2: 0.0,
            eps4: default_eps4(),
            laplacian: JstLaplacian::default(),
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MethodSpec {
    pub name: MethodName,
    #[serde(default = "default_kernel")]
    pub kernel: KernelKind,
    /// Smoothing length over particle spacing.
    pub h_over_dx: f64,
    #[serde(default = "default_correction")]
    pub correction: CorrectionKind,
    #[serde(default = "default_integrator")]
    pub integrator: IntegratorKind,
    /// Fixed time step [s]; exactly one of `dt` and `cfl` is given.
    pub dt: Option<f64>,
    /// Courant number: Δt = cfl · Δx / (c_p + max |v|); the mixed methods replace c_p/Δx
    /// by the largest C_p,ab / r_ab of a pair, with the current distance r_ab and
    /// C_p,ab = c_p / ½(λ_a + λ_b), λ the smallest principal stretch (seed 002 eqs 31–32).
    pub cfl: Option<f64>,
    /// Mixed methods with `cfl`: the pair wave speed C_p,ab of the step (default `pair`).
    pub cfl_wave_speed: Option<CflWaveSpeed>,
    pub artificial_viscosity: Option<ArtificialViscosity>,
    /// Mixed methods: the conservation variables evolved (default {p, F, H, J}).
    pub variables: Option<Conserved>,
    /// Upwind-SPH: linear reconstruction of p and P to the mid-pair (default on).
    pub reconstruction: Option<bool>,
    /// Mixed methods: angular-momentum-preserving projection of the internal force and
    /// of the stabilisation (seed 003 Appendix B; default on without mirror planes, off
    /// with them, whose reactions are external forces).
    pub projection: Option<bool>,
    /// JST-SPH: dissipation coefficients (default ε⁽²⁾ = 0, ε⁽⁴⁾ = 1/8).
    pub jst: Option<Jst>,
    /// Mixed methods: the discrete divergence of P (default `weak`).
    pub momentum: Option<Momentum>,
    /// Mixed methods: the F the stress is evaluated at (default `evolved`).
    pub deformation_gradient: Option<DeformationGradient>,
}

/// The p-wave speed C_p,ab of a pair in the mixed methods' CFL step Δt = α min_ab r_ab /
/// C_p,ab (seed 002 eq 31).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CflWaveSpeed {
    /// C_p,ab = C_p^Lin / ½(λ_a + λ_b), λ the smallest principal stretch (eq 32).
    #[default]
    Pair,
    /// C_p^Lin = sqrt((λ + 2μ)/ρ₀) for every pair: the paper's choice for the bond-based
    /// column, which needs no stretches; r_ab still follows the motion.
    Linear,
}

/// Discrete DIV P of the mixed methods.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Momentum {
    /// T_a = Σ_b V_b [P_b ∇̃W̃_a(X_b) − P_a ∇̃W̃_b(X_a)] (seed 003 eqs 20–21).
    #[default]
    Weak,
    /// T_a = −½ Σ_b V_b (P_a + P_b)(∇W̃_b(X_a) − ∇W̃_a(X_b)) (seed 002 eq 22).
    Symmetrised,
}

/// The deformation gradient the stress of a mixed method is evaluated at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeformationGradient {
    /// The evolved F (eq 24 of seed 002, 38b of seed 003).
    #[default]
    Evolved,
    /// The kernel-smoothed bond-based F^c with the self-bond (seed 002 eqs 37, 39),
    /// recomputed from the positions at every stage; the evolved F stays the state.
    BondBased,
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

/// Monaghan artificial viscosity Π_ij = (−α c̄ μ_ij + β μ_ij²)/ρ̄_ij (seed 000 §3.1 step 6).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ArtificialViscosity {
    pub alpha: f64,
    pub beta: f64,
    #[serde(default = "default_eta")]
    pub eta: f64,
}

fn default_eta() -> f64 {
    0.1
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    pub name: String,
    pub geometry: Shape,
    pub initial_velocity: Option<VelocityField>,
}

/// How lattice particles share the volume of their body.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Volumes {
    #[default]
    Uniform,
    Tributary,
}

/// Where a box's lattice points sit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Lattice {
    /// On the vertices min + i·Δx: rows of particles lie on the faces.
    #[default]
    Vertex,
    /// At the centres min + (i + ½)Δx of the Δx cells that fill the box: no particle lies
    /// on a face, and the Δx^d volumes sum to the box's volume.
    CellCentred,
}

/// Geometry generators. Lattices are anchored at the lower corner of the shape's
/// bounding box: points min + i·Δx, i = 0, 1, … while ≤ max.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "shape", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Shape {
    /// Rectangle (2D) or box (3D), both ends closed.
    Box {
        min: Vec<f64>,
        max: Vec<f64>,
        /// Particle volumes: `uniform` (Δx^d each, the default) or `tributary` (the dual
        /// cell of a vertex lattice: halved on every face a particle lies on, so the
        /// volumes sum to the box's volume when its sides are multiples of Δx).
        #[serde(default)]
        volumes: Volumes,
        /// `vertex` (the default) or `cell-centred`.
        #[serde(default)]
        lattice: Lattice,
    },
    /// Disk of points with |x − c| < r (2D).
    Disk { center: Vec<f64>, radius: f64 },
    /// Annulus of points with r_i ≤ |x − c| < r_o (2D).
    Ring {
        center: Vec<f64>,
        inner_radius: f64,
        outer_radius: f64,
    },
    /// Solid or hollow cylinder along a coordinate axis (3D); `base` is the centre of
    /// the bottom face.
    Cylinder {
        base: Vec<f64>,
        axis: Axis,
        radius: f64,
        #[serde(default)]
        inner_radius: f64,
        length: f64,
        /// `vertex` (the default: layers on both end faces) or `cell-centred` (the
        /// centres of the Δx cells of the bounding box, Δx/2 inside its faces).
        #[serde(default)]
        lattice: Lattice,
    },
    /// Points from a CSV file with a header naming columns x, y[, z][, volume].
    Points { file: PathBuf },
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn index(self) -> usize {
        self as usize
    }
}

/// Initial velocity fields v(X).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum VelocityField {
    Uniform {
        value: Vec<f64>,
    },
    /// v = G X with the velocity gradient G given row by row (G_ij = ∂v_i/∂X_j).
    Linear {
        gradient: Vec<Vec<f64>>,
    },
    /// v = ω × (X − c); in 2D ω is the out-of-plane rate, in 3D `axis` gives its direction.
    RigidRotation {
        omega: f64,
        center: Vec<f64>,
        axis: Option<Vec<f64>>,
    },
    /// Longitudinal pulse v = A d exp(−((X·d − s0)/w)²) along the unit direction d.
    GaussianPulse {
        amplitude: f64,
        direction: Vec<f64>,
        center: f64,
        width: f64,
    },
    /// The swinging plate/cube mode of seed 003 §7.1.1 on [0, 1]^d at t = 0 of its sine
    /// form: v = U0 ω Φ(X) (see [`crate::analytic::SwingingMode`]).
    Swinging {
        amplitude: f64,
    },
    /// The twisting column of seed 003 §7.3.1: v = ω(Y) × X with ω = Ω sin(πY/(2L)) ŷ,
    /// about the Y axis through the origin.
    Twist {
        omega: f64,
        length: f64,
    },
}

/// A boundary condition on a region of the reference configuration.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    pub region: Region,
    pub condition: Condition,
}

/// Axis-aligned box in reference coordinates (every bound optional), optionally limited
/// to one body. Bounds are inclusive and widened by Δx/4 so that lattice rows lying on a
/// bound are selected despite round-off.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    pub body: Option<String>,
    pub x_min: Option<f64>,
    pub x_max: Option<f64>,
    pub y_min: Option<f64>,
    pub y_max: Option<f64>,
    pub z_min: Option<f64>,
    pub z_max: Option<f64>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Condition {
    /// u = 0, v = 0.
    Fixed,
    /// Prescribed velocity components (the others stay free); u follows as v·t.
    Velocity {
        vx: Option<f64>,
        vy: Option<f64>,
        vz: Option<f64>,
    },
    /// Mirror plane with the given normal: the normal velocity component is zero.
    Symmetry { normal: Axis },
    /// Surface traction t [Pa] on the region's particles, f = t·Δx^(d−1) each.
    Traction { traction: Vec<f64> },
}

/// A plane X_k = `at` across which the solution continues as its mirror image: for
/// `symmetric`, u'(X') = R u(X) (normal displacement zero on the plane); for
/// `skew-symmetric`, u'(X') = −R u(X) (tangential displacement zero), R the reflection.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MirrorSpec {
    pub normal: Axis,
    pub at: f64,
    pub kind: MirrorKind,
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum MirrorKind {
    Symmetric,
    SkewSymmetric,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// Simulated end time [s].
    pub end_time: f64,
    /// Stop as failed when the total energy exceeds this factor times the initial
    /// energy plus the work done by boundary conditions.
    #[serde(default = "default_energy_growth")]
    pub energy_growth_limit: f64,
    /// Stop as failed when the hourglass indicator η of a particle exceeds this, checked
    /// at every series sample (see [`crate::hourglass`]).
    #[serde(default)]
    pub hourglass_limit: Option<f64>,
    /// Stop as failed when the CFL step falls below this fraction of the first step
    /// (a collapse of the step: the run would crawl rather than end).
    #[serde(default)]
    pub min_step_ratio: Option<f64>,
}

fn default_energy_growth() -> f64 {
    10.0
}

/// Observers written to the CSV time series.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "kebab-case")]
pub enum Observer {
    /// Kinetic, strain and total energy.
    Energy,
    /// Σ m v.
    LinearMomentum,
    /// Σ m x × v about the origin.
    AngularMomentum,
    /// Current bounding-box size of every body along each axis.
    Extent,
    /// Smallest current height (y-extent) over the material columns of free particles.
    NeckHeight,
    /// Largest hourglass indicator η over the particles.
    Hourglass,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Time between VTU frames [s]; frames at t = 0 and at the end are always written.
    /// Absent: only those two.
    pub frame_interval: Option<f64>,
    /// Time between rows of the CSV time series [s]; absent: every step.
    pub series_interval: Option<f64>,
    #[serde(default = "default_observers")]
    pub observers: Vec<Observer>,
}

fn default_observers() -> Vec<Observer> {
    vec![Observer::Energy]
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            frame_interval: None,
            series_interval: None,
            observers: default_observers(),
        }
    }
}

/// A point probe: the particle nearest to `position` in the reference configuration.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    pub name: String,
    pub position: Vec<f64>,
}

/// What is wrong with a case file.
#[derive(Debug, Error)]
pub enum CaseError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: {message}")]
    Parse { file: PathBuf, message: String },
    #[error("{file}: --set {assignment}: {message}")]
    Override {
        file: PathBuf,
        assignment: String,
        message: String,
    },
    #[error("{file}: key `{key}`: {message}")]
    Invalid {
        file: PathBuf,
        key: String,
        message: String,
    },
}

impl Case {
    /// Reads, overrides (`key.path=value`) and validates a case file.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Case, CaseError> {
        let text = std::fs::read_to_string(path).map_err(|source| CaseError::Read {
            file: path.to_path_buf(),
            source,
        })?;
        Self::from_toml(&text, path, overrides)
    }

    /// Parses case text; `file` names it in errors and anchors relative paths.
    pub fn from_toml(text: &str, file: &Path, overrides: &[String]) -> Result<Case, CaseError> {
        let parse_error = |e: toml::de::Error| CaseError::Parse {
            file: file.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        };
        let mut case: Case = if overrides.is_empty() {
            toml::from_str(text).map_err(parse_error)?
        } else {
            let mut table: toml::Table = toml::from_str(text).map_err(parse_error)?;
            for assignment in overrides {
                overrides::apply(&mut table, assignment).map_err(|message| {
                    CaseError::Override {
                        file: file.to_path_buf(),
                        assignment: assignment.clone(),
                        message,
                    }
                })?;
            }
            Case::deserialize(table).map_err(parse_error)?
        };
        case.file = file.to_path_buf();
        validate::check(&case).map_err(|(key, message)| CaseError::Invalid {
            file: file.to_path_buf(),
            key,
            message,
        })?;
        Ok(case)
    }

    pub fn dim(&self) -> usize {
        self.dimension as usize
    }

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
