//! Dual-support SPH (seed 004) on the paper's remaining examples, at test sizes: the plate
//! under compression with the hourglass penalty swept (§6.2), the smoothing-length study
//! on the plane-stress beam (§6.4), the rubber pull to 500 % (§6.5) and the Newton
//! convergence of the hyperelastic cube (§6.6); the static FEM references of the plate and
//! the cube (`tl-fem` with its closed-form stiffness). The paper-scale figures of
//! docs/methods/dual-support.md come from the suites `plate-hourglass`, `beam-smoothing`
//! and `rubber-pull` (`meshless study …`).

use meshless::core::tensor::{D2, D3, Dim};
use meshless::diagnostics::analytic::Cantilever;
use meshless::methods::dual_support::Statics;
use meshless::run::{Backend, Engine, Iteration};

/// The static engine of a shipped case with overrides.
fn engine<D: Dim>(name: &str, set: &[String]) -> Statics<D> {
    let case = crate::common::load(name, set);
    let meshless::methods::MethodSpec::DualSupportSph(spec) = &case.spec else {
        panic!("{name} runs dual-support-sph")
    };
    Statics::<D>::new(&case, spec).unwrap_or_else(|e| panic!("{e}"))
}

fn set(items: &[&str]) -> Vec<String> {
    items.iter().map(|s| s.to_string()).collect()
}

/// (max u_x, min u_y) of the plate with hourglass penalty α.
fn plate(alpha: f64, extra: &[&str]) -> (f64, f64) {
    let mut overrides = set(extra);
    overrides.push(format!("method.hourglass={alpha}"));
    let mut e = engine::<D2>("plate-compression-2d", &overrides);
    e.advance(0.0, 1.0, 1).unwrap_or_else(|f| panic!("{f:?}"));
    let ux = e.u.iter().map(|u| u.x).fold(f64::NEG_INFINITY, f64::max);
    let uy = e.u.iter().map(|u| u.y).fold(f64::INFINITY, f64::min);
    (ux, uy)
}

#[test]
fn the_plate_hourglass_penalty_sweep_softens_then_locks() {
    // Seed 004 §6.2, Table 2 at p/E = 0.2 (note §4.2): max u_y −0.175, −0.1664,
    // −0.16367, −0.1604, −0.1465 for α = 0.2, 2, 10, 100, 1e3 (Abaqus −0.178); α = 1e5
    // locks at −0.0267. Measured on the shipped 20 × 20 irregular plate: −0.1842,
    // −0.1685, −0.1652, −0.1601, −0.1433, −0.0222. Bounds: within 6 % of the paper's value
    // for α ≤ 1e3 (its mesh is another irregular one; our 40 × 40 plate moves the values
    // by up to 2 %), |u_y| falls monotonically with α, and α = 1e5 keeps less than a
    // quarter of the α = 1 value (the paper: 15 %). A wrong hourglass sign or scale
    // (eq 27, eq 29 without the 2) moves these by far more.
    let alphas = [0.2, 2.0, 10.0, 100.0, 1e3, 1e5];
    let paper = [-0.175, -0.1664, -0.16367, -0.1604, -0.1465];
    let uy: Vec<f64> = alphas.iter().map(|&a| plate(a, &[]).1).collect();
    for ((a, u), p) in alphas.iter().zip(&uy).zip(paper) {
        assert!((u / p - 1.0).abs() < 0.06, "α = {a}: {u}; all {uy:?}");
    }
    for w in uy.windows(2) {
        assert!(w[1] > w[0], "not monotone: {uy:?}");
    }
    let (_, default) = plate(1.0, &[]);
    assert!(uy[5] / default < 0.25, "{uy:?} vs {default}");
}

