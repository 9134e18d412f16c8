//! `[material]`: the keys each model reads, their ranges, and the plane assumption.

use super::{Checked, fail, finite, non_negative, positive, toml_name};
use crate::physics::material::{Material, MaterialModel, MaterialSpec, ObjectiveRate, Plane};

/// A key of `[material]` that only some models read.
struct ModelKey {
    key: &'static str,
    value: Option<f64>,
    reads: fn(MaterialModel) -> bool,
    /// The models that must be given it (the others that read it take it as an option).
    required: fn(MaterialModel) -> bool,
    /// What a model that reads it must be given.
    needs: &'static str,
}

/// The keys of `[material]` that only some models read.
fn model_keys(m: &MaterialSpec) -> [ModelKey; 15] {
    let elastic = |model: MaterialModel| !model.reads_mooney_rivlin_constants();
    let plastic = |model| model == MaterialModel::VonMisesPlastic;
    // The rate model takes a yield stress as an option (a radial return of S).
    let yielding =
        |model| model == MaterialModel::VonMisesPlastic || model == MaterialModel::Hypoelastic;
    let rubber = MaterialModel::reads_mooney_rivlin_constants;
    const E_NU: &str = "give `youngs_modulus` (E [Pa], > 0) and `poisson_ratio` (ν in (−1, 0.5))";
    const PLASTIC: &str = "give `yield_stress` (τ_y⁰ [Pa], > 0) and `hardening_modulus` (H \
                           [Pa], > −3μ; negative softens, the yield stress stopping at zero)";
    const RUBBER: &str = "give `c1` [Pa] (> 0), `c2` [Pa] (≥ 0) and `lambda` [Pa] (> 0), the \
                          constants of seed 001 eq 18";
    let key = |key, value, reads, needs| ModelKey {
        key,
        value,
        reads,
        required: reads,
        needs,
    };
    let option = |key, value| ModelKey {
        key,
        value,
        reads: yielding,
        required: plastic,
        needs: PLASTIC,
    };
    // Johnson–Cook's terms, which the hyperelastic-plastic model takes as options.
    let johnson_cook = |key, value| ModelKey {
        key,
        value,
        reads: plastic,
        required: |_| false,
        needs: "",
    };
    [
        key("youngs_modulus", m.youngs_modulus, elastic, E_NU),
        key("poisson_ratio", m.poisson_ratio, elastic, E_NU),
        option("yield_stress", m.yield_stress),
        option("hardening_modulus", m.hardening_modulus),
        johnson_cook("hardening_exponent", m.hardening_exponent),
        johnson_cook("strain_rate_coefficient", m.strain_rate_coefficient),
        johnson_cook("reference_strain_rate", m.reference_strain_rate),
        johnson_cook("thermal_softening_exponent", m.thermal_softening_exponent),
        johnson_cook("melting_temperature", m.melting_temperature),
        johnson_cook("room_temperature", m.room_temperature),
        johnson_cook("specific_heat", m.specific_heat),
        johnson_cook("taylor_quinney", m.taylor_quinney),
        key("c1", m.c1, rubber, RUBBER),
        key("c2", m.c2, rubber, RUBBER),
        key("lambda", m.lambda, rubber, RUBBER),
    ]
}

