//! The Krongauz–Belytschko method on an Eulerian kernel (seed 001 §2.2, Table 2): the
//! kernel W(x − x_a, h0) of the current positions, so that the Shepard functions, M and
//! the corrected gradient G_a = M⁻¹∇W^S_a are recomputed at every rate evaluation on the
//! current configuration, with σ, current weights and L_q = Σ_a v_a ⊗ G_a(x_q) (the
//! updated-Lagrangian Galerkin system, [`crate::methods::cores::galerkin::updated`]). The lists
//! from the points to the particles are searched anew on the current configuration every
//! `search_every` steps (the paper's 30, §9.3), within the kernel's reach widened by
//! [`SKIN`]. The stress points move with the Shepard interpolant of the particles'
//! velocities; the particles are points at their own positions.

use super::KbmSpec;
use crate::case::{Case, CaseError};
use crate::core::kernel::{Kernel, neighbour_radius};
use crate::core::neighbour::{self, Csr, SKIN};
use crate::core::parallel::{load_field, load_word, save_field, whole_word};
use crate::core::quadrature::{QuadraturePoints, ShapeRow, krongauz_belytschko_shapes};
use crate::core::tensor::Dim;
use crate::engine::BlowUp;
use crate::methods::cores::galerkin::Mass;
use crate::methods::cores::galerkin::updated::{Degenerate, MovingPoints, Nodes, UlGalerkinState};
use crate::reference::Reference;

/// The points of the Eulerian-kernel KBM: the particles and (KBM (si)) the stress points,
/// with their lists to the particles from the last search.
pub struct EulerianPoints<D: Dim> {
    /// Reference positions and volumes w0_q of the points (the particles first).
    points: QuadraturePoints<D>,
    lists: Csr,
    /// The positions of the points at the last search (the particles first), from which
    /// a checkpoint's lists are searched again.
    searched: Vec<D::V>,
    kernel: Kernel,
    /// The reach of a search: the kernel support widened by the skin.
    reach: f64,
    search_every: u32,
    /// Steps begun since the last search.
    steps: u32,
    mass: Mass,
    /// Whether the material integrates ρ (rate model): w_q = w0_q ρ0/ρ_q; else
    /// w_q = w0_q det F_q.
    rate_model: bool,
    rho0: f64,
}

impl<D: Dim> EulerianPoints<D> {
    /// The points' reference positions and volumes (the particles first).
    pub fn points(&self) -> &QuadraturePoints<D> {
        &self.points
    }

    /// The kernel W(x − x_a, h0).
    pub fn kernel(&self) -> &Kernel {
        &self.kernel
    }

    /// The steps between two searches.
    pub fn search_every(&self) -> u32 {
        self.search_every
    }

    /// Takes `lists` as those of the last search (the device's, read back; the positions
    /// of that search, which the device's checkpoints hold, stay the host's).
    pub fn set_lists(&mut self, lists: Csr) {
        self.lists = lists;
    }

    /// The lists of a search from `at` (the points' positions, the particles first).
    fn search_at(&self, at: &[D::V]) -> Csr {
        self.search(at, &at[..self.points.particles])
    }

    /// The current position of point q, with the particles at x: its particle's, or
    /// X_q + u_q of a stress point.
    fn position(&self, q: usize, x: &[D::V], y: &UlGalerkinState<D>) -> D::V {
        if q < self.points.particles {
            x[q]
        } else {
            self.points.x0[q] + y.point_u[q]
        }
    }

    /// The particles of its body within the reach of every point at `at`, the particles
    /// at x.
    fn search(&self, at: &[D::V], x: &[D::V]) -> Csr {
        let particles = &self.points.body[..self.points.particles];
        neighbour::between::<D>(at, x, self.reach, Some((&self.points.body, particles)))
    }
}

/// The Krongauz–Belytschko functions at `centre` of the particles `list` at x into a
/// row: W^S_a, G_a and ∇W^S_a (eqs 27–32 on the current configuration).
fn kb_row<D: Dim>(
    centre: D::V,
    list: &[u32],
    x: &[D::V],
    kernel: &Kernel,
    row: &mut ShapeRow<D>,
) -> Result<(), Degenerate> {
    let shapes = krongauz_belytschko_shapes::<D>(centre, list, x, kernel).ok_or(Degenerate {
        quantity: "particles in the kernel support (too few, or all on one line, for M)",
        value: list.len() as f64,
    })?;
    for (p, (w, g, test)) in shapes.into_iter().enumerate() {
        row.n[p] = w;
        row.grad[p] = g;
        row.test[p] = test;
    }
    Ok(())
}

impl<D: Dim> MovingPoints<D> for EulerianPoints<D> {
    const OWN_MOTION: bool = true;
    const PETROV_GALERKIN: bool = true;

    /// The points of KBM (si) or (ni) on the reference configuration, and their first
    /// lists.
    type Spec = KbmSpec;

