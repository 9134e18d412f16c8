//! The GPU backend's shared machinery: wgpu compute shaders (WGSL) on storage buffers,
//! f32. The methods' GPU engines (`methods::<method>::gpu`) stand on it, each in a
//! [`shell::Shell`] that holds what they share.

pub mod bytes;
pub mod context;
pub mod layout;
pub mod memory;
pub mod neighbour;
pub mod parts;
pub mod plastic;
pub mod profile;
pub mod program;
pub mod reduction;
pub mod reference;
pub mod shaders;
pub mod shell;

pub use context::{Gpu, GpuError};
pub use layout::GpuDim;

use crate::case::{Case, CaseError};
use shaders::Constants;
use thiserror::Error;

/// Refuses reference positions, initial displacements and initial velocities beyond the
/// f32 range of the device, naming the body whose geometry or initial field gives them.
pub fn check_f32_particles<D: crate::core::tensor::Dim>(
    case: &Case,
    x0: &[D::V],
    u0: &[D::V],
    v0: &[D::V],
    body: &[u32],
) -> Result<(), CaseError> {
    let beyond = |v: &D::V| D::to3(*v).iter().any(|&c| !(c as f32).is_finite());
    for (key, what, values) in [
        ("geometry", "position", x0),
        ("initial_displacement", "displacement", u0),
        ("initial_velocity", "velocity", v0),
    ] {
        if let Some(i) = values.iter().position(beyond) {
            return Err(case.invalid(
                format!("body.{}.{key}", body[i]),
                format!(
                    "particle {i} has the {what} {:?}, beyond the f32 range (3.4e38) of the \
                     GPU; run with --backend cpu (f64), or express the case in other units",
                    D::to3(values[i])
                ),
            ));
        }
    }
    Ok(())
}

/// A GPU engine's state for a checkpoint: its [`reduction::WorkBalance`], then each
/// buffer (length, then its f32 values, exactly, as f64).
pub fn save_buffers(
    gpu: &Gpu,
    work: &reduction::WorkBalance,
    buffers: &[&wgpu::Buffer],
) -> Vec<f64> {
    let mut out = work.words().to_vec();
    for buffer in buffers {
        let flat: Vec<f32> = gpu.read(buffer);
        out.push(flat.len() as f64);
        out.extend(flat.iter().map(|&x| f64::from(x)));
    }
    out
}

/// Reads what [`save_buffers`] wrote into the same buffers (uploads them); returns the
/// work balance.
pub fn load_buffers(
    gpu: &Gpu,
    words: &[f64],
    buffers: &[(&str, &wgpu::Buffer)],
) -> Result<reduction::WorkBalance, String> {
    let (&work, mut rest) = words
        .split_first_chunk::<{ reduction::WORK_WORDS }>()
        .ok_or("the checkpoint holds no engine state")?;
    for (name, buffer) in buffers {
        let len = (buffer.size() / 4) as usize;
        match rest.split_first() {
            Some((&n, values)) if n == len as f64 && values.len() >= len => {
                let flat: Vec<f32> = values[..len].iter().map(|&x| x as f32).collect();
                gpu.queue
                    .write_buffer(buffer, 0, bytemuck::cast_slice(&flat));
                rest = &values[len..];
            }
            _ => {
                return Err(format!(
                    "the {name} buffer of the checkpoint does not have this run's {len} values"
                ));
            }
        }
    }
    if !rest.is_empty() {
        return Err(format!(
            "{} words are left over after the engine's state",
            rest.len()
        ));
    }
    Ok(reduction::WorkBalance::from_words(work))
}

/// Whether f32 holds `value`: finite, and normal unless zero (a subnormal keeps too few
/// digits, and a smaller value rounds to zero).
fn holds_f32(value: f64) -> bool {
    let f = value as f32;
    f.is_finite() && (value == 0.0 || f.is_normal())
}

/// The error of a value, valid in f64, that f32 cannot hold on the GPU.
fn beyond_f32(case: &Case, key: impl Into<String>, what: String) -> CaseError {
    case.invalid(
        key,
        format!(
            "{what}, which the f32 of the GPU backend cannot hold (normal f32 magnitudes lie between 1.2e-38 and 3.4e38); run with --backend cpu (f64), or express the case in other units"
        ),
    )
}

