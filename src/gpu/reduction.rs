//! The GPU reduction of a state (`shaders/common/reduce.wgsl`) and the work balance of supports
//! and loads, shared by the GPU engines: energies, momenta, the power of supports and
//! loads, max |v|, a non-finite count, the largest pair wave speed of the CFL step and
//! the viscous dissipation, per workgroup on the device and summed on the host in f64.
//! Only the partials (13 floats per 256 particles) are read back; and, for the `reaction` observer, the reactions of
//! the constrained particles (`shaders/interaction/boundary.wgsl`), which the host books to the
//! supports.

use super::context::{Gpu, GpuError, Pipeline};
use super::layout::{Field, Fields, Flat};
use super::memory::DeviceMemory;
use super::parts;
use super::shaders::{Source, Wgsl, source};
use crate::boundary::{Boundary, Reaction};
use crate::diagnostics::observe::Invariants;

/// Values per workgroup written by `reduce.wgsl`.
const REDUCED: usize = 13;

/// The reduce pass of a method whose strain energy reads the buffers `reduce.wgsl` reads
/// (the state `y`, `kin` and `reference`), with the function files it calls, the
/// method's energy among them (one that reads more lists its own).
pub const fn pass(common: &'static [Wgsl]) -> Source {
    Source {
        common,
        ..source!(
            "common/reduce.wgsl",
            [],
            [("y", false), ("kin", false), ("reference", false)]
        )
    }
}

/// Buffers by binding name.
type Table<'a> = Vec<(&'a str, &'a wgpu::Buffer)>;

/// The GPU reduction of one state, summed on the host.
#[derive(Clone, Copy, Debug)]
pub struct Reduced {
    pub invariants: Invariants,
    /// Power of supports and loads.
    pub power: f64,
    pub max_speed: f64,
    pub non_finite: bool,
    /// Mixed methods: Δx max_ab C_p,ab / r_ab over the pairs of real particles (seed 002
    /// eqs 31–32, `MixedSph::pair_wave_speed`); 0 for TLSPH.
    pub pair_wave_speed: f64,
    /// The artificial viscosity's dissipation −Σ m a_visc·v at the last rate evaluation
    /// (the method's `viscous_dissipation(i)`; 0 for the methods that do not book it).
    pub viscous_dissipation: f64,
}

/// The reduce pass of an engine and its cached result for the current state.
pub struct Reduction {
    pipeline: Pipeline,
    /// A bind group, its rows and its share of the pairs, a part of the lists.
    parts: Vec<(wgpu::BindGroup, u32, f64)>,
    partials: wgpu::Buffer,
    cached: Option<Reduced>,
}

impl Reduction {
    /// The buffer [`Self::new`] makes for `n` particles: a partial sum per workgroup.
    pub fn memory(memory: &mut DeviceMemory, n: usize) {
        let groups = (n as u64)
            .div_ceil(u64::from(super::context::WORKGROUP))
            .max(1);
        memory.words("partials", (groups * REDUCED as u64) as f64);
    }

    /// `source` is `reduce.wgsl` composed for the method; `inputs` its engine's buffers
    /// by binding name (the state `y`, `kin`, `reference` and those its hooks declare,
    /// none of the lists); the reduction adds its `partials` and the `part` of all `n`
    /// particles.
    pub fn new(
        gpu: &Gpu,
        source: &str,
        inputs: &[(&str, &wgpu::Buffer)],
        n: usize,
    ) -> Result<Self, GpuError> {
        let whole = parts::uniform(gpu, 0, n);
        let table = [inputs, &[("part", &whole)]].concat();
        Self::bind(gpu, source, n, vec![((n, 1.0), table)])
    }

    /// [`Self::new`] a part of the lists of `split` at a time, `tables` holding each
    /// part's buffers, its `part` uniform, `offsets`, `ids` and per-pair data among them.
    /// The parts start at workgroup boundaries ([`parts::Split::fitting`]), so the
    /// partials are the unsplit run's.
    pub fn by_part(
        gpu: &Gpu,
        source: &str,
        split: &parts::Split,
        tables: Vec<Table<'_>>,
    ) -> Result<Self, GpuError> {
        Self::bind(
            gpu,
            source,
            split.rows(),
            split.shares().zip(tables).collect(),
        )
    }

