//! The material functions of the shaders against the f64 CPU models, point by point: a
//! test pass evaluates `pk1` and `energy_density` (`shaders/common/mechanics.wgsl`) and
//! the von Mises `return_map` (`shaders/physics/plasticity.wgsl`) on a set of deformation
//! gradients, from small strains to stretches of 2, compression to 0.6 and rotations.
//! The inputs are rounded to f32 first, so that both sides see the same F and what
//! differs is the device's f32 arithmetic alone.

use crate::common::{gpu, noise, random_tensor};
use meshless::case::MaterialSpec;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::Gpu;
use meshless::gpu::layout::{Flat, GpuDim};
use meshless::gpu::shaders::{Constants, EIGEN, MECHANICS, PLASTICITY, Source, compose};
use meshless::physics::material::{Material, MaterialModel};
use meshless::physics::plasticity::{Hardening, RateSensitivity, Thermal, VonMises};

/// P and W of each H = F − I in `h` (DIM² floats each, column-major): DIM² + 1 floats
/// out per point.
const ELASTIC: &str = r#"
@group(0) @binding(0) var<storage, read> h_in: array<f32>;
@group(0) @binding(1) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if k >= POINTS {
        return;
    }
    let h = mload_h_in(DIM * DIM * k);
    let f_inv_t = transpose(inverse_d(identity_d() + h));
    let o = (DIM * DIM + 1u) * k;
    mstore_out(o, pk1(h, f_inv_t));
    out[o + DIM * DIM] = energy_density(h, matd(), 0.0);
}
"#;

/// Algorithm 2 at each F (9 floats, column-major, in `f_in`) from the history of the same
/// index in `hist`: P (9), C_p⁻¹ (9), ε_p and ψ out, 20 floats per point.
const RETURN_MAP: &str = r#"
@group(0) @binding(0) var<storage, read> f_in: array<f32>;
@group(0) @binding(1) var<storage, read> hist: array<f32>;
@group(0) @binding(2) var<storage, read_write> out: array<f32>;

fn load3(k: u32) -> mat3x3<f32> {
    return mat3x3<f32>(
        vec3<f32>(f_in[k], f_in[k + 1u], f_in[k + 2u]),
        vec3<f32>(f_in[k + 3u], f_in[k + 4u], f_in[k + 5u]),
        vec3<f32>(f_in[k + 6u], f_in[k + 7u], f_in[k + 8u]),
    );
}

fn store3(k: u32, m: mat3x3<f32>) {
    for (var c = 0u; c < 3u; c++) {
        for (var r = 0u; r < 3u; r++) {
            out[k + 3u * c + r] = m[c][r];
        }
    }
}

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if k >= POINTS {
        return;
    }
    let r = return_map(load3(9u * k), history(k));
    store3(20u * k, r.p);
    store3(20u * k + 9u, r.cp_inv);
    out[20u * k + 18u] = r.eps_p;
    out[20u * k + 19u] = r.psi;
}
"#;

/// Runs the test pass `text` (composed in D with `constants` and POINTS = n) over n
/// points with the read-only inputs `inputs` (name, data) and returns `out` of `len`
/// floats.
fn run<D: GpuDim>(
    gpu: &Gpu,
    source: Source,
    constants: Constants,
    n: usize,
    inputs: &[(&str, &[f32])],
    len: usize,
) -> Vec<f32> {
    let text = compose::<D>(&source, &constants.u32("POINTS", n as u32));
    let pipeline = gpu.pipeline(source.name, &text, "main").unwrap();
    let buffers: Vec<(&str, wgpu::Buffer)> = inputs
        .iter()
        .map(|&(name, data)| (name, gpu.storage(name, data)))
        .collect();
    let out = gpu.zeroed("out", len as u64 * 4);
    let mut table: Vec<(&str, &wgpu::Buffer)> = buffers.iter().map(|(n, b)| (*n, b)).collect();
    table.push(("out", &out));
    let bind = gpu.bind(&pipeline, &table).unwrap();
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        gpu.dispatch(&mut pass, &pipeline, &bind, n as u32);
    }
    gpu.queue.submit([encoder.finish()]);
    gpu.read(&out)
}

/// A tensor whose entries are f32 values.
fn rounded<D: GpuDim>(t: D::T) -> D::T {
    let mut flat = Vec::new();
    D::push_t(&mut flat, t);
    D::read_t(&flat)
}

