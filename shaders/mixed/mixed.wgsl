// Shared by the mixed {p, F, H, J} passes (seed 003; src/method/mixed.rs).
//
// Buffers are flat f32 arrays in structure-of-arrays segments. The state of the N real
// particles is y = [u | v | F − I | H − I | J − 1] (H only for {p, F, H, J}, J for
// {p, F, J} and {p, F, H, J}): the excesses keep their digits at small strain in f32, as
// u = x − X does for positions, and a ghost maps them like two-point tensors. The NG
// ghosts follow the real particles in the extended index (ghost k is N + k); per-pair
// data are in CSR order over the real rows, whose neighbour ids may be ghosts:
// pair = [G_ab | G_ba | d_ab | s_ab | w_ab (least squares) | ℓ_ab | w_ab (bond)], each
// where the scene uses it. The passes over the pairs run a part of the lists at a time
// (part.wgsl: rows part.first + row, offsets and pair data of the part's own). The kinematics kin = [P | H − I | ghost motion | F^c − I |
// power] (H only where D(J) gathers it, F^c with the bond-based F), the slopes and the
// Laplacians hold the real particles then the ghosts (filled by mixed_ghosts.wgsl). The
// stress is evaluated at stress_excess(a) (mixed_motion.wgsl): the evolved F − I, or the
// bond-based F^c − I of mixed_bond.wgsl (BOND = 1, seed 002). The field offsets are those
// of methods::mixed::gpu::MixedLayout.
//
// Scene constants: N, NG, DIM, MODEL, RHO0, MU, LAMBDA, BULK, YIELD, HARDENING (von Mises
// model, plasticity.wgsl), C_P, C_S, SPACING
// (particle spacing Δx), PAIR_STRETCH (1: the CFL step's C_p,ij = C_P / λ^Ave_ij, 0:
// C_P), H (smoothing length), STAB (STAB_UPWIND, STAB_JST or STAB_SUPG), RECON, EPS2, EPS4,
// MOMENTUM (MOMENTUM_WEAK or MOMENTUM_SYMMETRISED), EVOLVE_H, EVOLVE_J, KIN_H, BOND,
// PROJECTION, GROUPS (workgroups over N), TOTAL_VOL, and the field offsets.

// Size of one particle's slopes: ∇0v, then ∂P/∂X_l for l < DIM.
const SLOPE: u32 = (DIM + 1u) * DIM * DIM;

// Pair b's share of the internal force T_a of the stresses P_a, P_b with G_ab = V_b g_ab
// and G_ba = V_b g_ba (pair_force of system.rs): P_b G_ba − P_a G_ab (eq 21), or
// −½ (P_a + P_b)(G_ab − G_ba) (seed 002 eq 22).
fn pair_force(p_a: matd, p_b: matd, g_ab: vecd, g_ba: vecd) -> vecd {
    if MOMENTUM == MOMENTUM_SYMMETRISED {
        return (p_a + p_b) * (g_ab - g_ba) * -0.5;
    }
    return p_b * g_ba - p_a * g_ab;
}
