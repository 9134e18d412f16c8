//! The seed-000 tensile strip (§6.2): the updated-Lagrangian strong forms read as the
//! paper reads their failures (§9.1): without the tear criterion (`run.hourglass_limit`),
//! the strip parts under its grips' pull, Godunov SPH at the grips and Gray–Monaghan SPH
//! across its middle; and TLSPH's rate and state models pulled to failure (Fig. 4).

use crate::common::load;
use meshless::core::tensor::D2;
use meshless::methods::Method;
use meshless::methods::godunov::Godunov;
use meshless::methods::gray_monaghan::GrayMonaghan;
use meshless::methods::tlsph::Tlsph;
use meshless::run::Engine;

/// The lattice spacing of the strip.
const DX: f64 = 0.05;

/// The widest gap between the mean current x of adjacent lattice columns, and the X of
/// the column left of it.
fn widest_gap(x0: &[glam::DVec2], u: &[glam::DVec2]) -> (f64, f64) {
    let mut columns: Vec<(f64, f64, usize)> = Vec::new();
    for (x0, u) in x0.iter().zip(u) {
        match columns.iter_mut().find(|c| (c.0 - x0.x).abs() < 1e-9) {
            Some(c) => (c.1, c.2) = (c.1 + x0.x + u.x, c.2 + 1),
            None => columns.push((x0.x, x0.x + u.x, 1)),
        }
    }
    columns.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mean: Vec<(f64, f64)> = columns.iter().map(|c| (c.0, c.1 / c.2 as f64)).collect();
    mean.windows(2)
        .map(|w| (w[1].1 - w[0].1, w[0].0))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap()
}

#[test]
fn godunov_sph_parts_from_its_grips_as_the_paper_says() {
    // §9.1: "The Godunov algorithm immediately fails at the boundaries." Without the tear
    // criterion, at 8 ms (16 % extension) the strip has pulled away from a gripped column
    // (one a side): the widest gap is a grip's, more than twice the lattice's Δx (measured
    // 0.160 m; TLSPH's strip, which holds, has its widest at 0.059 m, 1.2 Δx, at 16 %).
    let case = load("tensile-strip-godunov", &["run.hourglass_limit="]);
    let mut e = meshless::scene::cpu_engine::<D2, Godunov<D2>>(&case).unwrap();
    e.advance(0.0, 1e-6, 8_000).unwrap();
    let (gap, at) = widest_gap(e.method.reference(), &e.y.u);
    assert!(gap > 2.0 * DX, "widest gap {gap} m, right of X = {at}");
    assert!(
        !(1e-9..0.95 - 1e-9).contains(&at),
        "widest gap {gap} m right of X = {at}, not at a grip"
    );
}

#[test]
fn gray_monaghan_sph_tears_across_its_middle() {
    // The paper: Gray–Monaghan "fails due to an oscillatory displacement mode" (Fig. 15).
    // Without the tear criterion, at 10 ms (20 % extension) the strip, whose three gripped
    // columns a side move together, has torn between its middle columns: the widest gap
    // lies within X = 0.3–0.7 and is more than twice Δx (measured 0.142 m right of X =
    // 0.55; below 1.5 Δx everywhere at 16 %).
    let case = load("tensile-strip-gray-monaghan", &["run.hourglass_limit="]);
    let mut e = meshless::scene::cpu_engine::<D2, GrayMonaghan<D2>>(&case).unwrap();
    e.advance(0.0, 1e-6, 10_000).unwrap();
    let (gap, at) = widest_gap(e.method.reference(), &e.y.u);
    assert!(gap > 2.0 * DX, "widest gap {gap} m, right of X = {at}");
    assert!(
        (0.3..=0.7).contains(&at),
        "widest gap {gap} m right of X = {at}, not in the middle"
    );
}

/// The time at which TLSPH's strip with material `model` fails when pulled on, within
/// 0.1 s (200 % extension).
fn failure_time(model: &str) -> Option<f64> {
    let model = format!("material.model={model}");
    let case = load("tensile-strip", &[model.as_str(), "run.end_time=0.1"]);
    let mut e = meshless::scene::cpu_engine::<D2, Tlsph<D2>>(&case).unwrap();
    let (dt, steps) = (1e-6, 100_000);
    match e.advance(0.0, dt, steps) {
        Ok(()) => None,
        Err(failed) => Some(f64::from(failed.completed) * dt),
    }
}

#[test]
#[ignore = "finding: docs/methods/tlsph.md, \"Fig. 4: the rate and the state model pulled to failure\""]
fn tlsph_s_state_model_fails_the_strip_40_percent_earlier() {
    // Seed 000 §2.2, Fig. 4: TLSPH on the strip with a state-based model "fails due to
    // excess oscillatory modes about 40 % earlier" than with the rate model. Here (the
    // shipped strip, plane strain) the rate model fails at 75.8 % extension and SVK at
    // 80.9 %: later, not earlier.
    let rate = failure_time("hypoelastic").expect("the rate model fails within 200 %");
    let state = failure_time("saint-venant-kirchhoff");
    assert!(
        state.is_some_and(|t| t <= 0.6 * rate),
        "the state model fails at {state:?} s, the rate model at {rate} s"
    );
}
