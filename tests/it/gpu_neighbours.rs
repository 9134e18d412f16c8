//! GPU neighbour search (cell list + scan + CSR fill) against the CPU reference
//! `meshless::core::neighbour::build`, and the GPU exclusive scan against a host prefix sum.
//!
//! These tests need a GPU adapter (on CPU-only Linux: Mesa's lavapipe, Debian package
//! mesa-vulkan-drivers). Without one they FAIL; they do not skip.

use crate::common::{gpu, lcg, validate_wgsl};
use glam::{DVec2, DVec3};
use meshless::core::neighbour::{self, Csr};
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::layout::flat_v;
use meshless::gpu::neighbour::{self as gpu_neighbour, CellParams, Positions, Room};
use meshless::gpu::shaders::compose;
use meshless::gpu::{Gpu, GpuDim};
use meshless::methods::shaders;

fn gpu_lists<D: GpuDim>(gpu: &Gpu, x: &[D::V], radius: f64) -> Csr {
    let buffer = gpu.storage("positions", &flat_v::<D>(x.iter().copied()));
    let (lo, hi) = meshless::core::neighbour::bounding_box(x.iter().map(|&p| D::to3(p)));
    let at = Positions {
        x: &buffer,
        offset: 0,
        n: x.len() as u32,
        body: None,
    };
    gpu_neighbour::build::<D>(gpu, at, lo, hi, radius)
        .expect("building GPU neighbour lists")
        .lists(gpu)
}

/// GPU lists equal the CPU lists exactly (same offsets, same ids in the same order).
fn assert_same_lists<D: GpuDim>(gpu: &Gpu, x: &[D::V], radius: f64, what: &str) {
    let cpu = neighbour::build::<D>(x, radius);
    let got = gpu_lists::<D>(gpu, x, radius);
    assert_eq!(got.len(), cpu.len(), "{what}: number of particles");
    for (i, p) in x.iter().enumerate() {
        assert_eq!(
            got.neighbours(i),
            cpu.neighbours(i),
            "{what}: neighbours of particle {i} at {p:?} (GPU left, CPU right)"
        );
    }
    assert_eq!(got, cpu, "{what}: CSR offsets/ids");
    assert!(cpu.pair_count() > 0, "{what}: the case should have pairs");
}

/// Marks the points to keep so that no pair's f64 distance lies within 1e-5·radius of the
/// radius; `lists` finds the candidate pairs.
fn near_tie_free<D: Dim>(
    x: &[D::V],
    radius: f64,
    lists: impl Fn(&[D::V], f64) -> Csr,
) -> Vec<bool> {
    let wide = lists(x, radius * (1.0 + 1e-5));
    let mut keep = vec![true; x.len()];
    for i in 0..x.len() {
        if !keep[i] {
            continue;
        }
        for &j in wide.neighbours(i) {
            let j = j as usize;
            if j > i && keep[j] && (D::norm2(x[i] - x[j]).sqrt() - radius).abs() <= 1e-5 * radius {
                keep[j] = false;
            }
        }
    }
    keep
}

/// Drops points so that no pair's f64 distance lies within 1e-5·radius of the radius;
/// `lists` finds the candidate pairs (the CPU cell list, or brute force).
///
/// The GPU compares f32 positions (relative rounding ~6e-8 of a coordinate, a few 1e-7
/// of a distance of the test sizes here), so pairs that close to the radius may classify
/// differently than in f64; a margin of 1e-5 leaves ample room. Removing a point only
/// removes pairs, so the survivors have no near-ties either.
fn drop_near_ties<D: Dim>(
    x: Vec<D::V>,
    radius: f64,
    lists: impl Fn(&[D::V], f64) -> Csr,
) -> Vec<D::V> {
    let keep = near_tie_free::<D>(&x, radius, lists);
    x.into_iter()
        .zip(keep)
        .filter_map(|(p, k)| k.then_some(p))
        .collect()
}

