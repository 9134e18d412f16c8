//! Total-Lagrangian SPH on the GPU: the passes of `shaders/tlsph/`, the integrator
//! program of [`crate::gpu::program`], and the set-up (neighbours, corrected gradients)
//! done once. The CPU system ([`super::system`]) is the reference it is checked against.
//!
//! A whole step, or several, is recorded into one command encoder; the host reads back
//! only when asked (outputs, observers, checks).

use super::system::{TlState, check_state, snapshot};
use crate::correction::{self, CorrectionKind};
use crate::gpu::context::Gpu;
use crate::gpu::layout::{Flat, GpuDim, boundary_buffers, flat_v};
use crate::gpu::neighbour;
use crate::gpu::program::{StateLayout, Stepper};
use crate::gpu::reduction::{Reduced, Reduction, WorkBalance};
use crate::gpu::shaders::{
    self, BOUNDARY, CONTACT, CORRECTION, Constants, INTEGRATE, MECHANICS, PAIR_OFFSETS, Source,
    Wgsl, source, wgsl,
};
use crate::gpu::{SetupError, check_f32_particles, check_f32_range};
use crate::integrate::Buf;
use crate::interaction::Interactions;
use crate::interaction::gpu::GpuInteractions;
use crate::material::Material;
use crate::methods::{BlowUp, MethodSpec, not_run_by};
use crate::neighbour as neighbour_cpu;
use crate::observe::{Invariants, Snapshot};
use crate::reference::Reference;
use crate::run::{Engine, Failed};
use crate::scene::Case;

/// Strain energy densities of the TLSPH models, for the reduction.
const ENERGY: Wgsl = wgsl!("tlsph/tlsph_energy.wgsl");

/// F, P (and ρ̇, Ṡ of the rate model) per particle.
pub const STRESS: Source = source!(
    "tlsph/tlsph.wgsl",
    [MECHANICS],
    [("y", false), ("grad", false), ("d", true), ("kin", true)]
);
/// Accelerations, artificial viscosity, boundary conditions.
pub const ACCEL: Source = source!(
    "tlsph/tlsph_accel.wgsl",
    [BOUNDARY],
    [
        ("y", false),
        ("grad", false),
        ("dx0", false),
        ("ext", false),
        ("kin", false),
        ("d", true)
    ]
);
/// Energies, momenta and checks of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, ENERGY],
    [("y", false), ("kin", false), ("x_hi", false)]
);

/// The passes compiled with a TLSPH scene's constants ([`scene_constants`]).
pub const SHADERS: &[Source] = &[
    STRESS,
    ACCEL,
    CONTACT,
    CORRECTION,
    INTEGRATE,
    PAIR_OFFSETS,
    REDUCE,
];

/// Offsets (in f32 entries) of the fields in the flat state and kinematics buffers.
/// The state holds u, v, ρ − ρ0 and S; the kinematics H = F − I, P, F⁻ᵀ and ρ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub dim: usize,
    pub rate: bool,
    pub u: usize,
    pub v: usize,
    pub rho: usize,
    pub s: usize,
    /// Flat state length.
    pub len: usize,
    pub kin_f: usize,
    pub kin_p: usize,
    pub kin_fit: usize,
    pub kin_rho: usize,
    pub kin_len: usize,
}

impl Layout {
    pub fn new(n: usize, dim: usize, rate: bool) -> Self {
        let (nd, nt) = (n * dim, n * dim * dim);
        let fields_after_v = if rate { n + nt } else { 0 };
        Self {
            n,
            dim,
            rate,
            u: 0,
            v: nd,
            rho: 2 * nd,
            s: 2 * nd + n,
            len: 2 * nd + fields_after_v,
            kin_f: 0,
            kin_p: nt,
            kin_fit: 2 * nt,
            kin_rho: 3 * nt,
            kin_len: 3 * nt + n,
        }
    }
}

