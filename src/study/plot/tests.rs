use super::*;

/// A finished run of suite `s` with the given error in v and P.
pub(in crate::study) fn record(
    variant: &str,
    backend: &str,
    sweep: &str,
    wall: f64,
    error: f64,
) -> RunRecord {
    RunRecord {
        id: format!("{variant}-{backend}-{sweep}"),
        suite: "s".into(),
        case: "c".into(),
        variant: variant.into(),
        backend: backend.into(),
        sweep_key: "spacing".into(),
        sweep_value: sweep.into(),
        spacing: 0.1,
        particles: 100,
        steps: 10,
        dt_last: 1e-6,
        time: 1e-5,
        wall_seconds: wall,
        error_velocity: error,
        error_stress: error,
        drift_angular_momentum: f64::NAN,
        drift_energy: f64::NAN,
        status: Status::Ok,
        reason: String::new(),
        machine: "m".into(),
        build: String::new(),
        date: String::new(),
    }
}

#[test]
fn log_axes_label_every_decade_of_the_data() {
    // (lo, hi) of data: many decades, a few, less than one across a decade, a narrow
    // band, exact decades. Tick values are compared with a relative slack of 1e-9.
    let cases = [
        (5.5e-6, 1.4),
        (2.1, 93.0),
        (0.02, 2.4),
        (8.0, 12.0),
        (5.53e-6, 5.65e-6),
        (1e-3, 1e-1),
        (3.0, 3.0),
        (0.049, 0.051),
        (2.5e-12, 7.0e3),
    ];
    let near = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-9;
    for (lo, hi) in cases {
        let a = log_axis(lo, hi);
        let msg = format!("data {lo:e}..{hi:e}: {a:?}");
        assert!(a.lo < lo && a.hi > hi, "range covers the data, {msg}");
        assert!(a.lo > lo / 10.0 / PAD && a.hi < hi * 10.0 * PAD, "{msg}");
        assert!(a.ticks.len() >= 3, "at least three labels, {msg}");
        assert!(
            near(a.ticks[0], a.lo) && near(*a.ticks.last().unwrap(), a.hi),
            "{msg}"
        );
        assert!(a.ticks.windows(2).all(|w| w[0] < w[1]), "{msg}");
        // Each tick is 1, 2 or 5 × 10^k.
        for &t in &a.ticks {
            let e = (t.log10() + 1e-9).floor();
            let m = t / 10f64.powf(e);
            assert!(
                [1.0, 2.0, 5.0].iter().any(|&k| near(m, k)),
                "tick {t:e}, {msg}"
            );
        }
        // Every decade inside the axis range carries a label.
        let first = (a.lo.log10() - 1e-9).ceil() as i32;
        let last = (a.hi.log10() + 1e-9).floor() as i32;
        for e in first..=last {
            let d = 10f64.powi(e);
            assert!(a.ticks.iter().any(|&t| near(t, d)), "decade 1e{e}, {msg}");
        }
        assert!(a.minor.iter().all(|&v| v > a.lo && v < a.hi), "{msg}");
    }
    // Two decades or more: whole decades only.
    assert_eq!(log_axis(5.5e-6, 1.4).ticks.len(), 8, "10⁻⁶ … 10¹");
}

#[test]
fn tick_labels_are_powers_of_ten_or_plain_decimals() {
    assert_eq!(tick_label(1e-5, false), "10⁻⁵");
    assert_eq!(tick_label(2e-5, false), "2×10⁻⁵");
    assert_eq!(tick_label(1e12, false), "10¹²");
    assert_eq!(tick_label(1.0, false), "10⁰");
    assert_eq!(tick_label(0.05, true), "0.05");
    assert_eq!(tick_label(0.1, true), "0.1");
    assert_eq!(tick_label(20.0, true), "20");
    assert_eq!(tick_label(1.0, true), "1");
    assert!(log_axis(0.02, 2.4).plain);
    assert!(!log_axis(5.5e-6, 1.4).plain);
}

#[test]
fn lines_are_sorted_by_wall_time() {
    let recs = [
        record("a", "cpu", "0.1", 3.0, 0.1),
        record("b", "gpu: x (y, Cpu)", "0.1", 0.5, 0.2),
        record("a", "cpu", "0.2", 1.0, 0.3),
        record("a", "cpu", "0.05", 2.0, 0.05),
        record("b", "gpu: x (y, Cpu)", "0.2", 0.25, 0.4),
        record("a", "cpu", "0.3", 1.0, 0.2),
    ];
    let points: Vec<(&RunRecord, f64, f64)> = recs
        .iter()
        .map(|r| (r, r.wall_seconds, r.error_velocity))
        .collect();
    let ls = lines(&points);
    let names: Vec<&str> = ls.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["a", "b (gpu)"]);
    let a: Vec<(f64, f64, &str)> = ls[0]
        .points
        .iter()
        .map(|(t, e, v)| (*t, *e, v.as_str()))
        .collect();
    // Equal wall times ordered by error.
    assert_eq!(
        a,
        [
            (1.0, 0.2, "0.3"),
            (1.0, 0.3, "0.2"),
            (2.0, 0.05, "0.05"),
            (3.0, 0.1, "0.1")
        ]
    );
    let b: Vec<f64> = ls[1].points.iter().map(|p| p.0).collect();
    assert_eq!(b, [0.25, 0.5]);
}

