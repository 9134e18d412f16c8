//! Checkpoint and resume: a run stopped at a random batch (interrupted, or killed after
//! its last checkpoint) and resumed ends bit for bit where the uninterrupted run does on
//! the CPU; the CPU path gives the same bits on 1 and 2 threads; a checkpoint of another
//! case or method is refused.

use crate::common::{cpu_options, load};
use meshless::core::tensor::D2;
use meshless::diagnostics::observe::{Invariants, Snapshot};
use meshless::methods::BlowUp;
use meshless::run::{Engine, Failed, RunError, RunOptions, drive, engine, run};
use meshless::scene::Scene;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// The spinning plate (Upwind-SPH {p, F, H, J} with the angular-momentum projection,
/// TVD-RK2, a CFL step updated at every check) at 1,681 particles, to 4 ms (about 100
/// steps in some 40 batches), with checkpoints every 0.5 ms.
fn plate(extra: &[&str]) -> Scene {
    let mut set = vec![
        "spacing=0.05",
        "run.end_time=4e-3",
        "run.checkpoint_interval=5e-4",
        "output.frame_interval=1e-3",
    ];
    set.extend(extra);
    load("spinning-plate", &set)
}

/// How a run is cut short at its `at`-th batch.
#[derive(Clone, Copy)]
enum Cut {
    /// The stop flag (SIGINT): the run ends after the batch with a checkpoint.
    Interrupt,
    /// A crash (kill -9): nothing more is written, the last periodic checkpoint stays.
    Crash,
}

/// An engine that cuts its run short at its `at`-th batch of steps.
struct CutShort {
    inner: Box<dyn Engine<D2>>,
    batches: usize,
    at: usize,
    cut: Cut,
    stop: Arc<AtomicBool>,
}

impl Engine<D2> for CutShort {
    fn backend(&self) -> String {
        self.inner.backend()
    }
    fn reference(&self) -> &[<D2 as meshless::core::tensor::Dim>::V] {
        self.inner.reference()
    }
    fn constrained(&self) -> &[(u32, u8)] {
        self.inner.constrained()
    }
    fn advance(&mut self, t: f64, dt: f64, steps: u32) -> Result<(), Failed> {
        self.batches += 1;
        if self.batches == self.at {
            match self.cut {
                Cut::Interrupt => self.stop.store(true, Ordering::Relaxed),
                Cut::Crash => panic!("killed at batch {}", self.at),
            }
        }
        self.inner.advance(t, dt, steps)
    }
    fn max_signal_speed(&mut self) -> f64 {
        self.inner.max_signal_speed()
    }
    fn external_work(&mut self) -> f64 {
        self.inner.external_work()
    }
    fn reactions(&mut self) -> Vec<meshless::boundary::Reaction> {
        self.inner.reactions()
    }
    fn booked(&mut self) -> meshless::diagnostics::balance::Booked {
        self.inner.booked()
    }
    fn check(&mut self) -> Result<(), BlowUp> {
        self.inner.check()
    }
    fn snapshot(&mut self) -> Snapshot<'_, D2> {
        self.inner.snapshot()
    }
    fn invariants(&mut self) -> Invariants {
        self.inner.invariants()
    }
    fn save(&mut self) -> Vec<f64> {
        self.inner.save()
    }
    fn restore(&mut self, words: &[f64]) -> Result<(), String> {
        self.inner.restore(words)
    }
}

/// Every file a run leaves in `dir` but its summary (which holds wall times), sorted by
/// name, with its bytes.
fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap() != "summary.json")
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    files.sort();
    files
}

/// The first batch at which to cut a run short, from a seeded linear congruential
/// generator (the same batches on every machine).
fn random_batches(seed: u64, count: usize, below: u64) -> Vec<usize> {
    let mut state = seed;
    (0..count)
        .map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (2 + (state >> 33) % (below - 2)) as usize
        })
        .collect()
}

