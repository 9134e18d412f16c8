//! The Krongauz–Belytschko method of Rabczuk, Belytschko and Xiao (seed 001, "EFG–KBM"):
//! a Petrov–Galerkin particle method on a Lagrangian kernel, with Shepard functions W^S_a
//! as test functions and the corrected gradient G_a = M⁻¹ ∇0W^S_a (eqs 27–32) as trial
//! gradient, F_q = I + Σ_a u_a ⊗ G_a(X_q) and f_a = Σ_q V_q ∇0W^S_a(X_q)·P_q (eq 64, spec
//! §7.4). Its points are the particles (nodal integration, "KBM (ni)") and, by default, a
//! stress point at the centre of every lattice cell ("KBM (si)", §5.2), weighted by the
//! Voronoi diagram of both (eq 65); or the particles with the test gradients smoothed over
//! their cells and the trial gradients corrected from those (stabilised conforming nodal
//! integration, Chen, Wu, Yoon and You 2001). Everything is built once on the reference
//! configuration (§2.2). It runs on the shared Galerkin system
//! ([`crate::methods::cores::galerkin`]). `kernel_frame = "eulerian"` selects the same method on
//! an Eulerian kernel ([`eulerian`], updated-Lagrangian; on the GPU [`gpu`]). Numerics
//! notes: `docs/methods/seed001.md`.

pub mod eulerian;
#[cfg(feature = "gpu")]
pub mod gpu;

use super::cores::galerkin::updated::{self, UlGalerkin};
use super::cores::galerkin::{Mass, TlGalerkin, TlSystem, particle_mass, smoothing_cells, tl_plan};
use crate::case::{Case, CaseError};
use crate::core::check::{Problem, fail};
use crate::core::quadrature::{Cells, QuadraturePoints, Shapes};
use crate::core::tensor::Dim;
use crate::engine::ranks::RankStart;
use crate::engine::{CpuEngine, EngineDim};
#[cfg(feature = "gpu")]
use crate::methods::cores::family::GpuBuild;
use crate::methods::cores::family::{CpuBuild, Feature, MethodFamily, Plan, RankBuild, cfl_step};
use crate::physics::material::Material;
use crate::reference::Reference;
use eulerian::EulerianPoints;
use serde::{Deserialize, Serialize};

/// Where the Krongauz–Belytschko method integrates (`method.integration`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Integration {
    /// At the particles and a stress point at the centre of every lattice cell, weighted
    /// by their joint Voronoi cells: KBM (si).
    #[default]
    StressPoints,
    /// At the particles, weighted by their volumes: KBM (ni).
    Nodal,
    /// At the particles, weighted by the areas of their cells, with the test gradients
    /// smoothed over the cells and the trial gradients corrected from them: stabilised
    /// conforming nodal integration.
    Scni,
}

/// The `[method]` keys of the Krongauz–Belytschko method.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct KbmSpec {
    /// `stress-points` (the default, the paper's KBM (si)), `nodal` (KBM (ni)) or `scni`
    /// (stabilised conforming nodal integration).
    #[serde(default)]
    pub integration: Integration,
    /// The nodal masses (default `particle`, ρ0 V of each particle: the Voronoi masses of
    /// eq 70 on a lattice of tributary volumes, `geometry.volumes = "tributary"`).
    #[serde(default = "particle_mass")]
    pub mass: Mass,
    /// The configuration of the kernel (default `lagrangian`).
    #[serde(default)]
    pub kernel_frame: KernelFrame,
    /// Steps between two neighbour searches of the Eulerian kernel (default
    /// [`eulerian::SEARCH_EVERY`]).
    #[serde(default)]
    pub search_every: Option<u32>,
}

/// Where the kernel lives (seed 001 §2.2).
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum KernelFrame {
    /// W(X − X_a, h0) on the reference configuration (eq 17): neighbours and functions
    /// built once, total-Lagrangian.
    #[default]
    Lagrangian,
    /// W(x − x_a, h0) on the current configuration (eq 16): functions recomputed at every
    /// rate evaluation, neighbours searched every `search_every` steps, updated-Lagrangian.
    Eulerian,
}

