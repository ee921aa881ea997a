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
//! on the `support × support` nodes from the stencil's first node. The 1D factors are the
//! kernel's polynomials at one coordinate per axis (`wx_p = S(t_x,p)`, `w′x_p = S′(t_x,p)/h`,
//! [`shape`](mod@crate::shape)), so [`Operators::reassemble`] stores per particle the first node and the
//! two coordinates `t_x,p`, `t_y,p`: 24 bytes per particle with every kernel, against 296 for
//! the three CSC value arrays of quadratic B-splines and their row indices. Where a boundary
//! rule changes a particle's weights beyond what `t` gives (mirrored walls fold them; uGIMP
//! shifts a stencil at the grid's edge), the operators store the factors themselves instead,
//! `4 · support` numbers per particle ([`Operators::stores_factors`]). The products
//! ([`Operators::scatter`], [`Operators::gather`] and the kernels of [`crate::kernels`]) form
//! the factors and the entries `wx[a] · wy[b]` as they go, with the same operations in the
//! same order as the CSC values, so results are identical to the last bit.
//!
//! The compressed sparse column (CSC) arrays ([`Operators::col_offsets`],
//! [`Operators::row_indices`], [`Operators::values`], the matrix views) are built from the
//! factors the first time they are asked for after an assembly and kept until the next one.
//! This module and [`crate::kernels`] are the only places with index arithmetic.
//!
//! Two tiers, as in faer:
//! - matrices for users' own algebra: [`Operators::n_matrix`] (a nalgebra-sparse
//!   [`CscMatrix`](nalgebra_sparse::CscMatrix)) and [`Operators::n_faer`] (a borrowed faer view), likewise for Gx, Gy;
//! - the kernels the time step uses: [`Operators::scatter`] (`op · X`, particle → grid) and
//!   [`Operators::gather`] (`opᵀ · Y`, grid → particle), moving `K` fields in one pass, and the
//!   fused kernels of [`crate::kernels`], all over [`Stencil`]s.

use std::sync::OnceLock;

mod locate;
mod products;
mod stencil;
mod view;

pub use products::weighted_product;
pub use stencil::Stencil;
pub(crate) use view::{relocate, ColumnView, Layout};

