//! A suite's `[picture]`: a field on the particles' current positions at the end of every
//! run (or at its failure), one panel per run, each on its own colour scale: σ_θθ on the
//! rings of seed 001 (Figs. 18–19), ε_p on the steel ring (Fig. 17), the pressure on seed
//! 003's stent (Fig. 29, seen from a `view` and mirrored across its symmetry planes). The
//! run writes its points (`runs/<id>/picture.csv`: x, y on the page, value; drawn in file
//! order, farthest first), the report draws them.

use super::fields::FinalState;
use super::plot::{register_font, write_figure};
use super::records::{RunRecord, Status};
use super::suite::{Picture, PictureField, Suite};
use glam::DVec3;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The points file of a run.
pub fn points_file(suite_dir: &Path, id: &str) -> PathBuf {
    suite_dir.join("runs").join(id).join("picture.csv")
}

/// The field of picture `p` at every particle of `state`, scaled; Err if the state has
/// no such field.
pub fn values(p: &Picture, state: &FinalState) -> Result<Vec<f64>, String> {
    let raw = match p.field {
        PictureField::HoopStress => hoop_stress(state),
        PictureField::PlasticStrain if state.plastic_strain.len() == state.x.len() => {
            state.plastic_strain.clone()
        }
        PictureField::PlasticStrain => {
            return Err(
                "the picture's field `plastic-strain` needs a `von-mises-plastic` \
                        material"
                    .into(),
            );
        }
        PictureField::Pressure => crate::physics::pressure::pressures(&state.sigma),
    };
    Ok(raw.into_iter().map(|v| v * p.scale).collect())
}

/// σ_θθ = e_θ·σ e_θ with e_θ = (−sin θ, cos θ) about the centroid of the current positions.
fn hoop_stress(state: &FinalState) -> Vec<f64> {
    let n = state.x.len().max(1) as f64;
    let c = state
        .x
        .iter()
        .fold([0.0; 2], |c, x| [c[0] + x[0] / n, c[1] + x[1] / n]);
    state
        .x
        .iter()
        .zip(&state.sigma)
        .map(|(x, s)| {
            let theta = (x[1] - c[1]).atan2(x[0] - c[0]);
            let e = [-theta.sin(), theta.cos()];
            (0..2)
                .flat_map(|r| (0..2).map(move |k| e[r] * s[r][k] * e[k]))
                .sum()
        })
        .collect()
}

/// The page's axes of an orthographic view from `view` (towards the eye, d): up e2, the
/// part of e_z normal to d (of e_y where d is along z), and right e1 = e2 × d.
fn page_axes(view: [f64; 3]) -> [DVec3; 3] {
    let d = DVec3::from(view).normalize();
    let up = if d.cross(DVec3::Z).length() > 1e-6 {
        DVec3::Z
    } else {
        DVec3::Y
    };
    let e2 = (up - d * up.dot(d)).normalize();
    [e2.cross(d), e2, d]
}

/// The points of picture `p` on the page, each (x, y, value), the farthest from the eye
/// first: every particle, and its mirror images across the planes of `reflect`.
fn page_points(p: &Picture, state: &FinalState) -> Result<Vec<[f64; 3]>, String> {
    let values = values(p, state)?;
    let [e1, e2, d] = p.view.map_or([DVec3::X, DVec3::Y, DVec3::Z], page_axes);
    let mut points: Vec<(f64, [f64; 3])> = Vec::new();
    for images in 0..1u32 << p.reflect.len() {
        for (x, &v) in state.x.iter().zip(&values) {
            let mut x = DVec3::from(*x);
            for (k, axis) in p.reflect.iter().enumerate() {
                if images & (1 << k) != 0 {
                    x[axis.index()] = -x[axis.index()];
                }
            }
            points.push((x.dot(d), [x.dot(e1), x.dot(e2), v]));
        }
    }
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(points.into_iter().map(|(_, point)| point).collect())
}

/// Writes the points of picture `p` of a run's final state.
pub fn write_points(path: &Path, p: &Picture, state: &FinalState) -> std::io::Result<()> {
    let points = page_points(p, state).map_err(std::io::Error::other)?;
    let mut text = String::from("x,y,value\n");
    for [x, y, v] in points {
        let _ = writeln!(text, "{x:e},{y:e},{v:e}");
    }
    crate::output::write_atomically(path, |w| std::io::Write::write_all(w, text.as_bytes()))
}

/// The points of a run's picture.
fn read_points(path: &Path) -> Result<Vec<[f64; 3]>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    text.lines()
        .skip(1)
        .map(|line| {
            let v: Vec<f64> = line
                .split(',')
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|e| format!("{}: {e}", path.display()))?;
            match v[..] {
                [x, y, value] => Ok([x, y, value]),
                _ => Err(format!(
                    "{}: a row of {} columns, not 3",
                    path.display(),
                    v.len()
                )),
            }
        })
        .collect()
}

/// One panel: its title (run, sweep value, end or failure time) and its points.
struct Panel {
    title: String,
    points: Vec<[f64; 3]>,
}

