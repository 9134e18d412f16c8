//! Mixed {p, F, H, J} SPH (seed 003: Upwind-SPH and JST-SPH) on the GPU: the passes of
//! `shaders/mixed/` and the integrator program of [`crate::gpu::program`]. The set-up is
//! the CPU reference's own (`MixedSph::new`, f64): the reference configuration and
//! neighbours ([`crate::gpu::reference`]), corrected gradients, the reverse pairs,
//! least-squares and Laplacian weights and the ghost table are computed once on the host
//! and uploaded in f32. The CPU method is kept for snapshots (σ and the
//! strain energy of a read-back state, in f64).
//!
//! One rate evaluation, all on the device and recorded in one compute pass:
//! ghost motion → [bond-based F^c] → kinematics (P, ∇0v, Ḟ, Ḣ, J̇) → ghost kinematics →
//! [slopes or Laplacians → their ghosts] → forces (T, D(p), D(J)) → [projection sums →
//! solve] → rates of v and u with the boundary conditions. A whole step, or several, is
//! recorded into one command encoder; the host reads back only when asked.

use super::compressibility::UNCONVERGED;
use super::gpu_corrector::{CORRECTOR, DeviceCorrector};
use super::system::{Fluxes, MixedSph, MixedState};
use super::{CflWaveSpeed, DeformationGradient, Momentum};
use crate::balance::Booked;
use crate::boundary::Reaction;
use crate::gpu::context::{Gpu, GpuError, Pipeline, WORKGROUP};
use crate::gpu::layout::{Fields, GpuDim};
use crate::gpu::profile::{NONE, PassBytes, Scale, Traffic, read, read_write, write};
use crate::gpu::program::{StateLayout, Stepper};
use crate::gpu::reduction::{self, Reduced, Reduction, WorkBalance};
use crate::gpu::reference::{self, DeviceReference, Extras};
use crate::gpu::shaders::{
    self, BOUNDARY, CONTACT, Constants, EIGEN, INTEGRATE, LOADS, MECHANICS, PLASTIC_STORE,
    PLASTICITY, PRESCRIBED, REFERENCE, Source, Wgsl, source, wgsl,
};
use crate::gpu::{SetupError, check_f32_particles, check_f32_range, check_f32_run};
use crate::integrate::IntegratorKind;
use crate::integrate::{Buf, Evaluation, evaluations};
use crate::interaction::gpu::GpuInteractions;
use crate::material::MaterialModel;
use crate::methods::shared::PseudoTime;
use crate::methods::{BlowUp, Method, not_run_by};
use crate::observe::{Invariants, Snapshot};
use crate::plasticity::History;
use crate::run::{Engine, Failed, build_method};
use crate::scene::Case;
use crate::tensor::Dim;
use bytemuck::{Pod, Zeroable};

/// Shared functions of the mixed passes: indexing, the pair force.
pub(super) const MIXED: Wgsl = wgsl!("mixed/mixed.wgsl");
/// Positions, velocities and the F and H of the stress.
pub(super) const MOTION: Wgsl = wgsl!("mixed/mixed_motion.wgsl");
/// The images of ghosts.
pub(super) const IMAGES: Wgsl = wgsl!("mixed/mixed_images.wgsl");
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

/// The flat buffers of a mixed scene, each described once ([`Fields`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MixedLayout {
    /// Real particles and ghosts.
    pub n: usize,
    pub ghosts: usize,
    pub dim: usize,
    /// The kinematics keep H for the D(J) gather (Upwind-SPH with J evolved).
    pub kin_h: bool,
    /// The state [u | v | F − I | H − I | J − 1 | p] of the real particles (H and J where
    /// evolved, the pressure p under artificial compressibility).
    pub state: Fields,
    /// [P | H − I] of the real particles then the ghosts, the ghost motion [u | v], the
    /// bond-based F^c − I and the power of supports and loads.
    pub kin: Fields,
    /// [T | D(p) | D(J)] of the real particles and the projection's λ, μ, c − X̄ (vec3
    /// padded to four floats each).
    pub force: Fields,
    /// Per pair in CSR order: G_ab = V_b g_ab, G_ba = V_b g_ba, d_ab = X_b − X_a (upwind
    /// flux, bond-based F), s_ab (JST), w_ab (least-squares slopes), ℓ_ab (JST
    /// Laplacian), w_ab (bond-based F), ℓ_ab of the pseudo-viscosity (eq 58).
    pub pair: Fields,
    pub reference: Fields,
    /// The corrector of artificial compressibility (mixed_corrector.wgsl): the iterate
    /// [w | δp] = [v − v^int | p − p^n], its pseudo stage, their rates, v^int, p^n, H^n
    /// and the constant part c of the pressure equation.
    pub corr: Fields,
}

