//! Stabilised conforming nodal integration (SCNI; Chen, Wu, Yoon and You 2001) of `efg`
//! and `kbm` (`integration = "scni"`): the smoothed gradients' linear completeness and
//! integration constraint, the displacement patch test on the static path, Timoshenko's
//! cantilever with the verification matrix's measure, and a released cantilever in
//! dynamics against the unstabilised nodal integration. The figures are in
//! docs/methods/seed001.md and docs/verification.md.

use crate::verification::{Row, cantilever_error};
use glam::{DMat2, DVec2};
use meshless::core::integrate::Integrator;
use meshless::core::kernel::{Kernel, KernelKind};
use meshless::core::quadrature::{Shapes, SmoothingCells};
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::Method;
use meshless::methods::cores::galerkin::{GalerkinState, TlGalerkin};
use meshless::run::{Backend, build_method, engine};
use meshless::scene::Scene;
use std::path::Path;

/// The particles of a vertex lattice of spacing dx from the origin with n_k points along
/// axis k, and their cells clipped to the box.
fn lattice<D: Dim>(n: [usize; 3], dx: f64) -> (Vec<D::V>, SmoothingCells) {
    let total: usize = n[..D::N].iter().product();
    let x: Vec<D::V> = (0..total)
        .map(|i| {
            let at = [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])];
            D::from_slice(&at.map(|a| a as f64 * dx)[..D::N])
        })
        .collect();
    let max = n.map(|k| (k - 1) as f64 * dx);
    let cells = SmoothingCells::clipped::<D>(&x, &vec![0; total], dx, &[([0.0; 3], max)]);
    (x, cells)
}

/// Σ_a ∇N_a = 0 and Σ_a X_a ⊗ ∇N_a = I at every point (trial gradients), Σ_a ∇Φ_a = 0 for
/// the test gradients: the largest error of either.
fn completeness_error<D: Dim>(shapes: &Shapes<D>, x: &[D::V]) -> f64 {
    let mut worst = 0.0f64;
    for q in 0..shapes.len() {
        let (mut trial, mut test, mut grad) = (D::zero(), D::zero(), D::zero_t());
        for p in shapes.csr.range(q) {
            let a = shapes.csr.ids[p] as usize;
            trial += shapes.grad[p];
            test += shapes.test_gradient(p);
            grad += D::outer(x[a], shapes.grad[p]);
        }
        let off = grad - D::identity();
        worst = worst
            .max(D::norm2(trial).sqrt())
            .max(D::norm2(test).sqrt())
            .max(D::ddot(off, off).sqrt());
    }
    worst
}

