//! The driver's checks: the blow-up checks after each batch (the energy bound and the
//! hourglass limit), the notes and warnings said at the start, and the attribution of a
//! failure (of those or of the CFL step) to a particle and a quantity.

use super::batch::{Batch, Callback};
use super::{Engine, RunError};
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::engine::BlowUp;
use crate::scene::Scene;

/// The blow-up checks after each batch: the total energy against
/// `run.energy_growth_limit` × (E0 + W_ext), and η against `run.hourglass_limit`.
pub(super) struct BlowUpChecks {
    energy_growth_limit: f64,
    hourglass_limit: Option<f64>,
}

impl BlowUpChecks {
    /// The checks of `case`; says the start's warning (a fixed step above the CFL step)
    /// and, unless `resumed`, its notes (mass and length of the sampled bodies).
    pub(super) fn new<D: Dim>(
        case: &Scene,
        engine: &mut dyn Engine<D>,
        dt_first: f64,
        resumed: bool,
    ) -> Self {
        if case.method.dt.is_some()
            && let Some(warning) =
                fixed_step_warning(dt_first, case.spacing / engine.max_signal_speed())
        {
            eprintln!("warning: {}: {warning}", case.file.display());
        }
        if !resumed {
            let mut notes = mass_notes(case, &engine.snapshot());
            notes.extend(length_notes(case));
            for note in notes {
                eprintln!("note: {}: {note}", case.file.display());
            }
        }
        Self {
            energy_growth_limit: case.run.energy_growth_limit,
            hourglass_limit: case.run.hourglass_limit,
        }
    }
}

impl<D: Dim> Callback<D> for BlowUpChecks {
    fn after_batch(&mut self, batch: &mut Batch<D>) -> Result<Option<BlowUp>, RunError> {
        if batch.start {
            return Ok(None);
        }
        let clock = &batch.clock;
        let bound = self.energy_growth_limit * (clock.e0 + clock.booked.external_work.max(0.0));
        // A non-finite energy (an overflowing velocity of a rigid motion, which leaves F
        // finite) is a blow-up whatever the bound.
        let e = batch.inv.total_energy();
        if !e.is_finite() || (e > bound && bound > 0.0) {
            return Ok(Some(
                batch.with_snapshot(|snap| energy_blow_up::<D>(snap, e, bound)),
            ));
        }
        let (Some(limit), Some((snap, _)), Some(fields)) =
            (self.hourglass_limit, batch.state(), batch.fields())
        else {
            return Ok(None);
        };
        Ok(fields
            .eta
            .as_ref()
            .and_then(|eta| hourglass_blow_up::<D>(snap, eta, limit)))
    }
}

/// Energy-growth failure, attributed to the particle with the largest kinetic energy.
fn energy_blow_up<D: Dim>(snap: &Snapshot<D>, energy: f64, bound: f64) -> BlowUp {
    let (v, m) = (&snap.v, snap.mass);
    let i = (0..m.len())
        .max_by(|&a, &b| (m[a] * D::norm2(v[a])).total_cmp(&(m[b] * D::norm2(v[b]))))
        .unwrap_or(0);
    BlowUp {
        particle: i,
        position: D::to3(snap.x0[i]),
        quantity: format!("total energy (bound {bound:e}, fastest particle shown)"),
        value: energy,
    }
}

/// Hourglass failure: the particle with the largest η, when η exceeds the limit.
fn hourglass_blow_up<D: Dim>(snap: &Snapshot<D>, eta: &[f64], limit: f64) -> Option<BlowUp> {
    let (i, &worst) = eta.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    (worst > limit).then(|| {
        let quantity = format!("hourglass indicator η (run.hourglass_limit = {limit})");
        BlowUp::at::<D>(snap.x0, i, &quantity, worst)
    })
}

/// Collapse of the CFL step below `floor`, attributed to the particle with the largest
/// signal-speed estimate: the method's stretch-dependent part
/// ([`crate::methods::MethodFamily::stretch_signal_speed`]) plus |v|.
pub(super) fn step_collapse<D: Dim>(case: &Scene, snap: &Snapshot<D>, floor: f64) -> BlowUp {
    let c_p = case.step_wave_speed();
    let speed =
        |i: usize| case.spec.stretch_signal_speed::<D>(c_p, snap.f[i]) + D::norm2(snap.v[i]).sqrt();
    let i = (0..snap.v.len())
        .max_by(|&a, &b| speed(a).total_cmp(&speed(b)))
        .unwrap_or(0);
    let quantity = format!(
        "collapse of the CFL step (below run.min_step_ratio × the first step = {floor:e} s); \
         signal speed [m/s] of the fastest particle"
    );
    BlowUp::at::<D>(snap.x0, i, &quantity, speed(i))
}

