//! Penalty contact between the bodies of a 2D scene (seed 000 §5.8, eqs 172–178).
//!
//! Every body is a master to every other. Its boundary is the convex hull of its
//! reference particles (collinear ones included), found once, ordered counter-clockwise;
//! at each hull particle p the
//! normal is the average of the outward unit normals of its two hull edges (eqs 172–176).
//! A slave particle s of another body, with c the closest hull particle of the master and
//! d = x_s − x_c, is in contact when d·n_c ≤ 0, and is then pushed back along n_c by
//! f_c = −α m_s (d·n_c) n_c / Δt² (eqs 177–178, α the penalty stiffness): the acceleration
//! that removes the fraction α of the penetration in one step. As in the seed's code the
//! forces are found from the positions at the start of a step and held through its
//! stages, so that their work over a step is the trapezoid of their powers at its start
//! and at its last rate evaluation. The master feels no reaction, so neither linear momentum nor energy is
//! conserved during contact: a slave pushed out by a master surface that moves towards it
//! gains energy, as a ball struck by a bat does.

use super::Interaction;
#[cfg(feature = "gpu")]
use super::gpu::{Bindings, GpuInteraction, Pass};
use crate::case::{Case, CaseError};
use crate::core::hull::{convex_hull, cross};
use crate::core::kernel::neighbour_radius;
use crate::core::neighbour::Csr;
use crate::core::sum::Exact;
use crate::core::tensor::Dim;
#[cfg(feature = "gpu")]
use crate::gpu::{GpuError, context::Gpu, shaders::Compose};
use rayon::prelude::*;

/// The hulls of a scene's bodies and the contact accelerations of the current step.
#[derive(Clone, Debug)]
pub struct Contact<D: Dim> {
    /// α of eq 178.
    penalty: f64,
    /// Body index of every particle.
    body: Vec<u32>,
    /// Hull particles of each body, counter-clockwise; empty for a body without area.
    hulls: Vec<Vec<u32>>,
    /// Mass m of every particle (the method's nodal mass).
    mass: Vec<f64>,
    /// a_c = f_c / m of every particle, held through the current step.
    accel: Vec<D::V>,
    /// Σ m a_c·v at the start of the current step.
    start_power: Exact,
}

impl<D: Dim> Contact<D> {
    /// Finds the hull of every body in the reference positions `x0`; `mass` is the
    /// particles' mass.
    pub fn new(penalty: f64, x0: &[D::V], body: &[u32], mass: &[f64]) -> Self {
        assert_eq!(D::N, 2, "contact finds hulls in 2D only");
        let bodies = body.iter().map(|&b| b as usize + 1).max().unwrap_or(0);
        let hulls = (0..bodies)
            .map(|b| {
                let members: Vec<u32> = (0..x0.len() as u32)
                    .filter(|&i| body[i as usize] as usize == b)
                    .collect();
                let at = |i: u32| plane::<D>(x0[i as usize]);
                let hull = convex_hull(&members, at);
                // A body whose hull encloses no area (fewer than three particles, or all on
                // a line) has no inside to enter and is no master.
                let doubled_area: f64 = (0..hull.len())
                    .map(|k| cross([0.0; 2], at(hull[k]), at(hull[(k + 1) % hull.len()])))
                    .sum();
                let extent2 = hull
                    .iter()
                    .map(|&i| dist2(at(i), at(hull[0])))
                    .fold(0.0, f64::max);
                if doubled_area > 1e-12 * extent2 {
                    hull
                } else {
                    Vec::new()
                }
            })
            .collect();
        Self {
            penalty,
            body: body.to_vec(),
            hulls,
            mass: mass.to_vec(),
            accel: vec![D::zero(); x0.len()],
            start_power: Exact::default(),
        }
    }

    /// The contact accelerations of a step of size dt from the positions x at its start.
    pub fn begin_step(&mut self, x: &[D::V], dt: f64) {
        let masters: Vec<Vec<([f64; 2], [f64; 2])>> = self
            .hulls
            .iter()
            .map(|hull| match hull.len() {
                0 => Vec::new(),
                _ => hull_normals(hull, |i| plane::<D>(x[i as usize])),
            })
            .collect();
        let scale = self.penalty / (dt * dt);
        let body = &self.body;
        self.accel.par_iter_mut().enumerate().for_each(|(s, a)| {
            let xs = plane::<D>(x[s]);
            let mut push = [0.0; 2];
            for (m, master) in masters.iter().enumerate() {
                if m == body[s] as usize || master.is_empty() {
                    continue;
                }
                let (xc, n) = *master
                    .iter()
                    .min_by(|(p, _), (q, _)| dist2(*p, xs).total_cmp(&dist2(*q, xs)))
                    .expect("non-empty hull");
                // eq 177: the penetration along n_c; eq 178: the push back.
                let d_n = (xs[0] - xc[0]) * n[0] + (xs[1] - xc[1]) * n[1];
                if d_n <= 0.0 {
                    push[0] -= scale * d_n * n[0];
                    push[1] -= scale * d_n * n[1];
                }
            }
            *a = D::from_slice(&push);
        });
    }

