//! The reference configuration of a case: the particles and what every method reads of
//! them, built once on the host in f64 and held (or uploaded) by the method.

use crate::boundary::Boundary;
use crate::case::{Case, CaseError, discretise};
use crate::core::kernel::{Kernel, neighbour_radius};
use crate::core::neighbour::{self, Csr, Neighbours, Rebuild};
use crate::core::quadrature::{Cells, QuadratureError, lattice_cells};
use crate::core::sum::{OneRank, Ranks};
use crate::core::tensor::Dim;
use crate::distributed::Local;
use crate::physics::material::Material;
use std::sync::Arc;

/// A method's CPU system, built on the reference configuration of a case.
pub trait Build<D: Dim>: Sized {
    /// The typed spec of the methods the system runs (the method's keys besides the
    /// case's common ones).
    type Spec: ?Sized;

    /// Builds the system of `spec` on `reference`.
    fn build(case: &Case, spec: &Self::Spec, reference: Reference<D>) -> Result<Self, CaseError>;
}

/// Builds the CPU system `M` of a case's method `spec` on its reference configuration.
pub fn build_method<D: Dim, M: Build<D>>(case: &Case, spec: &M::Spec) -> Result<M, CaseError> {
    M::build(case, spec, Reference::build(case)?)
}

/// Particles of a case in the reference configuration.
pub struct Reference<D: Dim> {
    /// Reference positions X.
    pub x0: Vec<D::V>,
    /// Volumes V0.
    pub vol: Vec<f64>,
    /// Masses ρ0 V0.
    pub mass: Vec<f64>,
    /// Body index of every particle.
    pub body: Vec<u32>,
    /// Initial velocities, with the boundary conditions imposed.
    pub v0: Vec<D::V>,
    /// Initial displacements (zero unless a body sets `initial_displacement`).
    pub u0: Vec<D::V>,
    pub boundary: Boundary<D>,
    pub material: Material,
    /// The case's kernel, at h = h_over_dx · Δx.
    pub kernel: Kernel,
    /// The smoothing length of every particle (all the kernel's h until a case sets them
    /// per particle); the neighbour search reaches the support of the larger of a pair's.
    pub h: Vec<f64>,
    /// Whether `h` holds the method's own lengths of the whole run
    /// ([`MethodFamily::smoothing_lengths`](crate::methods::cores::family::MethodFamily::smoothing_lengths)),
    /// set before a distributed run's partition: a rank's share then takes them rather
    /// than apply the method's rule to its particles alone.
    pub method_lengths: bool,
    /// The cells the geometry generators make (polar rings, meshes read at their
    /// vertices); see [`Self::cells`].
    pub generated_cells: Cells,
    /// Whether the system books each particle's share of its sums (energies, powers,
    /// reactions): every particle, but a rank's ghosts in a distributed run.
    pub counted: Vec<bool>,
    /// The ranks that share the particles, for the sums a rate evaluation takes over all
    /// of them (one rank: [`OneRank`]).
    pub ranks: Arc<dyn Ranks>,
}

impl<D: Dim> Reference<D> {
    /// Samples the case's bodies and sets up masses, boundary conditions and initial
    /// velocities.
    pub fn build(case: &Case) -> Result<Self, CaseError> {
        let disc = discretise::<D>(case)?;
        no_coincident_particles::<D>(case, &disc.x0, &disc.body)?;
        let material = Material::new(&case.material);
        let mass: Vec<f64> = disc.vol.iter().map(|v| v * material.rho0).collect();
        let boundary = Boundary::build(case, &disc, &mass)?;
        let mut v0 = disc.v0;
        boundary.impose(&mut v0);
        let kernel = case.kernel(D::N);
        Ok(Self {
            h: vec![kernel.h; disc.x0.len()],
            method_lengths: false,
            counted: vec![true; disc.x0.len()],
            ranks: Arc::new(OneRank),
            generated_cells: disc.cells,
            x0: disc.x0,
            vol: disc.vol,
            mass,
            body: disc.body,
            v0,
            u0: disc.u0,
            boundary,
            material,
            kernel,
        })
    }

    /// The background cells of the bodies: the generators' (polar rings, meshes at their
    /// vertices), and the lattice squares (cubes) of spacing Δx of the others (a tube,
    /// whose particles are its cells' centres, is refused by the methods that integrate
    /// over cells).
    pub fn cells(&self, spacing: f64) -> Result<Cells, QuadratureError> {
        lattice_cells::<D>(&self.x0, &self.body, spacing, &self.generated_cells, &[])
    }

