//! Mixed {p, F, H, J} total-Lagrangian SPH (seed 003, with the options of seed 002):
//! Upwind-SPH, JST-SPH and SUPG-SPH. The specs, the CPU system ([`system`], with its pair
//! weights in [`weights`], the angular-momentum projection in [`projection`], artificial
//! compressibility in [`compressibility`] and SUPG's stress points in [`stress_points`])
//! and the GPU engine ([`gpu`], with the corrector of artificial compressibility in
//! `gpu_corrector`). Numerics notes: `docs/methods/mixed.md`.

pub mod compressibility;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(feature = "gpu")]
mod gpu_corrector;
pub mod projection;
pub mod stress_points;
pub mod system;
pub mod weights;

pub use compressibility::ArtificialCompressibility;
#[cfg(feature = "gpu")]
pub use gpu::GpuMixed;
pub use system::{Fluxes, MixedSph, MixedState};

use crate::engine::ranks::RankStart;
#[cfg(feature = "gpu")]
use crate::methods::cores::family::GpuBuild;
use crate::methods::cores::family::{CpuBuild, Feature, MethodFamily, Plan, RankBuild};
use crate::methods::cores::shared;
use crate::reference::Reference;

use crate::case::Case;
use crate::core::check::{Problem, fail, non_negative, toml_name};
use crate::core::tensor::{Dim, smallest_stretch_squared};
use crate::engine::{CpuEngine, EngineDim};
use crate::physics::material::{Material, MaterialModel};
use serde::{Deserialize, Serialize};

/// Which geometric conservation laws a mixed method evolves besides p and F (seed 003 §6);
/// the others are computed from F (H = cof F, J = det F).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
pub enum Conserved {
    #[serde(rename = "p-F")]
    PF,
    #[serde(rename = "p-F-J")]
    PFJ,
    #[default]
    #[serde(rename = "p-F-H-J")]
    PFHJ,
}

impl Conserved {
    pub const ALL: [Conserved; 3] = [Self::PF, Self::PFJ, Self::PFHJ];

    pub fn evolves_h(self) -> bool {
        self == Self::PFHJ
    }

    pub fn evolves_j(self) -> bool {
        self != Self::PF
    }
}

/// JST dissipation: coefficients ε⁽²⁾ (Laplacian) and ε⁽⁴⁾ (bi-Laplacian), and the
/// discrete Laplacian both are built on.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Jst {
    #[serde(default)]
    pub eps2: f64,
    #[serde(default = "default_eps4")]
    pub eps4: f64,
    #[serde(default)]
    pub laplacian: JstLaplacian,
}

fn default_eps4() -> f64 {
    0.125
}

impl Default for Jst {
    fn default() -> Self {
        Self {
            eps2: 0.0,
            eps4: default_eps4(),
            laplacian: JstLaplacian::default(),
        }
    }
}

/// The discrete Laplacian ∇²f_a = Σ_b ℓ_ab (f_b − f_a) of the JST dissipation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum JstLaplacian {
    /// Brookshaw weights corrected to be exact for linear fields and |X|² (the properties
    /// seed 002 states); near free surfaces the weights grow and change sign, and a
    /// large ε⁽⁴⁾ then needs a smaller CFL number.
    #[default]
    Corrected,
    /// ℓ_ab = 2 V_b N_ab·∇̃W̃_b(X_a)/|X_ab| (seed 003 eq 55, Morris et al.): positive
    /// symmetrised weights, but the Laplacian of a linear field is not zero at free
    /// surfaces, so rigid and bending motion is damped there.
    Brookshaw,
}

/// The p-wave speed C_p,ab of a pair in the mixed methods' CFL step Δt = α min_ab r_ab /
/// C_p,ab (seed 002 eq 31).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CflWaveSpeed {
    /// C_p,ab = C_p^Lin / ½(λ_a + λ_b), λ the smallest principal stretch (eq 32).
    #[default]
    Pair,
    /// C_p^Lin = sqrt((λ + 2μ)/ρ₀) for every pair: the paper's choice for the bond-based
    /// column, which needs no stretches; r_ab still follows the motion.
    Linear,
}

/// Discrete DIV P of the mixed methods.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Momentum {
    /// T_a = Σ_b V_b [P_b ∇̃W̃_a(X_b) − P_a ∇̃W̃_b(X_a)] (seed 003 eqs 20–21).
    #[default]
    Weak,
    /// T_a = −½ Σ_b V_b (P_a + P_b)(∇W̃_b(X_a) − ∇W̃_a(X_b)) (seed 002 eq 22).
    Symmetrised,
}

