//! WGSL sources and their composition into scene-specific variants.
//!
//! A shader is the dimension prelude (`shaders/dim2.wgsl` or `dim3.wgsl`), a block of
//! scene constants, the shared function files it names, and the pass file. Scene
//! constants are compiled in (one variant per scene), so a 2D scene runs 2D code only.

use super::layout::GpuDim;
use crate::kernel::{Kernel, KernelKind};
use crate::material::{Material, MaterialModel};

/// A pass file of `shaders/`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Source {
    pub name: &'static str,
    pub text: &'static str,
    /// Shared function files it calls (`kernel.wgsl`, `mechanics.wgsl`), included first.
    pub common: &'static [&'static str],
    /// Flat f32 buffers that get `vload_/mload_` (and, if writable, `vstore_/mstore_`)
    /// accessors for DIM-vectors and DIM×DIM column-major tensors.
    pub flat: &'static [(&'static str, bool)],
}

macro_rules! source {
    ($name:literal) => {
        source!($name, [], [])
    };
    ($name:literal, [$($common:literal),*], [$(($buf:literal, $rw:literal)),*]) => {
        Source {
            name: $name,
            text: include_str!(concat!("../../shaders/", $name)),
            common: &[$($common),*],
            flat: &[$(($buf, $rw)),*],
        }
    };
}

/// Shared function files, by name.
const COMMON: &[(&str, &str)] = &[
    ("kernel.wgsl", include_str!("../../shaders/kernel.wgsl")),
    (
        "mechanics.wgsl",
        include_str!("../../shaders/mechanics.wgsl"),
    ),
    ("boundary.wgsl", include_str!("../../shaders/boundary.wgsl")),
    (
        "tlsph_energy.wgsl",
        include_str!("../../shaders/tlsph_energy.wgsl"),
    ),
    ("mixed.wgsl", include_str!("../../shaders/mixed.wgsl")),
    (
        "mixed_motion.wgsl",
        include_str!("../../shaders/mixed_motion.wgsl"),
    ),
    (
        "mixed_energy.wgsl",
        include_str!("../../shaders/mixed_energy.wgsl"),
    ),
    (
        "plasticity.wgsl",
        include_str!("../../shaders/plasticity.wgsl"),
    ),
];

pub const TLSPH_STRESS: Source = source!(
    "tlsph.wgsl",
    ["mechanics.wgsl"],
    [("y", false), ("grad", false), ("d", true), ("kin", true)]
);
pub const TLSPH_ACCEL: Source = source!(
    "tlsph_accel.wgsl",
    ["boundary.wgsl"],
    [
        ("y", false),
        ("grad", false),
        ("dx0", false),
        ("ext", false),
        ("kin", false),
        ("d", true)
    ]
);
pub const CORRECTION: Source = source!(
    "correction.wgsl",
    ["kernel.wgsl"],
    [("dx0", false), ("grad", true)]
);
pub const INTEGRATE: Source = source!("integrate.wgsl");
pub const REDUCE: Source = source!(
    "reduce.wgsl",
    ["mechanics.wgsl", "tlsph_energy.wgsl"],
    [("y", false), ("kin", false), ("x_hi", false)]
);
pub const PAIR_OFFSETS: Source = source!(
    "pair_offsets.wgsl",
    [],
    [("x_hi", false), ("x_lo", false), ("dx0", true)]
);

pub const CONTACT: Source = source!(
    "contact.wgsl",
    [],
    [
        ("x_hi", false),
        ("y", false),
        ("traction", false),
        ("ext", true)
    ]
);

/// The passes compiled with a TLSPH scene's constants (`gpu::tlsph::scene_constants`).
pub const SCENE: &[Source] = &[
    TLSPH_STRESS,
    TLSPH_ACCEL,
    CONTACT,
    CORRECTION,
    INTEGRATE,
    PAIR_OFFSETS,
    REDUCE,
];

pub const MIXED_GHOSTS: Source = source!(
    "mixed_ghosts.wgsl",
    ["mixed.wgsl"],
    [("ghost_img", false), ("field", true), ("y", false)]
);
pub const MIXED_KINEMATICS: Source = source!(
    "mixed_kinematics.wgsl",
    [
        "mechanics.wgsl",
        "mixed.wgsl",
        "mixed_motion.wgsl",
        "plasticity.wgsl"
    ],
    [
        ("grad", false),
        ("y", false),
        ("gm", false),
        ("kin", true),
        ("d", true),
        ("fs", false)
    ]
);
pub const MIXED_BOND: Source = source!(
    "mixed_bond.wgsl",
    ["mixed.wgsl", "mixed_motion.wgsl"],
    [("x_ab", false), ("y", false), ("gm", false), ("fc", true)]
);
pub const MIXED_SLOPES: Source = source!(
    "mixed_slopes.wgsl",
    ["mixed.wgsl", "mixed_motion.wgsl"],
    [
        ("weights", false),
        ("y", false),
        ("gm", false),
        ("out", true),
        ("kin", false)
    ]
);
pub const MIXED_FORCES: Source = source!(
    "mixed_forces.wgsl",
    ["mixed.wgsl", "mixed_motion.wgsl"],
    [
        ("grad", false),
        ("grad_rev", false),
        ("y", false),
        ("gm", false),
        ("kin", false),
        ("force", true),
        ("pair", false),
        ("second", false)
    ]
);
pub const MIXED_MOMENTUM: Source = source!(
    "mixed_momentum.wgsl",
    ["mixed.wgsl", "boundary.wgsl"],
    [
        ("force", false),
        ("y", false),
        ("y0", false),
        ("x_rel", false),
        ("ext", false),
        ("d", true)
    ]
);
pub const MIXED_REDUCE: Source = source!(
    "reduce.wgsl",
    ["mechanics.wgsl", "mixed_energy.wgsl", "plasticity.wgsl"],
    [("y", false), ("kin", false), ("x_hi", false)]
);

