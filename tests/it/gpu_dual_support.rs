//! Dual-support SPH's static solve on the GPU (seed 004; Newton in f64 on the host, each
//! step solved matrix-free by conjugate gradients on the device) against the CPU's
//! assembled tangent and direct solve.

use crate::common::{gpu, load};
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::GpuDim;
use meshless::methods::MethodSpec;
use meshless::methods::dual_support::gpu::lists;
use meshless::methods::dual_support::krylov::NewtonKrylov;
use meshless::methods::dual_support::pattern;
use meshless::reference::Reference;
use meshless::run::{Backend, Engine, Iteration};

/// A smooth deformation with strains of ~10 % and a rotation-free shear, plus a
/// deterministic ripple that varies from particle to particle, so that every 𝔸_i and every
/// pair differ.
fn deformation<D: Dim>(x0: &[D::V]) -> Vec<D::V> {
    x0.iter()
        .enumerate()
        .map(|(i, &x)| {
            let c = D::to3(x);
            let ripple = 0.01 * ((i as f64) * 0.7).sin();
            let u = [
                0.1 * c[0] + 0.05 * c[1] * c[1] + ripple,
                -0.04 * c[1] + 0.06 * (c[0] * 2.0).sin(),
                0.03 * c[0] * c[2] - ripple,
            ];
            D::from_slice(&u[..D::N])
        })
        .collect()
}

/// The largest difference between the device's K(u) v and the CPU's assembled tangent
/// times v, and the largest |K v|; particle 0 prescribed (v = 0 there).
fn product_error<D: GpuDim>(name: &str, set: &[&str]) -> (f64, f64) {
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    let case = load(name, &set);
    let MethodSpec::DualSupportSph(spec) = &case.spec else {
        panic!("{name} runs dual-support-sph")
    };
    let reference = Reference::<D>::build(&case).unwrap();
    let lists = lists(&case, spec, &reference).unwrap();
    let model = &lists.model;
    let (n, d) = (model.len(), D::N);
    let mut solver = NewtonKrylov::new(gpu(), &lists, 1e-5, 1000).unwrap();
    let u = deformation::<D>(&model.support.x0);
    let free: Vec<Option<u32>> = (0..n * d)
        .map(|dof| (dof >= d).then_some((dof - d) as u32))
        .collect();
    let v: Vec<f32> = (0..n * d)
        .map(|k| {
            if k < d {
                0.0
            } else {
                ((k as f32) * 1.37).sin()
            }
        })
        .collect();
    let q = solver.product(model, &u, &free, &v).unwrap();

    let pat = pattern(&model.support);
    let mut values = vec![0.0; pat.blocks() * d * d];
    model.stiffness(&model.tangents(&u), &pat, &mut values);
    let (mut err, mut scale) = (0.0f64, 0.0f64);
    for a in 0..n {
        for k in 0..d {
            let kv: f64 = (pat.offsets[a]..pat.offsets[a + 1])
                .map(|slot| {
                    let b = pat.cols[slot] as usize;
                    (0..d)
                        .map(|l| values[slot * d * d + k * d + l] * f64::from(v[b * d + l]))
                        .sum::<f64>()
                })
                .sum();
            scale = scale.max(kv.abs());
            err = err.max((kv - f64::from(q[a * d + k])).abs());
        }
    }
    (err, scale)
}

#[test]
fn the_matrix_free_product_is_the_assembled_tangent() {
    // The device's K(u) v (the force pass's gather with P → 𝔸 : δH and the hourglass force
    // along v) against the CPU's assembled tangent times v (eqs 39–41 and 29, itself
    // checked against finite differences of the force in `dual_support`), at a deformed
    // state with strains of ~10 % and a v that changes sign from component to component:
    // the 2D plate (linear elastic, supports to the 10th nearest particle: variable h),
    // with and without the hourglass term, and the 3D cube (Simo–Taylor–Pister
    // neo-Hooke) at Δx = 1/6. The product is a sum of ~10² f32 terms per component (two
    // hops through the supports), each rounded to ~6e-8: bound 1e-5 of the largest |K v|
    // (measured 1.6e-7 on the plate, 3.1e-7 on the cube). A missing or mis-signed term (the hourglass force along v, the
    // reverse pair's stress, the geometric part of 𝔸) is an error of order 1.
    for (name, set) in [
        ("plate-compression-2d", vec![]),
        ("plate-compression-2d", vec!["method.hourglass=0"]),
    ] {
        let (err, scale) = product_error::<D2>(name, &set);
        eprintln!("{name} {set:?}: |K v| difference {err:e} of {scale:e}");
        assert!(err < 1e-5 * scale, "{name} {set:?}: {err:e} of {scale:e}");
    }
    let (err, scale) = product_error::<D3>(
        "hyperelastic-cube-3d",
        &["spacing=0.16666666666666666", "method.hourglass=5"],
    );
    eprintln!("cube: |K v| difference {err:e} of {scale:e}");
    assert!(err < 1e-5 * scale, "cube: {err:e} of {scale:e}");
}

/// The displacements and Newton log of a shipped static case run to its end on `backend`.
fn run<D: meshless::run::EngineDim>(
    name: &str,
    set: &[&str],
    backend: Backend,
) -> (Vec<D::V>, Vec<Iteration>) {
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    let case = load(name, &set);
    let mut engine = meshless::run::engine::<D>(&case, backend).unwrap_or_else(|e| panic!("{e}"));
    let dt = case.method.dt.expect("a static case has a load step");
    let steps = (case.run.end_time / dt).round() as u32;
    engine
        .advance(0.0, dt, steps)
        .unwrap_or_else(|f| panic!("{name} on {backend:?}: {f:?}"));
    let log = engine.iterations();
    (engine.snapshot().u, log)
}