/// Checks of the `[material]` table; ν = 0.5 where the method accepts it.
pub(super) fn check(m: &MaterialSpec, incompressible: bool) -> Checked {
    positive("material.density", m.density)?;
    for ModelKey {
        key,
        value,
        reads,
        required,
        needs,
    } in model_keys(m)
    {
        let key = format!("material.{key}");
        match value {
            Some(_) if !reads(m.model) => {
                let names: Vec<String> = MaterialModel::ALL
                    .iter()
                    .filter(|&&r| reads(r))
                    .map(|r| format!("`{}`", toml_name(r)))
                    .collect();
                return fail(
                    key,
                    format!(
                        "is read only by {}, not by `{}`; remove it",
                        names.join(", "),
                        toml_name(&m.model)
                    ),
                );
            }
            None if required(m.model) => {
                return fail(
                    key,
                    format!("the `{}` model needs it: {needs}", toml_name(&m.model)),
                );
            }
            _ => {}
        }
    }
    if m.objective_rate.is_some() && !m.model.is_rate_based() {
        return fail(
            "material.objective_rate",
            format!(
                "is read only by {}, not by `{}`, whose stress follows from F and is objective \
                 as it is; remove it",
                MaterialModel::names_where(MaterialModel::is_rate_based),
                toml_name(&m.model)
            ),
        );
    }
    if m.model == MaterialModel::Hypoelastic {
        rate_plasticity(m)?;
    }
    if let Some(e) = m.youngs_modulus {
        positive("material.youngs_modulus", e)?;
    }
    if let Some(nu) = m.poisson_ratio
        && !(nu > -1.0 && (nu < 0.5 || (nu == 0.5 && incompressible)))
    {
        return fail(
            "material.poisson_ratio",
            format!(
                "is {nu:?}; it must lie in (−1, 0.5); 0.5 is incompressible, which only \
                 `upwind-sph` and `jst-sph` with [method.artificial_compressibility] and the \
                 `nearly-incompressible-neo-hookean` model run"
            ),
        );
    }
    if let Some(y) = m.yield_stress {
        positive("material.yield_stress", y)?;
    }
    if let Some(h) = m.hardening_modulus {
        finite("material.hardening_modulus", h)?;
        // Δγ = f/(3μ + H) of the radial return needs 3μ + H > 0: the yield function then
        // decreases along the return and has one root.
        let mu = Material::new(m).mu;
        if h <= -3.0 * mu {
            return fail(
                "material.hardening_modulus",
                format!(
                    "is {h:?}; softening (H < 0) must stay above −3μ = {:e} Pa (μ = E/(2(1 + \
                     ν))), where the radial return has no unique solution",
                    -3.0 * mu
                ),
            );
        }
    }
    johnson_cook(m)?;
    if let Some(c1) = m.c1 {
        positive("material.c1", c1)?;
    }
    if let Some(c2) = m.c2 {
        non_negative("material.c2", c2)?;
    }
    if let Some(lambda) = m.lambda {
        positive("material.lambda", lambda)?;
    }
    Ok(())
}

