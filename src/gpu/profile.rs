//! The pass report: per compute pass, the time its dispatches took on the device
//! (timestamp queries, where the adapter has them), the bytes it moves by a model declared
//! beside its WGSL ([`PassBytes`], in each pass file's [`Source`](super::shaders::Source):
//! the elements each binding moves per item and per pair; whether the entry point reads
//! or writes the binding, and the bytes of its element, come from naga's reflection of
//! the WGSL, [`super::context::Reflection`]), the achieved bandwidth, and its fraction of
//! the adapter's own copy bandwidth, measured once with `shaders/common/copy.wgsl`.
//!
//! Profiling is off unless asked for ([`Gpu::profile`]): a dispatch then writes a
//! timestamp before and after itself, and the timestamps are resolved and read back only
//! when the host waits for the queue anyway (a readback, the end of a batch), never once
//! per step.
//!
//! The model counts the compulsory traffic of a pass: every field of a particle it reads
//! or writes, once per item (an invocation: a particle, a ghost, a cell, a flat state
//! entry), whether the item's own or a neighbour's (a gather reads a neighbour's fields
//! from the cache after the first time), and every field indexed by a neighbour pair
//! (ids, gradients, offsets X_j − X_i) once per pair. Loads and stores of one field count
//! once each, a read-modify-write twice.

use super::context::{Gpu, Pipeline};
use super::shaders::{COPY, Constants, compose};
use crate::passes::{PassReport, PassRow};
use std::time::Instant;

/// Elements of a binding's array for one item or pair: scalars, DIM-vectors, DIM×DIM
/// tensors and slopes (a tensor and its DIM derivatives, (DIM + 1)·DIM² elements: the
/// mixed methods' least-squares slopes of v and P) and moduli (a fourth-order tensor such
/// as ∂P/∂F, DIM⁴ elements). An element's bytes are the array's element type's, from the
/// WGSL ([`BindingUse`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Words {
    pub scalars: u32,
    pub vectors: u32,
    pub tensors: u32,
    pub slopes: u32,
    pub moduli: u32,
}

impl Words {
    /// The elements of these words in dimension `dim`.
    pub const fn elements(self, dim: u32) -> u64 {
        let d2 = dim * dim;
        (self.scalars
            + self.vectors * dim
            + self.tensors * d2
            + self.slopes * (dim + 1) * d2
            + self.moduli * d2 * d2) as u64
    }
}

/// How a pass uses a binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    Read,
    Write,
    /// Read and written (a read-modify-write, or an atomic).
    ReadWrite,
}

impl Access {
    pub const fn reads(self) -> bool {
        matches!(self, Self::Read | Self::ReadWrite)
    }

    pub const fn writes(self) -> bool {
        matches!(self, Self::Write | Self::ReadWrite)
    }
}

/// How an entry point uses a storage binding, by naga's reflection of its WGSL: the
/// access, and the bytes of an element of its array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BindingUse {
    pub access: Access,
    pub element_bytes: u32,
}

/// The directions of a binding a [`Traffic`] counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Every direction the entry point uses it in (a read-modify-write twice).
    Used,
    /// Its loads alone, of a binding the entry point reads and writes in other amounts.
    Loads,
    /// Its stores alone, likewise.
    Stores,
}

/// One storage binding's traffic in a pass: elements per item and per neighbour pair,
/// counted once per direction of `part`, in the scene variants where every condition of
/// `when` holds (`"AV"`: the scene constant AV is 1; `"STAB == STAB_UPWIND"`: two
/// constants, or a constant and a number, are equal). Whether the binding is read or
/// written, and its element type, are the WGSL's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Traffic {
    pub binding: &'static str,
    pub part: Part,
    pub item: Words,
    pub pair: Words,
    pub when: &'static [&'static str],
}

impl Traffic {
    /// Only in the scene variants where the conditions hold.
    pub const fn when(self, when: &'static [&'static str]) -> Self {
        Self { when, ..self }
    }

    /// And `moduli` fourth-order tensors per item.
    pub const fn moduli(self, moduli: u32) -> Self {
        Self {
            item: Words {
                moduli,
                ..self.item
            },
            ..self
        }
    }

    /// And `slopes` slope blocks per item.
    pub const fn slopes(self, slopes: u32) -> Self {
        Self {
            item: Words {
                slopes,
                ..self.item
            },
            ..self
        }
    }

    /// The directions counted of a binding the entry point uses as `used`; Err: the
    /// entry point does not use it so.
    fn times(&self, entry: &str, used: Option<Access>) -> Result<u64, String> {
        let binding = self.binding;
        let used = used.ok_or_else(|| {
            format!(
                "the bytes model of `{entry}` counts `{binding}`, a binding the entry point \
                 does not use"
            )
        })?;
        let (reads, writes) = match self.part {
            Part::Used => (used.reads(), used.writes()),
            Part::Loads => (true, false),
            Part::Stores => (false, true),
        };
        if (reads && !used.reads()) || (writes && !used.writes()) {
            return Err(format!(
                "the bytes model of `{entry}` counts the {} of `{binding}`, which the entry \
                 point does not make",
                if reads { "loads" } else { "stores" }
            ));
        }
        Ok(u64::from(reads) + u64::from(writes))
    }
}

