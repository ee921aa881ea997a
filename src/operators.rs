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
//! ## Storage: factored columns
//! Every shape function here is a tensor product, `S_I(x) = S_i(x) S_j(y)`, so column `p` of
//! each operator is an outer product of two short vectors — the 1D weights and derivatives of
//! the particle along x and along y:
//!
//! ```text
//! N[:, p] = wy_p ⊗ wx_p,    Gx[:, p] = wy_p ⊗ w′x_p,    Gy[:, p] = w′y_p ⊗ wx_p
//! ```
//!
//! on the `support × support` nodes from the stencil's first node. [`Operators::reassemble`]
//! stores exactly that: per particle the first node and `4 · support` numbers (100 bytes per
//! particle for quadratic B-splines, against 296 for the three CSC value arrays and their row
//! indices). The products ([`Operators::scatter`], [`Operators::gather`] and the kernels of
//! [`crate::kernels`]) form the entries `wx[a] · wy[b]` as they go, the same products in the
//! same order as the CSC values, so results are identical to the last bit.
//!
//! The compressed sparse column (CSC) arrays ([`Operators::col_offsets`],
//! [`Operators::row_indices`], [`Operators::values`], the matrix views) are built from the
//! factors the first time they are asked for after an assembly and kept until the next one.
//! This module and [`crate::kernels`] are the only places with index arithmetic.
//!
//! Two tiers, as in faer:
//! - matrices for users' own algebra: [`Operators::n_matrix`] (a nalgebra-sparse
//!   [`CscMatrix`]) and [`Operators::n_faer`] (a borrowed faer view), likewise for Gx, Gy;
//! - the kernels the time step uses: [`Operators::scatter`] (`op · X`, particle → grid) and
//!   [`Operators::gather`] (`opᵀ · Y`, grid → particle), moving `K` fields in one pass, and the
//!   fused kernels of [`crate::kernels`], all over [`Stencil`]s.

use std::sync::OnceLock;

use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use nalgebra_sparse::CscMatrix;

use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::parallel::{Strided, Workers};
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

/// N, Gx, Gy for one particle configuration: factored columns, and the compressed-column form
/// with a shared pattern on demand.
#[derive(Debug, Clone, Default)]
pub struct Operators {
    num_nodes: usize,
    grid: Option<Grid>,
    shape: ShapeFunction,
    num_particles: usize,
    support: usize,
    /// Node strides along x and y.
    strides: [usize; 2],
    /// Grid indices `(i, j)` of the first node of each particle's stencil (its lowest x and y
    /// indices).
    first: Vec<[u32; 2]>,
    /// Grid origin and cell size, for node coordinates.
    origin: [f64; 2],
    cell_size: [f64; 2],
    /// Per particle `[wx; S], [w′x; S], [wy; S], [w′y; S]`.
    factors: Vec<f64>,
    /// Node numbers from the lowest to one past the highest node any stencil touches.
    span: std::ops::Range<usize>,
    /// The CSC arrays, built from the factors on first use after an assembly.
    csc: OnceLock<Csc>,
    /// Per block of particles, whether all were accepted and their lowest and highest first
    /// nodes (work arrays of the assembly).
    block_flags: Vec<bool>,
    block_spans: Vec<(usize, usize)>,
}

/// The compressed sparse column arrays of N, Gx, Gy (shared pattern).
#[derive(Debug, Clone, Default)]
struct Csc {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    n: Vec<f64>,
    gx: Vec<f64>,
    gy: Vec<f64>,
}

/// One particle's column of N, Gx, Gy in factored form, for a support of `S` nodes per axis.
///
/// The stencil's nodes come in runs of `S` consecutive node numbers (along the axis with node
/// stride 1); [`Stencil::row`] gives run `b` with its values, in the order of the CSC entries.
#[derive(Debug, Clone, Copy)]
pub struct Stencil<const S: usize> {
    /// Node number of the first node of the first run.
    pub first: usize,
    /// Distance in node numbers between runs.
    pub run_stride: usize,
    /// Whether runs go along x (node order x-fastest).
    pub runs_along_x: bool,
    /// 1D weights along x.
    pub wx: [f64; S],
    /// 1D derivatives along x, per unit length.
    pub dwx: [f64; S],
    /// 1D weights along y.
    pub wy: [f64; S],
    /// 1D derivatives along y, per unit length.
    pub dwy: [f64; S],
    /// Grid indices of the first node.
    pub first_ij: [usize; 2],
    /// Grid origin and cell size.
    pub origin: [f64; 2],
    /// Grid cell size.
    pub cell_size: [f64; 2],
}

