//! The pass report: per compute pass, the time its dispatches took on the device
//! (timestamp queries, where the adapter has them), the bytes it moves by the model
//! written above its entry point in the WGSL ([`super::bytes`]), the achieved bandwidth,
//! and its fraction of the adapter's own copy bandwidth, measured once with
//! `shaders/common/copy.wgsl`.
//!
//! Profiling is off unless asked for ([`Gpu::profile`]): a dispatch then writes a
//! timestamp before and after itself, and the timestamps are resolved and read back only
//! when the host waits for the queue anyway (a readback, the end of a batch), never once
//! per step.

use super::bytes::Cost;
use super::context::{Gpu, Pipeline};
use super::shaders::{COPY, Constants, compose};
use crate::diagnostics::passes::{PassReport, PassRow};
use std::time::Instant;

/// Timestamps a query set holds (wgpu's maximum).
const QUERIES: u32 = wgpu::QUERY_SET_MAX_QUERIES;

/// A pass's totals so far.
struct Totals {
    label: String,
    cost: Option<Cost>,
    dispatches: u64,
    items: u64,
    /// The lists its dispatches covered: 1 a dispatch over whole lists, the share of the
    /// pairs a dispatch over a part covers (`gpu::parts`).
    lists: f64,
    /// Indirect dispatches (a neighbour build that runs only when due).
    indirect: bool,
    nanos: f64,
}

/// The recording side of the pass report, held by a [`Gpu`] while profiling.
pub(crate) struct Profiler {
    timestamps: bool,
    sets: Vec<wgpu::QuerySet>,
    /// Queries written since the last resolve.
    used: u32,
    /// The pass (index into `passes`) of each timed dispatch since the last resolve, in
    /// recording order: its timestamps are queries 2k and 2k + 1.
    pending: Vec<usize>,
    passes: Vec<Totals>,
}

impl Profiler {
    pub(crate) fn new(timestamps: bool) -> Self {
        Self {
            timestamps,
            sets: Vec::new(),
            used: 0,
            pending: Vec::new(),
            passes: Vec::new(),
        }
    }

    /// Records one dispatch of `pipeline` over `items` items and the `share` of the lists'
    /// pairs, `encode` encoding it in `pass`, with a timestamp before and after where the
    /// adapter has them.
    pub(crate) fn dispatch(
        &mut self,
        device: &wgpu::Device,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        (items, share): (u64, f64),
        indirect: bool,
        encode: impl FnOnce(&mut wgpu::ComputePass<'_>),
    ) {
        let index = match self.passes.iter().position(|p| p.label == pipeline.pass) {
            Some(k) => k,
            None => {
                self.passes.push(Totals {
                    label: pipeline.pass.clone(),
                    cost: pipeline.cost,
                    dispatches: 0,
                    items: 0,
                    lists: 0.0,
                    indirect,
                    nanos: 0.0,
                });
                self.passes.len() - 1
            }
        };
        let totals = &mut self.passes[index];
        totals.dispatches += 1;
        totals.items += items;
        totals.lists += share;
        if !self.timestamps {
            encode(pass);
            return;
        }
        let (set, query) = (self.used / QUERIES, self.used % QUERIES);
        if set as usize == self.sets.len() {
            self.sets
                .push(device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("pass timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: QUERIES,
                }));
        }
        let set = &self.sets[set as usize];
        pass.write_timestamp(set, query);
        encode(pass);
        pass.write_timestamp(set, query + 1);
        self.used += 2;
        self.pending.push(index);
    }

    /// Reads the pending timestamps back (after the work that writes them was submitted)
    /// and adds each dispatch's time to its pass.
    pub(crate) fn resolve(&mut self, gpu: &Gpu) {
        if self.used == 0 {
            return;
        }
        let bytes = u64::from(self.used) * 8;
        let resolved = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("resolved timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps readback"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        for (k, set) in self.sets.iter().enumerate() {
            let first = k as u32 * QUERIES;
            if first >= self.used {
                break;
            }
            let count = (self.used - first).min(QUERIES);
            // Each set's slice starts at a multiple of QUERIES · 8 bytes, a multiple of
            // QUERY_RESOLVE_BUFFER_ALIGNMENT.
            encoder.resolve_query_set(set, 0..count, &resolved, u64::from(first) * 8);
        }
        encoder.copy_buffer_to_buffer(&resolved, 0, &staging, 0, bytes);
        gpu.queue.submit([encoder.finish()]);
        let slice = staging.slice(..);
        slice.map_async(wgpu::MapMode::Read, |r| r.expect("mapping the timestamps"));
        gpu.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("waiting for the GPU queue");
        let ticks: Vec<u64> = bytemuck::cast_slice(
            &slice
                .get_mapped_range()
                .expect("mapped range of the timestamps"),
        )
        .to_vec();
        staging.unmap();
        let period = f64::from(gpu.queue.get_timestamp_period());
        for (pass, t) in self.pending.drain(..).zip(ticks.chunks_exact(2)) {
            // A pair written across a counter reset would read as negative: not counted.
            if t[1] >= t[0] {
                self.passes[pass].nanos += (t[1] - t[0]) as f64 * period;
            }
        }
        self.used = 0;
    }
}

/// The runs of an engine's indirect passes, which the device skips when they are not due
/// (the neighbour builds of a list rebuilt on drift, the pseudo steps of a converged
/// corrector), against the runs recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IndirectRuns {
    pub ran: u64,
    pub recorded: u64,
}

impl std::ops::Sub for IndirectRuns {
    type Output = Self;
    fn sub(self, before: Self) -> Self {
        Self {
            ran: self.ran.saturating_sub(before.ran),
            recorded: self.recorded.saturating_sub(before.recorded),
        }
    }
}

