//! Gray–Monaghan updated-Lagrangian SPH on the CPU: neighbour lists rebuilt from moving
//! particles against a brute-force search, frame invariance, the analytic Jaumann rate of
//! an affine velocity field, exact linear momentum of the pair forces, the artificial
//! stress and viscosity (seed 000 §7 items 6, 7, 12, 22 and 23), and validation.

use crate::common::{load, noise, random_tensor};
use glam::{DMat2, DMat3, DVec2};
use meshless::case::CaseError;
use meshless::core::integrate::OdeSystem;
use meshless::core::kernel::Kernel;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::cores::ul::{PairScheme, UlSph, UlState};
use meshless::methods::gray_monaghan::GrayMonaghan;
use meshless::methods::gray_monaghan::system::{artificial_stress, principal_stresses};
use meshless::methods::{Method, Runs};
use meshless::run::build_method;
use meshless::scene::Scene;
use std::path::Path;

/// The shipped Gray–Monaghan disk (276 particles, h/dx = 1.7, AV, artificial stress and
/// XSPH) with overrides.
fn disk(overrides: &[&str]) -> GrayMonaghan<D2> {
    build_method(&load("rotating-disk-gray-monaghan", overrides)).unwrap()
}

/// A 3D block of 6 × 5 × 4 particles under the UL method `name` with the `[method]`
/// lines `keys`.
pub fn block_3d<S: PairScheme<D3>>(name: &str, correction: &str, keys: &str) -> UlSph<D3, S>
where
    S::Spec: Runs,
{
    build_method(&block_3d_scene(name, correction, keys, &[])).unwrap()
}

/// The scene of [`block_3d`], with `overrides`.
fn block_3d_scene(name: &str, correction: &str, keys: &str, overrides: &[&str]) -> Scene {
    let text = format!(
        r#"
name = "block"
dimension = 3
spacing = 0.1
[material]
model = "hypoelastic"
density = 1000.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
[method]
name = "{name}"
h_over_dx = 1.3
correction = "{correction}"
dt = 1.0e-5
{keys}
[[body]]
name = "b"
geometry = {{ shape = "box", min = [0.0, 0.0, 0.0], max = [0.5, 0.4, 0.3] }}
[run]
end_time = 1.0e-4
"#
    );
    let overrides: Vec<String> = overrides.iter().map(|o| o.to_string()).collect();
    Scene::from_toml(&text, Path::new("block.toml"), &overrides).unwrap()
}

/// The 3D block under Gray–Monaghan with every stabilisation, with `overrides`.
fn gray_monaghan_3d_with(correction: &str, overrides: &[&str]) -> GrayMonaghan<D3> {
    let keys = "artificial_viscosity = { alpha = 1.0, beta = 1.0, eta = 0.1 }\n\
                artificial_stress = { epsilon = 0.3, n = 4.0 }\nxsph = 0.5";
    build_method(&block_3d_scene(
        "gray-monaghan-sph",
        correction,
        keys,
        overrides,
    ))
    .unwrap()
}

/// The 3D block under Gray–Monaghan with every stabilisation.
fn gray_monaghan_3d(correction: &str) -> GrayMonaghan<D3> {
    gray_monaghan_3d_with(correction, &[])
}

/// The rates of state y.
pub fn rates<D: Dim, S: PairScheme<D>>(m: &mut UlSph<D, S>, y: &UlState<D>) -> UlState<D> {
    let mut d = y.clone();
    m.rates(0.0, y, &mut d).unwrap();
    d
}

/// A vector with components scale × noise.
pub fn random_vector<D: Dim>(seed: &mut u64, scale: f64) -> D::V {
    D::from_slice(&(0..D::N).map(|_| scale * noise(seed)).collect::<Vec<_>>())
}

/// A symmetric traceless tensor with entries of size `scale`.
pub fn random_deviator<D: Dim>(seed: &mut u64, scale: f64) -> D::T {
    let t = random_tensor::<D>(seed, scale);
    let sym = (t + D::transpose(t)) * 0.5;
    sym - D::identity() * (D::trace(sym) / D::N as f64)
}

