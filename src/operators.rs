//! The sparse operators N, Gx, Gy (nodes × particles) and the products with them.
//!
//! ```text
//! N[I, p]  = S_I(x_p)            Gx[I, p] = ∂S_I/∂x (x_p)            Gy[I, p] = ∂S_I/∂y (x_p)
//! ```
//!
//! Column `p` holds particle `p`'s weights: `support²` entries (4 bilinear, 9 uGIMP and
//! quadratic B-spline, 16 cubic B-spline; see [`crate::shape`](mod@crate::shape)), row indices ascending. The
//! three matrices share one sparsity pattern, stored once. Every column has exactly `support²`
//! stored entries, even where a weight is exactly zero (a particle on a grid line, or at a
//! kernel's breakpoint), so the pattern depends only on where each particle's stencil starts.
//!
//! The arrays are compressed sparse column (CSC) data, assembled directly into buffers that are
//! reused from one assembly to the next: no triplets, no sorting, no allocation once the
//! buffers have grown to size. This module is the one place with index arithmetic.
//!
//! Two tiers, as in faer:
//! - matrices for users' own algebra: [`Operators::n_matrix`] (a nalgebra-sparse
//!   [`CscMatrix`]) and [`Operators::n_faer`] (a borrowed faer view), likewise for Gx, Gy;
//! - the kernels the time step uses: [`Operators::scatter`] (`op · X`, particle → grid) and
//!   [`Operators::gather`] (`opᵀ · Y`, grid → particle), moving `K` fields in one pass.

use std::path::Path;

use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use nalgebra_sparse::CscMatrix;

use crate::error::{MpmError, Result};
use crate::grid::{Grid, NodeOrder};
use crate::particles::Particles;
use crate::shape::{AxisFrame, ShapeFunction};

/// Why particle `p` at `position` is not accepted by `shape` on `grid`.
fn rejection(grid: &Grid, shape: ShapeFunction, p: usize, position: [f64; 2]) -> MpmError {
    if !grid.contains(position[0], position[1]) {
        return MpmError::ParticleOutsideGrid {
            particle: p,
            position,
            bounds: grid.bounds(),
        };
    }
    let cells = grid.cells();
    if let Some(axis) = (0..2).find(|&a| cells[a] < shape.min_cells()) {
        return MpmError::InvalidGrid {
            reason: format!(
                "the {} shape functions span {} nodes per axis, so they need at least {} cells along {}; \
                 the grid has {}",
                shape.name(),
                shape.support(),
                shape.min_cells(),
                ["x", "y"][axis],
                cells[axis]
            ),
        };
    }
    MpmError::SupportOutsideGrid {
        particle: p,
        position,
        shape: shape.name(),
        allowed: shape.allowed_region(grid),
        padding: shape.recommended_padding(),
    }
}

/// Which of the three operators a product uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Operator {
    /// Shape-function values N.
    N,
    /// x derivatives Gx.
    Gx,
    /// y derivatives Gy.
    Gy,
}

/// N, Gx, Gy for one particle configuration, in compressed-column form with a shared pattern.
#[derive(Debug, Clone, Default)]
pub struct Operators {
    num_nodes: usize,
    grid: Option<Grid>,
    shape: ShapeFunction,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    n: Vec<f64>,
    gx: Vec<f64>,
    gy: Vec<f64>,
}

impl Operators {
    /// Assembles N, Gx, Gy for `particles` on `grid` with shape functions `shape`.
    ///
    /// # Errors
    /// As [`Operators::reassemble`].
    pub fn assemble(grid: &Grid, shape: ShapeFunction, particles: &Particles) -> Result<Operators> {
        let mut ops = Operators::default();
        ops.reassemble(grid, shape, &particles.x, &particles.y)?;
        Ok(ops)
    }

