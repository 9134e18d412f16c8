//! Seed 001 (Rabczuk, Belytschko & Xiao): "SPH (ni)" and "RLM (ni)" are TLSPH with
//! correction `none` and `randles-libersky`. Their rows of Table 1, written out here in
//! plain loops with the paper's cubic spline (eq 14) and the sign and V_I factor of spec
//! §7.4, against what TLSPH computes; the physical sign checks of spec §11 item 4; and the
//! §9.2 Gaussian rod against d'Alembert's solution.

use crate::common::{cpu_options, load, noise};
use glam::{DMat2, DVec2};
use meshless::core::integrate::OdeSystem;
use meshless::core::tensor::D2;
use meshless::methods::Method;
use meshless::methods::tlsph::Tlsph;
use meshless::output::series::read_column;
use meshless::reference::Reference;
use meshless::run::{build_method, run};
use meshless::scene::Scene;
use std::f64::consts::PI;
use std::path::Path;

const RHO0: f64 = 1000.0;
const E: f64 = 1.0e6;
const NU: f64 = 0.3;
const H_OVER_DX: f64 = 1.3;

/// A 1.0 × 0.6 m block on a vertex lattice of Δx = 0.1 m (11 × 7 particles) with
/// tributary volumes, Saint Venant–Kirchhoff in plane strain, the cubic spline at h/Δx =
/// 1.3 and the given correction, and Table 1's force (eq 134, `force = "reveles"`: B_I
/// of particle I on both stress terms); no boundary condition.
fn block(correction: &str) -> Scene {
    let text = format!(
        r#"
name = "table1"
dimension = 2
spacing = 0.1
[material]
model = "saint-venant-kirchhoff"
density = {RHO0}
youngs_modulus = {E}
poisson_ratio = {NU}
[method]
name = "tlsph"
kernel = "cubic-spline"
h_over_dx = {H_OVER_DX}
correction = "{correction}"
force = "reveles"
dt = 1.0e-5
[[body]]
name = "b"
geometry = {{ shape = "box", min = [0.0, 0.0], max = [1.0, 0.6], volumes = "tributary" }}
[run]
end_time = 1.0e-4
"#
    );
    Scene::from_toml(&text, Path::new("table1.toml"), &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// The block's reference configuration with every particle moved by up to 0.2 Δx and its
/// volume (and mass) scaled by up to ±20 %, reproducibly.
fn perturbed(case: &Scene, seed: &mut u64) -> Reference<D2> {
    let mut r = Reference::<D2>::build(case).unwrap();
    let dx = case.spacing;
    for i in 0..r.len() {
        r.x0[i] += DVec2::new(noise(seed), noise(seed)) * (0.2 * dx);
        r.vol[i] *= 1.0 + 0.2 * noise(seed);
        r.mass[i] = RHO0 * r.vol[i];
    }
    r
}

/// dW/dr of the paper's cubic spline (eqs 14–15, 2D: C = 10/(7π), support 2h).
fn dw_dr(r: f64, h: f64) -> f64 {
    let c = 10.0 / (7.0 * PI) / (h * h * h);
    let z = r / h;
    if z < 1.0 {
        c * (-3.0 * z + 2.25 * z * z)
    } else if z < 2.0 {
        -0.75 * c * (2.0 - z).powi(2)
    } else {
        0.0
    }
}

/// ∇W_IJ = ∂W(|X_I − X_J|)/∂X_I (spec §7.4's convention).
fn grad_w(xi: DVec2, xj: DVec2, h: f64) -> DVec2 {
    let d = xi - xj;
    let r = d.length();
    d * (dw_dr(r, h) / r)
}

/// Saint Venant–Kirchhoff in plane strain (F_zz = 1): P = F S, S = λ tr E I + 2μ E, E =
/// ½(FᵀF − I).
fn svk(f: DMat2) -> DMat2 {
    let lambda = E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU));
    let mu = E / (2.0 * (1.0 + NU));
    let green = (f.transpose() * f - DMat2::IDENTITY) * 0.5;
    let s = DMat2::IDENTITY * (lambda * (green.x_axis.x + green.y_axis.y)) + green * (2.0 * mu);
    f * s
}