impl<const S: usize> Stencil<S> {
    /// Run `b` (`0 ≤ b < S`): its first node and the values of N, Gx, Gy at its `S` nodes,
    ///
    /// ```text
    /// N = wx[a] wy[b],  Gx = w′x[a] wy[b],  Gy = wx[a] w′y[b]     (runs along x; a along the run)
    /// N = wx[b] wy[a],  Gx = w′x[b] wy[a],  Gy = wx[b] w′y[a]     (runs along y)
    /// ```
    #[inline(always)]
    pub fn row(&self, b: usize) -> (usize, [f64; S], [f64; S], [f64; S]) {
        let start = self.first + b * self.run_stride;
        if self.runs_along_x {
            let (y, dy) = (self.wy[b], self.dwy[b]);
            (
                start,
                std::array::from_fn(|a| self.wx[a] * y),
                std::array::from_fn(|a| self.dwx[a] * y),
                std::array::from_fn(|a| self.wx[a] * dy),
            )
        } else {
            let (x, dx) = (self.wx[b], self.dwx[b]);
            (
                start,
                std::array::from_fn(|a| x * self.wy[a]),
                std::array::from_fn(|a| dx * self.wy[a]),
                std::array::from_fn(|a| x * self.dwy[a]),
            )
        }
    }

    /// Offsets from `(xp, yp)` to the stencil's node coordinates along each axis,
    /// `x_{i0+a} − xp` and `y_{j0+a} − yp` with `x_i = x₀ + i·hx` (as [`Grid::node_position`]).
    #[inline(always)]
    pub fn offsets(&self, xp: f64, yp: f64) -> ([f64; S], [f64; S]) {
        let ([i0, j0], [ox, oy], [hx, hy]) = (self.first_ij, self.origin, self.cell_size);
        (
            std::array::from_fn(|a| (ox + (i0 + a) as f64 * hx) - xp),
            std::array::from_fn(|a| (oy + (j0 + a) as f64 * hy) - yp),
        )
    }

    /// The `(x_I − xp, y_I − yp)` of the nodes of run `b`, from [`Stencil::offsets`].
    #[inline(always)]
    pub fn run_offsets(&self, (dx, dy): &([f64; S], [f64; S]), b: usize) -> ([f64; S], [f64; S]) {
        if self.runs_along_x {
            (*dx, [dy[b]; S])
        } else {
            ([dx[b]; S], *dy)
        }
    }

    /// Run `b`: its first node and the values of N only.
    #[inline(always)]
    pub fn n_row(&self, b: usize) -> (usize, [f64; S]) {
        let start = self.first + b * self.run_stride;
        if self.runs_along_x {
            let y = self.wy[b];
            (start, std::array::from_fn(|a| self.wx[a] * y))
        } else {
            let x = self.wx[b];
            (start, std::array::from_fn(|a| x * self.wy[a]))
        }
    }
}