/// The deformation gradient the stress of a mixed method is evaluated at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeformationGradient {
    /// The evolved F (eq 24 of seed 002, 38b of seed 003).
    #[default]
    Evolved,
    /// The kernel-smoothed bond-based F^c with the self-bond (seed 002 eqs 37, 39),
    /// recomputed from the positions at every stage; the evolved F stays the state.
    BondBased,
    /// The kernel-smoothed purely kinematic bond F of seed 002 eqs 37 and 38, F_ab =
    /// (x_ab/r) ⊗ (X_ab/r): rank one per bond and not exact for affine motion, the
    /// deficiency that eq 39 mends; for comparison with the paper.
    KinematicBond,
}

/// The `[method]` keys both mixed methods read.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
pub struct MixedOptions {
    /// The conservation variables evolved (default {p, F, H, J}) where the material reads
    /// them; see [`MixedOptions::evolved`].
    #[serde(default)]
    pub variables: Conserved,
    /// The angular-momentum-preserving projection of the internal force and of the
    /// stabilisation (seed 003 Appendix B); see [`MixedOptions::projection`].
    pub projection: Option<bool>,
    /// The discrete divergence of P (default `weak`).
    #[serde(default)]
    pub momentum: Momentum,
    /// The F the stress is evaluated at (default `evolved`).
    #[serde(default)]
    pub deformation_gradient: DeformationGradient,
    /// With `cfl`: the pair wave speed C_p,ab of the step (default `pair`).
    #[serde(default)]
    pub cfl_wave_speed: CflWaveSpeed,
    /// Artificial compressibility (seed 003 §5): the pressure evolved in place of J,
    /// with a fictitious bulk modulus and a pseudo-time corrector; the only way to run
    /// ν = 0.5.
    pub artificial_compressibility: Option<ArtificialCompressibility>,
}

impl MixedOptions {
    /// The variables evolved for `model`: `variables` where the model reads H and J (the
    /// polyconvex nearly incompressible neo-Hookean of seed 003 eq 1), {p, F} for a
    /// model of F alone. Evolved beside such a model, H and J would be read by nothing,
    /// and J's stabilisation (eq 33), with no pressure to pull J back to det F, drives it
    /// through zero next to a clamp, where the stress jumps most.
    pub fn evolved(&self, model: MaterialModel) -> Conserved {
        if model.reads_h_and_j() {
            self.variables
        } else {
            Conserved::PF
        }
    }

    /// Whether the projection is on: as given, else on without mirror planes and off
    /// with them (their reactions are external forces).
    pub fn projection(&self, case: &Case) -> bool {
        self.projection.unwrap_or(case.mirrors.is_empty())
    }

    fn bond_based(&self) -> bool {
        self.deformation_gradient != DeformationGradient::Evolved
    }
}

/// Upwind-SPH: the acoustic Riemann stabilisation on p and J (seed 003).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
pub struct UpwindSpec {
    #[serde(flatten)]
    pub mixed: MixedOptions,
    /// Linear reconstruction of p and P to the mid-pair (default on).
    #[serde(default = "yes")]
    pub reconstruction: bool,
}

fn yes() -> bool {
    true
}

/// JST-SPH: Jameson–Schmidt–Turkel dissipation on p (seed 002 eqs 26–28).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
pub struct JstSpec {
    #[serde(flatten)]
    pub mixed: MixedOptions,
    /// Dissipation coefficients (default ε⁽²⁾ = 0, ε⁽⁴⁾ = 1/8) and Laplacian.
    #[serde(default)]
    pub jst: Jst,
}

/// SUPG-SPH's parameters (seed 003 Fig. 23b: τ_F = Δt, ξ_F = 0.2, τ_p = 0.1Δt): the
/// stress of the stress points is evaluated at F^st = F − τ_F (Ḟ − ∇0v) + ξ_F (∇0x − F),
/// and the velocity in the geometric laws is v + (τ_p/ρ0)(DIV P − ṗ).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Supg {
    /// τ_F in units of the step Δt.
    #[serde(default = "one")]
    pub tau_f: f64,
    /// τ_p in units of the step Δt.
    #[serde(default = "default_tau_p")]
    pub tau_p: f64,
    /// ξ_F, dimensionless.
    #[serde(default = "default_xi_f")]
    pub xi_f: f64,
}

