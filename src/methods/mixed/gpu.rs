//! Mixed {p, F, H, J} SPH (seed 003: Upwind-SPH and JST-SPH) on the GPU: the passes of
//! `shaders/mixed/` and the integrator program of [`crate::gpu::program`]. The set-up is
//! the CPU reference's own (`MixedSph::new`, f64): neighbours, corrected gradients, the
//! reverse pairs, least-squares and Laplacian weights and the ghost table are computed
//! once on the host and uploaded in f32. The CPU method is kept for snapshots (σ and the
//! strain energy of a read-back state, in f64).
//!
//! One rate evaluation, all on the device and recorded in one compute pass:
//! ghost motion → [bond-based F^c] → kinematics (P, ∇0v, Ḟ, Ḣ, J̇) → ghost kinematics →
//! [slopes or Laplacians → their ghosts] → forces (T, D(p), D(J)) → [projection sums →
//! solve] → rates of v and u with the boundary conditions. A whole step, or several, is
//! recorded into one command encoder; the host reads back only when asked.

use super::system::{Fluxes, MixedSph, MixedState};
use super::{CflWaveSpeed, DeformationGradient, Momentum};
use crate::gpu::context::{Gpu, WORKGROUP};
use crate::gpu::layout::{GpuDim, boundary_buffers, flat_v};
use crate::gpu::program::{StateLayout, Stepper};
use crate::gpu::reduction::{Reduced, Reduction, WorkBalance};
use crate::gpu::shaders::{
    self, BOUNDARY, CONTACT, Constants, INTEGRATE, MECHANICS, PLASTICITY, Source, Wgsl, source,
    wgsl,
};
use crate::gpu::{SetupError, check_f32_particles, check_f32_range};
use crate::integrate::IntegratorKind;
use crate::integrate::{Buf, Evaluation, evaluations};
use crate::interaction::gpu::GpuInteractions;
use crate::material::MaterialModel;
use crate::methods::{BlowUp, Method, not_run_by};
use crate::observe::{Invariants, Snapshot};
use crate::run::{Engine, Failed, build_method};
use crate::scene::Case;
use bytemuck::{Pod, Zeroable};
use glam::DMat3;

/// Shared functions of the mixed passes: state and kinematics access, ghost maps.
const MIXED: Wgsl = wgsl!("mixed/mixed.wgsl");
/// Current positions and pair geometry.
const MOTION: Wgsl = wgsl!("mixed/mixed_motion.wgsl");
/// Strain energy and the CFL pair wave speed, for the reduction.
const ENERGY: Wgsl = wgsl!("mixed/mixed_energy.wgsl");

/// Ghost motion and ghost fields.
pub const GHOSTS: Source = source!(
    "mixed/mixed_ghosts.wgsl",
    [MIXED],
    [("ghost_img", false), ("field", true), ("y", false)]
);
/// ∇0v, P(F, H, J) and the rates of F, H, J.
pub const KINEMATICS: Source = source!(
    "mixed/mixed_kinematics.wgsl",
    [MECHANICS, MIXED, MOTION, PLASTICITY],
    [
        ("grad", false),
        ("y", false),
        ("gm", false),
        ("kin", true),
        ("d", true),
        ("fs", false)
    ]
);
/// The bond-based F^c (seed 002 eqs 37, 39).
pub const BOND: Source = source!(
    "mixed/mixed_bond.wgsl",
    [MIXED, MOTION],
    [("x_ab", false), ("y", false), ("gm", false), ("fc", true)]
);
/// Least-squares slopes of v and P, or the Laplacian ∇²v.
pub const SLOPES: Source = source!(
    "mixed/mixed_slopes.wgsl",
    [MIXED, MOTION],
    [
        ("weights", false),
        ("y", false),
        ("gm", false),
        ("out", true),
        ("kin", false)
    ]
);
/// T, D(p) and D(J) per particle.
pub const FORCES: Source = source!(
    "mixed/mixed_forces.wgsl",
    [MIXED, MOTION],
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
/// The projection's sums and solve, and the rates with the boundary conditions.
pub const MOMENTUM: Source = source!(
    "mixed/mixed_momentum.wgsl",
    [MIXED, BOUNDARY],
    [
        ("force", false),
        ("y", false),
        ("y0", false),
        ("x_rel", false),
        ("ext", false),
        ("d", true)
    ]
);
/// Energies, momenta, checks and the CFL pair wave speed of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, ENERGY, PLASTICITY],
    [("y", false), ("kin", false), ("x_hi", false)]
);
/// The per-step commit of the plastic history.
pub const PLASTIC: Source = source!(
    "mixed/mixed_plastic.wgsl",
    [MIXED, PLASTICITY],
    [("y", false)]
);