/// Johnson–Cook's terms of `von-mises-plastic`: a positive exponent, with softening only
/// on the linear law; a rate coefficient ≥ 0 and its reference rate; and the thermal
/// softening's exponent, melting temperature and specific heat together, above the room
/// temperature.
fn johnson_cook(m: &MaterialSpec) -> Checked {
    if let Some(n) = m.hardening_exponent {
        positive("material.hardening_exponent", n)?;
        if n != 1.0 && m.hardening_modulus.is_some_and(|h| h < 0.0) {
            return fail(
                "material.hardening_exponent",
                format!(
                    "is {n:?} with a negative `hardening_modulus`: softening is linear only \
                     (the return's root is then unique); use hardening_exponent = 1 or a \
                     modulus ≥ 0"
                ),
            );
        }
    }
    if let Some(c) = m.strain_rate_coefficient {
        non_negative("material.strain_rate_coefficient", c)?;
    }
    if let Some(rate) = m.reference_strain_rate {
        positive("material.reference_strain_rate", rate)?;
        if m.strain_rate_coefficient.is_none() {
            return fail(
                "material.reference_strain_rate",
                "is the reference of the strain-rate term, which needs \
                 `strain_rate_coefficient` (Johnson–Cook's C, ≥ 0): give it, or remove this",
            );
        }
    }
    const THERMAL: &str = "give `thermal_softening_exponent` (m, > 0), \
                           `melting_temperature` (T_m [K]) and `specific_heat` (c_p [J/(kg K)], \
                           > 0) together";
    let thermal = [
        ("thermal_softening_exponent", m.thermal_softening_exponent),
        ("melting_temperature", m.melting_temperature),
        ("specific_heat", m.specific_heat),
    ];
    let given = thermal.iter().filter(|(_, v)| v.is_some()).count();
    if given == 0 {
        for (key, value) in [
            ("room_temperature", m.room_temperature),
            ("taylor_quinney", m.taylor_quinney),
        ] {
            if value.is_some() {
                return fail(
                    format!("material.{key}"),
                    format!(
                        "belongs to the thermal softening, which is off: {THERMAL}, or remove it"
                    ),
                );
            }
        }
        return Ok(());
    }
    if let Some((key, _)) = thermal.iter().find(|(_, v)| v.is_none()) {
        return fail(format!("material.{key}"), format!("is missing: {THERMAL}"));
    }
    for (key, value) in thermal {
        positive(&format!("material.{key}"), value.unwrap_or(f64::NAN))?;
    }
    let room = m.room_temperature.unwrap_or(MaterialSpec::ROOM_TEMPERATURE);
    positive("material.room_temperature", room)?;
    let melting = m.melting_temperature.unwrap_or(f64::NAN);
    if melting <= room {
        return fail(
            "material.melting_temperature",
            format!(
                "is {melting:?} K, at or below the room temperature {room:?} K; the thermal \
                 softening needs T_m > T_r"
            ),
        );
    }
    if let Some(chi) = m.taylor_quinney
        && !(0.0..=1.0).contains(&chi)
    {
        return fail(
            "material.taylor_quinney",
            format!("is {chi:?}; the fraction of the plastic work that heats lies in [0, 1]"),
        );
    }
    Ok(())
}

/// The yield stress of the rate model: `hardening_modulus` only with it, and a rate that
/// keeps S deviatoric, which the radial return scales.
fn rate_plasticity(m: &MaterialSpec) -> Checked {
    if m.yield_stress.is_none() {
        if m.hardening_modulus.is_some() {
            return fail(
                "material.hardening_modulus",
                "hardens the yield stress of the `hypoelastic` model, which has none: give                  `yield_stress` (τ_y⁰ [Pa], > 0) too, or remove it",
            );
        }
        return Ok(());
    }
    if m.objective_rate == Some(ObjectiveRate::Truesdell) {
        return fail(
            "material.objective_rate",
            "\"truesdell\" does not keep S deviatoric, and the radial return of              `yield_stress` scales a deviatoric S onto the von Mises surface: use              \"jaumann\" or \"green-naghdi\" with a yield stress",
        );
    }
    if m.plane == Plane::Stress {
        return fail(
            "material.plane",
            "\"stress\" with a `yield_stress`: the radial return is that of plane strain              and 3D (σ_zz = 0 would need an iterated return); use plane = \"strain\"",
        );
    }
    Ok(())
}

/// Plane stress is a 2D assumption, which the models linear in their strain measure take.
pub(super) fn plane(m: &MaterialSpec, dim: usize) -> Checked {
    if m.plane == Plane::Strain {
        return Ok(());
    }
    if dim != 2 {
        return fail(
            "material.plane",
            "applies to 2D scenes (dimension = 2) only; remove it from a 3D case",
        );
    }
    if !MaterialModel::PLANE_STRESS.contains(&m.model) {
        let models: Vec<String> = MaterialModel::PLANE_STRESS
            .iter()
            .map(|m| format!("`{}`", toml_name(m)))
            .collect();
        return fail(
            "material.plane",
            format!(
                "\"stress\" is taken by the models {} (linear in their strain measure), not \
                 by `{}`, whose σ_zz = 0 would need a per-particle solve for F_zz; use \
                 plane = \"strain\" or one of those models",
                models.join(", "),
                toml_name(&m.model)
            ),
        );
    }
    Ok(())
}
