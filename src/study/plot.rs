//! Error against wall time on log–log axes, one line per variant and backend, the Pareto
//! front marked; PNG and SVG with `plotters` (labels in the bundled DejaVu Sans, so no
//! system font is needed).
//!
//! Axes run over whole decades (or 1-2-5 steps on a short axis) and label every decade.
//! Lines differ in marker and dash as well as colour, so a greyscale print tells them
//! apart; each point carries its sweep value where the label has room; wall times below
//! 50 ms are shaded as timer noise.

use super::records::{RunRecord, Status};
use super::suite::{InvariantKind, Reference, Suite, SuiteKind};
use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

pub(super) fn register_font() {
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
            symbol: "R/S",
            label: "max |R(t)| / S(t), the energy balance's residue",
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

/// Writes `<suite>-<metric>.png` and `.svg` into `dir` for an accuracy suite, and on a
/// spacing ladder the error against the spacing ([`super::convergence`]).
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
        files.extend(write_figure(
            dir,
            &format!("{}-{}", suite.name, m.tag),
            |path| {
                draw(
                    BitMapBackend::new(path, (960, 640)).into_drawing_area(),
                    &title,
                    &m,
                    &points,
                )
            },
            |path| {
                draw(
                    SVGBackend::new(path, (960, 640)).into_drawing_area(),
                    &title,
                    &m,
                    &points,
                )
            },
        )?);
    }
    files.extend(super::convergence::plots(suite, records, dir)?);
    Ok(files)
}

/// Draws a figure into the file at a path.
type Draw<'a> = dyn FnOnce(&Path) -> Result<(), String> + 'a;

