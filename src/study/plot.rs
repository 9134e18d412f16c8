//! Error against wall time on log–log axes, one line per variant and backend, the Pareto
//! front marked; PNG and SVG with `plotters` (labels in the bundled DejaVu Sans, so no
//! system font is needed).

use super::records::{RunRecord, Status};
use super::suite::{InvariantKind, Reference, Suite, SuiteKind};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_err() {
            eprintln!("warning: the bundled plot font does not load; plots have no labels");
        }
    });
}

/// An error measure of a suite: file-name tag, axis label and the value of a record.
pub struct Metric {
    pub tag: &'static str,
    /// Short symbol for tables (`e(v)`, `ΔH/H0`).
    pub symbol: &'static str,
    pub label: &'static str,
    pub value: fn(&RunRecord) -> f64,
}

/// The measures a suite reports (its first is the headline).
pub fn metrics(suite: &Suite) -> Vec<Metric> {
    match &suite.reference {
        Reference::Analytic { .. } | Reference::Converged { .. } => vec![
            Metric {
                tag: "velocity",
                symbol: "e(v)",
                label: "relative L2 error of v at the end",
                value: |r| r.error_velocity,
            },
            Metric {
                tag: "stress",
                symbol: "e(P)",
                label: "relative L2 error of P at the end",
                value: |r| r.error_stress,
            },
        ],
        Reference::Invariant {
            quantity: InvariantKind::AngularMomentum,
        } => vec![Metric {
            tag: "angular-momentum",
            symbol: "ΔH/H0",
            label: "max |H(t)/H(0) - 1| over the run",
            value: |r| r.drift_angular_momentum,
        }],
        Reference::Invariant {
            quantity: InvariantKind::Energy,
        } => vec![Metric {
            tag: "energy",
            symbol: "ΔE/E0",
            label: "max |E(t) - W(t) - E(0)| / max(E(0), |W|)",
            value: |r| r.drift_energy,
        }],
        Reference::None => Vec::new(),
    }
}

/// Indices of the records on the Pareto front of (wall time, error): no other point is
/// at least as fast and at least as accurate and better in one of them.
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| {
            let (t, e) = points[i];
            !points
                .iter()
                .any(|&(t2, e2)| t2 <= t && e2 <= e && (t2 < t || e2 < e))
        })
        .collect();
    front.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0));
    front
}

/// Points of a metric that can go on log axes: finished runs with a positive error. With
/// a converged reference, runs at the reference's own sweep value are left out: they share
/// its resolution and measure only the other options' difference from it.
pub fn plottable<'a>(
    suite: &Suite,
    records: &'a [RunRecord],
    m: &Metric,
) -> Vec<(&'a RunRecord, f64, f64)> {
    let reference = suite.reference_value().map(|(_, v)| v);
    records
        .iter()
        .filter(|r| r.status == Status::Ok)
        .filter(|r| reference.as_ref() != Some(&r.sweep_value))
        .map(|r| (r, r.wall_seconds, (m.value)(r)))
        .filter(|&(_, t, e)| t > 0.0 && e > 0.0 && t.is_finite() && e.is_finite())
        .collect()
}

/// Writes `<suite>-<metric>.png` and `.svg` into `dir` for an accuracy suite.
pub fn plots(suite: &Suite, records: &[RunRecord], dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if suite.kind != SuiteKind::Accuracy {
        return Ok(files);
    }
    register_font();
    for m in metrics(suite) {
        let points = plottable(suite, records, &m);
        if points.is_empty() {
            continue;
        }
        let title = format!(
            "{}: {} against wall time (points labelled by {})",
            suite.name, m.tag, suite.sweep.key
        );
        for ext in ["png", "svg"] {
            let path = dir.join(format!("{}-{}.{ext}", suite.name, m.tag));
            let tmp = dir.join(format!(".{}-{}.tmp.{ext}", suite.name, m.tag));
            let result = if ext == "png" {
                draw(
                    BitMapBackend::new(&tmp, (960, 640)).into_drawing_area(),
                    &title,
                    &m,
                    &points,
                )
            } else {
                draw(
                    SVGBackend::new(&tmp, (960, 640)).into_drawing_area(),
                    &title,
                    &m,
                    &points,
                )
            };
            result.map_err(|e| std::io::Error::other(format!("{}: {e}", path.display())))?;
            std::fs::rename(&tmp, &path)?;
            files.push(path);
        }
    }
    Ok(files)
}

const COLOURS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    m: &Metric,
    points: &[(&RunRecord, f64, f64)],
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let range = |v: Vec<f64>| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (lo, hi) = if hi > lo * 1.5 {
            (lo, hi)
        } else {
            (lo / 1.5, hi * 1.5)
        };
        (lo / 1.4)..(hi * 1.4)
    };
    let xr = range(points.iter().map(|p| p.1).collect());
    let yr = range(points.iter().map(|p| p.2).collect());
    // The legend goes in a column right of the chart, never over the points.
    let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
    let (width, _) = root.dim_in_pixel();
    let (plot_area, legend_area) = root.split_horizontally(width.saturating_sub(230));
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(xr.log_scale(), yr.log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("wall time [s] (set-up + time loop)")
        .y_desc(m.label)
        .x_labels(8)
        .y_labels(10)
        .x_label_formatter(&|x| format!("{x:.1e}"))
        .y_label_formatter(&|y| format!("{y:.1e}"))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(err)?;

    let mut lines: Vec<String> = Vec::new();
    for (r, _, _) in points {
        if !lines.contains(&r.line()) {
            lines.push(r.line());
        }
    }
    for (k, line) in lines.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let mut pts: Vec<(f64, f64)> = points
            .iter()
            .filter(|(r, _, _)| &r.line() == line)
            .map(|&(_, t, e)| (t, e))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
            .map_err(err)?;
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 4, colour.filled())))
            .map_err(err)?;
    }
    let coords: Vec<(f64, f64)> = points.iter().map(|&(_, t, e)| (t, e)).collect();
    let front: Vec<(f64, f64)> = pareto(&coords).into_iter().map(|i| coords[i]).collect();
    chart
        .draw_series(DashedLineSeries::new(
            front.clone(),
            6u32,
            4u32,
            BLACK.stroke_width(1),
        ))
        .map_err(err)?;
    chart
        .draw_series(
            front
                .iter()
                .map(|&p| Circle::new(p, 8, BLACK.stroke_width(2))),
        )
        .map_err(err)?;
    // The sweep value next to each point.
    chart
        .draw_series(points.iter().map(|&(r, t, e)| {
            Text::new(
                format!(" {}", r.sweep_value),
                (t, e),
                ("sans-serif", 11).into_font().color(&RGBColor(90, 90, 90)),
            )
        }))
        .map_err(err)?;
    let font = ("sans-serif", 13).into_font();
    let row = |k: usize| 40 + 22 * k as i32;
    for (k, line) in lines.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let y = row(k);
        legend_area
            .draw(&PathElement::new(
                vec![(10, y), (34, y)],
                colour.stroke_width(2),
            ))
            .map_err(err)?;
        legend_area
            .draw(&Circle::new((22, y), 4, colour.filled()))
            .map_err(err)?;
        legend_area
            .draw(&Text::new(line.clone(), (40, y - 7), font.clone()))
            .map_err(err)?;
    }
    let y = row(lines.len());
    legend_area
        .draw(&Circle::new((22, y), 8, BLACK.stroke_width(2)))
        .map_err(err)?;
    legend_area
        .draw(&Text::new("Pareto front", (40, y - 7), font.clone()))
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}
