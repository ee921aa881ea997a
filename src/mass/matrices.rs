//! The consistent mass of a step in the forms the schemes apply it in: compressed columns for
//! the factorized schemes (and the ghost penalty, and the singularity policies that may need a
//! factorization), the stencil form for the conjugate gradient and the truncated series
//! otherwise; each plain, and stabilised where a scheme solves with the stabilised matrix.

use std::borrow::Cow;

use nalgebra_sparse::CscMatrix;

use super::options::{MassOptions, MassScheme, SingularityPolicy};
use super::stabilization::Stabilization;
use super::{consistent_mass, StencilMass};
use crate::operators::Operators;

/// The consistent mass of one configuration, as the schemes in use need it.
#[derive(Debug, Default)]
pub(super) struct Matrices {
    /// `M = N diag(m) Nᵀ` in compressed columns, when a factorized scheme (consistent,
    /// blended) or a singularity policy other than an error needs it, or the ghost penalty.
    pub(super) csc: Option<CscMatrix<f64>>,
    /// The stabilised `M` in compressed columns (a stabilisation other than none, with `csc`).
    pub(super) stabilized_csc: Option<CscMatrix<f64>>,
    /// `M` in stencil form, when only the conjugate gradient and the series apply it.
    pub(super) stencil: Option<StencilMass>,
    /// The stabilised `M` in stencil form (partial lumping, or the linear-extension penalty on
    /// a layout widened to couplings two lines apart), for the conjugate gradient.
    stencil_stabilized: Option<StencilMass>,
    /// Buffers of the stencil assembly of the factorized schemes.
    buffers: Option<StencilMass>,
    /// The conjugate gradient's diagonal preconditioner for `stabilized_csc` when the
    /// stabilisation adds to the diagonal beyond the row sums (`max(m_L,I, M_s,II)`).
    pub(super) preconditioner: Option<Vec<f64>>,
}

/// The matrix a scheme solves with, in whichever form it was assembled.
#[derive(Debug, Clone, Copy)]
pub(super) enum MassOperator<'a> {
    Csc(&'a CscMatrix<f64>),
    Stencil(&'a StencilMass),
}

impl<'a> MassOperator<'a> {
    /// The matrix in compressed columns.
    pub(super) fn to_csc(self) -> CscMatrix<f64> {
        match self {
            MassOperator::Csc(m) => (*m).clone(),
            MassOperator::Stencil(s) => s.to_csc(),
        }
    }

    /// `y = M x` over all nodes.
    pub(super) fn mul(&self, x: &[f64]) -> Vec<f64> {
        match self {
            MassOperator::Csc(m) => csc_times(m, x),
            MassOperator::Stencil(m) => m.mul(x),
        }
    }

    /// The matrix in compressed-column form.
    pub(super) fn csc(self) -> Cow<'a, CscMatrix<f64>> {
        match self {
            MassOperator::Csc(m) => Cow::Borrowed(m),
            MassOperator::Stencil(m) => Cow::Owned(m.to_csc()),
        }
    }
}

/// `y = M x` for a compressed-column matrix, column by column (`y_i += M_ik x_k` over the
/// stored entries of column `k`, in their order: the order of nalgebra-sparse's product of a
/// compressed-column matrix and a dense vector, so the same bits, without its per-entry views).
pub(crate) fn csc_times(m: &CscMatrix<f64>, x: &[f64]) -> Vec<f64> {
    assert_eq!(x.len(), m.ncols(), "vector length must equal the matrix's column count");
    let mut y = vec![0.0; m.nrows()];
    let (offsets, rows, values) = (m.col_offsets(), m.row_indices(), m.values());
    for (k, &xk) in x.iter().enumerate() {
        for e in offsets[k]..offsets[k + 1] {
            y[rows[e]] += values[e] * xk;
        }
    }
    y
}

