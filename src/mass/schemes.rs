//! The mass-solver family: every mass treatment through one code path, on the active nodes,
//! with fixed degrees of freedom eliminated before any factorization.
//!
//! | scheme | grid solve `u = M⁻¹ r` with | cost per step |
//! |---|---|---|
//! | [`MassScheme::Lumped`] | `M_L = diag(N m)` | one division per node |
//! | [`MassScheme::Consistent`] | `M = N diag(m) Nᵀ`, sparse Cholesky | assemble M, numeric factorization, two triangular solves |
//! | [`MassScheme::Blended`] | `(1 − γ) M_L + γ M`, sparse Cholesky | as consistent |
//! | [`MassScheme::TruncatedSeries`] | `Σ_{l<k} (I − M_L⁻¹M)^l M_L⁻¹` (FMPM(k)) | k − 1 products with M |
//! | [`MassScheme::Iterative`] | `M`, conjugate gradient preconditioned by `M_L` | one product with M per iteration |
//!
//! Degrees of freedom: for each component (x, y) the solve runs on `F = A \ D`, the active nodes
//! less the nodes whose component is prescribed ([`Constraints`]). Prescribed values `u_D` enter
//! the right-hand side as `r_F − M_FD u_D`; the solution takes `u_D` on D and 0 on inactive nodes.

use nalgebra_sparse::CscMatrix;

use super::options::{Constraints, MassOptions, MassScheme, SingularityPolicy, SolveOutcome, SolveReport};
use super::stabilization::Stabilization;
use super::stencil::{CgWork, StencilMass};
use super::{consistent_mass, local_index, lumped_mass, mark_active, singular_error, SparseCholesky};

use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::operators::Operators;

/// One component's free degrees of freedom.
#[derive(Debug, Clone, PartialEq, Default)]
struct Dofs {
    free: Vec<usize>,
    local: Vec<usize>,
}

impl Dofs {
    fn new(n: usize, active: &[usize], fixed: &[usize]) -> Dofs {
        let mut is_fixed = vec![false; n];
        for &i in fixed {
            if i < n {
                is_fixed[i] = true;
            }
        }
        let free: Vec<usize> = active.iter().copied().filter(|&i| !is_fixed[i]).collect();
        Dofs {
            local: local_index(n, &free),
            free,
        }
    }
}

/// A prepared solver for one scheme: its factorizations (if any) and what preparing them found.
#[derive(Debug, Default)]
struct SchemeSolver {
    /// The matrix weight γ actually factorized (after a regularization), if factorized.
    gamma: Option<f64>,
    factor_x: SparseCholesky,
    factor_y: SparseCholesky,
    outcome: Option<SolveOutcome>,
}

/// The grid mass of one step: lumped mass, active nodes, the consistent matrix when a scheme
/// needs it, and a prepared solver for each of the velocity and acceleration schemes.
///
/// [`GridMass::update`] prepares it for a new particle configuration, reusing the symbolic
/// Cholesky analysis while the sparsity pattern of the matrix is unchanged and the numeric
/// factor's buffers always.
#[derive(Debug, Default)]
pub struct GridMass {
    /// Lumped mass `m_L = N m` at every node.
    pub lumped: Vec<f64>,
    /// Active nodes (ascending).
    pub active: Vec<usize>,
    /// The consistent mass matrix `M = N diag(m) Nᵀ` in compressed-column form, when a
    /// factorized scheme (consistent, blended) or the ghost penalty needs it. The conjugate
    /// gradient and the truncated series apply `M` in stencil form instead
    /// ([`GridMass::stencil`]); [`GridMass::consistent_matrix`] gives `M` in either case.
    pub matrix: Option<CscMatrix<f64>>,
    /// The stabilised consistent mass the factorized and iterative schemes solve with, when
    /// [`MassOptions::stabilization`] is not [`Stabilization::None`](super::Stabilization::None)
    /// and `matrix` is assembled.
    pub stabilized: Option<CscMatrix<f64>>,
    /// `M` in stencil form, when only the conjugate gradient and the series need it.
    stencil: Option<StencilMass>,
    /// The partially lumped `M` in stencil form, for the conjugate gradient.
    stencil_stabilized: Option<StencilMass>,
    /// Buffers of the stencil assembly of the factorized schemes.
    stencil_buffers: Option<StencilMass>,
    /// The conjugate gradient's last solution per (role, component) over all nodes (NaN where
    /// a node was not free): the next solve starts from it.
    cg: std::sync::Mutex<CgState>,
    options: Option<MassOptions>,
    is_active: Vec<bool>,
    dofs_x: Dofs,
    dofs_y: Dofs,
    velocity: SchemeSolver,
    acceleration: SchemeSolver,
}

