//! The passes of a rate evaluation, their bind groups and how one evaluation is recorded.

use super::*;
use crate::gpu::shaders::Compose;

/// The uniform `Stage` of `mixed_momentum.wgsl`.
#[derive(Clone, Copy, Debug, ShaderType)]
pub(super) struct StagePoints {
    pub(super) half_dt: f32,
    pub(super) mid: u32,
}

impl StagePoints {
    /// The bytes of the uniform.
    pub(super) fn bytes() -> usize {
        crate::gpu::context::uniform_bytes(&StagePoints {
            half_dt: 0.0,
            mid: 0,
        })
        .len()
    }

    /// The uniform of the stage's points (`mid` = 0) or the mid-step points (1), with
    /// Δt/2 written when Δt is set.
    pub(super) fn uniform(gpu: &Gpu, label: &str, mid: u32) -> wgpu::Buffer {
        gpu.uniform(label, &StagePoints { half_dt: 0.0, mid })
    }
}

/// The pipelines of the mixed passes.
pub(super) struct Passes {
    pub(super) ghost_motion: Pipeline,
    pub(super) ghost_kin: Pipeline,
    /// Ghost slopes or Laplacians.
    pub(super) ghost_second: Pipeline,
    /// The bond-based F^c, where the scene uses it.
    pub(super) bond: Option<Pipeline>,
    pub(super) kinematics: Pipeline,
    /// Slopes or Laplacians.
    pub(super) second: Pipeline,
    pub(super) forces: Pipeline,
    /// SUPG-SPH's nodes, points and gather.
    pub(super) supg: Option<[Pipeline; 3]>,
    pub(super) balance_sums: Pipeline,
    pub(super) balance_solve: Pipeline,
    pub(super) rates: Pipeline,
}

/// The bind groups of one rate evaluation (a source state and its balance points); a
/// pass over the pairs has one a part of the lists.
pub(super) struct Bound {
    pub(super) ghost_motion: wgpu::BindGroup,
    pub(super) ghost_kin: wgpu::BindGroup,
    pub(super) bond: Option<Vec<wgpu::BindGroup>>,
    pub(super) kinematics: Vec<wgpu::BindGroup>,
    /// Slopes or Laplacians, and their ghost fill.
    pub(super) second: Option<(Vec<wgpu::BindGroup>, wgpu::BindGroup)>,
    pub(super) forces: Vec<wgpu::BindGroup>,
    pub(super) supg: Option<[wgpu::BindGroup; 3]>,
    pub(super) balance_sums: wgpu::BindGroup,
    pub(super) balance_solve: wgpu::BindGroup,
    pub(super) rates: wgpu::BindGroup,
    /// The corrector's start, under artificial compressibility.
    pub(super) corrector_start: Option<wgpu::BindGroup>,
}

impl Passes {
    /// The pipelines of a scene's passes, `compose` compiling a source with its constants.
    pub(super) fn new(
        gpu: &Gpu,
        layout: &MixedLayout,
        compose: Compose<'_>,
    ) -> Result<Self, GpuError> {
        let ghosts_src = compose(&GHOSTS);
        let slopes_src = compose(&SLOPES);
        let momentum_src = compose(&MOMENTUM);
        let pipeline = |label: &str, src: &str, entry: &str| gpu.pipeline(label, src, entry);
        let (second_entry, ghost_second_entry) = if layout.pair.has("ELL") {
            ("laplacian", "ghost_laplacian")
        } else {
            ("slopes", "ghost_slopes")
        };
        Ok(Self {
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
            supg: if layout.nodes.is_empty() {
                None
            } else {
                let src = compose(&SUPG);
                let [nodes, points, gather] = ["supg_nodes", "supg_points", "supg_gather"]
                    .map(|entry| pipeline("SUPG-SPH", &src, entry));
                Some([nodes?, points?, gather?])
            },
            balance_sums: pipeline("balance sums", &momentum_src, "balance_sums")?,
            balance_solve: pipeline("balance solve", &momentum_src, "balance_solve")?,
            rates: pipeline("mixed rates", &momentum_src, "rates")?,
        })
    }
}

impl Bound {
    /// The bind groups of the passes over the buffers `tables` (by binding name, one a
    /// part of the lists; a pass over the particles binds the first); `second` the
    /// slopes or Laplacians, where the scene has them.
    pub(super) fn new(
        gpu: &Gpu,
        p: &Passes,
        tables: &[Vec<(&str, &wgpu::Buffer)>],
        second: Option<&wgpu::Buffer>,
        corrector: Option<&DeviceCorrector>,
    ) -> Result<Self, GpuError> {
        let t = tables[0].as_slice();
        let by_part = |pipeline: &Pipeline| -> Result<Vec<wgpu::BindGroup>, GpuError> {
            tables.iter().map(|t| gpu.bind(pipeline, t)).collect()
        };
        let second = match second {
            None => None,
            Some(field) => {
                let with_second = [t, &[("field", field)]].concat();
                Some((
                    by_part(&p.second)?,
                    gpu.bind(&p.ghost_second, &with_second)?,
                ))
            }
        };
        Ok(Self {
            ghost_motion: gpu.bind(&p.ghost_motion, t)?,
            ghost_kin: gpu.bind(&p.ghost_kin, t)?,
            bond: p.bond.as_ref().map(by_part).transpose()?,
            kinematics: by_part(&p.kinematics)?,
            second,
            forces: by_part(&p.forces)?,
            supg: (p.supg.as_ref())
                .map(|[nodes, points, gather]| -> Result<_, GpuError> {
                    Ok([
                        gpu.bind(nodes, t)?,
                        gpu.bind(points, t)?,
                        gpu.bind(gather, t)?,
                    ])
                })
                .transpose()?,
            balance_sums: gpu.bind(&p.balance_sums, t)?,
            balance_solve: gpu.bind(&p.balance_solve, t)?,
            rates: gpu.bind(&p.rates, t)?,
            corrector_start: corrector.map(|c| c.bind_start(gpu, t)).transpose()?,
        })
    }
}

