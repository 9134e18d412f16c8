//! WGSL sources and their composition into scene-specific variants.
//!
//! A shader is the dimension prelude (`shaders/common/dim2.wgsl` or `dim3.wgsl`), the
//! dispatch prelude ([`DISPATCH`]: an invocation's flat index), a block of scene
//! constants, the function files it names, and the pass file. Scene constants are
//! compiled in (one variant per scene), so a 2D scene runs 2D code only. Shared files
//! are declared here: helpers in `shaders/common/`, the set-up of lists and corrected
//! gradients in `shaders/setup/`, the physics' in `shaders/physics/` and supports,
//! loads and contact in `shaders/interaction/`. A core's files are in `shaders/tl/`,
//! `shaders/ul/` and `shaders/galerkin/`, a family's own in `shaders/<family>/`, each
//! declared by its GPU engine.

use super::bytes::FILE;
use super::layout::GpuDim;
use crate::core::kernel::{Kernel, KernelKind};
use crate::physics::material::{Material, MaterialModel, ObjectiveRate};
use crate::physics::plasticity::{Hardening, RateSensitivity};

/// A WGSL file of `shaders/`, by its path there (`common/kernel.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wgsl {
    pub name: &'static str,
    pub text: &'static str,
}

/// The [`Wgsl`] file at a path under `shaders/`.
macro_rules! wgsl {
    ($path:literal) => {
        $crate::gpu::shaders::Wgsl {
            name: $path,
            text: include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $path)),
        }
    };
}
pub(crate) use wgsl;

/// A pass file composed with an engine's scene constants: its WGSL text.
pub type Compose<'a> = &'a dyn Fn(&Source) -> String;

/// A pass file with the function files it calls and its flat buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Source {
    pub name: &'static str,
    pub text: &'static str,
    /// Function files it calls (`common/kernel.wgsl`, …), included first.
    pub common: &'static [Wgsl],
    /// Flat f32 buffers that get `vload_/mload_` (and, if writable, `vstore_/mstore_`)
    /// accessors for DIM-vectors and DIM×DIM column-major tensors.
    pub flat: &'static [(&'static str, bool)],
}

/// The [`Source`] of a pass file under `shaders/` with the function files it calls and
/// its flat buffers `(name, writable)` (or `flat = ` a list shared by several files). The
/// bytes model of its entry points is in its WGSL (`gpu::bytes`).
macro_rules! source {
    ($path:literal) => {
        $crate::gpu::shaders::source!($path, [], [])
    };
    ($path:literal, [$($common:expr),*], [$(($buf:literal, $rw:literal)),*]) => {
        $crate::gpu::shaders::source!($path, [$($common),*], flat = &[$(($buf, $rw)),*])
    };
    ($path:literal, [$($common:expr),*], flat = $flat:expr) => {
        $crate::gpu::shaders::Source {
            name: $path,
            text: $crate::gpu::shaders::wgsl!($path).text,
            common: &[$($common),*],
            flat: $flat,
        }
    };
}
pub(crate) use source;

/// The flat index of an invocation, `index(gid, nwg)`, and of a workgroup,
/// `group_index(wid, nwg)`, in a dispatch of `Gpu::groups`: in every shader.
pub const DISPATCH: Wgsl = wgsl!("common/dispatch.wgsl");
/// Kernel functions W and ∇W of the scene's kernel.
pub const KERNEL: Wgsl = wgsl!("common/kernel.wgsl");
/// Stresses and strain energies of the material models, in H = F − I.
pub const MECHANICS: Wgsl = wgsl!("common/mechanics.wgsl");
/// Boundary conditions on the rates and the power of supports and loads.
pub const BOUNDARY: Wgsl = wgsl!("interaction/boundary.wgsl");
/// Accessors of the reference configuration on the device (`gpu::reference`).
pub const REFERENCE: Wgsl = wgsl!("setup/reference.wgsl");
/// Monaghan's artificial viscosity Π_ij of a pair.
pub const VISCOSITY: Wgsl = wgsl!("physics/viscosity.wgsl");
/// The uniform `part` of the neighbour lists a dispatch runs on (`gpu::parts`).
pub const PART: Wgsl = wgsl!("common/part.wgsl");
/// Eigen-decomposition of symmetric tensors (cyclic Jacobi) and tensors from principal
/// values.
pub const EIGEN: Wgsl = wgsl!("common/eigen.wgsl");
/// The rate model's objective stress rate (after [`EIGEN`]).
pub const OBJECTIVE: Wgsl = wgsl!("common/objective.wgsl");
/// Reproducing-kernel functions with a linear basis at a smoothing length of the caller's.
pub const RKPM: Wgsl = wgsl!("common/rkpm.wgsl");
/// The von Mises return map (after [`EIGEN`]).
pub const PLASTICITY: Wgsl = wgsl!("physics/plasticity.wgsl");
/// The store of a returned point into the plastic history (after [`PLASTICITY`], in a pass
/// that writes `hist`).
pub const PLASTIC_STORE: Wgsl = wgsl!("physics/plastic_store.wgsl");

