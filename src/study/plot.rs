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
    let bounds = |v: &mut dyn Iterator<Item = f64>| {
        v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        })
    };
    let (t_lo, t_hi) = bounds(&mut points.iter().map(|p| p.1));
    let (e_lo, e_hi) = bounds(&mut points.iter().map(|p| p.2));
    let (xa, ya) = (log_axis(t_lo, t_hi), log_axis(e_lo, e_hi));
    // The legend goes in a column right of the chart, never over the points.
    let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
    let (width, _) = root.dim_in_pixel();
    let font = ("sans-serif", 14).into_font();
    let lines = lines(points);
    let legend = legend_width(&root, lines.iter().map(|l| l.name.as_str()), &font);
    let (plot_area, legend_area) = root.split_horizontally(width.saturating_sub(legend));
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(
            (xa.lo..xa.hi)
                .log_scale()
                .with_key_points(xa.ticks.clone())
                .with_light_points(xa.minor.clone()),
            (ya.lo..ya.hi)
                .log_scale()
                .with_key_points(ya.ticks.clone())
                .with_light_points(ya.minor.clone()),
        )
        .map_err(err)?;
    let x_label = |x: &f64| tick_label(*x, xa.plain);
    let y_label = |y: &f64| tick_label(*y, ya.plain);
    chart
        .configure_mesh()
        .x_desc("wall time [s] (set-up + time loop)")
        .y_desc(m.label)
        .x_label_formatter(&x_label)
        .y_label_formatter(&y_label)
        .bold_line_style(RGBColor(190, 190, 190))
        .light_line_style(RGBColor(235, 235, 235))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(err)?;

    // Everything else in pixels of the plotting area.
    let area = chart.plotting_area().strip_coord_spec();
    let base = area.get_base_pixel();
    let px = |t: f64, e: f64| {
        let (x, y) = chart.backend_coord(&(t, e));
        (x - base.0, y - base.1)
    };
    let (aw, ah) = area.dim_in_pixel();
    let grey = RGBColor(90, 90, 90);
    let small = ("sans-serif", 12).into_font().color(&grey);

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
    let label_font = ("sans-serif", 13).into_font().color(&grey);
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
    let mut y = 40;
    for (k, line) in lines.iter().enumerate() {
        let style = line_style(k);
        draw_path(&legend_area, vec![(8, y), (48, y)], &style).map_err(err)?;
        draw_marker(&legend_area, style.marker, (28, y), style.colour).map_err(err)?;
        legend_area
            .draw(&Text::new(line.name.clone(), (56, y - 8), font.clone()))
            .map_err(err)?;
        y += 22;
        if timer_noise(line.points.iter().map(|p| p.0)) {
            legend_area
                .draw(&Text::new(
                    "all wall times < 50 ms: timer noise",
                    (56, y - 10),
                    small.clone(),
                ))
                .map_err(err)?;
            y += 16;
        }
    }
    legend_area
        .draw(&PathElement::new(vec![(8, y), (48, y)], band))
        .map_err(err)?;
    legend_area
        .draw(&Circle::new((28, y), MARKER + 4, BLACK.stroke_width(2)))
        .map_err(err)?;
    legend_area
        .draw(&Text::new("Pareto front", (56, y - 8), font.clone()))
        .map_err(err)?;
    if noise_band {
        y += 22;
        legend_area
            .draw(&Rectangle::new(
                [(8, y - 8), (48, y + 8)],
                NOISE_SHADE.filled(),
            ))
            .map_err(err)?;
        legend_area
            .draw(&Text::new("wall time < 50 ms:", (56, y - 8), font.clone()))
            .map_err(err)?;
        legend_area
            .draw(&Text::new(
                "timer noise, not speed",
                (56, y + 8),
                font.clone(),
            ))
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
pub(super) mod tests {
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
        let input: Vec<(f64, f64, &str)> =
            pts.iter().map(|(x, y, s)| (*x, *y, s.as_str())).collect();
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
}
