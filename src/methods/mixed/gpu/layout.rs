//! The flat buffers of a mixed scene, its compiled-in constants and its per-pair data.

use super::*;

/// The flat buffers of a mixed scene, each described once ([`Fields`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MixedLayout {
    /// Real particles and ghosts.
    pub n: usize,
    pub ghosts: usize,
    pub dim: usize,
    /// The kinematics keep H for the D(J) gather (Upwind-SPH with J evolved).
    pub kin_h: bool,
    /// The state [u | v | F − I | H − I | J − 1 | p] of the real particles (H and J where
    /// evolved, the pressure p under artificial compressibility).
    pub state: Fields,
    /// [P | H − I] of the real particles then the ghosts, the ghost motion [u | v], the
    /// bond-based F^c − I and the power of supports and loads.
    pub kin: Fields,
    /// [T | D(p) | D(J)] of the real particles and the projection's λ, μ, c − X̄ (vec3
    /// padded to four floats each).
    pub force: Fields,
    /// Per pair in CSR order: G_ab = V_b g_ab, G_ba = V_b g_ba, d_ab = X_b − X_a (upwind
    /// flux, bond-based F), s_ab (JST), w_ab (least-squares slopes), ℓ_ab (JST
    /// Laplacian), w_ab (bond-based F), ℓ_ab of the pseudo-viscosity (eq 58).
    pub pair: Fields,
    pub reference: Fields,
    /// SUPG-SPH (mixed_supg.wgsl): per extended particle what the stress points read,
    /// [F − I | ∇0v | Ḣ | J̇ | H − I | J − 1 | q | P | u | v] (H, J and their rates where
    /// evolved).
    pub nodes: Fields,
    /// SUPG-SPH: N_b and G_b per entry of the stress points' rows, and w_s per point.
    pub shapes: Fields,
    /// SUPG-SPH: ΔP_s and Δv_s per stress point.
    pub terms: Fields,
    /// The corrector of artificial compressibility (mixed_corrector.wgsl): the iterate
    /// [w | δp] = [v − v^int | p − p^n], its pseudo stage, their rates, v^int, p^n, H^n
    /// and the constant part c of the pressure equation.
    pub corr: Fields,
}

/// What sizes the buffers of a mixed scene: its counts, and the options that add fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sizes {
    /// Real particles, mirror particles, neighbour pairs (ghost neighbours among them)
    /// and particles with prescribed components.
    pub n: usize,
    pub ghosts: usize,
    pub pairs: usize,
    pub constrained: usize,
    pub evolves_h: bool,
    pub evolves_j: bool,
    /// Artificial compressibility, and its pseudo-viscosity (α > 0).
    pub ac: bool,
    pub pseudo_viscosity: bool,
    pub jst: bool,
    /// SUPG-SPH: its stress points and the entries of their rows (zero for the other
    /// stabilisations).
    pub points: usize,
    pub point_pairs: usize,
    pub supg: bool,
    /// The bond-based F.
    pub bond: bool,
    /// Upwind-SPH's linear reconstruction.
    pub reconstruction: bool,
}

impl Sizes {
    /// The sizes of the scene set up in `cpu`.
    pub(super) fn of_system<D: Dim>(cpu: &MixedSph<D>) -> Self {
        let n = cpu.reference().len();
        let corrector = cpu.corrector();
        let points = cpu.stress_points().map(|(_, s)| s);
        Self {
            n,
            ghosts: cpu.extended_reference().0.len() - n,
            pairs: cpu.neighbours().pair_count(),
            constrained: cpu.boundary().constrained.len(),
            evolves_h: cpu.conserved().evolves_h(),
            evolves_j: cpu.evolves_j(),
            ac: corrector.is_some(),
            pseudo_viscosity: corrector.is_some_and(|c| c.laplacian_weights().is_some()),
            jst: cpu.jst().is_some(),
            points: points.map_or(0, |s| s.len()),
            point_pairs: points.map_or(0, |s| s.shapes.csr.ids.len()),
            supg: points.is_some(),
            bond: cpu.bond_weights().is_some(),
            reconstruction: cpu.reconstruction(),
        }
    }

