//! The products with N, Gx, Gy: the matrices for users' own algebra (nalgebra-sparse copies,
//! faer views), `op · X` and `opᵀ · Y` moving several fields per pass, and the weighted products
//! `A diag(w) Bᵀ` of mass and stiffness.

use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use nalgebra_sparse::CscMatrix;

use super::{Csc, Operator, Operators, Stencil};
use crate::fields::VectorField;
use crate::with_support;

impl Operators {
    /// `op` as a nalgebra-sparse matrix (n × P), copied out of the buffers.
    pub fn matrix(&self, op: Operator) -> CscMatrix<f64> {
        CscMatrix::try_from_csc_data(
            self.num_nodes,
            self.num_particles(),
            self.col_offsets().to_vec(),
            self.row_indices().to_vec(),
            self.values(op).to_vec(),
        )
        .expect("assembled columns are sorted and in range")
    }
    /// N as a nalgebra-sparse matrix (n × P).
    pub fn n_matrix(&self) -> CscMatrix<f64> {
        self.matrix(Operator::N)
    }
    /// Gx as a nalgebra-sparse matrix (n × P).
    pub fn gx_matrix(&self) -> CscMatrix<f64> {
        self.matrix(Operator::Gx)
    }
    /// Gy as a nalgebra-sparse matrix (n × P).
    pub fn gy_matrix(&self) -> CscMatrix<f64> {
        self.matrix(Operator::Gy)
    }

    /// `op` as a faer sparse matrix view (n × P), borrowing the buffers without copying.
    pub fn faer(&self, op: Operator) -> SparseColMatRef<'_, usize, f64> {
        let symbolic = SymbolicSparseColMatRef::new_checked(
            self.num_nodes,
            self.num_particles(),
            self.col_offsets(),
            None,
            self.row_indices(),
        );
        SparseColMatRef::new(symbolic, self.values(op))
    }
    /// N as a faer view.
    pub fn n_faer(&self) -> SparseColMatRef<'_, usize, f64> {
        self.faer(Operator::N)
    }
    /// Gx as a faer view.
    pub fn gx_faer(&self) -> SparseColMatRef<'_, usize, f64> {
        self.faer(Operator::Gx)
    }
    /// Gy as a faer view.
    pub fn gy_faer(&self) -> SparseColMatRef<'_, usize, f64> {
        self.faer(Operator::Gy)
    }

    /// Particle → grid product of `K` fields in one pass over `op`:
    ///
    /// ```text
    /// out[k] = op · x[k]          (n-vector = (n × P) · P-vector), for k = 0..K
    /// ```
    ///
    /// `out` is overwritten.
    ///
    /// # Panics
    /// If a field's length is not `P` or an output's length is not `n`.
    pub fn scatter<const K: usize>(&self, op: Operator, x: [&[f64]; K], out: [&mut [f64]; K]) {
        self.scatter_scaled(op, None, x, out)
    }

    /// Particle → grid product of `K` fields scaled entrywise by a particle weight `w`, in one
    /// pass over `op`:
    ///
    /// ```text
    /// out[k] = op · (w ∘ x[k])     e.g. momentum N (m ∘ v), external force N (m ∘ b)
    /// ```
    ///
    /// `w = None` means `w = 1`. `out` is overwritten.
    ///
    /// # Panics
    /// If a field's or `w`'s length is not `P` or an output's length is not `n`.
    pub fn scatter_scaled<const K: usize>(
        &self,
        op: Operator,
        w: Option<&[f64]>,
        x: [&[f64]; K],
        mut out: [&mut [f64]; K],
    ) {
        let np = self.num_particles();
        for f in &x {
            assert_eq!(f.len(), np, "particle field length must equal the particle count");
        }
        if let Some(w) = w {
            assert_eq!(w.len(), np, "particle weight length must equal the particle count");
        }
        for o in out.iter_mut() {
            assert_eq!(o.len(), self.num_nodes, "grid output length must equal the node count");
            o.fill(0.0);
        }
        with_support!(self, scatter_columns::<S, K>(self, op, w, &x, &mut out));
    }

    /// Grid → particle product of `K` grid fields in one pass over `op`:
    ///
    /// ```text
    /// out[k] = opᵀ · y[k]         (P-vector = (P × n) · n-vector), for k = 0..K
    /// ```
    ///
    /// `out` is overwritten.
    ///
    /// # Panics
    /// If a field's length is not `n` or an output's length is not `P`.
    pub fn gather<const K: usize>(&self, op: Operator, y: [&[f64]; K], mut out: [&mut [f64]; K]) {
        let np = self.num_particles();
        for f in &y {
            assert_eq!(f.len(), self.num_nodes, "grid field length must equal the node count");
        }
        for o in &out {
            assert_eq!(o.len(), np, "particle output length must equal the particle count");
        }
        with_support!(self, gather_columns::<S, K>(self, op, &y, &mut out));
    }
}

impl Operators {
    /// The consistent-mass product without the matrix, in one sweep over the particles:
    ///
    /// ```text
    /// out = N diag(w) Nᵀ u      (n-vectors, both components)
    /// ```
    ///
    /// the same operations and order as [`Operators::gather`] of `N` followed by
    /// [`Operators::scatter_scaled`] with weights `w` (so the same bits), with no per-particle
    /// array. `out` is cleared over the node span only and must be zero outside it.
    ///
    /// # Panics
    /// If `w` does not have one entry per particle, or `u`, `out` one per node.
    pub(crate) fn mass_product_into(&self, w: &[f64], u: &VectorField, out: &mut VectorField) {
        assert_eq!(w.len(), self.num_particles(), "one weight per particle");
        assert!(
            u.len() == self.num_nodes && out.len() == self.num_nodes,
            "one value per node"
        );
        let span = self.node_span();
        out.x[span.clone()].fill(0.0);
        out.y[span].fill(0.0);
        with_support!(self, mass_product_columns::<S>(self, w, u, out));
    }
}

