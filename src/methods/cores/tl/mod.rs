//! The core of the total-Lagrangian methods on the CPU: what TLSPH, TLSPH from the elastic
//! potential, corotated TLSPH (seed 000 §5.3–5.5) and the dynamics of dual-support SPH
//! share.
//!
//! [`TlSph`] is a whole CPU system, generic over a [`TlScheme`], which gives one method's
//! stress pass, its pair force and its own checks. The core holds the particles of the
//! reference configuration, the boundary conditions and the interactions; it closes every
//! rate evaluation with the supports, loads and interactions and their work, and gives the
//! [`Method`] accessors. [`ReferencePairs`] are the neighbour lists and corrected
//! gradients that the SPH schemes compute once on the reference configuration. The state
//! is [`TlState`]: u = x − X, v and, for the rate-based (hypoelastic) model, ρ and S.

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod hourglass;

use crate::boundary::OnPatches;
use crate::core::integrate::OdeSystem;
use crate::diagnostics::observe::ScalarField;
use crate::engine::{BlowUp, BoundaryWork, Method, Traffic, check_motion};
use crate::interaction::Interactions;
use crate::methods::cores::particles::{
    Surroundings, check_stresses, max_speed, particle_accessors,
};
use crate::physics::material::{Material, stress_fields};
use crate::physics::plasticity::{History, Returned};

use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::parallel::{MIN_CHUNK, particle_state};
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::methods::cores::shared::{own_gradients, reference_gradients, reverse_gradients};
use crate::physics::viscosity::ArtificialViscosity;
use crate::reference::{Build, Reference};
use rayon::prelude::*;
use std::ops::Deref;

particle_state! {
    /// Integrated state of a total-Lagrangian method: u and v of the particles (or of a
    /// Galerkin method's nodes), and a rate model's ρ and S of the particles (or of the
    /// Galerkin method's quadrature points).
    pub struct TlState {
        /// Density (rate-based model only; empty otherwise).
        pub rho: Vec<f64>,
        /// Deviatoric Cauchy stress (rate-based model only; empty otherwise).
        pub s: Vec<D::T>,
    }
}

impl<D: Dim> TlState<D> {
    /// The state u0, v0 with ρ = ρ0 and S = 0 at `stresses` places (a rate model's
    /// particles or points; none for a state model).
    pub fn initial(u0: &[D::V], v0: &[D::V], rho0: f64, stresses: usize) -> Self {
        Self {
            u: u0.to_vec(),
            v: v0.to_vec(),
            rho: vec![rho0; stresses],
            s: vec![D::zero_t(); stresses],
        }
    }

    /// This state with displacement u and velocity v: a static or implicit solve's state.
    pub fn moving(self, u: &[D::V], v: &[D::V]) -> Self {
        Self {
            u: u.to_vec(),
            v: v.to_vec(),
            ..self
        }
    }
}

/// The first particle with a non-finite u, v, ρ or S, as a blow-up.
pub fn check_state<D: Dim>(x0: &[D::V], y: &TlState<D>) -> Result<(), BlowUp> {
    check_motion::<D>(x0, &y.u, &y.v)?;
    check_stresses::<D>(&y.rho, &y.s, |i, quantity, value| {
        BlowUp::at::<D>(x0, i, quantity, value)
    })
}

/// The fields of a total-Lagrangian state that its frames and observers read.
pub struct Fields<D: Dim> {
    /// The deformation gradient F.
    pub f: Vec<D::T>,
    /// The Cauchy stress σ (3 × 3; 2D: with σ_zz).
    pub sigma: Vec<[[f64; 3]; 3]>,
    /// The strain energy.
    pub strain_energy: Exact,
}

impl<D: Dim> Fields<D> {
    /// The snapshot of state y with these fields.
    pub fn snapshot<'a>(
        self,
        x0: &'a [D::V],
        mass: &'a [f64],
        body: &'a [u32],
        y: TlState<D>,
    ) -> Snapshot<'a, D> {
        Snapshot {
            x0,
            mass,
            body,
            u: y.u,
            v: y.v,
            f: self.f,
            sigma: self.sigma,
            strain_energy: self.strain_energy,
            extra: Vec::new(),
            cells: &[],
            quadrature: None,
        }
    }
}

/// Each particle's return map at its F in `f` from its committed plastic history.
pub fn returned_all<D: Dim>(history: &History, f: &[D::T]) -> Vec<Returned> {
    (f.par_iter().enumerate())
        .with_min_len(MIN_CHUNK)
        .map(|(i, &f)| history.returned::<D>(i, f))
        .collect()
}