    /// The sizes a scene of `case` under `spec` will have on `counts`, before it is set
    /// up (the constrained particles' reaction slots, a surface's few words each, left
    /// out): what [`Self::of_system`] gives once it is. SUPG-SPH's stress points are
    /// those of a lattice of one cell a particle: 2^d points of 2^d corners each.
    pub fn of_case(case: &Case, spec: &dyn MixedScheme, counts: &Counts) -> Self {
        let options = spec.options();
        let conserved = options.evolved(case.material.model);
        let ac = options.artificial_compressibility.as_ref();
        let stabiliser = spec.stabiliser();
        let supg = matches!(stabiliser, Stabiliser::Supg(_));
        let n = Counts::whole(counts.particles);
        let corners = 1 << case.dim();
        let points = if supg { corners * n } else { 0 };
        Self {
            n,
            ghosts: Counts::whole(counts.ghosts),
            pairs: Counts::whole(counts.pairs),
            constrained: 0,
            evolves_h: conserved.evolves_h(),
            evolves_j: conserved.evolves_j() && ac.is_none(),
            ac: ac.is_some(),
            pseudo_viscosity: ac.is_some_and(|a| a.alpha > 0.0),
            jst: matches!(stabiliser, Stabiliser::Jst(_)),
            points,
            point_pairs: corners * points,
            supg,
            bond: options.bond_based(),
            reconstruction: matches!(
                stabiliser,
                Stabiliser::Upwind {
                    reconstruction: true
                }
            ),
        }
    }
}

impl MixedLayout {
    /// The layout of the scene set up in `cpu`, whose per-pair buffers hold `pairs` pairs
    /// each (the most of a part of the lists).
    pub fn of<D: Dim>(cpu: &MixedSph<D>, pairs: usize) -> Self {
        let sizes = Sizes {
            pairs,
            ..Sizes::of_system(cpu)
        };
        Self::new(&sizes, D::N)
    }

    /// The layout of a scene of `sizes` in `dim` dimensions.
    pub fn new(sizes: &Sizes, dim: usize) -> Self {
        let Sizes {
            n,
            ghosts,
            pairs,
            constrained,
            evolves_h,
            evolves_j,
            ac,
            pseudo_viscosity,
            jst,
            points,
            point_pairs,
            supg,
            bond,
            reconstruction,
        } = *sizes;
        let upwind = !jst && !supg;
        let ne = n + ghosts;
        let kin_h = upwind && evolves_j;
        Self {
            n,
            ghosts,
            dim,
            kin_h,
            state: Fields::new("", dim)
                .vectors("U", true, n)
                .vectors("V", true, n)
                .tensors("F", true, n)
                .tensors("H", evolves_h, n)
                .scalars("J", evolves_j, n)
                .scalars("PRES", ac, n),
            kin: reduction::with_reactions(
                Fields::new("K", dim)
                    .tensors("P", true, n + ghosts)
                    .tensors("H", kin_h, n + ghosts)
                    .vectors("GM", true, 2 * ghosts)
                    .tensors("FC", bond, n)
                    .scalars("POW", true, n),
                constrained,
            ),
            force: Fields::new("F", dim)
                .vectors("T", true, n)
                .vectors("D", true, n)
                .scalars("J", true, n)
                .block("PROJ", true, 3, 4),
            pair: Fields::new("P", dim)
                .vectors("G", true, pairs)
                .vectors("GR", true, pairs)
                .vectors("DX", upwind || bond, pairs)
                .scalars("S", jst, pairs)
                .vectors("LS", upwind && reconstruction, pairs)
                .scalars("ELL", jst, pairs)
                .scalars("W", bond, pairs)
                .scalars("BL", pseudo_viscosity, pairs),
            reference: reference::fields(n, constrained, dim, EXTRAS),
            nodes: Fields::new("SN", dim)
                .tensors("F", supg, ne)
                .tensors("GV", supg, ne)
                .tensors("HD", supg && evolves_h, ne)
                .scalars("JD", supg && evolves_j, ne)
                .tensors("H", supg && evolves_h, ne)
                .scalars("J", supg && evolves_j, ne)
                .vectors("Q", supg, ne)
                .tensors("P", supg, ne)
                .vectors("U", supg, ne)
                .vectors("V", supg, ne),
            shapes: Fields::new("SS", dim)
                .scalars("N", supg, point_pairs)
                .vectors("G", supg, point_pairs)
                .scalars("W", supg, points),
            terms: Fields::new("ST", dim)
                .tensors("DP", supg, points)
                .vectors("DV", supg, points),
            corr: [("V", "Q"), ("V1", "Q1"), ("RV", "RQ")]
                .into_iter()
                .fold(Fields::new("C", dim), |c, (w, dp)| {
                    c.vectors(w, ac, n).scalars(dp, ac, n)
                })
                .vectors("VI", ac, n)
                .scalars("PN", ac, n)
                .tensors("HN", ac, n)
                .scalars("C", ac, n),
        }
    }