fn norm<D: Dim>(t: D::T) -> f64 {
    D::ddot(t, t).sqrt()
}

/// H = F − I of the test set in D: the identity, small strains (1e-4) with and without a
/// rotation of 1 rad, moderate ones (0.1, 0.3), a uniaxial stretch of 2, a biaxial
/// compression to 0.6 and a simple shear of 1; each rounded to f32.
fn strains<D: GpuDim>() -> Vec<D::T> {
    let mut seed = 11;
    let identity = D::identity();
    let along = |k: usize, s: f64| {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        let v = D::from_slice(&e);
        D::outer(v, v) * s
    };
    let mut rotation = D::identity();
    let (c, s) = (1f64.cos(), 1f64.sin());
    for (k, l, v) in [(0, 0, c - 1.0), (1, 1, c - 1.0), (0, 1, -s), (1, 0, s)] {
        let (mut ek, mut el) = ([0.0; 3], [0.0; 3]);
        ek[k] = 1.0;
        el[l] = 1.0;
        rotation += D::outer(D::from_slice(&ek), D::from_slice(&el)) * v;
    }
    let mut set = vec![D::zero_t()];
    for scale in [1e-4, 1e-4, 0.1, 0.3] {
        set.push(random_tensor::<D>(&mut seed, scale));
    }
    let small = identity + random_tensor::<D>(&mut seed, 1e-4);
    set.push(rotation * small - identity);
    set.push(along(0, 1.0));
    set.push(along(0, -0.4) + along(1, -0.4));
    set.push(D::outer(
        D::from_slice(&[1.0, 0.0, 0.0][..D::N]),
        D::from_slice(&[0.0, 1.0, 0.0][..D::N]),
    ));
    set.into_iter().map(rounded::<D>).collect()
}

/// An elastic material of E = 1e7 Pa, ν = 0.45, ρ0 = 1000 (the Mooney–Rivlin model with
/// the same linearisation).
fn material(model: MaterialModel) -> Material {
    let rubber = model == MaterialModel::MooneyRivlin;
    let (e, nu) = (1e7, 0.45);
    let (mu, bulk) = (e / (2.0 * (1.0 + nu)), e / (3.0 * (1.0 - 2.0 * nu)));
    Material::new(&MaterialSpec {
        youngs_modulus: (!rubber).then_some(e),
        poisson_ratio: (!rubber).then_some(nu),
        c1: rubber.then_some(0.9 * mu),
        c2: rubber.then_some(0.1 * mu),
        lambda: rubber.then_some(bulk / 2.0),
        ..MaterialSpec::elastic(model, 1000.0, e, nu)
    })
}

