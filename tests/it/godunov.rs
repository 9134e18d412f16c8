//! Godunov SPH on the CPU: the acoustic Riemann solver's consistency (seed 000 §7 item
//! 21), the reduction to the standard SPH sums for equal states, frame invariance (item
//! 6) and exact linear momentum of the Riemann pair forces (item 12).

use crate::common::{load, noise};
use crate::gray_monaghan::{block_3d, net, random_deviator, random_state, random_vector, rates};
use glam::{DMat2, DVec2};
use meshless::core::tensor::{D2, D3};
use meshless::methods::Method;
use meshless::methods::godunov::Godunov;
use meshless::methods::godunov::system::{contact_traction, contact_velocity};
use meshless::run::build_method;

/// The shipped Godunov disk (276 particles, h/dx = 1.7) with overrides.
fn disk(overrides: &[&str]) -> Godunov<D2> {
    build_method(&load("rotating-disk-godunov", overrides)).unwrap()
}

#[test]
fn identical_states_give_their_own_velocity_and_traction() {
    // Item 21: with equal left and right states u* = u and t* = σ e (to the round-off of
    // the sums: 1e-15 of |u| + |p|/Z, 4e-16 of |t|); unequal pressures push the contact towards the lower
    // pressure, and a velocity jump adds Z_i Z_j/(Z_i + Z_j) (v_j − v_i) to the traction.
    let mut seed = 5;
    for _ in 0..20 {
        let z = 1.0 + 1e4 * (1.0 + noise(&mut seed));
        let (u, p) = (30.0 * noise(&mut seed), 1e6 * noise(&mut seed));
        let u_star = contact_velocity(z, u, p, z, u, p);
        let scale = u.abs() + p.abs() / z;
        assert!(
            (u_star - u).abs() <= 1e-15 * scale,
            "u* = {u_star}, u = {u}"
        );
        let t = random_vector::<D2>(&mut seed, 1e6);
        let v = random_vector::<D2>(&mut seed, 30.0);
        let t_star = contact_traction::<D2>(z, t, v, z, t, v);
        assert!(
            (t_star - t).length() <= 4e-16 * t.length(),
            "t* = {t_star}, t = {t}"
        );
    }
    // p_i > p_j with both at rest: the contact moves along −n (away from i, towards j).
    assert!(contact_velocity(2.0, 0.0, 3.0, 2.0, 0.0, 1.0) == -0.5);
    let jump = contact_traction::<D2>(
        2.0,
        DVec2::ZERO,
        DVec2::ZERO,
        6.0,
        DVec2::ZERO,
        DVec2::new(4.0, 0.0),
    );
    assert_eq!(jump, DVec2::new(2.0 * 6.0 / 8.0 * 4.0, 0.0));
}

#[test]
fn equal_pair_states_give_the_standard_sph_sums() {
    // Uniform ρ and S (so equal p and σ on both sides of every pair) on disordered
    // positions, at rest: t* = σ e, so v̇_i = Σ_j 2 m_j σ/ρ² ∇W_ij (eq 103), computed here
    // from the method's own lists. With random velocities and uniform ρ, u* is the mean
    // normal velocity, so ρ̇_i = −ρ Σ_j V_j (v_j − v_i)·∇W_ij = −ρ tr L_i (eq 104), L being
    // the plain gradient of eq 105. Round-off of ~40 terms: 1e-12 relative.
    let mut m = disk(&[]);
    let mut seed = 9;
    let dx = 2.0 / 19.0;
    let sigma_dev = random_deviator::<D2>(&mut seed, 1e5);
    let rho = 1.004;
    let mut y = m.initial_state();
    for i in 0..y.u.len() {
        y.u[i] = random_vector::<D2>(&mut seed, 0.2 * dx);
        y.v[i] = DVec2::ZERO;
        y.rho[i] = rho;
        y.s[i] = sigma_dev;
    }
    let d = rates(&mut m, &y);
    let kernel = meshless::core::kernel::Kernel::new(
        meshless::core::kernel::KernelKind::CubicSpline,
        1.7 * dx,
        2,
    );
    // p = (K/ρ0)(ρ − ρ0), K = E/(3(1 − 2ν)) = 1e7/0.6.
    let sigma = sigma_dev - DMat2::IDENTITY * (1e7 / 0.6 * (rho - 1.0));
    let x: Vec<DVec2> = m
        .reference()
        .iter()
        .zip(&y.u)
        .map(|(&x0, &u)| x0 + u)
        .collect();
    for i in 0..x.len() {
        let (mut standard, mut size) = (DVec2::ZERO, 0.0);
        for &j in m.neighbours().neighbours(i) {
            let j = j as usize;
            let term = sigma * kernel.grad::<D2>(x[i] - x[j]) * (2.0 * m.mass()[j] / (rho * rho));
            standard += term;
            size += term.length();
        }
        assert!(
            (d.v[i] - standard).length() < 1e-12 * size,
            "v̇ at {i}: {} against {standard}",
            d.v[i]
        );
    }
    for i in 0..y.v.len() {
        y.v[i] = random_vector::<D2>(&mut seed, 10.0);
    }
    let d = rates(&mut m, &y);
    let expected: Vec<f64> =
        d.f.iter()
            .map(|l| -rho * (l.col(0).x + l.col(1).y))
            .collect();
    let largest = expected.iter().fold(0.0, |a: f64, e| a.max(e.abs()));
    for (i, (&rho_dot, &e)) in d.rho.iter().zip(&expected).enumerate() {
        assert!(
            (rho_dot - e).abs() < 1e-12 * largest,
            "ρ̇ at {i}: {rho_dot} against {e}"
        );
    }
}