/// How the force row of Table 1 uses the Randles–Libersky matrix.
#[derive(Clone, Copy, PartialEq)]
enum Form {
    /// SPH: F_I = I + Σ_J V_J (u_J − u_I) ⊗ ∇W_IJ; f_I = V_I Σ_J V_J (P_I + P_J)·∇W_IJ.
    Sph,
    /// RLM as Table 1 writes it: B_I (eq 34) on the gradient (eq 33) and on both stress
    /// terms of the force, f_I = V_I Σ_J V_J (P_I + P_J)·(B_Iᵀ ∇W_IJ).
    RlmTable1,
    /// The symmetric variant the paper does not use: f_I = V_I Σ_J V_J (P_I B_Iᵀ ∇W_IJ −
    /// P_J B_Jᵀ ∇W_JI), pairwise antisymmetric.
    RlmSymmetric,
}

/// F_I and f_I = m_I a_I of Table 1 on the points x0 with volumes vol and displacements u,
/// by plain loops over every pair within the support 2h.
fn table1(form: Form, x0: &[DVec2], vol: &[f64], u: &[DVec2], h: f64) -> (Vec<DMat2>, Vec<DVec2>) {
    let n = x0.len();
    let pairs = |i: usize| (0..n).filter(move |&j| j != i && (x0[i] - x0[j]).length() < 2.0 * h);
    let b: Vec<DMat2> = (0..n)
        .map(|i| match form {
            Form::Sph => DMat2::IDENTITY,
            _ => {
                let mut m = DMat2::ZERO;
                for j in pairs(i) {
                    m += outer(x0[j] - x0[i], grad_w(x0[i], x0[j], h)) * vol[j];
                }
                m.inverse() // eq 34
            }
        })
        .collect();
    let f: Vec<DMat2> = (0..n)
        .map(|i| {
            let mut g = DMat2::ZERO;
            for j in pairs(i) {
                g += outer(u[j] - u[i], grad_w(x0[i], x0[j], h)) * vol[j];
            }
            DMat2::IDENTITY + g * b[i] // eq 33 (b = I: eq 25)
        })
        .collect();
    let p: Vec<DMat2> = f.iter().map(|&f| svk(f)).collect();
    let force = (0..n)
        .map(|i| {
            let mut sum = DVec2::ZERO;
            for j in pairs(i) {
                let g_ij = grad_w(x0[i], x0[j], h);
                sum += match form {
                    Form::Sph | Form::RlmTable1 => (p[i] + p[j]) * (b[i].transpose() * g_ij),
                    Form::RlmSymmetric => {
                        p[i] * (b[i].transpose() * g_ij)
                            - p[j] * (b[j].transpose() * grad_w(x0[j], x0[i], h))
                    }
                } * vol[j];
            }
            sum * vol[i]
        })
        .collect();
    (f, force)
}

fn outer(a: DVec2, b: DVec2) -> DMat2 {
    DMat2::from_cols(a * b.x, a * b.y)
}

/// A smooth displacement with a rotation of 0.4 rad and strains of ~5 %, so that P is far
/// from symmetric and the index order of P·∇W matters (spec §7.3 d).
fn displacement(x: DVec2) -> DVec2 {
    let turn = DMat2::from_angle(0.4);
    turn * (x + DVec2::new(0.05 * (3.0 * x.y).sin(), 0.04 * x.x * x.x)) - x
}

/// TLSPH's F and m a on the perturbed block, and the plain loops' forms.
struct Compared {
    f: Vec<DMat2>,
    force: Vec<DVec2>,
    x0: Vec<DVec2>,
    vol: Vec<f64>,
    u: Vec<DVec2>,
    h: f64,
}

fn tlsph_on_perturbed_block(correction: &str) -> Compared {
    let case = block(correction);
    let reference = perturbed(&case, &mut 7);
    let (x0, vol, mass) = (
        reference.x0.clone(),
        reference.vol.clone(),
        reference.mass.clone(),
    );
    let mut m = Tlsph::<D2>::new(&case, crate::common::spec_of(&case), reference).unwrap();
    let mut y = m.initial_state();
    for (u, &x) in y.u.iter_mut().zip(&x0) {
        *u = displacement(x);
    }
    let mut d = y.clone();
    m.rates(0.0, &y, &mut d).unwrap();
    Compared {
        f: m.deformation_gradient(&y),
        force: d.v.iter().zip(&mass).map(|(&a, &m)| a * m).collect(),
        u: y.u,
        x0,
        vol,
        h: case.smoothing_length(),
    }
}

