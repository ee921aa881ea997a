//! [`GridMass::solve`]: `u = M⁻¹ r` with the scheme of a role, one match on the scheme that
//! sends each to its file (`lumped.rs`, `direct.rs`, `series.rs`, `cg.rs`).

use super::cg::{CgFailure, CgState};
use super::cholesky::SparseCholesky;
use super::grid_mass::Dofs;
use super::options::{MassScheme, SingularityPolicy, SolveOutcome, SolveReport};
use super::{singular_error, GridMass, Role};
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::operators::Operators;

/// Where the conjugate gradient starts and what it leaves for the next solve.
#[derive(Debug)]
pub(crate) enum Start<'a> {
    /// From the lumped solution, leaving the warm-start vectors as they were: the same `r`
    /// gives the same `u` whatever was solved before. The tolerance is the larger of the
    /// scheme's and `tolerance_floor`.
    Cold {
        /// The loosest relative residual accepted (0 for the scheme's own).
        tolerance_floor: f64,
    },
    /// From the last warm solve of the same role (the time loop's, whose right-hand sides change
    /// little from one step to the next) kept in the state, which this one then replaces.
    Warm(&'a mut CgState),
}

/// The relative residual of the mass solves inside a frequency estimate
/// (`GridMass::solve_for_estimate`).
///
/// Lanczos with an operator applied to a relative error `ε` gives Ritz values within about
/// `ε λ_max` of the exact operator's, far inside the estimate's own tolerance
/// ([`crate::stiffness::FREQUENCY_TOLERANCE`], 10⁻³) and its safety factor
/// ([`crate::stiffness::TIME_STEP_SAFETY`], 0.98).
pub const ESTIMATE_SOLVE_TOLERANCE: f64 = 1e-8;

/// How a prepared scheme solves this step.
enum Method {
    /// `M_L⁻¹` (the lumped scheme, a blend of weight 0, and a fallback to lumped).
    Lumped,
    /// A Cholesky factorization of `γ M + (1 − γ) M_L` (consistent, blended, regularized).
    Direct { gamma: f64 },
    /// The truncated series of `k` terms.
    Series { k: usize },
    /// The conjugate gradient.
    Iterative { tolerance: f64, max_iterations: usize },
}

impl GridMass {
    /// Solves `M u = r` with the scheme of `role`: `u` on the free degrees of freedom, the
    /// prescribed values on constrained ones (`prescribed`, or 0 when `None`), 0 on inactive
    /// nodes. Returns `u` and what the solve did; [`GridMass::solve_into`] writes into a
    /// given field.
    ///
    /// # Errors
    /// For [`MassScheme::Iterative`], a conjugate-gradient failure under
    /// [`SingularityPolicy::Error`] is [`MpmError::SingularMassMatrix`] when a Cholesky check
    /// locates a singular node, [`MpmError::Solver`] otherwise.
    ///
    /// # Panics
    /// If `r` (or `prescribed`) does not have one entry per node, or before [`GridMass::new`].
    pub fn solve(
        &self,
        role: Role,
        r: &VectorField,
        prescribed: Option<&VectorField>,
        ops: &Operators,
    ) -> Result<(VectorField, SolveReport)> {
        let mut u = VectorField::zeros(r.len());
        let report = self.solve_into(role, r, prescribed, ops, &mut u)?;
        Ok((u, report))
    }

    /// [`GridMass::solve`] into `u` (resized to the node count). With the lumped scheme it
    /// allocates nothing once `u` has one entry per node. The conjugate gradient starts from the
    /// lumped solution, so the result depends on `r` alone, not on earlier solves (the time
    /// loop's own solves start from the previous step's solution instead).
    ///
    /// # Errors
    /// As [`GridMass::solve`].
    ///
    /// # Panics
    /// As [`GridMass::solve`].
    pub fn solve_into(
        &self,
        role: Role,
        r: &VectorField,
        prescribed: Option<&VectorField>,
        ops: &Operators,
        u: &mut VectorField,
    ) -> Result<SolveReport> {
        let cold = || Start::Cold { tolerance_floor: 0.0 };
        self.solve_components([cold(), cold()], role, r, prescribed, ops, u)
    }

