//! A grid mass per velocity component, for walls that reflect the two components differently.
//!
//! A slip wall under the mirror rule (`crate::boundary::mirror`) reflects the component
//! normal to it oddly and the tangential one evenly, `v_c = C_c v̂_c`, so each component has its
//! own consistent mass,
//!
//! ```text
//! M_c = C_cᵀ M C_c = N̂_c diag(m) N̂_cᵀ,     N̂_c = C_cᵀ N      (c = x, y)
//! ```
//!
//! assembled from the operators folded for that component. [`GridMass::prepare_components`]
//! prepares this grid mass from `N̂_x` for the x component and a second one from `N̂_y` for the
//! y component (each with the other component entirely prescribed, so that it solves nothing
//! there); every solve then takes x from the first and y from the second. The lumped mass,
//! `|C|ᵀ m_L`, and so the active set are the same for both.

use super::options::{Constraints, MassOptions, SolveOutcome, SolveReport};
use super::solve::Start;
use super::GridMass;
use crate::error::Result;
use crate::fields::VectorField;
use crate::operators::Operators;
use crate::parallel::Workers;

impl GridMass {
    /// [`GridMass::prepare`] with one operator per component, `each = [N̂_x, N̂_y]` (the
    /// [module docs](self)), for a lumped mass that is zero outside `nodes`.
    ///
    /// # Errors
    /// As [`GridMass::new`].
    ///
    /// # Panics
    /// As [`GridMass::prepare`].
    pub(crate) fn prepare_components(
        &mut self,
        each: [&Operators; 2],
        m: &[f64],
        options: &MassOptions,
        constraints: &Constraints,
        nodes: std::ops::Range<usize>,
        workers: &Workers,
    ) -> Result<()> {
        let n = each[0].num_nodes();
        let every: Vec<usize> = (0..n).collect();
        let mut y = match self.component_y.take() {
            Some(y) => y,
            // A new part starts from this one's warm-start vectors (a resumed checkpoint's).
            None => {
                let mut y = Box::<GridMass>::default();
                y.cg.warm.clone_from(&self.cg.warm);
                y
            }
        };
        y.lumped.clone_from(&self.lumped);
        let x_only = Constraints {
            fixed_x: constraints.fixed_x.clone(),
            fixed_y: every.clone(),
        };
        let y_only = Constraints {
            fixed_x: every,
            fixed_y: constraints.fixed_y.clone(),
        };
        self.prepare_with(each[0], m, options, &x_only, nodes.clone(), workers)?;
        y.prepare_with(each[1], m, options, &y_only, nodes, workers)?;
        // What the solves write on prescribed components reads the real constraints.
        self.constraints.fixed_y.clone_from(&constraints.fixed_y);
        y.constraints.fixed_x.clone_from(&constraints.fixed_x);
        self.component_y = Some(y);
        Ok(())
    }

    /// Whether the components have grid masses of their own: the time loop's consistent mass
    /// beside slip walls under the mirror rule, which reflect the normal component oddly and
    /// the tangential one evenly (`M_c = N̂_c diag(m) N̂_cᵀ` for c = x, y).
    pub fn has_component_masses(&self) -> bool {
        self.component_y.is_some()
    }

    /// The solve of [`GridMass::solve_into`] from `start` for the x component (and for both
    /// with one grid mass), then from `start_y` by the y component's grid mass.
    pub(super) fn solve_components(
        &self,
        [start, start_y]: [Start<'_>; 2],
        role: super::Role,
        r: &VectorField,
        prescribed: Option<&VectorField>,
        ops: &Operators,
        u: &mut VectorField,
    ) -> Result<SolveReport> {
        let report = self.solve_from(start, role, r, prescribed, ops, u)?;
        let Some(y) = &self.component_y else {
            return Ok(report);
        };
        let mut uy = VectorField::zeros(r.len());
        let other = y.solve_from(start_y, role, r, prescribed, ops, &mut uy)?;
        u.y.copy_from_slice(&uy.y);
        Ok(SolveReport {
            iterations: report.iterations + other.iterations,
            relative_residual: report.relative_residual.max(other.relative_residual),
            outcome: match report.outcome {
                SolveOutcome::Solved => other.outcome,
                own => own,
            },
            ..report
        })
    }

    /// [`GridMass::solved_matrix`] of the y component's own grid mass, if it has one.
    pub(crate) fn component_y_solved_matrix(&self, role: super::Role) -> Option<nalgebra_sparse::CscMatrix<f64>> {
        self.component_y.as_ref().map(|y| y.solved_matrix(role))
    }
}
