//! The elastic-potential method (`tl-potential`, seed 000 §5.4) on the CPU: its force is
//! minus the gradient of the discrete energy, rigid motion is force- and stress-free, it
//! conserves linear momentum with corrected kernels (checklist 13) and angular momentum,
//! the reference code's force is the consistent one over V, and an affine stretch gives the
//! analytic stress with no interior force.

use crate::common::{block_case, block_text, largest_v, random_vector, shipped};
use glam::{DMat2, DMat3, DVec2, DVec3};
use meshless::core::integrate::OdeSystem;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::Method;
use meshless::methods::potential::Potential;
use meshless::methods::tlsph::TlState;
use meshless::physics::material::Material;
use meshless::physics::viscosity::ArtificialViscosity;
use meshless::run::{CpuEngine, Engine, build_method};
use meshless::scene::Scene;
use std::path::Path;

const AV: &str = "artificial_viscosity = { alpha = 1.0, beta = 1.0, eta = 0.1 }";

fn case(max: &[f64], keys: &str) -> Scene {
    block_case(max, "saint-venant-kirchhoff", "tl-potential", keys)
}

fn rates<D: Dim>(m: &mut Potential<D>, y: &TlState<D>) -> Vec<D::V> {
    let mut d = y.clone();
    m.rates(0.0, y, &mut d).unwrap();
    d.v
}

/// A state with displacements of `u_scale` and velocities of `v_scale` noise.
fn random<D: Dim>(m: &Potential<D>, seed: u64, u_scale: f64, v_scale: f64) -> TlState<D> {
    let mut seed = seed;
    let mut y = m.initial_state();
    for (u, v) in y.u.iter_mut().zip(y.v.iter_mut()) {
        *u = random_vector::<D>(&mut seed, u_scale);
        *v = random_vector::<D>(&mut seed, v_scale);
    }
    y
}

#[test]
fn the_force_is_minus_the_gradient_of_the_discrete_energy() {
    // m_k a_k = −∂Π/∂u_k with Π = Σ_i w_i ψ(F_i) (w_i = V_i consistent, 1 reference code),
    // by central differences with δ = 1e-7 m on strains of ~10 %: truncation O(δ²) and
    // cancellation ε·Π/δ ~ 1e-7 N against forces of ~1e3 N, so 1e-6 relative to the
    // largest force. A missing or extra volume factor fails by a factor 100 (V = 0.01).
    for force in ["consistent", "reference-code"] {
        let mut m: Potential<D2> =
            build_method(&case(&[1.0, 0.6], &format!("force = \"{force}\""))).unwrap();
        let y = random(&m, 7, 0.01, 0.0);
        let a = rates(&mut m, &y);
        let f: Vec<DVec2> = a.iter().zip(m.mass()).map(|(a, m)| *a * *m).collect();
        let scale = largest_v::<D2>(f.iter().copied());
        let delta = 1e-7;
        let n = m.reference().len();
        for k in [0, 5, n / 2, n - 1] {
            for (c, force_kc) in f[k].to_array().into_iter().enumerate() {
                let energy = |s: f64| {
                    let mut z = y.clone();
                    z.u[k][c] += s * delta;
                    m.strain_energy(&z).value()
                };
                let fd = -(energy(1.0) - energy(-1.0)) / (2.0 * delta);
                assert!(
                    (fd - force_kc).abs() < 1e-6 * scale,
                    "{force}: particle {k} component {c}: −∂Π/∂u = {fd}, m a = {force_kc}"
                );
            }
        }
    }
}

