//! Exact manufactured solutions (notes B5, B6) with the compressible neo-Hookean model in plane
//! strain, and [`run`], which runs one and measures the displacement error.
//!
//! # Conventions
//!
//! * `x0 = X = [X, Y]` is the reference (initial) position of a material point, `t` the time.
//! * The motion is `x = φ(X, t)`, the displacement `u = x − X`, the velocity `v = ∂u/∂t`.
//! * The deformation gradient is stored row-major as `[fxx, fxy, fyx, fyy]` with
//!   `fab = ∂x_a/∂X_b`, so `F = I + ∂u/∂X`.
//! * Constitutive model (the library's `NeoHookean`, plane strain, `F_zz = 1`, `J = det F` of
//!   the in-plane 2×2 block):
//!
//!   ```text
//!   W(F) = μ/2 (tr(Fᵀ F) − 2) − μ ln J + λ/2 (ln J)²
//!   σ    = μ/J (F Fᵀ − I) + λ ln J / J I                  (Cauchy)
//!   P    = J σ F⁻ᵀ = μ (F − F⁻ᵀ) + λ ln J F⁻ᵀ               (first Piola–Kirchhoff)
//!   μ = E / (2(1 + ν)),   λ = E ν / ((1 + ν)(1 − 2ν))
//!   ```
//!
//! * Body forces are **per unit mass**, functions of the *reference* position and time, chosen so
//!   that the Lagrangian momentum balance holds exactly:
//!
//!   ```text
//!   ρ0 ∂²u/∂t² = Div_X P + ρ0 b      ⇔      b = ∂²u/∂t² − (1/ρ0) Div_X P
//!   ```
//!
//!   In an MPM code evaluate `b(X_p, t)` at the particle's stored initial position `X_p`.

use std::f64::consts::PI;
use std::time::Instant;

use super::{Choices, History, Outcome};
use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge};
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{Material, NeoHookean};
use sparse_mpm::particles::{lattice, Particles};
use sparse_mpm::simulation::{Body, Simulation};

mod ring;
pub use ring::ExpandingRing;

/// Lamé constants `(μ, λ)` from Young's modulus and Poisson's ratio (3D relations, as used by the
/// library for plane strain).
pub fn lame(youngs_modulus: f64, poisson_ratio: f64) -> (f64, f64) {
    let (e, nu) = (youngs_modulus, poisson_ratio);
    (e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)))
}

/// First Piola–Kirchhoff stress of the plane-strain neo-Hookean model, row-major
/// `[Pxx, Pxy, Pyx, Pyy]` (`P_aB`: row = spatial index, column = reference index):
///
/// ```text
/// P = μ (F − F⁻ᵀ) + λ ln J F⁻ᵀ,     F⁻ᵀ = (1/J) [[fyy, −fyx], [−fxy, fxx]]
/// ```
pub fn neo_hookean_first_piola(mu: f64, lambda: f64, f: [f64; 4]) -> [f64; 4] {
    let [fxx, fxy, fyx, fyy] = f;
    let j = fxx * fyy - fxy * fyx;
    let finv_t = [fyy / j, -fyx / j, -fxy / j, fxx / j];
    let l = lambda * j.ln();
    [
        mu * (fxx - finv_t[0]) + l * finv_t[0],
        mu * (fxy - finv_t[1]) + l * finv_t[1],
        mu * (fyx - finv_t[2]) + l * finv_t[2],
        mu * (fyy - finv_t[3]) + l * finv_t[3],
    ]
}

// ---------------------------------------------------------------------------------------------
// B5: axis-aligned displacement MMS
// ---------------------------------------------------------------------------------------------

