//! Neighbour lists split into parts past the largest storage binding (`gpu::parts`): the
//! rates, reductions and steps of a run whose binding limit is forced down to 1 MiB
//! against the unsplit run's on the same adapter, and the refusals, by name, of the
//! engines that still need a buffer whole.

use crate::common::{gpu, load, random_state, random_vector, spec_of, tl_scheme};
use crate::galerkin::block;
use crate::gpu_ul::scheme as ul_scheme;
use crate::gray_monaghan::random_state as ul_random_state;
use meshless::core::tensor::{D2, D3, Dim};
use meshless::gpu::layout::GpuDim;
use meshless::gpu::reduction::Reduced;
use meshless::methods::cores::galerkin::GalerkinState;
use meshless::methods::cores::galerkin::gpu::GpuGalerkin;
use meshless::methods::cores::galerkin::updated::UlGalerkinState;
use meshless::methods::cores::ul::gpu::GpuUl;
use meshless::methods::cores::ul::{PairScheme, UlSph, UlState};
use meshless::methods::dual_support::{self, krylov::NewtonKrylov};
use meshless::methods::godunov::system::Scheme as GodunovScheme;
use meshless::methods::gray_monaghan::system::Scheme as GmScheme;
use meshless::methods::kbm::gpu::GpuEulerianKbm;
use meshless::methods::mixed::{GpuMixed, MixedState};
use meshless::methods::tlsph::{GpuTlsph, TlState};
use meshless::methods::ul_weak_form::gpu::GpuUlWeakForm;
use meshless::methods::{Method, MethodSpec, Runs};
use meshless::reference::Reference;
use meshless::run::{Engine, build_method};
use meshless::scene::Scene;
use meshless::statics::MatrixFree;
use std::process::Command;

/// The forced binding limit: several parts for the per-pair data of the scenes below
/// (3–9 MB), none for their per-particle buffers (under 0.8 MB each).
const LIMIT: u64 = 1 << 20;

/// A deformed, moving state of the engine's particles: a smooth stretch and shear
/// u = 0.02 (x y, −x², x z) and the velocity 0.3 u / |u|max, so that every pair term
/// (F, Ḟ, the viscosity, the hourglass control) is non-zero.
fn deformed<D: GpuDim>(g: &GpuTlsph<D>) -> TlState<D> {
    let mut y = g.state();
    for (i, &x) in g.reference().x0.iter().enumerate() {
        let x = D::to3(x);
        let u = [0.02 * x[0] * x[1], -0.02 * x[0] * x[0], 0.02 * x[0] * x[2]];
        y.u[i] = D::from_slice(&u);
        y.v[i] = D::from_slice(&u.map(|c| 15.0 * c));
    }
    y
}

/// The f32 values of rates, F and P, and the corrected gradients, as bits.
fn bits<D: GpuDim>(g: &mut GpuTlsph<D>, y: &TlState<D>) -> Vec<u64> {
    let (d, f, p) = g.rates(y);
    let mut out = Vec::new();
    let mut vectors = |vs: &[D::V]| {
        out.extend(vs.iter().flat_map(|&v| D::to3(v)).map(f64::to_bits));
    };
    vectors(&d.u);
    vectors(&d.v);
    vectors(&g.gradients());
    let tensors = [d.s, f, p].concat();
    out.extend(
        tensors
            .iter()
            .flat_map(|&t| D::to3x3(t).into_iter().flatten())
            .map(f64::to_bits),
    );
    out.extend(d.rho.iter().map(|r| r.to_bits()));
    out
}

/// The values of a reduction, as bits.
fn reduced_bits(r: &Reduced) -> Vec<u64> {
    let i = &r.invariants;
    [i.kinetic, i.strain]
        .into_iter()
        .chain(i.linear)
        .chain(i.angular)
        .chain([
            r.power,
            r.max_speed,
            r.pair_wave_speed,
            r.viscous_dissipation,
        ])
        .map(f64::to_bits)
        .collect()
}

/// Asserts that `a` and `b` hold the same bits, naming how many differ.
fn same_bits(what: &str, a: &[u64], b: &[u64]) {
    assert_eq!(a.len(), b.len(), "{what}");
    let differ = a.iter().zip(b).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{what}: {differ} of {} values differ", a.len());
}

