//! The WGSL sources of the mixed passes.

use super::*;

/// Shared functions of the mixed passes: indexing, the pair force.
pub(in crate::methods::mixed) const MIXED: Wgsl = wgsl!("mixed/mixed.wgsl");
/// Positions, velocities and the F and H of the stress.
pub(in crate::methods::mixed) const MOTION: Wgsl = wgsl!("mixed/mixed_motion.wgsl");
/// The images of ghosts.
pub(in crate::methods::mixed) const IMAGES: Wgsl = wgsl!("mixed/mixed_images.wgsl");
/// Strain energy and the CFL pair wave speed, for the reduction.
const ENERGY: Wgsl = wgsl!("mixed/mixed_energy.wgsl");

/// Ghost motion and ghost fields; an item is a ghost.
pub const GHOSTS: Source = source!(
    "mixed/mixed_ghosts.wgsl",
    [MIXED, IMAGES],
    [("ghost_img", false), ("field", true), ("y", false)]
);
/// ∇0v, P(F, H, J) and the rates of F, H, J.
pub const KINEMATICS: Source = source!(
    "mixed/mixed_kinematics.wgsl",
    [MECHANICS, MIXED, MOTION, EIGEN, PLASTICITY, PART],
    [("pair", false), ("y", false), ("kin", true), ("d", true)]
);
/// The bond-based F^c (seed 002 eqs 37, 39).
pub const BOND: Source = source!(
    "mixed/mixed_bond.wgsl",
    [MIXED, MOTION, PART],
    [("pair", false), ("y", false), ("kin", true)]
);
/// Least-squares slopes of v and P, or the Laplacian ∇²v.
pub const SLOPES: Source = source!(
    "mixed/mixed_slopes.wgsl",
    [MIXED, MOTION, PART],
    [("pair", false), ("y", false), ("out", true), ("kin", false)]
);
/// T, D(p) and D(J) per particle.
pub const FORCES: Source = source!(
    "mixed/mixed_forces.wgsl",
    [MIXED, MOTION, PART],
    [
        ("pair", false),
        ("y", false),
        ("kin", false),
        ("force", true),
        ("second", false)
    ]
);
/// The projection's sums and solve, and the rates with the boundary conditions.
pub const MOMENTUM: Source = source!(
    "mixed/mixed_momentum.wgsl",
    [MIXED, BOUNDARY, REFERENCE],
    [
        ("force", false),
        ("y", false),
        ("y0", false),
        ("reference", false),
        ("ext", false),
        ("kin", true),
        ("d", true)
    ]
);
/// SUPG-SPH: the nodes the stress points read, the points' ΔP and Δv, and their gather
/// to D(p) and the rates of F, H, J.
pub const SUPG: Source = source!(
    "mixed/mixed_supg.wgsl",
    [MECHANICS, MIXED, MOTION, IMAGES, REFERENCE],
    [
        ("y", false),
        ("d", true),
        ("kin", false),
        ("force", true),
        ("reference", false),
        ("ghost_img", false),
        ("nodes", true),
        ("shapes", false),
        ("terms", true)
    ]
);
/// Energies, momenta, checks and the CFL pair wave speed of a state.
pub const REDUCE: Source = crate::gpu::reduction::pass(&[
    MECHANICS, MIXED, MOTION, ENERGY, EIGEN, PLASTICITY, REFERENCE, PART,
]);
/// The per-step commit of the plastic history.
pub const PLASTIC: Source = source!(
    "mixed/mixed_plastic.wgsl",
    [MIXED, EIGEN, PLASTICITY, PLASTIC_STORE],
    [("y", false)]
);

/// The passes compiled with a mixed scene's constants ([`scene`]).
pub const SHADERS: &[Source] = &[
    GHOSTS, KINEMATICS, PLASTIC, BOND, SLOPES, FORCES, SUPG, MOMENTUM, CORRECTOR, REDUCE,
    INTEGRATE, CONTACT, LOADS, PRESCRIBED,
];
