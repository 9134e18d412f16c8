//! Seed 003 §7.3.2's stent-like tube (`cases/stent.toml`): its cylindrical lattice and
//! holes, its three mirror planes against the solid they stand for, and its compression.

use crate::common::{case_file, load, run_mixed_steps};
use meshless::case::discretise;
use meshless::core::tensor::D3;
use meshless::scene::Scene;
use std::f64::consts::PI;

/// The wall's radii, the hole radius and the rows of holes of the whole tube: at z = 0,
/// ±5 mm the holes at θ = k · 22.5°, at ±2.5 and ±7.5 mm turned by 11.25°.
const INNER: f64 = 9.5e-3;
const OUTER: f64 = 10.0e-3;
const HOLE: f64 = 1.0e-3;

/// The holes whose rows lie in [z0, z1] and whose directions lie in [θ0, θ1] (degrees),
/// as TOML tables: each a line through the axis, so that it pierces the wall at θ and
/// θ + 180°.
fn holes((z0, z1): (f64, f64), (theta0, theta1): (f64, f64)) -> Vec<toml::Value> {
    let mut out = Vec::new();
    for row in -3i32..=3 {
        let z = 2.5e-3 * f64::from(row);
        if z < z0 - 1e-12 || z > z1 + 1e-12 {
            continue;
        }
        let turn = if row % 2 == 0 { 0.0 } else { 11.25 };
        for k in 0..16 {
            let theta = turn + 22.5 * f64::from(k);
            if theta < theta0 - 1e-9 || theta > theta1 + 1e-9 {
                continue;
            }
            let (s, c) = theta.to_radians().sin_cos();
            let text = format!(
                "center = [0.0, 0.0, {z:?}]\nradius = {HOLE:?}\naxis = [{c:?}, {s:?}, 0.0]"
            );
            out.push(toml::Value::Table(toml::from_str(&text).unwrap()));
        }
    }
    out
}

/// Whether two TOML values agree, their floats within 1e-15 (the shipped holes' digits).
fn close(a: &toml::Value, b: &toml::Value) -> bool {
    match (a, b) {
        (toml::Value::Array(a), toml::Value::Array(b)) => {
            a.len() == b.len() && a.iter().zip(b).all(|(a, b)| close(a, b))
        }
        (toml::Value::Table(a), toml::Value::Table(b)) => {
            a.len() == b.len() && a.iter().all(|(k, v)| b.get(k).is_some_and(|w| close(v, w)))
        }
        (a, b) => match (a.as_float(), b.as_float()) {
            (Some(x), Some(y)) => (x - y).abs() <= 1e-15,
            _ => a == b,
        },
    }
}

fn shipped_text() -> toml::Table {
    toml::from_str(&std::fs::read_to_string(case_file("stent")).unwrap()).unwrap()
}

/// The particles' reference positions of a case.
fn positions(case: &Scene) -> Vec<glam::DVec3> {
    discretise::<D3>(case).unwrap().x0
}

#[test]
fn the_tube_puts_two_particles_through_the_wall_and_the_holes_match_the_pattern() {
    // The shipped holes are the pattern's in the eighth (z ∈ [0, 10 mm], θ ∈ [0, 90°]).
    let table = shipped_text();
    let shipped = &table["body"][0]["holes"];
    let pattern = toml::Value::Array(holes((0.0, 10e-3), (0.0, 90.0)));
    assert!(
        close(shipped, &pattern),
        "the shipped holes are not the pattern's"
    );

    // Two layers of cell centres through the wall, r = 9.625 and 9.875 mm; inside the
    // eighth, off its faces; none in a hole; the volumes those of the tube's cells.
    let case = load("stent", &[] as &[&str]);
    let d = discretise::<D3>(&case).unwrap();
    let (dr, dz) = ((OUTER - INNER) / 2.0, 10e-3 / 40.0);
    let dtheta = PI / 2.0 / 61.0;
    for (x, v) in d.x0.iter().zip(&d.vol) {
        let r = x.x.hypot(x.y);
        let layer = ((r - INNER) / dr - 0.5).round();
        assert!(
            (layer == 0.0 || layer == 1.0) && (r - INNER - (layer + 0.5) * dr).abs() < 1e-15,
            "particle at {x}: r = {r}"
        );
        let r0 = INNER + layer * dr;
        let cell = 0.5 * ((r0 + dr).powi(2) - r0 * r0) * dtheta * dz;
        assert!((v / cell - 1.0).abs() < 1e-12, "volume {v} against {cell}");
        assert!(x.x > 0.0 && x.y > 0.0 && x.z > 0.0 && x.z < 10e-3, "{x}");
        for row in 0..4 {
            let z = 2.5e-3 * f64::from(row);
            let turn = if row % 2 == 0 { 0.0 } else { 11.25 };
            for k in 0..=4 {
                let (s, c) = (turn + 22.5 * f64::from(k)).to_radians().sin_cos();
                let p = glam::DVec3::new(x.x, x.y, x.z - z);
                let off =
                    (p - glam::DVec3::new(c, s, 0.0) * p.dot(glam::DVec3::new(c, s, 0.0))).length();
                assert!(off >= HOLE, "particle at {x} is {off} m from a hole's axis");
            }
        }
    }
}

