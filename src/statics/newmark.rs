//! Implicit time integration on the static path's residual and tangent (`run.solve =
//! "implicit"`): Newmark's average-acceleration rule (β = 1/4, γ = 1/2) and the HHT-α
//! method of Hilber, Hughes & Taylor (1977), of which it is the case α = 0.
//!
//! With the lumped masses M, the internal force f_int(u) (−∂Π/∂u for a hyperelastic
//! model) and the loads f_ext, a step of size Δt solves for u_{n+1}
//!
//! G(u_{n+1}) = (1 + α) f_int(u_{n+1}) − α f_int(u_n) + f_ext − M a_{n+1} = 0,
//!
//! a_{n+1} = (u_{n+1} − u_n − Δt v_n − Δt² (½ − β) a_n) / (β Δt²),
//! v_{n+1} = v_n + Δt [(1 − γ) a_n + γ a_{n+1}],
//!
//! with β = (1 − α)²/4 and γ = ½ − α, α in [−1/3, 0], by Newton's method on the tangent
//! −∂G/∂u = (1 + α) K + M/(β Δt²). α = 0 conserves the energy of a linear system exactly
//! and is second-order accurate; α < 0 damps the modes that the step does not resolve,
//! to the spectral radius (1 + α)/(1 − α) as ω Δt → ∞, and stays second order.

/// The HHT-α parameters of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Newmark {
    pub alpha: f64,
    pub beta: f64,
    pub gamma: f64,
}

impl Newmark {
    /// HHT-α with β = (1 − α)²/4 and γ = ½ − α; α = 0 is Newmark's average-acceleration
    /// (trapezoidal) rule.
    pub fn hht(alpha: f64) -> Self {
        Self {
            alpha,
            beta: (1.0 - alpha).powi(2) / 4.0,
            gamma: 0.5 - alpha,
        }
    }

    /// The spectral radius of the step's amplification as ω Δt → ∞, (1 + α)/(1 − α).
    pub fn high_frequency_radius(&self) -> f64 {
        (1.0 + self.alpha) / (1.0 - self.alpha)
    }

    /// a_{n+1} of the displacement u_{n+1} from the state (u_n, v_n, a_n) of one
    /// component.
    #[inline]
    pub fn acceleration(&self, dt: f64, u_next: f64, [u, v, a]: [f64; 3]) -> f64 {
        (u_next - u - dt * v - dt * dt * (0.5 - self.beta) * a) / (self.beta * dt * dt)
    }

    /// v_{n+1} from v_n, a_n and a_{n+1}.
    #[inline]
    pub fn velocity(&self, dt: f64, v: f64, a: f64, a_next: f64) -> f64 {
        v + dt * ((1.0 - self.gamma) * a + self.gamma * a_next)
    }