fn mass_product_columns<const S: usize>(ops: &Operators, w: &[f64], u: &VectorField, out: &mut VectorField) {
    for p in 0..ops.num_particles {
        let st = ops.stencil::<S>(p);
        // gather_columns' sums, then scatter_columns' products.
        let mut acc = [0.0; 2];
        for b in 0..S {
            let (start, v) = st.n_row(b);
            for (k, y) in [&u.x, &u.y].into_iter().enumerate() {
                for a in 0..S {
                    acc[k] += v[a] * y[start + a];
                }
            }
        }
        let xp = [w[p] * acc[0], w[p] * acc[1]];
        for b in 0..S {
            let (start, v) = st.n_row(b);
            for (k, o) in [&mut out.x, &mut out.y].into_iter().enumerate() {
                for a in 0..S {
                    o[start + a] += v[a] * xp[k];
                }
            }
        }
    }
}

/// The values of `op` along one run.
#[inline(always)]
fn run_values<const S: usize>(st: &Stencil<S>, op: Operator, b: usize) -> (usize, [f64; S]) {
    match op {
        Operator::N => st.n_row(b),
        Operator::Gx => {
            let (start, _, gx, _) = st.row(b);
            (start, gx)
        }
        Operator::Gy => {
            let (start, _, _, gy) = st.row(b);
            (start, gy)
        }
    }
}

#[inline(always)]
fn scatter_columns<const S: usize, const K: usize>(
    ops: &Operators,
    op: Operator,
    w: Option<&[f64]>,
    x: &[&[f64]; K],
    out: &mut [&mut [f64]; K],
) {
    for p in 0..ops.num_particles {
        let scale = w.map_or(1.0, |w| w[p]);
        let xp: [f64; K] = std::array::from_fn(|k| scale * x[k][p]);
        let st = ops.stencil::<S>(p);
        for b in 0..S {
            let (start, v) = run_values(&st, op, b);
            for k in 0..K {
                let o = &mut out[k][start..start + S];
                for a in 0..S {
                    o[a] += v[a] * xp[k];
                }
            }
        }
    }
}

#[inline(always)]
fn gather_columns<const S: usize, const K: usize>(
    ops: &Operators,
    op: Operator,
    y: &[&[f64]; K],
    out: &mut [&mut [f64]; K],
) {
    for p in 0..ops.num_particles {
        let mut acc = [0.0; K];
        let st = ops.stencil::<S>(p);
        for b in 0..S {
            let (start, v) = run_values(&st, op, b);
            for k in 0..K {
                let yk = &y[k][start..start + S];
                for a in 0..S {
                    acc[k] += v[a] * yk[a];
                }
            }
        }
        for k in 0..K {
            out[k][p] = acc[k];
        }
    }
}

pub(super) fn column_entries<const S: usize>(ops: &Operators, p: usize, entries: &mut Vec<(usize, f64, f64, f64)>) {
    let st = ops.stencil::<S>(p);
    for b in 0..S {
        let (start, n, gx, gy) = st.row(b);
        for a in 0..S {
            entries.push((start + a, n[a], gx[a], gy[a]));
        }
    }
}

pub(super) fn fill_csc<const S: usize>(ops: &Operators, csc: &mut Csc) {
    let np = ops.num_particles;
    let k = S * S;
    csc.col_ptr = (0..=np).map(|p| p * k).collect();
    csc.row_idx = Vec::with_capacity(np * k);
    csc.n = Vec::with_capacity(np * k);
    csc.gx = Vec::with_capacity(np * k);
    csc.gy = Vec::with_capacity(np * k);
    for p in 0..np {
        let st = ops.stencil::<S>(p);
        for b in 0..S {
            let (start, n, gx, gy) = st.row(b);
            csc.row_idx.extend((0..S).map(|a| start + a));
            csc.n.extend_from_slice(&n);
            csc.gx.extend_from_slice(&gx);
            csc.gy.extend_from_slice(&gy);
        }
    }
}

/// The weighted product of two of the operators, the building block of mass and stiffness:
///
/// ```text
/// A diag(w) Bᵀ    (n × n sparse; A, B ∈ {N, Gx, Gy}, w a P-vector)
/// ```
///
/// e.g. `weighted_product(ops, Gx, Gx, V ∘ C11)` is the xx block of the stiffness's normal
/// part. The product of nalgebra-sparse (`A · (Bᵀ diag(w))`), rows sorted; every pair of nodes
/// sharing a particle is stored, even if the value is zero.
///
/// # Panics
/// If `w.len()` is not the particle count.
pub fn weighted_product(ops: &Operators, a: Operator, b: Operator, w: &[f64]) -> CscMatrix<f64> {
    assert_eq!(
        w.len(),
        ops.num_particles(),
        "the weight must have one entry per particle"
    );
    let mut wbt = ops.matrix(b).transpose();
    // Bᵀ is particles × nodes: row p of it scaled by w_p.
    let (_, rows, values) = wbt.csc_data_mut();
    for (v, &p) in values.iter_mut().zip(rows.iter()) {
        *v *= w[p];
    }
    &ops.matrix(a) * &wbt
}