/// The passes compiled with a mixed scene's constants ([`scene`]).
pub const SHADERS: &[Source] = &[
    GHOSTS, KINEMATICS, PLASTIC, BOND, SLOPES, FORCES, MOMENTUM, REDUCE, INTEGRATE, CONTACT,
];

/// Offsets (in f32 entries) of the fields in the flat buffers of a mixed scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MixedLayout {
    /// Real particles and ghosts.
    pub n: usize,
    pub ghosts: usize,
    pub dim: usize,
    pub evolves_h: bool,
    pub evolves_j: bool,
    /// The kinematics keep H for the D(J) gather (Upwind-SPH with J evolved).
    pub kin_h: bool,
    /// State [u | v | F − I | H − I | J − 1] of the real particles.
    pub u: usize,
    pub v: usize,
    pub f: usize,
    pub h: usize,
    pub j: usize,
    pub len: usize,
    /// F − I of the stress: F in the state, or with the bond-based F (seed 002) F^c − I
    /// at 0 of its own buffer (DIM² per real particle).
    pub fs: usize,
    /// Kinematics [P | H − I] of the real particles then the ghosts.
    pub kin_p: usize,
    pub kin_h_off: usize,
    pub kin_len: usize,
    /// Forces [T | D(p) | D(J)] of the real particles.
    pub force_t: usize,
    pub force_d: usize,
    pub force_j: usize,
    pub force_len: usize,
}

impl MixedLayout {
    pub fn new(
        n: usize,
        ghosts: usize,
        dim: usize,
        evolves: (bool, bool),
        upwind: bool,
        bond: bool,
    ) -> Self {
        let (evolves_h, evolves_j) = evolves;
        let (nd, nt) = (n * dim, n * dim * dim);
        let h = 2 * nd + nt;
        let j = h + if evolves_h { nt } else { 0 };
        let kin_h = upwind && evolves_j;
        let ext_t = (n + ghosts) * dim * dim;
        Self {
            n,
            ghosts,
            dim,
            evolves_h,
            evolves_j,
            kin_h,
            u: 0,
            v: nd,
            f: 2 * nd,
            h,
            j,
            len: j + if evolves_j { n } else { 0 },
            fs: if bond { 0 } else { 2 * nd },
            kin_p: 0,
            kin_h_off: ext_t,
            kin_len: if kin_h { 2 * ext_t } else { ext_t },
            force_t: 0,
            force_d: nd,
            force_j: 2 * nd,
            force_len: 2 * nd + n,
        }
    }

    fn state(&self) -> StateLayout {
        StateLayout {
            n: self.n,
            dim: self.dim,
            rest: self.f,
            len: self.len,
        }
    }
}

