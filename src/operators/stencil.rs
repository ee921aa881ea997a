//! One particle's column of the operators in factored form, [`Stencil`]: the first node and
//! the 1D weights and derivatives along each axis, and the [`with_support!`](crate::with_support)
//! dispatch from the kernel's support to the const-generic kernels.

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
    /// `x_{i0+a} − xp` and `y_{j0+a} − yp` with `x_i = x₀ + i·hx` (as [`Grid::node_position`](crate::grid::Grid::node_position)).
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

/// Calls `$f::<S>(…)` with `S` bound to the support of the operators' shape function as a
/// constant (2, 3 or 4 nodes per axis, [`crate::ShapeFunction::support`]), so that the loops
/// over a stencil unroll.
#[macro_export]
#[doc(hidden)]
macro_rules! with_support {
    ($ops:expr, $f:ident :: <S $(, $g:tt)*> ( $($arg:expr),* $(,)? )) => {
        match $ops.shape_function().support() {
            2 => $f::<2 $(, $g)*>($($arg),*),
            3 => $f::<3 $(, $g)*>($($arg),*),
            4 => $f::<4 $(, $g)*>($($arg),*),
            s => unreachable!("a support of {s} nodes per axis (at most MAX_SUPPORT = 4)"),
        }
    };
}