#[test]
fn rigid_motion_is_stress_and_force_free() {
    // Checklist 6–7: x = Q X + b with a rigid velocity ω × x + c. The corrected F equals Q
    // to ~1e-13 (sums of O(30) terms of size 1/Δx), so |a| ~ E·1e-13/(ρ0 Δx) ~ 1e-9 m/s²,
    // and the viscosity sees v_ij·x_ij = 0. A strain of 1e-6 would give |a| ~ 10 m/s².
    for force in ["consistent", "reference-code"] {
        let keys = format!("force = \"{force}\"\n{AV}");
        let mut m: Potential<D2> = build_method(&case(&[1.0, 0.6], &keys)).unwrap();
        let q = DMat2::from_angle(0.9);
        let mut y = m.initial_state();
        for ((u, v), &x) in y.u.iter_mut().zip(y.v.iter_mut()).zip(m.reference()) {
            *u = q * x - x + DVec2::new(3.0, -1.0);
            let xc = q * x + DVec2::new(3.0, -1.0);
            *v = DVec2::new(-20.0 * xc.y, 20.0 * xc.x) + DVec2::new(5.0, 2.0);
        }
        let a = largest_v::<D2>(rates(&mut m, &y));
        let bound = if force == "consistent" { 1e-8 } else { 1e-6 };
        assert!(a < bound, "{force}: max |a| = {a:e}");
        let sigma = m
            .cauchy_stress(&y)
            .iter()
            .flat_map(|s| s.iter().flatten().copied())
            .fold(0.0f64, |a, b| a.max(b.abs()));
        assert!(sigma < 1e-7, "{force}: max |σ| = {sigma:e} Pa");
    }
    // 3D: the same with a general rotation; the bound is the 2D one (same Δx, E, ρ0).
    let mut m: Potential<D3> = build_method(&case(&[0.5, 0.4, 0.3], AV)).unwrap();
    let q = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 2.0).normalize(), 0.7);
    let mut y = m.initial_state();
    for ((u, v), &x) in y.u.iter_mut().zip(y.v.iter_mut()).zip(m.reference()) {
        *u = q * x - x + DVec3::new(1.0, 2.0, 3.0);
        *v = DVec3::new(1.0, -2.0, 0.5).cross(q * x) + DVec3::new(0.0, 1.0, 0.0);
    }
    let a = largest_v::<D3>(rates(&mut m, &y));
    assert!(a < 1e-8, "3D: max |a| = {a:e}");
}

/// |Σ m a| and Σ |m a| of accelerations a.
fn momentum_balance<D: Dim>(mass: &[f64], a: &[D::V]) -> (f64, f64) {
    let mut total = D::zero();
    let mut size = 0.0;
    for (&m, &a) in mass.iter().zip(a) {
        total += a * m;
        size += m * D::norm2(a).sqrt();
    }
    (D::norm2(total).sqrt(), size)
}

#[test]
fn linear_momentum_is_conserved_with_corrected_kernels() {
    // Checklist 13: each pair's two terms enter rows i and j with opposite signs, so
    // Σ m a = 0 although ∇0W̃_ji ≠ −∇0W̃_ij (Randles–Libersky). The viscosity's direction
    // ½(F_i⁻ᵀ∇0W̃_ij − F_j⁻ᵀ∇0W̃_ji) is antisymmetric too. Round-off of sums of ~1e3
    // terms: 1e-12 of Σ|m a|.
    for force in ["consistent", "reference-code"] {
        for av in ["", AV] {
            let keys = format!("force = \"{force}\"\n{av}");
            let mut m: Potential<D2> = build_method(&case(&[1.0, 0.6], &keys)).unwrap();
            let y = random(&m, 11, 0.01, 1.0);
            let a = rates(&mut m, &y);
            let (net, size) = momentum_balance::<D2>(m.mass(), &a);
            assert!(
                net < 1e-12 * size,
                "{force} {av}: |Σ m a| = {net:e} of {size:e}"
            );
        }
    }
    let mut m: Potential<D3> = build_method(&case(&[0.5, 0.4, 0.3], AV)).unwrap();
    let y = random(&m, 3, 0.01, 1.0);
    let a = rates(&mut m, &y);
    let (net, size) = momentum_balance::<D3>(m.mass(), &a);
    assert!(net < 1e-12 * size, "3D: |Σ m a| = {net:e} of {size:e}");
}