#[test]
fn smoothed_gradients_are_linearly_complete_and_meet_the_integration_constraint() {
    // Chen et al. 2001: b̃_a(X_L) = (1/A_L) ∮_{Γ_L} Φ_a n dΓ by 2 Gauss points an edge is
    // exact for a linear field (Φ_a reproduce it), so Σ_a b̃_a = 0 and Σ_a X_a ⊗ b̃_a = I at
    // every particle, corners included, for the MLS functions and for the smoothed
    // Krongauz–Belytschko ones (G̃_a = M̃⁻¹ ∇̃W^S_a, Σ_a X_a ⊗ G̃_a = I by construction;
    // the Shepard test gradients sum to zero as ∮ n = 0). Round-off of sums of O(40)
    // terms of O(1/Δx): 1e-10/Δx. The cells tile the box (Σ A_L = its area, exact in
    // binary on this lattice), and the faces inside the box cancel: Σ_L A_L b̃_a(X_L) is
    // the quadrature of ∮_Γ Φ_a n over the box's boundary, zero for a node whose support
    // does not reach it (1e-12 of Σ_L A_L |b̃_a|).
    let dx = 0.1;
    let kernel = Kernel::new(KernelKind::CubicSpline, 1.3 * dx, 2);
    let (x, cells) = lattice::<D2>([12, 9, 1], dx);
    let body = vec![0; x.len()];
    let volumes = cells.volumes::<D2>();
    let area: f64 = volumes.iter().sum();
    assert!((area - 1.1 * 0.8).abs() < 1e-14, "Σ A_L = {area}");
    let mls = Shapes::<D2>::smoothed_moving_least_squares(&cells, &x, &body, &kernel).unwrap();
    let kb = Shapes::<D2>::smoothed_krongauz_belytschko(&cells, &x, &body, &kernel).unwrap();
    assert!(mls.test.is_empty() && kb.test.len() == kb.grad.len());
    for (name, shapes) in [("MLS", &mls), ("KB", &kb)] {
        let error = completeness_error::<D2>(shapes, &x);
        assert!(
            error < 1e-10 / dx,
            "{name}: linear completeness off by {error:e}"
        );
        let mut constraint = vec![(DVec2::ZERO, 0.0); x.len()];
        for (l, &a_l) in volumes.iter().enumerate() {
            for p in shapes.csr.range(l) {
                let c = &mut constraint[shapes.csr.ids[p] as usize];
                c.0 += shapes.test_gradient(p) * a_l;
                c.1 += shapes.test_gradient(p).length() * a_l;
            }
        }
        let support = 2.0 * kernel.h;
        for (a, (sum, scale)) in constraint.iter().enumerate() {
            let inside =
                x[a].min_element() > support && x[a].x < 1.1 - support && x[a].y < 0.8 - support;
            if inside {
                assert!(
                    sum.length() < 1e-12 * scale,
                    "{name}: node {a}: Σ A b̃ = {sum}"
                );
            }
        }
    }
    // 3D: 2×2 Gauss points a face, the same identities.
    let kernel = Kernel::new(KernelKind::CubicSpline, 1.3 * dx, 3);
    let (x, cells) = lattice::<D3>([5, 4, 4], dx);
    let body = vec![0; x.len()];
    assert!((cells.volumes::<D3>().iter().sum::<f64>() - 0.4 * 0.3 * 0.3).abs() < 1e-15);
    for shapes in [
        Shapes::<D3>::smoothed_moving_least_squares(&cells, &x, &body, &kernel).unwrap(),
        Shapes::<D3>::smoothed_krongauz_belytschko(&cells, &x, &body, &kernel).unwrap(),
    ] {
        let error = completeness_error::<D3>(&shapes, &x);
        assert!(
            error < 1e-10 / dx,
            "3D: linear completeness off by {error:e}"
        );
    }
}

/// A static plane-stress linear-elastic block [0, 1.2] × [0, 1] at Δx = 0.1 under
/// `method` with `keys`, with u = A X + c prescribed on every particle closer than
/// `layer` to the boundary: (the largest error of u at the free particles over the
/// largest |u| there, the number of free particles).
fn patch_test(method: &str, keys: &str, layer: f64) -> (f64, usize) {
    let (dx, lx, ly): (f64, f64, f64) = (0.1, 1.2, 1.0);
    let a = DMat2::from_cols(DVec2::new(1.0e-3, -2.0e-4), DVec2::new(4.0e-4, 6.0e-4));
    let c = DVec2::new(1.0e-4, -2.0e-4);
    let exact = |x: DVec2| a * x + c;
    let mut boundaries = String::new();
    let (nx, ny) = ((lx / dx).round() as usize, (ly / dx).round() as usize);
    for j in 0..=ny {
        for i in 0..=nx {
            let x = DVec2::new(i as f64 * dx, j as f64 * dx);
            let depth = x.x.min(x.y).min(lx - x.x).min(ly - x.y);
            if depth < layer {
                let u = exact(x);
                let (lo, hi) = (x - 0.25 * dx, x + 0.25 * dx);
                boundaries += &format!(
                    "[[boundary]]\nregion = {{ x_min = {}, x_max = {}, y_min = {}, y_max = {} }}\n\
                     condition = {{ type = \"displacement\", ux = {:e}, uy = {:e} }}\n",
                    lo.x, hi.x, lo.y, hi.y, u.x, u.y
                );
            }
        }
    }
    let text = format!(
        r#"
name = "patch"
dimension = 2
spacing = {dx}
[material]
model = "linear-elastic"
plane = "stress"
density = 1000.0
youngs_modulus = 1.0e7
poisson_ratio = 0.3
[method]
name = "{method}"
h_over_dx = 1.3
{keys}
dt = 1.0
[[body]]
name = "block"
geometry = {{ shape = "box", min = [0.0, 0.0], max = [{lx}, {ly}] }}
{boundaries}
[run]
solve = "static"
end_time = 1.0
"#
    );
    let case = Scene::from_toml(&text, Path::new("patch.toml"), &[]).unwrap();
    let mut e = engine::<D2>(&case, Backend::Cpu).unwrap();
    e.advance(0.0, 1.0, 1).unwrap();
    let s = e.snapshot();
    let (mut error, mut scale, mut free) = (0.0f64, 0.0f64, 0);
    for (x, u) in s.x0.iter().zip(&s.u) {
        if x.x.min(x.y).min(lx - x.x).min(ly - x.y) >= layer {
            error = error.max((*u - exact(*x)).length());
            scale = scale.max(exact(*x).length());
            free += 1;
        }
    }
    (error / scale, free)
}