fn one() -> f64 {
    1.0
}

fn default_tau_p() -> f64 {
    0.1
}

fn default_xi_f() -> f64 {
    0.2
}

impl Default for Supg {
    fn default() -> Self {
        Self {
            tau_f: one(),
            tau_p: default_tau_p(),
            xi_f: default_xi_f(),
        }
    }
}

/// SUPG-SPH: the residual-based Petrov–Galerkin stabilisation evaluated at stress points
/// (seed 003 §1, ref. [27]).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
pub struct SupgSpec {
    #[serde(flatten)]
    pub mixed: MixedOptions,
    /// The parameters (default τ_F = Δt, τ_p = 0.1Δt, ξ_F = 0.2).
    #[serde(default)]
    pub supg: Supg,
}

/// The stabilisation of a mixed method, as its systems read it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stabiliser {
    Upwind { reconstruction: bool },
    Jst(Jst),
    Supg(Supg),
}

/// What a mixed system reads of its method's spec ([`UpwindSpec`], [`JstSpec`]).
pub trait MixedScheme {
    fn options(&self) -> &MixedOptions;
    fn stabiliser(&self) -> Stabiliser;
}

/// Checks both mixed methods share: a first-order correction, a state model, the CFL
/// wave speed only with a CFL step, the bond-based F with {p, F}, no projection against
/// mirror planes.
fn validate(m: &MixedOptions, case: &Case) -> Result<(), Problem> {
    let name = case.method.name;
    if !case.method.correction.is_first_order() {
        return fail(
            "method.correction",
            format!(
                "`{name}` needs gradients that are exact for linear fields; use `cgck` (the \
                 paper's), `randles-libersky` or `rkpm`, not {}",
                toml_name(&case.method.correction)
            ),
        );
    }
    if case.material.model.is_rate_based() {
        return fail(
            "material.model",
            format!(
                "`{name}` evolves F and evaluates P(F, H, J): use a state model ({}), not {}",
                MaterialModel::names_where(|m| !m.is_rate_based()),
                toml_name(&case.material.model)
            ),
        );
    }
    if m.cfl_wave_speed != CflWaveSpeed::default() && case.method.cfl.is_none() {
        return fail(
            "method.cfl_wave_speed",
            "sets the wave speed of the CFL step and is read only with method.cfl; remove it \
             or replace method.dt by method.cfl",
        );
    }
    if m.bond_based() && m.variables != Conserved::PF {
        return fail(
            "method.deformation_gradient",
            "the bond-based F (seed 002) replaces F in P(F) and goes with the {p, F} system; \
             set method.variables = \"p-F\"",
        );
    }
    if let Some(ac) = &m.artificial_compressibility {
        ac.validate(m, case)?;
        if let Some(b) = case
            .bodies
            .iter()
            .position(|b| b.initial_displacement.is_some())
        {
            return fail(
                format!("body.{b}.initial_displacement"),
                "artificial compressibility starts its pressure at zero, out of balance with \
                 a displaced start; remove the key or method.artificial_compressibility",
            );
        }
    }
    if !case.mirrors.is_empty() && m.projection == Some(true) {
        return fail(
            "method.projection",
            "the projection removes the net force and moment of the internal forces, but \
             mirror planes exert reactions on the body; set projection = false or remove the \
             [[mirror]] planes",
        );
    }
    Ok(())
}

