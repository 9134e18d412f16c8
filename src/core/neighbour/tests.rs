use super::*;
use crate::core::tensor::{D2, D3};
use glam::DVec2;

/// Deterministic pseudo-random numbers in [0, 1) (64-bit LCG), so tests need no RNG crate.
fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// n pseudo-random points in the box [0, extent_k], k < D::N, drawn from `seed`.
fn cloud<D: Dim>(n: usize, extent: &[f64], seed: &mut u64) -> Vec<D::V> {
    (0..n)
        .map(|_| D::from_slice(&extent.iter().map(|e| lcg(seed) * e).collect::<Vec<_>>()))
        .collect()
}

fn brute<D: Dim>(x: &[D::V], radius: f64) -> Vec<Vec<u32>> {
    (0..x.len())
        .map(|i| {
            (0..x.len() as u32)
                .filter(|&j| j as usize != i && D::norm2(x[i] - x[j as usize]) <= radius * radius)
                .collect()
        })
        .collect()
}

fn check<D: Dim>(x: &[D::V], radius: f64) {
    let csr = build::<D>(x, radius);
    let reference = brute::<D>(x, radius);
    assert_eq!(csr.len(), x.len());
    for (i, expected) in reference.iter().enumerate() {
        assert_eq!(csr.neighbours(i), expected.as_slice(), "particle {i}");
    }
}

#[test]
fn cell_list_equals_brute_force_2d() {
    let mut s = 7;
    let random = cloud::<D2>(600, &[3.0, 1.0], &mut s);
    check::<D2>(&random, 0.13);
    let lattice: Vec<DVec2> = (0..400)
        .map(|k| DVec2::new((k % 20) as f64 * 0.1, (k / 20) as f64 * 0.1))
        .collect();
    // Radius exactly on lattice distances (2 dx): ties must be included on both sides.
    check::<D2>(&lattice, 0.2);
}

#[test]
fn cell_list_equals_brute_force_3d() {
    let mut s = 11;
    let random = cloud::<D3>(700, &[1.0, 2.0, 1.0], &mut s);
    check::<D3>(&random, 0.21);
}

#[test]
fn per_particle_reach_and_body_masks_equal_brute_force() {
    // Random radii between 0.05 and 0.2 (a pair within the larger of its two radii)
    // and three bodies: the lists are the brute-force ones, and symmetric.
    let mut s = 5;
    let x = cloud::<D2>(500, &[2.0, 1.0], &mut s);
    let radius: Vec<f64> = (0..x.len()).map(|_| 0.05 + 0.15 * lcg(&mut s)).collect();
    let body: Vec<u32> = (0..x.len() as u32).map(|i| i % 3).collect();
    for mask in [None, Some(body.as_slice())] {
        let csr = build_within::<D2>(&x, Reach::PerParticle(&radius), mask);
        for i in 0..x.len() {
            let expected: Vec<u32> = (0..x.len() as u32)
                .filter(|&j| {
                    let j = j as usize;
                    let r = radius[i].max(radius[j]);
                    j != i
                        && mask.is_none_or(|b| b[i] == b[j])
                        && (x[i] - x[j]).length_squared() <= r * r
                })
                .collect();
            assert_eq!(csr.neighbours(i), expected.as_slice(), "particle {i}");
            for &j in csr.neighbours(i) {
                assert!(csr.neighbours(j as usize).contains(&(i as u32)));
            }
        }
    }
    // Equal radii give the uniform search's lists.
    let uniform = vec![0.13; x.len()];
    assert_eq!(
        build_within::<D2>(&x, Reach::PerParticle(&uniform), None),
        build::<D2>(&x, 0.13)
    );
}

#[test]
fn a_rebuild_reuses_its_buffers_and_follows_the_particles() {
    // Particles shuffled by up to twice the radius between rebuilds: every rebuild
    // gives the brute-force lists of the current positions, and once the lists have
    // reached their largest size the rebuilds allocate nothing (the pair buffer stays
    // where it is: the first rebuild is of the cloud squeezed to half its size, with
    // about four times the pairs of any later one). `Once` keeps the first lists
    // whatever the particles do.
    let mut s = 23;
    let x0 = cloud::<D2>(500, &[2.0, 1.0], &mut s);
    let radius = 0.1;
    let reach = vec![radius; x0.len()];
    let mut every = Neighbours::new::<D2>(Rebuild::EveryStage, &x0, reach.clone(), None);
    let once = Neighbours::new::<D2>(Rebuild::Once, &x0, reach, None);
    let mut kept = once.clone();
    let squeezed: Vec<DVec2> = x0.iter().map(|&p| p * 0.5).collect();
    every.update::<D2>(&squeezed);
    let capacity = every.lists().ids.capacity();
    let pairs = every.lists().ids.as_ptr();
    for _ in 0..4 {
        let x: Vec<DVec2> = x0
            .iter()
            .map(|&p| p + DVec2::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5) * 4.0 * radius)
            .collect();
        assert!(every.update::<D2>(&x));
        let expected = brute::<D2>(&x, radius);
        for (i, e) in expected.iter().enumerate() {
            assert_eq!(every.lists().neighbours(i), e.as_slice(), "particle {i}");
        }
        assert!(every.lists().pair_count() <= capacity);
        assert_eq!(every.lists().ids.as_ptr(), pairs, "the pair buffer moved");
        assert!(!kept.update::<D2>(&x));
        assert_eq!(kept.lists(), once.lists());
    }
}

