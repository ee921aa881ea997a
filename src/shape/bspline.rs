//! Uniform node-centred quadratic and cubic B-spline kernels.
//!
//! In cell units `ξ = (x − x_I)/h`, the quadratic B-spline (support `|ξ| < 3/2`, 3 nodes per
//! axis, C¹) is
//!
//! ```text
//!          ⎧ 3/4 − ξ²                   |ξ| < 1/2
//! S(ξ)  =  ⎨ (3/2 − |ξ|)²/2             1/2 ≤ |ξ| < 3/2
//!          ⎩ 0                          otherwise
//!
//!          ⎧ −2ξ                        |ξ| < 1/2
//! S'(ξ) =  ⎨ −sign(ξ)(3/2 − |ξ|)        1/2 ≤ |ξ| < 3/2
//!          ⎩ 0                          otherwise
//! ```
//!
//! and the cubic B-spline (support `|ξ| < 2`, 4 nodes per axis, C²) is
//!
//! ```text
//!          ⎧ 2/3 − ξ² + |ξ|³/2          |ξ| < 1
//! S(ξ)  =  ⎨ (2 − |ξ|)³/6               1 ≤ |ξ| < 2
//!          ⎩ 0                          otherwise
//!
//!          ⎧ −2ξ + (3/2) ξ|ξ|           |ξ| < 1
//! S'(ξ) =  ⎨ −sign(ξ)(2 − |ξ|)²/2       1 ≤ |ξ| < 2
//!          ⎩ 0                          otherwise           (per unit ξ; divide by h for d/dx)
//! ```
//!
//! Both are non-negative, sum to one over the nodes and reproduce linear functions
//! (`Σ_I S(ξ − I) I = ξ`); their derivatives are continuous, so there is no one-sided
//! convention to choose at grid lines.
//!
//! The library does not evaluate these piecewise formulas node by node: for a point it takes
//! the few supporting nodes and evaluates one polynomial per node ([`quadratic_weights`],
//! [`cubic_weights`]), which is the same function written per interval.

use crate::lanes::Real;

/// Nodes per axis in the support of a point for the quadratic B-spline: 3.
pub const QUADRATIC_SUPPORT: usize = 3;
/// Nodes per axis in the support of a point for the cubic B-spline: 4.
pub const CUBIC_SUPPORT: usize = 4;

/// Quadratic B-spline value `S(ξ)`.
pub fn quadratic(xi: f64) -> f64 {
    let a = xi.abs();
    if a < 0.5 {
        0.75 - a * a
    } else if a < 1.5 {
        0.5 * (1.5 - a) * (1.5 - a)
    } else {
        0.0
    }
}

/// Quadratic B-spline derivative `S'(ξ)` per unit `ξ`.
pub fn quadratic_derivative(xi: f64) -> f64 {
    let a = xi.abs();
    if a < 0.5 {
        -2.0 * xi
    } else if a < 1.5 {
        -xi.signum() * (1.5 - a)
    } else {
        0.0
    }
}

/// Cubic B-spline value `S(ξ)`.
pub fn cubic(xi: f64) -> f64 {
    let a = xi.abs();
    if a < 1.0 {
        2.0 / 3.0 - a * a + 0.5 * a * a * a
    } else if a < 2.0 {
        let r = 2.0 - a;
        r * r * r / 6.0
    } else {
        0.0
    }
}

/// Cubic B-spline derivative `S'(ξ)` per unit `ξ`.
pub fn cubic_derivative(xi: f64) -> f64 {
    let a = xi.abs();
    if a < 1.0 {
        -2.0 * xi + 1.5 * xi * a
    } else if a < 2.0 {
        let r = 2.0 - a;
        -xi.signum() * 0.5 * r * r
    } else {
        0.0
    }
}

/// Quadratic weights of the nodes `c − 1, c, c + 1` for a point at `t = s − c ∈ [−1/2, 1/2]`
/// cell units from node `c` (the nearest node): values and derivatives per unit `ξ`,
///
/// ```text
/// S = [ (1/2 − t)²/2,   3/4 − t²,   (1/2 + t)²/2 ]
/// S' = [ −(1/2 − t),     −2t,        1/2 + t     ]
/// ```
#[inline]
pub fn quadratic_weights(t: f64) -> ([f64; QUADRATIC_SUPPORT], [f64; QUADRATIC_SUPPORT]) {
    quadratic_weights_of(t)
}

/// [`quadratic_weights`] for one particle or four side by side ([`Real`]).
#[inline(always)]
pub(crate) fn quadratic_weights_of<R: Real>(t: R) -> ([R; QUADRATIC_SUPPORT], [R; QUADRATIC_SUPPORT]) {
    let c = R::splat;
    let (a, b) = (c(0.5) - t, c(0.5) + t);
    ([c(0.5) * a * a, c(0.75) - t * t, c(0.5) * b * b], [-a, c(-2.0) * t, b])
}

/// Cubic weights of the nodes `c − 1, c, c + 1, c + 2` for a point at `t = s − c ∈ [0, 1]`
/// cell units from node `c`: values and derivatives per unit `ξ`, with `u = 1 − t`,
///
/// ```text
/// S  = [ u³/6,     2/3 − t² + t³/2,     2/3 − u² + u³/2,     t³/6 ]
/// S' = [ −u²/2,    −2t + 3t²/2,         2u − 3u²/2,          t²/2 ]
/// ```
#[inline]
pub fn cubic_weights(t: f64) -> ([f64; CUBIC_SUPPORT], [f64; CUBIC_SUPPORT]) {
    cubic_weights_of(t)
}

/// [`cubic_weights`] for one particle or four side by side ([`Real`]).
#[inline(always)]
pub(crate) fn cubic_weights_of<R: Real>(t: R) -> ([R; CUBIC_SUPPORT], [R; CUBIC_SUPPORT]) {
    let c = R::splat;
    let u = c(1.0) - t;
    let (t2, u2) = (t * t, u * u);
    (
        [
            u2 * u / c(6.0),
            c(2.0 / 3.0) - t2 + c(0.5) * t2 * t,
            c(2.0 / 3.0) - u2 + c(0.5) * u2 * u,
            t2 * t / c(6.0),
        ],
        [
            c(-0.5) * u2,
            c(-2.0) * t + c(1.5) * t2,
            c(2.0) * u - c(1.5) * u2,
            c(0.5) * t2,
        ],
    )
}
