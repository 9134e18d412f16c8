//! Case files: the schema of `cases/*.toml`, loading with `--set` overrides, and validation.
//!
//! A case is parsed completely and validated before anything runs; every error names
//! the file, the key and what is allowed.

mod expression;
mod geometry;
pub mod mesh;
mod overrides;
mod polygon;
pub(crate) mod validate;

pub use expression::Expression;
pub use geometry::{BodySize, Discretised, PARTICLE_ID_LIMIT, discretise, estimate_particles};

use crate::material::MaterialModel;
use crate::methods::{MethodTable, drop_foreign_keys};
use crate::mooney_rivlin::MooneyRivlin;
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
    pub method: MethodTable,
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
    /// Young's modulus E [Pa]: every model but `mooney-rivlin`.
    pub youngs_modulus: Option<f64>,
    /// Poisson ratio ν: every model but `mooney-rivlin`.
    pub poisson_ratio: Option<f64>,
    /// `von-mises-plastic`: initial yield stress τ_y⁰ [Pa].
    pub yield_stress: Option<f64>,
    /// `von-mises-plastic`: linear isotropic hardening modulus H [Pa]: τ_y = τ_y⁰ + H ε_p,
    /// negative for softening (down to τ_y = 0).
    pub hardening_modulus: Option<f64>,
    /// `mooney-rivlin`: c1 of seed 001 eq 18 [Pa].
    pub c1: Option<f64>,
    /// `mooney-rivlin`: c2 of seed 001 eq 18 [Pa].
    pub c2: Option<f64>,
    /// `mooney-rivlin`: λ of seed 001 eq 18 [Pa], half the bulk modulus (not Lamé's λ,
    /// which is 2λ − ⅔(c1 + c2)).
    pub lambda: Option<f64>,
    /// What the out-of-plane direction of a 2D scene holds fixed.
    #[serde(default)]
    pub plane: Plane,
}

impl MaterialSpec {
    /// The constants of a `mooney-rivlin` material (None for the other models).
    pub fn mooney_rivlin(&self) -> Option<MooneyRivlin> {
        match (self.model, self.c1, self.c2, self.lambda) {
            (MaterialModel::MooneyRivlin, Some(c1), Some(c2), Some(lambda)) => {
                Some(MooneyRivlin { c1, c2, lambda })
            }
            _ => None,
        }
    }

    /// Young's modulus and Poisson's ratio (E, ν): as given, or for `mooney-rivlin` those
    /// of its linearisation at F = I (μ = c1 + c2, λ_L = 2λ − ⅔μ). The closed-form
    /// solutions of linear elasticity take them. NaN where validation would refuse the
    /// case.
    pub fn youngs_and_poisson(&self) -> (f64, f64) {
        match self.mooney_rivlin() {
            Some(m) => {
                let (mu, lambda) = m.lame();
                (
                    mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu),
                    lambda / (2.0 * (lambda + mu)),
                )
            }
            None => (
                self.youngs_modulus.unwrap_or(f64::NAN),
                self.poisson_ratio.unwrap_or(f64::NAN),
            ),
        }
    }
}

/// The out-of-plane assumption of a 2D scene.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Plane {
    /// F_zz = 1 (ε_zz = 0): a slice of a long body.
    #[default]
    Strain,
    /// σ_zz = 0: a thin sheet, as the seed-000 reference code's SVK and small-strain
    /// models are.
    Stress,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    pub name: String,
    pub geometry: Shape,
    pub initial_velocity: Option<VelocityField>,
    /// The displacement the state starts from (the methods whose F follows from u).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_displacement: Option<DisplacementField>,
    /// An imperfection of the initial state: random velocities added to the initial ones.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity_noise: Option<VelocityNoise>,
    /// Holes through the body: the particles inside any of them are left out (the
    /// perforated block of seed 003 §7.2). The others keep their volumes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub holes: Vec<Hole>,
    /// The largest relative difference between the sampled volume Σ V and the volume of
    /// the shape the case names that a run accepts (default 0.02): past it the lattice
    /// does not fit the shape (a side that is not a multiple of Δx, a round shape on too
    /// few particles) and the run is refused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume_tolerance: Option<f64>,
}

/// The default of `body.N.volume_tolerance`: 2 %, the sampled area of a disk of radius
/// 10Δx on the square lattice (within about 1 % of πr²) with room to spare, and a fifth of
/// the mass a vertex lattice with Δx^d volumes adds to a 20Δx square (10 %).
pub const VOLUME_TOLERANCE: f64 = 0.02;

