//! Shape functions: 1D kernels and their 2D tensor products.
//!
//! A 2D shape function is the product of 1D kernels, `S_I(x, y) = S(ξ) S(η)` with
//! `ξ = (x − x_I)/hx`, `η = (y − y_I)/hy`, and its gradient is
//! `∇S_I = (S'(ξ) S(η)/hx, S(ξ) S'(η)/hy)`. Each kernel gives, for one coordinate, the first
//! node of the point's support and the values and derivatives on the `support()` consecutive
//! nodes from there; the [operators](crate::operators) multiply them out.
//!
//! # The kernels
//!
//! | [`ShapeFunction`] | kernel | nodes per axis | entries per column | continuity | margin (cells) |
//! |---|---|---|---|---|---|
//! | `Linear` | tent, [`linear`] | 2 | 4 | C⁰ | 0 |
//! | `Gimp { half_width: l }` | uGIMP, [`gimp`] | 3 | 9 | C¹ | `l` |
//! | `QuadraticBSpline` | [`bspline::quadratic`] | 3 | 9 | C¹ | 1/2 |
//! | `CubicBSpline` | [`bspline::cubic`] | 4 | 16 | C² | 1 |
//!
//! ```text
//! linear     S(ξ) = 1 − |ξ|                                  |ξ| ≤ 1
//! uGIMP      S(ξ) = 1 − (ξ² + l²)/(2l)                       |ξ| < l
//!                 = 1 − |ξ|                                  l ≤ |ξ| ≤ 1 − l
//!                 = (1 + l − |ξ|)²/(4l)                      1 − l < |ξ| < 1 + l
//! quadratic  S(ξ) = 3/4 − ξ²                                 |ξ| < 1/2
//!                 = (3/2 − |ξ|)²/2                           1/2 ≤ |ξ| < 3/2
//! cubic      S(ξ) = 2/3 − ξ² + |ξ|³/2                        |ξ| < 1
//!                 = (2 − |ξ|)³/6                             1 ≤ |ξ| < 2
//! ```
//!
//! Every column of N, Gx, Gy has exactly `support()²` stored entries, row indices ascending,
//! even where a weight is exactly zero (a point at a breakpoint of the kernel), so the
//! pattern depends only on which nodes the stencil starts at.
//!
//! # Near the grid's edge
//! The library never truncates a kernel: a point's whole support must be grid nodes, so the
//! shape functions sum to one everywhere a point is accepted. A point must therefore keep
//! [`ShapeFunction::margin`] cells away from the grid's edge along each axis
//! ([`ShapeFunction::allowed_region`]); otherwise [`ShapeFunction::axis_weights`] returns
//! `None`, [`evaluate`] returns zeros and [`Operators::reassemble`](crate::Operators::reassemble)
//! fails with [`MpmError::SupportOutsideGrid`]. A point a hair (up to
//! `1e-9` cells, rounding) outside `[margin, cells − margin]` in cell coordinates is moved onto
//! the allowed boundary; a point outside the grid altogether is
//! [`MpmError::ParticleOutsideGrid`] as before.
//!
//! Holding [`ShapeFunction::boundary_layers`] node layers at zero normal velocity at a wall
//! keeps particles from ever reaching the margin (in continuous time): a particle exactly at
//! the margin has zero weight on every other node, so its normal velocity there is zero. Pad
//! the grid by [`ShapeFunction::recommended_padding`] cells so that the innermost held layer
//! sits at the physical wall. On a fixed edge the layers beyond that wall are mirrored rather
//! than held by default ([`crate::boundary::WallRule`], [`crate::boundary::mirror`]): the
//! operators fold their weights onto the interior. See docs/shape_functions.md.
//!
//! [`shape`] and [`dshape`] are the seed's bilinear functions whatever the family;
//! [`evaluate`] works for every kernel.

pub mod bspline;
pub mod gimp;
pub mod linear;

use std::fmt;
use std::str::FromStr;

use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::lanes::Real;
use crate::names::{self, Spelled};

/// Largest support (nodes per axis) of any kernel: 4, for cubic B-splines. Fixed-size buffers
/// use it.
pub const MAX_SUPPORT: usize = 4;