#[test]
fn a_resumed_run_ends_bit_for_bit_where_the_uninterrupted_one_does() {
    let case = plate(&[]);
    let whole = tempfile::tempdir().unwrap();
    let summary = run(&case, &cpu_options(whole.path(), true)).unwrap();
    let expected = outputs(whole.path());
    // The series, the index, the frames and the last checkpoint, every byte.
    assert!(
        expected.len() >= 7,
        "{:?}",
        expected.iter().map(|f| &f.0).collect::<Vec<_>>()
    );

    for (at, cut) in random_batches(22, 2, 30)
        .into_iter()
        .zip([Cut::Interrupt, Cut::Crash])
    {
        let dir = tempfile::tempdir().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let opts = RunOptions {
            stop: Some(stop.clone()),
            ..cpu_options(dir.path(), true)
        };
        let cut_short = CutShort {
            inner: engine::<D2>(&case, opts.backend).unwrap(),
            batches: 0,
            at,
            cut,
            stop,
        };
        let first = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            drive::<D2, _>(&case, &opts, cut_short)
        }));
        match (cut, first) {
            (Cut::Interrupt, Ok(Err(RunError::Interrupted { step, .. }))) => {
                assert!(step > 0 && step < summary.steps, "{step}")
            }
            (Cut::Crash, Err(_)) => {}
            (_, other) => panic!("batch {at}: not cut short: {:?}", other.map(|r| r.is_ok())),
        }
        let resumed = RunOptions {
            resume: true,
            ..cpu_options(dir.path(), true)
        };
        let end = run(&case, &resumed).unwrap();
        assert_eq!(end.steps, summary.steps, "batch {at}");
        assert_eq!(end.final_invariants, summary.final_invariants, "batch {at}");
        let got = outputs(dir.path());
        let names =
            |files: &[(String, Vec<u8>)]| files.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
        assert_eq!(names(&got), names(&expected), "batch {at}");
        for ((name, bytes), (_, want)) in got.iter().zip(&expected) {
            assert!(
                bytes == want,
                "batch {at}: {name} differs from the uninterrupted run's"
            );
        }
    }
}

#[test]
fn one_and_two_threads_give_the_same_bits() {
    // Every sum over particles (the projection's net force and moment, the invariants,
    // the strain energy) is reduced in fixed chunks, so the thread count changes nothing.
    let case = plate(&["run.end_time=1e-3"]);
    let on = |threads: usize| {
        let dir = tempfile::tempdir().unwrap();
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run(&case, &cpu_options(dir.path(), true)).unwrap());
        outputs(dir.path())
    };
    assert!(on(1) == on(2), "1 and 2 threads differ");
}

#[test]
fn a_checkpoint_of_another_case_or_method_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let case = plate(&["run.end_time=5e-4"]);
    run(&case, &cpu_options(dir.path(), false)).unwrap();
    let resumed = |case: &Scene| {
        let opts = RunOptions {
            resume: true,
            ..cpu_options(dir.path(), false)
        };
        match run(case, &opts) {
            Err(RunError::Checkpoint { message, .. }) => message,
            other => panic!("resumed: {:?}", other.map(|s| s.status)),
        }
    };
    // A longer run of the same case resumes; another material, method or spacing not.
    let longer = plate(&["run.end_time=1e-3"]);
    let opts = RunOptions {
        resume: true,
        ..cpu_options(dir.path(), false)
    };
    run(&longer, &opts).unwrap();
    let e = resumed(&plate(&["material.youngs_modulus=2e7"]));
    assert!(e.contains("keys differ"), "{e}");
    let e = resumed(&plate(&["method.name=jst-sph"]));
    assert!(e.contains("method is upwind-sph"), "{e}");
    let e = resumed(&plate(&["spacing=0.1"]));
    assert!(e.contains("particles is 1681"), "{e}");
    std::fs::write(
        dir.path().join("checkpoint.bin"),
        b"not a checkpoint at all",
    )
    .unwrap();
    let e = resumed(&case);
    assert!(e.contains("not a meshless checkpoint"), "{e}");
}

