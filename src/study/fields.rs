//! Final fields of a run and the error norms against a reference: a closed form, or the
//! final state of a converged run matched by reference position.

use crate::case::VelocityField;
use crate::core::tensor::Dim;
use crate::diagnostics::analytic::{Exact, SwingingMode};
use crate::diagnostics::observe::Snapshot;
use crate::physics::material::Material;
use crate::physics::plasticity::PLASTIC_STRAIN;
use crate::scene::Scene;
use std::collections::HashMap;
use std::io::{BufRead, Write};
use std::path::Path;

/// The end state of a run, independent of the dimension: reference positions, volumes,
/// velocity and first Piola–Kirchhoff stress P = J σ F⁻ᵀ (in-plane block in 2D), which
/// the error norms read and [`Self::write_csv`] keeps; and the current positions, the
/// Cauchy stress and ε_p (plastic models), which the suite's picture reads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FinalState {
    pub dim: usize,
    pub x0: Vec<[f64; 3]>,
    pub volume: Vec<f64>,
    pub v: Vec<[f64; 3]>,
    pub pk1: Vec<[[f64; 3]; 3]>,
    pub x: Vec<[f64; 3]>,
    pub sigma: Vec<[[f64; 3]; 3]>,
    /// Empty for an elastic model.
    pub plastic_strain: Vec<f64>,
}

impl FinalState {
    /// From a snapshot; volumes are m/ρ0.
    pub fn of<D: Dim>(snap: &Snapshot<D>, rho0: f64) -> Self {
        let pk1 = snap
            .f
            .iter()
            .zip(&snap.sigma)
            .map(|(&f, s)| {
                let mut sigma = D::zero_t();
                for (k, row) in s.iter().enumerate().take(D::N) {
                    for (l, &x) in row.iter().enumerate().take(D::N) {
                        sigma += D::outer(unit::<D>(k), unit::<D>(l)) * x;
                    }
                }
                let p = sigma * D::transpose(D::inverse(f)) * D::det(f);
                D::to3x3(p)
            })
            .collect();
        Self {
            dim: D::N,
            x0: snap.x0.iter().map(|&x| D::to3(x)).collect(),
            volume: snap.reference_volumes(rho0),
            v: snap.v.iter().map(|&v| D::to3(v)).collect(),
            pk1,
            x: snap
                .x0
                .iter()
                .zip(&snap.u)
                .map(|(&x0, &u)| D::to3(x0 + u))
                .collect(),
            sigma: snap.sigma.clone(),
            plastic_strain: snap
                .field(PLASTIC_STRAIN)
                .map_or_else(Vec::new, <[f64]>::to_vec),
        }
    }

    /// Velocities, `dim` numbers per particle.
    pub fn velocity_flat(&self) -> Vec<f64> {
        self.v.iter().flat_map(|v| v[..self.dim].to_vec()).collect()
    }

    /// P, `dim²` numbers per particle.
    pub fn stress_flat(&self) -> Vec<f64> {
        self.pk1.iter().flat_map(|p| self.block(p)).collect()
    }

    fn block(&self, p: &[[f64; 3]; 3]) -> Vec<f64> {
        (0..self.dim)
            .flat_map(|k| (0..self.dim).map(move |l| p[k][l]))
            .collect()
    }

    /// Writes the state as CSV (x, y, z, volume, v, P row by row), digits that round-trip.
    pub fn write_csv(&self, path: &Path) -> std::io::Result<()> {
        crate::output::write_atomically(path, |w| {
            writeln!(w, "dim,{}", self.dim)?;
            for i in 0..self.x0.len() {
                let mut row: Vec<f64> = self.x0[i].to_vec();
                row.push(self.volume[i]);
                row.extend(self.v[i]);
                row.extend(self.pk1[i].iter().flatten());
                let text: Vec<String> = row.iter().map(|x| format!("{x:e}")).collect();
                writeln!(w, "{}", text.join(","))?;
            }
            Ok(())
        })
    }

    pub fn read_csv(path: &Path) -> std::io::Result<Self> {
        let bad = |m: String| std::io::Error::new(std::io::ErrorKind::InvalidData, m);
        let file = std::io::BufReader::new(std::fs::File::open(path)?);
        let mut out = FinalState::default();
        for (n, line) in file.lines().enumerate() {
            let line = line?;
            if n == 0 {
                out.dim = line
                    .strip_prefix("dim,")
                    .and_then(|d| d.parse().ok())
                    .ok_or_else(|| bad(format!("{}: no dim header", path.display())))?;
                continue;
            }
            let x: Vec<f64> = line
                .split(',')
                .map(|s| s.parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| bad(format!("{}:{}: {e}", path.display(), n + 1)))?;
            if x.len() != 16 {
                return Err(bad(format!("{}:{}: 16 columns", path.display(), n + 1)));
            }
            out.x0.push([x[0], x[1], x[2]]);
            out.volume.push(x[3]);
            out.v.push([x[4], x[5], x[6]]);
            out.pk1.push([
                [x[7], x[8], x[9]],
                [x[10], x[11], x[12]],
                [x[13], x[14], x[15]],
            ]);
        }
        Ok(out)
    }
}

fn unit<D: Dim>(k: usize) -> D::V {
    let mut e = [0.0; 3];
    e[k] = 1.0;
    D::from_slice(&e)
}

