//! Shape functions: 1D kernels and their 2D tensor products.
//!
//! A 2D shape function is the product of 1D kernels, `S_I(x, y) = S(ξ) S(η)` with
//! `ξ = (x − x_I)/hx`, `η = (y − y_I)/hy`, and its gradient is
//! `∇S_I = (S'(ξ) S(η)/hx, S(ξ) S'(η)/hy)`. Each kernel gives, for one coordinate, the first
//! node of the point's support and the values and derivatives on the `support()` consecutive
//! nodes from there; the [operators](crate::operators) multiply them out.

pub mod linear;

use crate::grid::Grid;

/// Largest support (nodes per axis) of any kernel the library has or will have (cubic
/// B-splines need 4); fixed-size buffers use it.
pub const MAX_SUPPORT: usize = 4;

/// The shape-function family used to build N, Gx, Gy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ShapeFunction {
    /// Bilinear (tent) functions: 2 × 2 nodes per particle, C⁰, gradients jump at grid lines.
    #[default]
    Linear,
}

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
    /// Nodes per axis in a point's support (2 for linear).
    pub fn support(&self) -> usize {
        match self {
            ShapeFunction::Linear => linear::SUPPORT,
        }
    }

    /// Entries per column of N, Gx, Gy: `support()²`.
    pub fn nodes_per_particle(&self) -> usize {
        self.support() * self.support()
    }

    /// The 1D weights along `axis` (0 = x, 1 = y) of a point at coordinate `value`, or `None`
    /// if the point is outside the grid along that axis.
    pub fn axis_weights(&self, grid: &Grid, axis: usize, value: f64) -> Option<AxisWeights> {
        let cells = grid.cells()[axis];
        let h = grid.cell_size()[axis];
        let [lo, hi] = [grid.bounds()[2 * axis], grid.bounds()[2 * axis + 1]];
        if !(lo..=hi).contains(&value) {
            return None;
        }
        // Inside the bounds, rounding may put (x − x₀)/h a hair outside [0, cells].
        let s = grid.cell_coordinate(axis, value).clamp(0.0, cells as f64);
        match self {
            ShapeFunction::Linear => {
                let cell = (s.floor() as usize).min(cells - 1);
                let (w, dw) = linear::cell_weights(s - cell as f64);
                let mut out = AxisWeights {
                    first: cell,
                    len: 2,
                    value: [0.0; MAX_SUPPORT],
                    derivative: [0.0; MAX_SUPPORT],
                };
                out.value[..2].copy_from_slice(&w);
                out.derivative[..2].copy_from_slice(&[dw[0] / h, dw[1] / h]);
                Some(out)
            }
        }
    }
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
/// `shape` at `(x, y)`; zeros when the node is not in the point's support.
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