/// Refuses the values a GPU run reaches from the case besides its constants and initial
/// state: the time step in the integrator's coefficients (its smallest, Δt/6 of RK4;
/// a CFL step estimated as α Δx / c_p), prescribed velocities, the time laws over the run
/// times what they scale, the number of constrained particles (their slots are f32
/// integers) and the accelerations of the traction loads, each named by its key.
pub fn check_f32_run<D: crate::core::tensor::Dim>(
    case: &Case,
    boundary: &crate::boundary::Boundary<D>,
) -> Result<(), CaseError> {
    let (key, dt) = match (case.method.dt, case.method.cfl) {
        (Some(dt), _) => ("method.dt", dt),
        (_, cfl) => {
            let c_p = crate::physics::material::Material::new(&case.material).p_wave_speed();
            ("method.cfl", cfl.unwrap_or(0.0) * case.spacing / c_p)
        }
    };
    if !(holds_f32(dt) && holds_f32(dt / 6.0)) {
        return Err(beyond_f32(
            case,
            key,
            format!("gives the time step Δt = {dt:e} s (and Δt/6 in the stage coefficients)"),
        ));
    }
    for (b, bc) in case.boundaries.iter().enumerate() {
        if let crate::case::Condition::Velocity { vx, vy, vz, .. } = &bc.condition {
            for (name, v) in [("vx", vx), ("vy", vy), ("vz", vz)] {
                if let Some(v) = v.filter(|&v| !holds_f32(v)) {
                    return Err(beyond_f32(
                        case,
                        format!("boundary.{b}.condition.{name}"),
                        format!("prescribes the velocity {v:e} m/s"),
                    ));
                }
            }
        }
    }
    // A time law over the run times what it scales: the velocity or load it reaches, at
    // most f32's largest (a law that decays to nothing is fine). The constant laws' values
    // are the conditions' own, checked by key.
    for (b, bc) in case.boundaries.iter().enumerate() {
        let (law, scale) = (bc.condition.law(), bc.condition.law_scale());
        if law.is_constant() {
            continue;
        }
        let beyond = |(_, l): &(f64, f64)| (l * scale).abs() > f64::from(f32::MAX);
        if let Some((t, law)) = law.over_run(case.run.end_time).find(beyond) {
            return Err(beyond_f32(
                case,
                format!("boundary.{b}.condition.law"),
                format!(
                    "reaches {law:.4e} at t = {t:.4e} s, which makes the condition {:.4e}",
                    law * scale
                ),
            ));
        }
    }
    if boundary.constrained.len() > reference::MAX_SLOTS {
        return Err(case.invalid(
            "boundary",
            format!(
                "constrains {} particles, above the {} whose reactions the GPU indexes \
                 exactly (f32 integers); run with --backend cpu",
                boundary.constrained.len(),
                reference::MAX_SLOTS
            ),
        ));
    }
    let load = boundary
        .external
        .iter()
        .find(|(_, a)| D::to3(*a).iter().any(|&c| !holds_f32(c)));
    if let Some(&(i, a)) = load {
        // The traction or body force with the largest magnitude gives it.
        let magnitude = |t: &[f64]| t.iter().map(|c| c * c).sum::<f64>();
        let (b, name) = (0..case.boundaries.len())
            .filter_map(|b| match &case.boundaries[b].condition {
                crate::case::Condition::Traction { traction, .. } => {
                    Some((b, "traction", magnitude(traction)))
                }
                crate::case::Condition::BodyForce { acceleration, .. } => {
                    Some((b, "acceleration", magnitude(acceleration)))
                }
                _ => None,
            })
            .max_by(|x, y| x.2.total_cmp(&y.2))
            .map_or((0, "traction"), |(b, name, _)| (b, name));
        return Err(beyond_f32(
            case,
            format!("boundary.{b}.condition.{name}"),
            format!(
                "gives particle {i} the acceleration {:?} m/s² (f/m, or g)",
                D::to3(a)
            ),
        ));
    }
    Ok(())
}

/// Refuses scene constants that f32 cannot hold (a value valid in f64, such as E = 1e39
/// Pa or a density of 1e-46), naming the case key they come from.
pub fn check_f32_range(case: &Case, constants: &Constants) -> Result<(), CaseError> {
    let Some((name, value)) = constants.out_of_f32_range() else {
        return Ok(());
    };
    let rubber = case.material.model.reads_mooney_rivlin_constants();
    let key = match name {
        "RHO0" => "material.density",
        // The Mooney–Rivlin μ = c1 + c2 and the moduli and speeds that λ dominates.
        "MU" if rubber => "material.c1",
        "LAMBDA" | "BULK" | "C_P" | "C_S" if rubber => "material.lambda",
        "MU" | "LAMBDA" | "BULK" | "C_P" | "C_S" => "material.youngs_modulus",
        "MR_C1" => "material.c1",
        "MR_C2" => "material.c2",
        "MR_LAMBDA" => "material.lambda",
        "YIELD" => "material.yield_stress",
        "HARDENING" => "material.hardening_modulus",
        "HARDENING_EXPONENT" => "material.hardening_exponent",
        "RATE_COEFFICIENT" => "material.strain_rate_coefficient",
        "REFERENCE_RATE" => "material.reference_strain_rate",
        "THERMAL_EXPONENT" => "material.thermal_softening_exponent",
        "THERMAL_SPAN" => "material.melting_temperature",
        "HEATING" => "material.specific_heat",
        "EPS2" | "EPS4" => "method.jst",
        n if n.starts_with("AV_") => "method.artificial_viscosity",
        n if n.starts_with("AS_") => "method.artificial_stress",
        n if n.starts_with("XSPH_") => "method.xsph",
        _ => "spacing",
    };
    Err(case.invalid(
        key,
        format!(
            "gives the GPU constant {name} = {value:e}, which f32 cannot hold (normal f32 \
             magnitudes lie between 1.2e-38 and 3.4e38); run with --backend cpu (f64), or \
             express the case in other units"
        ),
    ))
}

/// Why a GPU engine could not be set up: the case, or the device.
#[derive(Debug, Error)]
pub enum SetupError {
    #[error(transparent)]
    Case(#[from] CaseError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
}
