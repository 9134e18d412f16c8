use super::*;

/// A suite of variants `a` to `e` and `x` with its `[advice]` (`advice`, the table's keys).
fn suite(kind: &str, reference: &str, advice: &str) -> Suite {
    let variants: String = ["a", "b", "c", "d", "e", "x"]
        .iter()
        .map(|v| format!("[[variant]]\nname = \"{v}\"\n"))
        .collect();
    toml::from_str(&format!(
        r#"
name = "s"
job = "the job"
kind = "{kind}"
case = "c"
sweep = {{ key = "spacing", values = [0.1, 0.05] }}
reference = {reference}
history = {{ column = "y", label = "the quantity" }}
advice = {{ {advice} }}
{variants}"#
    ))
    .unwrap()
}

const ANALYTIC: &str = r#"{ type = "analytic", solution = "swinging" }"#;
const NONE: &str = r#"{ type = "none" }"#;

/// The advice of a suite on records and history curves.
fn advise_on(s: &Suite, recs: &[RunRecord], history: &[Curve]) -> Advised {
    advise(&Evidence {
        suite: s,
        records: recs,
        history,
    })
}

fn curve(name: &str, sweep: &str, points: &[(f64, f64)]) -> Curve {
    Curve {
        name: name.into(),
        sweep_value: sweep.into(),
        points: points.to_vec(),
        failed: false,
    }
}

fn record(variant: &str, sweep: &str, wall: f64, error: f64, status: Status) -> RunRecord {
    RunRecord {
        status,
        ..crate::study::plot::tests::record(variant, "cpu", sweep, wall, error)
    }
}

fn failed(time: f64) -> Status {
    Status::Failed {
        time,
        step: 7,
        particle: 3,
        quantity: "det F".into(),
    }
}

#[test]
fn long_numbers_are_shown_to_four_significant_digits() {
    assert_eq!(short_value("0.041666666666666664"), "0.04167");
    assert_eq!(short_value("0.0010666666666666667"), "0.001067");
    assert_eq!(short_value("5.333333333333333e-4"), "5.333e-4");
    assert_eq!(short_value("0.16666666666666666"), "0.1667");
    assert_eq!(short_value("166.66666666666666"), "166.7");
    assert_eq!(short_value("123456.78901"), "1.235e5");
    // Short numbers and words stay as written.
    assert_eq!(short_value("8e-4"), "8e-4");
    assert_eq!(short_value("0.125"), "0.125");
    assert_eq!(short_value("p-F-H-J"), "p-F-H-J");
}

#[test]
fn an_evidence_variant_is_never_advised_however_accurate() {
    // `x` has the smallest error and is the fastest, but it is no candidate: `a`, the
    // best candidate, is advised and `x` is named as evidence.
    let s = suite(
        "accuracy",
        ANALYTIC,
        r#"measure = "velocity", budget = 10.0, candidates = ["a", "b"]"#,
    );
    let recs = vec![
        record("x", "0.05", 0.5, 1e-5, Status::Ok),
        record("a", "0.05", 2.0, 1e-3, Status::Ok),
        record("b", "0.05", 3.0, 5e-3, Status::Ok),
    ];
    let advised = advise_on(&s, &recs, &[]);
    assert_eq!(advised.use_, "`a`", "{}", advised.text);
    assert!(
        advised
            .text
            .contains("use `a` at spacing = 0.05: e(v) = 1.00e-3 in 2.00 s"),
        "{}",
        advised.text
    );
    assert!(!advised.text.contains("`x` at"), "{}", advised.text);
    assert!(
        advised
            .text
            .contains("Evidence only, never advised: `c`, `d`, `e`, `x`."),
        "{}",
        advised.text
    );
}

