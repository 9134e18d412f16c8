//! The stress points of Algorithm 7 and the particles' own functions: candidate lists
//! fixed at set-up, covariance-ellipse neighbourhoods and reproducing-kernel functions
//! recomputed on the current configuration.

use crate::case::{Case, CaseError};
use crate::core::correction;
use crate::core::kernel::{Kernel, KernelKind};
use crate::core::neighbour::{self, Csr};
use crate::core::neighbourhood::Ellipse;
use crate::core::parallel::MIN_CHUNK;
use crate::core::quadrature::{QuadraturePoints, Rule, ShapeRow, Shapes};
use crate::core::tensor::Dim;
use crate::engine::BlowUp;
use crate::methods::cores::galerkin::Mass;
use crate::methods::cores::galerkin::updated::{Degenerate, MovingPoints, Nodes, UlGalerkinState};
use crate::reference::Reference;
use rayon::prelude::*;

/// The half-width of the candidate box in spacings: 2·h_c with h_c = 1.5 Δx (the
/// reference code's `neighbor_ellipse`).
pub const CANDIDATE_BOX: f64 = crate::case::BOX_HALF;

/// The stress points (one per lattice cell, at its centre) and the particles' candidate
/// lists and own functions.
pub struct StressPoints<D: Dim> {
    /// Reference positions X_q and volumes w0_q = Δx^d of the stress points.
    points: QuadraturePoints<D>,
    /// From every stress point to the particles of its body within the candidate box.
    candidates: Csr,
    /// The particles' own functions N_j(x_i) on their candidate lists (itself included),
    /// of the last evaluation.
    particle_shapes: Shapes<D>,
    smoothing: bool,
    rho0: f64,
}

/// For every point y_q (of body `at_body[q]`), the particles x_j of its body with
/// |y_q,k − x_j,k| ≤ `half` in every direction k, in ascending order (a particle at the
/// point itself included).
pub fn box_candidates<D: Dim>(
    at: &[D::V],
    at_body: &[u32],
    x: &[D::V],
    body: &[u32],
    half: f64,
) -> Csr {
    let half = half * (1.0 + 1e-6);
    let corner = half * (D::N as f64).sqrt();
    let within = neighbour::between::<D>(at, x, corner, Some((at_body, body)));
    let mut csr = Csr {
        offsets: vec![0],
        ids: Vec::with_capacity(within.pair_count()),
    };
    for (q, &y) in at.iter().enumerate() {
        let inside = |&&j: &&u32| {
            let d = D::to3(y - x[j as usize]);
            d.iter().all(|c| c.abs() <= half)
        };
        csr.ids.extend(within.neighbours(q).iter().filter(inside));
        csr.offsets.push(csr.ids.len());
    }
    csr
}

/// The functions at a point at `centre` of the candidates `candidates` (positions x,
/// volumes `vol(j)`): the ellipse neighbourhood and h (§1.5), then the reproducing-kernel
/// functions with a linear basis (§1.4) of the neighbours with the cubic spline of that
/// h, N_j = V_j Ψ_j(centre) and ∇N_j into the candidates' slots (zero outside the
/// ellipse).
pub fn ellipse_shapes<D: Dim>(
    centre: D::V,
    candidates: &[u32],
    x: &[D::V],
    vol: impl Fn(usize) -> f64,
    n: &mut [f64],
    grad: &mut [D::V],
) -> Result<(), Degenerate> {
    // The offsets x_q − x_j wait in the gradients' slots, and the volumes V_j in the
    // functions' slots (zero outside the ellipse, where a node adds nothing), until the
    // functions replace them.
    for (r, &j) in grad.iter_mut().zip(candidates) {
        *r = centre - x[j as usize];
    }
    let ellipse = Ellipse::<D>::new(grad).ok_or(Degenerate {
        quantity: "candidates spanning no ellipse (all on one line)",
        value: candidates.len() as f64,
    })?;
    for ((v, &r), &j) in n.iter_mut().zip(grad.iter()).zip(candidates) {
        *v = if ellipse.contains(r) {
            vol(j as usize)
        } else {
            0.0
        };
    }
    let kernel = Kernel::new(KernelKind::CubicSpline, ellipse.h, D::N);
    let kept = || {
        grad.iter()
            .zip(n.iter())
            .filter(|&(_, &v)| v != 0.0)
            .map(|(&r, &v)| (r, v))
    };
    let rkpm = correction::Rkpm::<D>::at(kept(), &kernel).ok_or_else(|| Degenerate {
        quantity: "particles in the ellipse (too few or on one line for RKPM)",
        value: kept().count() as f64,
    })?;
    for (n, g) in n.iter_mut().zip(grad.iter_mut()) {
        (*n, *g) = if *n != 0.0 {
            let (psi, grad_psi) = rkpm.shape(*g, &kernel);
            (*n * psi, grad_psi * *n)
        } else {
            (0.0, D::zero())
        };
    }
    Ok(())
}

impl<D: Dim> StressPoints<D> {
    /// The particles' own functions at the positions `nodes.x` with volumes m/ρ (ρ of the
    /// nodes' state).
    fn update_particle_shapes(&mut self, nodes: &Nodes<D>) -> Result<(), (usize, Degenerate)> {
        let node_rho = &nodes.y.node_rho;
        let vol = |j: usize| nodes.mass[j] / node_rho[j];
        self.particle_shapes
            .recompute(&mut [], |i, candidates, row| {
                ellipse_shapes::<D>(nodes.x[i], candidates, nodes.x, vol, row.n, row.grad)
                    .map(|()| 0.0)
            })
    }

