// Set-up of the pair data's reverse gradients (field GREV), for the pair forces that
// derive from Σ_i V_i ψ(F_i) (seed 000 eq 148). The host file declares `pair` read_write
// (with vload_pair/vstore_pair) and the constants PAIRS, PG_OFF and PGREV_OFF; rev holds
// the index of the pair (j, i) of every pair (i, j).

@group(0) @binding(8) var<storage, read> rev: array<u32>;

// One invocation per pair p = (i, j): ∇0W̃_ji, j's corrected gradient towards i.
// bytes:
// - rev: 1 scalar per item
// - pair loads: 1 vector per item
// - pair stores: 1 vector per item
@compute @workgroup_size(256)
fn reverse_gradients(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = index(gid, nwg);
    if p >= PAIRS {
        return;
    }
    vstore_pair(PGREV_OFF + DIM * p, vload_pair(PG_OFF + DIM * rev[p]));
}