/// Writes `<stem>.png` and `<stem>.svg` into `dir`, each drawn by its function into a
/// fresh temporary file of this process (never a link planted in the folder), which the
/// backend overwrites by name, then renamed into place.
pub(super) fn write_figure(
    dir: &Path,
    stem: &str,
    png: impl FnOnce(&Path) -> Result<(), String>,
    svg: impl FnOnce(&Path) -> Result<(), String>,
) -> std::io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let draws: [(&str, Box<Draw<'_>>); 2] = [("png", Box::new(png)), ("svg", Box::new(svg))];
    for (ext, draw) in draws {
        let path = dir.join(format!("{stem}.{ext}"));
        let (file, tmp) = crate::output::create_temporary_with(&path, &format!(".{ext}"))?;
        drop(file);
        if let Err(e) = draw(&tmp) {
            let _ = std::fs::remove_file(&tmp);
            return Err(std::io::Error::other(format!("{}: {e}", path.display())));
        }
        std::fs::rename(&tmp, &path)?;
        files.push(path);
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

/// Wall times below this [s] are dominated by timer and start-up noise.
pub const NOISE_SECONDS: f64 = 0.05;

/// Shade of the wall times below [`NOISE_SECONDS`].
const NOISE_SHADE: RGBAColor = RGBAColor(0, 0, 0, 0.06);

/// The grey of the chart's notes and sweep labels.
const GREY: RGBColor = RGBColor(90, 90, 90);

/// Whether a line's wall times are all below [`NOISE_SECONDS`], so that their
/// differences say nothing about speed.
pub fn timer_noise(wall_seconds: impl IntoIterator<Item = f64>) -> bool {
    let mut any = false;
    for t in wall_seconds {
        if t.is_nan() || t >= NOISE_SECONDS {
            return false;
        }
        any = true;
    }
    any
}

/// One line of a plot: the runs of one variant on one backend.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Variant, with the backend when it is not the CPU ([`RunRecord::line`]).
    pub name: String,
    /// (wall time, error, sweep value), by increasing wall time.
    pub points: Vec<(f64, f64, String)>,
}

/// Groups plottable points into lines, in order of first appearance, each sorted by wall
/// time (ties by error) so that no line runs backwards.
pub fn lines(points: &[(&RunRecord, f64, f64)]) -> Vec<Line> {
    let mut out: Vec<Line> = Vec::new();
    for &(r, t, e) in points {
        let name = r.line();
        let point = (t, e, r.sweep_value.clone());
        match out.iter_mut().find(|l| l.name == name) {
            Some(l) => l.points.push(point),
            None => out.push(Line {
                name,
                points: vec![point],
            }),
        }
    }
    for l in &mut out {
        l.points
            .sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    }
    out
}

/// The width of the legend column right of a chart: the widest of `labels` after the
/// 56-pixel line sample, at least 250 pixels and at most half the figure.
pub(super) fn legend_width<'a, DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    labels: impl Iterator<Item = &'a str>,
    font: &FontDesc,
) -> u32 {
    let (width, _) = root.dim_in_pixel();
    let style = TextStyle::from(font.clone());
    let widest = labels
        .filter_map(|l| root.estimate_text_size(l, &style).ok())
        .map(|(w, _)| w)
        .max()
        .unwrap_or(0);
    (widest + 64).clamp(250, (width / 2).max(250))
}

/// A logarithmic axis: its range and the values that carry a label.
#[derive(Clone, Debug, PartialEq)]
pub struct LogAxis {
    pub lo: f64,
    pub hi: f64,
    /// Labelled values, increasing: whole decades, or 1-2-5 steps on a short axis.
    pub ticks: Vec<f64>,
    /// Unlabelled grid values (2…9 × 10^k) on an axis of a few decades.
    pub minor: Vec<f64>,
    /// Labels as plain decimals (all ticks within 0.01…5000) instead of powers of ten.
    pub plain: bool,
}

/// The n-th value of the 1-2-5 sequence: …, 0.5, 1, 2, 5, 10, … (index 0 is 1).
fn step_125(n: i64) -> (u32, i32) {
    ([1, 2, 5][n.rem_euclid(3) as usize], n.div_euclid(3) as i32)
}

fn value(mantissa: u32, exponent: i32) -> f64 {
    f64::from(mantissa) * 10f64.powi(exponent)
}

fn value_125(n: i64) -> f64 {
    let (m, e) = step_125(n);
    value(m, e)
}

/// Relative slack when comparing a data value with a tick value.
const SNAP: f64 = 1e-9;

/// Data within this factor of an axis end is moved inwards, off the frame.
const PAD: f64 = 1.08;

/// The [`LogAxis`] over the values of `v`, from their smallest to their largest.
pub(super) fn log_axis_over(v: impl Iterator<Item = f64>) -> LogAxis {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    log_axis(lo, hi)
}

/// A chart on a drawing area with logarithmic axes over two [`LogAxis`], their labelled
/// values as key points and the others as light grid lines.
macro_rules! log_log_chart {
    ($area:expr, $xa:expr, $ya:expr) => {
        ChartBuilder::on($area)
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(78)
            .build_cartesian_2d(
                ($xa.lo..$xa.hi)
                    .log_scale()
                    .with_key_points($xa.ticks.clone())
                    .with_light_points($xa.minor.clone()),
                ($ya.lo..$ya.hi)
                    .log_scale()
                    .with_key_points($ya.ticks.clone())
                    .with_light_points($ya.minor.clone()),
            )
    };
}
pub(super) use log_log_chart;

/// The axis for data in `lo..=hi` (both positive): whole decades around the data when it
/// spans two decades or more, else 1-2-5 steps around it with at least three of them
/// labelled.
pub fn log_axis(lo: f64, hi: f64) -> LogAxis {
    let (lo, hi) = (lo.min(hi) / PAD, hi.max(lo) * PAD);
    let d_lo = (lo.log10() + SNAP).floor() as i32;
    let d_hi = (hi.log10() - SNAP).ceil() as i32;
    let ticks: Vec<f64> = if hi / lo >= 100.0 {
        (d_lo..=d_hi).map(|e| value(1, e)).collect()
    } else {
        let mut a = 3 * i64::from(d_lo);
        while value_125(a + 1) <= lo * (1.0 + SNAP) {
            a += 1;
        }
        let mut b = 3 * i64::from(d_hi);
        while value_125(b - 1) >= hi * (1.0 - SNAP) {
            b -= 1;
        }
        while b - a < 2 {
            // Widen on the side where the data is nearer the end.
            if (lo / value_125(a)).ln() < (value_125(b) / hi).ln() {
                a -= 1;
            } else {
                b += 1;
            }
        }
        (a..=b).map(value_125).collect()
    };
    let (lo, hi) = (ticks[0], ticks[ticks.len() - 1]);
    let decades = (hi / lo).log10().round() as i32;
    let minor = if decades <= 5 {
        (d_lo..d_hi)
            .flat_map(|e| (2..10).map(move |m| value(m, e)))
            .filter(|&v| v > lo && v < hi)
            .filter(|v| !ticks.iter().any(|t| (t / v - 1.0).abs() < SNAP))
            .collect()
    } else {
        Vec::new()
    };
    let plain = ticks
        .iter()
        .all(|&t| (0.01 * (1.0 - SNAP)..=5000.0).contains(&t));
    LogAxis {
        lo,
        hi,
        ticks,
        minor,
        plain,
    }
}

/// Superscript form of an integer exponent.
fn superscript(e: i32) -> String {
    e.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'][d as usize - '0' as usize],
        })
        .collect()
}