    /// Σ m a_c·v of the current step's forces at velocities v.
    fn power(&self, v: &[D::V], mass: &[f64]) -> Exact {
        (0..self.accel.len())
            .map(|i| mass[i] * D::dot(self.accel[i], v[i]))
            .sum()
    }

    /// a_c = f_c / m of every particle for the current step.
    pub fn accelerations(&self) -> &[D::V] {
        &self.accel
    }

    /// Hull particles of each body, counter-clockwise.
    pub fn hulls(&self) -> &[Vec<u32>] {
        &self.hulls
    }
}

impl<D: Dim> Interaction<D> for Contact<D> {
    fn begin_step(&mut self, _t: f64, dt: f64, x: &[D::V], v: &[D::V]) {
        Contact::begin_step(self, x, dt);
        self.start_power = self.power(v, &self.mass);
    }

    fn accelerate(&self, v: &[D::V], mass: &[f64], a: &mut [D::V]) -> Exact {
        for (a, &a_c) in a.iter_mut().zip(&self.accel) {
            *a += a_c;
        }
        self.power(v, mass)
    }

    fn contact(&self) -> bool {
        true
    }

    fn start_power(&self) -> Option<Exact> {
        Some(self.start_power.clone())
    }

    #[cfg(feature = "gpu")]
    fn gpu_pass(&self) -> Option<&dyn super::gpu::GpuInteraction> {
        Some(self)
    }
}

/// The uniform `ContactParams` of `contact.wgsl`: α/Δt².
#[cfg(feature = "gpu")]
#[derive(Clone, Copy, Debug, encase::ShaderType)]
struct ContactParams {
    scale: f32,
}

#[cfg(feature = "gpu")]
impl<D: Dim> GpuInteraction for Contact<D> {
    /// `shaders/interaction/contact.wgsl`: one invocation per slave over the other bodies'
    /// hulls (concatenated, body m's at hull_start[m]..hull_start[m + 1]), with α/Δt² in
    /// its uniform.
    fn pass(&self, gpu: &Gpu, compose: Compose<'_>, on: &Bindings) -> Result<Pass, GpuError> {
        let mut hull_start = vec![0u32];
        let mut hull = Vec::new();
        for h in &self.hulls {
            hull.extend_from_slice(h);
            hull_start.push(hull.len() as u32);
        }
        let pipeline = gpu.pipeline(
            "contact",
            &compose(&crate::gpu::shaders::CONTACT),
            "contact",
        )?;
        let params = gpu.uniform("contact params", &ContactParams { scale: 0.0 });
        let (body, hull, hull_start) = (
            gpu.storage("body", &self.body),
            gpu.storage("hull", &hull),
            gpu.storage("hull start", &hull_start),
        );
        let bind = gpu.bind(
            &pipeline,
            &[
                ("params", &params),
                ("reference", on.reference),
                ("y", on.y),
                ("body", &body),
                ("hull", &hull),
                ("hull_start", &hull_start),
                ("ext", on.ext),
            ],
        )?;
        let penalty = self.penalty;
        Ok(super::gpu::Pass {
            pipeline,
            bind,
            params: Some((
                params,
                Box::new(move |dt| {
                    let scale = (penalty / (dt * dt)) as f32;
                    crate::gpu::context::uniform_bytes(&ContactParams { scale })
                }),
            )),
            step_values: None,
        })
    }
}

/// Contact needs bodies that no kernel spans in the reference configuration: a
/// total-Lagrangian kernel between two bodies would bond them for the whole run.
pub(super) fn apart<D: Dim>(case: &Case, csr: &Csr, body: &[u32]) -> Result<(), CaseError> {
    let bonded = (0..csr.len()).find_map(|i| {
        csr.neighbours(i)
            .iter()
            .find(|&&j| body[j as usize] != body[i])
            .map(|&j| (i, j as usize))
    });
    match bonded {
        None => Ok(()),
        Some((i, j)) => {
            let name = |k: usize| &case.bodies[body[k] as usize].name;
            Err(case.invalid(
                "contact",
                format!(
                    "particle {i} of body `{}` and particle {j} of body `{}` lie within the \
                     kernel support ({:e} m) of each other in the reference configuration, so \
                     the kernels would bond the bodies; move them apart by more than the support",
                    name(i),
                    name(j),
                    neighbour_radius(&case.kernel(D::N))
                ),
            ))
        }
    }
}