impl MixedLayout {
    /// The layout of the scene set up in `cpu`.
    pub fn of<D: Dim>(cpu: &MixedSph<D>) -> Self {
        let n = cpu.reference().len();
        let ghosts = cpu.extended_reference().0.len() - n;
        let pairs = cpu.neighbours().pair_count();
        let conserved = cpu.conserved();
        let (evolves_h, evolves_j) = (conserved.evolves_h(), cpu.evolves_j());
        let corrector = cpu.corrector();
        let ac = corrector.is_some();
        let pseudo_viscosity = corrector.is_some_and(|c| c.laplacian_weights().is_some());
        let (jst, bond) = (cpu.jst().is_some(), cpu.bond_weights().is_some());
        let upwind = !jst;
        let kin_h = upwind && evolves_j;
        let dim = D::N;
        let constrained = cpu.boundary().constrained.len();
        Self {
            n,
            ghosts,
            dim,
            kin_h,
            state: Fields::new("", dim)
                .vectors("U", true, n)
                .vectors("V", true, n)
                .tensors("F", true, n)
                .tensors("H", evolves_h, n)
                .scalars("J", evolves_j, n)
                .scalars("PRES", ac, n),
            kin: reduction::with_reactions(
                Fields::new("K", dim)
                    .tensors("P", true, n + ghosts)
                    .tensors("H", kin_h, n + ghosts)
                    .vectors("GM", true, 2 * ghosts)
                    .tensors("FC", bond, n)
                    .scalars("POW", true, n),
                constrained,
            ),
            force: Fields::new("F", dim)
                .vectors("T", true, n)
                .vectors("D", true, n)
                .scalars("J", true, n)
                .block("PROJ", true, 3, 4),
            pair: Fields::new("P", dim)
                .vectors("G", true, pairs)
                .vectors("GR", true, pairs)
                .vectors("DX", upwind || bond, pairs)
                .scalars("S", jst, pairs)
                .vectors("LS", upwind && cpu.reconstruction(), pairs)
                .scalars("ELL", jst, pairs)
                .scalars("W", bond, pairs)
                .scalars("BL", pseudo_viscosity, pairs),
            reference: reference::fields(n, constrained, dim, EXTRAS),
            corr: Fields::new("C", dim)
                .vectors("V", ac, n)
                .scalars("Q", ac, n)
                .vectors("V1", ac, n)
                .scalars("Q1", ac, n)
                .vectors("RV", ac, n)
                .scalars("RQ", ac, n)
                .vectors("VI", ac, n)
                .scalars("PN", ac, n)
                .tensors("HN", ac, n)
                .scalars("C", ac, n),
        }
    }

    fn stepped(&self) -> StateLayout {
        StateLayout {
            n: self.n,
            dim: self.dim,
            rest: self.state.offset("F"),
            len: self.state.len(),
        }
    }

    /// A mixed state as a flat f32 state: F − I, H − I and J − 1 are formed in f64.
    fn encode<D: GpuDim>(&self, y: &MixedState<D>) -> Vec<f32> {
        let l = &self.state;
        let mut flat = l.zeroed();
        l.write_v::<D>(&mut flat, "U", &y.u);
        l.write_v::<D>(&mut flat, "V", &y.v);
        l.write_t::<D>(&mut flat, "F", &y.f, D::identity());
        l.write_t::<D>(&mut flat, "H", &y.h, D::identity());
        l.write_s(&mut flat, "J", &y.j, 1.0);
        l.write_s(&mut flat, "PRES", &y.pressure, 0.0);
        flat
    }

    /// Decodes a flat state (`excess`: F, H, J are stored less I, I, 1) or rate buffer.
    fn decode<D: GpuDim>(&self, flat: &[f32], excess: bool) -> MixedState<D> {
        let (one_t, one) = if excess {
            (D::identity(), 1.0)
        } else {
            (D::zero_t(), 0.0)
        };
        let l = &self.state;
        MixedState {
            u: l.read_v::<D>(flat, "U"),
            v: l.read_v::<D>(flat, "V"),
            f: l.read_t::<D>(flat, "F", one_t),
            h: l.read_t::<D>(flat, "H", one_t),
            j: l.read_s(flat, "J", one),
            pressure: l.read_s(flat, "PRES", 0.0),
        }
    }
}

/// The reference fields the mixed passes read besides X and V: X − X̄ for the projection.
const EXTRAS: Extras = Extras {
    lo: false,
    centred: true,
};