#[test]
fn angular_momentum_is_conserved_with_first_order_corrections() {
    // With Σ_j V_j X_ji ⊗ ∇0W̃_ij = I (Randles–Libersky), F_i = Σ_j V_j x_ji ⊗ ∇0W̃_ij
    // turns with the body, so Π is invariant under rotations of x and its gradient exerts
    // no torque: Σ x × m a = 0 (without viscosity, whose pair direction is not x_ij).
    // Round-off: 1e-12 of Σ |x||m a|. With the uncorrected kernel F_i keeps a term
    // I − Σ_j V_j X_ji ⊗ ∇0W_ij that does not turn, and the torque is not zero.
    let torque = |correction: &str| {
        let keys = format!("correction = \"{correction}\"");
        let mut m: Potential<D2> = build_method(&case(&[1.0, 0.6], &keys)).unwrap();
        let y = random(&m, 5, 0.01, 0.0);
        let a = rates(&mut m, &y);
        let (mut net, mut size) = (0.0, 0.0);
        for (i, a) in a.iter().enumerate() {
            let x = m.reference()[i] + y.u[i];
            net += m.mass()[i] * x.perp_dot(*a);
            size += m.mass()[i] * x.length() * a.length();
        }
        net.abs() / size
    };
    let corrected = torque("randles-libersky");
    assert!(
        corrected < 1e-12,
        "randles-libersky: relative torque {corrected:e}"
    );
    let plain = torque("none");
    assert!(plain > 1e-6, "none: relative torque {plain:e}");
}

#[test]
fn the_reference_code_force_is_the_consistent_one_over_the_volume() {
    // Seed 000 §3.4: on a uniform lattice (V = Δx² = 0.01) each term lacks one factor V,
    // so a_code = a_consistent/V; both sum the same terms in the same order (1e-12).
    let run = |force: &str| {
        let mut m: Potential<D2> =
            build_method(&case(&[1.0, 0.6], &format!("force = \"{force}\""))).unwrap();
        let y = random(&m, 9, 0.01, 0.0);
        rates(&mut m, &y)
    };
    let (consistent, code) = (run("consistent"), run("reference-code"));
    let scale = largest_v::<D2>(code.iter().copied());
    let err = largest_v::<D2>(consistent.iter().zip(&code).map(|(a, b)| *a / 0.01 - *b));
    assert!(
        err < 1e-12 * scale,
        "max |a/V − a_code| = {err:e} of {scale:e}"
    );
}

#[test]
fn an_affine_stretch_gives_the_analytic_stress_and_no_interior_force() {
    // u = (A − I) X: the corrected F = A exactly at every particle, so σ = F S Fᵀ/J with
    // the SVK S = λ tr E I + 2μ E, E = ½(AᵀA − I), in closed form (1e-9 of |σ| ~ 1e5 Pa).
    // A particle whose neighbours all have complete lattice neighbourhoods (two supports
    // from the surface) has ∇0W̃_ji = −∇0W̃_ij and Σ_j ∇0W̃_ij = 0, so no net force:
    // |a| < 1e-9 of the surface particles' accelerations.
    let mut m: Potential<D2> = build_method(&case(&[1.6, 1.6], "")).unwrap();
    let a_mat = DMat2::from_cols_array(&[1.1, 0.02, 0.0, 0.95]);
    let mut y = m.initial_state();
    for (u, &x) in y.u.iter_mut().zip(m.reference()) {
        *u = a_mat * x - x;
    }
    let (e_mod, nu) = (1.0e6, 0.3);
    let (mu, lambda) = (
        e_mod / (2.0 * (1.0 + nu)),
        e_mod * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
    );
    let e = (a_mat.transpose() * a_mat - DMat2::IDENTITY) * 0.5;
    let s = DMat2::IDENTITY * (lambda * (e.x_axis.x + e.y_axis.y)) + e * (2.0 * mu);
    let sigma = a_mat * s * a_mat.transpose() * (1.0 / a_mat.determinant());
    for (i, got) in m.cauchy_stress(&y).iter().enumerate() {
        for (k, l) in [(0, 0), (0, 1), (1, 1)] {
            let want = sigma.col(l)[k];
            assert!(
                (got[k][l] - want).abs() < 1e-9 * 1e5,
                "particle {i}: σ_{k}{l} = {} vs {want}",
                got[k][l]
            );
        }
    }
    let a = rates(&mut m, &y);
    let scale = largest_v::<D2>(a.iter().copied());
    let reach = 2.0 * 2.0 * 1.3 * 0.1 + 1e-9;
    let mut interior = 0;
    for (x, a) in m.reference().iter().zip(&a) {
        if x.min_element() >= reach && x.max_element() <= 1.6 - reach {
            interior += 1;
            assert!(a.length() < 1e-9 * scale, "X = {x}: |a| = {:e}", a.length());
        }
    }
    assert!(interior >= 9, "{interior} interior particles");
}

