//! The discrete energy of dual-support SPH and its derivatives: the strain energy
//! Σ_i V_i ψ(F_i) (eq 38) and the hourglass energy Σ_i V_i 𝓕_i^hg (eq 21), the internal
//! force −∂E/∂u (eq 18, and eq 28 with the sign of the hourglass term corrected), and the
//! tangent ∂²E/∂u² assembled in two steps (eqs 39–41 and the corrected eq 29).

use super::support::Support;
use crate::core::sum::{Exact, par_sum, par_sums};
use crate::core::tensor::Dim;
use crate::diagnostics::observe::{ScalarField, Snapshot};
use crate::engine::BlowUp;
use crate::physics::material::{Material, Tangent};
use crate::statics::sparse::BlockPattern;
use rayon::prelude::*;

/// Strain and hourglass energy of a displacement field: exact sums over the counted
/// particles ([`Reference::counted`](crate::reference::Reference::counted)).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Energies {
    /// Σ_i V_i ψ(F_i).
    pub strain: Exact,
    /// Σ_i V_i 𝓕_i^hg.
    pub hourglass: Exact,
}

/// Dual-support SPH on a reference configuration: supports, material and the hourglass
/// coefficient of every particle.
pub struct DualSupport<D: Dim> {
    pub support: Support<D>,
    pub material: Material,
    /// c_i = α/m_{L_i} with m_{L_i} = tr L_i < 0 and the penalty α = (factor) μ ≥ 0, so
    /// that c_i w_ij ≥ 0 and 𝓕^hg ≥ 0 (note §1.6: keep the signs of W′ and m_L together).
    pub hourglass: Vec<f64>,
    /// The hourglass term 2 V_i c_i w_ij e_ij of every pair slot, kept from one force
    /// evaluation to the next.
    pair_terms: Vec<D::V>,
    /// Whether each particle's share of the sums is booked and its F checked: all but a
    /// rank's ghosts.
    counted: Vec<bool>,
}

impl<D: Dim> DualSupport<D> {
    /// The method on `support` with the hourglass penalty α = `factor` · μ (0: no
    /// hourglass control), booking the sums of the `counted` particles and checking
    /// their F.
    pub fn new(support: Support<D>, material: Material, factor: f64, counted: Vec<bool>) -> Self {
        let alpha = factor * material.mu;
        let hourglass = support.l.iter().map(|&l| alpha / D::trace(l)).collect();
        Self {
            support,
            material,
            hourglass,
            pair_terms: Vec::new(),
            counted,
        }
    }

    pub fn len(&self) -> usize {
        self.support.len()
    }

    pub fn is_empty(&self) -> bool {
        self.support.is_empty()
    }

    /// F_i of every particle (eq 12).
    pub fn deformation_gradients(&self, u: &[D::V]) -> Vec<D::T> {
        self.displacement_gradients(u)
            .into_iter()
            .map(|h| D::identity() + h)
            .collect()
    }

    /// H_i = F_i − I of every particle (eq 12).
    pub fn displacement_gradients(&self, u: &[D::V]) -> Vec<D::T> {
        (0..self.len())
            .into_par_iter()
            .map(|i| self.support.displacement_gradient(u, i))
            .collect()
    }

    /// The first particle with det F ≤ 0 or a non-finite F among H = F − I, as a blow-up.
    pub fn first_inadmissible(&self, h: &[D::T]) -> Option<BlowUp> {
        let det = |h: D::T| D::det(D::identity() + h);
        let bad = |h: D::T| !D::is_finite_t(h) || det(h) <= 0.0 || det(h).is_nan();
        let i =
            (h.par_iter().zip(&self.counted)).position_first(|(&h, &counted)| counted && bad(h))?;
        Some(BlowUp::at::<D>(&self.support.x0, i, "det F", det(h[i])))
    }

    /// e_ij = x_ij − F_i X_ij = u_ij − H_i X_ij of particle i and its neighbour j: the
    /// error of the affine map of i at j.
    #[inline]
    fn pair_error(&self, u: &[D::V], h_i: D::T, i: usize, j: usize) -> D::V {
        let x0 = &self.support.x0;
        (u[j] - u[i]) - h_i * (x0[j] - x0[i])
    }

    /// 2 V_i c_i w_ij e_ij of the pairs of row i, into `out` (eq 28's hourglass term).
    fn hourglass_terms(&self, u: &[D::V], h_i: D::T, i: usize, out: &mut [D::V]) {
        let s = &self.support;
        let k = 2.0 * s.vol[i] * self.hourglass[i];
        for (term, (j, &w)) in out.iter_mut().zip(s.lists.pairs(i, &s.w)) {
            *term = self.pair_error(u, h_i, i, j) * (k * w);
        }
    }