/// The stresses of a total-Lagrangian state, its strain energy and, with a plastic
/// history, the particles' ε_p.
pub struct StressState {
    /// σ (3 × 3; 2D with σ_zz).
    pub sigma: Vec<[[f64; 3]; 3]>,
    /// Σ w_i ψ_i.
    pub energy: Exact,
    pub plastic: Vec<(&'static str, Vec<f64>)>,
}

/// The [`StressState`] of state y with deformation gradients f and weights `vol`, from
/// `stress_fields`, or with a plastic `history` from each particle's return map.
pub fn stress_state<D: Dim>(
    material: &Material,
    f: &[D::T],
    y: &TlState<D>,
    vol: &[f64],
    history: Option<&History>,
) -> StressState {
    let Some(history) = history else {
        let (sigma, energy) = stress_fields::<D>(material, f, &y.s, &y.rho, vol);
        return StressState {
            sigma,
            energy,
            plastic: Vec::new(),
        };
    };
    let r = returned_all::<D>(history, f);
    StressState {
        sigma: r.iter().zip(f).map(|(r, &f)| r.cauchy::<D>(f)).collect(),
        energy: r.iter().zip(vol).map(|(r, w)| w * r.psi).sum(),
        plastic: history.fields(&r),
    }
}

/// A snapshot of state y of the particles (x0, mass, body) with deformation gradients f:
/// stresses and strain energy Σ w_i ψ_i (weights `vol`) follow from [`stress_state`], with
/// ε_p as a field of a plastic `history`. Shared by the CPU and GPU paths.
pub fn snapshot<'a, D: Dim>(
    material: &Material,
    (x0, mass, body): (&'a [D::V], &'a [f64], &'a [u32]),
    vol: &[f64],
    y: TlState<D>,
    f: Vec<D::T>,
    history: Option<&History>,
) -> Snapshot<'a, D> {
    let stressed = stress_state::<D>(material, &f, &y, vol, history);
    let fields = Fields {
        f,
        sigma: stressed.sigma,
        strain_energy: stressed.energy,
    };
    let mut snapshot = fields.snapshot(x0, mass, body, y);
    let plastic = stressed.plastic.into_iter();
    (snapshot.extra).extend(plastic.map(|(name, values)| ScalarField { name, values }));
    snapshot
}

/// The neighbour lists of the reference configuration and the corrected reference
/// gradients ∇0W̃_ij of every pair, in CSR order, computed once.
pub struct ReferencePairs<D: Dim> {
    pub csr: Csr,
    pub grad: Vec<D::V>,
}

impl<D: Dim> ReferencePairs<D> {
    /// The lists and corrected gradients of the case's correction.
    pub fn new(case: &Case, reference: &Reference<D>) -> Result<Self, CaseError> {
        let csr = reference.neighbours();
        let grad = reference_gradients::<D>(case, &reference.x0, &reference.vol, &csr)?;
        Ok(Self { csr, grad })
    }

    /// ∇0W̃_ji (j's corrected gradient, evaluated at i) for every pair (i, j), in CSR
    /// order: the second gradient of a force with each side's own gradient.
    pub fn reverse(&self, case: &Case) -> Result<Vec<D::V>, CaseError> {
        reverse_gradients::<D>(case, &self.csr, &self.grad)
    }

    /// ∇0W̃_i(X_i), each row's corrected gradient of its own kernel at its own position
    /// ([`crate::core::correction::own_gradients`]).
    pub fn own(&self, case: &Case, reference: &Reference<D>) -> Result<Vec<D::V>, CaseError> {
        own_gradients::<D>(case, &reference.x0, &reference.vol, &self.csr)
    }
}

/// `Some(i)` when det F_i ≤ 0 or NaN: the particle's F is not admissible.
#[inline]
pub fn inadmissible<D: Dim>(i: usize, f: D::T) -> Option<usize> {
    let det = D::det(f);
    (det.is_nan() || det <= 0.0).then_some(i)
}

/// The particles of a total-Lagrangian method and what every such method does with them.
pub struct TlCore<D: Dim> {
    /// Reference positions X.
    pub x0: Vec<D::V>,
    /// Reference volumes V0.
    pub vol: Vec<f64>,
    pub mass: Vec<f64>,
    pub body: Vec<u32>,
    v0: Vec<D::V>,
    /// Initial displacements.
    u0: Vec<D::V>,
    pub material: Material,
    /// The smoothing length of the case's kernel.
    pub h: f64,
    pub surroundings: Surroundings<D>,
    /// Each particle's power of the artificial viscosity, −m a_visc·v, at the last rate
    /// evaluation ([`viscous_pair_pass`]; zero for a scheme without the pass).
    dissipation: Vec<f64>,
    /// Whether each particle's share of the sums is booked and its kinematics checked:
    /// all but a rank's ghosts ([`Reference::counted`]).
    pub counted: Vec<bool>,
    /// V0 of the counted particles and 0 for a rank's ghosts: the weights of the strain
    /// energy Σ V0 ψ.
    pub energy_weights: Vec<f64>,
    /// The particles' plastic history (von Mises), committed at the start of every step;
    /// None for the elastic models.
    pub plastic: Option<History>,
}