/// The run plan of a mixed method.
fn plan(m: &MixedOptions, stab: Stabiliser, case: &Case, gpu: bool) -> Plan {
    let mat = Material::new(&case.material);
    let bond = m.bond_based();
    let ghosts = if case.mirrors.is_empty() {
        String::new()
    } else {
        format!(", ghost particles of {} mirror planes", case.mirrors.len())
    };
    let weights = match stab {
        Stabiliser::Jst(_) => "Laplacian weights ℓ_ab, s_ab",
        Stabiliser::Upwind {
            reconstruction: true,
        } => "least-squares weights M_a⁻¹N_ab/|d_ab|",
        Stabiliser::Upwind {
            reconstruction: false,
        } => "N_ab",
        Stabiliser::Supg(_) => {
            "stress points at the 2^d Gauss points of the lattice cells with the cells' \
             isoparametric functions N_b(X_s), G_b(X_s), and the lists that gather them to \
             the particles"
        }
    };
    let mut left_out = Vec::new();
    if !m.projection(case) {
        left_out.push("angular-momentum projection");
    }
    let evolved = m.evolved(case.material.model);
    let ac = m.artificial_compressibility;
    if ac.is_none() {
        left_out.push("artificial compressibility (J evolved or det F)");
    }
    if evolved != m.variables {
        left_out.push("H and J evolution: the material reads F alone (H = cof F, J = det F)");
    } else {
        if !evolved.evolves_h() {
            left_out.push("H evolution (H = cof F)");
        }
        if !evolved.evolves_j() {
            left_out.push("J evolution (J = det F)");
        }
        if ac.is_some() {
            left_out.push("J evolution (the pressure p in its place; J = det F)");
        }
    }
    if !bond {
        left_out.push("bond-based F^c (P of the evolved F)");
    }
    Plan {
        once: format!(
            "once, on the reference configuration (host, f64{}): cell-list neighbours \
             (CSR){ghosts}, corrected gradients g_ab and g_ba, {weights}{}",
            if gpu { ", uploaded in f32" } else { "" },
            if bond {
                ", bond weights V_b W̃_b(X_a)/|X_ab|²"
            } else {
                ""
            }
        ),
        state: format!(
            "u, v, F{}{} ({}; {:?})",
            if evolved.evolves_h() { ", H" } else { "" },
            match ac {
                Some(_) => ", p",
                None if evolved.evolves_j() => ", J",
                None => "",
            },
            match ac {
                Some(_) if evolved.evolves_h() => "{p, F, H, p}".to_string(),
                Some(_) => "{p, F, p}".to_string(),
                None => format!("{evolved:?}"),
            },
            mat.model
        ),
        cfl_step: format!(
            "Δt = cfl·min_ab r_ab/C_p,ab with C_p,ab = {} (seed 002 eqs 31–32), C_p^Lin = \
             {:.1} m/s{}",
            match m.cfl_wave_speed {
                CflWaveSpeed::Pair => "C_p^Lin/½(λ_a + λ_b)",
                CflWaveSpeed::Linear => "C_p^Lin",
            },
            match ac {
                Some(ac) => ac.p_wave_speed(&mat),
                None => mat.p_wave_speed(),
            },
            match ac {
                Some(ac) => format!(
                    " (of the fictitious bulk modulus κ̃ = {:.4e} Pa, seed 003 eq 46)",
                    ac.kappa(&mat)
                ),
                None => String::new(),
            }
        ),
        rates: rate_passes(m, stab, case),
        checked: "det F, J",
        check_note: if bond && gpu {
            format!(
                " (strain energy ψ(F^c): {}bond-based F^c of Y recorded before the reduction)",
                if case.mirrors.is_empty() {
                    ""
                } else {
                    "ghost motion and "
                }
            )
        } else {
            String::new()
        },
        left_out,
    }
}

