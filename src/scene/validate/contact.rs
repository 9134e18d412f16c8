//! `[contact]`: penalty contact between the bodies.

use super::{Checked, fail, feature};
use crate::case::{Case, ContactSpec};
use crate::methods::Feature;

/// Penalty contact: 2D, a method that runs it, at least two bodies, 0 < α ≤ 1. That the bodies lie
/// apart by more than the kernel support is checked on their particles, when the method
/// finds its neighbours.
pub(super) fn check(case: &Case) -> Checked {
    let Some(ContactSpec { penalty }) = case.contact else {
        return Ok(());
    };
    if !(penalty > 0.0 && penalty <= 1.0) {
        return fail(
            "contact.penalty",
            format!(
                "must lie in (0, 1] (the fraction of a penetration removed in one step; the \
                 seed uses 0.1), got {penalty:?}"
            ),
        );
    }
    if case.dim() != 2 {
        return fail(
            "contact",
            "contact finds each body's boundary as a 2D convex hull; a 3D case cannot have \
             contact, remove the [contact] table",
        );
    }
    feature(
        case,
        Feature::Contact,
        "contact",
        "penalty contact is a pass of the methods",
        "remove the [contact] table",
    )?;
    if case.bodies.len() < 2 {
        return fail(
            "contact",
            "contact acts between bodies and the case has one; add a [[body]] or remove the \
             [contact] table",
        );
    }
    Ok(())
}
