//! Loads that vary in time: the tractions and body forces with a time law and the
//! pressures of a case ([`crate::boundary::timed_loads`]), each a group of per-particle
//! accelerations (g_a = f_a/m_a for a surface load, its forces carried to the nodes and
//! divided by the nodal masses as the method does it for the constant loads of
//! [`crate::boundary::Boundary`]) scaled by its law. The law is evaluated at the middle
//! of every step and held through the step's stages, as the contact forces are, on both
//! backends: on the GPU the host writes each step's law values as it records the step,
//! and the pass `shaders/interaction/loads.wgsl` adds Σ_g law_g g_g,i to `ext`.

use super::Interaction;
#[cfg(feature = "gpu")]
use super::gpu::{Bindings, GpuInteraction, Pass};
use crate::boundary::NodalForces;
use crate::case::{Case, CaseError, TimeLaw, discretise};
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
#[cfg(feature = "gpu")]
use crate::gpu::{GpuError, context::Gpu, shaders::Compose};

/// The time-dependent loads of a case, one group per boundary condition.
pub struct TimedLoads<D: Dim> {
    laws: Vec<TimeLaw>,
    /// Per group, the (particle, acceleration at law value 1) of every loaded particle.
    groups: Vec<Vec<(u32, D::V)>>,
    /// The law values of the current step.
    factors: Vec<f64>,
    /// The number of particles (the device's dense layout).
    #[cfg(feature = "gpu")]
    n: usize,
}

impl<D: Dim> TimedLoads<D> {
    /// The case's timed loads on particles of nodal masses `mass` (the method's: the
    /// forces do not depend on them, the accelerations do), their surface forces carried
    /// to the nodes by `nodal`, or None if it has none.
    pub fn build(
        case: &Case,
        nodal: &dyn NodalForces<D>,
        mass: &[f64],
    ) -> Result<Option<Self>, CaseError> {
        if !case.boundaries.iter().any(|b| b.condition.is_timed_load()) {
            return Ok(None);
        }
        let disc = discretise::<D>(case)?;
        let loads = crate::boundary::timed_loads::<D>(case, &disc, nodal, &mass[..disc.x0.len()])?;
        let laws: Vec<TimeLaw> = loads.iter().map(|l| l.law.clone()).collect();
        let groups = loads.into_iter().map(|l| l.accelerations).collect();
        Ok(Some(Self {
            factors: laws.iter().map(|law| law.at(0.0)).collect(),
            laws,
            groups,
            #[cfg(feature = "gpu")]
            n: disc.x0.len(),
        }))
    }
}

/// The laws' values for the step from t to t + dt: at its middle.
fn step_values(laws: &[TimeLaw], t: f64, dt: f64) -> impl Iterator<Item = f64> + '_ {
    laws.iter().map(move |law| law.at(t + 0.5 * dt))
}

impl<D: Dim> Interaction<D> for TimedLoads<D> {
    fn begin_step(&mut self, t: f64, dt: f64, _x: &[D::V], _v: &[D::V]) {
        self.factors = step_values(&self.laws, t, dt).collect();
    }

    fn accelerate(&self, v: &[D::V], mass: &[f64], a: &mut [D::V]) -> Exact {
        let mut power = Exact::default();
        for (group, &factor) in self.groups.iter().zip(&self.factors) {
            for &(i, g) in group {
                let (i, g) = (i as usize, g * factor);
                a[i] += g;
                power.add(mass[i] * D::dot(g, v[i]));
            }
        }
        power
    }

    #[cfg(feature = "gpu")]
    fn gpu_pass(&self) -> Option<&dyn super::gpu::GpuInteraction> {
        Some(self)
    }
}

#[cfg(feature = "gpu")]
impl<D: Dim> GpuInteraction for TimedLoads<D> {
    /// `shaders/interaction/loads.wgsl`: one invocation per particle adds the groups'
    /// accelerations (`loads`, group g's at g·N·DIM) times the step's law values (`law`,
    /// written by the host for every step it records).
    fn pass(&self, gpu: &Gpu, compose: Compose<'_>, on: &Bindings) -> Result<Pass, GpuError> {
        let mut dense = vec![D::zero(); self.n * self.groups.len()];
        for (g, group) in self.groups.iter().enumerate() {
            for &(i, a) in group {
                dense[g * self.n + i as usize] += a;
            }
        }
        let pipeline = gpu.pipeline(
            "timed loads",
            &compose(&crate::gpu::shaders::LOADS),
            "timed_loads",
        )?;
        let flat: Vec<f32> = dense
            .iter()
            .flat_map(|&a| D::to3(a).into_iter().take(D::N).map(|c| c as f32))
            .collect();
        let loads = gpu.storage("timed loads", &flat);
        let law = gpu.zeroed("law values", 4 * self.groups.len() as u64);
        let bind = gpu.bind(
            &pipeline,
            &[("loads", &loads), ("law", &law), ("ext", on.ext)],
        )?;
        Ok(super::gpu::Pass {
            pipeline,
            bind,
            params: None,
            step_values: Some(super::gpu::StepValues {
                target: law,
                values: Box::new({
                    let laws = self.laws.clone();
                    move |t, dt| step_values(&laws, t, dt).map(|v| v as f32).collect()
                }),
            }),
        })
    }
}
