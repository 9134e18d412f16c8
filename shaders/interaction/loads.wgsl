// Loads that vary in time (src/interaction/loads.rs), run before every step after `ext`
// received the constant traction loads: one invocation per particle adds
// Σ_g law[g] loads_g,i, the accelerations of every group g (a boundary condition with a
// time law) at law value 1, DIM floats per particle at g·N·DIM, times the step's law
// values, which the host writes for every step it records. Scene constants N and DIM.

@group(0) @binding(0) var<storage, read> loads: array<f32>;
@group(0) @binding(1) var<storage, read> law: array<f32>;
@group(0) @binding(2) var<storage, read_write> ext: array<f32>;

// bytes:
// - loads: 1 vector per item
// - law: nothing
// - ext: 1 vector per item
@compute @workgroup_size(256)
fn timed_loads(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = index(gid, nwg);
    if i >= N {
        return;
    }
    let groups = arrayLength(&law);
    var a = vload_ext(DIM * i);
    for (var g = 0u; g < groups; g++) {
        a += vload_loads(DIM * (g * N + i)) * law[g];
    }
    vstore_ext(DIM * i, a);
}