/// The largest |a_I − b_I| and the largest |b_I|.
fn largest_difference<T: Copy>(a: &[T], b: &[T], norm: impl Fn(T, T) -> (f64, f64)) -> (f64, f64) {
    a.iter()
        .zip(b)
        .map(|(&a, &b)| norm(a, b))
        .fold((0.0, 0.0), |(d, s), (x, y)| (d.max(x), s.max(y)))
}

fn mat_norm(a: DMat2, b: DMat2) -> (f64, f64) {
    let d = a - b;
    (
        (d.x_axis.length_squared() + d.y_axis.length_squared()).sqrt(),
        (b.x_axis.length_squared() + b.y_axis.length_squared()).sqrt(),
    )
}

fn vec_norm(a: DVec2, b: DVec2) -> (f64, f64) {
    ((a - b).length(), b.length())
}

#[test]
fn sph_is_table_1s_sph_row() {
    // F_I and m_I a_I of TLSPH without correction against Table 1's SPH row on a randomly
    // perturbed lattice (positions ±0.2 Δx, volumes ±20 %): the same sums in another
    // order, so they agree to round-off. Terms are O(1/Δx) (F) and O(E Δx) (forces) with
    // ~20 of them; 1e-11 relative to the largest leaves a factor 1e3 over round-off.
    let t = tlsph_on_perturbed_block("none");
    let (f, force) = table1(Form::Sph, &t.x0, &t.vol, &t.u, t.h);
    let (df, fmax) = largest_difference(&t.f, &f, mat_norm);
    assert!(
        df < 1e-11 * fmax,
        "max |F − F_table1| = {df:e} (|F| ≤ {fmax:e})"
    );
    let (da, amax) = largest_difference(&t.force, &force, vec_norm);
    assert!(
        da < 1e-11 * amax,
        "max |ma − f_table1| = {da:e} (|f| ≤ {amax:e})"
    );
    // The SPH pair terms are antisymmetric (∇W_JI = −∇W_IJ), so the forces sum to zero:
    // global linear momentum is kept (round-off of ~1,000 terms of size amax).
    let total: DVec2 = t.force.iter().sum();
    assert!(
        total.length() < 1e-12 * amax * t.x0.len() as f64,
        "Σ f = {total}"
    );
}

#[test]
fn randles_libersky_is_table_1s_rlm_row_with_b_i_on_both_terms() {
    // TLSPH's Randles–Libersky correction is Table 1's RLM row (B_I of eq 34 on eq 33 and
    // on both stress terms of the force): agreement to round-off, as for SPH. B_I is the
    // inverse of a 2×2 sum, which may lose a few digits at boundary particles: 1e-10.
    let t = tlsph_on_perturbed_block("randles-libersky");
    let (f, force) = table1(Form::RlmTable1, &t.x0, &t.vol, &t.u, t.h);
    let (df, fmax) = largest_difference(&t.f, &f, mat_norm);
    assert!(df < 1e-10 * fmax, "max |F − F_table1| = {df:e}");
    let (da, amax) = largest_difference(&t.force, &force, vec_norm);
    assert!(
        da < 1e-10 * amax,
        "max |ma − f_table1| = {da:e} (|f| ≤ {amax:e})"
    );

    // By design it is not the symmetric variant (B_I and B_J), which the paper does not
    // use: on this lattice the two differ by a fair fraction of the largest force (the
    // B_J of boundary particles are far from I), and only the symmetric one has pair
    // forces that cancel. Table 1's form does not keep linear momentum (spec §7.3 f): its
    // net force is far above round-off (1e-6 of Σ|f| would be 1e6 times round-off).
    let (_, symmetric) = table1(Form::RlmSymmetric, &t.x0, &t.vol, &t.u, t.h);
    let (ds, _) = largest_difference(&t.force, &symmetric, vec_norm);
    assert!(
        ds > 0.05 * amax,
        "RL forces within {ds:e} of the symmetric form"
    );
    let sum_abs: f64 = t.force.iter().map(|f| f.length()).sum();
    let net: DVec2 = t.force.iter().sum();
    assert!(
        net.length() > 1e-6 * sum_abs,
        "Σ f = {net} of Σ|f| = {sum_abs:e}"
    );
    let net_symmetric: DVec2 = symmetric.iter().sum();
    assert!(
        net_symmetric.length() < 1e-12 * sum_abs,
        "symmetric Σ f = {net_symmetric}"
    );
}