/// A fixed step above the method's CFL step Δx/(signal speed) at the start: a Courant
/// number above 1, where explicit steps of these methods blow up.
fn fixed_step_warning(dt: f64, cfl_step: f64) -> Option<String> {
    let courant = dt / cfl_step;
    (courant > 1.0).then(|| {
        format!(
            "method.dt = {dt:e} s is {courant:.2} times the method's CFL step Δx/(signal \
             speed) = {cfl_step:e} s at the start (a Courant number of {courant:.2}); explicit \
             steps above 1 blow up: give method.dt below {cfl_step:e} s, or method.cfl = 0.3 \
             instead"
        )
    })
}

/// The bodies whose mass as the method lumps it differs from ρ0 times the volume of the
/// shape the case names (beyond round-off, 1e-9), each with the difference: a lattice that
/// does not fit the shape within `body.N.volume_tolerance`, said at the start of a run.
fn mass_notes<D: Dim>(case: &Scene, snap: &Snapshot<D>) -> Vec<String> {
    let rho0 = crate::physics::material::Material::new(&case.material).rho0;
    case.bodies
        .iter()
        .enumerate()
        .filter(|(_, body)| body.holes.is_empty())
        .filter_map(|(b, body)| {
            let named = rho0 * body.geometry.volume(D::N)?;
            let mass: f64 = (0..snap.mass.len())
                .filter(|&i| snap.body[i] as usize == b)
                .map(|i| snap.mass[i])
                .sum();
            let difference = mass / named - 1.0;
            (difference.abs() > 1e-9).then(|| {
                format!(
                    "body `{}` has mass {mass:.6e} kg, {:+.3} % of ρ0 times the volume of \
                     the named shape ({named:.6e} kg): the lattice of spacing {} does not fit it",
                    body.name,
                    100.0 * difference,
                    case.spacing
                )
            })
        })
        .collect()
}

/// The cylinders whose sampled length along the axis differs from the named one beyond
/// round-off (1e-9), each with the difference ([`crate::case::Shape::sampled_length`]):
/// their volumes are scaled to the named shape, so the mass does not show it; said at the
/// start of a run (past `body.N.volume_tolerance` the case is refused).
fn length_notes(case: &Scene) -> Vec<String> {
    let cells = case.method.lattice_cells;
    case.bodies
        .iter()
        .filter_map(|body| {
            let (sampled, named) = body.geometry.sampled_length(case.spacing, cells)?;
            let difference = sampled / named - 1.0;
            (difference.abs() > 1e-9).then(|| {
                format!(
                    "body `{}` is sampled {sampled:.6e} m long along its axis, {:+.3} % of the \
                     named length {named:.6e} m (its volumes are scaled to the named volume): \
                     the length is no multiple of the spacing {}",
                    body.name,
                    100.0 * difference,
                    case.spacing
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{fixed_step_warning, length_notes};
    use crate::case::{Axis, Lattice, Shape};
    use crate::scene::validate::minimal_case;

    #[test]
    fn a_cylinder_sampled_short_of_its_length_is_said() {
        // 1.01 m at Δx = 0.1 m: the vertex lattice spans 1.0 m, −0.990 %; cell-centred, 10
        // layers of 0.1 m, the same; 1.0 m fits both (no note).
        let mut c = minimal_case();
        c.dimension = 3;
        let cylinder = |length: f64, lattice: Lattice| Shape::Cylinder {
            base: vec![0.0; 3],
            axis: Axis::Z,
            radius: 0.3,
            inner_radius: 0.0,
            length,
            lattice,
            volumes: None,
        };
        for lattice in [Lattice::Vertex, Lattice::CellCentred] {
            c.bodies[0].geometry = cylinder(1.01, lattice);
            let notes = length_notes(&c);
            assert!(
                notes.len() == 1 && notes[0].contains("-0.990 %") && notes[0].contains("`b`"),
                "{notes:?}"
            );
            c.bodies[0].geometry = cylinder(1.0, lattice);
            assert!(length_notes(&c).is_empty());
        }
    }

    #[test]
    fn a_fixed_step_above_the_cfl_step_is_named_with_the_limit() {
        assert_eq!(fixed_step_warning(0.5e-6, 1e-6), None);
        assert_eq!(fixed_step_warning(1e-6, 1e-6), None);
        let w = fixed_step_warning(4.6e-6, 1e-6).expect("a Courant number of 4.6");
        assert!(
            w.contains("4.60") && w.contains("1e-6") && w.contains("method.cfl"),
            "{w}"
        );
    }
}