#[test]
fn the_mirror_planes_give_the_eighth_of_the_half_tube() {
    // The eighth (x, y, z > 0, mirrors x = 0, y = 0, z = 0) against the half tube
    // (θ ∈ [0, 180°], z ∈ [−10, 10] mm, the mirror y = 0 only, both ends driven towards
    // the middle): the eighth's particles are the half's with x, z > 0, and the x and z
    // planes hold only if their ghosts move as the half's real particles there. Both
    // runs take 40 steps of the same Δt from eq 60's peak speed (c = 0: 1.2 m/s at the
    // ends from t = 0), so that the ends have moved 40 Δt · 1.2 m/s ≈ 0.04 mm and the
    // waves have crossed the holes' rows near them. The states agree to round-off: the
    // same pair sums, in another order, over steps that do not amplify it (1e-10 of the
    // largest displacement, a million times the f64 rounding).
    let overrides = ["boundary.0.condition.law.constants.c=0.0"];
    let eighth = load("stent", &overrides);

    let mut half = shipped_text();
    let body = half["body"][0].as_table_mut().unwrap();
    let geometry = body["geometry"].as_table_mut().unwrap();
    geometry.insert(
        "base".into(),
        toml::Value::try_from([0.0, 0.0, -10e-3]).unwrap(),
    );
    geometry.insert("length".into(), toml::Value::Float(20e-3));
    geometry.insert(
        "angles".into(),
        toml::Value::try_from([0.0, 180.0]).unwrap(),
    );
    // The eighth's 61 rays over 90°, twice: the arc over Δx alone gives 123.
    geometry.insert("sectors".into(), toml::Value::Integer(122));
    body.insert(
        "holes".into(),
        toml::Value::Array(holes((-10e-3, 10e-3), (0.0, 180.0))),
    );
    let mirrors = half["mirror"].as_array_mut().unwrap();
    mirrors.retain(|m| m["normal"].as_str() == Some("y"));
    let boundaries = half["boundary"].as_array_mut().unwrap();
    let mut start = boundaries[0].clone();
    let start_table = start.as_table_mut().unwrap();
    start_table.insert("name".into(), toml::Value::String("start".into()));
    let region: toml::Table = toml::from_str("z_max = -9.75e-3").unwrap();
    start_table.insert("region".into(), toml::Value::Table(region));
    start_table["condition"]
        .as_table_mut()
        .unwrap()
        .insert("vz".into(), toml::Value::Float(1.0));
    boundaries.push(start);
    let text = toml::to_string(&half).unwrap();
    let half = Scene::from_toml(&text, &case_file("stent"), &overrides.map(String::from)).unwrap();

    let steps = 40;
    let (x8, xh) = (positions(&eighth), positions(&half));
    let (e8, eh) = (
        run_mixed_steps::<D3>(&eighth, steps),
        run_mixed_steps::<D3>(&half, steps),
    );
    let key = |x: &glam::DVec3| (x * 1e8).round().as_i64vec3().to_array();
    let index: std::collections::HashMap<[i64; 3], usize> =
        xh.iter().enumerate().map(|(i, x)| (key(x), i)).collect();
    let largest = e8.y.u.iter().map(|u| u.length()).fold(0.0, f64::max);
    let mut worst: f64 = 0.0;
    for (a, x) in x8.iter().enumerate() {
        let b = index[&key(x)];
        worst = worst.max((e8.y.u[a] - eh.y.u[b]).length());
    }
    eprintln!(
        "{} and {} particles: max |Δu| = {worst:e} m of max |u| = {largest:e} m",
        x8.len(),
        xh.len()
    );
    assert_eq!(xh.len(), 4 * x8.len(), "the half holds four eighths");
    assert!(largest > 1e-5, "the ends moved {largest:e} m only");
    assert!(worst <= 1e-10 * largest, "max |Δu| = {worst:e} m");
}