/// A disordered state: |u| ~ 0.2 Δx, |v| ~ 10 m/s, ρ within 1 % of ρ0, |S| ~ 1e5 Pa
/// (tension and compression, so the artificial stress acts), F = I.
pub fn random_state<D: Dim, S: PairScheme<D>>(
    m: &UlSph<D, S>,
    dx: f64,
    seed: &mut u64,
) -> UlState<D> {
    let mut y = m.initial_state();
    for i in 0..y.u.len() {
        y.u[i] = random_vector::<D>(seed, 0.2 * dx);
        y.v[i] = random_vector::<D>(seed, 10.0);
        y.rho[i] *= 1.0 + 0.01 * noise(seed);
        y.s[i] = random_deviator::<D>(seed, 1e5);
    }
    y
}

// ---------------------------------------------------------------------------------------
// Neighbours

/// Brute-force lists: j ≠ i within `radius` of the positions x, of one body when `body`.
fn brute_force<D: Dim>(x: &[D::V], radius: f64, body: Option<&[u32]>) -> Vec<Vec<u32>> {
    (0..x.len())
        .map(|i| {
            (0..x.len() as u32)
                .filter(|&j| {
                    let j = j as usize;
                    j != i
                        && body.is_none_or(|b| b[i] == b[j])
                        && D::norm2(x[i] - x[j]) <= radius * radius
                })
                .collect()
        })
        .collect()
}