#[test]
fn a_more_accurate_candidate_over_the_budget_is_named_not_advised() {
    // `b` at 0.05 is ten times more accurate than `a` but takes 100 s, over the budget
    // of 10 s: `a` is advised, `b` named as over the budget; `b`'s run within the budget
    // (at 0.1) is the runner-up.
    let s = suite(
        "accuracy",
        ANALYTIC,
        r#"measure = "velocity", budget = 10.0, candidates = ["a", "b"]"#,
    );
    let recs = vec![
        record("a", "0.05", 5.0, 1e-3, Status::Ok),
        record("b", "0.1", 1.0, 5e-3, Status::Ok),
        record("b", "0.05", 100.0, 1e-4, Status::Ok),
    ];
    let text = advise_on(&s, &recs, &[]).text;
    assert!(text.contains("use `a` at spacing = 0.05"), "{text}");
    assert!(
        text.contains(
            "`b` at spacing = 0.05 is more accurate (e(v) = 1.00e-4) but takes 100 s, over \
             the budget."
        ),
        "{text}"
    );
    assert!(
        text.contains("Runner-up: `b` at spacing = 0.1 (e(v) = 5.00e-3 in 1.00 s)."),
        "{text}"
    );
}

#[test]
fn the_runner_up_and_the_cheapest_within_twice_the_error_are_named() {
    // Best: `a` at 0.05 (1.0e-3, 8 s). Runner-up: `b` (1.2e-3). Within 2× of the best:
    // `a`, `b` and `c` at 0.05, of which `c` is the fastest (2 s); `c` at 0.1 is faster
    // still but 2.5× the error. `d` is 20× the best; `e` failed.
    let s = suite(
        "accuracy",
        ANALYTIC,
        r#"measure = "velocity", budget = 10.0, candidates = ["a", "b", "c", "d", "e"]"#,
    );
    let recs = vec![
        record("a", "0.1", 1.0, 4e-3, Status::Ok),
        record("a", "0.05", 8.0, 1.0e-3, Status::Ok),
        record("b", "0.05", 6.0, 1.2e-3, Status::Ok),
        record("c", "0.1", 0.5, 2.5e-3, Status::Ok),
        record("c", "0.05", 2.0, 1.9e-3, Status::Ok),
        record("d", "0.05", 1.0, 2e-2, Status::Ok),
        record("e", "0.1", 0.5, 1e-5, failed(0.25)),
        record("e", "0.05", 1.0, 1e-5, Status::Ok),
    ];
    let text = advise_on(&s, &recs, &[]).text;
    assert!(
        text.contains("use `a` at spacing = 0.05: e(v) = 1.00e-3 in 8.00 s"),
        "{text}"
    );
    assert!(
        text.contains("Runner-up: `b` at spacing = 0.05 (e(v) = 1.20e-3 in 6.00 s)."),
        "{text}"
    );
    assert!(
        text.contains("`c` at spacing = 0.05 is 4.0× faster, at 1.9× the error"),
        "{text}"
    );
    assert!(
        text.contains(
            "Avoid `e`: fails at spacing = 0.1 (t = 2.50e-1 s, det F); `d`: e(v) = 2.00e-2 \
             at best within the budget, 20× the advised."
        ),
        "{text}"
    );
}

#[test]
fn a_history_measure_against_a_variant_ranks_by_the_distance_of_the_curves() {
    // Against `x`'s curve y = 1: `a` is 10 % off, `b` 1 %; `x` itself is not ranked.
    let s = suite(
        "stability",
        NONE,
        r#"measure = "history", against = "x", budget = 10.0, candidates = ["a", "b", "x"]"#,
    );
    let recs = vec![
        record("a", "0.1", 1.0, f64::NAN, Status::Ok),
        record("b", "0.1", 2.0, f64::NAN, Status::Ok),
        record("x", "0.1", 0.5, f64::NAN, Status::Ok),
    ];
    let xs = [0.0, 0.5, 1.0];
    let line = |name: &str, y: f64| curve(name, "0.1", &xs.map(|x| (x, y)));
    let history = [line("a", 1.1), line("b", 0.99), line("x", 1.0)];
    let text = advise_on(&s, &recs, &history).text;
    assert!(
        text.contains("use `b` at spacing = 0.1: error = 1.00e-2 in 2.00 s"),
        "{text}"
    );
    assert!(
        text.contains("Runner-up: `a` at spacing = 0.1 (error = 1.00e-1 in 1.00 s)."),
        "{text}"
    );
    // The distance is taken at the curve's own points, the reference linear between its.
    let reference = [(0.0, 0.0), (2.0, 2.0)];
    let d = distance(&[(1.0, 1.5), (3.0, 9.0)], &reference);
    assert!((d - 0.5).abs() < 1e-12, "{d}");
}

