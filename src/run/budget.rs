//! The resources a run needs, estimated from the case before anything is allocated: the
//! particle count, the neighbour pairs, the memory of each backend and the step count;
//! a run that does not fit the machine, or passes the caps, is refused as a case error
//! naming the key that sets the figure.

use crate::case::{CaseError, Shape, estimate_particles};
#[cfg(feature = "gpu")]
use crate::core::tensor::{D2, D3};
use crate::scene::Scene;
use std::path::Path;

/// Caps on what one run may ask for (`--max-particles`, `--max-steps`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub max_particles: f64,
    pub max_steps: f64,
}

impl Limits {
    /// Ten million particles: 16 GB for TLSPH in 2D (the memory estimate bounds the
    /// heavier methods and 3D further).
    pub const MAX_PARTICLES: f64 = 1e7;
    /// A hundred million steps: the shipped cases take at most 150,000.
    pub const MAX_STEPS: f64 = 1e8;
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_particles: Self::MAX_PARTICLES,
            max_steps: Self::MAX_STEPS,
        }
    }
}

/// Host memory assumed where the operating system does not say (no /proc/meminfo).
pub const ASSUMED_MEMORY: f64 = 8.0 * GIB;

const GIB: f64 = (1u64 << 30) as f64;

/// Bytes per particle and per neighbour pair of a CPU run, [2D, 3D]. Peak resident
/// sizes measured on the CPU (`/usr/bin/time -f %M` over one step): TLSPH 2D 1.1 kB a
/// particle (12 pairs), Upwind-SPH {p, F} 2D 3.1 kB (21 pairs), TLSPH 3D 3.7 kB (73
/// pairs), Upwind-SPH 3D 17.8 kB (73 pairs, the heaviest); the constants bound them all
/// (the last by 20 %). A GPU run's host share is the CPU reference its set-up builds.
const CPU_PARTICLE_BYTES: [f64; 2] = [1500.0, 3000.0];
const CPU_PAIR_BYTES: [f64; 2] = [120.0, 260.0];

/// What a case needs, estimated from its keys alone.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// Particles of every body (the lattice points of its bounding box times the fraction
    /// the shape fills, or the points of a points or mesh file).
    pub bodies: Vec<f64>,
    pub particles: f64,
    /// Neighbour pairs within the kernel support, body by body ([`crate::case::BodySize::pairs`]: from
    /// the lattice's density, or the points a file holds).
    pub pairs: f64,
    /// Cells between the lattice points ([`crate::case::BodySize::cells`]).
    pub cells: f64,
    /// Host memory of a CPU run [bytes].
    pub cpu_bytes: f64,
    /// Device memory of a GPU run [bytes] (its host share is `cpu_bytes`): the total of
    /// [`Self::device`]; 0 for a method without a GPU engine, or without the GPU backend.
    pub device_bytes: f64,
    /// The buffers of the method's GPU engine for these counts, field by field
    /// ([`crate::methods::MethodSpec::device_memory`]).
    #[cfg(feature = "gpu")]
    pub device: Option<crate::gpu::memory::DeviceMemory>,
    /// Steps to the end time: exact for a fixed Δt; for a CFL step from c_p alone (the
    /// velocities only shorten it), then from the engine's first Δt once it is built
    /// ([`crate::run::check`]).
    pub steps: f64,
    /// Whether the step is the CFL step, which follows the state: the count is then that of
    /// the first Δt, and an impact that compresses and speeds the body up takes more.
    pub adaptive: bool,
    /// Lattice points the sampler visits (the bodies' bounding boxes).
    pub visited: f64,
}

/// How many lattice points the sampler may visit per particle allowed: a thin ring
/// fills a small part of its bounding box, and the box is what the sampler walks.
const VISITS_PER_PARTICLE: f64 = 100.0;