/// The layout and compiled-in constants of a scene's mixed passes, from its CPU set-up.
///
/// Under artificial compressibility the material's constants are the predictor's: BULK
/// and LAMBDA of κ̃, and C_P = c̃_p; the true κ enters the corrector as INV_BULK = 1/κ,
/// zero at ν = 0.5.
pub fn scene<D: GpuDim>(case: &Case, cpu: &MixedSph<D>) -> (MixedLayout, Constants) {
    let layout = MixedLayout::of(cpu);
    let l = &layout;
    let spec = super::scheme(case).and_then(|(o, _)| o.artificial_compressibility);
    let material = &match spec {
        Some(ac) => ac.predictor(cpu.material()),
        None => *cpu.material(),
    };
    let corrector = cpu.corrector();
    let total_vol: f64 = cpu.volume().iter().sum();
    let jst = cpu.jst();
    let (eps2, eps4) = jst.map_or((0.0, 0.0), |(c, ..)| (c.eps2, c.eps4));
    let u = |x: usize| x as u32;
    let constants = Constants::default()
        .u32("N", u(l.n))
        .u32("BODIES", u(case.bodies.len()))
        .u32("NG", u(l.ghosts))
        .material(material)
        .f32("C_P", material.p_wave_speed())
        .f32("C_S", material.s_wave_speed())
        .f32("SPACING", case.spacing)
        .u32(
            "PAIR_STRETCH",
            u32::from(cpu.cfl_wave_speed() == CflWaveSpeed::Pair),
        )
        .f32("H", cpu.smoothing_length())
        .choice("STAB", &["UPWIND", "JST"], usize::from(jst.is_some()))
        .u32("RECON", u32::from(cpu.reconstruction()))
        .f32("EPS2", eps2)
        .f32("EPS4", eps4)
        .choice(
            "MOMENTUM",
            &["WEAK", "SYMMETRISED"],
            usize::from(cpu.momentum() == Momentum::Symmetrised),
        )
        .u32("EVOLVE_H", u32::from(l.state.has("H")))
        .u32("EVOLVE_J", u32::from(l.state.has("J")))
        .u32("KIN_H", u32::from(l.kin_h))
        .u32("BOND", u32::from(l.kin.has("FC")))
        .u32("PROJECTION", u32::from(cpu.projection()))
        .u32("GROUPS", u(l.n).div_ceil(WORKGROUP))
        .f32("TOTAL_VOL", total_vol)
        .u32("REST_OFF", u(l.state.offset("F")))
        .u32("AC", u32::from(corrector.is_some()))
        .f32("INV_BULK", corrector.map_or(0.0, |c| 1.0 / c.kappa()))
        .f32("TOLERANCE", corrector.map_or(0.0, |c| c.tolerance()))
        .u32(
            "MAX_ITERATIONS",
            corrector.map_or(0, |c| c.max_iterations()),
        )
        .u32("PSEUDO_VISCOSITY", u32::from(l.pair.has("BL")));
    let constants = [&l.state, &l.kin, &l.force, &l.pair, &l.reference, &l.corr]
        .into_iter()
        .fold(constants, |c, fields| fields.constants(c));
    (layout, constants)
}

/// The per-pair buffer of the scene set up in `cpu`, host side (f32).
fn pair_data<D: GpuDim>(cpu: &MixedSph<D>, l: &Fields) -> Vec<f32> {
    let csr = cpu.neighbours();
    let (x0, vol) = cpu.extended_reference();
    let (grad, grad_rev) = cpu.pair_gradients();
    let rows = || (0..csr.len()).flat_map(|a| csr.range(a).map(move |q| (a, q)));
    // Gradients scaled by V_b: G_b(X_a) = V_b g_ab.
    let scaled = |g: &[D::V]| -> Vec<D::V> {
        rows()
            .map(|(_, q)| g[q] * vol[csr.ids[q] as usize])
            .collect()
    };
    let mut flat = l.zeroed();
    l.write_v::<D>(&mut flat, "G", &scaled(grad));
    l.write_v::<D>(&mut flat, "GR", &scaled(grad_rev));
    if l.has("DX") {
        let d: Vec<D::V> = rows()
            .map(|(a, q)| x0[csr.ids[q] as usize] - x0[a])
            .collect();
        l.write_v::<D>(&mut flat, "DX", &d);
    }
    if let Some((_, ell, s)) = cpu.jst() {
        l.write_s(&mut flat, "S", s, 0.0);
        l.write_s(&mut flat, "ELL", ell, 0.0);
    }
    if l.has("LS") {
        l.write_v::<D>(&mut flat, "LS", cpu.ls_weights());
    }
    if let Some(w) = cpu.bond_weights() {
        l.write_s(&mut flat, "W", w, 0.0);
    }
    if let Some(ell) = cpu.corrector().and_then(|c| c.laplacian_weights()) {
        l.write_s(&mut flat, "BL", ell, 0.0);
    }
    flat
}

/// The uniform `Stage` of `mixed_momentum.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct StagePoints {
    half_dt: f32,
    mid: u32,
}

/// The pipelines of the mixed passes.
struct Passes {
    ghost_motion: Pipeline,
    ghost_kin: Pipeline,
    /// Ghost slopes or Laplacians.
    ghost_second: Pipeline,
    /// The bond-based F^c, where the scene uses it.
    bond: Option<Pipeline>,
    kinematics: Pipeline,
    /// Slopes or Laplacians.
    second: Pipeline,
    forces: Pipeline,
    balance_sums: Pipeline,
    balance_solve: Pipeline,
    rates: Pipeline,
}

