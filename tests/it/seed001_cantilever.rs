//! Seed 001 §9.1: the static cantilever with a parabolic end shear, solved by the static
//! path of the explicit methods (`run.solve = "static"`, `src/statics/explicit.rs`) on the
//! substitute beam of `cases/cantilever-convergence.toml` (L = 48, D = 12, E = 3e7, ν =
//! 0.3, P = 1000, plane stress), against Timoshenko & Goodier with the errors of eqs 71–74
//! in each method's own quadrature. The full ladder is the suite
//! `cases/studies/seed001-cantilever.toml`; docs/methods/seed001.md has its orders.

use crate::common::load;
use meshless::core::tensor::D2;
use meshless::diagnostics::observe::{solution_errors, solution_of};
use meshless::physics::material::Material;
use meshless::run::{Backend, Engine, engine};
use meshless::scene::Scene;
use std::path::Path;

/// The variants of the paper, as overrides of the shipped case (SPH (ni)).
const SPH: &[&str] = &[];
const RLM: &[&str] = &["method.correction=randles-libersky"];
const KBM_SI: &[&str] = &["method.name=kbm"];
const KBM_NI: &[&str] = &["method.name=kbm", "method.integration=nodal"];
const EFG_NI: &[&str] = &["method.name=efg", "method.integration=nodal"];
const EFG_CI: &[&str] = &["method.name=efg"];

/// The static solve of a case: (displacement error, energy error).
fn solve(case: &Scene) -> (f64, f64) {
    let mut e = engine::<D2>(case, Backend::Cpu).unwrap_or_else(|e| panic!("{e}"));
    e.advance(0.0, 1.0, 1)
        .unwrap_or_else(|f| panic!("{}", f.cause));
    let closed = solution_of(case).expect("the case has a solution-displacement condition");
    let snap = e.snapshot();
    let [du, de] = solution_errors(&snap, &closed, &Material::new(&case.material));
    (du, de)
}

/// The errors of a variant at spacing Δx, with h/Δx = 1.3 or, if given, h fixed.
fn errors(variant: &[&str], spacing: f64, h: Option<f64>) -> (f64, f64) {
    let mut set: Vec<String> = variant.iter().map(|s| s.to_string()).collect();
    set.push(format!("spacing={spacing}"));
    if let Some(h) = h {
        set.push(format!("method.h_over_dx={}", h / spacing));
    }
    solve(&load("cantilever-convergence", &set))
}

/// log2 of successive error ratios on a ladder halving Δx.
fn orders(e: &[f64]) -> Vec<f64> {
    e.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
}