/// **B5**, axis-aligned displacement MMS (Wallstedt & Guilkey 2008, JCP 227; Uintah `MMS.cc`),
/// on the unit square `[0, 1]²`:
///
/// ```text
/// u_x = A sin(π X) sin(c π t),   u_y = A sin(π Y) sin(c π t),   c = √(E/ρ0)
/// v_x = A c π sin(π X) cos(c π t)   (likewise y)
/// F   = diag(F_xx, F_yy),  F_xx = 1 + A π cos(π X) sin(c π t),  F_yy = 1 + A π cos(π Y) sin(c π t)
/// J   = F_xx F_yy   (plane strain)
/// ```
///
/// Body force (derived for `P = μ(F − F⁻ᵀ) + λ ln J F⁻ᵀ`; `P` is diagonal and `P_xx` depends on `X`
/// only through `F_xx`, with `∂F_xx/∂X = −π² u_x` and `∂²u_x/∂t² = −c²π² u_x`):
///
/// ```text
/// Div P_x = ∂P_xx/∂X = −π² u_x [ μ + (μ + λ (1 − ln J)) / F_xx² ]
/// b_x     = π² u_x [ μ/ρ0 − c² − (λ (ln J − 1) − μ) / (ρ0 F_xx²) ]      (likewise y with F_yy)
/// ```
///
/// which is identical to the Uintah form. `c` is a time scale only (`√(E/ρ0)`), not a wave
/// speed of the model, so `b ≠ 0` even at small amplitude.
///
/// Boundary conditions: `u·n = 0` and the shear traction `P_tn = 0` on all four sides, i.e.
/// rollers (normal velocity 0 on `X = 0, 1` and `Y = 0, 1`); the normal traction is not zero, so
/// a free surface is wrong.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisAlignedMms {
    /// Young's modulus `E`.
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν`.
    pub poisson_ratio: f64,
    /// Reference density `ρ0`.
    pub density: f64,
    /// Displacement amplitude `A` (Uintah 0.05, Wallstedt 0.1).
    pub amplitude: f64,
}

impl Default for AxisAlignedMms {
    /// Uintah's set: `E = 1e4`, `ν = 0.3`, `ρ0 = 1`, `A = 0.05` (so `c = 100`).
    fn default() -> Self {
        AxisAlignedMms {
            youngs_modulus: 1.0e4,
            poisson_ratio: 0.3,
            density: 1.0,
            amplitude: 0.05,
        }
    }
}

impl AxisAlignedMms {
    /// Wallstedt's set: as [`Default`] with `A = 0.1`.
    pub fn wallstedt() -> Self {
        AxisAlignedMms {
            amplitude: 0.1,
            ..Self::default()
        }
    }

    /// Lamé constants `(μ, λ)`.
    pub fn lame(&self) -> (f64, f64) {
        lame(self.youngs_modulus, self.poisson_ratio)
    }

    /// `c = √(E/ρ0)`; the angular frequency is `ω = c π`.
    pub fn c(&self) -> f64 {
        (self.youngs_modulus / self.density).sqrt()
    }

    /// Period `T = 2/c`.
    pub fn period(&self) -> f64 {
        2.0 / self.c()
    }

    /// Body region: the closed unit square.
    pub fn inside(&self, x0: [f64; 2]) -> bool {
        (0.0..=1.0).contains(&x0[0]) && (0.0..=1.0).contains(&x0[1])
    }

    /// `u = A sin(c π t) (sin π X, sin π Y)`.
    pub fn displacement(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let s = self.amplitude * (self.c() * PI * t).sin();
        [s * (PI * x0[0]).sin(), s * (PI * x0[1]).sin()]
    }

    /// `v = A c π cos(c π t) (sin π X, sin π Y)`.
    pub fn velocity(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let c = self.c();
        let s = self.amplitude * c * PI * (c * PI * t).cos();
        [s * (PI * x0[0]).sin(), s * (PI * x0[1]).sin()]
    }

    /// `a = ∂²u/∂t² = −c² π² u`.
    pub fn acceleration(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let k = -(self.c() * PI).powi(2);
        let u = self.displacement(x0, t);
        [k * u[0], k * u[1]]
    }

    /// `F = diag(1 + A π cos(π X) sin(c π t), 1 + A π cos(π Y) sin(c π t))`.
    pub fn deformation_gradient(&self, x0: [f64; 2], t: f64) -> [f64; 4] {
        let s = self.amplitude * PI * (self.c() * PI * t).sin();
        [1.0 + s * (PI * x0[0]).cos(), 0.0, 0.0, 1.0 + s * (PI * x0[1]).cos()]
    }

    /// Exact first Piola–Kirchhoff stress `P(F(X, t))`.
    pub fn first_piola(&self, x0: [f64; 2], t: f64) -> [f64; 4] {
        let (mu, lambda) = self.lame();
        neo_hookean_first_piola(mu, lambda, self.deformation_gradient(x0, t))
    }

    /// Body force per unit mass (see the type's docs):
    /// `b_a = π² u_a [μ/ρ0 − c² − (λ (ln J − 1) − μ) / (ρ0 F_aa²)]`, `a = x, y`.
    pub fn body_force(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let (mu, lambda) = self.lame();
        let (rho, c) = (self.density, self.c());
        let u = self.displacement(x0, t);
        let [fxx, _, _, fyy] = self.deformation_gradient(x0, t);
        let ln_j = (fxx * fyy).ln();
        let b =
            |ua: f64, faa: f64| PI * PI * ua * (mu / rho - c * c - (lambda * (ln_j - 1.0) - mu) / (rho * faa * faa));
        [b(u[0], fxx), b(u[1], fyy)]
    }
}

// ---------------------------------------------------------------------------------------------
// B6: generalised vortex MMS
// ---------------------------------------------------------------------------------------------

/// The ring profile of the vortex and the expanding ring, `g = qⁿ` with `q = 1 − ξ²`,
/// `ξ = (R − Rm)/w`, `Rm = (Ri + Ro)/2`, `w = (Ro − Ri)/2` (`n` at least 2), and its first two
/// derivatives:
///
/// ```text
/// g = qⁿ,   g' = −2n ξ qⁿ⁻¹ / w,   g'' = (4n(n − 1) ξ² qⁿ⁻² − 2n qⁿ⁻¹) / w²
/// ```
pub fn ring_profile(inner_radius: f64, outer_radius: f64, exponent: u32, r: f64) -> (f64, f64, f64) {
    let rm = 0.5 * (inner_radius + outer_radius);
    let w = 0.5 * (outer_radius - inner_radius);
    let xi = (r - rm) / w;
    let q = 1.0 - xi * xi;
    let n = exponent.max(2) as i32;
    let nf = f64::from(n);
    let g = q.powi(n);
    let g1 = -2.0 * nf * xi * q.powi(n - 1) / w;
    let g2 = (4.0 * nf * (nf - 1.0) * xi * xi * q.powi(n - 2) - 2.0 * nf * q.powi(n - 1)) / (w * w);
    (g, g1, g2)
}