const fn words(w: [u32; 3]) -> Words {
    Words {
        scalars: w[0],
        vectors: w[1],
        tensors: w[2],
        slopes: 0,
        moduli: 0,
    }
}

/// `binding`'s `[scalars, vectors, tensors]` per item and per pair, in every direction
/// the entry point uses it.
pub const fn count(binding: &'static str, item: [u32; 3], pair: [u32; 3]) -> Traffic {
    Traffic {
        binding,
        part: Part::Used,
        item: words(item),
        pair: words(pair),
        when: &[],
    }
}

/// `binding`'s loads, of a binding also stored in other amounts.
pub const fn loads(binding: &'static str, item: [u32; 3], pair: [u32; 3]) -> Traffic {
    Traffic {
        part: Part::Loads,
        ..count(binding, item, pair)
    }
}

/// `binding`'s stores, of a binding also loaded in other amounts.
pub const fn stores(binding: &'static str, item: [u32; 3], pair: [u32; 3]) -> Traffic {
    Traffic {
        part: Part::Stores,
        ..count(binding, item, pair)
    }
}

/// No words.
pub const NONE: [u32; 3] = [0, 0, 0];

/// The rows of `first`, then those of `then`: a shared part of a pass's table (a core's)
/// and its own. N is A + B (checked when the constant is evaluated).
pub const fn joined<const A: usize, const B: usize, const N: usize>(
    first: [Traffic; A],
    then: [Traffic; B],
) -> [Traffic; N] {
    assert!(A + B == N, "a joined table has the rows of both");
    let mut rows = [count("", NONE, NONE); N];
    let mut k = 0;
    while k < N {
        rows[k] = if k < A { first[k] } else { then[k - A] };
        k += 1;
    }
    rows
}

/// The bytes model of one entry point of a pass file: its storage bindings' traffic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassBytes {
    pub entry: &'static str,
    pub traffic: &'static [Traffic],
}

/// A pass's model in one compiled variant: bytes per item and per neighbour pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cost {
    pub item: u64,
    pub pair: u64,
}

impl PassBytes {
    /// The bytes per item and per pair in the variant whose scene constants `constant`
    /// gives by name (None: no such constant, or not an integer) and whose entry point
    /// uses each storage binding as `binding` gives by name (None: not at all);
    /// dimension from `DIM`. Err: a condition names no constant, or a count names a
    /// binding, or a direction of one, that the entry point does not use.
    pub fn cost(
        &self,
        constant: impl Fn(&str) -> Option<i64>,
        binding: impl Fn(&str) -> Option<BindingUse>,
    ) -> Result<Cost, String> {
        let dim = constant("DIM").ok_or("the pass has no constant DIM")? as u32;
        let value = |side: &str| -> Result<i64, String> {
            let side = side.trim();
            side.parse::<i64>()
                .ok()
                .or_else(|| constant(side))
                .ok_or_else(|| {
                    format!(
                        "the bytes model of `{}` names `{side}`, not a constant",
                        self.entry
                    )
                })
        };
        let holds = |condition: &str| -> Result<bool, String> {
            match condition.split_once("==") {
                Some((a, b)) => Ok(value(a)? == value(b)?),
                None => match condition.split_once("!=") {
                    Some((a, b)) => Ok(value(a)? != value(b)?),
                    None => Ok(value(condition)? == 1),
                },
            }
        };
        let mut cost = Cost { item: 0, pair: 0 };
        for t in self.traffic {
            let used = binding(t.binding);
            let times = t.times(self.entry, used.map(|u| u.access))?;
            let mut counted = true;
            for condition in t.when {
                counted &= holds(condition)?;
            }
            if counted {
                let bytes = times * u64::from(used.map_or(0, |u| u.element_bytes));
                cost.item += bytes * t.item.elements(dim);
                cost.pair += bytes * t.pair.elements(dim);
            }
        }
        Ok(cost)
    }
}

/// Timestamps a query set holds (wgpu's maximum).
const QUERIES: u32 = wgpu::QUERY_SET_MAX_QUERIES;

/// A pass's totals so far.
struct Totals {
    label: String,
    cost: Option<Cost>,
    dispatches: u64,
    items: u64,
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

    /// Records one dispatch of `pipeline` over `items` items, `encode` encoding it in
    /// `pass`, with a timestamp before and after where the adapter has them.
    pub(crate) fn dispatch(
        &mut self,
        device: &wgpu::Device,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        items: u64,
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
                    indirect,
                    nanos: 0.0,
                });
                self.passes.len() - 1
            }
        };
        let totals = &mut self.passes[index];
        totals.dispatches += 1;
        totals.items += items;
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

/// What scales a step's bytes: the neighbour pairs of the engine's lists and, for an
/// engine with indirect passes, their runs.
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
        let limit = self
            .limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size);
        let bytes = COPY_BYTES.min(limit) / 16 * 16;
        let text = compose::<crate::tensor::D2>(&COPY, &Constants::default());
        let pipeline = self
            .pipeline("copy", &text, "copy")
            .expect("copy.wgsl compiles (validated by the shader tests)");
        let (src, dst) = (
            self.zeroed("copy src", bytes),
            self.zeroed("copy dst", bytes),
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
                    u64::from(items),
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
                let bytes = p.cost.map(|c| {
                    let items = p.items / p.dispatches.max(1);
                    runs * (c.item * items + c.pair * scale.pairs)
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