/// A hole through a body: in 2D the disk |X − c| < r, in 3D the points closer than r to
/// the line through c along `axis` (a cylinder through the whole body).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Hole {
    pub center: Vec<f64>,
    pub radius: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<Axis>,
}

impl Hole {
    /// Whether the point p (padded to 3D) is inside.
    pub fn contains(&self, p: [f64; 3]) -> bool {
        let along = self.axis.map(Axis::index);
        let r2: f64 = (0..self.center.len())
            .filter(|&k| Some(k) != along)
            .map(|k| (p[k] - self.center[k]).powi(2))
            .sum();
        r2 < self.radius * self.radius
    }
}

/// Velocities added to every particle's initial one: per axis a value uniform in
/// ±`amplitude` [m/s], from a generator seeded by `seed`, the same on every run and
/// backend. It seeds the instabilities a perfectly symmetric lattice would only meet
/// through round-off.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VelocityNoise {
    pub amplitude: f64,
    #[serde(default)]
    pub seed: u64,
}

/// How lattice particles share the volume of their body.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Volumes {
    Uniform,
    Tributary,
    Scaled,
}

impl Volumes {
    /// The volumes of a lattice when a case gives none: `tributary` on a vertex lattice,
    /// whose outer particles lie on the faces, `uniform` on a cell-centred one; either
    /// way they sum to the volume of a box whose sides are multiples of Δx.
    pub fn or_default_for(volumes: Option<Volumes>, lattice: Lattice) -> Volumes {
        volumes.unwrap_or(match lattice {
            Lattice::Vertex => Volumes::Tributary,
            Lattice::CellCentred => Volumes::Uniform,
        })
    }
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

/// How a ring is sampled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RingLattice {
    /// The points of the square lattice of spacing Δx inside the annulus.
    #[default]
    Square,
    /// Rings at r_i + kΔr from the inner to the outer radius (Δr the spacing nearest Δx
    /// that divides the wall) times `sectors` rays: particles on both rims, the
    /// quadrilaterals between them as the body's cells, and volumes a quarter of each
    /// adjacent cell's area (the mass allocation scheme of seed 001 §6).
    Polar,
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
        /// Particle volumes: `tributary` (the dual cell of a vertex lattice: halved on
        /// every face a particle lies on, so the volumes sum to the box's volume when its
        /// sides are multiples of Δx; the default on a vertex lattice) or `uniform` (Δx^d
        /// each; the default on a cell-centred lattice, where they sum to the box's
        /// volume too).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        volumes: Option<Volumes>,
        /// `vertex` (the default) or `cell-centred`.
        #[serde(default)]
        lattice: Lattice,
    },
    /// Disk of points with |x − c| < r (2D).
    Disk {
        center: Vec<f64>,
        radius: f64,
        /// Particle volumes: `scaled` (the default: Δx^d times the one factor that makes
        /// them sum to the named shape's volume) or `uniform` (Δx^d each, as the lattice
        /// falls: the mass is off by the cells the boundary cuts).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        volumes: Option<Volumes>,
    },
    /// Annulus (2D): the square-lattice points with r_i ≤ |x − c| < r_o (`square`, the
    /// default), or a polar lattice of rings and rays (`polar`, see [`RingLattice`]).
    Ring {
        center: Vec<f64>,
        inner_radius: f64,
        outer_radius: f64,
        #[serde(default)]
        lattice: RingLattice,
        /// The rays of a polar lattice (default: the nearest whole number to the mid
        /// circumference over Δx).
        #[serde(default)]
        sectors: Option<u32>,
        /// Particle volumes of the square lattice: `scaled` (the default: Δx^d times the one factor that makes
        /// them sum to the named shape's volume) or `uniform` (Δx^d each, as the lattice
        /// falls: the mass is off by the cells the boundary cuts).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        volumes: Option<Volumes>,
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
        /// Particle volumes: `scaled` (the default: Δx^d times the one factor that makes
        /// them sum to the named shape's volume) or `uniform` (Δx^d each, as the lattice
        /// falls: the mass is off by the cells the boundary cuts).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        volumes: Option<Volumes>,
    },
    /// A simple polygon (2D): the lattice points inside it or on its edges (within 1e-9
    /// of a spacing), the vertices in either orientation, no edge crossing another.
    Polygon {
        vertices: Vec<Vec<f64>>,
        /// Particle volumes: `scaled` (the default: Δx^d times the one factor that makes
        /// them sum to the polygon's area) or `uniform` (Δx^d each, as the lattice falls).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        volumes: Option<Volumes>,
    },
    /// Points from a CSV file with a header naming columns x, y[, z][, volume] and
    /// optionally their initial velocities vx, vy[, vz].
    Points { file: PathBuf },
    /// The cells of a Gmsh mesh (`.msh`, ASCII format 2.2 or 4.1; triangles and
    /// quadrangles in 2D, tetrahedra and hexahedra in 3D): a particle at each cell's
    /// centroid, the cell's area or volume its volume ([`mesh`]); or, with `nodes =
    /// "vertices"`, a particle at each vertex and the cells as the cells of the Galerkin
    /// methods ([`MeshNodes`]).
    Mesh {
        file: PathBuf,
        #[serde(default, skip_serializing_if = "MeshNodes::is_centroids")]
        nodes: MeshNodes,
    },
}

