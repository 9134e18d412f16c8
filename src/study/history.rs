//! A suite's `[history]`: one column of every run's time series (`series.csv`) against
//! time, a line per run, on linear axes: H/H̄ of the rotating disk per method (seed 000
//! Fig. 7), the strip's neck height against extension (Fig. 9), a ring's height (Fig. 12).
//! Also written as one long CSV (`variant,backend,sweep_value,x,y`) for plotting scripts.

use super::plot::{
    draw_marker, draw_path, legend_width, line_style, pixel_area, register_font, styled_mesh,
    write_figure,
};
use super::records::{RunRecord, Status};
use super::suite::{History, Suite};
use crate::output::series::{ColumnError, read_column};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The time series of one run of a suite: its record's line name and the points.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    pub name: String,
    pub sweep_value: String,
    /// (x_scale · t, scale · column), in time order.
    pub points: Vec<(f64, f64)>,
    /// Whether the run failed (the curve ends at the failure).
    pub failed: bool,
}

/// The series file of a run.
pub fn series_file(suite_dir: &Path, id: &str) -> PathBuf {
    suite_dir.join("runs").join(id).join("series.csv")
}

/// Reads column `h.column` of a series file against its `time` column (or its
/// `x_column`), scaled.
pub fn read_series(path: &Path, h: &History) -> Result<Vec<(f64, f64)>, String> {
    let read = |column: &str, key: &str| {
        read_column(path, column).map_err(|e| match e {
            ColumnError::NoColumn { .. } => format!(
                "{e}; name one of them in the suite's [history] `{key}`, or add its observer \
                 to the case's `output.observers`"
            ),
            ColumnError::Unreadable(_) => e.to_string(),
        })
    };
    let points = read(&h.column, "column")?;
    let x: Vec<f64> = match &h.x_column {
        Some(column) => read(column, "x_column")?.into_iter().map(|p| p.1).collect(),
        None => points.iter().map(|p| p.0).collect(),
    };
    Ok(x.into_iter()
        .zip(points)
        .map(|(x, (_, c))| (h.x_scale * x, h.scale * c))
        .collect())
}

/// The curves of a suite's finished and failed runs whose series can be read; runs without
/// one (not run, or from before the series was kept) are left out, with the reason.
pub fn curves(h: &History, records: &[RunRecord], suite_dir: &Path) -> (Vec<Curve>, Vec<String>) {
    let mut curves = Vec::new();
    let mut missing = Vec::new();
    for r in records {
        let failed = matches!(r.status, Status::Failed { .. });
        if r.status != Status::Ok && !failed {
            continue;
        }
        match read_series(&series_file(suite_dir, &r.id), h) {
            Ok(points) => curves.push(Curve {
                name: r.line(),
                sweep_value: r.sweep_value.clone(),
                points: thinned(points.into_iter().filter(|p| p.1.is_finite()).collect()),
                failed,
            }),
            Err(e) => missing.push(e),
        }
    }
    (curves, missing)
}

/// The curves of a `<suite>-history.csv` as [`write`] writes it (`run,sweep_value,x,y`);
/// none when the file does not exist. A curve read back does not know whether its run
/// failed (its record does).
pub fn read_csv(path: &Path) -> std::io::Result<Vec<Curve>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    let mut curves: Vec<Curve> = Vec::new();
    for row in text.lines().skip(1) {
        // The run's name is the only field that may hold a comma: split from the right.
        let mut fields = row.rsplitn(4, ',');
        let (Some(y), Some(x), Some(value), Some(name)) =
            (fields.next(), fields.next(), fields.next(), fields.next())
        else {
            continue;
        };
        let (Ok(x), Ok(y)) = (x.parse::<f64>(), y.parse::<f64>()) else {
            continue;
        };
        match curves.last_mut() {
            Some(c) if c.name == name && c.sweep_value == value => c.points.push((x, y)),
            _ => curves.push(Curve {
                name: name.to_string(),
                sweep_value: value.to_string(),
                points: vec![(x, y)],
                failed: false,
            }),
        }
    }
    Ok(curves)
}

/// The most points of a run that its curve keeps.
const MAX_POINTS: usize = 2000;

