//! Regions of a body: a material, an initial velocity or an initial stress of its own for the
//! body's particles inside a shape.
//!
//! ```toml
//! [[bodies]]
//! name = "slope"
//! material = { model = "drucker_prager", youngs_modulus = 1e7, poisson_ratio = 0.3, friction_angle = 30.0 }
//! density = 1800.0
//! initial_stress = "geostatic"
//! geometry = { rectangle = { min = [0.0, 0.0], max = [4.0, 1.0] } }
//!
//! [[bodies.regions]]             # a stiff layer at the base
//! geometry = { rectangle = { min = [0.0, 0.0], max = [4.0, 0.25] } }
//! material = { model = "linear_elastic", youngs_modulus = 1e9, poisson_ratio = 0.25, plane = "strain" }
//! ```
//!
//! A particle takes the values of the last region whose shape holds it, and the body's where a
//! region gives none. A region's `velocity` replaces the body's (a particle file's `vx`, `vy` are
//! still added); its `initial_stress` replaces the body's, with the depth measured from the
//! body's top. A region with a `material` is a body of its own in the solver (its particles'
//! `body` in the snapshots is numbered after the scene's bodies, in order), which shares the
//! body's velocity field: so a scene with `[contact]` refuses region materials.

use serde::{Deserialize, Serialize};

use super::{Geometry, InitialStress, Scene};
use crate::material::Material;

/// The most regions one body may have (every particle is tested against each).
pub const MAX_REGIONS: usize = 64;

/// A region of a body (`[[bodies.regions]]` of a scene, docs/simulation.md "Regions").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    /// Where the region is (not a particle file).
    pub geometry: Geometry,
    /// The region's material (default: the body's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<Material>,
    /// The region's initial velocity (default: the body's).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::pairs::optional_pair"
    )]
    pub velocity: Option<[f64; 2]>,
    /// The region's initial stress (default: the body's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_stress: Option<InitialStress>,
}

impl Scene {
    /// The scene's body of each of the solver's bodies ([`Scene::bodies`]).
    pub(super) fn region_owners(&self) -> Vec<usize> {
        let mut out: Vec<usize> = (0..self.bodies.len()).collect();
        for (k, b) in self.bodies.iter().enumerate() {
            out.extend(b.regions.iter().filter(|r| r.material.is_some()).map(|_| k));
        }
        out
    }

    /// The solver's body of each region of body `k` with a material of its own (`None` for a
    /// region that keeps the body's): numbered after the scene's bodies, in order.
    pub(super) fn region_bodies(&self, k: usize) -> Vec<Option<usize>> {
        let mut next = self.bodies.len()
            + self.bodies[..k]
                .iter()
                .map(|b| b.regions.iter().filter(|r| r.material.is_some()).count())
                .sum::<usize>();
        self.bodies[k]
            .regions
            .iter()
            .map(|r| {
                r.material.map(|_| {
                    next += 1;
                    next - 1
                })
            })
            .collect()
    }
}
