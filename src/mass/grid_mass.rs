//! [`GridMass`]: the grid mass of one configuration, prepared for the two solves of a step.
//!
//! | scheme | grid solve `u = M⁻¹ r` with | file |
//! |---|---|---|
//! | [`MassScheme::Lumped`] | `M_L = diag(N m)`: `u = r ∘ m_L⁻¹` | `lumped.rs` |
//! | [`MassScheme::Consistent`] | `M = N diag(m) Nᵀ`, sparse Cholesky | `direct.rs` |
//! | [`MassScheme::Blended`] | `(1 − γ) M_L + γ M`, sparse Cholesky | `direct.rs` |
//! | [`MassScheme::TruncatedSeries`] | `Σ_{l<k} (I − M_L⁻¹M)^l M_L⁻¹` (FMPM(k)) | `series.rs` |
//! | [`MassScheme::Iterative`] | `M`, conjugate gradient preconditioned by `M_L` | `cg.rs` |
//!
//! Degrees of freedom: for each component (x, y) a solve runs on `F = A \ D`, the active nodes
//! `A` less the nodes `D` whose component is prescribed ([`Constraints`]). Prescribed values
//! `u_D` enter the right-hand side as `r_F − M_FD u_D`; the solution takes `u_D` on `D ∩ A` and
//! 0 on inactive nodes. The active set is one mask ([`GridMass::is_active`]); every list of
//! nodes is derived from it.

use nalgebra_sparse::CscMatrix;

use super::cholesky::SparseCholesky;
use super::matrices::Matrices;
use super::options::{Constraints, MassOptions, MassScheme, SingularityPolicy, SolveOutcome};
use super::stabilization::Stabilization;
use super::{is_active_mass, local_index, lumped_mass_into, singular_error, StencilMass};
use crate::error::{MpmError, Result};
use crate::operators::Operators;
use crate::parallel::Workers;

/// Which of the two solves of a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The velocity projection `v̄ = M⁻¹ q`.
    Velocity,
    /// The acceleration solve `a = M⁻¹ f`.
    Acceleration,
}

/// One component's free degrees of freedom: `free` (ascending) and `local[i]`, the position of
/// node `i` in `free` or `usize::MAX`.
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct Dofs {
    pub(super) free: Vec<usize>,
    pub(super) local: Vec<usize>,
}

impl Dofs {
    /// The active nodes less `fixed`, reusing the buffers (`is_fixed` is work space).
    fn update(&mut self, is_active: &[bool], fixed: &[usize], is_fixed: &mut Vec<bool>) {
        let n = is_active.len();
        is_fixed.clear();
        is_fixed.resize(n, false);
        for &i in fixed.iter().filter(|&&i| i < n) {
            is_fixed[i] = true;
        }
        self.free.clear();
        self.free.extend((0..n).filter(|&i| is_active[i] && !is_fixed[i]));
        self.local = local_index(n, &self.free);
    }

    /// Whether node `i` is active but not free (its component is prescribed).
    pub(super) fn is_prescribed(&self, i: usize, is_active: &[bool]) -> bool {
        is_active[i] && self.local[i] == usize::MAX
    }
}

/// The factorizations of one scheme and what preparing them found.
#[derive(Debug, Default)]
pub(super) struct SchemeSolver {
    /// The matrix weight γ actually factorized (after a regularization), if factorized.
    pub(super) gamma: Option<f64>,
    /// Factors of the x and y components (y unused when both have the same free nodes).
    pub(super) factors: [SparseCholesky; 2],
    pub(super) outcome: SolveOutcome,
}

/// Factorizes `g M + (1 − g) M_L` on the free nodes of each component into `solver` (the y
/// factor only where y has free nodes of its own): the node and scaled pivot of a breakdown.
fn factor_components(
    solver: &mut SchemeSolver,
    matrix: &CscMatrix<f64>,
    lumped: &[f64],
    dofs: &[Dofs; 2],
    g: f64,
    tolerance: f64,
) -> std::result::Result<(), (usize, f64)> {
    let own_y = dofs[1].free != dofs[0].free;
    for c in 0..if own_y { 2 } else { 1 } {
        let d = &dofs[c];
        solver.factors[c]
            .factor(matrix, lumped, g, &d.free, &d.local, tolerance)
            .map_err(|b| (d.free[b.local], b.pivot))?;
    }
    Ok(())
}

