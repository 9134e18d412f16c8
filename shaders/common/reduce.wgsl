// Global sums of one state, per workgroup: kinetic and strain energy, linear and angular
// momentum, the power of supports and loads, max |v|², a count of non-finite entries, the
// largest pair wave speed of the CFL step (`pair_wave_speed(i)`: Δx max_j C_p,ij / r_ij
// for the mixed methods, seed 002 eqs 31–32; unused, 0, for TLSPH) and the viscous
// dissipation of the last rate evaluation (`viscous_dissipation(i)`: the TLSPH family's
// kin[KDIS_OFF + i]; 0 for the methods that do not book it).
// One invocation per particle of a part of the lists (part.wgsl); a tree reduction in
// workgroup memory writes REDUCED values per workgroup to `partials` at the workgroup's
// index in the whole run (parts start at workgroup boundaries, src/gpu/parts.rs), so a
// split run writes the unsplit run's partials; the host sums them (max for |v|² and the
// pair wave speed) in f64. The method's `strain_energy(i)` (tlsph_energy.wgsl: from the
// stress pass's kin for the same state; mixed_energy.wgsl: from the F of the stress) is
// V_i ψ_i; a non-finite energy counts as a non-finite entry. The power of supports and
// loads is the rate passes' kin[KPOW_OFF + i] (boundary.wgsl). The method's file may
// declare bindings past 3 for its hooks (mixed_energy.wgsl: the part's neighbour lists,
// particle i at row i − part.first). Constants: N, DIM, RHO0, U_OFF, V_OFF, KPOW_OFF and
// the reference fields (reference.wgsl).

const REDUCED: u32 = 13u;

@group(0) @binding(0) var<storage, read> y: array<f32>;
// The method's per-particle scratch of the last rate evaluation (kinematics, power).
@group(0) @binding(1) var<storage, read> kin: array<f32>;
@group(0) @binding(2) var<storage, read> reference: array<f32>;
@group(0) @binding(3) var<storage, read_write> partials: array<f32>;

var<workgroup> sums: array<array<f32, REDUCED>, 256>;

fn finite(x: f32) -> bool {
    // NaN fails both comparisons; ±inf fails the bound.
    return abs(x) <= 3.0e38;
}

@compute @workgroup_size(256)
fn reduce(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let row = index(gid, nwg);
    let i = part.first + row;
    var q: array<f32, REDUCED>;
    if row < part.rows {
        let m = RHO0 * vol_of(i);
        let u = pad3(vload_y(U_OFF + DIM * i));
        let v = pad3(vload_y(V_OFF + DIM * i));
        let x = pad3(x0_of(i)) + u;
        let p = m * v;
        let l = cross(x, p);
        q[0] = 0.5 * dot(p, v);
        q[1] = strain_energy(i);
        q[2] = p.x;
        q[3] = p.y;
        q[4] = p.z;
        q[5] = l.x;
        q[6] = l.y;
        q[7] = l.z;
        q[8] = kin[KPOW_OFF + i];
        q[9] = dot(v, v);
        var bad = 0.0;
        for (var k = 0u; k < 3u; k++) {
            if !finite(u[k]) || !finite(v[k]) {
                bad = 1.0;
            }
        }
        if !finite(q[1]) {
            bad = 1.0;
        }
        q[10] = bad;
        q[11] = pair_wave_speed(i);
        q[12] = viscous_dissipation(i);
    }
    sums[lid] = q;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if lid < stride {
            for (var k = 0u; k < REDUCED; k++) {
                if k == 9u || k == 11u {
                    sums[lid][k] = max(sums[lid][k], sums[lid + stride][k]);
                } else {
                    sums[lid][k] += sums[lid + stride][k];
                }
            }
        }
        workgroupBarrier();
    }
    // A dispatch may hold workgroups past the part's rows (Gpu::groups): they write no
    // partial, so as not to overwrite the next part's.
    let group = group_index(wid, nwg);
    if lid == 0u && group * 256u < part.rows {
        let slot = part.first / 256u + group;
        for (var k = 0u; k < REDUCED; k++) {
            partials[slot * REDUCED + k] = sums[0][k];
        }
    }
}