/// The compiled-in constants of a scene's TLSPH passes.
pub fn scene_constants(case: &Case, layout: &Layout) -> Constants {
    let material = Material::new(&case.material);
    let kernel = case.kernel(layout.dim);
    let correction = match case.method.correction {
        CorrectionKind::None => 0,
        CorrectionKind::Shepard => 1,
        CorrectionKind::RandlesLibersky | CorrectionKind::Rkpm | CorrectionKind::Cgck => 2,
    };
    let av = match &case.method.spec {
        MethodSpec::Tlsph(spec) => spec.artificial_viscosity,
        _ => None,
    };
    let u = |x: usize| x as u32;
    Constants::default()
        .kernel(&kernel)
        .u32("N", u(layout.n))
        .u32("BODIES", u(case.bodies.len()))
        .material(&material)
        .choice("CORRECTION", &["NONE", "SHEPARD", "LINEAR"], correction)
        .f32("H", kernel.h)
        .u32("AV", u32::from(av.is_some()))
        .f32("AV_ALPHA", av.map_or(0.0, |a| a.alpha))
        .f32("AV_BETA", av.map_or(0.0, |a| a.beta))
        .f32("AV_ETA", av.map_or(0.0, |a| a.eta))
        .u32("U_OFF", u(layout.u))
        .u32("V_OFF", u(layout.v))
        .u32("RHO_OFF", u(layout.rho))
        .u32("REST_OFF", u(layout.rho))
        .u32("S_OFF", u(layout.s))
        .u32("LEN", u(layout.len))
        .u32("KF_OFF", u(layout.kin_f))
        .u32("KP_OFF", u(layout.kin_p))
        .u32("KFIT_OFF", u(layout.kin_fit))
        .u32("KRHO_OFF", u(layout.kin_rho))
}

/// The stress and acceleration passes of one rate evaluation, bound to a source state.
struct Rates {
    stress: wgpu::BindGroup,
    accel: wgpu::BindGroup,
}

/// The TLSPH system resident on the GPU.
pub struct GpuTlsph<D: GpuDim> {
    gpu: Gpu,
    layout: Layout,
    material: Material,
    stepper: Stepper,
    kin: wgpu::Buffer,
    grad: wgpu::Buffer,
    status: wgpu::Buffer,
    stress: wgpu::ComputePipeline,
    accel: wgpu::ComputePipeline,
    /// Rate evaluations of the states in `Y` and in `Stage`.
    rates: [Rates; 2],
    x0: Vec<D::V>,
    mass: Vec<f64>,
    body: Vec<u32>,
    vol: Vec<f64>,
    /// The stress pass on `Y` writing into `Acc` (for snapshots: F at the current state
    /// without touching the integrator's rates).
    kinematics_y: wgpu::BindGroup,
    reduction: Reduction,
    /// Passes before every step (contact) and the `ext` they write.
    interactions: GpuInteractions,
    constrained: Vec<(u32, u8)>,
    work: WorkBalance,
}

/// Value of `status[0]` when no particle failed.
const STATUS_OK: u32 = u32::MAX;