/// Calls `$body` with `S` bound to the operators' support as a constant (2, 3 or 4), so that
/// the loops over a stencil unroll.
#[macro_export]
#[doc(hidden)]
macro_rules! with_support {
    ($ops:expr, $f:ident :: <S $(, $g:tt)*> ( $($arg:expr),* $(,)? )) => {
        match $ops.support() {
            2 => $f::<2 $(, $g)*>($($arg),*),
            3 => $f::<3 $(, $g)*>($($arg),*),
            4 => $f::<4 $(, $g)*>($($arg),*),
            0 => $f::<2 $(, $g)*>($($arg),*),
            other => unreachable!("no kernel has a support of {other} nodes"),
        }
    };
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
    /// first call with a given particle count this allocates nothing (the CSC arrays, when
    /// asked for later, are built anew).
    ///
    /// # Errors
    /// The operators are left as they were, and the error is
    /// - [`MpmError::InvalidParameter`] when `shape` is invalid ([`ShapeFunction::validate`]);
    /// - [`MpmError::ParticleOutsideGrid`] naming the first particle outside the grid (or with a
    ///   non-finite position);
    /// - [`MpmError::SupportOutsideGrid`] naming the first particle inside the grid but closer
    ///   to its edge than [`ShapeFunction::margin`], whose support would need nodes outside it;
    /// - [`MpmError::InvalidGrid`] when there are particles but the grid has fewer cells along
    ///   an axis than the kernel's support needs ([`ShapeFunction::min_cells`]), or more than
    ///   2³² nodes.
    ///
    /// # Panics
    /// If `x` and `y` differ in length.
    pub fn reassemble(&mut self, grid: &Grid, shape: ShapeFunction, x: &[f64], y: &[f64]) -> Result<()> {
        self.reassemble_with(grid, shape, x, y, &Workers::default())
    }

    /// [`Operators::reassemble`] on `workers`' threads (the result does not depend on them).
    ///
    /// # Errors
    /// As [`Operators::reassemble`].
    ///
    /// # Panics
    /// If `x` and `y` differ in length.
    pub fn reassemble_with(
        &mut self,
        grid: &Grid,
        shape: ShapeFunction,
        x: &[f64],
        y: &[f64],
        workers: &Workers,
    ) -> Result<()> {
        assert_eq!(x.len(), y.len(), "x and y must have one entry per particle");
        shape.validate()?;
        let (fx, fy) = (shape.axis_frame(grid, 0), shape.axis_frame(grid, 1));
        // Branch-free passes (they vectorise); the offender is looked for only on failure.
        let mut accepted = std::mem::take(&mut self.block_flags);
        workers.blocks(x.len(), &mut accepted, |range| {
            x[range.clone()]
                .iter()
                .zip(&y[range])
                .fold(true, |ok, (&xp, &yp)| ok & fx.accepts(xp) & fy.accepts(yp))
        });
        let all_accepted = accepted.iter().all(|&a| a);
        self.block_flags = accepted;
        if !all_accepted {
            let p = (0..x.len())
                .find(|&p| !(fx.accepts(x[p]) && fy.accepts(y[p])))
                .expect("some particle was rejected");
            return Err(rejection(grid, shape, p, [x[p], y[p]]));
        }
        if u32::try_from(grid.num_nodes()).is_err() {
            return Err(MpmError::InvalidGrid {
                reason: format!("{} nodes: the operators number at most 2^32 nodes", grid.num_nodes()),
            });
        }
        let num_particles = x.len();
        let support = shape.support();
        self.num_nodes = grid.num_nodes();
        if self.grid.as_ref() != Some(grid) {
            self.grid = Some(grid.clone());
        }
        self.shape = shape;
        self.num_particles = num_particles;
        self.support = support;
        self.strides = grid.strides();
        self.origin = grid.origin();
        self.cell_size = grid.cell_size();
        self.csc.take();
        self.first.resize(num_particles, [0, 0]);
        self.factors.resize(num_particles * 4 * support, 0.0);
        // A fixed stencil size per call lets the compiler unroll the loops.
        match support {
            2 => self.fill_factors::<2>((fx, fy), x, y, workers),
            3 => self.fill_factors::<3>((fx, fy), x, y, workers),
            4 => self.fill_factors::<4>((fx, fy), x, y, workers),
            other => unreachable!("no kernel has a support of {other} nodes"),
        }
        Ok(())
    }

    /// Writes every particle's first node and factors; every particle must have been accepted.
    fn fill_factors<const S: usize>(
        &mut self,
        (fx, fy): (AxisFrame, AxisFrame),
        x: &[f64],
        y: &[f64],
        workers: &Workers,
    ) {
        let [sx, sy] = self.strides;
        let accepted = "position checked against the allowed region above";
        let mut spans = std::mem::take(&mut self.block_spans);
        let out = (&mut self.first[..], Strided(&mut self.factors[..], 4 * S));
        workers.split_blocks(out, &mut spans, |start, (firsts, Strided(factors, _))| {
            let (mut lo, mut hi) = (usize::MAX, 0);
            for (j, (first, f)) in firsts.iter_mut().zip(factors.chunks_exact_mut(4 * S)).enumerate() {
                let p = start + j;
                let wx = fx.weights(fx.accept(x[p]).expect(accepted));
                let wy = fy.weights(fy.accept(y[p]).expect(accepted));
                let node = wx.first * sx + wy.first * sy;
                lo = lo.min(node);
                hi = hi.max(node);
                *first = [wx.first as u32, wy.first as u32];
                f[..S].copy_from_slice(&wx.value[..S]);
                f[S..2 * S].copy_from_slice(&wx.derivative[..S]);
                f[2 * S..3 * S].copy_from_slice(&wy.value[..S]);
                f[3 * S..].copy_from_slice(&wy.derivative[..S]);
            }
            (lo, hi)
        });
        let (lo, hi) = spans
            .iter()
            .fold((usize::MAX, 0), |(lo, hi), &(l, h)| (lo.min(l), hi.max(h)));
        self.block_spans = spans;
        // The last node of a stencil is (S − 1)(sx + sy) after its first.
        self.span = if x.is_empty() {
            0..0
        } else {
            lo..hi + (S - 1) * (sx + sy) + 1
        };
    }

    /// Nodes per grid line, a line being the nodes that share the index along the axis with
    /// the larger node stride (for x-fastest numbering, a row of constant `j`): the runs of a
    /// [`Stencil`] lie within lines, one run per line.
    pub fn line_length(&self) -> usize {
        let [sx, sy] = self.strides;
        sx.max(sy).max(1)
    }

    /// The lines (see [`Operators::line_length`]) any particle's support touches.
    pub fn line_span(&self) -> std::ops::Range<usize> {
        let len = self.line_length();
        if self.span.is_empty() {
            0..0
        } else {
            self.span.start / len..(self.span.end - 1) / len + 1
        }
    }

    /// The first line of particle `p`'s stencil; its runs lie on this line and the next
    /// `support − 1`.
    ///
    /// # Panics
    /// If `p >= num_particles()`.
    #[inline(always)]
    pub fn first_line(&self, p: usize) -> usize {
        let [i0, j0] = self.first[p];
        if self.strides[0] == 1 {
            j0 as usize
        } else {
            i0 as usize
        }
    }

    /// The node numbers from the lowest to one past the highest node in any particle's support:
    /// every row of N, Gx, Gy outside this range is empty. (Empty before the first assembly.)
    pub fn node_span(&self) -> std::ops::Range<usize> {
        self.span.clone()
    }

    /// Node-number strides along x and y.
    pub(crate) fn strides(&self) -> [usize; 2] {
        self.strides
    }

    /// Nodes per axis in each particle's support (2 linear, 3 uGIMP and quadratic, 4 cubic; 0
    /// before the first assembly).
    pub fn support(&self) -> usize {
        self.support
    }

    /// Particle `p`'s column in factored form, for `S` equal to [`Operators::support`].
    ///
    /// # Panics
    /// If `p >= num_particles()` or `S` is not the support.
    #[inline(always)]
    pub fn stencil<const S: usize>(&self, p: usize) -> Stencil<S> {
        assert_eq!(S, self.support, "stencil size must equal the support");
        let f = &self.factors[4 * S * p..4 * S * (p + 1)];
        let [sx, sy] = self.strides;
        let runs_along_x = sx == 1;
        let [i0, j0] = self.first[p];
        let first_ij = [i0 as usize, j0 as usize];
        Stencil {
            first: first_ij[0] * sx + first_ij[1] * sy,
            run_stride: if runs_along_x { sy } else { sx },
            runs_along_x,
            wx: std::array::from_fn(|a| f[a]),
            dwx: std::array::from_fn(|a| f[S + a]),
            wy: std::array::from_fn(|a| f[2 * S + a]),
            dwy: std::array::from_fn(|a| f[3 * S + a]),
            first_ij,
            origin: self.origin,
            cell_size: self.cell_size,
        }
    }

    /// The CSC arrays, built from the factors on first use after an assembly.
    fn csc(&self) -> &Csc {
        self.csc.get_or_init(|| {
            let mut csc = Csc::default();
            with_support!(self, fill_csc::<S>(self, &mut csc));
            csc
        })
    }

    /// Number of rows (grid nodes) `n`.
    pub fn num_nodes(&self) -> usize {
        self.num_nodes
    }
    /// Number of columns (particles) `P`.
    pub fn num_particles(&self) -> usize {
        self.num_particles
    }
    /// Stored entries per operator: `P · support²`.
    pub fn nnz(&self) -> usize {
        self.num_particles * self.support * self.support
    }
    /// The grid the operators were assembled on (`None` before the first assembly).
    pub fn grid(&self) -> Option<&Grid> {
        self.grid.as_ref()
    }
    /// The shape-function family the operators were assembled with.
    pub fn shape_function(&self) -> ShapeFunction {
        self.shape
    }
    /// CSC column offsets (length `P + 1`), shared by N, Gx, Gy (built on first use).
    pub fn col_offsets(&self) -> &[usize] {
        &self.csc().col_ptr
    }
    /// CSC row indices (node numbers, ascending within each column), shared by N, Gx, Gy
    /// (built on first use).
    pub fn row_indices(&self) -> &[usize] {
        &self.csc().row_idx
    }
    /// CSC values of `op`, aligned with [`Operators::row_indices`] (built on first use).
    pub fn values(&self, op: Operator) -> &[f64] {
        let csc = self.csc();
        match op {
            Operator::N => &csc.n,
            Operator::Gx => &csc.gx,
            Operator::Gy => &csc.gy,
        }
    }

    /// The nodes in particle `p`'s support and `(N, Gx, Gy)` there, in CSC order.
    ///
    /// # Panics
    /// If `p >= num_particles()`.
    pub fn column(&self, p: usize) -> impl Iterator<Item = (usize, f64, f64, f64)> + '_ {
        assert!(p < self.num_particles, "particle {p} of {}", self.num_particles);
        let mut entries = Vec::with_capacity(self.support * self.support);
        with_support!(self, column_entries::<S>(self, p, &mut entries));
        entries.into_iter()
    }

    /// The particles whose support contains `node` (the non-zero pattern of row `node`),
    /// ascending. Costs one pass over the pattern.
    pub fn particles_touching(&self, node: usize) -> Vec<usize> {
        (0..self.num_particles())
            .filter(|&p| self.column(p).any(|(i, ..)| i == node))
            .collect()
    }

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

