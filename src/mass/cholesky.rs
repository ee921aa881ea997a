//! Sparse Cholesky factorization of a (blended) mass matrix on a set of degrees of freedom,
//! with Jacobi scaling, a pivot check that names where it breaks down, and reuse of the
//! symbolic analysis while the sparsity pattern is unchanged.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};
use nalgebra_sparse::CscMatrix;

/// Value a regularized factorization puts in place of a tiny pivot (see `count_small_pivots`).
const REPLACED_PIVOT: f64 = 4.0;

/// Where a factorization broke down: the position in `dofs` and the scaled pivot there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Breakdown {
    pub local: usize,
    pub pivot: f64,
}

/// `LLᵀ` of `D^{-1/2} A D^{-1/2}`, `A = γ M_FF + (1 − γ) diag(m_L)_FF`, `D = diag(A)`.
#[derive(Debug, Default)]
pub(crate) struct SparseCholesky {
    dofs: Vec<usize>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    inv_sqrt_diag: Vec<f64>,
    symbolic: Option<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
    perm_fwd: Vec<usize>,
    symbolic_analyses: usize,
}

impl SparseCholesky {
    /// Number of symbolic analyses done so far (one per distinct pattern).
    pub fn symbolic_analyses(&self) -> usize {
        self.symbolic_analyses
    }

    /// The degrees of freedom (global node numbers, ascending) of the last factorization.
    pub fn dofs(&self) -> &[usize] {
        &self.dofs
    }

    /// Factorizes `A` restricted to `dofs`. `local[i]` is the position of global node `i` in
    /// `dofs` or `usize::MAX`. Reuses the symbolic analysis when the pattern is unchanged.
    pub fn factor(
        &mut self,
        m: &CscMatrix<f64>,
        lumped: &[f64],
        gamma: f64,
        dofs: &[usize],
        local: &[usize],
        pivot_tolerance: f64,
    ) -> Result<(), Breakdown> {
        let entry = |i: usize, j: usize, v: f64| {
            if i == j {
                gamma * v + (1.0 - gamma) * lumped[i]
            } else {
                gamma * v
            }
        };
        self.scale(m, dofs, &entry)?;
        let same_pattern = self.assemble_upper(m, dofs, local, &entry);
        if !same_pattern {
            self.analyse(dofs);
        }
        self.factor_numeric(pivot_tolerance)
    }

    /// `D^{-1/2}` of `A = entry(M)` on `dofs`: a non-positive diagonal is a breakdown there.
    fn scale(
        &mut self,
        m: &CscMatrix<f64>,
        dofs: &[usize],
        entry: &impl Fn(usize, usize, f64) -> f64,
    ) -> Result<(), Breakdown> {
        self.inv_sqrt_diag.clear();
        for (k, &j) in dofs.iter().enumerate() {
            let col = m.col(j);
            let mjj = col
                .row_indices()
                .iter()
                .position(|&r| r == j)
                .map_or(0.0, |e| col.values()[e]);
            let d = entry(j, j, mjj);
            if d.is_nan() || d <= 0.0 {
                return Err(Breakdown { local: k, pivot: 0.0 });
            }
            self.inv_sqrt_diag.push(1.0 / d.sqrt());
        }
        Ok(())
    }

    /// The upper triangle of the scaled `A` in compressed columns; whether its pattern is the
    /// one of the last factorization.
    fn assemble_upper(
        &mut self,
        m: &CscMatrix<f64>,
        dofs: &[usize],
        local: &[usize],
        entry: &impl Fn(usize, usize, f64) -> f64,
    ) -> bool {
        let same_dofs = self.symbolic.is_some() && self.dofs == dofs;
        let (old_ptr, old_idx) = (std::mem::take(&mut self.col_ptr), std::mem::take(&mut self.row_idx));
        self.col_ptr.push(0);
        self.values.clear();
        for (kj, &j) in dofs.iter().enumerate() {
            let col = m.col(j);
            for (&i, &v) in col.row_indices().iter().zip(col.values()) {
                let ki = local[i];
                if ki != usize::MAX && ki <= kj {
                    self.row_idx.push(ki);
                    self.values
                        .push(entry(i, j, v) * self.inv_sqrt_diag[ki] * self.inv_sqrt_diag[kj]);
                }
            }
            self.col_ptr.push(self.row_idx.len());
        }
        same_dofs && old_ptr == self.col_ptr && old_idx == self.row_idx
    }

