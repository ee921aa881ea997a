//! Implicit time integration in matrix form: the internal force of a grid displacement and its
//! exact tangent ([`tangent`]), assembled from the operators Gx, Gy as `K = 𝔾ᵀ 𝔻 𝔾`.
//!
//! The tangent is the building block of Newmark integration on the grid, where the consistent
//! mass costs no stable step (docs/implicit.md).

pub mod tangent;

pub use tangent::{
    displacement_gradients, gradient_operator, internal_force, internal_force_and_tangent, particle_stress,
};
