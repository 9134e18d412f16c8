//! The updated-Lagrangian Galerkin methods on the GPU against the f64 CPU reference on a
//! software (or real) adapter: `ul-fem`'s Gauss points evaluated on the current cells at
//! every rate evaluation, one rate evaluation of a rotated, stretched and disordered state
//! in 2D and 3D, whole runs, and an inverted element. A missing adapter fails these tests.

use crate::common::{gpu, load, noise, random_tensor, random_vector};
use crate::galerkin::block;
use crate::gpu_galerkin::{check_rates, check_run};
use meshless::core::integrate::{Integrator, OdeSystem};
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::Gpu;
use meshless::gpu::layout::GpuDim;
use meshless::methods::cores::galerkin::gpu::{Frame, GpuGalerkin};
use meshless::methods::cores::galerkin::updated::{UlGalerkin, UlGalerkinState};
use meshless::methods::cores::galerkin::{GalerkinState, TlGalerkin, TlSystem};
use meshless::methods::fem::{FemSpec, RULE};
use meshless::methods::ul_fem::Elements;
use meshless::methods::{Method, MethodSpec};
use meshless::reference::Reference;
use meshless::run::{Engine, build_method};
use meshless::scene::Scene;

type UlFem<D> = UlGalerkin<D, Elements<D>>;

/// The elements of a `ul-fem` case, with its masses.
fn elements(case: &Scene) -> FemSpec {
    match &case.spec {
        MethodSpec::UlFem(spec) => FemSpec { mass: spec.mass },
        other => panic!("not ul-fem: {other:?}"),
    }
}

/// `ul-fem`'s GPU engine for `case` on `gpu`.
pub fn device_on<D: GpuDim>(case: &Scene, gpu: Gpu) -> GpuGalerkin<D> {
    GpuGalerkin::<D>::in_frame(case, &elements(case), Frame::Current(RULE), gpu).unwrap()
}

/// `ul-fem`'s GPU engine for `case`.
fn device<D: GpuDim>(case: &Scene) -> GpuGalerkin<D> {
    device_on(case, gpu())
}

/// The fields the GPU state carries of a CPU state.
fn on_device<D: Dim>(y: &UlGalerkinState<D>) -> GalerkinState<D> {
    GalerkinState {
        u: y.u.clone(),
        v: y.v.clone(),
        rho: y.rho.clone(),
        s: y.s.clone(),
    }
}

/// A state far from the reference: the block rotated by 1 rad and stretched by up to 30 %
/// (x = R (I + G) X), with |Δu| ~ 1 mm (1 % of Δx) of noise on top, |v| ~ 1 m/s, ρ within
/// 1 % of ρ0 and |S| ~ 1e4 Pa.
fn deformed<D: Dim>(m: &UlFem<D>, seed: u64) -> UlGalerkinState<D> {
    let mut seed = seed;
    let (c, s) = (1f64.cos(), 1f64.sin());
    // The columns of R (I + G), the rotation about z.
    let columns = [
        [1.3 * c, 1.3 * s + 0.2 * c, 0.0],
        [-0.9 * s, 0.9 * c, 0.1],
        [0.0, 0.0, 1.1],
    ];
    let map = crate::common::of_columns::<D>(&columns);
    let mut y = m.initial_state();
    for ((u, v), &x) in y.u.iter_mut().zip(y.v.iter_mut()).zip(m.reference()) {
        *u = map * x - x + random_vector::<D>(&mut seed, 1e-3);
        *v = random_vector::<D>(&mut seed, 1.0);
    }
    for (rho, s) in y.rho.iter_mut().zip(y.s.iter_mut()) {
        *rho *= 1.0 + 0.01 * noise(&mut seed);
        *s = random_tensor::<D>(&mut seed, 1e4);
    }
    y
}

