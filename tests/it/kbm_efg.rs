//! Seed 001's Galerkin particle methods on the CPU: the Krongauz–Belytschko method with
//! and without stress points (`kbm`) and the element-free Galerkin method with nodal and
//! cell integration (`efg`). Spec §11: linear completeness at every point (the patch
//! test's F), partition of unity (Σ f = 0), signs and factors (no force at F = I or under
//! a rigid rotation, free ends pulled inward in tension), the variational force of the
//! Bubnov–Galerkin EFG, and the zero-energy modes of nodal integration that stress points
//! remove.

use crate::common::{largest_v, random_vector};
use crate::galerkin::block;
use glam::{DMat2, DVec2};
use meshless::core::integrate::OdeSystem;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::Method;
use meshless::methods::cores::galerkin::{GalerkinState, TlGalerkin};
use meshless::run::build_method;
use meshless::scene::Scene;

/// The four variants: (method, keys, the paper's name).
const VARIANTS: [(&str, &str, &str); 4] = [
    ("kbm", "", "KBM (si)"),
    ("kbm", "integration = \"nodal\"", "KBM (ni)"),
    ("efg", "", "EFG (ci)"),
    ("efg", "integration = \"nodal\"", "EFG (ni)"),
];

fn system<D: Dim>(max: &[f64], model: &str, method: &str, keys: &str) -> TlGalerkin<D> {
    build_method(&block(max, model, method, keys)).unwrap()
}

fn forces<D: Dim>(m: &mut TlGalerkin<D>, y: &GalerkinState<D>) -> Vec<D::V> {
    let mut d = y.clone();
    m.rates(0.0, y, &mut d).unwrap();
    d.v.iter().zip(m.mass()).map(|(&a, &m)| a * m).collect()
}

/// The initial state with displacements u(X).
fn displaced<D: Dim>(m: &TlGalerkin<D>, mut u: impl FnMut(D::V) -> D::V) -> GalerkinState<D> {
    let mut y = m.initial_state();
    for (u_a, &x) in y.u.iter_mut().zip(m.reference()) {
        *u_a = u(x);
    }
    y
}

#[test]
fn deformation_gradients_are_exact_for_affine_motion_at_every_point() {
    // Checklist item 2: u = G X gives F_q = I + G at every particle and stress point
    // (corners included) and every Gauss point, by the linear completeness of the
    // corrected gradient (eq 29) and of the MLS functions. Round-off of sums of O(20)
    // terms of O(G/Δx·Δx): 1e-12. Nodal fields are the point values where the particles
    // are points, a projection otherwise; both are I + G exactly.
    let g = DMat2::from_cols(DVec2::new(0.05, 0.02), DVec2::new(0.01, -0.03));
    for (method, keys, name) in VARIANTS {
        let m: TlGalerkin<D2> = system(&[1.0, 0.6], "saint-venant-kirchhoff", method, keys);
        let y = displaced(&m, |x| g * x);
        for (a, f) in m.deformation_gradient(&y).iter().enumerate() {
            let error = (*f - DMat2::IDENTITY - g)
                .abs()
                .to_cols_array()
                .into_iter()
                .fold(0.0, f64::max);
            assert!(error < 1e-12, "{name}: node {a}: F off by {error:e}");
        }
    }
}

