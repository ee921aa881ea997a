//! Implicit time integration in matrix form: the internal force of a grid displacement and its
//! exact tangent ([`tangent`]), assembled from the operators Gx, Gy as `K = 𝔾ᵀ 𝔻 𝔾`.
//!
//! The tangent is the building block of Newmark integration on the grid, where the consistent
//! mass costs no stable step (docs/implicit.md).

pub(crate) mod newton;
pub mod solve;
pub mod tangent;

pub use solve::SparseLu;

pub use tangent::{
    displacement_gradients, gradient_operator, internal_force, internal_force_and_tangent, particle_stress,
};

use serde::{Deserialize, Serialize};

use crate::error::{MpmError, Result};
use crate::schemes::TimeStep;

/// How the grid equations are integrated in time.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Integrator {
    /// The explicit update of the update scheme (USF, USL, MUSL), with a stable-step limit.
    #[default]
    Explicit,
    /// Newmark's rule on the grid with Newton iterations (docs/implicit.md); a fixed `Δt`, no
    /// stable-step limit for `2β ≥ γ ≥ ½`.
    Newmark(Newmark),
    /// Static equilibrium reached in load increments, each by Newton iterations on
    /// `f_int(u) + λ f_ext = 0` with the exact tangent and no mass (docs/implicit.md).
    QuasiStatic(QuasiStatic),
}

/// The quasi-static integrator's load increments and Newton controls. Step `k` (from 1) applies
/// the load factor `λ_k = min(k / load_steps, 1)` to gravity and the body forces, and moves
/// prescribed nodes by `v̄ Δt` (`Δt` the fixed step: a scene's `time.end / load_steps`); the
/// operators are assembled anew at the converged configuration of each increment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QuasiStatic {
    /// Increments of the load (1 to 10⁶).
    pub load_steps: usize,
    /// Converged when `‖r‖ ≤ tolerance · ‖λ|f_ext| + |f_int|‖` on the free degrees of freedom and
    /// the reactions at the others (or by a vanishing increment with the residual within
    /// `√tolerance`); in
    /// [`MIN_TOLERANCE`], 1).
    pub tolerance: f64,
    /// Newton iterations allowed per increment (1 to 1000).
    pub max_iterations: usize,
}

impl Default for QuasiStatic {
    fn default() -> Self {
        QuasiStatic {
            load_steps: 20,
            tolerance: 1e-10,
            max_iterations: 25,
        }
    }
}

impl QuasiStatic {
    /// The load factor of step `step` (from 1): `min(step / load_steps, 1)`.
    pub fn load_factor(&self, step: usize) -> f64 {
        (step as f64 / self.load_steps as f64).min(1.0)
    }

    /// Checks the parameters.
    ///
    /// # Errors
    /// [`MpmError::InvalidOption`] naming the parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |option: &'static str, reason: String| Err(MpmError::InvalidOption { option, reason });
        if !(1..=1_000_000).contains(&self.load_steps) {
            return bad(
                "integrator.quasi_static.load_steps",
                format!("{}: give 1 to 10⁶ load increments", self.load_steps),
            );
        }
        newton_controls(self.tolerance, self.max_iterations, "quasi_static")
    }
}

/// Newmark's parameters and the Newton iteration's controls.
///
/// ```text
/// u = Δt v_n + Δt² ((½ − β) a_n + β a_{n+1}),   v_{n+1} = v_n + Δt ((1 − γ) a_n + γ a_{n+1})
/// ```
///
/// The default, average acceleration (`β = ¼`, `γ = ½`, the trapezoidal rule), is
/// unconditionally stable and conserves the energy of linear problems.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Newmark {
    /// `β` in (0, ½], with `2β ≥ γ` (stable for every `Δt`).
    pub beta: f64,
    /// `γ` in [½, 1].
    pub gamma: f64,
    /// Converged when `‖r‖ ≤ tolerance · ‖|f_ext| + |f_int| + (|M u| + |M c|)/(β Δt²)‖` on the free
    /// degrees of freedom with the reactions `|f_ext| + |f_int|` at the others
    /// (`c = Δt v_n + Δt² (½ − β) a_n`: the size of each term of
    /// `r = f_ext + f_int − M (u − c)/(β Δt²)`), or when the increment `‖δu‖ ≤ tolerance · ‖u‖`
    /// with that relative residual within `√tolerance` (a residual held up by round-off); in
    /// [`MIN_TOLERANCE`], 1).
    pub tolerance: f64,
    /// Newton iterations allowed per step (1 to 1000).
    pub max_iterations: usize,
}