    /// The particles a rank holds in a distributed run (`local`: its own and its
    /// ghosts, in ascending global id): their rows of every array, the boundary
    /// conditions and loads of its own ([`Boundary::restrict`]), and only its own
    /// counted, its sums completed over `ranks`. The lists built on them keep each row's
    /// global order, and they are the global rows of every particle whose neighbours are
    /// all local.
    pub fn restrict(&self, local: &Local, ranks: Arc<dyn Ranks>) -> Self {
        fn rows<T: Copy>(all: &[T], ids: &[u32]) -> Vec<T> {
            ids.iter().map(|&g| all[g as usize]).collect()
        }
        let ids = &local.ids;
        Self {
            x0: rows(&self.x0, ids),
            vol: rows(&self.vol, ids),
            mass: rows(&self.mass, ids),
            body: rows(&self.body, ids),
            v0: rows(&self.v0, ids),
            u0: rows(&self.u0, ids),
            boundary: self.boundary.restrict(ids, &local.owned),
            material: self.material,
            kernel: self.kernel,
            h: rows(&self.h, ids),
            method_lengths: self.method_lengths,
            generated_cells: Cells::default(),
            counted: local.owned.clone(),
            ranks,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x0.is_empty()
    }

    /// Neighbour lists on the reference positions: the pairs within the kernel support
    /// of the larger smoothing length of the two.
    pub fn neighbours(&self) -> Csr {
        self.neighbour_lists(Rebuild::Once, false).into_lists()
    }

    /// The neighbour lists of a method that keeps them by the policy `rebuild`, built on
    /// the reference positions (pairs within the kernel support of the larger smoothing
    /// length of the two) and, with `per_body`, only of pairs of one body.
    pub fn neighbour_lists(&self, rebuild: Rebuild, per_body: bool) -> Neighbours {
        let reach: Vec<f64> = self
            .h
            .iter()
            .map(|&h| neighbour_radius(&Kernel::new(self.kernel.kind, h, D::N)))
            .collect();
        let body = per_body.then(|| self.body.clone());
        Neighbours::new::<D>(rebuild, &self.x0, reach, body)
    }
}

/// Refuses particles of one body closer than 1e-6 of the spacing to each other, and
/// particles of two bodies closer than half a spacing, naming both, their bodies and the
/// position. The first is a row repeated in a points file, which would double the mass
/// there (and collapse the CFL step); sampled lattices are a spacing apart, so the bound
/// leaves six decades of room. The second is two bodies laid over each other (offset
/// lattices, a ring inside a hole of another body): their particles would count each
/// other's mass and volume, while the lattices of bodies that touch along a face stay a
/// spacing apart.
fn no_coincident_particles<D: Dim>(
    case: &Case,
    x0: &[D::V],
    body: &[u32],
) -> Result<(), CaseError> {
    let name = |b: usize| &case.bodies[b].name;
    let at = |i: usize| D::to3(x0[i]);
    let one_body = |i: usize, j: usize| body[i] == body[j];
    if let Some((i, j)) = neighbour::first_pair::<D>(x0, 1e-6 * case.spacing, one_body) {
        let b = body[i] as usize;
        return Err(case.invalid(
            format!("body.{b}.geometry"),
            format!(
                "particles {i} and {j} of body `{}` coincide at {:?} (closer than 1e-6 of \
                 the spacing); remove the repeated point",
                name(b),
                at(i)
            ),
        ));
    }
    let two_bodies = |i: usize, j: usize| body[i] != body[j];
    if let Some((i, j)) = neighbour::first_pair::<D>(x0, 0.5 * case.spacing, two_bodies) {
        let (bi, bj) = (body[i] as usize, body[j as usize] as usize);
        return Err(case.invalid(
            format!("body.{}.geometry", bi.max(bj)),
            format!(
                "particle {i} of body `{}` and particle {j} of body `{}` are {:.3e} apart at \
                 {:?}, closer than half the spacing: the bodies overlap; move them apart \
                 or cut one out of the other",
                name(bi),
                name(bj),
                D::norm2(x0[i] - x0[j as usize]).sqrt(),
                at(i)
            ),
        ));
    }
    Ok(())
}