impl Estimate {
    /// Estimates the resources of a case without building it.
    pub fn of(case: &Scene) -> Result<Self, CaseError> {
        let sizes = estimate_particles(case)?;
        let bodies: Vec<f64> = sizes.iter().map(|s| s.particles).collect();
        let particles: f64 = bodies.iter().sum();
        let visited: f64 = sizes.iter().map(|s| s.visited).sum();
        let pairs: f64 = sizes.iter().map(|s| s.pairs).sum();
        let cells: f64 = sizes.iter().map(|s| s.cells).sum();
        let k = case.dim() - 2;
        #[cfg(feature = "gpu")]
        let (device, device_bytes) = {
            let sum = |of: fn(&crate::case::BodySize) -> f64| sizes.iter().map(of).sum();
            let counts = crate::gpu::memory::Counts {
                particles,
                pairs,
                cells,
                gauss_pairs: sum(|s| s.gauss_pairs),
                centre_pairs: sum(|s| s.centre_pairs),
                box_pairs: sum(|s| s.box_pairs),
                centre_box_pairs: sum(|s| s.centre_box_pairs),
                ghosts: sum(|s| s.ghosts),
            };
            let device = match case.dimension {
                2 => case.spec.device_memory::<D2>(case, &counts),
                _ => case.spec.device_memory::<D3>(case, &counts),
            };
            let bytes = device
                .as_ref()
                .map_or(0.0, crate::gpu::memory::DeviceMemory::total);
            (device, bytes)
        };
        #[cfg(not(feature = "gpu"))]
        let device_bytes = 0.0;
        Ok(Self {
            particles,
            pairs,
            cells,
            cpu_bytes: particles * CPU_PARTICLE_BYTES[k] + pairs * CPU_PAIR_BYTES[k],
            device_bytes,
            #[cfg(feature = "gpu")]
            device,
            steps: case.run.end_time / first_step(case),
            adaptive: case.method.dt.is_none(),
            bodies,
            visited,
        })
    }

    /// The bytes the host's memory is held to: the CPU run's, and on the `gpu` the
    /// device's share beside them (an integrated GPU or a software adapter shares the
    /// host's memory).
    pub fn host_bytes(&self, gpu: bool) -> f64 {
        match gpu {
            true => self.cpu_bytes + self.device_bytes,
            false => self.cpu_bytes,
        }
    }

    /// One line for `meshless check` and `--explain`, with the device's share on the
    /// `gpu`.
    pub fn describe(&self, gpu: bool) -> String {
        let gpu = match gpu && self.device_bytes > 0.0 {
            true => format!(
                ", on the GPU {} of device memory ({:.0} B/particle) beside the host's",
                size(self.device_bytes),
                self.device_bytes / self.particles.max(1.0),
            ),
            false => String::new(),
        };
        format!(
            "about {:.3e} particles, {:.3e} neighbour pairs, {} of host memory{gpu}, {:.3e} \
             steps{}",
            self.particles,
            self.pairs,
            size(self.cpu_bytes),
            self.steps,
            if self.adaptive {
                " at the first Δt (the CFL step follows the state: an impact takes more)"
            } else {
                ""
            }
        )
    }

    /// The GPU engine's buffers, largest first, an indented line each with its bytes, its
    /// bytes per particle and its share, those under 0.1 % of the total in one line (for
    /// `check` and `--explain` on the GPU); None for a method without a GPU engine.
    #[cfg(feature = "gpu")]
    pub fn device_table(&self) -> Option<String> {
        let mut rows = self.device.as_ref()?.rows().to_vec();
        rows.sort_by(|a, b| b.1.total_cmp(&a.1));
        let small = rows.iter().position(|r| r.1 < 1e-3 * self.device_bytes);
        let rest = small.map(|k| rows.split_off(k)).unwrap_or_default();
        let line = |label: &str, bytes: f64| {
            format!(
                "  {label}: {} ({:.0} B/particle, {:.1} %)\n",
                size(bytes),
                bytes / self.particles.max(1.0),
                100.0 * bytes / self.device_bytes
            )
        };
        let mut table: String = rows
            .iter()
            .map(|&(label, bytes)| line(label, bytes))
            .collect();
        if !rest.is_empty() {
            let bytes = rest.iter().map(|r| r.1).sum();
            table += &line(&format!("{} other buffers", rest.len()), bytes);
        }
        Some(table)
    }
}

/// The first time step: the fixed Δt, or the CFL step α Δx / c_p.
fn first_step(case: &Scene) -> f64 {
    match (case.method.dt, case.method.cfl) {
        (Some(dt), _) => dt,
        (_, Some(cfl)) => cfl * case.spacing / case.step_wave_speed(),
        _ => unreachable!("validation requires dt or cfl"),
    }
}