fn column_entries<const S: usize>(ops: &Operators, p: usize, entries: &mut Vec<(usize, f64, f64, f64)>) {
    let st = ops.stencil::<S>(p);
    for b in 0..S {
        let (start, n, gx, gy) = st.row(b);
        for a in 0..S {
            entries.push((start + a, n[a], gx[a], gy[a]));
        }
    }
}

fn fill_csc<const S: usize>(ops: &Operators, csc: &mut Csc) {
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
/// part. Built column by column (Gustavson's product through the row pattern of B), with sorted
/// row indices. Every pair of nodes sharing a particle is stored, even if the value is zero.
///
/// # Panics
/// If `w.len()` is not the particle count.
pub fn weighted_product(ops: &Operators, a: Operator, b: Operator, w: &[f64]) -> CscMatrix<f64> {
    let (n, np) = (ops.num_nodes(), ops.num_particles());
    assert_eq!(w.len(), np, "the weight must have one entry per particle");
    let (cp, ri) = (ops.col_offsets(), ops.row_indices());
    let (av, bv) = (ops.values(a), ops.values(b));
    // Row pattern of the operators: for each node, the stored entries touching it.
    let mut row_ptr = vec![0usize; n + 1];
    for &i in ri {
        row_ptr[i + 1] += 1;
    }
    for i in 0..n {
        row_ptr[i + 1] += row_ptr[i];
    }
    let mut fill = row_ptr.clone();
    let mut row_entry = vec![0usize; ri.len()];
    for e in 0..ri.len() {
        let i = ri[e];
        row_entry[fill[i]] = e;
        fill[i] += 1;
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
            let p = cp.partition_point(|&c| c <= ej) - 1;
            let scale = w[p] * bv[ej];
            for e in cp[p]..cp[p + 1] {
                let i = ri[e];
                if marker[i] != j {
                    marker[i] = j;
                    work[i] = 0.0;
                    touched.push(i);
                }
                work[i] += scale * av[e];
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