/// Where a mesh body's particles sit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MeshNodes {
    /// At the centroid of every cell, the cell's measure its volume: a particle set for
    /// the methods that integrate at their particles.
    #[default]
    Centroids,
    /// At the vertices of the cells, which must be quadrangles (2D) or hexahedra (3D):
    /// the cells are then the body's cells for the methods that integrate over cells
    /// (bilinear or trilinear, as the lattice's), each vertex's volume its 2^-d share of
    /// the measure of every cell it is a corner of.
    Vertices,
}

impl MeshNodes {
    fn is_centroids(&self) -> bool {
        *self == Self::Centroids
    }
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
    /// A swinging mode at t = 0 of its sine form, v = U0 ω Φ(X)
    /// ([`crate::analytic::SwingingMode`]): `dilatational` (the default), seed 003
    /// §7.1.1's plate/cube on [0, 1]^d; `shear`, seed 002 §5.1's plate on [0, 2]².
    Swinging {
        amplitude: f64,
        #[serde(default)]
        mode: crate::analytic::SwingingKind,
    },
    /// The twisting column of seed 003 §7.3.1: v = ω(Y) × X with ω = Ω sin(πY/(2L)) ŷ,
    /// about the Y axis through the origin.
    Twist {
        omega: f64,
        length: f64,
    },
    /// Each component an expression of the reference coordinates x, y (z in 3D) and the
    /// named `constants` ([`Expression`]), e.g. `vy = "0.05*c*sin(PI*x/L)"`.
    Expression {
        vx: String,
        vy: String,
        vz: Option<String>,
        #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
        constants: std::collections::BTreeMap<String, f64>,
    },
}

impl VelocityField {
    /// The component expressions of an `expression` field, parsed for a `dim`-D scene
    /// (with `vz` in 3D only), each with its key below `key`; None for the other fields.
    pub fn expressions(
        &self,
        key: &str,
        dim: usize,
    ) -> Option<Result<Vec<Expression>, (String, String)>> {
        let Self::Expression {
            vx,
            vy,
            vz,
            constants,
        } = self
        else {
            return None;
        };
        let components = [("vx", Some(vx)), ("vy", Some(vy)), ("vz", vz.as_ref())];
        Some(component_expressions(&components, constants, key, dim))
    }
}

/// Initial displacement fields u(X), for the methods whose deformation gradient follows
/// from the displacement (the state starts at x = X + u(X)).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum DisplacementField {
    /// u = G X with G given row by row (G_ij = ∂u_i/∂X_j): the affine pre-deformation
    /// F = I + G.
    Linear { gradient: Vec<Vec<f64>> },
    /// Each component an expression of the reference coordinates x, y (z in 3D) and the
    /// named `constants` ([`Expression`]), e.g. `uy = "d*(x/L)^2"`.
    Expression {
        ux: String,
        uy: String,
        uz: Option<String>,
        #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
        constants: std::collections::BTreeMap<String, f64>,
    },
    /// A swinging mode at t = 0 of its cosine form, u = U0 Φ(X), at rest
    /// ([`crate::analytic::SwingingMode`], seed 003 §E.5): `dilatational` (the default),
    /// seed 003 §7.1.1's plate/cube on [0, 1]^d; `shear`, seed 002 §5.1's plate on [0, 2]².
    Swinging {
        amplitude: f64,
        #[serde(default)]
        mode: crate::analytic::SwingingKind,
    },
}

impl DisplacementField {
    /// u(X) of the field in a `dim`-D scene; `expressions` are its parsed components
    /// ([`Self::expressions`]).
    pub fn at(&self, expressions: &[Expression], x: [f64; 3], dim: usize) -> [f64; 3] {
        match self {
            Self::Linear { gradient } => linear_field(gradient, x),
            Self::Swinging { amplitude, mode } => {
                crate::analytic::SwingingMode::shape_at(*mode, dim, x).map(|phi| amplitude * phi)
            }
            Self::Expression { .. } => {
                let mut u = [0.0; 3];
                for (u, e) in u.iter_mut().zip(expressions) {
                    *u = e.at(&x);
                }
                u
            }
        }
    }

