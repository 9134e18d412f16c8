// The reference configuration on the device (src/gpu/reference.rs), one flat buffer
// `reference` of fields at RX_OFF (X, the f32 part of the hi + lo split, DIM per
// particle), RXLO_OFF (the lo part), RXREL_OFF (X − X̄ about the volume-weighted
// centroid), RVOL_OFF (V), RMASK_OFF (the prescribed velocity components, bit k for
// component k, as an f32 integer) and RSLOT_OFF (a constrained particle's index among the
// constrained particles, an f32 integer). Needs the binding `reference`.

fn x0_of(i: u32) -> vecd {
    return vload_reference(RX_OFF + DIM * i);
}

fn vol_of(i: u32) -> f32 {
    return reference[RVOL_OFF + i];
}

fn mask_of(i: u32) -> u32 {
    return u32(reference[RMASK_OFF + i]);
}

fn slot_of(i: u32) -> u32 {
    return u32(reference[RSLOT_OFF + i]);
}