#[test]
fn timer_noise_means_all_wall_times_below_50_ms() {
    assert!(timer_noise([0.001, 0.02, 0.0499]));
    assert!(!timer_noise([0.001, 0.05]), "50 ms itself is not noise");
    assert!(!timer_noise([0.01, 3.0]), "one long run is enough");
    assert!(!timer_noise([]), "no runs, no claim");
    assert!(!timer_noise([f64::NAN]));
}

#[test]
fn labels_of_close_points_do_not_overlap() {
    // Text 7 px per character, 12 px high; markers of half-side 6 px.
    let size = |s: &str| (7.0 * s.chars().count() as f64, 12.0);
    let bounds = PixelBox {
        x0: 0.0,
        y0: 0.0,
        x1: 400.0,
        y1: 300.0,
    };
    // Three flat lines 4 px apart with points 10 px apart, six points on one spot, and
    // points at the edges.
    let mut pts: Vec<(f64, f64, String)> = Vec::new();
    for line in 0..3 {
        for i in 0..8 {
            let y = 150.0 + 4.0 * f64::from(line);
            pts.push((100.0 + 10.0 * f64::from(i), y, format!("1.{i}e-5")));
        }
    }
    for _ in 0..6 {
        pts.push((300.0, 60.0, "0.0125".into()));
    }
    pts.push((1.0, 1.0, "corner".into()));
    pts.push((399.0, 150.0, "edge".into()));
    let input: Vec<(f64, f64, &str)> = pts.iter().map(|(x, y, s)| (*x, *y, s.as_str())).collect();
    let gap = 6.0;
    let boxes = place_labels(&input, size, gap, bounds);
    assert_eq!(boxes.len(), input.len());
    let kept: Vec<PixelBox> = boxes.iter().flatten().copied().collect();
    for (i, a) in kept.iter().enumerate() {
        assert!(a.within(&bounds), "{a:?} outside");
        for b in &kept[i + 1..] {
            assert!(!a.intersects(b), "{a:?} overlaps {b:?}");
        }
        for &(x, y, _) in &input {
            let marker = PixelBox {
                x0: x - gap,
                y0: y - gap,
                x1: x + gap,
                y1: y + gap,
            };
            assert!(!a.intersects(&marker), "{a:?} covers the point ({x}, {y})");
        }
    }
    // Some labels are kept, not all.
    assert!(
        kept.len() >= 4 && kept.len() < input.len(),
        "{} kept",
        kept.len()
    );
    assert_eq!(
        boxes[24..30].iter().flatten().count(),
        4,
        "a spot has four places: above, below, right, left"
    );
    // Each kept box sits next to its own point.
    for (b, &(x, y, _)) in boxes.iter().zip(&input) {
        if let Some(b) = b {
            let (cx, cy) = ((b.x0 + b.x1) / 2.0, (b.y0 + b.y1) / 2.0);
            assert!((cx - x).abs() <= gap + 7.0 * 8.0 && (cy - y).abs() <= gap + 12.0);
        }
    }
    // Far-apart points all keep their labels.
    let sparse = [(50.0, 50.0, "a"), (200.0, 150.0, "b"), (350.0, 250.0, "c")];
    let boxes = place_labels(&sparse, size, gap, bounds);
    assert!(boxes.iter().all(Option::is_some));
}

#[test]
fn plots_of_hand_made_runs() {
    // PNG and SVG files are written; the SVG names lines, the noise note and decades.
    let suite = Suite::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/studies/swinging-plate.toml"),
    )
    .unwrap();
    let mut recs = Vec::new();
    for (k, v) in ["rl-rk4", "rkpm-rk4", "shepard-rk4"].iter().enumerate() {
        for (i, s) in ["0.1", "0.05", "0.025", "0.0125"].iter().enumerate() {
            let t = 0.02 * 4f64.powi(i as i32) * (1.0 + 0.1 * k as f64);
            let e = 0.16 / 2f64.powi(i as i32) * (1.0 + k as f64);
            recs.push(record(v, "cpu", s, t, e));
        }
    }
    for (i, s) in ["0.1", "0.05"].iter().enumerate() {
        recs.push(record(
            "rl-leapfrog",
            "gpu: a (b, Cpu)",
            s,
            0.01 + 0.01 * i as f64,
            0.2,
        ));
    }
    let dir = tempfile::tempdir().unwrap();
    // Links planted where a plot goes and at a guessable temporary name are not
    // written through: the plot replaces the first, and the target is left as it was.
    let target = dir.path().join("target.txt");
    std::fs::write(&target, "kept").unwrap();
    #[cfg(unix)]
    for planted in [
        "swinging-plate-velocity.png",
        ".swinging-plate-velocity.tmp.png",
    ] {
        std::os::unix::fs::symlink(&target, dir.path().join(planted)).unwrap();
    }
    let files = plots(&suite, &recs, dir.path()).unwrap();
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "kept");
    assert!(
        !std::fs::symlink_metadata(dir.path().join("swinging-plate-velocity.png"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(
        files
            .iter()
            .any(|f| f.ends_with("swinging-plate-velocity.png"))
    );
    let svg = std::fs::read_to_string(dir.path().join("swinging-plate-velocity.svg")).unwrap();
    for text in [
        "rkpm-rk4",
        "rl-leapfrog (gpu)",
        "timer noise",
        "Pareto front",
    ] {
        assert!(svg.contains(text), "{text} in the SVG");
    }
}