/// ‖u‖_error of eq 56 and the strain energy Σ V ψ of the plane-stress beam at spacing
/// Δx with h_over_dx, and the overrides `extra`.
fn beam(spacing: f64, h_over_dx: f64, extra: &[&str]) -> (f64, f64) {
    let mut overrides = set(extra);
    overrides.push(format!("spacing={spacing}"));
    overrides.push(format!("method.h_over_dx={h_over_dx}"));
    let mut e = engine::<D2>("beam-smoothing-2d", &overrides);
    e.advance(0.0, 1.0, 1).unwrap_or_else(|f| panic!("{f:?}"));
    let exact = Cantilever {
        load: -1000.0,
        length: 8.0,
        depth: 3.0,
        youngs_modulus: 3.0e10,
        poisson_ratio: 0.3,
    };
    let s = &e.model.support;
    let (mut num, mut den) = (0.0, 0.0);
    for ((x, u), v) in s.x0.iter().zip(&e.u).zip(&s.vol) {
        let [ux, uy] = exact.displacement(x.x, x.y);
        num += ((ux - u.x).powi(2) + (uy - u.y).powi(2)) * v;
        den += (ux * ux + uy * uy) * v;
    }
    ((num / den).sqrt(), e.model.energies(&e.u).strain.value())
}

/// The paper's n of eq 58 as the kernel's h_over_dx: support radius n · 2√(V/π) with
/// V = Δx², over the quintic's 3h.
fn h_over_dx(n: f64) -> f64 {
    n * 2.0 / (3.0 * std::f64::consts::PI.sqrt())
}

#[test]
fn the_beam_error_has_a_minimum_in_the_smoothing_length() {
    // Seed 004 §6.4: the error is not monotone in n; n = 0.9 is still acceptable and the
    // error grows beyond the optimum (the paper's n ≈ 2.2). Measured at Δx = 0.5 m: see
    // the method page. Bounds: n = 0.9 solves (every L_i invertible with 4 lattice
    // neighbours) within 10 % in ‖u‖ (the paper's Fig. 13 spans a few per cent; a missing
    // dual-support term or a singular L would be off by far more), the error at n = 3.8
    // exceeds the one at n = 2.2, and the smallest error lies strictly inside the sweep.
    let ns = [0.9, 1.5, 2.2, 3.0, 3.8];
    let errors: Vec<f64> = ns.iter().map(|&n| beam(0.5, h_over_dx(n), &[]).0).collect();
    assert!(errors[0] < 0.1, "{errors:?}");
    assert!(errors[4] > errors[2], "{errors:?}");
    let best = (0..ns.len())
        .min_by(|&a, &b| errors[a].total_cmp(&errors[b]))
        .unwrap();
    assert!(best > 0 && best < ns.len() - 1, "{errors:?}");
}

/// The n of the sweep 1.2 … 3.8 with the smallest ‖u‖_error of the beam at Δx = 0.25 m
/// on the particles of `points` (None: the vertex lattice), and the errors.
fn best_n(points: Option<&str>) -> (f64, Vec<f64>) {
    let ns = [1.2, 1.5, 2.0, 2.2, 2.4, 3.0, 3.8];
    let geometry = points
        .map(|file| format!("body.0.geometry={{ shape = \"points\", file = \"points/{file}\" }}"));
    // A points body's face reaches Δx/2 past its particles unless the region bounds it.
    let mut extra = vec!["boundary.1.region={ x_min = 8.0, y_min = -1.5, y_max = 1.5 }"];
    extra.extend(geometry.as_deref());
    let errors: Vec<f64> = ns
        .iter()
        .map(|&n| beam(0.25, h_over_dx(n), &extra).0)
        .collect();
    let best = (0..ns.len())
        .min_by(|&a, &b| errors[a].total_cmp(&errors[b]))
        .unwrap();
    (ns[best], errors)
}

#[test]
fn the_beam_s_best_smoothing_length_grows_with_the_clouds_irregularity() {
    // Seed 004 §6.4 puts the optimum at n ≈ 2.2 on its unpublished irregular mesh (Fig.
    // 12). The optimum is the cloud's: on the vertex lattice it is n = 2 (measured
    // ‖u‖_error 0.0062), on the nodes of a quadrilateral mesh with interior nodes moved
    // by up to ±Δx/8 n = 2.4 (0.0287), by up to ±Δx/4 n = 3 (0.0499), each with the
    // element areas averaged to the nodes (`points/quad_mesh_points.py --nodes 32 12 0.25
    // a 17 0 -1.5`). Bounds: the optimum grows strictly with the disorder, and the paper's
    // 2.2 lies between the lattice's and the most disordered cloud's.
    let (lattice, e0) = best_n(None);
    let (mild, e1) = best_n(Some("beam-nodes-irregular-8.csv"));
    let (strong, e2) = best_n(Some("beam-nodes-irregular-4.csv"));
    let all = format!("{e0:?}\n{e1:?}\n{e2:?}");
    assert!(
        lattice < mild && mild < strong,
        "n* {lattice}, {mild}, {strong}:\n{all}"
    );
    assert!(
        (lattice..=strong).contains(&2.2),
        "n* {lattice} to {strong}:\n{all}"
    );
}

