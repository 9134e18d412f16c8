//! The static solve of dual-support SPH on the GPU: Newton–Raphson on the host in f64
//! (residual, load steps, step cutting: [`crate::statics`]) with each Newton step
//! K(u) Δu = R solved matrix-free on the device by Jacobi-preconditioned conjugate
//! gradients (`shaders/dual_support/krylov.wgsl`). K is never assembled: its product with
//! a direction is the force pass's gather on the union lists S_i ∪ S'_i, with P replaced by
//! 𝔸_i : δH_i and the hourglass force taken along the direction, so the memory is that of
//! the explicit variant plus 𝔸 and five vectors, not the two-hop pattern of the
//! assembled tangent.
//!
//! Scaling. The device solves for the increment Δu only, never for positions X + u (at
//! u/X ≈ 1e-6, f32 rounds X + u to X); the right-hand side is scaled to unit norm, and
//! the Jacobi preconditioner makes the iteration that of D^(−1/2) K D^(−1/2), whose
//! diagonal is 1: every quantity of the iteration is O(1) whatever E and the load. 𝔸 and
//! the diagonal are computed on the host in f64 at the Newton state and rounded once. The
//! recursive residual of f32 CG keeps falling after the true one stalls near 1e-6 (f32
//! sums of ~1e2 terms per row), so the device stops at the relative residual
//! max(method.linear_tolerance, [`F32_TOLERANCE`]) and the f64 Newton residual on the host
//! does the rest: an inexact Newton method, linear at the rate of the solve's true
//! residual where the direct solve is quadratic.

use super::gpu::DeviceLists;
use super::model::DualSupport;
use crate::core::neighbour::Csr;
use crate::core::tensor::Dim;
use crate::gpu::context::{Gpu, GpuError, Pipeline, WORKGROUP};
use crate::gpu::layout::GpuDim;
use crate::gpu::memory::{Counts, DeviceMemory};
use crate::gpu::parts::{self, Split};
use crate::gpu::profile::Scale;
use crate::gpu::shaders::{Constants, PART, Source, compose, source};
use crate::statics::MatrixFree;
use crate::statics::sparse::{SolveError, SolveStats};
use std::time::Instant;

/// The lowest relative residual the device's f32 iteration is asked for.
pub const F32_TOLERANCE: f64 = 1e-5;

/// CG iterations recorded per submission; the host reads the iteration's state (eight
/// words) after each batch. Iterations past convergence in a batch are no-ops (α = 0).
const BATCH: u32 = 32;

/// The scalars of the iteration on the device (krylov.wgsl).
const SCALARS: usize = 8;
const RR: usize = 3;
const THRESHOLD: usize = 4;
const STATE: usize = 5;
const ITERATIONS: usize = 6;
/// The values of its state word.
const CONVERGED: f32 = 1.0;
const INDEFINITE: f32 = 2.0;

/// The passes of the matrix-free solve. Items: particles (strain, product), degrees of
/// freedom (start, update, direction) and workgroup partials (begin, alpha, beta).
pub const KRYLOV: Source = source!(
    "dual_support/krylov.wgsl",
    [PART],
    [
        ("p", false),
        ("g", false),
        ("grev", false),
        ("hg", false),
        ("q", true),
        ("lin", true)
    ]
);

/// The scene constants of the passes on n particles in `dim` dimensions, whose partials
/// are `groups` = (the workgroups of particles, of the degrees of freedom's dispatch).
pub fn constants(dim: usize, n: usize, hourglass: bool, groups: (u32, u32)) -> Constants {
    Constants::default()
        .u32("NDOF", (n * dim) as u32)
        .u32("LP_OFF", (n * dim * dim) as u32)
        .u32("HOURGLASS", u32::from(hourglass))
        .u32("GROUPS_N", groups.0)
        .u32("GROUPS_DOF", groups.1)
}

/// What a pass runs over.
#[derive(Clone, Copy, Debug)]
enum Items {
    Particles,
    Dofs,
    /// One workgroup summing the partials of the particle passes (alpha).
    ParticleSums,
    /// One workgroup summing the partials of the degree-of-freedom passes (begin, beta).
    DofSums,
}

