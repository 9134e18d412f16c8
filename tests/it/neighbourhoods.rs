//! The neighbourhood and smoothing-length algorithms of seed 000 §3.2 (eqs 60–64) and the
//! comparison of its Fig. 3 (`meshless neighbourhoods`, docs/methods/ul-neighbourhoods.md).

use crate::common::block_case;
use crate::gray_monaghan::rates;
use meshless::core::kernel::KernelKind;
use meshless::core::neighbour::Csr;
use meshless::core::neighbourhood::{
    Ellipse, PRIME_SPACE_TOLERANCE, continuity_smoothing_length, density_smoothing_length,
    prime_space,
};
use meshless::core::tensor::{D2, D3, Dim};
use meshless::methods::Method;
use meshless::methods::cores::ul::{H_CAP, PRIME_SPACE_REACH};
use meshless::methods::gray_monaghan::GrayMonaghan;
use meshless::run::build_method;
use meshless::study::neighbourhoods::{MOTIONS, Neighbourhood, compare, motion_anisotropy};

/// A cubic lattice of spacing `s` (13 points a side), as offsets from its centre with unit
/// masses.
fn lattice<D: Dim>(s: f64) -> Vec<(D::V, f64)> {
    let side: Vec<f64> = (-6..=6).map(|k| s * f64::from(k)).collect();
    let mut out = Vec::new();
    for &x in &side {
        for &y in &side {
            if D::N == 2 {
                out.push((D::from_slice(&[x, y]), 1.0));
            } else {
                for &z in &side {
                    out.push((D::from_slice(&[x, y, z]), 1.0));
                }
            }
        }
    }
    out
}

fn uniform_compression_scales_h<D: Dim>() {
    // x = s X scales every kernel sum as W(s r; s h) = s^(−d) W(r; h), so the fixed point
    // of eqs 60–61 is h(s) = s h(1) and ⟨ρ⟩ = s^(−d) ⟨ρ⟩(1): h ∝ ρ^(−1/d) exactly. The fixed
    // point stops at 1e-12 of h; the bound leaves 100 times that. The continuity update of
    // eq 62 with ρ = ρ0 s^(−d) gives the same h.
    let h_of = |s: f64| {
        let candidates = lattice::<D>(s);
        density_smoothing_length::<D>(
            candidates.iter().copied(),
            1.0,
            1.3,
            KernelKind::CubicSpline,
            1.0,
            f64::INFINITY,
        )
        .unwrap()
    };
    let h1 = h_of(1.0);
    for s in [0.5, 0.8, 1.25] {
        let h = h_of(s);
        assert!(
            (h / h1 - s).abs() < 1e-10,
            "{}D: h({s})/h(1) = {}",
            D::N,
            h / h1
        );
        let rho = s.powi(-(D::N as i32));
        let continuity = continuity_smoothing_length(h1, 1.0, rho, D::N);
        assert!((continuity / h1 - s).abs() < 1e-14, "{}D continuity", D::N);
    }
}

#[test]
fn a_uniformly_compressed_block_gives_h_proportional_to_rho_to_the_minus_one_over_d() {
    uniform_compression_scales_h::<D2>();
    uniform_compression_scales_h::<D3>();
}

#[test]
fn the_ellipse_keeps_its_candidates_under_any_affine_motion() {
    // x_ijᵀ C⁻¹ x_ij is invariant under x → F x (C → F C Fᵀ): the same candidates lie
    // inside, so the neighbourhood follows any homogeneous deformation exactly.
    let boxed: Vec<glam::DVec2> = lattice::<D2>(1.0)
        .into_iter()
        .map(|(r, _)| r)
        .filter(|r| r.x.abs() <= 3.0 && r.y.abs() <= 3.0)
        .collect();
    let inside = |f: glam::DMat2| -> Vec<bool> {
        let moved: Vec<glam::DVec2> = boxed.iter().map(|&r| f * r).collect();
        let e = Ellipse::<D2>::new(&moved).unwrap();
        moved.iter().map(|&r| e.contains(r)).collect()
    };
    let reference = inside(glam::DMat2::IDENTITY);
    for f in [[1.0, 0.0, 0.7, 1.0], [2.0, 0.3, -0.4, 0.6]] {
        assert_eq!(
            inside(glam::DMat2::from_cols_array(&f)),
            reference,
            "F = {f:?}"
        );
    }
}

fn find<'a>(rows: &'a [Neighbourhood], motion: &str, algorithm: &str) -> &'a Neighbourhood {
    rows.iter()
        .find(|r| r.motion == motion && r.algorithm == algorithm)
        .unwrap()
}