/// Corrected reference gradients (Randles–Libersky, Shepard, none).
pub const CORRECTION: Source = source!(
    "setup/correction.wgsl",
    [KERNEL, REFERENCE, PART],
    [("pair", true), ("reference", false)]
);
/// The integrators' stage operations over the flat state; an item is one f32 entry of it.
pub const INTEGRATE: Source = source!("common/integrate.wgsl");
/// Reference pair offsets X_j − X_i from hi + lo positions.
pub const PAIR_OFFSETS: Source = source!(
    "setup/pair_offsets.wgsl",
    [REFERENCE, PART],
    [("reference", false), ("pair", true)]
);
/// Penalty contact of seed 000 §5.8: one gather per slave over the other bodies' hulls.
pub const CONTACT: Source = source!(
    "interaction/contact.wgsl",
    [REFERENCE],
    [("reference", false), ("y", false), ("ext", true)]
);
/// Loads that vary in time (`interaction::TimedLoads`): an item is a particle, whose
/// acceleration it reads from every group.
pub const LOADS: Source = source!(
    "interaction/loads.wgsl",
    [],
    [("loads", false), ("ext", true)]
);
/// Prescribed velocities that vary in time (`boundary::TimedVelocity`): an item is a
/// particle, whose timed components it reads (the mask, one index and one velocity each).
pub const PRESCRIBED: Source = source!("interaction/prescribed.wgsl", [], []);
/// Cell list and neighbour lists, with the constants of `gpu::neighbour::constants`. An
/// item is a particle (a cell in `copy_cursor`, either in `clear_counts`).
pub const CELL_LIST: Source = source!("setup/cell_list.wgsl", [PART], [("x", false)]);
/// Prefix scans; an item is an invocation (two entries in `scan_blocks`, one in
/// `add_block_sums`).
pub const SCAN: Source = source!("setup/scan.wgsl");
/// The copy that measures an adapter's copy bandwidth (`gpu::profile`): 16 bytes an item,
/// one `vec4<f32>` element.
pub const COPY: Source = source!("common/copy.wgsl");

/// The shared pass files that take no scene constants (the cell list takes its own).
pub const SHARED: &[Source] = &[CELL_LIST, SCAN, COPY];

/// Scene constants compiled into a variant.
#[derive(Clone, Debug, Default)]
pub struct Constants(Vec<(String, String, Option<f64>)>);

impl Constants {
    pub fn f32(mut self, name: &str, value: f64) -> Self {
        self.0
            .push((name.into(), format!("{:?}", value as f32), Some(value)));
        self
    }

    pub fn u32(mut self, name: &str, value: u32) -> Self {
        self.0.push((name.into(), format!("{value}u"), None));
        self
    }

    /// A choice among named alternatives: `const {name}_{alternative}: u32` for each (0, 1,
    /// …) and `const {name}: u32` the chosen one's, so that shaders compare against names
    /// (`MODEL == MODEL_NEO_HOOKEAN`), not bare tags.
    pub fn choice(self, name: &str, alternatives: &[&str], chosen: usize) -> Self {
        let with = alternatives.iter().enumerate().fold(self, |c, (k, alt)| {
            c.u32(&format!("{name}_{alt}"), k as u32)
        });
        with.u32(name, chosen as u32)
    }

    /// KERNEL (a choice), KERNEL_H and KERNEL_SCALE of a kernel.
    pub fn kernel(self, kernel: &Kernel) -> Self {
        let kind = match kernel.kind {
            KernelKind::CubicSpline => 0,
            KernelKind::Quintic => 1,
            KernelKind::WendlandC2 => 2,
            KernelKind::Quadratic => 3,
        };
        self.choice(
            "KERNEL",
            &["CUBIC_SPLINE", "QUINTIC", "WENDLAND_C2", "QUADRATIC"],
            kind,
        )
        .f32("KERNEL_H", kernel.h)
        .f32("KERNEL_SCALE", kernel.scale())
    }

