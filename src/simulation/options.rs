//! The choices of a simulation: update scheme, transfer, time step, bodies, and [`Options`]
//! holding them all.

use crate::boundary::BoundaryCondition;
use crate::error::{MpmError, Result};
pub use crate::implicit::{Integrator, Newmark, QuasiStatic};
use crate::mass::{MassOptions, MassScheme};
use crate::material::Material;
use crate::particles::{MAX_ACCELERATION, MAX_SPEED};
use crate::schemes::PositionUpdate;
pub use crate::schemes::TimeStep;
pub use crate::schemes::{Transfer, UpdateScheme};
use crate::shape::ShapeFunction;

/// Default [`Options::stability_interval`]: steps between estimates of the stable time step.
pub const DEFAULT_STABILITY_INTERVAL: usize = 100;

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
    /// The time over which gravity rises linearly from zero to [`Options::gravity`]
    /// (`g min(t/T, 1)` at the start of each step; `None`: all of it from the start). A load
    /// applied gradually excites less of the dynamics a damped run must then dissipate.
    pub gravity_ramp: Option<f64>,
    /// Nodal boundary conditions.
    pub boundaries: Vec<BoundaryCondition>,
    /// Re-sort the particles by cell every this many steps (0: never).
    pub sort_interval: usize,
    /// Re-estimate the stable time step every this many steps (it is always estimated before
    /// the first step; 0: never again). See [`Simulation::stable_time_step`](super::Simulation::stable_time_step).
    pub stability_interval: usize,
    /// Worker threads (1: serial). Results do not depend on it, to the last bit
    /// ([`crate::parallel`]).
    pub threads: usize,
    /// The explicit step's fused pass: the grid-to-particle pass of each step also locates the
    /// moved particles and scatters the next step's particle-to-grid terms
    /// ([`crate::kernels`], `fused`), where the schemes allow it. Results do not depend on it,
    /// to the last bit; on the benchmark it is 7–8% faster than the separate passes with
    /// quadratic B-splines and 20–22% with linear shape functions (docs/performance.md). Off by
    /// default: between its steps [`Simulation::operators`] holds the columns of the particles'
    /// present positions while the grid mass and fields are the last step's.
    ///
    /// [`Simulation::operators`]: super::Simulation::operators
    pub fused_passes: bool,
    /// Explicit (the default) or implicit Newmark integration ([`crate::implicit`]).
    pub integrator: Integrator,
    /// Damping of the explicit step's grid force, for dynamic relaxation ([`crate::damping`];
    /// `None`, the default: undamped).
    pub damping: Option<crate::damping::Damping>,
    /// Contact between bodies, one grid velocity field per body ([`crate::contact`]; `None`,
    /// the default: one field shared by every body).
    pub contact: Option<crate::contact::Contact>,
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
            gravity_ramp: None,
            boundaries: Vec::new(),
            sort_interval: 50,
            stability_interval: DEFAULT_STABILITY_INTERVAL,
            threads: 1,
            fused_passes: false,
            integrator: Integrator::Explicit,
            damping: None,
            contact: None,
        }
    }
}

impl Options {
    /// The schemes contact (and a wall with friction) works with: the explicit integrator, both
    /// solves lumped or neither, USL or MUSL, and not a series transfer.
    pub(super) fn validate_contact_schemes(&self) -> Result<()> {
        let refuse = |reason: &str| {
            Err(MpmError::InvalidOption {
                option: "contact",
                reason: reason.into(),
            })
        };
        if self.integrator != Integrator::Explicit {
            return refuse(
                "contact (one velocity field per body) is for the explicit integrator: Newmark's and the \
                 quasi-static Newton stage solve one field for every body",
            );
        }
        if self.mass.velocity.is_lumped() != self.mass.acceleration.is_lumped() {
            return refuse(&format!(
                "contact with the {} velocity mass and the {} acceleration mass: the contact impulses go through \
                 each solve's own mass, and where one is lumped and the other not they disagree (the energy of \
                 two disks in impact grew by 10% and 94%); use a lumped mass in both solves or in neither",
                self.mass.velocity, self.mass.acceleration
            ));
        }
        if self.update == UpdateScheme::Usf {
            return refuse(
                "contact with USF: its stress update reads the velocities of the momentum stage, whose contact is \
                 decided before the force stage's, and the two disagree where the bodies press together (the \
                 energy of two blocks in impact grew by 30%); use MUSL or USL",
            );
        }
        if self.transfer.series_terms().is_some() {
            return refuse(&format!(
                "contact with {}: its series velocity is one field over every body; use PIC, FLIP, a blend or APIC",
                self.transfer.name().to_uppercase()
            ));
        }
        Ok(())
    }

