//! Seed 000 Fig. 3: the neighbourhood algorithms of §3.2 ([`crate::core::neighbourhood`])
//! compared on a lattice moved by a prescribed motion, no physics: the initial state, a
//! simple shear and an isochoric tension, at the lattice's centre particle.
//!
//! The paper gives neither the lattice nor the motions; here a square lattice of 13 × 13
//! particles, Δx = 1, m = 1, with the reference code's candidate set of the ellipse (the
//! particles within |ΔX|, |ΔY| ≤ 3Δx of the reference configuration: 7 × 7) and h0 = 1.5Δx
//! (its h_c), the cubic spline; shear x = X + γY with γ = 0.5 (γ = 1 maps the lattice onto
//! itself), tension x = (2X, Y/2). The
//! isotropic algorithms (eqs 60–62) search the whole lattice within their support 2h; the
//! prime space (eq 63) and the ellipse (eq 64) take the 7 × 7 candidates.

use crate::core::kernel::KernelKind;
use crate::core::neighbourhood::{
    Ellipse, continuity_smoothing_length, density_smoothing_length, prime_space, within,
};
use crate::core::tensor::D2;
use glam::{DMat2, DVec2};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Half the lattice's side in spacings (13 × 13 particles).
const HALF: i32 = 6;
/// h0/Δx: the reference code's h_c of the ellipse's candidate box.
const H0: f64 = 1.5;
/// The candidate box of the prime space and the ellipse, |ΔX|, |ΔY| ≤ 3Δx.
const BOX: i32 = 3;

/// The prescribed motions: x = F X about the centre particle.
pub const MOTIONS: [(&str, [f64; 4]); 3] = [
    ("initial", [1.0, 0.0, 0.0, 1.0]),
    ("shear", [1.0, 0.0, 0.5, 1.0]),
    ("tension", [2.0, 0.0, 0.0, 0.5]),
];

/// The algorithms, by the names of the table.
pub const ALGORITHMS: [&str; 4] = ["density", "continuity", "prime-space", "ellipse"];

/// One algorithm's neighbourhood of the centre particle under one motion.
#[derive(Clone, Debug)]
pub struct Neighbourhood {
    pub motion: &'static str,
    pub algorithm: &'static str,
    /// The neighbours' offsets x_j − x_i (the particle itself left out).
    pub offsets: Vec<DVec2>,
    /// The neighbours not in the same algorithm's neighbourhood of the initial state.
    pub gained: usize,
    /// The smoothing length [Δx] (the ellipse's max |x_ij|/2; NaN for the prime space).
    pub h: f64,
}

impl Neighbourhood {
    /// The neighbours counted.
    pub fn count(&self) -> usize {
        self.offsets.len()
    }

    /// |Σ_j (x_j − x_i)| over Σ_j |x_j − x_i|: 0 for a neighbourhood symmetric about the
    /// particle, 1 for one on a ray from it.
    pub fn asymmetry(&self) -> f64 {
        let sum = self.offsets.iter().fold(DVec2::ZERO, |s, &r| s + r);
        let size: f64 = self.offsets.iter().map(|r| r.length()).sum();
        sum.length() / size
    }

    /// sqrt(λ_max/λ_min) of the neighbours' second moment Σ_j r_j ⊗ r_j: the ratio of the
    /// neighbourhood's principal extents.
    pub fn anisotropy(&self) -> f64 {
        let m = self
            .offsets
            .iter()
            .fold(DMat2::ZERO, |m, &r| m + DMat2::from_cols(r * r.x, r * r.y));
        stretch_ratio(m).sqrt()
    }
}

/// λ_max/λ_min of a symmetric 2 × 2 matrix.
fn stretch_ratio(m: DMat2) -> f64 {
    let (a, b, d) = (m.x_axis.x, m.y_axis.x, m.y_axis.y);
    let mean = 0.5 * (a + d);
    let radius = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    (mean + radius) / (mean - radius)
}

/// The principal stretch ratio λ1/λ2 of a motion's F: the anisotropy a neighbourhood
/// following the deformation would have.
pub fn motion_anisotropy(f: [f64; 4]) -> f64 {
    let f = DMat2::from_cols_array(&f);
    stretch_ratio(f * f.transpose()).sqrt()
}