/// The bind groups of one rate evaluation (a source state and its balance points).
struct Bound {
    ghost_motion: wgpu::BindGroup,
    ghost_kin: wgpu::BindGroup,
    bond: Option<wgpu::BindGroup>,
    kinematics: wgpu::BindGroup,
    /// Slopes or Laplacians, and their ghost fill.
    second: Option<(wgpu::BindGroup, wgpu::BindGroup)>,
    forces: wgpu::BindGroup,
    balance_sums: wgpu::BindGroup,
    balance_solve: wgpu::BindGroup,
    rates: wgpu::BindGroup,
    /// The corrector's start, under artificial compressibility.
    corrector_start: Option<wgpu::BindGroup>,
}

/// The passes of a rate evaluation and their bind groups.
struct Evaluator {
    passes: Passes,
    /// The corrector of every stage under artificial compressibility.
    corrector: Option<DeviceCorrector>,
    /// Bind groups by [`Evaluator::key`].
    bound: Vec<((Buf, bool), Bound)>,
    n: u32,
    ghosts: u32,
    projection: bool,
    /// The second TVD-RK2 stage balances about x^n + Δt/2 (v^n + v*) (projection on).
    tvd_mid: bool,
}

impl Evaluator {
    /// The source buffer of an evaluation, and whether it balances about the mid-step
    /// points.
    fn key(&self, e: Evaluation) -> (Buf, bool) {
        (e.src, self.tvd_mid && e.index == 1)
    }

    fn bound(&self, key: (Buf, bool)) -> &Bound {
        &self
            .bound
            .iter()
            .find(|(k, _)| *k == key)
            .expect("every evaluation of the program is bound")
            .1
    }

    /// The motion of the ghosts and, with the bond-based F, F^c − I of the state bound
    /// in `b`: what the kinematics read besides the state.
    fn record_motion(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>, b: &Bound) {
        let p = &self.passes;
        if self.ghosts > 0 {
            gpu.dispatch(pass, &p.ghost_motion, &b.ghost_motion, self.ghosts);
        }
        if let (Some(pipeline), Some(bond)) = (&p.bond, &b.bond) {
            gpu.dispatch(pass, pipeline, bond, self.n);
        }
    }

    /// Records one rate evaluation into one compute pass.
    fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation) {
        let b = self.bound(self.key(e));
        let (p, n, ng) = (&self.passes, self.n, self.ghosts);
        let mut pass = encoder.begin_compute_pass(&Default::default());
        self.record_motion(gpu, &mut pass, b);
        gpu.dispatch(&mut pass, &p.kinematics, &b.kinematics, n);
        if ng > 0 {
            gpu.dispatch(&mut pass, &p.ghost_kin, &b.ghost_kin, ng);
        }
        if let Some((second, ghost_second)) = &b.second {
            gpu.dispatch(&mut pass, &p.second, second, n);
            if ng > 0 {
                gpu.dispatch(&mut pass, &p.ghost_second, ghost_second, ng);
            }
        }
        gpu.dispatch(&mut pass, &p.forces, &b.forces, n);
        self.record_rates(gpu, &mut pass, b);
        if let (Some(corrector), Some(start)) = (&self.corrector, &b.corrector_start) {
            // The predictor's rates give v^int; the corrector adds its force to T, and
            // the rates follow again from the forces of the stage.
            corrector.record(gpu, &mut pass, start);
            self.record_rates(gpu, &mut pass, b);
        }
    }

    /// The projection of the forces and the rates with the boundary conditions.
    fn record_rates(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>, b: &Bound) {
        let (p, n) = (&self.passes, self.n);
        if self.projection {
            gpu.dispatch(pass, &p.balance_sums, &b.balance_sums, n);
            gpu.dispatch(pass, &p.balance_solve, &b.balance_solve, 1);
        }
        gpu.dispatch(pass, &p.rates, &b.rates, n);
    }
}

/// Values of `status` when no particle failed.
const STATUS_OK: [u32; 2] = [u32::MAX; 2];

/// The mixed system resident on the GPU.
pub struct GpuMixed<D: GpuDim> {
    gpu: Gpu,
    cpu: MixedSph<D>,
    layout: MixedLayout,
    stepper: Stepper,
    evaluator: Evaluator,
    /// The `Stage` uniform of the mid-step points (Δt/2 rewritten when Δt changes).
    mid_points: wgpu::Buffer,
    dt: f64,
    kin: wgpu::Buffer,
    force: wgpu::Buffer,
    status: wgpu::Buffer,
    reduction: Reduction,
    /// The plastic history (plasticity.wgsl; 10 floats of a dummy for elastic models).
    hist: wgpu::Buffer,
    /// The commit of the plastic history before every step (mixed_plastic.wgsl).
    commit: Option<(Pipeline, wgpu::BindGroup)>,
    /// Passes before every step (contact) and the `ext` they write.
    interactions: GpuInteractions,
    work: WorkBalance,
    /// The balance's terms besides the work of supports and loads: zero where the case has
    /// none, None where it has them and they are not booked here (the stabilisation's
    /// dissipation; the plastic work, committed on the device; contact's, which `ext`
    /// adds to the loads' power).
    unbooked: Booked,
}

