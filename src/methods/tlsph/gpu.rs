//! Total-Lagrangian SPH on the GPU: the passes of `shaders/tlsph/`, the integrator
//! program of [`crate::gpu::program`], and the set-up done once: the reference
//! configuration and neighbours uploaded from the host, the pair offsets and corrected
//! gradients derived on the device. The CPU system ([`super::system`]) is the reference it is checked against.
//!
//! A whole step, or several, is recorded into one command encoder; the host reads back
//! only when asked (outputs, observers, checks).

use super::system::hourglass_stiffness;
use super::{TlsphForce, ViscosityGradient};
use crate::balance::Booked;
use crate::boundary::{OnPatches, Reaction};
use crate::correction::{self, CorrectionKind};
use crate::engine::{BlowUp, Engine, Failed};
use crate::gpu::context::{Gpu, GpuError, Pipeline};
use crate::gpu::layout::{Fields, GpuDim, flat_v};
use crate::gpu::profile::{NONE, PassBytes, Scale, read, read_write, write};
use crate::gpu::program::{StateLayout, Stepper};
use crate::gpu::reduction::{self, Reduced, Reduction, WorkBalance};
use crate::gpu::reference::{self, DeviceReference, Extras};
use crate::gpu::shaders::{
    self, BOUNDARY, CONTACT, CORRECTION, Constants, INTEGRATE, LOADS, MECHANICS, PAIR_OFFSETS,
    PRESCRIBED, REFERENCE, REVERSE_GRADIENTS, REVERSE_GRADIENTS_BYTES, Source, VISCOSITY, Wgsl,
    source, wgsl,
};
use crate::gpu::{SetupError, check_f32_particles, check_f32_range, check_f32_run};
use crate::integrate::Buf;
use crate::interaction::Interactions;
use crate::interaction::gpu::GpuInteractions;
use crate::material::Material;
use crate::methods::tl::{TlState, check_state, snapshot};
use crate::methods::{MethodSpec, not_run_by};
use crate::observe::{Invariants, Snapshot};
use crate::reference::Reference;
use crate::scene::{Case, CaseError};

/// Strain energy densities of the TLSPH models, for the reduction.
const ENERGY: Wgsl = wgsl!("tlsph/tlsph_energy.wgsl");

/// F, P (and ρ̇, Ṡ of the rate model) per particle.
pub const STRESS: Source = source!(
    "tlsph/tlsph.wgsl",
    [MECHANICS, REFERENCE],
    [
        ("y", false),
        ("pair", false),
        ("reference", false),
        ("d", true),
        ("kin", true)
    ],
    &[PassBytes {
        entry: "stress",
        traffic: &[
            read("offsets", [1, 0, 0], NONE),
            read("ids", NONE, [1, 0, 0]),
            // ∇0W̃_ij.
            read("pair", NONE, [0, 1, 0]),
            // V_j.
            read("reference", [1, 0, 0], NONE),
            // u, v; ρ − ρ0 and S of the rate model.
            read("y", [0, 2, 0], NONE),
            read("y", [1, 0, 1], NONE).when(&["RATE"]),
            // H, P, F⁻ᵀ, ρ.
            write("kin", [1, 0, 3], NONE),
            write("d", [1, 0, 1], NONE).when(&["RATE"]),
            read_write("status", NONE, NONE),
        ],
    }]
);
/// Accelerations, artificial viscosity, boundary conditions; the reverse gradients of
/// the variational force (set-up).
pub const ACCEL: Source = source!(
    "tlsph/tlsph_accel.wgsl",
    [BOUNDARY, REFERENCE, VISCOSITY, REVERSE_GRADIENTS],
    [
        ("y", false),
        ("pair", true),
        ("reference", false),
        ("ext", false),
        ("kin", true),
        ("d", true)
    ],
    &[
        REVERSE_GRADIENTS_BYTES,
        PassBytes {
            entry: "accel",
            traffic: &[
                read("offsets", [1, 0, 0], NONE),
                read("ids", NONE, [1, 0, 0]),
                // ∇0W̃_ij, and ∇0W̃_ji for the variational force; X_j − X_i for the viscosity.
                read("pair", NONE, [0, 1, 0]),
                read("pair", NONE, [0, 1, 0]).when(&["FORCE == FORCE_VARIATIONAL"]),
                read("pair", NONE, [0, 1, 0]).when(&["AV"]),
                // κ_ij and X_j − X_i, u_j and H_j for the hourglass control.
                read("pair", NONE, [1, 1, 0]).when(&["HOURGLASS"]),
                read("y", NONE, [0, 1, 0]).when(&["HOURGLASS"]),
                read("kin", [0, 0, 1], [0, 0, 1]).when(&["HOURGLASS"]),
                // V, the boundary mask.
                read("reference", [2, 0, 0], NONE),
                // u, v.
                read("y", [0, 2, 0], NONE),
                // P, F⁻ᵀ, ρ in; the power of supports and loads and the viscous dissipation out.
                read("kin", [1, 0, 2], NONE),
                write("kin", [2, 0, 0], NONE),
                read("ext", [0, 1, 0], NONE),
                // u̇ = v, v̇.
                write("d", [0, 2, 0], NONE),
            ],
        }
    ]
);
/// Energies, momenta and checks of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, ENERGY, REFERENCE],
    [("y", false), ("kin", false), ("reference", false)]
);

