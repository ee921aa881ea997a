//! Preconditioned conjugate gradient through faer's matrix-free solver, with the operator and
//! the diagonal (lumped-mass) preconditioner given as plain closures and vectors.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::matrix_free::conjugate_gradient::{conjugate_gradient, conjugate_gradient_scratch, CgError, CgParams};
use faer::matrix_free::{InitialGuessStatus, LinOp, Precond};
use faer::{Mat, MatMut, MatRef, Par};

struct Operator<'a> {
    n: usize,
    apply: &'a (dyn Fn(&[f64]) -> Vec<f64> + Sync),
}

impl std::fmt::Debug for Operator<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "mass operator ({} unknowns)", self.n)
    }
}

impl LinOp<f64> for Operator<'_> {
    fn apply_scratch(&self, _rhs_ncols: usize, _par: Par) -> StackReq {
        StackReq::EMPTY
    }
    fn nrows(&self) -> usize {
        self.n
    }
    fn ncols(&self) -> usize {
        self.n
    }
    fn apply(&self, mut out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, _par: Par, _stack: &mut MemStack) {
        for c in 0..rhs.ncols() {
            let x: Vec<f64> = (0..self.n).map(|i| rhs[(i, c)]).collect();
            let y = (self.apply)(&x);
            for i in 0..self.n {
                out[(i, c)] = y[i];
            }
        }
    }
    fn conj_apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, par: Par, stack: &mut MemStack) {
        self.apply(out, rhs, par, stack)
    }
}

/// `x ↦ x / d`, the inverse of a positive diagonal.
#[derive(Debug)]
struct Diagonal {
    d: Vec<f64>,
}

impl LinOp<f64> for Diagonal {
    fn apply_scratch(&self, _rhs_ncols: usize, _par: Par) -> StackReq {
        StackReq::EMPTY
    }
    fn nrows(&self) -> usize {
        self.d.len()
    }
    fn ncols(&self) -> usize {
        self.d.len()
    }
    fn apply(&self, mut out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, _par: Par, _stack: &mut MemStack) {
        for c in 0..rhs.ncols() {
            for i in 0..self.d.len() {
                out[(i, c)] = rhs[(i, c)] / self.d[i];
            }
        }
    }
    fn conj_apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, par: Par, stack: &mut MemStack) {
        self.apply(out, rhs, par, stack)
    }
}

impl Precond<f64> for Diagonal {}

/// Solves `A x = b` from the initial guess `x0` with the preconditioner `diag(d)⁻¹`, to the
/// residual `‖b − A x‖ ≤ tolerance · max(scale, ‖b‖)`. Returns the solution and the iteration count, or the reason
/// for failure.
pub(crate) fn solve(
    apply: impl Fn(&[f64]) -> Vec<f64> + Sync,
    d: Vec<f64>,
    b: &[f64],
    x0: Vec<f64>,
    tolerance: f64,
    scale: f64,
    max_iterations: usize,
) -> Result<(Vec<f64>, usize), String> {
    let n = b.len();
    if n == 0 {
        return Ok((Vec::new(), 0));
    }
    let op = Operator { n, apply: &apply };
    let precond = Diagonal { d };
    let rhs = Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
    let mut x = Mat::<f64>::from_fn(n, 1, |i, _| x0[i]);
    let params = CgParams {
        // faer 0.24 reads uninitialised scratch with `Zero`: always pass MaybeNonZero.
        initial_guess: InitialGuessStatus::MaybeNonZero,
        abs_tolerance: tolerance * scale,
        rel_tolerance: tolerance,
        max_iters: max_iterations,
        ..Default::default()
    };
    let mut mem = MemBuffer::new(conjugate_gradient_scratch(&precond, &op, 1, Par::Seq));
    let result = conjugate_gradient(
        x.as_mut(),
        &precond,
        &op,
        rhs.as_ref(),
        params,
        |_| {},
        Par::Seq,
        MemStack::new(&mut mem),
    );
    match result {
        Ok(info) => Ok(((0..n).map(|i| x[(i, 0)]).collect(), info.iter_count)),
        Err(CgError::NoConvergence { rel_residual, .. }) => Err(format!(
            "conjugate gradient did not reach the relative residual {tolerance:e} in {max_iterations} iterations (reached {rel_residual:.3e})"
        )),
        Err(CgError::NonPositiveDefiniteOperator) => Err("the mass matrix is not positive definite".into()),
        Err(CgError::NonPositiveDefinitePreconditioner) => Err("the lumped mass is not positive".into()),
    }
}
