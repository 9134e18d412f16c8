// Penalty contact between the bodies of a 2D scene (seed 000 §5.8, eqs 172–178;
// src/interaction/contact.rs), run before every step. One invocation per slave particle s gathers over
// the hull particles of every other body (counter-clockwise, concatenated in `hull`,
// body m's at hull_start[m]..hull_start[m + 1]), takes the closest one c (the first of
// equals), its normal n_c = ½(n_left + n_right) from the current positions of its hull
// neighbours, and with d = x_s − x_c and d·n_c ≤ 0 pushes back by −α (d·n_c) n_c / Δt².
// It adds the sum over the masters to its own entry of ext (which holds the traction
// acceleration, copied before the interaction passes), which the next step's rate passes
// add (boundary.wgsl). Scene constants N, DIM, U_OFF, BODIES and the reference fields
// (reference.wgsl).

struct ContactParams {
    // α / Δt².
    scale: f32,
}

@group(0) @binding(0) var<uniform> params: ContactParams;
@group(0) @binding(1) var<storage, read> reference: array<f32>;
@group(0) @binding(2) var<storage, read> y: array<f32>;
@group(0) @binding(3) var<storage, read> body: array<u32>;
@group(0) @binding(4) var<storage, read> hull: array<u32>;
@group(0) @binding(5) var<storage, read> hull_start: array<u32>;
@group(0) @binding(6) var<storage, read_write> ext: array<f32>;

fn position(i: u32) -> vecd {
    return x0_of(i) + vload_y(U_OFF + DIM * i);
}

// The in-plane vector t turned by +90° (−t_y, t_x), made unit.
fn turned_left(t: vecd) -> vecd {
    var n: vecd;
    n[0] = -t[1];
    n[1] = t[0];
    return normalize(n);
}

// bytes:
// Hull particles' positions counted once each, as a slave's.
// - reference: 1 vector per item
// - y: 1 vector per item
// - body: 1 scalar per item
// - hull: 1 scalar per item
// - hull_start: nothing
// - ext: 1 vector per item
@compute @workgroup_size(256)
fn contact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let s = index(gid, nwg);
    if s >= N {
        return;
    }
    let x_s = position(s);
    var push: vecd;
    for (var m = 0u; m < BODIES; m++) {
        let first = hull_start[m];
        let k = hull_start[m + 1u] - first;
        // A body without area has an empty hull (src/interaction/contact.rs) and is no master.
        if m == body[s] || k == 0u {
            continue;
        }
        var closest = 0u;
        var nearest = 3.4e38;
        for (var q = 0u; q < k; q++) {
            let d = x_s - position(hull[first + q]);
            if dot(d, d) < nearest {
                nearest = dot(d, d);
                closest = q;
            }
        }
        let x_c = position(hull[first + closest]);
        let t_left = position(hull[first + (closest + k - 1u) % k]) - x_c;
        let t_right = position(hull[first + (closest + 1u) % k]) - x_c;
        // eq 176: n_left = R₉₀ r_left, n_right = R₋₉₀ r_right.
        let n = 0.5 * (turned_left(t_left) - turned_left(t_right));
        // eqs 177–178.
        let d_n = dot(x_s - x_c, n);
        if d_n <= 0.0 {
            push -= n * (params.scale * d_n);
        }
    }
    vstore_ext(DIM * s, vload_ext(DIM * s) + push);
}