/// All pairs by brute force, as CSR (for clouds the CPU cell list cannot grid).
fn brute_force<D: Dim>(x: &[D::V], radius: f64) -> Csr {
    let mut csr = Csr {
        offsets: vec![0],
        ids: Vec::new(),
    };
    for i in 0..x.len() {
        csr.ids.extend(
            (0..x.len() as u32)
                .filter(|&j| j as usize != i && D::norm2(x[i] - x[j as usize]) <= radius * radius),
        );
        csr.offsets.push(csr.ids.len());
    }
    csr
}

#[test]
fn cell_params_match_the_wgsl_uniform_layout() {
    use std::mem::{offset_of, size_of};
    assert_eq!(size_of::<CellParams>(), 48);
    let all = shaders();
    let source = all
        .iter()
        .find(|s| s.name == "setup/cell_list.wgsl")
        .expect("cell_list.wgsl among the passes");
    let constants = gpu_neighbour::constants(0, false);
    for text in [
        compose::<D2>(source, &constants),
        compose::<D3>(source, &constants),
    ] {
        let module = naga::front::wgsl::parse_str(&text).expect("cell_list.wgsl parses");
        let (span, members) = module
            .types
            .iter()
            .find_map(|(_, ty)| match (&ty.name, &ty.inner) {
                (Some(name), naga::TypeInner::Struct { members, span }) if name == "CellParams" => {
                    Some((*span, members.clone()))
                }
                _ => None,
            })
            .expect("struct CellParams in cell_list.wgsl");
        assert_eq!(span as usize, size_of::<CellParams>());
        let offset = |name: &str| {
            members
                .iter()
                .find(|m| m.name.as_deref() == Some(name))
                .unwrap_or_else(|| panic!("member {name}"))
                .offset as usize
        };
        assert_eq!(offset("origin"), offset_of!(CellParams, origin));
        assert_eq!(offset("inv_cell"), offset_of!(CellParams, inv_cell));
        assert_eq!(offset("dims"), offset_of!(CellParams, dims));
        assert_eq!(offset("n"), offset_of!(CellParams, n));
        assert_eq!(offset("radius2"), offset_of!(CellParams, radius2));
        assert_eq!(offset("ncells"), offset_of!(CellParams, ncells));
    }
}

#[test]
fn neighbour_shaders_validate_with_naga() {
    for name in ["setup/cell_list.wgsl", "setup/scan.wgsl"] {
        let all = shaders();
        let source = all
            .iter()
            .find(|s| s.name == name)
            .expect("shader among the passes");
        for masked in [false, true] {
            let constants = gpu_neighbour::constants(3, masked);
            for text in [
                compose::<D2>(source, &constants),
                compose::<D3>(source, &constants),
            ] {
                validate_wgsl(name, &text);
            }
        }
    }
}

#[test]
fn scan_matches_host_prefix_sum() {
    let gpu = gpu();
    let mut seed = 3;
    // 512 per workgroup: 70_000 needs two levels, 262_145 = 512² + 1 three.
    for n in [1usize, 255, 256, 257, 511, 512, 513, 70_000, 262_145] {
        // Full-range values: the sums wrap, exactly like u32 wrapping_add on the host.
        let data: Vec<u32> = (0..n)
            .map(|_| (lcg(&mut seed) * 4_294_967_296.0) as u32)
            .collect();
        let mut expected = Vec::with_capacity(n);
        let mut sum = 0u32;
        for &v in &data {
            expected.push(sum);
            sum = sum.wrapping_add(v);
        }
        // Entries past n must stay untouched.
        let sentinel = [0xDEAD_BEEF_u32, 7, 1 << 31];
        let mut padded = data.clone();
        padded.extend(sentinel);
        let buffer = gpu.storage("scan data", &padded);
        gpu_neighbour::exclusive_scan(&gpu, &buffer, n as u32).unwrap();
        let got: Vec<u32> = gpu.read(&buffer);
        if let Some(i) = (0..n).find(|&i| got[i] != expected[i]) {
            panic!(
                "scan of {n}: entry {i} is {}, expected {}",
                got[i], expected[i]
            );
        }
        assert_eq!(&got[n..n + 3], &sentinel, "scan of {n} wrote past its end");
    }
}