/// The passes of one rate evaluation (the GPU's dispatches, the CPU's loops).
fn rate_passes(m: &MixedOptions, stab: Stabiliser, case: &Case) -> String {
    let ghosts = !case.mirrors.is_empty();
    let evolved = m.evolved(case.material.model);
    let (h, j) = (evolved.evolves_h(), evolved.evolves_j());
    let upwind = matches!(stab, Stabiliser::Upwind { .. });
    let d_j = upwind && j && m.artificial_compressibility.is_none();
    let bond = m.bond_based();
    let mut passes = Vec::new();
    if ghosts {
        passes.push("ghost motion".to_string());
    }
    if bond {
        passes.push("bond-based F^c (gather of u)".into());
    }
    passes.push(format!(
        "kinematics (P{}, ∇0v, Ḟ{}{})",
        if bond { "(F^c)" } else { "" },
        if h { ", Ḣ" } else { "" },
        match (m.artificial_compressibility, j) {
            (Some(_), _) => ", ṗ (κ̃)",
            (None, true) => ", J̇",
            (None, false) => "",
        }
    ));
    if ghosts {
        passes.push(format!("ghost P{}", if d_j { ", H" } else { "" }));
    }
    let second = match stab {
        Stabiliser::Jst(_) => Some("Laplacians ∇²v"),
        Stabiliser::Upwind {
            reconstruction: true,
        } => Some("least-squares slopes of v, P"),
        Stabiliser::Upwind {
            reconstruction: false,
        }
        | Stabiliser::Supg(_) => None,
    };
    if let Some(second) = second {
        passes.push(second.into());
        if ghosts {
            passes.push("their ghosts".into());
        }
    }
    let t = match m.momentum {
        Momentum::Weak => "T",
        Momentum::Symmetrised => "T symmetrised",
    };
    passes.push(match (stab, d_j) {
        (Stabiliser::Jst(_), _) => format!("forces ({t}, JST D(p))"),
        (Stabiliser::Supg(_), _) => format!("forces ({t})"),
        (_, true) => format!("forces ({t}, upwind D(p), D(J))"),
        (_, false) => format!("forces ({t}, upwind D(p))"),
    });
    if let Stabiliser::Supg(_) = stab {
        passes.push(format!(
            "SUPG nodes (F, ∇0v{}{}, ṗ of the particles{})",
            if h { ", H, Ḣ" } else { "" },
            if j { ", J, J̇" } else { "" },
            if ghosts { " and ghosts" } else { "" }
        ));
        passes.push(
            "stress points (the nodes interpolated; ∇0v, ∇0x, DIV P; ΔP = P(F^st) − P(F), Δv \
             = τ_p/ρ0 (DIV P − ṗ))"
                .into(),
        );
        passes.push("gather of the points' −ΔP G and −Δv ⊗ G to the particles".into());
    }
    if m.projection(case) {
        passes.push("projection sums (per workgroup) + solve (one invocation)".into());
        passes.push("rates (ρ0 v̇ = D(p) − T projected, BCs, u̇ = v)".into());
    } else {
        passes.push("rates (ρ0 v̇ = D(p) − T, BCs, u̇ = v)".into());
    }
    if let Some(ac) = m.artificial_compressibility {
        passes.push(format!(
            "corrector (seed 003 eqs 52–58): pseudo-time TVD-RK2 on v, p to a residual of {:e} \
             of max|v| (at most {} iterations{}), then −T[(p − p^n)H^n]{}",
            ac.tolerance,
            ac.max_iterations,
            if ac.alpha > 0.0 {
                format!(", pseudo-viscosity α = {}", ac.alpha)
            } else {
                String::new()
            },
            if m.projection(case) { " projected" } else { "" }
        ));
    }
    passes.join(" → ")
}

/// The keys of a mixed method's table: those of [`MixedOptions`] and its stabilisation's
/// own.
const fn keys(own: &'static str) -> [&'static str; 7] {
    [
        "variables",
        "projection",
        "momentum",
        "deformation_gradient",
        "cfl_wave_speed",
        "artificial_compressibility",
        own,
    ]
}

/// What distinguishes the two mixed methods; everything else of their
/// [`MethodFamily`] is shared.
trait MixedMethod: MixedScheme {
    const DESCRIPTION: &'static str;
    const KEYS: &'static [&'static str];
    const FEATURES: &'static [Feature] = &[
        Feature::Contact,
        Feature::InitialDisplacement,
        Feature::MirrorPlanes,
        Feature::Plasticity,
    ];
    /// The force reads the neighbours' stress (of the bond-based F^c, from their
    /// neighbours' u) and their slopes or Laplacians of v; the slopes of P, which would
    /// read a third layer's u through F^c, enter only D(J), which {p, F} leaves out.
    const HALO_LAYERS: Option<usize> = Some(2);
    /// Checks of the stabilisation's own keys and of the options it runs with.
    fn validate_own(&self) -> Result<(), Problem>;
}

impl MixedMethod for UpwindSpec {
    const DESCRIPTION: &'static str = "mixed {p, F, H, J} total-Lagrangian SPH with the \
        acoustic Riemann (upwind) stabilisation on p and J, linear reconstruction and the \
        angular-momentum projection (Lee et al. 2018; seed 003)";
    const KEYS: &'static [&'static str] = &keys("reconstruction");

    fn validate_own(&self) -> Result<(), Problem> {
        Ok(())
    }
}

impl MixedScheme for UpwindSpec {
    fn options(&self) -> &MixedOptions {
        &self.mixed
    }

    fn stabiliser(&self) -> Stabiliser {
        Stabiliser::Upwind {
            reconstruction: self.reconstruction,
        }
    }
}

impl MixedMethod for JstSpec {
    const DESCRIPTION: &'static str = "mixed {p, F, H, J} total-Lagrangian SPH with \
        Jameson–Schmidt–Turkel dissipation on p (Lee et al. 2016; seed 002 eqs 26–28)";
    const KEYS: &'static [&'static str] = &keys("jst");

    fn validate_own(&self) -> Result<(), Problem> {
        non_negative("method.jst.eps2", self.jst.eps2)?;
        non_negative("method.jst.eps4", self.jst.eps4)
    }
}