/// The layout and compiled-in constants of a scene's mixed passes, from its CPU set-up.
pub fn scene<D: GpuDim>(case: &Case, cpu: &MixedSph<D>) -> (MixedLayout, Constants) {
    let n = cpu.reference().len();
    let conserved = cpu.conserved();
    let jst = cpu.jst();
    let layout = MixedLayout::new(
        n,
        cpu.extended_reference().1.len() - n,
        D::N,
        (conserved.evolves_h(), conserved.evolves_j()),
        jst.is_none(),
        cpu.bond_weights().is_some(),
    );
    let material = cpu.material();
    let total_vol: f64 = cpu.volume().iter().sum();
    let (eps2, eps4) = jst.map_or((0.0, 0.0), |(c, ..)| (c.eps2, c.eps4));
    let u = |x: usize| x as u32;
    let l = &layout;
    let constants = Constants::default()
        .u32("N", u(n))
        .u32("BODIES", u(case.bodies.len()))
        .u32("NG", u(l.ghosts))
        .material(material)
        .f32("YIELD", material.hardening.map_or(0.0, |h| h.yield_stress))
        .f32("HARDENING", material.hardening.map_or(0.0, |h| h.modulus))
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
        .u32("EVOLVE_H", u32::from(l.evolves_h))
        .u32("EVOLVE_J", u32::from(l.evolves_j))
        .u32("KIN_H", u32::from(l.kin_h))
        .u32("PROJECTION", u32::from(cpu.projection()))
        .u32("GROUPS", u(n).div_ceil(WORKGROUP))
        .f32("TOTAL_VOL", total_vol)
        .u32("U_OFF", u(l.u))
        .u32("V_OFF", u(l.v))
        .u32("F_OFF", u(l.f))
        .u32("H_OFF", u(l.h))
        .u32("J_OFF", u(l.j))
        .u32("FS_OFF", u(l.fs))
        .u32("REST_OFF", u(l.f))
        .u32("LEN", u(l.len))
        .u32("KP_OFF", u(l.kin_p))
        .u32("KH_OFF", u(l.kin_h_off))
        .u32("FT_OFF", u(l.force_t))
        .u32("FD_OFF", u(l.force_d))
        .u32("FJ_OFF", u(l.force_j));
    (layout, constants)
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
    ghost_motion: wgpu::ComputePipeline,
    ghost_kin: wgpu::ComputePipeline,
    /// Ghost slopes or Laplacians.
    ghost_second: wgpu::ComputePipeline,
    /// The bond-based F^c, where the scene uses it.
    bond: Option<wgpu::ComputePipeline>,
    kinematics: wgpu::ComputePipeline,
    /// Slopes or Laplacians.
    second: wgpu::ComputePipeline,
    forces: wgpu::ComputePipeline,
    balance_sums: wgpu::ComputePipeline,
    balance_solve: wgpu::ComputePipeline,
    rates: wgpu::ComputePipeline,
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
}