/// The rates and the reduction of `case` on lists split by [`LIMIT`] and on whole lists:
/// the same bits. The split run sums each particle's pairs in the same order, from the
/// same f32 inputs, and its parts start at workgroup boundaries, so the reduction's
/// per-workgroup partials are the same too.
fn split_equals_whole<D: GpuDim>(what: &str, case: &Scene) {
    let mut whole = GpuTlsph::<D>::new(case, tl_scheme(case), gpu()).unwrap();
    let split_gpu = gpu().with_binding_limit(LIMIT);
    let mut split = GpuTlsph::<D>::new(case, tl_scheme(case), split_gpu).unwrap();
    assert!(
        whole.split().is_whole(),
        "{what}: one part without the limit"
    );
    let parts = split.split().parts.len();
    assert!(parts >= 3, "{what}: {parts} parts under 1 MiB");
    let y = deformed(&whole);
    same_bits(what, &bits(&mut whole, &y), &bits(&mut split, &y));
    let reduced = |g: &mut GpuTlsph<D>| reduced_bits(&g.reduced());
    same_bits(what, &reduced(&mut whole), &reduced(&mut split));
}

#[test]
fn tl_rates_on_lists_split_past_a_1mib_binding_are_the_unsplit_bits() {
    // Every scheme of the total-Lagrangian engine: the pair data of each (∇0W̃, X_j − X_i,
    // the reverse gradients of the variational forces, the hourglass stiffnesses), 2D on
    // the plate at Δx = 0.01 (10,201 particles, about 21 pairs each) and TLSPH in 3D on
    // the block at Δx = 1/16 (4,913 particles, about 74 pairs each).
    let plate = |set: &[&str]| {
        let mut set = set.to_vec();
        set.push("spacing=0.01");
        load("studies/cases/swinging-plate", &set)
    };
    let schemes: [(&str, &[&str]); 7] = [
        ("tlsph (reveles)", &[]),
        ("tlsph (variational)", &["method.force=variational"]),
        ("tlsph (hourglass control)", &["method.hourglass=0.1"]),
        ("tlsph (hypoelastic)", &["material.model=hypoelastic"]),
        (
            "tl-potential",
            &["method.name=tl-potential", "method.force="],
        ),
        (
            "corotated-tlsph (variational)",
            &["method.name=corotated-tlsph", "method.force=variational"],
        ),
        (
            "corotated-tlsph (reference code)",
            &[
                "method.name=corotated-tlsph",
                "method.correction=none",
                "method.force=\"reference-code\"",
            ],
        ),
    ];
    for (what, set) in schemes {
        split_equals_whole::<D2>(what, &plate(set));
    }
    let block = load("spinning-block-3d", &["spacing=0.0625"]);
    split_equals_whole::<D3>("tlsph 3D", &block);
}

#[test]
fn dual_support_rates_and_energy_on_split_lists_are_the_unsplit_bits() {
    // Dual-support SPH's energy reduction sums each particle's support S_i ∪ S'_i over
    // the part's lists.
    let case = load(
        "studies/cases/swinging-plate",
        &[
            "method.name=dual-support-sph",
            "method.correction=",
            "method.force=",
            "run.solve=dynamic",
            "spacing=0.01",
        ],
    );
    split_equals_whole::<D2>("dual-support", &case);
}