#[test]
fn internal_forces_sum_to_zero() {
    // Checklist item 3: the test functions of every point sum to one, so Σ_a ∇Φ_a(X_q) =
    // 0 and Σ_a f_a = −Σ_q w_q P_q Σ_a ∇Φ_a = 0 for any state (global linear momentum),
    // Shepard test functions included. Random u under SVK, 2D and 3D. Round-off of sums
    // of ~1e3 terms of the largest force: 1e-12 of it per node.
    for (method, keys, name) in VARIANTS {
        let mut m: TlGalerkin<D2> = system(&[1.0, 0.6], "saint-venant-kirchhoff", method, keys);
        let mut seed = 11;
        let y = displaced(&m, |_| random_vector::<D2>(&mut seed, 0.01));
        let f = forces(&mut m, &y);
        let total: DVec2 = f.iter().sum();
        let scale = largest_v::<D2>(f.iter().copied());
        assert!(
            total.length() < 1e-12 * scale * f.len() as f64,
            "{name}: Σ f = {total} against |f| up to {scale}"
        );
    }
    let mut m: TlGalerkin<D3> = system(&[0.4, 0.3, 0.3], "neo-hookean", "kbm", "");
    let mut seed = 3;
    let y = displaced(&m, |_| random_vector::<D3>(&mut seed, 0.005));
    let f = forces(&mut m, &y);
    let total = f.iter().fold(glam::DVec3::ZERO, |s, &f| s + f);
    let scale = largest_v::<D3>(f.iter().copied());
    assert!(
        total.length() < 1e-12 * scale * f.len() as f64,
        "3D KBM (si): Σ f = {total}"
    );
}

#[test]
fn no_force_at_rest_or_under_a_rigid_rotation_and_free_ends_pull_inward() {
    // Checklist item 4. F = I and F = R (a rotation by 0.7 rad, reproduced exactly by the
    // linear completeness of every variant) give P = 0 for SVK, so every force is
    // round-off: 1e-9 of the force a 1 % stretch gives. Under a uniform 1 % stretch along
    // x, only the particles on the two free ends carry a net force (the interior ones a
    // quadrature error, below) and it points inward: −x at X = 1, +x at X = 0.
    let rotation = DMat2::from_angle(0.7);
    for (method, keys, name) in VARIANTS {
        let mut m: TlGalerkin<D2> = system(&[1.0, 0.6], "saint-venant-kirchhoff", method, keys);
        let stretched = displaced(&m, |x| DVec2::new(0.01 * x.x, 0.0));
        let f = forces(&mut m, &stretched);
        let scale = largest_v::<D2>(f.iter().copied());
        for (label, y) in [
            ("rest", m.initial_state()),
            ("rotation", displaced(&m, |x| rotation * x - x)),
        ] {
            let worst = largest_v::<D2>(forces(&mut m, &y));
            assert!(worst < 1e-9 * scale, "{name}, {label}: |f| up to {worst:e}");
        }
        let x0 = m.reference().to_vec();
        let end = |at: f64| -> f64 {
            f.iter()
                .zip(&x0)
                .filter(|(_, x)| (x.x - at).abs() < 1e-9)
                .map(|(f, _)| f.x)
                .sum()
        };
        let (left, right) = (end(0.0), end(1.0));
        assert!(
            left > 0.5 * scale && right < -0.5 * scale,
            "{name}: the end columns' forces are {left:e} at X = 0 and {right:e} at X = 1"
        );
    }
}

#[test]
fn the_element_free_galerkin_force_is_minus_the_energy_gradient() {
    // Bubnov–Galerkin: f_a = −∂Π/∂u_a with Π = Σ_q w_q ψ(F_q), by central differences
    // (δ = 1e-7 m on strains of ~1 %: truncation O(δ²), cancellation ε·Π/δ, together 1e-6
    // of the largest force). Krongauz–Belytschko's Petrov–Galerkin force is not (its
    // corrected gradient is not the gradient of a function, spec §3.2): it misses by more
    // than 1 % of the largest force at some node.
    let mismatch = |method: &str, keys: &str| {
        let mut m: TlGalerkin<D2> = system(&[1.0, 0.6], "saint-venant-kirchhoff", method, keys);
        let mut seed = 7;
        let y = displaced(&m, |_| random_vector::<D2>(&mut seed, 0.01));
        let f = forces(&mut m, &y);
        let scale = largest_v::<D2>(f.iter().copied());
        let delta = 1e-7;
        let mut worst = 0.0f64;
        for (k, f_k) in f.iter().enumerate() {
            for (c, f_kc) in f_k.to_array().into_iter().enumerate() {
                let energy = |s: f64| {
                    let mut z = y.clone();
                    z.u[k][c] += s * delta;
                    m.strain_energy(&z).value()
                };
                let fd = -(energy(1.0) - energy(-1.0)) / (2.0 * delta);
                worst = worst.max((fd - f_kc).abs() / scale);
            }
        }
        worst
    };
    for keys in ["", "integration = \"nodal\""] {
        let worst = mismatch("efg", keys);
        assert!(
            worst < 1e-6,
            "EFG ({keys}): f differs from −∂Π/∂u by {worst:e}"
        );
    }
    let worst = mismatch("kbm", "");
    assert!(worst > 1e-2, "KBM (si) is variational to {worst:e}");
}

