//! The choices of the mass solves: [`MassScheme`], [`SingularityPolicy`], [`Constraints`],
//! [`MassOptions`], and what a solve reports ([`SolveOutcome`], [`SolveReport`]).

use serde::{Deserialize, Serialize};

use super::stabilization::Stabilization;
use super::{DEFAULT_ACTIVE_MASS_TOLERANCE, DEFAULT_PIVOT_TOLERANCE};
use crate::error::{MpmError, Result};

/// How the grid mass turns momenta into velocities and forces into accelerations.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum MassScheme {
    /// Row-sum lumped mass `m_L = N m`.
    #[default]
    Lumped,
    /// Consistent mass `M = N diag(m) Nᵀ`, solved by sparse Cholesky.
    Consistent,
    /// `(1 − γ) M_L + γ M` with `0 ≤ γ ≤ 1`: γ = 0 is lumped, γ = 1 consistent.
    Blended {
        /// Weight γ of the consistent mass.
        gamma: f64,
    },
    /// The first `k` terms of `M⁻¹ = Σ_l (I − M_L⁻¹ M)^l M_L⁻¹` (Nairn's FMPM(k), equal to
    /// XPIC(k) grid velocities); `k = 1` is lumped.
    TruncatedSeries {
        /// Number of terms, at least 1.
        k: usize,
    },
    /// Conjugate gradient on `M u = r` preconditioned by the lumped mass, started from the
    /// previous step's solution (the lumped solution on nodes that were not free then). With
    /// no or partial-lumping stabilisation it runs on `M` in stencil form
    /// ([`super::StencilMass`]), without assembling the compressed-column matrix.
    Iterative {
        /// Relative residual at which to stop: each component's `‖M u − r‖` at most
        /// `tolerance · ‖r‖`, with `‖r‖` the norm of the whole vector right-hand side (both
        /// components), so that the criterion does not depend on the orientation of the axes.
        tolerance: f64,
        /// Iteration limit; reaching it is a failure handled by the [`SingularityPolicy`].
        max_iterations: usize,
    },
}

impl MassScheme {
    /// Whether the scheme needs the assembled consistent mass matrix.
    pub fn needs_consistent_matrix(&self) -> bool {
        !matches!(self, MassScheme::Lumped | MassScheme::TruncatedSeries { k: 1 })
    }

    /// A short name for reports (`"lumped"`, `"consistent"`, `"blended(0.5)"` …).
    pub fn label(&self) -> String {
        match self {
            MassScheme::Lumped => "lumped".into(),
            MassScheme::Consistent => "consistent".into(),
            MassScheme::Blended { gamma } => format!("blended({})", crate::numbers::decimals(*gamma, 4)),
            MassScheme::TruncatedSeries { k } => format!("series({k})"),
            MassScheme::Iterative { tolerance, .. } => format!("cg({tolerance:e})"),
        }
    }

    pub(crate) fn validate(&self) -> Result<()> {
        match *self {
            MassScheme::Blended { gamma } if !(0.0..=1.0).contains(&gamma) => Err(MpmError::InvalidParameter {
                name: "gamma",
                value: gamma,
                reason: "the blend weight must lie in [0, 1]",
            }),
            MassScheme::TruncatedSeries { k: 0 } => Err(MpmError::InvalidParameter {
                name: "k",
                value: 0.0,
                reason: "the truncated series needs at least one term",
            }),
            MassScheme::Iterative {
                tolerance,
                max_iterations,
            } => {
                if !(tolerance > 0.0 && tolerance < 1.0) {
                    Err(MpmError::InvalidParameter {
                        name: "tolerance",
                        value: tolerance,
                        reason: "the relative tolerance must lie in (0, 1)",
                    })
                } else if max_iterations == 0 {
                    Err(MpmError::InvalidParameter {
                        name: "max_iterations",
                        value: 0.0,
                        reason: "at least one iteration is needed",
                    })
                } else {
                    Ok(())
                }
            }
            _ => Ok(()),
        }
    }
}