#[test]
fn random_cloud_2d_matches_cpu() {
    let gpu = gpu();
    let radius = 0.08;
    let mut s = 7;
    let x: Vec<DVec2> = (0..3000)
        .map(|_| DVec2::new(lcg(&mut s) * 3.0, lcg(&mut s)))
        .collect();
    let x = drop_near_ties::<D2>(x, radius, neighbour::build::<D2>);
    assert!(
        x.len() > 2990,
        "too many near-ties dropped: {} left",
        x.len()
    );
    assert_same_lists::<D2>(&gpu, &x, radius, "2D random cloud");
}

#[test]
fn lattice_2d_matches_cpu_including_ties() {
    let gpu = gpu();
    let (nx, ny) = (40, 30);
    // dx = 1: integer coordinates and their differences are exact in f32, so the ties at
    // r = 2 dx (pairs at exactly 2 dx) are included on both sides with the exact radius.
    // r = 1.3·2·dx = 2.6 dx has no lattice distance near it (2.6² = 6.76 vs 6 and 7).
    let unit: Vec<DVec2> = (0..nx * ny)
        .map(|k| DVec2::new((k % nx) as f64, (k / nx) as f64))
        .collect();
    for radius in [2.6, 2.0] {
        assert_same_lists::<D2>(
            &gpu,
            &unit,
            radius,
            &format!("2D lattice dx = 1, r = {radius}"),
        );
    }
    // dx = 0.1 off the origin: k·0.1 is inexact in f64 and more so in f32, so a pair at
    // 2 dx may land on either side of r = 0.2 in either precision. Both sides use
    // r·(1 + 1e-5): coordinates up to 4.9 round by up to 2.4e-7 in f32 (half an ulp), so
    // a 2 dx = 0.2 difference is off by up to 4.8e-7, 2.4e-6 relative: 1e-6 is not a safe
    // margin here. The next lattice distance past 2 dx is √5 dx, far outside the margin.
    let dx = 0.1;
    let scaled: Vec<DVec2> = (0..nx * ny)
        .map(|k| DVec2::new(1.0 + (k % nx) as f64 * dx, 2.0 + (k / nx) as f64 * dx))
        .collect();
    for radius in [1.3 * 2.0 * dx, 2.0 * dx] {
        let r = radius * (1.0 + 1e-5);
        assert_same_lists::<D2>(
            &gpu,
            &scaled,
            r,
            &format!("2D lattice dx = 0.1, r = {radius}(1 + 1e-5)"),
        );
    }
    // Interior count as in seed 000 §1.1: 21 points (self included) within 2.6 dx.
    let lists = gpu_lists::<D2>(&gpu, &unit, 2.6);
    assert_eq!(lists.neighbours(15 * nx + 20).len() + 1, 21);
}

#[test]
fn random_cloud_3d_matches_cpu() {
    let gpu = gpu();
    let radius = 0.2;
    let mut s = 11;
    let x: Vec<DVec3> = (0..2000)
        .map(|_| DVec3::new(lcg(&mut s), lcg(&mut s) * 2.0, lcg(&mut s)))
        .collect();
    let x = drop_near_ties::<D3>(x, radius, neighbour::build::<D3>);
    assert!(
        x.len() > 1990,
        "too many near-ties dropped: {} left",
        x.len()
    );
    assert_same_lists::<D3>(&gpu, &x, radius, "3D random cloud");
}

