use super::*;
use crate::core::kernel::{Kernel, KernelKind};
use crate::core::tensor::{D2, D3};
use glam::{DVec2, DVec3};

/// Particles of an nx × ny lattice of spacing dx from the origin.
fn lattice(nx: usize, ny: usize, dx: f64) -> Vec<DVec2> {
    (0..ny)
        .flat_map(|j| (0..nx).map(move |i| DVec2::new(i as f64 * dx, j as f64 * dx)))
        .collect()
}

/// The particles of an nx × ny lattice of spacing dx, all of body 0.
fn one_body(nx: usize, ny: usize, dx: f64) -> (Vec<DVec2>, Vec<u32>) {
    let x = lattice(nx, ny, dx);
    let body = vec![0; x.len()];
    (x, body)
}

#[test]
fn a_rectangle_has_its_lattice_squares_as_cells() {
    // (nx − 1)(ny − 1) cells, each of area dx²: the 2×2 Gauss weights sum to the
    // rectangle's area to round-off.
    let (nx, ny, dx) = (5, 4, 0.25);
    let x = lattice(nx, ny, dx);
    let cells = lattice_cells::<D2>(&x, &vec![0; x.len()], dx, &Cells::default(), &[]).unwrap();
    assert_eq!(cells.len(), (nx - 1) * (ny - 1));
    for c in 0..cells.len() {
        let k = cells.of::<D2>(c);
        // Counter-clockwise: the signed area of the corner polygon is dx².
        let area: f64 = (0..4)
            .map(|a| x[k[a] as usize].perp_dot(x[k[(a + 1) % 4] as usize]))
            .sum::<f64>()
            / 2.0;
        assert!((area - dx * dx).abs() < 1e-14, "cell {c}: area {area}");
    }
    let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
    let total: f64 = points.weight.iter().sum();
    let area = ((nx - 1) * (ny - 1)) as f64 * dx * dx;
    assert!((total - area).abs() < 1e-13 * area);
    let centres = QuadraturePoints::<D2>::new(&cells, &x, Rule::Centre);
    assert!((centres.weight.iter().sum::<f64>() - area).abs() < 1e-13 * area);
}

#[test]
fn particles_off_the_lattice_and_bodies_without_cells_are_refused() {
    let dx = 0.1;
    let mut x = lattice(3, 3, dx);
    x[4].x += 0.3 * dx;
    let err = lattice_cells::<D2>(&x, &[0; 9], dx, &Cells::default(), &[]).unwrap_err();
    assert!(
        matches!(err, QuadratureError::OffLattice { particle: 4, .. }),
        "{err}"
    );
    let line = lattice(4, 1, dx);
    let err = lattice_cells::<D2>(&line, &[0; 4], dx, &Cells::default(), &[]).unwrap_err();
    assert_eq!(err, QuadratureError::NoCell { body: 0 });
}

#[test]
fn isoparametric_gradients_reproduce_linear_fields_in_a_distorted_cell() {
    // N_a partition unity and ∇N_a of a linear field f = a + b·x is b exactly, in a
    // quadrilateral that is no parallelogram (J varies over the cell). Round-off: 1e-13.
    let x = vec![
        DVec2::new(0.0, 0.0),
        DVec2::new(1.0, 0.1),
        DVec2::new(1.2, 0.9),
        DVec2::new(-0.1, 1.0),
    ];
    let cells = Cells {
        corners: vec![0, 1, 2, 3],
        body: vec![0],
    };
    let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
    let shapes = Shapes::isoparametric(&cells, &points, &x);
    let b = DVec2::new(0.7, -1.3);
    let f: Vec<f64> = x.iter().map(|p| 2.0 + b.dot(*p)).collect();
    for q in 0..points.len() {
        let r = shapes.csr.range(q);
        let sum: f64 = shapes.n[r.clone()].iter().sum();
        assert!((sum - 1.0).abs() < 1e-14);
        let value: f64 = r
            .clone()
            .map(|p| shapes.n[p] * f[shapes.csr.ids[p] as usize])
            .sum();
        assert!((value - 2.0 - b.dot(points.x0[q])).abs() < 1e-13);
        let grad = r.fold(DVec2::ZERO, |g, p| {
            g + shapes.grad[p] * f[shapes.csr.ids[p] as usize]
        });
        assert!((grad - b).length() < 1e-13, "point {q}: {grad}");
    }
}

