// Integrator stages on whole flat states (one invocation per f32 entry, or per particle
// for the leapfrog). Constants: N, DIM, U_OFF, V_OFF, REST_OFF (the first field after v),
// LEN (flat state length).

struct Coefficients {
    a: f32,
    b: f32,
}

@group(0) @binding(0) var<uniform> c: Coefficients;
@group(0) @binding(1) var<storage, read_write> out: array<f32>;
@group(0) @binding(2) var<storage, read> x: array<f32>;
// The state a blend starts from when it is not `out`.
@group(0) @binding(3) var<storage, read> base: array<f32>;

// out = a·out + b·x (blend, axpy with a = 1).
// bytes:
// out = a·out + b·x: out read and written.
// - out: 1 scalar per item
// - x: 1 scalar per item
@compute @workgroup_size(256)
fn blend(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k < LEN {
        out[k] = c.a * out[k] + c.b * x[k];
    }
}

// out = a·base + b·x: a copy fused into a blend (out is written, not read).
// bytes:
// - out: 1 scalar per item
// - base: 1 scalar per item
// - x: 1 scalar per item
@compute @workgroup_size(256)
fn blend_from(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k < LEN {
        out[k] = c.a * base[k] + c.b * x[k];
    }
}

// Leapfrog kick: v += b·(rate of v).
// bytes:
// v += b·v̇.
// - out: 1 scalar per item
// - x: 1 scalar per item
@compute @workgroup_size(256)
fn kick(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k < N * DIM {
        out[V_OFF + k] += c.b * x[V_OFF + k];
    }
}

// Leapfrog drift: u += b·v (own velocity); every field after v += b·rate.
// bytes:
// u += b·v, and every field after v += b·rate: one more read either way.
// - out: 1 scalar per item
// - x: 1 scalar per item
@compute @workgroup_size(256)
fn drift(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = index(gid, nwg);
    if k < N * DIM {
        out[U_OFF + k] += c.b * out[V_OFF + k];
    } else if REST_OFF + k - N * DIM < LEN {
        let m = REST_OFF + k - N * DIM;
        out[m] += c.b * x[m];
    }
}