impl<D: GpuDim> GpuTlsph<D> {
    /// Discretises the case, builds neighbours and corrected gradients, and uploads the
    /// initial state.
    pub fn new(case: &Case, gpu: Gpu) -> Result<Self, SetupError> {
        if !matches!(case.method.spec, MethodSpec::Tlsph(_)) {
            return Err(not_run_by(case, "GpuTlsph").into());
        }
        let disc = Reference::<D>::build(case)?;
        let Reference {
            material,
            kernel,
            boundary,
            ..
        } = &disc;
        let n = disc.len();
        let layout = Layout::new(n, D::N, material.model.is_rate_based());
        let constants = scene_constants(case, &layout);
        check_f32_range(case, &constants)?;
        check_f32_particles::<D>(case, &disc.x0, &disc.v0, &disc.body)?;
        let compose = |s: &Source| shaders::compose::<D>(s, &constants);

        // Neighbours on the GPU from f32 positions; the 1e-5 margin keeps lattice pairs lying
        // exactly on the support on both sides of the f32 rounding (their W and ∇W vanish).
        let typed: Vec<D::HV> = disc.x0.iter().map(|&x| D::v(x)).collect();
        let x_typed = gpu.storage("x0 (cell list)", &typed);
        let (lo, hi) = neighbour_cpu::bounding_box(disc.x0.iter().map(|&x| D::to3(x)));
        let csr = neighbour::build::<D>(
            &gpu,
            &x_typed,
            lo,
            hi,
            n as u32,
            kernel.support() * (1.0 + 1e-5),
        )?;
        let pairs = u64::from(csr.pairs);
        gpu.check_size("per-pair gradient buffer", pairs * D::N as u64 * 4)?;
        gpu.check_size("kinematics buffer", layout.kin_len as u64 * 4)?;
        let (offsets, ids) = (csr.offsets.clone(), csr.ids.clone());
        // X = hi + lo in f32 pairs, for exact pair offsets (see pair_offsets.wgsl).
        let x_hi = flat_v::<D>(disc.x0.iter().copied());
        let x_lo: Vec<f32> = disc
            .x0
            .iter()
            .flat_map(|&x| D::to3(x).into_iter().take(D::N))
            .zip(&x_hi)
            .map(|(x, &h)| (x - f64::from(h)) as f32)
            .collect();
        let (x_hi, x_lo) = (gpu.storage("x hi", &x_hi), gpu.storage("x lo", &x_lo));
        let dx0 = gpu.zeroed("dx0", pairs * D::N as u64 * 4);
        let pipeline = gpu.pipeline("pair offsets", &compose(&PAIR_OFFSETS), "pair_offsets")?;
        let bind = gpu.bind(&pipeline, &[&offsets, &ids, &x_hi, &x_lo, &dx0]);
        dispatch(&gpu, &pipeline, &bind, n as u32);
        let vol32: Vec<f32> = disc.vol.iter().map(|&v| v as f32).collect();
        let vol = gpu.storage("vol", &vol32);
        let status = gpu.storage("status", &[STATUS_OK]);
        let host_solved = matches!(
            case.method.correction,
            CorrectionKind::Rkpm | CorrectionKind::Cgck
        );
        let grad = if host_solved {
            // The RKPM and CGCK corrections run once on the host (f64) and are uploaded.
            let g = correction::gradients::<D>(
                case.method.correction,
                &disc.x0,
                &disc.vol,
                &neighbour::read_lists(&gpu, &csr),
                kernel,
            )
            .map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
            gpu.storage("grad", &flat_v::<D>(g))
        } else {
            let grad = gpu.zeroed("grad", pairs * D::N as u64 * 4);
            let pipeline = gpu.pipeline("correction", &compose(&CORRECTION), "correct")?;
            let bind = gpu.bind(&pipeline, &[&offsets, &ids, &dx0, &vol, &grad, &status]);
            dispatch(&gpu, &pipeline, &bind, n as u32);
            if let Some(i) = read_status(&gpu, &status) {
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
            grad
        };

        let (mask, traction) = boundary_buffers(&gpu, boundary, n);
        let state = StateLayout {
            n,
            dim: D::N,
            rest: layout.rho,
            len: layout.len,
        };
        let stepper = Stepper::new(
            &gpu,
            case.method.integrator,
            &compose(&INTEGRATE),
            state,
            &initial_state::<D>(&layout, &disc.v0),
        )?;
        let interactions = Interactions::<D>::build(case, &disc.x0, &disc.body, || {
            neighbour::read_lists(&gpu, &csr)
        })?;
        let interactions = GpuInteractions::new(
            &gpu,
            &interactions,
            &compose,
            &x_hi,
            stepper.buffer(Buf::Y),
            traction,
        )?;
        let ext = interactions.ext();
        let kin = gpu.zeroed("kinematics", layout.kin_len as u64 * 4);
        let power = gpu.zeroed("power", n as u64 * 4);

        let stress = gpu.pipeline("tlsph stress", &compose(&STRESS), "stress")?;
        let accel = gpu.pipeline("tlsph accel", &compose(&ACCEL), "accel")?;
        let rates_d = stepper.buffer(Buf::Rates);
        let rates = [Buf::Y, Buf::Stage].map(|src| {
            let s = stepper.buffer(src);
            Rates {
                stress: gpu.bind(
                    &stress,
                    &[&offsets, &ids, &grad, &vol, s, &kin, rates_d, &status],
                ),
                accel: gpu.bind(
                    &accel,
                    &[
                        &offsets, &ids, &grad, &vol, &dx0, s, &kin, &mask, ext, rates_d, &power,
                    ],
                ),
            }
        });
        let y = stepper.buffer(Buf::Y);
        let reduction = Reduction::new(
            &gpu,
            &compose(&REDUCE),
            &[(0, y), (1, &kin), (2, &vol), (3, &x_hi), (4, &power)],
            n,
        )?;
        let kinematics_y = gpu.bind(
            &stress,
            &[
                &offsets,
                &ids,
                &grad,
                &vol,
                y,
                &kin,
                stepper.buffer(Buf::Acc),
                &status,
            ],
        );
        let constrained = disc.boundary.constrained.clone();
        let Reference {
            x0,
            vol,
            mass,
            body,
            material,
            ..
        } = disc;
        Ok(Self {
            gpu,
            layout,
            material,
            stepper,
            kin,
            grad,
            status,
            stress,
            accel,
            rates,
            x0,
            mass,
            body,
            vol,
            kinematics_y,
            reduction,
            interactions,
            constrained,
            work: WorkBalance::default(),
        })
    }
}

fn dispatch(gpu: &Gpu, pipeline: &wgpu::ComputePipeline, bind: &wgpu::BindGroup, n: u32) {
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        gpu.dispatch(&mut pass, pipeline, bind, n);
    }
    gpu.queue.submit([encoder.finish()]);
}

