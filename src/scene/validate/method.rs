//! `[method]`: the smoothing length, the step (`dt` or `cfl`), and the keys of other
//! methods. A method's own keys are its spec's (`MethodFamily::validate`).

use super::{Checked, fail, positive, toml_name};
use crate::case::MethodKeys;
use crate::methods::{REGISTRY, entry, quoted};
use crate::scene::Scene;

/// `h_over_dx` against the kernel's support, and one of `dt` and `cfl`.
pub(super) fn check(m: &MethodKeys) -> Checked {
    // The support radius (support factor × h) must reach the nearest lattice neighbour:
    // h ≥ Δx/2 for the kernels of support 2h, Δx/3 for the quintic (support 3h; seed 004
    // §6.4's smallest support, 0.9 times a particle's diameter, is h = 0.338 Δx).
    let h = m.h_over_dx;
    let lowest = 1.0 / m.kernel.support_factor();
    if !(h.is_finite() && (lowest..=4.0).contains(&h)) {
        return fail(
            "method.h_over_dx",
            format!(
                "must be a finite number in [{}, 4] (the {} kernel's support {}h must \
                 reach one spacing), got {h:?}",
                (lowest * 1e4).round() / 1e4,
                toml_name(&m.kernel),
                m.kernel.support_factor()
            ),
        );
    }
    match (m.dt, m.cfl) {
        (Some(dt), Some(cfl)) => {
            return fail(
                "method.dt",
                format!(
                    "`method.dt` = {dt:?} and `method.cfl` = {cfl:?} are both given; give \
                     exactly one of them: `dt` for a fixed time step [s] or `cfl` for an \
                     adaptive one"
                ),
            );
        }
        (None, None) => {
            return fail(
                "method.dt",
                "neither `method.dt` nor `method.cfl` is given; give exactly one of them: `dt` \
                 for a fixed time step [s] or `cfl` for an adaptive one",
            );
        }
        (Some(dt), None) => positive("method.dt", dt)?,
        (None, Some(cfl)) => {
            if !(cfl > 0.0 && cfl <= 2.0) {
                return fail("method.cfl", format!("must lie in (0, 2], got {cfl:?}"));
            }
        }
    }
    Ok(())
}

/// Keys of other methods in the `[method]` table: named with the methods that read them
/// and the keys this one reads.
pub(super) fn foreign_keys(scene: &Scene) -> Checked {
    let Some(key) = scene.foreign.first() else {
        return Ok(());
    };
    let name = scene.method.name;
    let owners = REGISTRY
        .iter()
        .filter(|e| e.keys.contains(&key.as_str()))
        .map(|e| e.name);
    let own = entry(name).map_or(&[][..], |e| e.keys);
    fail(
        format!("method.{key}"),
        format!(
            "is read only by {}, not by `{name}`; remove it (the keys of `{name}` besides \
             the common ones: {})",
            quoted(owners),
            if own.is_empty() {
                "none".to_string()
            } else {
                own.join(", ")
            }
        ),
    )
}