fn gib(bytes: f64) -> String {
    format!("{:.3} GiB", bytes / GIB)
}

/// The host memory available to a new process [bytes]: MemAvailable of /proc/meminfo,
/// or `None` where it cannot be read.
pub fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// The variable that states the GPU's memory, which wgpu does not report: bytes, or a
/// number with a unit (`80GB`, `141 GB`, `24GiB`, `512MiB`).
pub const DEVICE_MEMORY_ENV: &str = "MESHLESS_DEVICE_MEMORY";

/// The device's memory [bytes] and where it was read: `MESHLESS_DEVICE_MEMORY`, else the
/// largest GPU memory the platform reports ([`platform_device_memory`]), else None (an
/// integrated GPU or a software adapter shares the host's memory, which the host check
/// bounds with the device's share in it).
fn device_memory() -> Result<Option<(f64, String)>, CaseError> {
    let Ok(value) = std::env::var(DEVICE_MEMORY_ENV) else {
        return Ok(platform_device_memory());
    };
    crate::case::parse_bytes(&value)
        .map(|bytes| Some((bytes, format!("{DEVICE_MEMORY_ENV} says"))))
        .ok_or_else(|| CaseError::Environment {
            variable: DEVICE_MEMORY_ENV,
            value,
            message: "give the GPU's memory as bytes or with a unit: B, kB, MB, GB, TB \
                      (powers of 1000) or KiB, MiB, GiB, TiB (powers of 1024), e.g. 80GB"
                .into(),
        })
}

/// The largest GPU memory the platform reports, where it can be read: on Linux, the
/// `mem_info_vram_total` of every card of the amdgpu driver in /sys/class/drm, and
/// `nvidia-smi --query-gpu=memory.total` of NVIDIA's driver (MiB a GPU); wgpu reports
/// none on any back end. The largest, since the best adapter is the one a run opens
/// unless `MESHLESS_ADAPTER` names another.
fn platform_device_memory() -> Option<(f64, String)> {
    let amd = std::fs::read_dir("/sys/class/drm").ok().and_then(|cards| {
        cards
            .filter_map(|card| {
                let path = card.ok()?.path().join("device/mem_info_vram_total");
                std::fs::read_to_string(path)
                    .ok()?
                    .trim()
                    .parse::<f64>()
                    .ok()
            })
            .reduce(f64::max)
            .map(|bytes| (bytes, "the amdgpu driver reports".to_string()))
    });
    let nvidia = || {
        let out = std::process::Command::new("nvidia-smi")
            .args(["--query-gpu=memory.total", "--format=csv,noheader,nounits"])
            .output()
            .ok()
            .filter(|o| o.status.success())?;
        nvidia_memory(&String::from_utf8_lossy(&out.stdout))
            .map(|bytes| (bytes, "nvidia-smi reports".to_string()))
    };
    amd.or_else(nvidia)
}

/// The largest of the memories `nvidia-smi --query-gpu=memory.total
/// --format=csv,noheader,nounits` lists, one GPU a line in MiB [bytes].
fn nvidia_memory(listing: &str) -> Option<f64> {
    listing
        .lines()
        .filter_map(|l| l.trim().parse::<f64>().ok())
        .filter(|m| m.is_finite() && *m > 0.0)
        .map(|mib| mib * 1024.0 * 1024.0)
        .reduce(f64::max)
}

/// Refuses a GPU run whose estimated device share passes the memory
/// `MESHLESS_DEVICE_MEMORY` states, naming the spacing that would fit.
fn check_device(case: &Scene, estimate: &Estimate) -> Result<(), CaseError> {
    let Some((memory, source)) = device_memory()? else {
        return Ok(());
    };
    if estimate.device_bytes <= memory {
        return Ok(());
    }
    // Particles and pairs scale together with the spacing to the power −d.
    let ratio = estimate.device_bytes / memory;
    let fits = estimate.particles / ratio;
    let spacing = case.spacing * ratio.powf(1.0 / case.dim() as f64);
    Err(case.invalid(
        particle_key(case, estimate),
        format!(
            "gives about {:.3e} particles and {:.3e} neighbour pairs, which need about {} \
             of GPU memory, and {source} the device has {}: about {fits:.3e} particles \
             fit, at `spacing` ≥ {spacing:.4e} (now {:e}); or run on the CPU",
            estimate.particles,
            estimate.pairs,
            size(estimate.device_bytes),
            size(memory),
            case.spacing
        ),
    ))
}

