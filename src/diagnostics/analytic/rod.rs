//! d'Alembert's rod: the 1D wave in an unbounded rod, between free ends, and from a
//! driven end; the bar speed of a longitudinal wave.

use crate::physics::material::Material;

/// d'Alembert's solution of the 1D wave equation ρ0 ∂v/∂t = ∂σ/∂s, ∂σ/∂t = ρ0 c² ∂v/∂s
/// from an initial velocity g(s) and no initial stress:
///
///   v(s, t) = ½[ĝ(s − ct) + ĝ(s + ct)],   σ(s, t) = ½ ρ0 c [ĝ(s + ct) − ĝ(s − ct)].
///
/// Unbounded (`ends = None`), ĝ = g. Between free ends a < b (σ = 0 there), ĝ is the even,
/// 2(b − a)-periodic extension of g about both ends: a free end reflects the velocity
/// with its sign kept and the stress with its sign reversed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rod {
    /// c [m/s].
    pub wave_speed: f64,
    /// ρ0 [kg/m³].
    pub density: f64,
    /// The free ends [a, b], if any.
    pub ends: Option<[f64; 2]>,
}

impl Rod {
    /// The point of [a, b] that s folds onto, so that ĝ(s) = g(fold(s)).
    pub fn fold(&self, s: f64) -> f64 {
        let Some([a, b]) = self.ends else {
            return s;
        };
        let l = b - a;
        let r = (s - a).rem_euclid(2.0 * l);
        a + if r > l { 2.0 * l - r } else { r }
    }

    /// v(s, t) for the initial velocity g.
    pub fn velocity(&self, g: impl Fn(f64) -> f64, s: f64, t: f64) -> f64 {
        let ct = self.wave_speed * t;
        0.5 * (g(self.fold(s - ct)) + g(self.fold(s + ct)))
    }

    /// σ(s, t) for the initial velocity g (small strain: the axial stress, P = σ).
    pub fn stress(&self, g: impl Fn(f64) -> f64, s: f64, t: f64) -> f64 {
        let ct = self.wave_speed * t;
        0.5 * self.density * self.wave_speed * (g(self.fold(s + ct)) - g(self.fold(s - ct)))
    }
}

/// The rod at rest whose end a is driven at velocity V from t = 0 to the release t_p and
/// free after, the end b free (seed 001 §9.2 case A; c t_p ≤ L = b − a, so the pulse has
/// left the driven end before it returns). With f the 2L-periodic function equal to V on
/// (a − c t_p, a) modulo 2L and 0 elsewhere:
///
///   v(s, t) = f(s − ct) + H(t − t_p) f(2a − s − ct),
///   σ(s, t) = ρ0 c [H(t − t_p) f(2a − s − ct) − f(s − ct)].
///
/// While driven (t < t_p) only the right-running wave f(s − ct) is in the rod: V on
/// (a, a + ct), 0 ahead, the end keeping v = V. From the release both ends are free,
/// where d'Alembert's v = F(s − ct) + G(s + ct) needs σ = ρ0 c (G − F) = 0: G(a + ct) =
/// F(a − ct), so G(ξ) = F(2a − ξ), and F(b − ct) = F(2a − b − ct), so F is 2L-periodic;
/// F = f matches the state at t_p, where f(2a − s − ct_p) vanishes on (a, b). The image
/// term is the wave the free end reflects with its velocity sign kept (and its stress
/// sign reversed). A right-running wave carries σ = −ρ0 c v: compression behind a pushed
/// end. Momentum ρ0 V c min(t, t_p) per unit area, energy ρ0 V² c min(t, t_p), half of it
/// kinetic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrivenEnd {
    /// V [m/s].
    pub amplitude: f64,
    /// t_p [s].
    pub duration: f64,
}

impl Rod {
    /// f(ξ) of [`DrivenEnd`]: V on (a − c t_p, a) modulo 2L.
    fn driven_profile(&self, end: DrivenEnd, xi: f64) -> f64 {
        let [a, b] = self.ends.expect("a driven rod has ends");
        let length = self.wave_speed * end.duration;
        if (xi - (a - length)).rem_euclid(2.0 * (b - a)) < length {
            end.amplitude
        } else {
            0.0
        }
    }