impl<D: GpuDim> GpuMixed<D> {
    /// Builds the CPU set-up of the case and uploads it with the initial state.
    pub fn new(case: &Case, gpu: Gpu) -> Result<Self, SetupError> {
        let (options, _) = super::scheme(case).ok_or_else(|| not_run_by(case, "GpuMixed"))?;
        let plastic = case.material.model == MaterialModel::VonMisesPlastic;
        if plastic && options.deformation_gradient == DeformationGradient::BondBased {
            return Err(case
                .invalid(
                    "method.deformation_gradient",
                    "the GPU commits the plastic history from the evolved F; the bond-based F \
                     with `von-mises-plastic` runs with --backend cpu",
                )
                .into());
        }
        let cpu: MixedSph<D> = build_method(case)?;
        let (layout, constants) = scene(case, &cpu);
        check_f32_range(case, &constants)?;
        check_f32_run(case, cpu.boundary())?;
        let y0 = cpu.initial_state();
        check_f32_particles::<D>(case, cpu.reference(), &y0.u, &y0.v, cpu.body())?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);
        let (n, ng) = (layout.n, layout.ghosts);
        gpu.check_size("per-pair buffer", layout.pair.bytes())?;
        gpu.check_size("kinematics buffer", layout.kin.bytes())?;
        let (x0, vol) = cpu.extended_reference();
        let device = DeviceReference::upload::<D>(
            &gpu,
            &x0[..n],
            &vol[..n],
            cpu.boundary(),
            cpu.neighbours(),
            EXTRAS,
        );
        let pair = gpu.storage("per-pair data", &pair_data(&cpu, &layout.pair));
        // Slopes (upwind with reconstruction) or Laplacians (JST) of the extended particles.
        let second_len = if layout.pair.has("ELL") {
            (n + ng) * D::N
        } else if layout.pair.has("LS") {
            (n + ng) * (D::N + 1) * D::N * D::N
        } else {
            0
        };
        gpu.check_size("slope buffer", second_len as u64 * 4)?;
        let second = gpu.zeroed("slopes or Laplacians", second_len as u64 * 4);

        // Ghost table: source and (r, σ) of every ghost.
        let table = cpu.ghosts().table();
        let ghost_src: Vec<u32> = table.iter().map(|&(s, _)| s).collect();
        let ghost_img: Vec<f32> = table
            .iter()
            .flat_map(|(_, m)| {
                (0..D::N)
                    .map(|l| m.axis_sign(l) as f32)
                    .chain([m.sign() as f32])
            })
            .collect();
        let ghost_src = gpu.storage("ghost sources", &ghost_src);
        let ghost_img = gpu.storage("ghost images", &ghost_img);

        let kin = gpu.zeroed("kinematics", layout.kin.bytes());
        let force = gpu.zeroed("forces", layout.force.bytes());
        let status = gpu.storage("status", &STATUS_OK);
        let (gx, gy) = gpu.groups(n as u32);
        let partials = gpu.zeroed("balance partials", u64::from(gx * gy) * 16 * 4);
        let hist = gpu.storage(
            "plastic history",
            &History::VIRGIN_F32.repeat(if plastic { n } else { 1 }),
        );

        let stepper = Stepper::new(
            &gpu,
            case.method.integrator,
            &compose(&INTEGRATE),
            layout.stepped(),
            &layout.encode(&cpu.initial_state()),
        )?;
        let interactions = GpuInteractions::new(
            &gpu,
            cpu.interactions(),
            cpu.boundary(),
            &compose,
            &device.reference,
            stepper.buffer(Buf::Y),
            device.traction,
        )?;

        let ghosts_src = compose(&GHOSTS);
        let slopes_src = compose(&SLOPES);
        let momentum_src = compose(&MOMENTUM);
        let pipeline = |label: &str, src: &str, entry: &str| gpu.pipeline(label, src, entry);
        let (second_entry, ghost_second_entry) = if layout.pair.has("ELL") {
            ("laplacian", "ghost_laplacian")
        } else {
            ("slopes", "ghost_slopes")
        };
        let passes = Passes {
            ghost_motion: pipeline("ghost motion", &ghosts_src, "ghost_motion")?,
            ghost_kin: pipeline("ghost kinematics", &ghosts_src, "ghost_kin")?,
            ghost_second: pipeline("ghost slopes", &ghosts_src, ghost_second_entry)?,
            bond: layout
                .kin
                .has("FC")
                .then(|| pipeline("bond-based F", &compose(&BOND), "bond_f"))
                .transpose()?,
            kinematics: pipeline("mixed kinematics", &compose(&KINEMATICS), "kinematics")?,
            second: pipeline("slopes", &slopes_src, second_entry)?,
            forces: pipeline("mixed forces", &compose(&FORCES), "forces")?,
            balance_sums: pipeline("balance sums", &momentum_src, "balance_sums")?,
            balance_solve: pipeline("balance solve", &momentum_src, "balance_solve")?,
            rates: pipeline("mixed rates", &momentum_src, "rates")?,
        };