/// max |F_q − I| over the points at least `margin` inside the block [0, 1.6] × [0, 1.2]
/// (their supports symmetric), split into particles and the other points, under the
/// displacement u(i, j) of the particle in lattice column i and row j.
fn interior_strain(keys: &str, u: impl Fn(i64, i64) -> DVec2) -> (f64, f64) {
    let m: TlGalerkin<D2> = system(&[1.6, 1.2], "saint-venant-kirchhoff", "kbm", keys);
    let dx = 0.1;
    let y = displaced(&m, |x| {
        u((x.x / dx).round() as i64, (x.y / dx).round() as i64)
    });
    let margin = 0.26 + 1e-9;
    let inside = |x: DVec2| x.min_element() >= margin && x.x <= 1.6 - margin && x.y <= 1.2 - margin;
    let n = m.reference().len();
    let (mut particles, mut others) = (0.0f64, 0.0f64);
    for (q, f) in m.point_f(&y).iter().enumerate() {
        if inside(m.points().x0[q]) {
            let e = (*f - DMat2::IDENTITY)
                .abs()
                .to_cols_array()
                .into_iter()
                .fold(0.0, f64::max);
            if q < n {
                particles = particles.max(e)
            } else {
                others = others.max(e)
            }
        }
    }
    (particles, others)
}

#[test]
fn stress_points_strain_the_modes_that_nodal_integration_does_not_see() {
    // Seed 001 §5.2: nodal integration is rank-deficient. On a lattice the corrected
    // gradient at a particle whose support is whole is antisymmetric about it, so any
    // pattern even about every particle has F = I there: the stripes u = δ(−1)^i e_x
    // (and (−1)^j) are zero-energy modes of KBM (ni) in the interior. A cell centre is no
    // centre of the stripes ((−1)^(1−i) = −(−1)^i), so the stress points strain them:
    // O(δ/Δx). The checkerboard δ(−1)^(i+j) is even about the particles and about the cell
    // centres alike, so neither point set strains it in the interior: KBM (si) controls
    // it only where supports are cut (boundaries, or an envelope's gradient), as one-point
    // quadrilaterals their hourglass modes. Round-off on δ/Δx = 1e-3: 1e-12. The stress
    // points see the stripes through the kernel's average of alternating neighbours:
    // measured |F − I| = 0.272 δ/Δx at h/Δx = 1.3; bound 0.1 δ/Δx.
    let delta = 1e-4;
    let stripes = |i: i64, _j: i64| DVec2::new(delta * (-1f64).powi(i as i32), 0.0);
    let checkerboard = |i: i64, j: i64| DVec2::new(0.0, delta * (-1f64).powi((i + j) as i32));
    let scale = delta / 0.1;
    let (nodal, _) = interior_strain("integration = \"nodal\"", stripes);
    assert!(
        nodal < 1e-12,
        "KBM (ni): stripes strain interior particles by {nodal:e}"
    );
    let (particles, centres) = interior_strain("", stripes);
    eprintln!(
        "stripes under KBM (si): |F − I| {particles:e} at particles, {centres:e} at stress points (δ/Δx = {scale:e})"
    );
    assert!(
        particles < 1e-12 && centres > 0.1 * scale,
        "KBM (si): stripes {particles:e}, {centres:e}"
    );
    let (particles, centres) = interior_strain("", checkerboard);
    assert!(
        particles < 1e-12 && centres < 1e-12,
        "KBM (si): the checkerboard strains the interior by {particles:e}, {centres:e}"
    );
}