/// Bytes in GiB, MiB or KiB, whichever shows them with at least one whole unit.
fn size(bytes: f64) -> String {
    match bytes {
        b if b >= GIB => gib(b),
        b if b >= 1024.0 * 1024.0 => format!("{:.3} MiB", b / (1024.0 * 1024.0)),
        b => format!("{:.3} KiB", b / 1024.0),
    }
}

/// Refuses a case whose estimate passes the particle cap or the machine's available
/// memory on `gpu` or the CPU, the device memory `MESHLESS_DEVICE_MEMORY` states on the
/// GPU, or whose step count passes the step cap; returns the estimate otherwise.
pub fn check(case: &Scene, gpu: bool, limits: &Limits) -> Result<Estimate, CaseError> {
    with_steps(case, fits(case, gpu, limits)?, limits)
}

/// `estimate`, once its step count passes the step cap.
fn with_steps(case: &Scene, estimate: Estimate, limits: &Limits) -> Result<Estimate, CaseError> {
    check_steps(case, estimate.steps, first_step(case), limits)?;
    Ok(estimate)
}

/// [`check`] without the step count: the particle cap and the memory, for a run of a
/// given number of steps (`meshless bench`).
pub fn fits(case: &Scene, gpu: bool, limits: &Limits) -> Result<Estimate, CaseError> {
    check_copies(case, gpu, limits, 1)
}

/// Keeps a tenth of the memory free when [`largest`] sizes a run to it: the pairs per
/// particle grow a little with the size, and the lattice's spacing is rounded.
const HEADROOM: f64 = 0.9;

/// The most particles of `case` (its bodies, finer or coarser) that the particle cap and
/// the memory hold by the estimate, with a tenth kept free: the host's available memory
/// for the host's share (with the device's on the GPU, as [`fits`] counts them), and on
/// the GPU the device's memory, where it is known (`MESHLESS_DEVICE_MEMORY` or the
/// platform), for the device's share. The bytes a particle are those of the
/// case's estimate at its own spacing, taken again at the size they give, since a finer
/// lattice has fewer particles at the surface and so more pairs a particle.
pub fn largest(case: &Scene, gpu: bool, limits: &Limits) -> Result<f64, CaseError> {
    let host = available_memory().unwrap_or(ASSUMED_MEMORY);
    let device = match gpu {
        true => device_memory()?.map(|(bytes, _)| bytes),
        false => None,
    };
    let most = |e: &Estimate| {
        let per = |bytes: f64| bytes / e.particles.max(1.0);
        let on_host = host / per(e.host_bytes(gpu));
        let on_device = device.map_or(f64::INFINITY, |memory| memory / per(e.device_bytes));
        (HEADROOM * on_host.min(on_device)).min(limits.max_particles)
    };
    let own = Estimate::of(case)?;
    let first = most(&own);
    let mut there = case.clone();
    there.case.spacing *= (own.particles / first).powf(1.0 / case.dim() as f64);
    Ok(most(&Estimate::of(&there)?).min(first))
}

/// [`check`] for a rank of a distributed run, one of `on_node` ranks on this machine:
/// each builds the whole run's set-up before it keeps its share, so the machine holds
/// `on_node` of them at once.
pub fn check_rank(case: &Scene, limits: &Limits, on_node: usize) -> Result<Estimate, CaseError> {
    with_steps(
        case,
        check_copies(case, false, limits, on_node.max(1))?,
        limits,
    )
}