fn elastic_models_match<D: GpuDim>(gpu: &Gpu) {
    let hs = strains::<D>();
    let mut flat = Vec::new();
    for &h in &hs {
        D::push_t(&mut flat, h);
    }
    let source = Source {
        name: "test/elastic",
        text: ELASTIC,
        common: &[MECHANICS],
        flat: &[("h_in", false), ("out", true)],
    };
    let stride = D::N * D::N + 1;
    for model in MaterialModel::ALL {
        if model.is_rate_based() || model == MaterialModel::VonMisesPlastic {
            continue;
        }
        let m = material(model);
        let constants = Constants::default().material(&m);
        let mut worst = (0.0f64, 0.0f64);
        let out = run::<D>(
            gpu,
            source,
            constants,
            hs.len(),
            &[("h_in", &flat)],
            stride * hs.len(),
        );
        for (k, &h) in hs.iter().enumerate() {
            let f = D::identity() + h;
            let (p_cpu, w_cpu) = (m.pk1::<D>(f), m.energy_density::<D>(f, D::zero_t(), m.rho0));
            let p_gpu = D::read_t(&out[stride * k..]);
            let w_gpu = f64::from(out[stride * k + D::N * D::N]);
            // f32 carries 6e-8 relative; a model's stress is a few dozen operations on
            // terms of (λ + 2μ)|H|(1 + |H|)² (SVK's cubic growth, the others' smaller), each
            // rounded once: 1e-5 of that scale leaves a factor ~10 over 20 roundings
            // (measured: 2.5e-7 of it at most). The energy is second order, its terms (λ +
            // 2μ)|H|²(1 + |H|)², regrouped on the device so that no first-order term
            // cancels analytically; but q = (J − 1) − tr H is still a difference of two
            // first-order numbers, each rounded to ε_f32 |H|, weighted by μ ≤ λ + 2μ:
            // 1e-5 of the scale and 4 (λ + 2μ) ε_f32 |H| (measured: 1.2e-5 of the scale
            // at strains of 1e-4). At F = I the reference itself is f64 round-off of terms
            // of λ + 2μ (the polyconvex P(I) = −4.7e-10 Pa): 1e-14 (λ + 2μ) on P.
            let size = norm::<D>(h);
            let stiff = m.lambda + 2.0 * m.mu;
            let scale_p = stiff * size * (1.0 + size).powi(2);
            let (ep, ew) = (norm::<D>(p_gpu - p_cpu), (w_gpu - w_cpu).abs());
            if size > 0.0 {
                worst = (
                    worst.0.max(ep / scale_p),
                    worst.1.max(ew / (scale_p * size)),
                );
            }
            assert!(
                ep <= 1e-5 * scale_p + 1e-14 * stiff,
                "{model:?} {}D F = I + {h:?}: |ΔP| = {ep:e} of {scale_p:e} (P = {p_cpu:?})",
                D::N
            );
            assert!(
                ew <= (1e-5 * scale_p + 4.0 * stiff * f64::from(f32::EPSILON)) * size,
                "{model:?} {}D F = I + {h:?}: W {w_gpu:e} vs {w_cpu:e}",
                D::N
            );
        }
        eprintln!(
            "{model:?} {}D: largest |ΔP| {:.1e} and |ΔW| {:.1e} of their scales",
            D::N,
            worst.0,
            worst.1
        );
    }
}

#[test]
fn the_state_models_match_the_cpu_point_by_point() {
    let gpu = gpu();
    elastic_models_match::<D2>(&gpu);
    elastic_models_match::<D3>(&gpu);
}