/// A damaged checkpoint is refused before anything is restored, naming the damage: a
/// flipped bit anywhere (the checksum), a driver state that a run cannot reach however
/// its checksum is made (a time that is NaN or past the end), and a file grown far past
/// its announced words (refused from its length, without reading or allocating them).
#[test]
fn a_damaged_checkpoint_is_refused_before_anything_is_restored() {
    let dir = tempfile::tempdir().unwrap();
    let case = plate(&["run.end_time=5e-4"]);
    run(&case, &cpu_options(dir.path(), false)).unwrap();
    let path = dir.path().join("checkpoint.bin");
    let good = std::fs::read(&path).unwrap();
    let resumed = |bytes: &[u8]| {
        std::fs::write(&path, bytes).unwrap();
        let opts = RunOptions {
            resume: true,
            ..cpu_options(dir.path(), false)
        };
        match run(&case, &opts) {
            Err(RunError::Checkpoint { message, .. }) => message,
            other => panic!("resumed: {:?}", other.map(|s| s.status)),
        }
    };
    // One bit of a state word, near the end of the file.
    let mut flipped = good.clone();
    let k = good.len() - 100;
    flipped[k] ^= 0x10;
    let e = resumed(&flipped);
    assert!(e.contains("checksum does not match"), "{e}");
    // The time word (the first after the header and the count), rewritten with a
    // checksum that matches.
    let header = u32::from_le_bytes(good[12..16].try_into().unwrap()) as usize;
    let t_at = 16 + header + 8;
    let with_time = |t: f64| {
        let mut bytes = good.clone();
        bytes[t_at..t_at + 8].copy_from_slice(&t.to_le_bytes());
        let body = bytes.len() - 8;
        let sum = meshless::case::fnv1a(&bytes[..body]);
        bytes[body..].copy_from_slice(&sum.to_le_bytes());
        bytes
    };
    let e = resumed(&with_time(f64::NAN));
    assert!(e.contains("time t = NaN is not in [0, run.end_time"), "{e}");
    let e = resumed(&with_time(1.0));
    assert!(
        e.contains("time t = 1 is not in") && e.contains("raise run.end_time"),
        "{e}"
    );
    // 60 GiB more, as a sparse tail: refused from the length alone.
    std::fs::write(&path, &good).unwrap();
    let file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
    file.set_len(good.len() as u64 + (60 << 30)).unwrap();
    drop(file);
    let opts = RunOptions {
        resume: true,
        ..cpu_options(dir.path(), false)
    };
    let Err(RunError::Checkpoint { message, .. }) = run(&case, &opts) else {
        panic!("a grown checkpoint is resumed")
    };
    assert!(
        message.contains("announces") && message.contains("holds"),
        "{message}"
    );
    // The undamaged file still resumes.
    std::fs::write(&path, &good).unwrap();
    run(&case, &opts).unwrap();
}

/// The columns of a `series.csv`: (name, values).
#[cfg(feature = "gpu")]
fn series_columns(dir: &Path) -> Vec<(String, Vec<f64>)> {
    let text = std::fs::read_to_string(dir.join("series.csv")).unwrap();
    let mut lines = text.lines();
    let names: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut columns: Vec<(String, Vec<f64>)> =
        names.iter().map(|n| (n.to_string(), Vec::new())).collect();
    for line in lines {
        for (column, value) in columns.iter_mut().zip(line.split(',')) {
            column.1.push(value.parse().unwrap_or(f64::NAN));
        }
    }
    columns
}