    /// MODEL (a choice), RHO0, MU, LAMBDA, BULK, RATE, OBJECTIVE_RATE (a choice), the
    /// Mooney–Rivlin constants MR_C1, MR_C2, MR_LAMBDA (zero for the other models) and the
    /// yield stress's ([`Self::hardening`]) of a material (mechanics.wgsl, plasticity.wgsl).
    pub fn material(self, material: &Material) -> Self {
        let model = match material.model {
            MaterialModel::Hypoelastic => 0,
            MaterialModel::SaintVenantKirchhoff => 1,
            MaterialModel::NeoHookean => 2,
            MaterialModel::LinearElastic => 3,
            MaterialModel::NearlyIncompressibleNeoHookean => 4,
            MaterialModel::VonMisesPlastic => 5,
            MaterialModel::MooneyRivlin => 6,
        };
        let rubber = material.mooney_rivlin;
        self.choice(
            "MODEL",
            &[
                "HYPOELASTIC",
                "SAINT_VENANT_KIRCHHOFF",
                "NEO_HOOKEAN",
                "LINEAR_ELASTIC",
                "NEARLY_INCOMPRESSIBLE_NEO_HOOKEAN",
                "VON_MISES_PLASTIC",
                "MOONEY_RIVLIN",
            ],
            model,
        )
        .choice(
            "OBJECTIVE_RATE",
            &["JAUMANN", "GREEN_NAGHDI", "TRUESDELL"],
            match material.objective_rate {
                ObjectiveRate::Jaumann => 0,
                ObjectiveRate::GreenNaghdi => 1,
                ObjectiveRate::Truesdell => 2,
            },
        )
        .u32("RATE", u32::from(material.model.is_rate_based()))
        .f32("RHO0", material.rho0)
        .f32("MU", material.mu)
        .f32("LAMBDA", material.lambda)
        .f32("BULK", material.bulk)
        .f32("MR_C1", rubber.map_or(0.0, |m| m.c1))
        .f32("MR_C2", rubber.map_or(0.0, |m| m.c2))
        .f32("MR_LAMBDA", rubber.map_or(0.0, |m| m.lambda))
        .hardening(&material.hardening.unwrap_or(Hardening::linear(0.0, 0.0)))
    }

    /// The yield stress (plasticity.wgsl): YIELD (τ_y⁰), HARDENING (H), HARDENING_EXPONENT
    /// (n), RATE_COEFFICIENT (C, zero without the rate term), REFERENCE_RATE (ε̇0),
    /// THERMAL_EXPONENT (m), THERMAL_SPAN (T_m − T_r, zero without thermal softening),
    /// HEATING (χ/(ρ0 c_p)).
    pub fn hardening(self, h: &Hardening) -> Self {
        let rate = h.rate.unwrap_or(RateSensitivity {
            coefficient: 0.0,
            reference: 1.0,
        });
        let (exponent, span, heating) = h.thermal.map_or((1.0, 0.0, 0.0), |t| {
            (t.exponent, t.melting - t.room, t.heating)
        });
        self.f32("YIELD", h.yield_stress)
            .f32("HARDENING", h.modulus)
            .f32("HARDENING_EXPONENT", h.exponent)
            .f32("RATE_COEFFICIENT", rate.coefficient)
            .f32("REFERENCE_RATE", rate.reference)
            .f32("THERMAL_EXPONENT", exponent)
            .f32("THERMAL_SPAN", span)
            .f32("HEATING", heating)
    }

    /// The first f32 constant whose value f32 cannot hold: infinite, or a nonzero value
    /// that rounds to zero or loses digits as a subnormal. (name, value).
    pub fn out_of_f32_range(&self) -> Option<(&str, f64)> {
        self.0.iter().find_map(|(name, _, value)| {
            let v = (*value)?;
            let f = v as f32;
            let bad = !f.is_finite() || (v != 0.0 && !f.is_normal());
            bad.then_some((name.as_str(), v))
        })
    }

    fn render(&self) -> String {
        self.0
            .iter()
            .map(|(n, v, real)| {
                let ty = if real.is_some() { "f32" } else { "u32" };
                format!("const {n}: {ty} = {v};\n")
            })
            .collect()
    }
}

/// The full WGSL text of a pass in dimension D with the given constants. Each file it
/// holds is preceded by a line naming it ([`FILE`]), where the bytes models' errors find
/// their file and line.
pub fn compose<D: GpuDim>(source: &Source, constants: &Constants) -> String {
    let mut text = String::new();
    text.push_str(D::PRELUDE);
    let file = |text: &mut String, name: &str, wgsl: &str| {
        if !text.ends_with('\n') {
            text.push('\n');
        }
        text.push_str(&format!("{FILE}{name}\n"));
        text.push_str(wgsl);
    };
    file(&mut text, DISPATCH.name, DISPATCH.text);
    text.push_str(&constants.render());
    for common in source.common {
        file(&mut text, common.name, common.text);
    }
    for &(name, writable) in source.flat {
        text.push_str(&accessors(name, D::N, writable));
    }
    file(&mut text, source.name, source.text);
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