/// The grid mass of one step: lumped mass, its inverse and the active nodes, and for schemes
/// other than lumped the consistent matrix and a prepared solver for each of the velocity and
/// acceleration solves ([`GridMass::solve`]).
///
/// [`GridMass::update`] prepares it for a new particle configuration, reusing every buffer:
/// with the lumped mass in both solves nothing is allocated after the first step; the symbolic
/// Cholesky analysis is reused while the sparsity pattern of the matrix is unchanged.
#[derive(Debug, Default)]
pub struct GridMass {
    pub(super) options: MassOptions,
    /// `m_L = N m` at every node.
    pub(super) lumped: Vec<f64>,
    /// `1 / m_L,I` on active nodes, 0 elsewhere.
    pub(super) inverse: Vec<f64>,
    /// The one active set: `m_L,I > tolerance · max m_L` ([`mark_active`](super::mark_active)).
    pub(super) is_active: Vec<bool>,
    /// Whether every node with a positive lumped mass is active.
    every_massive_node_active: bool,
    /// Per block of nodes, work space of [`GridMass::prepare_with`].
    block_counts: Vec<[usize; 2]>,
    /// The nodes whose active flag and `1/m_L` the last preparation wrote.
    prepared: std::ops::Range<usize>,
    /// The prescribed degrees of freedom of the last update.
    pub(super) constraints: Constraints,
    /// Free degrees of freedom of the x and y components (schemes other than lumped).
    pub(super) dofs: [Dofs; 2],
    is_fixed: Vec<bool>,
    /// The consistent mass in the forms the schemes apply it in.
    pub(super) matrices: Matrices,
    pub(super) velocity: SchemeSolver,
    pub(super) acceleration: SchemeSolver,
    /// What the conjugate gradient keeps between the time loop's warm solves
    /// ([`GridMass::solve_warm_into`]).
    pub(super) cg: super::cg::CgState,
    /// The y component's own grid mass when the components see different walls (slip walls
    /// mirrored: [`GridMass::prepare_components`]); this one then solves the x component.
    pub(super) component_y: Option<Box<GridMass>>,
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