    /// A mixed state as a flat f32 state: F − I, H − I and J − 1 are formed in f64.
    pub(super) fn encode<D: GpuDim>(&self, y: &MixedState<D>) -> Vec<f32> {
        let l = &self.state;
        let mut flat = l.zeroed();
        l.write_v::<D>(&mut flat, "U", &y.u);
        l.write_v::<D>(&mut flat, "V", &y.v);
        l.write_t::<D>(&mut flat, "F", &y.f, D::identity());
        l.write_t::<D>(&mut flat, "H", &y.h, D::identity());
        l.write_s(&mut flat, "J", &y.j, 1.0);
        l.write_s(&mut flat, "PRES", &y.pressure, 0.0);
        flat
    }

    /// Decodes a flat state (`excess`: F, H, J are stored less I, I, 1) or rate buffer.
    pub(super) fn decode<D: GpuDim>(&self, flat: &[f32], excess: bool) -> MixedState<D> {
        let (one_t, one) = if excess {
            (D::identity(), 1.0)
        } else {
            (D::zero_t(), 0.0)
        };
        let l = &self.state;
        MixedState {
            u: l.read_v::<D>(flat, "U"),
            v: l.read_v::<D>(flat, "V"),
            f: l.read_t::<D>(flat, "F", one_t),
            h: l.read_t::<D>(flat, "H", one_t),
            j: l.read_s(flat, "J", one),
            pressure: l.read_s(flat, "PRES", 0.0),
        }
    }
}

/// The reference fields the mixed passes read besides X and V: X − X̄ for the projection.
pub(super) const EXTRAS: Extras = Extras {
    lo: false,
    centred: true,
};

