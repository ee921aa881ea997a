//! The linear (tent) kernel, whose tensor product is the bilinear shape function.
//!
//! In cell units `ξ = (x − x_I)/h`:
//!
//! ```text
//! S(ξ)  = 1 − |ξ|            for |ξ| ≤ 1,   0 otherwise
//! S'(ξ) = −sign(ξ)           for |ξ| < 1,   0 otherwise      (per unit ξ; divide by h for d/dx)
//! ```
//!
//! # The gradient at a kink
//! `S` has kinks at `ξ = −1, 0, 1` (the point lies on a grid line) where the derivative jumps.
//! The library takes the derivative from the cell the point belongs to. Cells are half-open
//! on their upper side (see [`crate::grid`]), so at an interior grid line this is the
//! **right-hand derivative**: `S'(−1) = +1`, `S'(0) = −1`, `S'(1) = 0`. On the grid's last line
//! along an axis the point belongs to the last cell and the derivative is the left-hand one.
//! Either way the gradients of the nodes of that cell still sum to zero and reproduce linear
//! fields exactly.
//!
//! # At the grid's edge
//! The support is the point's cell, always on the grid: the margin is 0, every point of the
//! closed grid rectangle is accepted, and a wall holds one node layer
//! ([`ShapeFunction::boundary_layers`](super::ShapeFunction::boundary_layers)).

use crate::lanes::Real;

/// Nodes per axis in the support of a point: 2.
pub const SUPPORT: usize = 2;

/// Tent value `S(ξ) = max(0, 1 − |ξ|)`.
pub fn tent(xi: f64) -> f64 {
    (1.0 - xi.abs()).max(0.0)
}

/// Tent derivative `S'(ξ)` per unit `ξ`, right-hand at the kinks (see the module docs):
/// `+1` on `[−1, 0)`, `−1` on `[0, 1)`, `0` elsewhere.
pub fn tent_derivative(xi: f64) -> f64 {
    if (-1.0..0.0).contains(&xi) {
        1.0
    } else if (0.0..1.0).contains(&xi) {
        -1.0
    } else {
        0.0
    }
}

/// Weights of the two nodes of a cell at local coordinate `ξ ∈ [0, 1]` from its left node:
/// values `[1 − ξ, ξ]` and derivatives per unit `ξ` `[−1, 1]`.
pub fn cell_weights(xi: f64) -> ([f64; 2], [f64; 2]) {
    cell_weights_of(xi)
}

/// [`cell_weights`] for one particle or four side by side ([`Real`]).
#[inline(always)]
pub(crate) fn cell_weights_of<R: Real>(xi: R) -> ([R; 2], [R; 2]) {
    ([R::splat(1.0) - xi, xi], [R::splat(-1.0), R::splat(1.0)])
}
