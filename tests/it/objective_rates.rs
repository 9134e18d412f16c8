//! The Green–Naghdi and Truesdell rates on the GPU against the f64 CPU reference, on the
//! three families that integrate the rate model: the updated-Lagrangian SPH core (on a
//! state whose F stretches and turns, so that the Green–Naghdi spin differs from W),
//! TLSPH and the total-Lagrangian Galerkin points. The bounds are those of each family's
//! cross-check, whose Jaumann rates they share the passes with. Their closed forms are
//! checked on the CPU (`physics::material::objective`) and through a method's rates
//! (`gray_monaghan::an_affine_velocity_gives_the_green_naghdi_and_truesdell_rates`).

use crate::common::{gpu, load, noise};
use crate::galerkin::block;
use crate::gpu_ul::{GRAY_MONAGHAN_KEYS, compare_edited_rates};
use meshless::core::tensor::{D2, D3};
use meshless::gpu::layout::GpuDim;
use meshless::methods::gray_monaghan::system::Scheme as GmScheme;
use meshless::physics::material::ObjectiveRate;
use meshless::scene::Scene;

const RATES: [ObjectiveRate; 2] = [ObjectiveRate::GreenNaghdi, ObjectiveRate::Truesdell];

fn with_rate(mut case: Scene, rate: ObjectiveRate) -> Scene {
    case.material.objective_rate = Some(rate);
    case
}

/// Gray–Monaghan's rates with F = I + 0.3 × noise at every particle (stretches of ±30 %
/// and turns, det F > 0).
fn compare_strained<D: GpuDim>(max: &[f64], rate: ObjectiveRate) {
    let keys = format!("correction = \"randles-libersky\"\n{GRAY_MONAGHAN_KEYS}");
    let case = with_rate(
        crate::common::block_case(max, "hypoelastic", "gray-monaghan-sph", &keys),
        rate,
    );
    let mut seed = 23;
    compare_edited_rates::<D, GmScheme>(&case, gpu(), |y| {
        for f in &mut y.f {
            let noise: Vec<f64> = (0..D::N * D::N).map(|_| 0.3 * noise(&mut seed)).collect();
            let mut h = D::zero_t();
            for (k, &e) in noise.iter().enumerate() {
                let unit = |c: usize| {
                    let mut v = vec![0.0; D::N];
                    v[c] = 1.0;
                    D::from_slice(&v)
                };
                h += D::outer(unit(k / D::N), unit(k % D::N)) * e;
            }
            *f = D::identity() + h;
            assert!(D::det(*f) > 0.0);
        }
    });
}

#[test]
fn updated_lagrangian_objective_rates_match_the_cpu() {
    for rate in RATES {
        compare_strained::<D2>(&[1.0, 0.6], rate);
        compare_strained::<D3>(&[0.5, 0.4, 0.3], rate);
    }
}

#[test]
fn total_lagrangian_objective_rates_match_the_cpu() {
    for rate in RATES {
        // TLSPH's rotating disk after 0.05 rad (F a rotation and a small stretch).
        let disk = with_rate(load("rotating-disk", &["method.dt=5e-6"]), rate);
        crate::gpu_tlsph::compare_rates::<D2>(&disk, 200, 5e-6);
        // The Galerkin points on a random state (|F − I| ~ 1e-2).
        let fem = |max: &[f64]| with_rate(block(max, "hypoelastic", "tl-fem", ""), rate);
        crate::gpu_galerkin::compare_rates::<D2>(&fem(&[1.0, 0.6]));
        crate::gpu_galerkin::compare_rates::<D3>(&fem(&[0.4, 0.3, 0.3]));
    }
}