#[test]
fn figure_3_the_isotropic_algorithms_take_neighbours_the_others_do_not() {
    // Seed 000 §3.2: "the two classical approaches identify an excess number of neighbours
    // due to the isotropic expansion of the neighbourhood", and "some additional neighbours
    // are identified by the ellipse fit" against the prime space. Excess: neighbours that
    // were not the same algorithm's in the initial state (they come in along the
    // compressed direction); the prime space and the ellipse take none. Counts are exact
    // integers on the lattice.
    let rows = compare();
    for motion in ["shear", "tension"] {
        for classical in ["density", "continuity"] {
            let r = find(&rows, motion, classical);
            assert!(r.gained > 0, "{motion} {classical}: none gained");
        }
        for anisotropic in ["prime-space", "ellipse"] {
            assert_eq!(
                find(&rows, motion, anisotropic).gained,
                0,
                "{motion} {anisotropic}"
            );
        }
        let (prime, ellipse) = (
            find(&rows, motion, "prime-space"),
            find(&rows, motion, "ellipse"),
        );
        assert!(
            prime.count() < ellipse.count(),
            "{motion}: the prime space is not sparser"
        );
        // The ellipse follows the motion's stretch ratio exactly (affine invariance).
        let f = MOTIONS.iter().find(|m| m.0 == motion).unwrap().1;
        assert!(
            (ellipse.anisotropy() - motion_anisotropy(f)).abs() < 1e-9,
            "{motion}"
        );
    }
}

#[test]
#[ignore = "finding: docs/methods/ul-neighbourhoods.md"]
fn figure_3_the_prime_space_is_not_symmetric_under_shear() {
    // The paper: "the neighbourhood in the shear case identified by the prime space
    // algorithm is not symmetric about the query point". On a candidate set symmetric
    // about the particle (a lattice under an affine motion) the images' convex hull is
    // symmetric too, and so is its neighbourhood: asymmetry 0.
    let rows = compare();
    let a = find(&rows, "shear", "prime-space").asymmetry();
    assert!(a > 0.05, "prime space under shear: asymmetry {a}");
}

#[test]
#[ignore = "finding: docs/methods/ul-neighbourhoods.md"]
fn figure_3_the_prime_space_follows_the_tension_more_closely_than_the_ellipse() {
    // The paper: in tension "the prime space algorithm follows the anisotropy of the
    // deformation more closely". The ellipse keeps the same candidates under any affine
    // motion, so its stretch ratio is the motion's exactly (4); the prime space keeps the
    // 3×3 stencil, whose ratio is 4 too: a tie, not closer.
    let rows = compare();
    let f = MOTIONS[2].1;
    let off = |a: &str| (find(&rows, "tension", a).anisotropy() - motion_anisotropy(f)).abs();
    assert!(
        off("prime-space") < off("ellipse"),
        "prime {} ellipse {}",
        off("prime-space"),
        off("ellipse")
    );
}

/// The smoothing lengths of `gray-monaghan-sph` with `smoothing_length = mode` on a block
/// (Δx = 0.1, h = 1.3Δx) scaled uniformly by s about the origin, x = s X with ρ = ρ0 s^(−d),
/// after one rate evaluation; and the lists, with whether they then hold every pair within
/// the support of its kernel.
fn scaled_block_lengths<D: Dim>(mode: &str, s: f64) -> (Vec<f64>, Csr, bool) {
    let max = vec![0.8; D::N];
    let key = format!("smoothing_length = \"{mode}\"");
    let case = block_case(&max, "hypoelastic", "gray-monaghan-sph", &key);
    let mut m: GrayMonaghan<D> = build_method(&case).unwrap();
    let mut y = m.initial_state();
    for (i, &x0) in m.reference().iter().enumerate() {
        y.u[i] = x0 * (s - 1.0);
        y.rho[i] *= s.powi(-(D::N as i32));
    }
    rates(&mut m, &y);
    let core = &m.core;
    let n = y.u.len();
    let h: Vec<f64> = (0..n).map(|i| core.h(i)).collect();
    let complete = (0..n).all(|i| {
        let listed = core.neighbours().neighbours(i);
        (0..n).filter(|&j| j != i).all(|j| {
            let r = D::norm2(core.x[i] - core.x[j]).sqrt();
            r >= core.pair_kernel(i, j).support() || listed.contains(&(j as u32))
        })
    });
    (h, core.neighbours().clone(), complete)
}

fn adaptive_lengths_scale_with_the_block<D: Dim>() {
    // x = s X scales every kernel sum of eqs 60–61 as ρ does, at every particle (the faces
    // and corners too), so h_i(s) = s h_i(1) wherever h stays below its cap of 2h; the
    // fixed point stops at 1e-12 of h, and the bound leaves 100 times that. Eq 62 gives
    // h(s) = s h from ρ alone. Expanding by 1.3 moves every support past the lists built
    // for s = 1, so the lists must grow with h.
    let cap = H_CAP * 0.13;
    for mode in ["density", "continuity"] {
        let (h1, _, complete) = scaled_block_lengths::<D>(mode, 1.0);
        assert!(complete, "{}D {mode}: lists short at s = 1", D::N);
        if mode == "continuity" {
            assert!(h1.iter().all(|&h| (h - 0.13).abs() < 1e-15));
        }
        for s in [0.8, 1.3] {
            let (h, _, complete) = scaled_block_lengths::<D>(mode, s);
            assert!(complete, "{}D {mode}: lists short at s = {s}", D::N);
            let mut checked = 0;
            for (i, (&hs, &h1)) in h.iter().zip(&h1).enumerate() {
                if h1 * s < cap * (1.0 - 1e-9) {
                    checked += 1;
                    let ratio = hs / h1;
                    assert!(
                        (ratio - s).abs() < 1e-10,
                        "{}D {mode}: h_{i}({s})/h_{i}(1) = {ratio}",
                        D::N
                    );
                } else {
                    assert!(hs <= cap * (1.0 + 1e-12), "{}D {mode}: h_{i} = {hs}", D::N);
                }
            }
            assert!(
                checked > h.len() / 2,
                "{}D {mode}: {checked} uncapped",
                D::N
            );
        }
    }
}