    /// The right-running wave f(s − ct) and the image f(2a − s − ct) present from t_p.
    fn driven_waves(&self, end: DrivenEnd, s: f64, t: f64) -> (f64, f64) {
        let [a, _] = self.ends.expect("a driven rod has ends");
        let ct = self.wave_speed * t;
        let image = if t >= end.duration {
            self.driven_profile(end, 2.0 * a - s - ct)
        } else {
            0.0
        };
        (self.driven_profile(end, s - ct), image)
    }

    /// v(s, t) of the rod driven at its end a ([`DrivenEnd`]).
    pub fn driven(&self, end: DrivenEnd, s: f64, t: f64) -> f64 {
        let (right, image) = self.driven_waves(end, s, t);
        right + image
    }

    /// σ(s, t) of the rod driven at its end a ([`DrivenEnd`]).
    pub fn driven_stress(&self, end: DrivenEnd, s: f64, t: f64) -> f64 {
        let (right, image) = self.driven_waves(end, s, t);
        self.density * self.wave_speed * (image - right)
    }

    /// The distance from s to the nearest jump of the driven rod's v at time t: the jumps
    /// of f at a − c t_p and a (modulo 2L), carried by both waves.
    pub fn driven_front_distance(&self, end: DrivenEnd, s: f64, t: f64) -> f64 {
        let [a, b] = self.ends.expect("a driven rod has ends");
        let (ct, length, period) = (
            self.wave_speed * t,
            self.wave_speed * end.duration,
            2.0 * (b - a),
        );
        let mut jumps = vec![a - length + ct, a + ct];
        if t >= end.duration {
            // 2a − s − ct = ξ at s = 2a − ct − ξ.
            jumps.extend([a + length - ct, a - ct]);
        }
        jumps
            .into_iter()
            .map(|p| ((s - p + 0.5 * period).rem_euclid(period) - 0.5 * period).abs())
            .fold(f64::INFINITY, f64::min)
    }
}

