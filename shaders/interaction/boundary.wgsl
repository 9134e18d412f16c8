// Boundary conditions of a rate pass (src/boundary.rs), shared by the rate passes of every
// method: the external acceleration of the loads ext[i] is added, then prescribed velocity
// components (bit k of mask_of(i), reference.wgsl) get their rate: zero, or, where bit
// k + 4 is set too (a timed velocity held over the step, prescribed.wgsl), the rate in
// the particle's slot s = slot_of(i) of the field RATE. kin[KPOW_OFF + i] receives the
// power of the support reactions and the loads on the particle, m (a_ext · v) +
// Σ_k∈prescribed m (a_k,prescribed − a_k) v_k, for the work balance of the energy check.
// A constrained particle also writes its reaction m (a_k,prescribed − a_k) and that
// reaction's power per component to its slot of the fields KRF and KRP of kin, which the
// host books to the supports (`Boundary::reactions`).
// Needs the bindings reference, ext (DIM per particle) and kin (read_write).

fn apply_boundary(i: u32, acc: vecd, v: vecd, mass: f32) -> vecd {
    let ext_i = vload_ext(DIM * i);
    var a = acc + ext_i;
    var pw = mass * dot(ext_i, v);
    let m = mask_of(i);
    if m != 0u {
        let s = slot_of(i);
        var force = vecd(0.0);
        var power = vecd(0.0);
        for (var k = 0u; k < DIM; k++) {
            if ((m >> k) & 1u) != 0u {
                let timed = ((m >> (k + 4u)) & 1u) != 0u;
                let rate = select(0.0, reference[RRATE_OFF + DIM * s + k], timed);
                force[k] = mass * (rate - a[k]);
                power[k] = force[k] * v[k];
                pw += power[k];
                a[k] = rate;
            }
        }
        vstore_kin(KRF_OFF + DIM * s, force);
        vstore_kin(KRP_OFF + DIM * s, power);
    }
    kin[KPOW_OFF + i] = pw;
    return a;
}