#[test]
fn the_method_needs_a_state_model() {
    // The hypoelastic model has no P(F): refused by name at validation.
    let text = block_text(&[1.0, 0.6], "hypoelastic", "tl-potential", "");
    let e = Scene::from_toml(&text, Path::new("block.toml"), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("material.model") && e.contains("`tl-potential`"),
        "{e}"
    );
}

/// The rates and the strain energy of a random state (|u| ~ 0.1 Δx, |v| ~ 1 m/s) on the
/// GPU against the CPU, for both forces with viscosity.
#[cfg(feature = "gpu")]
fn compare_on_the_gpu<D: meshless::gpu::layout::GpuDim>(max: &[f64]) {
    use meshless::methods::tlsph::GpuTlsph;
    for force in ["consistent", "reference-code"] {
        let c = case(max, &format!("force = \"{force}\"\n{AV}"));
        let mut cpu: Potential<D> = build_method(&c).unwrap();
        let y = random(&cpu, 11, 0.01, 1.0);
        let a = rates(&mut cpu, &y);
        let mut g =
            GpuTlsph::<D>::new(&c, crate::common::tl_scheme(&c), crate::common::gpu()).unwrap();
        let (d, _, _) = g.rates(&y);
        // Each acceleration sums 20–80 pair terms P ∇0W̃ V V of the random state, which do
        // not cancel; P comes from H = F − I summed in f32 (|H| ~ 0.3, 6e-8 relative per
        // term): ~1e-6 of the largest acceleration. Bound 1e-4 of it.
        let scale = largest_v::<D>(a.iter().copied());
        let err = largest_v::<D>(a.iter().zip(&d.v).map(|(&x, &y)| x - y));
        assert!(
            err < 1e-4 * scale,
            "{force} {}D: |Δa| = {err:e} of {scale:e}",
            D::N
        );
        // Σ w_i ψ_i summed in f32 per workgroup from the same F: 1e-4 relative.
        let w_cpu = cpu.strain_energy(&y).value();
        let w_gpu = g.invariants().strain;
        assert!(
            (w_gpu - w_cpu).abs() < 1e-4 * w_cpu,
            "{force} {}D: strain energy {w_gpu} on the GPU, {w_cpu} on the CPU",
            D::N
        );
    }
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_force_and_energy_match_the_cpu_in_2d_and_3d() {
    compare_on_the_gpu::<D2>(&[1.0, 0.6]);
    compare_on_the_gpu::<D3>(&[0.5, 0.4, 0.3]);
}

#[test]
fn a_free_vibration_conserves_energy_and_both_momenta() {
    // Checklist 13: with the consistent force and no viscosity, kinetic + Σ V ψ is
    // conserved up to RK4's error, and the run keeps Σ m v and (first-order correction)
    // Σ m x × v. A block with random velocities of 1 m/s, 200 steps at a Courant number of
    // 0.1 (c_p = 36.7 m/s, Δx = 0.1): RK4's energy error of the fastest lattice mode,
    // (ω Δt)⁶/72 per step with ω Δt ≈ 0.2, sums to ~2e-4 of that mode's share (measured:
    // 1.9e-6 of E0); bound 1e-4 of E0. Σ m v is linear in the state, which RK4 keeps to
    // round-off (1e-14 measured); Σ m x × v is quadratic, kept to RK4's truncation error
    // (8e-11 of Σ m |v| measured); bound 1e-9 of Σ m |v| for both.
    let case = case(&[1.0, 0.6], "");
    let mut e: CpuEngine<D2, Potential<D2>> = meshless::scene::cpu_engine(&case).unwrap();
    let mut seed = 31;
    for v in e.y.v.iter_mut() {
        *v = random_vector::<D2>(&mut seed, 1.0);
    }
    let start = e.invariants();
    let scale: f64 =
        e.y.v
            .iter()
            .zip(e.method.mass())
            .map(|(v, m)| v.length() * m)
            .sum();
    e.advance(0.0, 2.7e-4, 200).unwrap();
    let end = e.invariants();
    let drift = (end.total_energy() - start.total_energy()).abs() / start.total_energy();
    assert!(end.strain > 0.1 * start.kinetic, "strain {:e}", end.strain);
    assert!(drift < 1e-4, "energy drift {drift:e}");
    for k in 0..2 {
        let dp = (end.linear[k] - start.linear[k]).abs();
        assert!(dp < 1e-9 * scale, "Σ m v_{k} moved by {dp:e}");
    }
    let dh = (end.angular[2] - start.angular[2]).abs();
    assert!(dh < 1e-9 * scale, "Σ m x × v moved by {dh:e}");
}

#[test]
fn artificial_viscosity_acts_on_approaching_pairs_only() {
    // Checklist 23: Π_ij = 0 for v_ij·x_ij ≥ 0; for an approaching pair μ_ij < 0 and
    // Π_ij = (−α c̄ μ + β μ²)/ρ̄ > 0, here in closed form (round-off 1e-12 relative).
    let av = ArtificialViscosity {
        alpha: 1.0,
        beta: 2.0,
        eta: 0.1,
    };
    let (h, c, rho) = (0.13, 40.0, 1000.0);
    let x_ij = DVec2::new(0.1, 0.05);
    for v_ij in [DVec2::new(1.0, 0.0), DVec2::new(-0.05, 0.1), DVec2::ZERO] {
        assert_eq!(av.pi::<D2>(h, x_ij, v_ij, c, rho), 0.0, "v_ij = {v_ij}");
    }
    let v_ij = DVec2::new(-2.0, 0.5);
    let mu = h * v_ij.dot(x_ij) / (x_ij.length_squared() + 0.01 * h * h);
    let want = (-c * mu + 2.0 * mu * mu) / rho;
    let got = av.pi::<D2>(h, x_ij, v_ij, c, rho);
    assert!(
        want > 0.0 && (got - want).abs() < 1e-12 * want,
        "{got} vs {want}"
    );
}

#[test]
fn the_shipped_cases_have_the_seeds_plane_stress_constants() {
    // Checklist 20: the seed's state models are plane stress with E = 1e7 Pa, ν = 0.4,
    // i.e. in-plane G = 3.5714e6 Pa and λ* = Dν = 4.7619e6 Pa (D = E/(1 − ν²)); the shipped
    // cases' `plane = "stress"` must give them (λ* = 2λμ/(λ + 2μ) in the material, a
    // different expression: round-off only, 1e-9 relative).
    let (e, nu) = (1.0e7, 0.4);
    let g = e / (2.0 * (1.0 + nu));
    let lambda_star = e / (1.0 - nu * nu) * nu;
    for name in ["tensile-strip-potential", "rotating-disk-corotated"] {
        let m = Material::new(&shipped(name).material);
        assert!((m.mu - g).abs() < 1e-9 * g, "{name}: μ = {}", m.mu);
        assert!(
            (m.lambda - lambda_star).abs() < 1e-9 * lambda_star,
            "{name}: λ = {}",
            m.lambda
        );
    }
}