/// The entry points of one CG iteration, in order, and of the start.
const ITERATION: [(&str, Items); 6] = [
    ("strain", Items::Particles),
    ("product", Items::Particles),
    ("alpha", Items::ParticleSums),
    ("update", Items::Dofs),
    ("beta", Items::DofSums),
    ("direction", Items::Dofs),
];
const START: [(&str, Items); 2] = [("start", Items::Dofs), ("begin", Items::DofSums)];

/// A pass with its bind groups (one a part of the lists for the particle passes, else
/// one) and items.
type Pass = (Pipeline, Vec<wgpu::BindGroup>, Items);

/// The device's matrix-free solver of one dual-support model.
pub struct NewtonKrylov {
    gpu: Gpu,
    n: usize,
    dim: usize,
    /// The parts of the union lists, each with its own lists and per-pair buffers.
    split: Split,
    /// The passes of an iteration and of the start.
    iteration: Vec<Pass>,
    start: Vec<Pass>,
    tangent: wgpu::Buffer,
    inv_diag: wgpu::Buffer,
    x: wgpu::Buffer,
    r: wgpu::Buffer,
    p: wgpu::Buffer,
    q: wgpu::Buffer,
    scalars: wgpu::Buffer,
    /// Pairs of the union lists.
    pairs: u64,
    /// The device's relative residual and iteration limit.
    tolerance: f64,
    max_iterations: usize,
}

impl NewtonKrylov {
    /// The buffers [`Self::new`] makes for `counts` in `dim` dimensions: the union lists
    /// (taken as the case kernel's pairs) with their per-pair data, the tangent moduli
    /// (dim³ a degree of freedom) and the conjugate gradients' vectors.
    pub fn memory(counts: &Counts, dim: usize) -> DeviceMemory {
        DeviceMemory::of(counts, |m| {
            let (n, pairs) = (counts.particles, counts.pairs);
            let dofs = n * dim as f64;
            m.words("lists", n + 1.0 + pairs);
            m.words("g", pairs * dim as f64);
            m.words("grev", pairs * dim as f64);
            m.words("hg", pairs * (dim + 2) as f64);
            m.words("tangent", dofs * dim.pow(3) as f64);
            for label in ["inv_diag", "x", "r", "p", "q"] {
                m.words(label, dofs);
            }
            m.words("lin", 2.0 * dofs * dim as f64);
            let groups = (dofs / f64::from(crate::gpu::context::WORKGROUP))
                .ceil()
                .max(1.0);
            m.words("partials", 2.0 * groups);
            m.words("scalars", SCALARS as f64);
        })
    }

