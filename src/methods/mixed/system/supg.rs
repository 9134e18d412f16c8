//! SUPG-SPH's pass (seed 003 §1; docs/methods/mixed.md "SUPG-SPH"): the residuals of
//! the conservation laws at the stress points, and their Petrov–Galerkin terms gathered
//! to the particles.
//!
//! At a particle the residuals vanish by construction (Ḟ_a is Σ_b v_b ⊗ G_b(X_a)); at a
//! stress point s the rates interpolated from the particles differ from the gradients
//! taken there exactly by what the particles' quadrature cannot see. With the
//! first-order functions N_b(X_s), G_b(X_s) of the points:
//! - R_F = Σ N_b Ḟ_b − ∇0v_s, R_H = Σ N_b Ḣ_b − F_s × ∇0v_s, R_J = Σ N_b J̇_b − H_s : ∇0v_s;
//! - F^st = F_s − τ_F R_F + ξ_F (∇0x_s − F_s) (H^st, J^st likewise, with cof ∇0x_s and
//!   det ∇0x_s), and ΔP_s = P(F^st, H^st, J^st) − P(F_s, H_s, J_s);
//! - r_s = DIV P_s + f0 − ṗ_s = Σ_b P_b G_b(X_s) − Σ_b N_b q_b, and Δv_s = (τ_p/ρ0) r_s,
//!   with q_b = ṗ_b − f0 of the particles' own equation: −T_b, the body force cancelling,
//!   and zero along a component a support holds, whose ṗ is the support's and not the
//!   unbalanced internal force (its body force, and the tractions and contact forces of
//!   the other particles, left out: they act on boundary layers).
//!
//! Tested with the particles' functions and lumped: V_a ṗ_a += −Σ_s V_s ΔP_s G_a(X_s)
//! (the SUPG term of the momentum law), and the velocity of the geometric laws gains
//! L_a = −(1/V_a) Σ_s V_s Δv_s ⊗ G_a(X_s) (Ḟ = ∇0v + L, Ḣ = F × (∇0v + L), J̇ = H :
//! (∇0v + L)). Every term vanishes for a linear velocity on an affine motion.

use super::*;

/// The Galerkin rates of a particle (real or ghost) the stress points interpolate.
#[derive(Clone, Copy, Debug)]
pub(super) struct NodeRates<D: Dim> {
    /// The evolved F.
    f: D::T,
    /// Ḣ = F × ∇0v and J̇ = H : ∇0v.
    h_dot: D::T,
    j_dot: f64,
    /// q = ṗ − f0 without SUPG's term.
    q: D::V,
}

/// A stress point's increments ΔP_s and Δv_s, and the smaller of det F^st and J^st.
#[derive(Clone, Copy, Debug)]
pub(super) struct PointTerms<D: Dim> {
    dp: D::T,
    dv: D::V,
    det: f64,
}

/// SUPG's per-stage buffers.
pub(super) struct SupgBuffers<D: Dim> {
    nodes: Vec<NodeRates<D>>,
    terms: Vec<PointTerms<D>>,
    /// L_a of every real particle.
    pub(super) l: Vec<D::T>,
    /// The components each real particle's supports hold (bit k: component k).
    held: Vec<u8>,
}

impl<D: Dim> Default for SupgBuffers<D> {
    fn default() -> Self {
        Self {
            nodes: Vec::new(),
            terms: Vec::new(),
            l: Vec::new(),
            held: Vec::new(),
        }
    }
}

impl<D: Dim> MixedSph<D> {
    /// SUPG-SPH: its parameters and stress points.
    pub fn stress_points(&self) -> Option<(crate::methods::mixed::Supg, &StressPoints<D>)> {
        match &self.stabilisation {
            Stabilisation::Supg { parameters, points } => Some((*parameters, points)),
            Stabilisation::Upwind { .. } | Stabilisation::Jst { .. } => None,
        }
    }