/// The smallest relative tolerance of the Newton iterations: about a hundred times the
/// round-off of `f64`.
pub const MIN_TOLERANCE: f64 = 1e-14;

impl Default for Newmark {
    fn default() -> Self {
        Newmark {
            beta: 0.25,
            gamma: 0.5,
            tolerance: 1e-10,
            max_iterations: 25,
        }
    }
}

impl Newmark {
    /// Checks the parameters.
    ///
    /// # Errors
    /// [`MpmError::InvalidOption`] naming the parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |option: &'static str, reason: String| Err(MpmError::InvalidOption { option, reason });
        if !(self.beta > 0.0 && self.beta <= 0.5) {
            return bad(
                "integrator.newmark.beta",
                format!("{}: β must lie in (0, 0.5]", shown(self.beta)),
            );
        }
        if !(0.5..=1.0).contains(&self.gamma) {
            return bad(
                "integrator.newmark.gamma",
                format!("{}: γ must lie in [0.5, 1]", shown(self.gamma)),
            );
        }
        if self.gamma > 2.0 * self.beta {
            return bad(
                "integrator.newmark.beta",
                format!(
                    "β = {}, γ = {}: Newmark's rule is stable for every Δt only when 2β ≥ γ ≥ ½, and this engine \
                     has no stable-step limit for it; give β ≥ γ/2 = {} (β = 0.25, γ = 0.5 is the average \
                     acceleration rule)",
                    shown(self.beta),
                    shown(self.gamma),
                    shown(self.gamma / 2.0)
                ),
            );
        }
        newton_controls(self.tolerance, self.max_iterations, "newmark")
    }
}

/// The Newton controls of the integrator `key`: a relative tolerance in [[`MIN_TOLERANCE`], 1)
/// and 1 to 1000 iterations.
fn newton_controls(tolerance: f64, max_iterations: usize, key: &str) -> Result<()> {
    let (option, reason) = if !(MIN_TOLERANCE..1.0).contains(&tolerance) {
        (
            "tolerance",
            format!(
                "{}: the relative tolerance must lie in [{MIN_TOLERANCE:e}, 1) (a residual relative to the size of \
                 its terms does not fall much below round-off)",
                shown(tolerance)
            ),
        )
    } else if !(1..=1000).contains(&max_iterations) {
        (
            "max_iterations",
            format!("{max_iterations}: give 1 to 1000 Newton iterations"),
        )
    } else {
        return Ok(());
    };
    let option = match (key, option) {
        ("newmark", "tolerance") => "integrator.newmark.tolerance",
        ("newmark", _) => "integrator.newmark.max_iterations",
        (_, "tolerance") => "integrator.quasi_static.tolerance",
        _ => "integrator.quasi_static.max_iterations",
    };
    Err(MpmError::InvalidOption { option, reason })
}

impl Newmark {
    /// The step of at most `max_dt` the integrator takes at time `time` after `steps` steps:
    /// the fixed step.
    ///
    /// # Errors
    /// [`MpmError::InvalidOption`] for a step that is not fixed; [`MpmError::StepRejected`] when
    /// the clock cannot resolve the step or 1/(β Δt²) is not a number.
    pub fn time_step(&self, time_step: TimeStep, time: f64, steps: usize, max_dt: f64) -> Result<f64> {
        let TimeStep::Fixed { dt } = time_step else {
            return Err(MpmError::InvalidOption {
                option: "integrator",
                reason: "the Newmark integrator takes a fixed time step".into(),
            });
        };
        let dt = dt.min(max_dt);
        let inertia = 1.0 / (self.beta * dt * dt);
        if dt > 0.0 && time + dt > time && inertia.is_normal() {
            return Ok(dt);
        }
        Err(MpmError::StepRejected {
            step: steps + 1,
            reason: format!(
                "a step of {dt:e} at t = {time} is too short for the Newmark integrator (the time does not \
                 advance, or 1/(β Δt²) is not a number): give a longer step"
            ),
        })
    }
}

/// `x` as a message shows it: plainly between 10⁻⁴ and 10⁶, in exponent form beyond.
fn shown(x: f64) -> String {
    if x == 0.0 || (1e-4..1e6).contains(&x.abs()) || !x.is_finite() {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}