/// The passes of a rate evaluation and their bind groups.
struct Evaluator {
    passes: Passes,
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
        if self.projection {
            gpu.dispatch(&mut pass, &p.balance_sums, &b.balance_sums, n);
            gpu.dispatch(&mut pass, &p.balance_solve, &b.balance_solve, 1);
        }
        gpu.dispatch(&mut pass, &p.rates, &b.rates, n);
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
    commit: Option<(wgpu::ComputePipeline, wgpu::BindGroup)>,
    /// Passes before every step (contact) and the `ext` they write.
    interactions: GpuInteractions,
    work: WorkBalance,
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
        check_f32_particles::<D>(case, cpu.reference(), &cpu.initial_state().v, cpu.body())?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);
        let (n, ng) = (layout.n, layout.ghosts);
        let csr = cpu.neighbours();
        let pairs = csr.pair_count() as u64;
        let d = D::N as u64;
        gpu.check_size("per-pair gradient buffer", pairs * d * 4)?;
        gpu.check_size("kinematics buffer", layout.kin_len as u64 * 4)?;
        let (x0, vol) = cpu.extended_reference();
        let (grad, grad_rev) = cpu.pair_gradients();

        // Per-pair data in CSR order; gradients scaled by V_b: G_b(X_a) = V_b g_ab.
        let offsets: Vec<u32> = csr.offsets.iter().map(|&o| o as u32).collect();
        let offsets = gpu.storage("offsets", &offsets);
        let ids = gpu.storage("ids", &csr.ids);
        let scaled = |g: &[D::V]| {
            flat_v::<D>((0..csr.pair_count()).map(|q| g[q] * vol[csr.ids[q] as usize]))
        };
        let grad_buf = gpu.storage("G_ab", &scaled(grad));
        let grad_rev_buf = gpu.storage("G_ba", &scaled(grad_rev));
        let pair_offsets = || {
            let q = (0..n).flat_map(|a| csr.range(a).map(move |q| (a, q)));
            flat_v::<D>(q.map(|(a, q)| x0[csr.ids[q] as usize] - x0[a]))
        };
        let dummy = || gpu.zeroed("unused", 4);
        let jst = cpu.jst();
        let upwind = jst.is_none();
        let reconstruction = cpu.reconstruction();
        let f32s = |x: &[f64]| x.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        // Upwind: d_ab and (reconstruction) the least-squares weights; JST: s_ab and ℓ_ab.
        let (pair, weights, second_len) = match jst {
            Some((_, ell, s)) => {
                let (s, ell) = (f32s(s), f32s(ell));
                (
                    gpu.storage("s_ab", &s),
                    Some(gpu.storage("ell_ab", &ell)),
                    (n + ng) * D::N,
                )
            }
            None if reconstruction => {
                let ls = flat_v::<D>(cpu.ls_weights().iter().copied());
                gpu.check_size("per-pair weight buffer", ls.len() as u64 * 4)?;
                (
                    gpu.storage("d_ab", &pair_offsets()),
                    Some(gpu.storage("w_ab", &ls)),
                    (n + ng) * (D::N + 1) * D::N * D::N,
                )
            }
            None => (gpu.storage("d_ab", &pair_offsets()), None, 0),
        };
        gpu.check_size("slope buffer", second_len as u64 * 4)?;
        let second = match second_len {
            0 => dummy(),
            len => gpu.zeroed("slopes or Laplacians", len as u64 * 4),
        };
        // The bond-based F (seed 002): X_ab (the upwind flux's d_ab where it has one) and
        // w_ab per pair, and the F^c − I it writes per real particle.
        let bond = cpu.bond_weights().map(|w| {
            let x_ab = if upwind {
                pair.clone()
            } else {
                gpu.storage("X_ab", &pair_offsets())
            };
            let fc = gpu.zeroed("F^c − I", (n * D::N * D::N) as u64 * 4);
            (x_ab, gpu.storage("bond weights w_ab", &f32s(w)), fc)
        });

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
        let gm = gpu.zeroed("ghost motion", (2 * ng * D::N) as u64 * 4);

        // Per-particle data of the real particles.
        let x_real = &x0[..n];
        let total_vol: f64 = vol[..n].iter().sum();
        let centroid = x_real
            .iter()
            .zip(vol)
            .fold(D::zero(), |c, (&x, &v)| c + x * v)
            * (1.0 / total_vol);
        let x_rel = gpu.storage("X − X̄", &flat_v::<D>(x_real.iter().map(|&x| x - centroid)));
        let x_hi = gpu.storage("X", &flat_v::<D>(x_real.iter().copied()));
        let vol32: Vec<f32> = vol[..n].iter().map(|&v| v as f32).collect();
        let vol_buf = gpu.storage("vol", &vol32);
        let (mask, traction) = boundary_buffers(&gpu, cpu.boundary(), n);
        let power = gpu.zeroed("power", n as u64 * 4);
        let kin = gpu.zeroed("kinematics", layout.kin_len as u64 * 4);
        let force = gpu.zeroed("forces", layout.force_len as u64 * 4);
        let status = gpu.storage("status", &STATUS_OK);
        let (gx, gy) = gpu.groups(n as u32);
        let partials = gpu.zeroed("balance partials", u64::from(gx * gy) * 16 * 4);
        let proj = gpu.zeroed("projection", 12 * 4);

        let y0 = encode::<D>(&layout, &cpu.initial_state());
        let stepper = Stepper::new(
            &gpu,
            case.method.integrator,
            &compose(&INTEGRATE),
            layout.state(),
            &y0,
        )?;
        let interactions = GpuInteractions::new(
            &gpu,
            cpu.interactions(),
            &compose,
            &x_hi,
            stepper.buffer(Buf::Y),
            traction,
        )?;
        let ext = interactions.ext();

        let ghosts_src = compose(&GHOSTS);
        let slopes_src = compose(&SLOPES);
        let momentum_src = compose(&MOMENTUM);
        let pipeline = |label: &str, src: &str, entry: &str| gpu.pipeline(label, src, entry);
        let (second_entry, ghost_second_entry) = if upwind {
            ("slopes", "ghost_slopes")
        } else {
            ("laplacian", "ghost_laplacian")
        };
        let passes = Passes {
            ghost_motion: pipeline("ghost motion", &ghosts_src, "ghost_motion")?,
            ghost_kin: pipeline("ghost kinematics", &ghosts_src, "ghost_kin")?,
            ghost_second: pipeline("ghost slopes", &ghosts_src, ghost_second_entry)?,
            bond: bond
                .as_ref()
                .map(|_| pipeline("bond-based F", &compose(&BOND), "bond_f"))
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
        let rates_d = stepper.buffer(Buf::Rates);
        // [C_p⁻¹ by columns | ε_p] per real particle, from the virgin state.
        let virgin = [1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let hist = gpu.storage(
            "plastic history",
            &virgin.repeat(if plastic { n } else { 1 }),
        );
        let commit = match plastic {
            true => {
                let pipeline = gpu.pipeline("plastic commit", &compose(&PLASTIC), "commit")?;
                let bind = gpu.bind(&pipeline, &[y_start, &hist]);
                Some((pipeline, bind))
            }
            false => None,
        };
        let p = &evaluator.passes;
        // F − I of the stress (`fs`): the state's own, or F^c − I.
        let stress_f = |y| bond.as_ref().map_or(y, |(.., fc)| fc);
        let bind = |(src, mid): (Buf, bool)| {
            let y = stepper.buffer(src);
            let points = if mid { &mid_points } else { &stage_points };
            let second_pass = weights.as_ref().map(|w| {
                let mut e = vec![
                    (0, &offsets),
                    (1, &ids),
                    (2, w),
                    (3, y),
                    (4, &gm),
                    (5, &second),
                ];
                if upwind {
                    e.push((6, &kin));
                }
                (
                    gpu.bind_at(&p.second, &e),
                    gpu.bind(&p.ghost_second, &[&ghost_src, &ghost_img, &second]),
                )
            });
            Bound {
                ghost_motion: gpu.bind(&p.ghost_motion, &[&ghost_src, &ghost_img, &gm, y]),
                ghost_kin: gpu.bind(&p.ghost_kin, &[&ghost_src, &ghost_img, &kin]),
                bond: p
                    .bond
                    .as_ref()
                    .zip(bond.as_ref())
                    .map(|(pipeline, (x_ab, w, fc))| {
                        gpu.bind(pipeline, &[&offsets, &ids, x_ab, w, y, &gm, fc])
                    }),
                kinematics: gpu.bind(
                    &p.kinematics,
                    &[
                        &offsets,
                        &ids,
                        &grad_buf,
                        y,
                        &gm,
                        &kin,
                        rates_d,
                        &status,
                        stress_f(y),
                        &hist,
                    ],
                ),
                second: second_pass,
                forces: gpu.bind(
                    &p.forces,
                    &[
                        &offsets,
                        &ids,
                        &grad_buf,
                        &grad_rev_buf,
                        y,
                        &gm,
                        &kin,
                        &force,
                        &pair,
                        &second,
                    ],
                ),
                balance_sums: gpu.bind_at(
                    &p.balance_sums,
                    &[
                        (0, points),
                        (1, &force),
                        (2, y),
                        (3, y_start),
                        (4, &x_rel),
                        (5, &vol_buf),
                        (6, &partials),
                    ],
                ),
                balance_solve: gpu.bind_at(&p.balance_solve, &[(6, &partials), (7, &proj)]),
                rates: gpu.bind_at(
                    &p.rates,
                    &[
                        (0, points),
                        (1, &force),
                        (2, y),
                        (3, y_start),
                        (4, &x_rel),
                        (5, &vol_buf),
                        (7, &proj),
                        (8, &mask),
                        (9, ext),
                        (10, rates_d),
                        (11, &power),
                    ],
                ),
            }
        };
        let bound = keys.into_iter().map(|k| (k, bind(k))).collect();
        evaluator.bound = bound;
        let reduction = Reduction::new(
            &gpu,
            &compose(&REDUCE),
            &[
                (0, y_start),
                (1, stress_f(y_start)),
                (2, &vol_buf),
                (3, &x_hi),
                (4, &power),
                (6, &offsets),
                (7, &ids),
                (8, &hist),
            ],
            n,
        )?;
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
        })
    }
}