    /// [`GridMass::solve_into`] warm-started, as the time loop solves: the conjugate gradient
    /// starts from the last warm solution of the same role (per component; the lumped solution
    /// on nodes that were not free then) and keeps this one for the next warm solve. Where the
    /// right-hand side changes little between calls (one step to the next) this saves most
    /// iterations; the result then depends on the earlier warm solves, to within the tolerance.
    /// Schemes other than the iterative one solve as [`GridMass::solve_into`].
    ///
    /// # Errors
    /// As [`GridMass::solve`].
    ///
    /// # Panics
    /// As [`GridMass::solve`].
    pub fn solve_warm_into(
        &mut self,
        role: Role,
        r: &VectorField,
        prescribed: Option<&VectorField>,
        ops: &Operators,
        u: &mut VectorField,
    ) -> Result<SolveReport> {
        let mut state = std::mem::take(&mut self.cg);
        let mut state_y = self
            .component_y
            .as_mut()
            .map(|y| std::mem::take(&mut y.cg))
            .unwrap_or_default();
        let starts = [Start::Warm(&mut state), Start::Warm(&mut state_y)];
        let report = self.solve_components(starts, role, r, prescribed, ops, u);
        self.cg = state;
        if let Some(y) = &mut self.component_y {
            y.cg = state_y;
        }
        report
    }

    /// What a lumped solve of `role` reports ([`GridMass::solve_lumped`]'s, when the time loop
    /// makes the lumped solves in its grid pass).
    pub(crate) fn lumped_report(&self, role: Role) -> SolveReport {
        SolveReport {
            scheme: self.scheme(role),
            outcome: self.solver(role).outcome.clone(),
            iterations: 0,
            relative_residual: 0.0,
        }
    }

    /// [`GridMass::solve_into`] inside a frequency estimate: a cold start at the relative residual
    /// [`ESTIMATE_SOLVE_TOLERANCE`] (or the scheme's, if looser).
    pub(crate) fn solve_for_estimate(
        &self,
        role: Role,
        r: &VectorField,
        ops: &Operators,
        u: &mut VectorField,
    ) -> Result<()> {
        let start = || Start::Cold {
            tolerance_floor: ESTIMATE_SOLVE_TOLERANCE,
        };
        self.solve_components([start(), start()], role, r, None, ops, u)
            .map(|_| ())
    }

    /// [`GridMass::solve_into`] from `start`, by this grid mass alone.
    pub(super) fn solve_from(
        &self,
        start: Start<'_>,
        role: Role,
        r: &VectorField,
        prescribed: Option<&VectorField>,
        ops: &Operators,
        u: &mut VectorField,
    ) -> Result<SolveReport> {
        let scheme = self.scheme(role);
        let outcome = self.solver(role).outcome.clone();
        let report = |iterations: usize, relative_residual: f64, outcome: SolveOutcome| SolveReport {
            scheme,
            outcome,
            iterations,
            relative_residual,
        };
        match self.method(role) {
            Method::Lumped => {
                self.solve_lumped(r, prescribed, u);
                Ok(report(0, 0.0, outcome))
            }
            Method::Direct { gamma } => {
                let rhs = self.coupled_rhs(scheme, gamma, r, prescribed);
                let x = self.solve_direct(role, &rhs);
                let residual = self.residual(scheme, gamma, &x, &rhs);
                self.write_solution(&x, prescribed, u);
                Ok(report(0, residual, outcome))
            }
            Method::Series { k } => {
                let rhs = self.coupled_rhs(scheme, 1.0, r, prescribed);
                let x = self.solve_series(k, &rhs);
                let residual = self.residual(scheme, 1.0, &x, &rhs);
                self.write_solution(&x, prescribed, u);
                Ok(report(2 * k, residual, outcome))
            }
            Method::Iterative {
                tolerance,
                max_iterations,
            } => {
                let rhs = self.coupled_rhs(scheme, 1.0, r, prescribed);
                let norm_r = self.free_norm(r);
                // A cold solve works in buffers of its own and leaves the warm state alone.
                let mut cold = CgState::default();
                let (state, warm, tolerance) = match start {
                    Start::Cold { tolerance_floor } => (&mut cold, false, tolerance.max(tolerance_floor)),
                    Start::Warm(state) => (state, true, tolerance),
                };
                match self.solve_cg(role, state, warm, &rhs, [tolerance, norm_r], max_iterations) {
                    Ok((x, iterations, residual)) => {
                        self.write_solution(&x, prescribed, u);
                        Ok(report(iterations, residual, outcome))
                    }
                    Err(failure) => {
                        let iterations = failure.iterations;
                        let (outcome, residual) = self.cg_failed(failure, &rhs, r, prescribed, ops, u)?;
                        Ok(report(iterations + max_iterations, residual, outcome))
                    }
                }
            }
        }
    }