#[test]
fn hexahedra_weights_and_gradients() {
    // A 3 × 3 × 3 lattice: 8 cubes, Gauss weights summing to the volume, and
    // trilinear gradients exact for a linear field.
    let dx = 0.5;
    let x: Vec<DVec3> = (0..27)
        .map(|i| DVec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * dx)
        .collect();
    let cells = lattice_cells::<D3>(&x, &[0; 27], dx, &Cells::default(), &[]).unwrap();
    assert_eq!(cells.len(), 8);
    let points = QuadraturePoints::<D3>::new(&cells, &x, Rule::Gauss2);
    assert_eq!(points.len(), 64);
    assert!((points.weight.iter().sum::<f64>() - 1.0).abs() < 1e-13);
    let shapes = Shapes::isoparametric(&cells, &points, &x);
    let b = DVec3::new(0.3, -0.2, 1.1);
    for q in 0..points.len() {
        let grad = shapes.csr.range(q).fold(DVec3::ZERO, |g, p| {
            g + shapes.grad[p] * b.dot(x[shapes.csr.ids[p] as usize])
        });
        assert!((grad - b).length() < 1e-13);
    }
}

#[test]
fn reproducing_functions_reproduce_linear_fields_at_every_point() {
    // Seed 000 checklist item 4 at the quadrature points: Σ_j V_j Ψ_j = 1,
    // Σ_j V_j Ψ_j x_j = x_q and Σ_j V_j ∇Ψ_j ⊗ x_j = I (N_j = V_j Ψ_j) at every Gauss
    // point, boundary
    // cells included (the moment conditions, eqs 44–45). Round-off of sums of O(30)
    // terms of O(1): 1e-12.
    let dx = 0.1;
    let (x, body) = one_body(9, 7, dx);
    let vol = vec![dx * dx; x.len()];
    let cells = lattice_cells::<D2>(&x, &body, dx, &Cells::default(), &[]).unwrap();
    let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
    let kernel = Kernel::new(KernelKind::CubicSpline, 1.5 * dx, 2);
    let shapes =
        Shapes::<D2>::reproducing(&points.x0, &points.body, &x, &vol, &body, &kernel).unwrap();
    for q in 0..points.len() {
        let (mut unity, mut first, mut grad) = (0.0, DVec2::ZERO, glam::DMat2::ZERO);
        for p in shapes.csr.range(q) {
            let j = shapes.csr.ids[p] as usize;
            unity += shapes.n[p];
            first += x[j] * shapes.n[p];
            grad += D2::outer(shapes.grad[p], x[j]);
        }
        assert!((unity - 1.0).abs() < 1e-12, "point {q}: Σ V Ψ = {unity}");
        assert!((first - points.x0[q]).length() < 1e-12 * dx * 10.0);
        assert!((grad - glam::DMat2::IDENTITY).abs_diff_eq(glam::DMat2::ZERO, 1e-11));
    }
}

#[test]
fn stress_point_weights_are_the_joint_voronoi_cells() {
    // Seed 001 §5.2 (spec [D]): particles and cell-centre stress points of a square
    // lattice form a lattice rotated by 45°, whose Voronoi cells are diamonds of
    // Δx²/2, cut to Δx²/4 on an edge and Δx²/8 at a corner. Exact in binary: 1e-15.
    let (nx, ny, dx) = (5, 4, 0.5);
    let (x, body) = one_body(nx, ny, dx);
    let cells = lattice_cells::<D2>(&x, &body, dx, &Cells::default(), &[]).unwrap();
    let points = QuadraturePoints::<D2>::with_stress_points(&cells, &x, &body);
    assert_eq!(points.len(), nx * ny + (nx - 1) * (ny - 1));
    assert_eq!(points.particles, nx * ny);
    let cell = dx * dx;
    for (q, (&w, &y)) in points.weight.iter().zip(&points.x0).enumerate() {
        let on_edges = if q < nx * ny {
            [y.x, y.y]
                .iter()
                .zip([(nx - 1) as f64 * dx, (ny - 1) as f64 * dx])
                .filter(|(c, end)| **c == 0.0 || **c == *end)
                .count()
        } else {
            0
        };
        let expected = cell / 2.0 / f64::from(1 << on_edges);
        assert!((w - expected).abs() < 1e-15, "point {q} at {y}: weight {w}");
    }
    let area = ((nx - 1) * (ny - 1)) as f64 * cell;
    assert!((points.weight.iter().sum::<f64>() - area).abs() < 1e-14);
    // In 3D the joint cells (a body-centred lattice's truncated octahedra) weigh
    // Δx³/2 and the weights sum to the volume.
    let x3: Vec<DVec3> = (0..27)
        .map(|i| DVec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * dx)
        .collect();
    let cells = lattice_cells::<D3>(&x3, &[0; 27], dx, &Cells::default(), &[]).unwrap();
    let points = QuadraturePoints::<D3>::with_stress_points(&cells, &x3, &[0; 27]);
    assert_eq!(points.weight[13], dx.powi(3) / 2.0);
    assert!((points.weight.iter().sum::<f64>() - 8.0 * dx.powi(3)).abs() < 1e-14);
}

