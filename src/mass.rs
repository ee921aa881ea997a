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

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::mat::MatMut;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};
use nalgebra_sparse::CscMatrix;

use crate::error::{MpmError, Result};
use crate::operators::{Operator, Operators};

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
/// Built column by column (Gustavson's SpGEMM through the transpose pattern of N), with
/// sorted row indices. Nodes touched by no particle have empty rows and columns.
///
/// # Panics
/// If `m.len()` is not the particle count.
pub fn consistent_mass(ops: &Operators, m: &[f64]) -> CscMatrix<f64> {
    let (n, np) = (ops.num_nodes(), ops.num_particles());
    assert_eq!(m.len(), np, "mass must have one entry per particle");
    let (cp, ri, nv) = (ops.col_offsets(), ops.row_indices(), ops.values(Operator::N));
    // Row pattern of N (= columns of Nᵀ): for each node, the entries (particle, value) touching it.
    let mut row_ptr = vec![0usize; n + 1];
    for &i in ri {
        row_ptr[i + 1] += 1;
    }
    for i in 0..n {
        row_ptr[i + 1] += row_ptr[i];
    }
    let mut fill = row_ptr.clone();
    let mut row_entry = vec![0usize; ri.len()];
    for p in 0..np {
        for e in cp[p]..cp[p + 1] {
            let i = ri[e];
            row_entry[fill[i]] = e;
            fill[i] += 1;
        }
    }
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0);
    let mut rows = Vec::new();
    let mut vals = Vec::new();
    let mut work = vec![0.0f64; n];
    let mut marker = vec![usize::MAX; n];
    let mut touched = Vec::new();
    for j in 0..n {
        touched.clear();
        for &ej in &row_entry[row_ptr[j]..row_ptr[j + 1]] {
            let p = particle_of_entry(cp, ej);
            let w = m[p] * nv[ej];
            for e in cp[p]..cp[p + 1] {
                let i = ri[e];
                if marker[i] != j {
                    marker[i] = j;
                    work[i] = 0.0;
                    touched.push(i);
                }
                work[i] += w * nv[e];
            }
        }
        touched.sort_unstable();
        for &i in &touched {
            rows.push(i);
            vals.push(work[i]);
        }
        col_ptr.push(rows.len());
    }
    CscMatrix::try_from_csc_data(n, n, col_ptr, rows, vals).expect("rows are sorted and in range")
}

/// The column (particle) that stored entry `e` belongs to.
fn particle_of_entry(col_ptr: &[usize], e: usize) -> usize {
    col_ptr.partition_point(|&c| c <= e) - 1
}

/// The active nodes: those with `m_L,I > tolerance · max_J m_L,J`, ascending.
pub fn active_nodes(lumped: &[f64], tolerance: f64) -> Vec<usize> {
    let max = lumped.iter().cloned().fold(0.0, f64::max);
    let threshold = tolerance * max;
    (0..lumped.len())
        .filter(|&i| lumped[i] > threshold && lumped[i] > 0.0)
        .collect()
}

/// `a_I = f_I / m_L,I` on active nodes, 0 elsewhere: the lumped solve of `M_L a = f`.
///
/// # Panics
/// On length mismatch.
pub fn divide_by_lumped_mass(f: &[f64], lumped: &[f64], active: &[usize]) -> Vec<f64> {
    assert_eq!(f.len(), lumped.len(), "one value per node");
    let mut a = vec![0.0; f.len()];
    for &i in active {
        a[i] = f[i] / lumped[i];
    }
    a
}

/// Options of the consistent-mass solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConsistentSolveOptions {
    /// A Cholesky pivot of the Jacobi-scaled matrix at or below this value (the part of a
    /// node's own mass not already accounted for by its neighbours) marks `M_AA` as singular.
    /// The solve's relative error grows like `machine epsilon / pivot`, so the default `1e-10`
    /// keeps it below about `1e-6`.
    pub pivot_tolerance: f64,
}

impl Default for ConsistentSolveOptions {
    fn default() -> Self {
        ConsistentSolveOptions { pivot_tolerance: 1e-10 }
    }
}

/// A Cholesky factorization of the consistent mass matrix restricted to the active nodes,
/// ready to solve `M_AA x_A = b_A` for any number of right-hand sides.
#[derive(Debug)]
pub struct ConsistentMassSolver {
    num_nodes: usize,
    active: Vec<usize>,
    /// `1/√M_II` for each active node, in active order.
    inv_sqrt_diag: Vec<f64>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
}