/// `d_I = max(m_L,I, M_II)`: the lumped mass where it bounds the diagonal (the consistent
/// mass and the row-sum-keeping stabilisations), the diagonal where a penalty raises it above
/// the row sum.
fn diagonal_preconditioner(m: &CscMatrix<f64>, lumped: &[f64]) -> Vec<f64> {
    let mut d = lumped.to_vec();
    for (j, col) in m.col_iter().enumerate() {
        if let Some(k) = col.row_indices().iter().position(|&i| i == j) {
            d[j] = d[j].max(col.values()[k]);
        }
    }
    d
}

/// Adds the linear-extension penalty to `m`, a stencil assembled with
/// [`StencilMass::reassemble_extended`].
fn add_extension(
    m: &mut StencilMass,
    ops: &Operators,
    lumped: &[f64],
    active: &[bool],
    [gamma, threshold, onset]: [f64; 3],
) {
    let grid = ops.grid().expect("operators assembled on a grid");
    let full = super::extension::full_support_inertia(ops.shape_function(), grid);
    m.add_extension_penalty(grid.nodes_per_axis(), lumped, active, [gamma, threshold, onset], full);
}

/// [`diagonal_preconditioner`] of a matrix in stencil form.
fn stencil_preconditioner(m: &StencilMass, lumped: &[f64]) -> Vec<f64> {
    lumped.iter().zip(m.diagonal()).map(|(l, d)| l.max(d)).collect()
}

impl Matrices {
    /// No matrix (both solves lumped).
    pub(super) fn clear(&mut self) {
        self.csc = None;
        self.stabilized_csc = None;
        self.stencil = None;
        self.stencil_stabilized = None;
        self.preconditioner = None;
    }

    /// Assembles `M` for particles with masses `m` in the forms `options` need, reusing the
    /// buffers of the last assembly.
    pub(super) fn assemble(
        &mut self,
        ops: &Operators,
        m: &[f64],
        options: &MassOptions,
        lumped: &[f64],
        is_active: &[bool],
    ) {
        let needs_matrix = options.velocity.needs_consistent_matrix()
            || options.acceleration.needs_consistent_matrix()
            || options.singularity != SingularityPolicy::Error;
        let in_stencil = match options.stabilization {
            Stabilization::None | Stabilization::PartialLumping { .. } | Stabilization::LinearExtension { .. } => true,
            Stabilization::GhostPenalty { .. } => false,
        };
        let stencil_only = needs_matrix
            && !options.velocity.factorized()
            && !options.acceleration.factorized()
            && options.singularity == SingularityPolicy::Error
            && in_stencil;
        if stencil_only {
            self.assemble_stencil(ops, m, options, lumped, is_active);
        } else if needs_matrix && in_stencil {
            self.assemble_csc_from_stencil(ops, m, options, lumped, is_active);
        } else {
            self.clear();
            self.csc = needs_matrix.then(|| consistent_mass(ops, m));
            self.stabilized_csc = match &self.csc {
                Some(matrix) => options.stabilization.apply(ops, matrix, lumped, is_active),
                None => None,
            };
            self.preconditioner = self.stabilized_csc.as_ref().map(|m| diagonal_preconditioner(m, lumped));
        }
    }

    /// The factorized schemes' matrices: assembled in stencil form, handed over in compressed
    /// columns (the stencil kept for its buffers only).
    fn assemble_csc_from_stencil(
        &mut self,
        ops: &Operators,
        m: &[f64],
        options: &MassOptions,
        lumped: &[f64],
        is_active: &[bool],
    ) {
        let mut stencil = self.buffers.take().or(self.stencil.take()).unwrap_or_default();
        self.preconditioner = None;
        match options.stabilization {
            Stabilization::LinearExtension {
                gamma,
                threshold,
                onset,
            } => {
                stencil.reassemble_extended(ops, m);
                self.csc = Some(stencil.to_csc());
                add_extension(&mut stencil, ops, lumped, is_active, [gamma, threshold, onset]);
                self.preconditioner = Some(stencil_preconditioner(&stencil, lumped));
                self.stabilized_csc = Some(stencil.to_csc());
            }
            Stabilization::PartialLumping { threshold } => {
                stencil.reassemble(ops, m);
                self.csc = Some(stencil.to_csc());
                stencil.partially_lump(lumped, threshold);
                self.stabilized_csc = Some(stencil.to_csc());
            }
            Stabilization::None | Stabilization::GhostPenalty { .. } => {
                stencil.reassemble(ops, m);
                self.csc = Some(stencil.to_csc());
                self.stabilized_csc = None;
            }
        }
        self.buffers = Some(stencil);
        self.stencil = None;
        self.stencil_stabilized = None;
    }