#[test]
fn a_rigid_translation_gives_no_stress_rate_and_no_force() {
    // Item 6: equal states on every pair, no stress: t* = 0 exactly (v_j − v_i = 0), so
    // no force and no stress rate; u* = u up to the round-off of Z u (1e-16 relative), so
    // ρ̇ vanishes to 1e-12 of ρ0 |v|/Δx.
    let mut m = disk(&[]);
    let mut y = m.initial_state();
    for i in 0..y.u.len() {
        y.u[i] = DVec2::new(0.3, -0.7);
        y.v[i] = DVec2::new(12.0, 5.0);
    }
    let d = rates(&mut m, &y);
    for i in 0..y.u.len() {
        assert!(
            d.rho[i].abs() < 1e-12 * 13.0 * 19.0 / 2.0,
            "ρ̇ at {i}: {}",
            d.rho[i]
        );
        assert_eq!(d.s[i], DMat2::ZERO, "Ṡ at {i}");
        assert_eq!(d.v[i], DVec2::ZERO, "v̇ at {i}");
        assert_eq!(d.u[i], y.v[i], "ẋ at {i}");
    }
}

#[test]
fn the_riemann_pair_forces_conserve_linear_momentum() {
    // Item 12: t*_ji = −t*_ij and W'(r) is common to both, so Σ m v̇ cancels pairwise; the
    // sum of ~1e4 terms in f64 leaves 1e-13 of their size.
    let mut seed = 13;
    // An adaptive h keeps W'(r) common to both through h_ij = ½(h_i + h_j), and the prime
    // space's lists are symmetric.
    for key in [
        "method.correction=none",
        "method.correction=randles-libersky",
        "method.correction=rkpm",
        "method.smoothing_length=density",
        "method.smoothing_length=continuity",
        "method.smoothing_length=prime-space",
    ] {
        let mut m = disk(&[key]);
        let y = random_state(&m, 2.0 / 19.0, &mut seed);
        let d = rates(&mut m, &y);
        let (total, size) = net::<D2>(m.mass(), &d.v);
        eprintln!("Godunov ({key}): |Σ m v̇| = {total:e} of {size:e}");
        assert!(total < 1e-12 * size, "Σ m v̇ = {total:e} of {size:e}");
    }
    // 3D: the traction of eq 132 as one vector across the pair axis.
    let mut m: Godunov<D3> = block_3d("godunov-sph", "none", "");
    let y = random_state(&m, 0.1, &mut seed);
    let d = rates(&mut m, &y);
    let (total, size) = net::<D3>(m.mass(), &d.v);
    eprintln!("Godunov 3D: |Σ m v̇| = {total:e} of {size:e}");
    assert!(total < 1e-12 * size, "3D: Σ m v̇ = {total:e} of {size:e}");
}