/// A curve of at most about [`MAX_POINTS`] points: a longer series (a row at every step of
/// a long run) keeps every k-th point and its first, smallest, largest and last, so that
/// the table's values stand and the CSV and plots stay small.
fn thinned(points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if points.len() <= MAX_POINTS {
        return points;
    }
    let stride = points.len().div_ceil(MAX_POINTS);
    let by_y = |a: &(usize, &(f64, f64)), b: &(usize, &(f64, f64))| a.1.1.total_cmp(&b.1.1);
    let smallest = points.iter().enumerate().min_by(by_y).map_or(0, |p| p.0);
    let largest = points.iter().enumerate().max_by(by_y).map_or(0, |p| p.0);
    let last = points.len() - 1;
    points
        .into_iter()
        .enumerate()
        .filter(|&(k, _)| k % stride == 0 || k == smallest || k == largest || k == last)
        .map(|(_, p)| p)
        .collect()
}

/// Writes `<suite>-history.csv` and, per sweep value, `<suite>-history[-k].png/svg` into
/// `dir` from the series under `suite_dir`.
pub fn write(
    suite: &Suite,
    records: &[RunRecord],
    suite_dir: &Path,
    dir: &Path,
) -> std::io::Result<Vec<PathBuf>> {
    let Some(h) = &suite.history else {
        return Ok(Vec::new());
    };
    let (curves, missing) = curves(h, records, suite_dir);
    for m in &missing {
        eprintln!("warning: {}: history: {m}", suite.name);
    }
    let mut files = Vec::new();
    if curves.is_empty() {
        return Ok(files);
    }
    register_font();
    let csv = dir.join(format!("{}-history.csv", suite.name));
    let mut text = String::from("run,sweep_value,x,y\n");
    for c in &curves {
        for (x, y) in &c.points {
            let _ = writeln!(text, "{},{},{x:e},{y:e}", c.name, c.sweep_value);
        }
    }
    crate::output::write_atomically(&csv, |w| std::io::Write::write_all(w, text.as_bytes()))?;
    files.push(csv);
    let mut values: Vec<&str> = Vec::new();
    for c in &curves {
        if !values.contains(&c.sweep_value.as_str()) {
            values.push(&c.sweep_value);
        }
    }
    for (k, value) in values.iter().enumerate() {
        let these: Vec<&Curve> = curves.iter().filter(|c| c.sweep_value == *value).collect();
        let stem = if values.len() == 1 {
            format!("{}-history", suite.name)
        } else {
            format!("{}-history-{}", suite.name, k + 1)
        };
        let title = if values.len() == 1 {
            format!("{}: {}", suite.name, h.label)
        } else {
            format!(
                "{}: {} at {} = {value}",
                suite.name, h.label, suite.sweep.key
            )
        };
        files.extend(write_figure(
            dir,
            &stem,
            |path| {
                draw(
                    BitMapBackend::new(path, (960, 640)).into_drawing_area(),
                    &title,
                    h,
                    &these,
                )
            },
            |path| {
                draw(
                    SVGBackend::new(path, (960, 640)).into_drawing_area(),
                    &title,
                    h,
                    &these,
                )
            },
        )?);
    }
    Ok(files)
}

/// A Markdown table of the history of every run: its value at the start, its smallest and
/// largest, and its last (at the end, or at the failure), with the x of the last. `folder`
/// is the path of the history CSV's folder relative to the Markdown file (`study/`, or empty).
pub fn table(suite: &Suite, records: &[RunRecord], suite_dir: &Path, folder: &str) -> String {
    let Some(h) = &suite.history else {
        return String::new();
    };
    if !h.at.is_empty() {
        return at_table(suite, h, records, suite_dir, folder);
    }
    let (curves, _) = curves(h, records, suite_dir);
    if curves.is_empty() {
        return String::new();
    }
    let g = |v: f64| format!("{v:.5}");
    let mut s = format!(
        "{} per run ([`{}-history.csv`]({folder}{}-history.csv) has the points, at most \
         about 2000 per run):\n\n\
         | run | {} | first | min | max | last | at {} |\n|---|---|---|---|---|---|---|\n",
        h.label, suite.name, suite.name, suite.sweep.key, h.x_label
    );
    for c in &curves {
        let ys = || c.points.iter().map(|p| p.1);
        let (Some(first), Some(last)) = (c.points.first(), c.points.last()) else {
            continue;
        };
        let _ = writeln!(
            s,
            "| {}{} | {} | {} | {} | {} | {} | {} |",
            c.name,
            if c.failed { " (failed)" } else { "" },
            c.sweep_value,
            g(first.1),
            g(ys().fold(f64::INFINITY, f64::min)),
            g(ys().fold(f64::NEG_INFINITY, f64::max)),
            g(last.1),
            g(last.0)
        );
    }
    s + "\n"
}

