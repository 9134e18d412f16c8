// Shared by the gathers of the mixed passes, which bind the state y and the ghost motion gm.

// Displacement and velocity of extended particle b: the state, or the ghost motion
// gm = [u | v] (NG·DIM each) written by the ghost fill.
fn displacement(b: u32) -> vecd {
    if b < N {
        return vload_y(U_OFF + DIM * b);
    }
    return vload_gm(DIM * (b - N));
}

fn velocity(b: u32) -> vecd {
    if b < N {
        return vload_y(V_OFF + DIM * b);
    }
    return vload_gm(DIM * (NG + b - N));
}
