//! [`MixedSph`] as an ODE system and as a method: its rates, state, accessors and
//! traffic.

use super::*;
use crate::methods::cores::particles::{max_speed, particle_accessors};
use crate::reference::Build;

impl<D: Dim> OdeSystem for MixedSph<D> {
    type State = MixedState<D>;
    type Error = BlowUp;

    fn begin_step(&mut self, t: f64, dt: f64, y: &MixedState<D>) {
        self.stage = 0;
        let x0 = &self.x0[..self.n];
        self.surroundings.begin_step(t, dt, x0, &y.u, &y.v);
        // The plastic history is committed once per step, from the state at its start.
        if let Some(committed) = self.returned_all(y)
            && let Some(pl) = self.plastic.as_mut()
        {
            pl.commit(&committed, &self.vol[..self.n], dt);
        }
        if self.projection && self.integrator == IntegratorKind::TvdRk2 {
            self.step_start = Some((y.u.clone(), y.v.clone(), dt));
        }
        self.dt = dt;
        if let Some(c) = self.compressibility.as_mut() {
            c.begin_step();
        }
    }

    fn rates(&mut self, _t: f64, y: &MixedState<D>, d: &mut MixedState<D>) -> Result<(), BlowUp> {
        let checked = self.prepare(y);
        if self.projection || self.compressibility.is_some() {
            // The projection's sums and the corrector's iteration are collectives: every
            // rank learns whether any met a blow-up, and all skip them together.
            let mut failed = [f64::from(u8::from(checked.is_err()))];
            self.ranks.max(&mut failed);
            if failed[0] != 0.0 {
                return checked;
            }
        }
        checked?;
        let mut forces = std::mem::take(&mut self.forces);
        self.forces(y, &mut forces);
        if let Err(e) = self.supg(y, &mut forces) {
            self.forces = forces;
            return Err(e);
        }
        let (mut t, mut dp) = (std::mem::take(&mut self.t), std::mem::take(&mut self.dp));
        if self.projection {
            t.par_iter_mut()
                .with_min_len(MIN_CHUNK)
                .zip(dp.par_iter_mut())
                .zip(&forces)
                .for_each(|((t, dp), f)| (*t, *dp) = (f.t, f.d));
            let mut points = std::mem::take(&mut self.points);
            self.balance_points(y, &mut points);
            let balance =
                Balance::<D>::new(&points, &self.vol[..self.n], &self.counted, &*self.ranks);
            balance.project(&mut t);
            balance.project(&mut dp);
            self.points = points;
        }
        self.stage += 1;
        let inv_rho0 = 1.0 / self.material.rho0;
        let projected = self.projection;
        // The velocity gradient of the geometric laws: ∇0v, and with SUPG ∇0v + L.
        let supg_l = &self.supg.l;
        let grad_v = |a: usize| match supg_l.get(a) {
            Some(&l) => self.kin[a].grad_v + l,
            None => self.kin[a].grad_v,
        };
        // eq 38a: dp/dt = −T + D(p) (the state holds v = p/ρ0); u̇ = v; eq 39b: Ḟ = ∇0v.
        d.v.par_iter_mut()
            .zip(d.u.par_iter_mut())
            .zip(d.f.par_iter_mut())
            .enumerate()
            .with_min_len(MIN_CHUNK)
            .for_each(|(a, ((v_dot, u_dot), f_dot))| {
                let (t_a, dp_a) = if projected {
                    (t[a], dp[a])
                } else {
                    (forces[a].t, forces[a].d)
                };
                *v_dot = (dp_a - t_a) * inv_rho0;
                *u_dot = y.v[a];
                *f_dot = grad_v(a);
            });
        // The stabilisation's power on the bodies, Σ_a V_a D(p_a)·v_a (D per unit reference
        // volume, m_a = ρ0 V_a), D(J)'s on the stored energy, Σ_a V_a π_a D(J_a) with
        // π = ∂ψ/∂J (J̇ = H:∇0v + D(J), and the forces do the work of H:∇0v), and SUPG's
        // L on it, Σ_a V_a P_a : L_a (P = Σ_F + Σ_H × F + Σ_J H): minus the power the
        // balance books as dissipated. Over the counted particles: a rank's own.
        let stabilisation = |a: usize| if projected { dp[a] } else { forces[a].d };
        let evolves_j = self.evolves_j();
        self.dissipation = par_sum(self.n, |a| {
            if !self.counted[a] {
                return 0.0;
            }
            let volume_jump = if evolves_j {
                let pi = self.material.energy_density_mixed_dj::<D>(y.f[a], y.j[a]);
                pi * forces[a].dj
            } else {
                0.0
            };
            let supg = supg_l.get(a).map_or(0.0, |&l| D::ddot(self.kin[a].p, l));
            -self.vol[a] * (D::dot(stabilisation(a), y.v[a]) + volume_jump + supg)
        });
        // eqs 38c–d in the difference form 39c–d.
        if self.conserved.evolves_h() {
            d.h.par_iter_mut()
                .with_min_len(MIN_CHUNK)
                .enumerate()
                .for_each(|(a, h)| *h = D::cof_rate(y.f[a], grad_v(a)));
        }
        if self.evolves_j() {
            d.j.par_iter_mut()
                .with_min_len(MIN_CHUNK)
                .enumerate()
                .for_each(|(a, j)| {
                    *j = D::ddot(self.kin[a].h, grad_v(a)) + forces[a].dj;
                });
        }
        (self.forces, self.t, self.dp) = (forces, t, dp);
        if self.compressibility.is_some() {
            self.correct(y, d)?;
        }
        self.surroundings.close(&y.v, &self.mass, &mut d.v);
        Ok(())
    }
}

