//! SUPG-SPH (seed 003; docs/methods/mixed.md "SUPG-SPH"): its stress-point terms vanish
//! on affine motion and conserve linear momentum, mirror planes give the whole body's
//! rates, the zero-energy modes of the particles' sums decay under it alone, and its keys
//! are checked by name.

use crate::common::{largest_t, largest_v, random_state, random_tensor, random_vector};
use meshless::core::integrate::{Integrator, OdeSystem};
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::Method;
use meshless::methods::mixed::{Fluxes, MixedSph, MixedState};
use meshless::run::build_method;
use meshless::scene::Scene;
use std::path::Path;

/// A box from `lo` to `hi` (2D or 3D, cell-centred at Δx = 0.1) of `model` (ρ0 = 1000
/// kg/m³, E = 1 MPa, ν = 0.45) under `method` on `variables`, with the method lines `keys`
/// and the mirror planes `mirrors` (axis, position, kind).
fn box_case(
    lo: &[f64],
    hi: &[f64],
    model: &str,
    method: &str,
    keys: &str,
    mirrors: &[(&str, f64, &str)],
) -> Scene {
    let planes: String = mirrors
        .iter()
        .map(|(axis, at, kind)| {
            format!("[[mirror]]\nnormal = \"{axis}\"\nat = {at:?}\nkind = \"{kind}\"\n")
        })
        .collect();
    let text = format!(
        r#"
name = "box"
dimension = {}
spacing = 0.1
[material]
model = "{model}"
density = 1000.0
youngs_modulus = 1.0e6
poisson_ratio = 0.45
[method]
name = "{method}"
h_over_dx = 1.3
cfl = 0.3
{keys}
[[body]]
name = "b"
geometry = {{ shape = "box", min = {lo:?}, max = {hi:?}, lattice = "cell-centred" }}
{planes}
[run]
end_time = 1.0e-3
"#,
        lo.len()
    );
    Scene::from_toml(&text, Path::new("box.toml"), &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// The neo-Hookean box [0, 1]^d under SUPG-SPH on {p, F, H, J} with the method lines
/// `keys`.
fn free_box<D: Dim>(keys: &str) -> Scene {
    let model = "nearly-incompressible-neo-hookean";
    let keys = format!("variables = \"p-F-H-J\"\n{keys}");
    box_case(
        &vec![0.0; D::N],
        &vec![1.0; D::N],
        model,
        "supg-sph",
        &keys,
        &[],
    )
}

/// The state u = G X, F = I + G, H = cof F, J = det F, v = A X + b.
fn affine<D: Dim>(m: &MixedSph<D>, g: D::T, a: D::T, b: D::V) -> MixedState<D> {
    let mut y = m.initial_state();
    for (k, &x) in m.reference().iter().enumerate() {
        y.u[k] = g * x;
        y.v[k] = a * x + b;
        y.f[k] = D::identity() + g;
        y.h[k] = D::cof(y.f[k]);
        y.j[k] = D::det(y.f[k]);
    }
    y
}

/// The rates of state y after `begin_step` at Δt = 1e-4 s (τ_F and τ_p are multiples of
/// it), and the fluxes T, D of the same state.
fn rates_and_fluxes<D: Dim>(m: &mut MixedSph<D>, y: &MixedState<D>) -> (MixedState<D>, Fluxes<D>) {
    m.begin_step(0.0, 1.0e-4, y);
    let mut d = y.clone();
    m.rates(0.0, y, &mut d).unwrap();
    (d, m.fluxes(y).unwrap())
}

/// On an affine motion every residual vanishes (the cells' functions are exact for linear
/// fields), so SUPG adds nothing: D = 0, Ḟ = A, Ḣ = F × A, J̇ = H : A, the particles'
/// own corrected-gradient rates. First with u = G X (F = I + G, a uniform stress) and τ_p =
/// 0: the free surface carries the uniform stress's unbalanced traction, ṗ ≠ 0 there, so
/// DIV P − ṗ is a true residual that τ_p would act on; then at rest (F = I, P = 0) with
/// every term on. Bounds: round-off of sums of O(30) terms, 1e-10 of |P|/Δx for D and of
/// |A| for the rates.
fn affine_motion_adds_nothing<D: Dim>() {
    let mut seed = 5;
    let (a, b) = (
        random_tensor::<D>(&mut seed, 1.0),
        random_vector::<D>(&mut seed, 1.0),
    );
    for (keys, g) in [
        (
            "supg = { tau_p = 0.0 }",
            random_tensor::<D>(&mut seed, 0.05),
        ),
        ("", D::zero_t()),
    ] {
        let case = free_box::<D>(keys);
        let mut m: MixedSph<D> = build_method(&case).unwrap();
        let y = affine(&m, g, a, b);
        let (d, fluxes) = rates_and_fluxes(&mut m, &y);
        let p = m.first_piola(&y).unwrap();
        let force_scale = (largest_t::<D>(p) / case.spacing).max(1.0);
        let d_max = largest_v::<D>(fluxes.d.iter().copied());
        assert!(
            d_max < 1e-10 * force_scale,
            "{}D {keys:?}: max |D| = {d_max:e}",
            D::N
        );
        let scale = D::ddot(a, a).sqrt();
        for k in 0..y.f.len() {
            let f = y.f[k];
            let errors = [
                d.f[k] - a,
                d.h[k] - D::cof_rate(f, a),
                D::identity() * (d.j[k] - D::ddot(y.h[k], a)),
            ];
            for e in errors {
                assert!(
                    D::ddot(e, e).sqrt() < 1e-10 * scale,
                    "{}D {keys:?}, particle {k}: error {e:?}",
                    D::N
                );
            }
        }
    }
}

#[test]
fn an_affine_motion_gets_no_stabilisation() {
    affine_motion_adds_nothing::<D2>();
    affine_motion_adds_nothing::<D3>();
}

/// Σ_a V_a D_a = −Σ_s V_s ΔP_s Σ_a G_a(X_s) = 0 for any state: the cells' gradients sum
/// to zero. Round-off of O(N·k) terms: 1e-12 of Σ V |D|, which must not vanish itself.
fn stress_points_conserve_linear_momentum<D: Dim>() {
    let case = free_box::<D>("projection = false");
    let mut m: MixedSph<D> = build_method(&case).unwrap();
    let y = random_state(&m, &mut 3, 0.01);
    let (_, Fluxes { d, .. }) = rates_and_fluxes(&mut m, &y);
    let vol = m.volume();
    let total = d.iter().zip(vol).fold(D::zero(), |s, (&d, &v)| s + d * v);
    let scale: f64 = d
        .iter()
        .zip(vol)
        .map(|(&d, &v)| v * D::norm2(d).sqrt())
        .sum();
    assert!(scale > 0.0, "{}D: SUPG gave no force", D::N);
    assert!(
        D::norm2(total).sqrt() < 1e-12 * scale,
        "{}D: |Σ V D| = {:e} of {scale:e}",
        D::N,
        D::norm2(total).sqrt()
    );
}

#[test]
fn the_stress_points_conserve_linear_momentum() {
    stress_points_conserve_linear_momentum::<D2>();
    stress_points_conserve_linear_momentum::<D3>();
}

/// A 2D field on the plate: its value and gradient (∂_j f_i in column j) at X.
type Field = fn(glam::DVec2) -> (glam::DVec2, glam::DMat2);

/// The rates of the plate [lo, hi] with `mirrors` at the state u, F = I + ∇u, H = cof F,
/// J = det F, v of the fields, by reference position.
fn plate_rates(
    model: &str,
    keys: &str,
    lo: [f64; 2],
    hi: [f64; 2],
    mirrors: &[(&str, f64, &str)],
    (u, v): (Field, Field),
) -> (Vec<glam::DVec2>, MixedState<D2>) {
    let case = box_case(&lo, &hi, model, "supg-sph", keys, mirrors);
    let mut m: MixedSph<D2> = build_method(&case).unwrap();
    let mut y = m.initial_state();
    for (k, &x) in m.reference().iter().enumerate() {
        let (uk, grad_u) = u(x);
        y.u[k] = uk;
        y.v[k] = v(x).0;
        y.f[k] = glam::DMat2::IDENTITY + grad_u;
        if !y.h.is_empty() {
            y.h[k] = D2::cof(y.f[k]);
        }
        if !y.j.is_empty() {
            y.j[k] = D2::det(y.f[k]);
        }
    }
    let (d, _) = rates_and_fluxes(&mut m, &y);
    (m.reference().to_vec(), d)
}

/// Mirror planes stand for the mirrored body: the rates of the quarter plate [0, 1] ×
/// [0, 0.6] with planes on X = 0 and Y = 0 equal those of the whole plate [−1, 1] ×
/// [−0.6, 0.6] at the same particles, for fields with the planes' symmetries. The stress
/// points near the planes are those of the whole plate's cells across them, reached
/// through the ghosts' images (in the corner through both). Two pairs: symmetric planes
/// with the neo-Hookean model on {p, F, H, J}, and a skew-symmetric X = 0 with the linear
/// model on {p, F} (exactly skew-symmetric only for a linear stress). Bound: round-off,
/// 1e-10 of each rate's largest value; SUPG's own part of v̇ (against τ = ξ = 0) is checked
/// to be above 1e-4 of it, so that the comparison sees the stress points.
#[test]
fn mirror_planes_give_the_whole_body_s_rates() {
    let symmetric: (Field, Field) = (
        |x| {
            let (a, b) = (x.x, x.y);
            let u = glam::DVec2::new(
                0.01 * a.powi(3) + 0.02 * a * b * b,
                0.015 * a * a * b + 0.01 * b.powi(3),
            );
            let g = glam::DMat2::from_cols(
                glam::DVec2::new(0.03 * a * a + 0.02 * b * b, 0.03 * a * b),
                glam::DVec2::new(0.04 * a * b, 0.015 * a * a + 0.03 * b * b),
            );
            (u, g)
        },
        |x| {
            (
                glam::DVec2::new(
                    0.3 * x.x + 0.2 * x.x * x.y * x.y,
                    -0.1 * x.y + 0.25 * x.x * x.x * x.y,
                ),
                glam::DMat2::ZERO,
            )
        },
    );
    let skew: (Field, Field) = (
        |x| {
            let (a, b) = (x.x, x.y);
            let u = glam::DVec2::new(0.01 * a * a + 0.02 * b * b, 0.03 * a * b);
            let g = glam::DMat2::from_cols(
                glam::DVec2::new(0.02 * a, 0.03 * b),
                glam::DVec2::new(0.04 * b, 0.03 * a),
            );
            (u, g)
        },
        |x| {
            (
                glam::DVec2::new(0.2 * x.x * x.x - 0.1 * x.y * x.y, 0.3 * x.x * x.y),
                glam::DMat2::ZERO,
            )
        },
    );
    let pairs = [
        (
            "nearly-incompressible-neo-hookean",
            "p-F-H-J",
            "symmetric",
            symmetric,
        ),
        ("linear-elastic", "p-F", "skew-symmetric", skew),
    ];
    for (model, variables, kind_x, fields) in pairs {
        let keys = format!("variables = \"{variables}\"\nprojection = false");
        let planes = [("x", 0.0, kind_x), ("y", 0.0, "symmetric")];
        let quarter = plate_rates(model, &keys, [0.0, 0.0], [1.0, 0.6], &planes, fields);
        let whole = plate_rates(model, &keys, [-1.0, -0.6], [1.0, 0.6], &[], fields);
        let galerkin = format!("{keys}\nsupg = {{ tau_f = 0.0, tau_p = 0.0, xi_f = 0.0 }}");
        let plain = plate_rates(model, &galerkin, [0.0, 0.0], [1.0, 0.6], &planes, fields);
        let (xq, dq) = &quarter;
        let (xw, dw) = &whole;
        let dg = &plain.1;
        let scale_v = largest_v::<D2>(dq.v.iter().copied());
        let scale_f = largest_t::<D2>(dq.f.iter().copied());
        let (mut err_v, mut err_f, mut own) = (0.0f64, 0.0f64, 0.0f64);
        for (k, &x) in xq.iter().enumerate() {
            let w = (xw.iter().position(|&xw| (xw - x).length() < 1e-9))
                .expect("the whole plate holds the quarter's particles");
            err_v = err_v.max((dq.v[k] - dw.v[w]).length());
            let df = dq.f[k] - dw.f[w];
            err_f = err_f.max(D2::ddot(df, df).sqrt());
            if !dq.h.is_empty() {
                let dh = dq.h[k] - dw.h[w];
                err_f = err_f.max(D2::ddot(dh, dh).sqrt());
                err_f = err_f.max((dq.j[k] - dw.j[w]).abs());
            }
            own = own.max((dq.v[k] - dg.v[k]).length());
        }
        eprintln!(
            "{model}, X = 0 {kind_x}: |Δv̇| {err_v:e} of {scale_v:e}, |ΔḞ| {err_f:e} of {scale_f:e}, SUPG's part {own:e}"
        );
        assert!(
            err_v < 1e-10 * scale_v,
            "{model}: |Δv̇| = {err_v:e} of {scale_v:e}"
        );
        assert!(
            err_f < 1e-10 * scale_f,
            "{model}: |ΔḞ| = {err_f:e} of {scale_f:e}"
        );
        assert!(
            own > 1e-4 * scale_v,
            "{model}: SUPG's part of v̇ is {own:e} of {scale_v:e}"
        );
    }
}

/// The square [0, 2]² closed by symmetric planes on all four sides: every particle is an
/// interior one, and a pattern alternating between lattice rows continues across the
/// planes.
fn closed_square(keys: &str) -> Scene {
    let planes = [
        ("x", 0.0, "symmetric"),
        ("y", 0.0, "symmetric"),
        ("x", 2.0, "symmetric"),
        ("y", 2.0, "symmetric"),
    ];
    let model = "nearly-incompressible-neo-hookean";
    let keys = format!("variables = \"p-F-J\"\n{keys}");
    box_case(&[0.0, 0.0], &[2.0, 2.0], model, "supg-sph", &keys, &planes)
}

/// (−1)^i and (−1)^(i+j) of the lattice row i and column j of X (Δx = 0.1).
fn stripe_and_checker(x: glam::DVec2) -> (f64, f64) {
    let (i, j) = ((x.x / 0.1).floor() as i64, (x.y / 0.1).floor() as i64);
    let sign = |k: i64| if k % 2 == 0 { 1.0 } else { -1.0 };
    (sign(i), sign(i + j))
}

/// The kinetic energy of the stripe v = ε(−1)^i x̂ after `steps` CFL steps, over its
/// start, and the rate ⟨δJ, J̇⟩/|δJ|² of a J checkerboard δJ = ε(−1)^(i+j) at rest.
fn zero_energy_modes(keys: &str, steps: usize) -> (f64, f64) {
    let case = closed_square(keys);
    let mut m: MixedSph<D2> = build_method(&case).unwrap();
    let x0 = m.reference().to_vec();
    let mut y = m.initial_state();
    for (k, &x) in x0.iter().enumerate() {
        y.j[k] = 1.0 + 1e-3 * stripe_and_checker(x).1;
    }
    let (d, _) = rates_and_fluxes(&mut m, &y);
    let dj: f64 = (0..x0.len()).map(|k| (y.j[k] - 1.0) * d.j[k]).sum();
    let norm: f64 = y.j.iter().map(|j| (j - 1.0).powi(2)).sum();
    let mut y = m.initial_state();
    for (k, &x) in x0.iter().enumerate() {
        y.v[k] = glam::DVec2::new(1e-3 * stripe_and_checker(x).0, 0.0);
    }
    let kinetic = |y: &MixedState<D2>| y.v.iter().map(|v| v.length_squared()).sum::<f64>();
    let k0 = kinetic(&y);
    let dt = case.method.cfl.unwrap() * case.spacing / m.max_signal_speed(&y);
    let mut integrator = Integrator::new(case.method.integrator, &y);
    for k in 0..steps {
        integrator.step(&mut m, k as f64 * dt, dt, &mut y).unwrap();
    }
    (kinetic(&y) / k0, dj / norm)
}

/// The particles' sums miss two patterns on a closed lattice: a stripe of the velocity
/// alternating between rows, v = ε(−1)^i x̂, whose corrected gradient vanishes at every
/// particle (a zero-energy mode: no force, no strain, v̇ = 0), and a checkerboard of J,
/// whose pressure the wide sums do not see. Without SUPG's terms (τ = ξ = 0) the stripe
/// keeps its kinetic energy exactly (bound: round-off, 1e-12) and J's rate has no part
/// along the checkerboard; with the paper's parameters the cells' gradients see both: the
/// stripe's kinetic energy falls to 1.3e-8 of its start in 20 CFL steps (asserted below
/// 1e-6) and the checkerboard decays (measured ⟨δJ, J̇⟩/|δJ|² = −10.2 s⁻¹ at Δt = 1e-4 s,
/// τ_p = 1e-5 s; asserted negative, as a rate that is only dissipative).
#[test]
fn the_zero_energy_modes_of_the_sums_decay_under_supg() {
    let (stripe, checker) =
        zero_energy_modes("supg = { tau_f = 0.0, tau_p = 0.0, xi_f = 0.0 }", 20);
    assert!(
        (stripe - 1.0).abs() < 1e-12,
        "without SUPG the stripe keeps {stripe} of its energy"
    );
    assert!(
        checker.abs() < 1e-12,
        "without SUPG, ⟨δJ, J̇⟩/|δJ|² = {checker:e}"
    );
    let (stripe, checker) = zero_energy_modes("", 20);
    assert!(
        stripe < 1e-6,
        "SUPG leaves {stripe:e} of the stripe's energy"
    );
    assert!(checker < 0.0, "SUPG's ⟨δJ, J̇⟩/|δJ|² = {checker:e}");
}

/// The stress points live in the lattice cells: a body off a lattice (the irregular
/// points of `plate-compression-2d`) is refused at set-up with the key, the particle and
/// the methods that run it.
#[test]
fn a_body_off_a_lattice_is_refused() {
    let case = crate::common::load("plate-compression-2d", &["method.name=supg-sph"]);
    let Err(e) = build_method::<D2, MixedSph<D2>>(&case) else {
        panic!("irregular points gave SUPG-SPH stress points");
    };
    let shown = e.to_string();
    for part in [
        "method.name",
        "`supg-sph`",
        "particle 0",
        "lattice",
        "`upwind-sph`",
    ] {
        assert!(shown.contains(part), "the error lacks {part:?}: {shown}");
    }
}

/// The stent's tube without its holes under SUPG-SPH, with the method line `keys`.
fn plain_tube(keys: &[&str]) -> Scene {
    let mut set = vec!["method.name=supg-sph", "body.0.holes=[]"];
    set.extend(keys);
    crate::common::load("stent", &set)
}

/// On a tube the stress points are the Gauss points of the cells of its cylindrical
/// lattice, between the centres of the cells the particles sit at, and of their images
/// across the three mirror planes. Kept on the eighth's side of the planes, they carry
/// the volume the cells span there: r from 9.625 to 9.875 mm (the two layers' radii), θ
/// from 0 to 90° and z from 0 to 9.875 mm (the last layer's centre). The cells are
/// trilinear, their faces chords of the arcs, so the points' weights sum to the chordal
/// volume, sin Δθ/Δθ = 1 − Δθ²/6 = 1 − 1.1e-4 of the sector's at Δθ = 90°/61: bound 3e-4.
#[test]
fn the_tube_s_stress_points_fill_its_cells_across_the_mirror_planes() {
    let case = plain_tube(&[]);
    let m: MixedSph<D3> = build_method(&case).unwrap();
    let (_, points) = m.stress_points().expect("SUPG-SPH has stress points");
    let (r0, r1, length) = (9.625e-3, 9.875e-3, 9.875e-3);
    let sector = 0.5 * (r1 * r1 - r0 * r0) * std::f64::consts::FRAC_PI_2 * length;
    let total: f64 = points.weight.iter().sum();
    let error = total / sector - 1.0;
    eprintln!("Σ w = {total:e} m³ against {sector:e} m³ ({error:.2e})");
    assert!(error.abs() < 3e-4, "Σ w / V − 1 = {error:e}");
}

/// An affine motion compatible with the three symmetric planes (diagonal G and A) adds
/// nothing on the tube, as on the box of `an_affine_motion_gets_no_stabilisation`: the
/// cells' functions are exact for linear fields on the curved lattice too. τ_p = 0 for
/// the free surfaces' unbalanced traction. Bounds as there: 1e-10 of |P|/Δx for D and of
/// |A| for Ḟ.
#[test]
fn an_affine_motion_gets_no_stabilisation_on_the_tube() {
    let case = plain_tube(&["method.supg={ tau_p = 0.0 }"]);
    let mut m: MixedSph<D3> = build_method(&case).unwrap();
    let diagonal = |d: [f64; 3]| glam::DMat3::from_diagonal(glam::DVec3::from(d));
    let (g, a) = (diagonal([0.02, -0.01, -0.03]), diagonal([3.0, 1.0, -2.0]));
    let y = affine(&m, g, a, glam::DVec3::ZERO);
    let (d, fluxes) = rates_and_fluxes(&mut m, &y);
    let p = m.first_piola(&y).unwrap();
    let force_scale = largest_t::<D3>(p) / case.spacing;
    let d_max = largest_v::<D3>(fluxes.d.iter().copied());
    assert!(
        d_max < 1e-10 * force_scale,
        "max |D| = {d_max:e} of {force_scale:e}"
    );
    let scale = D3::ddot(a, a).sqrt();
    let f_error = largest_t::<D3>(d.f.iter().map(|&f| f - a));
    assert!(f_error < 1e-10 * scale, "max |Ḟ − A| = {f_error:e}");
}