#[test]
fn drift_lists_hold_every_pair_in_reach_and_rebuild_only_past_the_skin() {
    // Particles moved in small random steps: after every update the drift lists hold
    // each pair within the radius of the current positions (brute force), with the
    // extra pairs no farther than radius·(1 + SKIN) + 2·drift; the lists are rebuilt
    // only when some particle moved more than half the skin since the last build.
    let mut s = 29;
    let mut x = cloud::<D2>(400, &[2.0, 1.0], &mut s);
    let radius = 0.1;
    let mut drift = Neighbours::new::<D2>(Rebuild::OnDrift, &x, vec![radius; 400], None);
    let mut since = vec![DVec2::ZERO; x.len()];
    let (mut rebuilds, mut kept) = (0, 0);
    for _ in 0..60 {
        for (p, m) in x.iter_mut().zip(&mut since) {
            let step = DVec2::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5) * 0.002;
            *p += step;
            *m += step;
        }
        let far = since.iter().any(|m| m.length() > 0.5 * SKIN * radius);
        let rebuilt = drift.update::<D2>(&x);
        assert_eq!(
            rebuilt, far,
            "rebuilt exactly when a particle left the skin"
        );
        if rebuilt {
            since.iter_mut().for_each(|m| *m = DVec2::ZERO);
            rebuilds += 1;
        } else {
            kept += 1;
        }
        for (i, within) in brute::<D2>(&x, radius).iter().enumerate() {
            let listed = drift.lists().neighbours(i);
            assert!(within.iter().all(|j| listed.contains(j)), "particle {i}");
            assert!(listed.windows(2).all(|w| w[0] < w[1]), "sorted ids");
        }
    }
    assert!(
        rebuilds > 2 && kept > 10,
        "{rebuilds} rebuilds, {kept} kept"
    );
}

#[test]
fn sparse_clouds_use_a_bounded_grid() {
    // Two clusters 1e6 radii apart: a grid of radius-sized cells would need 1e12 cells.
    let mut s = 3;
    let x: Vec<DVec2> = (0..400)
        .map(|k| {
            let shift = if k % 2 == 0 { 0.0 } else { 1e5 };
            DVec2::new(shift + lcg(&mut s), lcg(&mut s))
        })
        .collect();
    check::<D2>(&x, 0.1);
}

#[test]
fn interior_lattice_counts_match_the_seed() {
    // Seed 000 §1.1: inside r ≤ 2h with h/dx = 1.3 an interior particle has 21 points
    // (self included), with h/dx = 1.7 it has 37.
    let x: Vec<DVec2> = (0..441)
        .map(|k| DVec2::new((k % 21) as f64, (k / 21) as f64))
        .collect();
    let centre = 220;
    assert_eq!(build::<D2>(&x, 2.6).neighbours(centre).len() + 1, 21);
    assert_eq!(build::<D2>(&x, 3.4).neighbours(centre).len() + 1, 37);
}

#[test]
fn the_first_pair_is_the_brute_force_first_pair() {
    // A random cloud with a few points repeated: the first pair, in row order then
    // neighbour order, of the brute-force lists, and none without the repeats.
    let mut s = 11;
    let mut x = cloud::<D2>(2000, &[1.0, 1.0], &mut s);
    let any = |_: usize, _: usize| true;
    assert_eq!(first_pair::<D2>(&x, 1e-9, any), None);
    x[1700] = x[1500];
    x[900] = x[1900];
    x[1200] = x[900];
    let radius = 1e-9;
    let expected = brute::<D2>(&x, radius)
        .iter()
        .enumerate()
        .find_map(|(i, row)| row.first().map(|&j| (i, j)));
    assert_eq!(expected, Some((900, 1200)));
    assert_eq!(first_pair::<D2>(&x, radius, any), expected);
    // Of the pairs that count: with (900, 1200) left out, the next in row order.
    let not_900 = |i: usize, j: usize| i != 900 && j != 900;
    assert_eq!(first_pair::<D2>(&x, radius, not_900), Some((1200, 1900)));
}

#[test]
fn rows_fill_in_place_and_the_first_failing_row_fails_all() {
    // Rows enough to split across threads (more than MIN_ROWS): every value lands in
    // its pair's slot, and of two failing rows the error names the first.
    let x: Vec<DVec2> = (0..4000)
        .map(|k| DVec2::new((k % 63) as f64, (k / 63) as f64))
        .collect();
    let csr = build::<D2>(&x, 1.5);
    let ids = csr
        .fill_rows(|i, out: &mut [u32]| {
            out.copy_from_slice(csr.neighbours(i));
            Ok::<(), usize>(())
        })
        .unwrap();
    assert_eq!(ids, csr.ids);
    let mapped = csr
        .map_rows(|i| Ok::<_, usize>(csr.neighbours(i).iter().map(move |&j| j + i as u32)))
        .unwrap();
    let expected: Vec<u32> = (0..csr.len())
        .flat_map(|i| csr.neighbours(i).iter().map(move |&j| j + i as u32))
        .collect();
    assert_eq!(mapped, expected);
    let failed = csr.fill_rows(|i, _: &mut [u32]| match i {
        3500 | 700 => Err(i),
        _ => Ok(()),
    });
    assert_eq!(failed, Err(700));
}