#[test]
fn a_settings_suite_gives_each_settings_effect_with_the_observed_order() {
    // Errors falling fourfold as the spacing halves: order 2; the history's last value
    // is the error (`measure = "history"`).
    let s = suite(
        "accuracy",
        NONE,
        r#"measure = "history", budget = 10.0, candidates = ["a"], settings = true"#,
    );
    let recs = vec![
        record("a", "0.1", 1.0, f64::NAN, Status::Ok),
        record("a", "0.05", 2.0, f64::NAN, Status::Ok),
    ];
    let history = [
        curve("a", "0.1", &[(0.0, 1.0), (1.0, 4e-2)]),
        curve("a", "0.05", &[(0.0, 1.0), (1.0, 1e-2)]),
    ];
    let text = advise_on(&s, &recs, &history).text;
    assert!(
        text.contains("\n  - `a`: 4.00e-2 at 0.1, 1.00e-2 at 0.05; observed order 2.00"),
        "{text}"
    );
}

#[test]
fn a_stability_only_settings_suite_gives_its_history_not_stable() {
    // The pseudo-viscosity suite: every setting stable; each one's iteration count over
    // the sweep is its effect, and the cheapest at the end of the sweep is advised.
    let s = suite(
        "stability",
        NONE,
        r#"measure = "stability", budget = 10.0, candidates = ["a", "b"], settings = true"#,
    );
    let recs = vec![
        record("a", "0.1", 0.1, f64::NAN, Status::Ok),
        record("a", "0.05", 1.9, f64::NAN, Status::Ok),
        record("b", "0.1", 0.1, f64::NAN, Status::Ok),
        record("b", "0.05", 0.2, f64::NAN, Status::Ok),
    ];
    let history = [
        curve("a", "0.1", &[(1.0, 60.0)]),
        curve("a", "0.05", &[(1.0, 2292.0)]),
        curve("b", "0.1", &[(1.0, 51.0)]),
        curve("b", "0.05", &[(1.0, 203.0)]),
    ];
    let advised = advise_on(&s, &recs, &history);
    let text = &advised.text;
    assert_eq!(advised.use_, "`b`", "{text}");
    assert!(
        text.contains("Each setting's effect (the quantity, the last value of each run"),
        "{text}"
    );
    assert!(
        text.contains("\n  - `a`: 60.00 at 0.1, 2292 at 0.05"),
        "{text}"
    );
    assert!(
        text.contains("\n  - `b`: 51.00 at 0.1, 203.0 at 0.05"),
        "{text}"
    );
}

#[test]
fn runs_to_failure_advise_the_candidate_that_lasts_longest() {
    let s = suite(
        "stability",
        NONE,
        r#"measure = "stability", budget = 10.0, candidates = ["a", "b", "c"]"#,
    );
    let recs = vec![
        record("a", "0.1", 1.0, f64::NAN, failed(0.5)),
        record("b", "0.1", 1.0, f64::NAN, failed(0.9)),
        record("c", "0.1", 1.0, f64::NAN, failed(0.2)),
        record("x", "0.1", 1.0, f64::NAN, failed(2.0)),
    ];
    let advised = advise_on(&s, &recs, &[]);
    assert_eq!(advised.use_, "`b`", "{}", advised.text);
    assert_eq!(
        advised.evidence,
        "lasts longest: fails at spacing = 0.1 (t = 9.00e-1 s, det F)"
    );
}

#[test]
fn a_sweep_choice_names_the_values_stable_on_every_scene_and_their_effects() {
    // Variants `a` and `b` are scenes; 0.1 is stable on both, 0.05 fails on `b`.
    let mut s = suite(
        "stability",
        NONE,
        r#"measure = "stability", budget = 10.0, candidates = ["a", "b"]"#,
    );
    s.choice = Choice::Sweep;
    let recs = vec![
        record("a", "0.1", 1.0, f64::NAN, Status::Ok),
        record("b", "0.1", 1.0, f64::NAN, Status::Ok),
        record("a", "0.05", 1.0, f64::NAN, Status::Ok),
        record("b", "0.05", 1.0, f64::NAN, failed(0.5)),
    ];
    let advised = advise_on(&s, &recs, &[]);
    assert_eq!(advised.evidence, "spacing = 0.1 stable on every scene");
    assert!(
        advised
            .text
            .contains("Avoid `b`: fails at spacing = 0.05 (t = 5.00e-1 s, det F)."),
        "{}",
        advised.text
    );
    assert!(
        advised
            .text
            .contains("\n  - `a`: 1.00 s at 0.1, 1.00 s at 0.05"),
        "{}",
        advised.text
    );
}

