//! What the kernels read of the operators, as borrowed views: the layout shared by every column
//! ([`Layout`]), the columns of a range of particles ([`ColumnView`]), and the relocation in
//! place of the explicit step's fused pass, which writes each particle's new column as soon as
//! it has moved ([`Operators::relocation`], [`Operators::finish_relocation`]).

use super::Operators;
use crate::lanes::Real;
use crate::shape::AxisFrame;

/// What every column of the operators shares: the kernel's frames along x and y, the
/// node-number strides, the grid's origin and cell size, the support.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Layout {
    pub(crate) frames: [AxisFrame; 2],
    pub(crate) strides: [usize; 2],
    pub(crate) origin: [f64; 2],
    pub(crate) cell_size: [f64; 2],
    pub(crate) support: usize,
}

impl Layout {
    /// The line (along the slower node axis) of a first node `[i, j]`.
    #[inline(always)]
    pub(crate) fn line_of(&self, [i, j]: [u32; 2]) -> usize {
        if self.strides[0] == 1 {
            j as usize
        } else {
            i as usize
        }
    }
}

/// The columns of a range of particles: entry `k` of each array is particle `first + k`'s
/// (`first` known to the caller), read by [`crate::kernels`].
#[derive(Clone, Copy)]
pub(crate) struct ColumnView<'a> {
    pub(crate) layout: Layout,
    /// Each particle's first node `[i, j]`.
    pub(crate) first: &'a [[u32; 2]],
    /// The kernel coordinates `t_x`, `t_y` (read unless `factors`).
    pub(crate) local: [&'a [f64]; 2],
    /// The stored factors, `4 S` per particle, when the operators store them.
    pub(crate) factors: Option<&'a [f64]>,
}

impl ColumnView<'_> {
    /// The first line of entry `k`'s stencil.
    #[inline(always)]
    pub(crate) fn first_line(&self, k: usize) -> usize {
        self.layout.line_of(self.first[k])
    }
}

/// What the relocation of particles `j …` (one per lane) found: whether every lane was
/// accepted by the grid and unshifted, whether a weight may be zero, and (when usable) the
/// lowest and highest first line and first node of the lanes' stencils.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Relocated {
    pub(crate) usable: bool,
    pub(crate) zero: bool,
    pub(crate) lines: [usize; 2],
    pub(crate) nodes: [usize; 2],
    /// The lanes' lowest and highest first node's index along the lines.
    pub(crate) along: [usize; 2],
}

/// Locates the particles at `(x, y)` (one per lane, [`AxisFrame::locate_lanes`], the same
/// numbers as [`Operators::reassemble`]) and writes their first nodes and kernel coordinates to
/// entries `j …` of `first` and `local`. Nothing is written for lanes that are not accepted or
/// whose stencil would be shifted (uGIMP at the grid's edge): the caller then reassembles.
#[inline(always)]
pub(crate) fn relocate<R: Real>(
    layout: &Layout,
    x: R,
    y: R,
    j: usize,
    first: &mut [[u32; 2]],
    [tx, ty]: [&mut [f64]; 2],
) -> Relocated {
    let [fx, fy] = &layout.frames;
    let (ok_x, first_x, t_x, shifted_x, zero_x) = fx.locate_lanes(x);
    let (ok_y, first_y, t_y, shifted_y, zero_y) = fy.locate_lanes(y);
    let usable = ok_x && ok_y && !shifted_x && !shifted_y;
    let (mut lines, mut nodes, mut along) = ([0; 2], [0; 2], [0; 2]);
    if usable {
        // One store, which the transfers' one load of the same entries then reads
        // (`Real::first_nodes`).
        R::store_pairs(first_x, first_y, first, j);
        t_x.store(tx, j);
        t_y.store(ty, j);
        // Lines and node numbers as exact integers in f64 (below 2⁵³), reduced over the lanes.
        let [sx, sy] = layout.strides;
        let (line, index) = if sx == 1 {
            (first_y, first_x)
        } else {
            (first_x, first_y)
        };
        let node = first_x * R::splat(sx as f64) + first_y * R::splat(sy as f64);
        lines = [line.min_lane() as usize, line.max_lane() as usize];
        along = [index.min_lane() as usize, index.max_lane() as usize];
        nodes = [node.min_lane() as usize, node.max_lane() as usize];
    }
    Relocated {
        usable,
        zero: zero_x || zero_y,
        lines,
        nodes,
        along,
    }
}

impl Operators {
    /// The layout shared by every column.
    #[inline(always)]
    pub(crate) fn layout(&self) -> Layout {
        Layout {
            frames: self.frames,
            strides: self.strides,
            origin: self.origin,
            cell_size: self.cell_size,
            support: self.support,
        }
    }

    /// Every particle's column.
    #[inline(always)]
    pub(crate) fn view(&self) -> ColumnView<'_> {
        ColumnView {
            layout: self.layout(),
            first: &self.first,
            local: [&self.local[0], &self.local[1]],
            factors: self.stores_factors.then_some(&self.factors[..]),
        }
    }

    /// Whether the columns can be rewritten in place by [`relocate`]: assembled from kernel
    /// coordinates (not stored factors) and not from a grid the particles have since left.
    pub(crate) fn relocatable(&self) -> bool {
        !self.stores_factors && self.support > 0 && self.num_particles > 0
    }

    /// The layout and the per-particle arrays that [`relocate`] rewrites. The operators are
    /// not usable until [`Operators::finish_relocation`] (or a reassembly) follows.
    pub(crate) fn relocation(&mut self) -> (Layout, &mut [[u32; 2]], [&mut [f64]; 2]) {
        let layout = self.layout();
        self.csc.take();
        let [tx, ty] = &mut self.local;
        (layout, &mut self.first, [tx, ty])
    }

    /// Marks the operators unusable until reassembled (a relocation stopped at a particle the
    /// grid does not accept).
    pub(crate) fn invalidate(&mut self) {
        self.csc.take();
        self.num_particles = 0;
    }

    /// After every column was rewritten by [`relocate`]: the node span from the lowest and
    /// highest first node `lo`, `hi`, the column span from the lowest and highest first
    /// node's index along the lines `along`, and whether some weight may be zero.
    pub(crate) fn finish_relocation(&mut self, [lo, hi]: [usize; 2], along: [usize; 2], zero: bool) {
        let [sx, sy] = self.strides;
        self.span = lo..hi + (self.support - 1) * (sx + sy) + 1;
        self.columns = along[0]..along[1] + self.support;
        self.zero_weights = zero;
        self.stores_factors = false;
        self.csc.take();
    }
}