    fn build(case: &Case, spec: &KbmSpec, reference: &Reference<D>) -> Result<Self, CaseError> {
        let (_, points) = spec.points(case, reference)?;
        let kernel = reference.kernel;
        let mut eulerian = Self {
            lists: Csr::default(),
            searched: points.x0.clone(),
            points,
            reach: neighbour_radius(&kernel) * (1.0 + SKIN),
            kernel,
            search_every: spec.search_every(),
            steps: 0,
            mass: spec.mass,
            rate_model: reference.material.model.is_rate_based(),
            rho0: reference.material.rho0,
        };
        eulerian.lists = eulerian.search_at(&eulerian.searched);
        Ok(eulerian)
    }

    fn lists(&self) -> &Csr {
        &self.lists
    }

    fn reference_weights(&self) -> &[f64] {
        &self.points.weight
    }

    fn mass(&self) -> Mass {
        self.mass
    }

    /// The functions at the point's current position among its listed particles at
    /// theirs; w_q = w0_q ρ0/ρ_q (rate model) or w0_q det F_q with F_q = (Σ_a X_a ⊗
    /// G_a)⁻¹ (state model).
    /// Each point reads X_q, u_q and w0_q (and ρ_q), and writes ẋ_q, interpolated over
    /// the ids and N of every pair; the particles copy their v.
    fn shape_traffic(&self) -> [f64; 3] {
        let (v, f) = (size_of::<D::V>(), size_of::<f64>());
        let pair = size_of::<u32>() + f;
        [(3 * v + 2 * f) as f64, pair as f64, v as f64]
    }

    fn shapes_at(&self, q: usize, nodes: &Nodes<D>, row: ShapeRow<D>) -> Result<f64, Degenerate> {
        let y = nodes.y;
        let list = self.lists.neighbours(q);
        let centre = self.position(q, nodes.x, y);
        let mut row = row;
        kb_row::<D>(centre, list, nodes.x, &self.kernel, &mut row)?;
        if self.rate_model {
            return Ok(self.points.weight[q] * self.rho0 / y.rho[q]);
        }
        let inverse_f = list
            .iter()
            .zip(row.grad.iter())
            .fold(D::zero_t(), |m, (&a, &g)| {
                m + D::outer(nodes.x0[a as usize], g)
            });
        let det_f = 1.0 / D::det(inverse_f);
        if det_f.is_nan() || det_f <= 0.0 {
            return Err(Degenerate {
                quantity: "det F",
                value: det_f,
            });
        }
        Ok(self.points.weight[q] * det_f)
    }

    /// ẋ = v at the points that are particles, which move with their own velocity (the
    /// stress points with the core's ẋ_q = Σ_a W^S_a(x_q) v_a).
    fn own_rates(&mut self, nodes: &Nodes<D>, d: &mut UlGalerkinState<D>) -> Result<(), BlowUp> {
        let n = self.points.particles;
        d.point_u[..n].copy_from_slice(&nodes.y.v);
        Ok(())
    }

    /// Every `search_every` steps: the lists on the current configuration.
    fn relist(&mut self, x0: &[D::V], y: &UlGalerkinState<D>) -> Option<Csr> {
        self.steps += 1;
        if self.steps < self.search_every {
            return None;
        }
        self.steps = 0;
        let x: Vec<D::V> = x0.iter().zip(&y.u).map(|(&x0, &u)| x0 + u).collect();
        self.searched = (0..self.points.len())
            .map(|q| self.position(q, &x, y))
            .collect();
        self.lists = self.search_at(&self.searched);
        Some(self.lists.clone())
    }

    /// The steps since the last search and the points' positions then.
    fn save(&self, out: &mut Vec<f64>) {
        out.push(f64::from(self.steps));
        save_field(&self.searched, out);
    }

    /// The steps since the last search, and its lists searched again from the positions
    /// then.
    fn load(&mut self, words: &mut &[f64]) -> Result<Option<Csr>, String> {
        let steps = load_steps(words, self.search_every)?;
        let mut searched = vec![D::zero(); self.points.len()];
        let name = "the points' positions at the last search";
        load_field(&mut searched, name, words)?;
        if !searched.iter().all(|&x| D::is_finite_v(x)) {
            return Err(format!("{name} are not all finite"));
        }
        (self.steps, self.searched) = (steps, searched);
        self.lists = self.search_at(&self.searched);
        Ok(Some(self.lists.clone()))
    }
}

/// The steps since an Eulerian kernel's last search, from the front of a checkpoint's
/// words: a count below `search_every`.
pub fn load_steps(words: &mut &[f64], search_every: u32) -> Result<u32, String> {
    let name = "the steps since the Eulerian kernel's last search";
    whole_word(load_word(words, name)?)
        .and_then(|s| u32::try_from(s).ok())
        .filter(|&s| s < search_every)
        .ok_or_else(|| format!("{name} is not a count below search_every ({search_every})"))
}

impl KbmSpec {
    /// The steps between two neighbour searches of the Eulerian kernel.
    pub fn search_every(&self) -> u32 {
        self.search_every.unwrap_or(SEARCH_EVERY)
    }
}

/// The paper's steps between two neighbour searches of an Eulerian kernel (§9.3).
pub const SEARCH_EVERY: u32 = 30;