/// [`fits`] with `copies` set-ups of the run in memory at once.
fn check_copies(
    case: &Scene,
    gpu: bool,
    limits: &Limits,
    copies: usize,
) -> Result<Estimate, CaseError> {
    let estimate = Estimate::of(case)?;
    let key = particle_key(case, &estimate);
    if estimate.particles > limits.max_particles {
        return Err(case.invalid(
            key,
            format!(
                "gives about {:.3e} particles, above the cap of {:.3e} (--max-particles); \
                 increase `spacing` (now {:e}) or raise the cap with --max-particles",
                estimate.particles, limits.max_particles, case.spacing
            ),
        ));
    }
    if estimate.visited > VISITS_PER_PARTICLE * limits.max_particles {
        return Err(case.invalid(
            key,
            format!(
                "samples the bodies on about {:.3e} lattice points (their bounding boxes), \
                 above {VISITS_PER_PARTICLE} times the cap of {:.3e} particles \
                 (--max-particles); increase `spacing` (now {:e}) or raise the cap",
                estimate.visited, limits.max_particles, case.spacing
            ),
        ));
    }
    if gpu {
        check_device(case, &estimate)?;
    }
    let one = estimate.host_bytes(gpu);
    let backend = match gpu {
        true => "the GPU backend (host and device)".to_string(),
        false => "the CPU backend".to_string(),
    };
    let (needed, backend) = match copies {
        1 => (one, backend),
        n => (
            one * n as f64,
            format!(
                "{backend} for {n} ranks on this machine (each builds the whole run's \
                 set-up; run fewer ranks a machine)"
            ),
        ),
    };
    let (available, source) = match available_memory() {
        Some(bytes) => (bytes, "available (MemAvailable of /proc/meminfo)"),
        None => (
            ASSUMED_MEMORY,
            "assumed available (this system does not report it)",
        ),
    };
    if needed > available {
        let fix = if key == "spacing" {
            format!("increase `spacing` (now {:e})", case.spacing)
        } else {
            format!(
                "the kernel's support, h_over_dx × spacing, holds about {:.0} neighbours a \
                 point of this file: give `spacing` (now {:e}) the file's point spacing, or \
                 use fewer points",
                estimate.pairs / estimate.particles,
                case.spacing
            )
        };
        return Err(case.invalid(
            key,
            format!(
                "gives about {:.3e} particles and {:.3e} neighbour pairs, which need about \
                 {} on {backend}; the machine has {} {source}; {fix}",
                estimate.particles,
                estimate.pairs,
                gib(needed),
                gib(available),
            ),
        ));
    }
    check_steps(case, estimate.steps, first_step(case), limits)?;
    Ok(estimate)
}

/// Refuses a run of `steps` steps of `dt` (the first Δt) past the step cap, naming the
/// time step's key when the step is far below the CFL step α = 1 would give (1e-3 of
/// it), and `run.end_time` otherwise.
pub fn check_steps(case: &Scene, steps: f64, dt: f64, limits: &Limits) -> Result<(), CaseError> {
    if steps <= limits.max_steps {
        return Ok(());
    }
    let c_p = case.step_wave_speed();
    let tiny = dt < 1e-3 * case.spacing / c_p;
    let key = match (tiny, case.method.dt.is_some()) {
        (false, _) => "run.end_time",
        (true, true) => "method.dt",
        (true, false) => "method.cfl",
    };
    Err(case.invalid(
        key,
        format!(
            "run.end_time = {:e} s in steps of Δt = {dt:e} s is about {steps:.3e} steps, \
             above the cap of {:.3e} (--max-steps); shorten run.end_time, lengthen the step \
             (method.dt or method.cfl), or raise the cap with --max-steps",
            case.run.end_time, limits.max_steps
        ),
    ))
}

/// The share of the output folder's free space past which the frames still to come draw
/// a warning: past half, the run may leave too little room for anything else.
pub const ROOM_WARNING: f64 = 0.5;

/// Refuses the frames of case file `file` that will not fit: `bytes` of them still to
/// come into the output folder `dir` with `free` bytes free. Ok(Some(warning)) past
/// [`ROOM_WARNING`] of it.
pub fn check_room(
    file: &Path,
    bytes: u64,
    free: u64,
    dir: &Path,
) -> Result<Option<String>, CaseError> {
    let gib = |b: u64| b as f64 / f64::from(1u32 << 30);
    let what = format!(
        "the frames still to come take about {:.3} GiB, and {} has {:.3} GiB free",
        gib(bytes),
        dir.display(),
        gib(free)
    );
    let advice = "raise output.frame_interval, shorten run.end_time, or write into another \
                  folder (--out)";
    if bytes > free {
        return Err(CaseError::Invalid {
            file: file.to_path_buf(),
            key: "output.frame_interval".into(),
            message: format!("{what}; they will not fit: {advice}"),
        });
    }
    Ok((bytes as f64 > ROOM_WARNING * free as f64).then(|| {
        format!(
            "{what}: more than {:.0} % of it; {advice}",
            100.0 * ROOM_WARNING
        )
    }))
}