#[test]
fn lattice_3d_matches_cpu_including_ties() {
    let gpu = gpu();
    let (nx, ny, nz) = (14, 12, 10);
    let at = |k: usize, dx: f64, o: f64| {
        DVec3::new(
            o + (k % nx) as f64 * dx,
            o + (k / nx % ny) as f64 * dx,
            o + (k / (nx * ny)) as f64 * dx,
        )
    };
    // Exact in f32 (see the 2D lattice test).
    let unit: Vec<DVec3> = (0..nx * ny * nz).map(|k| at(k, 1.0, 0.0)).collect();
    for radius in [2.6, 2.0] {
        assert_same_lists::<D3>(
            &gpu,
            &unit,
            radius,
            &format!("3D lattice dx = 1, r = {radius}"),
        );
    }
    // Inexact spacing: the ties need the margin r·(1 + 1e-5) on both sides.
    let dx = 0.05;
    let scaled: Vec<DVec3> = (0..nx * ny * nz).map(|k| at(k, dx, 0.5)).collect();
    for radius in [1.3 * 2.0 * dx, 2.0 * dx] {
        let r = radius * (1.0 + 1e-5);
        assert_same_lists::<D3>(
            &gpu,
            &scaled,
            r,
            &format!("3D lattice dx = 0.05, r = {radius}(1 + 1e-5)"),
        );
    }
}

#[test]
fn sparse_clusters_and_tiny_inputs() {
    let gpu = gpu();
    // Two clusters 1e4 apart with r = 0.05: 2e5 cells per axis at cell = r, so the GPU
    // grid grows its cells (fewer, larger cells); the lists must not change. The CPU
    // cell list would allocate 4e10 cells here, so the reference is brute force.
    let radius = 0.05;
    let mut s = 5;
    let x: Vec<DVec2> = (0..600)
        .map(|k| {
            let o = if k % 2 == 0 { 0.0 } else { 1.0e4 };
            DVec2::new(o + lcg(&mut s) * 0.5, o + lcg(&mut s) * 0.5)
        })
        .collect();
    // Positions near 1e4 round by up to ~5e-4 in f32 (1e-2 of the radius), so all points
    // are snapped to f32 values first; their differences are then exact in f32 (Sterbenz)
    // and the f64 reference sees what the GPU sees. Then near-ties go, by brute force.
    let x: Vec<DVec2> = x
        .into_iter()
        .map(|p| DVec2::new(p.x as f32 as f64, p.y as f32 as f64))
        .collect();
    let x = drop_near_ties::<D2>(x, radius, brute_force::<D2>);
    let expected = brute_force::<D2>(&x, radius);
    assert!(expected.pair_count() > 0);
    assert_eq!(
        gpu_lists::<D2>(&gpu, &x, radius),
        expected,
        "2D sparse clusters"
    );

    // No points, one point, two points within the radius.
    assert_eq!(
        gpu_lists::<D2>(&gpu, &[], 1.0),
        neighbour::build::<D2>(&[], 1.0)
    );
    let one = [DVec3::new(1.0, 2.0, 3.0)];
    assert_eq!(
        gpu_lists::<D3>(&gpu, &one, 1.0),
        neighbour::build::<D3>(&one, 1.0)
    );
    let two = [DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.5, 2.0, 3.0)];
    assert_same_lists::<D3>(&gpu, &two, 1.0, "two points");
}