/// What scales a step's bytes: the neighbour pairs of the engine's lists (a pass over a
/// part of them moves the part's share, `gpu::parts`), and, for an engine with indirect
/// passes, their runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Scale {
    pub pairs: u64,
    pub indirect: Option<IndirectRuns>,
}

/// Bytes a copy-bandwidth measurement copies (at most; the device's binding limit may cut
/// it): 64 MiB, far above any cache.
const COPY_BYTES: u64 = 64 << 20;

impl Gpu {
    /// Starts profiling (measuring the copy bandwidth first, once per device) or stops it,
    /// dropping what was recorded.
    pub fn profile(&self, on: bool) {
        if on && self.copy_bandwidth().is_none() {
            let measured = self.measure_copy_bandwidth();
            *self.copy.lock().expect("copy bandwidth lock") = Some(measured);
        }
        *self.profiler.lock().expect("profiler lock") =
            on.then(|| Profiler::new(self.timestamps()));
    }

    /// Whether the device writes timestamps inside compute passes.
    pub fn timestamps(&self) -> bool {
        self.device.features().contains(
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES,
        )
    }

    /// The copy bandwidth measured by [`Gpu::profile`], bytes read plus written per second.
    pub fn copy_bandwidth(&self) -> Option<f64> {
        *self.copy.lock().expect("copy bandwidth lock")
    }

    /// The best of five copies of a large buffer by `copy.wgsl` (after one to warm up):
    /// timed by timestamps where the adapter has them, else by the wall clock around a
    /// submission and its wait.
    fn measure_copy_bandwidth(&self) -> f64 {
        let bytes = COPY_BYTES.min(self.binding_limit()) / 16 * 16;
        let text = compose::<crate::core::tensor::D2>(&COPY, &Constants::default());
        let pipeline = self
            .pipeline("copy", &text, "copy")
            .expect("copy.wgsl compiles (validated by the shader tests)");
        let (src, dst) = (
            self.scratch("copy src", bytes),
            self.scratch("copy dst", bytes),
        );
        let bind = self
            .bind(&pipeline, &[("src", &src), ("dst", &dst)])
            .expect("copy.wgsl binds src and dst");
        let items = (bytes / 16) as u32;
        let mut profiler = Profiler::new(self.timestamps());
        let mut best = 0.0f64;
        for round in 0..6 {
            let mut encoder = self.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipeline.raw);
                pass.set_bind_group(0, &bind, &[]);
                let (x, y) = self.groups(items);
                profiler.dispatch(
                    &self.device,
                    &mut pass,
                    &pipeline,
                    (u64::from(items), 1.0),
                    false,
                    |pass| pass.dispatch_workgroups(x, y, 1),
                );
            }
            let started = Instant::now();
            self.queue.submit([encoder.finish()]);
            self.device
                .poll(wgpu::PollType::wait_indefinitely())
                .expect("waiting for the GPU queue");
            let wall = started.elapsed().as_secs_f64();
            let before = profiler.passes[0].nanos;
            profiler.resolve(self);
            let timed = (profiler.passes[0].nanos - before) * 1e-9;
            let seconds = if self.timestamps() && timed > 0.0 {
                timed
            } else {
                wall
            };
            if round > 0 {
                best = best.max(2.0 * bytes as f64 / seconds);
            }
        }
        best
    }

    /// Resolves the timestamps written so far, when profiling (the queue is idle).
    pub(crate) fn resolve_profile(&self) {
        if let Some(profiler) = self.profiler.lock().expect("profiler lock").as_mut() {
            profiler.resolve(self);
        }
    }

    /// The pass report of what was recorded since [`Gpu::profile`] started it: `steps`
    /// steps in `wall_seconds`, bytes scaled by `scale`.
    pub fn pass_report(&self, scale: Scale, steps: u32, wall_seconds: f64) -> PassReport {
        let mut guard = self.profiler.lock().expect("profiler lock");
        let Some(profiler) = guard.as_mut() else {
            return PassReport::default();
        };
        profiler.resolve(self);
        let timed = profiler.timestamps;
        let rows = profiler
            .passes
            .iter()
            .map(|p| {
                // An indirect pass moves its bytes only in the runs that were due.
                let runs = match (p.indirect, scale.indirect) {
                    (true, Some(b)) => p.dispatches * b.ran / b.recorded.max(1),
                    _ => p.dispatches,
                };
                // The items of the dispatches, and the pairs of the lists they covered (a
                // pass dispatched a part covers each part's share), scaled to the runs.
                let bytes = p.cost.map(|c| {
                    let share = p.lists / p.dispatches.max(1) as f64;
                    c.item * p.items * runs / p.dispatches.max(1)
                        + (c.pair as f64 * scale.pairs as f64 * share * runs as f64).round() as u64
                });
                PassRow {
                    pass: p.label.clone(),
                    dispatches: p.dispatches,
                    runs,
                    seconds: timed.then_some(p.nanos * 1e-9),
                    bytes,
                }
            })
            .collect();
        PassReport {
            adapter: self.name(),
            particles: 0,
            steps,
            wall_seconds,
            copy_bandwidth: self.copy_bandwidth().unwrap_or(f64::NAN),
            rows,
            note: (!timed).then(|| {
                format!(
                    "adapter {} has no timestamp queries inside compute passes (wgpu features \
                     TIMESTAMP_QUERY and TIMESTAMP_QUERY_INSIDE_PASSES): the report shows \
                     the bytes of each pass, not its time; run on an adapter that has them \
                     (`meshless info` lists each adapter's features) for the times",
                    self.name()
                )
            }),
        }
    }
}