    /// The passes and buffers on the union lists of `lists` (the pairs' g_ij, g_ji,
    /// X_j − X_i and hourglass stiffnesses, uploaded once); CG stops at the relative
    /// residual max(`tolerance`, [`F32_TOLERANCE`]) or fails after `max_iterations`.
    pub fn new<D: GpuDim>(
        gpu: Gpu,
        lists: &DeviceLists<D>,
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<Self, GpuError> {
        let (n, dim) = (lists.model.len(), D::N);
        let csr = &lists.csr;
        let [g, grev, hg] = pair_data(lists);
        let split = Split::fitting(&gpu, csr, 4 * (dim as u64 + 2))?;
        let nd = (n * dim) as u64 * 4;
        let moduli = nd * (dim * dim * dim) as u64;
        gpu.check_size("tangent buffer", moduli)?;
        let hourglass = lists.model.hourglass.iter().any(|&c| c != 0.0);
        let groups_dof = gpu.groups((n * dim) as u32);
        let groups = (
            n.div_ceil(WORKGROUP as usize) as u32,
            groups_dof.0 * groups_dof.1,
        );
        let text = compose::<D>(&KRYLOV, &constants(dim, n, hourglass, groups));
        let partials = u64::from(groups.0.max(groups.1)) * 8;
        let part_buffers = part_buffers(&gpu, csr, &split, [&g, &grev, &hg], dim);
        let tangent = gpu.zeroed("tangent", moduli);
        let inv_diag = gpu.zeroed("inv_diag", nd);
        let (x, r, p, q) = (
            gpu.zeroed("x", nd),
            gpu.zeroed("r", nd),
            gpu.zeroed("p", nd),
            gpu.zeroed("q", nd),
        );
        let lin = gpu.zeroed("lin", 2 * nd * dim as u64);
        let partials = gpu.zeroed("partials", partials);
        let scalars = gpu.zeroed("scalars", SCALARS as u64 * 4);
        let whole = [
            ("tangent", &tangent),
            ("inv_diag", &inv_diag),
            ("x", &x),
            ("r", &r),
            ("p", &p),
            ("q", &q),
            ("lin", &lin),
            ("partials", &partials),
            ("scalars", &scalars),
        ];
        let bind = |pipeline: &Pipeline, part: &[wgpu::Buffer; 5]| {
            let table: Vec<(&str, &wgpu::Buffer)> = (whole.iter().copied())
                .chain(PART_NAMES.into_iter().zip(part))
                .collect();
            gpu.bind(pipeline, &table)
        };
        // The particle passes bind each part; the others bind the first, which they leave
        // unread.
        let passes = |entries: &[(&str, Items)]| -> Result<Vec<Pass>, GpuError> {
            entries
                .iter()
                .map(|&(entry, items)| {
                    let pipeline = gpu.pipeline("dual-support Krylov", &text, entry)?;
                    let binds = match items {
                        Items::Particles => (part_buffers.iter())
                            .map(|part| bind(&pipeline, part))
                            .collect::<Result<Vec<_>, _>>()?,
                        _ => vec![bind(&pipeline, &part_buffers[0])?],
                    };
                    Ok((pipeline, binds, items))
                })
                .collect()
        };
        let (iteration, start) = (passes(&ITERATION)?, passes(&START)?);
        Ok(Self {
            n,
            dim,
            split,
            iteration,
            start,
            tangent,
            inv_diag,
            x,
            r,
            p,
            q,
            scalars,
            pairs: csr.ids.len() as u64,
            tolerance: tolerance.max(F32_TOLERANCE),
            max_iterations,
            gpu,
        })
    }

    /// The parts of the union lists.
    pub fn split(&self) -> &Split {
        &self.split
    }

    /// Records the passes `passes` once each into `pass`.
    fn record(&self, pass: &mut wgpu::ComputePass<'_>, passes: &[Pass]) {
        let gpu = &self.gpu;
        let (n, nd) = (self.n as u32, (self.n * self.dim) as u32);
        // The items of a summing pass: the workgroups whose partials it sums (of the
        // particles, a part at a time: the workgroups of particles).
        let sums = |over: u32| {
            let (gx, gy) = gpu.groups(over);
            u64::from(gx * gy)
        };
        let particle_groups = u64::from(n.div_ceil(WORKGROUP));
        for (pipeline, binds, items) in passes {
            let one = (1, 1);
            match *items {
                Items::Particles => self.split.dispatch(gpu, pass, pipeline, binds),
                Items::Dofs => gpu.dispatch(pass, pipeline, &binds[0], nd),
                Items::ParticleSums => {
                    gpu.dispatch_groups(pass, pipeline, &binds[0], one, particle_groups);
                }
                Items::DofSums => gpu.dispatch_groups(pass, pipeline, &binds[0], one, sums(nd)),
            }
        }
    }

    /// Uploads V_i 𝔸_i and the inverse diagonal of K (0 on prescribed components) of
    /// `model` at displacement u, both from the host's f64.
    fn linearise<D: Dim>(
        &self,
        model: &DualSupport<D>,
        u: &[D::V],
        free: &[Option<u32>],
    ) -> Result<(), SolveError> {
        let d = self.dim;
        let tangents = model.tangents(u);
        let diag = model.diagonal(&tangents);
        let mut inv_diag = vec![0.0f32; self.n * d];
        for (dof, f) in free.iter().enumerate() {
            if f.is_some() {
                let k = D::comp(diag[dof / d], dof % d);
                if k.is_nan() || k <= 0.0 {
                    return Err(SolveError::NotPositiveDefinite);
                }
                inv_diag[dof] = (1.0 / k) as f32;
            }
        }
        let vol = &model.support.vol;
        let moduli: Vec<f32> = tangents
            .iter()
            .zip(vol)
            .flat_map(|(a, &v)| {
                (0..d * d).flat_map(move |kj| {
                    (0..d * d)
                        .map(move |ll| (a[3 * (kj / d) + kj % d][3 * (ll / d) + ll % d] * v) as f32)
                })
            })
            .collect();
        let queue = &self.gpu.queue;
        queue.write_buffer(&self.tangent, 0, bytemuck::cast_slice(&moduli));
        queue.write_buffer(&self.inv_diag, 0, bytemuck::cast_slice(&inv_diag));
        Ok(())
    }

    /// K(u) v on the device, every row (the iteration keeps the prescribed components of
    /// its vectors at 0, so their rows never enter it; for checks against the assembled
    /// tangent); v has d components per particle.
    pub fn product<D: Dim>(
        &mut self,
        model: &DualSupport<D>,
        u: &[D::V],
        free: &[Option<u32>],
        v: &[f32],
    ) -> Result<Vec<f32>, SolveError> {
        self.linearise(model, u, free)?;
        self.gpu
            .queue
            .write_buffer(&self.p, 0, bytemuck::cast_slice(v));
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            self.record(&mut pass, &self.iteration[..2]);
        }
        self.gpu.queue.submit([encoder.finish()]);
        Ok(self.gpu.read(&self.q))
    }