impl<D: Dim> Build<D> for MixedSph<D> {
    type Spec = dyn MixedScheme;

    fn build(
        case: &Case,
        spec: &dyn MixedScheme,
        reference: Reference<D>,
    ) -> Result<Self, CaseError> {
        Self::new(case, spec, reference)
    }
}

impl<D: Dim> Method<D> for MixedSph<D> {
    fn initial_state(&self) -> MixedState<D> {
        let n = self.n;
        let f = self.initial_deformation_gradient();
        MixedState {
            u: self.u0.clone(),
            v: self.v0.clone(),
            h: if self.conserved.evolves_h() {
                f.iter().map(|&f| D::cof(f)).collect()
            } else {
                Vec::new()
            },
            j: if self.evolves_j() {
                f.iter().map(|&f| D::det(f)).collect()
            } else {
                Vec::new()
            },
            f,
            pressure: if self.compressibility.is_some() {
                vec![0.0; n]
            } else {
                Vec::new()
            },
        }
    }

    particle_accessors!(MixedState<D>);

    fn reference(&self) -> &[D::V] {
        &self.x0[..self.n]
    }

    fn deformation_gradient(&self, y: &MixedState<D>) -> Vec<D::T> {
        y.f.clone()
    }

    /// σ = J⁻¹ P Fᵀ with the method's J (2D: σ_zz of plane strain from F).
    fn cauchy_stress(&self, y: &MixedState<D>) -> Vec<[[f64; 3]; 3]> {
        let mat = &self.material;
        let u_ext = self.extended_displacement(&y.u);
        (0..self.n)
            .into_par_iter()
            .map(|a| {
                let (f, h, j) = self.stress_arguments(y, a, &u_ext);
                if let Some(r) = self.returned(a, f) {
                    return r.cauchy::<D>(f);
                }
                let sigma = self.stress(y, a, f, h, j) * D::transpose(f) * (1.0 / j);
                let mut out = D::to3x3(sigma);
                if D::N == 2 {
                    out[2][2] = match self.compressibility {
                        Some(_) => mat.sigma_zz_with_pressure::<D>(f, y.pressure[a]),
                        None => mat.sigma_zz::<D>(f, D::zero_t(), mat.rho0),
                    };
                }
                out
            })
            .collect()
    }