impl<D: Dim> TlCore<D> {
    /// The particles of the reference configuration r, with interactions on the scheme's
    /// lists.
    fn new(case: &Case, r: Reference<D>, lists: &Csr) -> Result<Self, CaseError> {
        let interactions =
            Interactions::build(case, &r.x0, &r.body, &OnPatches, &r.mass, || lists.clone())?;
        Ok(Self {
            plastic: r.material.von_mises().map(|m| History::virgin(m, r.len())),
            dissipation: vec![0.0; r.len()],
            energy_weights: (r.vol.iter().zip(&r.counted))
                .map(|(&v, &c)| if c { v } else { 0.0 })
                .collect(),
            counted: r.counted,
            x0: r.x0,
            vol: r.vol,
            mass: r.mass,
            body: r.body,
            v0: r.v0,
            u0: r.u0,
            material: r.material,
            h: r.kernel.h,
            surroundings: Surroundings::new(r.boundary, interactions),
        })
    }

    /// The exact sum of the particles' shares of a power, over the counted particles.
    pub fn booked_sum(&self, shares: impl IntoIterator<Item = f64>) -> Exact {
        (shares.into_iter().zip(&self.counted))
            .filter_map(|(x, &counted)| counted.then_some(x))
            .sum()
    }

    /// The first blow-up of `quantity` at particle i.
    pub fn blow_up(&self, i: usize, quantity: &str, value: f64) -> BlowUp {
        BlowUp::at::<D>(&self.x0, i, quantity, value)
    }

    /// The current position x_i = X_i + u_i.
    #[inline]
    pub fn x(&self, i: usize, u: &[D::V]) -> D::V {
        self.x0[i] + u[i]
    }
}

/// u̇ = v of every particle, for a scheme whose pair pass writes v̇ alone.
pub fn displacement_rates<D: Dim>(u_dot: &mut [D::V], v: &[D::V]) {
    u_dot
        .par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(v)
        .for_each(|(u, &v)| *u = v);
}

/// A pair force with Monaghan viscosity along a pair direction of the scheme, for
/// [`viscous_pair_pass`].
pub trait ViscousPairs<D: Dim>: TlScheme<D> {
    /// The viscosity; none without it.
    fn viscosity(&self) -> Option<&ArtificialViscosity>;
    /// The current density of particle i (its sound speed is √(K/ρ)).
    fn rho(&self, i: usize) -> f64;
    /// The stress term of pair p = (i, j).
    fn stress(&self, core: &TlCore<D>, i: usize, j: usize, p: usize) -> D::V;
    /// The direction of pair p = (i, j)'s viscous force, antisymmetric in the pair.
    fn viscous_direction(&self, i: usize, j: usize, p: usize) -> D::V;
    /// The acceleration of i from the sum of its stress terms.
    fn acceleration(&self, core: &TlCore<D>, i: usize, stress: D::V) -> D::V;
}

/// The forces of a [`ViscousPairs`] scheme: a_i = acceleration(Σ_j stress_ij) −
/// Σ_j dir_ij ½ m_j Π_ij, with Π_ij of the pair's mean sound speed and density, each
/// particle's viscous dissipation −m_i a_visc·v_i into the core's record, then u̇ = v.
pub fn viscous_pair_pass<D: Dim, S: ViscousPairs<D>>(
    scheme: &S,
    core: &mut TlCore<D>,
    y: &TlState<D>,
    d: &mut TlState<D>,
) {
    let mut dissipation = std::mem::take(&mut core.dissipation);
    viscous_accelerations(scheme, core, y, &mut d.v, &mut dissipation);
    core.dissipation = dissipation;
    displacement_rates::<D>(&mut d.u, &y.v);
}