/// The device's K(u) v and one conjugate-gradient solve K Δu = r of dual-support SPH's
/// static Newton step, on the union lists whole and split by `limit` (at least 2 parts):
/// the same bits and iterations. The strain and product passes run a part at a time, and
/// the product's per-workgroup partials of p·Kp land in the unsplit slots.
fn krylov_split_equals_whole<D: GpuDim>(what: &str, case: &Scene, limit: u64) {
    let MethodSpec::DualSupportSph(spec) = &case.spec else {
        panic!("{what} runs dual-support-sph")
    };
    let reference = Reference::<D>::build(case).unwrap();
    let lists = dual_support::gpu::lists(case, spec, &reference).unwrap();
    let new = |gpu| NewtonKrylov::new(gpu, &lists, 1e-5, 1000).unwrap();
    let (mut whole, mut split) = (new(gpu()), new(gpu().with_binding_limit(limit)));
    assert!(
        whole.split().is_whole(),
        "{what}: one part without the limit"
    );
    let parts = split.split().parts.len();
    assert!(parts >= 2, "{what}: {parts} parts under {limit} B");
    let mut model = lists.model;
    let (n, d) = (model.len(), D::N);
    // A stretch of 1 % ± 0.1 % from particle to particle; the face x = x_min held (no rigid
    // motion, so K is positive definite on the free components).
    let x0 = &model.support.x0;
    let u: Vec<D::V> = (x0.iter().enumerate())
        .map(|(i, &x)| x * (0.01 + 1e-3 * (i as f64 * 0.7).sin()))
        .collect();
    let x_min = x0
        .iter()
        .map(|&x| D::comp(x, 0))
        .fold(f64::INFINITY, f64::min);
    let held = |i: usize| D::comp(x0[i], 0) < x_min + 0.5 * case.spacing;
    let mut unknowns = 0;
    let free: Vec<Option<u32>> = (0..n * d)
        .map(|dof| {
            let f = (!held(dof / d)).then_some(unknowns);
            unknowns += u32::from(f.is_some());
            f
        })
        .collect();
    let v: Vec<f32> = (free.iter().enumerate())
        .map(|(k, f)| f.map_or(0.0, |_| (k as f32 * 1.37).sin()))
        .collect();
    let product = |s: &mut NewtonKrylov| s.product(&model, &u, &free, &v).unwrap();
    let bits = |q: Vec<f32>| {
        q.into_iter()
            .map(|x| u64::from(x.to_bits()))
            .collect::<Vec<_>>()
    };
    let (a, b) = (bits(product(&mut whole)), bits(product(&mut split)));
    same_bits(&format!("{what}: K v"), &a, &b);
    let r: Vec<f64> = (0..unknowns).map(|k| (f64::from(k) * 0.61).cos()).collect();
    let mut solve = |s: &mut NewtonKrylov| {
        let (du, stats) = MatrixFree::solve(s, &mut model, &u, &free, &r).unwrap();
        (
            du.into_iter().map(f64::to_bits).collect::<Vec<_>>(),
            stats.iterations,
        )
    };
    let (a, b) = (solve(&mut whole), solve(&mut split));
    same_bits(&format!("{what}: Δu"), &a.0, &b.0);
    assert_eq!(a.1, b.1, "{what}: CG iterations");
}

#[test]
fn dual_support_static_products_and_solves_on_split_lists_are_the_unsplit_bits() {
    // The §6.4 beam at Δx = 0.05 (9,821 particles, 3.1 MB of per-pair data in its
    // largest buffer: 3 parts under 1 MiB, where the tangent moduli, 64 B a particle, still
    // fit one binding), and the neo-Hookean cube at Δx = 0.1 (1,331 particles, 0.77 MB
    // of per-pair data, under a 512 KiB binding; the moduli, 324 B a particle, fit it).
    let beam = load("beam-smoothing-2d", &["spacing=0.05"]);
    krylov_split_equals_whole::<D2>("beam", &beam, LIMIT);
    let cube = load("hyperelastic-cube-3d", &["spacing=0.1"]);
    krylov_split_equals_whole::<D3>("cube", &cube, 512 << 10);
}

/// The values of an updated-Lagrangian state, as bits.
fn ul_bits<D: GpuDim>(y: &UlState<D>) -> Vec<u64> {
    let vectors = [&y.u, &y.v].into_iter().flatten().flat_map(|&v| D::to3(v));
    let tensors = (y.s.iter().chain(&y.f)).flat_map(|&t| D::to3x3(t).into_iter().flatten());
    (vectors.chain(tensors))
        .chain(y.rho.iter().copied())
        .map(f64::to_bits)
        .collect()
}