/// The label of a tick value m × 10^e: `10⁻⁵`, `2×10⁻⁵`, or as a plain decimal (`0.05`, `20`).
pub fn tick_label(v: f64, plain: bool) -> String {
    let e = (v.log10() + SNAP).floor() as i32;
    let m = (v / 10f64.powi(e)).round() as u32;
    if plain {
        if e >= 0 {
            format!("{m}{}", "0".repeat(e as usize))
        } else {
            format!("0.{}{m}", "0".repeat((-e - 1) as usize))
        }
    } else if m == 1 {
        format!("10{}", superscript(e))
    } else {
        format!("{m}×10{}", superscript(e))
    }
}

/// A box in pixels: left, top, right, bottom (y downwards).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelBox {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl PixelBox {
    /// Whether the two boxes share interior (touching edges do not count).
    pub fn intersects(&self, o: &PixelBox) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    fn within(&self, o: &PixelBox) -> bool {
        self.x0 >= o.x0 && self.y0 >= o.y0 && self.x1 <= o.x1 && self.y1 <= o.y1
    }
}

/// Places the labels of points (x, y, text) in pixels: each label goes above, below, right
/// or left of its point, `gap` pixels from its centre, at the first of these places whose
/// box stays inside `bounds` and meets neither a label placed before it nor a marker (a
/// square of half-side `gap` around every point). A label with no such place is left out
/// (`None`). `size` gives a text's width and height.
pub fn place_labels(
    points: &[(f64, f64, &str)],
    size: impl Fn(&str) -> (f64, f64),
    gap: f64,
    bounds: PixelBox,
) -> Vec<Option<PixelBox>> {
    let markers: Vec<PixelBox> = points
        .iter()
        .map(|&(x, y, _)| PixelBox {
            x0: x - gap,
            y0: y - gap,
            x1: x + gap,
            y1: y + gap,
        })
        .collect();
    let mut placed: Vec<PixelBox> = Vec::new();
    points
        .iter()
        .map(|&(x, y, text)| {
            let (w, h) = size(text);
            let at = |x0: f64, y0: f64| PixelBox {
                x0,
                y0,
                x1: x0 + w,
                y1: y0 + h,
            };
            let candidates = [
                at(x - w / 2.0, y - gap - h),
                at(x - w / 2.0, y + gap),
                at(x + gap, y - h / 2.0),
                at(x - gap - w, y - h / 2.0),
            ];
            let free = candidates.into_iter().find(|b| {
                b.within(&bounds)
                    && !placed.iter().any(|p| p.intersects(b))
                    && !markers.iter().any(|m| m.intersects(b))
            });
            if let Some(b) = free {
                placed.push(b);
            }
            free
        })
        .collect()
}

/// Marker shapes, in the order lines take them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Marker {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
    Cross,
    Plus,
    OpenSquare,
}

const MARKERS: [Marker; 8] = [
    Marker::Circle,
    Marker::Square,
    Marker::TriangleUp,
    Marker::Diamond,
    Marker::TriangleDown,
    Marker::Cross,
    Marker::Plus,
    Marker::OpenSquare,
];

/// Dash patterns (dash, gap in pixels; `None` solid), in the order lines take them. Three
/// patterns against eight markers: 24 lines before a marker and pattern pair repeats.
const DASHES: [Option<(u32, u32)>; 3] = [None, Some((10, 5)), Some((3, 4))];

/// How line `k` is drawn.
#[derive(Clone, Copy, Debug)]
pub(super) struct LineStyle {
    pub colour: RGBColor,
    pub marker: Marker,
    dash: Option<(u32, u32)>,
}

pub(super) fn line_style(k: usize) -> LineStyle {
    LineStyle {
        colour: COLOURS[k % COLOURS.len()],
        marker: MARKERS[k % MARKERS.len()],
        dash: DASHES[k % DASHES.len()],
    }
}

/// Marker radius in pixels.
const MARKER: i32 = 5;