/// **B6**, generalised vortex MMS (Kamojjala, Brannon, Sadeghirad & Guilkey, "Establishing
/// credibility of particle methods through verification testing", Particles 2011; Uintah
/// `MMS.cc`). A ring `Ri ≤ R ≤ Ro` about the origin; each circle of radius `R` rotates rigidly
/// by the angle
///
/// ```text
/// α(R, t) = A sin(c π t) g(R),   g(R) = (1 − ξ²)ⁿ,   ξ = (R − Rm)/w,  Rm = (Ri+Ro)/2, w = (Ro−Ri)/2
/// ```
///
/// with the published exponent `n = 2` (and `Ri = 0.75`, `Ro = 1.25`:
/// `g = (1 − 16(R − 1)²)² = (4R − 3)²(4R − 5)²`) or the smooth `n = 3`
/// ([`GeneralisedVortex::smooth`]). `g = g' = 0` at `Ri` and `Ro`; with `n = 3` also `g'' = 0`,
/// so the body force's `b_θ` and the shear stress's gradient vanish at the free surfaces too. With `Q(α)` the rotation by `α` and `x = Q(α) X`:
///
/// ```text
/// u = Q(α) X − X
/// v = α̇ (−y, x),                                   α̇ = A c π cos(c π t) g(R)
/// F = Q(α) [I + (α'/R) (−Y, X) ⊗ (X, Y)],           α' = ∂α/∂R = A sin(c π t) g'(R)
/// ```
///
/// In the polar bases `(e_r, e_θ)` (current angle `β = Θ + α`) ⊗ `(E_R, E_Θ)`,
/// `F = [[1, 0], [R α', 1]]`: a simple shear of amount `γ = R α'`, so `J = 1` **exactly** and
/// `ln J ≡ 0`; the λ term and its divergence vanish identically. Since `Div(J F⁻ᵀ) = 0` (Piola
/// identity) and `J ≡ 1`, `Div F⁻ᵀ = 0`, hence `Div P = μ Div F = μ Δ_X x`. With
/// `z = R e^{iβ}`, `Δ_X z = e^{iβ} (i(3α' + R α'') − R α'²)` and `z̈ = R e^{iβ} (i α̈ − α̇²)`:
///
/// ```text
/// b_r = −R α̇² + (μ/ρ0) R α'²
/// b_θ =  R α̈ − (μ/ρ0) (3 α' + R α'')
/// b_x = cos β b_r − sin β b_θ,   b_y = sin β b_r + cos β b_θ
/// ```
///
/// which for the published ring is exactly the Uintah / notes form
/// `b_r = −R A²c²π² cos²(cπt)(4R−3)⁴(4R−5)⁴ + (4096 μ/ρ0)(4R−5)²(R−1)²(4R−3)² A² sin²(cπt) R`,
/// `b_θ = −A sin(cπt)[R c²π²(4R−3)²(4R−5)² + (64μ/ρ0)(96R³ − 240R² + 188R − 45)]`.
///
/// Boundary conditions: none. On `R = Ri, Ro`, `F = I` and `P = 0` (traction free) and `v = 0`.
/// With `n = 2`, `b_θ ≠ 0` on the boundary (`g'' = 8/w² ≠ 0` there): the shear stress vanishes
/// at the free surface but its gradient does not, which a particle discretisation resolves only
/// to first order near the surface; `n = 3` removes that.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneralisedVortex {
    /// Young's modulus `E` (only `μ` enters the body force).
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν`.
    pub poisson_ratio: f64,
    /// Reference density `ρ0`.
    pub density: f64,
    /// Rotation amplitude `A` (radians at `R = Rm`).
    pub amplitude: f64,
    /// Inner radius `Ri`.
    pub inner_radius: f64,
    /// Outer radius `Ro`.
    pub outer_radius: f64,
    /// The profile's exponent `n` in `g = (1 − ξ²)ⁿ`: 2 (published) or 3 (smooth); at least 2.
    pub exponent: u32,
}

impl Default for GeneralisedVortex {
    /// Published set: `E = 1000`, `ν = 0.3`, `ρ0 = 1000`, `A = 1`, `Ri = 0.75`, `Ro = 1.25`
    /// (so `c = 1`, `μ = 384.615…`).
    fn default() -> Self {
        GeneralisedVortex {
            youngs_modulus: 1000.0,
            poisson_ratio: 0.3,
            density: 1000.0,
            amplitude: 1.0,
            inner_radius: 0.75,
            outer_radius: 1.25,
            exponent: 2,
        }
    }
}

impl GeneralisedVortex {
    /// Lamé constants `(μ, λ)`.
    pub fn lame(&self) -> (f64, f64) {
        lame(self.youngs_modulus, self.poisson_ratio)
    }

    /// `c = √(E/ρ0)` (a time scale; the angular frequency is `c π`).
    pub fn c(&self) -> f64 {
        (self.youngs_modulus / self.density).sqrt()
    }

    /// Period `T = 2/c`.
    pub fn period(&self) -> f64 {
        2.0 / self.c()
    }

    /// Body region: the closed ring `Ri ≤ |X| ≤ Ro`.
    pub fn inside(&self, x0: [f64; 2]) -> bool {
        let r = x0[0].hypot(x0[1]);
        r >= self.inner_radius && r <= self.outer_radius
    }

    /// The published set with the smooth profile `g = (1 − ξ²)³` (`n = 3`) at amplitude `A`.
    pub fn smooth(amplitude: f64) -> Self {
        GeneralisedVortex {
            amplitude,
            exponent: 3,
            ..GeneralisedVortex::default()
        }
    }

    /// `g(R)` and its first two derivatives `(g, g', g'')` ([`ring_profile`] of this ring).
    pub fn profile(&self, r: f64) -> (f64, f64, f64) {
        ring_profile(self.inner_radius, self.outer_radius, self.exponent, r)
    }

    /// `(α, α̇, α̈, α', α'')` at radius `R` and time `t`.
    fn angle(&self, r: f64, t: f64) -> [f64; 5] {
        let w = self.c() * PI;
        let (s, co) = (w * t).sin_cos();
        let (g, g1, g2) = self.profile(r);
        let a = self.amplitude;
        [a * s * g, a * w * co * g, -a * w * w * s * g, a * s * g1, a * s * g2]
    }

    /// Current position `x = Q(α) X`.
    pub fn position(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let [al, ..] = self.angle(x0[0].hypot(x0[1]), t);
        let (s, c) = al.sin_cos();
        [c * x0[0] - s * x0[1], s * x0[0] + c * x0[1]]
    }

    /// `u = Q(α) X − X`.
    pub fn displacement(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let x = self.position(x0, t);
        [x[0] - x0[0], x[1] - x0[1]]
    }

    /// `v = α̇ (−y, x)` with `x = Q(α) X`.
    pub fn velocity(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let [_, ad, ..] = self.angle(x0[0].hypot(x0[1]), t);
        let x = self.position(x0, t);
        [-ad * x[1], ad * x[0]]
    }

    /// `a = α̈ (−y, x) − α̇² (x, y)`.
    pub fn acceleration(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let [_, ad, add, ..] = self.angle(x0[0].hypot(x0[1]), t);
        let x = self.position(x0, t);
        [-add * x[1] - ad * ad * x[0], add * x[0] - ad * ad * x[1]]
    }

    /// `F = Q(α) [I + (α'/R) (−Y, X) ⊗ (X, Y)]` (`det F = 1`).
    pub fn deformation_gradient(&self, x0: [f64; 2], t: f64) -> [f64; 4] {
        let [xx, yy] = x0;
        let r = xx.hypot(yy);
        let [al, _, _, a1, _] = self.angle(r, t);
        let k = a1 / r;
        // H = I + k (−Y, X) ⊗ (X, Y)
        let h = [1.0 - k * yy * xx, -k * yy * yy, k * xx * xx, 1.0 + k * xx * yy];
        let (s, c) = al.sin_cos();
        [
            c * h[0] - s * h[2],
            c * h[1] - s * h[3],
            s * h[0] + c * h[2],
            s * h[1] + c * h[3],
        ]
    }

    /// Exact first Piola–Kirchhoff stress `P(F(X, t))`.
    pub fn first_piola(&self, x0: [f64; 2], t: f64) -> [f64; 4] {
        let (mu, lambda) = self.lame();
        neo_hookean_first_piola(mu, lambda, self.deformation_gradient(x0, t))
    }

    /// Body force per unit mass (see the type's docs):
    /// `b_r = −R α̇² + (μ/ρ0) R α'²`, `b_θ = R α̈ − (μ/ρ0)(3α' + R α'')`, rotated to Cartesian
    /// with the current angle `β = Θ + α`.
    pub fn body_force(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        let (mu, _) = self.lame();
        let m = mu / self.density;
        let r = x0[0].hypot(x0[1]);
        let [_, ad, add, a1, a2] = self.angle(r, t);
        let br = -r * ad * ad + m * r * a1 * a1;
        let bt = r * add - m * (3.0 * a1 + r * a2);
        // (cos β, sin β) = x / R
        let x = self.position(x0, t);
        let (cb, sb) = (x[0] / r, x[1] / r);
        [cb * br - sb * bt, sb * br + cb * bt]
    }
}