    /// The component expressions of an `expression` field, parsed for a `dim`-D scene,
    /// each with its key below `key`; empty for the other fields.
    pub fn expressions(&self, key: &str, dim: usize) -> Result<Vec<Expression>, (String, String)> {
        match self {
            Self::Linear { .. } | Self::Swinging { .. } => Ok(Vec::new()),
            Self::Expression {
                ux,
                uy,
                uz,
                constants,
            } => {
                let components = [("ux", Some(ux)), ("uy", Some(uy)), ("uz", uz.as_ref())];
                component_expressions(&components, constants, key, dim)
            }
        }
    }
}

/// G X of a linear field, G given row by row (rows beyond the dimension absent).
pub(crate) fn linear_field(gradient: &[Vec<f64>], x: [f64; 3]) -> [f64; 3] {
    let mut y = [0.0; 3];
    for (y, row) in y.iter_mut().zip(gradient) {
        *y = row.iter().zip(&x).map(|(g, x)| g * x).sum();
    }
    y
}

/// The first `dim` of the (name, text) components of a vector field, parsed as
/// expressions of the reference coordinates, each with its key `key.name`; the third is
/// required in 3D.
fn component_expressions(
    components: &[(&str, Option<&String>); 3],
    constants: &std::collections::BTreeMap<String, f64>,
    key: &str,
    dim: usize,
) -> Result<Vec<Expression>, (String, String)> {
    components[..dim]
        .iter()
        .map(|&(name, text)| {
            let key = format!("{key}.{name}");
            let text = text.ok_or_else(|| {
                (
                    key.clone(),
                    "is required in 3D: give the z component as an expression".to_string(),
                )
            })?;
            Expression::parse(
                text,
                &expression::COORDINATES[..dim],
                "the reference coordinates",
                constants,
            )
            .map_err(|e| (key, e))
        })
        .collect()
}

/// A boundary condition on a region of the reference configuration.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    /// The prefix of the condition's columns of the `reaction` observer: a support's
    /// reaction, a load's applied force; absent: `boundary<k>` for a support, k its index
    /// among the case's `[[boundary]]` tables, and no column for a load.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub region: Region,
    pub condition: Condition,
}

impl BoundarySpec {
    /// The name of the `k`-th boundary condition of a case.
    pub fn name(&self, k: usize) -> String {
        self.name.clone().unwrap_or_else(|| format!("boundary{k}"))
    }
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
    /// Prescribed velocity components (the others stay free): v times the time law
    /// (constant by default) while t < `until` [s] (for the whole run without it), the
    /// components free from `until` on; u follows as ∫ v dt.
    Velocity {
        vx: Option<f64>,
        vy: Option<f64>,
        vz: Option<f64>,
        #[serde(default, skip_serializing_if = "TimeLaw::is_constant")]
        law: TimeLaw,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        until: Option<f64>,
    },
    /// Mirror plane with the given normal: the normal velocity component is zero.
    Symmetry { normal: Axis },
    /// Surface traction t [Pa] on the face the region's particles lie on: each carries
    /// f = ∫ t dA over its patch of the face, Δx wide in each direction along it and
    /// clipped to the named shape (half a patch at the edge of a vertex lattice), times the
    /// time law (constant by default). The force does not depend on a method's masses.
    Traction {
        traction: Vec<f64>,
        #[serde(default, skip_serializing_if = "TimeLaw::is_constant")]
        law: TimeLaw,
    },
    /// A pressure p [Pa] on a circle of the reference configuration (2D): the region's
    /// particles within Δx of the circle on the body's side (`inner`: the body lies
    /// outside it, as round a ring's hole; `outer`: inside) carry p times their share of
    /// the circle's length (half the angle to each neighbour along it, times the radius)
    /// along the normal into the body, times the time law.
    Pressure {
        pressure: f64,
        center: Vec<f64>,
        radius: f64,
        surface: Surface,
        #[serde(default, skip_serializing_if = "TimeLaw::is_constant")]
        law: TimeLaw,
    },
    /// A body force: the acceleration g [m/s²] (gravity, or any other field) on every
    /// particle of the region (`region = {}`: the whole scene; `{ body = "…" }`: one body),
    /// whatever its volume, times the time law (constant by default). Its work enters the
    /// energy balance with the other loads'.
    BodyForce {
        acceleration: Vec<f64>,
        #[serde(default, skip_serializing_if = "TimeLaw::is_constant")]
        law: TimeLaw,
    },
    /// Prescribed displacement components [m] reached at the end time (static path: the
    /// load steps ramp them with the load factor t/end_time); the others stay free.
    Displacement {
        ux: Option<f64>,
        uy: Option<f64>,
        uz: Option<f64>,
    },
    /// The displacement of a closed-form solution at each particle's reference position,
    /// for the listed components (static path, ramped like `displacement`).
    SolutionDisplacement {
        solution: Solution,
        components: Vec<Axis>,
    },
    /// The traction t = σ(X) n of a closed-form solution's stress on a face with outward
    /// unit normal n along an axis: each particle carries ∫ t dA over its patch of the
    /// face, Δx wide in each direction and clipped to the extent of the region's particles
    /// (the tributary patch of a vertex lattice), by 2-point Gauss in each direction of the
    /// face (exact for tractions quadratic in X).
    SolutionTraction {
        solution: Solution,
        normal: Vec<f64>,
    },
}