    /// 𝓕_i^hg = c_i Σ_j w_ij |e_ij|² (eq 21, first form), an energy density.
    fn hourglass_density(&self, u: &[D::V], h_i: D::T, i: usize) -> f64 {
        let c = self.hourglass[i];
        if c == 0.0 {
            return 0.0;
        }
        let s = &self.support;
        c * s
            .lists
            .pairs(i, &s.w)
            .map(|(j, &w)| w * D::norm2(self.pair_error(u, h_i, i, j)))
            .sum::<f64>()
    }

    /// The scalar-field hourglass of eq 30 on a field s (a temperature, a pressure, one
    /// component of u): per particle 𝓕_i = c_i Σ_j w_ij ε_ij² with the error of the linear
    /// map of i at j, ε_ij = s_ij − ∇s_i·X_ij, ∇s_i = Σ_j s_ij g_ij; returns the energy
    /// Σ_i V_i 𝓕_i and the force −∂E/∂s on every particle. The pair term is eq 30's with
    /// the sign of the energy, 2 V_i c_i w_ij ε_ij, as for eq 27 (notes §1.6): the ∇s_i it
    /// depends on adds nothing, since Σ_j w_ij ε_ij X_ij = 0. The vector form (eq 21) is
    /// this on each component of u.
    pub fn scalar_hourglass(&self, s: &[f64]) -> (Exact, Vec<f64>) {
        let sup = &self.support;
        let mut force = vec![0.0; s.len()];
        let mut energy = Exact::default();
        for i in 0..self.len() {
            let c = self.hourglass[i];
            if c == 0.0 {
                continue;
            }
            let pairs = || sup.lists.pairs(i, &sup.g);
            let grad = pairs().fold(D::zero(), |acc, (j, &g)| acc + g * (s[j] - s[i]));
            for (j, &w) in sup.lists.pairs(i, &sup.w) {
                let eps = s[j] - s[i] - D::dot(grad, sup.x0[j] - sup.x0[i]);
                energy.add(sup.vol[i] * c * w * eps * eps);
                let t = 2.0 * sup.vol[i] * c * w * eps;
                force[i] += t;
                force[j] -= t;
            }
        }
        (energy, force)
    }

    /// 𝓕_i^hg of every particle (eq 21), for the frames.
    pub fn hourglass_densities(&self, u: &[D::V]) -> Vec<f64> {
        (0..self.len())
            .into_par_iter()
            .map(|i| self.hourglass_density(u, self.support.displacement_gradient(u, i), i))
            .collect()
    }

    /// The strain and hourglass energies of displacement u.
    pub fn energies(&self, u: &[D::V]) -> Energies {
        let s = &self.support;
        let [strain, hourglass] = par_sums(self.len(), |i| {
            if !self.counted[i] {
                return [0.0; 2];
            }
            let h = s.displacement_gradient(u, i);
            let psi = (self.material).energy_density::<D>(
                D::identity() + h,
                D::zero_t(),
                self.material.rho0,
            );
            [s.vol[i] * psi, s.vol[i] * self.hourglass_density(u, h, i)]
        });
        Energies { strain, hourglass }
    }

    /// The internal forces f_a = −∂E/∂u_a with E the strain energy plus, with
    /// `with_hourglass`, the hourglass energy. Per particle a, as a gather over its
    /// support and dual-support (eq 18; eq 28 with −T^hg):
    /// f_a = V_a P_a Σ_j g_aj − Σ_{i∈S'_a} V_i P_i g_ia
    ///     + 2 V_a c_a Σ_j w_aj e_aj − Σ_{i∈S'_a} 2 V_i c_i w_ia e_ia.
    /// Every pair term enters two particles with opposite signs: Σ_a f_a = 0.
    pub fn internal_force(&mut self, u: &[D::V], with_hourglass: bool) -> Vec<D::V> {
        let h = self.displacement_gradients(u);
        self.internal_force_at(u, &h, with_hourglass)
    }

    /// [`Self::internal_force`] with the displacement gradients h = F − I of u given.
    pub fn internal_force_at(&mut self, u: &[D::V], h: &[D::T], with_hourglass: bool) -> Vec<D::V> {
        // The hourglass term of every pair slot p = (i, j), once per slot: both particles
        // of the pair gather it.
        let mut hourglass = std::mem::take(&mut self.pair_terms);
        if with_hourglass {
            let Ok(()) = self.support.lists.fill_rows_into(&mut hourglass, |i, out| {
                self.hourglass_terms(u, h[i], i, out);
                Ok::<(), std::convert::Infallible>(())
            });
        }
        let f = self.gather_force(h, with_hourglass.then_some(&hourglass[..]));
        self.pair_terms = hourglass;
        f
    }

