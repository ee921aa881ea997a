//! The expanding ring: the vortex's ring breathing radially, where the compressible λ term of
//! the neo-Hookean stress acts.

use std::f64::consts::PI;

use crate::verification::manufactured::{lame, neo_hookean_first_piola, ring_profile, Manufactured};
use sparse_mpm::material::NeoHookean;

/// **The expanding ring**: the vortex's ring `Ri ≤ R ≤ Ro` breathing radially, which the
/// isochoric vortex cannot: `J ≠ 1`, so the λ term of the neo-Hookean stress and its
/// divergence enter. Each circle of radius `R` moves to radius
///
/// ```text
/// r(R, t) = R + A sin(c π t) g(R),   g = (1 − ξ²)ⁿ (the vortex's profile, n = 3 by default)
/// x = (r/R) X,   v = ṙ X/R,   a = r̈ X/R,   F = (r/R) I + (r' − r/R) n ⊗ n,   n = X/R,   J = r' r/R
/// ```
///
/// In the polar bases `P = P_rR e_r⊗E_R + P_θΘ e_θ⊗E_Θ` with
/// `P_rR = μ (r' − 1/r') + λ ln J / r'`, `P_θΘ = μ (r/R − R/r) + λ ln J · R/r`, and the body force
/// per unit mass is radial:
///
/// ```text
/// b_r = r̈ − (1/ρ0) [∂P_rR/∂R + (P_rR − P_θΘ)/R],
/// ∂P_rR/∂R = μ r'' (1 + 1/r'²) + λ [(ln J)'/r' − ln J r''/r'²],   (ln J)' = r''/r' + r'/r − 1/R
/// ```
///
/// On `R = Ri, Ro`, `g = g' = 0`: `r = R`, `F = I`, `P = 0` (traction free), `v = 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExpandingRing {
    /// Young's modulus `E`.
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν`.
    pub poisson_ratio: f64,
    /// Reference density `ρ0`.
    pub density: f64,
    /// Radial displacement amplitude `A` (length).
    pub amplitude: f64,
    /// Inner radius `Ri`.
    pub inner_radius: f64,
    /// Outer radius `Ro`.
    pub outer_radius: f64,
    /// The profile's exponent `n` (at least 2).
    pub exponent: u32,
}

impl Default for ExpandingRing {
    /// The vortex's set (`E = 1000`, `ν = 0.3`, `ρ0 = 1000`, `Ri = 0.75`, `Ro = 1.25`), the smooth
    /// profile `n = 3`, `A = 0.01`.
    fn default() -> Self {
        ExpandingRing {
            youngs_modulus: 1000.0,
            poisson_ratio: 0.3,
            density: 1000.0,
            amplitude: 0.01,
            inner_radius: 0.75,
            outer_radius: 1.25,
            exponent: 3,
        }
    }
}

impl ExpandingRing {
    /// Lamé constants `(μ, λ)`.
    pub fn lame(&self) -> (f64, f64) {
        lame(self.youngs_modulus, self.poisson_ratio)
    }

    /// `c = √(E/ρ0)` (the angular frequency is `c π`).
    pub fn c(&self) -> f64 {
        (self.youngs_modulus / self.density).sqrt()
    }

    /// The profile `(g, g', g'')` ([`ring_profile`] of this ring).
    pub fn profile(&self, r: f64) -> (f64, f64, f64) {
        ring_profile(self.inner_radius, self.outer_radius, self.exponent, r)
    }

    /// `(r, ṙ, r̈, r', r'')` at reference radius `R` and time `t`.
    fn radius(&self, r0: f64, t: f64) -> [f64; 5] {
        let w = self.c() * PI;
        let (s, co) = (w * t).sin_cos();
        let (g, g1, g2) = self.profile(r0);
        let a = self.amplitude;
        [
            r0 + a * s * g,
            a * w * co * g,
            -a * w * w * s * g,
            1.0 + a * s * g1,
            a * s * g2,
        ]
    }

    /// Current position `x = (r/R) X`.
    pub fn position(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let r0 = x0[0].hypot(x0[1]);
        let [r, ..] = self.radius(r0, t);
        [x0[0] * r / r0, x0[1] * r / r0]
    }

    /// `F = (r/R) I + (r' − r/R) n ⊗ n`, row-major.
    pub fn deformation_gradient(&self, x0: [f64; 2], t: f64) -> [f64; 4] {
        let r0 = x0[0].hypot(x0[1]);
        let [r, _, _, r1, _] = self.radius(r0, t);
        let (nx, ny) = (x0[0] / r0, x0[1] / r0);
        let (q, d) = (r / r0, r1 - r / r0);
        [q + d * nx * nx, d * nx * ny, d * nx * ny, q + d * ny * ny]
    }

    /// Exact first Piola–Kirchhoff stress `P(F(X, t))`.
    pub fn first_piola(&self, x0: [f64; 2], t: f64) -> [f64; 4] {
        let (mu, lambda) = self.lame();
        neo_hookean_first_piola(mu, lambda, self.deformation_gradient(x0, t))
    }

    /// Body force per unit mass (the type's docs), radial.
    pub fn body_force(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let (mu, lambda) = self.lame();
        let r0 = x0[0].hypot(x0[1]);
        let [r, _, rdd, r1, r2] = self.radius(r0, t);
        let j = r1 * r / r0;
        let lj = j.ln();
        let p_rr = mu * (r1 - 1.0 / r1) + lambda * lj / r1;
        let p_tt = mu * (r / r0 - r0 / r) + lambda * lj * r0 / r;
        let dlj = r2 / r1 + r1 / r - 1.0 / r0;
        let dp_rr = mu * r2 * (1.0 + 1.0 / (r1 * r1)) + lambda * (dlj / r1 - lj * r2 / (r1 * r1));
        let br = rdd - (dp_rr + (p_rr - p_tt) / r0) / self.density;
        [br * x0[0] / r0, br * x0[1] / r0]
    }
}

impl Manufactured for ExpandingRing {
    fn name(&self) -> &'static str {
        "mms_ring"
    }
    fn material(&self) -> NeoHookean {
        NeoHookean {
            youngs_modulus: self.youngs_modulus,
            poisson_ratio: self.poisson_ratio,
        }
    }
    fn reference_density(&self) -> f64 {
        self.density
    }
    fn exact_displacement(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let x = self.position(x0, t);
        [x[0] - x0[0], x[1] - x0[1]]
    }
    fn exact_velocity(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let r0 = x0[0].hypot(x0[1]);
        let [_, rd, ..] = self.radius(r0, t);
        [rd * x0[0] / r0, rd * x0[1] / r0]
    }
    fn exact_body_force(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        self.body_force(x0, t)
    }
    fn in_body(&self, x0: [f64; 2]) -> bool {
        let r = x0[0].hypot(x0[1]);
        r >= self.inner_radius && r <= self.outer_radius
    }
    /// `[−1.35, 1.35]²`, as the vortex.
    fn domain(&self) -> [f64; 2] {
        [-1.35, 1.35]
    }
    /// A quarter period, the time of the largest expansion.
    fn end_time(&self) -> f64 {
        0.5 / self.c()
    }
    /// The amplitude `A`.
    fn displacement_scale(&self) -> f64 {
        self.amplitude
    }
    fn rollers(&self) -> bool {
        false
    }
}
