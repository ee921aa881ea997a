//! The uGIMP kernel (undeformed generalized interpolation material point, Bardenhagen & Kober
//! 2004): the tent convolved with the characteristic function of the particle's domain.
//!
//! The particle occupies `[x_p − lp, x_p + lp]` along each axis, with `lp = l·h` a fixed
//! fraction `l` (`half_width`, in cells) of the cell size, `0 < l ≤ 1/2`. The kernel is the
//! average of the tent over that domain. In cell units `ξ = (x_p − x_I)/h`:
//!
//! ```text
//!          ⎧ 1 − (ξ² + l²)/(2l)         |ξ| < l
//! S(ξ)  =  ⎨ 1 − |ξ|                    l ≤ |ξ| ≤ 1 − l
//!          ⎪ (1 + l − |ξ|)²/(4l)        1 − l < |ξ| < 1 + l
//!          ⎩ 0                          otherwise
//!
//!          ⎧ −ξ/l                       |ξ| < l
//! S'(ξ) =  ⎨ −sign(ξ)                   l ≤ |ξ| ≤ 1 − l
//!          ⎪ −sign(ξ)(1 + l − |ξ|)/(2l) 1 − l < |ξ| < 1 + l
//!          ⎩ 0                          otherwise           (per unit ξ; divide by h for d/dx)
//! ```
//!
//! `S` is C¹: value and derivative are continuous everywhere (the second derivative jumps at
//! `|ξ| = l, 1 − l, 1 + l`), so unlike the tent there is no one-sided convention to choose.
//! The support is `|ξ| < 1 + l ≤ 3/2`: 3 nodes per axis, 9 per particle in 2D. As `l → 0` the
//! kernel tends to the tent.
//!
//! "Undeformed" (uGIMP): `lp` stays the same all run long; the domain does not follow the
//! particle's deformation. Particles that fill their cells exactly, `k × k` per cell, have
//! `l = 1/(2k)` (`l = 1/4` for 2 × 2 per cell).

use crate::lanes::Real;

/// Nodes per axis in the support of a point: 3.
pub const SUPPORT: usize = 3;

/// Value and derivative per unit `ξ`, `(S(ξ), S'(ξ))`, of the uGIMP kernel of half-width
/// `l` cells (`0 < l ≤ 1/2`; other values give meaningless numbers): the piecewise formula of
/// the module docs, for one node. The operators use [`nearest_weights`] instead.
pub fn kernel(xi: f64, l: f64) -> (f64, f64) {
    let a = xi.abs();
    if a < l {
        (1.0 - (xi * xi + l * l) / (2.0 * l), -xi / l)
    } else if a <= 1.0 - l {
        (1.0 - a, -xi.signum())
    } else if a < 1.0 + l {
        let r = 1.0 + l - a;
        (r * r / (4.0 * l), -xi.signum() * r / (2.0 * l))
    } else {
        (0.0, 0.0)
    }
}

/// The kernel value `S(ξ)` alone; see [`kernel`].
pub fn value(xi: f64, l: f64) -> f64 {
    kernel(xi, l).0
}

/// The kernel derivative `S'(ξ)` per unit `ξ` alone; see [`kernel`].
pub fn derivative(xi: f64, l: f64) -> f64 {
    kernel(xi, l).1
}

/// Weights of the nodes `c − 1, c, c + 1` for a point at `t = s − c ∈ [−1/2, 1/2]` cell units
/// from its nearest node `c`: values and derivatives per unit `ξ`. No other node has a
/// non-zero weight (`|t ± 2| ≥ 3/2 ≥ 1 + l`).
///
/// In that range the middle node is in the inner or the linear piece and each neighbour in
/// the linear, the outer or the zero piece. With `m = max(l − |t|, 0)` (non-zero only when the
/// particle domain straddles node `c`) the pieces combine into one expression per node:
///
/// ```text
/// node c − 1:  S = max(−t, 0) + m²/(4l)      S' = −clamp((l − t)/(2l), 0, 1)
/// node c:      S = 1 − |t| − m²/(2l)         S' = −(S'_{c−1} + S'_{c+1})
/// node c + 1:  S = max(t, 0) + m²/(4l)       S' = clamp((l + t)/(2l), 0, 1)
/// ```
///
/// (for `|t| < l`: `1 − |t| − (l − |t|)²/(2l) = 1 − (t² + l²)/(2l)` and
/// `max(t, 0) + (l − |t|)²/(4l) = (l + t)²/(4l)`; for `|t| ≥ l`: `1 − |t|`, `max(±t, 0)`).
/// They need no branches — where a point falls relative to the breakpoints is as good as
/// random from one particle to the next, so branches would be mispredicted — and sum to one
/// and to zero by construction.
#[inline]
pub fn nearest_weights(t: f64, l: f64) -> ([f64; SUPPORT], [f64; SUPPORT]) {
    nearest_weights_scaled(t, l, 0.5 / l)
}

/// [`nearest_weights`] with `half_inv_l = 1/(2l)` worked out once by the caller.
#[inline]
pub(super) fn nearest_weights_scaled(t: f64, l: f64, half_inv_l: f64) -> ([f64; SUPPORT], [f64; SUPPORT]) {
    nearest_weights_of(t, l, half_inv_l)
}

/// [`nearest_weights`] with `half_inv_l = 1/(2l)`, for one particle or four side by side
/// ([`Real`]; `max` and `clamp` as its comparisons).
#[inline(always)]
pub(crate) fn nearest_weights_of<R: Real>(t: R, l: f64, half_inv_l: f64) -> ([R; SUPPORT], [R; SUPPORT]) {
    let c = R::splat;
    let (l, h) = (c(l), c(half_inv_l));
    let a = t.abs();
    let m = (l - a).max(c(0.0));
    let shared = c(0.5) * m * m * h; // m²/(4l)
    let d_left = -((l - t) * h).clamp(0.0, 1.0);
    let d_right = ((l + t) * h).clamp(0.0, 1.0);
    (
        [
            (-t).max(c(0.0)) + shared,
            c(1.0) - a - c(2.0) * shared,
            t.max(c(0.0)) + shared,
        ],
        [d_left, -(d_left + d_right), d_right],
    )
}