/// The passes compiled with a TLSPH scene's constants ([`scene_constants`]).
pub const SHADERS: &[Source] = &[
    STRESS,
    ACCEL,
    CONTACT,
    LOADS,
    PRESCRIBED,
    CORRECTION,
    INTEGRATE,
    PAIR_OFFSETS,
    REDUCE,
];

/// The force of one total-Lagrangian method on this engine: TLSPH's own, another method's
/// on the same stress pass (the elastic potential's), or a method's with its own
/// per-particle pass (corotated TLSPH's shape matching).
pub struct TlScheme {
    /// Its per-particle pass file (entry point `stress`): [`STRESS`], or the method's own.
    /// It writes the kinematics H, P, F⁻ᵀ and ρ (and its own `kin_tensors`) and records
    /// failed particles in `status` (slot k for the quantity `checks[k]`).
    pub stress: Source,
    /// Its acceleration pass file (entry point `accel`).
    pub accel: Source,
    /// Its reduction (`reduce`, with the method's strain energy).
    pub reduce: Source,
    /// The pass file's set-up entry `reverse_gradients` fills ∇0W̃_ji of every pair (i, j)
    /// into the pair data (field GREV) from the index of the reverse pair (`rev`).
    pub reverse: bool,
    /// The hourglass control's α: the host fills its stiffness κ_ij into the pair data
    /// (field HGK), which the acceleration pass reads.
    pub hourglass: Option<f64>,
    /// Where the pair lists and gradients come from.
    pub lists: Lists,
    /// Its own compiled-in constants.
    pub constants: Constants,
    /// Its force derives from Σ_i ψ_i rather than Σ_i V_i ψ_i (the reference code's
    /// potential force): the strain energy weighs each ψ_i by 1 and the wave speed of the
    /// CFL step is c_p/√V_min.
    pub unit_weights: bool,
    /// Per-particle tensors its stress pass keeps in the kinematics besides H, P and F⁻ᵀ
    /// (field `K{name}`: corotated TLSPH's rotation R).
    pub kin_tensors: &'static [&'static str],
    /// What the kinematics' H = F − I is the excess of, for the outputs.
    pub frame: Frame,
    /// The quantities whose failure the stress pass records, one status slot each (the
    /// first particle, by `atomicMin`), as a blow-up names them.
    pub checks: &'static [&'static str],
}

/// The pair lists and corrected gradients of a scheme.
#[derive(Clone, Debug, PartialEq)]
pub enum Lists {
    /// The reference neighbours within the kernel's support and the case's correction.
    Kernel,
    /// Dual-support SPH's ([`crate::methods::dual_support::gpu::lists`]): the supports
    /// and dual-supports S_i ∪ S'_i with each particle's own h, g_ij/V_j (zero where
    /// j ∉ S_i), the hourglass stiffnesses of both sides of every pair (fields HGK and
    /// HGKR), and the host's model for the outputs.
    DualSupport(crate::methods::dual_support::DualSupportSpec),
}

/// What the kinematics' H = F − I measures, for snapshots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Frame {
    /// The deformation gradient F itself.
    Reference,
    /// The corotated gradient F̂ in the frame of the kinematics' rotation R (field `KR`):
    /// F = R F̂ (seed 000 §5.5).
    Corotated,
}