/// Draws a marker centred at pixel `c` of `area`.
pub(super) fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    marker: Marker,
    c: (i32, i32),
    colour: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (x, y) = c;
    let r = MARKER;
    let s = r - 1;
    let fill = colour.filled();
    let stroke = colour.stroke_width(2);
    match marker {
        Marker::Circle => area.draw(&Circle::new(c, r, fill)),
        Marker::Square => area.draw(&Rectangle::new([(x - s, y - s), (x + s, y + s)], fill)),
        Marker::OpenSquare => {
            area.draw(&Rectangle::new(
                [(x - s, y - s), (x + s, y + s)],
                WHITE.filled(),
            ))?;
            area.draw(&Rectangle::new([(x - s, y - s), (x + s, y + s)], stroke))
        }
        Marker::TriangleUp => area.draw(&Polygon::new(
            vec![
                (x, y - r - 1),
                (x + r + 1, y + r - 1),
                (x - r - 1, y + r - 1),
            ],
            fill,
        )),
        Marker::TriangleDown => area.draw(&Polygon::new(
            vec![
                (x, y + r + 1),
                (x + r + 1, y - r + 1),
                (x - r - 1, y - r + 1),
            ],
            fill,
        )),
        Marker::Diamond => area.draw(&Polygon::new(
            vec![
                (x, y - r - 1),
                (x + r + 1, y),
                (x, y + r + 1),
                (x - r - 1, y),
            ],
            fill,
        )),
        Marker::Cross => {
            area.draw(&PathElement::new(
                vec![(x - s, y - s), (x + s, y + s)],
                stroke,
            ))?;
            area.draw(&PathElement::new(
                vec![(x - s, y + s), (x + s, y - s)],
                stroke,
            ))
        }
        Marker::Plus => {
            area.draw(&PathElement::new(vec![(x - r, y), (x + r, y)], stroke))?;
            area.draw(&PathElement::new(vec![(x, y - r), (x, y + r)], stroke))
        }
    }
}

/// The grid, fonts, axis descriptions and tick labels of the study's charts.
pub(super) fn styled_mesh<'m, 'a, 'b, X: Ranged, Y: Ranged, DB: DrawingBackend>(
    mesh: &'m mut MeshStyle<'a, 'b, X, Y, DB>,
    x_desc: &str,
    y_desc: &str,
    x_label: &'b dyn Fn(&X::ValueType) -> String,
    y_label: &'b dyn Fn(&Y::ValueType) -> String,
) -> &'m mut MeshStyle<'a, 'b, X, Y, DB> {
    mesh.x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(x_label)
        .y_label_formatter(y_label)
        .bold_line_style(RGBColor(190, 190, 190))
        .light_line_style(RGBColor(235, 235, 235))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 16))
}

/// The plotting area of `chart` on its own, with the map from a point (x, y) of the
/// chart's coordinates to the area's pixels.
pub(super) fn pixel_area<'c, DB, X, Y>(
    chart: &'c ChartContext<'_, DB, Cartesian2d<X, Y>>,
) -> (DrawingArea<DB, Shift>, impl Fn(f64, f64) -> (i32, i32) + 'c)
where
    DB: DrawingBackend,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let area = chart.plotting_area().strip_coord_spec();
    let base = area.get_base_pixel();
    let px = move |x: f64, y: f64| {
        let (a, b) = chart.backend_coord(&(x, y));
        (a - base.0, b - base.1)
    };
    (area, px)
}

