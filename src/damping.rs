//! Damping of the explicit step's grid force, for dynamic relaxation: an explicit run that
//! settles to static equilibrium (`loads.damping` in a scene, [`Options::damping`]).
//!
//! Applied to the grid force `f = f_ext + f_int` after the velocity projection (6) and before
//! the acceleration solve (7), so that it works with every mass scheme, at the active nodes
//! with the projected velocity `v`:
//!
//! ```text
//! local (non-viscous, Cundall 1987):  f_I ← f_I − α |f_I| sign(v_I)     per component, 0 ≤ α < 1
//! mass-proportional (viscous):         f_I ← f_I − α m_L,I v_I           α in 1/time
//! ```
//!
//! The local rule, the geomechanics codes' default for dynamic relaxation (FLAC, and MPM codes
//! after it), removes a fraction `α` of the force where it accelerates the motion and adds it
//! where it decelerates: it damps every mode alike, needs no frequency, and vanishes at
//! equilibrium (`f = 0`). The mass-proportional rule damps the low modes most (critically at
//! `α = 2ω`). The energy the damping removes, `Σ_I −f_d,I · v_I Δt` over the steps, is
//! reported (`damping_work`), so that the energy balance closes; a run is reported settled
//! once the kinetic energy of the motion that moves the particles, `½ Σ_p m_p |(Nᵀ w)_p|²`, has
//! fallen below `settled` times its largest value (not the particles' own: FLIP keeps particle
//! velocities the grid does not see, which no damping of the grid force reaches and which move
//! no particle). With the consistent mass the local rule leaves that energy near 10⁻⁸ of its
//! largest (the sign of each node's velocity flips from step to step); the mass-proportional
//! rule takes it to round-off.
//!
//! [`Options::damping`]: crate::simulation::Options::damping

use serde::{Deserialize, Serialize};

use crate::error::{MpmError, Result};
use crate::fields::VectorField;

/// The damping rule of [`Damping`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DampingModel {
    /// `f ← f − α |f| sign(v)` per node and component (`0 ≤ α < 1`).
    Local,
    /// `f ← f − α m_L v` (`α ≥ 0`, in 1/time).
    MassProportional,
}

/// Damping of the grid force ([module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Damping {
    /// The rule.
    pub model: DampingModel,
    /// Its coefficient `α`.
    pub alpha: f64,
    /// The fraction of the largest kinetic energy below which a run is reported settled.
    #[serde(default = "default_settled")]
    pub settled: f64,
}

/// The default [`Damping::settled`]: 10⁻⁶ of the largest kinetic energy.
pub const DEFAULT_SETTLED: f64 = 1e-6;

fn default_settled() -> f64 {
    DEFAULT_SETTLED
}

impl Damping {
    /// Checks the coefficient (`0 ≤ α < 1` for the local rule, finite and non-negative for the
    /// mass-proportional one) and `0 < settled < 1`.
    ///
    /// # Errors
    /// [`MpmError::InvalidOption`] naming the key.
    pub fn validate(&self) -> Result<()> {
        let ok = match self.model {
            DampingModel::Local => (0.0..1.0).contains(&self.alpha),
            DampingModel::MassProportional => self.alpha.is_finite() && self.alpha >= 0.0,
        };
        if !ok {
            return Err(MpmError::InvalidOption {
                option: "damping.alpha",
                reason: format!(
                    "{}: the local rule takes 0 ≤ α < 1 (0.8 is usual), the mass-proportional one a finite α ≥ 0",
                    self.alpha
                ),
            });
        }
        if !(self.settled > 0.0 && self.settled < 1.0) {
            return Err(MpmError::InvalidOption {
                option: "damping.settled",
                reason: format!(
                    "{}: give a fraction of the largest kinetic energy in (0, 1)",
                    self.settled
                ),
            });
        }
        Ok(())
    }

    /// Damps the force `f` at the active nodes for the velocity `v` and lumped mass `lumped`
    /// ([module docs](self)); returns the power of the damping force, `Σ_I f_d,I · v_I ≤ 0`.
    ///
    /// # Panics
    /// If the fields do not have one entry per node.
    pub fn apply(&self, f: &mut VectorField, v: &VectorField, lumped: &[f64], is_active: &[bool]) -> f64 {
        let n = lumped.len();
        assert!(
            f.len() == n && v.len() == n && is_active.len() == n,
            "one value per node"
        );
        let mut power = 0.0;
        for i in (0..n).filter(|&i| is_active[i]) {
            for (force, velocity) in [(&mut f.x[i], v.x[i]), (&mut f.y[i], v.y[i])] {
                let damping = match self.model {
                    DampingModel::Local => -self.alpha * force.abs() * sign(velocity),
                    DampingModel::MassProportional => -self.alpha * lumped[i] * velocity,
                };
                *force += damping;
                power += damping * velocity;
            }
        }
        power
    }
}

/// `sign(x)`, 0 at 0.
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_damping_force_opposes_the_velocity_and_vanishes_with_the_force_or_the_velocity() {
        let v = VectorField {
            x: vec![1.0, -2.0, 0.0, 3.0],
            y: vec![0.5, 0.0, -1.0, 1.0],
        };
        let f0 = VectorField {
            x: vec![2.0, 4.0, 1.0, 0.0],
            y: vec![-1.0, 3.0, 2.0, 5.0],
        };
        let lumped = [1.0, 2.0, 3.0, 4.0];
        let active = [true, true, true, false];
        let local = Damping {
            model: DampingModel::Local,
            alpha: 0.5,
            settled: DEFAULT_SETTLED,
        };
        let mut f = f0.clone();
        let power = local.apply(&mut f, &v, &lumped, &active);
        assert_eq!(f.x, vec![1.0, 6.0, 1.0, 0.0]);
        assert_eq!(f.y, vec![-1.5, 3.0, 3.0, 5.0]);
        assert_eq!(power, -1.0 - 0.5 * 0.5 - 2.0 * 2.0 - 1.0);
        let viscous = Damping {
            model: DampingModel::MassProportional,
            alpha: 2.0,
            ..local
        };
        let mut f = f0.clone();
        let power = viscous.apply(&mut f, &v, &lumped, &active);
        assert_eq!(f.x, vec![0.0, 12.0, 1.0, 0.0]);
        assert_eq!(f.y, vec![-2.0, 3.0, 8.0, 5.0]);
        assert!(power < 0.0);
        assert!(Damping { alpha: 1.0, ..local }.validate().is_err());
        assert!(Damping { alpha: -1.0, ..viscous }.validate().is_err());
        assert!(Damping { settled: 0.0, ..local }.validate().is_err());
        assert!(local.validate().is_ok() && viscous.validate().is_ok());
    }
}