/// Σ_a N_a = 1, Σ_a ∇N_a = 0 (trial and test) and Σ_a X_a ⊗ ∇N_a = I at every point
/// of `shapes`, to `tol`.
fn check_linear_completeness(shapes: &Shapes<D2>, at: &[DVec2], x: &[DVec2], tol: f64) {
    for (q, &y) in at.iter().enumerate() {
        let (mut unity, mut first) = (0.0, DVec2::ZERO);
        let (mut trial, mut test) = (DVec2::ZERO, DVec2::ZERO);
        let mut grad = glam::DMat2::ZERO;
        for p in shapes.csr.range(q) {
            let a = shapes.csr.ids[p] as usize;
            unity += shapes.n[p];
            first += (x[a] - y) * shapes.n[p];
            trial += shapes.grad[p];
            test += shapes.test_gradient(p);
            grad += D2::outer(x[a], shapes.grad[p]);
        }
        assert!((unity - 1.0).abs() < tol, "point {q}: Σ N = {unity}");
        assert!(trial.length() < tol && test.length() < tol, "point {q}");
        let off = (grad - glam::DMat2::IDENTITY).abs().to_cols_array();
        assert!(off.iter().all(|&e| e < tol), "point {q}: Σ X ⊗ ∇N = {grad}");
        // Only the MLS values reproduce X itself; Shepard values do not at a boundary.
        if shapes.test.is_empty() {
            assert!(first.length() < tol, "point {q}: Σ N (X − y) = {first}");
        }
    }
}

#[test]
fn krongauz_belytschko_gradients_are_linearly_complete_at_every_point() {
    // Seed 001 checklist items 2 and 3 (spec §11): at every particle and stress point
    // of a lattice, corners included, the Shepard functions sum to one with
    // gradients summing to zero, and G_a = M⁻¹ ∇W^S_a reproduces a linear field's
    // gradient (eq 29). Also on a jittered cloud at its particles. Round-off of sums of
    // O(20) terms of O(1/Δx) against 1: 1e-10 · (1/Δx).
    let dx = 0.1;
    let kernel = Kernel::new(KernelKind::CubicSpline, 1.3 * dx, 2);
    let (x, body) = one_body(9, 7, dx);
    let cells = lattice_cells::<D2>(&x, &body, dx, &Cells::default(), &[]).unwrap();
    let points = QuadraturePoints::<D2>::with_stress_points(&cells, &x, &body);
    let kb =
        Shapes::<D2>::krongauz_belytschko(&points.x0, &points.body, &x, &body, &kernel).unwrap();
    assert_eq!(kb.test.len(), kb.grad.len());
    check_linear_completeness(&kb, &points.x0, &x, 1e-10 / dx);
    let jittered: Vec<DVec2> = x
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let s = ((i as f64 * 12.9898).sin() * 43758.5453).fract();
            p + DVec2::new(s, 1.0 - 2.0 * s.abs()) * 0.2 * dx
        })
        .collect();
    let kb =
        Shapes::<D2>::krongauz_belytschko(&jittered, &body, &jittered, &body, &kernel).unwrap();
    check_linear_completeness(&kb, &jittered, &jittered, 1e-10 / dx);
    // The test gradients are the Shepard ones: not corrected, so at a corner they do
    // not reproduce the gradient of X (the paper's "not linearly complete" test
    // functions, which cost global angular momentum).
    let corner = kb.csr.range(0).fold(glam::DMat2::ZERO, |g, p| {
        g + D2::outer(jittered[kb.csr.ids[p] as usize], kb.test[p])
    });
    let off = (corner - glam::DMat2::IDENTITY).abs().to_cols_array();
    assert!(
        off.iter().any(|&e| e > 0.1),
        "Σ X ⊗ ∇W^S = {corner} at a corner"
    );
}

