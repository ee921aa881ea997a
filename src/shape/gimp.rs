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
/// the linear, the outer or the zero piece:
///
/// ```text
/// node c:      S = 1 − (t² + l²)/(2l),  S' = −t/l           |t| < l
///                = 1 − |t|,             S' = −sign(t)        otherwise
/// node c + 1:  S = t,                   S' = 1               t ≥ l
///                = q²/(4l),             S' = q/(2l)          otherwise, q = max(t + l, 0)
/// node c − 1:  the same with t → −t and S' → −S'
/// ```
///
/// Every piece is computed and the right one selected, so the compiler can avoid branches:
/// where a point falls relative to the breakpoints is as good as random from one particle to
/// the next, and mispredicted branches would cost more than the arithmetic.
#[inline]
pub fn nearest_weights(t: f64, l: f64) -> ([f64; SUPPORT], [f64; SUPPORT]) {
    let half_inv_l = 0.5 / l;
    let quarter_inv_l = 0.5 * half_inv_l;
    let select = |c: bool, a: f64, b: f64| if c { a } else { b };
    // Node c + 1.
    let (linear, q) = (t >= l, (t + l).max(0.0));
    let w_right = select(linear, t, q * q * quarter_inv_l);
    let d_right = select(linear, 1.0, q * half_inv_l);
    // Node c − 1: t → −t, derivative sign flipped.
    let (linear, q) = (-t >= l, (l - t).max(0.0));
    let w_left = select(linear, -t, q * q * quarter_inv_l);
    let d_left = select(linear, -1.0, -q * half_inv_l);
    // Node c.
    let (inner, a) = (t.abs() < l, t.abs());
    let w_mid = select(inner, 1.0 - (t * t + l * l) * half_inv_l, 1.0 - a);
    let d_mid = select(inner, -2.0 * t * half_inv_l, -(1.0_f64.copysign(t)));
    ([w_left, w_mid, w_right], [d_left, d_mid, d_right])
}