#[test]
fn scni_passes_the_displacement_patch_test() {
    // The free particles' functions must vanish on the boundary (a free node whose test
    // function reaches Γ would carry the unknown reaction ∫_Γ Φ_a t dΓ of the prescribed
    // boundary in its equation), so u = A X + c is prescribed on every particle within the
    // support 2h = 0.26 of the boundary: three rows, leaving 7 × 5 free. With SCNI the
    // linear field gives F exact at every particle, a uniform P, and a free node's force
    // P·Σ_L A_L b̃_a(X_L) = P·∮_Γ Φ_a n dΓ = 0 exactly (the integration constraint): the
    // linear field solves the equations, and the solve reproduces it to its round-off,
    // κ(K)·ε on strains of 1e-3 (bound 1e-10 of |u|). The 2×2 Gauss cells of EFG (ci)
    // integrate the rational MLS gradients inexactly, Σ_q w_q ∇Φ_a ≠ 0, and miss by
    // more: reported in docs/methods/seed001.md, not asserted.
    let layer = 0.26;
    for (method, keys) in [
        ("efg", "integration = \"scni\""),
        ("kbm", "integration = \"scni\""),
    ] {
        let (error, free) = patch_test(method, keys, layer);
        eprintln!("{method} ({keys}): patch test error {error:.3e} at {free} free particles");
        assert_eq!(free, 35);
        assert!(error < 1e-10, "{method} ({keys}): relative error {error:e}");
    }
    for (method, keys) in [
        ("efg", ""),
        ("efg", "integration = \"nodal\""),
        ("kbm", ""),
        ("kbm", "integration = \"nodal\""),
    ] {
        let (error, _) = patch_test(method, keys, layer);
        eprintln!("{method} ({keys}): patch test error {error:.3e}");
    }
}

/// The rows of SCNI in the verification matrix's measure: the bounds are 1.5 times the
/// errors measured at Δx = 0.125 m (docs/verification.md), so that a change that adds half
/// the error fails; the orders are those of the methods' default integration in the
/// matrix: two for EFG (a linearly complete Bubnov–Galerkin method, as Chen et al. 2001
/// find for SCNI), one for KBM.
const SCNI_ROWS: [Row; 2] = [
    Row {
        method: "efg",
        keys: "h_over_dx = 1.3\nintegration = \"scni\"",
        order: 2.0,
        cantilever_error: 1.15e-2,
        patch_error: 1e-9,
    },
    Row {
        method: "kbm",
        keys: "h_over_dx = 1.3\nintegration = \"scni\"",
        order: 1.0,
        cantilever_error: 0.134,
        patch_error: 1e-9,
    },
];