/// Writes `<suite>-picture.png/svg` into `dir` from the points under `suite_dir`: a grid
/// with a row per sweep value and a column per variant and backend.
pub fn write(
    suite: &Suite,
    records: &[RunRecord],
    suite_dir: &Path,
    dir: &Path,
) -> std::io::Result<Vec<PathBuf>> {
    let Some(p) = &suite.picture else {
        return Ok(Vec::new());
    };
    let mut drawn: Vec<RunRecord> = Vec::new();
    let mut panels: Vec<Panel> = Vec::new();
    for r in records {
        let failed = matches!(r.status, Status::Failed { .. });
        if r.status != Status::Ok && !failed {
            continue;
        }
        match read_points(&points_file(suite_dir, &r.id)) {
            Ok(points) => {
                let when = if failed {
                    format!("failed at t = {:.3e} s", r.time)
                } else {
                    format!("t = {:.3e} s", r.time)
                };
                let title = format!(
                    "{}, {} = {}: {when}",
                    r.line(),
                    suite.sweep.key,
                    r.sweep_value
                );
                panels.push(Panel { title, points });
                drawn.push(r.clone());
            }
            Err(e) => eprintln!("warning: {}: picture: {e}", suite.name),
        }
    }
    if panels.is_empty() {
        return Ok(Vec::new());
    }
    register_font();
    let (lines, values) = (super::report::lines(&drawn), super::report::values(&drawn));
    let (cols, rows) = (lines.len(), values.len());
    // Row per sweep value, column per line.
    let grid: Vec<Option<&Panel>> = values
        .iter()
        .flat_map(|v| {
            let (drawn, panels) = (&drawn, &panels);
            lines.iter().map(move |l| {
                drawn
                    .iter()
                    .position(|r| &r.line() == l && &r.sweep_value == v)
                    .map(|k| &panels[k])
            })
        })
        .collect();
    let size = (480 * cols as u32, 440 * rows as u32 + 40);
    let title = format!("{}: {}", suite.name, p.label);
    // A view's page coordinates are no lengths along the body's axes.
    let axes = p.view.is_none();
    let stem = format!("{}-picture", suite.name);
    write_figure(
        dir,
        &stem,
        |path| {
            draw(
                BitMapBackend::new(path, size).into_drawing_area(),
                &title,
                &grid,
                cols,
                axes,
            )
        },
        |path| {
            draw(
                SVGBackend::new(path, size).into_drawing_area(),
                &title,
                &grid,
                cols,
                axes,
            )
        },
    )
}

fn draw<DB: DrawingBackend>(
    area: DrawingArea<DB, Shift>,
    title: &str,
    grid: &[Option<&Panel>],
    cols: usize,
    axes: bool,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    area.fill(&WHITE).map_err(err)?;
    let area = area
        .titled(title, ("sans-serif", 20).into_font())
        .map_err(err)?;
    let rows = grid.len().div_ceil(cols);
    for (panel, cell) in grid.iter().zip(area.split_evenly((rows, cols))) {
        if let Some(panel) = panel {
            draw_panel(&cell, panel, axes).map_err(err)?;
        }
    }
    area.present().map_err(err)
}

/// A blue–white–red scale over [lo, hi] (white at the middle: zero for a field of both
/// signs, [`scale_range`]), readable in greyscale as
/// dark–light–dark only at the ends, so the panel also prints its range.
fn colour(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    let mix = |a: f64, b: f64, s: f64| (a + (b - a) * s).round() as u8;
    if t < 0.5 {
        let s = t / 0.5;
        RGBColor(
            mix(33.0, 247.0, s),
            mix(102.0, 247.0, s),
            mix(172.0, 247.0, s),
        )
    } else {
        let s = (t - 0.5) / 0.5;
        RGBColor(
            mix(247.0, 178.0, s),
            mix(247.0, 24.0, s),
            mix(247.0, 43.0, s),
        )
    }
}

fn draw_panel<DB: DrawingBackend>(
    cell: &DrawingArea<DB, Shift>,
    panel: &Panel,
    axes: bool,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (lo, hi) = scale_range(&panel.points);
    let (x0, x1, y0, y1) = panel.points.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), p| (a.min(p[0]), b.max(p[0]), c.min(p[1]), d.max(p[1])),
    );
    // Equal scales on both axes: the larger extent fills the square plot.
    let half = 0.55 * (x1 - x0).max(y1 - y0).max(f64::MIN_POSITIVE);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (plot, bar) = cell.split_horizontally(cell.dim_in_pixel().0 - 70);
    let mut chart = ChartBuilder::on(&plot)
        .caption(&panel.title, ("sans-serif", 13))
        .margin(8)
        .build_cartesian_2d(cx - half..cx + half, cy - half..cy + half)?;
    if axes {
        chart.configure_mesh().disable_mesh().draw()?;
    }
    let span = if hi > lo { hi - lo } else { 1.0 };
    chart.draw_series(panel.points.iter().map(|p| {
        let c = colour((p[2] - lo) / span);
        Circle::new((p[0], p[1]), 2, c.filled())
    }))?;
    // The colour bar with its range.
    let h = bar.dim_in_pixel().1;
    let (top, bottom) = (40i32, h as i32 - 40);
    let steps = 64;
    for k in 0..steps {
        let y0 = bottom - (bottom - top) * k / steps;
        let y1 = bottom - (bottom - top) * (k + 1) / steps;
        let c = colour(k as f64 / (steps - 1) as f64);
        bar.draw(&Rectangle::new([(10, y1), (28, y0)], c.filled()))?;
    }
    let text = |y: i32, v: f64| Text::new(label(v), (6, y), ("sans-serif", 12));
    bar.draw(&text(top - 18, hi))?;
    bar.draw(&text(bottom + 6, lo))?;
    Ok(())
}

