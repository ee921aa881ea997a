//! Elastoplastic models: von Mises (J2) with linear isotropic hardening and Drucker–Prager,
//! both as one return map on the principal logarithmic (Hencky) strains of the elastic left
//! Cauchy–Green tensor ([`super::hencky`] carries it to the finite-strain update).
//!
//! Elasticity is Hencky's, in three dimensions on the principal elastic log strains `εᵢ`
//! (the out-of-plane one is the third):
//!
//! ```text
//! τᵢ = K tr ε + 2μ (εᵢ − tr ε / 3),   W(ε) = μ Σ εᵢ² + (λ/2)(tr ε)²,   λ = K − 2μ/3
//! ```
//!
//! with `τ` the Kirchhoff stress, `K = E/(3(1 − 2ν))`, `μ = E/(2(1 + ν))`. Both models are one
//! cone in the principal stress space, with `p = tr τ / 3` (tension positive), `s = dev τ`:
//!
//! ```text
//! f(τ, ε̄ᵖ) = ‖s‖ + B p − (A + h ε̄ᵖ) ≤ 0,      plastic potential  g = ‖s‖ + B_ψ p
//! von Mises:      B = B_ψ = 0,  A = √(2/3) σ_y,  h = √(2/3) H   (‖s‖ = √(2/3) σ_eq)
//! Drucker–Prager: B_ψ = 3√2 tan ψ / √(9 + 12 tan²ψ),  h = 0,
//!                 B = 2 sin φ / (√(2 − B_ψ²/3) + B_ψ sin φ/3),
//!                 A = c cos φ (2 − B B_ψ/3) / √(2 − B_ψ²/3)
//! ```
//!
//! (the Drucker–Prager cone fitted to Mohr–Coulomb in plane strain for its own flow rule: at
//! plastic flow with `Δεᵖ_zz = 0` the in-plane stresses obey Mohr–Coulomb with `φ`, `c` and
//! dilate at `ψ`; with associated flow it is the familiar `B = 3√2 tan φ / √(9 + 12 tan²φ)`,
//! `A = 3√2 c / √(9 + 12 tan²φ)`, with `ψ = 0` it is `B = √2 sin φ`, `A = √2 c cos φ`). The return from a trial
//! state `ε^tr` (radial in the deviatoric plane, as the flow `∂g/∂τ = n + (B_ψ/3) 1`,
//! `n = s^tr/‖s^tr‖`, prescribes):
//!
//! ```text
//! Δγ = f(τ^tr) / (2μ + K B B_ψ + h c_ψ),   c_ψ = √(2/3) √(1 + B_ψ²/3)
//! s = s^tr (1 − 2μ Δγ / ‖s^tr‖),   p = p^tr − K B_ψ Δγ,   ε̄ᵖ += c_ψ Δγ
//! ```
//!
//! and when that would reverse `s` (`2μ Δγ > ‖s^tr‖`, beyond the cone's apex in tension) the
//! apex return `τ = (A/B) 1`. The equivalent plastic strain grows by `√(2/3) ‖ε^tr − ε‖` in
//! both. The algorithmic tangent `D = ∂τ/∂ε^tr` (3 × 3, principal):
//!
//! ```text
//! elastic:  D = K 1⊗1 + 2μ P_dev
//! cone:     D = K 1⊗1 − K B_ψ 1⊗g + 2μ θ P_dev − 2μ n⊗g + (4μ² Δγ / ‖s^tr‖) n⊗n,
//!           θ = 1 − 2μ Δγ / ‖s^tr‖,   g = (2μ n + K B 1) / (2μ + K B B_ψ + h c_ψ)
//! apex:     D = 0
//! ```
//!
//! (non-symmetric when `ψ ≠ φ`). References: J. C. Simo, Comput. Methods Appl. Mech. Engrg.
//! 99 (1992) 61–112 (the return map on principal log strains, Box 1); E. A. de Souza Neto,
//! D. Perić, D. R. J. Owen, *Computational Methods for Plasticity* (Wiley 2008), §8.3 (the
//! Drucker–Prager cone and apex returns, the plane-strain fit); G. Klar et al., ACM Trans.
//! Graph. 35 (2016) 103 (the same on the Hencky strain in MPM, for sand).

