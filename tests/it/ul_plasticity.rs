//! A yield stress on the rate model of the updated-Lagrangian strong forms (Gray–Monaghan
//! and Godunov SPH; seed 000 App. 9.1): the radial return that closes every step against
//! the closed form of homogeneous uniaxial strain, its plastic work, the GPU against the
//! CPU, and the plastic tensile strip's neck.

use crate::common::max_s;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::Method;
use meshless::methods::cores::ul::{PairScheme, UlSph};
use meshless::methods::godunov::system::Scheme as GodunovScheme;
use meshless::methods::gray_monaghan::system::Scheme as GmScheme;
use meshless::run::Engine;
use meshless::scene::Scene;
use std::path::Path;

type GmPlastic = UlSph<D2, GmScheme>;

/// E = 1 MPa, ν = 0.3: μ = E/2.6.
const MU: f64 = 1e6 / 2.6;
/// Yield at a logarithmic strain of 1 % in uniaxial strain, where q = 2μ e.
const YIELD: f64 = 2.0 * MU * 0.01;
/// The stretch rate ε̇ = ∂v_x/∂X [1/s] and the step.
const RATE: f64 = 10.0;
const DT: f64 = 1e-5;

/// The method lines of the two strong forms: Randles–Libersky-corrected L, which is exact
/// for the affine motion at every particle, the surface's included.
const METHODS: [&str; 2] = [
    "name = \"gray-monaghan-sph\"\ncorrection = \"randles-libersky\"",
    "name = \"godunov-sph\"\ncorrection = \"randles-libersky\"",
];

/// A block of Δx = 0.1 whose every particle is held at v = (ε̇ (X − X̄), 0[, 0]) by a
/// velocity condition on its column: homogeneous uniaxial strain, with the current
/// L = ε̇/(1 + ε̇t) e_x ⊗ e_x. `hardening` is H [Pa].
fn stretched<D: Dim>(max: &[f64], method: &str, hardening: f64) -> Scene {
    let dim = D::N;
    let text = |boundaries: &str| {
        format!(
            r#"name = "stretched"
dimension = {dim}
spacing = 0.1
[material]
model = "hypoelastic"
density = 1000.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
yield_stress = {YIELD:e}
hardening_modulus = {hardening:e}
[method]
{method}
h_over_dx = 1.3
integrator = "rk4"
dt = {DT:e}
[[body]]
name = "b"
geometry = {{ shape = "box", min = {:?}, max = {max:?}, volumes = "uniform" }}
{boundaries}
[run]
end_time = 1.0
"#,
            vec![0.0; dim]
        )
    };
    let load = |t: &str| Scene::from_toml(t, Path::new("stretched.toml"), &[]).unwrap();
    // The columns' X from the lattice of the case without conditions.
    let free = load(&text(""));
    let r = meshless::reference::Reference::<D>::build(&free).unwrap();
    let mut columns: Vec<f64> = r.x0.iter().map(|&x| D::to3(x)[0]).collect();
    columns.sort_by(f64::total_cmp);
    columns.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let centre = 0.5 * (columns[0] + columns[columns.len() - 1]);
    let zero = if dim == 3 { ", vz = 0.0" } else { "" };
    let boundaries: String = columns
        .iter()
        .map(|&c| {
            format!(
                "[[boundary]]\nregion = {{ x_min = {:e}, x_max = {:e} }}\n\
                 condition = {{ type = \"velocity\", vx = {:e}, vy = 0.0{zero} }}\n",
                c - 0.25 * 0.1,
                c + 0.25 * 0.1,
                RATE * (c - centre)
            )
        })
        .collect();
    load(&text(&boundaries))
}

/// The closed form at log strain e = ln(1 + ε̇t) of uniaxial strain with a radial return
/// at every step's end: (S_xx, S_yy, ε_p) and the strain energy the returns took out per
/// unit reference volume, stepping the trial q = q_n + 2μ Δe of each step.
fn closed_form(steps: u32, hardening: f64) -> ([f64; 2], f64, f64) {
    let e = |k: u32| (1.0 + RATE * DT * f64::from(k)).ln();
    let (mut q, mut eps_p, mut work) = (0.0, 0.0, 0.0);
    for k in 0..steps {
        let trial = q + 2.0 * MU * (e(k + 1) - e(k));
        let tau = YIELD + hardening * eps_p;
        q = trial;
        if trial > tau {
            let d_eps = (trial - tau) / (3.0 * MU + hardening);
            q = trial - 3.0 * MU * d_eps;
            eps_p += d_eps;
            // S:S + S_zz² = (2/3) q², so S:S/(4μ) = q²/(6μ).
            work += (trial * trial - q * q) / (6.0 * MU);
        }
    }
    // S = (q/3)(2, −1, −1) along (x, y, z): dev D ∝ (2, −1, −1).
    ([2.0 * q / 3.0, -q / 3.0], eps_p, work)
}