/// The first failed particle recorded in a status buffer, if any.
fn read_status(gpu: &Gpu, status: &wgpu::Buffer) -> Option<usize> {
    let s: Vec<u32> = gpu.read(status);
    (s[0] != STATUS_OK).then_some(s[0] as usize)
}

/// Flat initial state: u = 0, v = v0, ρ − ρ0 = 0, S = 0.
fn initial_state<D: Flat>(layout: &Layout, v0: &[D::V]) -> Vec<f32> {
    let mut y = vec![0.0f32; layout.len];
    let mut v = Vec::with_capacity(layout.n * D::N);
    v0.iter().for_each(|&x| D::push_v(&mut v, x));
    y[layout.v..layout.v + v.len()].copy_from_slice(&v);
    y
}

impl<D: GpuDim> GpuTlsph<D> {
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub fn reference(&self) -> &[D::V] {
        &self.x0
    }

    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    pub fn body(&self) -> &[u32] {
        &self.body
    }

    pub fn volume(&self) -> &[f64] {
        &self.vol
    }

    pub fn material(&self) -> &Material {
        &self.material
    }

    /// Records one rate evaluation: the stress and acceleration passes on `rates`.
    fn record_rates(
        gpu: &Gpu,
        n: u32,
        (stress, accel): (&wgpu::ComputePipeline, &wgpu::ComputePipeline),
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
        let mut y = self.decode(&flat);
        y.rho.iter_mut().for_each(|r| *r += self.material.rho0);
        y
    }

    /// Decodes a flat state or rate buffer (the density entry is ρ − ρ0, or ρ̇).
    fn decode(&self, flat: &[f32]) -> TlState<D> {
        let l = &self.layout;
        let (d, t) = (D::N, D::N * D::N);
        let vecs = |off: usize| (0..l.n).map(|i| D::read_v(&flat[off + d * i..])).collect();
        TlState {
            u: vecs(l.u),
            v: vecs(l.v),
            rho: if l.rate {
                flat[l.rho..l.rho + l.n].iter().map(|&r| r.into()).collect()
            } else {
                Vec::new()
            },
            s: if l.rate {
                (0..l.n).map(|i| D::read_t(&flat[l.s + t * i..])).collect()
            } else {
                Vec::new()
            },
        }
    }