    /// Re-prepares for a new configuration: `m_L = N m`, then [`GridMass::prepare`].
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
        if self.lumped.len() != ops.num_nodes() {
            // Refused before the node arrays are made, where this process cannot hold them.
            let n = ops.num_nodes();
            let lumped_only = options.velocity == MassScheme::Lumped && options.acceleration == MassScheme::Lumped;
            let per_node = crate::limits::BYTES_PER_NODE
                + if lumped_only {
                    0.0
                } else {
                    crate::limits::BYTES_PER_NODE_CONSISTENT
                };
            crate::limits::ensure_memory(per_node * n as f64, || {
                format!(
                    "the grid mass (velocity {}, acceleration {}) on {n} nodes",
                    options.velocity, options.acceleration
                )
            })?;
            self.lumped = vec![0.0; n];
        }
        lumped_mass_into(ops, m, &mut self.lumped);
        self.prepare(ops, m, options, constraints)
    }

    /// The lumped mass `m_L` to be filled in place (by the time loop's particle-to-grid pass);
    /// [`GridMass::prepare`] then prepares the solves for it.
    pub fn lumped_mut(&mut self) -> &mut Vec<f64> {
        &mut self.lumped
    }

    /// Prepares the solves for the lumped mass this grid mass holds (from
    /// [`GridMass::update`] or written through [`GridMass::lumped_mut`]): the active set
    /// ([`mark_active`](super::mark_active)), `1/m_L` on it, and for schemes other than lumped the free degrees of
    /// freedom, the consistent matrix in the forms the schemes need, and the factorizations.
    ///
    /// # Errors
    /// As [`GridMass::new`].
    ///
    /// # Panics
    /// If `m.len()` is not the particle count or the lumped mass does not have one entry per
    /// node of `ops`.
    pub fn prepare(
        &mut self,
        ops: &Operators,
        m: &[f64],
        options: &MassOptions,
        constraints: &Constraints,
    ) -> Result<()> {
        let all = 0..ops.num_nodes();
        self.prepare_with(ops, m, options, constraints, all, &Workers::default())
    }

    /// [`GridMass::prepare`] for a lumped mass that is zero outside the nodes `nodes` (the
    /// operators' node span, for the time loop's particle-to-grid pass): the active set and
    /// `1/m_L` written there only (and cleared where the last call wrote them and this one does
    /// not), in blocks of nodes on `workers`' threads (the result does not depend on them).
    pub(crate) fn prepare_with(
        &mut self,
        ops: &Operators,
        m: &[f64],
        options: &MassOptions,
        constraints: &Constraints,
        nodes: std::ops::Range<usize>,
        workers: &Workers,
    ) -> Result<()> {
        let n = ops.num_nodes();
        assert_eq!(self.lumped.len(), n, "one lumped mass per node");
        assert!(nodes.end <= n, "the nodes lie on the grid");
        validate(options)?;
        self.component_y = None;
        self.options = *options;
        self.constraints.fixed_x.clone_from(&constraints.fixed_x);
        self.constraints.fixed_y.clone_from(&constraints.fixed_y);
        if self.is_active.len() != n {
            // Zeroed pages, touched where the nodes need them.
            (self.is_active, self.inverse, self.prepared) = (vec![false; n], vec![0.0; n], 0..0);
        }
        let old = std::mem::replace(&mut self.prepared, nodes.clone());
        for range in [old.start..old.end.min(nodes.start), old.start.max(nodes.end)..old.end] {
            if range.start < range.end {
                self.is_active[range.clone()].fill(false);
                self.inverse[range].fill(0.0);
            }
        }
        // mark_active with 1/m_L beside it: the largest mass (order-free), then the flags.
        let lumped = &self.lumped[nodes.clone()];
        let mut maxima = std::mem::take(&mut self.block_counts);
        workers.blocks(lumped.len(), &mut maxima, |range| {
            // Eight running maxima side by side (the maximum does not depend on the order).
            let mut lanes = [0.0f64; 8];
            let chunks = lumped[range].chunks_exact(8);
            let rest = chunks.remainder();
            for chunk in chunks {
                for (m, &v) in lanes.iter_mut().zip(chunk) {
                    *m = m.max(v);
                }
            }
            let max = rest.iter().chain(&lanes).cloned().fold(0.0, f64::max);
            [max.to_bits() as usize, 0]
        });
        let max = maxima.iter().map(|b| f64::from_bits(b[0] as u64)).fold(0.0, f64::max);
        let threshold = options.active_tolerance * max;
        let out = (&mut self.is_active[nodes.clone()], &mut self.inverse[nodes]);
        workers.split_blocks(out, &mut maxima, |first, (flags, inverse)| {
            let (mut active, mut positive) = (0, 0);
            for (j, (flag, inv)) in flags.iter_mut().zip(inverse.iter_mut()).enumerate() {
                let m = lumped[first + j];
                *flag = is_active_mass(m, threshold);
                *inv = if *flag { 1.0 / m } else { 0.0 };
                active += usize::from(*flag);
                positive += usize::from(m > 0.0);
            }
            [active, positive]
        });
        let [active, positive] = maxima.iter().fold([0, 0], |[a, p], b| [a + b[0], p + b[1]]);
        self.block_counts = maxima;
        self.every_massive_node_active = active == positive;
        self.velocity.outcome = SolveOutcome::Solved;
        self.acceleration.outcome = SolveOutcome::Solved;
        if options.velocity == MassScheme::Lumped && options.acceleration == MassScheme::Lumped {
            self.matrices.clear();
            return Ok(());
        }
        let [dx, dy] = &mut self.dofs;
        dx.update(&self.is_active, &constraints.fixed_x, &mut self.is_fixed);
        dy.update(&self.is_active, &constraints.fixed_y, &mut self.is_fixed);
        self.matrices.assemble(ops, m, options, &self.lumped, &self.is_active);
        self.factorize(Role::Velocity, ops)?;
        if !self.shares_solver() {
            self.factorize(Role::Acceleration, ops)?;
        }
        Ok(())
    }

    /// Whether the prepared solve of `role` substitutes another mass for its scheme's: the
    /// lumped mass after [`SingularityPolicy::FallbackToLumped`], or `(1 − ε) M + ε M_L` after
    /// [`SingularityPolicy::Regularize`], because the matrix was singular at this
    /// configuration. (A conjugate gradient that fails reports it in its [`SolveOutcome`].)
    pub fn substitutes(&self, role: Role) -> bool {
        match self.solver(role).outcome {
            SolveOutcome::Solved => false,
            SolveOutcome::FellBackToLumped { .. } | SolveOutcome::Regularized { .. } => true,
        }
    }

    /// The matrix the solve of `role` inverts, when it bounds the particles' consistent mass
    /// from above and keeps every node's inertia bounded, so that `λ_max(K, M_s)` is a close
    /// upper bound of the update's `ω²_max` ([`crate::stiffness::mpm_mass_bound_frequency_squared`]):
    /// the consistent and iterative schemes with the linear-extension penalty (`M_s = M + P`,
    /// `P` positive semi-definite and of about a full node's mass where a node's support
    /// empties), when the solve substitutes nothing. The other stabilisations also give
    /// `M_s ⪰ M`, but leave a nearly empty row (partial lumping) or a nearly singular direction
    /// (the ghost penalty, at times) where a node's support empties, and there the bound is far
    /// above the update's frequency (15× with partial lumping on the benchmark's random block;
    /// 10⁶× with the ghost penalty at one step): they are left to the exact estimate, as is the
    /// plain consistent mass, whose singularity the solves report.
    pub(crate) fn bounding_mass(&self, role: Role) -> Option<BoundingMass<'_>> {
        // The whole stabilised consistent mass (consistent, cg).
        let scheme_ok = self.scheme(role).consistent_weight() == Some(1.0);
        let stabilization_ok = matches!(self.options.stabilization, Stabilization::LinearExtension { .. });
        let solver = self.solver(role);
        let whole = solver.gamma.is_none_or(|g| g == 1.0);
        // (Per-component masses are left to the exact estimate.)
        if !(scheme_ok && stabilization_ok && whole && !self.substitutes(role)) || self.has_component_masses() {
            return None;
        }
        let stencil = self.matrices.stabilized_stencil()?;
        Some(BoundingMass { stencil })
    }

    /// The mass matrix the solve of `role` stands for, over all nodes:
    ///
    /// ```text
    /// lumped, or after a fall-back to lumped            diag(m_L)
    /// consistent, blended (factorized)                  g M_s + (1 − g) diag(m_L)
    ///     g = 1 (consistent) or γ (blended), times (1 − ε) after a regularisation
    /// conjugate gradient                                M_s
    /// truncated series                                  M (the plain matrix it is defined with)
    /// ```
    ///
    /// with `M_s` the stabilised consistent mass (the plain `M` without a stabilisation).
    pub(crate) fn solved_matrix(&self, role: Role) -> CscMatrix<f64> {
        let diagonal = |scale: f64| lumped_matrix(&self.lumped, scale);
        let solver = self.solver(role);
        if matches!(solver.outcome, SolveOutcome::FellBackToLumped { .. }) {
            return diagonal(1.0);
        }
        let scheme = self.scheme(role);
        let matrix = if scheme.iterative() || scheme.series_terms().is_some() {
            // What the iterations multiply by, in compressed columns or in stencil form.
            self.matrices.operator(scheme).map(|op| op.to_csc())
        } else {
            // A factorized blend of weight γ (none for the lumped mass).
            solver.gamma.and_then(|g| {
                let m = self.matrices.factorized_csc()?;
                Some(if g == 1.0 {
                    m.clone()
                } else {
                    &(m * g) + &diagonal(1.0 - g)
                })
            })
        };
        matrix.unwrap_or_else(|| diagonal(1.0))
    }

    /// The options in force.
    pub fn options(&self) -> MassOptions {
        self.options
    }

    /// The lumped mass `m_L = N m`, one entry per node.
    pub fn lumped(&self) -> &[f64] {
        &self.lumped
    }

    /// `1 / m_L,I` on active nodes, 0 elsewhere.
    pub fn inverse_lumped(&self) -> &[f64] {
        &self.inverse
    }

    /// Whether no node in a particle's support is inactive, known without looking at the
    /// particles: every node of positive mass is active, and the operators have no zero weight
    /// (so that every node in a support has positive mass).
    pub(crate) fn supports_all_active(&self, ops: &Operators) -> bool {
        self.every_massive_node_active && !ops.may_have_zero_weights()
    }

    /// The active set as a mask, one flag per node ([`mark_active`](super::mark_active) of the lumped mass).
    pub fn is_active(&self) -> &[bool] {
        &self.is_active
    }

    /// The active nodes, ascending (derived from [`GridMass::is_active`]).
    pub fn active_nodes(&self) -> Vec<usize> {
        (0..self.is_active.len()).filter(|&i| self.is_active[i]).collect()
    }

    /// Free degrees of freedom of the x and y components: the active nodes less the prescribed
    /// ones, ascending.
    pub fn free_dofs(&self) -> [Vec<usize>; 2] {
        if let Some(y) = &self.component_y {
            let [x, _] = self.own_free_dofs();
            let [_, yy] = y.own_free_dofs();
            return [x, yy];
        }
        self.own_free_dofs()
    }

    fn own_free_dofs(&self) -> [Vec<usize>; 2] {
        let n = self.is_active.len();
        [&self.constraints.fixed_x, &self.constraints.fixed_y].map(|fixed| {
            let mut is_fixed = vec![false; n];
            fixed.iter().filter(|&&i| i < n).for_each(|&i| is_fixed[i] = true);
            (0..n).filter(|&i| self.is_active[i] && !is_fixed[i]).collect()
        })
    }

    /// The plain consistent mass `M = N diag(m) Nᵀ` in compressed-column form, from whichever
    /// form was assembled (built on each call from the stencil form); `None` when no scheme
    /// needed it.
    pub fn consistent_matrix(&self) -> Option<std::borrow::Cow<'_, CscMatrix<f64>>> {
        self.matrices.plain_csc()
    }

    /// The stabilised consistent mass the factorized schemes solve with, when a stabilisation
    /// is in force and the compressed-column matrix was assembled.
    pub fn stabilized_matrix(&self) -> Option<&CscMatrix<f64>> {
        self.matrices.stabilized_csc.as_ref()
    }

    /// The consistent mass in stencil form, when the schemes in use apply it that way (the
    /// conjugate gradient and the truncated series with no or partial-lumping stabilisation).
    pub fn stencil(&self) -> Option<&StencilMass> {
        self.matrices.stencil.as_ref()
    }

    /// Symbolic Cholesky analyses done so far by the solver of `role` (x and y components).
    pub fn symbolic_analyses(&self, role: Role) -> usize {
        let s = self.solver(role);
        s.factors[0].symbolic_analyses() + s.factors[1].symbolic_analyses()
    }

    /// The scheme of `role`.
    pub fn scheme(&self, role: Role) -> MassScheme {
        match role {
            Role::Velocity => self.options.velocity,
            Role::Acceleration => self.options.acceleration,
        }
    }

    pub(super) fn solver(&self, role: Role) -> &SchemeSolver {
        match role {
            Role::Acceleration if !self.shares_solver() => &self.acceleration,
            _ => &self.velocity,
        }
    }

    /// Whether both solves use the same scheme, and so one factorization.
    fn shares_solver(&self) -> bool {
        self.options.velocity == self.options.acceleration
    }

    /// Whether the y component has free nodes of its own (else it shares the x factor).
    pub(super) fn y_has_own_dofs(&self) -> bool {
        self.dofs[1].free != self.dofs[0].free
    }

    /// Applies the singularity policy to a mass that the stable step found nearly singular
    /// (`ratio` its top frequency over the largest single node's, at least
    /// [`crate::simulation::NEARLY_SINGULAR_RATIO`]; `node` where the top mode is largest), as
    /// to a matrix whose factorization broke down, for this step: an error naming the node,
    /// the lumped mass, or `(1 − ε) M_s + ε M_L` (factorized now, for the conjugate gradient too).
    ///
    /// # Errors
    /// [`MpmError::SingularMassMatrix`] under [`SingularityPolicy::Error`], or when even the
    /// regularized matrix is singular.
    pub(crate) fn substitute_nearly_singular(&mut self, node: usize, ratio: f64, ops: &Operators) -> Result<()> {
        if let Some(y) = &mut self.component_y {
            y.substitute_nearly_singular(node, ratio, ops)?;
        }
        let policy = self.options.singularity;
        let roles: &[Role] = if self.shares_solver() {
            &[Role::Velocity]
        } else {
            &[Role::Velocity, Role::Acceleration]
        };
        for &role in roles {
            let Some(gamma) = self.scheme(role).consistent_weight() else {
                continue;
            };
            match policy {
                SingularityPolicy::Error => {
                    return Err(MpmError::SingularMassMatrix {
                        node,
                        particles: ops.particles_touching(node),
                        relative_pivot: f64::NAN,
                        cause: format!(
                            "its highest frequency is {ratio:.3e} times the highest of any single node, so a \
combination of nodes moves with almost no mass and the stable step collapses; {}",
                            super::singular_cause(ops.shape_function())
                        ),
                    })
                }
                SingularityPolicy::FallbackToLumped => {
                    let solver = self.solver_mut(role);
                    solver.gamma = None;
                    solver.outcome = SolveOutcome::FellBackToLumped {
                        node: Some(node),
                        relative_pivot: f64::NAN,
                    };
                }
                SingularityPolicy::Regularize { epsilon } => {
                    let g = gamma * (1.0 - epsilon);
                    let tolerance = self.options.pivot_tolerance;
                    let (lumped, dofs, matrices, solver) = self.factor_parts(role);
                    let matrix = match matrices.factorized_csc() {
                        Some(m) => std::borrow::Cow::Borrowed(m),
                        None => matrices
                            .operator(MassScheme::Consistent)
                            .expect("assembled for the consistent, blended and iterative schemes")
                            .csc(),
                    };
                    factor_components(solver, &matrix, lumped, dofs, g, tolerance)
                        .map_err(|(node, pivot)| singular_error(node, pivot, ops))?;
                    solver.gamma = Some(g);
                    solver.outcome = SolveOutcome::Regularized {
                        node: Some(node),
                        epsilon,
                    };
                }
            }
        }
        Ok(())
    }

    /// What a factorization of `role` reads (the lumped mass, the free nodes, the matrices) and
    /// the solver it writes.
    fn factor_parts(&mut self, role: Role) -> (&[f64], &[Dofs; 2], &Matrices, &mut SchemeSolver) {
        let GridMass {
            lumped,
            dofs,
            matrices,
            velocity,
            acceleration,
            ..
        } = self;
        let solver = match role {
            Role::Velocity => velocity,
            Role::Acceleration => acceleration,
        };
        (lumped, dofs, matrices, solver)
    }

    fn solver_mut(&mut self, role: Role) -> &mut SchemeSolver {
        match role {
            Role::Acceleration if !self.shares_solver() => &mut self.acceleration,
            _ => &mut self.velocity,
        }
    }

    /// Factorizes what the scheme of `role` needs, applying the singularity policy.
    fn factorize(&mut self, role: Role, ops: &Operators) -> Result<()> {
        let scheme = self.scheme(role);
        let gamma = scheme.consistent_weight().filter(|_| scheme.factorized());
        let (policy, pivot_tolerance) = (self.options.singularity, self.options.pivot_tolerance);
        let (lumped, dofs, matrices, solver) = self.factor_parts(role);
        solver.gamma = None;
        let Some(gamma) = gamma else { return Ok(()) };
        // Factorized schemes are never the series: the stabilised matrix when there is one.
        let matrix = matrices.factorized_csc().expect("assembled for factorized schemes");
        let factor_both = |s: &mut SchemeSolver, g: f64| factor_components(s, matrix, lumped, dofs, g, pivot_tolerance);
        match factor_both(solver, gamma) {
            Ok(()) => solver.gamma = Some(gamma),
            Err((node, pivot)) => match policy {
                SingularityPolicy::Error => return Err(singular_error(node, pivot, ops)),
                SingularityPolicy::FallbackToLumped => {
                    solver.outcome = SolveOutcome::FellBackToLumped {
                        node: Some(node),
                        relative_pivot: pivot,
                    };
                }
                SingularityPolicy::Regularize { epsilon } => {
                    let g = gamma * (1.0 - epsilon);
                    factor_both(solver, g).map_err(|(node, pivot)| singular_error(node, pivot, ops))?;
                    solver.gamma = Some(g);
                    solver.outcome = SolveOutcome::Regularized {
                        node: Some(node),
                        epsilon,
                    };
                }
            },
        }
        Ok(())
    }

    /// Replaces the lumped mass (resuming from a checkpoint: what [`GridMass::lumped`] shows
    /// until the next step prepares the grid mass again).
    pub(crate) fn set_lumped(&mut self, lumped: Vec<f64>) {
        self.lumped = lumped;
    }
}

