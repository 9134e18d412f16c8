//! The WGSL sources of the mixed passes and the traffic of their bindings.

use super::*;

/// Shared functions of the mixed passes: indexing, the pair force.
pub(in crate::methods::mixed) const MIXED: Wgsl = wgsl!("mixed/mixed.wgsl");
/// Positions, velocities and the F and H of the stress.
pub(in crate::methods::mixed) const MOTION: Wgsl = wgsl!("mixed/mixed_motion.wgsl");
/// The images of ghosts.
pub(in crate::methods::mixed) const IMAGES: Wgsl = wgsl!("mixed/mixed_images.wgsl");
/// Strain energy and the CFL pair wave speed, for the reduction.
const ENERGY: Wgsl = wgsl!("mixed/mixed_energy.wgsl");

/// A ghost's source particle and its image (reflection and sign), per ghost.
const GHOST_MAP: [Traffic; 2] = [
    read("ghost_src", [1, 0, 0], NONE),
    read("ghost_img", [1, 1, 0], NONE),
];

/// Ghost motion and ghost fields; an item is a ghost. The gathers read a ghost's values
/// once each, counted here, not in the gathers.
pub const GHOSTS: Source = source!(
    "mixed/mixed_ghosts.wgsl",
    [MIXED, IMAGES],
    [("ghost_img", false), ("field", true), ("y", false)],
    &[
        PassBytes {
            entry: "ghost_motion",
            traffic: &[
                GHOST_MAP[0],
                GHOST_MAP[1],
                read("y", [0, 2, 0], NONE),
                write("field", [0, 2, 0], NONE),
            ],
        },
        PassBytes {
            entry: "ghost_kin",
            traffic: &[
                GHOST_MAP[0],
                GHOST_MAP[1],
                read("field", [0, 0, 1], NONE),
                write("field", [0, 0, 1], NONE),
                read("field", [0, 0, 1], NONE).when(&["KIN_H"]),
                write("field", [0, 0, 1], NONE).when(&["KIN_H"]),
            ],
        },
        PassBytes {
            entry: "ghost_slopes",
            traffic: &[
                GHOST_MAP[0],
                GHOST_MAP[1],
                read("field", NONE, NONE).slopes(1),
                write("field", NONE, NONE).slopes(1),
            ],
        },
        PassBytes {
            entry: "ghost_laplacian",
            traffic: &[
                GHOST_MAP[0],
                GHOST_MAP[1],
                read("field", [0, 1, 0], NONE),
                write("field", [0, 1, 0], NONE),
            ],
        },
    ]
);
/// ∇0v, P(F, H, J) and the rates of F, H, J.
pub const KINEMATICS: Source = source!(
    "mixed/mixed_kinematics.wgsl",
    [MECHANICS, MIXED, MOTION, EIGEN, PLASTICITY],
    [("pair", false), ("y", false), ("kin", true), ("d", true)],
    &[PassBytes {
        entry: "kinematics",
        traffic: &[
            read("offsets", [1, 0, 0], NONE),
            read("ids", NONE, [1, 0, 0]),
            // ∇0W̃_ab.
            read("pair", NONE, [0, 1, 0]),
            // v, F; H, J and p where evolved; ghosts' v and the bond-based F^c from kin.
            read("y", [0, 1, 1], NONE),
            read("y", [0, 0, 1], NONE).when(&["EVOLVE_H"]),
            read("y", [1, 0, 0], NONE).when(&["EVOLVE_J"]),
            read("y", [1, 0, 0], NONE).when(&["AC"]),
            read("kin", NONE, NONE),
            read("kin", [0, 0, 1], NONE).when(&["BOND"]),
            read("hist", [10, 0, 0], NONE).when(&["MODEL == MODEL_VON_MISES_PLASTIC"]),
            // P (and H).
            write("kin", [0, 0, 1], NONE),
            write("kin", [0, 0, 1], NONE).when(&["KIN_H"]),
            // Ḟ, Ḣ, J̇, ṗ.
            write("d", [0, 0, 1], NONE),
            write("d", [0, 0, 1], NONE).when(&["EVOLVE_H"]),
            write("d", [1, 0, 0], NONE).when(&["EVOLVE_J"]),
            write("d", [1, 0, 0], NONE).when(&["AC"]),
            read_write("status", NONE, NONE),
        ],
    }]
);
/// The bond-based F^c (seed 002 eqs 37, 39).
pub const BOND: Source = source!(
    "mixed/mixed_bond.wgsl",
    [MIXED, MOTION],
    [("pair", false), ("y", false), ("kin", true)],
    &[PassBytes {
        entry: "bond_f",
        traffic: &[
            read("offsets", [1, 0, 0], NONE),
            read("ids", NONE, [1, 0, 0]),
            // X_b − X_a and the bond weight.
            read("pair", NONE, [1, 1, 0]),
            // u, F; ghosts' u from kin.
            read("y", [0, 1, 1], NONE),
            read("kin", NONE, NONE),
            write("kin", [0, 0, 1], NONE),
        ],
    }]
);
/// Least-squares slopes of v and P, or the Laplacian ∇²v.
pub const SLOPES: Source = source!(
    "mixed/mixed_slopes.wgsl",
    [MIXED, MOTION],
    [("pair", false), ("y", false), ("out", true), ("kin", false)],
    &[
        PassBytes {
            entry: "slopes",
            traffic: &[
                read("offsets", [1, 0, 0], NONE),
                read("ids", NONE, [1, 0, 0]),
                // Least-squares weights.
                read("pair", NONE, [0, 1, 0]),
                read("y", [0, 1, 0], NONE),
                // P (and ghosts' v).
                read("kin", [0, 0, 1], NONE),
                write("out", NONE, NONE).slopes(1),
            ],
        },
        PassBytes {
            entry: "laplacian",
            traffic: &[
                read("offsets", [1, 0, 0], NONE),
                read("ids", NONE, [1, 0, 0]),
                // Laplacian weights.
                read("pair", NONE, [1, 0, 0]),
                read("y", [0, 1, 0], NONE),
                read("kin", NONE, NONE),
                write("out", [0, 1, 0], NONE),
            ],
        },
    ]
);
/// T, D(p) and D(J) per particle.
pub const FORCES: Source = source!(
    "mixed/mixed_forces.wgsl",
    [MIXED, MOTION],
    [
        ("pair", false),
        ("y", false),
        ("kin", false),
        ("force", true),
        ("second", false)
    ],
    &[PassBytes {
        entry: "forces",
        traffic: &[
            read("offsets", [1, 0, 0], NONE),
            read("ids", NONE, [1, 0, 0]),
            // ∇0W̃_ab, ∇0W̃_ba; X_b − X_a (upwind) or the JST scale.
            read("pair", NONE, [0, 2, 0]),
            read("pair", NONE, [0, 1, 0]).when(&["STAB == STAB_UPWIND"]),
            read("pair", NONE, [1, 0, 0]).when(&["STAB == STAB_JST"]),
            read("y", [0, 2, 0], NONE),
            // P (and H).
            read("kin", [0, 0, 1], NONE),
            read("kin", [0, 0, 1], NONE).when(&["KIN_H"]),
            // The Laplacian (JST) or the slopes (reconstruction).
            read("second", [0, 1, 0], NONE).when(&["STAB == STAB_JST"]),
            read("second", NONE, NONE)
                .slopes(1)
                .when(&["STAB == STAB_UPWIND", "RECON"]),
            // T, D(p), D(J).
            write("force", [1, 2, 0], NONE),
        ],
    }]
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
    ],
    &[
        // Per workgroup, 16 partial sums (not counted).
        PassBytes {
            entry: "balance_sums",
            traffic: &[
                read("reference", [1, 1, 0], NONE),
                read("y", [0, 2, 0], NONE),
                read("y0", [0, 2, 0], NONE),
                read("force", [0, 2, 0], NONE),
                write("partials", NONE, NONE),
            ],
        },
        // One item: the partial sums of every workgroup in (not counted), the rotation,
        // translation and centre of the projection out.
        PassBytes {
            entry: "balance_solve",
            traffic: &[
                read("partials", NONE, NONE),
                write("force", [9, 0, 0], NONE)
            ],
        },
        PassBytes {
            entry: "rates",
            traffic: &[
                // T, D(p); D(J) with H kept.
                read("force", [0, 2, 0], NONE),
                read("force", [1, 0, 0], NONE).when(&["KIN_H"]),
                read("y", [0, 1, 0], NONE),
                read("y", [0, 1, 0], NONE).when(&["PROJECTION"]),
                read("y0", [0, 2, 0], NONE).when(&["PROJECTION"]),
                read("reference", [2, 0, 0], NONE),
                read("reference", [0, 1, 0], NONE).when(&["PROJECTION"]),
                read("ext", [0, 1, 0], NONE),
                write("kin", [1, 0, 0], NONE),
                write("d", [0, 2, 0], NONE),
                read_write("d", [1, 0, 0], NONE).when(&["KIN_H"]),
            ],
        },
    ]
);
/// Energies, momenta, checks and the CFL pair wave speed of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [
        MECHANICS, MIXED, MOTION, ENERGY, EIGEN, PLASTICITY, REFERENCE
    ],
    [("y", false), ("kin", false), ("reference", false)]
);
/// The per-step commit of the plastic history.
pub const PLASTIC: Source = source!(
    "mixed/mixed_plastic.wgsl",
    [MIXED, EIGEN, PLASTICITY, PLASTIC_STORE],
    [("y", false)],
    &[PassBytes {
        entry: "commit",
        traffic: &[
            read("y", [0, 0, 1], NONE),
            read_write("hist", [10, 0, 0], NONE),
        ],
    }]
);

/// The passes compiled with a mixed scene's constants ([`scene`]).
pub const SHADERS: &[Source] = &[
    GHOSTS, KINEMATICS, PLASTIC, BOND, SLOPES, FORCES, MOMENTUM, CORRECTOR, REDUCE, INTEGRATE,
    CONTACT, LOADS, PRESCRIBED,
];