    /// Reassembles in place for particles at `(x[p], y[p])`, reusing the buffers: after the
    /// first call with a given particle count this allocates nothing.
    ///
    /// # Errors
    /// The operators are left as they were, and the error is
    /// - [`MpmError::InvalidParameter`] when `shape` is invalid ([`ShapeFunction::validate`]);
    /// - [`MpmError::ParticleOutsideGrid`] naming the first particle outside the grid (or with a
    ///   non-finite position);
    /// - [`MpmError::SupportOutsideGrid`] naming the first particle inside the grid but closer
    ///   to its edge than [`ShapeFunction::margin`], whose support would need nodes outside it;
    /// - [`MpmError::InvalidGrid`] when there are particles but the grid has fewer cells along
    ///   an axis than the kernel's support needs ([`ShapeFunction::min_cells`]).
    ///
    /// # Panics
    /// If `x` and `y` differ in length.
    pub fn reassemble(&mut self, grid: &Grid, shape: ShapeFunction, x: &[f64], y: &[f64]) -> Result<()> {
        assert_eq!(x.len(), y.len(), "x and y must have one entry per particle");
        shape.validate()?;
        let (fx, fy) = (shape.axis_frame(grid, 0), shape.axis_frame(grid, 1));
        // One branch-free pass (it vectorises); the offender is looked for only on failure.
        let all_accepted = x
            .iter()
            .zip(y)
            .fold(true, |ok, (&xp, &yp)| ok & fx.accepts(xp) & fy.accepts(yp));
        if !all_accepted {
            let p = (0..x.len())
                .find(|&p| !(fx.accepts(x[p]) && fy.accepts(y[p])))
                .expect("some particle was rejected");
            return Err(rejection(grid, shape, p, [x[p], y[p]]));
        }
        let num_particles = x.len();
        let k = shape.nodes_per_particle();
        self.num_nodes = grid.num_nodes();
        if self.grid.as_ref() != Some(grid) {
            self.grid = Some(grid.clone());
        }
        self.shape = shape;
        self.col_ptr.clear();
        self.col_ptr.extend((0..=num_particles).map(|p| p * k));
        let nnz = num_particles * k;
        self.row_idx.resize(nnz, 0);
        self.n.resize(nnz, 0.0);
        self.gx.resize(nnz, 0.0);
        self.gy.resize(nnz, 0.0);
        // A fixed stencil size per call lets the compiler unroll the column loops.
        match shape.support() {
            2 => self.fill_columns::<2>(grid, (fx, fy), x, y),
            3 => self.fill_columns::<3>(grid, (fx, fy), x, y),
            4 => self.fill_columns::<4>(grid, (fx, fy), x, y),
            other => unreachable!("no kernel has a support of {other} nodes"),
        }
        Ok(())
    }

    /// Writes the `S × S` entries of every column; every particle must have been accepted.
    fn fill_columns<const S: usize>(&mut self, grid: &Grid, (fx, fy): (AxisFrame, AxisFrame), x: &[f64], y: &[f64]) {
        let [sx, sy] = grid.strides();
        // Outer loop over the axis with the larger stride, so row indices come out ascending.
        let y_outer = grid.node_order() == NodeOrder::XFastest;
        let accepted = "position checked against the allowed region above";
        let columns = self
            .row_idx
            .chunks_exact_mut(S * S)
            .zip(self.n.chunks_exact_mut(S * S))
            .zip(self.gx.chunks_exact_mut(S * S))
            .zip(self.gy.chunks_exact_mut(S * S));
        for (p, (((rows, n), gx), gy)) in columns.enumerate() {
            let wx = fx.weights(fx.accept(x[p]).expect(accepted));
            let wy = fy.weights(fy.accept(y[p]).expect(accepted));
            let mut e = 0;
            for outer in 0..S {
                for inner in 0..S {
                    let (a, b) = if y_outer { (inner, outer) } else { (outer, inner) };
                    rows[e] = (wx.first + a) * sx + (wy.first + b) * sy;
                    n[e] = wx.value[a] * wy.value[b];
                    gx[e] = wx.derivative[a] * wy.value[b];
                    gy[e] = wx.value[a] * wy.derivative[b];
                    e += 1;
                }
            }
        }
    }

