//! The choices of a simulation: update scheme, transfer, time step, bodies, and [`Options`]
//! holding them all.

use serde::{Deserialize, Serialize};

use crate::boundary::BoundaryCondition;
use crate::error::{MpmError, Result};
use crate::mass::{MassOptions, MassScheme};
use crate::material::Material;
use crate::shape::ShapeFunction;
use crate::step::PositionUpdate;

/// Default [`Options::stability_interval`]: steps between estimates of the stable time step.
pub const DEFAULT_STABILITY_INTERVAL: usize = 100;

/// When the stress is updated relative to the grid solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UpdateScheme {
    /// Update stress first, from the grid velocity of the particles' momentum.
    Usf,
    /// Update stress last, from the updated grid velocity. Nodes with tiny mass at a body's
    /// edge can give large `a = f / m` and so large strain rates (the small-mass problem).
    Usl,
    /// Modified USL (the default): the stress is updated from a grid velocity re-projected from
    /// the updated particle velocities (Sulsky et al. 1995), which removes the small-mass
    /// problem of USL.
    #[default]
    Musl,
}

/// How the particle velocities are updated from the grid.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Transfer {
    /// Particle velocity = interpolated grid velocity (dissipative, stable).
    Pic,
    /// Particle velocity incremented by the interpolated grid velocity change.
    #[default]
    Flip,
    /// `flip · FLIP + (1 − flip) · PIC`.
    Blend {
        /// Weight of FLIP, in [0, 1].
        flip: f64,
    },
    /// Affine PIC (Jiang et al. 2015): PIC plus a per-particle affine velocity matrix `C`.
    Apic,
    /// Hammerquist & Nairn's XPIC(k): the particle velocity interpolates the lumped grid
    /// velocity of the step's start extrapolated by k terms of the full-mass series, plus the
    /// lumped acceleration; `x ← x + Δt (Nᵀ v + ½ (v_p,new − v_p,old))`. Lumped mass only.
    /// XPIC(1) gives PIC's velocities.
    Xpic {
        /// Number of series terms, at least 1.
        k: usize,
    },
    /// Nairn & Hammerquist's FMPM(k): the particle velocity interpolates the updated lumped
    /// grid velocity passed through k terms of the full-mass series (once per step, just before
    /// the particle update), the stress update uses that velocity, and
    /// `x ← x + (Δt/2)(v_p,old + v_p,new)`. Lumped mass only. FMPM(1) is PIC with the
    /// trapezoidal position update.
    Fmpm {
        /// Number of series terms, at least 1.
        k: usize,
    },
}

impl Transfer {
    /// The transfer's name as a scene spells it: `"pic"`, `"flip"`, `"blend"`, `"apic"`,
    /// `"xpic"` or `"fmpm"`.
    pub fn name(&self) -> &'static str {
        match self {
            Transfer::Pic => "pic",
            Transfer::Flip => "flip",
            Transfer::Blend { .. } => "blend",
            Transfer::Apic => "apic",
            Transfer::Xpic { .. } => "xpic",
            Transfer::Fmpm { .. } => "fmpm",
        }
    }

    /// The number of series terms of XPIC(k) and FMPM(k), `None` for the other transfers.
    pub fn series_terms(&self) -> Option<usize> {
        match *self {
            Transfer::Xpic { k } | Transfer::Fmpm { k } => Some(k),
            _ => None,
        }
    }

    /// The weight `α` with which the new particle velocity keeps the old one: 1 for FLIP, the
    /// FLIP weight of a blend, 0 for PIC, APIC, XPIC and FMPM (which replace it by an
    /// interpolated velocity). It sets the stable step ([`crate::stiffness::mpm_critical_time_step`]).
    pub fn flip_weight(&self) -> f64 {
        match *self {
            Transfer::Flip => 1.0,
            Transfer::Blend { flip } => flip,
            _ => 0.0,
        }
    }
}

/// How the time step is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum TimeStep {
    /// A fixed step; it must not exceed the stable estimate unless
    /// [`Options::allow_unstable_time_step`] is set.
    Fixed {
        /// Step length (> 0).
        dt: f64,
    },
    /// `Δt = number · Δt_stable`, recomputed every step (see [`Simulation::stable_time_step`](super::Simulation::stable_time_step)).
    Cfl {
        /// Courant number in (0, 1].
        number: f64,
    },
}

