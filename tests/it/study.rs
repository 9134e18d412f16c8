//! The study runner: error norms on manufactured fields with known errors, a blow-up
//! recorded as failed while the study goes on, resumption without redoing finished runs,
//! and the files a suite writes.

use crate::common::{cases_dir, toml_files};
use meshless::physics::material::Material;
use meshless::scene::Scene;
use meshless::study::fields::{FinalState, analytic_fields, matched_fields, relative_l2};
use meshless::study::suite::{AnalyticSolution, TimeMeasure};
use meshless::study::{
    RUN_TIME_LIMIT, RunRecord, Status, StudyOptions, Suite, records, report, run_suite,
};
use std::path::PathBuf;

fn studies() -> PathBuf {
    cases_dir().join("studies")
}

fn ci_suite() -> Suite {
    Suite::load(&studies().join("ci.toml")).unwrap()
}

/// Particles on the lattice of spacing dx over [0, 1]², unit volume weights.
fn lattice(dx: f64) -> FinalState {
    let n = (1.0 / dx).round() as usize;
    let mut s = FinalState {
        dim: 2,
        ..FinalState::default()
    };
    for i in 0..=n {
        for j in 0..=n {
            s.x0.push([i as f64 * dx, j as f64 * dx, 0.0]);
            s.volume.push(dx * dx);
            s.v.push([0.0; 3]);
            s.pk1.push([[0.0; 3]; 3]);
        }
    }
    s
}

#[test]
fn relative_l2_of_a_scaled_field_is_the_scale_error() {
    // q = q_ex (1 + ε) gives e = |ε| for any weights and field (round-off only: 1e-13).
    let w: Vec<f64> = (0..50)
        .map(|i| 0.5 + (i as f64 * 0.37).sin().abs())
        .collect();
    let q_ex: Vec<f64> = (0..150).map(|k| (k as f64 * 0.11).cos() + 0.2).collect();
    for eps in [1e-6, 3e-3, -0.25, 2.0] {
        let q: Vec<f64> = q_ex.iter().map(|x| x * (1.0 + eps)).collect();
        let e = relative_l2(&w, &q, &q_ex);
        assert!((e - eps.abs()).abs() < 1e-13, "ε = {eps}: e = {e}");
    }
    // An error on one particle only: e = sqrt(w_k δ² / Σ w |q_ex|²) exactly.
    let w = [1.0, 2.0, 3.0];
    let q_ex = [1.0, 0.0, 2.0, 1.0, 0.0, 1.0];
    let mut q = q_ex;
    q[2] += 0.5;
    let expected = (2.0f64 * 0.25 / (1.0 + 2.0 * 5.0 + 3.0)).sqrt();
    assert!((relative_l2(&w, &q, &q_ex) - expected).abs() < 1e-15);
    // Mismatched sizes and a zero reference are not measured.
    assert!(relative_l2(&w, &q[..5], &q_ex[..5]).is_nan());
    assert!(relative_l2(&w, &q, &[0.0; 6]).is_nan());
}

#[test]
fn analytic_errors_of_a_manufactured_swinging_state() {
    // The exact swinging-plate state with v scaled by (1 + ε) and P by (1 − 2ε) must give
    // e(v) = ε and e(P) = 2ε (tolerance 1e-12).
    let case = Scene::load(&studies().join("cases/swinging-plate.toml"), &[]).unwrap();
    let mut state = lattice(0.05);
    let t = 0.013;
    let (v_ex, p_ex) = analytic_fields(AnalyticSolution::Swinging, &case, &state, t).unwrap();
    assert_eq!(v_ex.len(), 2 * state.x0.len());
    assert_eq!(p_ex.len(), 4 * state.x0.len());
    let eps = 0.01;
    for i in 0..state.x0.len() {
        state.v[i] = [
            v_ex[2 * i] * (1.0 + eps),
            v_ex[2 * i + 1] * (1.0 + eps),
            0.0,
        ];
        for k in 0..2 {
            for l in 0..2 {
                state.pk1[i][k][l] = p_ex[4 * i + 2 * k + l] * (1.0 - 2.0 * eps);
            }
        }
    }
    let ev = relative_l2(&state.volume, &state.velocity_flat(), &v_ex);
    let es = relative_l2(&state.volume, &state.stress_flat(), &p_ex);
    assert!((ev - eps).abs() < 1e-12, "e(v) = {ev}");
    assert!((es - 2.0 * eps).abs() < 1e-12, "e(P) = {es}");
    // The exact fields themselves: |v| peaks at U0 ω |cos ωt| at the corner X = (1, 0).
    let omega = meshless::diagnostics::analytic::SwingingMode::new(
        5e-4,
        &Material::new(&case.material),
        2,
        meshless::diagnostics::analytic::SwingingKind::Dilatational,
    )
    .omega;
    let vmax = v_ex.chunks(2).map(|v| v[0].hypot(v[1])).fold(0.0, f64::max);
    assert!((vmax - 5e-4 * omega * (omega * t).cos().abs()).abs() < 1e-12);
}