/// How far, in cell units, a point's cell coordinate may fall outside
/// `[margin, cells − margin]` and still be accepted (and moved onto that interval): rounding
/// in `(x − x₀)/h` and in positions computed as `x₀ + margin·h` is many orders of magnitude
/// smaller, while moving a point by `1e-9` cells changes its weights by at most ~`1e-9`.
pub const MARGIN_TOLERANCE: f64 = 1e-9;

/// The shape-function family used to build N, Gx, Gy.
///
/// Kernels, support and behaviour at the grid's edge are described in the
/// [module docs](self) and in docs/shape_functions.md.
///
/// As text ([`crate::names`]): `linear`, `gimp[:l]` (default `l` = 0.25), `quadratic_bspline`,
/// `cubic_bspline` (read also as `quadratic` and `cubic`; scene files may write
/// `{ gimp = { half_width = l } }`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ShapeFunction {
    /// Bilinear (tent) functions: 2 × 2 nodes per particle, C⁰, gradients jump at grid lines.
    /// See [`linear`].
    ///
    /// ```text
    /// S(ξ) = max(0, 1 − |ξ|)
    /// ```
    #[default]
    Linear,
    /// uGIMP: particle domain of half-width `half_width` cells (lp = half_width·h per axis),
    /// fixed in time. 3 × 3 nodes per particle, C¹. `half_width` must be in `(0, 1/2]`;
    /// `1/(2k)` for `k × k` particles per cell fills the cells exactly. See [`gimp`].
    ///
    /// ```text
    /// S(ξ) = 1 − (ξ² + l²)/(2l)       |ξ| < l              (l = half_width)
    ///      = 1 − |ξ|                  l ≤ |ξ| ≤ 1 − l
    ///      = (1 + l − |ξ|)²/(4l)      1 − l < |ξ| < 1 + l
    ///      = 0                        otherwise
    /// ```
    Gimp {
        /// Half-width `l = lp/h` of the particle domain, in cells of each axis.
        half_width: f64,
    },
    /// Uniform node-centred quadratic B-spline: 3 × 3 nodes per particle, C¹. See [`bspline`].
    ///
    /// ```text
    /// S(ξ) = 3/4 − ξ²                 |ξ| < 1/2
    ///      = (3/2 − |ξ|)²/2           1/2 ≤ |ξ| < 3/2
    ///      = 0                        otherwise
    /// ```
    QuadraticBSpline,
    /// Uniform node-centred cubic B-spline: 4 × 4 nodes per particle, C². See [`bspline`].
    ///
    /// ```text
    /// S(ξ) = 2/3 − ξ² + |ξ|³/2        |ξ| < 1
    ///      = (2 − |ξ|)³/6             1 ≤ |ξ| < 2
    ///      = 0                        otherwise
    /// ```
    CubicBSpline,
}

/// One of each family (GIMP at its default half-width), for studies and tests that run them all.
pub const FAMILIES: [ShapeFunction; 4] = [
    ShapeFunction::Linear,
    ShapeFunction::Gimp {
        half_width: DEFAULT_GIMP_HALF_WIDTH,
    },
    ShapeFunction::QuadraticBSpline,
    ShapeFunction::CubicBSpline,
];

/// How a kernel's APIC inertia `D_p` is obtained ([`ShapeFunction::apic_inertia`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ApicInertia {
    /// Linear kernels: the particle stores `C_p` itself (their `D_p` vanishes on grid lines).
    StoredC,
    /// B-splines: `D_p = diag(dxx, dyy)`, the same for every particle.
    Constant([f64; 2]),
    /// GIMP: summed over the particle's column.
    Column,
}

impl ApicInertia {
    /// The inertia of `shape` on `grid` ([`ShapeFunction::apic_inertia`]).
    pub fn of(shape: ShapeFunction, grid: &Grid) -> ApicInertia {
        shape.apic_inertia(grid)
    }
}

/// uGIMP's default particle half-width, a quarter cell (2 × 2 particles per cell).
pub const DEFAULT_GIMP_HALF_WIDTH: f64 = 0.25;