use serde::{Deserialize, Serialize};

use super::PlaneCondition;
use crate::error::{MpmError, Result};

/// von Mises (J2) plasticity with linear isotropic hardening on Hencky elasticity (finite
/// strain; [module docs](self)). Plane strain by default; plane stress solves for the
/// out-of-plane strain that makes `τ_zz = 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VonMises {
    /// Young's modulus `E` (> 0).
    #[serde(deserialize_with = "super::youngs_modulus")]
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν` (−1 < ν < ½).
    #[serde(deserialize_with = "super::poisson_ratio")]
    pub poisson_ratio: f64,
    /// Initial yield stress `σ_y` in uniaxial stress (> 0).
    #[serde(deserialize_with = "yield_stress")]
    pub yield_stress: f64,
    /// Linear isotropic hardening modulus `H` (≥ 0): `σ_eq = σ_y + H ε̄ᵖ`.
    #[serde(default, deserialize_with = "hardening_modulus")]
    pub hardening_modulus: f64,
    /// Plane strain (default) or plane stress.
    #[serde(default = "plane_strain")]
    pub plane: PlaneCondition,
}

/// Drucker–Prager plasticity on Hencky elasticity, its cone fitted to Mohr–Coulomb in plane
/// strain, with non-associated flow (dilatancy angle `ψ ≤ φ`) and the apex return in tension
/// ([module docs](self)). Plane strain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DruckerPrager {
    /// Young's modulus `E` (> 0).
    #[serde(deserialize_with = "super::youngs_modulus")]
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν` (−1 < ν < ½).
    #[serde(deserialize_with = "super::poisson_ratio")]
    pub poisson_ratio: f64,
    /// Friction angle `φ` in degrees, `[0, 90)`.
    #[serde(deserialize_with = "friction_angle")]
    pub friction_angle: f64,
    /// Cohesion `c` (≥ 0; 0 for a cohesionless granular material).
    #[serde(default, deserialize_with = "cohesion")]
    pub cohesion: f64,
    /// Dilatancy angle `ψ` in degrees, `[0, φ]` (0: plastic flow at constant volume).
    #[serde(default, deserialize_with = "dilatancy_angle")]
    pub dilatancy_angle: f64,
}

fn plane_strain() -> PlaneCondition {
    PlaneCondition::Strain
}

fn yield_stress<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    super::number_named(d, "yield_stress")
}
fn hardening_modulus<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    super::number_named(d, "hardening_modulus")
}
fn friction_angle<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    super::number_named(d, "friction_angle")
}
fn cohesion<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    super::number_named(d, "cohesion")
}
fn dilatancy_angle<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    super::number_named(d, "dilatancy_angle")
}

/// `Ok` when `ok`, else the error naming the parameter, its value and its range.
fn require(ok: bool, name: &'static str, value: f64, reason: &'static str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(MpmError::InvalidParameter { name, value, reason })
    }
}

/// Checks `E` and `ν` as [`super::LinearElastic::validate`] does.
fn check_elastic(youngs_modulus: f64, poisson_ratio: f64) -> Result<()> {
    super::LinearElastic::new(youngs_modulus, poisson_ratio, PlaneCondition::Strain).map(|_| ())
}

/// The largest yield stress, cohesion or hardening modulus accepted, relative to `E`
/// (beyond it the model never yields in any representable state and is an elastic one).
const STRENGTH_RANGE: f64 = 1e100;

impl VonMises {
    /// Checks the parameters.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] naming `youngs_modulus`, `poisson_ratio` (as
    /// [`super::LinearElastic::validate`]), `yield_stress` (must be positive and finite) or
    /// `hardening_modulus` (must be non-negative and finite).
    pub fn validate(&self) -> Result<()> {
        check_elastic(self.youngs_modulus, self.poisson_ratio)?;
        let (y, h) = (self.yield_stress, self.hardening_modulus);
        require(
            y > 0.0 && y < STRENGTH_RANGE,
            "yield_stress",
            y,
            "must be a positive finite number (below 1e100)",
        )?;
        require(
            (0.0..STRENGTH_RANGE).contains(&h),
            "hardening_modulus",
            h,
            "must be a non-negative finite number (below 1e100; softening is not modelled)",
        )
    }