    /// The pass over `n` particles in parts of the given rows, shares of the pairs and
    /// buffers.
    fn bind(
        gpu: &Gpu,
        source: &str,
        n: usize,
        parts: Vec<((usize, f64), Table<'_>)>,
    ) -> Result<Self, GpuError> {
        let pipeline = gpu.pipeline("reduce", source, "reduce")?;
        let (gx, gy) = gpu.groups(n as u32);
        let partials = gpu.zeroed("partials", u64::from(gx * gy) * REDUCED as u64 * 4);
        let parts = (parts.iter())
            .map(|((rows, share), inputs)| {
                let entries = [inputs.as_slice(), &[("partials", &partials)]].concat();
                Ok((gpu.bind(&pipeline, &entries)?, *rows as u32, *share))
            })
            .collect::<Result<_, GpuError>>()?;
        Ok(Self {
            pipeline,
            parts,
            partials,
            cached: None,
        })
    }

    /// Forgets the cached result (the state changed).
    pub fn invalidate(&mut self) {
        self.cached = None;
    }

    /// The reduction of the current state; `before` records the passes it needs first
    /// (into the same compute pass). Cached until [`Reduction::invalidate`].
    pub fn get(&mut self, gpu: &Gpu, before: impl FnOnce(&mut wgpu::ComputePass<'_>)) -> Reduced {
        if let Some(r) = self.cached {
            return r;
        }
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            before(&mut pass);
            for (bind, rows, share) in &self.parts {
                gpu.dispatch_part(&mut pass, &self.pipeline, bind, *rows, *share);
            }
        }
        gpu.queue.submit([encoder.finish()]);
        let partials: Vec<f32> = gpu.read(&self.partials);
        let mut q = [0.0f64; REDUCED];
        for group in partials.chunks_exact(REDUCED) {
            for (k, &v) in group.iter().enumerate() {
                q[k] = if k == 9 || k == 11 {
                    q[k].max(f64::from(v))
                } else {
                    q[k] + f64::from(v)
                };
            }
        }
        let r = Reduced {
            invariants: Invariants {
                kinetic: q[0],
                strain: q[1],
                linear: [q[2], q[3], q[4]],
                angular: [q[5], q[6], q[7]],
            },
            power: q[8],
            max_speed: q[9].sqrt(),
            non_finite: q[10] != 0.0 || !q[..10].iter().all(|x| x.is_finite()),
            pair_wave_speed: q[11],
            viscous_dissipation: q[12],
        };
        self.cached = Some(r);
        r
    }
}

/// Work done on the bodies by supports and loads, and the energy the artificial
/// viscosity dissipated: each trapezoidal over the intervals between the reductions that
/// give its power (the driver reduces at every check).
#[derive(Clone, Copy, Debug, Default)]
pub struct WorkBalance {
    /// Simulated time advanced so far.
    time: f64,
    work: Integral,
    dissipated: Integral,
}

/// ∫ p dt, trapezoidal between updates.
#[derive(Clone, Copy, Debug, Default)]
struct Integral {
    value: f64,
    /// Time and power of the last update (none yet: from zero at t = 0).
    last: Option<(f64, f64)>,
}

impl Integral {
    /// The integral up to `time`, given the power then. A second update at the time of
    /// the last one changes nothing: the power recorded then stands. This is what keeps a
    /// resumed run exact, whose engine, restored from a checkpoint, reduces before its
    /// first rate evaluation a power that is not its state's.
    fn update(&mut self, time: f64, power: f64) -> f64 {
        let (t_last, p_last) = self.last.unwrap_or_default();
        if self.last.is_none() || time != t_last {
            self.value += 0.5 * (p_last + power) * (time - t_last);
            self.last = Some((time, power));
        }
        self.value
    }
}

/// The words of a [`WorkBalance`] in a checkpoint.
pub const WORK_WORDS: usize = 7;

impl WorkBalance {
    pub fn advance(&mut self, dt: f64, steps: u32) {
        self.time += dt * f64::from(steps);
    }

    /// Its numbers, for a checkpoint: the time, then the work and the dissipation, each
    /// with the time and power of its last update.
    pub fn words(&self) -> [f64; WORK_WORDS] {
        let (w, d) = (self.work, self.dissipated);
        let ((tw, pw), (td, pd)) = (w.last.unwrap_or_default(), d.last.unwrap_or_default());
        [self.time, w.value, tw, pw, d.value, td, pd]
    }

    pub fn from_words([time, w, tw, pw, d, td, pd]: [f64; WORK_WORDS]) -> Self {
        Self {
            time,
            work: Integral {
                value: w,
                last: Some((tw, pw)),
            },
            dissipated: Integral {
                value: d,
                last: Some((td, pd)),
            },
        }
    }

    /// The work up to now, given the power of supports and loads at the current state.
    pub fn update(&mut self, power: f64) -> f64 {
        self.work.update(self.time, power)
    }

    /// The viscous dissipation up to now, given its power at the current state.
    pub fn update_dissipation(&mut self, power: f64) -> f64 {
        self.dissipated.update(self.time, power)
    }
}

/// Appends to an engine's `kin` fields the reaction (KRF) and its power per component
/// (KRP) of each of the `constrained` particles, written by `boundary.wgsl`.
pub fn with_reactions(kin: Fields, constrained: usize) -> Fields {
    kin.vectors("RF", true, constrained)
        .vectors("RP", true, constrained)
}

/// The supports' reactions at the last rate evaluation: the fields of
/// [`with_reactions`] read from the engine's `kin` buffer and booked to the supports of
/// `boundary` in f64.
pub fn reactions<D: Flat>(
    gpu: &Gpu,
    kin: &wgpu::Buffer,
    fields: &Fields,
    boundary: &Boundary<D>,
) -> Vec<Reaction> {
    let (rf, rp) = (fields.field("RF"), fields.field("RP"));
    let end = rp.offset + rp.count * rp.width;
    let floats: Vec<f32> = gpu.read_range(kin, 4 * rf.offset as u64, 4 * (end - rf.offset) as u64);
    let vectors = |field: &Field| -> Vec<D::V> {
        floats[field.offset - rf.offset..][..field.count * field.width]
            .chunks_exact(D::N)
            .map(D::read_v)
            .collect()
    };
    boundary.reactions(&vectors(rf), &vectors(rp))
}