/// The failure TLSPH's stress pass records (slot 0).
pub const DET_F: &[&str] = &["det F (f32, GPU)"];

/// TLSPH's own force: eq 134, or the variational form, with the spec's viscosity.
pub fn scheme(spec: &super::TlsphSpec) -> TlScheme {
    let variational = spec.force == TlsphForce::Variational;
    TlScheme {
        stress: STRESS,
        accel: ACCEL,
        reduce: REDUCE,
        reverse: variational,
        hourglass: spec.hourglass,
        lists: Lists::Kernel,
        constants: viscosity(spec.artificial_viscosity.as_ref())
            .u32("HOURGLASS", u32::from(spec.hourglass.is_some()))
            .choice(
                "AV_GRADIENT",
                &["PUSHED_FORWARD", "REFERENCE"],
                usize::from(spec.viscosity_gradient == ViscosityGradient::Reference),
            )
            .choice(
                "FORCE",
                &["REVELES", "VARIATIONAL"],
                usize::from(variational),
            ),
        unit_weights: false,
        kin_tensors: &[],
        frame: Frame::Reference,
        checks: DET_F,
    }
}

/// The constants AV, AV_ALPHA, AV_BETA and AV_ETA of a Monaghan viscosity, if any.
pub fn viscosity(av: Option<&super::ArtificialViscosity>) -> Constants {
    Constants::default()
        .u32("AV", u32::from(av.is_some()))
        .f32("AV_ALPHA", av.map_or(0.0, |a| a.alpha))
        .f32("AV_BETA", av.map_or(0.0, |a| a.beta))
        .f32("AV_ETA", av.map_or(0.0, |a| a.eta))
}

/// The scheme of a case's method on this engine.
fn scheme_of(case: &Case) -> Result<TlScheme, CaseError> {
    match &case.method.spec {
        MethodSpec::Tlsph(spec) => Ok(scheme(spec)),
        MethodSpec::TlPotential(spec) => Ok(crate::methods::potential::gpu::scheme(spec)),
        MethodSpec::CorotatedTlsph(spec) => Ok(crate::methods::corotated::gpu::scheme(spec)),
        MethodSpec::DualSupportSph(spec) => Ok(crate::methods::dual_support::gpu::scheme(spec)),
        _ => Err(not_run_by(case, "GpuTlsph")),
    }
}

/// The flat buffers of a TLSPH scene, each described once ([`Fields`]): the state
/// [u | v | ρ − ρ0 | S] (ρ and S for the rate model only), the kinematics
/// [H = F − I | P | F⁻ᵀ | ρ | power | viscous dissipation | the scheme's own tensors |
/// the constrained particles' reactions], the per-pair data
/// [∇0W̃ | X_j − X_i | ∇0W̃_ji for the schemes that read it] and the reference
/// configuration.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub dim: usize,
    pub rate: bool,
    pub state: Fields,
    pub kin: Fields,
    pub pair: Fields,
    pub reference: Fields,
}

impl Layout {
    /// The layout of n particles, `constrained` of them with prescribed components, and
    /// `pairs` neighbour pairs.
    pub fn new(
        n: usize,
        constrained: usize,
        dim: usize,
        rate: bool,
        pairs: usize,
        scheme: &TlScheme,
    ) -> Self {
        let dual = matches!(scheme.lists, Lists::DualSupport(_));
        let kin = Fields::new("K", dim)
            .tensors("F", true, n)
            .tensors("P", true, n)
            .tensors("FIT", true, n)
            .scalars("RHO", true, n)
            .scalars("POW", true, n)
            .scalars("DIS", true, n);
        let kin = scheme
            .kin_tensors
            .iter()
            .fold(kin, |k, &name| k.tensors(name, true, n));
        let kin = reduction::with_reactions(kin, constrained);
        Self {
            n,
            dim,
            rate,
            state: Fields::new("", dim)
                .vectors("U", true, n)
                .vectors("V", true, n)
                .scalars("RHO", rate, n)
                .tensors("S", rate, n),
            kin,
            pair: Fields::new("P", dim)
                .vectors("G", true, pairs)
                .vectors("DX", true, pairs)
                .vectors("GREV", scheme.reverse, pairs)
                .scalars("HGK", scheme.hourglass.is_some() || dual, pairs)
                .scalars("HGKR", dual, pairs),
            reference: reference::fields(n, constrained, dim, EXTRAS),
        }
    }