/// A mixed state as a flat f32 state: F − I, H − I and J − 1 are formed in f64.
fn encode<D: GpuDim>(l: &MixedLayout, y: &MixedState<D>) -> Vec<f32> {
    let mut flat = flat_v::<D>(y.u.iter().chain(&y.v).copied());
    y.f.iter()
        .for_each(|&f| D::push_t(&mut flat, f - D::identity()));
    y.h.iter()
        .for_each(|&h| D::push_t(&mut flat, h - D::identity()));
    flat.extend(y.j.iter().map(|&j| (j - 1.0) as f32));
    debug_assert_eq!(flat.len(), l.len);
    flat
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
    pub fn advance_steps(&mut self, dt: f64, steps: u32) {
        self.work.advance(dt, steps);
        self.reduction.invalidate();
        self.set_dt(dt);
        self.interactions.set_step(&self.gpu, dt);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        let Self {
            gpu,
            stepper,
            evaluator,
            commit,
            layout,
            interactions,
            ..
        } = self;
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
            },
        );
        self.gpu.queue.submit([encoder.finish()]);
    }
}

impl<D: GpuDim> GpuMixed<D> {
    /// Decodes a flat state (`excess`: F, H, J are stored less I, I, 1) or rate buffer.
    fn decode(&self, flat: &[f32], excess: bool) -> MixedState<D> {
        let l = &self.layout;
        let (d, t) = (D::N, D::N * D::N);
        let (one_t, one) = if excess {
            (D::identity(), 1.0)
        } else {
            (D::zero_t(), 0.0)
        };
        let vecs = |off: usize| (0..l.n).map(|i| D::read_v(&flat[off + d * i..])).collect();
        let tensors = |off: usize| {
            (0..l.n)
                .map(|i| one_t + D::read_t(&flat[off + t * i..]))
                .collect()
        };
        MixedState {
            u: vecs(l.u),
            v: vecs(l.v),
            f: tensors(l.f),
            h: if l.evolves_h {
                tensors(l.h)
            } else {
                Vec::new()
            },
            j: if l.evolves_j {
                flat[l.j..l.j + l.n]
                    .iter()
                    .map(|&j| one + f64::from(j))
                    .collect()
            } else {
                Vec::new()
            },
        }
    }