    /// The cone of the [module docs](self): `B = B_ψ = 0`, `A = √(2/3) σ_y`, `h = √(2/3) H`.
    pub fn cone(&self) -> Cone {
        let k = (2.0f64 / 3.0).sqrt();
        Cone {
            strength: k * self.yield_stress,
            hardening: k * self.hardening_modulus,
            ..Cone::elastic(self.youngs_modulus, self.poisson_ratio, self.plane)
        }
    }
}

/// `B_ψ = 3√2 tan ψ / √(9 + 12 tan² ψ) = √6 sin ψ / √(3 + sin² ψ)` for `ψ` in degrees: the
/// slope of the plastic potential whose plane-strain flow dilates at the angle `ψ`.
fn dilation_slope(degrees: f64) -> f64 {
    let t = degrees.to_radians().tan();
    3.0 * std::f64::consts::SQRT_2 * t / (9.0 + 12.0 * t * t).sqrt()
}

impl DruckerPrager {
    /// Checks the parameters.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] naming `youngs_modulus`, `poisson_ratio`,
    /// `friction_angle` (`[0, 90)` degrees), `cohesion` (non-negative and finite; positive
    /// when `φ = 0`) or `dilatancy_angle` (`[0, φ]`).
    pub fn validate(&self) -> Result<()> {
        check_elastic(self.youngs_modulus, self.poisson_ratio)?;
        let (phi, c, psi) = (self.friction_angle, self.cohesion, self.dilatancy_angle);
        require(
            (0.0..90.0).contains(&phi),
            "friction_angle",
            phi,
            "must lie in [0, 90) degrees",
        )?;
        require(
            (0.0..STRENGTH_RANGE).contains(&c),
            "cohesion",
            c,
            "must be a non-negative finite number (below 1e100)",
        )?;
        require(
            phi > 0.0 || c > 0.0,
            "cohesion",
            c,
            "must be positive when friction_angle is 0 (the material would have no strength)",
        )?;
        require(
            psi >= 0.0 && psi <= phi,
            "dilatancy_angle",
            psi,
            "must lie in [0, friction_angle] degrees",
        )
    }

    /// The cone of the [module docs](self), fitted to Mohr–Coulomb in plane strain for the
    /// flow rule it has: with `B_ψ` of the dilatancy angle,
    ///
    /// ```text
    /// B = 2 sin φ / (√(2 − B_ψ²/3) + B_ψ sin φ / 3),   A = c cos φ (2 − B B_ψ/3) / √(2 − B_ψ²/3)
    /// ```
    ///
    /// so that at plastic flow in plane strain (`Δεᵖ_zz = 0`) the in-plane stresses obey
    /// `τ_max = c cos φ − σ_m sin φ` exactly (`σ_m` the in-plane mean stress, tension positive):
    /// `B = 3√2 tan φ / √(9 + 12 tan² φ)` for associated flow (`ψ = φ`), `√2 sin φ` for
    /// `ψ = 0`.
    pub fn cone(&self) -> Cone {
        let (sin, cos) = self.friction_angle.to_radians().sin_cos();
        let dilation = dilation_slope(self.dilatancy_angle);
        let root = (2.0 - dilation * dilation / 3.0).sqrt();
        let slope = 2.0 * sin / (root + dilation * sin / 3.0);
        Cone {
            slope,
            dilation,
            strength: self.cohesion * cos * (2.0 - slope * dilation / 3.0) / root,
            ..Cone::elastic(self.youngs_modulus, self.poisson_ratio, PlaneCondition::Strain)
        }
    }
}