#[test]
fn the_softening_and_johnson_cook_return_maps_match_the_cpu() {
    // The steel of seed 001 §9.5 (E = 2e11 Pa, ν = 0.3 (not given there), σ_Y(0) = 1e10
    // Pa, H = −E/10: the yield stress reaches zero at ε_p = 0.5), a hardening copper
    // (seed 003) and Johnson and Cook's OFHC copper (Johnson and Cook 1983, Table 1:
    // A = 90 MPa, B = 292 MPa, n = 0.31, C = 0.025, m = 1.09, T_m = 1356 K), from
    // histories that put the returns on both branches: virgin and elastic, virgin and
    // yielding, ε_p = 0.45 crossing ε_p = 0.5 within the return, and ε_p = 0.7 with
    // τ_y = 0; the Johnson–Cook points at a rise of 0 or 300 K over steps of 1e-8 s (rates
    // of 1e5–1e7 /s).
    let gpu = gpu();
    let (e, nu) = (2e11, 0.3);
    let steel = VonMises {
        mu: e / (2.0 * (1.0 + nu)),
        bulk: e / (3.0 * (1.0 - 2.0 * nu)),
        hardening: Hardening::linear(1e10, -e / 10.0),
    };
    let (e, nu) = (117e9, 0.35);
    let copper = VonMises {
        mu: e / (2.0 * (1.0 + nu)),
        bulk: e / (3.0 * (1.0 - 2.0 * nu)),
        hardening: Hardening::linear(0.4e9, 0.1e9),
    };
    let johnson_cook = VonMises {
        hardening: Hardening {
            exponent: 0.31,
            rate: Some(RateSensitivity {
                coefficient: 0.025,
                reference: 1.0,
            }),
            thermal: Some(Thermal {
                exponent: 1.09,
                room: 293.15,
                melting: 1356.0,
                heating: 0.9 / (8960.0 * 383.0),
            }),
            ..Hardening::linear(90e6, 292e6)
        },
        ..copper
    };
    let dt = f64::from(1e-8f32);
    let mut seed = 5;
    let mut f_flat = Vec::new();
    let mut hist = Vec::new();
    let mut points = Vec::new();
    for (eps_p, heat) in [(0.0, 0.0), (0.0, 300.0), (0.45, 0.0), (0.7, 300.0)] {
        for scale in [0.01, 0.2] {
            let f = rounded::<D3>(glam::DMat3::IDENTITY + random_tensor::<D3>(&mut seed, scale));
            // A plastic history: an isochoric C_p⁻¹ = exp(−2 ε_p N) about a random
            // deviatoric direction N (rounded to f32).
            let n = random_tensor::<D3>(&mut seed, 1.0);
            let dev = (n + n.transpose()) * 0.5 - glam::DMat3::IDENTITY * (D3::trace(n) / 3.0);
            let dev = dev * (noise(&mut seed).abs() / norm::<D3>(dev));
            let cp_inv = rounded::<D3>(exp_sym(dev * (-2.0 * eps_p)));
            D3::push_t(&mut f_flat, f);
            D3::push_t(&mut hist, cp_inv);
            hist.extend([eps_p as f32, heat as f32, dt as f32]);
            points.push((f, cp_inv, f64::from(eps_p as f32), heat));
        }
    }
    let source = Source {
        name: "test/return-map",
        text: RETURN_MAP,
        common: &[EIGEN, PLASTICITY],
        flat: &[],
    };
    hist.push(1e-8);
    for model in [steel, copper, johnson_cook] {
        let mut yielded = 0;
        let constants = Constants::default()
            .f32("MU", model.mu)
            .f32("BULK", model.bulk)
            .hardening(&model.hardening);
        let out = run::<D3>(
            &gpu,
            source,
            constants,
            points.len(),
            &[("f_in", &f_flat), ("hist", &hist)],
            20 * points.len(),
        );
        for (k, &(f, cp_inv, eps_p, heat)) in points.iter().enumerate() {
            let cpu = model.return_map(f, cp_inv, eps_p, dt, heat);
            let o = &out[20 * k..];
            let p_gpu = D3::read_t(o);
            let (eps_gpu, psi_gpu) = (f64::from(o[18]), f64::from(o[19]));
            yielded += usize::from(cpu.eps_p > eps_p);
            // The trial stress comes from logarithms of the eigenvalues of F C_p⁻¹ Fᵀ by
            // f32 Jacobi rotations (converged to 3e-7 of the tensor): the Kirchhoff stress
            // carries ~1e-6 of its largest term, the trial stress (2μ + κ)|ln λ|, and Δγ
            // that over 3μ + H. Bounds: 1e-5 of (2μ + κ)(|ln λ| + 0.01) for P and of its
            // strain for ε_p, and 1e-5 of (2μ + κ)(|ln λ| + 0.01)² for ψ.
            let (eig, _) =
                meshless::physics::plasticity::symmetric_eigen(f * cp_inv * f.transpose());
            let ln_stretch = eig
                .to_array()
                .iter()
                .map(|e| 0.5 * e.ln().abs())
                .fold(0.0, f64::max)
                + 0.01;
            let stiff = 2.0 * model.mu + model.bulk;
            let ep = norm::<D3>(p_gpu - cpu.p);
            assert!(
                ep <= 1e-5 * stiff * ln_stretch,
                "H = {:e}, point {k}: |ΔP| = {ep:e} of {:e}",
                model.hardening.modulus,
                stiff * ln_stretch
            );
            assert!(
                (eps_gpu - cpu.eps_p).abs() <= 1e-5 * ln_stretch,
                "H = {:e}, point {k}: ε_p {eps_gpu} vs {}",
                model.hardening.modulus,
                cpu.eps_p
            );
            assert!(
                (psi_gpu - cpu.psi).abs() <= 1e-5 * stiff * ln_stretch * ln_stretch,
                "H = {:e}, point {k}: ψ {psi_gpu:e} vs {:e}",
                model.hardening.modulus,
                cpu.psi
            );
        }
        // Both branches are taken: returns from the virgin state and past saturation.
        assert!(yielded >= 4, "{yielded} of {} points yield", points.len());
    }
}

/// exp(S) of a symmetric S, from its eigen-decomposition.
fn exp_sym(s: glam::DMat3) -> glam::DMat3 {
    let (eig, n) = meshless::physics::plasticity::symmetric_eigen(s);
    let d = glam::DMat3::from_diagonal(glam::DVec3::from_array(eig.to_array().map(f64::exp)));
    n * d * n.transpose()
}