/// The colour scale's range over the points' values: [min, max], or for a field of both
/// signs ±max |value|, so that white is zero.
fn scale_range(points: &[[f64; 3]]) -> (f64, f64) {
    let (lo, hi) = (points.iter()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p[2]), hi.max(p[2]))
    });
    if lo < 0.0 && hi > 0.0 {
        let m = hi.max(-lo);
        (-m, m)
    } else {
        (lo, hi)
    }
}

/// A colour-bar end: four significant digits, in exponent form outside [0.01, 1e4).
fn label(v: f64) -> String {
    if v == 0.0 || (1e-2..1e4).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tensor::Axis;

    /// Particles at `x` under the stress diag(−1, −2, −3) × k for the k-th (pressure 2k).
    fn state(x: &[[f64; 3]]) -> FinalState {
        let n = x.len();
        FinalState {
            dim: 3,
            x0: x.to_vec(),
            volume: vec![1.0; n],
            v: vec![[0.0; 3]; n],
            pk1: vec![[[0.0; 3]; 3]; n],
            x: x.to_vec(),
            sigma: (1..=n)
                .map(|k| {
                    let k = k as f64;
                    [[-k, 0.0, 0.0], [0.0, -2.0 * k, 0.0], [0.0, 0.0, -3.0 * k]]
                })
                .collect(),
            plastic_strain: Vec::new(),
        }
    }

    fn pressure(view: Option<[f64; 3]>, reflect: Vec<Axis>) -> Picture {
        Picture {
            field: PictureField::Pressure,
            label: "p".into(),
            scale: 1.0,
            view,
            reflect,
        }
    }

    #[test]
    fn a_view_puts_z_up_and_draws_the_nearest_last() {
        // Seen from +x: the page's right is +y, its up +z; the particle at x = 5 is
        // nearer the eye than the one at x = −1, so it comes last whatever the order.
        let s = state(&[[5.0, 1.0, 2.0], [-1.0, 3.0, 4.0]]);
        let points = page_points(&pressure(Some([2.0, 0.0, 0.0]), vec![]), &s).unwrap();
        assert_eq!(points, vec![[3.0, 4.0, 4.0], [1.0, 2.0, 2.0]]);
        // From an oblique direction the page's axes are orthonormal and normal to it,
        // up the part of e_z normal to the view.
        let [e1, e2, d] = page_axes([1.0, 0.6, 0.5]);
        let m = glam::DMat3::from_cols(e1, e2, d);
        assert!((m.transpose() * m).abs_diff_eq(glam::DMat3::IDENTITY, 1e-15));
        assert!((m.determinant() - 1.0).abs() < 1e-15);
        assert!(e2.z > 0.0 && e1.z.abs() < 1e-15);
        // Along z the page is the x–y plane, as without a view.
        let s = state(&[[1.0, 2.0, 0.0]]);
        let top = page_points(&pressure(Some([0.0, 0.0, 1.0]), vec![]), &s).unwrap();
        assert_eq!(top, page_points(&pressure(None, vec![]), &s).unwrap());
        assert_eq!(top, vec![[1.0, 2.0, 2.0]]);
    }

    #[test]
    fn a_field_of_both_signs_is_white_at_zero() {
        let at = |values: &[f64]| {
            scale_range(&values.iter().map(|&v| [0.0, 0.0, v]).collect::<Vec<_>>())
        };
        assert_eq!(at(&[-1.0, 3.0, 0.5]), (-3.0, 3.0));
        assert_eq!(at(&[-4.0, 1.0]), (-4.0, 4.0));
        assert_eq!(at(&[0.0, 2.0, 1.0]), (0.0, 2.0));
        assert_eq!(at(&[-2.0, -1.0]), (-2.0, -1.0));
    }

    #[test]
    fn reflecting_across_two_planes_gives_four_images() {
        // Seen from +y the page is (−x, z): the images of (1, 2, 3) across x = 0 and z = 0
        // are (∓1, ±3) on it, all at the same depth, so in the order of the images.
        let s = state(&[[1.0, 2.0, 3.0]]);
        let picture = pressure(Some([0.0, 1.0, 0.0]), vec![Axis::X, Axis::Z]);
        assert_eq!(
            page_points(&picture, &s).unwrap(),
            vec![
                [-1.0, 3.0, 2.0],
                [1.0, 3.0, 2.0],
                [-1.0, -3.0, 2.0],
                [1.0, -3.0, 2.0]
            ]
        );
    }
}