pub use crate::diagnostics::analytic::relative_l2;

/// Velocity and stress of a closed-form solution at the particles of `state`, time t,
/// flattened as [`FinalState::velocity_flat`] and [`FinalState::stress_flat`]. For the
/// rod pulse only the axial component of P along the pulse is kept (its other
/// components are zero in the exact solution but depend on the constitutive model).
pub fn analytic_fields(
    solution: super::suite::AnalyticSolution,
    case: &Scene,
    state: &FinalState,
    t: f64,
) -> Result<(Vec<f64>, Vec<f64>), String> {
    let exact = Exact::of(solution, case)?;
    if let Exact::Swinging { mode, .. } = exact {
        let material = Material::new(&case.material);
        return Ok(match state.dim {
            2 => swinging::<crate::core::tensor::D2>(mode, &material, state, t),
            _ => swinging::<crate::core::tensor::D3>(mode, &material, state, t),
        });
    }
    let mut v = Vec::new();
    let mut p = Vec::new();
    for &x in &state.x0 {
        v.extend_from_slice(&exact.velocity(x, t)[..state.dim]);
        p.push(exact.axial_stress(x, t));
    }
    Ok((v, p))
}

/// Axial stress d·P·d of a state (the rod pulse's stress measure).
pub fn axial_stress(state: &FinalState, case: &Scene) -> Vec<f64> {
    let dir = match case
        .bodies
        .first()
        .and_then(|b| b.initial_velocity.as_ref())
    {
        Some(VelocityField::GaussianPulse { direction, .. }) => direction.clone(),
        _ => vec![1.0, 0.0, 0.0],
    };
    let n = dir.iter().map(|d| d * d).sum::<f64>().sqrt();
    let d: Vec<f64> = dir.iter().map(|x| x / n).collect();
    state
        .pk1
        .iter()
        .map(|p| {
            (0..state.dim)
                .flat_map(|k| (0..state.dim).map(move |l| (k, l)))
                .map(|(k, l)| d[k] * p[k][l] * d[l])
                .sum()
        })
        .collect()
}

fn swinging<D: Dim>(
    mode: SwingingMode,
    material: &Material,
    state: &FinalState,
    t: f64,
) -> (Vec<f64>, Vec<f64>) {
    let mut v = Vec::new();
    let mut p = Vec::new();
    for x in &state.x0 {
        let x = D::from_slice(x);
        let vx = D::to3(mode.velocity::<D>(x, t));
        v.extend_from_slice(&vx[..D::N]);
        let px = D::to3x3(mode.stress::<D>(material, x, t));
        for row in px.iter().take(D::N) {
            p.extend_from_slice(&row[..D::N]);
        }
    }
    (v, p)
}

/// The reference state's fields at the particles of `state`: each particle takes the
/// values of the reference particle nearest to its reference position (on nested
/// lattices of one ladder the positions coincide). Returns (velocity, stress, largest
/// match distance).
pub fn matched_fields(reference: &FinalState, state: &FinalState) -> (Vec<f64>, Vec<f64>, f64) {
    let grid = Grid::new(&reference.x0);
    let mut v = Vec::new();
    let mut p = Vec::new();
    let mut worst: f64 = 0.0;
    for x in &state.x0 {
        let (j, d) = grid.nearest(&reference.x0, x);
        worst = worst.max(d);
        v.extend_from_slice(&reference.v[j][..state.dim]);
        p.extend(reference.block(&reference.pk1[j]));
    }
    (v, p, worst)
}

/// A uniform hash grid for nearest-neighbour queries.
struct Grid {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<usize>>,
}

impl Grid {
    fn new(points: &[[f64; 3]]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let extent: Vec<f64> = (0..3).map(|k| hi[k] - lo[k]).filter(|&e| e > 0.0).collect();
        let volume: f64 = extent.iter().product();
        let cell = if extent.is_empty() {
            1.0
        } else {
            (volume / points.len().max(1) as f64).powf(1.0 / extent.len() as f64) * 2.0
        };
        let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            cells.entry(key(p, cell)).or_default().push(i);
        }
        Self { cell, cells }
    }

    /// Index and distance of the nearest point.
    fn nearest(&self, points: &[[f64; 3]], x: &[f64; 3]) -> (usize, f64) {
        let c = key(x, self.cell);
        let mut best = (0, f64::INFINITY);
        for ring in 0i64.. {
            // Points in ring r + 1 are at least r cells away.
            if best.1 < (ring - 1).max(0) as f64 * self.cell || ring > 1 << 20 {
                break;
            }
            for a in -ring..=ring {
                for b in -ring..=ring {
                    for e in -ring..=ring {
                        if a.abs().max(b.abs()).max(e.abs()) != ring {
                            continue;
                        }
                        let Some(list) = self.cells.get(&[c[0] + a, c[1] + b, c[2] + e]) else {
                            continue;
                        };
                        for &j in list {
                            let d = (0..3)
                                .map(|k| (points[j][k] - x[k]).powi(2))
                                .sum::<f64>()
                                .sqrt();
                            if d < best.1 {
                                best = (j, d);
                            }
                        }
                    }
                }
            }
            if self.cells.is_empty() {
                break;
            }
        }
        best
    }
}

fn key(p: &[f64; 3], cell: f64) -> [i64; 3] {
    [0, 1, 2].map(|k| (p[k] / cell).floor() as i64)
}