    /// The power against the hourglass control at velocities v, from the hourglass terms
    /// of the last [`Self::internal_force_at`] with them: −Σ_a f_a^hg·v_a = Σ over the pair
    /// slots (i, j) of T_ij·(v_j − v_i), each slot's term acting on i and, opposite, on j.
    pub fn hourglass_power(&self, v: &[D::V]) -> Exact {
        let s = &self.support;
        par_sum(self.len(), |i| {
            if !self.counted[i] {
                return 0.0;
            }
            (s.lists.pairs(i, &self.pair_terms))
                .map(|(j, &term)| D::dot(term, v[j] - v[i]))
                .sum::<f64>()
        })
    }

    /// f_a = −Σ V P ∇W over a's support and dual-support, plus the hourglass terms of its
    /// pair slots minus those of the slots that hold a (eq 18, eq 28).
    fn gather_force(&self, h: &[D::T], hourglass: Option<&[D::V]>) -> Vec<D::V> {
        let s = &self.support;
        let vp: Vec<D::T> = (0..self.len())
            .into_par_iter()
            .map(|i| self.material.pk1::<D>(D::identity() + h[i]) * s.vol[i])
            .collect();
        (0..self.len())
            .into_par_iter()
            .map(|a| {
                let mut f = -(vp[a] * s.g_self[a]);
                for (i, &slot) in s.dual.pairs(a, &s.dual_slot) {
                    f -= vp[i] * s.g[slot as usize];
                }
                if let Some(hourglass) = hourglass {
                    for term in &hourglass[s.lists.range(a)] {
                        f += *term;
                    }
                    for &slot in &s.dual_slot[s.dual.range(a)] {
                        f -= hourglass[slot as usize];
                    }
                }
                f
            })
            .collect()
    }