/// Every algorithm's neighbourhood under every motion, in the order of [`MOTIONS`] and
/// [`ALGORITHMS`].
pub fn compare() -> Vec<Neighbourhood> {
    let lattice: Vec<DVec2> = (-HALF..=HALF)
        .flat_map(|j| (-HALF..=HALF).map(move |i| DVec2::new(i as f64, j as f64)))
        .collect();
    let candidate = |x0: DVec2| x0.x.abs() <= BOX as f64 && x0.y.abs() <= BOX as f64;
    let mut out = Vec::new();
    for (motion, f) in MOTIONS {
        let f = DMat2::from_cols_array(&f);
        // Offsets x_j − x_i of the centre particle i at the origin, itself included.
        let all: Vec<DVec2> = lattice.iter().map(|&x0| f * x0).collect();
        let boxed: Vec<DVec2> = (lattice.iter().zip(&all))
            .filter(|&(&x0, _)| candidate(x0))
            .map(|(_, &x)| x)
            .collect();
        let others = |keep: Vec<usize>, from: &[DVec2]| -> Vec<DVec2> {
            keep.into_iter()
                .map(|k| from[k])
                .filter(|r| *r != DVec2::ZERO)
                .collect()
        };
        let f_inv = f.inverse();
        let kind = KernelKind::CubicSpline;
        let density = density_smoothing_length::<D2>(
            all.iter().map(|&r| (r, 1.0)),
            1.0,
            H0,
            kind,
            H0,
            f64::INFINITY,
        )
        .expect("the lattice reaches every support");
        // ρ of the continuity equation is ρ0/J, and both motions keep the volume.
        let det = f.determinant();
        let continuity = continuity_smoothing_length(H0, 1.0, 1.0 / det, 2);
        for (algorithm, h, offsets) in [
            (
                "density",
                density,
                others(within::<D2>(&all, 2.0 * density), &all),
            ),
            (
                "continuity",
                continuity,
                others(within::<D2>(&all, 2.0 * continuity), &all),
            ),
            ("prime-space", f64::NAN, {
                let flat: Vec<[f64; 2]> = boxed.iter().map(|r| r.to_array()).collect();
                others(prime_space(&flat), &boxed)
            }),
            (
                "ellipse",
                { Ellipse::<D2>::new(&boxed).map_or(f64::NAN, |e| e.h) },
                {
                    let e = Ellipse::<D2>::new(&boxed)
                        .expect("the lattice's candidates span the plane");
                    let inside = (0..boxed.len()).filter(|&k| e.contains(boxed[k])).collect();
                    others(inside, &boxed)
                },
            ),
        ] {
            // The reference offsets of the same algorithm's initial neighbourhood.
            let initial: Vec<DVec2> = out
                .iter()
                .find(|n: &&Neighbourhood| n.motion == MOTIONS[0].0 && n.algorithm == algorithm)
                .map_or_else(|| offsets.clone(), |n| n.offsets.clone());
            let gained = offsets
                .iter()
                .filter(|&&r| !initial.iter().any(|&q| (q - f_inv * r).length() < 1e-9))
                .count();
            out.push(Neighbourhood {
                motion,
                algorithm,
                offsets,
                gained,
                h,
            });
        }
    }
    out
}

/// The comparison as CSV: motion, algorithm, h [Δx], count, asymmetry, anisotropy and
/// the motion's stretch ratio.
pub fn table(rows: &[Neighbourhood]) -> String {
    let mut s =
        String::from("motion,algorithm,h,count,gained,asymmetry,anisotropy,motion_anisotropy\n");
    for r in rows {
        let f = MOTIONS
            .iter()
            .find(|m| m.0 == r.motion)
            .expect("a motion")
            .1;
        s += &format!(
            "{},{},{:.6},{},{},{:.6},{:.6},{:.6}\n",
            r.motion,
            r.algorithm,
            r.h,
            r.count(),
            r.gained,
            r.asymmetry(),
            r.anisotropy(),
            motion_anisotropy(f)
        );
    }
    s
}

/// Writes `neighbourhoods.csv` and Fig. 3 as `neighbourhoods.png` and `.svg` into `dir`:
/// a row per motion, a column per algorithm, the lattice in grey, the neighbours in
/// colour and the particle in red.
pub fn write(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let rows = compare();
    let csv = dir.join("neighbourhoods.csv");
    std::fs::write(&csv, table(&rows))?;
    let mut files = vec![csv];
    super::plot::register_font();
    files.extend(super::plot::write_figure(
        dir,
        "neighbourhoods",
        |path| {
            draw(
                BitMapBackend::new(path, (1200, 900)).into_drawing_area(),
                &rows,
            )
        },
        |path| {
            draw(
                SVGBackend::new(path, (1200, 900)).into_drawing_area(),
                &rows,
            )
        },
    )?);
    Ok(files)
}

/// Draws the panels of [`write`].
fn draw<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    rows: &[Neighbourhood],
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    area.fill(&WHITE).map_err(e)?;
    let panels = area.split_evenly((MOTIONS.len(), ALGORITHMS.len()));
    for (panel, r) in panels.iter().zip(rows) {
        let f = DMat2::from_cols_array(
            &MOTIONS
                .iter()
                .find(|m| m.0 == r.motion)
                .expect("a motion")
                .1,
        );
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{} / {}: {} neighbours", r.motion, r.algorithm, r.count()),
                ("sans-serif", 16),
            )
            .margin(6)
            .build_cartesian_2d(-7.5..7.5, -5.5..5.5)
            .map_err(e)?;
        let lattice = (-HALF..=HALF)
            .flat_map(|j| (-HALF..=HALF).map(move |i| DVec2::new(i as f64, j as f64)))
            .map(|x0| f * x0);
        chart
            .draw_series(
                lattice.map(|x| Circle::new((x.x, x.y), 2, RGBColor(190, 190, 190).filled())),
            )
            .map_err(e)?;
        chart
            .draw_series(
                r.offsets
                    .iter()
                    .map(|x| Circle::new((x.x, x.y), 4, BLUE.filled())),
            )
            .map_err(e)?;
        chart
            .draw_series(std::iter::once(Circle::new((0.0, 0.0), 5, RED.filled())))
            .map_err(e)?;
    }
    area.present().map_err(e)
}
