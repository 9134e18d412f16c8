//! A simple polygon in the plane (`shape = "polygon"`): its area, bounding box, the
//! point-in-polygon test its lattice is sampled with, and the check that it is simple.
//! The vertices are validated pairs [x, y] in either orientation.

/// The most vertices a polygon may have: the simplicity check compares every pair of
/// edges and the sampler tests every lattice point against every edge, so a polygon of
/// more is a mesh's job (`shape = "mesh"`).
pub const MAX_VERTICES: usize = 4096;

type Point = [f64; 2];

fn point(v: &[f64]) -> Point {
    [v[0], v[1]]
}

/// The edges (a, b) of the polygon, the last closing it.
fn edges(vertices: &[Vec<f64>]) -> impl Iterator<Item = (Point, Point)> + '_ {
    let n = vertices.len();
    (0..n).map(move |k| (point(&vertices[k]), point(&vertices[(k + 1) % n])))
}

/// The area by the shoelace formula, ½|Σ x_k y_(k+1) − x_(k+1) y_k| (either orientation).
pub fn area(vertices: &[Vec<f64>]) -> f64 {
    0.5 * edges(vertices)
        .map(|(a, b)| a[0] * b[1] - b[0] * a[1])
        .sum::<f64>()
        .abs()
}

/// The bounding box (lower and upper corners).
pub fn bounds(vertices: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
    let fold =
        |k: usize, f: fn(f64, f64) -> f64, start: f64| vertices.iter().map(|v| v[k]).fold(start, f);
    (
        vec![
            fold(0, f64::min, f64::INFINITY),
            fold(1, f64::min, f64::INFINITY),
        ],
        vec![
            fold(0, f64::max, f64::NEG_INFINITY),
            fold(1, f64::max, f64::NEG_INFINITY),
        ],
    )
}

/// (b − a) × (c − a): positive when c lies to the left of the line from a to b.
fn orient(a: Point, b: Point, c: Point) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// The distance from p to the segment from a to b.
fn distance_to_segment(p: Point, a: Point, b: Point) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let length2 = dx * dx + dy * dy;
    let s = if length2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - s * dx).hypot(p[1] - a[1] - s * dy)
}