impl Default for KbmSpec {
    fn default() -> Self {
        Self {
            integration: Integration::StressPoints,
            mass: Mass::Particle,
            kernel_frame: KernelFrame::Lagrangian,
            search_every: None,
        }
    }
}

impl KbmSpec {
    /// The cells (stress points only) and the points of KBM (si) and (ni): the particles,
    /// then with stress points one at the centre of every cell, weighted by their joint
    /// Voronoi cells.
    pub fn points<D: Dim>(
        &self,
        case: &Case,
        reference: &Reference<D>,
    ) -> Result<(Cells, QuadraturePoints<D>), CaseError> {
        Ok(if self.integration == Integration::StressPoints {
            let cells = reference
                .cells(case.spacing)
                .map_err(|e| case.invalid("method.integration", e.to_string()))?;
            let points =
                QuadraturePoints::with_stress_points(&cells, &reference.x0, &reference.body);
            (cells, points)
        } else {
            let points =
                QuadraturePoints::at_particles(&reference.x0, &reference.vol, &reference.body);
            (Cells::default(), points)
        })
    }
}

impl<D: Dim> TlSystem<D> for KbmSpec {
    /// The Galerkin system with the Krongauz–Belytschko functions at the particles and,
    /// with stress points, at the cell centres; or with SCNI their smoothed gradients at
    /// the particles.
    fn system(&self, case: &Case, reference: Reference<D>) -> Result<TlGalerkin<D>, CaseError> {
        let (x0, body, kernel) = (&reference.x0, &reference.body, &reference.kernel);
        let (cells, points, shapes) = if self.integration == Integration::Scni {
            let smoothing = smoothing_cells(case, &reference, "method.integration")?;
            let points = QuadraturePoints::at_particles(x0, &smoothing.volumes::<D>(), body);
            let shapes = Shapes::smoothed_krongauz_belytschko(&smoothing, x0, body, kernel);
            (Cells::default(), points, shapes)
        } else {
            let (cells, points) = self.points(case, &reference)?;
            let shapes = Shapes::krongauz_belytschko(&points.x0, &points.body, x0, body, kernel);
            (cells, points, shapes)
        };
        let shapes = shapes.map_err(|e| case.invalid("method.h_over_dx", e.to_string()))?;
        TlGalerkin::new(case, reference, cells, points, shapes, self.mass, None)
    }
}