// ---------------------------------------------------------------------------------------------
// Running a manufactured solution
// ---------------------------------------------------------------------------------------------

/// A manufactured solution as a verification problem: the exact motion, its body force, the
/// body's region and what the run needs around it.
pub trait Manufactured {
    /// The problem's name in outcomes (`"mms_axis_aligned"`, `"mms_vortex"`).
    fn name(&self) -> &'static str;
    /// The material (plane-strain neo-Hookean).
    fn material(&self) -> NeoHookean;
    /// Reference density `ρ0`.
    fn reference_density(&self) -> f64;
    /// Exact displacement `u(X, t)`.
    fn exact_displacement(&self, x0: [f64; 2], t: f64) -> [f64; 2];
    /// Exact velocity `v(X, t)`.
    fn exact_velocity(&self, x0: [f64; 2], t: f64) -> [f64; 2];
    /// Body force per unit mass `b(X, t)`.
    fn exact_body_force(&self, x0: [f64; 2], t: f64) -> [f64; 2];
    /// Whether `X` belongs to the body.
    fn in_body(&self, x0: [f64; 2]) -> bool;
    /// The square `[lo, hi]²` the grid covers before padding.
    fn domain(&self) -> [f64; 2];
    /// End time of a run.
    fn end_time(&self) -> f64;
    /// Displacement scale the errors are divided by.
    fn displacement_scale(&self) -> f64;
    /// Whether the domain's edges are rollers (normal velocity zero).
    fn rollers(&self) -> bool;
}