#[test]
fn the_static_solve_passes_the_patch_test_with_finite_elements() {
    // Uniaxial stress σ = 1e4 along x on a 4 × 2 block of bilinear elements (tl-fem),
    // u_x prescribed on x = 0 (and u_y at one point), the traction σ on x = 4: the exact
    // field is linear, which the elements contain, so the static solve (closed-form
    // stiffness, sparse Cholesky, Newton to 1e-10 of the load) must
    // give it: bound 1e-9 relative in u (a wrong stiffness column or load is off by far
    // more).
    let text = r#"
name = "patch"
dimension = 2
spacing = 0.5
[material]
model = "linear-elastic"
density = 1.0
youngs_modulus = 3.0e7
poisson_ratio = 0.3
plane = "stress"
[method]
name = "tl-fem"
dt = 1.0
[[body]]
name = "block"
geometry = { shape = "box", min = [0.0, 0.0], max = [4.0, 2.0], volumes = "tributary" }
[[boundary]]
region = { x_max = 0.0 }
condition = { type = "solution-displacement", components = ["x"], solution = { type = "uniaxial-stress", stress = 1.0e4 } }
[[boundary]]
region = { x_max = 0.0, y_max = 0.0 }
condition = { type = "displacement", uy = 0.0 }
[[boundary]]
region = { x_min = 4.0 }
condition = { type = "solution-traction", normal = [1.0, 0.0], solution = { type = "uniaxial-stress", stress = 1.0e4 } }
[run]
end_time = 1.0
solve = "static"
"#;
    let case =
        Scene::from_toml(text, Path::new("patch.toml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    let mut e = engine::<D2>(&case, Backend::Cpu).unwrap();
    e.advance(0.0, 1.0, 1)
        .unwrap_or_else(|f| panic!("{}", f.cause));
    let snap = e.snapshot();
    let eps = 1.0e4 / 3.0e7;
    for (x, u) in snap.x0.iter().zip(&snap.u) {
        let exact = [eps * x.x, -0.3 * eps * x.y];
        assert!(
            (u.x - exact[0]).abs() < 1e-9 * 4.0 * eps && (u.y - exact[1]).abs() < 1e-9 * 4.0 * eps,
            "at {x}: {u} vs {exact:?}"
        );
    }
}

#[test]
fn a_body_left_free_to_move_is_refused_by_name() {
    // Only u_y held at x = 0: the beam may slide along x, so the stiffness would be
    // singular. The set-up names the body and the free motion instead of solving.
    let case = load(
        "cantilever-convergence",
        &["boundary.0.condition.components=[\"y\"]", "spacing=4.0"],
    );
    let err = engine::<D2>(&case, Backend::Cpu).err().expect("refused");
    let text = err.to_string();
    assert!(
        text.contains("`beam`") && text.contains("translation in x"),
        "{text}"
    );
}

/// The displacement and energy errors of a variant on the ladder Δx = 4, 2, 1 (13 × 4 to
/// 49 × 13 particles).
fn ladder(variant: &[&str], h: Option<f64>) -> (Vec<f64>, Vec<f64>) {
    [4.0, 2.0, 1.0]
        .iter()
        .map(|&dx| errors(variant, dx, h))
        .unzip()
}

#[test]
fn efg_converges_at_second_order_in_the_displacement_and_cells_are_best() {
    // Spec §11 item 8: EFG (ci) best, EFG (ni) "only a little" slower. Measured (Δx = 4,
    // 2, 1): EFG (ci) 0.0528, 0.01155, 0.00312 (orders 2.19, 1.89), EFG (ni) 0.130,
    // 0.0390, 0.00978 (1.73, 2.00); energy errors 0.120, 0.0561, 0.0302 and 0.209,
    // 0.0827, 0.0393 (orders 0.9–1.3). Bounds: the last order in u within 1.6–2.4 (the
    // linearly complete functions' 2 with the boundary layer's scatter), in energy above
    // 0.7 (its 1), and EFG (ci) below EFG (ni) on the two finer rungs.
    let (ci, ci_e) = ladder(EFG_CI, None);
    let (ni, ni_e) = ladder(EFG_NI, None);
    eprintln!("EFG (ci) {ci:?} {ci_e:?}; EFG (ni) {ni:?} {ni_e:?}");
    for (u, e) in [(&ci, &ci_e), (&ni, &ni_e)] {
        let (ou, oe) = (orders(u), orders(e));
        assert!((1.6..2.4).contains(&ou[1]), "{u:?}: orders {ou:?}");
        assert!(oe[1] > 0.7, "{e:?}: orders {oe:?}");
    }
    assert!(ci[1] < ni[1] && ci[2] < ni[2], "{ci:?} {ni:?}");
}

#[test]
fn the_finite_elements_converge_at_orders_two_and_one() {
    // The static solve checked against theory on the cantilever: bilinear elements
    // (tl-fem, 2 × 2 Gauss) converge as O(Δx²) in u and O(Δx) in energy. Measured:
    // 0.0487, 0.01274, 0.00322 (orders 1.94, 1.98) and 0.231, 0.118, 0.0593 (0.97,
    // 0.99). Bounds: 1.9–2.1 and 0.9–1.1 on the finer pair.
    let (u, e) = ladder(&["method.name=tl-fem"], None);
    let (ou, oe) = (orders(&u), orders(&e));
    assert!((1.9..2.1).contains(&ou[1]), "{u:?}: {ou:?}");
    assert!((0.9..1.1).contains(&oe[1]), "{e:?}: {oe:?}");
}

/// Where a claim of §9.1 does not come out (docs/methods/seed001.md, "The cantilever of
/// §9.1", "What does not", with the runs that separate the causes).
const FINDING: &str = "docs/methods/seed001.md, \"The cantilever of §9.1\"";

#[test]
#[ignore = "finding: docs/methods/seed001.md, \"The cantilever of §9.1\": KBM (si) converges at first order"]
fn kbm_with_stress_points_converges_at_close_to_second_order() {
    // The paper's conclusions: KBM (si)'s rate is "close to two" in the displacement norm,
    // "only a little bit less" than EFG (ci)'s. Bound: the order on Δx = 2 → 1 within
    // 1.6–2.4, the band EFG's own orders pass with (above). Measured: 0.477, 0.187,
    // 0.0842 at Δx = 4, 2, 1, orders 1.35 and 1.15: first order (the Shepard functions'
    // zeroth-order completeness at the free faces; the finding has the runs that show it).
    let (si, _) = ladder(KBM_SI, None);
    let o = orders(&si);
    assert!(
        (1.6..2.4).contains(&o[1]),
        "{si:?}: orders {o:?} ({FINDING})"
    );
}

#[test]
fn stress_points_lower_kbms_energy_error() {
    // The paper: KBM (si) gives "pretty good results" where KB corrections with nodal
    // integration "yield poor" ones. In the energy norm the stress points do lower the
    // error (docs/methods/seed001.md's table of orders). Bound: KBM (si) below KBM (ni)
    // at Δx = 2 and 1 (the claim, with no margin asked).
    let (_, si_e) = ladder(KBM_SI, None);
    let (_, ni_e) = ladder(KBM_NI, None);
    assert!(si_e[1] < ni_e[1] && si_e[2] < ni_e[2], "{si_e:?} {ni_e:?}");
}

#[test]
fn rlm_with_nodal_integration_is_poor() {
    // The paper: RL corrections with nodal integration "yield poor results", EFG (ni)
    // "pretty good" ones. The paper's Fig. 6 has no numbers here, so "poor" is taken as
    // an error over five times EFG (ni)'s at Δx = 1 in both norms; measured 0.253
    // against 0.00978 in u (26 times) and 0.396 against 0.0393 in energy (10 times).
    let (u, e) = errors(RLM, 1.0, None);
    let (u_efg, e_efg) = errors(EFG_NI, 1.0, None);
    eprintln!("RLM {u} {e}; EFG (ni) {u_efg} {e_efg}");
    assert!(
        u > 5.0 * u_efg && e > 5.0 * e_efg,
        "RLM {u} {e}, EFG (ni) {u_efg} {e_efg}"
    );
}

#[test]
fn sph_with_h_over_dx_fixed_is_far_off() {
    // The paper: symmetrised SPH "does not converge at all" with h/Δx fixed. Its error
    // stays far above every other method's: measured 0.764 at Δx = 1 with h/Δx = 1.3,
    // where every other variant is below 0.26. Bound: above 0.5 at Δx = 1.
    let (u, _) = errors(SPH, 1.0, None);
    assert!(u > 0.5, "{u}");
}

#[test]
#[ignore = "finding: docs/methods/seed001.md, \"The cantilever of §9.1\": SPH converges slowly with h/Δx fixed"]
fn sph_does_not_converge_with_h_over_dx_fixed() {
    // The paper: no convergence at all with h/Δx fixed. Bound: no order above 0.5 on
    // the ladder (an error that does not fall as Δx halves). Measured: 5.53, 1.69, 0.764,
    // orders 1.71 and 1.15: slow convergence.
    let (u, _) = ladder(SPH, None);
    let o = orders(&u);
    assert!(
        o.iter().all(|&x| x < 0.5),
        "{u:?}: orders {o:?} ({FINDING})"
    );
}

#[test]
#[ignore = "finding: docs/methods/seed001.md, \"The cantilever of §9.1\": SPH with h fixed gets worse"]
fn sph_converges_with_h_fixed() {
    // The paper's Fig. 7: SPH converges when the domain of influence is held constant.
    // Bound: with h = 2 the error at Δx = 1 below that at Δx = 2. Measured: 1.02 at
    // Δx = 2, 1.83 at Δx = 1 (and 5.36 at Δx = 0.5): it grows.
    let (coarse, _) = errors(SPH, 2.0, Some(2.0));
    let (fine, _) = errors(SPH, 1.0, Some(2.0));
    assert!(fine < coarse, "{coarse} {fine} ({FINDING})");
}