impl Condition {
    /// Whether the condition is a load that `interaction::TimedLoads` applies: a traction,
    /// pressure or body force with a time law (a constant one is the boundary's).
    pub fn is_timed_load(&self) -> bool {
        match self {
            Self::Traction { law, .. }
            | Self::BodyForce { law, .. }
            | Self::Pressure { law, .. } => !law.is_constant(),
            _ => false,
        }
    }

    /// The condition's time law (constant for the conditions without one).
    pub fn law(&self) -> &TimeLaw {
        const CONSTANT: &TimeLaw = &TimeLaw::Constant;
        match self {
            Self::Traction { law, .. }
            | Self::BodyForce { law, .. }
            | Self::Pressure { law, .. }
            | Self::Velocity { law, .. } => law,
            _ => CONSTANT,
        }
    }

    /// Whether the condition prescribes motion (velocity or displacement components), so
    /// that a support holds it with a reaction force.
    pub fn is_support(&self) -> bool {
        matches!(
            self,
            Self::Fixed
                | Self::Velocity { .. }
                | Self::Symmetry { .. }
                | Self::Displacement { .. }
                | Self::SolutionDisplacement { .. }
        )
    }

    /// Whether the condition is a prescribed velocity that varies in time: under a time
    /// law, or released at `until`.
    pub fn is_timed_velocity(&self) -> bool {
        match self {
            Self::Velocity { law, until, .. } => !law.is_constant() || until.is_some(),
            _ => false,
        }
    }
}

/// Which side of a pressure's circle the body lies on.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Surface {
    /// The body lies outside the circle (a hole): the pressure pushes outwards.
    Inner,
    /// The body lies inside the circle: the pressure pushes inwards.
    Outer,
}

/// How a load varies in time: its value at time t is the condition's times law(t). A
/// load is evaluated at the middle of each step and held through its stages (as the
/// contact forces are), on both backends.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum TimeLaw {
    /// 1 at every time.
    #[default]
    Constant,
    /// t/duration until `duration`, 1 after.
    Ramp { duration: f64 },
    /// 1 until `start` (default 0), exp(−(t − start)/tau) after: a load held and then
    /// decaying with the time constant tau [s].
    Exponential {
        tau: f64,
        #[serde(default)]
        start: f64,
    },
    /// Linear between the points [t, value], times non-decreasing; the first value before
    /// the first time and the last after the last. A time given twice is a jump: the
    /// second value holds from that time on (`[[0, 1], [1e-4, 1], [1e-4, 0]]` holds a load
    /// for 0.1 ms and removes it).
    Table { points: Vec<[f64; 2]> },
    /// An expression of the time t [s] and named `constants` ([`Expression`]), e.g.
    /// `value = "sin(2*PI*f*t)"` with `constants = { f = 50.0 }`.
    Expression {
        value: String,
        #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
        constants: std::collections::BTreeMap<String, f64>,
    },
}

impl TimeLaw {
    /// The parsed expression of an `expression` law; None for the other laws.
    pub fn expression(&self) -> Option<Result<Expression, String>> {
        let Self::Expression { value, constants } = self else {
            return None;
        };
        Some(Expression::parse(value, &["t"], "the time [s]", constants))
    }

    pub fn is_constant(&self) -> bool {
        *self == Self::Constant
    }