impl Manufactured for AxisAlignedMms {
    fn name(&self) -> &'static str {
        "mms_axis_aligned"
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
        self.displacement(x0, t)
    }
    fn exact_velocity(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        self.velocity(x0, t)
    }
    fn exact_body_force(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        self.body_force(x0, t)
    }
    fn in_body(&self, x0: [f64; 2]) -> bool {
        self.inside(x0)
    }
    fn domain(&self) -> [f64; 2] {
        [0.0, 1.0]
    }
    /// One period, `2/c`.
    fn end_time(&self) -> f64 {
        self.period()
    }
    fn displacement_scale(&self) -> f64 {
        self.amplitude
    }
    fn rollers(&self) -> bool {
        true
    }
}

impl Manufactured for GeneralisedVortex {
    /// `"mms_vortex"` (published profile) or `"mms_vortex_smooth"` (`n = 3`).
    fn name(&self) -> &'static str {
        if self.exponent >= 3 {
            "mms_vortex_smooth"
        } else {
            "mms_vortex"
        }
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
        self.displacement(x0, t)
    }
    fn exact_velocity(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        self.velocity(x0, t)
    }
    fn exact_body_force(&self, x0: [f64; 2], t: f64) -> [f64; 2] {
        self.body_force(x0, t)
    }
    fn in_body(&self, x0: [f64; 2]) -> bool {
        self.inside(x0)
    }
    /// `[−1.35, 1.35]²` (Nguyen's 2.7 × 2.7 grid).
    fn domain(&self) -> [f64; 2] {
        [-1.35, 1.35]
    }
    /// A quarter period, the time of the largest shear (Nguyen's `t = 0.5` for `c = 1`).
    fn end_time(&self) -> f64 {
        0.25 * self.period()
    }
    /// The largest displacement, about `A · Rm` at the mid-radius.
    fn displacement_scale(&self) -> f64 {
        self.amplitude * 0.5 * (self.inner_radius + self.outer_radius)
    }
    fn rollers(&self) -> bool {
        false
    }
}