#[cfg(feature = "study")]
#[test]
#[ignore = "finding: docs/methods/mixed.md"]
fn the_stent_compresses_to_figure_29_without_zero_energy_modes() {
    use crate::common::cpu_options;
    use meshless::output::series::read_column;
    use meshless::run::Backend;
    use meshless::study::engine::run_case;

    // Seed 003 §7.3.2: with two particles through the wall the structure is "freed from
    // zero energy modes" and its pressure "extremely well captured" at t = 0.0216 s
    // (Fig. 29), the ends having moved b/(1 + γ) = 5.97 mm. Asserted: the shipped case
    // completes to 0.0216 s; the hourglass indicator η (the misplacement of the bonds
    // against the particle's own F) stays below 0.05, where a mode that pairs particles a
    // tenth of a spacing apart gives 0.1.
    let case = load("stent", &["run.end_time=0.0216"]);
    let dir = tempfile::tempdir().unwrap();
    let outcome = run_case(&case, Backend::Cpu, &cpu_options(dir.path(), false));
    let series = dir.path().join("series.csv");
    let column = |name: &str| read_column(&series, name).unwrap();
    let eta = column("hourglass_max")
        .iter()
        .map(|&(_, e)| e)
        .fold(0.0, f64::max);
    eprintln!("largest η {eta:e}");
    outcome.result.unwrap();
    assert!(eta < 0.05, "hourglass indicator η = {eta:e}");
}

/// The hourglass indicator follows the load, at a size CI runs. Eq 60's pulse ten times
/// faster (a = 8000 1/s, b = 0.6 mm, c = 1.5 ms: the same peak speed, 1.2 m/s) drives the
/// shipped eighth to 1 ms, when its ends have moved u_e = b [1/(1 + e^{a(c−t)}) −
/// 1/(1 + e^{ac})] = 0.044Δx. In this linear response a smooth deformation's η is
/// O(Δx |∇F|), in proportion to u_e: η/(u_e/Δx) is a constant of the geometry. A
/// zero-energy mode is not driven by the load; seeded by round-off, one growing faster
/// than the load (whose rate is a) would raise that ratio. Asserted: from 0.3 ms
/// (u_e = 1.5e-4 Δx, past the start-up of the first rows) to 1 ms, while u_e grows 290
/// times, the ratio stays within 20 % of its value at 0.3 ms (measured: 0.024 there, 0.023
/// after; the geometric nonlinearity adds 5 % by 1.4 ms); and η at 1 ms is below 0.01
/// (measured 1.0e-3), where a mode pairing particles a tenth of a spacing apart gives 0.1.
#[test]
fn the_hourglass_indicator_follows_the_load() {
    use crate::common::cpu_options;
    use meshless::output::series::read_column;
    use meshless::run::run;

    let (a, b, c, spacing) = (8000.0, 6.0e-4, 1.5e-3, 2.5e-4);
    let law = format!("boundary.0.condition.law.constants={{ a = {a:?}, b = {b:?}, c = {c:?} }}");
    let case = load(
        "stent",
        &[&law, "run.end_time=1.0e-3", "output.series_interval=1.0e-4"],
    );
    let dir = tempfile::tempdir().unwrap();
    run(&case, &cpu_options(dir.path(), false)).unwrap();
    let eta = read_column(&dir.path().join("series.csv"), "hourglass_max").unwrap();
    let u_e = |t: f64| b * (1.0 / (1.0 + (a * (c - t)).exp()) - 1.0 / (1.0 + (a * c).exp()));
    let ratios: Vec<(f64, f64)> = (eta.iter())
        .filter(|&&(t, _)| t > 2.95e-4)
        .map(|&(t, e)| (t, e * spacing / u_e(t)))
        .collect();
    eprintln!("η/(u_e/Δx): {ratios:.4?}");
    let (first, (_, last_eta)) = (ratios[0].1, eta[eta.len() - 1]);
    assert!(ratios.len() >= 7, "{} rows from 0.3 ms", ratios.len());
    for &(t, ratio) in &ratios {
        assert!(
            (ratio / first - 1.0).abs() < 0.2,
            "at t = {t:e} s η/(u_e/Δx) = {ratio:e} against {first:e} at 0.3 ms"
        );
    }
    assert!(last_eta < 0.01, "η = {last_eta:e} at 1 ms");
}