#[test]
fn neighbours_rebuilt_from_moving_particles_equal_a_brute_force_search() {
    // Two rings of the coarse rings lattice, the right one moved into the left one and
    // every particle shuffled by up to 3Δx, far past the skin of the drift lists, so that
    // every rate evaluation rebuilds them: the lists are those of an O(n²) search on the
    // current positions within the reach widened by the skin (`neighbour::SKIN`), per
    // body with contact (the rings never share a pair) and across bodies without it.
    let rings = |contact: &str| {
        let case = load(
            "rings-impact",
            &[
                "spacing=4.2105263157894736e-3",
                "method.dt=4.0e-7",
                "method.name=gray-monaghan-sph",
                "material.model=hypoelastic",
                "method.correction=none",
                contact,
            ],
        );
        let radius =
            Kernel::new(case.method.kernel, case.smoothing_length(), 2).support() * (1.0 + 1e-9);
        let m: GrayMonaghan<D2> = build_method(&case).unwrap();
        (m, radius)
    };
    let mut seed = 17;
    for (contact, masked) in [("contact.penalty=0.1", true), ("contact=", false)] {
        let (mut m, radius) = rings(contact);
        let body = m.body().to_vec();
        let dx = 0.08 / 19.0;
        for _ in 0..2 {
            let mut y = m.initial_state();
            for (u, &b) in y.u.iter_mut().zip(&body) {
                let shift = if b == 1 { -0.04 } else { 0.0 };
                *u = DVec2::new(shift, 0.0) + random_vector::<D2>(&mut seed, 3.0 * dx);
            }
            rates(&mut m, &y);
            let x: Vec<DVec2> = m
                .reference()
                .iter()
                .zip(&y.u)
                .map(|(&x0, &u)| x0 + u)
                .collect();
            let widened = radius * (1.0 + meshless::core::neighbour::SKIN);
            let expected = brute_force::<D2>(&x, widened, masked.then_some(body.as_slice()));
            let lists = m.neighbours();
            let mut across = 0;
            for (i, e) in expected.iter().enumerate() {
                assert_eq!(
                    lists.neighbours(i),
                    e.as_slice(),
                    "particle {i} ({contact})"
                );
                across += e.iter().filter(|&&j| body[j as usize] != body[i]).count();
            }
            // The overlap puts pairs across the bodies within reach: the masks must drop them.
            assert_eq!(
                across == 0,
                masked,
                "{across} pairs across bodies ({contact})"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Frame invariance (seed 000 §7 items 6 and 7)

#[test]
fn a_rigid_translation_gives_no_stress_rate_and_no_force() {
    // Item 6: translated positions and a uniform velocity give L = 0, ρ̇ = 0, Ṡ = 0, no
    // force and ẋ = v exactly (every sum is of v_j − v_i = 0, and a stress-free state
    // with v_ij · x_ij = 0 leaves the artificial stress and viscosity idle).
    for correction in ["none", "randles-libersky"] {
        let mut m = disk(&[&format!("method.correction={correction}")]);
        let mut y = m.initial_state();
        for i in 0..y.u.len() {
            y.u[i] = DVec2::new(0.3, -0.7);
            y.v[i] = DVec2::new(12.0, 5.0);
        }
        let d = rates(&mut m, &y);
        for i in 0..y.u.len() {
            assert_eq!(d.rho[i], 0.0, "{correction}: ρ̇ at {i}");
            assert_eq!(d.s[i], DMat2::ZERO, "{correction}: Ṡ at {i}");
            assert_eq!(d.f[i], DMat2::ZERO, "{correction}: Ḟ at {i}");
            assert_eq!(d.v[i], DVec2::ZERO, "{correction}: v̇ at {i}");
            assert_eq!(d.u[i], y.v[i], "{correction}: ẋ at {i}");
        }
    }
}

#[test]
fn a_rigid_rotation_is_exact_with_the_correction_and_not_without() {
    // Item 7: on a configuration rotated by 40° and spinning at ω = 50 rad/s, the
    // Randles–Libersky- and RKPM-corrected L (both first-order complete) is exactly the spin [[0, −ω], [ω, 0]] at every
    // particle, boundary included, so ρ̇ = 0 and Ṡ = 0 from a stress-free state. Round-off
    // of O(40) terms of size ω/Δx·Δx: bound 1e-10 ω. The uncorrected kernel (the paper's)
    // is not first-order complete: near the boundary it gives a spurious strain rate,
    // O(ω) (bound from below 1e-2 ω, so that the check above can tell them apart).
    let omega = 50.0;
    let q = DMat2::from_angle(40f64.to_radians());
    let spin = DMat2::from_cols_array(&[0.0, omega, -omega, 0.0]);
    let largest_strain_rate = |correction: &str| {
        let mut m = disk(&[&format!("method.correction={correction}")]);
        let mut y = m.initial_state();
        for i in 0..y.u.len() {
            let x = q * m.reference()[i];
            y.u[i] = x - m.reference()[i];
            y.v[i] = spin * x;
        }
        let d = rates(&mut m, &y);
        let mut worst: f64 = 0.0;
        for i in 0..y.u.len() {
            // F = I in the state, so Ḟ = L F is L itself.
            let l = d.f[i];
            let sym = (l + l.transpose()) * 0.5;
            worst = worst.max(sym.abs().to_cols_array().into_iter().fold(0.0, f64::max));
            if correction != "none" {
                let err = (l - spin)
                    .abs()
                    .to_cols_array()
                    .into_iter()
                    .fold(0.0, f64::max);
                assert!(err < 1e-10 * omega, "L at {i} off the spin by {err:e}");
                assert!(d.rho[i].abs() < 1e-10 * omega, "ρ̇ at {i}: {}", d.rho[i]);
                let s_dot = d.s[i].abs().to_cols_array().into_iter().fold(0.0, f64::max);
                // Ṡ = 2G dev(sym L): 2G × 1e-10 ω.
                assert!(s_dot < 2.0 * 3.6e6 * 1e-10 * omega, "Ṡ at {i}: {s_dot:e}");
            }
        }
        worst
    };
    let corrected = largest_strain_rate("randles-libersky");
    let reproducing = largest_strain_rate("rkpm");
    let plain = largest_strain_rate("none");
    eprintln!(
        "largest |sym L| of a rigid rotation: {corrected:e} Randles–Libersky, \
         {reproducing:e} RKPM, {plain:e} plain"
    );
    assert!(plain > 1e-2 * omega, "plain kernel: |sym L| = {plain:e}");
}

// ---------------------------------------------------------------------------------------
// The Jaumann rate of an affine velocity field

/// Ṡ = 2G (ε̇ − ⅓ tr ε̇ I) − S ω + ω S with ε̇ = sym L, ω = skew L (seed 000 eqs 89–92),
/// written out from the paper for the test.
fn jaumann<D: Dim>(g: f64, s: D::T, l: D::T) -> D::T {
    let eps = (l + D::transpose(l)) * 0.5;
    let w = (l - D::transpose(l)) * 0.5;
    (eps - D::identity() * (D::trace(eps) / 3.0)) * (2.0 * g) - s * w + w * s
}

/// Under v = L0 x + b with a uniform pre-stress S0, density ρ1 and deformation gradient F1,
/// the corrected L is L0 at every particle and the rates are the analytic ρ̇ = −ρ1 tr L0
/// and Ṡ = `rate`(S0, L0).
fn check_affine<D: Dim>(
    mut m: GrayMonaghan<D>,
    g: f64,
    seed: &mut u64,
    f1: D::T,
    rate: impl Fn(D::T, D::T) -> D::T,
) {
    let l0 = random_tensor::<D>(seed, 30.0);
    let b = random_vector::<D>(seed, 5.0);
    let s0 = random_deviator::<D>(seed, 2e4);
    let rho1 = 1.003 * m.initial_state().rho[0];
    let mut y = m.initial_state();
    for i in 0..y.u.len() {
        y.v[i] = l0 * m.reference()[i] + b;
        y.s[i] = s0;
        y.rho[i] = rho1;
        y.f[i] = f1;
    }
    let d = rates(&mut m, &y);
    let s_dot = rate(s0, l0);
    // Round-off of O(40) terms of size |L0|: 1e-11 relative to |L0| (measured 1e-13).
    let scale = D::ddot(l0, l0).sqrt();
    for i in 0..y.u.len() {
        let dl = d.f[i] - l0 * f1;
        assert!(D::ddot(dl, dl).sqrt() < 1e-11 * scale, "Ḟ at {i}");
        let drho = d.rho[i] + rho1 * D::trace(l0);
        assert!(drho.abs() < 1e-11 * rho1 * scale, "ρ̇ at {i}: {drho:e}");
        let ds = d.s[i] - s_dot;
        assert!(
            D::ddot(ds, ds).sqrt() < 1e-11 * 2.0 * g * scale,
            "Ṡ at {i}: off by {:e}",
            D::ddot(ds, ds).sqrt()
        );
    }
}

#[test]
fn an_affine_velocity_gives_the_analytic_jaumann_rate() {
    let mut seed = 3;
    // The disk: E = 1e7, ν = 0.4 ⇒ G = E/(2(1 + ν)); the 3D block: E = 1e6, ν = 0.3. Both
    // first-order corrections on the current positions reproduce linear fields (RKPM is
    // §6.1's W̊).
    let (g2, g3) = (1e7 / 2.8, 1e6 / 2.6);
    for correction in ["randles-libersky", "rkpm"] {
        let disk = disk(&[&format!("method.correction={correction}")]);
        check_affine::<D2>(disk, g2, &mut seed, DMat2::IDENTITY, |s, l| {
            jaumann::<D2>(g2, s, l)
        });
        let block = gray_monaghan_3d(correction);
        check_affine::<D3>(block, g3, &mut seed, DMat3::IDENTITY, |s, l| {
            jaumann::<D3>(g3, s, l)
        });
    }
}

#[test]
fn an_affine_velocity_gives_the_green_naghdi_and_truesdell_rates() {
    // Written out for the test: Green–Naghdi is the Jaumann form with W replaced by the
    // spin θ̇ of R's angle θ = atan2(F_yx − F_xy, F_xx + F_yy) in 2D (Ḟ = L F), and
    // Truesdell Ṡ = 2G dev D + L S + S Lᵀ − tr(D) S. F1 stretches by 30 % and turns.
    let mut seed = 5;
    let g = 1e7 / 2.8;
    let f1 = DMat2::from_angle(0.4) * DMat2::from_cols_array(&[1.3, 0.1, 0.1, 0.8]);
    let disk = disk(&[
        "method.correction=randles-libersky",
        "material.objective_rate=\"green-naghdi\"",
    ]);
    check_affine::<D2>(disk, g, &mut seed, f1, |s, l| {
        let f_dot = l * f1;
        let (a, b) = (f1.x_axis.x + f1.y_axis.y, f1.x_axis.y - f1.y_axis.x);
        let (a_dot, b_dot) = (
            f_dot.x_axis.x + f_dot.y_axis.y,
            f_dot.x_axis.y - f_dot.y_axis.x,
        );
        let spin = (a * b_dot - b * a_dot) / (a * a + b * b);
        let w = (l - l.transpose()) * 0.5;
        let omega = DMat2::from_cols_array(&[0.0, spin, -spin, 0.0]);
        jaumann::<D2>(g, s, l) + s * w - w * s - s * omega + omega * s
    });
    let truesdell = |g: f64| {
        move |s: DMat3, l: DMat3| {
            let d = (l + l.transpose()) * 0.5;
            let dev = d - DMat3::IDENTITY * (D3::trace(d) / 3.0);
            dev * (2.0 * g) + l * s + s * l.transpose() - s * D3::trace(d)
        }
    };
    let block = gray_monaghan_3d_with(
        "randles-libersky",
        &["material.objective_rate=\"truesdell\""],
    );
    let g = 1e6 / 2.6;
    let f1 = DMat3::from_cols_array(&[1.2, 0.1, 0.0, -0.2, 0.9, 0.1, 0.0, 0.3, 1.1]);
    check_affine::<D3>(block, g, &mut seed, f1, truesdell(g));
}

// ---------------------------------------------------------------------------------------
// Conservation (seed 000 §7 item 12)

/// |Σ_i m_i r_i| against Σ_i m_i |r_i|.
pub fn net<D: Dim>(mass: &[f64], r: &[D::V]) -> (f64, f64) {
    let total = mass.iter().zip(r).fold(D::zero(), |s, (&m, &r)| s + r * m);
    let size: f64 = mass
        .iter()
        .zip(r)
        .map(|(&m, &r)| m * D::norm2(r).sqrt())
        .sum();
    (D::norm2(total).sqrt(), size)
}

/// Σ m v̇ = 0 and Σ m (ẋ − v) = 0 for a disordered state, to round-off.
fn check_momentum<D: Dim>(mut m: GrayMonaghan<D>, dx: f64, seed: &mut u64) {
    let y = random_state(&m, dx, seed);
    let d = rates(&mut m, &y);
    // The pair terms (stress, artificial stress, viscosity) are antisymmetric in (i, j)
    // and cancel pairwise; the sum of ~1e4 terms in f64 leaves 1e-13 of their size.
    let (total, size) = net::<D>(m.mass(), &d.v);
    eprintln!("{}D: |Σ m v̇| = {total:e} of Σ m |v̇| = {size:e}", D::N);
    assert!(total < 1e-12 * size, "Σ m v̇ = {total:e} of {size:e}");
    // XSPH with m_j/ρ̄_ij changes ẋ by antisymmetric pair terms too.
    let xsph: Vec<D::V> = d.u.iter().zip(&y.v).map(|(&x_dot, &v)| x_dot - v).collect();
    let (total, size) = net::<D>(m.mass(), &xsph);
    assert!(
        size > 0.0 && total < 1e-12 * size,
        "Σ m (ẋ − v) = {total:e} of {size:e}"
    );
}

#[test]
fn the_pair_forces_conserve_linear_momentum() {
    // Uncorrected (the paper's) and with the corrected velocity gradient: the momentum
    // equation uses the antisymmetric ∇W_ij in both.
    let mut seed = 11;
    let dx = 2.0 / 19.0;
    for correction in ["none", "randles-libersky"] {
        check_momentum::<D2>(
            disk(&[&format!("method.correction={correction}")]),
            dx,
            &mut seed,
        );
    }
    check_momentum::<D3>(gray_monaghan_3d("none"), 0.1, &mut seed);
    // An adaptive h: each pair's kernel at h_ij = ½(h_i + h_j) keeps ∇W_ij antisymmetric
    // (and the prime space's lists are symmetric).
    for smoothing in ["density", "continuity", "prime-space"] {
        let key = format!("method.smoothing_length={smoothing}");
        check_momentum::<D2>(disk(&[&key]), dx, &mut seed);
    }
}

// ---------------------------------------------------------------------------------------
// Artificial stress and viscosity (seed 000 §7 items 22 and 23)

fn diag2(a: f64, b: f64) -> DMat2 {
    DMat2::from_diagonal(DVec2::new(a, b))
}

#[test]
fn the_artificial_stress_acts_on_tensile_principal_stresses_only() {
    let (eps, rho) = (0.3, 2.0);
    let close = |a: DMat2, b: DMat2| {
        (a - b)
            .abs()
            .to_cols_array()
            .into_iter()
            .fold(0.0, f64::max)
    };
    // σ = diag(σ1, σ2): R = diag(−ε σ1⁺/ρ², −ε σ2⁺/ρ²), exactly.
    assert_eq!(
        artificial_stress::<D2>(diag2(4.0, -3.0), rho, eps),
        diag2(-0.3, 0.0)
    );
    assert_eq!(
        artificial_stress::<D2>(diag2(-4.0, 8.0), rho, eps),
        diag2(0.0, -0.6)
    );
    assert_eq!(
        artificial_stress::<D2>(diag2(-4.0, -3.0), rho, eps),
        DMat2::ZERO
    );
    // Isotropic tension (d = 0: θ = 0).
    assert_eq!(
        artificial_stress::<D2>(diag2(4.0, 4.0), rho, eps),
        diag2(-0.3, -0.3)
    );
    // Rotated principal axes: R = Q R(diag) Qᵀ, and the rotation (c, s) diagonalises σ
    // (σ̄_xy = 0); round-off of the closed form: 1e-14 of |σ|.
    for degrees in [0.0, 10.0, 45.0, 90.0, 100.0, 135.0, 170.0, -60.0] {
        let q = DMat2::from_angle(f64::to_radians(degrees));
        for (a, b) in [(4.0, -3.0), (-4.0, 8.0), (5.0, 1.0), (-1.0, -2.0)] {
            let sigma = q * diag2(a, b) * q.transpose();
            let expected = q * artificial_stress::<D2>(diag2(a, b), rho, eps) * q.transpose();
            let got = artificial_stress::<D2>(sigma, rho, eps);
            assert!(
                close(got, expected) < 1e-14 * 8.0,
                "{degrees}° ({a}, {b}): {got}"
            );
            let (values, n) = principal_stresses::<D2>(sigma);
            assert!(
                (n[0].dot(sigma * n[1])).abs() < 1e-14 * 8.0,
                "σ̄_xy at {degrees}°"
            );
            let mut sorted = [values[0], values[1]];
            sorted.sort_by(f64::total_cmp);
            let mut exact = [a, b];
            exact.sort_by(f64::total_cmp);
            assert!((sorted[0] - exact[0]).abs() + (sorted[1] - exact[1]).abs() < 1e-13);
        }
    }
    // 3D (Jacobi directions): a rotated diag(6, −2, 3) gives Q diag(−ε 6/ρ², 0, −ε 3/ρ²) Qᵀ.
    let q = glam::DMat3::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0);
    let sigma = q * glam::DMat3::from_diagonal(glam::DVec3::new(6.0, -2.0, 3.0)) * q.transpose();
    let expected =
        q * glam::DMat3::from_diagonal(glam::DVec3::new(-0.45, 0.0, -0.225)) * q.transpose();
    let got = artificial_stress::<D3>(sigma, rho, eps);
    let err = (got - expected)
        .abs()
        .to_cols_array()
        .into_iter()
        .fold(0.0, f64::max);
    assert!(err < 1e-13, "3D: off by {err:e}");
}

#[test]
fn the_artificial_viscosity_acts_only_on_approaching_pairs() {
    // Item 23: under a uniform expansion v = k x every pair separates (v_ij · x_ij =
    // k r² > 0), so the rates with and without viscosity are identical; under a uniform
    // compression they differ.
    let off = &["method.artificial_viscosity="];
    for (k, same) in [(40.0, true), (-40.0, false)] {
        let mut with = disk(&[]);
        let mut without = disk(off);
        let mut y = with.initial_state();
        for i in 0..y.v.len() {
            y.v[i] = with.reference()[i] * k;
        }
        let (a, b) = (rates(&mut with, &y), rates(&mut without, &y));
        assert_eq!(a.v == b.v, same, "k = {k}");
    }
}

// ---------------------------------------------------------------------------------------
// Validation

fn refused(overrides: &[&str]) -> (String, String) {
    let mut set = vec!["method.name=gray-monaghan-sph"];
    set.extend_from_slice(overrides);
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    match Scene::load(
        &crate::common::case_file("rotating-disk-gray-monaghan"),
        &set,
    ) {
        Err(CaseError::Invalid { key, message, .. }) => (key, message),
        other => panic!("{overrides:?}: {:?}", other.map(|c| c.name.clone())),
    }
}

#[test]
fn validation_names_the_model_the_correction_and_the_integrator() {
    let (key, message) = refused(&["material.model=neo-hookean"]);
    assert_eq!(key, "material.model");
    assert!(message.contains("hypoelastic"), "{message}");
    let (key, message) = refused(&["method.correction=cgck"]);
    assert_eq!(key, "method.correction");
    assert!(
        message.contains("randles-libersky")
            && message.contains("rkpm")
            && message.contains("cgck"),
        "{message}"
    );
    let (key, message) = refused(&["method.integrator=leapfrog"]);
    assert_eq!(key, "method.integrator");
    assert!(message.contains("xsph"), "{message}");
    let (key, _) = refused(&["method.xsph=1.5"]);
    assert_eq!(key, "method.xsph");
    let (key, _) = refused(&["method.artificial_stress={ epsilon = -0.3, n = 4.0 }"]);
    assert_eq!(key, "method.artificial_stress.epsilon");
}