use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::parallel::{Strided, Workers};
use crate::particles::Particles;
use crate::shape::{AxisFrame, ShapeFunction};
use crate::with_support;
use locate::fill_local_body;
#[cfg(target_arch = "x86_64")]
use locate::{fill_local_avx2, fill_local_avx512};
use locate::{BlockSpan, LocalBlock};
use products::{column_entries, fill_csc};

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
    /// The kernel's constants along x and y, whose `weights_at(t)` are the factors.
    frames: [AxisFrame; 2],
    /// Per particle the kernel coordinates `t_x`, `t_y` ([`Located::t`](crate::shape)): the factors are
    /// their weights, unless `factors` holds them.
    local: [Vec<f64>; 2],
    /// Whether `factors` holds the columns (a fold or a shifted stencil), not `local`.
    stores_factors: bool,
    /// Whether some column may hold a weight of exactly zero.
    zero_weights: bool,
    /// Per particle `[wx; S], [w′x; S], [wy; S], [w′y; S]` (when `stores_factors`).
    factors: Vec<f64>,
    /// Node numbers from the lowest to one past the highest node any stencil touches.
    span: std::ops::Range<usize>,
    /// Indices along the grid lines from the lowest to one past the highest any stencil touches.
    columns: std::ops::Range<usize>,
    /// The CSC arrays, built from the factors on first use after an assembly.
    csc: OnceLock<Csc>,
    /// Per block of particles, whether all were accepted, and their lowest and highest first
    /// nodes and whether a stencil was shifted (work arrays of the assembly).
    block_flags: Vec<bool>,
    block_spans: Vec<BlockSpan>,
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
        self.frames = [fx, fy];
        self.first.resize(num_particles, [0, 0]);
        for t in self.local.iter_mut() {
            t.resize(num_particles, 0.0);
        }
        let (shifted, zero_weights) = self.fill_local(x, y, workers);
        self.stores_factors = shifted;
        self.zero_weights = zero_weights || shifted;
        if shifted {
            // uGIMP stencils shifted at the grid's edge: their weights are not a function of
            // `t` alone, so every column's factors are stored.
            self.factors.resize(num_particles * 4 * support, 0.0);
            // A fixed stencil size per call lets the compiler unroll the loops.
            match shape.support() {
                2 => self.fill_factors::<2>(x, y, workers),
                3 => self.fill_factors::<3>(x, y, workers),
                4 => self.fill_factors::<4>(x, y, workers),
                s => unreachable!("a support of {s} nodes per axis (at most MAX_SUPPORT = 4)"),
            }
        }
        Ok(())
    }

    /// Writes every particle's first node and kernel coordinates, and the node span; whether
    /// some stencil is shifted ([`Located::shift`](crate::shape)) and whether some weight may be zero
    /// ([`AxisFrame::locate_lanes`](crate::shape)). Every particle must have been accepted.
    fn fill_local(&mut self, x: &[f64], y: &[f64], workers: &Workers) -> (bool, bool) {
        let [sx, sy] = self.strides;
        let frames = self.frames;
        let mut spans = std::mem::take(&mut self.block_spans);
        let [tx, ty] = &mut self.local;
        let out = (&mut self.first[..], [&mut tx[..], &mut ty[..]]);
        workers.split_blocks(out, &mut spans, |start, (firsts, t)| {
            let block = LocalBlock {
                frames,
                strides: [sx as f64, sy as f64],
                x: &x[start..start + firsts.len()],
                y: &y[start..start + firsts.len()],
            };
            #[cfg(target_arch = "x86_64")]
            match crate::lanes::lanes_available() {
                // SAFETY: the CPU has AVX-512F (checked just above).
                8 => return unsafe { fill_local_avx512(&block, firsts, t) },
                // SAFETY: the CPU has AVX2 (checked just above).
                4 => return unsafe { fill_local_avx2(&block, firsts, t) },
                _ => {}
            }
            fill_local_body::<1>(&block, firsts, t)
        });
        let found = spans.iter().fold(BlockSpan::default(), |a, &b| a.join(b));
        self.block_spans = spans;
        self.set_span(x.is_empty(), found);
        (found.shifted, found.zero)
    }

    /// Writes every particle's first node and factors from its position (as
    /// [`AxisFrame::weights`]), and the node span; every particle must have been accepted.
    fn fill_factors<const S: usize>(&mut self, x: &[f64], y: &[f64], workers: &Workers) {
        let [fx, fy] = self.frames;
        let [sx, sy] = self.strides;
        let accepted = "position checked against the allowed region above";
        let mut spans = std::mem::take(&mut self.block_spans);
        let out = (&mut self.first[..], Strided(&mut self.factors[..], 4 * S));
        workers.split_blocks(out, &mut spans, |start, (firsts, Strided(factors, _))| {
            let mut found = BlockSpan {
                shifted: true,
                zero: true,
                ..BlockSpan::default()
            };
            for (j, (first, f)) in firsts.iter_mut().zip(factors.chunks_exact_mut(4 * S)).enumerate() {
                let p = start + j;
                let wx = fx.weights(fx.accept(x[p]).expect(accepted));
                let wy = fy.weights(fy.accept(y[p]).expect(accepted));
                found = found.join(BlockSpan::of_first(wx.first, wy.first, [sx, sy]));
                *first = [wx.first as u32, wy.first as u32];
                f[..S].copy_from_slice(&wx.value[..S]);
                f[S..2 * S].copy_from_slice(&wx.derivative[..S]);
                f[2 * S..3 * S].copy_from_slice(&wy.value[..S]);
                f[3 * S..].copy_from_slice(&wy.derivative[..S]);
            }
            found
        });
        let found = spans.iter().fold(BlockSpan::default(), |a, &b| a.join(b));
        self.block_spans = spans;
        self.set_span(x.is_empty(), found);
    }

    /// The node span and the column span from what the assembly `found`.
    fn set_span(&mut self, empty: bool, found: BlockSpan) {
        let [sx, sy] = self.strides;
        let s = self.support;
        // The last node of a stencil is (S − 1)(sx + sy) after its first.
        (self.span, self.columns) = if empty {
            (0..0, 0..0)
        } else {
            let [a, b] = found.along;
            (found.lo..found.hi + (s - 1) * (sx + sy) + 1, a..b + s)
        };
    }

    /// A per-particle array whose contents the next [`Operators::reassemble`] rewrites whatever
    /// they are, lent as work space (the time loop's sort uses it between two assemblies): the
    /// operators are not usable until reassembled.
    pub(crate) fn reassembly_scratch(&mut self) -> &mut Vec<f64> {
        self.csc.take();
        self.num_particles = 0;
        &mut self.local[0]
    }

    /// Whether the operators store every column's factors (after a fold of the weights by
    /// mirrored walls, or with a uGIMP stencil shifted at the grid's edge) rather than the
    /// kernel coordinates they are computed from.
    pub fn stores_factors(&self) -> bool {
        self.stores_factors
    }

    /// Whether some column may hold a weight of exactly zero (so that a node in a particle's
    /// support may get no mass from it): see [`shape`](mod@crate::shape); always after a fold.
    pub fn may_have_zero_weights(&self) -> bool {
        self.zero_weights
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

    /// The indices along the grid lines (see [`Operators::line_length`]) from the lowest to one
    /// past the highest any particle's support touches: within [`Operators::node_span`], every
    /// row of N, Gx, Gy whose node's index along its line lies outside this range is empty.
    /// (Empty before the first assembly.)
    pub fn column_span(&self) -> std::ops::Range<usize> {
        self.columns.clone()
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
        let [sx, sy] = self.strides;
        let runs_along_x = sx == 1;
        let [i0, j0] = self.first[p];
        let first_ij = [i0 as usize, j0 as usize];
        let ((wx, dwx), (wy, dwy)) = self.factors_of::<S>(p);
        Stencil {
            first: first_ij[0] * sx + first_ij[1] * sy,
            run_stride: if runs_along_x { sy } else { sx },
            runs_along_x,
            wx,
            dwx,
            wy,
            dwy,
            first_ij,
            origin: self.origin,
            cell_size: self.cell_size,
        }
    }

    /// Particle `p`'s 1D weights and derivatives along x and along y.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn factors_of<const S: usize>(&self, p: usize) -> (([f64; S], [f64; S]), ([f64; S], [f64; S])) {
        if self.stores_factors {
            let f = &self.factors[4 * S * p..4 * S * (p + 1)];
            (
                (std::array::from_fn(|a| f[a]), std::array::from_fn(|a| f[S + a])),
                (
                    std::array::from_fn(|a| f[2 * S + a]),
                    std::array::from_fn(|a| f[3 * S + a]),
                ),
            )
        } else {
            let [fx, fy] = &self.frames;
            (
                fx.weights_at::<f64, S>(self.local[0][p]),
                fy.weights_at::<f64, S>(self.local[1][p]),
            )
        }
    }

    /// Each particle's first node as grid indices `[i, j]` (the lowest x and y indices of its
    /// support).
    pub(crate) fn first_nodes(&self) -> &[[u32; 2]] {
        &self.first
    }

    /// Rewrites the factored columns in place, for a boundary rule that folds weights
    /// (`boundary::mirror`): `f(p, first, factors)` may change particle `p`'s first node
    /// indices and its `[wx; S], [w′x; S], [wy; S], [w′y; S]` factors (a stencil must stay on
    /// the grid). The node span is recomputed; the compressed columns are rebuilt on next use.
    pub(crate) fn refold(&mut self, mut f: impl FnMut(usize, &mut [u32; 2], &mut [f64])) {
        let s = self.support;
        if s == 0 || self.num_particles == 0 {
            return;
        }
        if !self.stores_factors {
            self.factors.resize(self.num_particles * 4 * s, 0.0);
            crate::with_support!(self, store_factors::<S>(self));
            self.stores_factors = true;
        }
        self.zero_weights = true;
        for (p, (first, factors)) in self
            .first
            .iter_mut()
            .zip(self.factors.chunks_exact_mut(4 * s))
            .enumerate()
        {
            f(p, first, factors);
        }
        self.csc.take();
        let strides = self.strides;
        let found = self.first.iter().fold(BlockSpan::default(), |a, &[i, j]| {
            a.join(BlockSpan::of_first(i as usize, j as usize, strides))
        });
        self.set_span(self.first.is_empty(), found);
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
}

/// Writes every column's factors from its kernel coordinates into `ops.factors`.
fn store_factors<const S: usize>(ops: &mut Operators) {
    let [fx, fy] = ops.frames;
    let [tx, ty] = &ops.local;
    for (p, f) in ops.factors.chunks_exact_mut(4 * S).enumerate() {
        let (wx, dwx) = fx.weights_at::<f64, S>(tx[p]);
        let (wy, dwy) = fy.weights_at::<f64, S>(ty[p]);
        f[..S].copy_from_slice(&wx);
        f[S..2 * S].copy_from_slice(&dwx);
        f[2 * S..3 * S].copy_from_slice(&wy);
        f[3 * S..].copy_from_slice(&dwy);
    }
}