    fn stepped(&self) -> StateLayout {
        StateLayout {
            n: self.n,
            dim: self.dim,
            rest: self.state.offset("RHO"),
            len: self.state.len(),
        }
    }
}

/// The reference fields the TLSPH passes read besides X and V: the lo part of X, for the
/// exact pair offsets.
const EXTRAS: Extras = Extras {
    lo: true,
    centred: false,
};

/// The compiled-in constants of a scene's TLSPH passes with the scheme's own.
pub fn scene_constants(case: &Case, layout: &Layout, scheme: &TlScheme) -> Constants {
    let material = Material::new(&case.material);
    let kernel = case.kernel(layout.dim);
    let correction = match case.method.correction {
        CorrectionKind::None => 0,
        CorrectionKind::Shepard => 1,
        CorrectionKind::RandlesLibersky | CorrectionKind::Rkpm | CorrectionKind::Cgck => 2,
    };
    let u = |x: usize| x as u32;
    let constants = scheme
        .constants
        .clone()
        .kernel(&kernel)
        .u32("N", u(layout.n))
        .u32("PAIRS", u(layout.pair.field("G").count))
        .u32("BODIES", u(case.bodies.len()))
        .material(&material)
        .choice("CORRECTION", &["NONE", "SHEPARD", "LINEAR"], correction)
        .u32("REST_OFF", u(layout.state.offset("RHO")));
    [&layout.state, &layout.kin, &layout.pair, &layout.reference]
        .into_iter()
        .fold(constants, |c, fields| fields.constants(c))
}

/// The stress and acceleration passes of one rate evaluation, bound to a source state.
struct Rates {
    stress: wgpu::BindGroup,
    accel: wgpu::BindGroup,
}

/// The TLSPH system resident on the GPU.
pub struct GpuTlsph<D: GpuDim> {
    gpu: Gpu,
    /// The host's f64 reference configuration, which the device's was uploaded from.
    reference: Reference<D>,
    /// The weight of each particle's ψ in the strain energy (`TlScheme::unit_weights`).
    energy_weight: Vec<f64>,
    /// The factor on c_p in the CFL step's wave speed (`TlScheme::unit_weights`).
    wave_speed_scale: f64,
    /// What the kinematics' H measures (`TlScheme::frame`).
    frame: Frame,
    /// The quantity of each status slot (`TlScheme::checks`).
    checks: &'static [&'static str],
    /// Dual-support SPH's model on the host, whose f64 outputs the snapshots take from
    /// the state read back ([`Lists::DualSupport`]).
    dual_support: Option<crate::methods::dual_support::DualSupport<D>>,
    layout: Layout,
    /// Neighbour pairs of the reference lists.
    pairs: u64,
    stepper: Stepper,
    kin: wgpu::Buffer,
    pair: wgpu::Buffer,
    status: wgpu::Buffer,
    stress: Pipeline,
    accel: Pipeline,
    /// Rate evaluations of the states in `Y` and in `Stage`.
    rates: [Rates; 2],
    /// The stress pass on `Y` writing into `Acc` (for snapshots: F at the current state
    /// without touching the integrator's rates).
    kinematics_y: wgpu::BindGroup,
    reduction: Reduction,
    /// Passes before every step (contact) and the `ext` they write.
    interactions: GpuInteractions,
    work: WorkBalance,
    /// The balance's terms besides the work and the dissipation: zero where the case has
    /// none, None where it has them and they are not booked here (the hourglass control's
    /// work; contact's, which `ext` adds to the loads' power).
    unbooked: Booked,
}

/// Value of `status[0]` when no particle failed.
const STATUS_OK: u32 = u32::MAX;

