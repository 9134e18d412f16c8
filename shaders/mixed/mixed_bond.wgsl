// The bond-based deformation gradient of seed 002 (MixedSph::bond_based_f), one invocation
// per real particle gathering over its pairs: F^c_a = F_a + Σ_b w_ab [(x_b − x_a) − F_a X_ab]
// ⊗ X_ab with w_ab = V_b W̃_b(X_a)/|X_ab|² (eqs 37, 39 with the self-bond). In excesses
// f = F − I the X_ab of x_b − x_a and of F_a X_ab cancel analytically:
//   F^c_a − I = f_a + Σ_b w_ab [(u_b − u_a) − f_a X_ab] ⊗ X_ab,
// or with KINEMATIC_BOND eq 38's F^c_a − I = f_a + Σ_b w_ab [x_ab ⊗ X_ab − |X_ab|² F_a],
// with u of the ghosts from the ghost motion, X_ab at PDX_OFF and w_ab at PW_OFF of
// `pair`. Writes F^c − I of its own particle at KFC_OFF of kin, which the kinematics and
// the strain energy read in place of F. Layout and constants: mixed.wgsl.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> y: array<f32>;
@group(0) @binding(4) var<storage, read_write> kin: array<f32>;

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// X_b − X_a and the bond weight.
// - pair: 1 scalar + 1 vector per pair
// u, F; ghosts' u from kin.
// - y: 1 vector + 1 tensor per item
// - kin stores: 1 tensor per item
@compute @workgroup_size(256)
fn bond_f(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    let f = mload_y(F_OFF + DIM * DIM * a);
    let u_a = displacement(a);
    var f_c = f;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let x = vload_pair(PDX_OFF + DIM * p);
        let du = displacement(ids[p]) - u_a;
        if KINEMATIC_BOND == 1u {
            // Eq 38: w_ab [x_ab ⊗ X_ab − |X_ab|² F_a] in excesses.
            f_c += (outer(du + x, x) - (identity_d() + f) * dot(x, x)) * pair[PW_OFF + p];
        } else {
            f_c += outer(du - f * x, x * pair[PW_OFF + p]);
        }
    }
    mstore_kin(KFC_OFF + DIM * DIM * a, f_c);
}
