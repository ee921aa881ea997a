//! `[contact]` of a scene: contact between its bodies by name ([`crate::contact`]), turned into
//! the library's [`Contact`](crate::contact::Contact) and checked key by key.

use serde::{Deserialize, Serialize};

use super::{invalid, Scene};
use crate::error::{MpmError, Result};

/// `[contact]`: contact between the bodies ([`crate::contact`]), by body name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Coulomb's coefficient between every pair of bodies (0, the default: frictionless).
    #[serde(default)]
    pub friction: f64,
    /// Pairs with their own coefficient: `[[contact.pairs]] bodies = ["a", "b"], friction = μ`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pairs: Vec<PairSpec>,
    /// Bodies of prescribed motion: each moves at its `velocity` throughout (a ramp, a floor, an
    /// indenter).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rigid: Vec<String>,
    /// Nodes where a body's share of a pair's mass is below this are not corrected.
    #[serde(default = "default_min_mass_fraction")]
    pub min_mass_fraction: f64,
    /// The separation test ([`crate::contact::Separation`]): `"kernel"` (the default), a cutoff
    /// in cells, or `"off"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub separation: Option<SeparationSpec>,
    /// The stabilisation of each body's own consistent mass (`"partial_lumping"` by default;
    /// [`crate::contact::Contact::stabilization`]), as `schemes.mass.stabilization` is written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stabilization: Option<crate::mass::Stabilization>,
}

/// `[contact] separation`: `"kernel"`, `"off"`, or a cutoff in cells.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SeparationSpec {
    /// `"kernel"` or `"off"`.
    Named(String),
    /// A cutoff in cells.
    Cutoff(f64),
}

fn default_min_mass_fraction() -> f64 {
    crate::contact::DEFAULT_MIN_MASS_FRACTION
}

/// One of `[[contact.pairs]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairSpec {
    /// The two bodies' names.
    pub bodies: [String; 2],
    /// Their friction coefficient (`[contact] friction` when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// Their contact normal: `"average"` (the default), the name of one of the two (that body's
    /// own surface), or a direction `[nx, ny]` from the first toward the second
    /// ([`crate::contact::Normal`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<NormalSpec>,
}

/// `[[contact.pairs]] normal`: a name (`"average"` or a body's) or a direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum NormalSpec {
    /// `"average"`, or the name of one of the pair's bodies.
    Named(String),
    /// A direction from the first body toward the second.
    Direction([f64; 2]),
}

impl Scene {
    /// The index of the body named `name` (one past the last when there is none, which
    /// [`Contact::validate`](crate::contact::Contact::validate) refuses).
    fn body_index(&self, name: &str) -> usize {
        self.bodies
            .iter()
            .position(|b| b.name == name)
            .unwrap_or(self.bodies.len())
    }

    /// The library's contact options of `[contact]`: names to indices, rigid bodies at their
    /// initial velocities.
    pub(super) fn contact_options(&self, c: &ContactSpec) -> crate::contact::Contact {
        crate::contact::Contact {
            friction: c.friction,
            pairs: c
                .pairs
                .iter()
                .map(|p| crate::contact::Pair {
                    bodies: [self.body_index(&p.bodies[0]), self.body_index(&p.bodies[1])],
                    friction: p.friction.unwrap_or(c.friction),
                    normal: match &p.normal {
                        None => crate::contact::Normal::Average,
                        Some(NormalSpec::Named(n)) if n == "average" => crate::contact::Normal::Average,
                        Some(NormalSpec::Named(n)) => crate::contact::Normal::Body(self.body_index(n)),
                        Some(NormalSpec::Direction(d)) => crate::contact::Normal::Direction(*d),
                    },
                })
                .collect(),
            rigid: c
                .rigid
                .iter()
                .map(|name| {
                    let body = self.body_index(name);
                    let velocity = self.bodies.get(body).map_or([0.0; 2], |b| b.velocity);
                    crate::contact::RigidBody { body, velocity }
                })
                .collect(),
            min_mass_fraction: c.min_mass_fraction,
            separation: match &c.separation {
                Some(SeparationSpec::Named(n)) if n == "off" => crate::contact::Separation::Off,
                Some(SeparationSpec::Cutoff(v)) => crate::contact::Separation::Cutoff(*v),
                _ => crate::contact::Separation::Kernel,
            },
            stabilization: c.stabilization.unwrap_or(crate::contact::DEFAULT_STABILIZATION),
        }
    }

    /// `[contact]`'s body names, each naming a body of the scene, and its coefficients.
    pub(super) fn validate_contact(&self) -> Result<()> {
        let Some(c) = &self.contact else {
            return Ok(());
        };
        let known = |key: String, name: &str| {
            if self.bodies.iter().any(|b| b.name == name) {
                Ok(())
            } else {
                let names: Vec<&str> = self.bodies.iter().map(|b| b.name.as_str()).collect();
                Err(invalid(
                    key,
                    format!("no body is named {name:?} (the bodies: {names:?})"),
                ))
            }
        };
        for (k, pair) in c.pairs.iter().enumerate() {
            for (j, name) in pair.bodies.iter().enumerate() {
                known(format!("contact.pairs[{k}].bodies[{j}]"), name)?;
            }
            if let Some(NormalSpec::Named(name)) = &pair.normal {
                if name != "average" && !pair.bodies.contains(name) {
                    return Err(invalid(
                        format!("contact.pairs[{k}].normal"),
                        format!("{name:?} is neither \"average\" nor one of the pair {:?}", pair.bodies),
                    ));
                }
            }
        }
        for (k, name) in c.rigid.iter().enumerate() {
            known(format!("contact.rigid[{k}]"), name)?;
        }
        if let Some(SeparationSpec::Named(name)) = &c.separation {
            if name != "kernel" && name != "off" {
                return Err(invalid(
                    "contact.separation",
                    format!("{name:?}: give \"kernel\", \"off\" or a cutoff in cells"),
                ));
            }
        }
        self.contact_options(c)
            .validate(self.bodies.len())
            .map_err(|e| match e {
                MpmError::InvalidOption { option, reason } => invalid(option, reason),
                e => e,
            })
    }
}