    /// Gravity at time `t`: `g min(t/T, 1)` with the ramp `T` ([`Options::gravity_ramp`]), `g`
    /// without one.
    pub fn gravity_at(&self, t: f64) -> [f64; 2] {
        let factor = self.gravity_ramp.map_or(1.0, |ramp| (t / ramp).clamp(0.0, 1.0));
        self.gravity.map(|g| factor * g)
    }

    /// Checks every option on its own and against the others; [`Simulation::new`](super::Simulation::new)
    /// calls it, and a scene maps its errors to the scene's keys.
    ///
    /// # Errors
    /// The errors of [`ShapeFunction::validate`] and of the mass schemes (a blend weight outside
    /// [0, 1], a series without terms …);
    /// [`MpmError::InvalidOption`] naming the option for a non-positive or non-finite fixed step
    /// (`time_step.dt`), a Courant number outside (0, 1] (`time_step.cfl`), a FLIP weight
    /// outside [0, 1] (`transfer.flip`), an XPIC/FMPM series without terms (`transfer.k`), an
    /// XPIC/FMPM transfer with a consistent or series mass (`transfer`), APIC with a velocity
    /// projection other than lumped (`transfer`: the message names both scene keys and the
    /// pairs that work), a gravity that is not finite or above [`MAX_ACCELERATION`]
    /// (`gravity`), a boundary's prescribed speed above [`MAX_SPEED`] (`boundaries`): the
    /// bounds a scene is held to, for options built in code.
    pub fn validate(&self) -> Result<()> {
        self.shape.validate()?;
        self.mass.validate()?;
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
            TimeStep::Fixed { .. } | TimeStep::Cfl { .. } => {}
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
            if k > crate::mass::MAX_SERIES_TERMS {
                return Err(MpmError::InvalidOption {
                    option: "transfer.k",
                    reason: format!(
                        "{name}({k}): at most {} terms (each costs a product with the mass per step)",
                        crate::mass::MAX_SERIES_TERMS
                    ),
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
        if self.transfer == Transfer::Apic && self.mass.velocity != MassScheme::Lumped {
            return Err(MpmError::InvalidOption {
                option: "transfer",
                reason: format!(
                    "APIC with the velocity projection `{}` (schemes.transfer = \"apic\" with schemes.mass.velocity \
                     = \"{}\") is unstable: APIC's affine momentum belongs to the lumped projection, and a particle \
                     inverts within tens of steps at any time step. Use schemes.mass.velocity = \"lumped\" with APIC \
                     (any acceleration mass), or keep the consistent velocity projection with schemes.transfer = \
                     \"flip\", \"pic\" or a blend (it reproduces affine velocity fields without APIC's matrix)",
                    self.mass.velocity, self.mass.velocity
                ),
            });
        }
        if self.threads == 0 || self.threads > crate::parallel::MAX_THREADS {
            return Err(MpmError::InvalidOption {
                option: "threads",
                reason: format!(
                    "{} threads: give 1 to {} (1 runs serially; the results are the same bits for any count)",
                    self.threads,
                    crate::parallel::MAX_THREADS
                ),
            });
        }
        if self.contact.is_some() {
            self.validate_contact_schemes()?;
        }
        if let Some(damping) = self.damping {
            damping.validate()?;
            if self.integrator != Integrator::Explicit {
                return Err(MpmError::InvalidOption {
                    option: "damping",
                    reason: "damping (dynamic relaxation) is for the explicit integrator; the quasi-static one \
                             reaches equilibrium itself and Newmark's rule has its own dissipation"
                        .into(),
                });
            }
        }
        if let Some(ramp) = self.gravity_ramp {
            if !(ramp.is_finite() && ramp > 0.0) {
                return Err(MpmError::InvalidOption {
                    option: "gravity_ramp",
                    reason: format!("{ramp}: the time over which gravity rises must be positive and finite"),
                });
            }
            if matches!(self.integrator, Integrator::QuasiStatic(_)) {
                return Err(MpmError::InvalidOption {
                    option: "gravity_ramp",
                    reason: "the quasi-static integrator applies its loads in load_steps increments: leave out the \
                             gravity ramp"
                        .into(),
                });
            }
        }
        if let Integrator::QuasiStatic(q) = self.integrator {
            q.validate()?;
            if !matches!(self.time_step, TimeStep::Fixed { dt } if dt > 0.0 && dt.is_finite()) {
                return Err(MpmError::InvalidOption {
                    option: "integrator",
                    reason: "the quasi-static integrator takes a fixed step (a scene's time.end / load_steps: \
                             prescribed velocities move their nodes by v̄ Δt per increment)"
                        .into(),
                });
            }
        }
        if let Integrator::Newmark(newmark) = self.integrator {
            newmark.validate()?;
            let TimeStep::Fixed { dt } = self.time_step else {
                return Err(MpmError::InvalidOption {
                    option: "integrator",
                    reason: "the Newmark integrator takes a fixed time step (time.dt): it has no stable-step limit \
                             to follow"
                        .into(),
                });
            };
            // The Newton matrix holds M / (β Δt²): it must be a number.
            let inertia = 1.0 / (newmark.beta * dt * dt);
            if !(inertia.is_finite() && inertia.is_normal()) {
                return Err(MpmError::InvalidOption {
                    option: "time_step.dt",
                    reason: format!(
                        "{dt:e} with the Newmark integrator: 1/(β Δt²) = {inertia:e} is not a usable number; give a \
                         time step of at least 1e-150"
                    ),
                });
            }
            // The series approximates M⁻¹ without standing for a mass: with a few terms its a_n
            // is far from M⁻¹ f, and the trapezoidal rule, which conserves energy only with the
            // a_n of its own M, gained energy 890-fold in a step (GIMP, series:2).
            if let crate::mass::MassScheme::TruncatedSeries { .. } = self.mass.acceleration {
                return Err(MpmError::InvalidOption {
                    option: "mass.acceleration",
                    reason: format!(
                        "the Newmark integrator (schemes.integrator) solves with the mass itself, and the truncated \
                         series ({:#}) only approximates its inverse; give \"consistent\", \"cg\", a \
                         blend or \"lumped\" there (the series may stay in schemes.mass.velocity)",
                        self.mass.acceleration
                    ),
                });
            }
            if !matches!(self.transfer, Transfer::Pic | Transfer::Flip | Transfer::Blend { .. }) {
                return Err(MpmError::InvalidOption {
                    option: "integrator",
                    reason: format!(
                        "the Newmark integrator updates the particles with PIC, FLIP or a blend, not {}",
                        self.transfer.name()
                    ),
                });
            }
        }
        let g = self.gravity[0].hypot(self.gravity[1]);
        if !g.is_finite() || g > MAX_ACCELERATION {
            return Err(MpmError::InvalidOption {
                option: "gravity",
                reason: format!(
                    "{:?} must be finite, of magnitude at most {MAX_ACCELERATION:e} (a scene's loads.gravity is held \
                     to the same bound)",
                    self.gravity
                ),
            });
        }
        for (k, bc) in self.boundaries.iter().enumerate() {
            for (name, v) in [("vx", bc.vx), ("vy", bc.vy)] {
                if v.is_some_and(|v| !v.is_finite() || v.abs() > MAX_SPEED) {
                    return Err(MpmError::InvalidOption {
                        option: "boundaries",
                        reason: format!(
                            "boundaries[{k}].{name} = {}: a prescribed speed must be finite and at most {MAX_SPEED:e}",
                            v.unwrap_or_default()
                        ),
                    });
                }
            }
        }
        Ok(())
    }
}
