//! The GPU mixed {p, F, H, J} passes (Upwind-SPH, JST-SPH, SUPG-SPH) against the f64 CPU reference
//! on a software (or real) adapter. A missing adapter fails these tests: the GPU path is
//! part of what CI checks.

use crate::common::{
    gpu, gpus, is_supg, load, max_s, max_t, max_v, mixed_variants, random_state, random_tensor,
    shipped,
};
use meshless::core::integrate::{Integrator, OdeSystem};
use meshless::core::tensor::{D2, D3};
use meshless::diagnostics::observe::Invariants;
use meshless::gpu::Gpu;
use meshless::gpu::layout::GpuDim;
use meshless::methods::Method;
use meshless::methods::mixed::{
    GpuMixed, MixedOptions, MixedScheme, MixedSph, MixedState, Stabiliser,
};
use meshless::physics::plasticity::{PLASTIC_STRAIN, TEMPERATURE};
use meshless::run::{Backend, Engine, build_method};
use meshless::scene::Scene;

/// Asserts `error ≤ tol · scale` and reports the ratio.
fn check(label: &str, field: &str, (error, scale): (f64, f64), tol: f64) {
    eprintln!(
        "{label}: {field}: max |Δ| = {error:.3e} of {scale:.3e} ({:.2e})",
        error / scale
    );
    assert!(
        error <= tol * scale,
        "{label}: {field}: max |Δ| = {error:e} above {tol:e} of the field scale {scale:e}"
    );
}

/// The options and stabilisation of a mixed case.
fn mixed(c: &Scene) -> (&MixedOptions, Stabiliser) {
    let spec: &dyn MixedScheme = crate::common::spec_of(c);
    (spec.options(), spec.stabiliser())
}