impl ConsistentMassSolver {
    /// Factorizes `M_AA`, the consistent mass matrix `mass` (n × n, from [`consistent_mass`])
    /// restricted to the nodes `active` (ascending, e.g. from [`active_nodes`]).
    ///
    /// # Errors
    /// [`MpmError::SingularMassMatrix`] naming the node (grid numbering) where the
    /// factorization breaks down and the particles touching it; [`MpmError::Solver`] if faer
    /// fails for another reason.
    ///
    /// # Panics
    /// If `mass` is not square or an active node is out of range.
    pub fn new(
        mass: &CscMatrix<f64>,
        active: &[usize],
        ops: &Operators,
        options: ConsistentSolveOptions,
    ) -> Result<ConsistentMassSolver> {
        let n = mass.nrows();
        assert_eq!(n, mass.ncols(), "the mass matrix must be square");
        let mut local = vec![usize::MAX; n];
        for (k, &i) in active.iter().enumerate() {
            local[i] = k;
        }
        // Diagonal of M_AA.
        let diag: Vec<f64> = active
            .iter()
            .map(|&i| {
                let col = mass.col(i);
                col.row_indices()
                    .iter()
                    .position(|&r| r == i)
                    .map_or(0.0, |k| col.values()[k])
            })
            .collect();
        if let Some(k) = diag.iter().position(|&d| d.is_nan() || d <= 0.0) {
            return Err(singular(
                active[k],
                0.0,
                ops,
                "the node is active but has no mass on the diagonal",
            ));
        }
        let inv_sqrt_diag: Vec<f64> = diag.iter().map(|d| 1.0 / d.sqrt()).collect();
        // Upper triangle of the scaled M_AA in CSC form.
        let na = active.len();
        let mut col_ptr = Vec::with_capacity(na + 1);
        col_ptr.push(0usize);
        let mut row_idx = Vec::new();
        let mut vals = Vec::new();
        for (kj, &j) in active.iter().enumerate() {
            let col = mass.col(j);
            for (&i, &v) in col.row_indices().iter().zip(col.values()) {
                let ki = local[i];
                if ki != usize::MAX && ki <= kj {
                    row_idx.push(ki);
                    vals.push(v * inv_sqrt_diag[ki] * inv_sqrt_diag[kj]);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let sym = SymbolicSparseColMatRef::new_checked(na, na, &col_ptr, None, &row_idx);
        let a = SparseColMatRef::new(sym, &vals);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams {
                // Simplicial storage puts each pivot first in its column of L, where the
                // singularity check reads it.
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
                ..Default::default()
            },
        )
        .map_err(|e| MpmError::Solver {
            reason: format!("{e:?}"),
        })?;
        let mut l_values = vec![0.0; symbolic.len_val()];
        let mut mem = MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        let result = symbolic.factorize_numeric_llt(
            &mut l_values,
            a,
            Side::Upper,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        );
        let perm_fwd: Vec<usize> = match symbolic.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..na).collect(),
        };
        let cause = "the particles touching this node do not determine its motion independently of \
                     its neighbours' (a consistent mass matrix needs, in every group of nodes, at least \
                     as many particles in general position as nodes: one particle in a bilinear cell is \
                     not enough). Use lumped mass, more particles per cell, or a blended mass";
        match result {
            Ok(_) => {}
            Err(LltError::NonPositivePivot { index }) => {
                // faer reports a 1-based position in the fill-reducing order.
                let k = perm_fwd[index.saturating_sub(1).min(na - 1)];
                return Err(singular(active[k], 0.0, ops, cause));
            }
        }
        if let SymbolicCholeskyRaw::Simplicial(s) = symbolic.raw() {
            let (lcp, lri) = (s.col_ptr(), s.row_idx());
            for jp in 0..na {
                let e = lcp[jp];
                debug_assert_eq!(lri[e], jp, "simplicial L stores the diagonal first");
                let pivot = l_values[e] * l_values[e];
                if pivot <= options.pivot_tolerance {
                    return Err(singular(active[perm_fwd[jp]], pivot, ops, cause));
                }
            }
        }
        Ok(ConsistentMassSolver {
            num_nodes: n,
            active: active.to_vec(),
            inv_sqrt_diag,
            symbolic,
            l_values,
        })
    }