impl fmt::Display for ShapeFunction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ShapeFunction::Gimp { half_width } => names::write(f, "gimp", &[half_width]),
            ShapeFunction::Linear | ShapeFunction::QuadraticBSpline | ShapeFunction::CubicBSpline => f.pad(self.name()),
        }
    }
}

impl FromStr for ShapeFunction {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<ShapeFunction, String> {
        let s = Spelled::parse(text)?;
        let shape = match s.name {
            "linear" => ShapeFunction::Linear,
            "gimp" => ShapeFunction::Gimp {
                half_width: s.param(0, Some(DEFAULT_GIMP_HALF_WIDTH))?,
            },
            "quadratic_bspline" | "quadratic" => ShapeFunction::QuadraticBSpline,
            "cubic_bspline" | "cubic" => ShapeFunction::CubicBSpline,
            _ => {
                return Err(format!(
                    "unknown shape function `{text}` (linear, gimp[:half_width], quadratic_bspline, cubic_bspline)"
                ))
            }
        };
        if !matches!(shape, ShapeFunction::Gimp { .. }) {
            s.no_params()?;
        }
        Ok(shape)
    }
}

impl names::Choice for ShapeFunction {
    const EXPECTING: &'static str = "a shape function (linear, gimp:l, quadratic_bspline, cubic_bspline)";
    const PARAMETERS: &'static [(&'static str, &'static [&'static str])] = &[("gimp", &["half_width"])];
}

names::choice_serde!(ShapeFunction);

/// One axis of a point's support: nodes `first .. first + len` along that axis carry
/// `value[k]` and `derivative[k]` (already divided by the cell size).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisWeights {
    /// Index along the axis of the first supporting node.
    pub first: usize,
    /// Number of supporting nodes.
    pub len: usize,
    /// Kernel values `S`.
    pub value: [f64; MAX_SUPPORT],
    /// Kernel derivatives `dS/dx`, per unit length.
    pub derivative: [f64; MAX_SUPPORT],
}

