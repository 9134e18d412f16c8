use super::*;
use crate::core::neighbour::{self, Csr};
use crate::core::tensor::{D2, D3, Dim};
use std::collections::BTreeMap;

/// A lattice of unit spacing with `counts` points along each axis, and its neighbour
/// lists within `radius`, built as the methods build theirs.
fn lattice<D: Dim>(counts: &[usize], radius: f64) -> (Vec<D::V>, Csr) {
    let total: usize = counts.iter().product();
    let x: Vec<D::V> = (0..total)
        .map(|mut n| {
            let c: Vec<f64> = counts
                .iter()
                .map(|&m| {
                    let k = n % m;
                    n /= m;
                    k as f64
                })
                .collect();
            D::from_slice(&c)
        })
        .collect();
    let lists = neighbour::build::<D>(&x, radius);
    (x, lists)
}

/// The 2D and 3D lattices of the tests: radius 2.1 gives interior rows of 12 and 32
/// pairs, fewer at the edges, so the weights vary.
fn lattices() -> Vec<(&'static str, Partitioner)> {
    vec![
        ("2D 23×17", Partitioner::new::<D2>(&[23, 17], 2.1)),
        ("3D 9×7×6", Partitioner::new::<D3>(&[9, 7, 6], 2.1)),
    ]
}

/// A lattice's lists and its bisection for a number of ranks, the dimension erased.
struct Partitioner {
    lists: Csr,
    bisect: Box<dyn Fn(usize) -> Result<Partition, Error>>,
}

impl Partitioner {
    fn new<D: Dim + 'static>(counts: &[usize], radius: f64) -> Self {
        let (x, lists) = lattice::<D>(counts, radius);
        let l = lists.clone();
        Partitioner {
            lists,
            bisect: Box::new(move |ranks| Partition::bisect::<D>(&x, &l, ranks)),
        }
    }
}