/// The layout and compiled-in constants of a scene's mixed passes, from its CPU set-up,
/// with per-pair buffers of `pairs` pairs each (the most of a part of the lists).
///
/// Under artificial compressibility the material's constants are the predictor's: BULK
/// and LAMBDA of κ̃, and C_P = c̃_p; the true κ enters the corrector as INV_BULK = 1/κ,
/// zero at ν = 0.5.
pub fn scene<D: GpuDim>(
    case: &Case,
    options: &MixedOptions,
    cpu: &MixedSph<D>,
    pairs: usize,
) -> (MixedLayout, Constants) {
    let layout = MixedLayout::of(cpu, pairs);
    let l = &layout;
    let spec = options.artificial_compressibility;
    let material = &match spec {
        Some(ac) => ac.predictor(cpu.material()),
        None => *cpu.material(),
    };
    let corrector = cpu.corrector();
    let total_vol: f64 = cpu.volume().iter().sum();
    let jst = cpu.jst();
    let (eps2, eps4) = jst.map_or((0.0, 0.0), |(c, ..)| (c.eps2, c.eps4));
    let supg = cpu.stress_points();
    let stab = match (jst, supg) {
        (Some(_), _) => 1,
        (None, Some(_)) => 2,
        (None, None) => 0,
    };
    let parameters = supg.map(|(p, _)| p);
    let u = |x: usize| x as u32;
    let constants = Constants::default()
        .u32("N", u(l.n))
        .u32("BODIES", u(case.bodies.len()))
        .u32("NG", u(l.ghosts))
        .material(material)
        .f32("C_P", material.p_wave_speed())
        .f32("C_S", material.s_wave_speed())
        .f32("SPACING", case.spacing)
        .u32(
            "PAIR_STRETCH",
            u32::from(cpu.cfl_wave_speed() == CflWaveSpeed::Pair),
        )
        .f32("H", cpu.smoothing_length())
        .choice("STAB", &["UPWIND", "JST", "SUPG"], stab)
        .u32("RECON", u32::from(cpu.reconstruction()))
        .f32("EPS2", eps2)
        .f32("EPS4", eps4)
        .choice(
            "MOMENTUM",
            &["WEAK", "SYMMETRISED"],
            usize::from(cpu.momentum() == Momentum::Symmetrised),
        )
        .u32("EVOLVE_H", u32::from(l.state.has("H")))
        .u32("EVOLVE_J", u32::from(l.state.has("J")))
        .u32("KIN_H", u32::from(l.kin_h))
        .u32("BOND", u32::from(l.kin.has("FC")))
        .u32("KINEMATIC_BOND", u32::from(cpu.kinematic_bond()))
        .u32("PROJECTION", u32::from(cpu.projection()))
        .u32("GROUPS", u(l.n).div_ceil(WORKGROUP))
        .f32("TOTAL_VOL", total_vol)
        .u32("REST_OFF", u(l.state.offset("F")))
        .u32("AC", u32::from(corrector.is_some()))
        .f32("INV_BULK", corrector.map_or(0.0, |c| 1.0 / c.kappa()))
        .f32("TOLERANCE", corrector.map_or(0.0, |c| c.tolerance()))
        .u32(
            "MAX_ITERATIONS",
            corrector.map_or(0, |c| c.max_iterations()),
        )
        .u32("PSEUDO_VISCOSITY", u32::from(l.pair.has("BL")))
        .u32("NS", supg.map_or(0, |(_, s)| u(s.len())))
        .f32("TAU_F", parameters.map_or(0.0, |p| p.tau_f))
        .f32("TAU_P", parameters.map_or(0.0, |p| p.tau_p))
        .f32("XI_F", parameters.map_or(0.0, |p| p.xi_f));
    let fields = [&l.state, &l.kin, &l.force, &l.pair, &l.reference, &l.corr];
    let constants = (fields.into_iter())
        .chain([&l.nodes, &l.shapes, &l.terms])
        .fold(constants, |c, fields| fields.constants(c));
    (layout, constants)
}

/// The per-pair buffer of each part of `split` of the lists of the scene set up in `cpu`,
/// host side (f32), laid out as `l`.
pub(super) fn pair_data<D: GpuDim>(
    cpu: &MixedSph<D>,
    l: &Fields,
    split: &Split,
) -> impl Iterator<Item = Vec<f32>> {
    let csr = cpu.neighbours();
    let (x0, vol) = cpu.extended_reference();
    let (grad, grad_rev) = cpu.pair_gradients();
    let rows = || (0..csr.len()).flat_map(|a| csr.range(a).map(move |q| (a, q)));
    // Gradients scaled by V_b: G_b(X_a) = V_b g_ab.
    let scaled = |g: &[D::V]| -> Vec<D::V> {
        rows()
            .map(|(_, q)| g[q] * vol[csr.ids[q] as usize])
            .collect()
    };
    // The fields of every pair, then each part's share.
    let whole = l.resized(csr.pair_count());
    let mut flat = whole.zeroed();
    whole.write_v::<D>(&mut flat, "G", &scaled(grad));
    whole.write_v::<D>(&mut flat, "GR", &scaled(grad_rev));
    if whole.has("DX") {
        let d: Vec<D::V> = rows()
            .map(|(a, q)| x0[csr.ids[q] as usize] - x0[a])
            .collect();
        whole.write_v::<D>(&mut flat, "DX", &d);
    }
    if let Some((_, ell, s)) = cpu.jst() {
        whole.write_s(&mut flat, "S", s, 0.0);
        whole.write_s(&mut flat, "ELL", ell, 0.0);
    }
    if whole.has("LS") {
        whole.write_v::<D>(&mut flat, "LS", cpu.ls_weights());
    }
    if let Some(w) = cpu.bond_weights() {
        whole.write_s(&mut flat, "W", w, 0.0);
    }
    if let Some(ell) = cpu.corrector().and_then(|c| c.laplacian_weights()) {
        whole.write_s(&mut flat, "BL", ell, 0.0);
    }
    (split.parts.clone().into_iter()).map(move |p| l.items_of(&whole, &flat, p.start, p.pairs))
}