    /// The law's value at time t.
    pub fn at(&self, t: f64) -> f64 {
        match self {
            Self::Constant => 1.0,
            Self::Ramp { duration } => (t / duration).clamp(0.0, 1.0),
            Self::Exponential { tau, start } => (-(t - start).max(0.0) / tau).exp(),
            Self::Table { points } => {
                // The last point at or before t (right-continuous at a jump).
                match points.iter().rposition(|p| p[0] <= t) {
                    None => points.first().map_or(1.0, |p| p[1]),
                    Some(k) if k + 1 == points.len() => points[k][1],
                    Some(k) => {
                        let ([t0, v0], [t1, v1]) = (points[k], points[k + 1]);
                        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
                    }
                }
            }
            Self::Expression { .. } => self
                .expression()
                .and_then(Result::ok)
                .map_or(f64::NAN, |e| e.at(&[t])),
        }
    }
}

/// Closed-form solutions that boundary conditions can take their values from.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Solution {
    /// The cantilever with a parabolic end shear of Timoshenko & Goodier (seed 004 eqs
    /// 53–55, plane stress, the material's E and ν): x ∈ [0, length] from the clamped
    /// end, y ∈ [−depth/2, depth/2], end load `load` per unit thickness [N/m].
    TimoshenkoCantilever { load: f64, length: f64, depth: f64 },
    /// Uniaxial stress σ_aa = `stress` [Pa] along `axis` (default x; seed 004 §6.3): u_a =
    /// σX_a/E, the other components −νσX_k/E. As a traction on the face normal to that
    /// axis it is a uniform pressure −`stress` (§6.2's plate, §6.6's cube).
    UniaxialStress {
        stress: f64,
        #[serde(default = "x_axis")]
        axis: Axis,
    },
}

fn x_axis() -> Axis {
    Axis::X
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
    /// Simulated end time [s] (of the static path: the pseudo-time of the full load).
    pub end_time: f64,
    /// How the run advances: `dynamic`, integrating in time, or `static`, solving for
    /// equilibrium at every load step of `method.dt` ([`crate::statics`]). Absent: the
    /// method's own (static for the static-only methods, dynamic for the others).
    #[serde(default)]
    pub solve: Option<Solve>,
    /// Newton's convergence tolerances of a static run, `{ residual = …, increment = … }`
    /// (each optional; the defaults and the force scale: [`crate::statics::Tolerance`]).
    #[serde(default, skip_serializing_if = "crate::statics::Tolerance::is_unset")]
    pub tolerance: crate::statics::Tolerance,
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
    /// Simulated time between checkpoints [s] (`checkpoint.bin` in the output folder,
    /// from which `--resume` continues); absent: none.
    #[serde(default)]
    pub checkpoint_interval: Option<f64>,
    /// CPU threads of the run (a pool of its own); absent: every core. A study sweeps it
    /// to measure the parallel speed-up.
    #[serde(default)]
    pub threads: Option<usize>,
}

/// `run.solve`.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Solve {
    Dynamic,
    Static,
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
    /// The relative L2 error of the velocity against a closed form at the row's time,
    /// sqrt(Σ V |v − v_ex|²)/sqrt(Σ V |v_ex|²) over the particles, all components (column
    /// `velocity_error`); in case files `{ velocity-error = "free-rod" }`.
    VelocityError(crate::analytic::AnalyticSolution),
    /// How far a ring is from rotational symmetry (2D): the particles grouped into rings
    /// of equal reference radius about the reference centroid (those of a polar lattice),
    /// the largest spread of σ_θθ around a ring, std over the largest |mean| of a ring
    /// (column `hoop_stress_spread`), and of the current gaps between neighbours on a ring,
    /// std over mean (column `hoop_gap_spread`). Both are zero under a rotationally
    /// symmetric motion and grow where particles cluster. With `von-mises-plastic`, also
    /// the largest std over mean of ε_p around a ring, the mean at least 1e-3 (column
    /// `plastic_strain_spread`), which grows where the plastic strain localises.
    RingSymmetry,
    /// The relative errors against the closed form of the case's `solution-displacement`
    /// condition, with the method's own quadrature (seed 001 eqs 71–74): of the
    /// displacement, sqrt(Σ_q w_q |u^h − u_a|²)/sqrt(Σ_q w_q |u_a|²) (column
    /// `displacement_error`), and in energy, sqrt(Σ_q w_q ψ(I + ∇u^h − ∇u_a))/sqrt(Σ_q w_q
    /// ψ(I + ∇u_a)) (column `energy_error`; for the linear-elastic model ψ(I + H) =
    /// ½ ε:C:ε, so this is the energy norm sqrt(½ ∫ (P:Fᵀ of the difference)) of eq 74).
    SolutionError,
    /// Oscillations about a closed form with jumps (`driven-rod`) away from them, relative
    /// to its amplitude V, over the particles farther than
    /// [`crate::observe::FRONT_MARGIN`] smoothing lengths along its axis d from every jump:
    /// the largest |v·d|/V where the closed form is at rest and the nearest jump runs
    /// towards the particle (column `ahead_oscillation`: ahead of the pulse) or away from
    /// it (`behind_oscillation`), and the largest |(v − v_ex)·d|/V where it moves
    /// (`plateau_oscillation`); in case files `{ front-oscillation = "driven-rod" }`.
    FrontOscillation(crate::analytic::AnalyticSolution),
    /// The force each support (a boundary condition that prescribes motion) applies to
    /// hold its prescribed components, and its power, at the last rate evaluation:
    /// R = Σ m (a_prescribed − a) over the components it holds, columns
    /// `<name>.reaction_x`, … and `<name>.power` (R·v), with `<name>` the condition's
    /// `name` (default `boundary<k>`); and for every load with a `name` (a traction,
    /// pressure, body force or a solution's traction), the total external force it applies
    /// at the row's time, `<name>.applied_force_x`, …: the sum of its particles' forces
    /// (a body force's on the method's masses) times its time law at t, or times the load
    /// factor t/end_time on the static path.
    Reaction,
    /// How much of the pressure is a spurious oscillation: ‖δp‖/‖p‖ over the particles,
    /// δp the deviation of each particle's pressure from the linear fit over its
    /// neighbours (column `pressure_oscillation`; [`crate::pressure`]). The frames carry
    /// δp as `pressure_deviation` whether or not the observer is on.
    PressureOscillation,
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
    /// The case's documented checks, evaluated on the series at the end of a run.
    #[serde(default, rename = "check")]
    pub checks: Vec<CheckSpec>,
}

