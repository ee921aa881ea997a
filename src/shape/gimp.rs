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
/// `l` cells (`0 < l ≤ 1/2`; other values give meaningless numbers). See the module docs.
#[inline]
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

/// Weights of the three nodes `first, first + 1, first + 2` for a point at `s − first = r`
/// cell units from the first one: values and derivatives per unit `ξ`, node `k` at
/// `ξ = r − k`. The three hold every node with a non-zero weight when `r ∈ [l, 2 − l]`: in
/// particular when the middle node is the point's nearest (`r ∈ [1/2, 3/2]`), and at the
/// grid's edge for a point no closer than `l` cells to it, the first or last node.
#[inline]
pub fn weights(r: f64, l: f64) -> ([f64; SUPPORT], [f64; SUPPORT]) {
    let (w0, d0) = kernel(r, l);
    let (w1, d1) = kernel(r - 1.0, l);
    let (w2, d2) = kernel(r - 2.0, l);
    ([w0, w1, w2], [d0, d1, d2])
}