/// The strain energy Σ V ψ [J] of the tension bar at spacing Δx with hourglass penalty α,
/// on the particles of `points` (None: the vertex lattice).
fn bar(spacing: f64, alpha: f64, points: Option<&str>) -> f64 {
    let mut overrides = vec![
        format!("spacing={spacing}"),
        format!("method.hourglass={alpha}"),
        // A points body's face reaches Δx/2 past its particles unless the region bounds it.
        "boundary.3.region={ x_min = 8.0, y_min = -1.5, y_max = 1.5, z_min = 0.0, z_max = 2.0 }"
            .to_string(),
    ];
    if let Some(file) = points {
        overrides.push(format!(
            "body.0.geometry={{ shape = \"points\", file = \"points/{file}\" }}"
        ));
    }
    let mut e = engine::<D3>("tension-bar-3d", &overrides);
    e.advance(0.0, 1.0, 1).unwrap_or_else(|f| panic!("{f:?}"));
    e.model.energies(&e.u).strain.value()
}

#[test]
fn without_hourglass_control_a_disordered_bar_stores_more_energy_with_refinement() {
    // Seed 004 §6.3, Table 3: without hourglass control the bar's strain energy (800 J
    // exact) is 874.9 J and 901.5 J on its irregular clouds of 2,609 and 14,250
    // particles: above 800 and growing with refinement. On the vertex lattice it is
    // 818.1 and 808.2 J at Δx = 0.5 and 0.25 m, falling. On the nodes of a hexahedral
    // mesh disordered by up to ±Δx/8 (`points/hex_mesh_points.py 16 6 4 0.5 0.125 17 0
    // -1.5 0` and its 32 12 8 0.25 refinement) it is 909.8 and 999.2 J (1,038.4 J at Δx =
    // 1/6), growing, and control brings it back to 815.4 and 814.3 J. So the paper's
    // growth is its cloud's. Bounds: on the lattice the energy falls with Δx and stays
    // within 3 % of 800 J; on the disordered cloud it grows with refinement and exceeds
    // the controlled run's by more than 10 % at both spacings.
    let lattice = [bar(0.5, 0.0, None), bar(0.25, 0.0, None)];
    assert!(lattice[1] < lattice[0], "lattice: {lattice:?}");
    assert!(
        lattice.iter().all(|e| (e / 800.0 - 1.0).abs() < 0.03),
        "{lattice:?}"
    );
    let files = [
        "bar-nodes-irregular-8-0.5.csv",
        "bar-nodes-irregular-8-0.25.csv",
    ];
    let spacings = [0.5, 0.25];
    let free: Vec<f64> = (files.iter().zip(spacings))
        .map(|(f, dx)| bar(dx, 0.0, Some(f)))
        .collect();
    let controlled: Vec<f64> = (files.iter().zip(spacings))
        .map(|(f, dx)| bar(dx, 1.0, Some(f)))
        .collect();
    assert!(free[1] > free[0], "disordered, α = 0: {free:?}");
    for (f, c) in free.iter().zip(&controlled) {
        assert!(
            f > &(1.1 * c),
            "α = 0 {free:?} against α = μ {controlled:?}"
        );
    }
}