/// Which of the two solves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The velocity projection `v̄ = M⁻¹ q`.
    Velocity,
    /// The acceleration solve `a = M⁻¹ f`.
    Acceleration,
}

impl GridMass {
    /// Prepares the grid mass for particles with masses `m` and operators `ops`.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] for an invalid scheme parameter;
    /// [`MpmError::SingularMassMatrix`] when a factorized matrix is singular and the policy is
    /// [`SingularityPolicy::Error`].
    ///
    /// # Panics
    /// If `m.len()` is not the particle count.
    pub fn new(ops: &Operators, m: &[f64], options: &MassOptions, constraints: &Constraints) -> Result<GridMass> {
        let mut mass = GridMass::default();
        mass.update(ops, m, options, constraints)?;
        Ok(mass)
    }

    /// Re-prepares for a new configuration, reusing factorization buffers and, while the
    /// pattern is unchanged, the symbolic analysis.
    ///
    /// # Errors
    /// As [`GridMass::new`]. On error the previous state is not usable for solves.
    ///
    /// # Panics
    /// If `m.len()` is not the particle count.
    pub fn update(
        &mut self,
        ops: &Operators,
        m: &[f64],
        options: &MassOptions,
        constraints: &Constraints,
    ) -> Result<()> {
        let lumped = lumped_mass(ops, m);
        self.update_with_lumped(ops, m, &lumped, options, constraints)
    }

    /// [`GridMass::update`] with the lumped mass `m_L = N m` already at hand (the time loop
    /// accumulates it with the momentum in [`crate::kernels::p2g`]); the active set is then
    /// [`mark_active`] of that `m_L`, the same set the lumped solves use.
    ///
    /// # Errors
    /// As [`GridMass::new`].
    ///
    /// # Panics
    /// If `m.len()` is not the particle count or `lumped.len()` not the node count.
    pub fn update_with_lumped(
        &mut self,
        ops: &Operators,
        m: &[f64],
        lumped: &[f64],
        options: &MassOptions,
        constraints: &Constraints,
    ) -> Result<()> {
        assert_eq!(lumped.len(), ops.num_nodes(), "one lumped mass per node");
        options.velocity.validate()?;
        options.acceleration.validate()?;
        options.stabilization.validate()?;
        if let SingularityPolicy::Regularize { epsilon } = options.singularity {
            if !(epsilon > 0.0 && epsilon <= 1.0) {
                return Err(MpmError::InvalidParameter {
                    name: "epsilon",
                    value: epsilon,
                    reason: "the regularization weight must lie in (0, 1]",
                });
            }
        }
        let n = ops.num_nodes();
        self.options = Some(*options);
        self.lumped.clear();
        self.lumped.extend_from_slice(lumped);
        self.is_active.resize(n, false);
        mark_active(&self.lumped, options.active_tolerance, &mut self.is_active);
        self.active.clear();
        self.active.extend((0..n).filter(|&i| self.is_active[i]));
        self.dofs_x = Dofs::new(n, &self.active, &constraints.fixed_x);
        self.dofs_y = Dofs::new(n, &self.active, &constraints.fixed_y);
        let needs_matrix = options.velocity.needs_consistent_matrix()
            || options.acceleration.needs_consistent_matrix()
            || options.singularity != SingularityPolicy::Error;
        let factorized = |s: MassScheme| match s {
            MassScheme::Consistent => true,
            MassScheme::Blended { gamma } => gamma > 0.0,
            _ => false,
        };
        let stencil_stabilization = matches!(
            options.stabilization,
            Stabilization::None | Stabilization::PartialLumping { .. }
        );
        let stencil_form = needs_matrix
            && !factorized(options.velocity)
            && !factorized(options.acceleration)
            && options.singularity == SingularityPolicy::Error
            && stencil_stabilization;
        if needs_matrix && !stencil_form && stencil_stabilization {
            // Factorized schemes: assembled in stencil form, handed over in compressed columns.
            let mut stencil = self.stencil_buffers.take().or(self.stencil.take()).unwrap_or_default();
            stencil.reassemble(ops, m);
            self.matrix = Some(stencil.to_csc());
            self.stabilized = match options.stabilization {
                Stabilization::PartialLumping { threshold } => {
                    stencil.partially_lump(&self.lumped, threshold);
                    Some(stencil.to_csc())
                }
                _ => None,
            };
            // Kept for its buffers only.
            self.stencil_buffers = Some(stencil);
            self.stencil = None;
            self.stencil_stabilized = None;
        } else if stencil_form {
            if self.stencil.is_none() {
                self.stencil = self.stencil_buffers.take();
            }
            self.matrix = None;
            self.stabilized = None;
            let mut stencil = self.stencil.take().unwrap_or_default();
            stencil.reassemble(ops, m);
            let iterative = |s: MassScheme| matches!(s, MassScheme::Iterative { .. });
            self.stencil_stabilized = match options.stabilization {
                Stabilization::PartialLumping { threshold }
                    if iterative(options.velocity) || iterative(options.acceleration) =>
                {
                    let mut lumped = self.stencil_stabilized.take().unwrap_or_default();
                    lumped.clone_from(&stencil);
                    lumped.partially_lump(&self.lumped, threshold);
                    Some(lumped)
                }
                _ => None,
            };
            self.stencil = Some(stencil);
        } else {
            self.stencil = None;
            self.stencil_stabilized = None;
            self.matrix = needs_matrix.then(|| consistent_mass(ops, m));
            self.stabilized = match &self.matrix {
                Some(matrix) => options.stabilization.apply(ops, matrix, &self.lumped, &self.is_active),
                None => None,
            };
        }
        self.prepare(Role::Velocity, ops)?;
        if !self.shares_solver() {
            self.prepare(Role::Acceleration, ops)?;
        }
        Ok(())
    }