/// max |u_gpu − u_cpu| and max |u_cpu| [m].
fn difference<D: Dim>(cpu: &[D::V], gpu: &[D::V]) -> (f64, f64) {
    let largest =
        |it: &mut dyn Iterator<Item = D::V>| it.map(|v| D::norm2(v).sqrt()).fold(0.0, f64::max);
    let diff = largest(&mut cpu.iter().zip(gpu).map(|(&a, &b)| a - b));
    (diff, largest(&mut cpu.iter().copied()))
}

/// The distance [m] of a run's last iterate from the solution of its equations that its
/// Newton log implies: the last increment |Δu_k| times q/(1 − q), q = |R_k|/|R_(k−1)| the
/// last contraction of the residual (the a-posteriori estimate of a contracting
/// iteration: the next increments would sum to that if each contracted as the last did).
fn implied_error(log: &[Iteration]) -> f64 {
    let [.., before, last] = log else {
        panic!("a static run logs its residual before and after a solve: {log:?}")
    };
    let q = last.residual / before.residual;
    last.increment * q / (1.0 - q)
}

#[test]
fn the_gpu_newton_krylov_solution_is_the_cpu_direct_one() {
    // The whole static run on the GPU (f32 matrix-free CG to a relative residual of 1e-5
    // inside f64 Newton) against the CPU's sparse Cholesky, both to the case's Newton
    // tolerance on the f64 residual. (1) The seed 004 cantilever (§6.1, Δx = 0.5 m,
    // E = 30 GPa, tip deflection 2.8e-6 m: the scaling the f32 solve needs), linear:
    // the CPU converges in one iteration, the GPU's inexact steps contract the residual
    // by the CG tolerance, so it needs at most two. (2) The neo-Hookean cube (§6.6,
    // Δx = 1/8, four load sub-steps to a 50 % compression): at most two iterations more
    // per sub-step than the CPU's quadratic Newton (measured: the same counts, 4, 4, 5, 6).
    // (3) The §6.2 plate, linear with hourglass control and variable h. Both runs solve
    // the same f64 equations, so the two answers differ by no more than the distances
    // of each from the solution that their logs imply (`implied_error`), which the
    // residual each stops at sets: bound ten times their sum, for a next contraction up
    // to ten times weaker than the last (the GPU's inexact steps contract by 9e-6 to
    // 1.3e-4). Measured, difference against bound, relative to max |u|: 5.1e-11 against
    // 4.3e-6 (the CPU's direct solve stops at the f64 floor of the cantilever's residual,
    // 3e-9 relative, which its estimate takes for an error), 3.4e-12 against 2.8e-10,
    // and 3.9e-11 against 1.6e-9. Where the logs' bound is looser than the earlier
    // 1e-6 of max |u| (the condition number, ~1e4, times the ~1e-10 relative residual the
    // runs stop at), the tighter of the two holds: the cantilever's.
    for (name, set, d3) in [
        ("cantilever-3d", vec![], true),
        (
            "hyperelastic-cube-3d",
            vec!["spacing=0.125", "method.solver=direct"],
            true,
        ),
        ("plate-compression-2d", vec![], false),
    ] {
        let ((diff, largest), cpu_log, gpu_log) = if d3 {
            let (cpu, cpu_log) = run::<D3>(name, &set, Backend::Cpu);
            let (gpu, gpu_log) = run::<D3>(name, &set, Backend::Gpu);
            (difference::<D3>(&cpu, &gpu), cpu_log, gpu_log)
        } else {
            let (cpu, cpu_log) = run::<D2>(name, &set, Backend::Cpu);
            let (gpu, gpu_log) = run::<D2>(name, &set, Backend::Gpu);
            (difference::<D2>(&cpu, &gpu), cpu_log, gpu_log)
        };
        let bound =
            (10.0 * (implied_error(&cpu_log) + implied_error(&gpu_log))).min(1e-6 * largest);
        let per_step = |log: &[Iteration]| -> Vec<u32> {
            let last = log.iter().map(|it| it.load_step).max().unwrap_or(0);
            (1..=last)
                .map(|s| {
                    log.iter()
                        .filter(|it| it.load_step == s)
                        .map(|it| it.iteration)
                        .max()
                        .unwrap_or(0)
                })
                .collect()
        };
        let (cpu_its, gpu_its) = (per_step(&cpu_log), per_step(&gpu_log));
        let cg: Vec<u32> = gpu_log.iter().map(|it| it.linear_iterations).collect();
        eprintln!(
            "{name}: |Δu| {:e} of max |u| (bound {:e}); Newton iterations cpu {cpu_its:?}, \
             gpu {gpu_its:?}; CG iterations {cg:?}",
            diff / largest,
            bound / largest
        );
        assert!(diff < bound, "{name}: |Δu| {diff:e} m, bound {bound:e} m");
        assert_eq!(cpu_its.len(), gpu_its.len(), "{cpu_its:?} {gpu_its:?}");
        for (c, g) in cpu_its.iter().zip(&gpu_its) {
            assert!(*g <= c + 2, "{name}: cpu {cpu_its:?}, gpu {gpu_its:?}");
        }
        assert!(cg.iter().any(|&k| k > 0), "{cg:?}");
    }
}
