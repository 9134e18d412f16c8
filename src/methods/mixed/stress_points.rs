//! The secondary cloud of SUPG-SPH (seed 003 §1, ref. [27]): stress points at the 2^d
//! Gauss points of the lattice cells between the particles, with the cell's
//! isoparametric (bilinear, trilinear) functions of its corners there, and the lists that
//! gather the points' terms back to the particles.
//!
//! The cell's own functions, not the kernel's: a reproducing kernel spans 2.6Δx and
//! interpolates a checkerboard or a stripe of alternate particles to almost nothing at
//! any point, so the residuals there would not see the modes the particles' sums miss
//! (measured on a J checkerboard and a velocity stripe, 10⁻² and 10⁻³ of the cell
//! functions' damping; docs/methods/mixed.md "SUPG-SPH").
//!
//! Mirror planes: the points are those of the whole (mirrored) body on the body's side of
//! every plane, in the cells of the lattice of the real particles and their ghosts. A
//! cell across a plane is symmetric about it and no Gauss point lies on it; every point
//! of the whole body beyond a plane is the image M(s) of a point s kept here, and reaches
//! a real particle a through the ghost M(a) among the corners of s's cell, since
//! G_a(X_M(s)) = R G_M(a)(X_s).

use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::quadrature::{Cells, QuadraturePoints, Rule, Shapes, lattice_cells};
use crate::core::tensor::Dim;
use crate::physics::mirror::{Ghosts, Image};

/// A stress point's share of a real particle's gather: the point, the pair of the point's
/// row that is the particle (or its ghost), and the image the point's terms pass through
/// (None: the point itself).
#[derive(Clone, Copy, Debug)]
pub struct Share {
    pub point: u32,
    pub pair: u32,
    pub image: Option<Image>,
}

/// Stress points with weights V_s (the reference volume each carries), the functions
/// N_b(X_s) and G_b(X_s) of their cell's corners b (real particles and ghosts, in
/// `shapes.csr` order), and per real particle the [`Share`]s that reach it.
pub struct StressPoints<D: Dim> {
    pub weight: Vec<f64>,
    pub shapes: Shapes<D>,
    /// Row a: the shares of real particle a.
    pub gather: Vec<Vec<Share>>,
}

impl<D: Dim> StressPoints<D> {
    /// The Gauss points of the cells of the particles x0 (real, then `ghosts`; bodies
    /// `body`) on the body's side of every mirror plane: the cells the generators made of
    /// the real particles (`generated`: polar rings, meshes), and the lattice cells of the
    /// other bodies. Their functions are exact for linear fields: Σ_b N_b = 1, Σ_b N_b X_b
    /// = X_s, Σ_b G_b = 0, Σ_b X_b ⊗ G_b = I.
    pub fn build(
        case: &Case,
        x0: &[D::V],
        body: &[u32],
        ghosts: &Ghosts<D>,
        generated: &Cells,
    ) -> Result<Self, CaseError> {
        if !(ghosts.is_empty() || generated.is_empty()) {
            return Err(case.invalid(
                "mirror",
                "`supg-sph` finds the stress points across a mirror plane in the lattice \
                 cells of the particles and their images, and a body whose generator makes its \
                 own cells (a polar ring, a mesh) has none there; remove the [[mirror]] planes \
                 and model the whole body, or use `upwind-sph` or `jst-sph`",
            ));
        }
        let tubes = crate::case::tube_frames(case);
        let cells = lattice_cells::<D>(x0, body, case.spacing, generated, &tubes).map_err(|e| {
            case.invalid(
                "method.name",
                format!(
                    "`supg-sph` puts its stress points in the lattice cells between the \
                     particles: {e}; or use `upwind-sph` or `jst-sph`"
                ),
            )
        })?;
        let all = QuadraturePoints::<D>::new(&cells, x0, Rule::Gauss2);
        let keep: Vec<u32> = (0..all.len() as u32)
            .filter(|&q| ghosts.depths(all.x0[q as usize]).all(|d| d > 0.0))
            .collect();
        let points = all.restrict(&keep);
        let shapes = Shapes::isoparametric(&cells, &points, x0);
        let gather = gather_lists(&shapes.csr, ghosts);
        Ok(Self {
            weight: points.weight,
            shapes,
            gather,
        })
    }

    pub fn len(&self) -> usize {
        self.weight.len()
    }

    pub fn is_empty(&self) -> bool {
        self.weight.is_empty()
    }
}

/// Per real particle a, the shares of the points whose rows hold a or a ghost of a.
fn gather_lists<D: Dim>(csr: &Csr, ghosts: &Ghosts<D>) -> Vec<Vec<Share>> {
    let mut gather = vec![Vec::new(); ghosts.real()];
    for s in 0..csr.len() {
        for q in csr.range(s) {
            let (a, image) = ghosts.origin(csr.ids[q] as usize);
            gather[a].push(Share {
                point: s as u32,
                pair: q as u32,
                image,
            });
        }
    }
    gather
}