    /// How the scheme of `role` solves, given what preparing it found.
    fn method(&self, role: Role) -> Method {
        let solver = self.solver(role);
        match (&solver.outcome, solver.gamma) {
            (SolveOutcome::FellBackToLumped { .. }, _) => return Method::Lumped,
            // A conjugate gradient regularized before its solve (a nearly singular mass,
            // [`GridMass::substitute_nearly_singular`]) solves with the factors made then.
            (SolveOutcome::Regularized { .. }, Some(gamma)) => return Method::Direct { gamma },
            _ => {}
        }
        match self.scheme(role) {
            MassScheme::Lumped => Method::Lumped,
            MassScheme::Blended { gamma: 0.0 } => Method::Lumped,
            MassScheme::Consistent | MassScheme::Blended { .. } => Method::Direct {
                gamma: solver.gamma.expect("factorized"),
            },
            MassScheme::TruncatedSeries { k } => Method::Series { k },
            MassScheme::Iterative {
                tolerance,
                max_iterations,
            } => Method::Iterative {
                tolerance,
                max_iterations,
            },
        }
    }

    /// The right-hand side on the free degrees of freedom, 0 elsewhere: `r_F − γ M_FD u_D` for
    /// the matrix of `scheme` (prescribed zeros, such as walls at rest, couple nothing).
    fn coupled_rhs(
        &self,
        scheme: MassScheme,
        gamma: f64,
        r: &VectorField,
        prescribed: Option<&VectorField>,
    ) -> VectorField {
        let n = self.lumped.len();
        let mut rhs = VectorField::zeros(n);
        for (c, dofs) in self.dofs.iter().enumerate() {
            let (rc, out) = if c == 0 { (&r.x, &mut rhs.x) } else { (&r.y, &mut rhs.y) };
            for &i in &dofs.free {
                out[i] = rc[i];
            }
            let Some(pc) = prescribed.map(|p| if c == 0 { &p.x } else { &p.y }) else {
                continue;
            };
            let nonzero = (0..n).any(|i| pc[i] != 0.0 && dofs.is_prescribed(i, &self.is_active));
            if gamma > 0.0 && nonzero {
                let mut ud = pc.clone();
                for &i in &dofs.free {
                    ud[i] = 0.0;
                }
                let m = self
                    .matrices
                    .operator(scheme)
                    .expect("matrix assembled when coupling is needed");
                let mud = m.mul(&ud);
                for &i in &dofs.free {
                    out[i] -= gamma * mud[i];
                }
            }
        }
        rhs
    }

    /// `u = x` on the free degrees of freedom, the prescribed values on the prescribed
    /// components of active nodes, 0 elsewhere.
    fn write_solution(&self, x: &VectorField, prescribed: Option<&VectorField>, u: &mut VectorField) {
        let n = self.lumped.len();
        for (c, dofs) in self.dofs.iter().enumerate() {
            let (xc, out) = if c == 0 { (&x.x, &mut u.x) } else { (&x.y, &mut u.y) };
            let pc = prescribed.map(|p| if c == 0 { &p.x } else { &p.y });
            out.resize(n, 0.0);
            for i in 0..n {
                out[i] = match pc {
                    Some(pc) if dofs.is_prescribed(i, &self.is_active) => pc[i],
                    _ => 0.0,
                };
            }
            for &i in &dofs.free {
                out[i] = xc[i];
            }
        }
    }