/// An updated-Lagrangian engine of `case` on the device's lists whole and split by
/// [`LIMIT`] (at least 2 parts, each built on the device with its own ids): the rates of
/// a random state and its reduction, then 3 steps from the initial state (also on lists
/// that start with room for one pair and grow into parts), are the same bits. The parts' rows are whole workgroups and each particle's ids are sorted, so the
/// split run sums the same pairs in the same order.
fn ul_split_equals_whole<D: GpuDim, S: PairScheme<D>>(what: &str, case: &Scene)
where
    S::Spec: Runs,
{
    let cpu: UlSph<D, S> = build_method(case).unwrap();
    let new = |gpu| GpuUl::<D>::new(case, gpu, &ul_scheme(case)).unwrap();
    let (mut whole, mut split) = (new(gpu()), new(gpu().with_binding_limit(LIMIT)));
    let n = cpu.initial_state().u.len() as u32;
    assert_eq!(whole.room().rows, n, "{what}: one part without the limit");
    let parts = n.div_ceil(split.room().rows);
    assert!(parts >= 2, "{what}: {parts} parts under 1 MiB");
    let steps = |g: &mut GpuUl<D>| {
        let dt = 0.3 * case.spacing / Engine::<D>::max_signal_speed(g);
        Engine::<D>::advance(g, 0.0, dt, 3).unwrap();
        (ul_bits(&g.state()), reduced_bits(&g.reduced()))
    };
    let (a, b) = (steps(&mut whole), steps(&mut split));
    same_bits(&format!("{what}: 3 steps"), &a.0, &b.0);
    same_bits(&format!("{what}: reduction after 3 steps"), &a.1, &b.1);
    // Lists with room for one pair overflow at the first build and grow into parts.
    let mut grown = new(gpu().with_binding_limit(LIMIT));
    grown.set_capacity(1).unwrap();
    let c = steps(&mut grown);
    let grown_parts = n.div_ceil(grown.room().rows);
    assert!(grown_parts >= 2, "{what}: grown into {grown_parts} parts");
    same_bits(&format!("{what}: 3 steps on grown lists"), &a.0, &c.0);
    let y = ul_random_state(&cpu, case.spacing, &mut 17);
    let rates = |g: &mut GpuUl<D>| (ul_bits(&g.rates(&y)), reduced_bits(&g.reduced()));
    let (a, b) = (rates(&mut whole), rates(&mut split));
    same_bits(&format!("{what}: rates"), &a.0, &b.0);
    same_bits(&format!("{what}: reduction"), &a.1, &b.1);
}

#[test]
fn ul_rates_and_steps_on_split_device_lists_are_the_unsplit_bits() {
    // Gray–Monaghan SPH (with the Randles–Libersky correction, which gathers in the
    // particle pass too) and Godunov SPH on the plate at Δx = 0.01 (10,201 particles,
    // 2 parts of ids; finer, the per-particle quantities pass 1 MiB), and Gray–Monaghan SPH in 3D on the block at Δx = 1/16 (4,913
    // particles, about 5 MB of ids).
    let plate = |set: &[&str]| {
        let mut set = set.to_vec();
        set.extend([
            "spacing=0.01",
            "material.model=hypoelastic",
            "method.force=",
        ]);
        load("studies/cases/swinging-plate", &set)
    };
    let corrected = plate(&[
        "method.name=gray-monaghan-sph",
        "method.correction=randles-libersky",
    ]);
    ul_split_equals_whole::<D2, GmScheme>("gray-monaghan-sph", &corrected);
    let godunov = plate(&["method.name=godunov-sph", "method.correction="]);
    ul_split_equals_whole::<D2, GodunovScheme>("godunov-sph", &godunov);
    let block = load(
        "spinning-block-3d",
        &[
            "spacing=0.0625",
            "material.model=hypoelastic",
            "method.name=gray-monaghan-sph",
            "method.force=",
        ],
    );
    ul_split_equals_whole::<D3, GmScheme>("gray-monaghan-sph 3D", &block);
}

/// The values of a mixed state, as bits.
fn mixed_bits<D: GpuDim>(y: &MixedState<D>) -> Vec<u64> {
    let vectors = [&y.u, &y.v].into_iter().flatten().flat_map(|&v| D::to3(v));
    let tensors = (y.f.iter().chain(&y.h)).flat_map(|&t| D::to3x3(t).into_iter().flatten());
    (vectors.chain(tensors))
        .chain(y.j.iter().chain(&y.pressure).copied())
        .map(f64::to_bits)
        .collect()
}