impl<D: GpuDim> GpuTlsph<D> {
    /// Uploads the case's reference configuration and initial state, and derives the
    /// reference pair offsets and corrected gradients on the device (the RKPM and CGCK
    /// corrections on the host, in f64).
    pub fn new(case: &Case, gpu: Gpu) -> Result<Self, SetupError> {
        let scheme = scheme_of(case)?;
        let disc = Reference::<D>::build(case)?;
        check_f32_run(case, &disc.boundary)?;
        check_f32_particles::<D>(case, &disc.x0, &disc.u0, &disc.v0, &disc.body)?;
        let n = disc.len();
        let dual = match &scheme.lists {
            Lists::Kernel => None,
            Lists::DualSupport(spec) => Some(crate::methods::dual_support::gpu::lists::<D>(
                case, spec, &disc,
            )?),
        };
        let csr = dual
            .as_ref()
            .map_or_else(|| disc.neighbours(), |d| d.csr.clone());
        let layout = Layout::new(
            n,
            disc.boundary.constrained.len(),
            D::N,
            disc.material.model.is_rate_based(),
            csr.pair_count(),
            &scheme,
        );
        let constants = scene_constants(case, &layout, &scheme);
        check_f32_range(case, &constants)?;
        gpu.check_size("per-pair buffer", layout.pair.bytes())?;
        gpu.check_size("kinematics buffer", layout.kin.bytes())?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);

        let device =
            DeviceReference::upload::<D>(&gpu, &disc.x0, &disc.vol, &disc.boundary, &csr, EXTRAS);
        let pair = gpu.zeroed("per-pair data", layout.pair.bytes());
        let status = gpu.storage("status", &vec![STATUS_OK; scheme.checks.len().max(1)]);
        let set_up: [(&str, &wgpu::Buffer); 5] = [
            ("offsets", &device.offsets),
            ("ids", &device.ids),
            ("reference", &device.reference),
            ("pair", &pair),
            ("status", &status),
        ];
        // X_j − X_i, then (but for the host's RKPM and CGCK) the corrected gradients.
        let offsets_pass = (compose(&PAIR_OFFSETS), "pair_offsets");
        let correct_pass = (compose(&CORRECTION), "correct");
        let host_solved = dual.is_some()
            || matches!(
                case.method.correction,
                CorrectionKind::Rkpm | CorrectionKind::Cgck
            );
        let passes = if host_solved {
            vec![offsets_pass]
        } else {
            vec![offsets_pass, correct_pass]
        };
        run_once(&gpu, &passes, &set_up, n)?;
        let write_pair = |field: &str, values: &[f32]| {
            let at = (layout.pair.offset(field) * 4) as u64;
            gpu.queue
                .write_buffer(&pair, at, bytemuck::cast_slice(values));
        };
        if let Some(d) = &dual {
            write_pair("G", &flat_v::<D>(d.g.clone()));
            write_pair("HGK", &d.hgk);
            write_pair("HGKR", &d.hgk_rev);
        } else if host_solved {
            let g = correction::gradients::<D>(
                case.method.correction,
                &disc.x0,
                &disc.vol,
                &csr,
                &disc.kernel,
            )
            .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
            write_pair("G", &flat_v::<D>(g));
        } else if let Some((i, _)) = read_status(&gpu, &status) {
            return Err(case
                .invalid(
                    "method.h_over_dx",
                    format!(
                        "the Randles–Libersky matrix of particle {i} is singular on the GPU \
                         (f32): too few neighbours; increase h/dx"
                    ),
                )
                .into());
        }
        if let Some(alpha) = scheme.hourglass {
            let kappa = hourglass_stiffness::<D>(case, alpha, &disc.x0, &disc.vol, &csr);
            let kappa: Vec<f32> = kappa.into_iter().map(|k| k as f32).collect();
            write_pair("HGK", &kappa);
        }
        if scheme.reverse {
            let rev = crate::methods::shared::reverse_pairs(case, &csr)?;
            reverse_gradients(&gpu, &compose(&scheme.accel), &rev, &pair)?;
        }

        let mut y0 = layout.state.zeroed();
        layout.state.write_v::<D>(&mut y0, "U", &disc.u0);
        layout.state.write_v::<D>(&mut y0, "V", &disc.v0);
        let stepper = Stepper::new(
            &gpu,
            case.method.integrator,
            &compose(&INTEGRATE),
            layout.stepped(),
            &y0,
        )?;
        let interactions =
            Interactions::<D>::build(case, &disc.x0, &disc.body, &OnPatches, &disc.mass, || {
                csr.clone()
            })?;
        let interactions = GpuInteractions::new(
            &gpu,
            &interactions,
            &disc.boundary,
            &compose,
            &device.reference,
            stepper.buffer(Buf::Y),
            device.traction,
        )?;
        let kin = gpu.zeroed("kinematics", layout.kin.bytes());