        let stage_points = gpu.uniform(
            "stage points",
            &StagePoints {
                half_dt: 0.0,
                mid: 0,
            },
        );
        let mid_points = gpu.uniform(
            "mid-step points",
            &StagePoints {
                half_dt: 0.0,
                mid: 1,
            },
        );
        let mut evaluator = Evaluator {
            passes,
            corrector: None,
            bound: Vec::new(),
            n: n as u32,
            ghosts: ng as u32,
            projection: cpu.projection(),
            tvd_mid: cpu.projection() && case.method.integrator == IntegratorKind::TvdRk2,
        };
        let mut keys = vec![(Buf::Y, false)];
        for e in evaluations(case.method.integrator) {
            let key = evaluator.key(e);
            if !keys.contains(&key) {
                keys.push(key);
            }
        }
        let y_start = stepper.buffer(Buf::Y);
        // Every buffer of the passes by binding name, with the state `y` an evaluation
        // reads and the balance points of its stage.
        let table = |y, points| -> Vec<(&str, &wgpu::Buffer)> {
            vec![
                ("offsets", &device.offsets),
                ("ids", &device.ids),
                ("reference", &device.reference),
                ("pair", &pair),
                ("ghost_src", &ghost_src),
                ("ghost_img", &ghost_img),
                ("field", &kin),
                ("kin", &kin),
                ("second", &second),
                ("out", &second),
                ("force", &force),
                ("status", &status),
                ("hist", &hist),
                ("partials", &partials),
                ("ext", interactions.ext()),
                ("y0", y_start),
                ("d", stepper.buffer(Buf::Rates)),
                ("stage", points),
                ("y", y),
            ]
        };
        let commit = match plastic {
            true => {
                let pipeline = gpu.pipeline("plastic commit", &compose(&PLASTIC), "commit")?;
                let bind = gpu.bind(&pipeline, &table(y_start, &stage_points))?;
                Some((pipeline, bind))
            }
            false => None,
        };
        let p = &evaluator.passes;
        let corr = gpu.zeroed("corrector", layout.corr.bytes());
        let state_bytes = layout.state.bytes();
        let corrector = match cpu.corrector() {
            Some(c) => {
                let mut t = table(y_start, &stage_points);
                t.push(("corr", &corr));
                let source = compose(&CORRECTOR);
                Some(DeviceCorrector::new(&gpu, &source, c, n, state_bytes, &t)?)
            }
            None => None,
        };
        let bind = |(src, mid): (Buf, bool)| -> Result<Bound, GpuError> {
            let points = if mid { &mid_points } else { &stage_points };
            let t = table(stepper.buffer(src), points);
            let mut with_second = t.clone();
            with_second.push(("field", &second));
            let second = match second_len {
                0 => None,
                _ => Some((
                    gpu.bind(&p.second, &t)?,
                    gpu.bind(&p.ghost_second, &with_second)?,
                )),
            };
            Ok(Bound {
                ghost_motion: gpu.bind(&p.ghost_motion, &t)?,
                ghost_kin: gpu.bind(&p.ghost_kin, &t)?,
                bond: p.bond.as_ref().map(|b| gpu.bind(b, &t)).transpose()?,
                kinematics: gpu.bind(&p.kinematics, &t)?,
                second,
                forces: gpu.bind(&p.forces, &t)?,
                balance_sums: gpu.bind(&p.balance_sums, &t)?,
                balance_solve: gpu.bind(&p.balance_solve, &t)?,
                rates: gpu.bind(&p.rates, &t)?,
                corrector_start: corrector
                    .as_ref()
                    .map(|c| c.bind_start(&gpu, &[t.as_slice(), &[("corr", &corr)]].concat()))
                    .transpose()?,
            })
        };
        evaluator.bound = keys
            .into_iter()
            .map(|k| Ok((k, bind(k)?)))
            .collect::<Result<_, GpuError>>()?;
        evaluator.corrector = corrector;
        let reduction = Reduction::new(&gpu, &compose(&REDUCE), &table(y_start, &stage_points), n)?;
        Ok(Self {
            gpu,
            cpu,
            layout,
            stepper,
            evaluator,
            mid_points,
            dt: f64::NAN,
            kin,
            force,
            status,
            reduction,
            hist,
            commit,
            interactions,
            work: WorkBalance::default(),
            unbooked: Booked {
                dissipated: None,
                plastic_work: (!plastic).then_some(0.0),
                contact_energy: case.contact.is_none().then_some(0.0),
                ..Booked::default()
            },
        })
    }
}

