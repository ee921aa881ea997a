//! The scheme choices the product kernels dispatch on: the update scheme (USF, USL, MUSL), the
//! velocity transfer (PIC, FLIP, blend, APIC, XPIC, FMPM) and the position rule. They are
//! re-exported by [`crate::simulation`] and [`crate::step`]; the kernels and both tiers of the
//! step read the same enums.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::names::{self, Param, Spelled};

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
///
/// As text ([`crate::names`]): `pic`, `flip`, `blend:α`, `apic`, `xpic:k`, `fmpm:k` (scene files
/// may also write `{ blend = { flip = α } }`, `{ xpic = { k = k } }`, `{ fmpm = { k = k } }`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
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
            Transfer::Pic | Transfer::Flip | Transfer::Blend { .. } | Transfer::Apic => None,
        }
    }

    /// The weight `α` with which the new particle velocity keeps the old one: 1 for FLIP, the
    /// FLIP weight of a blend, 0 for PIC, APIC, XPIC and FMPM (which replace it by an
    /// interpolated velocity). It sets the stable step ([`crate::stiffness::mpm_critical_time_step`]).
    pub fn flip_weight(&self) -> f64 {
        match *self {
            Transfer::Flip => 1.0,
            Transfer::Blend { flip } => flip,
            Transfer::Pic | Transfer::Apic | Transfer::Xpic { .. } | Transfer::Fmpm { .. } => 0.0,
        }
    }
}

impl fmt::Display for Transfer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Transfer::Pic | Transfer::Flip | Transfer::Apic => f.pad(self.name()),
            Transfer::Blend { flip } => names::write(f, "blend", &[flip]),
            Transfer::Xpic { k } | Transfer::Fmpm { k } => names::write_params(f, self.name(), &[Param::Count(k)]),
        }
    }
}

impl FromStr for Transfer {
    type Err = String;

    fn from_str(text: &str) -> Result<Transfer, String> {
        let s = Spelled::parse(text)?;
        let transfer = match s.name {
            "pic" => Transfer::Pic,
            "flip" => Transfer::Flip,
            "apic" => Transfer::Apic,
            "blend" => Transfer::Blend {
                flip: s.param(0, None)?,
            },
            "xpic" => Transfer::Xpic { k: s.param(0, None)? },
            "fmpm" => Transfer::Fmpm { k: s.param(0, None)? },
            _ => {
                return Err(format!(
                    "unknown transfer `{text}` (pic, flip, apic, blend:α, xpic:k, fmpm:k)"
                ))
            }
        };
        if matches!(transfer, Transfer::Pic | Transfer::Flip | Transfer::Apic) {
            s.no_params()?;
        }
        Ok(transfer)
    }
}

impl names::Choice for Transfer {
    const EXPECTING: &'static str = "a transfer (pic, flip, apic, blend:α, xpic:k, fmpm:k)";
    const PARAMETERS: &'static [(&'static str, &'static [&'static str])] =
        &[("blend", &["flip"]), ("xpic", &["k"]), ("fmpm", &["k"])];
}

names::choice_serde!(Transfer);

impl fmt::Display for UpdateScheme {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(match self {
            UpdateScheme::Usf => "usf",
            UpdateScheme::Usl => "usl",
            UpdateScheme::Musl => "musl",
        })
    }
}

impl FromStr for UpdateScheme {
    type Err = String;

    fn from_str(text: &str) -> Result<UpdateScheme, String> {
        match text.trim() {
            "usf" => Ok(UpdateScheme::Usf),
            "usl" => Ok(UpdateScheme::Usl),
            "musl" => Ok(UpdateScheme::Musl),
            _ => Err(format!("unknown update scheme `{text}` (usf, usl, musl)")),
        }
    }
}

/// How particle positions move in step (9).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PositionUpdate {
    /// `x ← x + Δt Nᵀ v̄'`: the standard MPM update with the updated grid velocity.
    #[default]
    GridVelocity,
    /// `x ← x + (Δt/2)(v_p + Nᵀ v̄')`: the seed's 4(C) as read in docs/homework.md.
    Trapezoidal,
}

/// Where an update scheme puts the stress update in a step: the one place that says so, read
/// by the time loop ([`UpdateScheme::schedule`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Schedule {
    /// The stress is updated right after the velocity projection (6), from `v`, and its internal
    /// force added then (USF); otherwise the particle-to-grid pass adds the internal force of
    /// the stress as it stands.
    pub stress_first: bool,
    /// The stress update after the grid-to-particle pass, if any.
    pub stress_last: Option<StressFrom>,
}

/// Which grid velocity the stress update after the grid-to-particle pass reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StressFrom {
    /// The updated grid velocity `w` (USL), whose gradient the grid-to-particle pass computes.
    Updated,
    /// The grid velocity re-projected from the updated particle velocities (MUSL).
    Reprojected,
}

impl UpdateScheme {
    /// The scheme's place for the stress update.
    pub fn schedule(self) -> Schedule {
        match self {
            UpdateScheme::Usf => Schedule {
                stress_first: true,
                stress_last: None,
            },
            UpdateScheme::Usl => Schedule {
                stress_first: false,
                stress_last: Some(StressFrom::Updated),
            },
            UpdateScheme::Musl => Schedule {
                stress_first: false,
                stress_last: Some(StressFrom::Reprojected),
            },
        }
    }
}

impl fmt::Display for PositionUpdate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(match self {
            PositionUpdate::GridVelocity => "grid_velocity",
            PositionUpdate::Trapezoidal => "trapezoidal",
        })
    }
}

impl FromStr for PositionUpdate {
    type Err = String;

    fn from_str(text: &str) -> Result<PositionUpdate, String> {
        match text.trim() {
            "grid_velocity" => Ok(PositionUpdate::GridVelocity),
            "trapezoidal" => Ok(PositionUpdate::Trapezoidal),
            _ => Err(format!("unknown position update `{text}` (grid_velocity, trapezoidal)")),
        }
    }
}

/// How the time step is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum TimeStep {
    /// A fixed step; it must not exceed the stable estimate unless
    /// [`Options::allow_unstable_time_step`](crate::simulation::Options::allow_unstable_time_step) is set.
    Fixed {
        /// Step length (> 0).
        dt: f64,
    },
    /// `Δt = number · Δt_stable`, recomputed every step (see [`Simulation::stable_time_step`](crate::simulation::Simulation::stable_time_step)).
    Cfl {
        /// Courant number in (0, 1].
        number: f64,
    },
}