    /// SUPG: adds −(1/V_a) Σ_s V_s ΔP_s G_a(X_s) to the stabilisation D of every real
    /// particle and sets L_a in `self.supg.l`; nothing for the other stabilisations.
    pub(super) fn supg(
        &mut self,
        y: &MixedState<D>,
        forces: &mut [Forces<D>],
    ) -> Result<(), BlowUp> {
        let mut buffers = std::mem::take(&mut self.supg);
        let failed = self.supg_terms(y, forces, &mut buffers);
        self.supg = buffers;
        match failed {
            Some((a, value)) => Err(self.blow_up(a, "det F^st at a stress point", value)),
            None => Ok(()),
        }
    }

    /// [`Self::supg`] into `buffers`; the particle nearest a stress point whose F^st or
    /// J^st is not positive, with the value, if any.
    fn supg_terms(
        &self,
        y: &MixedState<D>,
        forces: &mut [Forces<D>],
        buffers: &mut SupgBuffers<D>,
    ) -> Option<(usize, f64)> {
        let Stabilisation::Supg { parameters, points } = &self.stabilisation else {
            return None;
        };
        let kin = &self.kin;
        buffers.held.clear();
        buffers.held.resize(self.n, 0);
        for (i, mask) in self.surroundings.boundary.held_now() {
            buffers.held[i as usize] = mask;
        }
        let held = &buffers.held;
        buffers.nodes.resize(
            self.x0.len(),
            NodeRates {
                f: D::identity(),
                h_dot: D::zero_t(),
                j_dot: 0.0,
                q: D::zero(),
            },
        );
        let node = |k: usize| NodeRates {
            f: y.f[k],
            h_dot: D::cof_rate(y.f[k], kin[k].grad_v),
            j_dot: D::ddot(kin[k].h, kin[k].grad_v),
            q: free_components::<D>(forces[k].t * -1.0, held[k]),
        };
        self.ghosts
            .fill(&mut buffers.nodes, node, |m, r| NodeRates {
                f: m.unit_tensor::<D>(r.f),
                h_dot: m.tensor::<D>(r.h_dot),
                j_dot: m.scalar(r.j_dot),
                q: m.vector::<D>(r.q),
            });
        let (tau_f, tau_p, xi) = (
            parameters.tau_f * self.dt,
            parameters.tau_p * self.dt,
            parameters.xi_f,
        );
        let (evolves_h, evolves_j) = (self.conserved.evolves_h(), self.evolves_j());
        let shapes = &points.shapes;
        let nodes = &buffers.nodes;
        let (u, v) = (&self.u_ext, &self.v_ext);
        let mat = &self.material;
        let at_point = |s: usize| {
            let (mut f, mut h, mut j) = (D::zero_t(), D::zero_t(), 0.0);
            let (mut f_dot, mut h_dot, mut j_dot) = (D::zero_t(), D::zero_t(), 0.0);
            let (mut q_s, mut div_p) = (D::zero(), D::zero());
            let (mut grad_v, mut grad_u) = (D::zero_t(), D::zero_t());
            for q in shapes.csr.range(s) {
                let b = shapes.csr.ids[q] as usize;
                let (n, g) = (shapes.n[q], shapes.grad[q]);
                let (kb, rb) = (&kin[b], &nodes[b]);
                f += rb.f * n;
                h += kb.h * n;
                j += kb.j * n;
                f_dot += kb.grad_v * n;
                h_dot += rb.h_dot * n;
                j_dot += rb.j_dot * n;
                q_s += rb.q * n;
                div_p += kb.p * g;
                grad_v += D::outer(v[b], g);
                grad_u += D::outer(u[b], g);
            }
            let grad_x = D::identity() + grad_u;
            // F^st = F − τ_F (Ḟ − ∇0v) + ξ_F (∇0x − F).
            let f_st = f - (f_dot - grad_v) * tau_f + (grad_x - f) * xi;
            let (h, h_st) = if evolves_h {
                let r_h = h_dot - D::cof_rate(f, grad_v);
                (h, h - r_h * tau_f + (D::cof(grad_x) - h) * xi)
            } else {
                (D::cof(f), D::cof(f_st))
            };
            let (j, j_st) = if evolves_j {
                let r_j = j_dot - D::ddot(h, grad_v);
                (j, j - r_j * tau_f + (D::det(grad_x) - j) * xi)
            } else {
                (D::det(f), D::det(f_st))
            };
            let dp = mat.pk1_mixed::<D>(f_st, h_st, j_st) - mat.pk1_mixed::<D>(f, h, j);
            let dv = (div_p - q_s) * (tau_p / mat.rho0);
            PointTerms {
                dp,
                dv,
                det: D::det(f_st).min(j_st),
            }
        };
        buffers.terms.clear();
        (0..points.len())
            .into_par_iter()
            .with_min_len(MIN_CHUNK)
            .map(at_point)
            .collect_into_vec(&mut buffers.terms);
        let terms = &buffers.terms;
        if let Some(s) = terms
            .par_iter()
            .position_first(|p| !(p.det > 0.0 && p.det.is_finite()))
        {
            let row = shapes.csr.range(s);
            let nearest = row
                .clone()
                .max_by(|&p, &q| shapes.n[p].total_cmp(&shapes.n[q]));
            let (a, _) =
                (self.ghosts).origin(shapes.csr.ids[nearest.unwrap_or(row.start)] as usize);
            return Some((a, terms[s].det));
        }
        buffers.l.resize(self.n, D::zero_t());
        self.gather_points(points, terms, forces, &mut buffers.l);
        None
    }