/// The rubber sheet with the shipped 40 increments of 0.25 mm: the top displacement [m]
/// reached, load step by load step, until Newton fails, and the top displacement of the
/// first load step whose Newton iterations met an indefinite tangent (solved by LU).
fn rubber(alpha: f64, extra: &[&str]) -> (f64, Option<f64>) {
    let mut overrides = set(extra);
    overrides.push(format!("method.hourglass={alpha}"));
    let mut e = engine::<D2>("rubber-pull-2d", &overrides);
    let dt = 0.025;
    let mut indefinite = None;
    for k in 0..40 {
        let outcome = e.advance(f64::from(k) * dt, dt, 1);
        if indefinite.is_none() && e.iterations().iter().any(|it| it.indefinite) {
            indefinite = Some(f64::from(k + 1) * 0.25e-3);
        }
        if let Err(failed) = outcome {
            eprintln!("α = {alpha}: {}", failed.cause.quantity);
            return (f64::from(k) * 0.25e-3, indefinite);
        }
    }
    (10.0e-3, indefinite)
}

#[test]
fn the_rubber_loses_stability_without_hourglass_control_only() {
    // Seed 004 §6.5: without hourglass control Newton fails beyond 8 mm of the top
    // displacement (regular layout; 8.25 mm irregular); with α = 5μ the sheet reaches
    // 10 mm (500 %). Measured on the shipped regular 20 × 20 sheet: without control the
    // tangent turns indefinite at the increment to 8.75 mm, where Cholesky refuses it;
    // LU solves it and Newton converges on to 10 mm. With control the tangent stays
    // positive definite to 10 mm. Bounds: the loss of stability without control between
    // 5 and 10 mm (the paper's 8 mm, with a margin for its unpublished layout); none
    // with control. Without the linearised predictor of prescribed moves both fail at
    // the first 0.25 mm increment.
    let (with, with_indefinite) = rubber(5.0, &[]);
    let (without, without_indefinite) = rubber(0.0, &[]);
    assert_eq!(with, 10.0e-3, "α = 5μ stopped at {with} m");
    assert_eq!(with_indefinite, None, "α = 5μ met an indefinite tangent");
    assert_eq!(without, 10.0e-3, "α = 0 stopped at {without} m");
    let onset = without_indefinite.expect("α = 0 stays positive definite");
    assert!(
        (5.0e-3..10.0e-3).contains(&onset),
        "α = 0: indefinite at {onset} m"
    );
}

/// The Newton iterations of every load step of a log, and the relative residuals of each.
fn by_step(log: &[Iteration]) -> Vec<Vec<f64>> {
    let mut steps: Vec<Vec<f64>> = Vec::new();
    for it in log {
        if it.iteration == 0 {
            steps.push(Vec::new());
        }
        steps.last_mut().unwrap().push(it.relative_residual);
    }
    steps
}

/// The relative residuals of each of the four load steps of a log, asserting that each
/// converges within 10 iterations and quadratically: r_k+1 < 100 r_k² once r_k < 1e-3.
fn quadratic_in_four_steps(log: &[Iteration]) -> Vec<Vec<f64>> {
    let steps = by_step(log);
    assert_eq!(steps.len(), 4, "{steps:?}");
    for s in &steps {
        assert!(s.len() - 1 <= 10, "{steps:?}");
        for w in s.windows(2) {
            if w[0] < 1e-3 && w[1] > 1e-13 {
                assert!(w[1] < 100.0 * w[0] * w[0], "not quadratic: {steps:?}");
            }
        }
    }
    steps
}

#[test]
fn the_cube_converges_quadratically_in_each_load_sub_step() {
    // Seed 004 §6.6: 4 load sub-steps, Newton iterations (4, 4, 5, 7). On 9³ particles
    // (Δx = 1/8 m, direct solve) measured (4, 4, 5, 6) to 1e-10 of the force scale, with
    // r_k+1/r_k² up to 25 in the last sub-step. Every sub-step converges within 10
    // iterations and, once the relative residual r_k is below 1e-3, r_k+1 < 100 r_k²
    // (quadratic; a tangent missing the geometric or the J_FF part converges linearly,
    // r_k+1 ~ c r_k with c ≫ 100 r_k there); the last sub-step needs at least as many as
    // the first (the nonlinearity grows with the load).
    let mut e = engine::<D3>(
        "hyperelastic-cube-3d",
        &set(&["spacing=0.125", "method.solver=direct"]),
    );
    e.advance(0.0, 0.25, 4).unwrap_or_else(|f| panic!("{f:?}"));
    let steps = quadratic_in_four_steps(&e.iterations());
    assert!(steps[3].len() >= steps[0].len(), "{steps:?}");
    let uz = e.u.iter().map(|u| u.z).fold(f64::INFINITY, f64::min);
    eprintln!(
        "cube 9³: iterations {:?}, largest u_z {uz}",
        steps.iter().map(|s| s.len() - 1).collect::<Vec<_>>()
    );
    assert!(uz < -0.2 && uz > -0.5, "largest u_z {uz}");
}