impl ShapeFunction {
    /// The family's name: `"linear"`, `"gimp"`, `"quadratic_bspline"` or `"cubic_bspline"`.
    pub fn name(&self) -> &'static str {
        match self {
            ShapeFunction::Linear => "linear",
            ShapeFunction::Gimp { .. } => "gimp",
            ShapeFunction::QuadraticBSpline => "quadratic_bspline",
            ShapeFunction::CubicBSpline => "cubic_bspline",
        }
    }

    /// Checks the family's parameters: a GIMP `half_width` must be finite and in `(0, 1/2]`.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] named `"half_width"` otherwise.
    pub fn validate(&self) -> Result<()> {
        match *self {
            ShapeFunction::Gimp { half_width } if !gimp_half_width_is_valid(half_width) => {
                Err(MpmError::InvalidParameter {
                    name: "half_width",
                    value: half_width,
                    reason: "the uGIMP particle half-width must be a finite number of cells in (0, 0.5]",
                })
            }
            ShapeFunction::Gimp { .. }
            | ShapeFunction::Linear
            | ShapeFunction::QuadraticBSpline
            | ShapeFunction::CubicBSpline => Ok(()),
        }
    }

    /// Nodes per axis in a point's support: linear 2, GIMP 3, quadratic 3, cubic 4.
    pub fn support(&self) -> usize {
        match self {
            ShapeFunction::Linear => linear::SUPPORT,
            ShapeFunction::Gimp { .. } => gimp::SUPPORT,
            ShapeFunction::QuadraticBSpline => bspline::QUADRATIC_SUPPORT,
            ShapeFunction::CubicBSpline => bspline::CUBIC_SUPPORT,
        }
    }

    /// Entries per column of N, Gx, Gy: `support()²`.
    pub fn nodes_per_particle(&self) -> usize {
        self.support() * self.support()
    }

    /// The distance, in cells of each axis, a point must keep from the grid's edge so that its
    /// whole support is on the grid: linear 0, GIMP `half_width`, quadratic 1/2, cubic 1.
    pub fn margin(&self) -> f64 {
        match *self {
            ShapeFunction::Linear => 0.0,
            ShapeFunction::Gimp { half_width } => half_width,
            ShapeFunction::QuadraticBSpline => 0.5,
            ShapeFunction::CubicBSpline => 1.0,
        }
    }

    /// How many node layers next to an edge must be held at zero normal velocity so that
    /// particles never come closer to that edge than [`ShapeFunction::margin`]: linear 1,
    /// GIMP 2, quadratic 2, cubic 3.
    ///
    /// With the layers `0 .. boundary_layers()` held, a point exactly at the margin has zero
    /// weight on every other node (linear at `s = 0`: only node 0; GIMP at `s = l`: nodes 0
    /// and 1 carry `1 − l` and `l`; quadratic at `s = 1/2`: `1/2, 1/2` on nodes 0, 1; cubic at
    /// `s = 1`: `1/6, 2/3, 1/6` on nodes 0, 1, 2), so its interpolated normal velocity is zero
    /// and, the weights being Lipschitz, it tends to zero as a particle approaches the margin.
    /// One layer fewer leaves a node with a non-zero weight free.
    pub fn boundary_layers(&self) -> usize {
        match self {
            ShapeFunction::Linear => 1,
            ShapeFunction::Gimp { .. } | ShapeFunction::QuadraticBSpline => 2,
            ShapeFunction::CubicBSpline => 3,
        }
    }

    /// Cells to add on each side of a physical domain so that the innermost of the
    /// [`boundary_layers`](ShapeFunction::boundary_layers) held at a wall lies on the wall:
    /// `boundary_layers() − 1` (linear 0, GIMP 1, quadratic 1, cubic 2). It is at least
    /// `⌈margin⌉`, so every point of the unpadded domain is then accepted.
    pub fn recommended_padding(&self) -> usize {
        self.boundary_layers() - 1
    }

    /// Fewest cells along an axis that can hold a point's support: `support() − 1`.
    pub fn min_cells(&self) -> usize {
        self.support() - 1
    }

    /// Polynomial degree of the grid functions: linear and GIMP 1 (GIMP's weights integrate the
    /// bilinear grid functions over the particle's domain, so its grid space is bilinear),
    /// quadratic 2, cubic 3.
    pub fn degree(&self) -> usize {
        match self {
            ShapeFunction::Linear | ShapeFunction::Gimp { .. } => 1,
            ShapeFunction::QuadraticBSpline => 2,
            ShapeFunction::CubicBSpline => 3,
        }
    }

    /// Whether the weights' gradients are continuous as a particle crosses a grid line (all but
    /// the bilinear functions, whose gradient jumps there).
    pub fn continuous_gradient(&self) -> bool {
        !matches!(self, ShapeFunction::Linear)
    }

    /// How APIC obtains the inertia `D_p = Σ_I N_I (x_I − x_p)(x_I − x_p)ᵀ` on `grid`: stored
    /// `C_p` for the bilinear functions (their `D_p` vanishes on grid lines), `h²/4` (quadratic)
    /// and `h²/3` (cubic B-splines) per axis, summed over the column for GIMP.
    pub fn apic_inertia(&self, grid: &Grid) -> ApicInertia {
        let [hx, hy] = grid.cell_size();
        match self {
            ShapeFunction::Linear => ApicInertia::StoredC,
            ShapeFunction::QuadraticBSpline => ApicInertia::Constant([hx * hx / 4.0, hy * hy / 4.0]),
            ShapeFunction::CubicBSpline => ApicInertia::Constant([hx * hx / 3.0, hy * hy / 3.0]),
            ShapeFunction::Gimp { .. } => ApicInertia::Column,
        }
    }

    /// Why a consistent mass with these functions can be singular, in the words of the kernel
    /// (for the message of a singular mass matrix).
    pub fn singular_mass_example(&self) -> &'static str {
        match self {
            ShapeFunction::Linear => "one particle in a bilinear cell is not enough",
            ShapeFunction::Gimp { .. } => {
                "one particle per cell is not enough: GIMP's weights are bilinear wherever a particle's domain lies \
                 inside one cell"
            }
            ShapeFunction::QuadraticBSpline => {
                "a quadratic B-spline node is read across 3 × 3 cells, and sparse particles at a body's edge leave \
                 some of its combinations unseen"
            }
            ShapeFunction::CubicBSpline => {
                "a cubic B-spline node is read across 4 × 4 cells, and sparse particles at a body's edge leave some \
                 of its combinations unseen"
            }
        }
    }

    /// The interior period-error coefficients `[c_lumped, c_consistent]` of the explicit update
    /// with quarter-point particles, in `c θ²/96` (`θ = k h`, docs/mass.md), where a closed form
    /// is known: quadratic B-splines `[25, 1]`, cubic `[32, 0]`.
    pub fn interior_period_error(&self) -> Option<[f64; 2]> {
        match self {
            ShapeFunction::QuadraticBSpline => Some([25.0, 1.0]),
            ShapeFunction::CubicBSpline => Some([32.0, 0.0]),
            ShapeFunction::Linear | ShapeFunction::Gimp { .. } => None,
        }
    }

    /// `[x_min, x_max, y_min, y_max]` of the region where points are accepted: the grid shrunk
    /// by [`margin`](ShapeFunction::margin) cells on every side, `x₀ + margin·hx` to
    /// `x₀ + (cx − margin)·hx` and likewise in y. Points on its boundary are accepted.
    pub fn allowed_region(&self, grid: &Grid) -> [f64; 4] {
        let m = self.margin();
        let ([x0, y0], [hx, hy], [cx, cy]) = (grid.origin(), grid.cell_size(), grid.cells());
        [
            x0 + m * hx,
            x0 + (cx as f64 - m) * hx,
            y0 + m * hy,
            y0 + (cy as f64 - m) * hy,
        ]
    }

    /// The constants that accept points along `axis` and compute their weights, worked out
    /// once per grid, axis and family (the operators use one per axis for all particles).
    #[inline]
    pub(crate) fn axis_frame(&self, grid: &Grid, axis: usize) -> AxisFrame {
        let cells = grid.cells()[axis];
        let bounds = grid.bounds();
        let margin = self.margin();
        let valid = match *self {
            ShapeFunction::Gimp { half_width } => gimp_half_width_is_valid(half_width),
            ShapeFunction::Linear | ShapeFunction::QuadraticBSpline | ShapeFunction::CubicBSpline => true,
        };
        AxisFrame {
            shape: *self,
            origin: grid.origin()[axis],
            lo: bounds[2 * axis],
            hi: bounds[2 * axis + 1],
            cells,
            margin,
            top: cells as f64 - margin,
            half_inv_l: match *self {
                ShapeFunction::Gimp { half_width } if valid => 0.5 / half_width,
                ShapeFunction::Gimp { .. }
                | ShapeFunction::Linear
                | ShapeFunction::QuadraticBSpline
                | ShapeFunction::CubicBSpline => 0.0,
            },
            inv_h: 1.0 / grid.cell_size()[axis],
            usable: valid && cells >= self.min_cells(),
        }
    }

    /// The 1D weights along `axis` (0 = x, 1 = y) of a point at coordinate `value`, or `None`
    /// if the point is outside the grid along that axis or its support would leave the grid
    /// (the point is closer than [`margin`](ShapeFunction::margin) cells to the edge, or the
    /// grid has fewer than [`min_cells`](ShapeFunction::min_cells) cells along the axis), or
    /// the family's parameters are invalid.
    ///
    /// Only the `support()` supporting nodes are evaluated, with no allocation.
    #[inline]
    pub fn axis_weights(&self, grid: &Grid, axis: usize, value: f64) -> Option<AxisWeights> {
        let frame = self.axis_frame(grid, axis);
        frame.accept(value).map(|s| frame.weights(s))
    }
}