/// A Markdown table of the history at its `at` times, per run, each beside the variant's
/// published value, with the run's particles, steps and wall time.
fn at_table(
    suite: &Suite,
    h: &History,
    records: &[RunRecord],
    suite_dir: &Path,
    folder: &str,
) -> String {
    let mut head = format!("| run | {} | particles | steps |", suite.sweep.key);
    let mut rule = String::from("|---|---|---|---|");
    for &t in &h.at {
        let _ = write!(head, " at {} = {} |", h.x_label, significant(h.x_scale * t));
        rule += "---|";
        if h.published.is_some() {
            head += " published |";
            rule += "---|";
        }
    }
    head += " wall [s] |";
    rule += "---|";
    let mut rows = String::new();
    for r in records {
        let failed = matches!(r.status, Status::Failed { .. });
        if r.status != Status::Ok && !failed {
            continue;
        }
        let Ok(points) = read_series(&series_file(suite_dir, &r.id), h) else {
            continue;
        };
        let published = suite
            .variants
            .iter()
            .find(|v| v.name == r.variant)
            .map_or(&[][..], |v| v.published.as_slice());
        let _ = write!(
            rows,
            "| {}{} | {} | {} | {} |",
            r.line(),
            if failed { " (failed)" } else { "" },
            r.sweep_value,
            r.particles,
            r.steps
        );
        for (k, &t) in h.at.iter().enumerate() {
            let _ = write!(rows, " {} |", significant(value_at(&points, h.x_scale * t)));
            if h.published.is_some() {
                let paper = published.get(k).map_or(String::new(), |&v| significant(v));
                let _ = write!(rows, " {paper} |");
            }
        }
        let _ = writeln!(rows, " {:.1} |", r.wall_seconds);
    }
    if rows.is_empty() {
        return String::new();
    }
    let source = h
        .published
        .as_ref()
        .map(|p| format!(", beside the published values ({p})"))
        .unwrap_or_default();
    format!(
        "{} per run at {} = {}{source} ([`{}-history.csv`]({folder}{}-history.csv) has every \
         point; – where the run did not reach the time):\n\n{head}\n{rule}\n{rows}\n",
        h.label,
        h.x_label,
        h.at.iter()
            .map(|&t| significant(h.x_scale * t))
            .collect::<Vec<_>>()
            .join(" and "),
        suite.name,
        suite.name
    )
}

/// The series' value at x, linear between the points around it; NaN outside them (beyond
/// round-off of the last point's x).
pub fn value_at(points: &[(f64, f64)], x: f64) -> f64 {
    let tolerance = 1e-9 * x.abs().max(f64::MIN_POSITIVE);
    for w in points.windows(2) {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        if x0 <= x && x <= x1 && x1 > x0 {
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0);
        }
    }
    match points.last() {
        Some(&(xl, yl)) if (xl - x).abs() <= tolerance => yl,
        _ => f64::NAN,
    }
}