    /// The conjugate gradient's and the series' matrices, in stencil form only.
    fn assemble_stencil(
        &mut self,
        ops: &Operators,
        m: &[f64],
        options: &MassOptions,
        lumped: &[f64],
        is_active: &[bool],
    ) {
        if self.stencil.is_none() {
            self.stencil = self.buffers.take();
        }
        self.csc = None;
        self.stabilized_csc = None;
        self.preconditioner = None;
        let mut stencil = self.stencil.take().unwrap_or_default();
        stencil.reassemble(ops, m);
        let solves = options.velocity.iterative() || options.acceleration.iterative();
        let mut stabilized = self.stencil_stabilized.take().unwrap_or_default();
        self.stencil_stabilized = match options.stabilization {
            Stabilization::PartialLumping { threshold } if solves => {
                stabilized.clone_from(&stencil);
                stabilized.partially_lump(lumped, threshold);
                Some(stabilized)
            }
            Stabilization::LinearExtension {
                gamma,
                threshold,
                onset,
            } if solves => {
                stabilized.reassemble_extended(ops, m);
                add_extension(&mut stabilized, ops, lumped, is_active, [gamma, threshold, onset]);
                self.preconditioner = Some(stencil_preconditioner(&stabilized, lumped));
                Some(stabilized)
            }
            Stabilization::PartialLumping { .. }
            | Stabilization::LinearExtension { .. }
            | Stabilization::None
            | Stabilization::GhostPenalty { .. } => None,
        };
        self.stencil = Some(stencil);
    }

    /// The stabilised `M` in stencil form, where it was assembled so (the conjugate gradient's
    /// matrix, or the buffers the factorized schemes' matrix was handed over from).
    pub(super) fn stabilized_stencil(&self) -> Option<&StencilMass> {
        self.stencil_stabilized
            .as_ref()
            .or(self.buffers.as_ref().filter(|_| self.stabilized_csc.is_some()))
    }

    /// The plain `M` in compressed columns, from whichever form was assembled.
    pub(super) fn plain_csc(&self) -> Option<Cow<'_, CscMatrix<f64>>> {
        match (&self.csc, &self.stencil) {
            (Some(m), _) => Some(Cow::Borrowed(m)),
            (None, Some(s)) => Some(Cow::Owned(s.to_csc())),
            _ => None,
        }
    }

    /// What the factorized schemes factorize: the stabilised matrix when there is one.
    pub(super) fn factorized_csc(&self) -> Option<&CscMatrix<f64>> {
        self.stabilized_csc.as_ref().or(self.csc.as_ref())
    }

    /// The matrix `scheme` solves with: the plain consistent mass for the truncated series
    /// (which is defined with it), the stabilised one otherwise.
    pub(super) fn operator(&self, scheme: MassScheme) -> Option<MassOperator<'_>> {
        let series = scheme.series_terms().is_some();
        let csc = if series {
            self.csc.as_ref()
        } else {
            self.factorized_csc()
        };
        let stencil = if series {
            self.stencil.as_ref()
        } else {
            self.stencil_stabilized.as_ref().or(self.stencil.as_ref())
        };
        csc.map(MassOperator::Csc).or(stencil.map(MassOperator::Stencil))
    }
}