/// Runs `steps` steps of the CPU engine and checks S, ε_p and the plastic work against
/// [`closed_form`].
fn check_closed_form<D: Dim, S: PairScheme<D>>(case: &Scene, steps: u32, hardening: f64)
where
    S::Spec: meshless::methods::Runs,
{
    let mut e = meshless::scene::cpu_engine::<D, UlSph<D, S>>(case).unwrap();
    e.advance(0.0, DT, steps).unwrap();
    let ([sxx, syy], eps_p, work) = closed_form(steps, hardening);
    // RK4 integrates Ṡ = 2μ dev D(t) with D(t) = ε̇/(1 + ε̇t): Simpson's rule on a smooth
    // rate, exact to ~1e-13 of S per step; the returns are exact. 1e-9 of τ_y leaves room
    // for round-off over the steps and nothing for a missing or wrong return (which
    // leaves q = 2μe, 3× τ_y at the end, or a hardening off by H Δε_p).
    for (i, s) in e.y.s.iter().enumerate() {
        let s3 = D::to3x3(*s);
        let err = (s3[0][0] - sxx).abs().max((s3[1][1] - syy).abs());
        assert!(
            err < 1e-9 * YIELD,
            "{}: particle {i}: S = {s3:?}, closed form ({sxx}, {syy})",
            case.method.name
        );
    }
    let (err, _) = max_s(&e.y.eps_p, &vec![eps_p; e.y.eps_p.len()]);
    assert!(
        err < 1e-9 * eps_p,
        "{}: ε_p off by {err:e} of {eps_p}",
        case.method.name
    );
    let volume: f64 = e.method.core.vol0.iter().sum();
    let booked = e.method.plastic_work(&e.y);
    assert!(
        (booked - volume * work).abs() < 1e-9 * volume * work,
        "{}: plastic work {booked} against {}",
        case.method.name,
        volume * work
    );
}

#[test]
fn uniaxial_strain_yields_at_the_closed_form_and_stays_on_the_surface() {
    // 300 steps reach e = ln 1.03: yield at e = 1 % after 101 steps, then 2 % of plastic
    // flow. H = 0 (perfect plasticity, the paper's) and H = μ (linear hardening).
    for hardening in [0.0, MU] {
        for method in METHODS {
            let case = stretched::<D2>(&[0.7, 0.4], method, hardening);
            if method.contains("godunov") {
                check_closed_form::<D2, GodunovScheme>(&case, 300, hardening);
            } else {
                check_closed_form::<D2, GmScheme>(&case, 300, hardening);
            }
        }
        let case = stretched::<D3>(&[0.5, 0.3, 0.3], METHODS[0], hardening);
        check_closed_form::<D3, GmScheme>(&case, 300, hardening);
    }
    // Before the onset the state is elastic: no ε_p, no plastic work.
    let ([sxx, _], eps_p, work) = closed_form(100, 0.0);
    assert_eq!((eps_p, work), (0.0, 0.0));
    assert!(sxx < 2.0 / 3.0 * YIELD);
}

#[cfg(feature = "gpu")]
mod gpu {
    use super::{DT, METHODS, MU, YIELD, stretched};
    use crate::common::{gpu, max_s, max_t};
    use crate::gpu_ul::scheme;
    use meshless::core::tensor::{D2, D3};
    use meshless::gpu::layout::GpuDim;
    use meshless::methods::Method;
    use meshless::methods::cores::ul::gpu::GpuUl;
    use meshless::methods::cores::ul::{PairScheme, UlSph, UlState};
    use meshless::methods::godunov::system::Scheme as GodunovScheme;
    use meshless::methods::gray_monaghan::system::Scheme as GmScheme;
    use meshless::run::Engine;
    use meshless::scene::Scene;