impl MethodFamily for KbmSpec {
    const DESCRIPTION: &'static str = "Krongauz–Belytschko Petrov–Galerkin method (seed \
        001, EFG–KBM): Lagrangian kernel, Shepard test functions, corrected trial gradient, \
        integration at the particles and at stress points in the cell centres, or at the \
        particles alone (unstabilised or SCNI)";
    const KEYS: &'static [&'static str] = &["integration", "mass", "kernel_frame", "search_every"];
    const FEATURES: &'static [Feature] = super::cores::galerkin::FEATURES;
    const CORRECTED: bool = false;
    const HALO_LAYERS: Option<usize> = Some(1);
    #[cfg(feature = "gpu")]
    const SHADERS: &'static [crate::gpu::shaders::Source] = gpu::SHADERS;

    fn validate(&self, case: &Case) -> Result<(), Problem> {
        if self.kernel_frame == KernelFrame::Eulerian && self.integration == Integration::Scni {
            return fail(
                "method.integration",
                "\"scni\" takes the Lagrangian kernel only (its smoothing cells are built \
                 once on the reference configuration): use integration = \"stress-points\" \
                 or \"nodal\" with kernel_frame = \"eulerian\", or remove kernel_frame",
            );
        }
        if self.kernel_frame == KernelFrame::Eulerian && case.solves_by_newton() {
            return fail(
                "method.kernel_frame",
                "the static and implicit solves (run.solve = \"static\" or \"implicit\") take \
                 the Lagrangian kernel only: remove kernel_frame = \"eulerian\" or the solve",
            );
        }
        match (self.kernel_frame, self.search_every) {
            (KernelFrame::Lagrangian, Some(_)) => fail(
                "method.search_every",
                "is read with kernel_frame = \"eulerian\" only (a Lagrangian kernel's \
                 neighbours are found once): remove it or set kernel_frame",
            ),
            (KernelFrame::Eulerian, Some(0)) => fail(
                "method.search_every",
                "must be at least 1 (steps between two neighbour searches), got 0",
            ),
            _ => Ok(()),
        }
    }

    fn plan(&self, case: &Case, gpu: bool) -> Plan {
        if self.kernel_frame == KernelFrame::Eulerian {
            return self.eulerian_plan(case, gpu);
        }
        let (points, gradients) = match self.integration {
            Integration::StressPoints => (
                "the particles and a stress point at every lattice-cell centre, weighted by \
                 their joint Voronoi cells",
                "the Shepard functions W^S_a and ∇0W^S_a there",
            ),
            Integration::Nodal => (
                "the particles, weighted by their volumes",
                "the Shepard functions W^S_a and ∇0W^S_a there",
            ),
            Integration::Scni => (
                "the particles, weighted by the areas (volumes) A_L of their Δx cells \
                 clipped to the body's box",
                "the Shepard functions W^S_a there and their gradients smoothed over the \
                 cells (SCNI: ∇̃W^S_a = (1/A_L) Σ_g W^S_a(Y_g) n_g w_g over 2 Gauss points \
                 per cell edge, 2×2 per face in 3D), in M and G_a in place of ∇0W^S_a",
            ),
        };
        let once = format!(
            "once, on the reference configuration: the points ({points}), the particles \
             within the kernel support of every point (and of its cell's boundary), \
             {gradients}, M = Σ_a ∇0W^S_a ⊗ (X_a − X_q) and G_a = M⁻¹ ∇0W^S_a, and the \
             node-to-point gather lists"
        );
        let rates = if gpu {
            "points pass (F_q = I + Σ_a u_a ⊗ G_a, P_q, w_q ψ_q, ρ̇_q, Ṡ_q) + nodes pass \
             (−Σ_q w_q P_q ∇0W^S_a(X_q) gathered per particle, BCs)"
        } else {
            "F_q = I + Σ_a u_a ⊗ G_a (and Ḟ_q) and P_q at every point, then each particle \
             gathers −Σ_q w_q P_q ∇0W^S_a(X_q)"
        };
        let mut left_out = Vec::new();
        if self.integration == Integration::Nodal {
            left_out.push("stress points (nodal integration only: KBM (ni))");
        }
        tl_plan(case, once, rates.into(), "det F at the points", left_out)
    }

    fn cpu_engine<D: EngineDim>(&self, case: &Case) -> CpuBuild<D> {
        match self.kernel_frame {
            KernelFrame::Lagrangian => super::cores::galerkin::cpu_engine(case, self),
            KernelFrame::Eulerian => Ok(Box::new(
                CpuEngine::<D, UlGalerkin<D, EulerianPoints<D>>>::new(case, self)?,
            )),
        }
    }

    /// On a Lagrangian kernel; the Eulerian kernel's (updated-Lagrangian) does not run on
    /// several ranks.
    fn rank_engine<D: EngineDim>(
        &self,
        case: &Case,
        reference: Reference<D>,
        start: RankStart<D>,
    ) -> RankBuild<D> {
        match self.kernel_frame {
            KernelFrame::Lagrangian => {
                super::cores::galerkin::rank_engine(case, self, reference, start)
            }
            KernelFrame::Eulerian => Err(case.invalid(
                "method.kernel_frame",
                "`kbm` on an Eulerian kernel (updated-Lagrangian) does not run on several \
                 ranks yet; run it on one, or with `kernel_frame = \"lagrangian\"`",
            )),
        }
    }

    #[cfg(feature = "gpu")]
    fn gpu_engine<D: EngineDim>(&self, case: &Case, gpu: crate::gpu::Gpu) -> GpuBuild<D> {
        match self.kernel_frame {
            KernelFrame::Lagrangian => super::cores::galerkin::gpu_engine(case, self, gpu),
            KernelFrame::Eulerian => Ok(Box::new(gpu::GpuEulerianKbm::<D>::new(case, self, gpu)?)),
        }
    }

    #[cfg(feature = "gpu")]
    fn device_memory<D: EngineDim>(
        &self,
        case: &Case,
        counts: &crate::gpu::memory::Counts,
    ) -> Option<crate::gpu::memory::DeviceMemory> {
        use crate::methods::cores::galerkin::gpu::{Frame, GpuGalerkin, Points};
        let points = match self.integration {
            Integration::StressPoints => Points::stress_points(counts),
            Integration::Nodal | Integration::Scni => Points::nodal(counts),
        };
        Some(match self.kernel_frame {
            KernelFrame::Lagrangian => {
                GpuGalerkin::<D>::memory(case, counts, &points, Frame::Reference)
            }
            KernelFrame::Eulerian => gpu::GpuEulerianKbm::<D>::memory(case, counts, &points),
        })
    }

    fn searches_current_configuration(&self) -> bool {
        self.kernel_frame == KernelFrame::Eulerian
    }

    fn warning(&self, case: &Case) -> Option<String> {
        let nodal = (self.integration == Integration::Nodal).then_some(
            "method.integration = \"nodal\" integrates at the particles without \
             stabilisation: the stripes even about every particle are zero-energy modes \
             (docs/methods/seed001.md), and static bending gives deflections of the wrong \
             sign or several times too large; use integration = \"scni\" (stabilised \
             conforming nodal integration) or \"stress-points\" (the default)",
        );
        let dynamic = (!case.is_static()).then_some(
            "kbm's Petrov–Galerkin force is not the gradient of an energy, and in a free \
             bending vibration a mode grows: a plate released in its first mode \
             (cases/cantilever-mode.toml, period about 1 s) blows up at 0.37 s at Δx = \
             0.02 m and at 1.2 s at 0.04 m, with RK4 or leapfrog, at cfl 0.3 or 0.1, with \
             stress points or SCNI (docs/verification.md); for vibrations longer than a \
             fraction of a period use efg or tl-fem",
        );
        let both: Vec<&str> = nodal.into_iter().chain(dynamic).collect();
        (!both.is_empty()).then(|| both.join("; also, "))
    }

    fn lattice_cells(&self) -> bool {
        self.integration == Integration::StressPoints
    }
}