    /// Step 4: D_a into `forces` and L_a into `l`, gathered from the stress points'
    /// `terms`.
    fn gather_points(
        &self,
        points: &StressPoints<D>,
        terms: &[PointTerms<D>],
        forces: &mut [Forces<D>],
        l: &mut [D::T],
    ) {
        let shapes = &points.shapes;
        (forces.par_iter_mut().zip(l.par_iter_mut()))
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(a, (out, l))| {
                let (mut d, mut sum_l) = (D::zero(), D::zero_t());
                for share in &points.gather[a] {
                    let (s, q) = (share.point as usize, share.pair as usize);
                    let (term, g) = (terms[s], shapes.grad[q]);
                    let (dp, dv, g) = match share.image {
                        None => (term.dp, term.dv, g),
                        Some(m) => (
                            m.tensor::<D>(term.dp),
                            m.vector::<D>(term.dv),
                            m.reflect::<D>(g),
                        ),
                    };
                    let w = points.weight[s];
                    d -= dp * g * w;
                    sum_l -= D::outer(dv, g) * w;
                }
                let inv_vol = 1.0 / self.vol[a];
                out.d += d * inv_vol;
                *l = sum_l * inv_vol;
            });
    }
}

/// SUPG's stabilisation of a case: its `parameters` and the stress points of the cells
/// of the particles x0 (real, then `ghosts`; bodies `body`; `generated` the generators'
/// cells).
pub(super) fn stabilisation<D: Dim>(
    case: &Case,
    parameters: crate::methods::mixed::Supg,
    (x0, body): (&[D::V], &[u32]),
    ghosts: &Ghosts<D>,
    generated: &crate::core::quadrature::Cells,
) -> Result<Stabilisation<D>, CaseError> {
    let points = StressPoints::build(case, x0, body, ghosts, generated)?;
    Ok(Stabilisation::Supg {
        parameters,
        points: Box::new(points),
    })
}

/// The vector f with the components of `held` (bit k: component k) set to zero.
fn free_components<D: Dim>(f: D::V, held: u8) -> D::V {
    let mut c = [0.0; 3];
    for (k, c) in c.iter_mut().enumerate().take(D::N) {
        if held & (1 << k) == 0 {
            *c = D::comp(f, k);
        }
    }
    D::from_slice(&c[..D::N])
}