/// A body: a named group of particles sharing a material.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Name used in reports and errors.
    pub name: String,
    /// Constitutive model.
    pub material: Material,
}

/// Every choice of a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Shape-function family of N, Gx, Gy.
    pub shape: ShapeFunction,
    /// USF, USL or MUSL.
    pub update: UpdateScheme,
    /// PIC, FLIP, blend or APIC.
    pub transfer: Transfer,
    /// Mass scheme of the velocity projection and of the acceleration solve, singularity policy.
    pub mass: MassOptions,
    /// Position update rule.
    pub position_update: PositionUpdate,
    /// Fixed or CFL time step.
    pub time_step: TimeStep,
    /// Accept a fixed step above the stable estimate.
    pub allow_unstable_time_step: bool,
    /// Gravity (acceleration) added to every particle's body force.
    pub gravity: [f64; 2],
    /// Nodal boundary conditions.
    pub boundaries: Vec<BoundaryCondition>,
    /// Re-sort the particles by cell every this many steps (0: never).
    pub sort_interval: usize,
    /// Re-estimate the stable time step every this many steps (it is always estimated before
    /// the first step; 0: never again). See [`Simulation::stable_time_step`](super::Simulation::stable_time_step).
    pub stability_interval: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            shape: ShapeFunction::Linear,
            update: UpdateScheme::Musl,
            transfer: Transfer::Flip,
            mass: MassOptions::default(),
            position_update: PositionUpdate::GridVelocity,
            time_step: TimeStep::Cfl { number: 0.5 },
            allow_unstable_time_step: false,
            gravity: [0.0, 0.0],
            boundaries: Vec::new(),
            sort_interval: 50,
            stability_interval: DEFAULT_STABILITY_INTERVAL,
        }
    }
}

impl Options {
    /// Checks every option on its own and against the others; [`Simulation::new`](super::Simulation::new)
    /// calls it, and a scene maps its errors to the scene's keys.
    ///
    /// # Errors
    /// The errors of [`ShapeFunction::validate`] and of the mass schemes (a blend weight outside
    /// [0, 1], a series without terms …);
    /// [`MpmError::InvalidOption`] naming the option for a non-positive or non-finite fixed step
    /// (`time_step.dt`), a Courant number outside (0, 1] (`time_step.cfl`), a FLIP weight
    /// outside [0, 1] (`transfer.flip`), an XPIC/FMPM series without terms (`transfer.k`), an
    /// XPIC/FMPM transfer with a consistent or series mass (`transfer`), or a non-finite gravity
    /// (`gravity`).
    pub fn validate(&self) -> Result<()> {
        self.shape.validate()?;
        self.mass.velocity.validate()?;
        self.mass.acceleration.validate()?;
        match self.time_step {
            TimeStep::Fixed { dt } if !(dt.is_finite() && dt > 0.0) => {
                return Err(MpmError::InvalidOption {
                    option: "time_step.dt",
                    reason: format!("{dt} is not a positive finite time step"),
                })
            }
            TimeStep::Cfl { number } if !(number > 0.0 && number <= 1.0) => {
                return Err(MpmError::InvalidOption {
                    option: "time_step.cfl",
                    reason: format!("{number}: the Courant number must lie in (0, 1]"),
                })
            }
            _ => {}
        }
        if let Transfer::Blend { flip } = self.transfer {
            if !(0.0..=1.0).contains(&flip) {
                return Err(MpmError::InvalidOption {
                    option: "transfer.flip",
                    reason: format!("{flip}: the FLIP weight must lie in [0, 1]"),
                });
            }
        }
        if let Some(k) = self.transfer.series_terms() {
            let name = self.transfer.name().to_uppercase();
            if k == 0 {
                return Err(MpmError::InvalidOption {
                    option: "transfer.k",
                    reason: format!("{name}(0): the series needs at least one term (k = 1 is PIC)"),
                });
            }
            if self.mass.velocity != MassScheme::Lumped || self.mass.acceleration != MassScheme::Lumped {
                return Err(MpmError::InvalidOption {
                    option: "transfer",
                    reason: format!(
                        "{name} is defined on the lumped mass (its series is the full-mass correction); set both \
                         mass solves to lumped"
                    ),
                });
            }
        }
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err(MpmError::InvalidOption {
                option: "gravity",
                reason: format!("{:?} must be finite", self.gravity),
            });
        }
        Ok(())
    }
}