/// Per-axis constants for accepting points and computing their weights; see
/// [`ShapeFunction::axis_frame`].
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct AxisFrame {
    shape: ShapeFunction,
    origin: f64,
    lo: f64,
    hi: f64,
    cells: usize,
    margin: f64,
    top: f64,
    /// `1/(2·half_width)` for GIMP (0 otherwise), so that weights need no division.
    half_inv_l: f64,
    /// `1/h`.
    inv_h: f64,
    /// The family's parameters are valid and the axis has at least `min_cells()` cells.
    usable: bool,
}

impl AxisFrame {
    /// Whether a point at `value` is accepted: inside the grid, no closer to its edge than the
    /// margin (up to [`MARGIN_TOLERANCE`]), and the frame usable. This is the one definition
    /// of an accepted point. Branch-free (non-short-circuit `&`), so a pass over all
    /// particles vectorises; NaN is rejected.
    #[inline]
    pub(crate) fn accepts(&self, value: f64) -> bool {
        // Inside the bounds, rounding may put (x − x₀)/h a hair outside [margin, cells − margin].
        let s = self.cell_coordinate(value);
        self.usable
            & (value >= self.lo)
            & (value <= self.hi)
            & (s >= self.margin - MARGIN_TOLERANCE)
            & (s <= self.top + MARGIN_TOLERANCE)
    }