/// A mixed engine of `case` on whole lists and on lists split by [`LIMIT`] (at least 3
/// parts): the rates of a random state (but under artificial compressibility, whose
/// corrector needs a step), its reduction, then 3 steps from the initial state, are the
/// same bits, and so are the corrector's pseudo steps.
fn mixed_split_equals_whole<D: GpuDim>(what: &str, case: &Scene) {
    let new = |gpu| GpuMixed::<D>::new(case, spec_of(case), gpu).unwrap();
    let (mut whole, mut split) = (new(gpu()), new(gpu().with_binding_limit(LIMIT)));
    let parts = split.split().parts.len();
    assert!(parts >= 3, "{what}: {parts} parts under 1 MiB");
    let corrected = whole.pseudo_time().is_some();
    if !corrected {
        let y = random_state(whole.cpu(), &mut 7, 0.01);
        let rates = |g: &mut GpuMixed<D>| {
            let d = g.rates(&y);
            let fluxes = g.fluxes();
            let forces = (fluxes.t.iter().chain(&fluxes.d)).flat_map(|&v| D::to3(v));
            let mut out = mixed_bits(&d);
            out.extend(forces.chain(fluxes.dj).map(f64::to_bits));
            (out, reduced_bits(&g.reduced()))
        };
        let (a, b) = (rates(&mut whole), rates(&mut split));
        same_bits(&format!("{what}: rates"), &a.0, &b.0);
        same_bits(&format!("{what}: reduction"), &a.1, &b.1);
    }
    let steps = |g: &mut GpuMixed<D>| {
        let y0 = g.cpu().initial_state();
        g.set_state(&y0);
        let r = g.reduced();
        let dt = 0.3 * case.spacing / (r.pair_wave_speed.max(1.0) + r.max_speed);
        Engine::<D>::advance(g, 0.0, dt, 3).unwrap();
        let pseudo = g.pseudo_time().map(|p| (p.total, p.residual.to_bits()));
        (mixed_bits(&g.state()), reduced_bits(&g.reduced()), pseudo)
    };
    let (a, b) = (steps(&mut whole), steps(&mut split));
    same_bits(&format!("{what}: 3 steps"), &a.0, &b.0);
    same_bits(&format!("{what}: reduction after 3 steps"), &a.1, &b.1);
    assert_eq!(a.2, b.2, "{what}: pseudo steps");
}

#[test]
fn mixed_rates_steps_and_reductions_on_split_lists_are_the_unsplit_bits() {
    // Upwind-SPH with and without the reconstruction, JST-SPH, the seed 002 options (the
    // bond-based F, the symmetrised momentum) and artificial compressibility (the
    // corrector's passes over the lists and its per-workgroup residuals), on the plate at
    // Δx = 0.01, whose mirror planes put ghosts in the lists (10,201 particles, 2–4 MB of
    // pair data); Upwind-SPH in 3D on the swinging cube at Δx = 0.1 (1,331 particles,
    // about 3.5 MB of pair data).
    let plate = |set: &[&str]| {
        let mut set = set.to_vec();
        set.push("spacing=0.01");
        load("swinging-plate", &set)
    };
    let schemes: [(&str, &[&str]); 6] = [
        ("upwind-sph", &["method.name=upwind-sph"]),
        (
            "upwind-sph (no reconstruction)",
            &["method.name=upwind-sph", "method.reconstruction=false"],
        ),
        ("jst-sph", &["method.name=jst-sph"]),
        (
            "upwind-sph (seed 002 options)",
            &[
                "method.name=upwind-sph",
                "method.variables=p-F",
                "method.momentum=symmetrised",
                "method.deformation_gradient=bond-based",
            ],
        ),
        (
            "upwind-sph (p-F-H-J)",
            &["method.name=upwind-sph", "method.variables=p-F-H-J"],
        ),
        (
            "upwind-sph (artificial compressibility)",
            &[
                "method.name=upwind-sph",
                "material.poisson_ratio=0.4999",
                "material.model=nearly-incompressible-neo-hookean",
                "method.artificial_compressibility={ alpha = 0.2 }",
            ],
        ),
    ];
    for (what, set) in schemes {
        mixed_split_equals_whole::<D2>(what, &plate(set));
    }
    let cube = load("swinging-cube", &["method.name=upwind-sph", "spacing=0.1"]);
    mixed_split_equals_whole::<D3>("upwind-sph 3D", &cube);
}

/// The values of a Galerkin state, as bits.
fn galerkin_bits<D: GpuDim>(y: &GalerkinState<D>, p: &[D::T]) -> Vec<u64> {
    let vectors = [&y.u, &y.v].into_iter().flatten().flat_map(|&v| D::to3(v));
    let tensors = (y.s.iter().chain(p)).flat_map(|&t| D::to3x3(t).into_iter().flatten());
    (vectors.chain(tensors))
        .chain(y.rho.iter().copied())
        .map(f64::to_bits)
        .collect()
}

