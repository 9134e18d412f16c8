use super::*;

fn suite(kind: &str, reference: &str) -> Suite {
    toml::from_str(&format!(
        r#"
name = "s"
job = "the job"
kind = "{kind}"
case = "c"
sweep = {{ key = "spacing", values = [0.1, 0.05] }}
reference = {reference}
[[variant]]
name = "a"
"#
    ))
    .unwrap()
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
fn accuracy_suites_recommend_the_most_accurate_line_that_never_failed() {
    // `b` is the most accurate at its longest run but failed at the coarse spacing;
    // `a` is the best of the others; `e` and `c` are 40 and 20 times worse than `a`;
    // `d` is 5 times worse, within the ratio, so not listed. The failure comes first,
    // then the larger error.
    let s = suite(
        "accuracy",
        r#"{ type = "analytic", solution = "swinging" }"#,
    );
    let recs = vec![
        record("a", "0.1", 1.0, 1e-2, Status::Ok),
        record("a", "0.05", 8.0, 2.5e-3, Status::Ok),
        record("b", "0.1", 0.5, 1.0, failed(0.25)),
        record("b", "0.05", 4.0, 1e-3, Status::Ok),
        record("c", "0.05", 2.0, 5e-2, Status::Ok),
        record("d", "0.05", 3.0, 1.25e-2, Status::Ok),
        record("e", "0.05", 2.0, 1e-1, Status::Ok),
    ];
    let row = recommendation(&s, &recs);
    assert!(
        row.starts_with("| the job (`s`) | `a` | e(v) = 2.50e-3 at spacing = 0.05, 8.000 s |"),
        "{row}"
    );
    assert!(
        row.contains("`b`: fails at spacing = 0.1 (t = 2.50e-1 s, det F)"),
        "{row}"
    );
    assert!(
        row.contains("`c`: e(v) = 5.00e-2 at spacing = 0.05, over 10× the recommended's"),
        "{row}"
    );
    assert!(!row.contains("`d`"), "{row}");
    let at = |line: &str| row.find(&format!("`{line}`:")).expect(line);
    assert!(at("b") < at("e") && at("e") < at("c"), "{row}");
}

#[test]
fn near_equal_errors_are_decided_by_the_energy_drift() {
    // `a` is 5 % more accurate than `b` but its energy grew by 24 %: `b` is used.
    let s = suite(
        "accuracy",
        r#"{ type = "analytic", solution = "swinging" }"#,
    );
    let mut a = record("a", "0.05", 1.0, 2.10e-2, Status::Ok);
    a.drift_energy = 0.24;
    let mut b = record("b", "0.05", 2.0, 2.20e-2, Status::Ok);
    b.drift_energy = 0.04;
    let row = recommendation(&s, &[a, b]);
    assert!(row.starts_with("| the job (`s`) | `b` |"), "{row}");
}

#[test]
fn runs_to_failure_recommend_the_line_that_lasts_longest() {
    let s = suite("stability", r#"{ type = "none" }"#);
    let recs = vec![
        record("a", "0.1", 1.0, f64::NAN, failed(0.5)),
        record("b", "0.1", 1.0, f64::NAN, failed(0.9)),
        record("c", "0.1", 1.0, f64::NAN, failed(0.2)),
    ];
    let row = recommendation(&s, &recs);
    assert_eq!(
        row,
        "| the job (`s`) | `b` | lasts longest: fails at spacing = 0.1 (t = 9.00e-1 s, det \
         F) | `c`: fails at spacing = 0.1 (t = 2.00e-1 s, det F); `a`: fails at spacing = \
         0.1 (t = 5.00e-1 s, det F) |"
    );
}

#[test]
fn a_sweep_choice_recommends_the_values_stable_on_every_variant() {
    // Variants `a` and `b` are scenes; 0.1 is stable on both, 0.05 fails on `b`.
    let mut s = suite("stability", r#"{ type = "none" }"#);
    s.choice = Choice::Sweep;
    let recs = vec![
        record("a", "0.1", 1.0, f64::NAN, Status::Ok),
        record("b", "0.1", 1.0, f64::NAN, Status::Ok),
        record("a", "0.05", 1.0, f64::NAN, Status::Ok),
        record("b", "0.05", 1.0, f64::NAN, failed(0.5)),
    ];
    let row = recommendation(&s, &recs);
    assert_eq!(
        row,
        "| the job (`s`) | spacing = 0.1 | stable on all 2 variants | spacing = 0.05: fails \
         on `b` (t = 5.00e-1 s, det F) |"
    );
}

#[test]
fn stability_suites_recommend_the_line_stable_furthest_then_the_cheapest() {
    // `a` and `b` pass both values, `b` faster; `c` fails at the second value, `e`
    // at the first: listed earliest first.
    let s = suite("stability", r#"{ type = "none" }"#);
    let recs = vec![
        record("a", "0.1", 2.0, f64::NAN, Status::Ok),
        record("a", "0.05", 9.0, f64::NAN, Status::Ok),
        record("b", "0.1", 1.0, f64::NAN, Status::Ok),
        record("b", "0.05", 3.0, f64::NAN, Status::Ok),
        record("c", "0.1", 1.0, f64::NAN, Status::Ok),
        record("c", "0.05", 3.0, f64::NAN, failed(0.5)),
        record("e", "0.1", 1.0, f64::NAN, failed(0.01)),
    ];
    let row = recommendation(&s, &recs);
    assert!(
        row.starts_with(
            "| the job (`s`) | `b` | stable over the sweep (spacing to 0.05), 4.0 s in all |"
        ),
        "{row}"
    );
    let (e, c) = (
        row.find("`e`: fails at spacing = 0.1").unwrap(),
        row.find("`c`: fails at spacing = 0.05").unwrap(),
    );
    assert!(e < c, "earliest failure first: {row}");
    assert!(!row.contains("`a`"), "{row}");
}