/// The reaction at the loaded end is the change of momentum plus the internal force. On
/// eq 60's fast pulse (as in [`the_hourglass_indicator_follows_the_load`]) three
/// quantities the code computes apart are compared every 0.1 ms: the reaction R_z the
/// end's boundary books (m times the prescribed minus the free acceleration of the driven
/// layer), the rate of change of the momentum of the part above the plane z = 9 mm
/// (central differences of Σ m v_z over two steps), and the force S_z = ∫ P_zz dA across
/// that plane, from the particles' stresses with the hat weights of a `[[section]]`. The
/// plane lies in the hole-free band between the last row of holes (which ends at z =
/// 8.5 mm) and the driven layer (z > 9.75 mm), between the layers at 8.875 and 9.125 mm.
/// The part above feels the end's reaction and the pull of the wall below across the
/// plane, −S_z, so that R_z = d/dt Σ m v_z + S_z. Both terms carry weight: the inertia
/// is 31–33 % of R_z throughout (asserted above 20 %), the driven layer's alone about 8 %.
/// Asserted from 0.3 ms (the front of the first wave, which reached the plane at 0.02 ms,
/// has passed): |R_z − dP/dt − S_z| below 1 % of |R_z| (measured 0.2–0.4 %, the hat rule's
/// O(Δx²) error across the band), an eighth of the driven layer's inertia, which a
/// reaction booked without it would miss.
#[test]
fn the_end_s_reaction_is_the_change_of_momentum_plus_the_internal_force() {
    use meshless::engine::Engine;
    use meshless::methods::mixed::MixedSph;

    let (a, b, c) = (8000.0, 6.0e-4, 1.5e-3);
    let law = format!("boundary.0.condition.law.constants={{ a = {a:?}, b = {b:?}, c = {c:?} }}");
    let case = load("stent", &[&law]);
    let (cut, dx) = (9.0e-3, case.spacing);
    let rho0 = case.material.density;
    let mut e = meshless::scene::cpu_engine::<D3, MixedSph<D3>>(&case).unwrap();
    let dt = case.method.cfl.unwrap() * dx / e.max_signal_speed();
    let momentum_above = |e: &mut dyn Engine<D3>| {
        let s = e.snapshot();
        (s.x0.iter().zip(s.mass).zip(&s.v))
            .filter(|((x, _), _)| x.z > cut)
            .map(|((_, m), v)| m * v.z)
            .sum::<f64>()
    };
    let section = |e: &mut dyn Engine<D3>| {
        let s = e.snapshot();
        let mut force = 0.0;
        for i in 0..s.x0.len() {
            let w = (1.0 - (s.x0[i].z - cut).abs() / dx) / dx;
            if w > 0.0 {
                // P·N with N = e_z: J σ F⁻ᵀ e_z, its z component.
                let g = s.f[i].transpose().inverse() * glam::DVec3::Z;
                let row = s.sigma[i][2];
                let pzz = row[0] * g.x + row[1] * g.y + row[2] * g.z;
                force += s.f[i].determinant() * w * s.mass[i] / rho0 * pzz;
            }
        }
        force
    };
    let every = (1.0e-4 / dt).round() as u32;
    let mut t = 0.0;
    for k in 1..=10 {
        e.advance(t, dt, every - 1).unwrap();
        t += f64::from(every - 1) * dt;
        let before = momentum_above(&mut e);
        e.advance(t, dt, 1).unwrap();
        t += dt;
        let r = e.reactions()[0].force[2];
        let s = section(&mut e);
        e.advance(t, dt, 1).unwrap();
        t += dt;
        let rate = (momentum_above(&mut e) - before) / (2.0 * dt);
        eprintln!(
            "t = {:.3} ms: R_z = {r:e}, dP/dt = {rate:e}, S_z = {s:e}, R − dP/dt − S = {:e}",
            t * 1e3,
            r - rate - s
        );
        e.check().unwrap();
        if k >= 3 {
            assert!(
                (r - rate - s).abs() <= 0.01 * r.abs(),
                "at t = {t:e} s R_z = {r:e} N against dP/dt + S_z = {:e} N",
                rate + s
            );
            assert!(
                rate.abs() > 0.2 * r.abs(),
                "the inertia {rate:e} of {r:e} N"
            );
        }
    }
}
