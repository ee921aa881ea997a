//! The choices of the mass solves: [`MassScheme`], [`SingularityPolicy`], [`Constraints`],
//! [`MassOptions`], and what a solve reports ([`SolveOutcome`], [`SolveReport`]).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::stabilization::Stabilization;
use super::{DEFAULT_ACTIVE_MASS_TOLERANCE, DEFAULT_PIVOT_TOLERANCE};
use crate::error::{MpmError, Result};
use crate::names::{self, Param, Spelled};

/// How the grid mass turns momenta into velocities and forces into accelerations.
///
/// As text ([`crate::names`]): `lumped`, `consistent`, `blended:γ`, `series:k`,
/// `cg[:tolerance[:max_iterations]]` (`Display` and `FromStr`, the serde form too; scene files
/// may also write `{ blended = { gamma = γ } }`, `{ series = { k = k } }`,
/// `{ cg = { tolerance = t, max_iterations = n } }`, and the older `truncated_series` and
/// `iterative` for the last two).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
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

/// The most terms of a truncated series (`series:k`) accepted: 1000.
pub const MAX_SERIES_TERMS: usize = 1000;

/// The most CG iterations per solve accepted (`cg:tolerance:max_iterations`): 10⁵.
pub const MAX_CG_ITERATIONS: usize = 100_000;

impl MassScheme {
    /// Whether the scheme solves with the lumped mass alone (`M⁻¹ = M_L⁻¹`): lumped, blended
    /// with γ = 0, and the series of one term.
    pub fn is_lumped(&self) -> bool {
        match *self {
            MassScheme::Lumped | MassScheme::TruncatedSeries { k: 1 } => true,
            MassScheme::Blended { gamma } => gamma == 0.0,
            MassScheme::Consistent | MassScheme::TruncatedSeries { .. } | MassScheme::Iterative { .. } => false,
        }
    }

    /// Whether the scheme needs the assembled consistent mass matrix.
    pub fn needs_consistent_matrix(&self) -> bool {
        match self {
            MassScheme::Lumped | MassScheme::TruncatedSeries { k: 1 } => false,
            MassScheme::Consistent
            | MassScheme::Blended { .. }
            | MassScheme::TruncatedSeries { .. }
            | MassScheme::Iterative { .. } => true,
        }
    }

    /// The scheme's name in its text and the key of its table form (`lumped`, `consistent`,
    /// `blended`, `series`, `cg`).
    pub fn name(&self) -> &'static str {
        match self {
            MassScheme::Lumped => "lumped",
            MassScheme::Consistent => "consistent",
            MassScheme::Blended { .. } => "blended",
            MassScheme::TruncatedSeries { .. } => "series",
            MassScheme::Iterative { .. } => "cg",
        }
    }

    /// The weight `γ` of the consistent mass in the matrix the scheme stands for,
    /// `(1 − γ) M_L + γ M`: consistent and cg 1, blended `γ`; `None` for the lumped mass and the
    /// truncated series (which solve with no matrix of their own).
    pub fn consistent_weight(&self) -> Option<f64> {
        match *self {
            MassScheme::Consistent | MassScheme::Iterative { .. } => Some(1.0),
            MassScheme::Blended { gamma } => Some(gamma),
            MassScheme::Lumped | MassScheme::TruncatedSeries { .. } => None,
        }
    }

    /// Whether the scheme solves by a sparse Cholesky factorization: the consistent mass and a
    /// blend with `γ > 0`.
    pub fn factorized(&self) -> bool {
        !self.iterative() && self.consistent_weight().is_some_and(|g| g > 0.0)
    }

    /// Whether the scheme solves by iterations with the matrix (the conjugate gradient).
    pub fn iterative(&self) -> bool {
        matches!(self, MassScheme::Iterative { .. })
    }

    /// Terms `k` of the truncated series, for that scheme.
    pub fn series_terms(&self) -> Option<usize> {
        match *self {
            MassScheme::TruncatedSeries { k } => Some(k),
            _ => None,
        }
    }

    /// The Fourier symbol of the scheme's inverse for the symbols `m_l` of the lumped and `m`
    /// of the consistent mass:
    ///
    /// ```text
    /// 1/m̂_L (lumped),  1/M̂ (consistent, cg),  1/((1 − γ) m̂_L + γ M̂) (blended),
    /// (1/m̂_L) Σ_{ℓ<k} (1 − M̂/m̂_L)^ℓ (series)
    /// ```
    ///
    /// infinite where the inverted symbol is below `10⁻¹² m̂_L` (a singular matrix).
    pub fn inverse_symbol(&self, m_l: f64, m: f64) -> f64 {
        if let Some(k) = self.series_terms() {
            let r = 1.0 - m / m_l;
            return (0..k).map(|l| r.powi(l as i32)).sum::<f64>() / m_l;
        }
        let d = self.consistent_weight().map_or(m_l, |g| (1.0 - g) * m_l + g * m);
        // A symbol at round-off of the lumped mass is a singular matrix: no finite inverse.
        if d > 1e-12 * m_l {
            1.0 / d
        } else {
            f64::INFINITY
        }
    }

    /// Checks the parameters (`γ` of a blend in `[0, 1]`, terms, tolerances and iterations in range).
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] naming the parameter out of range.
    pub fn validate(&self) -> Result<()> {
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
            MassScheme::TruncatedSeries { k } if k > MAX_SERIES_TERMS => Err(MpmError::InvalidParameter {
                name: "k",
                value: k as f64,
                reason: "more terms than accepted (at most 1000: each term costs a product with the mass per solve)",
            }),
            MassScheme::Iterative { max_iterations, .. } if max_iterations > MAX_CG_ITERATIONS => {
                Err(MpmError::InvalidParameter {
                    name: "max_iterations",
                    value: max_iterations as f64,
                    reason: "more than 100000 iterations",
                })
            }
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
            MassScheme::Lumped
            | MassScheme::Consistent
            | MassScheme::Blended { .. }
            | MassScheme::TruncatedSeries { .. } => Ok(()),
        }
    }
}