/// The speed of a longitudinal wave in a bar with free lateral faces, long waves:
/// sqrt(E_bar/ρ0) with E_bar the modulus of uniaxial stress. In 3D E_bar = E =
/// μ(3λ + 2μ)/(λ + μ). In 2D E_bar = 4μ(λ + μ)/(λ + 2μ) with the model's in-plane λ: E in
/// plane stress, E/(1 − ν²) in plane strain (σ_zz holds ε_zz = 0). At ν = 0 every one of
/// them is sqrt(E/ρ0) = c_p, and the 1D solution is exact; at ν ≠ 0 the lateral inertia
/// makes the wave dispersive and this is its long-wave limit only.
pub fn bar_wave_speed(material: &Material, dim: usize) -> f64 {
    let (lambda, mu) = (material.lambda, material.mu);
    let modulus = if dim == 2 {
        4.0 * mu * (lambda + mu) / (lambda + 2.0 * mu)
    } else {
        mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu)
    };
    (modulus / material.rho0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnostics::analytic::relative_l2;
    use crate::physics::material::MaterialModel;
    use crate::physics::material::{MaterialSpec, Plane};

    /// Seed 001 §9.2's rod: L = 60 mm, c = sqrt(E/ρ0) of steel, a Gaussian of α = 0.025
    /// mm⁻² at x0 (m).
    const L: f64 = 0.06;
    const C: f64 = 5188.745216627708;
    const RHO: f64 = 7800.0;

    fn rod() -> Rod {
        Rod {
            wave_speed: C,
            density: RHO,
            ends: Some([0.0, L]),
        }
    }

    fn gaussian(x0: f64) -> impl Fn(f64) -> f64 {
        move |s: f64| (-((s - x0) / 6.324555320336759e-3).powi(2)).exp()
    }

    /// s = 0, …, L in n steps.
    fn grid(n: usize) -> impl Iterator<Item = f64> {
        (0..=n).map(move |k| L * k as f64 / n as f64)
    }

    #[test]
    fn folding_reflects_about_both_ends_with_period_2l() {
        let r = rod();
        // Inside the rod nothing moves; outside, mirror images about 0 and L, period 2L.
        // Bounds: round-off of rem_euclid on numbers of size L (1e-17 m).
        for (s, folded) in [
            (0.02, 0.02),
            (-0.02, 0.02),
            (0.07, 0.05),
            (0.12, 0.0),
            (0.13, 0.01),
            (-0.11, 0.01),
        ] {
            assert!(
                (r.fold(s) - folded).abs() < 1e-15,
                "fold({s}) = {}",
                r.fold(s)
            );
        }
        let free = Rod { ends: None, ..r };
        assert_eq!(free.fold(-0.3), -0.3);
    }

    #[test]
    fn the_pulse_re_forms_at_every_return() {
        // g symmetric about L/2 comes back at t = L/c and 2L/c; g off the centre comes back
        // mirrored, g(L − s), at L/c and as it was at 2L/c (the period). Only round-off of
        // fold and exp separates them: 1e-12 of the amplitude.
        let r = rod();
        for x0 in [0.5 * L, 0.02] {
            let g = gaussian(x0);
            for s in grid(600) {
                let first = r.velocity(&g, s, L / C);
                let second = r.velocity(&g, s, 2.0 * L / C);
                assert!(
                    (first - g(L - s)).abs() < 1e-12,
                    "x0 = {x0}, s = {s}: {first}"
                );
                assert!(
                    (second - g(s)).abs() < 1e-12,
                    "x0 = {x0}, s = {s}: {second}"
                );
            }
        }
        // Halfway to the first return the halves sit at the ends, each of half the peak
        // there, merged with their images into the full peak: v(0, L/2c) = g(L/2) = 1.
        let g = gaussian(0.5 * L);
        assert!((r.velocity(&g, 0.0, 0.5 * L / C) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn momentum_and_energy_stay_constant_and_the_ends_stay_free() {
        // ∫ρ0 v ds and ∫(½ρ0 v² + σ²/(2ρ0c²)) ds over [0, L] by the trapezoidal rule on
        // 24,000 intervals: g is smooth (its tails at the ends are 1e-10 of the peak and
        // the folds keep ĝ continuous), so the rule's error is far below the 1e-9 bound.
        let r = rod();
        let g = gaussian(0.021);
        let n = 24_000;
        let ds = L / n as f64;
        let integral = |f: &dyn Fn(f64) -> f64| {
            grid(n)
                .map(|s| if s == 0.0 || s == L { 0.5 } else { 1.0 } * f(s))
                .sum::<f64>()
                * ds
        };
        let energy = |t: f64| {
            integral(&|s| {
                let (v, sigma) = (r.velocity(&g, s, t), r.stress(&g, s, t));
                0.5 * RHO * v * v + sigma * sigma / (2.0 * RHO * C * C)
            })
        };
        let (p0, e0) = (integral(&|s| RHO * g(s)), energy(0.0));
        for t in [1.3e-6, 4.0e-6, 9.7e-6, 1.6e-5, 2.9e-5] {
            let p = integral(&|s| RHO * r.velocity(&g, s, t));
            assert!((p - p0).abs() < 1e-9 * p0, "t = {t}: momentum {p} vs {p0}");
            let e = energy(t);
            assert!((e - e0).abs() < 1e-9 * e0, "t = {t}: energy {e} vs {e0}");
            // σ = 0 at both ends (ĝ is even about them), up to the round-off of fold, 1e-17
            // m on a profile of slope ≤ 1/w: 1e-12 of the scale ρ0c.
            for end in [0.0, L] {
                let sigma = r.stress(&g, end, t);
                assert!(sigma.abs() < 1e-12 * RHO * C, "t = {t}: σ({end}) = {sigma}");
            }
        }
    }

    #[test]
    fn the_solution_satisfies_the_wave_equation() {
        // ρ0 ∂v/∂t = ∂σ/∂s and ∂σ/∂t = ρ0c² ∂v/∂s by central differences (step δ = 1 µm
        // and its time of flight): truncation ~(δ/w)²/6 = 4e-9 of the terms' scale ρ0c/w
        // (times c for the second), bound 1e-6.
        let r = rod();
        let g = gaussian(0.03);
        let (ds, t) = (1e-6, 7.1e-6);
        let dt = ds / C;
        for s in [0.004, 0.019, 0.033, 0.0571] {
            let v_t = (r.velocity(&g, s, t + dt) - r.velocity(&g, s, t - dt)) / (2.0 * dt);
            let sigma_s = (r.stress(&g, s + ds, t) - r.stress(&g, s - ds, t)) / (2.0 * ds);
            let sigma_t = (r.stress(&g, s, t + dt) - r.stress(&g, s, t - dt)) / (2.0 * dt);
            let v_s = (r.velocity(&g, s + ds, t) - r.velocity(&g, s - ds, t)) / (2.0 * ds);
            let scale = RHO * C / 6.3e-3;
            assert!((RHO * v_t - sigma_s).abs() < 1e-6 * scale, "s = {s}");
            assert!(
                (sigma_t - RHO * C * C * v_s).abs() < 1e-6 * scale * C * C,
                "s = {s}"
            );
        }
    }

    fn material(nu: f64, plane: Plane) -> Material {
        Material::new(&MaterialSpec {
            plane,
            ..MaterialSpec::elastic(MaterialModel::LinearElastic, RHO, 2.1e11, nu)
        })
    }

    #[test]
    fn bar_speed_is_sqrt_e_over_rho_at_nu_zero() {
        // The paper's c = sqrt(E/ρ) = 5188.7 m/s (seed 001 §9.2); in plane strain at ν ≠ 0
        // the bar modulus is E/(1 − ν²), in plane stress and 3D it is E. Round-off only.
        let c = (2.1e11f64 / RHO).sqrt();
        assert!((c - C).abs() < 1e-9);
        for dim in [2, 3] {
            let m = material(0.0, Plane::Strain);
            assert!((bar_wave_speed(&m, dim) - c).abs() < 1e-9 * c);
            assert!((m.p_wave_speed() - c).abs() < 1e-9 * c);
        }
        let nu: f64 = 0.3;
        let strain = bar_wave_speed(&material(nu, Plane::Strain), 2);
        assert!((strain - c / (1.0 - nu * nu).sqrt()).abs() < 1e-9 * c);
        let stress = bar_wave_speed(&material(nu, Plane::Stress), 2);
        assert!((stress - c).abs() < 1e-9 * c);
        assert!((bar_wave_speed(&material(nu, Plane::Strain), 3) - c).abs() < 1e-9 * c);
    }

    #[test]
    fn relative_l2_weights_by_volume() {
        // Two particles, volumes 1 and 3, one component: e² = (1·1 + 3·0)/(1·4 + 3·1).
        let e = relative_l2(&[1.0, 3.0], &[1.0, 1.0], &[2.0, 1.0]);
        assert!((e - (1.0f64 / 7.0).sqrt()).abs() < 1e-15);
        assert!(relative_l2(&[1.0], &[1.0, 2.0], &[1.0]).is_nan());
        assert!(relative_l2(&[1.0], &[1.0], &[0.0]).is_nan());
    }

    /// Case A of seed 001 §9.2: V = 50 m/s for t_p = 5.8 µs at the end s = 0.
    const DRIVEN: DrivenEnd = DrivenEnd {
        amplitude: 50.0,
        duration: 5.8e-6,
    };

    /// ∫ over [0, L] by the midpoint rule on n cells, whose cell edges the pulse's jumps
    /// fall between: its error is at most one cell at each jump, bounded by the caller.
    fn cells(n: usize, f: impl Fn(f64) -> f64) -> f64 {
        let ds = L / n as f64;
        (0..n).map(|k| f((k as f64 + 0.5) * ds)).sum::<f64>() * ds
    }

    #[test]
    fn the_driven_pulse_carries_the_impulse_and_work_of_the_end() {
        // Per unit area: the end pushes with σ = ρ0 c V at V for min(t, t_p), giving the
        // momentum ρ0 V c min(t, t_p) and the energy ρ0 V² c min(t, t_p) (half kinetic,
        // half strain; a pulse of c t_p = 30.1 mm). The midpoint rule on 240,000 cells
        // misses at most a cell (2.5e-7 m) at each of four jumps: 4e-5 of c t_p; bound 1e-4.
        let r = rod();
        let n = 240_000;
        for t in [2.1e-6f64, 5.7e-6, 8.0e-6, 1.4e-5, 2.0e-5, 2.6e-5, 4.2e-5] {
            let held = C * t.min(DRIVEN.duration);
            let p = cells(n, |s| RHO * r.driven(DRIVEN, s, t));
            let p_ex = RHO * DRIVEN.amplitude * held;
            assert!(
                (p - p_ex).abs() < 1e-4 * p_ex,
                "t = {t}: momentum {p} vs {p_ex}"
            );
            let kinetic = cells(n, |s| 0.5 * RHO * r.driven(DRIVEN, s, t).powi(2));
            let strain = cells(n, |s| {
                r.driven_stress(DRIVEN, s, t).powi(2) / (2.0 * RHO * C * C)
            });
            let e_ex = RHO * DRIVEN.amplitude.powi(2) * held;
            assert!(
                (kinetic + strain - e_ex).abs() < 1e-4 * e_ex,
                "t = {t}: energy"
            );
            // Half and half, but while a reflection overlaps the pulse with itself (the
            // strain cancels there): at 1.4e-5 s and 2.6e-5 s.
            if ![1.4e-5, 2.6e-5].contains(&t) {
                assert!(
                    (kinetic - strain).abs() < 1e-4 * e_ex,
                    "t = {t}: kinetic {kinetic}"
                );
            }
        }
    }

    #[test]
    fn the_driven_end_holds_v_and_the_free_ends_carry_no_stress() {
        // Exact values away from the jumps: v = V and σ = −ρ0 c V at the driven end while
        // driven; σ = 0 at both ends once free (and at the right end always).
        let r = rod();
        let (v, sigma) = (DRIVEN.amplitude, RHO * C * DRIVEN.amplitude);
        for t in [1e-7, 3.0e-6, 5.7e-6] {
            assert_eq!(r.driven(DRIVEN, 0.0, t), v);
            assert_eq!(r.driven_stress(DRIVEN, 0.0, t), -sigma);
            assert_eq!(r.driven_stress(DRIVEN, L, t), 0.0);
        }
        for t in [6.0e-6, 1.2e-5, 1.4e-5, 2.4e-5, 2.6e-5, 3.5e-5] {
            for end in [0.0, L] {
                assert_eq!(r.driven_stress(DRIVEN, end, t), 0.0, "t = {t}, s = {end}");
            }
        }
    }

    #[test]
    fn the_pulse_folds_about_the_free_ends_with_its_velocity_sign_kept() {
        // At t = 0.8, 1.8 and 2.8 L/c the pulse lies on (0.8L − c t_p, 0.8L) running right
        // (compression, σ = −ρ0 c V), on (0.2L, 0.2L + c t_p) running left after the right
        // end (tension, σ = +ρ0 c V), and on the first interval again running right after
        // the left end: V everywhere on it, 0 elsewhere, 1.5 mm from the jumps.
        let r = rod();
        let (v, sigma, length) = (
            DRIVEN.amplitude,
            RHO * C * DRIVEN.amplitude,
            C * DRIVEN.duration,
        );
        let period = L / C;
        for (t, (lo, hi), stress) in [
            (0.8 * period, (0.8 * L - length, 0.8 * L), -sigma),
            (1.8 * period, (0.2 * L, 0.2 * L + length), sigma),
            (2.8 * period, (0.8 * L - length, 0.8 * L), -sigma),
        ] {
            for s in grid(600) {
                let (inside, away) = (s > lo && s < hi, (s - lo).abs().min((s - hi).abs()));
                if away < 1.5e-3 {
                    continue;
                }
                let expected = if inside { (v, stress) } else { (0.0, 0.0) };
                let got = (r.driven(DRIVEN, s, t), r.driven_stress(DRIVEN, s, t));
                assert_eq!(got, expected, "t = {t}, s = {s}");
                // The jumps the observer measures from: lo and hi, nothing else.
                let d = r.driven_front_distance(DRIVEN, s, t);
                assert!((d - away).abs() < 1e-12, "t = {t}, s = {s}: {d} vs {away}");
            }
        }
        // While the pulse reflects at the right end (L/c < t < L/c + t_p) the incoming and
        // reflected halves overlap there: v = 2V and σ = 0 at the end.
        let t = period + 0.5 * DRIVEN.duration;
        assert_eq!(r.driven(DRIVEN, L - 1e-4, t), 2.0 * v);
        assert_eq!(r.driven_stress(DRIVEN, L - 1e-4, t), 0.0);
    }
}