    /// The cell coordinate `s = (value − x₀)/h` of an accepted point (see
    /// [`AxisFrame::accepts`]), clamped to `[margin, cells − margin]`; `None` otherwise.
    #[inline]
    pub(crate) fn accept(&self, value: f64) -> Option<f64> {
        self.accepts(value)
            .then(|| self.cell_coordinate(value).clamp(self.margin, self.top))
    }

    /// `s = (value − x₀) · (1/h)`, the coordinate in cells.
    #[inline(always)]
    fn cell_coordinate(&self, value: f64) -> f64 {
        (value - self.origin) * self.inv_h
    }

    /// Where the stencil of a point at an accepted, clamped cell coordinate `s` (from
    /// [`AxisFrame::accept`]) starts, and the point's coordinate `t` that its kernel's weights
    /// are a function of ([`AxisFrame::weights_at`]).
    #[inline(always)]
    pub(crate) fn locate(&self, s: f64) -> Located {
        let cells = self.cells;
        // `s ∈ [margin, cells − margin]`, and `cells ≥ min_cells()`, so every `first` below
        // leaves the whole stencil on nodes `0 ..= cells`. As `s ≥ 0`, `as usize` (truncation)
        // is the floor, without a call to libm's `floor`.
        match self.shape {
            ShapeFunction::Linear => {
                // The cell the point belongs to: half-open, the last one closed.
                let cell = (s as usize).min(cells - 1);
                Located::at(cell, s - cell as f64)
            }
            ShapeFunction::Gimp { .. } => {
                // The nearest node in the middle. Within half a cell of the edge (c = 0 or
                // c = cells) the outer neighbour is off the grid but has weight 0 (the point is
                // at least `half_width` cells inside), and so has the node on the other side
                // two cells away: shift the stencil onto the grid.
                let c = (s + 0.5) as usize;
                let t = s - c as f64;
                if c == 0 {
                    Located { first: 0, t, shift: 1 }
                } else if c >= cells {
                    Located {
                        first: cells - 2,
                        t,
                        shift: -1,
                    }
                } else {
                    Located::at(c - 1, t)
                }
            }
            ShapeFunction::QuadraticBSpline => {
                // The nearest node in the middle; at `s = cells − 1/2` (exactly) the upper
                // neighbour would be off the grid, so the stencil takes the lower one (t = 1/2).
                let c = ((s + 0.5) as usize).clamp(1, cells - 1);
                Located::at(c - 1, s - c as f64)
            }
            ShapeFunction::CubicBSpline => {
                // Nodes c − 1 ..= c + 2 around the cell [c, c + 1] holding the point; at
                // `s = cells − 1` (exactly) the stencil ends at the last node (t = 1).
                let c = (s as usize).clamp(1, cells - 2);
                Located::at(c - 1, s - c as f64)
            }
        }
    }