    /// The GPU's S and ε_p against the CPU's after the same steps through the yield.
    fn compare_gpu<D: GpuDim, S: PairScheme<D>>(case: &Scene, steps: u32)
    where
        S::Spec: meshless::methods::Runs,
        UlSph<D, S>: Method<D, State = UlState<D>>,
    {
        let mut cpu = meshless::scene::cpu_engine::<D, UlSph<D, S>>(case).unwrap();
        cpu.advance(0.0, DT, steps).unwrap();
        let mut g = GpuUl::<D>::new(case, gpu(), &scheme(case)).unwrap();
        g.advance(0.0, DT, steps).unwrap();
        let yg = g.state();
        // f32 rounding of S (6e-8 of |S| ≈ τ_y) in four stage updates and a return a step,
        // over 300 steps, adds to at most ~1e-4 of τ_y if it accumulates linearly; a missing
        // return on the device leaves 3× τ_y.
        let (es, _) = max_t::<D>(&cpu.y.s, &yg.s);
        assert!(
            es < 1e-4 * YIELD,
            "{}: max |ΔS| = {es:e} Pa",
            case.method.name
        );
        let (ee, scale) = max_s(&cpu.y.eps_p, &yg.eps_p);
        assert!(
            ee < 1e-4 * scale,
            "{}: max |Δε_p| = {ee:e} of {scale:e}",
            case.method.name
        );
    }

    #[test]
    fn the_gpu_returns_to_the_yield_surface_as_the_cpu() {
        compare_gpu::<D2, GmScheme>(&stretched::<D2>(&[0.7, 0.4], METHODS[0], MU), 300);
        compare_gpu::<D2, GodunovScheme>(&stretched::<D2>(&[0.7, 0.4], METHODS[1], 0.0), 300);
        compare_gpu::<D3, GmScheme>(&stretched::<D3>(&[0.5, 0.3, 0.3], METHODS[0], 0.0), 300);
    }
}

/// The height max y − min y of every material column (common X) of a 2D state, by X.
fn column_heights(x0: &[glam::DVec2], u: &[glam::DVec2]) -> Vec<(f64, f64)> {
    let mut columns: Vec<(f64, f64, f64)> = Vec::new();
    for (x0, u) in x0.iter().zip(u) {
        let y = x0.y + u.y;
        match columns.iter_mut().find(|c| (c.0 - x0.x).abs() < 1e-9) {
            Some(c) => (c.1, c.2) = (c.1.min(y), c.2.max(y)),
            None => columns.push((x0.x, y, y)),
        }
    }
    columns.sort_by(|a, b| a.0.total_cmp(&b.0));
    columns.iter().map(|c| (c.0, c.2 - c.1)).collect()
}

#[test]
fn the_plastic_strip_necks_at_its_middle_as_in_gray_et_al() {
    // App. 9.1's strip to 50 % extension (t = 0.025 s). Fig. 16 (Gray et al.'s test
    // re-created) shows one neck, at mid-length, between gripped ends; the elastic strip
    // of Fig. 15 has none. The set-up is mirror-symmetric about X = 0.5, so the neck must
    // lie there: within one Δx, for both the narrowest column and the largest ε_p. (At 25 %
    // the neck is still diffuse: the columns from X = 0.35 to 0.65 lie within 1 % of each
    // other, so the position is read at the end.)
    let case = crate::common::shipped("tensile-strip-plastic");
    let mut e = meshless::scene::cpu_engine::<D2, GmPlastic>(&case).unwrap();
    e.advance(0.0, 1e-6, 25_000).unwrap();
    let x0 = e.method.reference();
    let heights = column_heights(x0, &e.y.u);
    let (neck_x, neck) = heights
        .iter()
        .copied()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    assert!(
        (neck_x - 0.5).abs() <= 0.05 + 1e-9,
        "narrowest column at X = {neck_x} (l/l0 = {neck}): {heights:?}"
    );
    // The neck has localised: 50 % extension of a uniform strip at constant volume would
    // give l/l0 = 2/3 (the grips hold 1 at the ends).
    assert!(neck < 0.5, "l/l0 = {neck} at the neck");
    let (peak, _) =
        e.y.eps_p
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap();
    assert!(
        (x0[peak].x - 0.5).abs() <= 0.05 + 1e-9,
        "ε_p peaks at X = {:?}",
        x0[peak]
    );
}