#[test]
fn every_particle_has_one_owner_and_the_weights_are_balanced() {
    for (name, lattice) in lattices() {
        let lists = &lattice.lists;
        let n = lists.len();
        let w: Vec<u64> = (0..n).map(|i| work(lists, i)).collect();
        let (total, w_max) = (w.iter().sum::<u64>(), *w.iter().max().unwrap());
        for ranks in [1, 2, 3, 5, 7, 8] {
            let p = (lattice.bisect)(ranks).unwrap();
            assert_eq!(p.ranks(), ranks);
            let mut seen = vec![0; n];
            for r in 0..ranks {
                let owned = p.owned(r);
                assert!(
                    !owned.is_empty(),
                    "{name}: rank {r} of {ranks} owns nothing"
                );
                assert!(owned.windows(2).all(|a| a[0] < a[1]), "{name}: ascending");
                for &i in owned {
                    seen[i as usize] += 1;
                    assert_eq!(p.owner(i as usize), r, "{name}: owner of {i}");
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{name}: each owned once");
            // Each cut misses the share of its side by at most half the heaviest
            // particle's weight, and moves each rank's mean by at most that much, once
            // per level of cuts: |W_r − W/N| ≤ ⌈log₂ N⌉ · w_max / 2.
            let levels = ranks.next_power_of_two().trailing_zeros() as f64;
            let mean = total as f64 / ranks as f64;
            let mut largest = 0.0f64;
            for r in 0..ranks {
                let w_r: u64 = p.owned(r).iter().map(|&i| w[i as usize]).sum();
                let miss = (w_r as f64 - mean).abs();
                assert!(
                    miss <= levels * w_max as f64 / 2.0,
                    "{name}, {ranks} ranks: rank {r} weighs {w_r}, mean {mean}, w_max {w_max}"
                );
                largest = largest.max(w_r as f64 / mean);
            }
            println!("{name}, {ranks} ranks: largest rank weight / mean = {largest:.4}");
        }
    }
}

/// The particles within `layers` hops of rank r's by brute force: hop counts relaxed over
/// every pair of the global lists `layers` times.
fn brute_force_reach(p: &Partition, lists: &Csr, r: usize, layers: usize) -> Vec<bool> {
    let mut hops = vec![usize::MAX; lists.len()];
    for &i in p.owned(r) {
        hops[i as usize] = 0;
    }
    for _ in 0..layers {
        let before = hops.clone();
        for (i, &hops_i) in before.iter().enumerate() {
            for &j in lists.neighbours(i) {
                if hops_i != usize::MAX {
                    hops[j as usize] = hops[j as usize].min(hops_i + 1);
                }
            }
        }
    }
    hops.iter().map(|&h| h <= layers).collect()
}

/// The halo of rank r by brute force from the global lists: j is received from its owner
/// s ≠ r when it is within `layers` hops of r's particles; i of r is sent to s when it is
/// within `layers` hops of s's.
fn brute_force_halo(p: &Partition, lists: &Csr, r: usize, layers: usize) -> Halo {
    let mut receive: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
    let mut send: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
    let mine = brute_force_reach(p, lists, r, layers);
    for j in 0..lists.len() as u32 {
        let s = p.owner(j as usize);
        if s != r && mine[j as usize] {
            receive.entry(s).or_default().push(j);
        }
    }
    for s in (0..p.ranks()).filter(|&s| s != r) {
        let theirs = brute_force_reach(p, lists, s, layers);
        for &i in p.owned(r).iter().filter(|&&i| theirs[i as usize]) {
            send.entry(s).or_default().push(i);
        }
    }
    Halo {
        rank: r,
        layers,
        receive,
        send,
    }
}

#[test]
fn halos_equal_those_of_the_global_lists() {
    for (name, lattice) in lattices() {
        let lists = &lattice.lists;
        for (ranks, layers) in [(1, 1), (2, 1), (3, 1), (5, 1), (2, 2), (3, 2)] {
            let p = (lattice.bisect)(ranks).unwrap();
            let halos: Vec<Halo> = (0..ranks)
                .map(|r| Halo::new(&p, lists, r, layers))
                .collect();
            for (r, halo) in halos.iter().enumerate() {
                assert_eq!(
                    *halo,
                    brute_force_halo(&p, lists, r, layers),
                    "{name}, {ranks} ranks, {layers} layers, rank {r}"
                );
                for (s, other) in halos.iter().enumerate().filter(|&(s, _)| s != r) {
                    assert_eq!(
                        halo.receive.get(&s),
                        other.send.get(&r),
                        "{name}, {ranks} ranks: {r} receives from {s} what {s} sends to {r}"
                    );
                }
            }
            if ranks == 1 {
                assert!(halos[0].receive.is_empty() && halos[0].send.is_empty());
            } else {
                assert!(halos.iter().all(|h| !h.receive.is_empty()), "{name}: cuts");
            }
        }
    }
}

#[test]
fn the_same_input_gives_the_same_partition() {
    for (name, lattice) in lattices() {
        for ranks in [2, 3, 5] {
            let a = (lattice.bisect)(ranks).unwrap();
            let b = (lattice.bisect)(ranks).unwrap();
            assert_eq!(a, b, "{name}, {ranks} ranks");
        }
    }
}

#[test]
fn too_few_particles_or_no_ranks_are_refused() {
    let (x, lists) = lattice::<D2>(&[2, 1], 1.5);
    let none = Partition::bisect::<D2>(&x, &lists, 0).unwrap_err();
    assert_eq!(none, Error::NoRanks { particles: 2 });
    assert!(none.to_string().contains("at least 1 rank"), "{none}");
    let many = Partition::bisect::<D2>(&x, &lists, 3).unwrap_err();
    assert_eq!(
        many.to_string(),
        "3 ranks for 2 particles: run on at most 2 ranks"
    );
    let two = Partition::bisect::<D2>(&x, &lists, 2).unwrap();
    assert_eq!((two.owned(0), two.owned(1)), (&[0][..], &[1][..]));
}

#[test]
fn a_launcher_of_several_processes_is_refused_without_mpi() {
    let env = |pairs: &'static [(&'static str, &'static str)]| {
        move |k: &str| {
            pairs
                .iter()
                .find(|(name, _)| *name == k)
                .map(|(_, v)| v.to_string())
        }
    };
    let open_mpi = no_mpi_launcher(env(&[("OMPI_COMM_WORLD_SIZE", "2")])).unwrap_err();
    assert_eq!(
        open_mpi,
        Error::NoMpi {
            variable: "OMPI_COMM_WORLD_SIZE",
            size: 2
        }
    );
    let message = open_mpi.to_string();
    assert!(
        message.contains("OMPI_COMM_WORLD_SIZE=2")
            && message.contains("no MPI")
            && message.contains("--features mpi"),
        "{message}"
    );
    assert!(no_mpi_launcher(env(&[("PMI_SIZE", "4")])).is_err());
    assert!(no_mpi_launcher(env(&[("MPI_LOCALNRANKS", "3")])).is_err());
    // One process, a batch system's task count alone, or a value no launcher writes.
    assert_eq!(
        no_mpi_launcher(env(&[("OMPI_COMM_WORLD_SIZE", "1")])),
        Ok(())
    );
    assert_eq!(no_mpi_launcher(env(&[("SLURM_NTASKS", "8")])), Ok(()));
    assert_eq!(no_mpi_launcher(env(&[("PMI_SIZE", "many")])), Ok(()));
    assert_eq!(no_mpi_launcher(env(&[])), Ok(()));
}