#[test]
fn converged_reference_is_matched_by_reference_position() {
    // A coarse lattice inside a fine one: every coarse particle finds its fine twin at
    // distance 0, so a coarse field equal to the reference times (1 + ε) has error ε.
    let mut fine = lattice(0.025);
    for (i, x) in fine.x0.clone().iter().enumerate() {
        fine.v[i] = [x[0].sin() + 1.0, x[1] * x[0], 0.0];
        fine.pk1[i][0][1] = x[0] - x[1];
        fine.pk1[i][1][1] = 2.0 + x[1];
    }
    let mut coarse = lattice(0.1);
    for i in 0..coarse.x0.len() {
        let x = coarse.x0[i];
        coarse.v[i] = [(x[0].sin() + 1.0) * 1.03, x[1] * x[0] * 1.03, 0.0];
        coarse.pk1[i][0][1] = (x[0] - x[1]) * 1.03;
        coarse.pk1[i][1][1] = (2.0 + x[1]) * 1.03;
    }
    let (v_ref, p_ref, worst) = matched_fields(&fine, &coarse);
    assert!(worst < 1e-12, "largest match distance {worst}");
    let ev = relative_l2(&coarse.volume, &coarse.velocity_flat(), &v_ref);
    let es = relative_l2(&coarse.volume, &coarse.stress_flat(), &p_ref);
    assert!(
        (ev - 0.03).abs() < 1e-12 && (es - 0.03).abs() < 1e-12,
        "{ev} {es}"
    );
    // A lattice shifted by 0.01 along x falls back to the nearest neighbour, 0.01 away
    // (the other fine neighbour is 0.015 away).
    let mut shifted = lattice(0.1);
    shifted.x0.iter_mut().for_each(|x| x[0] += 0.01);
    let (_, _, worst) = matched_fields(&fine, &shifted);
    assert!((worst - 0.01).abs() < 1e-12, "{worst}");
}

