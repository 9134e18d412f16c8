//! The traction-free treatment of the updated-Lagrangian strong forms (seed 000 §4, eq 110,
//! `free_surface = "projection"`): the surface particles it finds and the surface traction
//! σ·n it leaves under a uniform stress, against the untreated method.

use crate::common::block_case;
use crate::gray_monaghan::rates;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::Method;
use meshless::methods::cores::ul::{PairScheme, UlSph};
use meshless::methods::godunov::system::Scheme as GodunovScheme;
use meshless::methods::gray_monaghan::system::Scheme as GmScheme;
use meshless::run::build_method;

/// On the block of `block_case` (Δx = 0.1, h = 1.3Δx) at rest under a uniform stress σ0
/// (S0 and ρ0(1 + 1e-3)): the particles the treatment calls surface, and the largest
/// surface traction |σ_i·n| over the face particles (exact normals along the axes) at
/// least 2h from an edge of the block, treated and untreated.
fn surface_tractions<D: Dim, S: PairScheme<D>>(
    max: &[f64],
    method: &str,
) -> (usize, usize, f64, f64, f64)
where
    S::Spec: meshless::methods::Runs,
{
    let traction = |keys: &str| {
        let case = block_case(max, "hypoelastic", method, keys);
        let mut m: UlSph<D, S> = build_method(&case).unwrap();
        let mut y = m.initial_state();
        let mut s = D::zero_t();
        for a in 0..D::N {
            for b in 0..D::N {
                let e = |c: usize| {
                    let mut v = vec![0.0; D::N];
                    v[c] = 1.0;
                    D::from_slice(&v)
                };
                let value = if a == b { 1e4 * (a as f64 - 0.5) } else { 3e3 };
                s += D::outer(e(a), e(b)) * value;
            }
        }
        let trace = D::trace(s) / D::N as f64;
        s -= D::identity() * trace;
        for i in 0..y.u.len() {
            y.s[i] = s;
            y.rho[i] *= 1.001;
        }
        let _ = rates(&mut m, &y);
        let x0 = m.reference().to_vec();
        let h = m.core.kernel.h;
        let mut worst: f64 = 0.0;
        let mut scale: f64 = 0.0;
        let mut on_surface = 0;
        let mut faces = 0;
        for (i, &x) in x0.iter().enumerate() {
            let p = D::to3(x);
            let sigma = m.core.cauchy(i, &y);
            if m.core.surface_normal(i, &y.rho).is_some() {
                on_surface += 1;
            }
            // The axis of the face particle i lies on, if exactly one, and at least 2h
            // from the block's other faces.
            let on = |k: usize| p[k].abs() < 1e-9 || (p[k] - max[k]).abs() < 1e-9;
            let faces_of: Vec<usize> = (0..D::N).filter(|&k| on(k)).collect();
            let inner = |k: usize| p[k] >= 2.0 * h - 1e-9 && p[k] <= max[k] - 2.0 * h + 1e-9;
            if faces_of.len() != 1 || !(0..D::N).filter(|&k| k != faces_of[0]).all(inner) {
                continue;
            }
            faces += 1;
            let mut n = vec![0.0; D::N];
            n[faces_of[0]] = if p[faces_of[0]] < 1e-9 { -1.0 } else { 1.0 };
            let t = sigma * D::from_slice(&n);
            worst = worst.max(D::norm2(t).sqrt());
            let sigma0 = y.s[i] - D::identity() * m.core.material.pressure(y.rho[i]);
            scale = scale.max(D::norm2(sigma0 * D::from_slice(&n)).sqrt());
        }
        (on_surface, faces, worst, scale)
    };
    let (surface, faces, treated, scale) = traction("free_surface = \"projection\"");
    let (_, _, untreated, _) = traction("");
    (surface, faces, treated, untreated, scale)
}

/// The particles on the faces of a lattice block (`block_case`: Δx = 0.1 from the origin).
fn boundary_particles(max: &[f64]) -> usize {
    let n: Vec<usize> = max.iter().map(|m| (m / 0.1).round() as usize + 1).collect();
    let all: usize = n.iter().product();
    let inner: usize = n.iter().map(|k| k - 2).product();
    all - inner
}

fn check<D: Dim, S: PairScheme<D>>(max: &[f64], method: &str)
where
    S::Spec: meshless::methods::Runs,
{
    let (surface, faces, treated, untreated, scale) = surface_tractions::<D, S>(max, method);
    eprintln!(
        "{method} {}D: {surface} surface particles, {faces} on faces: |σ·n| ≤ {treated:e} \
         treated, {untreated:e} untreated (|σ0·n| ≤ {scale:e})",
        D::N
    );
    // The Shepard sum is 0.70–0.84 on a face and ≥ 0.95 a row in: exactly the lattice's
    // boundary particles are found.
    assert_eq!(surface, boundary_particles(max), "{method} {}D", D::N);
    assert!(faces > 0);
    // On a flat face the gradient of the Shepard sum is along the normal by symmetry, to
    // round-off of its ~30 terms: 1e-10 of |σ0| leaves room for it. Untreated, the traction
    // is σ0·n itself.
    assert!(
        treated < 1e-10 * scale,
        "{method} {}D: treated |σ·n| = {treated:e}",
        D::N
    );
    assert!(
        (untreated - scale).abs() < 1e-9 * scale,
        "{method} {}D",
        D::N
    );
}

#[test]
fn the_projection_leaves_no_traction_on_the_free_faces_of_a_uniform_stress() {
    check::<D2, GmScheme>(&[1.0, 0.6], "gray-monaghan-sph");
    check::<D2, GodunovScheme>(&[1.0, 0.6], "godunov-sph");
    check::<D3, GmScheme>(&[0.8, 0.7, 0.7], "gray-monaghan-sph");
}
