//! SUPG-SPH's stress points on the device (`shaders/mixed/mixed_supg.wgsl`): the points'
//! rows, functions and weights and the particles' gather lists, uploaded once from the
//! CPU set-up ([`crate::methods::mixed::stress_points`]), and the buffers the passes
//! write.

use super::*;

/// The uniform `SupgStep` of `mixed_supg.wgsl`.
#[derive(Clone, Copy, Debug, ShaderType)]
pub(super) struct SupgStep {
    pub(super) dt: f32,
}

/// The buffers of SUPG-SPH's passes.
pub(super) struct SupgBuffers {
    /// Δt of the step ([`SupgStep`]).
    pub(super) step: wgpu::Buffer,
    nodes: wgpu::Buffer,
    /// The points' rows: offsets, then the corners' extended ids.
    points: wgpu::Buffer,
    shapes: wgpu::Buffer,
    terms: wgpu::Buffer,
    /// The real particles' lists: offsets, then (point, row entry, corner) per entry.
    gather: wgpu::Buffer,
}

impl SupgBuffers {
    /// The buffers [`Self::upload`] makes for `layout`.
    pub(super) fn memory(m: &mut DeviceMemory, layout: &MixedLayout, sizes: &Sizes) {
        if !sizes.supg {
            return;
        }
        m.fields("SUPG nodes", &layout.nodes);
        m.fields("stress point functions", &layout.shapes);
        m.fields("stress point terms", &layout.terms);
        m.words(
            "stress point rows",
            (sizes.points + 1 + sizes.point_pairs) as f64,
        );
        m.words(
            "SUPG gather lists",
            (sizes.n + 1 + 3 * sizes.point_pairs) as f64,
        );
    }

    /// The stress points of the scene set up in `cpu` on the device, laid out as
    /// `layout`; None for the other stabilisations.
    pub(super) fn upload<D: GpuDim>(
        gpu: &Gpu,
        cpu: &MixedSph<D>,
        layout: &MixedLayout,
    ) -> Result<Option<Self>, GpuError> {
        let Some((_, sp)) = cpu.stress_points() else {
            return Ok(None);
        };
        let csr = &sp.shapes.csr;
        let u = |k: usize| k as u32;
        let points: Vec<u32> = (csr.offsets.iter().map(|&o| u(o)))
            .chain(csr.ids.iter().copied())
            .collect();
        let l = &layout.shapes;
        let mut shapes = l.zeroed();
        l.write_s(&mut shapes, "N", &sp.shapes.n, 0.0);
        l.write_v::<D>(&mut shapes, "G", &sp.shapes.grad);
        l.write_s(&mut shapes, "W", &sp.weight, 0.0);
        let mut offsets = vec![0u32];
        let mut entries = Vec::new();
        for shares in &sp.gather {
            for share in shares {
                let corner = csr.ids[share.pair as usize];
                entries.extend([share.point, share.pair, corner]);
            }
            offsets.push(u(entries.len() / 3));
        }
        offsets.extend(entries);
        for (label, words) in [
            ("SUPG nodes", layout.nodes.len()),
            ("stress point functions", shapes.len()),
            ("stress point terms", layout.terms.len()),
            ("stress point rows", points.len()),
            ("SUPG gather lists", offsets.len()),
        ] {
            gpu.check_size(label, words as u64 * 4)?;
        }
        Ok(Some(Self {
            step: gpu.uniform("SUPG step", &SupgStep { dt: 0.0 }),
            nodes: gpu.zeroed("SUPG nodes", layout.nodes.bytes()),
            points: gpu.storage("stress point rows", &points),
            shapes: gpu.storage("stress point functions", &shapes),
            terms: gpu.zeroed("stress point terms", layout.terms.bytes()),
            gather: gpu.storage("SUPG gather lists", &offsets),
        }))
    }

    /// The buffers by binding name.
    pub(super) fn table(&self) -> [(&'static str, &wgpu::Buffer); 6] {
        [
            ("supg", &self.step),
            ("nodes", &self.nodes),
            ("points", &self.points),
            ("shapes", &self.shapes),
            ("terms", &self.terms),
            ("gather", &self.gather),
        ]
    }
}

crate::gpu::context::wgsl_twin_test!(supg_step_matches_wgsl: SupgStep = "SupgStep" in SUPG.text);