/// The key that sets the particle count: the points file of the largest body when it
/// is one, `spacing` otherwise.
fn particle_key(case: &Scene, estimate: &Estimate) -> String {
    let largest = (0..estimate.bodies.len())
        .max_by(|&a, &b| estimate.bodies[a].total_cmp(&estimate.bodies[b]));
    match largest {
        Some(b)
            if matches!(
                case.bodies[b].geometry,
                Shape::Points { .. } | Shape::Mesh { .. }
            ) =>
        {
            format!("body.{b}.geometry.file")
        }
        _ => "spacing".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::case::polygon::{L_SHAPE, polygon};
    use crate::case::{Lattice, discretise};
    use crate::core::tensor::{D2, D3};
    use crate::scene::validate::minimal_case;

    #[test]
    fn nvidia_smi_lists_mib_a_gpu_and_the_largest_is_taken() {
        // Two GPUs of 81,559 and 143,771 MiB (an H100 and an H200); blank and odd lines
        // are skipped; nothing readable is None.
        let listing = "81559\n143771\n\n[N/A]\n";
        assert_eq!(nvidia_memory(listing), Some(143_771.0 * 1024.0 * 1024.0));
        assert_eq!(nvidia_memory("[N/A]\n"), None);
        assert_eq!(nvidia_memory(""), None);
    }

    #[test]
    fn the_estimate_counts_a_box_exactly_and_a_disk_within_a_few_percent() {
        // The box lattice count is the sampler's own formula: equal. A disk of 20 Δx
        // radius has π r² / Δx² ≈ 1257 points to within its boundary layer, O(2πr/Δx) =
        // 126 points, so within 10 %.
        let mut c = minimal_case();
        let exact = discretise::<D2>(&c).unwrap().x0.len() as f64;
        assert_eq!(Estimate::of(&c).unwrap().particles, exact);
        c.bodies[0].geometry = Shape::Disk {
            center: vec![0.0, 0.0],
            radius: 2.0,
            volumes: None,
        };
        let n = discretise::<D2>(&c).unwrap().x0.len() as f64;
        let e = Estimate::of(&c).unwrap().particles;
        assert!((e / n - 1.0).abs() < 0.1, "{e} against {n}");
        // An L-shape, three quarters of its 2 m square: 21² × 3/4 = 330.75 against the
        // 21 × 11 + 11 × 10 = 341 points it keeps (its edges' included), within 10 %.
        c.bodies[0].geometry = Shape::Polygon {
            vertices: polygon(&L_SHAPE),
            volumes: None,
        };
        let n = discretise::<D2>(&c).unwrap().x0.len() as f64;
        let e = Estimate::of(&c).unwrap().particles;
        assert!((e / n - 1.0).abs() < 0.1, "{e} against {n}");
        c.dimension = 3;
        c.bodies[0].geometry = Shape::Cylinder {
            base: vec![0.0, 0.0, 0.0],
            axis: crate::case::Axis::Y,
            radius: 1.0,
            inner_radius: 0.5,
            length: 1.0,
            lattice: Lattice::Vertex,
            volumes: None,
        };
        let n = discretise::<D3>(&c).unwrap().x0.len() as f64;
        let e = Estimate::of(&c).unwrap().particles;
        assert!((e / n - 1.0).abs() < 0.2, "{e} against {n}");
    }

    /// A points file denser than `spacing`: the pairs come from the points it holds, to
    /// within 10 % of the exact count (counted here pair by pair), where the lattice's
    /// density would give 100 times too few; and a file far denser than its spacing is
    /// refused for its memory, naming the file.
    #[test]
    fn the_pairs_of_a_points_file_come_from_its_points() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("dense.csv");
        // A 1 m square at 0.01 m, 10,201 points, under a case whose spacing is 0.1 m.
        let grid: Vec<[f64; 2]> = (0..=100)
            .flat_map(|i| (0..=100).map(move |j| [0.01 * i as f64, 0.01 * j as f64]))
            .collect();
        let rows: String = grid
            .iter()
            .map(|p| format!("{},{}\n", p[0], p[1]))
            .collect();
        std::fs::write(&file, format!("x,y\n{rows}")).unwrap();
        let mut c = minimal_case();
        c.file = dir.path().join("case.toml");
        c.spacing = 0.1;
        c.bodies[0].geometry = Shape::Points {
            file: "dense.csv".into(),
        };
        let radius = c.method.kernel.support_factor() * c.method.h_over_dx * c.spacing;
        let exact = grid
            .iter()
            .map(|a| {
                let near = |b: &&[f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < radius;
                grid.iter().filter(near).count() as f64 - 1.0
            })
            .sum::<f64>();
        let e = Estimate::of(&c).unwrap();
        assert_eq!(e.particles, grid.len() as f64);
        assert!(
            (e.pairs / exact - 1.0).abs() < 0.1,
            "{} against {exact}",
            e.pairs
        );
        // 40,401 points at 0.005 m under a spacing of 1 m: some 3e5 neighbours a point,
        // 68 GiB of pairs by the estimate, more than any machine this runs on.
        let rows: String = (0..=200)
            .flat_map(|i| {
                (0..=200).map(move |j| format!("{},{}\n", 0.005 * i as f64, 0.005 * j as f64))
            })
            .collect();
        std::fs::write(&file, format!("x,y\n{rows}")).unwrap();
        c.spacing = 1.0;
        let lifted = Limits {
            max_particles: f64::INFINITY,
            ..Limits::default()
        };
        let e = check(&c, false, &lifted).unwrap_err().to_string();
        assert!(
            e.contains("body.0.geometry.file") && e.contains("the file's point spacing"),
            "{e}"
        );
    }

    #[test]
    fn a_tiny_spacing_is_refused_not_wrapped() {
        // 1e-300 gives (1/1e-300)² = ∞ particles: refused by the cap, naming `spacing`.
        let mut c = minimal_case();
        c.spacing = 1e-300;
        let e = check(&c, false, &Limits::default()).unwrap_err();
        let CaseError::Invalid { key, message, .. } = e else {
            panic!("{e}")
        };
        assert_eq!(key, "spacing");
        assert!(message.contains("--max-particles"), "{message}");
        // The sampler refuses it too, whoever calls it.
        assert!(discretise::<D2>(&c).is_err());
    }

    #[test]
    fn memory_beyond_the_machine_is_refused_with_the_estimate() {
        // 1e-6 on a 1 m² box: 1e12 particles. Above the cap; with the cap lifted, above
        // any machine's memory (1e12 × 1.5 kB = 1.5 PB).
        let mut c = minimal_case();
        c.spacing = 1e-6;
        let lifted = Limits {
            max_particles: f64::INFINITY,
            ..Limits::default()
        };
        let e = check(&c, false, &lifted).unwrap_err().to_string();
        assert!(
            e.contains("key `spacing`") && e.contains("GiB") && e.contains("available"),
            "{e}"
        );
    }

    #[test]
    fn step_counts_past_the_cap_name_the_key_at_fault() {
        let limits = Limits::default();
        let key = |c: &Scene| match check(c, false, &limits) {
            Err(CaseError::Invalid { key, .. }) => key,
            other => panic!("{other:?}"),
        };
        let mut c = minimal_case();
        c.method.dt = Some(1e-300);
        assert_eq!(key(&c), "method.dt");
        c.method.dt = Some(1e-5);
        c.run.end_time = 1e300;
        assert_eq!(key(&c), "run.end_time");
        c.run.end_time = 1e-3;
        c.method.dt = None;
        c.method.cfl = Some(1e-12);
        assert_eq!(key(&c), "method.cfl");
        c.method.cfl = Some(0.3);
        check(&c, false, &limits).unwrap();
    }

    #[test]
    fn frames_past_the_free_space_are_refused_and_past_half_of_it_warned() {
        // At ROOM_WARNING = 1/2: 40 of 100 bytes pass quietly, 60 warn, 101 are refused
        // with the key that sets the frame count.
        let (file, dir) = (Path::new("case.toml"), Path::new("out"));
        assert_eq!(check_room(file, 40, 100, dir).unwrap(), None);
        let warning = check_room(file, 60, 100, dir).unwrap().unwrap();
        assert!(warning.contains("50 %") && warning.contains("output.frame_interval"));
        let refusal = check_room(file, 101, 100, dir).unwrap_err().to_string();
        assert!(
            refusal.contains("output.frame_interval") && refusal.contains("case.toml"),
            "{refusal}"
        );
    }
}