/// A Galerkin engine of `case` on whole lists and on lists split by [`LIMIT`]: the rates
/// and P of a random state (|u| ~ 1 mm, |v| ~ 1 m/s) and its reduction (a node's share
/// of the points' energy, gathered over the part's lists) are the same bits, and so are
/// 3 steps from it with the weak form's velocity smoothing.
fn galerkin_split_equals_whole<D: GpuDim>(what: &str, case: &Scene) {
    let new = |gpu| match case.spec {
        MethodSpec::UlFem(_) => crate::gpu_ul_galerkin::device_on::<D>(case, gpu),
        _ => GpuGalerkin::<D>::new(case, spec_of(case), gpu).expect(what),
    };
    let (mut whole, mut split) = (new(gpu()), new(gpu().with_binding_limit(LIMIT)));
    let (points, gather) = split.splits();
    let parts = (points.parts.len(), gather.parts.len());
    assert!(
        parts.0 >= 2 && parts.1 >= 2,
        "{what}: {parts:?} parts under 1 MiB"
    );
    let mut y = whole.state();
    let mut seed = 5;
    for (u, v) in y.u.iter_mut().zip(y.v.iter_mut()) {
        *u = random_vector::<D>(&mut seed, 1e-3);
        *v = random_vector::<D>(&mut seed, 1.0);
    }
    let rates = |g: &mut GpuGalerkin<D>| {
        let (d, p) = g.rates(&y);
        (galerkin_bits(&d, &p), reduced_bits(&g.reduced()))
    };
    let (a, b) = (rates(&mut whole), rates(&mut split));
    same_bits(&format!("{what}: rates"), &a.0, &b.0);
    same_bits(&format!("{what}: reduction"), &a.1, &b.1);
    if let Some(smoothing) = split.smoothing_split() {
        let parts = smoothing.parts.len();
        assert!(parts >= 2, "{what}: {parts} parts of the smoothing lists");
        // Steps that end in the velocity smoothing, a part of its lists at a time.
        let steps = |g: &mut GpuGalerkin<D>| {
            g.set_state(&y);
            Engine::<D>::advance(g, 0.0, 1e-6, 3).unwrap();
            galerkin_bits(&g.state(), &[])
        };
        let (a, b) = (steps(&mut whole), steps(&mut split));
        same_bits(&format!("{what}: 3 smoothed steps"), &a, &b);
    }
}

#[test]
fn galerkin_rates_and_reductions_on_split_lists_are_the_unsplit_bits() {
    // The weak form, EFG and KBM (points' lists of 12–50 nodes a point) on a 2D block of
    // 81 × 81 nodes, whose point kinematics (under 1 MiB) stay whole, and the weak form
    // with its velocity smoothing after each step (at h = 2 Δx, lists of about 50 nodes a
    // node: 2 parts); the weak form in 3D on a slab of 25 × 25 × 2 nodes (in a cube, a workgroup
    // of nodes gathers about 590 points each, whose entries pass 1 MiB alone); `ul-fem`
    // on the 2D block (102,400 pairs of ∂N_a/∂ξ and X_a − X_first, 1.6 MB: 2 parts).
    for (method, keys) in [
        ("ul-fem", ""),
        ("tl-weak-form", ""),
        ("tl-weak-form", "smoothing = true\nh_over_dx = 2.0"),
        ("efg", ""),
        ("kbm", ""),
    ] {
        let case = block(&[8.0, 8.0], "neo-hookean", method, keys);
        galerkin_split_equals_whole::<D2>(&format!("{method} {keys:?}"), &case);
    }
    let slab = block(&[2.4, 2.4, 0.1], "neo-hookean", "tl-weak-form", "");
    galerkin_split_equals_whole::<D3>("tl-weak-form 3D", &slab);
}