    fn strain_energy(&self, y: &MixedState<D>) -> Exact {
        let u_ext = self.extended_displacement(&y.u);
        par_sum(self.n, |a| {
            if !self.counted[a] {
                return 0.0;
            }
            let (f, _, j) = self.stress_arguments(y, a, &u_ext);
            self.vol[a]
                * match self.returned(a, f) {
                    Some(r) => r.psi,
                    // ψ = ψ_iso + p²/(2κ): no volumetric energy at κ = ∞.
                    None if self.compressibility.is_some() => {
                        self.material.isochoric_energy_density::<D>(f, j)
                            + y.pressure[a].powi(2) / (2.0 * self.material.bulk)
                    }
                    None => self.material.energy_density_mixed::<D>(f, j),
                }
        })
    }

    fn dissipation_power(&self) -> Exact {
        self.dissipation.clone()
    }

    /// The committed plastic work and the current step's, over the reference volumes.
    fn plastic_work(&self, y: &MixedState<D>) -> f64 {
        let Some(pl) = &self.plastic else {
            return 0.0;
        };
        self.returned_all(y)
            .map_or(0.0, |r| pl.work_at(&r, &self.vol[..self.n]))
    }

    fn snapshot<'a>(&'a self, y: &MixedState<D>) -> Snapshot<'a, D> {
        Snapshot {
            x0: &self.x0[..self.n],
            mass: &self.mass,
            body: &self.body,
            u: y.u.clone(),
            v: y.v.clone(),
            f: y.f.clone(),
            sigma: self.cauchy_stress(y),
            strain_energy: self.strain_energy(y),
            extra: (self.returned_all(y).zip(self.plastic.as_ref()))
                .map_or(Vec::new(), |(r, pl)| pl.fields(&r))
                .into_iter()
                .map(|(name, values)| ScalarField { name, values })
                .chain(compatibility::<D>(y))
                .collect(),
            cells: &[],
            quadrature: None,
        }
    }

    /// Δx max_ab C_p,ab / r_ab + max |v| ([`MixedSph::pair_wave_speed`]): with v = 0 the
    /// driver's Δt = α Δx / signal speed is seed 002 eq 31, α min_ab r_ab / C_p,ab.
    fn signal_speed_terms(&self, y: &MixedState<D>) -> [f64; 2] {
        [self.pair_wave_speed(y), max_speed::<D>(&y.v)]
    }

    fn pseudo_time(&self) -> Option<PseudoTime> {
        self.compressibility.as_ref().map(|c| c.stats)
    }

    fn pairs(&self) -> usize {
        self.csr.pair_count()
    }

    /// Two copies extend u and v to the ghosts. Pass 1 reads F, v, V (H, J, p when
    /// evolved; X and u with the bond-based F; C_p⁻¹, ε_p when plastic) and writes the
    /// kinematics, which the admissibility check reads again; pass 2 reads v and writes
    /// ∇²v (JST), or also reads the kinematics and writes the slopes (reconstruction);
    /// pass 3 reads the kinematics, X, u, v, V (the slopes or ∇²v) and writes the forces.
    /// The projection splits them into T and D(p) and moves its points, V and both
    /// fields; one pass then reads the forces (or the projected T and D(p)), v and the
    /// kinematics and writes v̇, u̇ and Ḟ, and others Ḣ and J̇. Per pair:
    /// the ids and g_ab (w_ab) in pass 1, the ids and least-squares weights or ℓ_ab in
    /// pass 2, the ids, g_ab, g_ba and N_ab or s_ab in pass 3. Real particles only: the
    /// ghosts' records, the TVD-RK2 balance points and the pseudo-time corrector are left
    /// out.
    fn traffic(&self) -> Option<Traffic> {
        let Sizes { v, t, f, id } = Sizes::of::<D>();
        let (kin, slopes, forces) = (
            size_of::<Kinematics<D>>(),
            size_of::<Slopes<D>>(),
            size_of::<Forces<D>>(),
        );
        let when = |on: bool, bytes: usize| if on { bytes } else { 0 };
        let (upwind, reconstruction, jst) = match self.stabilisation {
            Stabilisation::Upwind { reconstruction } => (true, reconstruction, false),
            Stabilisation::Jst { .. } => (false, false, true),
            Stabilisation::Supg { .. } => (false, false, false),
        };
        let (evolves_h, evolves_j) = (self.conserved.evolves_h(), self.evolves_j());
        let pressure = self.compressibility.is_some();
        let bond = self.bond_weights.is_some();
        let extend = 4 * v;
        let pass_1 = t
            + v
            + f
            + 2 * kin
            + when(evolves_h, t)
            + when(evolves_j, f)
            + when(pressure, f)
            + when(bond, 2 * v)
            + Sizes::plastic_history(self.plastic.is_some());
        let pass_2 = when(reconstruction, kin + v + slopes) + when(jst, 2 * v);
        let pass_3 = kin
            + 3 * v
            + f
            + forces
            + when(upwind, v)
            + when(reconstruction, slopes)
            + when(jst, v);
        let projection = when(self.projection, forces + 2 * v + 15 * v + 5 * f);
        let stage_forces = if self.projection { 2 * v } else { forces };
        let rates = stage_forces
            + v
            + kin
            + 2 * v
            + t
            + when(evolves_h, 2 * t + kin)
            + when(evolves_j, kin + forces + f);
        let per_pair = (id + v + when(bond, f))
            + when(reconstruction, id + v)
            + when(jst, id + f)
            + (id + 2 * v + when(upwind, v) + when(jst, f));
        let state = 2 * v + t + when(evolves_h, t) + when(evolves_j, f) + when(pressure, f);
        Some(Traffic {
            per_particle: (extend + pass_1 + pass_2 + pass_3 + projection + rates) as f64,
            per_pair: per_pair as f64,
            state: state as f64,
            velocity: v as f64,
        })
    }

    fn check_finite(&self, y: &MixedState<D>) -> Result<(), BlowUp> {
        check_motion::<D>(&self.x0, &y.u, &y.v)?;
        let norm_t = |t: D::T| D::ddot(t, t).sqrt();
        if let Some(i) = y.f.par_iter().position_first(|&f| !D::is_finite_t(f)) {
            return Err(self.blow_up(i, "|F|", norm_t(y.f[i])));
        }
        if let Some(i) = y.h.par_iter().position_first(|&h| !D::is_finite_t(h)) {
            return Err(self.blow_up(i, "|H|", norm_t(y.h[i])));
        }
        if let Some(i) = y.j.par_iter().position_first(|j| !j.is_finite()) {
            return Err(self.blow_up(i, "J", y.j[i]));
        }
        if let Some(i) = y.pressure.par_iter().position_first(|p| !p.is_finite()) {
            return Err(self.blow_up(i, "pressure", y.pressure[i]));
        }
        Ok(())
    }

    /// The plastic history C_p⁻¹, ε_p of a `von-mises-plastic` material.
    fn save_history(&self, out: &mut Vec<f64>) {
        History::save(self.plastic.as_ref(), out);
    }

    fn load_history(&mut self, words: &mut &[f64]) -> Result<(), String> {
        History::load(self.plastic.as_mut(), words)
    }
}

/// Where the evolved J and H part from F's determinant and cofactor: J/det F and
/// |H − cof F|/|cof F| of every particle, for those of J and H the state evolves (1 and
/// 0 on a compatible state; the polyconvex ψ(F, H, J) may turn negative where they part).
fn compatibility<D: Dim>(y: &MixedState<D>) -> Vec<ScalarField> {
    let mut out = Vec::new();
    if !y.j.is_empty() {
        out.push(ScalarField {
            name: "J_over_det_F",
            values: (y.j.iter().zip(&y.f))
                .map(|(&j, &f)| j / D::det(f))
                .collect(),
        });
    }
    if !y.h.is_empty() {
        let norm = |t: D::T| D::ddot(t, t).sqrt();
        out.push(ScalarField {
            name: "H_cof_F_deviation",
            values: (y.h.iter().zip(&y.f))
                .map(|(&h, &f)| norm(h - D::cof(f)) / norm(D::cof(f)))
                .collect(),
        });
    }
    out
}
