//! Grid mass: lumped and consistent mass matrices, the active nodes, and the consistent-mass
//! solve.
//!
//! ```text
//! m_L = N m                      (n-vector: nodal lumped mass, the row sums of M)
//! M   = N diag(m) Nᵀ             (n × n, symmetric positive semi-definite)
//! ```
//!
//! A node is **active** when its lumped mass is above `tolerance · max_I m_L,I`
//! ([`DEFAULT_ACTIVE_MASS_TOLERANCE`] unless the caller says otherwise). Velocities and
//! accelerations are computed on active nodes only and are exactly zero elsewhere, never NaN.
//!
//! The consistent solve `M_AA a_A = f_A` on the active set `A` uses faer's sparse Cholesky
//! (`LLᵀ`) factorization of the Jacobi-scaled matrix `D^{-1/2} M_AA D^{-1/2}`,
//! `D = diag(M_AA)`, whose pivots are the fractions of each node's own mass that its
//! neighbours do not already account for. A pivot at or below
//! [`ConsistentSolveOptions::pivot_tolerance`] means `M_AA` is singular or so close to it that
//! a solve would return garbage: that is an error naming the node, never a silent result.

use nalgebra_sparse::CscMatrix;

use crate::error::{MpmError, Result};
use crate::operators::{Operator, Operators};
use crate::shape::ShapeFunction;

mod cg;
mod cholesky;
mod components;
mod diagnostics;
mod direct;
pub mod extension;
mod grid_mass;
mod lumped;
mod matrices;
mod options;
mod series;
mod solve;
pub use solve::ESTIMATE_SOLVE_TOLERANCE;
pub mod stabilization;
mod stencil;

pub(crate) use cholesky::SparseCholesky;
pub use diagnostics::{solve_condition_number, MassDiagnostics, TINY_MASS_FRACTION};
pub(crate) use grid_mass::lumped_matrix;
pub(crate) use grid_mass::BoundingMass;
pub use grid_mass::{GridMass, Role};
pub(crate) use matrices::csc_times;
pub use options::{
    Constraints, MassOptions, MassScheme, SingularityPolicy, SolveOutcome, SolveReport, DEFAULT_CG_MAX_ITERATIONS,
    DEFAULT_CG_TOLERANCE, MAX_CG_ITERATIONS, MAX_SERIES_TERMS,
};
pub use series::{series_velocity_into, SeriesOperator, SeriesScratch};
pub use stabilization::Stabilization;
pub use stencil::StencilMass;

/// Default relative mass below which a node is inactive: `m_L,I ≤ 1e-12 · max m_L`. A node
/// that light carries less than a trillionth of the heaviest node's mass; its velocity is set
/// to zero, which changes particle velocities by at most that fraction.
pub const DEFAULT_ACTIVE_MASS_TOLERANCE: f64 = 1e-12;

/// Nodal lumped mass, the seed's `M̄(n) = Σ_p N(n,p) m(p)`:
///
/// ```text
/// m_L = N m           (n-vector = (n × P) · P-vector)
/// ```
///
/// Equal to the row sums of the consistent mass matrix because the shape functions sum to one.
///
/// # Panics
/// If `m.len()` is not the particle count.
pub fn lumped_mass(ops: &Operators, m: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; ops.num_nodes()];
    lumped_mass_into(ops, m, &mut out);
    out
}

/// [`lumped_mass`] into a preallocated n-vector.
///
/// # Panics
/// On length mismatch.
pub fn lumped_mass_into(ops: &Operators, m: &[f64], out: &mut [f64]) {
    ops.scatter(Operator::N, [m], [out]);
}

/// The consistent mass matrix, the seed's `m̄(n,n') = Σ_p N(n',p) N(n,p) m(p)`:
///
/// ```text
/// M = N diag(m) Nᵀ    (n × n sparse, symmetric; M[I,J] ≠ 0 only if some particle touches both I and J)
/// ```
///
/// Nodes touched by no particle have empty rows and columns. Assembled in stencil form
/// ([`StencilMass`]) from the operators' factored columns; [`crate::operators::weighted_product`] with
/// `(N, N, m)` gives the same matrix by a general sparse product (equal up to the order of the
/// sums).
///
/// # Panics
/// If `m.len()` is not the particle count.
pub fn consistent_mass(ops: &Operators, m: &[f64]) -> CscMatrix<f64> {
    StencilMass::assemble(ops, m).to_csc()
}

/// The active nodes: those with `m_L,I > tolerance · max_J m_L,J`, ascending (the nodes
/// [`mark_active`] marks).
pub fn active_nodes(lumped: &[f64], tolerance: f64) -> Vec<usize> {
    let mut is_active = vec![false; lumped.len()];
    mark_active(lumped, tolerance, &mut is_active);
    (0..lumped.len()).filter(|&i| is_active[i]).collect()
}

/// The one definition of the active set, as a mask:
///
/// ```text
/// active_I  ⇔  m_L,I > tolerance · max_J m_L,J  and  m_L,I > 0
/// ```
///
/// Returns the number of active nodes.
///
/// # Panics
/// If `is_active` does not have one entry per node.
pub fn mark_active(lumped: &[f64], tolerance: f64, is_active: &mut [bool]) -> usize {
    assert_eq!(lumped.len(), is_active.len(), "one flag per node");
    let threshold = tolerance * lumped.iter().cloned().fold(0.0, f64::max);
    let mut active = 0;
    for (flag, &m) in is_active.iter_mut().zip(lumped) {
        *flag = is_active_mass(m, threshold);
        active += usize::from(*flag);
    }
    active
}