#[test]
fn stability_suites_advise_the_candidate_stable_furthest_then_the_cheapest() {
    // `a` and `b` pass both values, `b` faster there; `x` is faster still but evidence;
    // `c` fails at the second value, `e` at the first: listed earliest first. `d` is
    // stable but its run at 0.05 is over the budget.
    let s = suite(
        "stability",
        NONE,
        r#"measure = "stability", budget = 10.0, candidates = ["a", "b", "c", "d", "e"]"#,
    );
    let recs = vec![
        record("a", "0.1", 2.0, f64::NAN, Status::Ok),
        record("a", "0.05", 9.0, f64::NAN, Status::Ok),
        record("b", "0.1", 1.0, f64::NAN, Status::Ok),
        record("b", "0.05", 3.0, f64::NAN, Status::Ok),
        record("x", "0.1", 0.1, f64::NAN, Status::Ok),
        record("x", "0.05", 0.2, f64::NAN, Status::Ok),
        record("c", "0.1", 1.0, f64::NAN, Status::Ok),
        record("c", "0.05", 3.0, f64::NAN, failed(0.5)),
        record("d", "0.1", 1.0, f64::NAN, Status::Ok),
        record("d", "0.05", 30.0, f64::NAN, Status::Ok),
        record("e", "0.1", 1.0, f64::NAN, failed(0.01)),
    ];
    let advised = advise_on(&s, &recs, &[]);
    let text = &advised.text;
    assert!(
        text.contains(
            "use `b` (stability only; budget 10.0 s a run): stable to spacing = 0.05, the \
             whole sweep, in 3.00 s there."
        ),
        "{text}"
    );
    assert!(
        text.contains("Runner-up: `a`, stable to spacing = 0.05, the whole sweep"),
        "{text}"
    );
    assert!(
        text.contains("`d` at spacing = 0.05 is stable but takes 30.0 s, over the budget."),
        "{text}"
    );
    let (e, c) = (
        text.find("`e`: fails at spacing = 0.1").unwrap(),
        text.find("`c`: fails at spacing = 0.05").unwrap(),
    );
    assert!(e < c, "earliest failure first: {text}");
}

#[test]
fn the_advice_section_is_rewritten_in_place() {
    let (_dir, path) = crate::output::scratch::scratch("REPORT.md");
    let before = "# Report\n\nIntro.\n\n## Which method for which job\n\nOld advice.\n\n\
                  ## Suites\n\nKept.\n";
    std::fs::write(&path, before).unwrap();
    rewrite_advice(&path, "## Which method for which job\n\nNew advice.\n\n").unwrap();
    let after = std::fs::read_to_string(&path).unwrap();
    assert_eq!(
        after,
        "# Report\n\nIntro.\n\n## Which method for which job\n\nNew advice.\n\n## Suites\n\n\
         Kept.\n"
    );
    // A report without the section is refused, naming the file.
    std::fs::write(&path, "# Report\n").unwrap();
    let e = rewrite_advice(&path, "x").unwrap_err().to_string();
    assert!(
        e.contains("REPORT.md") && e.contains("no `## Which method"),
        "{e}"
    );
}