/// The cone `‖s‖ + B p ≤ A + h ε̄ᵖ` with its elastic constants: the one return map of both
/// models ([module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    /// Bulk modulus `K`.
    pub(crate) bulk: f64,
    /// Shear modulus `μ`.
    pub(crate) shear: f64,
    /// `B`.
    pub(crate) slope: f64,
    /// `B_ψ`.
    pub(crate) dilation: f64,
    /// `A`.
    pub(crate) strength: f64,
    /// `h`.
    pub(crate) hardening: f64,
    /// Plane strain or plane stress.
    pub(crate) plane: PlaneCondition,
}

/// Which branch a return took.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regime {
    /// Inside the yield surface: elastic.
    Elastic,
    /// Returned onto the cone's surface.
    Cone,
    /// Returned to the apex (tension beyond the cone).
    Apex,
}

/// The result of a return from a trial state in principal strains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Returned {
    /// Principal Kirchhoff stresses `τᵢ`.
    pub stress: [f64; 3],
    /// Principal elastic log strains `εᵢ` after the return.
    pub strain: [f64; 3],
    /// The trial strains returned from (the out-of-plane one solved for in plane stress).
    pub trial: [f64; 3],
    /// The growth of the equivalent plastic strain, `√(2/3) ‖ε^tr − ε‖`.
    pub plastic_strain: f64,
    /// The algorithmic tangent `∂τᵢ/∂ε^tr_j`.
    pub tangent: [[f64; 3]; 3],
    /// The branch taken.
    pub regime: Regime,
}

impl Cone {
    /// The constants of an elastic material (no cone yet: `A` infinite).
    fn elastic(youngs_modulus: f64, poisson_ratio: f64, plane: PlaneCondition) -> Cone {
        Cone {
            bulk: youngs_modulus / (3.0 * (1.0 - 2.0 * poisson_ratio)),
            shear: youngs_modulus / (2.0 * (1.0 + poisson_ratio)),
            slope: 0.0,
            dilation: 0.0,
            strength: f64::INFINITY,
            hardening: 0.0,
            plane,
        }
    }

    /// Hencky's `τᵢ = K tr ε + 2μ (εᵢ − tr ε/3)`.
    pub fn elastic_stress(&self, e: [f64; 3]) -> [f64; 3] {
        let tr = e[0] + e[1] + e[2];
        e.map(|ei| self.bulk * tr + 2.0 * self.shear * (ei - tr / 3.0))
    }

    /// Hencky's `W(ε) = μ Σ εᵢ² + (λ/2)(tr ε)²`, per unit reference volume.
    pub fn energy_density(&self, e: [f64; 3]) -> f64 {
        let tr = e[0] + e[1] + e[2];
        let lambda = self.bulk - 2.0 * self.shear / 3.0;
        self.shear * (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) + 0.5 * lambda * tr * tr
    }

    /// The principal strains of a principal Kirchhoff stress (Hencky inverted).
    pub fn strain_of(&self, t: [f64; 3]) -> [f64; 3] {
        let p = (t[0] + t[1] + t[2]) / 3.0;
        t.map(|ti| p / (3.0 * self.bulk) + (ti - p) / (2.0 * self.shear))
    }

    /// The elastic `C11` in the plane: `K + 4μ/3` (plane strain), `E/(1 − ν²)` (plane stress).
    pub fn c11(&self) -> f64 {
        let (k, mu) = (self.bulk, self.shear);
        match self.plane {
            PlaneCondition::Strain => k + 4.0 * mu / 3.0,
            PlaneCondition::Stress => 4.0 * mu * (3.0 * k + mu) / (3.0 * k + 4.0 * mu),
        }
    }