/// The in-plane coordinates of a 2D vector.
fn plane<D: Dim>(x: D::V) -> [f64; 2] {
    let p = D::to3(x);
    [p[0], p[1]]
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Current position and normal n_p = ½(n_left + n_right) of every hull particle (eqs
/// 172–176): the outward unit normals of the edges to the previous and the next one.
fn hull_normals(hull: &[u32], at: impl Fn(u32) -> [f64; 2]) -> Vec<([f64; 2], [f64; 2])> {
    let k = hull.len();
    let unit = |v: [f64; 2]| {
        let l = v[0].hypot(v[1]);
        [v[0] / l, v[1] / l]
    };
    (0..k)
        .map(|p| {
            let x = at(hull[p]);
            let (prev, next) = (at(hull[(p + k - 1) % k]), at(hull[(p + 1) % k]));
            let tl = [prev[0] - x[0], prev[1] - x[1]];
            let tr = [next[0] - x[0], next[1] - x[1]];
            let (nl, nr) = (unit([-tl[1], tl[0]]), unit([tr[1], -tr[0]]));
            (x, [0.5 * (nl[0] + nr[0]), 0.5 * (nl[1] + nr[1])])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tensor::D2;
    use glam::DVec2;

    #[cfg(feature = "gpu")]
    crate::gpu::context::wgsl_twin_test!(contact_params_match_wgsl: ContactParams = "ContactParams" in crate::gpu::shaders::CONTACT.text);

    /// A master square [0, 1]² sampled on a 5 × 5 lattice (body 0) and slave particles,
    /// each a body of its own (bodies 1, 2, …), which has no area and so is no master.
    fn square_and(slaves: &[DVec2]) -> (Vec<DVec2>, Vec<u32>) {
        let mut x: Vec<DVec2> = (0..25)
            .map(|k| DVec2::new(f64::from(k % 5), f64::from(k / 5)) * 0.25)
            .collect();
        let mut body = vec![0; 25];
        x.extend_from_slice(slaves);
        body.extend((1..=slaves.len() as u32).collect::<Vec<_>>());
        (x, body)
    }

    #[test]
    fn the_hull_of_a_lattice_square_is_its_boundary_counter_clockwise() {
        let (x, body) = square_and(&[DVec2::new(2.0, 2.0)]);
        let contact = Contact::<D2>::new(0.1, &x, &body, &vec![1.0; x.len()]);
        // The 16 boundary particles from (0, 0) along the bottom, up the right side,
        // back along the top and down the left side; the 9 interior ones are not on it.
        let boundary = vec![0, 1, 2, 3, 4, 9, 14, 19, 24, 23, 22, 21, 20, 15, 10, 5];
        assert_eq!(contact.hulls()[0], boundary);
        // A one-particle body, and a row of particles, enclose no area: no hull.
        assert!(contact.hulls()[1].is_empty());
        let row: Vec<DVec2> = (0..4).map(|k| DVec2::new(f64::from(k), 3.0)).collect();
        let mut x = x;
        x.extend_from_slice(&row);
        let mut body = body;
        body.extend([2; 4]);
        assert!(Contact::<D2>::new(0.1, &x, &body, &vec![1.0; x.len()]).hulls()[2].is_empty());
    }

    #[test]
    fn a_penetrating_particle_is_pushed_back_as_eq_178_says() {
        // Slave a at (0.9, 0.95) inside the square: its closest hull particle is the
        // corner (1, 1) with n = ½((0, 1) + (1, 0)) (eq 176), d = (−0.1, −0.05), d·n =
        // −0.075, so a_c = −α (d·n) n / Δt² = α 0.0375 (1, 1) / Δt². Slave b at (1.2, 1.1)
        // lies outside (d·n > 0): no force. Slave c at (0.4, 1.1) lies above the top face,
        // whose particle (0.5, 1) is its closest, with n = (0, 1): no force (a corner's
        // averaged normal would push it). The master feels none either. Round-off: 1e-12
        // relative.
        let (alpha, dt) = (0.1, 1e-3);
        let (x, body) = square_and(&[
            DVec2::new(0.9, 0.95),
            DVec2::new(1.2, 1.1),
            DVec2::new(0.4, 1.1),
        ]);
        let mut contact = Contact::<D2>::new(alpha, &x, &body, &vec![1.0; x.len()]);
        contact.begin_step(&x, dt);
        let a = contact.accelerations();
        let expected = DVec2::splat(alpha * 0.0375 / (dt * dt));
        assert!(
            (a[25] - expected).length() < 1e-12 * expected.length(),
            "a_c = {} against {expected}",
            a[25]
        );
        assert_eq!(a[26], DVec2::ZERO);
        assert_eq!(a[27], DVec2::ZERO);
        // The one-particle bodies have no area: the square's particles are not pushed.
        assert!(a[..25].iter().all(|&a| a == DVec2::ZERO));
    }
}
