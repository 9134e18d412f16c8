//! The spin of the Green–Naghdi rate, and the checks of the three objective rates
//! ([`super::ObjectiveRate`]) against their closed forms.

use crate::core::tensor::Dim;
use crate::physics::plasticity::{from_mat3, symmetric_eigen};
use glam::DMat3;

/// The spin Ω = Ṙ Rᵀ of the rotation R of F = R U while F changes at Ḟ = L F:
///
/// Ω = W − Σ_{i≠j} (λ_i − λ_j)/(λ_i + λ_j) (n_i · D n_j) n_i ⊗ n_j,
///
/// with λ_i² and n_i the eigenvalues and unit eigenvectors of B = F Fᵀ, W and D the skew
/// and symmetric parts of L. It follows from L = Ṙ Rᵀ + R U̇ U⁻¹ Rᵀ, whose skew part
/// gives Ω = W − R skew(U̇ U⁻¹) Rᵀ, with U̇ solving U U̇ + U̇ U = Ḟᵀ F + Fᵀ Ḟ in U's
/// eigenbasis. Equal stretches drop out, so F = I gives Ω = W. A 2D or 1D F is the block of
/// a 3D one whose other diagonal entries are 1 (and L's are 0).
pub fn rotation_spin<D: Dim>(f: D::T, l: D::T) -> D::T {
    let mut f3 = D::to3x3(f);
    for (k, row) in f3.iter_mut().enumerate().skip(D::N) {
        row[k] = 1.0;
    }
    let f3 = DMat3::from_cols_array_2d(&f3).transpose();
    let l3 = DMat3::from_cols_array_2d(&D::to3x3(l)).transpose();
    let (stretch2, n) = symmetric_eigen(f3 * f3.transpose());
    let stretch = stretch2.to_array().map(f64::sqrt);
    // D in the eigenbasis, n_i · D n_j.
    let d = n.transpose() * ((l3 + l3.transpose()) * 0.5) * n;
    let skew = DMat3::from_cols_array_2d(&std::array::from_fn(|j| {
        std::array::from_fn(|i| {
            let (a, b) = (stretch[i], stretch[j]);
            (a - b) / (a + b) * d.col(j)[i]
        })
    }));
    let w = (l3 - l3.transpose()) * 0.5;
    from_mat3::<D>(w - n * skew * n.transpose())
}

#[cfg(test)]
mod tests {
    use super::super::{Material, MaterialModel, MaterialSpec, ObjectiveRate};
    use super::*;
    use crate::core::tensor::{D2, D3};
    use glam::{DMat2, DVec3};

    const RATES: [ObjectiveRate; 3] = [
        ObjectiveRate::Jaumann,
        ObjectiveRate::GreenNaghdi,
        ObjectiveRate::Truesdell,
    ];

    fn material(rate: ObjectiveRate) -> Material {
        Material::new(&MaterialSpec {
            objective_rate: Some(rate),
            ..MaterialSpec::elastic(MaterialModel::Hypoelastic, 1000.0, 2.5, 0.25)
        })
    }

    /// The largest magnitude of a 2D tensor's entries.
    fn largest(t: DMat2) -> f64 {
        t.to_cols_array().iter().fold(0.0, |m, x| x.abs().max(m))
    }

