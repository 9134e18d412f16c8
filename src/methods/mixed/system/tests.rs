use super::*;
use crate::core::tensor::{D2, D3};
use crate::methods::MethodSpec;
use crate::scene::{Scene, build_method};

/// A shipped case.
fn shipped(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(format!("{name}.toml"));
    Scene::load(&path, &[]).unwrap()
}

/// The driver's CFL step α Δx / signal speed of a case's lattice at rest with the
/// uniform stretch F = diag(s) (u = (F − I) X), against seed 002 eq 31 in closed form:
/// every particle has λ = λ_min = min s, so Δt = α min |F X_ab| λ_min / c_p over the
/// lattice bonds X_ab = Δx k (k integer, 0 < |X_ab| ≤ the kernel support). Then one
/// particle alone stretched to F = diag(s) at u = 0: its pairs with the nearest
/// neighbours give Δt = α Δx ½(λ_min + 1) / c_p, the pair average of eq 32 (a
/// per-particle λ²_min would give α Δx λ²_min / c_p). With C_p^Lin for every pair the
/// stretches drop out: λ is 1 in both. Round-off of the distances and the eigenvalue:
/// 1e-12.
fn check_stretched_step<D: Dim>(case: &Scene, s: [f64; 3], wave: CflWaveSpeed) {
    let mut case = case.clone();
    match &mut case.spec {
        MethodSpec::UpwindSph(s) => s.mixed.cfl_wave_speed = wave,
        MethodSpec::JstSph(s) => s.mixed.cfl_wave_speed = wave,
        _ => panic!("{} is not a mixed case", case.name),
    }
    let case = &case;
    let m: MixedSph<D> = build_method(case).unwrap();
    let (alpha, dx) = (case.method.cfl.unwrap(), case.spacing);
    let c_p = m.material.p_wave_speed();
    let axis = |k: usize| {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        D::from_slice(&e[..D::N])
    };
    let f = (0..D::N).fold(D::zero_t(), |f, k| f + D::outer(axis(k), axis(k)) * s[k]);
    let lambda_min = match wave {
        CflWaveSpeed::Pair => s[..D::N].iter().copied().fold(f64::INFINITY, f64::min),
        CflWaveSpeed::Linear => 1.0,
    };
    let step = |y: &MixedState<D>| alpha * dx / m.max_signal_speed(y);
    let check = |what: &str, dt: f64, exact: f64| {
        let deviation = (dt / exact - 1.0).abs();
        eprintln!(
            "{}D {what}, {wave:?}: Δt = {dt:e} s ({deviation:.1e} from eq 31)",
            D::N
        );
        assert!(
            deviation < 1e-12,
            "{}D {what}, {wave:?}: Δt = {dt:e} s, eq 31 gives {exact:e} s",
            D::N
        );
    };

    let mut y = m.initial_state();
    for a in 0..m.n {
        y.u[a] = f * m.x0[a] - m.x0[a];
        y.v[a] = D::zero();
        y.f[a] = f;
    }
    let support = case.kernel(D::N).support();
    let reach = (support / dx) as i64;
    let side = 2 * reach + 1;
    let shortest = (0..side.pow(D::N as u32))
        .filter_map(|cell| {
            let k: Vec<f64> = (0..D::N as u32)
                .map(|l| (cell / side.pow(l) % side - reach) as f64 * dx)
                .collect();
            let x_ab = D::from_slice(&k);
            let r0 = D::norm2(x_ab).sqrt();
            (r0 > 0.0 && r0 <= support).then(|| D::norm2(f * x_ab).sqrt())
        })
        .fold(f64::INFINITY, f64::min);
    check(
        "uniform stretch",
        step(&y),
        alpha * shortest * lambda_min / c_p,
    );

    let mut y = m.initial_state();
    y.v.fill(D::zero());
    y.f[m.n / 2] = f;
    check(
        "one stretched particle",
        step(&y),
        alpha * dx * 0.5 * (lambda_min + 1.0) / c_p,
    );
}

#[test]
fn the_cfl_step_is_the_shortest_pair_crossing_of_eq_31() {
    for wave in [CflWaveSpeed::Pair, CflWaveSpeed::Linear] {
        check_stretched_step::<D2>(&shipped("spinning-plate"), [1.3, 0.7, 1.0], wave);
        check_stretched_step::<D3>(&shipped("pulling-column"), [0.8, 1.5, 0.6], wave);
    }
}
