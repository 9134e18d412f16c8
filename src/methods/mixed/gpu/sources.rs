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
    count("ghost_src", [1, 0, 0], NONE),
    count("ghost_img", [1, 1, 0], NONE),
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
                count("y", [0, 2, 0], NONE),
                count("field", [0, 2, 0], NONE),
            ],
        },
        PassBytes {
            entry: "ghost_kin",
            traffic: &[
                GHOST_MAP[0],
                GHOST_MAP[1],
                loads("field", [0, 0, 1], NONE),
                stores("field", [0, 0, 1], NONE),
                loads("field", [0, 0, 1], NONE).when(&["KIN_H"]),
                stores("field", [0, 0, 1], NONE).when(&["KIN_H"]),
            ],
        },
        PassBytes {
            entry: "ghost_slopes",
            traffic: &[
                GHOST_MAP[0],
                GHOST_MAP[1],
                loads("field", NONE, NONE).slopes(1),
                stores("field", NONE, NONE).slopes(1),
            ],
        },
        PassBytes {
            entry: "ghost_laplacian",
            traffic: &[
                GHOST_MAP[0],
                GHOST_MAP[1],
                loads("field", [0, 1, 0], NONE),
                stores("field", [0, 1, 0], NONE),
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
            count("offsets", [1, 0, 0], NONE),
            count("ids", NONE, [1, 0, 0]),
            // ∇0W̃_ab.
            count("pair", NONE, [0, 1, 0]),
            // v, F; H, J and p where evolved; ghosts' v and the bond-based F^c from kin.
            count("y", [0, 1, 1], NONE),
            count("y", [0, 0, 1], NONE).when(&["EVOLVE_H"]),
            count("y", [1, 0, 0], NONE).when(&["EVOLVE_J"]),
            count("y", [1, 0, 0], NONE).when(&["AC"]),
            loads("kin", [0, 0, 1], NONE).when(&["BOND"]),
            count("hist", [10, 0, 0], NONE).when(&["MODEL == MODEL_VON_MISES_PLASTIC"]),
            // P (and H).
            stores("kin", [0, 0, 1], NONE),
            stores("kin", [0, 0, 1], NONE).when(&["KIN_H"]),
            // Ḟ, Ḣ, J̇, ṗ.
            count("d", [0, 0, 1], NONE),
            count("d", [0, 0, 1], NONE).when(&["EVOLVE_H"]),
            count("d", [1, 0, 0], NONE).when(&["EVOLVE_J"]),
            count("d", [1, 0, 0], NONE).when(&["AC"]),
            count("status", NONE, NONE),
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
            count("offsets", [1, 0, 0], NONE),
            count("ids", NONE, [1, 0, 0]),
            // X_b − X_a and the bond weight.
            count("pair", NONE, [1, 1, 0]),
            // u, F; ghosts' u from kin.
            count("y", [0, 1, 1], NONE),
            stores("kin", [0, 0, 1], NONE),
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
                count("offsets", [1, 0, 0], NONE),
                count("ids", NONE, [1, 0, 0]),
                // Least-squares weights.
                count("pair", NONE, [0, 1, 0]),
                count("y", [0, 1, 0], NONE),
                // P (and ghosts' v).
                count("kin", [0, 0, 1], NONE),
                count("out", NONE, NONE).slopes(1),
            ],
        },
        PassBytes {
            entry: "laplacian",
            traffic: &[
                count("offsets", [1, 0, 0], NONE),
                count("ids", NONE, [1, 0, 0]),
                // Laplacian weights.
                count("pair", NONE, [1, 0, 0]),
                count("y", [0, 1, 0], NONE),
                count("kin", NONE, NONE),
                count("out", [0, 1, 0], NONE),
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
            count("offsets", [1, 0, 0], NONE),
            count("ids", NONE, [1, 0, 0]),
            // ∇0W̃_ab, ∇0W̃_ba; X_b − X_a (upwind) or the JST scale.
            count("pair", NONE, [0, 2, 0]),
            count("pair", NONE, [0, 1, 0]).when(&["STAB == STAB_UPWIND"]),
            count("pair", NONE, [1, 0, 0]).when(&["STAB == STAB_JST"]),
            count("y", [0, 2, 0], NONE),
            // P (and H).
            count("kin", [0, 0, 1], NONE),
            count("kin", [0, 0, 1], NONE).when(&["KIN_H"]),
            // The Laplacian (JST) or the slopes (reconstruction).
            count("second", [0, 1, 0], NONE).when(&["STAB == STAB_JST"]),
            count("second", NONE, NONE)
                .slopes(1)
                .when(&["STAB == STAB_UPWIND", "RECON"]),
            // T, D(p), D(J).
            count("force", [1, 2, 0], NONE),
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
                count("reference", [1, 1, 0], NONE),
                count("y", [0, 2, 0], NONE),
                count("y0", [0, 2, 0], NONE),
                count("force", [0, 2, 0], NONE),
                count("partials", NONE, NONE),
            ],
        },
        // One item: the partial sums of every workgroup in (not counted), the rotation,
        // translation and centre of the projection out.
        PassBytes {
            entry: "balance_solve",
            traffic: &[
                count("partials", NONE, NONE),
                count("force", [9, 0, 0], NONE)
            ],
        },
        PassBytes {
            entry: "rates",
            traffic: &[
                // T, D(p); D(J) with H kept.
                count("force", [0, 2, 0], NONE),
                count("force", [1, 0, 0], NONE).when(&["KIN_H"]),
                count("y", [0, 1, 0], NONE),
                count("y", [0, 1, 0], NONE).when(&["PROJECTION"]),
                count("y0", [0, 2, 0], NONE).when(&["PROJECTION"]),
                count("reference", [2, 0, 0], NONE),
                count("reference", [0, 1, 0], NONE).when(&["PROJECTION"]),
                count("ext", [0, 1, 0], NONE),
                count("kin", [1, 0, 0], NONE),
                stores("d", [0, 2, 0], NONE),
                count("d", [1, 0, 0], NONE).when(&["KIN_H"]),
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
        traffic: &[count("y", [0, 0, 1], NONE), count("hist", [10, 0, 0], NONE),],
    }]
);

/// The passes compiled with a mixed scene's constants ([`scene`]).
pub const SHADERS: &[Source] = &[
    GHOSTS, KINEMATICS, PLASTIC, BOND, SLOPES, FORCES, MOMENTUM, CORRECTOR, REDUCE, INTEGRATE,
    CONTACT, LOADS, PRESCRIBED,
];