/// The CPU engine of a shipped case with overrides, whatever its method.
fn any_engine<D: meshless::run::EngineDim>(name: &str, set: &[String]) -> Box<dyn Engine<D>> {
    let case = crate::common::load(name, set);
    meshless::run::engine::<D>(&case, Backend::Cpu).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_bilinear_plate_gives_the_abaqus_values_in_one_newton_iteration() {
    // Seed 004 §6.2's Abaqus reference, max u_y −0.178 and max u_x 0.04 at p/E = 0.2
    // (note §4.2), from our own bilinear elements on the 20 × 20 lattice
    // (`plate-compression-fem`). Measured: −0.17873 and 0.04038 (−0.17886 and 0.04036 on
    // 80 × 80). Bounds: u_y within 0.5 % of −0.178 (its rounding is 0.3 %, the mesh moves
    // 0.07 %); u_x within the rounding of the one digit given, [0.035, 0.045]. A p/E of
    // 1 (the paper's printed E = p = 2) would give five times both. Linear elasticity
    // with the closed-form stiffness: one Newton iteration leaves a residual at
    // round-off (spec §5 item 8), bound 1e-12 of the force scale.
    let mut e = any_engine::<D2>("plate-compression-fem", &[]);
    e.advance(0.0, 1.0, 1).unwrap_or_else(|f| panic!("{f:?}"));
    let snap = e.snapshot();
    let uy = snap.u.iter().map(|u| u.y).fold(f64::INFINITY, f64::min);
    let ux = snap.u.iter().map(|u| u.x).fold(f64::NEG_INFINITY, f64::max);
    eprintln!("Q4 plate 20 × 20: max u_x {ux}, min u_y {uy}");
    assert!((uy + 0.178).abs() < 0.005 * 0.178, "min u_y {uy}");
    assert!((0.035..0.045).contains(&ux), "max u_x {ux}");
    let steps = by_step(&e.iterations());
    assert_eq!(steps.len(), 1, "{steps:?}");
    assert_eq!(steps[0].len(), 2, "one solve: {steps:?}");
    assert!(steps[0][1] < 1e-12, "{steps:?}");
}

#[test]
fn the_trilinear_cube_converges_quadratically_towards_the_particle_solution() {
    // Seed 004 §6.6 on 8³ trilinear hexahedra (`hyperelastic-cube-fem` at Δx = 1/8):
    // the closed-form stiffness of the Simo–Taylor–Pister law makes Newton quadratic,
    // r_k+1 < 100 r_k² once r_k < 1e-3, as for the particle method above (a tangent
    // by finite differences or missing a term converges linearly there). Measured
    // iterations (4, 5, 5, 7); corner u_z −0.429 m here, −0.502 m at 16³ and −0.515 m
    // at 20³ against the particle method's −0.531 m at 21³ (docs/methods/dual-support.md:
    // the FEM rises towards the particle solution, away from the paper's −0.342 m and
    // AceFEM's −0.313 m). Bound: the corner below −0.42 m (2 % of room on the measured
    // −0.429 m): the paper's largest deflections, −0.342 and −0.313 m, lie above it on
    // this coarse mesh already.
    let mut e = any_engine::<D3>("hyperelastic-cube-fem", &set(&["spacing=0.125"]));
    e.advance(0.0, 0.25, 4).unwrap_or_else(|f| panic!("{f:?}"));
    quadratic_in_four_steps(&e.iterations());
    let snap = e.snapshot();
    let corner = snap
        .x0
        .iter()
        .position(|x| x.distance(glam::DVec3::Z) < 1e-9)
        .expect("a node at the corner (0, 0, 1)");
    let uz = snap.u[corner].z;
    eprintln!("Hex8 cube 8³: corner u_z {uz}");
    assert!(uz < -0.42, "corner u_z {uz}");
}