/// Draws a polyline in pixels of `area`, solid or dashed.
pub(super) fn draw_path<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    path: Vec<(i32, i32)>,
    style: &LineStyle,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let stroke = style.colour.stroke_width(2);
    match style.dash {
        None => area.draw(&PathElement::new(path, stroke)),
        Some((dash, gap)) => area.draw(&plotters::element::DashedPathElement::new(
            path, dash, gap, stroke,
        )),
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    m: &Metric,
    points: &[(&RunRecord, f64, f64)],
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let xa = log_axis_over(points.iter().map(|p| p.1));
    let ya = log_axis_over(points.iter().map(|p| p.2));
    // The legend goes in a column right of the chart, never over the points.
    let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
    let (width, _) = root.dim_in_pixel();
    let font = ("sans-serif", 14).into_font();
    let lines = lines(points);
    let legend = legend_width(&root, lines.iter().map(|l| l.name.as_str()), &font);
    let (plot_area, legend_area) = root.split_horizontally(width.saturating_sub(legend));
    let mut chart = log_log_chart!(&plot_area, xa, ya).map_err(err)?;
    let x_label = |x: &f64| tick_label(*x, xa.plain);
    let y_label = |y: &f64| tick_label(*y, ya.plain);
    let x_desc = "wall time [s] (set-up + time loop)";
    styled_mesh(
        &mut chart.configure_mesh(),
        x_desc,
        m.label,
        &x_label,
        &y_label,
    )
    .draw()
    .map_err(err)?;

    // Everything else in pixels of the plotting area.
    let (area, px) = pixel_area(&chart);
    let (aw, ah) = area.dim_in_pixel();

    // Wall times below the noise floor: a shaded band, explained in the legend.
    let noise_band = xa.lo < NOISE_SECONDS;
    if noise_band {
        let x1 = px(NOISE_SECONDS.min(xa.hi), ya.lo).0;
        area.draw(&Rectangle::new(
            [(0, 0), (x1, ah as i32)],
            NOISE_SHADE.filled(),
        ))
        .map_err(err)?;
    }

    let coords: Vec<(f64, f64)> = points.iter().map(|&(_, t, e)| (t, e)).collect();
    let front: Vec<(i32, i32)> = pareto(&coords)
        .into_iter()
        .map(|i| px(coords[i].0, coords[i].1))
        .collect();
    let band = ShapeStyle::from(&BLACK.mix(0.12)).stroke_width(12);
    area.draw(&PathElement::new(front.clone(), band))
        .map_err(err)?;
    for (k, line) in lines.iter().enumerate() {
        let style = line_style(k);
        let path: Vec<(i32, i32)> = line.points.iter().map(|p| px(p.0, p.1)).collect();
        draw_path(&area, path.clone(), &style).map_err(err)?;
        for &c in &path {
            draw_marker(&area, style.marker, c, style.colour).map_err(err)?;
        }
    }
    for &c in &front {
        area.draw(&Circle::new(c, MARKER + 4, BLACK.stroke_width(2)))
            .map_err(err)?;
    }

    // The sweep value by each point, where it has room: boxes with 2 px of padding, kept
    // clear of the Pareto rings.
    let shown: Vec<(f64, f64, String)> = lines
        .iter()
        .flat_map(|l| l.points.iter())
        .map(|(t, e, v)| {
            let (x, y) = px(*t, *e);
            (f64::from(x), f64::from(y), super::report::short_value(v))
        })
        .collect();
    let labelled: Vec<(f64, f64, &str)> =
        shown.iter().map(|(x, y, v)| (*x, *y, v.as_str())).collect();
    let label_font = ("sans-serif", 13).into_font().color(&GREY);
    let size = |s: &str| {
        let (w, h) = area
            .estimate_text_size(s, &label_font)
            .map(|(w, h)| (f64::from(w), f64::from(h)))
            .unwrap_or((7.0 * s.chars().count() as f64, 13.0));
        (w + 4.0, h + 4.0)
    };
    let whole = PixelBox {
        x0: 0.0,
        y0: 0.0,
        x1: f64::from(aw),
        y1: f64::from(ah),
    };
    let boxes = place_labels(&labelled, size, f64::from(MARKER + 6), whole);
    for (b, &(_, _, v)) in boxes.iter().zip(&labelled) {
        if let Some(b) = b {
            let at = (b.x0.round() as i32 + 2, b.y0.round() as i32 + 2);
            area.draw(&Text::new(v, at, label_font.clone()))
                .map_err(err)?;
        }
    }

    // Legend: line sample with its marker, the name, and a note on noisy timings.
    draw_legend(&legend_area, &lines, &font, band, noise_band).map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// The legend right of the chart: each line's sample with its marker and name (and a note
/// on noisy timings), the Pareto front's ring, and the noise band where the chart shows it.
fn draw_legend<DB: DrawingBackend>(
    legend_area: &DrawingArea<DB, Shift>,
    lines: &[Line],
    font: &FontDesc,
    band: ShapeStyle,
    noise_band: bool,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let small = ("sans-serif", 12).into_font().color(&GREY);
    let mut y = 40;
    for (k, line) in lines.iter().enumerate() {
        let style = line_style(k);
        draw_path(legend_area, vec![(8, y), (48, y)], &style)?;
        draw_marker(legend_area, style.marker, (28, y), style.colour)?;
        legend_area.draw(&Text::new(line.name.clone(), (56, y - 8), font.clone()))?;
        y += 22;
        if timer_noise(line.points.iter().map(|p| p.0)) {
            legend_area.draw(&Text::new(
                "all wall times < 50 ms: timer noise",
                (56, y - 10),
                small.clone(),
            ))?;
            y += 16;
        }
    }
    legend_area.draw(&PathElement::new(vec![(8, y), (48, y)], band))?;
    legend_area.draw(&Circle::new((28, y), MARKER + 4, BLACK.stroke_width(2)))?;
    legend_area.draw(&Text::new("Pareto front", (56, y - 8), font.clone()))?;
    if noise_band {
        y += 22;
        legend_area.draw(&Rectangle::new(
            [(8, y - 8), (48, y + 8)],
            NOISE_SHADE.filled(),
        ))?;
        legend_area.draw(&Text::new("wall time < 50 ms:", (56, y - 8), font.clone()))?;
        legend_area.draw(&Text::new(
            "timer noise, not speed",
            (56, y + 8),
            font.clone(),
        ))?;
    }
    Ok(())
}

#[cfg(test)]
pub(super) mod tests;