/// The accelerations and dissipation of [`viscous_pair_pass`].
fn viscous_accelerations<D: Dim, S: ViscousPairs<D>>(
    scheme: &S,
    core: &TlCore<D>,
    y: &TlState<D>,
    a: &mut [D::V],
    dissipation: &mut [f64],
) {
    let (bulk, h, mass, csr) = (core.material.bulk, core.h, &core.mass, scheme.lists());
    a.par_iter_mut()
        .zip(dissipation.par_iter_mut())
        .with_min_len(MIN_CHUNK)
        .enumerate()
        .for_each(|(i, (a, dissipation))| {
            let rho_i = scheme.rho(i);
            let xi = core.x(i, &y.u);
            let ci = (bulk / rho_i).sqrt();
            let mut stress = D::zero();
            let mut viscous = D::zero();
            for p in csr.range(i) {
                let j = csr.ids[p] as usize;
                stress += scheme.stress(core, i, j, p);
                if let Some(av) = scheme.viscosity() {
                    let rho_j = scheme.rho(j);
                    let x_ij = xi - core.x(j, &y.u);
                    let c = 0.5 * (ci + (bulk / rho_j).sqrt());
                    let rho = 0.5 * (rho_i + rho_j);
                    let pi = av.pi::<D>(h, x_ij, y.v[i] - y.v[j], c, rho);
                    viscous -= scheme.viscous_direction(i, j, p) * (0.5 * mass[j] * pi);
                }
            }
            *a = scheme.acceleration(core, i, stress) + viscous;
            *dissipation = -mass[i] * D::dot(viscous, y.v[i]);
        });
}

/// The stress pass and pair force of one total-Lagrangian method, on the core's
/// particles.
pub trait TlScheme<D: Dim>: Sized + Send + Sync {
    /// The scheme of a case on its reference configuration; an error if the case names
    /// another method.
    /// The typed spec of the scheme's method.
    type Spec;

    /// The scheme of a method's spec on the reference configuration.
    fn new(case: &Case, spec: &Self::Spec, reference: &Reference<D>) -> Result<Self, CaseError>;

    /// The neighbour lists of the reference configuration (those of the interactions).
    fn lists(&self) -> &Csr;

    /// Whether the state integrates ρ and S (the rate-based model).
    fn integrates_stress(&self, _core: &TlCore<D>) -> bool {
        false
    }

    /// The stress pass of state y: the scheme's per-particle quantities (and ρ̇, Ṡ of a
    /// rate model) and its checks; the first inadmissible particle as a blow-up.
    fn stresses(&mut self, core: &TlCore<D>, y: &TlState<D>, d: &mut TlState<D>) -> Option<BlowUp>;

    /// The pair force: u̇ and v̇ of state y before the supports, loads and interactions.
    fn forces(&mut self, core: &mut TlCore<D>, y: &TlState<D>, d: &mut TlState<D>);

    /// The deformation gradient F of every particle.
    fn deformation_gradient(&self, core: &TlCore<D>, y: &TlState<D>) -> Vec<D::T>;

    /// The fields of state y.
    fn snapshot<'a>(&'a self, core: &'a TlCore<D>, y: &TlState<D>) -> Snapshot<'a, D>;

    /// The Cauchy stress of every particle.
    fn cauchy_stress(&self, core: &TlCore<D>, y: &TlState<D>) -> Vec<[[f64; 3]; 3]> {
        self.snapshot(core, y).sigma
    }

    /// The strain energy.
    fn strain_energy(&self, core: &TlCore<D>, y: &TlState<D>) -> Exact {
        self.snapshot(core, y).strain_energy
    }

    /// The wave speed of the CFL step (the signal speed less max |v|).
    fn wave_speed(&self, core: &TlCore<D>) -> f64 {
        core.material.p_wave_speed()
    }

    /// [`Method::dissipation_power`]: the sum of the core's record of the artificial
    /// viscosity's power.
    fn dissipation_power(&self, core: &TlCore<D>) -> Exact {
        core.booked_sum(core.dissipation.iter().copied())
    }

    /// [`Method::hourglass_power`].
    fn hourglass_power(&self, _core: &TlCore<D>) -> Exact {
        Exact::default()
    }

    /// [`Method::traffic`].
    fn traffic(&self, core: &TlCore<D>) -> Traffic;
}

/// A total-Lagrangian system on the CPU (f64, rayon): the core and a scheme. The
/// scheme's own fields and accessors read through the system ([`Deref`]).
pub struct TlSph<D: Dim, S: TlScheme<D>> {
    pub core: TlCore<D>,
    pub scheme: S,
}

impl<D: Dim, S: TlScheme<D>> Deref for TlSph<D, S> {
    type Target = S;

    fn deref(&self) -> &S {
        &self.scheme
    }
}

impl<D: Dim, S: TlScheme<D>> TlSph<D, S> {
    /// The scheme's set-up on the reference configuration, then the core's.
    pub fn new(case: &Case, spec: &S::Spec, reference: Reference<D>) -> Result<Self, CaseError> {
        let scheme = S::new(case, spec, &reference)?;
        let core = TlCore::new(case, reference, scheme.lists())?;
        Ok(Self { core, scheme })
    }

