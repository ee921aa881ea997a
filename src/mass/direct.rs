//! The factorized schemes, consistent and blended: `(γ M + (1 − γ) M_L)_FF x = b_F` by the
//! sparse Cholesky factorization [`GridMass::prepare`] made, and the regularized
//! factorization `(1 − ε) M + ε M_L` a singularity policy asks for.

use super::cholesky::SparseCholesky;
use super::options::MassScheme;
use super::{singular_error, GridMass, Role};
use crate::error::Result;
use crate::fields::VectorField;
use crate::operators::Operators;

impl GridMass {
    /// `x_F = A_FF⁻¹ rhs_F` per component with the factors of `role`, 0 off F.
    pub(super) fn solve_direct(&self, role: Role, rhs: &VectorField) -> VectorField {
        let solver = self.solver(role);
        let own_y = self.y_has_own_dofs();
        self.per_component(rhs, |c, b| {
            solver.factors[if c == 1 && own_y { 1 } else { 0 }].solve_in_place(b)
        })
    }

    /// `x_F = ((1 − ε) M + ε M_L)_FF⁻¹ rhs_F` per component, factorized now.
    ///
    /// # Errors
    /// [`crate::MpmError::SingularMassMatrix`] when even the regularized matrix is singular.
    pub(super) fn solve_regularized(&self, epsilon: f64, rhs: &VectorField, ops: &Operators) -> Result<VectorField> {
        let m = self
            .matrices
            .operator(MassScheme::Consistent)
            .expect("assembled for the iterative scheme")
            .csc();
        let mut factors = [SparseCholesky::default(), SparseCholesky::default()];
        for (c, dofs) in self.dofs.iter().enumerate() {
            factors[c]
                .factor(&m, &self.lumped, 1.0 - epsilon, &dofs.free, &dofs.local, 0.0)
                .map_err(|b| singular_error(dofs.free[b.local], b.pivot, ops))?;
        }
        Ok(self.per_component(rhs, |c, b| factors[c].solve_in_place(b)))
    }

    /// `solve(c, b)` on each component's right-hand side compressed to its free nodes, the
    /// results spread back over all nodes (0 off F).
    fn per_component(&self, rhs: &VectorField, solve: impl Fn(usize, &mut [Vec<f64>])) -> VectorField {
        let n = self.lumped.len();
        let mut x = VectorField::zeros(n);
        for (c, dofs) in self.dofs.iter().enumerate() {
            let (bc, out) = if c == 0 { (&rhs.x, &mut x.x) } else { (&rhs.y, &mut x.y) };
            let mut local = vec![dofs.free.iter().map(|&i| bc[i]).collect::<Vec<f64>>()];
            solve(c, &mut local);
            for (&i, v) in dofs.free.iter().zip(&local[0]) {
                out[i] = *v;
            }
        }
        x
    }
}