/// Runs a manufactured solution on `cells` cells across its domain: particles on the
/// `particles_per_cell²` sub-lattice of the cells inside the body, started at the exact
/// velocity, loaded by the exact body force at each step's start time, to the problem's end
/// time; with the domain's edges as rollers where the problem has them (slip edges on the
/// domain's outline: mirrored with GIMP and B-splines, every node line at or beyond an edge
/// holding the normal component with linear functions).
///
/// Metrics: `displacement_error_l2` (`max_t √(Σ V₀ |x_p − X_p − u(X_p, t)|² / Σ V₀)`) and
/// `displacement_error_max` (`max_t max_p |x_p − X_p − u|`), both over the problem's
/// displacement scale; `stable_time_step`. History: `displacement_error_l2`.
///
/// # Errors
/// Those of [`Simulation::new`] and [`Simulation::step`].
pub fn run(problem: &impl Manufactured, cells: usize, choices: &Choices) -> Result<Outcome> {
    let [lo, hi] = problem.domain();
    let h = (hi - lo) / cells as f64;
    let pad = choices.shape.recommended_padding();
    let grid = Grid::new([lo - pad as f64 * h; 2], [h, h], [cells + 2 * pad; 2])?;
    let (x, y, volume) = lattice(&grid, choices.particles_per_cell, |px, py| {
        (lo..=hi).contains(&px) && (lo..=hi).contains(&py) && problem.in_body([px, py])
    });
    let n = x.len();
    let (vx, vy): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|k| problem.exact_velocity([x[k], y[k]], 0.0))
        .map(|v| (v[0], v[1]))
        .unzip();
    let reference: Vec<[f64; 2]> = (0..n).map(|k| [x[k], y[k]]).collect();
    let particles =
        Particles::new(x, y, vec![problem.reference_density() * volume; n], vec![volume; n])?.with_velocity(vx, vy)?;
    let mut boundaries = Vec::new();
    if problem.rollers() {
        // Slip edges whose wall is the domain's edge (the node line `pad` in): mirrored with
        // GIMP and B-splines, the lines beyond it held with linear functions.
        for edge in [Edge::Left, Edge::Right, Edge::Bottom, Edge::Top] {
            boundaries.push(BoundaryCondition::edge(edge, Condition::Slip).with_layers(pad + 1));
        }
    }
    let options = choices.options(boundaries);
    let bodies = vec![Body {
        name: problem.name().into(),
        material: Material::NeoHookean(problem.material()),
    }];
    let mut sim = Simulation::new(grid, particles, bodies, options)?;
    let stable = sim.stable_time_step();
    let total_volume = volume * n as f64;
    let scale = problem.displacement_scale();
    let mut history = History::new("displacement_error_l2");
    let (mut worst_l2, mut worst_max) = (0.0f64, 0.0f64);
    let clock = Instant::now();
    while sim.time() < problem.end_time() * (1.0 - 1e-12) {
        let t = sim.time();
        sim.set_body_force(|id, _| problem.exact_body_force(reference[id], t));
        sim.step_capped(problem.end_time() - t)?;
        let (p, t) = (sim.particles(), sim.time());
        let (mut sum, mut max) = (0.0, 0.0f64);
        for k in 0..p.len() {
            let x0 = reference[p.id[k]];
            let u = problem.exact_displacement(x0, t);
            let e = (p.x[k] - x0[0] - u[0]).hypot(p.y[k] - x0[1] - u[1]);
            sum += volume * e * e;
            max = max.max(e);
        }
        let l2 = (sum / total_volume).sqrt() / scale;
        history.push(t, l2);
        worst_l2 = worst_l2.max(l2);
        worst_max = worst_max.max(max / scale);
    }
    let seconds = clock.elapsed().as_secs_f64();
    Ok(Outcome {
        problem: problem.name().to_string(),
        cells,
        cell_size: h,
        metrics: vec![
            ("displacement_error_l2".to_string(), worst_l2),
            ("displacement_error_max".to_string(), worst_max),
            ("stable_time_step".to_string(), stable),
        ],
        histories: vec![history],
        steps: sim.steps(),
        seconds,
    })
}
