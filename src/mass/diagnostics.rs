//! Diagnostics of the grid mass, as data a user can print or plot.

use super::{active_nodes, consistent_mass, local_index, lumped_mass, GridMass, MassOptions, Role, SparseCholesky};
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::operators::Operators;
use crate::spectral::{lanczos_extremes, start_vector, DEFAULT_LANCZOS_STEPS};

/// A node is counted as tiny-mass when its lumped mass is below this fraction of the largest:
/// such nodes (touched only by the corner of a particle's support) carry accelerations
/// `f/m_L` that the stress gradients of their particles can make arbitrarily large.
pub const TINY_MASS_FRACTION: f64 = 1e-3;

/// Facts about the grid mass of one configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct MassDiagnostics {
    /// Number of active nodes.
    pub active_nodes: usize,
    /// Smallest lumped mass over the active nodes.
    pub min_nodal_mass: f64,
    /// Largest lumped mass.
    pub max_nodal_mass: f64,
    /// Active nodes with `m_L < TINY_MASS_FRACTION · max m_L`.
    pub tiny_mass_nodes: usize,
    /// Estimated nullity of the consistent mass on the active nodes: the number of Cholesky
    /// pivots of the Jacobi-scaled `M_AA` at or below the pivot tolerance.
    pub nullity_estimate: usize,
    /// Estimated smallest eigenvalue of `M_L⁻¹ M` on the active nodes (in [0, 1]; 0 when `M` is
    /// singular; 1 would mean `M = M_L`). Lanczos estimate, an upper bound.
    pub lambda_min_estimate: f64,
    /// Condition number (2-norm) of the matrix the acceleration scheme actually solves with,
    /// on its free degrees of freedom; infinite when it is singular.
    pub condition_number: f64,
}

impl MassDiagnostics {
    /// Computes the diagnostics of particles with masses `m` on operators `ops`, for the
    /// acceleration scheme and tolerances in `options` (no constraints).
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] for an invalid scheme parameter.
    ///
    /// # Panics
    /// If `m.len()` is not the particle count.
    pub fn compute(ops: &Operators, m: &[f64], options: &MassOptions) -> Result<MassDiagnostics> {
        let n = ops.num_nodes();
        let lumped = lumped_mass(ops, m);
        let active = active_nodes(&lumped, options.active_tolerance);
        let masses: Vec<f64> = active.iter().map(|&i| lumped[i]).collect();
        let max = masses.iter().cloned().fold(0.0, f64::max);
        let min = masses.iter().cloned().fold(f64::INFINITY, f64::min);
        let tiny = masses.iter().filter(|&&v| v < TINY_MASS_FRACTION * max).count();

        let matrix = consistent_mass(ops, m);
        let local = local_index(n, &active);
        let mut factor = SparseCholesky::default();
        let nullity_estimate = match factor.factor(&matrix, &lumped, 1.0, &active, &local, options.pivot_tolerance) {
            Ok(()) => 0,
            Err(_) => factor.count_small_pivots(options.pivot_tolerance).max(1),
        };
        // λ(M_L⁻¹ M): self-adjoint in the M_L inner product.
        let on_active = |i: usize| local[i] != usize::MAX;
        let start = start_vector(n, on_active);
        let lambda_min_estimate = lanczos_extremes(
            &start,
            DEFAULT_LANCZOS_STEPS,
            |v| {
                let mv = super::csc_times(&matrix, v);
                (0..n)
                    .map(|i| if on_active(i) { mv[i] / lumped[i] } else { 0.0 })
                    .collect()
            },
            |v| {
                (0..n)
                    .map(|i| if on_active(i) { lumped[i] * v[i] } else { 0.0 })
                    .collect()
            },
        )
        .map_or(f64::NAN, |(lo, _)| lo.max(0.0));
        let condition_number = match GridMass::new(
            ops,
            m,
            &MassOptions {
                singularity: Default::default(),
                ..*options
            },
            &Default::default(),
        ) {
            Ok(mass) => solve_condition_number(&mass, ops)?,
            Err(MpmError::SingularMassMatrix { .. }) => f64::INFINITY,
            Err(e) => return Err(e),
        };
        Ok(MassDiagnostics {
            active_nodes: active.len(),
            min_nodal_mass: if active.is_empty() { 0.0 } else { min },
            max_nodal_mass: max,
            tiny_mass_nodes: tiny,
            nullity_estimate,
            lambda_min_estimate,
            condition_number,
        })
    }
}

/// `κ = λ_max / λ_min` of the matrix the acceleration scheme of `mass` solves with, from a
/// Lanczos estimate of the extreme eigenvalues of its inverse (the solve itself, so every
/// scheme is covered the same way), on the free x degrees of freedom.
///
/// # Errors
/// Those of [`GridMass::solve`].
pub fn solve_condition_number(mass: &GridMass, ops: &Operators) -> Result<f64> {
    let n = mass.lumped.len();
    let [fx, _] = mass.free_dofs();
    if fx.is_empty() {
        return Ok(1.0);
    }
    let mut on = vec![false; n];
    fx.iter().for_each(|&i| on[i] = true);
    let start = start_vector(n, |i| on[i]);
    let mut failure = None;
    let extremes = lanczos_extremes(
        &start,
        DEFAULT_LANCZOS_STEPS,
        |v| {
            let r = VectorField {
                x: v.to_vec(),
                y: vec![0.0; n],
            };
            match mass.solve(Role::Acceleration, &r, None, ops) {
                Ok((u, _)) => u.x,
                Err(e) => {
                    failure.get_or_insert(e);
                    vec![0.0; n]
                }
            }
        },
        |v| v.to_vec(),
    );
    if let Some(e) = failure {
        return Err(e);
    }
    Ok(match extremes {
        Some((lo, hi)) if lo > 0.0 => hi / lo,
        _ => f64::INFINITY,
    })
}