/// One rate evaluation of a deformed state ([`deformed`]) on both backends, under the
/// bounds of the total-Lagrangian passes ([`check_rates`]) with the terms of each node's
/// force from the same elements' total-Lagrangian form, term by term the same (w_q σ_q
/// ∇N_a(x_q) = w0_q P_q ∇0N_a(X_q)). On the current cells each term comes from J_q and
/// F_q = J_q J0_q⁻¹ of 4 to 8 f32 differences of |x_a − x_first| ~ Δx (ε = 6e-8), fewer
/// than the 40 those bounds allow: measured node accelerations within 1.9e-6 of the sum
/// of their terms' magnitudes (bound 1e-4), ρ̇ and Ṡ within 2.8e-7 (bound 1e-5).
fn compare_rates<D: GpuDim>(case: &Scene) {
    let mut cpu: UlFem<D> = build_method(case).unwrap();
    let y = deformed(&cpu, 7);
    let mut d = y.clone();
    cpu.rates(0.0, &y, &mut d).unwrap();
    let (dg, _) = device::<D>(case).rates(&on_device(&y));
    let reference = Reference::build(case).unwrap();
    let mut tl: TlGalerkin<D> = elements(case).system(case, reference).unwrap();
    let mut d_tl = on_device(&y);
    tl.rates(0.0, &on_device(&y), &mut d_tl).unwrap();
    let what = format!("ul-fem {}D {:?}", D::N, case.material.model);
    check_rates(&what, &tl, &on_device(&d), &dg);
}

#[test]
fn ul_fem_rates_match_the_cpu() {
    for model in ["hypoelastic", "saint-venant-kirchhoff", "neo-hookean"] {
        compare_rates::<D2>(&block(&[1.0, 0.6], model, "ul-fem", ""));
    }
    compare_rates::<D3>(&block(&[0.4, 0.3, 0.3], "hypoelastic", "ul-fem", ""));
    compare_rates::<D3>(&block(&[0.4, 0.3, 0.3], "neo-hookean", "ul-fem", ""));
}

#[test]
fn ul_fem_whole_runs_track_the_cpu() {
    // 100 steps of the seed-000 strip (grips at ±10 m/s, the rate model, Δt = 1e-6 s) and
    // of the rotating disk (ω = 50 rad/s, |v| ≤ 50 m/s, Δt = 1e-5 s). f32 round-off of v
    // per stage update ~ 6e-8 |v|, four stages per step, 100 steps, accumulating at worst
    // linearly: 3e-5 of max |v|; bound 1e-4 (measured 5.8e-7 and 7.3e-7). The kinetic
    // energy of the GPU reduction (f32 partials of ≤ 256 terms, f64 sums): 256 × 6e-8 =
    // 1.5e-5; bound 1e-5 (the terms are positive, so their errors do not add in one sign;
    // measured 1.5e-7). The stored energy is second order in the strain, which on the
    // rotating disk is what f32 resolves of F − I = O(1) under rotation; bound 1e-3, as for
    // the total-Lagrangian passes (tests/it/gpu_galerkin.rs; measured 4.6e-8 and 3.6e-6).
    for (name, dt) in [
        ("tensile-strip-ul-fem", 1e-6),
        ("rotating-disk-ul-fem", 1e-5),
    ] {
        let case = load(name, &[] as &[&str]);
        let steps = 100;
        let mut cpu: UlFem<D2> = build_method(&case).unwrap();
        let mut y = cpu.initial_state();
        let mut integrator = Integrator::new(case.method.integrator, &y);
        for k in 0..steps {
            integrator
                .step(&mut cpu, k as f64 * dt, dt, &mut y)
                .unwrap();
        }
        let mut g = device::<D2>(&case);
        g.advance_steps(dt, steps as u32).unwrap();
        let strain = cpu.strain_energy(&y).value();
        check_run(name, &mut g, &y.v, cpu.mass(), strain);
    }
}

#[test]
fn an_inverted_element_stops_the_gpu_run() {
    // A node pushed 1.5 Δx across its neighbour inverts the cells around it: det J ≤ 0 at
    // their Gauss points, which the points pass flags and the check reports by name.
    let case = block(&[1.0, 0.6], "saint-venant-kirchhoff", "ul-fem", "");
    let cpu: UlFem<D2> = build_method(&case).unwrap();
    let mut y = cpu.initial_state();
    let inner = (cpu.reference().iter())
        .position(|x| (x.x - 0.5).abs() < 1e-9 && (x.y - 0.3).abs() < 1e-9)
        .unwrap();
    y.u[inner].x = 0.15;
    let mut g = device::<D2>(&case);
    g.rates(&on_device(&y));
    let e = g.check().unwrap_err().to_string();
    assert!(e.contains("det J (an inverted element)"), "{e}");
}