    /// The plain consistent mass `M = N diag(m) Nᵀ` in compressed-column form, from whichever
    /// form was assembled (built on each call from the stencil form); `None` when no scheme
    /// needed it.
    pub fn consistent_matrix(&self) -> Option<std::borrow::Cow<'_, CscMatrix<f64>>> {
        match (&self.matrix, &self.stencil) {
            (Some(m), _) => Some(std::borrow::Cow::Borrowed(m)),
            (None, Some(s)) => Some(std::borrow::Cow::Owned(s.to_csc())),
            _ => None,
        }
    }

    /// The consistent mass in stencil form, when the schemes in use apply it that way (the
    /// conjugate gradient and the truncated series with no or partial-lumping stabilisation).
    pub fn stencil(&self) -> Option<&StencilMass> {
        self.stencil.as_ref()
    }

    /// The options in force.
    pub fn options(&self) -> MassOptions {
        self.options.unwrap_or_default()
    }

    /// The active set as a mask, one flag per node ([`mark_active`] of the lumped mass).
    pub fn is_active(&self) -> &[bool] {
        &self.is_active
    }

    /// Free degrees of freedom of the x and y components (active nodes less prescribed ones).
    pub fn free_dofs(&self) -> (&[usize], &[usize]) {
        (&self.dofs_x.free, &self.dofs_y.free)
    }

    /// Symbolic Cholesky analyses done so far by the solver of `role` (x and y components).
    pub fn symbolic_analyses(&self, role: Role) -> usize {
        let s = self.solver(role);
        s.factor_x.symbolic_analyses() + s.factor_y.symbolic_analyses()
    }

    fn scheme(&self, role: Role) -> MassScheme {
        let o = self.options();
        match role {
            Role::Velocity => o.velocity,
            Role::Acceleration => o.acceleration,
        }
    }

    fn solver(&self, role: Role) -> &SchemeSolver {
        match role {
            Role::Acceleration if !self.shares_solver() => &self.acceleration,
            _ => &self.velocity,
        }
    }

    /// Whether both solves use the same scheme, and so one factorization.
    fn shares_solver(&self) -> bool {
        let o = self.options();
        o.velocity == o.acceleration
    }

    /// Factorizes what the scheme of `role` needs, applying the singularity policy.
    fn prepare(&mut self, role: Role, ops: &Operators) -> Result<()> {
        let scheme = self.scheme(role);
        let options = self.options();
        let gamma = match scheme {
            MassScheme::Consistent => Some(1.0),
            MassScheme::Blended { gamma } if gamma > 0.0 => Some(gamma),
            _ => None,
        };
        let solver = match role {
            Role::Velocity => &mut self.velocity,
            Role::Acceleration => &mut self.acceleration,
        };
        solver.outcome = Some(SolveOutcome::Solved);
        solver.gamma = None;
        let Some(gamma) = gamma else { return Ok(()) };
        // Factorized schemes are never the series: the stabilised matrix when there is one.
        let matrix = self
            .stabilized
            .as_ref()
            .or(self.matrix.as_ref())
            .expect("assembled for factorized schemes");
        let factor_both = |s: &mut SchemeSolver, g: f64| -> std::result::Result<(), (usize, f64)> {
            let fx = s.factor_x.factor(
                matrix,
                &self.lumped,
                g,
                &self.dofs_x.free,
                &self.dofs_x.local,
                options.pivot_tolerance,
            );
            fx.map_err(|b| (self.dofs_x.free[b.local], b.pivot))?;
            if self.dofs_y.free != self.dofs_x.free {
                let fy = s.factor_y.factor(
                    matrix,
                    &self.lumped,
                    g,
                    &self.dofs_y.free,
                    &self.dofs_y.local,
                    options.pivot_tolerance,
                );
                fy.map_err(|b| (self.dofs_y.free[b.local], b.pivot))?;
            }
            Ok(())
        };
        match factor_both(solver, gamma) {
            Ok(()) => solver.gamma = Some(gamma),
            Err((node, pivot)) => match options.singularity {
                SingularityPolicy::Error => return Err(singular_error(node, pivot, ops)),
                SingularityPolicy::FallbackToLumped => {
                    solver.outcome = Some(SolveOutcome::FellBackToLumped {
                        node: Some(node),
                        relative_pivot: pivot,
                    });
                }
                SingularityPolicy::Regularize { epsilon } => {
                    let g = gamma * (1.0 - epsilon);
                    factor_both(solver, g).map_err(|(node, pivot)| singular_error(node, pivot, ops))?;
                    solver.gamma = Some(g);
                    solver.outcome = Some(SolveOutcome::Regularized {
                        node: Some(node),
                        epsilon,
                    });
                }
            },
        }
        Ok(())
    }

    /// Solves `M u = r` with the scheme of `role`: `u` on the free degrees of freedom, the
    /// prescribed values on constrained ones (`prescribed`, or 0 when `None`), 0 on inactive
    /// nodes.
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
        let scheme = self.scheme(role);
        let solver = self.solver(role);
        let n = self.lumped.len();
        assert_eq!(r.len(), n, "right-hand side must have one entry per node");
        let mut outcome = solver.outcome.clone().expect("GridMass::new prepares every solver");
        let mut u = VectorField::zeros(n);
        let mut iterations = 0;
        let mut residual = 0.0;
        // The conjugate gradient's residuals are relative to the whole vector right-hand side
        // (both components): a criterion that does not depend on the orientation of the axes,
        // and that does not ask a component carrying only noise for digits the other has.
        let norm_r = {
            let sq = |v: &[f64], dofs: &Dofs| dofs.free.iter().map(|&i| v[i] * v[i]).sum::<f64>();
            (sq(&r.x, &self.dofs_x) + sq(&r.y, &self.dofs_y)).sqrt()
        };
        for (c, dofs) in [(0usize, &self.dofs_x), (1, &self.dofs_y)] {
            let rc = if c == 0 { &r.x } else { &r.y };
            let pc = prescribed.map(|u_d| if c == 0 { &u_d.x } else { &u_d.y });
            let coupling_gamma = match (&outcome, solver.gamma, scheme) {
                (SolveOutcome::FellBackToLumped { .. }, _, _) => 0.0,
                (_, Some(g), _) => g,
                (_, None, MassScheme::Lumped) | (_, None, MassScheme::Blended { .. }) => 0.0,
                _ => 1.0,
            };
            let mut rhs: Vec<f64> = dofs.free.iter().map(|&i| rc[i]).collect();
            // Prescribed values on D, zero on F, for the coupling term (prescribed zeros, such
            // as walls at rest, couple nothing).
            let prescribed_nonzero =
                pc.is_some_and(|pc| (0..n).any(|i| pc[i] != 0.0 && self.is_active[i] && dofs.local[i] == usize::MAX));
            if let (Some(pc), true) = (pc, coupling_gamma > 0.0 && prescribed_nonzero) {
                let mut ud_full = pc.clone();
                for &i in &dofs.free {
                    ud_full[i] = 0.0;
                }
                let m = self
                    .solve_matrix(scheme)
                    .expect("matrix assembled when coupling is needed");
                let mud = m.mul(&ud_full);
                for (k, &i) in dofs.free.iter().enumerate() {
                    rhs[k] -= coupling_gamma * mud[i];
                }
            }
            let (x, its, res) = match (&outcome, scheme) {
                (SolveOutcome::FellBackToLumped { .. }, _) | (_, MassScheme::Lumped) => {
                    (self.lumped_solve(dofs, &rhs), 0, 0.0)
                }
                (_, MassScheme::Blended { gamma: 0.0 }) => (self.lumped_solve(dofs, &rhs), 0, 0.0),
                (_, MassScheme::Consistent)
                | (_, MassScheme::Blended { .. })
                | (SolveOutcome::Regularized { .. }, _) => {
                    let factor = if c == 1 && self.dofs_y.free != self.dofs_x.free {
                        &solver.factor_y
                    } else {
                        &solver.factor_x
                    };
                    let mut sol = vec![rhs.clone()];
                    factor.solve_in_place(&mut sol);
                    let g = solver.gamma.expect("factorized");
                    let res = self.relative_residual(scheme, dofs, g, &sol[0], &rhs);
                    (sol.pop().expect("one column"), 0, res)
                }
                (_, MassScheme::TruncatedSeries { k }) => {
                    let x = self.series_solve(dofs, &rhs, k);
                    let res = self.relative_residual(scheme, dofs, 1.0, &x, &rhs);
                    (x, k, res)
                }
                (
                    _,
                    MassScheme::Iterative {
                        tolerance,
                        max_iterations,
                    },
                ) => match self.cg_solve(dofs, &rhs, tolerance, max_iterations, 2 * (role as usize) + c, norm_r) {
                    Ok((x, its, res)) => {
                        let res = res.unwrap_or_else(|| self.relative_residual(scheme, dofs, 1.0, &x, &rhs));
                        (x, its, res)
                    }
                    Err(reason) => {
                        let located = self.locate_singularity(dofs);
                        match self.options().singularity {
                            SingularityPolicy::Error => {
                                return Err(match located {
                                    Some((node, pivot)) => singular_error(node, pivot, ops),
                                    None => MpmError::Solver { reason },
                                })
                            }
                            SingularityPolicy::FallbackToLumped => {
                                outcome = SolveOutcome::FellBackToLumped {
                                    node: located.map(|l| l.0),
                                    relative_pivot: located.map_or(f64::NAN, |l| l.1),
                                };
                                (self.lumped_solve(dofs, &rhs), max_iterations, 0.0)
                            }
                            SingularityPolicy::Regularize { epsilon } => {
                                outcome = SolveOutcome::Regularized {
                                    node: located.map(|l| l.0),
                                    epsilon,
                                };
                                let mut f = SparseCholesky::default();
                                let m = self.solve_matrix(scheme).expect("assembled").csc();
                                f.factor(&m, &self.lumped, 1.0 - epsilon, &dofs.free, &dofs.local, 0.0)
                                    .map_err(|b| singular_error(dofs.free[b.local], b.pivot, ops))?;
                                let mut sol = vec![rhs.clone()];
                                f.solve_in_place(&mut sol);
                                let res = self.relative_residual(scheme, dofs, 1.0 - epsilon, &sol[0], &rhs);
                                (sol.pop().expect("one column"), max_iterations, res)
                            }
                        }
                    }
                },
            };
            iterations += its;
            residual = f64::max(residual, res);
            let out = if c == 0 { &mut u.x } else { &mut u.y };
            for i in 0..n {
                let prescribed_here = self.is_active[i] && dofs.local[i] == usize::MAX;
                out[i] = match pc {
                    Some(pc) if prescribed_here => pc[i],
                    _ => 0.0,
                };
            }
            for (k, &i) in dofs.free.iter().enumerate() {
                out[i] = x[k];
            }
        }
        Ok((
            u,
            SolveReport {
                scheme,
                outcome,
                iterations,
                relative_residual: residual,
            },
        ))
    }

    fn lumped_solve(&self, dofs: &Dofs, rhs: &[f64]) -> Vec<f64> {
        dofs.free.iter().zip(rhs).map(|(&i, r)| r / self.lumped[i]).collect()
    }

    /// The matrix `scheme` solves with: the plain consistent mass for the truncated series
    /// (which is defined with it), the stabilised one otherwise.
    fn solve_matrix(&self, scheme: MassScheme) -> Option<MassOperator<'_>> {
        let csc = match scheme {
            MassScheme::TruncatedSeries { .. } => self.matrix.as_ref(),
            _ => self.stabilized.as_ref().or(self.matrix.as_ref()),
        };
        let stencil = match scheme {
            MassScheme::TruncatedSeries { .. } => self.stencil.as_ref(),
            _ => self.stencil_stabilized.as_ref().or(self.stencil.as_ref()),
        };
        csc.map(MassOperator::Csc).or(stencil.map(MassOperator::Stencil))
    }

    /// `(γ M + (1 − γ) M_L)_FF x`, for `x` on F, with `M` the matrix of `scheme`.
    fn apply(&self, scheme: MassScheme, dofs: &Dofs, gamma: f64, x: &[f64]) -> Vec<f64> {
        let n = self.lumped.len();
        let mut full = vec![0.0; n];
        for (k, &i) in dofs.free.iter().enumerate() {
            full[i] = x[k];
        }
        let mx = match (self.solve_matrix(scheme), gamma > 0.0) {
            (Some(m), true) => m.mul(&full),
            _ => vec![0.0; n],
        };
        dofs.free
            .iter()
            .enumerate()
            .map(|(k, &i)| gamma * mx[i] + (1.0 - gamma) * self.lumped[i] * x[k])
            .collect()
    }

    fn relative_residual(&self, scheme: MassScheme, dofs: &Dofs, gamma: f64, x: &[f64], rhs: &[f64]) -> f64 {
        let ax = self.apply(scheme, dofs, gamma, x);
        let num: f64 = ax.iter().zip(rhs).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        let den: f64 = rhs.iter().map(|b| b * b).sum::<f64>().sqrt();
        if den == 0.0 {
            num
        } else {
            num / den
        }
    }

    /// `Σ_{l<k} (I − M_L⁻¹ M)^l M_L⁻¹ r` on F.
    fn series_solve(&self, dofs: &Dofs, rhs: &[f64], k: usize) -> Vec<f64> {
        let mut du = self.lumped_solve(dofs, rhs);
        let mut u = du.clone();
        for _ in 1..k {
            let mdu = self.apply(MassScheme::TruncatedSeries { k }, dofs, 1.0, &du);
            for (j, &i) in dofs.free.iter().enumerate() {
                du[j] -= mdu[j] / self.lumped[i];
                u[j] += du[j];
            }
        }
        u
    }

    /// Preconditioned conjugate gradient on `M_FF x = rhs` to `‖rhs − M_FF x‖ ≤ tolerance ·
    /// max(norm_r, ‖rhs‖)`: on the stencil form started from the last solution of `slot` (the
    /// lumped solution on nodes that were not free then), otherwise through faer from the
    /// lumped solution.
    fn cg_solve(
        &self,
        dofs: &Dofs,
        rhs: &[f64],
        tolerance: f64,
        max_iterations: usize,
        slot: usize,
        norm_r: f64,
    ) -> std::result::Result<(Vec<f64>, usize, Option<f64>), String> {
        // With prescribed values the right-hand side is r − M_FD u_D: never below its own norm.
        let own = rhs.iter().map(|v| v * v).sum::<f64>().sqrt();
        let scale = norm_r.max(own);
        if let Some(MassOperator::Stencil(m)) = self.solve_matrix(MassScheme::Consistent) {
            let mut x = self.lumped_solve(dofs, rhs);
            let mut state = self.cg.lock().expect("no solve panics holding it");
            let CgState { warm, work } = &mut *state;
            let last = &mut warm[slot];
            if last.len() == self.lumped.len() {
                for (x, &i) in x.iter_mut().zip(&dofs.free) {
                    if last[i].is_finite() {
                        *x = last[i];
                    }
                }
            }
            let (its, residual) = m.pcg(
                &dofs.free,
                &self.lumped,
                rhs,
                &mut x,
                tolerance,
                max_iterations,
                scale,
                work,
            )?;
            last.clear();
            last.resize(self.lumped.len(), f64::NAN);
            for (&x, &i) in x.iter().zip(&dofs.free) {
                last[i] = x;
            }
            return Ok((x, its, Some(residual)));
        }
        let (x, its) = super::cg::solve(
            |x| self.apply(MassScheme::Consistent, dofs, 1.0, x),
            dofs.free.iter().map(|&i| self.lumped[i]).collect(),
            rhs,
            self.lumped_solve(dofs, rhs),
            tolerance,
            scale,
            max_iterations,
        )?;
        Ok((x, its, None))
    }

    /// The conjugate gradient's warm-start vectors, one per (role, component): the last
    /// solution over all nodes (NaN where a node was not free), empty before the first solve.
    /// The next solves start from them, so they are part of a checkpoint.
    pub(crate) fn warm_start(&self) -> [Vec<f64>; 4] {
        self.cg
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .warm
            .clone()
    }

    /// Sets the warm-start vectors of [`GridMass::warm_start`] (resuming from a checkpoint).
    pub(crate) fn set_warm_start(&mut self, warm: [Vec<f64>; 4]) {
        self.cg
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .warm = warm;
    }

    /// Runs the Cholesky check on `M_FF` to name a singular node, if there is one.
    fn locate_singularity(&self, dofs: &Dofs) -> Option<(usize, f64)> {
        let m = self.solve_matrix(MassScheme::Consistent)?.csc();
        let mut f = SparseCholesky::default();
        f.factor(
            &m,
            &self.lumped,
            1.0,
            &dofs.free,
            &dofs.local,
            self.options().pivot_tolerance,
        )
        .err()
        .map(|b| (dofs.free[b.local], b.pivot))
    }
}