/// Whether a node of lumped mass `m` is active under the threshold `tolerance · max m_L`: the
/// one definition of [`mark_active`] and the time loop's grid mass.
#[inline(always)]
pub(crate) fn is_active_mass(m: f64, threshold: f64) -> bool {
    m > threshold && m > 0.0
}

/// Options of the consistent-mass solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConsistentSolveOptions {
    /// A Cholesky pivot of the Jacobi-scaled matrix at or below this value (the part of a
    /// node's own mass not already accounted for by its neighbours) marks the matrix as
    /// singular. The solve's relative error grows like `machine epsilon / pivot`, so the
    /// default [`DEFAULT_PIVOT_TOLERANCE`] keeps it below about `1e-6`.
    pub pivot_tolerance: f64,
}

/// Default pivot tolerance of the Cholesky singularity check.
pub const DEFAULT_PIVOT_TOLERANCE: f64 = 1e-10;

impl Default for ConsistentSolveOptions {
    fn default() -> Self {
        ConsistentSolveOptions {
            pivot_tolerance: DEFAULT_PIVOT_TOLERANCE,
        }
    }
}

/// A Cholesky factorization of the consistent mass matrix restricted to a set of nodes (the
/// active nodes, less any fixed ones), ready to solve `M_AA x_A = b_A` for any number of
/// right-hand sides.
#[derive(Debug)]
pub struct ConsistentMassSolver {
    num_nodes: usize,
    factor: SparseCholesky,
}

impl ConsistentMassSolver {
    /// Factorizes `M_AA`, the consistent mass matrix `mass` (n × n, from [`consistent_mass`])
    /// restricted to the nodes `active` (ascending, e.g. from [`active_nodes`]).
    ///
    /// # Errors
    /// [`MpmError::SingularMassMatrix`] naming the node (grid numbering) where the
    /// factorization breaks down and the particles touching it.
    ///
    /// # Panics
    /// If `mass` is not square, an active node is out of range, or `active` is not ascending.
    pub fn new(
        mass: &CscMatrix<f64>,
        active: &[usize],
        ops: &Operators,
        options: ConsistentSolveOptions,
    ) -> Result<ConsistentMassSolver> {
        let n = mass.nrows();
        assert_eq!(n, mass.ncols(), "the mass matrix must be square");
        assert!(active.windows(2).all(|w| w[0] < w[1]), "active nodes must be ascending");
        let local = local_index(n, active);
        let mut factor = SparseCholesky::default();
        // γ = 1: the lumped mass is not used.
        let no_lumped = vec![0.0; n];
        factor
            .factor(mass, &no_lumped, 1.0, active, &local, options.pivot_tolerance)
            .map_err(|b| singular_error(active[b.local], b.pivot, ops))?;
        Ok(ConsistentMassSolver { num_nodes: n, factor })
    }

    /// The nodes the solver works on.
    pub fn active_nodes(&self) -> &[usize] {
        self.factor.dofs()
    }

    /// Solves `M_AA x_A = b_A` for each right-hand side `b` (an n-vector over all nodes) in
    /// place; entries outside the solver's nodes are set to 0.
    ///
    /// # Panics
    /// If a right-hand side's length is not the node count.
    pub fn solve_in_place<const K: usize>(&self, rhs: [&mut [f64]; K]) {
        let dofs = self.factor.dofs();
        let mut local: Vec<Vec<f64>> = rhs
            .iter()
            .map(|b| {
                assert_eq!(b.len(), self.num_nodes, "right-hand side must have one entry per node");
                dofs.iter().map(|&i| b[i]).collect()
            })
            .collect();
        self.factor.solve_in_place(&mut local);
        for (b, x) in rhs.into_iter().zip(&local) {
            b.fill(0.0);
            for (&i, v) in dofs.iter().zip(x) {
                b[i] = *v;
            }
        }
    }

    /// Solves `M_AA x_A = b_A` for one right-hand side, returning `x` (0 outside the solver's
    /// nodes).
    ///
    /// # Panics
    /// If `b.len()` is not the node count.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x = b.to_vec();
        self.solve_in_place([&mut x]);
        x
    }
}

/// `local[i]` = position of node `i` in `dofs`, or `usize::MAX`.
pub(crate) fn local_index(n: usize, dofs: &[usize]) -> Vec<usize> {
    let mut local = vec![usize::MAX; n];
    for (k, &i) in dofs.iter().enumerate() {
        local[i] = k;
    }
    local
}

/// What the library says about a singular mass matrix with shape functions `shape`: why (in
/// the words of the kernel), and the remedies by the scene keys that choose them.
pub(crate) fn singular_cause(shape: ShapeFunction) -> String {
    let example = shape.singular_mass_example();
    format!(
        "the particles touching this node do not determine its motion independently of its neighbours' (a consistent \
mass matrix needs, in every group of nodes, at least as many particles in general position as nodes: {example}). \
Use the lumped mass, more particles per cell (`bodies[k].particles_per_cell`), a blended mass \
(`schemes.mass.velocity`, `.acceleration` = \"blended:0.5\"), or a singularity policy: \
`schemes.mass.singularity = \"fallback_to_lumped\"` or `{{ regularize = {{ epsilon = 0.1 }} }}` \
(in Rust, `SingularityPolicy::FallbackToLumped` or `SingularityPolicy::Regularize {{ epsilon }}`)"
    )
}

/// The error of a singular mass matrix at `node`, with the particles touching it.
pub(crate) fn singular_error(node: usize, relative_pivot: f64, ops: &Operators) -> MpmError {
    MpmError::SingularMassMatrix {
        node,
        particles: ops.particles_touching(node),
        relative_pivot,
        cause: singular_cause(ops.shape_function()),
    }
}