    /// Reads the current state back (waits for the queue).
    pub fn state(&self) -> MixedState<D> {
        let flat: Vec<f32> = self.gpu.read(self.stepper.buffer(Buf::Y));
        self.decode(&flat, true)
    }

    /// Replaces the state (e.g. to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &MixedState<D>) {
        self.stepper
            .set_state(&self.gpu, &encode::<D>(&self.layout, y));
        self.reduction.invalidate();
    }

    /// Rates of a given state (balanced about its own positions), read back.
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
        let flat = encode::<D>(&self.layout, stage);
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
        self.decode(&d, false)
    }

    /// P of the real particles at the last rate evaluation.
    pub fn first_piola(&self) -> Vec<D::T> {
        let kin: Vec<f32> = self.gpu.read(&self.kin);
        let (off, t) = (self.layout.kin_p, D::N * D::N);
        (0..self.layout.n)
            .map(|i| D::read_t(&kin[off + t * i..]))
            .collect()
    }

    /// T, D(p) and D(J) of the last rate evaluation, before the projection (D(J) is zero
    /// where the scene does not evolve J or is JST-SPH: nothing reads it there).
    pub fn fluxes(&self) -> Fluxes<D> {
        let f: Vec<f32> = self.gpu.read(&self.force);
        let l = &self.layout;
        let vecs = |off: usize| (0..l.n).map(|i| D::read_v(&f[off + D::N * i..])).collect();
        Fluxes {
            t: vecs(l.force_t),
            d: vecs(l.force_d),
            dj: f[l.force_j..l.force_j + l.n]
                .iter()
                .map(|&x| x.into())
                .collect(),
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
    fn backend(&self) -> String {
        format!("gpu: {}", self.gpu.name())
    }

    fn reference(&self) -> &[D::V] {
        self.cpu.reference()
    }

    fn constrained(&self) -> &[(u32, u8)] {
        self.cpu.constrained()
    }

    fn advance(&mut self, _t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
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

    fn check(&mut self) -> Result<(), BlowUp> {
        let x0 = self.cpu.reference();
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

    fn finish(&mut self) {
        self.gpu.wait();
    }

    fn snapshot(&mut self) -> Snapshot<'_, D> {
        let y = self.state();
        if self.commit.is_some() {
            let flat: Vec<f32> = self.gpu.read(&self.hist);
            let (cp_inv, eps_p) = flat
                .chunks_exact(10)
                .map(|h| {
                    let m: [f64; 9] = std::array::from_fn(|k| f64::from(h[k]));
                    (DMat3::from_cols_array(&m), f64::from(h[9]))
                })
                .unzip();
            self.cpu.set_plastic_history(cp_inv, eps_p);
        }
        self.cpu.snapshot(&y)
    }
}