#[test]
fn moving_least_squares_functions_are_those_of_eqs_40_to_42() {
    // Φ_a(X) = pᵀ(X) A⁻¹ p(X_a) W(X − X_a) with A = Σ_a p(X_a) pᵀ(X_a) W(X − X_a),
    // p = (1, X, Y), evaluated here directly (a 3×3 solve) at points between the
    // particles of a lattice whose boundary particles carry other volumes, which the
    // MLS functions must ignore; and linear completeness. Round-off: 1e-12.
    let dx = 0.1;
    let kernel = Kernel::new(KernelKind::CubicSpline, 1.5 * dx, 2);
    let (x, body) = one_body(8, 6, dx);
    let at = [
        DVec2::new(0.0, 0.0),
        DVec2::new(0.33, 0.21),
        DVec2::new(0.7, 0.45),
    ];
    let mls = Shapes::<D2>::moving_least_squares(&at, &[0; 3], &x, &body, &kernel).unwrap();
    check_linear_completeness(&mls, &at, &x, 1e-11 / dx);
    for (q, &y) in at.iter().enumerate() {
        let p = |z: DVec2| glam::DVec3::new(1.0, z.x, z.y);
        let w = |a: usize| kernel.w((y - x[a]).length());
        let a_matrix = (0..x.len()).fold(glam::DMat3::ZERO, |m, a| {
            let pa = p(x[a]);
            m + glam::DMat3::from_cols(pa * pa.x, pa * pa.y, pa * pa.z) * w(a)
        });
        let c = a_matrix.inverse() * p(y);
        for k in mls.csr.range(q) {
            let a = mls.csr.ids[k] as usize;
            let phi = c.dot(p(x[a])) * w(a);
            assert!((mls.n[k] - phi).abs() < 1e-12, "point {q}, node {a}");
        }
    }
}

#[test]
fn the_gather_lists_every_pair_once_under_its_node() {
    let dx = 1.0;
    let x = lattice(4, 3, dx);
    let cells = lattice_cells::<D2>(&x, &[0; 12], dx, &Cells::default(), &[]).unwrap();
    let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
    let shapes = Shapes::isoparametric(&cells, &points, &x);
    let gather = shapes.gather(x.len());
    let mut seen = vec![false; shapes.csr.ids.len()];
    for a in 0..x.len() {
        for e in gather.range(a) {
            let p = gather.pair[e] as usize;
            assert_eq!(shapes.csr.ids[p] as usize, a);
            assert!(shapes.csr.range(gather.point[e] as usize).contains(&p));
            assert!(!std::mem::replace(&mut seen[p], true));
        }
    }
    assert!(seen.iter().all(|&s| s));
    // A corner node is in one cell (4 points), an interior one in four (16).
    assert_eq!(gather.range(0).len(), 4);
    assert_eq!(gather.range(5).len(), 16);
}

#[test]
fn recompute_writes_each_point_into_its_own_slots_and_fails_at_the_first_point() {
    // Points enough to split across threads (more than MIN_ROWS): each point's values
    // land in its own pairs' slots and its weight in its own entry, the test gradients
    // too (Petrov–Galerkin); of two failing points the error names the first in order.
    let x = lattice(20, 12, 1.0);
    let cells = lattice_cells::<D2>(&x, &[0; 240], 1.0, &Cells::default(), &[]).unwrap();
    let points = QuadraturePoints::<D2>::new(&cells, &x, Rule::Gauss2);
    let mut shapes = Shapes::isoparametric(&cells, &points, &x);
    shapes.test = vec![DVec2::ZERO; shapes.csr.pair_count()];
    let mut weight = vec![0.0; shapes.len()];
    let written = shapes.recompute(&mut weight, |q, nodes, row| {
        for (k, &a) in nodes.iter().enumerate() {
            row.n[k] = (q * 10 + k) as f64;
            row.grad[k] = DVec2::new(a as f64, q as f64);
            row.test[k] = DVec2::new(q as f64, k as f64);
        }
        Ok::<f64, ()>(-(q as f64))
    });
    assert_eq!(written, Ok(()));
    assert_eq!(weight.len(), shapes.len());
    for (q, &w) in weight.iter().enumerate() {
        assert_eq!(w, -(q as f64));
        for (k, p) in shapes.csr.range(q).enumerate() {
            assert_eq!(shapes.n[p], (q * 10 + k) as f64);
            let a = shapes.csr.ids[p] as f64;
            assert_eq!(shapes.grad[p], DVec2::new(a, q as f64));
            assert_eq!(shapes.test[p], DVec2::new(q as f64, k as f64));
        }
    }
    let failed = shapes.recompute(&mut [], |q, _, _| match q {
        700 | 300 => Err(q),
        _ => Ok(0.0),
    });
    assert_eq!(failed, Err((300, 300)));
}