impl MixedScheme for JstSpec {
    fn options(&self) -> &MixedOptions {
        &self.mixed
    }

    fn stabiliser(&self) -> Stabiliser {
        Stabiliser::Jst(self.jst)
    }
}

impl MixedMethod for SupgSpec {
    const DESCRIPTION: &'static str = "mixed {p, F, H, J} total-Lagrangian SPH with the \
        residual-based SUPG stabilisation evaluated at stress points (Lee et al. 2017; seed \
        003)";
    const KEYS: &'static [&'static str] = &keys("supg");
    const FEATURES: &'static [Feature] = &[
        Feature::Contact,
        Feature::InitialDisplacement,
        Feature::MirrorPlanes,
    ];
    /// Not yet distributed: a rank would need the stress points of its halo's cells.
    const HALO_LAYERS: Option<usize> = None;

    fn validate_own(&self) -> Result<(), Problem> {
        non_negative("method.supg.tau_f", self.supg.tau_f)?;
        non_negative("method.supg.tau_p", self.supg.tau_p)?;
        non_negative("method.supg.xi_f", self.supg.xi_f)?;
        if self.supg.xi_f >= 1.0 {
            return fail(
                "method.supg.xi_f",
                format!(
                    "is {}; ξ_F blends ∇0x into F^st = F − τ_F R_F + ξ_F (∇0x − F) and must \
                     lie in [0, 1) (the paper's 0.2 by default)",
                    self.supg.xi_f
                ),
            );
        }
        let m = &self.mixed;
        if m.artificial_compressibility.is_some() {
            return fail(
                "method.artificial_compressibility",
                "`supg-sph` stabilises the pressure through J's residual at its stress points \
                 and does not run artificial compressibility; remove the table or use \
                 `upwind-sph` or `jst-sph`",
            );
        }
        if m.bond_based() {
            return fail(
                "method.deformation_gradient",
                "`supg-sph` stabilises the evolved F; remove the key or use `upwind-sph` or \
                 `jst-sph`",
            );
        }
        Ok(())
    }
}

impl MixedScheme for SupgSpec {
    fn options(&self) -> &MixedOptions {
        &self.mixed
    }

    fn stabiliser(&self) -> Stabiliser {
        Stabiliser::Supg(self.supg)
    }
}

impl<S: MixedMethod + 'static> MethodFamily for S {
    const DESCRIPTION: &'static str = S::DESCRIPTION;
    const KEYS: &'static [&'static str] = S::KEYS;
    const FEATURES: &'static [Feature] = S::FEATURES;
    const HALO_LAYERS: Option<usize> = S::HALO_LAYERS;
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = gpu::SHADERS;

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        self.validate_own()?;
        validate(self.options(), case)
    }

    fn rank_engine<D: EngineDim>(
        &self,
        case: &Case,
        reference: Reference<D>,
        start: RankStart<D>,
    ) -> RankBuild<D> {
        shared::rank_engine::<D, MixedSph<D>>(case, self, reference, start)
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        plan(self.options(), self.stabiliser(), case, gpu)
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        Ok(Box::new(CpuEngine::<D, MixedSph<D>>::new(case, self)?))
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D> {
        Ok(Box::new(GpuMixed::<D>::new(case, self, gpu)?))
    }

    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        Some(GpuMixed::<D>::memory(case, self, counts))
    }

    /// With artificial compressibility, that of the fictitious bulk modulus κ̃.
    fn step_wave_speed(&self, mat: &Material) -> f64 {
        match self.options().artificial_compressibility {
            Some(ac) => ac.p_wave_speed(mat),
            None => mat.p_wave_speed(),
        }
    }

    /// With artificial compressibility: its pressure replaces J.
    fn accepts_incompressible(&self) -> bool {
        self.options().artificial_compressibility.is_some()
    }

    /// c_p/λ²_min: the per-pair step of seed 002 eqs 31–32 falls as r_ab λ_ab, and
    /// r_ab ≥ λ_min |X_ab| for a locally affine motion.
    fn stretch_signal_speed<D: Dim>(&self, c_p: f64, f: D::T) -> f64 {
        c_p / smallest_stretch_squared::<D>(f)
    }
}
