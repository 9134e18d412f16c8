//! The physics that the methods share: the constitutive models (hypo- and
//! hyperelastic, Mooney–Rivlin, von Mises plasticity), Monaghan's artificial
//! viscosity, the pressure-oscillation and hourglass indicators and the mirror
//! planes. It builds on [`crate::core`] only.

pub mod hourglass;
pub mod material;
pub mod mirror;
pub mod mooney_rivlin;
pub mod plasticity;
pub mod pressure;
pub mod viscosity;