#[test]
fn undeformed_state_is_force_free_and_tension_pulls_the_free_ends_inward() {
    // Spec §11 item 4 on the regular 11 × 7 block, both forms.
    for correction in ["none", "randles-libersky"] {
        let mut m: Tlsph<D2> = build_method(&block(correction)).unwrap();
        let x0 = m.reference().to_vec();
        // u = 0: F = I exactly, P = 0, and every force is zero exactly.
        let y = m.initial_state();
        let mut d = y.clone();
        m.rates(0.0, &y, &mut d).unwrap();
        assert!(
            d.v.iter().all(|a| *a == DVec2::ZERO),
            "{correction}: u = 0 moves"
        );

        // A uniform stretch of 1e-3 along x: P_xx = (λ + 2μ)·1e-3 = 1.35e3 Pa (SVK, to
        // 1e-3). The particles on the ends x = 0 and x = 1, where the traction P·n is not
        // balanced, are pulled inward, towards the body. A free end's traction over its
        // half-spacing of mass gives the scale P/(ρ0 Δx) = 13.5 m/s², which the kernel
        // spreads over the 2h-wide end layer: every end particle (corners included) must
        // get at least 5 % of it. With the Randles–Libersky correction F is exact, so P
        // is uniform, and the columns with a support whole in x (2h from the ends) feel no
        // axial force, by the lattice's symmetry: round-off, 1e-9 of the scale. (SPH's F
        // is off within 2h of the ends, so there the neighbours' P differ up to 4h in.)
        let mut y = m.initial_state();
        for (u, &x) in y.u.iter_mut().zip(&x0) {
            *u = DVec2::new(1e-3 * x.x, 0.0);
        }
        m.rates(0.0, &y, &mut d).unwrap();
        let scale = (E * (1.0 - NU) / ((1.0 + NU) * (1.0 - 2.0 * NU))) * 1e-3 / (RHO0 * 0.1);
        let reach = 2.0 * H_OVER_DX * 0.1;
        for (i, &x) in x0.iter().enumerate() {
            let a = d.v[i].x;
            if x.x < 1e-9 {
                assert!(
                    a > 0.05 * scale,
                    "{correction}: left end at {x} has a_x = {a}"
                );
            } else if x.x > 1.0 - 1e-9 {
                assert!(
                    a < -0.05 * scale,
                    "{correction}: right end at {x} has a_x = {a}"
                );
            } else if correction == "randles-libersky" && x.x > reach && x.x < 1.0 - reach {
                assert!(a.abs() < 1e-9 * scale, "{correction}: a_x = {a} at {x}");
            }
        }
    }
}

/// The rod's L2 velocity errors (eq 75) at the returns t = L/c and 2L/c, read from the
/// `velocity_error` column of a run of the shipped `case` (Δx = 0.125 mm, 19,721
/// particles, 2,500 leapfrog steps) with the overrides `set`.
fn rod_errors(case: &str, set: &[&str]) -> [f64; 2] {
    let mut overrides = vec!["output.frame_interval="];
    overrides.extend(set);
    let case = load(case, &overrides);
    let dir = tempfile::tempdir().unwrap();
    run(&case, &cpu_options(dir.path(), false)).unwrap();
    let series = read_column(&dir.path().join("series.csv"), "velocity_error").unwrap();
    RETURNS.map(|t| {
        series
            .iter()
            .find(|(s, _)| (s - t).abs() < 1e-6 * t)
            .unwrap_or_else(|| panic!("no row at t = {t}"))
            .1
    })
}

/// The paper's output times, t = L/c and 2L/c [s].
const RETURNS: [f64; 2] = [1.1563e-5, 2.3126e-5];

/// Table 3's L2 velocity errors at the two returns: SPH (ni) and RLM (ni).
const TABLE_3: [(&str, &str, [f64; 2]); 2] = [
    ("SPH", "rod-gaussian", [0.05026, 0.04999]),
    ("RLM", "rod-gaussian-rlm", [0.01301, 0.01297]),
];

/// Where Table 3 does not come out (docs/methods/seed001.md, "The rod of §9.2, Gaussian
/// case", "What does not", with the time series that shows why).
const ROD_FINDING: &str = "docs/methods/seed001.md, \"The rod of §9.2, Gaussian case\"";