    /// Number of rows (grid nodes) `n`.
    pub fn num_nodes(&self) -> usize {
        self.num_nodes
    }
    /// Number of columns (particles) `P`.
    pub fn num_particles(&self) -> usize {
        self.col_ptr.len().saturating_sub(1)
    }
    /// Stored entries per operator: `P · support²`.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }
    /// The grid the operators were assembled on (`None` before the first assembly).
    pub fn grid(&self) -> Option<&Grid> {
        self.grid.as_ref()
    }
    /// The shape-function family the operators were assembled with.
    pub fn shape_function(&self) -> ShapeFunction {
        self.shape
    }
    /// CSC column offsets (length `P + 1`), shared by N, Gx, Gy.
    pub fn col_offsets(&self) -> &[usize] {
        &self.col_ptr
    }
    /// CSC row indices (node numbers, ascending within each column), shared by N, Gx, Gy.
    pub fn row_indices(&self) -> &[usize] {
        &self.row_idx
    }
    /// CSC values of `op`, aligned with [`Operators::row_indices`].
    pub fn values(&self, op: Operator) -> &[f64] {
        match op {
            Operator::N => &self.n,
            Operator::Gx => &self.gx,
            Operator::Gy => &self.gy,
        }
    }

    /// The nodes in particle `p`'s support and `(N, Gx, Gy)` there.
    ///
    /// # Panics
    /// If `p >= num_particles()`.
    pub fn column(&self, p: usize) -> impl Iterator<Item = (usize, f64, f64, f64)> + '_ {
        (self.col_ptr[p]..self.col_ptr[p + 1]).map(|e| (self.row_idx[e], self.n[e], self.gx[e], self.gy[e]))
    }

    /// The particles whose support contains `node` (the non-zero pattern of row `node`),
    /// ascending. Costs one pass over the pattern.
    pub fn particles_touching(&self, node: usize) -> Vec<usize> {
        (0..self.num_particles())
            .filter(|&p| self.row_idx[self.col_ptr[p]..self.col_ptr[p + 1]].contains(&node))
            .collect()
    }

    /// `op` as a nalgebra-sparse matrix (n × P), copied out of the buffers.
    pub fn matrix(&self, op: Operator) -> CscMatrix<f64> {
        CscMatrix::try_from_csc_data(
            self.num_nodes,
            self.num_particles(),
            self.col_ptr.clone(),
            self.row_idx.clone(),
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
            &self.col_ptr,
            None,
            &self.row_idx,
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
        let values = self.values(op);
        for p in 0..np {
            let scale = w.map_or(1.0, |w| w[p]);
            let xp: [f64; K] = std::array::from_fn(|k| scale * x[k][p]);
            for e in self.col_ptr[p]..self.col_ptr[p + 1] {
                let (i, v) = (self.row_idx[e], values[e]);
                for k in 0..K {
                    out[k][i] += v * xp[k];
                }
            }
        }
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
    pub fn gather<const K: usize>(&self, op: Operator, y: [&[f64]; K], out: [&mut [f64]; K]) {
        let np = self.num_particles();
        for f in &y {
            assert_eq!(f.len(), self.num_nodes, "grid field length must equal the node count");
        }
        for o in &out {
            assert_eq!(o.len(), np, "particle output length must equal the particle count");
        }
        let values = self.values(op);
        for p in 0..np {
            let mut acc = [0.0; K];
            for e in self.col_ptr[p]..self.col_ptr[p + 1] {
                let (i, v) = (self.row_idx[e], values[e]);
                for k in 0..K {
                    acc[k] += v * y[k][i];
                }
            }
            for k in 0..K {
                out[k][p] = acc[k];
            }
        }
    }

    /// Writes N, Gx and Gy to `dir/N.mtx`, `dir/Gx.mtx`, `dir/Gy.mtx` (Matrix Market coordinate
    /// format, 1-based indices, rows = nodes, columns = particles). Creates `dir` if needed.
    ///
    /// # Errors
    /// [`MpmError::Io`] naming the file that could not be written.
    pub fn write_matrix_market(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|source| MpmError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        for (op, name) in [(Operator::N, "N"), (Operator::Gx, "Gx"), (Operator::Gy, "Gy")] {
            crate::io::write_matrix_market(&self.matrix(op), &dir.join(format!("{name}.mtx")))?;
        }
        Ok(())
    }
}
