//! The convex hull of points in the plane: the bodies' outlines of 2D contact (seed 000
//! §5.8) and the prime-space neighbourhood of seed 000 eq 63.

/// z of (a − o) × (b − o): positive when o → a → b turns counter-clockwise.
pub fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Andrew's monotone chain: the points on the convex hull of `ids`, counter-clockwise,
/// collinear ones included (contact: on a flat face the closest hull particle is then one
/// of the face, whose normal is the face's, not a distant corner's averaged one).
pub fn convex_hull(ids: &[u32], at: impl Fn(u32) -> [f64; 2]) -> Vec<u32> {
    let mut sorted = ids.to_vec();
    sorted.sort_by(|&a, &b| {
        let (p, q) = (at(a), at(b));
        p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1]))
    });
    if sorted.len() < 3 {
        return sorted;
    }
    let mut hull: Vec<u32> = Vec::with_capacity(2 * sorted.len());
    for pass in [
        &sorted[..],
        &sorted.iter().rev().copied().collect::<Vec<_>>()[..],
    ] {
        let start = hull.len();
        for &i in pass {
            while hull.len() >= start + 2
                && cross(at(hull[hull.len() - 2]), at(hull[hull.len() - 1]), at(i)) < 0.0
            {
                hull.pop();
            }
            hull.push(i);
        }
        // The last point of each chain starts the other.
        hull.pop();
    }
    hull
}