/// A number a run of the case is checked by: a statistic of one series column, printed at
/// the end of the run and kept in `summary.json`, with the range it is expected in.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CheckSpec {
    /// What the number is, in words.
    pub label: String,
    /// The series column it is taken from.
    pub column: String,
    pub statistic: Statistic,
    /// The range [lo, hi] it is expected in, if any.
    pub expected: Option<[f64; 2]>,
    /// Where the expected range comes from (a paper's table, a closed form).
    pub source: Option<String>,
}

/// A statistic of a series column c(t).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Statistic {
    /// c at the last row.
    End,
    Min,
    Max,
    /// max_t |c(t) − c(0)| / |c(0)|.
    Drift,
}

impl Statistic {
    /// The statistic of the values c(t) in row order; NaN without rows.
    pub fn of(self, c: &[f64]) -> f64 {
        let (Some(&first), Some(&last)) = (c.first(), c.last()) else {
            return f64::NAN;
        };
        match self {
            Self::End => last,
            Self::Min => c.iter().copied().fold(f64::INFINITY, f64::min),
            Self::Max => c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            Self::Drift => c.iter().map(|x| (x - first).abs()).fold(0.0, f64::max) / first.abs(),
        }
    }
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
            checks: Vec::new(),
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

/// A section of the reference configuration, the plane X·e_normal = `at` (within one
/// body if `body` is given), across which the series gives the resultant force ∫ P·N dA
/// (columns `<name>.force_x`, …; N = e_normal, the force the material at larger X·N
/// exerts on the rest). Per particle, V P·N times the hat weight
/// max(0, 1 − |X·N − at|/Δx)/Δx, which sums to one over the rows of a lattice, so a
/// uniform P gives ∫ P·N dA exactly wherever the plane lies between rows.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SectionSpec {
    pub name: String,
    pub normal: Axis,
    pub at: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<String>,
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

/// `method.name` of a case table, if it is a string.
fn method_name(table: &toml::Table) -> Option<String> {
    table
        .get("method")?
        .get("name")?
        .as_str()
        .map(str::to_string)
}

/// A change of method by `--set method.name=X`, applied where it stands among the
/// overrides: the keys of the previous method that X also reads are kept, the others are
/// dropped (unless an override of the command sets them, so that a wrong one is still
/// reported), and a note names the dropped ones.
fn method_change(method: &mut toml::Table, name: &str, overrides: &[String]) -> Option<String> {
    let set: Vec<String> = overrides
        .iter()
        .filter_map(|a| a.split_once('=')?.0.trim().strip_prefix("method."))
        .map(|path| path.split('.').next().unwrap_or(path).to_string())
        .collect();
    let dropped = drop_foreign_keys(method, name, &set);
    (!dropped.is_empty()).then(|| {
        format!(
            "method.name = \"{name}\" does not read {}; dropped from the case",
            dropped
                .iter()
                .map(|k| format!("`method.{k}`"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
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
        let mut notes = Vec::new();
        let mut case: Case = if overrides.is_empty() {
            toml::from_str(text).map_err(parse_error)?
        } else {
            let mut table: toml::Table = toml::from_str(text).map_err(parse_error)?;
            for assignment in overrides {
                let name_before = method_name(&table);
                overrides::apply(&mut table, assignment).map_err(|message| {
                    CaseError::Override {
                        file: file.to_path_buf(),
                        assignment: assignment.clone(),
                        message,
                    }
                })?;
                if let Some(name) = method_name(&table).filter(|n| Some(n) != name_before.as_ref())
                    && let Some(toml::Value::Table(method)) = table.get_mut("method")
                {
                    notes.extend(method_change(method, &name, overrides));
                }
            }
            Case::deserialize(table).map_err(parse_error)?
        };
        case.notes = notes;
        case.file = file.to_path_buf();
        case.overrides = overrides.to_vec();
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

    /// The smoothing length h = h_over_dx · Δx.
    /// Whether the run solves for static equilibrium load step by load step: `run.solve
    /// = "static"`, or a static-only method.
    pub fn is_static(&self) -> bool {
        match self.run.solve {
            Some(solve) => solve == Solve::Static,
            None => self
                .method
                .spec
                .entry()
                .features
                .contains(&crate::methods::Feature::StaticDefault),
        }
    }

    pub fn smoothing_length(&self) -> f64 {
        self.method.h_over_dx * self.spacing
    }

    /// The case's kernel in `dim` dimensions.
    pub fn kernel(&self, dim: usize) -> crate::kernel::Kernel {
        crate::kernel::Kernel::new(self.method.kernel, self.smoothing_length(), dim)
    }

    /// A hash of everything in the case but its end time: a checkpoint of a run of this
    /// case, or of the same case run longer, has it.
    pub fn fingerprint(&self) -> u64 {
        let mut case = self.clone();
        case.run.end_time = 0.0;
        fnv1a(toml::to_string(&case).unwrap_or_default().as_bytes())
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

/// 64-bit FNV-1a: a hash that stays the same across Rust versions and platforms.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::{Statistic, TimeLaw};

    #[test]
    fn time_laws_take_their_values() {
        // Exact values (the arithmetic is a division, a clamp or one exponential, ~1e-16).
        assert_eq!(TimeLaw::Constant.at(-1.0), 1.0);
        assert_eq!(TimeLaw::Constant.at(5.0), 1.0);
        let ramp = TimeLaw::Ramp { duration: 2.0 };
        assert_eq!(
            [ramp.at(-1.0), ramp.at(0.5), ramp.at(2.0), ramp.at(7.0)],
            [0.0, 0.25, 1.0, 1.0]
        );
        let decay = TimeLaw::Exponential {
            tau: 1e-4,
            start: 2e-4,
        };
        assert_eq!(decay.at(1e-4), 1.0);
        assert!((decay.at(3e-4) - (-1f64).exp()).abs() < 1e-15);
        assert!((decay.at(4e-4) - (-2f64).exp()).abs() < 1e-15);
        // Held for 0.1 ms, then removed: a jump at a time given twice, the later value
        // from that time on; linear between points; the end values beyond the ends.
        let held = TimeLaw::Table {
            points: vec![[0.0, 1.0], [1e-4, 1.0], [1e-4, 0.0]],
        };
        assert_eq!(
            [held.at(-1.0), held.at(5e-5), held.at(1e-4), held.at(1.0)],
            [1.0, 1.0, 0.0, 0.0]
        );
        let table = TimeLaw::Table {
            points: vec![[1.0, 2.0], [3.0, 6.0], [4.0, 0.0]],
        };
        assert_eq!(
            [table.at(0.0), table.at(2.0), table.at(3.5), table.at(9.0)],
            [2.0, 4.0, 3.0, 0.0]
        );
    }

    #[test]
    fn statistics_of_a_series_column() {
        let c = [2.0, 3.0, 1.0, 2.5];
        assert_eq!(Statistic::End.of(&c), 2.5);
        assert_eq!(Statistic::Min.of(&c), 1.0);
        assert_eq!(Statistic::Max.of(&c), 3.0);
        // max |c − c(0)| = 1 (at 3 and at 1), over |c(0)| = 2.
        assert_eq!(Statistic::Drift.of(&c), 0.5);
        assert!(Statistic::End.of(&[]).is_nan());
    }
}
