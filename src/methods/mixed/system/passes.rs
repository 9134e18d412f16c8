//! The passes of the rates: kinematics, slopes, Laplacians, forces, fluxes and the
//! corrector.

use super::*;

impl<D: Dim> MixedSph<D> {
    /// u and v of the real particles and their ghosts.
    pub(super) fn extend_motion(&mut self, y: &MixedState<D>) {
        fill_extended(&self.ghosts, &mut self.u_ext, &y.u);
        fill_extended(&self.ghosts, &mut self.v_ext, &y.v);
    }

    /// Pass 1: P(F, H, J) and the corrected velocity gradient of every particle.
    pub(super) fn kinematics(&mut self, y: &MixedState<D>) -> Result<(), BlowUp> {
        self.extend_motion(y);
        let mut kin = std::mem::take(&mut self.kin);
        let kinematics = |a: usize| {
            let (f, h, j) = self.stress_arguments(y, a, &self.u_ext);
            Kinematics {
                p: self.stress(y, a, f, h, j),
                h,
                grad_v: self.gradient(&self.v_ext, a),
                j,
                det_f: D::det(f),
            }
        };
        self.ghosts.fill(&mut kin, kinematics, |m, k| Kinematics {
            p: m.tensor::<D>(k.p),
            h: m.unit_tensor::<D>(k.h),
            grad_v: m.tensor::<D>(k.grad_v),
            j: m.unit_scalar(k.j),
            det_f: m.unit_scalar(k.det_f),
        });
        self.kin = kin;
        // A rank's own particles: its outermost ghosts' F^c and ∇0v lack neighbours.
        let bad = (self.kin[..self.n].par_iter().zip(&self.counted))
            .position_first(|(k, &counted)| counted && !(k.j > 0.0 && k.det_f > 0.0));
        match bad {
            Some(a) if self.kin[a].det_f > 0.0 => Err(self.blow_up(a, "J", self.kin[a].j)),
            Some(a) => Err(self.blow_up(a, "det F", self.kin[a].det_f)),
            None => Ok(()),
        }
    }

    /// Pass 2 (Upwind-SPH with reconstruction): least-squares slopes of v and P.
    pub(super) fn slopes(&mut self) {
        let mut slopes = std::mem::take(&mut self.slopes);
        let least_squares = |a: usize| {
            let mut grad_v = D::zero_t();
            let mut grad_p = [D::zero_t(); 3];
            let pa = self.kin[a].p;
            for (b, &w) in self.csr.pairs(a, &self.ls) {
                grad_v += D::outer(self.v_ext[b] - self.v_ext[a], w);
                let dp = self.kin[b].p - pa;
                for (l, g) in grad_p.iter_mut().enumerate().take(D::N) {
                    *g += dp * D::comp(w, l);
                }
            }
            Slopes { grad_v, grad_p }
        };
        // ∂P'/∂X'_l = r_l σ R (∂P/∂X_l) R.
        self.ghosts.fill(&mut slopes, least_squares, |m, s| Slopes {
            grad_v: m.tensor::<D>(s.grad_v),
            grad_p: std::array::from_fn(|l| {
                let sign = if l < D::N { m.axis_sign(l) } else { 0.0 };
                m.tensor::<D>(s.grad_p[l]) * sign
            }),
        });
        self.slopes = slopes;
    }

    /// Pass 2 (JST-SPH): ∇²v_a = Σ_b ℓ_ab (v_b − v_a) (seed 002 eq 27).
    pub(super) fn laplacians(&mut self) {
        let Stabilisation::Jst { ell, .. } = &self.stabilisation else {
            return;
        };
        let mut lap = std::mem::take(&mut self.lap);
        let laplacian = |a: usize| {
            let mut sum = D::zero();
            for (b, &ell) in self.csr.pairs(a, ell) {
                sum += (self.v_ext[b] - self.v_ext[a]) * ell;
            }
            sum
        };
        self.ghosts
            .fill(&mut lap, laplacian, |m, l| m.vector::<D>(l));
        self.lap = lap;
    }