/// Four significant digits ("0.05026", "11.56"), – for NaN.
pub(crate) fn significant(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let decimals = (3.0 - v.abs().log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// A linear axis over `lo..=hi` widened to whole steps of 1, 2 or 5 × 10^k, about five to
/// ten of them: (start, end, step).
pub fn linear_axis(lo: f64, hi: f64) -> (f64, f64, f64) {
    let span = if hi > lo {
        hi - lo
    } else {
        lo.abs().max(1e-12) * 0.1
    };
    let raw = span / 6.0;
    let decade = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|s| span / s <= 10.0)
        .unwrap_or(10.0 * decade);
    // Round-off in the products may leave an end a hair inside the data: widen by a step.
    let a = (lo / step).floor() * step;
    let a = if a > lo { a - step } else { a };
    let b = (hi / step).ceil() * step;
    let b = if b < hi { b + step } else { b };
    if b > a {
        (a, b, step)
    } else {
        (a - step, b + step, step)
    }
}

/// A tick label with as many decimals as the step needs (no `-0.0`).
pub fn tick(v: f64, step: f64) -> String {
    let decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
    let text = format!("{v:.decimals$}");
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    h: &History,
    curves: &[&Curve],
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let all = || curves.iter().flat_map(|c| c.points.iter());
    let fold = |f: fn(&(f64, f64)) -> f64| {
        all()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let (x_lo, x_hi, x_step) = linear_axis(fold(|p| p.0).0, fold(|p| p.0).1);
    let (y_lo, y_hi, y_step) = linear_axis(fold(|p| p.1).0, fold(|p| p.1).1);
    let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
    let (width, _) = root.dim_in_pixel();
    let font = ("sans-serif", 14).into_font();
    let names: Vec<String> = curves
        .iter()
        .map(|c| {
            if c.failed {
                format!("{} (failed, ×)", c.name)
            } else {
                c.name.clone()
            }
        })
        .collect();
    let legend = legend_width(&root, names.iter().map(String::as_str), &font);
    let (plot_area, legend_area) = root.split_horizontally(width.saturating_sub(legend));
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(x_lo..x_hi, y_lo..y_hi)
        .map_err(err)?;
    let (x_label, y_label) = (|v: &f64| tick(*v, x_step), |v: &f64| tick(*v, y_step));
    styled_mesh(
        &mut chart.configure_mesh(),
        &h.x_label,
        &h.label,
        &x_label,
        &y_label,
    )
    .draw()
    .map_err(err)?;
    let (area, px) = pixel_area(&chart);
    // Markers every ~1/12 of the x range, so that dense series stay lines.
    let every = (x_hi - x_lo) / 12.0;
    let mut y = 40;
    for (k, c) in curves.iter().enumerate() {
        let style = line_style(k);
        let path: Vec<(i32, i32)> = c.points.iter().map(|p| px(p.0, p.1)).collect();
        draw_path(&area, path, &style).map_err(err)?;
        let mut next = f64::NEG_INFINITY;
        for (i, p) in c.points.iter().enumerate() {
            let last = i + 1 == c.points.len();
            if p.0 >= next || last {
                let marker = if last && c.failed {
                    super::plot::Marker::Cross
                } else {
                    style.marker
                };
                draw_marker(&area, marker, px(p.0, p.1), style.colour).map_err(err)?;
                next = p.0 + every;
            }
        }
        draw_path(&legend_area, vec![(8, y), (48, y)], &style).map_err(err)?;
        draw_marker(&legend_area, style.marker, (28, y), style.colour).map_err(err)?;
        legend_area
            .draw(&Text::new(names[k].as_str(), (56, y - 8), font.clone()))
            .map_err(err)?;
        y += 22;
    }
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_series_is_thinned_keeping_its_first_extremes_and_last() {
        // 10,001 points of a sine with its minimum and maximum off the stride: at most
        // MAX_POINTS + 3 remain, in order, the four values the table shows among them.
        let points: Vec<(f64, f64)> = (0..=10_000)
            .map(|k| (k as f64, (k as f64 * 0.001_3 + 0.3).sin()))
            .collect();
        let kept = thinned(points.clone());
        assert!(kept.len() <= MAX_POINTS + 3, "{}", kept.len());
        assert!(kept.windows(2).all(|w| w[0].0 < w[1].0));
        let y = |p: &[(f64, f64)], f: fn(f64, f64) -> f64, init: f64| {
            p.iter().map(|q| q.1).fold(init, f)
        };
        assert_eq!(kept[0], points[0]);
        assert_eq!(kept.last(), points.last());
        assert_eq!(
            y(&kept, f64::min, f64::INFINITY),
            y(&points, f64::min, f64::INFINITY)
        );
        assert_eq!(
            y(&kept, f64::max, f64::NEG_INFINITY),
            y(&points, f64::max, f64::NEG_INFINITY)
        );
        // A short series is kept whole.
        assert_eq!(thinned(points[..MAX_POINTS].to_vec()), points[..MAX_POINTS]);
    }

    #[test]
    fn linear_axes_cover_the_data_in_round_steps() {
        for (lo, hi) in [
            (0.0, 0.15),
            (0.9468, 0.9475),
            (-3.0, 7.0),
            (2.0, 2.0),
            (77.0, 78.0),
        ] {
            let (a, b, step) = linear_axis(lo, hi);
            assert!(((b - a) / step - ((b - a) / step).round()).abs() < 1e-6);
            assert!(a <= lo && b >= hi && b > a, "({lo}, {hi}) → ({a}, {b})");
            // At most 11 steps of the chosen size over the range: not wider than needed
            // by more than a step on each side.
            assert!(
                (b - a) <= 4.0 * (hi - lo).max(lo.abs() * 0.1),
                "({lo}, {hi}) → ({a}, {b})"
            );
        }
    }

    #[test]
    fn tick_labels_carry_the_decimals_of_the_step() {
        assert_eq!(tick(-0.0, 0.2), "0.0");
        assert_eq!(tick(-1e-17, 0.05), "0.00");
        assert_eq!(tick(0.9472, 1e-4), "0.9472");
        assert_eq!(tick(-0.4, 0.2), "-0.4");
        assert_eq!(tick(300.0, 50.0), "300");
    }

    #[test]
    fn values_at_given_times_are_interpolated_between_rows() {
        let points = [(0.0, 1.0), (2.0, 3.0), (4.0, 0.0)];
        assert_eq!(value_at(&points, 1.0), 2.0);
        assert_eq!(value_at(&points, 2.0), 3.0);
        assert_eq!(value_at(&points, 3.0), 1.5);
        // The last row answers for its own time up to round-off, nothing beyond it.
        assert_eq!(value_at(&points, 4.0 * (1.0 + 1e-12)), 0.0);
        assert!(value_at(&points, 4.1).is_nan());
        assert!(value_at(&points, -0.1).is_nan());
        assert!(value_at(&[], 1.0).is_nan());
    }

    #[test]
    fn tabulated_values_keep_four_significant_digits() {
        assert_eq!(significant(0.05026), "0.05026");
        assert_eq!(significant(0.006817), "0.006817");
        assert_eq!(significant(11.563), "11.56");
        assert_eq!(significant(1234.5), "1234");
        assert_eq!(significant(f64::NAN), "–");
    }

    #[test]
    fn a_series_column_is_read_and_scaled_and_a_missing_one_is_named() {
        let dir = std::env::temp_dir().join(format!("meshless-history-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("series.csv");
        std::fs::write(
            &path,
            "time,step,dt,neck_height,grip.ux\n0,0,1e-6,1.0,0\n0.01,10,1e-6,0.8,0.003\n",
        )
        .unwrap();
        let h = History {
            column: "neck_height".into(),
            label: "l/l0".into(),
            scale: 2.0,
            x_label: "extension [%]".into(),
            x_scale: 2000.0,
            x_column: None,
            at: Vec::new(),
            published: None,
        };
        assert_eq!(
            read_series(&path, &h).unwrap(),
            vec![(0.0, 2.0), (20.0, 1.6)]
        );
        // Against another column: x = x_scale · grip.ux.
        let against = History {
            x_column: Some("grip.ux".into()),
            x_scale: 1000.0,
            ..h.clone()
        };
        assert_eq!(
            read_series(&path, &against).unwrap(),
            vec![(0.0, 2.0), (3.0, 1.6)]
        );
        let wrong = History {
            column: "left.extent_y".into(),
            ..h
        };
        let e = read_series(&path, &wrong).unwrap_err();
        assert!(
            e.contains("left.extent_y") && e.contains("neck_height"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