#[test]
fn a_failure_beyond_the_advised_reach_is_no_reason_to_avoid() {
    // `a` and `b` both hold at 0.1 and fail at 0.05 (the impact speed each carries); `b`
    // is faster at 0.1, so advised, and `a`'s failure at 0.05 is its limit, as `b`'s is.
    // `c` fails at 0.1, within the advised reach: avoided.
    let s = suite(
        "stability",
        NONE,
        r#"measure = "stability", budget = 10.0, candidates = ["a", "b", "c"]"#,
    );
    let recs = vec![
        record("a", "0.1", 2.0, f64::NAN, Status::Ok),
        record("a", "0.05", 1.0, f64::NAN, failed(0.5)),
        record("b", "0.1", 1.0, f64::NAN, Status::Ok),
        record("b", "0.05", 1.0, f64::NAN, failed(0.4)),
        record("c", "0.1", 1.0, f64::NAN, failed(0.1)),
    ];
    let advised = advise_on(&s, &recs, &[]);
    assert_eq!(advised.use_, "`b`", "{}", advised.text);
    let text = &advised.text;
    assert!(
        text.contains(" Avoid `c`: fails at spacing = 0.1 (t = 1.00e-1 s, det F). Evidence"),
        "{text}"
    );
    assert!(!text.contains("`a`: fails"), "{text}");
}

#[test]
fn errors_within_five_per_cent_are_equal_and_the_faster_is_advised() {
    // `a` is the most accurate by 3 % but takes twice `b`'s time: `b` is advised, `a` is
    // its runner-up, as accurate but slower. `c` is 20 % less accurate, a real difference.
    let s = suite(
        "accuracy",
        ANALYTIC,
        r#"measure = "velocity", budget = 10.0, candidates = ["a", "b", "c"]"#,
    );
    let recs = vec![
        record("a", "0.05", 8.0, 1.00e-3, Status::Ok),
        record("b", "0.05", 4.0, 1.03e-3, Status::Ok),
        record("c", "0.05", 1.0, 1.20e-3, Status::Ok),
    ];
    let advised = advise_on(&s, &recs, &[]);
    assert_eq!(advised.use_, "`b`", "{}", advised.text);
    assert!(
        advised.text.contains(
            "Runner-up: `a` at spacing = 0.05 (e(v) = 1.00e-3 in 8.00 s), as accurate to 5 % \
             but slower."
        ),
        "{}",
        advised.text
    );
    assert!(
        advised
            .text
            .contains("`c` at spacing = 0.05 is 4.0× faster"),
        "{}",
        advised.text
    );
}

#[test]
fn errors_at_round_off_are_equal_and_the_fastest_is_advised() {
    // Three conserved-quantity drifts at round-off: their ratios mean nothing, so the
    // fastest run is advised; none is over the budget and more accurate.
    let s = suite(
        "accuracy",
        ANALYTIC,
        r#"measure = "velocity", budget = 100.0, candidates = ["a", "b", "c"]"#,
    );
    let recs = vec![
        record("a", "0.05", 76.0, 7.3e-15, Status::Ok),
        record("b", "0.05", 63.0, 9.4e-15, Status::Ok),
        record("c", "0.05", 13.0, 1.3e-13, Status::Ok),
        record("a", "0.025", 600.0, 1e-15, Status::Ok),
    ];
    let advised = advise_on(&s, &recs, &[]);
    assert_eq!(advised.use_, "`c`", "{}", advised.text);
    assert!(!advised.text.contains("more accurate"), "{}", advised.text);
}

#[test]
fn a_candidate_to_avoid_is_no_runner_up_and_a_small_speed_up_is_not_named() {
    // `b` is 46× the advised error: it is to be avoided, not the runner-up. `c`'s 4 %
    // speed-up at 1.1× the error is within the noise of one run's wall time: not named.
    let s = suite(
        "accuracy",
        ANALYTIC,
        r#"measure = "velocity", budget = 600.0, candidates = ["a", "b", "c"]"#,
    );
    let recs = vec![
        record("a", "0.05", 1.23, 1.0e-3, Status::Ok),
        record("b", "0.05", 537.0, 4.6e-2, Status::Ok),
        record("c", "0.05", 1.18, 1.1e-3, Status::Ok),
    ];
    let advised = advise_on(&s, &recs, &[]);
    assert_eq!(advised.use_, "`a`", "{}", advised.text);
    assert!(
        advised.text.contains("Runner-up: `c`") && !advised.text.contains("Runner-up: `b`"),
        "{}",
        advised.text
    );
    assert!(!advised.text.contains("faster"), "{}", advised.text);
    assert!(advised.text.contains("Avoid `b`"), "{}", advised.text);
}
