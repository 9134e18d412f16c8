// Boundary conditions of a rate pass (src/boundary.rs), shared by the TLSPH and mixed
// passes: the external acceleration of tractions ext[i] is added, prescribed velocity
// components (bit k of mask_of(i), reference.wgsl) get their rate: zero, or, where bit
// k + 4 is set too (a timed velocity held over the step, prescribed.wgsl), ext[i]'s
// component, which then holds that rate; kin[KPOW_OFF + i] receives the power of the
// support reactions and traction loads on the particle, m (a_ext · v) +
// Σ_k∈prescribed m (a_k,prescribed − a_k) v_k, for the work balance of the energy check.
// Needs the bindings reference, ext (DIM per particle) and kin (read_write).

fn apply_boundary(i: u32, acc: vecd, v: vecd, mass: f32) -> vecd {
    let ext_i = vload_ext(DIM * i);
    var a = acc + ext_i;
    var pw = mass * dot(ext_i, v);
    let m = mask_of(i);
    for (var k = 0u; k < DIM; k++) {
        if ((m >> k) & 1u) != 0u {
            let rate = select(0.0, ext_i[k], ((m >> (k + 4u)) & 1u) != 0u);
            pw += mass * (rate - a[k]) * v[k];
            a[k] = rate;
        }
    }
    kin[KPOW_OFF + i] = pw;
    return a;
}
