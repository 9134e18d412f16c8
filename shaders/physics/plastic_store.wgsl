// The commit of a returned point into the plastic history (plasticity.wgsl's layout: 12
// floats per point), for the passes that declare hist read_write: [C_p⁻¹]ⁿ⁺¹, ε_pⁿ⁺¹, the
// temperature rise ΔTⁿ + χ w/(ρ0 c_p) of the step's plastic work w (History::commit), and
// the Δt of the steps being recorded (the slot after the last point), over which the
// point's next returns are.

fn store_history(a: u32, r: Returned) {
    let o = 12u * a;
    if THERMAL_SPAN > 0.0 {
        let h = history(a);
        hist[o + 10u] = h.heat + HEATING * plastic_work(h, r.eps_p - h.eps_p);
    }
    for (var c = 0u; c < 3u; c++) {
        hist[o + 3u * c] = r.cp_inv[c].x;
        hist[o + 3u * c + 1u] = r.cp_inv[c].y;
        hist[o + 3u * c + 2u] = r.cp_inv[c].z;
    }
    hist[o + 9u] = r.eps_p;
    hist[o + 11u] = hist[arrayLength(&hist) - 1u];
}