/// `y = M x` for a CSC matrix (full storage).
pub(crate) fn spmv(m: &CscMatrix<f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; m.nrows()];
    for (j, col) in m.col_iter().enumerate() {
        let xj = x[j];
        if xj != 0.0 {
            for (&i, &v) in col.row_indices().iter().zip(col.values()) {
                y[i] += v * xj;
            }
        }
    }
    y
}

/// What the conjugate gradient keeps between solves.
#[derive(Debug, Default)]
struct CgState {
    /// The last solution per (role, component) over all nodes (NaN where a node was not free).
    warm: [Vec<f64>; 4],
    work: CgWork,
}

/// The matrix a scheme solves with, in whichever form it was assembled.
#[derive(Debug, Clone, Copy)]
enum MassOperator<'a> {
    Csc(&'a CscMatrix<f64>),
    Stencil(&'a StencilMass),
}

impl<'a> MassOperator<'a> {
    /// `y = M x` over all nodes.
    fn mul(&self, x: &[f64]) -> Vec<f64> {
        match self {
            MassOperator::Csc(m) => spmv(m, x),
            MassOperator::Stencil(m) => m.mul(x),
        }
    }

    /// The matrix in compressed-column form.
    fn csc(self) -> std::borrow::Cow<'a, CscMatrix<f64>> {
        match self {
            MassOperator::Csc(m) => std::borrow::Cow::Borrowed(m),
            MassOperator::Stencil(m) => std::borrow::Cow::Owned(m.to_csc()),
        }
    }
}