    /// The mass's factor in the tangent, 1/(β Δt²).
    pub fn mass_factor(&self, dt: f64) -> f64 {
        1.0 / (self.beta * dt * dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One step of size dt of the linear oscillator ü + ω² u = 0 (unit mass) from the
    /// state (u, v, a), solving G = 0 exactly (it is linear).
    fn step(scheme: Newmark, omega: f64, dt: f64, state: [f64; 3]) -> [f64; 3] {
        let (k, alpha, c) = (omega * omega, scheme.alpha, scheme.mass_factor(dt));
        // G(u) = −(1 + α) k u + α k u_n − a(u): linear in u, slope −((1 + α) k + c).
        let g0 = alpha * k * state[0] - scheme.acceleration(dt, 0.0, state);
        let u_next = g0 / ((1.0 + alpha) * k + c);
        let a_next = scheme.acceleration(dt, u_next, state);
        [
            u_next,
            scheme.velocity(dt, state[1], state[2], a_next),
            a_next,
        ]
    }

    /// The states after each of `steps` steps from (u0, v0) at rest's consistent a0.
    fn oscillate(
        scheme: Newmark,
        omega: f64,
        dt: f64,
        steps: usize,
        u0: f64,
        v0: f64,
    ) -> Vec<[f64; 3]> {
        let mut state = [u0, v0, -omega * omega * u0];
        (0..steps)
            .map(|_| {
                state = step(scheme, omega, dt, state);
                state
            })
            .collect()
    }

    #[test]
    fn the_average_acceleration_rule_conserves_a_linear_oscillators_energy() {
        // ½ m v² + ½ k u² is an invariant of the trapezoidal rule on a linear system, at
        // any step: round-off over 1,000 steps of ω Δt = 0.5 and of ω Δt = 50 (far past
        // an explicit method's limit of 2): 1e-12 relative.
        for omega_dt in [0.5, 50.0] {
            let (omega, dt) = (3.0, omega_dt / 3.0);
            let e = |[u, v, _]: [f64; 3]| 0.5 * v * v + 0.5 * omega * omega * u * u;
            let e0 = e([0.2, 0.7, 0.0]);
            let worst = oscillate(Newmark::hht(0.0), omega, dt, 1000, 0.2, 0.7)
                .into_iter()
                .map(|s| (e(s) / e0 - 1.0).abs())
                .fold(0.0, f64::max);
            assert!(
                worst < 1e-12,
                "ω Δt = {omega_dt}: |E/E0 − 1| up to {worst:e}"
            );
        }
    }

    #[test]
    fn newmark_and_hht_are_second_order_in_the_step() {
        // u(T/4) against cos(π/2) = 0 at a quarter period, where the error is the phase
        // error itself, halving Δt from T/80: the error falls by 4 per halving (order 2;
        // bound: slopes within 0.05 of 2), for α = 0, −0.1 and −0.3.
        let omega = 2.0;
        let quarter = std::f64::consts::PI / (2.0 * omega);
        for alpha in [0.0, -0.1, -0.3] {
            let error = |n: usize| {
                let s = oscillate(Newmark::hht(alpha), omega, quarter / n as f64, n, 1.0, 0.0);
                s[n - 1][0].abs()
            };
            let errors: Vec<f64> = [20, 40, 80, 160].map(error).to_vec();
            for pair in errors.windows(2) {
                let order = (pair[0] / pair[1]).log2();
                assert!(
                    (order - 2.0).abs() < 0.05,
                    "α = {alpha}: order {order} from {errors:?}"
                );
            }
        }
    }

    #[test]
    fn hht_damps_unresolved_modes_to_its_closed_form_radius() {
        // At ω Δt = 1e4 the mean decay per step of the state's size |(u, v/ω, a/ω²)| over
        // 4,000 steps (renormalised at each, after 100 that let the third root's transient
        // die) is the spectral radius (1 + α)/(1 − α) of the limit ω Δt → ∞: its
        // O((ω Δt)⁻²) correction is 1e-8, and the bounded wobble of the size along the
        // principal pair's rotation adds at most ln(20)/4000 < 1e-3; bound 1e-3. (At α =
        // −1/3 the three roots meet and the limit is approached far more slowly: 0.5017
        // at ω Δt = 1e4.) A resolved mode (ω Δt = 0.01) keeps its amplitude over a period
        // to O((ω Δt)²) = 1e-4.
        for alpha in [-0.05, -0.1, -0.2, -0.3] {
            let scheme = Newmark::hht(alpha);
            let norm = |[u, v, a]: [f64; 3]| (u * u + v * v + a * a).sqrt();
            let (omega, dt) = (1.0, 1e4);
            let (skip, steps) = (100, 4000);
            let mut state = [1.0, 0.0, -1.0];
            let mut log_decay = 0.0;
            for k in 0..skip + steps {
                let next = step(scheme, omega, dt, state);
                let scaled = next.map(|c| c / norm(next));
                if k >= skip {
                    log_decay += (norm(next) / norm(state)).ln();
                }
                state = scaled;
            }
            let rate = (log_decay / steps as f64).exp();
            let radius = scheme.high_frequency_radius();
            assert!(
                (rate - radius).abs() < 1e-3,
                "α = {alpha}: decay per step {rate}, closed form {radius}"
            );
            let n = (2.0 * std::f64::consts::PI / 0.01).round() as usize;
            let resolved = oscillate(scheme, omega, 0.01, n, 1.0, 0.0);
            let amplitude = |[u, v, _]: [f64; 3]| (u * u + v * v).sqrt();
            let kept = amplitude(resolved[n - 1]);
            assert!(
                (kept - 1.0).abs() < 1e-4,
                "α = {alpha}: resolved amplitude {kept}"
            );
        }
    }
}