    /// Pass 3: the internal force, the stabilisation of p and the dissipation of J of
    /// every real particle, into `out`.
    pub(super) fn forces(&self, y: &MixedState<D>, out: &mut [Forces<D>]) {
        let mat = &self.material;
        let (c_p, c_s) = (self.c_p, mat.s_wave_speed());
        // Artificial compressibility leaves D(J) out: in the corrector's constraint it is a
        // compact Laplacian of P that the wide DIV of the pair sums cannot balance, and it
        // grows the pressure checkerboard (docs/methods/mixed.md).
        let dissipates_j = self.compressibility.is_none();
        // JST's ε⁽²⁾h, ε⁽⁴⁾h³ and ½ c_p ρ0 of eq 26, once for all pairs.
        let (e2_h, e4_h3, jst_scale) = match &self.stabilisation {
            Stabilisation::Jst { coefficients, .. } => (
                coefficients.eps2 * self.h,
                coefficients.eps4 * self.h.powi(3),
                0.5 * c_p * mat.rho0,
            ),
            Stabilisation::Upwind { .. } | Stabilisation::Supg { .. } => (0.0, 0.0, 0.0),
        };
        let (u, v) = (&self.u_ext, &self.v_ext);
        out.par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(a, out)| {
                let ka = self.kin[a];
                let xa = self.x0[a] + y.u[a];
                let mut t = D::zero();
                let mut d = D::zero();
                let mut dj = 0.0;
                let row = self.csr.range(a);
                let pairs = self
                    .csr
                    .pairs(a, &self.grad)
                    .zip(&self.grad_rev[row.clone()]);
                for (q, ((b, &g_ab), &g_ba)) in row.zip(pairs) {
                    let kb = self.kin[b];
                    t += pair_force::<D>(self.momentum, self.vol[b], ka.p, kb.p, g_ab, g_ba);
                    match &self.stabilisation {
                        Stabilisation::Upwind { reconstruction } => {
                            let n_ref = self.normal[q];
                            let (mut dv, mut dp) = (v[b] - v[a], kb.p - ka.p);
                            if *reconstruction {
                                // eq 37: faces at the mid-pair, p_f⁻ from a, p_f⁺ from b.
                                let d_ab = self.x0[b] - self.x0[a];
                                let (va, pa) = self.slopes[a].along(d_ab, 0.5);
                                let (vb, pb) = self.slopes[b].along(d_ab, -0.5);
                                dv = dv + vb - va;
                                dp = dp + pb - pa;
                            }
                            let x_ab = self.x0[b] + u[b] - xa;
                            let n = x_ab * (1.0 / D::norm2(x_ab).sqrt());
                            // eq 28: S^p Δp = ½[c_p n (n·Δp) + c_s (Δp − n (n·Δp))].
                            let dp_mom = dv * mat.rho0;
                            let normal_part = n * D::dot(n, dp_mom);
                            let s_dp = (normal_part * c_p + (dp_mom - normal_part) * c_s) * 0.5;
                            // eq 32: 2 V_b (S^p Δp)(N_ab · ∇̃W̃^Ave_b(X_a)).
                            let g_ave = (g_ab - g_ba) * 0.5;
                            d += s_dp * (2.0 * self.vol[b] * D::dot(n_ref, g_ave));
                            // eq 28: p^stab = n (n · ΔP N_ab)/(2 c_p); eq 33 with the
                            // dissipative sign: V_b p^stab/ρ0 · (H_a g_ab − H_b g_ba).
                            if dissipates_j {
                                let p_stab = n * (D::dot(n, dp * n_ref) / (2.0 * c_p));
                                let h_g = ka.h * g_ab - kb.h * g_ba;
                                dj += self.vol[b] / mat.rho0 * D::dot(p_stab, h_g);
                            }
                        }
                        Stabilisation::Jst { s, .. } => {
                            let lap = self.lap[b] - self.lap[a];
                            let dv = v[b] - v[a];
                            d += (dv * e2_h - lap * e4_h3) * (jst_scale * s[q]);
                        }
                        // Its terms come from the stress points (`supg`).
                        Stabilisation::Supg { .. } => {}
                    }
                }
                *out = Forces { t, d, dj };
            });
    }

    /// Positions 𝒳_a about which angular momentum is balanced (eq B.1): the stage
    /// positions, and x^n + Δt/2 (v^n + v*) = x^{n+1} at the second TVD-RK2 stage, which
    /// makes the step conserve angular momentum exactly.
    pub(super) fn balance_points(&self, y: &MixedState<D>, out: &mut [D::V]) {
        let points = out.par_iter_mut().with_min_len(MIN_CHUNK).enumerate();
        match (&self.step_start, self.stage) {
            (Some((u0, v0, dt)), 1) if self.integrator == IntegratorKind::TvdRk2 => {
                points.for_each(|(a, x)| *x = self.x0[a] + u0[a] + (v0[a] + y.v[a]) * (0.5 * dt))
            }
            _ => points.for_each(|(a, x)| *x = self.x0[a] + y.u[a]),
        }
    }

    /// The parts of the rates at state y before projection and boundary conditions:
    /// the internal force T_a, the stabilisation D(p_a) (both per unit reference volume)
    /// and the J dissipation D(J_a).
    pub fn fluxes(&mut self, y: &MixedState<D>) -> Result<Fluxes<D>, BlowUp> {
        self.prepare(y)?;
        let mut forces = std::mem::take(&mut self.forces);
        self.forces(y, &mut forces);
        let supg = self.supg(y, &mut forces);
        self.forces = forces;
        supg?;
        let forces = &self.forces;
        Ok(Fluxes {
            t: forces.iter().map(|f| f.t).collect(),
            d: forces.iter().map(|f| f.d).collect(),
            dj: forces.iter().map(|f| f.dj).collect(),
        })
    }

    /// Passes 1 and 2: stresses, velocity gradients and the slopes or Laplacians the
    /// stabilisation reads.
    pub(super) fn prepare(&mut self, y: &MixedState<D>) -> Result<(), BlowUp> {
        self.kinematics(y)?;
        match self.stabilisation {
            Stabilisation::Upwind {
                reconstruction: true,
            } => self.slopes(),
            Stabilisation::Jst { .. } => self.laplacians(),
            Stabilisation::Upwind { .. } | Stabilisation::Supg { .. } => {}
        }
        Ok(())
    }

    /// Artificial compressibility: the pressure rate of the predictor and the corrector
    /// of the stage (eqs 51d, 52–58, without D(J)) on the rates `d` of the explicit stage, before loads
    /// and supports. v^int and p^int are the predictor's stage ends, loads, contact and
    /// supports included; the converged pressure's force −T[(p^{n+1} − p^n)H^n] (the
    /// last iterate's if the iteration fails) is added to v̇ (projected with the stage's
    /// other forces), and ṗ = (p^{n+1} − p^n)/Δt.
    pub(super) fn correct(
        &mut self,
        y: &MixedState<D>,
        d: &mut MixedState<D>,
    ) -> Result<(), BlowUp> {
        let mut corrector = self
            .compressibility
            .take()
            .expect("correct runs with artificial compressibility");
        let (n, dt) = (self.n, self.dt);
        let kappa_tilde = corrector.kappa_tilde();
        // eq 51d without D(J): (p^int − p^n)/Δt = κ̃ H^n : ∇0v^n.
        d.pressure
            .par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .zip(&self.kin[..n])
            .for_each(|(p, k)| *p = kappa_tilde * D::ddot(k.h, k.grad_v));
        let mut b = std::mem::take(&mut corrector.buffers);
        b.p_int.clear();
        b.p_int
            .extend((0..n).map(|a| y.pressure[a] + dt * d.pressure[a]));
        b.a_int.clone_from(&d.v);
        let surroundings = &self.surroundings;
        b.work.finish(
            &surroundings.interactions,
            &surroundings.boundary,
            &y.v,
            &self.mass,
            &mut b.a_int,
        );
        b.v_int.clear();
        b.v_int.extend((0..n).map(|a| y.v[a] + b.a_int[a] * dt));
        b.held.clear();
        b.held.resize(n, 0);
        for (i, mask) in surroundings.boundary.held_now() {
            b.held[i as usize] = mask;
        }
        b.h.clear();
        b.h.extend(self.kin[..n].iter().map(|k| k.h));
        let stage = StageStart {
            dt,
            v_int: &b.v_int,
            v_n: &y.v,
            p_n: &y.pressure,
            p_int: &b.p_int,
            h: &b.h,
            held: &b.held,
        };
        let pairs = Pairs {
            csr: &self.csr,
            grad: &self.grad,
            grad_rev: &self.grad_rev,
            vol: &self.vol,
            ghosts: &self.ghosts,
            momentum: self.momentum,
        };
        let solved = corrector
            .solve(&pairs, &stage)
            .map_err(|u| self.blow_up(u.particle, UNCONVERGED, u.residual));
        // The corrector's force, into the predictor's stage ends' array, at the last
        // iterate if the iteration failed: the projection's sums are collectives that the
        // other ranks, whose share converged or not, take too.
        let force = &mut b.a_int;
        corrector.force(&pairs, force);
        if self.projection {
            let balance =
                Balance::<D>::new(&self.points, &self.vol[..n], &self.counted, &*self.ranks);
            balance.project(force);
        }
        let inv_rho0 = 1.0 / self.material.rho0;
        let p_next = corrector.p();
        for a in 0..n {
            d.v[a] += force[a] * inv_rho0;
            d.pressure[a] = (p_next[a] - y.pressure[a]) / dt;
        }
        corrector.buffers = b;
        self.compressibility = Some(corrector);
        solved
    }

    /// Δx max_ab C_p,ab / r_ab over the neighbour pairs of real particles (seed 002 eqs
    /// 31–32): the speed that crosses the spacing Δx in the shortest time r_ab / C_p,ab
    /// a wave takes across a pair, r_ab = |x_b − x_a| the current distance.
    ///
    /// Pairs with a ghost do not count: a ghost is no material point, and counting it
    /// could only lower Δt through the mirror construction. Across a symmetry plane the
    /// image b' of b is no nearer to a than b is (|x_a − x_b'| ≥ |x_a − x_b| for a and b
    /// on the body's side, likewise in the reference, so (a, b) is a pair too) and
    /// λ_b' = λ_b; only a particle's pair with its own image would add a rate, at twice
    /// its distance to the plane: Δx at rest on a cell-centred lattice, and for a locally
    /// affine motion stretched as the real pairs along the plane's normal are. Across a
    /// skew-symmetric plane the image carries −u along the plane, and its distance to a is
    /// no distance in the body.
    ///
    /// With [`CflWaveSpeed::Linear`] every pair has C_p,ab = C_p^Lin.
    pub fn pair_wave_speed(&self, y: &MixedState<D>) -> f64 {
        // λ_a: the smallest principal stretch, sqrt of the smallest eigenvalue of C_a;
        // 1 for C_p^Lin.
        let stretch: Vec<f64> = match self.cfl_wave_speed {
            CflWaveSpeed::Pair => {
                y.f.par_iter()
                    .map(|&f| smallest_stretch_squared::<D>(f).sqrt())
                    .collect()
            }
            CflWaveSpeed::Linear => vec![1.0; self.n],
        };
        let c_p = self.c_p;
        let fastest = (0..self.n)
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(|a| {
                let xa = self.x0[a] + y.u[a];
                self.csr
                    .neighbours(a)
                    .iter()
                    .map(|&b| b as usize)
                    .filter(|&b| b < self.n)
                    .map(|b| {
                        let r_ab = D::norm2(self.x0[b] + y.u[b] - xa).sqrt();
                        // eq 32: C_p,ab = C_p^Lin / λ^Ave_ab, λ^Ave_ab = ½(λ_a + λ_b).
                        let c_ab = c_p / (0.5 * (stretch[a] + stretch[b]));
                        c_ab / r_ab
                    })
                    .fold(0.0, f64::max)
            })
            .reduce(|| 0.0, f64::max);
        self.spacing * fastest
    }

    /// First Piola–Kirchhoff stress of every particle.
    pub fn first_piola(&mut self, y: &MixedState<D>) -> Result<Vec<D::T>, BlowUp> {
        self.kinematics(y)?;
        Ok(self.kin.iter().map(|k| k.p).collect())
    }
}