#[test]
fn adaptive_smoothing_lengths_scale_with_a_uniformly_scaled_block() {
    adaptive_lengths_scale_with_the_block::<D2>();
    adaptive_lengths_scale_with_the_block::<D3>();
}

#[test]
fn the_prime_space_of_a_lattice_is_its_stencil_at_any_angle() {
    // eq 63 on the offsets (a, b)Δx, |a|, |b| ≤ 4, of a square lattice: the images
    // (a, b)/((a² + b²)Δx) lie inside the diamond |x'| + |y'| ≤ 1/Δx, on it exactly for
    // the eight of the 3×3 stencil (the diagonals mid-edge) and at least 0.35/Δx inside
    // for any other. Rotated by any angle and perturbed by 1e-6 Δx (positions in f32 far
    // from the origin), the choice stays the stencil: the diagonals, within 1e-6 of an
    // edge, are inside the tolerance of 1e-3; without it they would depend on rounding.
    let dx = 0.1;
    let mut seed = 3_u64;
    let mut noise = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for angle in [0.0_f64, 0.3, std::f64::consts::FRAC_PI_4, 2.0] {
        let (c, s) = (angle.cos(), angle.sin());
        let mut offsets = Vec::new();
        let mut stencil = Vec::new();
        for a in -4_i32..=4 {
            for b in -4_i32..=4 {
                if (a, b) == (0, 0) {
                    continue;
                }
                let (x, y) = (f64::from(a) * dx, f64::from(b) * dx);
                if a.abs().max(b.abs()) == 1 {
                    stencil.push(offsets.len());
                }
                offsets.push([
                    c * x - s * y + 1e-6 * dx * noise(),
                    s * x + c * y + 1e-6 * dx * noise(),
                ]);
            }
        }
        assert_eq!(prime_space(&offsets), stencil, "angle {angle}");
    }
    assert!(PRIME_SPACE_TOLERANCE > 1e-5 && PRIME_SPACE_TOLERANCE < 0.35 / 2f64.sqrt());
}

#[test]
fn prime_space_neighbourhoods_take_the_stencil_and_scale_with_the_block() {
    // `smoothing_length = "prime-space"` on the block (Δx = 0.1, h0 = 0.13): a particle off
    // the faces takes the eight of its 3×3 stencil (the lists are symmetric, and a face
    // particle takes no interior particle outside its stencil), so h_i = √2 Δx/(0.75 · 2),
    // the farthest at three quarters of the cubic spline's support. x = s X scales the
    // images by 1/s and the hull's tolerance with them: the same pairs and h_i(s) = s h_i(1)
    // there (1e-12 covers the rounding of x = s X). Face particles take every face
    // particle within the candidates' reach, 2 H_CAP h0 at any s, so theirs do not scale.
    let dx = 0.1;
    let (h1, lists1, _) = scaled_block_lengths::<D2>("prime-space", 1.0);
    let case = block_case(&[0.8, 0.8], "hypoelastic", "gray-monaghan-sph", "");
    let m: GrayMonaghan<D2> = build_method(&case).unwrap();
    let x0 = m.reference().to_vec();
    let inner = |i: usize| x0[i].min_element() > 1e-9 && x0[i].max_element() < 0.8 - 1e-9;
    let stencil = 2f64.sqrt() * dx / (PRIME_SPACE_REACH * 2.0);
    let mut checked = 0;
    for i in (0..x0.len()).filter(|&i| inner(i)) {
        let listed = lists1.neighbours(i);
        assert_eq!(listed.len(), 8, "particle {i} at {}", x0[i]);
        for &j in listed {
            let r = (x0[i] - x0[j as usize]).length();
            assert!(r < 2f64.sqrt() * dx * (1.0 + 1e-9), "{i}–{j} at {r}");
        }
        assert!(
            (h1[i] - stencil).abs() < 1e-12 * stencil,
            "h_{i} = {}",
            h1[i]
        );
        checked += 1;
    }
    assert!(checked >= 49, "{checked} particles off the faces");
    for s in [0.8, 1.3] {
        let (h, lists, _) = scaled_block_lengths::<D2>("prime-space", s);
        for i in (0..x0.len()).filter(|&i| inner(i)) {
            assert_eq!(lists.neighbours(i), lists1.neighbours(i), "s = {s}, {i}");
            let ratio = h[i] / h1[i];
            assert!((ratio - s).abs() < 1e-12, "h_{i}({s})/h_{i}(1) = {ratio}");
        }
        assert!(h.iter().all(|&h| h <= H_CAP * 0.13 * (1.0 + 1e-12)));
    }
}