    /// S(t) of Ṡ = rate(t, S) by classical RK4 in n steps from S(0) = s0.
    fn integrate<T>(s0: T, t: f64, n: usize, rate: impl Fn(f64, T) -> T) -> T
    where
        T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
    {
        let h = t / n as f64;
        (0..n).fold(s0, |s, k| {
            let t = k as f64 * h;
            let k1 = rate(t, s);
            let k2 = rate(t + 0.5 * h, s + k1 * (0.5 * h));
            let k3 = rate(t + 0.5 * h, s + k2 * (0.5 * h));
            let k4 = rate(t + h, s + k3 * h);
            s + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0)
        })
    }

    #[test]
    fn a_rigid_rotation_rotates_the_stress_with_the_body_under_every_rate() {
        // L = W constant spins the body, F(t) = Q(t) = exp(t W); an objective rate leaves
        // S(t) = Q S0 Qᵀ: no stress change in the body's frame. RK4 in 1000 steps over one
        // radian errs by ~1e-13 of |S0|; bound 1e-10.
        let s0 = DMat3::from_cols_array(&[2.0, 0.7, -0.3, 0.7, -1.5, 0.4, -0.3, 0.4, -0.5]);
        let axis = DVec3::new(1.0, -2.0, 0.5).normalize();
        let w = DMat3::from_cols_array_2d(&[
            [0.0, axis.z, -axis.y],
            [-axis.z, 0.0, axis.x],
            [axis.y, -axis.x, 0.0],
        ]);
        for rate in RATES {
            let m = material(rate);
            let q = |t: f64| DMat3::from_axis_angle(axis, t);
            let s = integrate(s0, 1.0, 1000, |t, s| m.stress_rate::<D3>(s, w, q(t)));
            let exact = q(1.0) * s0 * q(1.0).transpose();
            let err = (s - exact).to_cols_array().map(f64::abs);
            assert!(
                err.iter().all(|&e| e < 1e-10),
                "{rate:?}: S = {s}, Q S0 Qᵀ = {exact}"
            );
            // In 2D about z, through the same code.
            let s0 = DMat2::from_cols_array(&[2.0, 0.7, 0.7, -1.5]);
            let w2 = DMat2::from_cols_array(&[0.0, 1.0, -1.0, 0.0]);
            let q2 = |t: f64| DMat2::from_angle(t);
            let s = integrate(s0, 1.0, 1000, |t, s| m.stress_rate::<D2>(s, w2, q2(t)));
            let exact = q2(1.0) * s0 * q2(1.0).transpose();
            assert!(largest(s - exact) < 1e-10, "{rate:?} in 2D: {s}");
        }
    }

    /// S(γ) under simple shear x = X + γ Y at unit rate from S = 0, in 2D and in 3D.
    fn sheared(rate: ObjectiveRate, gamma: f64) -> [[f64; 3]; 2] {
        let m = material(rate);
        let n = 4000;
        let l2 = DMat2::from_cols_array(&[0.0, 0.0, 1.0, 0.0]);
        let f2 = |g: f64| DMat2::from_cols_array(&[1.0, 0.0, g, 1.0]);
        let s2 = integrate(DMat2::ZERO, gamma, n, |g, s| {
            m.stress_rate::<D2>(s, l2, f2(g))
        });
        let l3 = DMat3::from_cols_array(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let f3 = |g: f64| DMat3::IDENTITY + l3 * g;
        let s3 = integrate(DMat3::ZERO, gamma, n, |g, s| {
            m.stress_rate::<D3>(s, l3, f3(g))
        });
        assert!(s3.z_axis.abs().max_element() < 1e-12, "{rate:?}: S_iz = 0");
        [
            [s2.x_axis.x, s2.y_axis.y, s2.y_axis.x],
            [s3.x_axis.x, s3.y_axis.y, s3.y_axis.x],
        ]
    }

    #[test]
    fn simple_shear_follows_the_closed_form_of_each_rate() {
        // (S_xx, S_yy, S_xy)/μ at shear γ:
        // - Jaumann: (1 − cos γ, cos γ − 1, sin γ), the oscillation;
        // - Green–Naghdi (Dienes 1979, tan β = γ/2): S_xx = −S_yy = 4μ[cos 2β ln cos β +
        //   β sin 2β − sin²β], S_xy = 2μ cos 2β [2β − 2 tan 2β ln cos β − tan β], monotone;
        // - Truesdell: (γ², 0, γ).
        // RK4 in 4000 steps to γ = 10 errs by ~1e-12 μ; bound 1e-8 μ.
        let mu = material(ObjectiveRate::Jaumann).mu;
        for gamma in [0.5, 2.0, 6.0, 10.0] {
            let beta = (gamma / 2.0_f64).atan();
            let (c2, ln_c) = ((2.0 * beta).cos(), beta.cos().ln());
            let gn_xx = 4.0 * (c2 * ln_c + beta * (2.0 * beta).sin() - beta.sin().powi(2));
            let gn_xy = 2.0 * c2 * (2.0 * beta - 2.0 * (2.0 * beta).tan() * ln_c - beta.tan());
            let expected = [
                [1.0 - gamma.cos(), gamma.cos() - 1.0, gamma.sin()],
                [gn_xx, -gn_xx, gn_xy],
                [gamma * gamma, 0.0, gamma],
            ];
            for (rate, exact) in RATES.into_iter().zip(expected) {
                for (dim, s) in sheared(rate, gamma).into_iter().enumerate() {
                    for (got, want) in s.into_iter().zip(exact) {
                        assert!(
                            (got / mu - want).abs() < 1e-8,
                            "{rate:?} ({}D) at γ = {gamma}: S/μ = {s:?}, closed form {exact:?}",
                            dim + 2
                        );
                    }
                }
            }
        }
        // Green–Naghdi's shear stress grows monotonically where Jaumann's turns back.
        let gn = |g| sheared(ObjectiveRate::GreenNaghdi, g)[0][2];
        assert!(gn(6.0) > gn(2.0) && gn(10.0) > gn(6.0));
    }

    #[test]
    fn the_2d_spin_is_the_rate_of_the_polar_angle() {
        // In 2D, R is the rotation by θ = atan2(F_yx − F_xy, F_xx + F_yy), so Ω_yx = θ̇ =
        // (a ḃ − b ȧ)/(a² + b²) with a = F_xx + F_yy, b = F_yx − F_xy, Ḟ = L F: a closed form
        // that does not go through the eigenvectors. Round-off bound 1e-12.
        let f = DMat2::from_cols_array(&[1.3, -0.4, 0.9, 0.7]);
        let l = DMat2::from_cols_array(&[0.2, -1.1, 0.6, -0.5]);
        let f_dot = l * f;
        let (a, b) = (f.x_axis.x + f.y_axis.y, f.x_axis.y - f.y_axis.x);
        let (a_dot, b_dot) = (
            f_dot.x_axis.x + f_dot.y_axis.y,
            f_dot.x_axis.y - f_dot.y_axis.x,
        );
        let theta_dot = (a * b_dot - b * a_dot) / (a * a + b * b);
        let omega = rotation_spin::<D2>(f, l);
        let exact = DMat2::from_cols_array(&[0.0, theta_dot, -theta_dot, 0.0]);
        assert!(
            largest(omega - exact) < 1e-12,
            "Ω = {omega}, θ̇ = {theta_dot}"
        );
    }

    #[test]
    fn the_truesdell_out_of_plane_stress_follows_the_density() {
        // 3D under a constant plane-strain L (L_iz = L_zi = 0), where ρ̇ = −ρ tr L gives
        // ρ = ρ0 exp(−t tr L): S_zz of the 3D integration is the 2D model's
        // (2μ/3)(ρ/ρ0 − 1), which the 2D model does not integrate. RK4 in 2000 steps:
        // ~1e-13 of μ; bound 1e-9 of μ.
        let m = material(ObjectiveRate::Truesdell);
        let l = DMat3::from_cols_array(&[-0.3, 0.2, 0.0, 0.5, 0.1, 0.0, 0.0, 0.0, 0.0]);
        // Truesdell's rate does not read F.
        let s = integrate(DMat3::ZERO, 1.0, 2000, |_, s| {
            m.stress_rate::<D3>(s, l, DMat3::IDENTITY)
        });
        let rho = m.rho0 * (-D3::trace(l)).exp();
        let expected = m.plane_strain_szz::<D2>(DMat2::ZERO, rho);
        let szz = s.z_axis.z;
        assert!(
            (szz - expected).abs() < 1e-9 * m.mu,
            "S_zz = {szz}, 2D: {expected}"
        );
        assert!(szz.abs() > 1e-2 * m.mu, "the test compresses: S_zz = {szz}");
    }
}