    /// Replaces the state (e.g. to cross-check rates on a given state).
    pub fn set_state(&mut self, y: &TlState<D>) {
        let l = &self.layout;
        let mut flat = vec![0.0f32; l.len];
        let mut put_v = |off: usize, vs: &[D::V]| {
            let mut tmp = Vec::with_capacity(vs.len() * D::N);
            vs.iter().for_each(|&v| D::push_v(&mut tmp, v));
            flat[off..off + tmp.len()].copy_from_slice(&tmp);
        };
        put_v(l.u, &y.u);
        put_v(l.v, &y.v);
        if l.rate {
            for (k, &r) in y.rho.iter().enumerate() {
                flat[l.rho + k] = (r - self.material.rho0) as f32;
            }
            let mut tmp = Vec::with_capacity(l.n * D::N * D::N);
            y.s.iter().for_each(|&s| D::push_t(&mut tmp, s));
            flat[l.s..l.s + tmp.len()].copy_from_slice(&tmp);
        }
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
        (self.decode(&d), f, p)
    }

    /// The corrected reference gradients, in CSR order.
    pub fn gradients(&self) -> Vec<D::V> {
        let g: Vec<f32> = self.gpu.read(&self.grad);
        g.chunks_exact(D::N).map(D::read_v).collect()
    }

    /// F and P of the last rate evaluation (the GPU keeps H = F − I; I is added in f64).
    pub fn kinematics(&self) -> (Vec<D::T>, Vec<D::T>) {
        let kin: Vec<f32> = self.gpu.read(&self.kin);
        let l = &self.layout;
        let t = D::N * D::N;
        let tensor = |off: usize, i: usize| D::read_t(&kin[off + t * i..]);
        let f = (0..l.n)
            .map(|i| D::identity() + tensor(l.kin_f, i))
            .collect();
        let p = (0..l.n).map(|i| tensor(l.kin_p, i)).collect();
        (f, p)
    }

    /// The first particle whose det F ≤ 0 (or NaN) in any evaluation so far.
    pub fn failed_particle(&self) -> Option<usize> {
        read_status(&self.gpu, &self.status)
    }
}

impl<D: GpuDim> Engine<D> for GpuTlsph<D> {
    fn backend(&self) -> String {
        format!("gpu: {}", self.gpu.name())
    }

    fn reference(&self) -> &[D::V] {
        &self.x0
    }

    fn constrained(&self) -> &[(u32, u8)] {
        &self.constrained
    }

    fn advance(&mut self, _t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        self.advance_steps(dt, steps);
        Ok(())
    }

    fn max_signal_speed(&mut self) -> f64 {
        self.material.p_wave_speed() + self.reduction().max_speed
    }

    /// Trapezoidal over the intervals between calls (the driver calls it at every check).
    fn external_work(&mut self) -> f64 {
        let power = self.reduction().power;
        self.work.update(power)
    }

    fn check(&mut self) -> Result<(), BlowUp> {
        if let Some(i) = self.failed_particle() {
            return Err(BlowUp {
                particle: i,
                position: D::to3(self.x0[i]),
                quantity: "det F (f32, GPU)".into(),
                value: 0.0,
            });
        }
        if self.reduction().non_finite {
            return check_state(&self.x0, &self.state());
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
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            let n = self.layout.n as u32;
            self.gpu
                .dispatch(&mut pass, &self.stress, &self.kinematics_y, n);
        }
        self.gpu.queue.submit([encoder.finish()]);
        let y = self.state();
        let (f, _) = self.kinematics();
        snapshot(
            &self.material,
            &self.x0,
            &self.mass,
            &self.body,
            &self.vol,
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
