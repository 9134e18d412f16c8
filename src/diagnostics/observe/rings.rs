//! The `ring-symmetry` observer's rings: the particles of a body on a polar lattice
//! grouped by reference radius, and the spreads around each ring.

use super::Snapshot;
use crate::case::{Case, CaseError};
use crate::core::tensor::Dim;
use crate::physics::plasticity::PLASTIC_STRAIN;
use std::collections::BTreeMap;

/// The fewest particles a ring of the `ring-symmetry` observer has.
const RING_MIN: usize = 8;

/// The particles grouped by reference radius |X − X̄| about their centroid X̄ (to 1e-6 Δx),
/// each group in order of reference angle; groups of fewer than [`RING_MIN`] are left
/// out. Err: a 3D case, or no such group (the body is no ring on a polar lattice).
pub(super) fn rings<D: Dim>(case: &Case, x0: &[D::V]) -> Result<Vec<Vec<usize>>, CaseError> {
    let invalid = |m: &str| case.invalid("output.observers", format!("`ring-symmetry` {m}"));
    if D::N != 2 {
        return Err(invalid("is a 2D observer; remove it from this 3D case"));
    }
    let centre = x0.iter().fold(D::zero(), |s, &x| s + x) * (1.0 / x0.len().max(1) as f64);
    let polar = |i: usize| {
        let d = D::to3(x0[i] - centre);
        (d[0].hypot(d[1]), d[1].atan2(d[0]))
    };
    let mut groups: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
    for i in 0..x0.len() {
        let key = (polar(i).0 / case.spacing * 1e6).round() as i64;
        groups.entry(key).or_default().push(i);
    }
    let rings: Vec<Vec<usize>> = groups
        .into_values()
        .filter(|g| g.len() >= RING_MIN)
        .map(|mut g| {
            g.sort_by(|&a, &b| polar(a).1.total_cmp(&polar(b).1));
            g
        })
        .collect();
    if rings.is_empty() {
        return Err(invalid(&format!(
            "finds no ring of {RING_MIN} or more particles at one radius about their centroid; \
             sample the body as a ring with lattice = \"polar\""
        )));
    }
    Ok(rings)
}

/// The spreads of σ_θθ and of the gaps around the rings (see [`Observer::RingSymmetry`]);
/// the largest ring mean counts as at least `floor`, so that an unstressed ring's
/// round-off is no spread.
pub(super) fn ring_spreads<D: Dim>(
    rings: &[Vec<usize>],
    snap: &Snapshot<D>,
    floor: f64,
) -> [f64; 2] {
    let x = |i: usize| D::to3(snap.x0[i] + snap.u[i]);
    let centre = (0..snap.x0.len()).fold([0.0; 3], |c, i| {
        let xi = x(i);
        [c[0] + xi[0], c[1] + xi[1], 0.0]
    });
    let centre = centre.map(|c| c / snap.x0.len() as f64);
    let hoop = |i: usize| {
        let xi = x(i);
        let theta = (xi[1] - centre[1]).atan2(xi[0] - centre[0]);
        let e = [-theta.sin(), theta.cos()];
        let s = &snap.sigma[i];
        (0..2)
            .flat_map(|r| (0..2).map(move |c| e[r] * s[r][c] * e[c]))
            .sum::<f64>()
    };
    let mean_std = |values: &[f64]| {
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64;
        (mean, var.sqrt())
    };
    let (mut largest_mean, mut stress_std, mut gap_spread) = (0.0f64, 0.0f64, 0.0f64);
    for ring in rings {
        let stresses: Vec<f64> = ring.iter().map(|&i| hoop(i)).collect();
        let (mean, std) = mean_std(&stresses);
        largest_mean = largest_mean.max(mean.abs());
        stress_std = stress_std.max(std);
        let gaps: Vec<f64> = (0..ring.len())
            .map(|k| {
                let (a, b) = (x(ring[k]), x(ring[(k + 1) % ring.len()]));
                (a[0] - b[0]).hypot(a[1] - b[1])
            })
            .collect();
        let (mean, std) = mean_std(&gaps);
        gap_spread = gap_spread.max(std / mean);
    }
    [stress_std / largest_mean.max(floor), gap_spread]
}

/// ε_p below which a ring's mean counts as elastic round-off in its spread: 1e-3.
const PLASTIC_FLOOR: f64 = 1e-3;

/// The largest std over mean of ε_p around a ring, the mean at least [`PLASTIC_FLOOR`],
/// so that the first yielding particles of a ring are no spread of order one.
pub(super) fn plastic_strain_spread<D: Dim>(rings: &[Vec<usize>], snap: &Snapshot<D>) -> f64 {
    let Some(eps_p) = snap.field(PLASTIC_STRAIN) else {
        return f64::NAN;
    };
    rings
        .iter()
        .map(|ring| {
            let n = ring.len() as f64;
            let mean = ring.iter().map(|&i| eps_p[i]).sum::<f64>() / n;
            let var = ring.iter().map(|&i| (eps_p[i] - mean).powi(2)).sum::<f64>() / n;
            var.sqrt() / mean.max(PLASTIC_FLOOR)
        })
        .fold(0.0, f64::max)
}