/// The passes compiled with a mixed scene's constants (`gpu::mixed::scene_constants`).
pub const MIXED_PLASTIC: Source = source!(
    "mixed_plastic.wgsl",
    ["mixed.wgsl", "plasticity.wgsl"],
    [("y", false)]
);

pub const MIXED_SCENE: &[Source] = &[
    MIXED_GHOSTS,
    MIXED_KINEMATICS,
    MIXED_PLASTIC,
    MIXED_BOND,
    MIXED_SLOPES,
    MIXED_FORCES,
    MIXED_MOMENTUM,
    MIXED_REDUCE,
    INTEGRATE,
];

/// Every pass file, for validation.
pub const ALL: &[Source] = &[
    REDUCE,
    PAIR_OFFSETS,
    TLSPH_STRESS,
    TLSPH_ACCEL,
    CONTACT,
    CORRECTION,
    INTEGRATE,
    MIXED_GHOSTS,
    MIXED_KINEMATICS,
    MIXED_PLASTIC,
    MIXED_BOND,
    MIXED_SLOPES,
    MIXED_FORCES,
    MIXED_MOMENTUM,
    MIXED_REDUCE,
    source!("cell_list.wgsl"),
    source!("scan.wgsl"),
];

/// Scene constants compiled into a variant.
#[derive(Clone, Debug, Default)]
pub struct Constants(Vec<(String, String)>);

impl Constants {
    pub fn f32(mut self, name: &str, value: f64) -> Self {
        self.0.push((name.into(), format!("{:?}", value as f32)));
        self
    }

    pub fn u32(mut self, name: &str, value: u32) -> Self {
        self.0.push((name.into(), format!("{value}u")));
        self
    }

    /// KERNEL, KERNEL_H and KERNEL_SCALE of a kernel.
    pub fn kernel(self, kernel: &Kernel) -> Self {
        let kind = match kernel.kind {
            KernelKind::CubicSpline => 0,
            KernelKind::Quintic => 1,
            KernelKind::WendlandC2 => 2,
            KernelKind::Quadratic => 3,
        };
        self.u32("KERNEL", kind)
            .f32("KERNEL_H", kernel.h)
            .f32("KERNEL_SCALE", kernel.scale())
    }

    /// MODEL (0 hypoelastic, 1 SVK, 2 neo-Hookean, 3 linear elastic, 4 polyconvex
    /// neo-Hookean), RHO0, MU, LAMBDA, BULK and RATE of a material (mechanics.wgsl).
    pub fn material(self, material: &Material) -> Self {
        let model = match material.model {
            MaterialModel::Hypoelastic => 0,
            MaterialModel::SaintVenantKirchhoff => 1,
            MaterialModel::NeoHookean => 2,
            MaterialModel::LinearElastic => 3,
            MaterialModel::NearlyIncompressibleNeoHookean => 4,
            MaterialModel::VonMisesPlastic => 5,
        };
        self.u32("MODEL", model)
            .u32("RATE", u32::from(material.model.is_rate_based()))
            .f32("RHO0", material.rho0)
            .f32("MU", material.mu)
            .f32("LAMBDA", material.lambda)
            .f32("BULK", material.bulk)
    }

    fn render(&self) -> String {
        self.0
            .iter()
            .map(|(n, v)| {
                let ty = if v.ends_with('u') { "u32" } else { "f32" };
                format!("const {n}: {ty} = {v};\n")
            })
            .collect()
    }
}

/// The full WGSL text of a pass in dimension D with the given constants.
pub fn compose<D: GpuDim>(source: &Source, constants: &Constants) -> String {
    let mut text = String::new();
    text.push_str(D::PRELUDE);
    text.push_str(&constants.render());
    for name in source.common {
        let (_, common) = COMMON
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("{}: no shared shader file {name}", source.name));
        text.push_str(common);
    }
    for &(name, writable) in source.flat {
        text.push_str(&accessors(name, D::N, writable));
    }
    text.push_str(source.text);
    text
}

/// Load (and store) functions for DIM-vectors and column-major DIM×DIM tensors at a flat
/// f32 index of buffer `name`.
fn accessors(name: &str, dim: usize, writable: bool) -> String {
    let at = |k: usize| {
        if k == 0 {
            format!("{name}[k]")
        } else {
            format!("{name}[k + {k}u]")
        }
    };
    let list = |n: usize| (0..n).map(at).collect::<Vec<_>>().join(", ");
    let comps = ["x", "y", "z"];
    let mut text = format!(
        "fn vload_{name}(k: u32) -> vecd {{ return vecd({}); }}\n\
         fn mload_{name}(k: u32) -> matd {{ return matd({}); }}\n",
        list(dim),
        list(dim * dim)
    );
    if writable {
        let vstore: String = (0..dim)
            .map(|c| format!("{} = v.{}; ", at(c), comps[c]))
            .collect();
        let mstore: String = (0..dim * dim)
            .map(|c| format!("{} = m[{}].{}; ", at(c), c / dim, comps[c % dim]))
            .collect();
        text.push_str(&format!(
            "fn vstore_{name}(k: u32, v: vecd) {{ {vstore}}}\n\
             fn mstore_{name}(k: u32, m: matd) {{ {mstore}}}\n"
        ));
    }
    text
}
