use super::*;
use crate::core::tensor::{D2, D3};
use crate::physics::material::{MaterialModel, MaterialSpec};

fn material() -> Material {
    Material::new(&MaterialSpec::elastic(
        MaterialModel::NeoHookean,
        1100.0,
        1.7e7,
        0.3,
    ))
}

/// ρ0 ü = DIV P at interior points, by central differences of the analytic stress
/// (step 1e-4: truncation ~1e-8 relative, well inside the 1e-6 bound).
fn satisfies_elastodynamics<D: Dim>(kind: SwingingKind) {
    let mat = material();
    let sine = SwingingMode::new(5e-4, &mat, D::N, kind);
    for mode in [sine, sine.cosine()] {
        satisfies_elastodynamics_in::<D>(&mat, mode);
    }
}

fn satisfies_elastodynamics_in<D: Dim>(mat: &Material, mode: SwingingMode) {
    let t = 0.3 / mode.omega;
    let h = 1e-4;
    for x in [
        [0.3, 0.6, 0.2],
        [0.85, 0.1, 0.5],
        [0.5, 0.5, 0.9],
        [1.7, 1.2, 0.4],
    ] {
        let x = D::from_slice(&x);
        let accel = mode.displacement::<D>(x, t) * (-mode.omega * mode.omega * mat.rho0);
        let mut div = vec![0.0; D::N];
        for l in 0..D::N {
            let mut e = [0.0; 3];
            e[l] = h;
            let dp = mode.stress::<D>(mat, x + D::from_slice(&e), t)
                - mode.stress::<D>(mat, x - D::from_slice(&e), t);
            for (k, d) in div.iter_mut().enumerate() {
                *d += D::entry(dp, k, l) / (2.0 * h);
            }
        }
        let (a, d) = (D::to3(accel), div);
        let scale = D::norm2(accel).sqrt();
        for k in 0..D::N {
            assert!((a[k] - d[k]).abs() < 1e-6 * scale, "{a:?} vs {d:?}");
        }
    }
}

#[test]
fn swinging_plate_and_cube_solve_linear_elastodynamics() {
    satisfies_elastodynamics::<D2>(SwingingKind::Dilatational);
    satisfies_elastodynamics::<D3>(SwingingKind::Dilatational);
    satisfies_elastodynamics::<D2>(SwingingKind::Shear);
}

#[test]
fn the_cosine_form_starts_at_rest_displaced_by_the_shape() {
    // u = U0 cos(ωt) Φ: u(0) = U0 Φ as `shape_at` gives it, v(0) = 0, and at any t
    // the sine form a quarter period later (exact identities, so round-off bounds).
    let mat = material();
    let sine = SwingingMode::new(5e-4, &mat, 3, SwingingKind::Dilatational);
    let cosine = sine.cosine();
    let x = [0.3, 0.6, 0.2];
    let xv = D3::from_slice(&x);
    let u0 = D3::to3(cosine.displacement::<D3>(xv, 0.0));
    let phi = SwingingMode::shape_at(SwingingKind::Dilatational, 3, x);
    for k in 0..3 {
        assert!((u0[k] - 5e-4 * phi[k]).abs() < 1e-18, "{u0:?} vs {phi:?}");
    }
    // cos(π/2) is 6.1e-17 in f64: v(0) is that fraction of U0 ω.
    let v0 = D3::norm2(cosine.velocity::<D3>(xv, 0.0)).sqrt();
    assert!(v0 < 1e-16 * 5e-4 * sine.omega, "v(0) = {v0:e}");
    let t = 1.3e-3;
    let quarter = FRAC_PI_2 / sine.omega;
    let (a, b) = (
        cosine.velocity::<D3>(xv, t),
        sine.velocity::<D3>(xv, t + quarter),
    );
    assert!(D3::norm2(a - b).sqrt() < 1e-12 * D3::norm2(b).sqrt());
}

#[test]
fn the_shear_mode_is_seed_002s_with_rollers_on_the_square() {
    // Eq 42 at a = π/2, ω of eq 43 (159.708 rad/s at E = 17 MPa, ν = 0.495 in the
    // note's derivation, here at ν = 0.3 from the same formula), and u·n = 0 on the
    // four edges of [0, 2]².
    let mat = material();
    let mode = SwingingMode::new(0.01, &mat, 2, SwingingKind::Shear);
    assert!((mode.omega - FRAC_PI_2 * (2.0 * mat.mu / mat.rho0).sqrt()).abs() < 1e-9);
    let t = 0.2 / mode.omega;
    let (x1, x2) = (0.7, 1.3);
    let u = mode.displacement::<D2>(D2::from_slice(&[x1, x2]), t);
    let a = FRAC_PI_2;
    let s = 0.01 * (mode.omega * t).sin();
    assert!((u.x + s * (a * x1).sin() * (a * x2).cos()).abs() < 1e-15);
    assert!((u.y - s * (a * x1).cos() * (a * x2).sin()).abs() < 1e-15);
    for e in [0.0, 2.0] {
        for q in [0.3, 1.1] {
            assert!(mode.displacement::<D2>(D2::from_slice(&[e, q]), t).x.abs() < 1e-15);
            assert!(mode.displacement::<D2>(D2::from_slice(&[q, e]), t).y.abs() < 1e-15);
        }
    }
}

#[test]
fn swinging_mode_meets_its_boundary_conditions() {
    let mode = SwingingMode::new(1.0, &material(), 3, SwingingKind::Dilatational);
    let u0 = D3::to3(mode.displacement::<D3>(D3::from_slice(&[0.0, 0.4, 0.7]), 1e-3));
    assert_eq!(u0[0], 0.0);
    let u1 = D3::to3(mode.displacement::<D3>(D3::from_slice(&[1.0, 0.4, 0.7]), 1e-3));
    assert!(u1[1].abs() < 1e-15 && u1[2].abs() < 1e-15 && u1[0] != 0.0);
}