    /// The active nodes the solver works on.
    pub fn active_nodes(&self) -> &[usize] {
        &self.active
    }

    /// Solves `M_AA x_A = b_A` for each right-hand side `b` (an n-vector over all nodes) in
    /// place; entries at inactive nodes are set to 0.
    ///
    /// # Panics
    /// If a right-hand side's length is not the node count.
    pub fn solve_in_place<const K: usize>(&self, rhs: [&mut [f64]; K]) {
        let na = self.active.len();
        let mut x = faer::Mat::<f64>::zeros(na, K);
        for (k, b) in rhs.iter().enumerate() {
            assert_eq!(b.len(), self.num_nodes, "right-hand side must have one entry per node");
            for (a, &i) in self.active.iter().enumerate() {
                x[(a, k)] = b[i] * self.inv_sqrt_diag[a];
            }
        }
        let llt = LltRef::new(&self.symbolic, &self.l_values);
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(K, Par::Seq));
        let xm: MatMut<'_, f64> = x.as_mut();
        llt.solve_in_place_with_conj(Conj::No, xm, Par::Seq, MemStack::new(&mut mem));
        for (k, b) in rhs.into_iter().enumerate() {
            b.fill(0.0);
            for (a, &i) in self.active.iter().enumerate() {
                b[i] = x[(a, k)] * self.inv_sqrt_diag[a];
            }
        }
    }

    /// Solves `M_AA x_A = b_A` for one right-hand side, returning `x` (0 at inactive nodes).
    ///
    /// # Panics
    /// If `b.len()` is not the node count.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x = b.to_vec();
        self.solve_in_place([&mut x]);
        x
    }
}

fn singular(node: usize, relative_pivot: f64, ops: &Operators, cause: &str) -> MpmError {
    MpmError::SingularMassMatrix {
        node,
        particles: ops.particles_touching(node),
        relative_pivot,
        cause: cause.to_string(),
    }
}

/// Which mass matrix a grid solve uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MassChoice {
    /// Divide by the lumped mass `m_L = N m`.
    #[default]
    Lumped,
    /// Solve with the consistent mass `M = N diag(m) Nᵀ` on the active nodes (sparse Cholesky).
    Consistent,
}

/// The grid mass of one step, ready to turn momenta into velocities and forces into
/// accelerations: `u = M⁻¹ r` with `M` lumped or consistent, on the active nodes.
#[derive(Debug)]
pub struct GridMass {
    /// Lumped mass `m_L = N m` at every node.
    pub lumped: Vec<f64>,
    /// Active nodes (ascending).
    pub active: Vec<usize>,
    /// The consistent mass matrix and its factorization, when [`MassChoice::Consistent`].
    pub consistent: Option<(CscMatrix<f64>, ConsistentMassSolver)>,
}

impl GridMass {
    /// Builds the grid mass: lumped mass and active nodes always; with
    /// [`MassChoice::Consistent`] also `M` and its Cholesky factorization on the active nodes.
    ///
    /// # Errors
    /// [`MpmError::SingularMassMatrix`] when the consistent mass is singular on the active nodes.
    ///
    /// # Panics
    /// If `m.len()` is not the particle count.
    pub fn new(
        ops: &Operators,
        m: &[f64],
        choice: MassChoice,
        active_tolerance: f64,
        options: ConsistentSolveOptions,
    ) -> Result<GridMass> {
        let lumped = lumped_mass(ops, m);
        let active = active_nodes(&lumped, active_tolerance);
        let consistent = match choice {
            MassChoice::Lumped => None,
            MassChoice::Consistent => {
                let matrix = consistent_mass(ops, m);
                let solver = ConsistentMassSolver::new(&matrix, &active, ops, options)?;
                Some((matrix, solver))
            }
        };
        Ok(GridMass {
            lumped,
            active,
            consistent,
        })
    }

    /// `u = M⁻¹ r` on the active nodes (0 elsewhere), with the chosen mass.
    ///
    /// # Panics
    /// If `r` does not have one entry per node.
    pub fn solve(&self, r: &crate::transfer::VectorField) -> crate::transfer::VectorField {
        match &self.consistent {
            None => crate::transfer::divide_by_lumped(r, &self.lumped, &self.active),
            Some((_, solver)) => crate::transfer::solve_consistent(r, solver),
        }
    }
}