    /// Neighbour lists (reference configuration).
    pub fn neighbours(&self) -> &Csr {
        self.scheme.lists()
    }

    /// Reference volumes V0.
    pub fn volume(&self) -> &[f64] {
        &self.core.vol
    }
}

impl<D: Dim, S: TlScheme<D>> OdeSystem for TlSph<D, S> {
    type State = TlState<D>;
    type Error = BlowUp;

    fn rates(&mut self, _t: f64, y: &TlState<D>, d: &mut TlState<D>) -> Result<(), BlowUp> {
        let core = &mut self.core;
        if let Some(b) = self.scheme.stresses(core, y, d) {
            return Err(b);
        }
        self.scheme.forces(core, y, d);
        core.surroundings.close(&y.v, &core.mass, &mut d.v);
        Ok(())
    }

    /// The plastic history committed from F at the step's start, then the interactions'
    /// work before the step (the contact forces of seed 000 §5.8).
    fn begin_step(&mut self, t: f64, dt: f64, y: &TlState<D>) {
        if let Some(history) = &self.core.plastic {
            let f = self.scheme.deformation_gradient(&self.core, y);
            let committed = returned_all::<D>(history, &f);
            let core = &mut self.core;
            if let Some(history) = core.plastic.as_mut() {
                history.commit(&committed, &core.energy_weights, dt);
            }
        }
        self.core
            .surroundings
            .begin_step(t, dt, &self.core.x0, &y.u, &y.v);
    }
}

impl<D: Dim, S: TlScheme<D>> Build<D> for TlSph<D, S> {
    type Spec = S::Spec;

    fn build(case: &Case, spec: &S::Spec, reference: Reference<D>) -> Result<Self, CaseError> {
        Self::new(case, spec, reference)
    }
}

impl<D: Dim, S: TlScheme<D>> Method<D> for TlSph<D, S> {
    fn initial_state(&self) -> TlState<D> {
        let core = &self.core;
        let rate = self.scheme.integrates_stress(core);
        let stresses = if rate { core.x0.len() } else { 0 };
        TlState::initial(&core.u0, &core.v0, core.material.rho0, stresses)
    }

    particle_accessors!(TlState<D>, core);

    fn reference(&self) -> &[D::V] {
        &self.core.x0
    }

    fn deformation_gradient(&self, y: &TlState<D>) -> Vec<D::T> {
        self.scheme.deformation_gradient(&self.core, y)
    }

    fn cauchy_stress(&self, y: &TlState<D>) -> Vec<[[f64; 3]; 3]> {
        self.scheme.cauchy_stress(&self.core, y)
    }

    fn strain_energy(&self, y: &TlState<D>) -> Exact {
        self.scheme.strain_energy(&self.core, y)
    }

    fn snapshot<'a>(&'a self, y: &TlState<D>) -> Snapshot<'a, D> {
        self.scheme.snapshot(&self.core, y)
    }

    /// The scheme's wave speed and max |v|.
    fn signal_speed_terms(&self, y: &TlState<D>) -> [f64; 2] {
        [self.scheme.wave_speed(&self.core), max_speed::<D>(&y.v)]
    }

    fn dissipation_power(&self) -> Exact {
        self.scheme.dissipation_power(&self.core)
    }

    fn hourglass_power(&self) -> Exact {
        self.scheme.hourglass_power(&self.core)
    }

    fn pairs(&self) -> usize {
        self.scheme.lists().pair_count()
    }

    /// The committed plastic work and the current step's, over the reference volumes.
    fn plastic_work(&self, y: &TlState<D>) -> f64 {
        let Some(history) = &self.core.plastic else {
            return 0.0;
        };
        let f = self.scheme.deformation_gradient(&self.core, y);
        history.work_at(&returned_all::<D>(history, &f), &self.core.energy_weights)
    }

    /// The plastic history C_p⁻¹, ε_p of the particles.
    fn save_history(&self, out: &mut Vec<f64>) {
        History::save(self.core.plastic.as_ref(), out);
    }

    fn load_history(&mut self, words: &mut &[f64]) -> Result<(), String> {
        History::load(self.core.plastic.as_mut(), words)
    }

    fn traffic(&self) -> Option<Traffic> {
        Some(self.scheme.traffic(&self.core))
    }

    fn check_finite(&self, y: &TlState<D>) -> Result<(), BlowUp> {
        check_state(&self.core.x0, y)
    }
}