    /// `‖r‖` over the free degrees of freedom of both components.
    fn free_norm(&self, r: &VectorField) -> f64 {
        let sq = |v: &[f64], dofs: &Dofs| dofs.free.iter().map(|&i| v[i] * v[i]).sum::<f64>();
        (sq(&r.x, &self.dofs[0]) + sq(&r.y, &self.dofs[1])).sqrt()
    }

    /// The largest over the components of `‖(γ M + (1 − γ) M_L) x − rhs‖ / ‖rhs‖` on the free
    /// degrees of freedom, with `M` the matrix of `scheme`.
    pub(super) fn residual(&self, scheme: MassScheme, gamma: f64, x: &VectorField, rhs: &VectorField) -> f64 {
        let mut worst = 0.0f64;
        for (c, dofs) in self.dofs.iter().enumerate() {
            let (xc, bc) = if c == 0 { (&x.x, &rhs.x) } else { (&x.y, &rhs.y) };
            let mut on_f = vec![0.0; self.lumped.len()];
            for &i in &dofs.free {
                on_f[i] = xc[i];
            }
            let mx = match (self.matrices.operator(scheme), gamma > 0.0) {
                (Some(m), true) => m.mul(&on_f),
                _ => vec![0.0; self.lumped.len()],
            };
            let (mut num, mut den) = (0.0, 0.0);
            for &i in &dofs.free {
                let a = gamma * mx[i] + (1.0 - gamma) * self.lumped[i] * xc[i];
                num += (a - bc[i]) * (a - bc[i]);
                den += bc[i] * bc[i];
            }
            let (num, den) = (f64::sqrt(num), f64::sqrt(den));
            worst = worst.max(if den == 0.0 { num } else { num / den });
        }
        worst
    }

    /// What the singularity policy makes of a conjugate-gradient `failure`: an error, the lumped
    /// solve of `r`, or a regularized factorization of the coupled `rhs`.
    fn cg_failed(
        &self,
        failure: CgFailure,
        rhs: &VectorField,
        r: &VectorField,
        prescribed: Option<&VectorField>,
        ops: &Operators,
        u: &mut VectorField,
    ) -> Result<(SolveOutcome, f64)> {
        let CgFailure { component, reason, .. } = failure;
        let located = self.locate_singularity(&self.dofs[component]);
        match self.options.singularity {
            SingularityPolicy::Error => Err(match located {
                Some((node, pivot)) => singular_error(node, pivot, ops),
                None => MpmError::Solver { reason },
            }),
            SingularityPolicy::FallbackToLumped => {
                self.solve_lumped(r, prescribed, u);
                let outcome = SolveOutcome::FellBackToLumped {
                    node: located.map(|l| l.0),
                    relative_pivot: located.map_or(f64::NAN, |l| l.1),
                };
                Ok((outcome, 0.0))
            }
            SingularityPolicy::Regularize { epsilon } => {
                let x = self.solve_regularized(epsilon, rhs, ops)?;
                let residual = self.residual(MassScheme::Consistent, 1.0 - epsilon, &x, rhs);
                self.write_solution(&x, prescribed, u);
                let outcome = SolveOutcome::Regularized {
                    node: located.map(|l| l.0),
                    epsilon,
                };
                Ok((outcome, residual))
            }
        }
    }

    /// Runs the Cholesky check on `M_FF` to name a singular node, if there is one.
    fn locate_singularity(&self, dofs: &Dofs) -> Option<(usize, f64)> {
        let m = self.matrices.operator(MassScheme::Consistent)?.csc();
        let mut f = SparseCholesky::default();
        f.factor(
            &m,
            &self.lumped,
            1.0,
            &dofs.free,
            &dofs.local,
            self.options.pivot_tolerance,
        )
        .err()
        .map(|b| (dofs.free[b.local], b.pivot))
    }
}
