// Pass 3 of a mixed rate evaluation (MixedSph::forces), one invocation per real particle
// gathering over its pairs, with G_ab = V_b g_ab and G_ba = V_b g_ba:
//   T_a = Σ_b [P_b G_ba − P_a G_ab] (eqs 20–21), or symmetrised (MOMENTUM_SYMMETRISED):
//   T_a = −½ Σ_b (P_a + P_b)(G_ab − G_ba) (seed 002 eq 22);
//   Upwind-SPH: D(p_a) = Σ_b (S^p Δp)(N_ab · (G_ab − G_ba)) (eqs 28, 32) with the jumps
//   reconstructed to the mid-pair face (eq 37, "−" from a, "+" from b) and n_ab from the
//   current positions; D(J_a) = Σ_b p^stab/ρ0 · (H_a G_ab − H_b G_ba) (eq 33 with the
//   dissipative sign), p^stab = n (n · ΔP N_ab)/(2 c_p), only where J is evolved;
//   JST-SPH: D(p_a) = ½ c_p ρ0 Σ_b s_ab (ε⁽²⁾ h Δv − ε⁽⁴⁾ h³ Δ∇²v) (seed 002 eq 28);
//   SUPG-SPH: D(p_a) = 0 here, its terms gathered from the stress points (mixed_supg.wgsl).
// Writes force = [T | D(p) | D(J)] of its own particle. Per pair: G_ab, G_ba, and
// d_ab = X_b − X_a (Upwind-SPH) or s_ab (JST-SPH). Layout and constants: mixed.wgsl.

@group(0) @binding(0) var<storage, read> offsets: array<u32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> pair: array<f32>;
@group(0) @binding(3) var<storage, read> y: array<f32>;
@group(0) @binding(4) var<storage, read> kin: array<f32>;
@group(0) @binding(5) var<storage, read_write> force: array<f32>;
// Upwind with reconstruction: the slopes; JST: the Laplacians; else unused.
@group(0) @binding(6) var<storage, read> second: array<f32>;

// Least-squares slopes of an extended particle: ∇0v and ∂P/∂X_l.
struct Slopes {
    v: matd,
    p: array<matd, 3>,
}

fn slopes_of(b: u32) -> Slopes {
    var s: Slopes;
    s.v = mload_second(SLOPE * b);
    for (var l = 0u; l < DIM; l++) {
        s.p[l] = mload_second(SLOPE * b + (l + 1u) * DIM * DIM);
    }
    return s;
}

// bytes:
// - offsets: 1 scalar per item
// - ids: 1 scalar per pair
// ∇0W̃_ab, ∇0W̃_ba; X_b − X_a (upwind) or the JST scale.
// - pair: 2 vectors per pair
// - pair: 1 vector per pair, when STAB == STAB_UPWIND
// - pair: 1 scalar per pair, when STAB == STAB_JST
// v; u orients the upwind flux.
// - y: 1 vector per item
// - y: 1 vector per item, when STAB == STAB_UPWIND
// P (and H).
// - kin: 1 tensor per item
// - kin: 1 tensor per item, when KIN_H
// The Laplacian (JST) or the slopes (reconstruction).
// - second: 1 vector per item, when STAB == STAB_JST
// - second: 1 slope per item, when STAB == STAB_UPWIND and RECON
// T, D(p), D(J).
// - force: 1 scalar + 2 vectors per item
@compute @workgroup_size(256)
fn forces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let row = index(gid, nwg);
    if row >= part.rows {
        return;
    }
    let a = part.first + row;
    let p_a = mload_kin(KP_OFF + DIM * DIM * a);
    var h_a: matd;
    if KIN_H == 1u {
        h_a = identity_d() + mload_kin(KH_OFF + DIM * DIM * a);
    }
    let u_a = displacement(a);
    let v_a = velocity(a);
    var lap_a: vecd;
    var s_a: Slopes;
    if STAB == STAB_JST {
        lap_a = vload_second(DIM * a);
    } else if RECON == 1u {
        s_a = slopes_of(a);
    }
    var t: vecd;
    var dp_sum: vecd;
    var dj = 0.0;
    let p_end = offsets[row + 1u];
    for (var p = offsets[row]; p < p_end; p++) {
        let b = ids[p];
        let g_ab = vload_pair(PG_OFF + DIM * p);
        let g_ba = vload_pair(PGR_OFF + DIM * p);
        let p_b = mload_kin(KP_OFF + DIM * DIM * b);
        t += pair_force(p_a, p_b, g_ab, g_ba);
        let v_b = velocity(b);
        if STAB == STAB_UPWIND {
            let d_ab = vload_pair(PDX_OFF + DIM * p);
            let n_ref = normalize(d_ab);
            var dv = v_b - v_a;
            var dp = p_b - p_a;
            if RECON == 1u {
                // eq 37: the face at the mid-pair, 𝒰⁻ = 𝒰_a + ½𝒢_a·d, 𝒰⁺ = 𝒰_b − ½𝒢_b·d.
                var s_b = slopes_of(b);
                var slope_p: matd;
                for (var l = 0u; l < DIM; l++) {
                    slope_p += (s_a.p[l] + s_b.p[l]) * d_ab[l];
                }
                dv -= (s_a.v + s_b.v) * d_ab * 0.5;
                dp -= slope_p * 0.5;
            }
            let n = normalize(d_ab + displacement(b) - u_a);
            // eq 28: S^p Δp = ½[c_p n (n·Δp) + c_s (Δp − n (n·Δp))], Δp = ρ0 Δv.
            let dp_mom = dv * RHO0;
            let normal_part = n * dot(n, dp_mom);
            let s_dp = (normal_part * C_P + (dp_mom - normal_part) * C_S) * 0.5;
            dp_sum += s_dp * dot(n_ref, g_ab - g_ba);
            if KIN_H == 1u {
                let p_stab = n * (dot(n, dp * n_ref) / (2.0 * C_P));
                let h_b = identity_d() + mload_kin(KH_OFF + DIM * DIM * b);
                dj += dot(p_stab, h_a * g_ab - h_b * g_ba) / RHO0;
            }
        } else if STAB == STAB_JST {
            let lap = vload_second(DIM * b) - lap_a;
            dp_sum += ((v_b - v_a) * (EPS2 * H) - lap * (EPS4 * H * H * H)) * (0.5 * C_P * RHO0 * pair[PS_OFF + p]);
        }
    }
    vstore_force(FT_OFF + DIM * a, t);
    vstore_force(FD_OFF + DIM * a, dp_sum);
    force[FJ_OFF + a] = dj;
}
