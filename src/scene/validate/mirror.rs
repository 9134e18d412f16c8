//! `[[mirror]]`: symmetry and skew-symmetry planes closed by ghost particles.

use super::{Checked, fail, feature, finite, only_in_3d, toml_name};
use crate::case::Case;
use crate::methods::Feature;

/// Mirror planes: a method that runs them, at most two per axis. Where the particles lie
/// against the planes is checked when the ghosts are built.
pub(super) fn check(case: &Case) -> Checked {
    let dim = case.dim();
    for (i, mirror) in case.mirrors.iter().enumerate() {
        let key = format!("mirror.{i}");
        feature(
            case,
            Feature::MirrorPlanes,
            &key,
            "mirror planes are ghost particles",
            "use a [[boundary]] with a `symmetry` condition instead",
        )?;
        if mirror.normal.index() >= dim {
            return only_in_3d(
                format!("{key}.normal"),
                dim,
                Some("z"),
                "use \"x\" or \"y\"",
            );
        }
        finite(&format!("{key}.at"), mirror.at)?;
        let same_axis = case.mirrors[..i]
            .iter()
            .filter(|o| o.normal == mirror.normal)
            .count();
        if same_axis >= 2 {
            return fail(
                format!("{key}.normal"),
                format!(
                    "a body lies between at most two planes normal to {}; this is the third",
                    toml_name(&mirror.normal)
                ),
            );
        }
    }
    Ok(())
}