#[test]
fn eulerian_kbm_on_split_lists_is_the_unsplit_bits() {
    // KBM (si) on an Eulerian kernel on the 2D block of 81 × 81 particles and 6,400 stress
    // points: the self-search of all points (about 50 a point, 2.6 MB of ids) in 3 parts
    // under 1 MiB. The rates, the reduction and 12 steps through a search (every 5 steps)
    // on the split lists are the unsplit bits.
    let case = block(
        &[8.0, 8.0],
        "neo-hookean",
        "kbm",
        "kernel_frame = \"eulerian\"\nsearch_every = 5",
    );
    let new = |gpu| GpuEulerianKbm::<D2>::new(&case, spec_of(&case), gpu).unwrap();
    let (mut whole, mut split) = (new(gpu()), new(gpu().with_binding_limit(LIMIT)));
    let parts = split.parts();
    assert!(parts >= 2, "{parts} parts under 1 MiB");
    let mut y = whole.state();
    let mut seed = 5;
    for (u, v) in y.u.iter_mut().zip(y.v.iter_mut()) {
        *u = random_vector::<D2>(&mut seed, 1e-3);
        *v = random_vector::<D2>(&mut seed, 1.0);
    }
    let bits = |y: &UlGalerkinState<D2>| -> Vec<u64> {
        let vectors = [&y.u, &y.v, &y.point_u].into_iter().flatten();
        vectors
            .flat_map(|&v| D2::to3(v))
            .map(f64::to_bits)
            .collect()
    };
    let rates = |g: &mut GpuEulerianKbm<D2>| (bits(&g.rates(&y)), reduced_bits(&g.reduced()));
    let (a, b) = (rates(&mut whole), rates(&mut split));
    same_bits("eulerian kbm: rates", &a.0, &b.0);
    same_bits("eulerian kbm: reduction", &a.1, &b.1);
    let steps = |g: &mut GpuEulerianKbm<D2>| {
        g.set_state(&y);
        Engine::<D2>::advance(g, 0.0, 1e-5, 12).unwrap();
        bits(&g.state())
    };
    same_bits(
        "eulerian kbm: 12 steps",
        &steps(&mut whole),
        &steps(&mut split),
    );
}

#[test]
fn ul_weak_form_on_split_lists_is_the_unsplit_bits() {
    // The updated-Lagrangian weak form on the 2D block of 101 × 101 particles and 10,000
    // stress points: the candidate lists, their transpose and the particles' own (42–46
    // ids a row, 1.7–1.9 MB each) in 2 parts each under 1 MiB. The rates, the reduction
    // and 12 steps with the velocity smoothing on the split lists are the unsplit bits.
    let case = block(&[10.0, 10.0], "hypoelastic", "ul-weak-form", "");
    let new = |gpu| GpuUlWeakForm::<D2>::new(&case, spec_of(&case), gpu).unwrap();
    let (mut whole, mut split) = (new(gpu()), new(gpu().with_binding_limit(LIMIT)));
    let parts = split.parts();
    assert!(parts.iter().all(|&p| p >= 2), "{parts:?} parts under 1 MiB");
    let mut y = whole.state();
    let mut seed = 5;
    for (u, v) in y.u.iter_mut().zip(y.v.iter_mut()) {
        *u = random_vector::<D2>(&mut seed, 1e-3);
        *v = random_vector::<D2>(&mut seed, 1.0);
    }
    let bits = |y: &UlGalerkinState<D2>| -> Vec<u64> {
        let vectors = [&y.u, &y.v, &y.point_u].into_iter().flatten();
        (vectors.flat_map(|&v| D2::to3(v)))
            .chain(y.node_rho.iter().copied())
            .map(f64::to_bits)
            .collect()
    };
    let rates = |g: &mut GpuUlWeakForm<D2>| (bits(&g.rates(&y)), reduced_bits(&g.reduced()));
    let (a, b) = (rates(&mut whole), rates(&mut split));
    same_bits("ul-weak-form: rates", &a.0, &b.0);
    same_bits("ul-weak-form: reduction", &a.1, &b.1);
    let steps = |g: &mut GpuUlWeakForm<D2>| {
        g.set_state(&y);
        Engine::<D2>::advance(g, 0.0, 1e-5, 12).unwrap();
        bits(&g.state())
    };
    same_bits(
        "ul-weak-form: 12 steps",
        &steps(&mut whole),
        &steps(&mut split),
    );
}