    /// The symbolic analysis (fill-reducing order and the factor's structure) of the pattern
    /// just assembled.
    fn analyse(&mut self, dofs: &[usize]) {
        let nf = dofs.len();
        self.dofs = dofs.to_vec();
        let sym = SymbolicSparseColMatRef::new_checked(nf, nf, &self.col_ptr, None, &self.row_idx);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Upper,
            SymmetricOrdering::Amd,
            // faer picks simplicial or supernodal storage by the flop ratio (supernodal
            // for the grid-sized matrices of a time loop); `pivots` reads either.
            CholeskySymbolicParams::default(),
        )
        .expect("symbolic Cholesky analysis only fails when out of memory");
        self.perm_fwd = match symbolic.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..nf).collect(),
        };
        self.l_values = vec![0.0; symbolic.len_val()];
        self.symbolic = Some(symbolic);
        self.symbolic_analyses += 1;
    }

    /// The numeric factorization into the kept buffers, and the pivot check: the first pivot
    /// at or below `pivot_tolerance` (in the fill-reducing order) is a breakdown.
    fn factor_numeric(&mut self, pivot_tolerance: f64) -> Result<(), Breakdown> {
        let nf = self.dofs.len();
        let symbolic = self.symbolic.as_ref().expect("analysed before");
        let sym = SymbolicSparseColMatRef::new_checked(nf, nf, &self.col_ptr, None, &self.row_idx);
        let a = SparseColMatRef::new(sym, &self.values);
        let mut mem = MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        let result = symbolic.factorize_numeric_llt(
            &mut self.l_values,
            a,
            Side::Upper,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        );
        if let Err(LltError::NonPositivePivot { index }) = result {
            // faer reports a 1-based position in the fill-reducing order.
            let k = self.perm_fwd[index.saturating_sub(1).min(nf - 1)];
            return Err(Breakdown { local: k, pivot: 0.0 });
        }
        let mut breakdown = None;
        pivots(symbolic, &self.l_values, |jp, l| {
            let pivot = l * l;
            if breakdown.is_none() && pivot <= pivot_tolerance {
                breakdown = Some(Breakdown {
                    local: self.perm_fwd[jp],
                    pivot,
                });
            }
        });
        breakdown.map_or(Ok(()), Err)
    }

    /// Number of pivots at or below `tolerance` in a factorization that replaces each such
    /// pivot by 4 and goes on: an estimate of the nullity of the last matrix passed to
    /// [`SparseCholesky::factor`]. (Pivots of the Jacobi-scaled positive semi-definite matrix
    /// never exceed 1, so a diagonal entry of exactly `√4 = 2` in L marks a replaced pivot.)
    pub fn count_small_pivots(&self, tolerance: f64) -> usize {
        let Some(symbolic) = self.symbolic.as_ref() else {
            return 0;
        };
        let nf = self.dofs.len();
        let sym = SymbolicSparseColMatRef::new_checked(nf, nf, &self.col_ptr, None, &self.row_idx);
        let a = SparseColMatRef::new(sym, &self.values);
        let mut l = vec![0.0; symbolic.len_val()];
        let mut mem = MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        let regularization = LltRegularization {
            dynamic_regularization_delta: REPLACED_PIVOT,
            dynamic_regularization_epsilon: tolerance,
        };
        let result = symbolic.factorize_numeric_llt(
            &mut l,
            a,
            Side::Upper,
            regularization,
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        );
        match result {
            Ok(_) => {
                let mut count = 0;
                pivots(symbolic, &l, |_, d| count += usize::from(d == REPLACED_PIVOT.sqrt()));
                count
            }
            _ => nf,
        }
    }

    /// Solves `A x = b` in place for `K` right-hand sides given on `dofs` (length `dofs.len()`).
    pub fn solve_in_place(&self, rhs: &mut [Vec<f64>]) {
        let nf = self.dofs.len();
        let symbolic = self.symbolic.as_ref().expect("factor() must succeed before solve");
        let k = rhs.len();
        let mut x = faer::Mat::<f64>::zeros(nf, k);
        for (c, b) in rhs.iter().enumerate() {
            for a in 0..nf {
                x[(a, c)] = b[a] * self.inv_sqrt_diag[a];
            }
        }
        let llt = LltRef::new(symbolic, &self.l_values);
        let mut mem = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(k, Par::Seq));
        llt.solve_in_place_with_conj(Conj::No, x.as_mut(), Par::Seq, MemStack::new(&mut mem));
        for (c, b) in rhs.iter_mut().enumerate() {
            for a in 0..nf {
                b[a] = x[(a, c)] * self.inv_sqrt_diag[a];
            }
        }
    }
}

/// Calls `f(j, L_jj)` for every column `j` (in the fill-reducing order) of a Cholesky factor
/// `L` with values `l`, in simplicial (pivot first in its column) or supernodal (dense
/// column-major diagonal block at the top of each supernode) storage.
fn pivots(symbolic: &SymbolicCholesky<usize>, l: &[f64], mut f: impl FnMut(usize, f64)) {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => {
            let lcp = s.col_ptr();
            for j in 0..s.ncols() {
                f(j, l[lcp[j]]);
            }
        }
        SymbolicCholeskyRaw::Supernodal(s) => {
            let (begin, end) = (s.supernode_begin(), s.supernode_end());
            let (row_ptr, val_ptr) = (s.col_ptr_for_row_idx(), s.col_ptr_for_val());
            for k in 0..s.n_supernodes() {
                let ncols = end[k] - begin[k];
                let nrows = ncols + (row_ptr[k + 1] - row_ptr[k]);
                for c in 0..ncols {
                    f(begin[k] + c, l[val_ptr[k] + c * nrows + c]);
                }
            }
        }
    }
}
