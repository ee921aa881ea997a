//! The Newton system's sparse LU with faer, keeping the symbolic analysis (fill-reducing
//! ordering, elimination structure) while the sparsity pattern is unchanged: across the Newton
//! iterations of a step, and across steps whose operators have the same pattern.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, NumericLu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par};
use nalgebra_sparse::CscMatrix;

/// A reusable sparse LU solver (partial pivoting).
#[derive(Debug, Default)]
pub struct SparseLu {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    symbolic: Option<SymbolicLu<usize>>,
    numeric: NumericLu<usize, f64>,
    analyses: usize,
}

impl SparseLu {
    /// Symbolic analyses done so far (one per distinct pattern).
    pub fn symbolic_analyses(&self) -> usize {
        self.analyses
    }

    /// Solves `A x = b` in place (`b` becomes `x`), analysing `A`'s pattern only when it changed.
    ///
    /// # Errors
    /// A message when `A` is structurally or numerically singular, or `b` has the wrong length.
    pub fn solve(&mut self, a: &CscMatrix<f64>, b: &mut [f64]) -> Result<(), String> {
        let n = a.nrows();
        if a.ncols() != n || b.len() != n {
            return Err(format!(
                "a {}×{} system with {} right-hand values",
                n,
                a.ncols(),
                b.len()
            ));
        }
        if n == 0 {
            return Ok(());
        }
        let (ptr, idx, values) = (a.col_offsets(), a.row_indices(), a.values());
        if self.symbolic.is_none() || self.col_ptr != ptr || self.row_idx != idx {
            let pattern = SymbolicSparseColMatRef::new_checked(n, n, ptr, None, idx);
            let symbolic = factorize_symbolic_lu(pattern, Default::default()).map_err(|e| format!("{e:?}"))?;
            self.symbolic = Some(symbolic);
            // A numeric factorization of another pattern is not reused (its buffers are sized
            // for that one).
            self.numeric = NumericLu::new();
            self.col_ptr = ptr.to_vec();
            self.row_idx = idx.to_vec();
            self.analyses += 1;
        }
        let symbolic = self.symbolic.as_ref().expect("analysed above");
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, values);
        let par = Par::Seq;
        let need = symbolic
            .factorize_numeric_lu_scratch::<f64>(par, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, par));
        let mut buffer = MemBuffer::new(need);
        let lu = symbolic
            .factorize_numeric_lu(
                &mut self.numeric,
                matrix,
                par,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|e| format!("the Newton matrix is singular ({e:?})"))?;
        let rhs = faer::MatMut::from_column_major_slice_mut(b, n, 1);
        lu.solve_in_place_with_conj(Conj::No, rhs, par, MemStack::new(&mut buffer));
        if b.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err("the Newton matrix is singular (the solution is not finite)".into())
        }
    }
}