#[test]
fn a_blow_up_is_recorded_and_the_study_goes_on_then_resumes_without_redoing() {
    // Results in <root>/ci/, as `meshless study` lays them out, so the report finds the
    // runs' series there.
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("ci");
    let suite = ci_suite();
    let opts = StudyOptions {
        out_dir: dir.clone(),
        resume: true,
        progress: false,
        run_time_limit: RUN_TIME_LIMIT,
        measure: true,
    };
    let first = run_suite(&suite, &opts).unwrap();
    let n = suite.variants.len() * suite.sweep.values.len();
    assert_eq!(
        (first.records.len(), first.executed, first.skipped),
        (n, n, 0)
    );

    check_failures_and_errors(&first.records);

    check_files(&dir, n);

    // Half-finished: drop the last two rows, as if the study had been stopped there.
    let path = dir.join("results.csv");
    let mut kept = records::read(&path).unwrap();
    kept.truncate(n - 2);
    records::write(&path, &kept).unwrap();
    // A long suite under `meshless study all` only reads what it has, even without resume:
    // nothing runs, the kept rows are its records.
    let read_only = StudyOptions {
        resume: false,
        measure: false,
        ..opts.clone()
    };
    let read = run_suite(&suite, &read_only).unwrap();
    assert_eq!((read.executed, read.records.len()), (0, n - 2));
    let second = run_suite(&suite, &opts).unwrap();
    assert_eq!((second.executed, second.skipped), (2, n - 2));
    // Kept rows are the earlier measurements, bit for bit (wall times would differ).
    for (a, b) in kept.iter().zip(&second.records) {
        assert_eq!(a.id, b.id);
        assert_eq!(a.wall_seconds.to_bits(), b.wall_seconds.to_bits());
    }
    assert_eq!(second.records.len(), n);

    // Nothing left to do; without resume everything runs again.
    let third = run_suite(&suite, &opts).unwrap();
    assert_eq!((third.executed, third.skipped), (0, n));
    let fresh = StudyOptions {
        resume: false,
        ..opts.clone()
    };
    assert_eq!(run_suite(&suite, &fresh).unwrap().executed, n);

    // The report over the suite: findings, plot links and the table.
    let report_path = dir.join("docs/REPORT.md");
    report::write_report(
        &[(suite.clone(), third.records.clone())],
        root.path(),
        &report_path,
        "test",
    )
    .unwrap();
    let text = std::fs::read_to_string(&report_path).unwrap();
    assert!(text.contains("## Which method for which job"));
    assert!(text.contains("](study/ci-velocity.png)"));
    assert!(text.contains("failed at t = "));
    assert!(dir.join("docs/study/ci-velocity.svg").is_file());
    assert!(dir.join("docs/study/ci.csv").is_file());
    assert!(text.contains("](study/ci-history-1.png)"));
    assert!(dir.join("docs/study/ci-history.csv").is_file());

    // With a failure measure, each failure time is also shown in that measure.
    let measured = Suite {
        failure_measure: Some(TimeMeasure {
            name: "λ3".into(),
            per_second: 1e4,
            unit: "%".into(),
        }),
        ..suite.clone()
    };
    let table = report::runs_table(&measured, &third.records);
    for r in &third.records {
        if let Status::Failed { time, .. } = r.status {
            let shown = format!("λ3 = {:.0} %", 1e4 * time);
            assert!(table.contains(&shown), "{shown} not in\n{table}");
        }
    }
}

/// The first pass of the CI suite: the leapfrog variant failed with its time, step,
/// particle, quantity and reason; the others finished with errors that fall with the
/// spacing.
fn check_failures_and_errors(recs: &[RunRecord]) {
    // The leapfrog variant at c_p·Δt/Δx = 2.2 and 4.3 (listed first) blows up at both spacings: failed, with
    // time, step, particle, quantity and the driver's reason.
    for r in recs.iter().filter(|r| r.variant == "leapfrog-dt3e-3") {
        let Status::Failed {
            time,
            step,
            particle,
            quantity,
        } = &r.status
        else {
            panic!("expected a failure, got {r:?}")
        };
        assert!(*time > 0.0 && *time < 0.01226 && *step >= 1, "{r:?}");
        assert!(*particle < r.particles && !quantity.is_empty(), "{r:?}");
        assert!(r.reason.contains("particle"), "{}", r.reason);
        assert!(r.error_velocity.is_nan());
    }
    // The runs after it finished, with analytic errors that fall with the spacing.
    // Measured (rl-rk4): e(v) = 0.30 at Δx = 0.2, 0.14 at 0.1; bound 0.5 and a fall.
    for v in ["rl-rk4", "rkpm-leapfrog"] {
        let e: Vec<f64> = recs
            .iter()
            .filter(|r| r.variant == v)
            .map(|r| {
                assert_eq!(r.status, Status::Ok, "{r:?}");
                r.error_velocity
            })
            .collect();
        assert!(e.len() == 2 && e[1] < e[0] && e[0] < 0.5, "{v}: {e:?}");
    }
}

