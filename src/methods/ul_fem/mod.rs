//! The updated-Lagrangian finite-element reference of seed 000 (§5, "UL FEM"): 4-node
//! quadrilaterals (8-node hexahedra in 3D) on the lattice cells of the bodies, 2×2 (2×2×2)
//! Gauss points whose positions, gradients ∇N_a = J⁻ᵀ ∂N_a/∂ξ and weights w_q = det J
//! follow the current node positions at every rate evaluation, a lumped mass, explicit, on
//! the shared updated-Lagrangian Galerkin system ([`crate::methods::cores::galerkin::updated`])
//! on the CPU, and on the GPU on the Galerkin passes evaluating the elements of `tl-fem`
//! on the current cells ([`Frame::Current`]). Numerics notes: `docs/methods/galerkin.md`.

use super::cores::galerkin::Mass;
#[cfg(feature = "gpu")]
use super::cores::galerkin::gpu::{Frame, GpuGalerkin};
use super::cores::galerkin::updated::{self, Degenerate, MovingPoints, Nodes, UlGalerkin};
#[cfg(feature = "gpu")]
use super::fem::FemSpec;
use super::fem::RULE;
use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::quadrature::{Cells, QuadraturePoints, ShapeRow, Shapes, isoparametric_shapes};
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
        Gauss points recomputed on the current configuration, lumped mass, explicit";
    const KEYS: &'static [&'static str] = &["mass"];
    const FEATURES: &'static [Feature] = &[Feature::Contact];
    const KERNEL: bool = false;
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = super::cores::galerkin::gpu::SHADERS;

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let rates = if gpu {
            format!(
                "points pass (at every Gauss point J = Σ_a x_a ⊗ ∂N_a/∂ξ of the current \
                 cell, ∇N_a = J⁻ᵀ ∂N_a/∂ξ and w_q = det J, then {}; w_q σ_q J⁻ᵀ) + nodes \
                 pass (−Σ_q w_q σ_q ∇N_a(x_q) gathered per node, BCs)",
                point_rates(&mat)
            )
        } else {
            format!(
                "x = X + u; at every Gauss point of the current cells N_a, ∇N_a = J⁻ᵀ \
                 ∂N_a/∂ξ and w_q = det J, then {}; each node gathers −Σ_q w_q σ_q \
                 ∇N_a(x_q)",
                point_rates(&mat)
            )
        };
        Plan {
            once: format!(
                "once, on the reference configuration: the lattice cells of every body as \
                 elements, 2^d Gauss points each, the node-to-point gather lists, {} nodal \
                 masses",
                self.mass.name()
            ),
            state: updated::state(&mat, "the Gauss points"),
            cfl_step: cfl_step(&mat),
            rates,
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

    /// The Galerkin passes on `tl-fem`'s elements (the same cells, Gauss points and
    /// masses) evaluated on the current cells; the host's outputs are those of the same
    /// discrete method (`docs/methods/galerkin.md`).
    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(
        &self,
        case: &Case,
        gpu: crate::gpu::Gpu,
    ) -> crate::methods::cores::family::GpuBuild<D> {
        let elements = FemSpec { mass: self.mass };
        let frame = Frame::Current(RULE);
        Ok(Box::new(GpuGalerkin::<D>::in_frame(
            case, &elements, frame, gpu,
        )?))
    }

    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        Some(super::fem::element_memory::<D>(
            case,
            counts,
            Frame::Current(RULE),
        ))
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