        let stress = gpu.pipeline("tl stress", &compose(&scheme.stress), "stress")?;
        let accel = gpu.pipeline("tl accel", &compose(&scheme.accel), "accel")?;
        let table = |y, d| -> [(&str, &wgpu::Buffer); 9] {
            [
                ("offsets", &device.offsets),
                ("ids", &device.ids),
                ("pair", &pair),
                ("reference", &device.reference),
                ("kin", &kin),
                ("status", &status),
                ("ext", interactions.ext()),
                ("y", y),
                ("d", d),
            ]
        };
        let rates_d = stepper.buffer(Buf::Rates);
        let bound = |src| -> Result<Rates, GpuError> {
            let t = table(stepper.buffer(src), rates_d);
            Ok(Rates {
                stress: gpu.bind(&stress, &t)?,
                accel: gpu.bind(&accel, &t)?,
            })
        };
        let rates = [bound(Buf::Y)?, bound(Buf::Stage)?];
        let y = stepper.buffer(Buf::Y);
        let reduction = Reduction::new(&gpu, &compose(&scheme.reduce), &table(y, rates_d), n)?;
        let energy_weight = if scheme.unit_weights {
            vec![1.0; n]
        } else {
            disc.vol.clone()
        };
        let wave_speed_scale = if scheme.unit_weights {
            crate::methods::potential::system::unit_weight_wave_speed_scale(&disc.vol)
        } else {
            1.0
        };
        let kinematics_y = gpu.bind(&stress, &table(y, stepper.buffer(Buf::Acc)))?;
        let dual_hourglass = dual
            .as_ref()
            .is_some_and(|d| d.model.hourglass.iter().any(|&c| c != 0.0));
        Ok(Self {
            gpu,
            pairs: csr.pair_count() as u64,
            reference: disc,
            energy_weight,
            wave_speed_scale,
            frame: scheme.frame,
            checks: scheme.checks,
            dual_support: dual.map(|d| d.model),
            layout,
            stepper,
            kin,
            pair,
            status,
            stress,
            accel,
            rates,
            kinematics_y,
            reduction,
            interactions,
            work: WorkBalance::default(),
            unbooked: Booked {
                hourglass_work: (scheme.hourglass.is_none() && !dual_hourglass).then_some(0.0),
                contact_energy: case.contact.is_none().then_some(0.0),
                ..Booked::default()
            },
        })
    }
}

/// Compiles the entry points `(source, entry)`, binds them from `table` and runs them
/// once, in order, over n particles (set-up passes), in one compute pass.
fn run_once(
    gpu: &Gpu,
    passes: &[(String, &str)],
    table: &[(&str, &wgpu::Buffer)],
    n: usize,
) -> Result<(), GpuError> {
    let mut bound = Vec::new();
    for (source, entry) in passes {
        let pipeline = gpu.pipeline(entry, source, entry)?;
        let bind = gpu.bind(&pipeline, table)?;
        bound.push((pipeline, bind));
    }
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        for (pipeline, bind) in &bound {
            gpu.dispatch(&mut pass, pipeline, bind, n as u32);
        }
    }
    gpu.queue.submit([encoder.finish()]);
    Ok(())
}

/// Runs the pass file's `reverse_gradients` set-up entry: ∇0W̃_ji of every pair (i, j)
/// into GREV, from `rev`, the index of the pair (j, i) of each.
fn reverse_gradients(
    gpu: &Gpu,
    source: &str,
    rev: &[u32],
    pair: &wgpu::Buffer,
) -> Result<(), GpuError> {
    let index = gpu.storage("reverse pairs", rev);
    let pipeline = gpu.pipeline("reverse_gradients", source, "reverse_gradients")?;
    let bind = gpu.bind(&pipeline, &[("pair", pair), ("rev", &index)])?;
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        gpu.dispatch(&mut pass, &pipeline, &bind, rev.len() as u32);
    }
    gpu.queue.submit([encoder.finish()]);
    Ok(())
}

/// The first failed particle recorded in a status buffer, if any, and its slot: the
/// lowest particle of any slot, the later slot on a tie.
fn read_status(gpu: &Gpu, status: &wgpu::Buffer) -> Option<(usize, usize)> {
    let s: Vec<u32> = gpu.read(status);
    let (slot, &i) = s.iter().enumerate().rev().min_by_key(|&(_, &i)| i)?;
    (i != STATUS_OK).then_some((i as usize, slot))
}