    /// Solves K x = b on the device for b of unit norm (zero on prescribed components),
    /// with `inv_diag` and the tangent uploaded: x and the iterations.
    fn iterate(&self, b: &[f32]) -> Result<(Vec<f32>, usize), SolveError> {
        let gpu = &self.gpu;
        gpu.queue.write_buffer(&self.r, 0, bytemuck::cast_slice(b));
        let mut scalars = [0.0f32; SCALARS];
        scalars[THRESHOLD] = (self.tolerance * self.tolerance) as f32;
        gpu.queue
            .write_buffer(&self.scalars, 0, bytemuck::cast_slice(&scalars));
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            self.record(&mut pass, &self.start);
        }
        gpu.queue.submit([encoder.finish()]);
        loop {
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                for _ in 0..BATCH {
                    self.record(&mut pass, &self.iteration);
                }
            }
            gpu.queue.submit([encoder.finish()]);
            let s: Vec<f32> = gpu.read(&self.scalars);
            let iterations = s[ITERATIONS] as usize;
            if s[STATE] == CONVERGED {
                return Ok((gpu.read(&self.x), iterations));
            }
            if s[STATE] == INDEFINITE || !s[RR].is_finite() {
                return Err(SolveError::NotPositiveDefinite);
            }
            if iterations >= self.max_iterations {
                return Err(SolveError::NoConvergence {
                    tolerance: self.tolerance,
                    iterations,
                    reached: f64::from(s[RR]).sqrt(),
                });
            }
        }
    }
}