#[test]
fn scni_does_not_strain_the_stripes_inside_either() {
    // A particle's smoothing cell is a square centred on it, so a pattern even about every
    // particle has an interpolant even about it in the interior, and ∮ Φ n dΓ over the
    // square cancels: SCNI, like nodal integration, leaves the stripes δ(−1)^i unstrained
    // at interior particles (round-off on δ/Δx = 1e-3: 1e-12). Only the cells the
    // boundary cuts see them: the stability SCNI has on a lattice comes from its
    // boundary (docs/methods/seed001.md).
    let stripes = |i: i64, _j: i64| DVec2::new(1e-4 * (-1f64).powi(i as i32), 0.0);
    let (particles, _) = interior_strain("integration = \"scni\"", stripes);
    assert!(
        particles < 1e-12,
        "KBM SCNI: stripes strain interior particles by {particles:e}"
    );
}

/// The largest hourglass indicator η at `steps` steps of a free block [0, 1.6] × [0, 1.2]
/// set moving by the stripes v = v0 (−1)^i e_x under a smooth envelope that vanishes on
/// the boundary, v0 = 1e-3 m/s.
fn stripes_eta(case: &Scene, steps: &[usize]) -> Vec<f64> {
    let mut m: TlGalerkin<D2> = build_method(case).unwrap();
    let mut y = m.initial_state();
    for (v, x) in y.v.iter_mut().zip(m.reference()) {
        let envelope =
            (std::f64::consts::PI * x.x / 1.6).sin() * (std::f64::consts::PI * x.y / 1.2).sin();
        let sign = (-1f64).powi((x.x / case.spacing).round() as i32);
        *v = DVec2::new(1e-3 * sign * envelope, 0.0);
    }
    crate::common::hourglass_after(case, &mut m, y, steps, |m, y| {
        (y.u.clone(), m.deformation_gradient(y))
    })
}

#[test]
fn a_stripe_perturbation_grows_under_nodal_integration_only() {
    // The dynamic face of the test above: under KBM (ni) the interior stripes have no
    // stiffness but what the envelope's gradient gives, so their displacement, and the
    // hourglass indicator η with it, keeps growing; under KBM (si) they oscillate at
    // ω ≈ 2c/Δx (a period of ≈ 900 steps here) with an amplitude v0/ω, so η stays bounded.
    // η is sampled every 100 steps; the largest value over the first and the second
    // 20 ms (2000 steps) are compared. Measured: KBM (ni) 1.89e-4 then 2.60e-4 (×1.37),
    // KBM (si) 1.365e-4 then 1.363e-4; bounds ×1.2 for the growth, ×1.05 for the bound.
    let eta = |keys: &str| {
        let case = block(&[1.6, 1.2], "saint-venant-kirchhoff", "kbm", keys);
        let samples = stripes_eta(&case, &(1..=40).map(|k| 100 * k).collect::<Vec<_>>());
        let peak = |s: &[f64]| s.iter().copied().fold(0.0, f64::max);
        [peak(&samples[..20]), peak(&samples[20..])]
    };
    let nodal = eta("integration = \"nodal\"");
    let stress_points = eta("");
    eprintln!("largest η over 0–20 and 20–40 ms: KBM (ni) {nodal:?}, KBM (si) {stress_points:?}");
    assert!(
        nodal[1] > 1.2 * nodal[0],
        "KBM (ni): η does not grow: {nodal:?}"
    );
    assert!(
        stress_points[1] < 1.05 * stress_points[0] && stress_points[1] < 0.7 * nodal[1],
        "KBM (si): η {stress_points:?} against KBM (ni) {nodal:?}"
    );
}