impl<D: GpuDim> GpuTlsph<D> {
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// The host's reference configuration of the scene.
    pub fn reference(&self) -> &Reference<D> {
        &self.reference
    }

    /// Records one rate evaluation: the stress and acceleration passes on `rates`.
    fn record_rates(
        gpu: &Gpu,
        n: u32,
        (stress, accel): (&Pipeline, &Pipeline),
        encoder: &mut wgpu::CommandEncoder,
        rates: &Rates,
    ) {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        gpu.dispatch(&mut pass, stress, &rates.stress, n);
        gpu.dispatch(&mut pass, accel, &rates.accel, n);
    }

    /// Records `steps` steps of size `dt` into one command encoder and submits them.
    pub fn advance_steps(&mut self, dt: f64, steps: u32) {
        self.work.advance(dt, steps);
        self.reduction.invalidate();
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.interactions.set_step(&self.gpu, dt);
        let Self {
            gpu,
            stepper,
            stress,
            accel,
            rates,
            layout,
            interactions,
            ..
        } = self;
        let n = layout.n as u32;
        stepper.record(
            gpu,
            &mut encoder,
            dt,
            steps,
            |encoder, e| {
                let src = usize::from(e.src != Buf::Y);
                Self::record_rates(gpu, n, (stress, accel), encoder, &rates[src]);
            },
            |encoder| interactions.record(gpu, encoder, n),
        );
        self.gpu.queue.submit([encoder.finish()]);
    }

    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> TlState<D> {
        let flat: Vec<f32> = self.gpu.read(self.stepper.buffer(Buf::Y));
        self.decode(&flat, self.reference.material.rho0)
    }

    /// Decodes a flat state (`rho0` = ρ0: the density is stored as ρ − ρ0) or rate
    /// buffer (`rho0` = 0).
    fn decode(&self, flat: &[f32], rho0: f64) -> TlState<D> {
        let l = &self.layout.state;
        TlState {
            u: l.read_v::<D>(flat, "U"),
            v: l.read_v::<D>(flat, "V"),
            rho: l.read_s(flat, "RHO", rho0),
            s: l.read_t::<D>(flat, "S", D::zero_t()),
        }
    }

    /// Replaces the state (e.g. to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &TlState<D>) {
        let l = &self.layout.state;
        let mut flat = l.zeroed();
        l.write_v::<D>(&mut flat, "U", &y.u);
        l.write_v::<D>(&mut flat, "V", &y.v);
        l.write_s(&mut flat, "RHO", &y.rho, self.reference.material.rho0);
        l.write_t::<D>(&mut flat, "S", &y.s, D::zero_t());
        self.stepper.set_state(&self.gpu, &flat);
        self.reduction.invalidate();
    }

    /// Rates of a given state: (dy/dt, F, P) per particle, read back.
    pub fn rates(&mut self, y: &TlState<D>) -> (TlState<D>, Vec<D::T>, Vec<D::T>) {
        self.set_state(y);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        let n = self.layout.n as u32;
        let pipelines = (&self.stress, &self.accel);
        Self::record_rates(&self.gpu, n, pipelines, &mut encoder, &self.rates[0]);
        self.gpu.queue.submit([encoder.finish()]);
        let d: Vec<f32> = self.gpu.read(self.stepper.buffer(Buf::Rates));
        let (f, p) = self.kinematics();
        (self.decode(&d, 0.0), f, p)
    }

    /// The corrected reference gradients, in CSR order.
    pub fn gradients(&self) -> Vec<D::V> {
        let pair: Vec<f32> = self.gpu.read(&self.pair);
        self.layout.pair.read_v::<D>(&pair, "G")
    }

    /// F and P of the last rate evaluation (the GPU keeps H = F − I; I is added in f64);
    /// the corotated F̂ and P̂ of a [`Frame::Corotated`] scheme.
    pub fn kinematics(&self) -> (Vec<D::T>, Vec<D::T>) {
        let kin: Vec<f32> = self.gpu.read(&self.kin);
        let l = &self.layout.kin;
        (
            l.read_t::<D>(&kin, "F", D::identity()),
            l.read_t::<D>(&kin, "P", D::zero_t()),
        )
    }

    /// A per-particle tensor of the scheme's own (`TlScheme::kin_tensors`) of the last
    /// rate evaluation: corotated TLSPH's rotations R.
    pub fn kin_tensor(&self, name: &str) -> Vec<D::T> {
        let kin: Vec<f32> = self.gpu.read(&self.kin);
        self.layout.kin.read_t::<D>(&kin, name, D::zero_t())
    }

    /// The first particle whose stress pass failed (det F ≤ 0 or NaN, or the scheme's
    /// other checks) in any evaluation so far.
    pub fn failed_particle(&self) -> Option<usize> {
        read_status(&self.gpu, &self.status).map(|(i, _)| i)
    }
}

