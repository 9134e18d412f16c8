//! The updated-Lagrangian finite-element reference of seed 000 (§5, "UL FEM"): 4-node
//! quadrilaterals (8-node hexahedra in 3D) on the lattice cells of the bodies, 2×2 (2×2×2)
//! Gauss points whose positions, gradients ∇N_a = J⁻ᵀ ∂N_a/∂ξ and weights w_q = det J
//! follow the current node positions at every rate evaluation, a lumped mass, explicit, on
//! the shared updated-Lagrangian Galerkin system ([`crate::methods::cores::galerkin::updated`]).
//! CPU only. Numerics notes: `docs/methods/galerkin.md`.

use super::cores::galerkin::Mass;
use super::cores::galerkin::updated::{self, Degenerate, MovingPoints, Nodes, UlGalerkin};
use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::quadrature::{
    Cells, QuadraturePoints, Rule, ShapeRow, Shapes, isoparametric_shapes,
};
use crate::core::tensor::Dim;
use crate::engine::{CpuEngine, EngineDim};
use crate::methods::cores::family::{CpuBuild, Feature, MethodFamily, Plan, cfl_step};
use crate::physics::material::Material;
use crate::reference::Reference;
use serde::{Deserialize, Serialize};

/// The `[method]` keys of the updated-Lagrangian FEM.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct UlFemSpec {
    /// The nodal masses (default `row-sum`).
    #[serde(default)]
    pub mass: Mass,
}

/// The elements: the lattice cells with their Gauss points.
pub struct Elements<D: Dim> {
    cells: Cells,
    points: QuadraturePoints<D>,
    /// Every point's cell corners, in VTK order.
    lists: Csr,
    mass: Mass,
}

/// The Gauss rule of the elements.
const RULE: Rule = Rule::Gauss2;

impl<D: Dim> MovingPoints<D> for Elements<D> {
    const OWN_MOTION: bool = false;

    type Spec = UlFemSpec;

    fn build(case: &Case, spec: &UlFemSpec, reference: &Reference<D>) -> Result<Self, CaseError> {
        let cells = reference
            .cells(case.spacing)
            .map_err(|e| case.invalid("body", e.to_string()))?;
        let points = QuadraturePoints::new(&cells, &reference.x0, RULE);
        let lists = Shapes::isoparametric(&cells, &points, &reference.x0).csr;
        Ok(Self {
            cells,
            points,
            lists,
            mass: spec.mass,
        })
    }

    fn lists(&self) -> &Csr {
        &self.lists
    }

    /// The elements.
    fn cells(&self) -> &[u32] {
        &self.cells.corners
    }

    fn reference_weights(&self) -> &[f64] {
        &self.points.weight
    }

    fn mass(&self) -> Mass {
        self.mass
    }

    /// Each point reads its cell and which parent point of the rule it is (the rule's
    /// tabulated functions stay in cache).
    fn shape_traffic(&self) -> [f64; 3] {
        let per_point = size_of::<u32>() + size_of::<u8>();
        [per_point as f64, 0.0, 0.0]
    }

    /// The bilinear (trilinear) functions of the point's cell with its corners at their
    /// current positions, from the rule's tabulated N_a and ∂N_a/∂ξ: w_q = det J (UL FEM
    /// step 1); an inverted cell (det J ≤ 0) degenerates.
    fn shapes_at(&self, q: usize, nodes: &Nodes<D>, row: ShapeRow<D>) -> Result<f64, Degenerate> {
        let corners = self.cells.of::<D>(self.points.cell[q] as usize);
        let parent = &self.points.rule[self.points.parent[q] as usize];
        let det = isoparametric_shapes::<D>(corners, nodes.x, parent, row.n, row.grad);
        if det.is_nan() || det <= 0.0 {
            return Err(Degenerate {
                quantity: "det J (an inverted element)",
                value: det,
            });
        }
        Ok(RULE.weight::<D>() * det)
    }
}

impl MethodFamily for UlFemSpec {
    const DESCRIPTION: &'static str = "updated-Lagrangian finite elements (seed 000's UL FEM \
        reference): bilinear quadrilaterals (trilinear hexahedra) on the lattice cells, 2^d \
        Gauss points recomputed on the current configuration, lumped mass, explicit; CPU only";
    const KEYS: &'static [&'static str] = &["mass"];
    const FEATURES: &'static [Feature] = &[Feature::Contact];
    const GPU_ENGINE: bool = false;
    const KERNEL: bool = false;
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = &[];

    fn plan(&self, case: &Case, _gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        Plan {
            once: format!(
                "once, on the reference configuration: the lattice cells of every body as \
                 elements, 2^d Gauss points each, the node-to-point gather lists, {} nodal \
                 masses; runs on the CPU only (no GPU engine)",
                self.mass.name()
            ),
            state: updated::state(&mat, "the Gauss points"),
            cfl_step: cfl_step(&mat),
            rates: format!(
                "on the CPU: x = X + u; at every Gauss point of the current cells N_a, \
                 ∇N_a = J⁻ᵀ ∂N_a/∂ξ and w_q = det J, then {}; each node gathers \
                 −Σ_q w_q σ_q ∇N_a(x_q)",
                point_rates(&mat)
            ),
            checked: "det J (an inverted element) and ρ at the Gauss points",
            check_note: String::new(),
            left_out: vec!["kernels and neighbour lists (the cells are the mesh)"],
        }
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        Ok(Box::new(CpuEngine::<D, UlGalerkin<D, Elements<D>>>::new(
            case, self,
        )?))
    }

    fn lattice_cells(&self) -> bool {
        true
    }
}

/// What a point computes in one rate evaluation, for `--explain`.
pub(crate) fn point_rates(mat: &Material) -> &'static str {
    if mat.model.is_rate_based() {
        "L_q = Σ_a v_a ⊗ ∇N_a, ρ̇_q = −ρ_q tr L_q, the objective Ṡ_q and σ_q = S_q − p I"
    } else {
        "F_q = (Σ_a X_a ⊗ ∇N_a)⁻¹ and σ_q = P(F_q) F_qᵀ / det F_q"
    }
}