/// What to do when the mass matrix to be solved is singular (or so close that a solve would be
/// garbage), or an iterative solve fails. Whatever happens is recorded in the [`SolveReport`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum SingularityPolicy {
    /// Return [`MpmError::SingularMassMatrix`] naming the node and the particles touching it.
    #[default]
    Error,
    /// Solve with the lumped mass instead, for this step.
    FallbackToLumped,
    /// Solve with `(1 − ε) M + ε M_L` instead (positive definite for `ε > 0`), for this step.
    Regularize {
        /// Weight ε of the lumped mass, in (0, 1].
        epsilon: f64,
    },
}

/// Nodal degrees of freedom whose value is prescribed (fixed or roller nodes). They are
/// eliminated from the mass solve.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Constraints {
    /// Nodes whose x component is prescribed.
    pub fixed_x: Vec<usize>,
    /// Nodes whose y component is prescribed.
    pub fixed_y: Vec<usize>,
}

impl Constraints {
    /// No prescribed degrees of freedom.
    pub fn none() -> Constraints {
        Constraints::default()
    }

    /// Whether no degree of freedom is prescribed.
    pub fn is_empty(&self) -> bool {
        self.fixed_x.is_empty() && self.fixed_y.is_empty()
    }
}

/// The mass treatment of a step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MassOptions {
    /// Scheme for the velocity projection `v̄ = M⁻¹ q`.
    pub velocity: MassScheme,
    /// Scheme for the acceleration solve `a = M⁻¹ f`.
    pub acceleration: MassScheme,
    /// What to do with a singular matrix or a failed iterative solve.
    pub singularity: SingularityPolicy,
    /// How the consistent mass is stabilised at a body's fringe before it is solved with
    /// (consistent, blended and conjugate-gradient schemes).
    pub stabilization: Stabilization,
    /// Relative lumped mass at or below which a node is inactive.
    pub active_tolerance: f64,
    /// Cholesky pivot (Jacobi-scaled) at or below which the matrix counts as singular.
    pub pivot_tolerance: f64,
}

impl Default for MassOptions {
    fn default() -> Self {
        MassOptions::both(MassScheme::Lumped)
    }
}

impl MassOptions {
    /// The same scheme for the velocity projection and the acceleration solve, default policy
    /// and tolerances.
    pub fn both(scheme: MassScheme) -> MassOptions {
        MassOptions {
            velocity: scheme,
            acceleration: scheme,
            singularity: SingularityPolicy::Error,
            stabilization: Stabilization::default(),
            active_tolerance: DEFAULT_ACTIVE_MASS_TOLERANCE,
            pivot_tolerance: DEFAULT_PIVOT_TOLERANCE,
        }
    }

    /// [`MassOptions::both`] with the textbook matrices: no fringe stabilisation
    /// ([`Stabilization::None`]), so that consistent solves use `M = N diag(m) Nᵀ` itself.
    pub fn plain(scheme: MassScheme) -> MassOptions {
        MassOptions {
            stabilization: Stabilization::None,
            ..MassOptions::both(scheme)
        }
    }
}

/// What a solve did.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum SolveOutcome {
    /// Solved with the requested scheme.
    #[default]
    Solved,
    /// The matrix was singular at `node`; the lumped mass was used instead.
    FellBackToLumped {
        /// Node (grid numbering) where the singularity was found, if it could be located.
        node: Option<usize>,
        /// Scaled pivot there.
        relative_pivot: f64,
    },
    /// The matrix was singular at `node`; `(1 − ε) M + ε M_L` was used instead.
    Regularized {
        /// Node (grid numbering) where the singularity was found, if it could be located.
        node: Option<usize>,
        /// The ε used.
        epsilon: f64,
    },
}

/// The record of one mass solve: scheme, outcome, work and accuracy.
#[derive(Debug, Clone, PartialEq)]
pub struct SolveReport {
    /// The scheme requested.
    pub scheme: MassScheme,
    /// What happened.
    pub outcome: SolveOutcome,
    /// Work, summed over the x and y components: conjugate-gradient iterations, or terms of the
    /// truncated series (k per component); 0 for direct solves.
    pub iterations: usize,
    /// `‖A u − r‖ / ‖r‖` over the free degrees of freedom, with `A` the matrix actually solved
    /// (for the truncated series, the consistent mass it approximates; 0 for lumped).
    pub relative_residual: f64,
}