    /// [`AxisFrame::accept`] and [`AxisFrame::locate`] for one point or four side by side, with
    /// the first node as a float (an exact integer): `(accepted, first, t, shifted, zero)`,
    /// `accepted` and the flags for all lanes together — every lane accepted; some stencil
    /// shifted ([`Located::shift`]; its `first` is then not the scalar one); some weight
    /// possibly zero (linear and the cubic B-spline at `t = 0` or `1`, the quadratic B-spline
    /// at `t = ±1/2`; uGIMP always, its outer nodes carrying no weight whenever the particle's
    /// domain does not reach them). Otherwise the same numbers as the scalar functions.
    #[inline(always)]
    pub(crate) fn locate_lanes<R: Real>(&self, value: R) -> (bool, R, R, bool, bool) {
        let c = R::splat;
        let raw = (value - c(self.origin)) * c(self.inv_h);
        let accepted = self.usable
            && value.all_ge(c(self.lo))
            && c(self.hi).all_ge(value)
            && raw.all_ge(c(self.margin - MARGIN_TOLERANCE))
            && c(self.top + MARGIN_TOLERANCE).all_ge(raw);
        let s = raw.clamp(self.margin, self.top);
        let cells = self.cells as f64;
        let (first, t, shifted, zero) = match self.shape {
            ShapeFunction::Linear => {
                let cell = s.floor_nonneg().min(c(cells - 1.0));
                let t = s - cell;
                (cell, t, false, t.any_eq(c(0.0)) || t.any_eq(c(1.0)))
            }
            ShapeFunction::Gimp { .. } => {
                let node = (s + c(0.5)).floor_nonneg();
                let shifted = node.any_eq(c(0.0)) || !c(cells).all_gt(node);
                (node - c(1.0), s - node, shifted, true)
            }
            ShapeFunction::QuadraticBSpline => {
                let node = (s + c(0.5)).floor_nonneg().max(c(1.0)).min(c(cells - 1.0));
                let t = s - node;
                (node - c(1.0), t, false, t.abs().any_eq(c(0.5)))
            }
            ShapeFunction::CubicBSpline => {
                let node = s.floor_nonneg().max(c(1.0)).min(c(cells - 2.0));
                let t = s - node;
                (node - c(1.0), t, false, t.any_eq(c(0.0)) || t.any_eq(c(1.0)))
            }
        };
        (accepted, first, t, shifted, zero)
    }

    /// The `S` weights and derivatives (per unit length) of the kernel at `t` (one point, or
    /// four side by side): linear `cell_weights(t)`, uGIMP `nearest_weights(t, l)`, the
    /// B-splines `quadratic_weights(t)` and `cubic_weights(t)`, derivatives times `1/h`. `S`
    /// must be the family's support; the stencil is unshifted ([`Located::shift`] 0).
    #[inline(always)]
    pub(crate) fn weights_at<R: Real, const S: usize>(&self, t: R) -> ([R; S], [R; S]) {
        let inv_h = R::splat(self.inv_h);
        #[inline(always)]
        fn fit<R: Real, const L: usize, const S: usize>((w, d): ([R; L], [R; L]), inv_h: R) -> ([R; S], [R; S]) {
            debug_assert!(L <= S, "the stencil holds the family's support");
            let zero = R::splat(0.0);
            let (mut value, mut derivative) = ([zero; S], [zero; S]);
            for k in 0..L {
                value[k] = w[k];
                derivative[k] = d[k] * inv_h;
            }
            (value, derivative)
        }
        match self.shape {
            ShapeFunction::Linear => fit(linear::cell_weights_of(t), inv_h),
            ShapeFunction::Gimp { half_width } => fit(gimp::nearest_weights_of(t, half_width, self.half_inv_l), inv_h),
            ShapeFunction::QuadraticBSpline => fit(bspline::quadratic_weights_of(t), inv_h),
            ShapeFunction::CubicBSpline => fit(bspline::cubic_weights_of(t), inv_h),
        }
    }

    /// The weights at an accepted, clamped cell coordinate `s` (from [`AxisFrame::accept`]).
    #[inline(always)]
    pub(crate) fn weights(&self, s: f64) -> AxisWeights {
        let at = self.locate(s);
        let len = self.shape.support();
        let (w, d) = self.weights_at::<f64, MAX_SUPPORT>(at.t);
        let mut out = AxisWeights {
            first: at.first,
            len,
            value: [0.0; MAX_SUPPORT],
            derivative: [0.0; MAX_SUPPORT],
        };
        // A shifted stencil (uGIMP at an edge) holds the kernel's nodes one place along.
        for k in 0..len {
            let from = k as isize + at.shift as isize;
            if (0..len as isize).contains(&from) {
                out.value[k] = w[from as usize];
                out.derivative[k] = d[from as usize];
            }
        }
        out
    }
}