#[test]
fn the_binding_limit_variable_splits_a_run_or_refuses_it_by_name() {
    // MESHLESS_MAX_BINDING forces the limit on any adapter. TLSPH, Upwind-SPH and
    // Gray–Monaghan SPH (the device's own lists) runs go on with split lists; a scene
    // whose per-particle buffers pass the limit (TLSPH at Δx = 0.005: 40,401 particles) is
    // refused with exit code 2 naming the buffer and the variable; a malformed value is
    // refused naming the variable.
    let exe = env!("CARGO_BIN_EXE_meshless");
    let dir = tempfile::tempdir().unwrap();
    let run = |limit: &str, set: &[&str]| {
        Command::new(exe)
            .args(["run", "studies/cases/swinging-plate", "--backend", "gpu"])
            .args(["--set", "run.end_time=2e-5", "--set", "method.force="])
            .args(set.iter().flat_map(|s| ["--set", s]))
            .args(["--quiet", "--out"])
            .arg(dir.path())
            .env("MESHLESS_MAX_BINDING", limit)
            .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/cases"))
            .output()
            .unwrap()
    };
    let methods: [&[&str]; 3] = [
        &["method.name=tlsph"],
        &["method.name=upwind-sph"],
        &[
            "method.name=gray-monaghan-sph",
            "material.model=hypoelastic",
        ],
    ];
    for method in methods {
        let split = run("1MiB", &[method, &["spacing=0.01"]].concat());
        let stderr = String::from_utf8_lossy(&split.stderr);
        assert!(split.status.success(), "{method:?}: {stderr}");
    }
    let fine = run("1MiB", &["method.name=tlsph", "spacing=0.005"]);
    let stderr = String::from_utf8_lossy(&fine.stderr);
    assert_eq!(fine.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("kinematics buffer") && stderr.contains("MESHLESS_MAX_BINDING"),
        "{stderr}"
    );
    let bad = run("a lot", &["method.name=tlsph", "spacing=0.01"]);
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success(), "{stderr}");
    assert!(stderr.contains("MESHLESS_MAX_BINDING=a lot"), "{stderr}");
    // `--backend auto` refuses it too, rather than falling back to the CPU.
    let auto = Command::new(exe)
        .args(["check", "studies/cases/swinging-plate", "--backend", "auto"])
        .env("MESHLESS_MAX_BINDING", "a lot")
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/cases"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&auto.stderr);
    assert!(!auto.status.success(), "{stderr}");
    assert!(stderr.contains("MESHLESS_MAX_BINDING=a lot"), "{stderr}");
}

#[test]
fn a_split_run_reports_the_bytes_of_the_unsplit_one() {
    // The pass report's bytes model counts a pass's pairs once over the dispatches of its
    // parts (each a share of the pairs, or of the rows for the device's own lists):
    // `meshless bench` of TLSPH, Upwind-SPH and Gray–Monaghan SPH on the plate at about
    // 1e4 particles gives each pass the same bytes per step, and the step
    // the same bytes per particle, split by a 1 MiB binding or whole (the dispatches per
    // step differ: one a part).
    let exe = env!("CARGO_BIN_EXE_meshless");
    let bench = |set: &[&str], limit: Option<&str>| {
        let mut command = Command::new(exe);
        command
            .args(["bench", "studies/cases/swinging-plate", "--backend", "gpu"])
            .args([
                "--particles",
                "1e4",
                "--steps",
                "2",
                "--set",
                "method.force=",
            ])
            .args(set.iter().flat_map(|s| ["--set", s]))
            .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/cases"));
        if let Some(limit) = limit {
            command.env("MESHLESS_MAX_BINDING", limit);
        }
        let out = command.output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // (pass, bytes per step) of each row of the pass report, and its last line.
        let rows: Vec<(String, String)> = stdout
            .lines()
            .map(|l| l.split('|').map(str::trim).collect::<Vec<_>>())
            .filter(|cells| cells.len() == 8 && cells[4].parse::<u64>().is_ok())
            .map(|cells| (cells[1].to_string(), cells[4].to_string()))
            .collect();
        let total = stdout
            .lines()
            .find(|l| l.contains("bytes per particle-step"))
            .and_then(|l| l.rsplit('(').next())
            .unwrap_or_default()
            .to_string();
        (rows, total)
    };
    // The passes of each method's step, the blends in place and from another buffer
    // among them.
    let methods: [(&[&str], usize); 3] = [
        (&["method.name=tlsph"], 5),
        (&["method.name=upwind-sph"], 9),
        (
            &[
                "method.name=gray-monaghan-sph",
                "material.model=hypoelastic",
            ],
            17,
        ),
    ];
    for (set, passes) in methods {
        let (whole, split) = (bench(set, None), bench(set, Some("1MiB")));
        assert_eq!(whole.0.len(), passes, "{set:?}: {whole:?}");
        assert_eq!(whole, split, "{set:?}");
    }
}