/// The passes of a rate evaluation and their bind groups.
pub(super) struct Evaluator {
    pub(super) passes: Passes,
    /// The corrector of every stage under artificial compressibility.
    pub(super) corrector: Option<DeviceCorrector>,
    /// Bind groups by [`Evaluator::key`].
    pub(super) bound: Vec<((Buf, bool), Bound)>,
    /// The parts of the neighbour lists.
    pub(super) split: Split,
    pub(super) n: u32,
    pub(super) ghosts: u32,
    /// SUPG-SPH: its stress points, and their row entries as a share of the neighbour
    /// lists' pairs (the bytes models' pairs of its passes).
    pub(super) supg: Option<(u32, f64)>,
    pub(super) projection: bool,
    /// The second TVD-RK2 stage balances about x^n + Δt/2 (v^n + v*) (projection on).
    pub(super) tvd_mid: bool,
}

impl Evaluator {
    /// The evaluator of the passes of `cpu`'s scene, before its bind groups.
    pub(super) fn new<D: Dim>(
        passes: Passes,
        layout: &MixedLayout,
        cpu: &MixedSph<D>,
        (integrator, split): (IntegratorKind, Split),
    ) -> Self {
        Self {
            passes,
            corrector: None,
            bound: Vec::new(),
            split,
            n: layout.n as u32,
            ghosts: layout.ghosts as u32,
            supg: cpu.stress_points().map(|(_, s)| {
                let pairs = cpu.neighbours().pair_count().max(1);
                (s.len() as u32, s.shapes.csr.ids.len() as f64 / pairs as f64)
            }),
            projection: cpu.projection(),
            tvd_mid: cpu.projection() && integrator == IntegratorKind::TvdRk2,
        }
    }

    /// The source buffer of an evaluation, and whether it balances about the mid-step
    /// points.
    pub(super) fn key(&self, e: Evaluation) -> (Buf, bool) {
        (e.src, self.tvd_mid && e.index == 1)
    }

    /// The keys of the evaluations of a step of `integrator`, the state `y` first.
    pub(super) fn keys(&self, integrator: IntegratorKind) -> Vec<(Buf, bool)> {
        let mut keys = vec![(Buf::Y, false)];
        for e in evaluations(integrator) {
            let key = self.key(e);
            if !keys.contains(&key) {
                keys.push(key);
            }
        }
        keys
    }

    pub(super) fn bound(&self, key: (Buf, bool)) -> &Bound {
        &self
            .bound
            .iter()
            .find(|(k, _)| *k == key)
            .expect("every evaluation of the program is bound")
            .1
    }

    /// The motion of the ghosts and, with the bond-based F, F^c − I of the state bound
    /// in `b`: what the kinematics read besides the state.
    pub(super) fn record_motion(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>, b: &Bound) {
        let p = &self.passes;
        if self.ghosts > 0 {
            gpu.dispatch(pass, &p.ghost_motion, &b.ghost_motion, self.ghosts);
        }
        if let (Some(pipeline), Some(bond)) = (&p.bond, &b.bond) {
            self.split.dispatch(gpu, pass, pipeline, bond);
        }
    }

    /// Records one rate evaluation into one compute pass.
    pub(super) fn record(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, e: Evaluation) {
        let b = self.bound(self.key(e));
        let (p, ng) = (&self.passes, self.ghosts);
        let mut pass = encoder.begin_compute_pass(&Default::default());
        self.record_motion(gpu, &mut pass, b);
        self.split
            .dispatch(gpu, &mut pass, &p.kinematics, &b.kinematics);
        if ng > 0 {
            gpu.dispatch(&mut pass, &p.ghost_kin, &b.ghost_kin, ng);
        }
        if let Some((second, ghost_second)) = &b.second {
            self.split.dispatch(gpu, &mut pass, &p.second, second);
            if ng > 0 {
                gpu.dispatch(&mut pass, &p.ghost_second, ghost_second, ng);
            }
        }
        self.split.dispatch(gpu, &mut pass, &p.forces, &b.forces);
        if let (Some([nodes, points, gather]), Some(bound), Some((count, share))) =
            (&p.supg, &b.supg, self.supg)
        {
            gpu.dispatch(&mut pass, nodes, &bound[0], self.n + ng);
            gpu.dispatch_part(&mut pass, points, &bound[1], count, share);
            gpu.dispatch_part(&mut pass, gather, &bound[2], self.n, share);
        }
        self.record_rates(gpu, &mut pass, b);
        if let (Some(corrector), Some(start)) = (&self.corrector, &b.corrector_start) {
            // The predictor's rates give v^int; the corrector adds its force to T, and
            // the rates follow again from the forces of the stage.
            corrector.record(gpu, &mut pass, start);
            self.record_rates(gpu, &mut pass, b);
        }
    }

    /// The projection of the forces and the rates with the boundary conditions.
    pub(super) fn record_rates(&self, gpu: &Gpu, pass: &mut wgpu::ComputePass<'_>, b: &Bound) {
        let (p, n) = (&self.passes, self.n);
        if self.projection {
            gpu.dispatch(pass, &p.balance_sums, &b.balance_sums, n);
            gpu.dispatch(pass, &p.balance_solve, &b.balance_solve, 1);
        }
        gpu.dispatch(pass, &p.rates, &b.rates, n);
    }
}

crate::gpu::context::wgsl_twin_test!(stage_points_match_wgsl: StagePoints = "Stage" in MOMENTUM.text);