/// Where a point's stencil lies along one axis ([`AxisFrame::locate`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Located {
    /// Index along the axis of the stencil's first node.
    pub(crate) first: usize,
    /// The coordinate the kernel's weights are a function of: from the stencil's cell (linear,
    /// `[0, 1]`), from the second node (quadratic B-spline and uGIMP, `[−1/2, 1/2]`; cubic
    /// B-spline, `[0, 1]`), in cells.
    pub(crate) t: f64,
    /// uGIMP within half a cell of the grid's edge: the stencil moved by one node onto the grid
    /// (+1 at the low edge, −1 at the high edge), its weights with it; 0 otherwise.
    pub(crate) shift: i8,
}

impl Located {
    fn at(first: usize, t: f64) -> Located {
        Located { first, t, shift: 0 }
    }
}

fn gimp_half_width_is_valid(half_width: f64) -> bool {
    half_width > 0.0 && half_width <= 0.5
}

/// The bilinear shape function of node `node` at `(x, y)`: the seed's `shape(n, x, y)`,
///
/// ```text
/// N_I(x, y) = S((x − x_I)/hx) · S((y − y_I)/hy),   S(ξ) = max(0, 1 − |ξ|).
/// ```
///
/// It is exactly the entry `N[node, p]` the operators assemble for a particle at `(x, y)`,
/// and 0 for a node outside the point's cell or a point outside the grid.
///
/// # Panics
/// If `node >= grid.num_nodes()`.
pub fn shape(grid: &Grid, node: usize, x: f64, y: f64) -> f64 {
    evaluate(grid, ShapeFunction::Linear, node, x, y).0
}

/// The gradient of the bilinear shape function of node `node` at `(x, y)`: the seed's
/// `dshape(n, x, y)`, returned as `(∂N_I/∂x, ∂N_I/∂y)`:
///
/// ```text
/// ∂N_I/∂x = S'(ξ) S(η) / hx,   ∂N_I/∂y = S(ξ) S'(η) / hy.
/// ```
///
/// On a grid line the derivative is taken from the cell the point belongs to (see
/// [`linear`] for the convention); the value equals the entries `Gx[node, p]`, `Gy[node, p]`.
///
/// # Panics
/// If `node >= grid.num_nodes()`.
pub fn dshape(grid: &Grid, node: usize, x: f64, y: f64) -> (f64, f64) {
    let (_, gx, gy) = evaluate(grid, ShapeFunction::Linear, node, x, y);
    (gx, gy)
}

/// Value and gradient `(S_I, ∂S_I/∂x, ∂S_I/∂y)` of node `node`'s shape function of family
/// `shape` at `(x, y)`, for every family: exactly the entries `N[node, p]`, `Gx[node, p]`,
/// `Gy[node, p]` the operators assemble for a particle at `(x, y)`.
///
/// Zeros when the node is not in the point's support, and for every node when the point is
/// not accepted: outside the grid, closer than [`ShapeFunction::margin`] cells to its edge
/// (where the operators report [`MpmError::SupportOutsideGrid`]), or `shape` is invalid.
///
/// # Panics
/// If `node >= grid.num_nodes()`.
pub fn evaluate(grid: &Grid, shape: ShapeFunction, node: usize, x: f64, y: f64) -> (f64, f64, f64) {
    let (i, j) = grid.node_ij(node);
    let (Some(wx), Some(wy)) = (shape.axis_weights(grid, 0, x), shape.axis_weights(grid, 1, y)) else {
        return (0.0, 0.0, 0.0);
    };
    let in_support = |w: &AxisWeights, k: usize| (w.first..w.first + w.len).contains(&k);
    if !(in_support(&wx, i) && in_support(&wy, j)) {
        return (0.0, 0.0, 0.0);
    }
    let (a, b) = (i - wx.first, j - wy.first);
    (
        wx.value[a] * wy.value[b],
        wx.derivative[a] * wy.value[b],
        wx.value[a] * wy.derivative[b],
    )
}
