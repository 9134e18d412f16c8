//! Error against particle spacing on log–log axes for an accuracy suite that sweeps
//! `spacing`: one line per variant and backend, each named with its observed order of
//! convergence, the least-squares slope of ln e against ln Δx over its runs.

use super::plot::{
    Metric, draw_marker, draw_path, legend_width, line_style, lines, log_axis_over, log_log_chart,
    metrics, pixel_area, plottable, register_font, styled_mesh, tick_label, write_figure,
};
use super::records::RunRecord;
use super::suite::{Suite, SuiteKind};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The observed order p of e ∝ Δx^p: the least-squares slope of ln e against ln Δx over
/// `points` (Δx, e). None with fewer than two distinct spacings.
pub fn observed_order(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points.iter().map(|&(h, e)| (h.ln(), e.ln())).collect();
    let n = logs.len() as f64;
    let (mx, my) = logs
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.0 / n, y + p.1 / n));
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 1e-12).then(|| sxy / sxx)
}

/// A line of the plot: its name with the observed order, and its (Δx, e) by spacing.
struct Ladder {
    name: String,
    points: Vec<(f64, f64)>,
}

/// The runs of `points` grouped by line (variant and backend) as the accuracy plots
/// group them ([`lines`]), with the spacing in place of the wall time: each sorted by
/// spacing and named with its observed order.
fn ladders(points: &[(&RunRecord, f64, f64)]) -> Vec<Ladder> {
    let by_spacing: Vec<(&RunRecord, f64, f64)> =
        points.iter().map(|&(r, _, e)| (r, r.spacing, e)).collect();
    lines(&by_spacing)
        .into_iter()
        .map(|line| {
            let points: Vec<(f64, f64)> = line.points.iter().map(|p| (p.0, p.1)).collect();
            let name = match observed_order(&points) {
                Some(p) => format!("{}: order {p:.2}", line.name),
                None => line.name,
            };
            Ladder { name, points }
        })
        .collect()
}

/// Writes `<suite>-<metric>-order.png` and `.svg` into `dir` for an accuracy suite whose
/// sweep is the spacing; nothing for another suite.
pub fn plots(suite: &Suite, records: &[RunRecord], dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if suite.kind != SuiteKind::Accuracy || suite.sweep.key != "spacing" {
        return Ok(files);
    }
    register_font();
    for m in metrics(suite) {
        let ladders = ladders(&plottable(suite, records, &m));
        if ladders.is_empty() {
            continue;
        }
        let title = format!("{}: {} against spacing", suite.name, m.tag);
        files.extend(write_figure(
            dir,
            &format!("{}-{}-order", suite.name, m.tag),
            |path| {
                let area = BitMapBackend::new(path, (960, 640)).into_drawing_area();
                draw(area, &title, &m, &ladders)
            },
            |path| {
                let area = SVGBackend::new(path, (960, 640)).into_drawing_area();
                draw(area, &title, &m, &ladders)
            },
        )?);
    }
    Ok(files)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    m: &Metric,
    ladders: &[Ladder],
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let all = || ladders.iter().flat_map(|l| l.points.iter());
    let xa = log_axis_over(all().map(|p| p.0));
    let ya = log_axis_over(all().map(|p| p.1));
    let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
    let (width, _) = root.dim_in_pixel();
    let font = ("sans-serif", 14).into_font();
    let legend = legend_width(&root, ladders.iter().map(|l| l.name.as_str()), &font);
    let (plot_area, legend_area) = root.split_horizontally(width.saturating_sub(legend));
    let mut chart = log_log_chart!(&plot_area, xa, ya).map_err(err)?;
    let x_label = |x: &f64| tick_label(*x, xa.plain);
    let y_label = |y: &f64| tick_label(*y, ya.plain);
    let mut mesh = chart.configure_mesh();
    styled_mesh(&mut mesh, "spacing Δx [m]", m.label, &x_label, &y_label)
        .draw()
        .map_err(err)?;
    let (area, px) = pixel_area(&chart);
    for (k, ladder) in ladders.iter().enumerate() {
        let style = line_style(k);
        let path: Vec<(i32, i32)> = ladder.points.iter().map(|p| px(p.0, p.1)).collect();
        draw_path(&area, path.clone(), &style).map_err(err)?;
        for &c in &path {
            draw_marker(&area, style.marker, c, style.colour).map_err(err)?;
        }
    }
    for (k, ladder) in ladders.iter().enumerate() {
        let (style, y) = (line_style(k), 40 + 22 * k as i32);
        draw_path(&legend_area, vec![(8, y), (48, y)], &style).map_err(err)?;
        draw_marker(&legend_area, style.marker, (28, y), style.colour).map_err(err)?;
        let text = Text::new(ladder.name.clone(), (56, y - 8), font.clone());
        legend_area.draw(&text).map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::plot::tests::record;

    #[test]
    fn the_observed_order_is_the_slope_of_a_power_law() {
        // e = 3 Δx² exactly: slope 2 to round-off; one spacing has no order.
        let points: Vec<(f64, f64)> = [0.1, 0.05, 0.025].map(|h| (h, 3.0 * h * h)).to_vec();
        let p = observed_order(&points).unwrap();
        assert!((p - 2.0).abs() < 1e-12, "{p}");
        assert_eq!(observed_order(&[(0.1, 1.0), (0.1, 2.0)]), None);
    }

    #[test]
    fn a_spacing_ladder_is_drawn_with_each_lines_order() {
        // Two variants on three spacings, errors of order 2 and 1: the SVG names each
        // with its order; a suite swept over another key draws nothing.
        let mut suite = Suite::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/studies/swinging-plate.toml"),
        )
        .unwrap();
        assert_eq!(suite.sweep.key, "spacing");
        let mut recs = Vec::new();
        for (variant, order) in [("second", 2), ("first", 1)] {
            for h in [0.1, 0.05, 0.025] {
                let mut r = record(variant, "cpu", &h.to_string(), 1.0 / h, h.powi(order));
                r.spacing = h;
                recs.push(r);
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let files = plots(&suite, &recs, dir.path()).unwrap();
        let svg = dir.path().join("swinging-plate-velocity-order.svg");
        assert!(files.contains(&svg), "{files:?}");
        let text = std::fs::read_to_string(&svg).unwrap();
        for name in ["second: order 2.00", "first: order 1.00"] {
            assert!(text.contains(name), "{name} in the SVG");
        }
        suite.sweep.key = "method.cfl".into();
        assert!(plots(&suite, &recs, dir.path()).unwrap().is_empty());
    }
}