impl<D: GpuDim> GpuMixed<D> {
    /// The CPU reference of the same scene (its set-up is the one uploaded).
    pub fn cpu(&self) -> &MixedSph<D> {
        &self.cpu
    }

    /// Writes Δt/2 into the uniform of the mid-step balance points when Δt changes.
    fn set_dt(&mut self, dt: f64) {
        if dt != self.dt {
            self.dt = dt;
            let points = StagePoints {
                half_dt: (0.5 * dt) as f32,
                mid: 1,
            };
            self.gpu
                .queue
                .write_buffer(&self.mid_points, 0, bytemuck::bytes_of(&points));
        }
    }

    /// Records `steps` steps of size `dt` into one command encoder and submits them.
    /// Under artificial compressibility the batch runs again from its start when a stage
    /// ran out of the pseudo steps recorded for it ([`DeviceCorrector`]).
    pub fn advance_steps(&mut self, dt: f64, steps: u32) {
        self.work.advance(dt, steps);
        self.reduction.invalidate();
        self.set_dt(dt);
        self.interactions.set_step(&self.gpu, dt);
        let start = self.interactions.time();
        loop {
            self.interactions.set_time(start);
            self.record_steps(dt, steps);
            let Some(corrector) = self.evaluator.corrector.as_mut() else {
                return;
            };
            if corrector.finish_batch(&self.gpu) {
                return;
            }
            corrector.restore_flags(&self.gpu, &self.status);
            self.stepper
                .restart_from(&self.gpu, corrector.saved_state());
        }
    }

    /// Records the steps of one batch and submits them; under artificial
    /// compressibility the state and failure flags at its start are saved first.
    fn record_steps(&mut self, dt: f64, steps: u32) {
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        let Self {
            gpu,
            cpu,
            stepper,
            evaluator,
            commit,
            layout,
            interactions,
            status,
            ..
        } = self;
        if let (Some(c), Some(cpu)) = (&mut evaluator.corrector, cpu.corrector()) {
            c.record_batch(u64::from(steps) * evaluations(stepper.kind()).len() as u64);
            c.set_dt(gpu, dt, cpu);
            c.save(&mut encoder, stepper.buffer(Buf::Y), status);
        }
        let evaluator = &*evaluator;
        stepper.record(
            gpu,
            &mut encoder,
            dt,
            steps,
            |encoder, e| evaluator.record(gpu, encoder, e),
            |encoder| {
                interactions.record(gpu, encoder, layout.n as u32);
                if let Some((pipeline, bind)) = commit {
                    let mut pass = encoder.begin_compute_pass(&Default::default());
                    gpu.dispatch(&mut pass, pipeline, bind, layout.n as u32);
                }
                if let Some(c) = &evaluator.corrector {
                    c.begin_step(encoder);
                }
            },
        );
        self.gpu.queue.submit([encoder.finish()]);
    }
}

impl<D: GpuDim> GpuMixed<D> {
    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> MixedState<D> {
        let flat: Vec<f32> = self.gpu.read(self.stepper.buffer(Buf::Y));
        self.layout.decode(&flat, true)
    }

    /// Replaces the state (e.g. to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &MixedState<D>) {
        self.stepper.set_state(&self.gpu, &self.layout.encode(y));
        self.reduction.invalidate();
    }

    /// Rates of a given state (balanced about its own positions), read back. Under
    /// artificial compressibility the corrector takes the Δt of the last step.
    pub fn rates(&mut self, y: &MixedState<D>) -> MixedState<D> {
        self.set_state(y);
        self.evaluate(Evaluation {
            src: Buf::Y,
            index: 0,
        })
    }

    /// Rates at the second stage of a TVD-RK2 step of size `dt` from `start` (y^n), of the
    /// stage state y*, read back: with the projection they balance about
    /// x^n + Δt/2 (v^n + v*).
    pub fn second_stage_rates(
        &mut self,
        start: &MixedState<D>,
        stage: &MixedState<D>,
        dt: f64,
    ) -> MixedState<D> {
        assert_eq!(
            self.stepper.kind(),
            IntegratorKind::TvdRk2,
            "the scene's integrator must be TVD-RK2"
        );
        self.set_state(start);
        let flat = self.layout.encode(stage);
        self.gpu.queue.write_buffer(
            self.stepper.buffer(Buf::Stage),
            0,
            bytemuck::cast_slice(&flat),
        );
        self.set_dt(dt);
        self.evaluate(Evaluation {
            src: Buf::Stage,
            index: 1,
        })
    }

    /// Records one evaluation alone and reads its rates back.
    fn evaluate(&mut self, e: Evaluation) -> MixedState<D> {
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.evaluator.record(&self.gpu, &mut encoder, e);
        self.gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = self.gpu.read(self.stepper.buffer(Buf::Rates));
        self.layout.decode(&d, false)
    }

    /// P of the real particles at the last rate evaluation.
    pub fn first_piola(&self) -> Vec<D::T> {
        let kin: Vec<f32> = self.gpu.read(&self.kin);
        let mut p = self.layout.kin.read_t::<D>(&kin, "P", D::zero_t());
        p.truncate(self.layout.n);
        p
    }

    /// T, D(p) and D(J) of the last rate evaluation, before the projection (D(J) is zero
    /// where the scene does not evolve J or is JST-SPH: nothing reads it there).
    pub fn fluxes(&self) -> Fluxes<D> {
        let f: Vec<f32> = self.gpu.read(&self.force);
        let l = &self.layout.force;
        Fluxes {
            t: l.read_v::<D>(&f, "T"),
            d: l.read_v::<D>(&f, "D"),
            dj: l.read_s(&f, "J", 0.0),
        }
    }

    /// The first particles whose det F ≤ 0 and whose J ≤ 0 (or NaN) in any evaluation.
    pub fn failed_particles(&self) -> [Option<usize>; 2] {
        let s: Vec<u32> = self.gpu.read(&self.status);
        [0, 1].map(|k| (s[k] != STATUS_OK[k]).then_some(s[k] as usize))
    }

    /// The reduction of the current state; with the bond-based F its strain energy reads
    /// F^c − I of the state, recorded first.
    fn reduction(&mut self) -> Reduced {
        let Self {
            gpu,
            evaluator,
            reduction,
            ..
        } = self;
        reduction.get(gpu, |pass| {
            if evaluator.passes.bond.is_some() {
                evaluator.record_motion(gpu, pass, evaluator.bound((Buf::Y, false)));
            }
        })
    }
}

