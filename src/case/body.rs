//! `[[body]]`: the shapes that generate the particles, holes, and the volumes' rules;
//! and `[contact]`, penalty contact between the bodies. The initial fields are in
//! `fields`.

use super::{Axis, DisplacementField, VelocityField};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

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
    pub axis: Option<HoleAxis>,
}

/// The direction of a 3D hole: a coordinate axis, or any direction [a_x, a_y, a_z] (a
/// radial hole through a tube's wall).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum HoleAxis {
    Named(Axis),
    Direction([f64; 3]),
}

impl Hole {
    /// Whether the point p (padded to 3D) is inside.
    pub fn contains(&self, p: [f64; 3]) -> bool {
        // p − c, padded with zeros past the hole's dimension.
        let d: [f64; 3] = std::array::from_fn(|k| self.center.get(k).map_or(0.0, |c| p[k] - c));
        let length2: f64 = d.iter().map(|x| x * x).sum();
        let along = match self.axis {
            None => 0.0,
            Some(HoleAxis::Named(a)) => d[a.index()],
            Some(HoleAxis::Direction(a)) => {
                let norm = a.iter().map(|x| x * x).sum::<f64>().sqrt();
                (0..3).map(|k| d[k] * a[k]).sum::<f64>() / norm
            }
        };
        length2 - along * along < self.radius * self.radius
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
    /// A tube (3D) on its own cylindrical lattice, for thin walls: the cell centres of
    /// n_r layers across the wall, n_θ rays over the `angles` and n_z layers along the
    /// axis, each count the nearest whole number to the span over Δx (at least one; n_θ
    /// over the mid radius's arc, or `sectors`), each particle its cell's volume
    /// ½(r₊² − r₋²) Δθ Δz, so that the volumes sum to the tube's. θ turns from the next
    /// axis after `axis` towards the one after it (from x towards y about z); no particle
    /// lies on a face of the tube or of its angles, so a `[[mirror]]` plane can close any
    /// of them.
    Tube {
        base: Vec<f64>,
        axis: Axis,
        inner_radius: f64,
        radius: f64,
        length: f64,
        /// [θ0, θ1] in degrees, 0 < θ1 − θ0 ≤ 360 (the default: the whole circle).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        angles: Option<[f64; 2]>,
        /// The rays over the angles (default: the mid radius's arc over Δx, rounded).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sectors: Option<u32>,
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
    /// centroid, the cell's area or volume its volume ([`super::mesh`]); or, with `nodes =
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

/// Penalty contact of seed 000 §5.8: every body is a master to every other, its boundary
/// the convex hull of its reference particles.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// α of eq 178, f = −α m (d·n) n / Δt²: the fraction of a penetration removed in one
    /// step (the seed uses 0.1).
    pub penalty: f64,
}