impl<D: GpuDim> Engine<D> for GpuTlsph<D> {
    fn backend(&self) -> String {
        format!("gpu: {}", self.gpu.name())
    }

    fn device(&mut self) -> Option<(&Gpu, Scale)> {
        let scale = Scale {
            pairs: self.pairs,
            indirect: None,
        };
        Some((&self.gpu, scale))
    }

    fn reference(&self) -> &[D::V] {
        &self.reference.x0
    }

    fn constrained(&self) -> &[(u32, u8)] {
        &self.reference.boundary.constrained
    }

    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        self.interactions.set_time(t);
        self.advance_steps(dt, steps);
        Ok(())
    }

    fn max_signal_speed(&mut self) -> f64 {
        self.wave_speed_scale * self.reference.material.p_wave_speed() + self.reduction().max_speed
    }

    /// Trapezoidal over the intervals between calls (the driver calls it at every check).
    fn external_work(&mut self) -> f64 {
        let power = self.reduction().power;
        self.work.update(power)
    }

    /// The work and the viscous dissipation, trapezoidal over the intervals between calls.
    fn booked(&mut self) -> Booked {
        let r = self.reduction();
        Booked {
            external_work: self.work.update(r.power),
            dissipated: Some(self.work.update_dissipation(r.viscous_dissipation)),
            ..self.unbooked
        }
    }

    fn reactions(&mut self) -> Vec<Reaction> {
        let boundary = &self.reference.boundary;
        reduction::reactions(&self.gpu, &self.kin, &self.layout.kin, boundary)
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        if let Some((i, slot)) = read_status(&self.gpu, &self.status) {
            return Err(BlowUp {
                particle: i,
                position: D::to3(self.reference.x0[i]),
                quantity: self.checks[slot].into(),
                value: 0.0,
            });
        }
        if self.reduction().non_finite {
            return check_state(&self.reference.x0, &self.state());
        }
        Ok(())
    }

    fn invariants(&mut self) -> Invariants {
        self.reduction().invariants
    }

    fn finish(&mut self) {
        self.gpu.wait();
    }

    /// The work balance and the state buffer (f32).
    fn save(&mut self) -> Vec<f64> {
        crate::gpu::save_buffers(&self.gpu, &self.work, &[self.stepper.buffer(Buf::Y)])
    }

    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        let y = [("state", self.stepper.buffer(Buf::Y))];
        self.work = crate::gpu::load_buffers(&self.gpu, words, &y)?;
        self.stepper.state_replaced();
        self.reduction.invalidate();
        Ok(())
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            let n = self.layout.n as u32;
            self.gpu
                .dispatch(&mut pass, &self.stress, &self.kinematics_y, n);
        }
        self.gpu.queue.submit([encoder.finish()]);
        let y = self.state();
        let r = &self.reference;
        if let Some(model) = &self.dual_support {
            return model.snapshot(y.u, y.v, &r.mass, &r.body, true);
        }
        let (f, _) = self.kinematics();
        if self.frame == Frame::Corotated {
            let rot = self.kin_tensor("R");
            let fields = crate::methods::corotated::outputs::<D>(&r.material, &r.vol, &rot, &f);
            return fields.snapshot(&r.x0, &r.mass, &r.body, y);
        }
        snapshot(
            &r.material,
            &r.x0,
            &r.mass,
            &r.body,
            &self.energy_weight,
            y,
            f,
        )
    }
}

impl<D: GpuDim> GpuTlsph<D> {
    /// Stress pass on the current state (F into the kinematics) and the reduction.
    fn reduction(&mut self) -> Reduced {
        let Self {
            gpu,
            stress,
            kinematics_y,
            layout,
            reduction,
            ..
        } = self;
        reduction.get(gpu, |pass| {
            gpu.dispatch(pass, stress, kinematics_y, layout.n as u32)
        })
    }
}