impl<D: GpuDim> Engine<D> for GpuMixed<D> {
    fn device(&mut self) -> Option<(&Gpu, Scale)> {
        let scale = Scale {
            pairs: self.cpu.neighbours().pair_count() as u64,
            indirect: self.evaluator.corrector.as_ref().map(|c| c.runs),
        };
        Some((&self.gpu, scale))
    }

    fn backend(&self) -> String {
        format!("gpu: {}", self.gpu.name())
    }

    fn reference(&self) -> &[D::V] {
        self.cpu.reference()
    }

    fn constrained(&self) -> &[(u32, u8)] {
        self.cpu.constrained()
    }

    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        self.interactions.set_time(t);
        self.advance_steps(dt, steps);
        Ok(())
    }

    fn max_signal_speed(&mut self) -> f64 {
        // As the CPU's MixedSph::max_signal_speed (seed 002 eqs 31–32).
        let r = self.reduction();
        r.pair_wave_speed + r.max_speed
    }

    /// Trapezoidal over the intervals between calls (the driver calls it at every check).
    fn external_work(&mut self) -> f64 {
        let power = self.reduction().power;
        self.work.update(power)
    }

    fn booked(&mut self) -> Booked {
        Booked {
            external_work: self.external_work(),
            ..self.unbooked
        }
    }

    fn reactions(&mut self) -> Vec<Reaction> {
        reduction::reactions(&self.gpu, &self.kin, &self.layout.kin, self.cpu.boundary())
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        let x0 = self.cpu.reference();
        if let Some(c) = &self.evaluator.corrector
            && let Some(u) = c.unconverged(&self.gpu)
        {
            let quantity = format!("{UNCONVERGED}; f32 on the GPU");
            return Err(BlowUp::at::<D>(x0, u.particle, &quantity, u.residual));
        }
        for (failed, quantity) in self
            .failed_particles()
            .into_iter()
            .zip(["det F (f32, GPU)", "J (f32, GPU)"])
        {
            if let Some(i) = failed {
                return Err(BlowUp::at::<D>(x0, i, quantity, 0.0));
            }
        }
        if self.reduction().non_finite {
            return self.cpu.check_finite(&self.state());
        }
        Ok(())
    }

    fn invariants(&mut self) -> Invariants {
        self.reduction().invariants
    }

    fn pseudo_time(&mut self) -> Option<PseudoTime> {
        self.evaluator.corrector.as_ref().map(|c| c.stats)
    }

    fn finish(&mut self) {
        self.gpu.wait();
    }

    /// The work balance, the state buffer and the plastic history (f32).
    fn save(&mut self) -> Vec<f64> {
        let buffers = [self.stepper.buffer(Buf::Y), &self.hist];
        crate::gpu::save_buffers(&self.gpu, &self.work, &buffers)
    }

    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        let buffers = [
            ("state", self.stepper.buffer(Buf::Y)),
            ("plastic history", &self.hist),
        ];
        self.work = crate::gpu::load_buffers(&self.gpu, words, &buffers)?;
        self.stepper.state_replaced();
        self.reduction.invalidate();
        Ok(())
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        let y = self.state();
        if let Some(history) = self.cpu.plastic_mut() {
            history.read_f32(&self.gpu.read::<f32>(&self.hist));
        }
        self.cpu.snapshot(&y)
    }
}