    /// The return of the [module docs](self) from the trial principal strains `e` with
    /// equivalent plastic strain `eqps` before the step.
    pub fn principal_return(&self, e: [f64; 3], eqps: f64) -> Returned {
        let (k, mu) = (self.bulk, self.shear);
        let tau = self.elastic_stress(e);
        let p = (tau[0] + tau[1] + tau[2]) / 3.0;
        let s = tau.map(|t| t - p);
        let q = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        let f = q + self.slope * p - (self.strength + self.hardening * eqps);
        let third = 1.0 / 3.0;
        let dev = |i: usize, j: usize| f64::from(u8::from(i == j)) - third;
        if f.is_nan() || f <= 0.0 {
            let mut d = [[0.0; 3]; 3];
            for (i, row) in d.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v = k + 2.0 * mu * dev(i, j);
                }
            }
            return Returned {
                stress: tau,
                strain: e,
                trial: e,
                plastic_strain: 0.0,
                tangent: d,
                regime: Regime::Elastic,
            };
        }
        let c_psi = (2.0f64 / 3.0).sqrt() * (1.0 + self.dilation * self.dilation / 3.0).sqrt();
        let denominator = 2.0 * mu + k * self.slope * self.dilation + self.hardening * c_psi;
        let dgamma = f / denominator;
        if 2.0 * mu * dgamma > q && self.slope > 0.0 {
            let apex = (self.strength + self.hardening * eqps) / self.slope;
            let stress = [apex; 3];
            let strain = self.strain_of(stress);
            return Returned {
                stress,
                strain,
                trial: e,
                plastic_strain: plastic_growth(e, strain),
                tangent: [[0.0; 3]; 3],
                regime: Regime::Apex,
            };
        }
        let n = s.map(|si| si / q);
        let theta = 1.0 - 2.0 * mu * dgamma / q;
        let p_new = p - k * self.dilation * dgamma;
        let stress = [0, 1, 2].map(|i| p_new + theta * s[i]);
        let strain = self.strain_of(stress);
        let g = n.map(|ni| (2.0 * mu * ni + k * self.slope) / denominator);
        let mut d = [[0.0; 3]; 3];
        for (i, row) in d.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = k - k * self.dilation * g[j] + 2.0 * mu * theta * dev(i, j) - 2.0 * mu * n[i] * g[j]
                    + 4.0 * mu * mu * dgamma / q * n[i] * n[j];
            }
        }
        Returned {
            stress,
            strain,
            trial: e,
            plastic_strain: plastic_growth(e, strain),
            tangent: d,
            regime: Regime::Cone,
        }
    }

    /// [`Cone::principal_return`] with the out-of-plane strain as the plane condition has it:
    /// `e[2]` itself in plane strain; in plane stress the `e[2]` that makes `τ₃ = 0` (Newton
    /// from `e[2]`), the tangent condensed to the in-plane strains
    /// (`Dᵢⱼ − Dᵢ₃ D₃ⱼ / D₃₃`, third row and column zero).
    pub fn plane_return(&self, e: [f64; 3], eqps: f64) -> Returned {
        if self.plane == PlaneCondition::Strain {
            return self.principal_return(e, eqps);
        }
        let mut e = e;
        let mut r = self.principal_return(e, eqps);
        let scale = r.stress[0].abs() + r.stress[1].abs() + self.shear * 1e-300;
        for _ in 0..60 {
            let d33 = r.tangent[2][2];
            if r.stress[2].abs() <= 1e-14 * scale || d33.is_nan() || d33 <= 0.0 {
                break;
            }
            e[2] -= r.stress[2] / d33;
            r = self.principal_return(e, eqps);
        }
        let d = r.tangent;
        let mut condensed = [[0.0; 3]; 3];
        if d[2][2] > 0.0 {
            for i in 0..2 {
                for j in 0..2 {
                    condensed[i][j] = d[i][j] - d[i][2] * d[2][j] / d[2][2];
                }
            }
        }
        r.tangent = condensed;
        r
    }
}

/// `√(2/3) ‖a − b‖`.
fn plastic_growth(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (2.0 / 3.0 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2])).sqrt()
}

impl Cone {
    /// The yield function `f = ‖s‖ + B p − (A + h ε̄ᵖ)` at the principal Kirchhoff stresses `τ`.
    pub fn yield_function(&self, tau: [f64; 3], eqps: f64) -> f64 {
        let p = (tau[0] + tau[1] + tau[2]) / 3.0;
        let q = tau.iter().map(|t| (t - p) * (t - p)).sum::<f64>().sqrt();
        q + self.slope * p - (self.strength + self.hardening * eqps)
    }

    /// The apex pressure `A / B` (infinite for von Mises).
    pub fn apex(&self) -> f64 {
        self.strength / self.slope
    }
}
