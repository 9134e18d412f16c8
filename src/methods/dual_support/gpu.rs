//! The explicit dynamic variant of dual-support SPH on the GPU: the total-Lagrangian
//! engine of [`crate::methods::cores::tl::gpu`] with the elastic potential's force pass
//! ([`POTENTIAL`]), on lists and gradients built here on the host.
//!
//! With F_i = I + Σ_{j∈S_i} (u_j − u_i) ⊗ g_ij, the force −∂(Σ_i V_i ψ(F_i))/∂u of eq 18,
//! f_a = V_a P_a Σ_j g_aj − Σ_{i∈S'_a} V_i P_i g_ia, is the potential's pair form
//! f_a = Σ_j [V_a P_a g_aj − V_j P_j g_ja] over the union S_a ∪ S'_a, where g_aj = 0 for
//! j ∉ S_a: the union lists are symmetric, so every pair has its reverse. The hourglass
//! force (eq 28) and energy (eq 21) take the stiffness k_ij = 2 V_i c_i w_ij of both sides
//! of each pair. The CPU system ([`super::dynamics`]) is the reference it is checked
//! against.

use super::DualSupportSpec;
use super::model::DualSupport;
use crate::case::{Case, CaseError};
use crate::core::neighbour::Csr;
use crate::core::tensor::Dim;
use crate::diagnostics::observe::Snapshot;
use crate::gpu::layout::GpuDim;
use crate::gpu::shaders::{MECHANICS, PART, REFERENCE, Source, Wgsl, source, wgsl};
use crate::methods::cores::tl::TlState;
use crate::methods::cores::tl::gpu::{
    HostLists, HostModel, Lists, POTENTIAL, STRESS, TlScheme, potential,
};
use crate::reference::Reference;

/// The energy of the reduction: V_i ψ_i plus the hourglass energy of i's support.
const ENERGY: Wgsl = wgsl!("dual_support/dual_support_energy.wgsl");

/// Energies, momenta and checks of a state.
pub const REDUCE: Source = source!(
    "common/reduce.wgsl",
    [MECHANICS, ENERGY, REFERENCE, PART],
    [
        ("y", false),
        ("kin", false),
        ("reference", false),
        ("pair", false)
    ]
);

/// The passes of a dual-support scene: the dynamic variant's, and the static solve's
/// matrix-free conjugate gradients ([`super::krylov`]).
pub const SHADERS: &[Source] = &[
    STRESS,
    POTENTIAL,
    crate::gpu::shaders::INTEGRATE,
    crate::gpu::shaders::PAIR_OFFSETS,
    REDUCE,
    super::krylov::KRYLOV,
];

/// The scheme of the dynamic variant: the potential's consistent force with the
/// dual-support hourglass term, on the lists of [`lists`].
pub fn scheme<D: GpuDim>(spec: &DualSupportSpec) -> TlScheme<D> {
    let spec = spec.clone();
    let host = Lists::Host(Box::new(move |case, reference| {
        lists(case, &spec, reference).map(DeviceLists::into_host)
    }));
    potential(REDUCE, host, None, None, true)
}

impl<D: GpuDim> DeviceLists<D> {
    /// The engine's host lists: the supports and dual-supports S_i ∪ S'_i with each
    /// particle's own h, g_ij/V_j (zero where j ∉ S_i), the hourglass stiffnesses of
    /// both sides of every pair, and the model for the outputs.
    fn into_host(self) -> HostLists<D> {
        let hourglass = self.model.hourglass.iter().any(|&c| c != 0.0);
        HostLists {
            csr: self.csr,
            g: self.g,
            hgk: self.hgk,
            hgk_rev: self.hgk_rev,
            hourglass,
            model: Box::new(self.model),
        }
    }
}

impl<D: GpuDim> HostModel<D> for DualSupport<D> {
    /// The model's f64 outputs, the hourglass energy in the strain energy: the whole
    /// energy the dynamic force derives from.
    fn snapshot<'a>(&'a self, y: TlState<D>, r: &'a Reference<D>) -> Snapshot<'a, D> {
        DualSupport::snapshot(self, y.u, y.v, &r.mass, &r.body, true)
    }
}

/// An entry of the union list of particle i: (j, the slot of (i, j) in S_i, the slot of
/// (j, i) in S_j).
type Entry = (u32, Option<usize>, Option<usize>);

/// The device's lists and pair data, and the host model they come from.
pub struct DeviceLists<D: Dim> {
    /// S_i ∪ S'_i of every particle, ascending.
    pub csr: Csr,
    /// g_ij/V_j for j ∈ S_i, zero otherwise, in `csr` order.
    pub g: Vec<D::V>,
    /// k_ij = 2 V_i c_i w_ij (zero where j ∉ S_i) and k_ji of the reverse pair.
    pub hgk: Vec<f32>,
    pub hgk_rev: Vec<f32>,
    pub model: DualSupport<D>,
}

/// Smoothing lengths, supports and dual-supports of the reference configuration
/// `reference` of `case`, and the device's lists and pair data from them.
pub fn lists<D: Dim>(
    case: &Case,
    spec: &DualSupportSpec,
    reference: &Reference<D>,
) -> Result<DeviceLists<D>, CaseError> {
    let model = spec.model(case, reference)?;
    let s = &model.support;
    let n = s.len();
    let mut rows: Vec<Vec<Entry>> = vec![Vec::new(); n];
    for (i, row) in rows.iter_mut().enumerate() {
        for p in s.lists.range(i) {
            row.push((s.lists.ids[p], Some(p), None));
        }
        for q in s.dual.range(i) {
            let j = s.dual.ids[q];
            let back = Some(s.dual_slot[q] as usize);
            match row.iter_mut().find(|e| e.0 == j) {
                Some(e) => e.2 = back,
                None => row.push((j, None, back)),
            }
        }
        row.sort_unstable_by_key(|e| e.0);
    }
    let stiffness = |i: usize, p: usize| (2.0 * s.vol[i] * model.hourglass[i] * s.w[p]) as f32;
    let mut csr = Csr {
        offsets: vec![0],
        ids: Vec::new(),
    };
    let (mut g, mut hgk, mut hgk_rev) = (Vec::new(), Vec::new(), Vec::new());
    for (i, row) in rows.iter().enumerate() {
        for &(j, own, back) in row {
            csr.ids.push(j);
            g.push(own.map_or(D::zero(), |p| s.g[p] * (1.0 / s.vol[j as usize])));
            hgk.push(own.map_or(0.0, |p| stiffness(i, p)));
            hgk_rev.push(back.map_or(0.0, |p| stiffness(j as usize, p)));
        }
        csr.offsets.push(csr.ids.len());
    }
    Ok(DeviceLists {
        csr,
        g,
        hgk,
        hgk_rev,
        model,
    })
}