    /// What observers and frames read at displacement u and velocity v: F, σ, the strain
    /// energy Σ V ψ (with `stored_hourglass`, plus the hourglass energy: the whole energy
    /// the force derives from), and the hourglass energy density and smoothing length of
    /// every particle.
    pub fn snapshot<'a>(
        &'a self,
        u: Vec<D::V>,
        v: Vec<D::V>,
        mass: &'a [f64],
        body: &'a [u32],
        stored_hourglass: bool,
    ) -> Snapshot<'a, D> {
        let f = self.deformation_gradients(&u);
        let material = &self.material;
        let sigma = f
            .par_iter()
            .map(|&f| {
                let mut s = D::to3x3(material.pk1::<D>(f) * D::transpose(f) * (1.0 / D::det(f)));
                if D::N == 2 {
                    s[2][2] = material.sigma_zz::<D>(f, D::zero_t(), material.rho0);
                }
                s
            })
            .collect();
        let energies = self.energies(&u);
        let hourglass = self.hourglass_densities(&u);
        Snapshot {
            x0: &self.support.x0,
            mass,
            body,
            u,
            v,
            f,
            sigma,
            strain_energy: if stored_hourglass {
                energies.strain.merged(energies.hourglass)
            } else {
                energies.strain
            },
            extra: vec![
                ScalarField {
                    name: "hourglass_energy_density",
                    values: hourglass,
                },
                // The frames' smoothing length: this method's own, per particle.
                ScalarField {
                    name: "smoothing_length",
                    values: self.support.h.clone(),
                },
            ],
            cells: &[],
            quadrature: None,
        }
    }

    /// 𝔸_i = ∂P/∂F of every particle at displacement u.
    pub fn tangents(&self, u: &[D::V]) -> Vec<Tangent> {
        (0..self.len())
            .into_par_iter()
            .map(|i| {
                let f = D::identity() + self.support.displacement_gradient(u, i);
                self.material.tangent::<D>(f)
            })
            .collect()
    }

    /// The tangent K = ∂²E/∂u² into the values of `pattern` (d×d blocks, row-major), in
    /// two steps: the nodal matrices K_i (eq 41 and the hourglass blocks,
    /// [`Self::element_blocks`]) summed into the global pattern (global assembly). Each row
    /// of blocks is gathered by its own particle a from the elements holding it (a itself
    /// and S'_a), so every block of every K_i is computed once and no two threads write
    /// one value.
    pub fn stiffness(&self, tangents: &[Tangent], pattern: &BlockPattern, values: &mut [f64]) {
        let s = &self.support;
        let d = D::N;
        let bs = d * d;
        pattern
            .rows_mut(values, bs)
            .into_par_iter()
            .for_each(|(a, cols, row)| {
                row.iter_mut().for_each(|v| *v = 0.0);
                for (i, ka) in s.elements_of(a) {
                    let nodes = s.nodes(i).enumerate();
                    self.element_blocks(&tangents[i], i, ka, nodes, |node, k| {
                        let col = cols
                            .binary_search(&(node as u32))
                            .expect("the pattern holds every pair of an element");
                        let block = &mut row[col * bs..(col + 1) * bs];
                        for ap in 0..d {
                            for b in 0..d {
                                block[ap * d + b] += k[ap][b];
                            }
                        }
                    });
                }
            });
    }

    /// The diagonal of K: per particle a, the diagonal entries of its d×d block K_aa,
    /// the Jacobi preconditioner of a matrix-free solve.
    pub fn diagonal(&self, tangents: &[Tangent]) -> Vec<D::V> {
        let s = &self.support;
        (0..self.len())
            .into_par_iter()
            .map(|a| {
                let mut diag = [0.0; 3];
                for (i, ka) in s.elements_of(a) {
                    let own = std::iter::once((ka, a));
                    self.element_blocks(&tangents[i], i, ka, own, |_, k| {
                        for (c, v) in diag.iter_mut().enumerate().take(D::N) {
                            *v += k[c][c];
                        }
                    });
                }
                D::from_slice(&diag[..D::N])
            })
            .collect()
    }

    /// The blocks of row ka of element i's nodal matrix with the columns of its local
    /// nodes `nodes` (local index l, particle): V_i δF_kᵀ 𝔸_i δF_l (eq 41) plus the
    /// hourglass block 2 V_i c_i (C_kl − g_k·L_i g_l) I (eq 29 with its factor 2 restored;
    /// constant), each handed to `add` with its particle.
    fn element_blocks(
        &self,
        tan: &Tangent,
        i: usize,
        ka: usize,
        nodes: impl Iterator<Item = (usize, usize)>,
        mut add: impl FnMut(usize, [[f64; 3]; 3]),
    ) {
        let s = &self.support;
        let d = D::N;
        let comp = |v: D::V| -> [f64; 3] { D::to3(v) };
        let gk = comp(s.weight(i, ka));
        let vi = s.vol[i];
        // T[a'][b][C] = Σ_B 𝔸[a'B][bC] g_k,B.
        let mut t = [[[0.0; 3]; 3]; 3];
        for (ap, ta) in t.iter_mut().enumerate().take(d) {
            for (b, tb) in ta.iter_mut().enumerate().take(d) {
                for (c, tc) in tb.iter_mut().enumerate().take(d) {
                    *tc = (0..d)
                        .map(|bb| tan[3 * ap + bb][3 * b + c] * gk[bb])
                        .sum::<f64>()
                        * vi;
                }
            }
        }
        let hg = 2.0 * vi * self.hourglass[i];
        let lg = comp(s.l[i] * s.weight(i, ka));
        for (l, node) in nodes {
            let gl = comp(s.weight(i, l));
            let mut k = [[0.0; 3]; 3];
            for ap in 0..d {
                for b in 0..d {
                    k[ap][b] = (0..d).map(|c| t[ap][b][c] * gl[c]).sum::<f64>();
                }
            }
            if hg != 0.0 {
                let c_kl = laplacian(s, i, ka, l);
                let g_lg = (0..d).map(|c| lg[c] * gl[c]).sum::<f64>();
                for (ap, row) in k.iter_mut().enumerate().take(d) {
                    row[ap] += hg * (c_kl - g_lg);
                }
            }
            add(node, k);
        }
    }
}

/// C_kl of the hourglass energy of particle i (note §1.6 block form): with w_k the weight
/// of local node k ≥ 1, C_00 = Σ_k w_k, C_0k = C_k0 = −w_k, C_kk = w_k, zero elsewhere.
fn laplacian<D: Dim>(s: &Support<D>, i: usize, k: usize, l: usize) -> f64 {
    let off = s.lists.offsets[i];
    match (k, l) {
        (0, 0) => s.w[s.lists.range(i)].iter().sum(),
        (0, l) => -s.w[off + l - 1],
        (k, 0) => -s.w[off + k - 1],
        (k, l) if k == l => s.w[off + k - 1],
        _ => 0.0,
    }
}
