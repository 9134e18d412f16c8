//! The observers that watch particles the case names by place: the probes (the particle
//! nearest a position) and the section forces (the resultant of P·N across a plane).

use super::{AXES, Snapshot, unit};
use crate::case::{Case, CaseError};
use crate::core::tensor::Dim;

/// A section-force observer ([`crate::case::SectionSpec`]): the normal axis, the body it
/// is limited to, and every particle within Δx of the plane with its hat weight
/// (1 − |X·N − at|/Δx)/Δx.
pub(super) struct Section {
    axis: usize,
    body: Option<u32>,
    weights: Vec<(usize, f64)>,
}

impl Section {
    /// The `k`-th section of `case`; Err where its plane crosses no particle of its body
    /// (or of the scene), so that its force would read zero whatever the load.
    pub(super) fn new<D: Dim>(
        k: usize,
        spec: &crate::case::SectionSpec,
        case: &Case,
        x0: &[D::V],
        bodies: &[u32],
    ) -> Result<Self, CaseError> {
        let (axis, dx) = (spec.normal.index(), case.spacing);
        let section = Self {
            axis,
            body: spec
                .body
                .as_ref()
                .and_then(|name| case.bodies.iter().position(|b| &b.name == name))
                .map(|b| b as u32),
            weights: (0..x0.len())
                .map(|i| (i, (1.0 - (D::comp(x0[i], axis) - spec.at).abs() / dx) / dx))
                .filter(|&(_, w)| w > 0.0)
                .collect(),
        };
        let crossed = section
            .weights
            .iter()
            .any(|&(i, _)| section.body.is_none_or(|b| bodies[i] == b));
        if !crossed {
            return Err(case.invalid(
                format!("section.{k}.at"),
                format!(
                    "puts the plane where no particle{} lies within Δx of it; give a plane \
                     through the body",
                    spec.body
                        .as_ref()
                        .map_or(String::new(), |b| format!(" of body `{b}`"))
                ),
            ));
        }
        Ok(section)
    }

    /// ∫ P·N dA ≈ Σ V P·N (hat weight) over the section's particles, with
    /// P = J σ F⁻ᵀ (the in-plane block of σ in 2D) and V = m/ρ0.
    pub(super) fn force<D: Dim>(&self, snap: &Snapshot<D>, rho0: f64) -> [f64; 3] {
        let n = unit::<D>(self.axis);
        let mut force = [0.0; 3];
        for &(i, w) in &self.weights {
            if self.body.is_some_and(|b| snap.body[i] != b) {
                continue;
            }
            let f = snap.f[i];
            let g = D::to3(D::inverse(D::transpose(f)) * n);
            let scale = D::det(f) * w * snap.mass[i] / rho0;
            for (r, row) in snap.sigma[i].iter().enumerate().take(D::N) {
                force[r] += scale * (0..D::N).map(|c| row[c] * g[c]).sum::<f64>();
            }
        }
        force
    }
}

/// The particle each probe of `case` watches, the nearest to its position, with its
/// series columns added to `names`; Err for a probe farther than 2Δx from every particle.
pub(super) fn probe_particles<D: Dim>(
    case: &Case,
    x0: &[D::V],
    names: &mut Vec<String>,
) -> Result<Vec<usize>, CaseError> {
    let mut probes = Vec::new();
    for (p, probe) in case.probes.iter().enumerate() {
        let target = D::from_slice(&probe.position);
        let nearest = (0..x0.len())
            .min_by(|&a, &b| D::norm2(x0[a] - target).total_cmp(&D::norm2(x0[b] - target)))
            .ok_or_else(|| {
                case.invalid(format!("probe.{p}.position"), "the scene has no particles")
            })?;
        // A probe is a particle's: one farther than 2Δx from every particle lies
        // outside the bodies and would watch a particle it does not name.
        let distance = D::norm2(x0[nearest] - target).sqrt();
        if distance > 2.0 * case.spacing {
            return Err(case.invalid(
                format!("probe.{p}.position"),
                format!(
                    "is {distance:e} m from the nearest particle, more than 2Δx = {:e} m: \
                     it lies outside the bodies; give a position in a body",
                    2.0 * case.spacing
                ),
            ));
        }
        probes.push(nearest);
        for q in ["u", "v"] {
            names.extend((0..D::N).map(|k| format!("{}.{q}{}", probe.name, AXES[k])));
        }
    }
    Ok(probes)
}