#[test]
fn scni_converges_to_timoshenkos_cantilever() {
    // The verification matrix's cantilever (8 × 2 m, P = −1000 N/m, E = 1e7, ν = 0.3) at
    // Δx = 0.25 and 0.125 m: the error at 0.125 under the row's bound and the observed
    // order at least 0.8 of the row's (the matrix's rule; measured 1.71 for EFG, 1.20 for
    // KBM). The unstabilised nodal integration is printed for docs/verification.md.
    let mut failures = Vec::new();
    for row in &SCNI_ROWS {
        let coarse = cantilever_error(row, 0.25);
        let fine = cantilever_error(row, 0.125);
        let order = (coarse / fine).log2();
        eprintln!(
            "{} SCNI: error {coarse:.3e} → {fine:.3e}, order {order:.2}",
            row.method
        );
        if fine > row.cantilever_error || order < 0.8 * row.order {
            failures.push(format!(
                "{}: error {coarse:.3e} → {fine:.3e}, order {order:.2}",
                row.method
            ));
        }
    }
    for method in ["efg", "kbm"] {
        let row = Row {
            method,
            keys: "h_over_dx = 1.3\nintegration = \"nodal\"",
            order: 0.0,
            cantilever_error: 0.0,
            patch_error: 0.0,
        };
        let (coarse, fine) = (cantilever_error(&row, 0.25), cantilever_error(&row, 0.125));
        eprintln!("{method} nodal: error {coarse:.3e} → {fine:.3e}");
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A plane-stress SVK cantilever, L = 1 m free, D = 0.2 m, clamped by the three columns
/// behind x = 0, released in Euler–Bernoulli's first bending mode (0.1 m/s at the tip),
/// under `method` with `keys` on the leapfrog at Δt = 1e-4 s (CFL 0.3).
fn released_cantilever(method: &str, keys: &str) -> Scene {
    let text = format!(
        r#"
name = "released"
dimension = 2
spacing = 0.04
[material]
model = "saint-venant-kirchhoff"
plane = "stress"
density = 1100.0
youngs_modulus = 1.7e7
poisson_ratio = 0.3
[method]
name = "{method}"
h_over_dx = 1.3
{keys}
integrator = "leapfrog"
dt = 1.0e-4
[[body]]
name = "beam"
geometry = {{ shape = "box", min = [-0.08, -0.1], max = [1.0, 0.1] }}
initial_velocity = {{ type = "expression", vx = "0", vy = "A*((cosh(b*x) - cos(b*x)) - s*(sinh(b*x) - sin(b*x)))", constants = {{ A = 0.05, b = 1.8751, s = 0.734096 }} }}
[[boundary]]
region = {{ x_max = 0.0 }}
condition = {{ type = "fixed" }}
[run]
end_time = 1.0
"#
    );
    Scene::from_toml(&text, Path::new("released.toml"), &[]).unwrap()
}

/// The largest |E(t)/E(0) − 1| of the total energy (kinetic + stored) and the largest
/// |u_y| of the beam, sampled every 50 steps over `steps` steps of the released
/// cantilever; None if it blew up.
fn energy_and_deflection(method: &str, keys: &str, steps: usize) -> Option<(f64, f64)> {
    let case = released_cantilever(method, keys);
    let mut m: TlGalerkin<D2> = build_method(&case).unwrap();
    let mut y: GalerkinState<D2> = m.initial_state();
    let energy = |m: &TlGalerkin<D2>, y: &GalerkinState<D2>| {
        let kinetic: f64 =
            y.v.iter()
                .zip(m.mass())
                .map(|(v, m)| 0.5 * m * v.length_squared())
                .sum();
        kinetic + m.strain_energy(y).value()
    };
    let e0 = energy(&m, &y);
    let mut integrator = Integrator::new(case.method.integrator, &y);
    let dt = case.method.dt.unwrap();
    let (mut drift, mut deflection) = (0.0f64, 0.0f64);
    for k in 0..steps {
        integrator.step(&mut m, k as f64 * dt, dt, &mut y).ok()?;
        if (k + 1) % 50 == 0 {
            let e = energy(&m, &y);
            if !e.is_finite() {
                return None;
            }
            drift = drift.max((e / e0 - 1.0).abs());
            deflection = y.u.iter().fold(deflection, |d, u| d.max(u.y.abs()));
        }
    }
    Some((drift, deflection))
}

#[test]
fn a_released_cantilever_keeps_its_energy_under_scni() {
    // Euler–Bernoulli: ω = (βL)² sqrt(E D²/(12 ρ L⁴)) = 25.2 rad/s, T = 0.249 s, tip
    // amplitude 0.1 m/s / ω = 4.0e-3 m; 7,500 steps are three periods. Without damping
    // the total energy of the Bubnov–Galerkin EFG is an invariant, which the leapfrog
    // keeps to O((ωΔt)²) (measured 5.7e-5, as EFG (ci)); bound 1e-3. The Petrov–Galerkin
    // KBM's force is not the gradient of its stored energy, whose sum with the kinetic
    // one moves by 5.6 % within the first eighth of a period and then stays (KBM (si)
    // alike, 5.7 %); bound 0.1. A zero-energy mode fed by the others would grow past
    // both: KBM's unstabilised nodal integration reaches 6e3 E(0) by the end (bound: more
    // than E(0)). The deflection stays within twice Euler–Bernoulli's amplitude
    // (measured 4.3e-3 and 4.4e-3 m: the coarse lattice's longer period).
    let steps = 7500;
    for (method, bound) in [("efg", 1e-3), ("kbm", 0.1)] {
        let result = energy_and_deflection(method, "integration = \"scni\"", steps);
        eprintln!("{method} SCNI: (energy drift, max |u_y|) = {result:?}");
        let (drift, deflection) = result.unwrap_or_else(|| panic!("{method} SCNI blew up"));
        assert!(drift < bound, "{method} SCNI: energy drift {drift:e}");
        assert!(
            deflection < 8.0e-3,
            "{method} SCNI: |u_y| up to {deflection:e} m"
        );
    }
    let nodal = energy_and_deflection("kbm", "integration = \"nodal\"", steps);
    eprintln!("kbm nodal: (energy drift, max |u_y|) = {nodal:?}");
    assert!(
        nodal.is_none_or(|(drift, _)| drift > 1.0),
        "KBM (ni) keeps its energy: {nodal:?}"
    );
}

#[test]
fn scni_refuses_what_its_cells_cannot_tile() {
    // The smoothing cells are a box's lattice squares: a disk, a box with holes and the
    // Eulerian kernel (whose cells would move) are refused, naming the key.
    let case = |method: &str, keys: &str, geometry: &str| {
        let text = format!(
            r#"
name = "refused"
dimension = 2
spacing = 0.1
[material]
model = "saint-venant-kirchhoff"
density = 1000.0
youngs_modulus = 1.0e7
poisson_ratio = 0.3
[method]
name = "{method}"
h_over_dx = 1.3
integration = "scni"
{keys}
dt = 1.0e-5
[[body]]
name = "plate"
{geometry}
[run]
end_time = 1.0e-4
"#
        );
        Scene::from_toml(&text, Path::new("refused.toml"), &[])
    };
    let disk = "geometry = { shape = \"disk\", center = [0.0, 0.0], radius = 1.0 }";
    let holed = "geometry = { shape = \"box\", min = [0.0, 0.0], max = [1.0, 1.0] }\n\
                 holes = [{ center = [0.5, 0.5], radius = 0.2 }]";
    for (method, geometry, key) in [
        ("efg", disk, "body.0.geometry"),
        ("kbm", holed, "body.0.holes"),
    ] {
        let case = case(method, "", geometry).unwrap();
        let error = engine::<D2>(&case, Backend::Cpu).err().unwrap().to_string();
        assert!(
            error.contains(key) && error.contains("scni"),
            "{method}: {error}"
        );
    }
    let box_ = "geometry = { shape = \"box\", min = [0.0, 0.0], max = [1.0, 1.0] }";
    let error = case("kbm", "kernel_frame = \"eulerian\"", box_)
        .err()
        .unwrap()
        .to_string();
    assert!(error.contains("method.integration"), "{error}");
}