#[cfg(feature = "gpu")]
#[test]
fn a_resumed_gpu_run_ends_where_the_uninterrupted_one_does() {
    // The strip under TLSPH on the GPU, crashed at three random batches after its last
    // checkpoint and resumed: the checkpoint holds the device's f32 state exactly (f32 →
    // f64 → f32) and the work balance in f64 (the work and dissipation so far, and the
    // last power of each), so the resumed run repeats the uninterrupted one's steps. Its
    // final invariants, its energy balance and every column of its series agree with the
    // uninterrupted run's within f32 round-off (1e-6 of each quantity's largest
    // magnitude: a few ulps of the energies summed in f32).
    use meshless::run::Backend;
    let case = load(
        "tensile-strip",
        &[
            "run.end_time=2e-4",
            "run.checkpoint_interval=5e-5",
            "output.series_interval=1e-5",
            "output.frame_interval=1e-4",
        ],
    );
    let gpu_options = |dir: &Path| RunOptions {
        backend: Backend::Gpu,
        ..cpu_options(dir, true)
    };
    let whole = tempfile::tempdir().unwrap();
    let summary = run(&case, &gpu_options(whole.path())).unwrap();
    let series = series_columns(whole.path());
    let close = |got: f64, want: f64, scale: f64| (got - want).abs() <= 1e-6 * scale.max(1e-12);
    // Batches 7 to 17 of 20 (of 1e-5 s each, the series interval), after the first
    // checkpoint at 5e-5 s.
    for at in random_batches(9, 3, 13).into_iter().map(|b| b + 5) {
        let dir = tempfile::tempdir().unwrap();
        let opts = gpu_options(dir.path());
        let cut_short = CutShort {
            inner: engine::<D2>(&case, Backend::Gpu).unwrap(),
            batches: 0,
            at,
            cut: Cut::Crash,
            stop: Arc::new(AtomicBool::new(false)),
        };
        let crashed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            drive::<D2, _>(&case, &opts, cut_short)
        }));
        assert!(crashed.is_err(), "batch {at}: not cut short");
        let end = run(
            &case,
            &RunOptions {
                resume: true,
                ..gpu_options(dir.path())
            },
        )
        .unwrap_or_else(|e| panic!("batch {at}: {e}"));
        assert_eq!(end.steps, summary.steps);
        for (name, &value) in summary
            .final_invariants
            .iter()
            .chain(&summary.energy_balance)
        {
            let got = end
                .final_invariants
                .get(name)
                .or_else(|| end.energy_balance.get(name))
                .copied()
                .unwrap_or(f64::NAN);
            let both_null = got.is_nan() && value.is_nan();
            assert!(
                both_null || close(got, value, value.abs()),
                "batch {at}: {name} = {got:e}, uninterrupted {value:e}"
            );
        }
        let resumed = series_columns(dir.path());
        assert_eq!(
            resumed.len(),
            series.len(),
            "batch {at}: the series' columns"
        );
        for ((name, got), (_, want)) in resumed.iter().zip(&series) {
            assert_eq!(got.len(), want.len(), "batch {at}: rows of {name}");
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (row, (&g, &w)) in got.iter().zip(want).enumerate() {
                assert!(
                    close(g, w, scale) || (g.is_nan() && w.is_nan()),
                    "batch {at}: {name} at row {row} = {g:e}, uninterrupted {w:e}"
                );
            }
        }
    }
}

/// The bits of the particles' displacements and velocities of an engine's snapshot.
fn motion_bits(e: &mut Box<dyn Engine<D2>>) -> Vec<u64> {
    let snap = e.snapshot();
    (snap.u.iter().chain(&snap.v))
        .flat_map(|v| [v.x, v.y])
        .map(f64::to_bits)
        .collect()
}

/// `kbm` on an Eulerian kernel under a shear, searching every 5 steps, checkpointed
/// after 13 steps (3 steps past a search, its lists those of the positions after 10 and
/// far from the reference's) and resumed in a new engine for 12 more: the bits of an
/// uninterrupted run of 25 steps. A checkpoint without the last search's positions and
/// the steps since it would resume on the reference configuration's lists.
fn resumed_eulerian_kbm_is_the_uninterrupted_bits(backend: meshless::run::Backend) {
    let velocity = "initial_velocity = { type = \"expression\", vx = \"200*(y-0.3)\", \
                    vy = \"100*(x-0.5)\" }\n";
    let keys = "kernel_frame = \"eulerian\"\nintegration = \"stress-points\"\nsearch_every = 5";
    let text = crate::common::block_text(&[1.0, 0.6], "hypoelastic", "kbm", keys).replacen(
        "volumes = \"uniform\" }\n",
        &format!("volumes = \"uniform\" }}\n{velocity}"),
        1,
    );
    let case = Scene::from_toml(&text, Path::new("sheared.toml"), &[]).unwrap();
    let dt = 1e-4;
    let new = || engine::<D2>(&case, backend).unwrap();
    let mut whole = new();
    whole.advance(0.0, dt, 25).unwrap();
    let mut first = new();
    first.advance(0.0, dt, 13).unwrap();
    let words = first.save();
    let mut resumed = new();
    resumed.restore(&words).unwrap();
    resumed.advance(13.0 * dt, dt, 12).unwrap();
    assert!(
        motion_bits(&mut resumed) == motion_bits(&mut whole),
        "{backend:?}: the resumed run left the uninterrupted run's bits"
    );
}

#[test]
fn a_resumed_eulerian_kernel_searches_where_the_uninterrupted_one_did() {
    resumed_eulerian_kbm_is_the_uninterrupted_bits(meshless::run::Backend::Cpu);
    #[cfg(feature = "gpu")]
    resumed_eulerian_kbm_is_the_uninterrupted_bits(meshless::run::Backend::Gpu);
}