#[test]
fn rod_at_the_papers_resolution_against_table_3() {
    // Seed 001 §9.2 at the paper's Δx = 0.125 mm (about 30 s for both runs on 2 cores).
    let errors = TABLE_3.map(|(name, case, paper)| (name, rod_errors(case, &[]), paper));
    let [(_, sph, _), (_, rlm, _)] = errors;
    for k in 0..2 {
        // The paper's ordering: uncorrected SPH is the less accurate (3.9 times RLM's
        // error in Table 3; measured here 15 and 14 times).
        assert!(
            sph[k] > rlm[k],
            "return {}: SPH {} ≤ RLM {}",
            k + 1,
            sph[k],
            rlm[k]
        );
    }
    for (name, e, paper) in errors {
        // No worse than the paper at its resolution (measured 0.0055 / 0.017 for SPH and
        // 0.00036 / 0.0013 for RLM). A wrong boundary mass, wave speed or correction costs
        // far more: SPH at h/Δx = 1.2 is at 0.17 on the second return.
        for k in 0..2 {
            assert!(
                e[k] <= paper[k],
                "{name} return {}: {} > Table 3's {}",
                k + 1,
                e[k],
                paper[k]
            );
        }
    }
}

#[test]
#[ignore = "finding: docs/methods/seed001.md, \"The rod of §9.2, Gaussian case\": errors 9–36 times below Table 3"]
fn rod_errors_are_table_3s_within_one_and_a_half() {
    // Table 3's errors to 1.5 times either way at both returns. Measured: SPH 0.0055 /
    // 0.017, RLM 0.00036 / 0.0013, 9 and 36 times below Table 3 at the first return (the
    // paper's h/Δx, integrator, viscosity and amplitude are not given).
    for (name, case, paper) in TABLE_3 {
        let e = rod_errors(case, &[]);
        for k in 0..2 {
            let ratio = e[k] / paper[k];
            assert!(
                (1.0 / 1.5..=1.5).contains(&ratio),
                "{name} return {}: {} against Table 3's {} ({ROD_FINDING})",
                k + 1,
                e[k],
                paper[k]
            );
        }
    }
}

#[test]
#[ignore = "finding: docs/methods/seed001.md, \"The rod of §9.2, Gaussian case\": errors grow between the returns"]
fn rod_errors_stay_level_from_the_first_return_to_the_second() {
    // Table 3's errors stay level: 0.05026 → 0.04999 (SPH), 0.01301 → 0.01297 (RLM).
    // Bound: the second at most 1.5 times the first. Measured: growth by 3.2 (SPH) and
    // 3.6 (RLM), the phase error of the dispersive discrete wave accumulating.
    for (name, case, _) in TABLE_3 {
        let e = rod_errors(case, &[]);
        assert!(
            e[1] <= 1.5 * e[0],
            "{name}: {} → {} ({ROD_FINDING})",
            e[0],
            e[1]
        );
    }
}

/// The error of the SPH interpolant Σ_J V_J W(X_I − X_J) v_J (the particle itself
/// included) of the rod's initial velocity at its particles, with uniform volumes V = Δx²
/// and the case's cubic spline at `h_over_dx`: sqrt(Σ V |v^h − v|²)/sqrt(Σ V |v|²).
fn sph_interpolant_error(h_over_dx: f64) -> f64 {
    let h = format!("method.h_over_dx={h_over_dx}");
    let case = load(
        "rod-gaussian",
        &[h.as_str(), "body.0.geometry.volumes=uniform"],
    );
    let r = Reference::<D2>::build(&case).unwrap();
    let lists = meshless::core::neighbour::build::<D2>(&r.x0, r.kernel.support());
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..r.x0.len() {
        let smoothed =
            lists
                .neighbours(i)
                .iter()
                .fold(r.vol[i] * r.kernel.w(0.0) * r.v0[i], |s, &j| {
                    let j = j as usize;
                    s + r.v0[j] * (r.vol[j] * r.kernel.w((r.x0[j] - r.x0[i]).length()))
                });
        num += r.vol[i] * (smoothed - r.v0[i]).length_squared();
        den += r.vol[i] * r.v0[i].length_squared();
    }
    (num / den).sqrt()
}

#[test]
fn table_3s_sph_error_is_that_of_an_sph_interpolant_of_the_pulse() {
    // Table 3's SPH (ni) errors, 0.05026 and 0.04999, are level from the first return to
    // the second, where this project's particle velocities are 0.0055 and 0.017 off, the
    // phase error growing. The exact pulse re-forms at each return (d'Alembert with free
    // ends), so an error level between the returns is one of representing the pulse,
    // not of its motion: the SPH interpolant Σ_J V_J W_IJ v_J of the exact velocity, whose
    // kernel sums fall to 0.76 in the rows on the free faces, is 0.0476, 0.0524 and 0.0600
    // off at h/Δx = 1.2, 1.3 and 1.5 (uniform volumes; 0.084 with the shipped tributary
    // ones). Bound: within 10 % of the table at h/Δx = 1.2 and 1.3 (the paper gives no
    // h/Δx; measured −5 % and +4.5 %).
    for h_over_dx in [1.2, 1.3] {
        let e = sph_interpolant_error(h_over_dx);
        for paper in [0.05026, 0.04999] {
            assert!(
                (e / paper - 1.0).abs() < 0.1,
                "h/Δx = {h_over_dx}: {e} against Table 3's {paper}"
            );
        }
    }
}