/// Iteration limit of [`MassScheme::Iterative`] when none is given (`cg:1e-10`).
pub const DEFAULT_CG_MAX_ITERATIONS: usize = 500;

/// Relative tolerance of [`MassScheme::Iterative`] when none is given (`cg`).
pub const DEFAULT_CG_TOLERANCE: f64 = 1e-10;

impl fmt::Display for MassScheme {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            MassScheme::Lumped => f.pad("lumped"),
            MassScheme::Consistent => f.pad("consistent"),
            MassScheme::Blended { gamma } => names::write(f, "blended", &[gamma]),
            MassScheme::TruncatedSeries { k } => names::write_params(f, "series", &[Param::Count(k)]),
            MassScheme::Iterative {
                tolerance,
                max_iterations: DEFAULT_CG_MAX_ITERATIONS,
            } => names::write(f, "cg", &[tolerance]),
            MassScheme::Iterative {
                tolerance,
                max_iterations,
            } => names::write_params(f, "cg", &[Param::Real(tolerance), Param::Count(max_iterations)]),
        }
    }
}

impl FromStr for MassScheme {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<MassScheme, String> {
        let s = Spelled::parse(text)?;
        let scheme = match s.name {
            "lumped" => MassScheme::Lumped,
            "consistent" => MassScheme::Consistent,
            "blended" => MassScheme::Blended {
                gamma: s.param(0, None)?,
            },
            "series" | "truncated_series" => MassScheme::TruncatedSeries { k: s.param(0, None)? },
            "cg" | "iterative" => MassScheme::Iterative {
                tolerance: s.param(0, Some(DEFAULT_CG_TOLERANCE))?,
                max_iterations: s.param(1, Some(DEFAULT_CG_MAX_ITERATIONS))?,
            },
            _ => {
                return Err(format!(
                    "unknown mass scheme `{text}` (lumped, consistent, blended:γ, series:k, \
                     cg[:tolerance[:max_iterations]])"
                ))
            }
        };
        if matches!(scheme, MassScheme::Lumped | MassScheme::Consistent) {
            s.no_params()?;
        }
        Ok(scheme)
    }
}

impl names::Choice for MassScheme {
    const EXPECTING: &'static str = "a mass scheme (lumped, consistent, blended:γ, series:k, cg[:tolerance])";
    const PARAMETERS: &'static [(&'static str, &'static [&'static str])] = &[
        ("blended", &["gamma"]),
        ("series", &["k"]),
        ("truncated_series", &["k"]),
        ("cg", &["tolerance", "max_iterations"]),
        ("iterative", &["tolerance", "max_iterations"]),
    ];
}

names::choice_serde!(MassScheme);

/// What to do when the mass matrix to be solved is singular (or so close that a solve would be
/// garbage), or an iterative solve fails. Whatever happens is recorded in the [`SolveReport`].
///
/// As text ([`crate::names`]): `error`, `fallback_to_lumped`, `regularize:ε` (scene files may
/// also write `{ regularize = { epsilon = ε } }`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
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

impl fmt::Display for SingularityPolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            SingularityPolicy::Error => f.pad("error"),
            SingularityPolicy::FallbackToLumped => f.pad("fallback_to_lumped"),
            SingularityPolicy::Regularize { epsilon } => names::write(f, "regularize", &[epsilon]),
        }
    }
}

impl FromStr for SingularityPolicy {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<SingularityPolicy, String> {
        let s = Spelled::parse(text)?;
        let policy = match s.name {
            "error" => SingularityPolicy::Error,
            "fallback_to_lumped" => SingularityPolicy::FallbackToLumped,
            "regularize" => SingularityPolicy::Regularize {
                epsilon: s.param(0, None)?,
            },
            _ => {
                return Err(format!(
                    "unknown singularity policy `{text}` (error, fallback_to_lumped, regularize:ε)"
                ))
            }
        };
        if !matches!(policy, SingularityPolicy::Regularize { .. }) {
            s.no_params()?;
        }
        Ok(policy)
    }
}

impl names::Choice for SingularityPolicy {
    const EXPECTING: &'static str = "a singularity policy (error, fallback_to_lumped, regularize:ε)";
    const PARAMETERS: &'static [(&'static str, &'static [&'static str])] = &[("regularize", &["epsilon"])];
}

names::choice_serde!(SingularityPolicy);

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