/// The suite's output files, its energy history and its plot.
fn check_files(dir: &std::path::Path, n: usize) {
    // Files: results CSV, the Markdown table and both plots.
    for f in [
        "results.csv",
        "results.md",
        "ci-velocity.png",
        "ci-velocity.svg",
        "ci-stress.png",
        "ci-history-1.png",
        "ci-history-2.svg",
        "ci-history.csv",
    ] {
        let len = std::fs::metadata(dir.join(f)).unwrap().len();
        assert!(len > 100, "{f}: {len} bytes");
    }
    // The history: every run's total energy against t in ms; a finished run's curve ends at
    // the end time (12.26 ms, to within the series interval of 0.2 ms plus the last step),
    // a failed one's before it.
    let history = std::fs::read_to_string(dir.join("ci-history.csv")).unwrap();
    let mut last_x = std::collections::BTreeMap::<String, f64>::new();
    for line in history.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        last_x.insert(format!("{}@{}", f[0], f[1]), f[2].parse().unwrap());
    }
    assert_eq!(last_x.len(), n, "one curve per run: {last_x:?}");
    for (run, x) in &last_x {
        if run.starts_with("leapfrog") {
            assert!(*x < 12.0, "{run} failed early, its curve ends at {x} ms");
        } else {
            assert!((x - 12.26).abs() < 0.21, "{run} ends at {x} ms");
        }
    }
    let png = std::fs::read(dir.join("ci-velocity.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let svg = std::fs::read_to_string(dir.join("ci-velocity.svg")).unwrap();
    assert!(
        svg.contains("Pareto front") && svg.contains("rl-rk4"),
        "labels in the SVG"
    );
}

#[test]
fn run_ids_are_stable_and_depend_on_what_runs() {
    let suite = ci_suite();
    let a = suite.plan();
    let b = suite.plan();
    let ids: Vec<&str> = a.iter().map(|r| r.id.as_str()).collect();
    assert_eq!(ids, b.iter().map(|r| r.id.as_str()).collect::<Vec<_>>());
    let mut unique = ids.clone();
    unique.sort_unstable();
    unique.dedup();
    assert_eq!(unique.len(), ids.len(), "one id per run");
    // Another end time is another run.
    let mut other = suite.clone();
    other.set.push("run.end_time=0.004".into());
    assert!(other.plan().iter().all(|r| !ids.contains(&r.id.as_str())));
}

#[test]
fn a_variant_runs_its_own_case_and_run_threads_sizes_the_pool() {
    // A variant naming another base case plans that case (its method and its Δt), the
    // others the suite's.
    let path = studies().join("seed000-disk.toml");
    let suite = Suite::load(&path).unwrap();
    for run in suite.plan() {
        let case = run.case.as_ref().unwrap();
        let expected = match run.variant.as_str() {
            "godunov" => ("godunov-sph", 1e-6),
            "gray-monaghan" | "gray-monaghan-rl" | "gray-monaghan-rkpm" => {
                ("gray-monaghan-sph", 1e-5)
            }
            "corotated" => ("corotated-tlsph", 2.5e-6),
            "potential" => ("tl-potential", 1e-6),
            "tl-weak-form" => ("tl-weak-form", 1e-6),
            "tl-fem" => ("tl-fem", 1e-6),
            "ul-weak-form" | "ul-weak-form-gpu" => ("ul-weak-form", 1e-6),
            "ul-fem" | "ul-fem-gpu" => ("ul-fem", 1e-5),
            _ => ("tlsph", 1e-6),
        };
        assert_eq!(
            (case.method.name, case.method.dt),
            (expected.0, Some(expected.1)),
            "{}",
            run.variant
        );
    }
    // run.threads = n runs in a pool of n threads; without it, in the global pool.
    let base = Scene::load(&cases_dir().join("rotating-disk.toml"), &[]).unwrap();
    for n in [1, 3] {
        let case = Scene::load(
            &cases_dir().join("rotating-disk.toml"),
            &[format!("run.threads={n}")],
        )
        .unwrap();
        let inside = meshless::run::with_threads(&case, rayon::current_num_threads).unwrap();
        assert_eq!(inside, n);
    }
    let inside = meshless::run::with_threads(&base, rayon::current_num_threads).unwrap();
    assert_eq!(inside, rayon::current_num_threads());
}

#[test]
fn shipped_suites_load_and_plan_valid_cases() {
    // Every suite file parses, and every planned case validates except where a sweep
    // value is meant to be refused (ν = 0.5).
    let mut count = 0;
    for path in toml_files(&studies()) {
        let suite = Suite::load(&path).unwrap_or_else(|e| panic!("{e}"));
        for run in suite.plan() {
            if let Err(e) = &run.case {
                assert!(
                    run.value == "0.5" && e.contains("poisson_ratio"),
                    "{}: {} {}: {e}",
                    suite.name,
                    run.variant,
                    run.value
                );
            }
        }
        count += 1;
    }
    assert!(count >= 6, "{count} suites");
}

#[test]
fn every_method_of_the_registry_runs_the_swinging_plate() {
    // The report compares every method on one analytic case: each registry entry must
    // have a variant of the `swinging-plate` suite whose planned case is valid and runs
    // it, so a method added to the registry without one fails here.
    let suite = Suite::load(&studies().join("swinging-plate.toml")).unwrap();
    let planned: std::collections::BTreeSet<&str> = suite
        .plan()
        .iter()
        .map(|run| {
            let case = run
                .case
                .as_ref()
                .unwrap_or_else(|e| panic!("{}: {e}", run.variant));
            case.spec.entry().name
        })
        .collect();
    let missing: Vec<&str> = meshless::methods::REGISTRY
        .iter()
        .map(|e| e.name)
        .filter(|n| !planned.contains(n))
        .collect();
    assert!(
        missing.is_empty(),
        "no swinging-plate variant runs {missing:?}"
    );
}

#[test]
fn every_method_counts_its_pairs_and_models_its_traffic() {
    // The swinging plate's suite runs every method of the registry (checked in
    // `study::every_method_of_the_registry_runs_the_swinging_plate`). At its coarsest
    // spacing (121 particles) every one measures on the CPU its pairs per particle, at
    // least one (each particle or point reaches a neighbour or node), and the bytes of a
    // step by its traffic model, at least the 4-byte ids of every pair it loops over.
    let suite = Suite::load(&studies().join("swinging-plate.toml")).unwrap();
    let plan = suite.plan();
    let coarsest = &plan[0].value;
    for run in plan.iter().filter(|r| &r.value == coarsest) {
        let case = run.case.as_ref().unwrap();
        let row = meshless::bench::measure(case, meshless::run::Backend::Cpu, 1).unwrap();
        let pairs = row.pairs_per_particle.expect(&run.variant);
        assert!(pairs >= 1.0, "{}: {pairs} pairs per particle", run.variant);
        let bytes = row.traffic.expect(&run.variant).bytes_per_particle;
        assert!(bytes >= 4.0 * pairs, "{}: {bytes} bytes", run.variant);
    }
}

#[test]
fn a_run_past_the_estimate_or_the_time_limit_is_recorded_and_the_study_goes_on() {
    // One sweep value asks for ~1e600 particles (spacing 1e-300): refused by the resource
    // estimate before anything is allocated, recorded as an error naming `spacing`; the
    // other value runs. With a zero wall-time limit the same runnable value is stopped
    // after its first batch and recorded as such.
    let dir = tempfile::tempdir().unwrap();
    let mut suite = ci_suite();
    suite.variants.truncate(2);
    suite.variants.remove(0);
    suite.sweep.values = vec![toml::Value::Float(1e-300), toml::Value::Float(0.2)];
    let opts = StudyOptions {
        out_dir: dir.path().to_path_buf(),
        resume: false,
        progress: false,
        run_time_limit: RUN_TIME_LIMIT,
        measure: true,
    };
    let done = run_suite(&suite, &opts).unwrap();
    let [tiny, ok] = &done.records[..] else {
        panic!("{:?}", done.records)
    };
    assert_eq!(tiny.status, Status::Error);
    assert!(
        tiny.reason.contains("key `spacing`") && tiny.reason.contains("--max-particles"),
        "{}",
        tiny.reason
    );
    assert_eq!(ok.status, Status::Ok, "{}", ok.reason);

    let hurried = StudyOptions {
        run_time_limit: std::time::Duration::ZERO,
        ..opts
    };
    let done = run_suite(&suite, &hurried).unwrap();
    let stopped = &done.records[1];
    assert_eq!(stopped.status, Status::Error);
    assert!(
        stopped.reason.contains("wall-time limit of 0 s"),
        "{}",
        stopped.reason
    );
    assert!(
        stopped.steps < ok.steps,
        "{} of {}",
        stopped.steps,
        ok.steps
    );
}