/// Whether p lies inside the polygon or within `tol` of an edge. Points on the boundary
/// are inside, as a box's vertex lattice keeps its faces, so that a polygon whose edges
/// follow the lattice keeps its edge rows (and the cells of the Galerkin methods span
/// it). Off the boundary, the crossing number of the ray from p towards +x, an edge
/// counted when its ends lie on different sides of the ray's line with the upper end
/// strictly above (the half-open rule), so that a ray through a vertex counts it once and
/// the test holds for either orientation.
pub fn contains(vertices: &[Vec<f64>], p: &[f64], tol: f64) -> bool {
    let p = point(p);
    let mut inside = false;
    for (a, b) in edges(vertices) {
        if distance_to_segment(p, a, b) <= tol {
            return true;
        }
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Whether the closed segments pq and rs share a point.
fn segments_meet(p: Point, q: Point, r: Point, s: Point) -> bool {
    let (d1, d2) = (orient(r, s, p), orient(r, s, q));
    let (d3, d4) = (orient(p, q, r), orient(p, q, s));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    // Touching or collinear: an end of one segment on the other.
    let on = |a: Point, b: Point, c: Point, d: f64| {
        d == 0.0
            && c[0] >= a[0].min(b[0])
            && c[0] <= a[0].max(b[0])
            && c[1] >= a[1].min(b[1])
            && c[1] <= a[1].max(b[1])
    };
    on(r, s, p, d1) || on(r, s, q, d2) || on(p, q, r, d3) || on(p, q, s, d4)
}

/// Why the vertices (each already two finite numbers) do not make a simple polygon: fewer
/// than three, more than [`MAX_VERTICES`], a repeated vertex, or two edges that meet
/// other than at their common vertex (vertices on one line fold an edge back onto its
/// neighbour). None if they do; a simple polygon encloses a positive area.
pub fn not_simple(vertices: &[Vec<f64>]) -> Option<String> {
    let n = vertices.len();
    if n < 3 {
        return Some(format!(
            "has {n} vertices; a polygon needs at least 3 ([[x, y], ...], in either \
             orientation)"
        ));
    }
    if n > MAX_VERTICES {
        return Some(format!(
            "has {n} vertices, more than the {MAX_VERTICES} a polygon may have; describe the \
             body as a Gmsh mesh (shape = \"mesh\") instead"
        ));
    }
    let e: Vec<(Point, Point)> = edges(vertices).collect();
    for (k, (a, b)) in e.iter().enumerate() {
        if a == b {
            return Some(format!(
                "repeats vertex {k} ({a:?}) as vertex {}; give each corner once",
                (k + 1) % n
            ));
        }
    }
    for k in 0..n {
        for j in k + 1..n {
            let adjacent = j == k + 1 || (k == 0 && j == n - 1);
            let ((p, q), (r, s)) = (e[k], e[j]);
            let crossing = if adjacent {
                // Edges that share a vertex meet elsewhere only when they fold back onto
                // each other: collinear, the angle between them zero.
                let (shared, far_k, far_j) = if j == k + 1 { (q, p, s) } else { (p, q, r) };
                orient(far_k, shared, far_j) == 0.0
                    && (far_k[0] - shared[0]) * (far_j[0] - shared[0])
                        + (far_k[1] - shared[1]) * (far_j[1] - shared[1])
                        > 0.0
            } else {
                segments_meet(p, q, r, s)
            };
            if crossing {
                return Some(format!(
                    "is not a simple polygon: edge {k} (vertices {k} to {}) and edge {j} \
                     (vertices {j} to {}) meet other than at a shared vertex; list the \
                     vertices in order round the boundary, without crossings",
                    (k + 1) % n,
                    (j + 1) % n
                ));
            }
        }
    }
    None
}

/// An L-shape, three quarters of the 2 m square, its reflex vertex at (1, 1): a test
/// polygon.
#[cfg(test)]
pub(crate) const L_SHAPE: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [2.0, 0.0],
    [2.0, 1.0],
    [1.0, 1.0],
    [1.0, 2.0],
    [0.0, 2.0],
];

/// The vertices of a test polygon as a case file gives them.
#[cfg(test)]
pub(crate) fn polygon(points: &[[f64; 2]]) -> Vec<Vec<f64>> {
    points.iter().map(|p| p.to_vec()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn areas_of_an_l_shape_and_a_triangle_in_either_orientation() {
        // Exact in binary: sums of products of small integers and halves.
        let l = polygon(&L_SHAPE);
        assert_eq!(area(&l), 3.0);
        let reversed: Vec<Vec<f64>> = l.iter().rev().cloned().collect();
        assert_eq!(area(&reversed), 3.0);
        assert_eq!(area(&polygon(&[[0.0, 0.0], [1.0, 0.0], [0.0, 0.5]])), 0.25);
    }

    #[test]
    fn points_on_edges_and_at_vertices_are_inside_and_rays_through_vertices_count_once() {
        let l = polygon(&L_SHAPE);
        let tol = 1e-12;
        // On an edge, at a convex vertex and at the reflex vertex (1, 1).
        for p in [[1.0, 0.0], [2.0, 0.0], [1.0, 1.0], [1.5, 1.0], [0.0, 1.5]] {
            assert!(contains(&l, &p, tol), "{p:?}");
        }
        // The ray from (0.5, 1) runs along the edge y = 1 from (1, 1) to (2, 1) and
        // through two vertices: the half-open rule counts the edges it crosses once.
        assert!(contains(&l, &[0.5, 1.0], tol));
        // Outside the notch, and beyond the vertex (2, 1) on the ray's line.
        for p in [
            [1.5, 1.5],
            [2.5, 1.0],
            [-0.5, 1.0],
            [1.0 + 1e-6, 1.0 + 1e-6],
        ] {
            assert!(!contains(&l, &p, tol), "{p:?}");
        }
        // Just inside an edge without the tolerance's help.
        assert!(contains(&l, &[1.0 - 1e-6, 1.5], 0.0));
    }

    #[test]
    fn crossing_folded_and_degenerate_polygons_are_refused() {
        let bow_tie = polygon(&[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]);
        assert!(not_simple(&bow_tie).unwrap().contains("edge 0"));
        let folded = polygon(&[[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
        assert!(not_simple(&folded).is_some());
        let line = polygon(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]);
        assert!(not_simple(&line).is_some());
        assert!(not_simple(&polygon(&[[0.0, 0.0], [1.0, 0.0]])).is_some());
        let repeated = polygon(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        assert!(not_simple(&repeated).unwrap().contains("repeats"));
        // A vertex touching a non-adjacent edge.
        let touching = polygon(&[[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.0], [0.0, 2.0]]);
        assert!(not_simple(&touching).is_some());
        let l = polygon(&L_SHAPE);
        assert_eq!(not_simple(&l), None);
    }
}