    /// The stress points' reference positions and volumes.
    pub fn points(&self) -> &QuadraturePoints<D> {
        &self.points
    }

    /// The particles' own functions of the last evaluation.
    pub fn particle_functions(&self) -> &Shapes<D> {
        &self.particle_shapes
    }
}

impl<D: Dim> MovingPoints<D> for StressPoints<D> {
    const OWN_MOTION: bool = true;
    const NODE_DENSITY: bool = true;

    /// One stress point per lattice cell at its centre (Rule::Centre, w0 = Δx^d), and the
    /// candidate lists of the stress points and particles on the reference positions.
    type Spec = super::UlWeakFormSpec;

    fn build(
        case: &Case,
        spec: &super::UlWeakFormSpec,
        reference: &Reference<D>,
    ) -> Result<Self, CaseError> {
        let (x0, body) = (&reference.x0, &reference.body);
        let cells = reference
            .cells(case.spacing)
            .map_err(|e| case.invalid("body", e.to_string()))?;
        let points = QuadraturePoints::new(&cells, x0, Rule::Centre);
        let half = CANDIDATE_BOX * case.spacing;
        let candidates = box_candidates::<D>(&points.x0, &points.body, x0, body, half);
        let own = box_candidates::<D>(x0, body, x0, body, half);
        let pairs = own.pair_count();
        Ok(Self {
            points,
            candidates,
            particle_shapes: Shapes {
                csr: own,
                n: vec![0.0; pairs],
                grad: vec![D::zero(); pairs],
                test: Vec::new(),
                family: None,
            },
            smoothing: spec.smoothing,
            rho0: reference.material.rho0,
        })
    }

    fn lists(&self) -> &Csr {
        &self.candidates
    }

    fn reference_weights(&self) -> &[f64] {
        &self.points.weight
    }

    /// The particle masses ρ0 V_j (eq 163), which with ρ_j give the volumes V_j = m_j/ρ_j.
    fn mass(&self) -> Mass {
        Mass::Particle
    }

    /// Steps 1–3 at stress point q: its ellipse and h among its candidates at their
    /// current positions, the reproducing-kernel functions with V_j = m_j/ρ_j, and
    /// w_q = V_q = m_q/ρ_q (the Riemann weight of the one point per cell).
    /// Each point reads X_q, u_q, w0_q and ρ_q and writes ẋ_q, interpolated over the ids
    /// and N of every pair; the particles' own functions are recomputed (x, m, ρ read,
    /// their ids read and N, ∇N written per own pair) and give ρ̇ (v, ρ read, ρ̇ written,
    /// the ids and ∇N of every own pair read), own pairs counted per particle.
    fn shape_traffic(&self) -> [f64; 3] {
        let (v, f, id) = (size_of::<D::V>(), size_of::<f64>(), size_of::<u32>());
        let own = &self.particle_shapes;
        let own_pairs = own.csr.pair_count() as f64 / own.len().max(1) as f64;
        let per_node = (v + 2 * f) + (v + 2 * f);
        [
            (3 * v + 2 * f) as f64,
            (id + f) as f64,
            per_node as f64 + own_pairs * (2 * id + f + 2 * v) as f64,
        ]
    }

    fn shapes_at(&self, q: usize, nodes: &Nodes<D>, row: ShapeRow<D>) -> Result<f64, Degenerate> {
        let y = nodes.y;
        let centre = self.points.x0[q] + y.point_u[q];
        let vol = |j: usize| nodes.mass[j] / y.node_rho[j];
        let candidates = self.candidates.neighbours(q);
        ellipse_shapes::<D>(centre, candidates, nodes.x, vol, row.n, row.grad)?;
        Ok(self.points.weight[q] * self.rho0 / y.rho[q])
    }

    /// ρ̇_i = −ρ_i tr L_i with L_i = Σ_j (v_j − v_i) ⊗ ∇N_j(x_i) (steps 6 and 9); the
    /// stress points' motion ẋ_q = Σ_j N_j(x_q) v_j (eq 169, step 11) is the core's.
    fn own_rates(&mut self, nodes: &Nodes<D>, d: &mut UlGalerkinState<D>) -> Result<(), BlowUp> {
        let y = nodes.y;
        self.update_particle_shapes(nodes).map_err(|(i, e)| {
            let what = format!("{} at the particle", e.quantity);
            BlowUp::at::<D>(nodes.x0, i, &what, e.value)
        })?;
        let own = &self.particle_shapes;
        d.node_rho
            .par_iter_mut()
            .with_min_len(MIN_CHUNK)
            .enumerate()
            .for_each(|(i, rho_dot)| {
                let div_v = own.csr.range(i).fold(0.0, |s, p| {
                    s + D::dot(y.v[own.csr.ids[p] as usize] - y.v[i], own.grad[p])
                });
                *rho_dot = -y.node_rho[i] * div_v;
            });
        Ok(())
    }

    /// The particles' own functions at the step's end, for the velocity smoothing.
    fn smoothing(&mut self, nodes: &Nodes<D>) -> Option<&Shapes<D>> {
        if !self.smoothing {
            return None;
        }
        self.update_particle_shapes(nodes).ok()?;
        Some(&self.particle_shapes)
    }
}