#[test]
fn the_galerkin_particle_methods_on_the_rod() {
    // The rod at Δx = 0.25 mm (5,061 particles; the paper's 0.125 mm takes two minutes
    // for the four runs; docs/methods/seed001.md has that ladder), errors at L/c and 2L/c.
    // Measured here: KBM (si) 0.0034 / 0.0113, KBM (ni) 0.0075 / 0.0076, EFG (ni)
    // 0.0033 / 0.0048, EFG (ci) 0.0016 / 0.0041; SPH 0.057 / 0.17.
    let coarse = |case: &str, key: &str| {
        let set: Vec<&str> = ["spacing=2.5e-4", key]
            .into_iter()
            .filter(|s| !s.is_empty())
            .collect();
        rod_errors(case, &set)
    };
    let kbm_si = coarse("rod-gaussian-kbm", "");
    let kbm_ni = coarse("rod-gaussian-kbm", "method.integration=nodal");
    let efg_ni = coarse("rod-gaussian-efg", "method.integration=nodal");
    let efg_ci = coarse("rod-gaussian-efg", "");
    let sph = coarse("rod-gaussian", "");
    for k in 0..2 {
        // Table 3's ordering at its ends: EFG (ci) the most accurate, SPH the least.
        for (name, e) in [
            ("KBM (si)", kbm_si),
            ("KBM (ni)", kbm_ni),
            ("EFG (ni)", efg_ni),
        ] {
            assert!(
                efg_ci[k] < e[k] && e[k] < sph[k],
                "return {}: EFG (ci) {}, {name} {}, SPH {}",
                k + 1,
                efg_ci[k],
                e[k],
                sph[k]
            );
        }
    }
    // Stress points halve KBM's error at the first return (2.2 times here, 2.2 at the
    // paper's resolution); at the second the accumulated phase error dominates both.
    assert!(
        kbm_si[0] < 0.7 * kbm_ni[0],
        "KBM: (si) {} against (ni) {}",
        kbm_si[0],
        kbm_ni[0]
    );
    // Already at twice the paper's spacing each is below its Table 3 value at the first
    // return (KBM (si) 0.00813, EFG (ni) 0.008322, EFG (ci) 0.006817); a wrong weight,
    // mass or gradient costs an order of magnitude (SPH's 0.057).
    for (name, e, paper) in [
        ("KBM (si)", kbm_si, 0.00813),
        ("EFG (ni)", efg_ni, 0.008322),
        ("EFG (ci)", efg_ci, 0.006817),
    ] {
        assert!(e[0] < paper, "{name}: {} against Table 3's {paper}", e[0]);
    }
}

#[test]
fn the_error_observer_names_a_closed_form_the_case_has() {
    // The shipped case survives the round trip through TOML that a study's run id takes,
    // observer and all.
    let case = load("rod-gaussian", &[] as &[&str]);
    let text = toml::to_string(&case.resolved()).unwrap();
    let again = Scene::from_toml(&text, Path::new("again.toml"), &[]).unwrap();
    assert_eq!(again.output.observers, case.output.observers);
    // A free rod needs a Gaussian pulse along an axis of a box; a swinging mode, the
    // `swinging` velocity: each refusal names the key and what is missing.
    for (set, expect) in [
        (
            "body.0.initial_velocity.direction=[1.0, 1.0]",
            "along an axis of the box",
        ),
        (
            r#"output.observers=[{ velocity-error = "swinging" }]"#,
            "`swinging`",
        ),
        (
            r#"output.observers=[{ velocity-error = "free-rod" }, { velocity-error = "rod-pulse" }]"#,
            "more than once",
        ),
    ] {
        let path = crate::common::case_file("rod-gaussian");
        let e = Scene::load(&path, &[set.to_string()])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("output.observers") && e.contains(expect),
            "{set}: {e}"
        );
    }
}