/// The seed 002 options a case sets (those other than the defaults), for the labels.
fn seed_002_options(c: &Scene) -> String {
    let (m, _) = mixed(c);
    let default = MixedOptions::default();
    [
        (m.momentum != default.momentum).then(|| format!(" {:?} momentum", m.momentum)),
        (m.deformation_gradient != default.deformation_gradient)
            .then(|| format!(" {:?} F", m.deformation_gradient)),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// One rate evaluation on a random state, GPU against CPU, field by field.
///
/// Every field is a gather of k ≤ 60 terms (ghosts included) of inputs rounded to f32
/// (relative ε = 6e-8), summed in f32: each sum is within k·ε of the sum of its terms'
/// magnitudes. On the random state nothing cancels systematically (the jumps Δv, ΔP of
/// the stabilisation are as large as the fields), so the bound is relative to the
/// largest value of the field: 1e-5 = 60 × 6e-8 × a factor 3 for the chained passes (P,
/// then its slopes, then the reconstructed jumps; ∇0v, then Ḣ and J̇). u̇ = v is a copy:
/// the f32 rounding of v, 1e-7. Measured: 3e-8 (u̇) to 1.0e-6 (P of the polyconvex model,
/// through exp and log in f32).
fn compare_rates<D: GpuDim>(c: &Scene, gpu: Gpu) {
    compare_rates_at::<D>(c, gpu, 1.0);
}

/// [`compare_rates`] with the random displacements scaled by `u_scale` (those of
/// `random_state`, 1 cm, are for spacings of 6–12 cm).
fn compare_rates_at<D: GpuDim>(c: &Scene, gpu: Gpu, u_scale: f64) {
    let label = format!(
        "{}D {} {} {:?}{}{}",
        D::N,
        c.name,
        c.method.name,
        mixed(c).0.variables,
        match mixed(c).1 {
            Stabiliser::Upwind {
                reconstruction: false,
            } => " (no reconstruction)",
            _ => "",
        },
        seed_002_options(c)
    );
    let mut cpu: MixedSph<D> = build_method(c).unwrap();
    let mut y = random_state(&cpu, &mut 7, 0.01);
    y.u.iter_mut().for_each(|u| *u = *u * u_scale);
    // A step of the case's CFL number: SUPG-SPH's τ_F Δt and τ_p Δt.
    let dt = c.method.cfl.unwrap() * c.spacing / cpu.max_signal_speed(&y);
    cpu.begin_step(0.0, dt, &y);
    let mut d = y.clone();
    cpu.rates(0.0, &y, &mut d).unwrap();
    let n = y.u.len();
    let p = cpu.first_piola(&y).unwrap();
    let fluxes = cpu.fluxes(&y).unwrap();

    let mut g: GpuMixed<D> = GpuMixed::new(c, crate::common::spec_of(c), gpu).unwrap();
    g.set_step(dt);
    let dg = g.rates(&y);
    let pg = g.first_piola();
    let fg = g.fluxes();
    assert_eq!(g.failed_particles(), [None; 3], "{label}");

    check(&label, "P", max_t::<D>(&p[..n], &pg), 1e-5);
    check(&label, "∇0v = Ḟ", max_t::<D>(&d.f, &dg.f), 1e-5);
    check(&label, "T", max_v::<D>(&fluxes.t, &fg.t), 1e-5);
    check(&label, "D(p)", max_v::<D>(&fluxes.d, &fg.d), 1e-5);
    check(&label, "v̇", max_v::<D>(&d.v, &dg.v), 1e-5);
    check(&label, "u̇ = v", max_v::<D>(&d.u, &dg.u), 1e-7);
    if !d.h.is_empty() {
        check(&label, "Ḣ", max_t::<D>(&d.h, &dg.h), 1e-5);
    }
    if !d.j.is_empty() {
        // The GPU computes D(J) only where it is read: Upwind-SPH with J evolved.
        if matches!(mixed(c).1, Stabiliser::Upwind { .. }) {
            check(&label, "D(J)", max_s(&fluxes.dj, &fg.dj), 1e-5);
        }
        check(&label, "J̇", max_s(&d.j, &dg.j), 1e-5);
    }
}

/// The seed 002 options on every variant of `mixed_variants`: the symmetrised momentum with each
/// set of conserved variables, and with {p, F} the bond-based F under either momentum and
/// eq 38's kinematic bond F under the symmetrised one.
fn seed_002_variants(base: &[&str]) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for set in mixed_variants(base) {
        let with = |options: [&str; 2]| {
            let mut s = set.clone();
            s.extend(options.map(|o| format!("method.{o}")));
            s
        };
        out.push(with([
            "momentum=symmetrised",
            "deformation_gradient=evolved",
        ]));
        if set.last().is_some_and(|v| v == "method.variables=p-F") && !is_supg(&set) {
            for momentum in ["weak", "symmetrised"] {
                out.push(with([
                    &format!("momentum={momentum}"),
                    "deformation_gradient=bond-based",
                ]));
            }
            out.push(with([
                "momentum=symmetrised",
                "deformation_gradient=kinematic-bond",
            ]));
        }
    }
    out
}

#[test]
fn rates_match_the_cpu_on_the_swinging_plate() {
    // Mirror planes (ghosts), linear elastic ({p, F}) and polyconvex (H, J), no projection.
    for set in mixed_variants(&[]) {
        compare_rates::<D2>(&load("swinging-plate", &set), gpu());
    }
}

#[test]
fn rates_match_the_cpu_on_every_adapter() {
    // Upwind-SPH and JST-SPH with all of p, F, H, J (the polyconvex model, which reads
    // them) on the swinging plate (ghosts) on every adapter wgpu enumerates, with the
    // bounds of compare_rates.
    for method in ["upwind-sph", "jst-sph"] {
        for gpu in gpus() {
            println!("adapter {}", gpu.name());
            let set = [
                format!("method.name={method}"),
                "material.model=nearly-incompressible-neo-hookean".into(),
                "method.variables=p-F-H-J".into(),
            ];
            compare_rates::<D2>(&load("swinging-plate", &set), gpu);
        }
    }
}

#[test]
fn rates_match_the_cpu_on_the_spinning_plate() {
    // No ghosts, polyconvex model, projection on (and a neo-Hookean variant).
    for set in mixed_variants(&[]) {
        compare_rates::<D2>(&load("spinning-plate", &set), gpu());
    }
    let neo = ["material.model=neo-hookean"];
    compare_rates::<D2>(&load("spinning-plate", &neo), gpu());
}

#[test]
fn rates_match_the_cpu_on_the_swinging_cube() {
    for set in mixed_variants(&["spacing=0.125"]) {
        compare_rates::<D3>(&load("swinging-cube", &set), gpu());
    }
    // 3D without ghosts, polyconvex, with the projection.
    let free = [
        "spacing=0.125",
        "mirror=",
        "material.model=nearly-incompressible-neo-hookean",
    ];
    compare_rates::<D3>(&load("swinging-cube", &free), gpu());
    // SUPG-SPH's stress points in the cells of the stent's cylindrical lattice and their
    // images across three planes, displacements of 0.1Δx.
    compare_rates_at::<D3>(&load("stent", &["method.name=supg-sph"]), gpu(), 2.5e-3);
    // A fixed base (velocity constraints through the mask; ν = 0.4995), both methods.
    for method in ["upwind-sph", "jst-sph"] {
        let m = format!("method.name={method}");
        compare_rates::<D3>(&load("twisting-column", &[&m]), gpu());
    }
}

/// The seed 002 options against the bound of `compare_rates`, 1e-5. The symmetrised T is
/// a gather like the weak one. The bond-based F^c is a gather of u (ghosts included) in
/// front of the chain (F^c, then P, its slopes, the reconstructed jumps): with k ε per
/// gather and four chained passes, 4 k ε = 4.8e-6 on the plate (k = 20 neighbours) and
/// 7.7e-6 on the column (k = 32). The swinging cube (k = 80) stands as it does in
/// `rates_match_the_cpu_on_the_swinging_cube`: its roundings, independent, add as √k ε.
/// Measured: at most 3.8e-7 (P of the cube with the bond-based F); 2.3e-7 on the column
/// as shipped.
#[test]
fn rates_match_the_cpu_with_the_seed_002_options_on_the_swinging_plate() {
    // Mirror planes: F^c gathers the ghosts' u (σRu).
    for set in seed_002_variants(&[]) {
        compare_rates::<D2>(&load("swinging-plate", &set), gpu());
    }
}

#[test]
fn rates_match_the_cpu_with_the_seed_002_options_on_the_bending_column() {
    // Seed 002's scene as shipped: JST-SPH {p, F} with ε⁽⁴⁾ = 1/64, symmetrised, the
    // bond-based F, polyconvex at ν = 0.495, a clamped base.
    compare_rates::<D3>(&shipped("bending-column"), gpu());
    // Every method (JST-SPH with its default coefficients).
    for set in seed_002_variants(&["method.jst="]) {
        compare_rates::<D3>(&load("bending-column", &set), gpu());
    }
    // 3D ghosts of the F^c gather.
    let cube = [
        "spacing=0.125",
        "method.variables=p-F",
        "method.momentum=symmetrised",
        "method.deformation_gradient=bond-based",
    ];
    compare_rates::<D3>(&load("swinging-cube", &cube), gpu());
}

/// `steps` TVD-RK2 steps of the CFL size on both backends from the case's initial state:
/// velocities, displacements and total energy at the end.
///
/// Each step rounds u and v to f32 in its two stages and the blend (relative ε = 6e-8 of
/// the field each time); accumulating linearly over 100 steps that is 3 × 100 × 6e-8 =
/// 1.8e-5 of the field's scale: bound 2e-5 for v and u (u starts at zero and is measured
/// against its final size). The energy is summed on the GPU in f32 per workgroup of 256
/// particles (≤ 256 ε = 1.5e-5 relative) from a state within 2e-5, whose kinetic energy
/// is then within 4e-5: bound 1e-4 of E(0). Measured: v 4e-7, u 2.7e-6, E 1.2e-7.
fn compare_runs<D: GpuDim>(c: &Scene, steps: u32) {
    let label = format!(
        "{}D {} {} {:?}{}",
        D::N,
        c.name,
        c.method.name,
        c.method.integrator,
        seed_002_options(c)
    );
    let mut cpu: MixedSph<D> = build_method(c).unwrap();
    let mut y = cpu.initial_state();
    let cfl = c.method.cfl.unwrap();
    let dt = cfl * c.spacing / cpu.max_signal_speed(&y);
    let mut integ = Integrator::new(c.method.integrator, &y);
    let e0 = Invariants::of(&cpu.snapshot(&y)).total_energy();
    for k in 0..steps {
        integ.step(&mut cpu, f64::from(k) * dt, dt, &mut y).unwrap();
    }
    let e_cpu = Invariants::of(&cpu.snapshot(&y));

    let mut g: GpuMixed<D> = GpuMixed::new(c, crate::common::spec_of(c), gpu()).unwrap();
    g.advance_steps(dt, steps).unwrap();
    Engine::<D>::check(&mut g).unwrap();
    let yg = g.state();
    let e_gpu = Engine::<D>::invariants(&mut g);
    check(&label, "v", max_v::<D>(&y.v, &yg.v), 2e-5);
    check(&label, "u", max_v::<D>(&y.u, &yg.u), 2e-5);
    check(
        &label,
        "E",
        ((e_cpu.total_energy() - e_gpu.total_energy()).abs(), e0),
        1e-4,
    );
}

#[test]
fn runs_track_the_cpu_on_the_swinging_plate_and_cube() {
    for method in ["upwind-sph", "jst-sph", "supg-sph"] {
        let m = format!("method.name={method}");
        compare_runs::<D2>(&load("swinging-plate", &[&m]), 100);
        compare_runs::<D3>(&load("swinging-cube", &[&m, "spacing=0.125"]), 100);
    }
    // The cosine form starts displaced, with F, H and J from the displacement's gradient:
    // the GPU engine must start from the same state.
    let cosine = [
        "spacing=0.125",
        "material.model=nearly-incompressible-neo-hookean",
        "method.variables=p-F-H-J",
        "body.0.initial_velocity=",
        "body.0.initial_displacement={ type = \"swinging\", amplitude = 5.0e-4 }",
    ];
    compare_runs::<D3>(&load("swinging-cube", &cosine), 100);
}

#[test]
fn runs_track_the_cpu_with_the_seed_002_options() {
    // The bending column as shipped runs SSP-RK3: five f32 updates a step (three stages,
    // two blends), 5 × 50 × 6e-8 = 1.5e-5 of the fields' scales over 50 steps, within the
    // bounds of `compare_runs` (2e-5 for v and u, 1e-4 of E(0)); its strain energy is
    // ψ(F^c) on both backends. The swinging plate with both options runs TVD-RK2 with
    // ghosts as in `compare_runs`. Measured: column v 2.2e-6, u 1.9e-6, E 3.2e-6; plate
    // v 6.0e-7, u 6.4e-7, E 8e-9.
    compare_runs::<D3>(&shipped("bending-column"), 50);
    let plate = [
        "method.variables=p-F",
        "method.momentum=symmetrised",
        "method.deformation_gradient=bond-based",
    ];
    compare_runs::<D2>(&load("swinging-plate", &plate), 100);
}

#[test]
fn gpu_backend_runs_the_seed_002_options() {
    // `--backend gpu` builds the GPU engine for the bending column (symmetrised momentum,
    // bond-based F) instead of refusing or falling back to the CPU.
    let engine = meshless::run::engine::<D3>(&shipped("bending-column"), Backend::Gpu)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(engine.backend().starts_with("gpu"), "{}", engine.backend());
}

#[test]
fn every_integrator_tracks_the_cpu() {
    // The other programs (RK4, SSP-RK3, the leapfrog with its priming evaluation) on the
    // spinning plate, whose projection balances about the stage positions there: 50 steps,
    // 4 f32 updates a step at most, 4 × 50 × 6e-8 = 1.2e-5 of the fields' scales; the
    // energy as in `compare_runs`. Bounds 2e-5 and 1e-4.
    for integrator in ["rk4", "ssp-rk3", "leapfrog"] {
        let c = load(
            "spinning-plate",
            &[&format!("method.integrator={integrator}")],
        );
        compare_runs::<D2>(&c, 50);
    }
}

#[test]
fn the_second_tvd_rk2_stage_balances_about_the_mid_step_points() {
    // Seed 003 Appendix B with TVD-RK2: the second stage projects about
    // x^n + Δt/2 (v^n + v*), not about x*. A synthetic step puts them far apart: y^n and
    // y* random with u* = u^n and Δt = 0.5 s, so the points differ by Δt/2 (v^n + v*),
    // ~ 0.5 m on a 2 m plate. The GPU's v̇ must match the CPU's within the 1e-5 of
    // `compare_rates`, and the rates balanced about x* must differ by more than 10 times
    // that (else a GPU that ignored the mid-step points would pass).
    let c = shipped("spinning-plate");
    let dt = 0.5;
    let mut cpu: MixedSph<D2> = build_method(&c).unwrap();
    let start = random_state(&cpu, &mut 3, 0.01);
    let mut stage = random_state(&cpu, &mut 4, 0.01);
    stage.u.clone_from(&start.u);
    let mut about_stage = stage.clone();
    cpu.rates(0.0, &stage, &mut about_stage).unwrap();
    let mut d = start.clone();
    cpu.begin_step(0.0, dt, &start);
    cpu.rates(0.0, &start, &mut d).unwrap();
    cpu.rates(dt, &stage, &mut d).unwrap();

    let mut g: GpuMixed<D2> = GpuMixed::new(&c, crate::common::spec_of(&c), gpu()).unwrap();
    let dg = g.second_stage_rates(&start, &stage, dt);
    let label = "2D spinning-plate, second TVD-RK2 stage";
    check(label, "v̇", max_v::<D2>(&d.v, &dg.v), 1e-5);
    let (shift, scale) = max_v::<D2>(&d.v, &about_stage.v);
    eprintln!("{label}: v̇ about x* differs by {shift:e} of {scale:e}");
    assert!(
        shift > 1e-3 * scale,
        "the balance points do not matter here"
    );
}

/// Largest |L(t)/L(0) − 1| of the spinning plate over `steps` TVD-RK2 steps on the GPU,
/// L = Σ m (X + u) × v summed in f64 from the read-back f32 state every 10 steps.
fn spinning_plate_drift(projection: bool, steps: u32) -> f64 {
    let c = load(
        "spinning-plate",
        &[&format!("method.projection={projection}")],
    );
    let mut g: GpuMixed<D2> = GpuMixed::new(&c, crate::common::spec_of(&c), gpu()).unwrap();
    let (x0, mass) = (g.cpu().reference().to_vec(), g.cpu().mass().to_vec());
    let l = |y: &MixedState<D2>| -> f64 {
        (0..x0.len())
            .map(|a| mass[a] * (x0[a] + y.u[a]).perp_dot(y.v[a]))
            .sum()
    };
    let l0 = l(&g.state());
    let dt = c.method.cfl.unwrap() * c.spacing / Engine::<D2>::max_signal_speed(&mut g);
    let mut worst: f64 = 0.0;
    for _ in 0..steps / 10 {
        g.advance_steps(dt, 10).unwrap();
        worst = worst.max((l(&g.state()) / l0 - 1.0).abs());
    }
    Engine::<D2>::check(&mut g).unwrap();
    worst
}

#[test]
fn projection_keeps_the_angular_momentum_of_the_spinning_plate() {
    // With the projection about x^n + Δt/2 (v^n + v*) each TVD-RK2 step conserves L
    // exactly but for the f32 rounding of u and v: relative 6e-8 per update, three
    // updates a step, independent over the 400 particles, so about 6e-8/√400 per update
    // and √600 × 3e-9 = 7e-8 over 200 steps; bound 1e-6 (measured 3e-8). Without it the
    // scheme does not conserve L (F ≠ ∇0x, seed 003 §4): measured 3.7e-4, required to be
    // above 1e-5 and 100 times the projected drift.
    let with = spinning_plate_drift(true, 200);
    let without = spinning_plate_drift(false, 200);
    eprintln!("spinning plate, 200 steps: max |L/L0 − 1| = {with:e} projected, {without:e} not");
    assert!(with < 1e-6, "projected: max |L/L0 − 1| = {with:e}");
    assert!(
        without > 1e-5 && without > 100.0 * with,
        "without the projection: max |L/L0 − 1| = {without:e} (projected {with:e})"
    );
}

/// The CFL signal speed Δx max_ab C_p,ab / r_ab + max |v| over the pairs of real
/// particles (seed 002 eqs 31–32; the CPU value against eq 31 in closed form is a unit
/// test of `method::mixed`), GPU against CPU, with mirror planes (their ghosts do not
/// count), on a random state (|u| ~ 1 cm at Δx = 0.125 m) in which one particle is
/// stretched to F = R diag(2, 0.4[, 1.3]) (λ_min = 0.63). The f32 error: λ from the f32
/// eigenvalue of C (entries ≤ 4 over λ²_min = 0.16: 25 × 6e-8 = 1.5e-6 on λ², half on
/// λ), r_ab from the f32 X (6e-8 of coordinates ≤ 1 m over r ≈ 0.125 m: 5e-7 per
/// position, 1e-6 for the pair): about 2e-6; bound 1e-5. Then on a nearly isotropic C everywhere
/// (eigenvalues within p ≈ 3e-3 of each other), where the 3D cubic has a near-triple
/// root and its f32 solution is only good to a fraction of p: within 1e-3, ample for a
/// time step.
fn check_signal_speed<D: GpuDim>(c: &Scene, stretched: D::T) {
    let cpu: MixedSph<D> = build_method(c).unwrap();
    let mut y = random_state(&cpu, &mut 11, 0.01);
    y.f[3] = stretched;
    let mut g: GpuMixed<D> = GpuMixed::new(c, crate::common::spec_of(c), gpu()).unwrap();
    let mut compare = |label: &str, y: &MixedState<D>, tol: f64| {
        g.set_state(y);
        let (on_gpu, on_cpu) = (g.max_signal_speed(), cpu.max_signal_speed(y));
        let deviation = (on_gpu / on_cpu - 1.0).abs();
        let wave = mixed(c).0.cfl_wave_speed;
        eprintln!(
            "{}D {label}, {wave:?}: signal speed GPU {on_gpu} vs CPU {on_cpu} m/s \
             ({deviation:.2e})",
            D::N
        );
        assert!(
            deviation < tol,
            "{}D {label}, {wave:?}: GPU {on_gpu} vs CPU {on_cpu} m/s",
            D::N
        );
    };
    compare("one stretched particle", &y, 1e-5);
    // Nearly isotropic C everywhere (F = I + 1e-3 noise: eigenvalues within 3e-3 of
    // each other), where the characteristic cubic has a near-triple root.
    let mut seed = 5;
    for f in &mut y.f {
        *f = D::identity() + random_tensor::<D>(&mut seed, 1e-3);
    }
    compare("nearly isotropic C", &y, 1e-3);
}

#[test]
fn the_cfl_signal_speed_follows_the_fastest_pair() {
    let r2 = glam::DMat2::from_angle(0.4);
    let s2 = r2 * glam::DMat2::from_diagonal(glam::DVec2::new(2.0, 0.4));
    let r3 = glam::DMat3::from_euler(glam::EulerRot::XYZ, 0.3, -0.5, 1.1);
    let s3 = r3 * glam::DMat3::from_diagonal(glam::DVec3::new(2.0, 0.4, 1.3));
    // Both pair wave speeds: C_p,ab of eq 32 and C_p^Lin, which skips the stretches.
    for wave in ["pair", "linear"] {
        let wave = format!("method.cfl_wave_speed={wave}");
        check_signal_speed::<D2>(&load("swinging-plate", &["spacing=0.125", &wave]), s2);
        check_signal_speed::<D3>(&load("swinging-cube", &["spacing=0.125", &wave]), s3);
    }
}

/// The von Mises return map and the per-step commit of the plastic history on the GPU
/// against the CPU: the coarse Taylor bar (960 particles, 227 m/s) over 500 fixed steps
/// of 20 ns (10 µs, the impact end deep in plastic flow). The displacements, the
/// largest 2.3 mm, agree to 1e-4 of it, and the energies to 1e-4 of E(0): f32 states and
/// a return map whose ln J and eigenvalues carry 6e-8 relative, amplified over 500 steps
/// of flow (measured: 3.8e-5 of the largest displacement, 8e-6 of E(0)). The plastic
/// strains, up to 0.66, agree to 1e-3 of the largest (measured 3e-5).
#[test]
fn plastic_flow_matches_the_cpu() {
    plastic_flow_matches("taylor-bar");
}

/// [`plastic_flow_matches_the_cpu`] in Johnson and Cook's OFHC copper: the rate term
/// (the history's ε̇_p, f32 on the device), the power law's Newton return (to 1e-6 of
/// its bracket in f32) and the adiabatic heating, under the same bounds. The temperature
/// rises, up to some 100 K at the impact end, agree to 1e-3 of the largest rise: the
/// heat of a step is k ∫ τ_s dγ of its Δγ, so it carries the plastic strain's relative
/// deviation.
#[test]
fn johnson_cook_flow_and_heating_match_the_cpu() {
    plastic_flow_matches("taylor-bar-johnson-cook");
}

/// The coarse bar of `case` over 500 steps of 20 ns on both backends (see
/// [`plastic_flow_matches_the_cpu`]); with thermal softening, its temperatures too.
fn plastic_flow_matches(case: &str) {
    let c = load(
        case,
        &[
            "spacing=1.0666666666666667e-3",
            "method.cfl=",
            "method.cfl_wave_speed=",
            "method.dt=2e-8",
        ],
    );
    let mut cpu = meshless::scene::cpu_engine::<D3, MixedSph<D3>>(&c).unwrap();
    let mut g: GpuMixed<D3> = GpuMixed::new(&c, crate::common::spec_of(&c), gpu()).unwrap();
    let e0 = cpu.invariants().total_energy();
    cpu.advance(0.0, 2e-8, 500).unwrap();
    Engine::<D3>::advance(&mut g, 0.0, 2e-8, 500).unwrap();
    let (on_cpu, on_gpu) = (cpu.snapshot(), Engine::<D3>::snapshot(&mut g));
    let (deviation, largest) = max_v::<D3>(&on_cpu.u, &on_gpu.u);
    let (energy_cpu, energy_gpu) = (
        on_cpu.strain_energy.value() + Invariants::of(&on_cpu).kinetic,
        on_gpu.strain_energy.value() + Invariants::of(&on_gpu).kinetic,
    );
    eprintln!(
        "Taylor bar, 500 steps: max |u_GPU − u_CPU| = {deviation:e} m of {largest:e} m; \
         energy {energy_gpu} against {energy_cpu} J (E0 = {e0} J)"
    );
    assert!(
        deviation < 1e-4 * largest,
        "{deviation:e} m of {largest:e} m"
    );
    assert!((energy_gpu - energy_cpu).abs() < 1e-4 * e0);
    let (eps_cpu, eps_gpu) = (
        on_cpu.field(PLASTIC_STRAIN).unwrap().to_vec(),
        on_gpu.field(PLASTIC_STRAIN).unwrap().to_vec(),
    );
    let (eps_deviation, eps_max) = max_s(&eps_cpu, &eps_gpu);
    eprintln!("ε_p: max {eps_max}, max |ε_p,GPU − ε_p,CPU| = {eps_deviation:e}");
    assert!(
        eps_max > 0.1,
        "the impact end must flow plastically: max ε_p = {eps_max}"
    );
    assert!(
        eps_deviation < 1e-3 * eps_max,
        "{eps_deviation:e} of {eps_max}"
    );
    let Some(t_cpu) = on_cpu.field(TEMPERATURE) else {
        return;
    };
    let room = t_cpu.iter().copied().fold(f64::INFINITY, f64::min);
    let rise = |t: &[f64]| t.iter().map(|t| t - room).collect::<Vec<f64>>();
    let t_gpu = on_gpu
        .field(TEMPERATURE)
        .expect("the device's temperatures");
    let (t_deviation, t_max) = max_s(&rise(t_cpu), &rise(t_gpu));
    eprintln!("ΔT: max {t_max} K, max |T_GPU − T_CPU| = {t_deviation:e} K");
    assert!(t_max > 10.0, "the impact end must heat: max ΔT = {t_max} K");
    assert!(t_deviation < 1e-3 * t_max, "{t_deviation:e} K of {t_max} K");
}

/// Artificial compressibility (seed 003 §5) on the GPU against the CPU: the same steps
/// of `case` on both backends, then v, u and the pressure, and the pseudo-time
/// iterations.
///
/// Each stage's corrector stops within `tolerance` = 1e-6 of the velocity scale on
/// either backend (at most the largest |v| of the run: the initial or the final one in
/// these runs, measured against the larger, since the swinging plate's velocity passes
/// through zero), so its v and p^{n+1} differ by up to that much at every stage besides
/// the f32 rounding of the explicit run (2e-5 over 100 steps, `compare_runs`). Over
/// `steps` ≤ 10 steps of two stages that is 20 × 1e-6 + 2e-5 = 4e-5 of the scale of v
/// and u: bound 1e-4. The pressure is the corrector's unknown, solved to the same
/// residual: a velocity residual r relative to the scale is a pressure error of about
/// r γ Δt/Δx, and over the run's stages 1e-3 of the largest |p| bounds it. The
/// iteration counts follow the same iterates, and an f32 residual crosses the
/// tolerance a pseudo step or two earlier or later in a stage: within 10 % of the CPU's.
fn compare_corrected_runs<D: GpuDim>(case: &Scene, steps: u32) {
    let label = format!("{}D {} {}", D::N, case.name, case.method.name);
    let mut cpu = meshless::scene::cpu_engine::<D, MixedSph<D>>(case).unwrap();
    let dt = case.method.cfl.unwrap() * case.spacing / cpu.max_signal_speed();
    let (_, v0) = max_v::<D>(&cpu.y.v, &cpu.y.v);
    cpu.advance(0.0, dt, steps).unwrap();
    let mut g: GpuMixed<D> = GpuMixed::new(case, crate::common::spec_of(case), gpu()).unwrap();
    Engine::<D>::advance(&mut g, 0.0, dt, steps).unwrap();
    Engine::<D>::check(&mut g).unwrap();
    let yg = g.state();
    let y = &cpu.y;
    let (dv, v) = max_v::<D>(&y.v, &yg.v);
    check(&label, "v", (dv, v.max(v0)), 1e-4);
    check(&label, "u", max_v::<D>(&y.u, &yg.u), 1e-4);
    check(&label, "p", max_s(&y.pressure, &yg.pressure), 1e-3);
    let (c, g) = (cpu.pseudo_time().unwrap(), g.pseudo_time().unwrap());
    eprintln!("{label}: pseudo steps CPU {} GPU {}", c.total, g.total);
    let ratio = g.total as f64 / c.total as f64;
    assert!(
        (0.9..=1.1).contains(&ratio),
        "{label}: {} pseudo steps on the GPU against {} on the CPU",
        g.total,
        c.total
    );
}

/// The keys of artificial compressibility at Poisson ratio ν.
fn incompressible(nu: f64) -> [String; 2] {
    [
        format!("material.poisson_ratio={nu}"),
        "method.artificial_compressibility={ alpha = 0.2 }".into(),
    ]
}

/// The free spinning plate at ν = 0.5 (the projection on; about 90 pseudo steps a
/// stage, above the first budget of pseudo steps recorded, so the first batch runs
/// again); the swinging plate at ν = 0.4999 (its analytic initial velocity needs
/// ν < 0.5) with the polyconvex model, whose mirror planes put ghosts in the
/// corrector's gathers; the twisting column at ν = 0.5 in 3D on 8 × 48 × 8 particles,
/// clamped at its base (held components), where an f32 iterate of v rather than of its
/// increment stalls at 2.4e-6 of the scale, above the tolerance.
#[test]
fn artificial_compressibility_tracks_the_cpu() {
    let nu_half = incompressible(0.5);
    let plate: Vec<&str> = nu_half.iter().map(String::as_str).collect();
    compare_corrected_runs::<D2>(&load("spinning-plate", &plate), 10);
    let nu = incompressible(0.4999);
    let nearly: Vec<&str> = nu.iter().map(String::as_str).collect();
    let mut swinging = nearly.clone();
    swinging.push("material.model=nearly-incompressible-neo-hookean");
    compare_corrected_runs::<D2>(&load("swinging-plate", &swinging), 10);
    let mut column = plate;
    column.extend(["spacing=0.125", "body.0.geometry.lattice=cell-centred"]);
    column.push("boundary.0.region.y_max=0.1");
    compare_corrected_runs::<D3>(&load("twisting-column", &column), 2);
}

/// A stage that does not converge within `max_iterations` stops the run with the
/// particle and the residual named, as on the CPU.
#[test]
fn an_unconverged_corrector_names_the_particle_and_the_key() {
    let case = load(
        "spinning-plate",
        &[
            "material.poisson_ratio=0.5",
            "method.artificial_compressibility={ alpha = 0.2, max_iterations = 5 }",
        ],
    );
    let mut g: GpuMixed<D2> = GpuMixed::new(&case, crate::common::spec_of(&case), gpu()).unwrap();
    let dt = case.method.cfl.unwrap() * case.spacing / Engine::<D2>::max_signal_speed(&mut g);
    Engine::<D2>::advance(&mut g, 0.0, dt, 2).unwrap();
    let message = Engine::<D2>::check(&mut g)
        .expect_err("5 pseudo steps do not converge")
        .to_string();
    for part in ["particle", "max_iterations", "pseudo-time residual"] {
        assert!(message.contains(part), "{message}");
    }
}

/// SUPG-SPH's check at its stress points. τ_F = 10⁴ Δt on a random state puts
/// F^st = F − τ_F Δt R_F + ξ_F (∇0x − F) far from F (R_F of the random velocities is of
/// order |v|/Δx): some points have det F^st ≤ 0 while every particle's det F and J stay
/// near 1. Both backends stop there. The GPU flags the points in the third status word
/// alone, and its check names a real particle and the quantity.
#[test]
fn a_stress_point_past_det_f_zero_stops_both_backends() {
    let c = load(
        "swinging-plate",
        &["method.name=supg-sph", "method.supg={ tau_f = 1.0e4 }"],
    );
    let mut cpu: MixedSph<D2> = build_method(&c).unwrap();
    let y = random_state(&cpu, &mut 7, 0.01);
    let dt = c.method.cfl.unwrap() * c.spacing / cpu.max_signal_speed(&y);
    cpu.begin_step(0.0, dt, &y);
    let mut d = y.clone();
    let cpu_error = cpu.rates(0.0, &y, &mut d).unwrap_err().to_string();
    assert!(cpu_error.contains("det F^st"), "{cpu_error}");

    let mut g: GpuMixed<D2> = GpuMixed::new(&c, crate::common::spec_of(&c), gpu()).unwrap();
    g.set_step(dt);
    g.rates(&y);
    let [det_f, j, point] = g.failed_particles();
    assert_eq!((det_f, j), (None, None));
    assert!(point.is_some_and(|a| a < y.u.len()), "{point:?}");
    let message = Engine::<D2>::check(&mut g)
        .expect_err("a stress point failed")
        .to_string();
    for part in ["particle", "det F^st at a stress point"] {
        assert!(message.contains(part), "{message}");
    }
}