/// A list built once and recorded again after the particles moved (rotated, stretched,
/// jittered and partly carried out of the grid's box) gives the CPU's lists of the new
/// positions, with and without per-body masks, whole or in parts of 256 rows; a list with
/// too little room reports the most pairs a part needs.
#[test]
fn a_rebuild_on_the_device_follows_moving_particles() {
    let gpu = gpu();
    let radius = 0.08;
    let mut s = 5;
    let reference: Vec<DVec2> = (0..2500)
        .map(|_| DVec2::new(lcg(&mut s) * 2.0, lcg(&mut s)))
        .collect();
    let (c, turn) = (DVec2::new(1.0, 0.5), glam::DMat2::from_angle(0.7));
    let moved: Vec<DVec2> = reference
        .iter()
        .map(|&x| {
            let jitter = DVec2::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5) * 0.02;
            c + turn * ((x - c) * DVec2::new(1.2, 0.9)) + jitter + DVec2::new(0.6, 0.0)
        })
        .collect();
    // Near-ties of either configuration are dropped from both (see drop_near_ties).
    let keep: Vec<bool> = near_tie_free::<D2>(&reference, radius, neighbour::build::<D2>)
        .into_iter()
        .zip(near_tie_free::<D2>(&moved, radius, neighbour::build::<D2>))
        .map(|(a, b)| a && b)
        .collect();
    let kept = |x: &[DVec2]| -> Vec<DVec2> {
        x.iter()
            .zip(&keep)
            .filter_map(|(&p, &k)| k.then_some(p))
            .collect()
    };
    let (reference, moved) = (kept(&reference), kept(&moved));
    assert!(reference.len() > 2480, "{} left", reference.len());
    let n = reference.len() as u32;
    let body: Vec<u32> = reference.iter().map(|x| u32::from(x.x > 1.0)).collect();
    let positions = gpu.storage("positions", &flat_v::<D2>(reference.iter().copied()));
    let bodies = gpu.storage("bodies", &body);
    // The grid covers the reference box only: the moved cloud leaves it by up to 0.6.
    let (lo, hi) = neighbour::bounding_box(reference.iter().map(|&p| D2::to3(p)));
    let grid = CellParams::new(&gpu, 2, lo, hi, n, radius).unwrap();
    // The lists whole, and in parts of 256 rows each with room for 256 × 40 pairs.
    let rooms = [
        Room {
            rows: n,
            pairs: 40 * n,
        },
        Room {
            rows: 256,
            pairs: 40 * 256,
        },
    ];
    for (masked, room) in [false, true]
        .into_iter()
        .flat_map(|m| rooms.map(|r| (m, r)))
    {
        let at = Positions {
            x: &positions,
            offset: 0,
            n,
            body: masked.then_some(&bodies),
        };
        let what = format!("masked {masked}, {room:?}");
        let lists = gpu_neighbour::CellList::new::<D2>(&gpu, at, &grid, room, 0.0).unwrap();
        assert_eq!(lists.parts.len(), n.div_ceil(room.rows) as usize, "{what}");
        let mask = masked.then_some(body.as_slice());
        for x in [&reference, &moved] {
            gpu.queue.write_buffer(
                &positions,
                0,
                bytemuck::cast_slice(&flat_v::<D2>(x.iter().copied())),
            );
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            lists.record(&gpu, &mut encoder);
            gpu.queue.submit([encoder.finish()]);
            let cpu = neighbour::build_within::<D2>(x, neighbour::Reach::Uniform(radius), mask);
            assert!(
                cpu.pair_count() > 20 * x.len(),
                "{} pairs",
                cpu.pair_count()
            );
            assert_eq!(lists.overflow(&gpu), None, "{what}");
            assert_eq!(
                lists.lists(&gpu),
                cpu,
                "{what}: lists of the moved particles"
            );
            assert_eq!(lists.pairs(&gpu), cpu.pair_count() as u64, "{what}");
        }
        // Room for 10 pairs a part: the build reports the most pairs of a part (of the
        // moved particles).
        let small = Room { pairs: 10, ..room };
        let small = gpu_neighbour::CellList::new::<D2>(&gpu, at, &grid, small, 0.0).unwrap();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        small.record(&gpu, &mut encoder);
        gpu.queue.submit([encoder.finish()]);
        let cpu = neighbour::build_within::<D2>(&moved, neighbour::Reach::Uniform(radius), mask);
        let rows = room.rows as usize;
        let fullest = (0..cpu.len().div_ceil(rows))
            .map(|k| cpu.offsets[((k + 1) * rows).min(cpu.len())] - cpu.offsets[k * rows])
            .max();
        assert_eq!(small.overflow(&gpu), fullest.map(|p| p as u32), "{what}");
    }
}