/// The per-pair data of the union lists of `lists`: g = V_j g_ij and grev = V_i g_ji (DIM
/// each), and hg = [X_j − X_i | k_ij | k_ji] (DIM + 2).
fn pair_data<D: GpuDim>(lists: &DeviceLists<D>) -> [Vec<f32>; 3] {
    let dim = D::N;
    let x0 = &lists.model.support.x0;
    let vol = &lists.model.support.vol;
    let csr = &lists.csr;
    let pairs = csr.ids.len();
    let (mut g, mut grev) = (vec![0.0f32; pairs * dim], vec![0.0f32; pairs * dim]);
    let mut hg = vec![0.0f32; pairs * (dim + 2)];
    for i in 0..csr.len() {
        for k in csr.offsets[i]..csr.offsets[i + 1] {
            let j = csr.ids[k] as usize;
            let back = csr.offsets[j]
                + csr
                    .neighbours(j)
                    .binary_search(&(i as u32))
                    .expect("the union lists are symmetric");
            let (g_ij, g_ji) = (lists.g[k] * vol[j], lists.g[back] * vol[i]);
            let dx = x0[j] - x0[i];
            for c in 0..dim {
                g[k * dim + c] = D::comp(g_ij, c) as f32;
                grev[k * dim + c] = D::comp(g_ji, c) as f32;
                hg[k * (dim + 2) + c] = D::comp(dx, c) as f32;
            }
            hg[k * (dim + 2) + dim] = lists.hgk[k];
            hg[k * (dim + 2) + dim + 1] = lists.hgk_rev[k];
        }
    }
    [g, grev, hg]
}

/// The names each part's buffers of [`part_buffers`] are bound as.
const PART_NAMES: [&str; 5] = ["lists", "g", "grev", "hg", "part"];

/// Each part's lists (its offsets from its first pair, then its ids), per-pair data
/// `[g, grev, hg]` (DIM, DIM and DIM + 2 words a pair) and uniform.
fn part_buffers(
    gpu: &Gpu,
    csr: &Csr,
    split: &Split,
    [g, grev, hg]: [&[f32]; 3],
    dim: usize,
) -> Vec<[wgpu::Buffer; 5]> {
    (split.parts.iter())
        .map(|part| {
            let (from, to) = (part.start, part.start + part.pairs);
            let rows = &csr.offsets[part.first..=part.first + part.rows];
            let list: Vec<u32> = (rows.iter().map(|&o| (o - from) as u32))
                .chain(csr.ids[from..to].iter().copied())
                .collect();
            [
                gpu.storage("lists", &list),
                gpu.storage("g", &g[from * dim..to * dim]),
                gpu.storage("grev", &grev[from * dim..to * dim]),
                gpu.storage("hg", &hg[from * (dim + 2)..to * (dim + 2)]),
                parts::uniform(gpu, part.first, part.rows),
            ]
        })
        .collect()
}

impl<D: Dim> MatrixFree<D, DualSupport<D>> for NewtonKrylov {
    /// 𝔸 and the diagonal at u on the host (f64, rounded once), the scaled right-hand
    /// side, the device's CG, and Δu = |r| x on the free components.
    fn solve(
        &mut self,
        model: &mut DualSupport<D>,
        u: &[D::V],
        free: &[Option<u32>],
        r: &[f64],
    ) -> Result<(Vec<f64>, SolveStats), SolveError> {
        let started = Instant::now();
        let unknowns = r.len();
        let norm = r.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm == 0.0 {
            return Ok((vec![0.0; unknowns], SolveStats::default()));
        }
        self.linearise(model, u, free)?;
        let mut b = vec![0.0f32; self.n * self.dim];
        for (dof, f) in free.iter().enumerate() {
            if let Some(q) = f {
                b[dof] = (r[*q as usize] / norm) as f32;
            }
        }
        let (x, iterations) = self.iterate(&b)?;
        let mut du = vec![0.0; unknowns];
        for (dof, f) in free.iter().enumerate() {
            if let Some(q) = f {
                du[*q as usize] = f64::from(x[dof]) * norm;
            }
        }
        Ok((
            du,
            SolveStats {
                iterations,
                seconds: started.elapsed().as_secs_f64(),
                indefinite: false,
            },
        ))
    }

    fn device(&mut self) -> Option<(&Gpu, Scale)> {
        let scale = Scale {
            pairs: self.pairs,
            indirect: None,
        };
        Some((&self.gpu, scale))
    }

    fn describe(&self, unknowns: usize) -> String {
        format!(
            "gpu: {}; matrix-free Jacobi conjugate gradients on {unknowns} unknowns (f32, \
             relative residual {:e}), Newton in f64 on the host",
            self.gpu.name(),
            self.tolerance
        )
    }
}