impl KbmSpec {
    /// The run plan of the Eulerian kernel.
    fn eulerian_plan(&self, case: &Case, gpu: bool) -> Plan {
        let mat = Material::new(&case.material);
        let points = if self.integration == Integration::StressPoints {
            "the particles and a stress point at every cell centre (moving with the Shepard \
             interpolant of the velocities)"
        } else {
            "the particles"
        };
        let mut left_out = Vec::new();
        if self.integration == Integration::Nodal {
            left_out.push("stress points (nodal integration only: KBM (ni))");
        }
        Plan {
            once: format!(
                "once, on the reference configuration: the points ({points}) and their \
                 reference weights"
            ),
            state: updated::state(&mat, "the points") + "; the stress points' displacements",
            cfl_step: cfl_step(&mat),
            rates: format!(
                "on the current configuration: W^S_a, ∇W^S_a, M and G_a = M⁻¹∇W^S_a at every \
                 point among the particles of its list (searched within 2h·(1 + skin) every \
                 {} steps{}), L_q = Σ_a v_a ⊗ G_a and σ_q, then each particle gathers \
                 −Σ_q w_q σ_q ∇W^S_a(x_q){}",
                self.search_every(),
                if gpu {
                    ", on the device: one cell-list search of every point, particles and \
                     stress points"
                } else {
                    ""
                },
                if gpu {
                    " over the points of its own list (points pass + nodes pass)"
                } else {
                    ""
                }
            ),
            checked: "det F (or ρ) at the points, and M at every point,",
            check_note: String::new(),
            left_out,
        }
    }
}