/// Checks the scheme parameters, the tolerances and the singularity policy
/// ([`MassOptions::validate`]).
fn validate(options: &MassOptions) -> Result<()> {
    options.velocity.validate()?;
    options.acceleration.validate()?;
    options.stabilization.validate()?;
    for (name, value, reason) in [
        (
            "active_tolerance",
            options.active_tolerance,
            "the relative lumped mass of an inactive node must lie in [0, 1)",
        ),
        (
            "pivot_tolerance",
            options.pivot_tolerance,
            "the scaled Cholesky pivot of a singular matrix must lie in [0, 1)",
        ),
    ] {
        if !(0.0..1.0).contains(&value) {
            return Err(MpmError::InvalidParameter { name, value, reason });
        }
    }
    if let SingularityPolicy::Regularize { epsilon } = options.singularity {
        if !(epsilon > 0.0 && epsilon <= 1.0) {
            return Err(MpmError::InvalidParameter {
                name: "epsilon",
                value: epsilon,
                reason: "the regularization weight must lie in (0, 1]",
            });
        }
    }
    Ok(())
}

impl MassOptions {
    /// Checks every choice: the schemes' parameters (a blend weight in [0, 1], a series of 1 to
    /// [`super::MAX_SERIES_TERMS`] terms, CG within [`super::MAX_CG_ITERATIONS`]), the
    /// stabilization, `active_tolerance` and `pivot_tolerance` in [0, 1), a regularization
    /// weight in (0, 1]: the bounds a scene file is held to.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] naming the parameter and its value.
    pub fn validate(&self) -> Result<()> {
        validate(self)
    }
}

/// The matrix of [`GridMass::bounding_mass`] in stencil form, with its penalty `R` recorded, so
/// that `M_s = M + R`.
pub(crate) struct BoundingMass<'a> {
    stencil: &'a super::StencilMass,
}

impl<'a> BoundingMass<'a> {
    /// `M_s` in stencil form, its penalty `R` recorded ([`super::StencilMass::penalty_product`]).
    pub(crate) fn stencil(&self) -> &'a super::StencilMass {
        self.stencil
    }
}

/// `scale · diag(m_L)`.
pub(crate) fn lumped_matrix(lumped: &[f64], scale: f64) -> CscMatrix<f64> {
    let n = lumped.len();
    let mut coo = nalgebra_sparse::CooMatrix::new(n, n);
    for (i, &m) in lumped.iter().enumerate() {
        if m != 0.0 {
            coo.push(i, i, scale * m);
        }
    }
    CscMatrix::from(&coo)
}
