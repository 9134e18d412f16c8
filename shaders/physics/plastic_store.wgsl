// The commit of a returned point into the plastic history (plasticity.wgsl's layout: 10
// floats per point, [C_p⁻¹]ⁿ⁺¹ by columns then ε_pⁿ⁺¹), for the passes that declare hist
// read_write.

fn store_history(a: u32, r: Returned) {
    let o = 10u * a;
    for (var c = 0u; c < 3u; c++) {
        hist[o + 3u * c] = r.cp_inv[c].x;
        hist[o + 3u * c + 1u] = r.cp_inv[c].y;
        hist[o + 3u * c + 2u] = r.cp_inv[c].z;
    }
    hist[o + 9u] = r.eps_p;
}
