// Shared by the gathers of the mixed passes, which bind the state y and the kinematics
// kin.

// Displacement and velocity of extended particle b: the state, or the ghost motion
// [u | v] (NG·DIM each) at KGM_OFF of kin, written by the ghost fill.
fn displacement(b: u32) -> vecd {
    if b < N {
        return vload_y(U_OFF + DIM * b);
    }
    return vload_kin(KGM_OFF + DIM * (b - N));
}

fn velocity(b: u32) -> vecd {
    if b < N {
        return vload_y(V_OFF + DIM * b);
    }
    return vload_kin(KGM_OFF + DIM * (NG + b - N));
}

// F − I of the stress of real particle a: the evolved F, or the bond-based F^c − I
// (seed 002) that mixed_bond.wgsl wrote at KFC_OFF of kin.
fn stress_excess(a: u32) -> matd {
    if BOND == 1u {
        return mload_kin(KFC_OFF + DIM * DIM * a);
    }
    return mload_y(F_OFF + DIM * DIM * a);
}

// H − I of real particle a whose stress takes f = F − I: the evolved H, or cof F.
fn h_excess(a: u32, f: matd) -> matd {
    if EVOLVE_H == 1u {
        return mload_y(H_OFF + DIM * DIM * a);
    }
    return cof_excess(f);
}
