//! Constitutive models.
//!
//! - [`LinearElastic`]: isotropic Hooke's law in rate form on the small-strain increment,
//!   plane stress or plane strain;
//! - [`NeoHookean`]: compressible neo-Hookean hyperelasticity from the deformation gradient,
//!   plane strain (`F_zz = 1`).
//!
//! [`Material`] is the choice between them that a simulation body carries: it updates the
//! stress of a particle from its velocity gradient and deformation gradient, gives the strain
//! energy and the wave speed that limits the time step.

use serde::{Deserialize, Serialize};

use crate::error::{MpmError, Result};
use crate::fields::StrainRate;

/// Which 2D idealisation a material uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlaneCondition {
    /// Thin body, `σzz = 0` (the seed's choice).
    #[default]
    Stress,
    /// Long body, `εzz = 0`.
    Strain,
}

/// Isotropic linear elasticity in rate form on the small-strain increment `Δε = ε̇ Δt`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearElastic {
    /// Young's modulus `E` (> 0).
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν` (−1 < ν < ½).
    pub poisson_ratio: f64,
    /// Plane stress or plane strain.
    #[serde(default)]
    pub plane: PlaneCondition,
}

impl LinearElastic {
    /// A validated linear elastic material.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] when `E` is not positive and finite or `ν ∉ (−1, ½)`.
    pub fn new(youngs_modulus: f64, poisson_ratio: f64, plane: PlaneCondition) -> Result<LinearElastic> {
        let m = LinearElastic {
            youngs_modulus,
            poisson_ratio,
            plane,
        };
        m.validate()?;
        Ok(m)
    }

    /// Checks the parameters (see [`LinearElastic::new`]).
    ///
    /// # Errors
    /// As [`LinearElastic::new`].
    pub fn validate(&self) -> Result<()> {
        if !(self.youngs_modulus.is_finite() && self.youngs_modulus > 0.0) {
            return Err(MpmError::InvalidParameter {
                name: "youngs_modulus",
                value: self.youngs_modulus,
                reason: "must be a positive finite number",
            });
        }
        if !(self.poisson_ratio > -1.0 && self.poisson_ratio < 0.5) {
            return Err(MpmError::InvalidParameter {
                name: "poisson_ratio",
                value: self.poisson_ratio,
                reason: "must lie strictly between -1 and 0.5",
            });
        }
        Ok(())
    }

    /// Shear modulus `G = E / (2 (1 + ν))`.
    pub fn shear_modulus(&self) -> f64 {
        self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))
    }

    /// The in-plane stiffness `[[C11, C12], [C12, C11]]` relating `(σxx, σyy)` to `(εxx, εyy)`:
    ///
    /// ```text
    /// plane stress:  C11 = E/(1 − ν²),               C12 = ν E/(1 − ν²)
    /// plane strain:  C11 = E(1 − ν)/((1 + ν)(1 − 2ν)), C12 = ν E/((1 + ν)(1 − 2ν))
    /// ```
    ///
    /// returned as `(C11, C12)`; the shear term is `σxy = 2 G εxy`.
    pub fn normal_stiffness(&self) -> (f64, f64) {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        match self.plane {
            PlaneCondition::Stress => (e / (1.0 - nu * nu), nu * e / (1.0 - nu * nu)),
            PlaneCondition::Strain => {
                let d = (1.0 + nu) * (1.0 - 2.0 * nu);
                (e * (1.0 - nu) / d, nu * e / d)
            }
        }
    }

    /// P-wave speed `c = √(C11/ρ)`, the speed that limits the explicit time step.
    pub fn wave_speed(&self, density: f64) -> f64 {
        (self.normal_stiffness().0 / density).sqrt()
    }

    /// Stress increment for a strain increment `(Δεxx, Δεyy, Δεxy)` (tensor shear):
    ///
    /// ```text
    /// Δσxx = C11 Δεxx + C12 Δεyy,   Δσyy = C12 Δεxx + C11 Δεyy,   Δσxy = 2 G Δεxy
    /// ```
    pub fn stress_increment(&self, dexx: f64, deyy: f64, dexy: f64) -> [f64; 3] {
        let (c11, c12) = self.normal_stiffness();
        [
            c11 * dexx + c12 * deyy,
            c12 * dexx + c11 * deyy,
            2.0 * self.shear_modulus() * dexy,
        ]
    }

    /// Rate-form stress update of every particle (seed 4(F), dimensionally consistent form):
    ///
    /// ```text
    /// σ_p ← σ_p + C : (ε̇_p Δt)
    /// ```
    ///
    /// # Panics
    /// On length mismatch.
    pub fn update_stress(&self, sxx: &mut [f64], syy: &mut [f64], sxy: &mut [f64], rate: &StrainRate, dt: f64) {
        assert!(
            sxx.len() == rate.xx.len() && syy.len() == rate.yy.len() && sxy.len() == rate.xy.len(),
            "one stress and one strain rate per particle"
        );
        for p in 0..sxx.len() {
            let [dxx, dyy, dxy] = self.stress_increment(rate.xx[p] * dt, rate.yy[p] * dt, rate.xy[p] * dt);
            sxx[p] += dxx;
            syy[p] += dyy;
            sxy[p] += dxy;
        }
    }
}

impl LinearElastic {
    /// Strain energy per unit volume from the stress, `W = ½ σ : ε` with `ε = C⁻¹ σ`:
    ///
    /// ```text
    /// W = ½ (σxx εxx + σyy εyy) + σxy² / (2 G),   (εxx, εyy) = [[C11, C12], [C12, C11]]⁻¹ (σxx, σyy)
    /// ```
    pub fn strain_energy_density(&self, sxx: f64, syy: f64, sxy: f64) -> f64 {
        let (c11, c12) = self.normal_stiffness();
        let det = c11 * c11 - c12 * c12;
        let exx = (c11 * sxx - c12 * syy) / det;
        let eyy = (c11 * syy - c12 * sxx) / det;
        0.5 * (sxx * exx + syy * eyy) + sxy * sxy / (2.0 * self.shear_modulus())
    }
}

/// Compressible neo-Hookean hyperelasticity in plane strain (`F_zz = 1`):
///
/// ```text
/// W(F) = μ/2 (tr(Fᵀ F) − 2) − μ ln J + λ/2 (ln J)²          (per unit reference volume)
/// σ    = (μ / J) (F Fᵀ − I) + (λ ln J / J) I                 (Cauchy stress, in-plane part)
/// ```
///
/// with `J = det F`, `μ = E / (2(1 + ν))`, `λ = E ν / ((1 + ν)(1 − 2ν))`. For small strains it
/// reduces to [`LinearElastic`] in plane strain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NeoHookean {
    /// Young's modulus `E` (> 0) of the small-strain limit.
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν` (−1 < ν < ½) of the small-strain limit.
    pub poisson_ratio: f64,
}

impl NeoHookean {
    /// Lamé constants `(μ, λ)`.
    pub fn lame(&self) -> (f64, f64) {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        (e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)))
    }

    /// Cauchy stress `(σxx, σyy, σxy)` for the deformation gradient `F = [[fxx, fxy], [fyx, fyy]]`
    /// (equation in the type's docs). `J ≤ 0` gives non-finite values; the simulation checks
    /// `J` first.
    pub fn stress(&self, f: [f64; 4]) -> [f64; 3] {
        let (mu, lambda) = self.lame();
        let [fxx, fxy, fyx, fyy] = f;
        let j = fxx * fyy - fxy * fyx;
        let (a, b) = (mu / j, lambda * j.ln() / j);
        [
            a * (fxx * fxx + fxy * fxy - 1.0) + b,
            a * (fyx * fyx + fyy * fyy - 1.0) + b,
            a * (fxx * fyx + fxy * fyy),
        ]
    }

    /// [`NeoHookean::stress`] and [`NeoHookean::strain_energy_density`] together, sharing
    /// `ln J`.
    pub fn stress_and_energy_density(&self, f: [f64; 4]) -> ([f64; 3], f64) {
        let (mu, lambda) = self.lame();
        let [fxx, fxy, fyx, fyy] = f;
        let j = fxx * fyy - fxy * fyx;
        let ln_j = j.ln();
        let (a, b) = (mu / j, lambda * ln_j / j);
        let stress = [
            a * (fxx * fxx + fxy * fxy - 1.0) + b,
            a * (fyx * fyx + fyy * fyy - 1.0) + b,
            a * (fxx * fyx + fxy * fyy),
        ];
        let energy =
            0.5 * mu * (fxx * fxx + fxy * fxy + fyx * fyx + fyy * fyy - 2.0) - mu * ln_j + 0.5 * lambda * ln_j * ln_j;
        (stress, energy)
    }

    /// Strain energy per unit reference volume `W(F)` (equation in the type's docs).
    pub fn strain_energy_density(&self, f: [f64; 4]) -> f64 {
        let (mu, lambda) = self.lame();
        let [fxx, fxy, fyx, fyy] = f;
        let ln_j = (fxx * fyy - fxy * fyx).ln();
        0.5 * mu * (fxx * fxx + fxy * fxy + fyx * fyx + fyy * fyy - 2.0) - mu * ln_j + 0.5 * lambda * ln_j * ln_j
    }
}

/// A material's constants (stiffness, Lamé parameters) computed once, for the per-particle
/// update of the time loop: the same arithmetic as [`Material::update`] and
/// [`Material::tangent`], without recomputing the constants for every particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Prepared {
    /// Linear elasticity: `C11`, `C12` and the shear modulus.
    Linear { c11: f64, c12: f64, shear: f64 },
    /// Neo-Hookean: the Lamé parameters.
    NeoHookean { mu: f64, lambda: f64 },
}

impl Prepared {
    /// `(σ, strain energy, C11)` after the update ([`Material::update_with_modulus`]).
    #[inline(always)]
    pub(crate) fn update_with_modulus(
        &self,
        sigma: [f64; 3],
        l: [f64; 4],
        f: [f64; 4],
        dt: f64,
        volume: f64,
    ) -> ([f64; 3], f64, f64) {
        match *self {
            Prepared::Linear { c11, c12, shear } => {
                let (dexx, deyy, dexy) = (l[0] * dt, l[3] * dt, 0.5 * (l[1] + l[2]) * dt);
                let d = [c11 * dexx + c12 * deyy, c12 * dexx + c11 * deyy, 2.0 * shear * dexy];
                let s = [sigma[0] + d[0], sigma[1] + d[1], sigma[2] + d[2]];
                let det = c11 * c11 - c12 * c12;
                let exx = (c11 * s[0] - c12 * s[1]) / det;
                let eyy = (c11 * s[1] - c12 * s[0]) / det;
                let w = 0.5 * (s[0] * exx + s[1] * eyy) + s[2] * s[2] / (2.0 * shear);
                (s, volume * w, c11)
            }
            Prepared::NeoHookean { mu, lambda } => {
                let [fxx, fxy, fyx, fyy] = f;
                let j = fxx * fyy - fxy * fyx;
                let ln_j = j.ln();
                let (a, b) = (mu / j, lambda * ln_j / j);
                let stress = [
                    a * (fxx * fxx + fxy * fxy - 1.0) + b,
                    a * (fyx * fyx + fyy * fyy - 1.0) + b,
                    a * (fxx * fyx + fxy * fyy),
                ];
                let w = 0.5 * mu * (fxx * fxx + fxy * fxy + fyx * fyx + fyy * fyy - 2.0) - mu * ln_j
                    + 0.5 * lambda * ln_j * ln_j;
                let mu_j = mu - lambda * ln_j;
                (stress, volume / j * w, (lambda + 2.0 * mu_j) / j)
            }
        }
    }
}

/// The constitutive model of a body.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum Material {
    /// Linear elasticity, rate form.
    LinearElastic(LinearElastic),
    /// Compressible neo-Hookean, plane strain.
    NeoHookean(NeoHookean),
}

impl Material {
    /// Checks the parameters.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] when `E` is not positive and finite or `ν ∉ (−1, ½)`.
    pub fn validate(&self) -> Result<()> {
        match self {
            Material::LinearElastic(m) => m.validate(),
            Material::NeoHookean(m) => {
                LinearElastic::new(m.youngs_modulus, m.poisson_ratio, PlaneCondition::Strain).map(|_| ())
            }
        }
    }

    /// The P-wave speed of the small-strain limit at reference density `ρ`, `c = √(C11/ρ)`
    /// (plane strain `C11 = λ + 2μ` for neo-Hookean).
    pub fn wave_speed(&self, density: f64) -> f64 {
        match self {
            Material::LinearElastic(m) => m.wave_speed(density),
            Material::NeoHookean(m) => LinearElastic {
                youngs_modulus: m.youngs_modulus,
                poisson_ratio: m.poisson_ratio,
                plane: PlaneCondition::Strain,
            }
            .wave_speed(density),
        }
    }

    /// The isotropic spatial tangent `[C11, C12, G]` at the deformation gradient `F`, which
    /// relates a stress rate to the rate of deformation (`σ̇xx = C11 ε̇xx + C12 ε̇yy`,
    /// `σ̇xy = 2 G ε̇xy`):
    ///
    /// ```text
    /// linear elastic:  C11, C12, G of the material (independent of F)
    /// neo-Hookean:     C11 = (λ + 2μ')/J,  C12 = λ/J,  G = μ'/J,   μ' = μ − λ ln J,  J = det F
    /// ```
    ///
    /// (the neo-Hookean one without the initial-stress term). It sets the stiffness of the
    /// stable-time-step estimate.
    pub fn tangent(&self, f: [f64; 4]) -> [f64; 3] {
        match self {
            Material::LinearElastic(m) => {
                let (c11, c12) = m.normal_stiffness();
                [c11, c12, m.shear_modulus()]
            }
            Material::NeoHookean(m) => {
                let (mu, lambda) = m.lame();
                let j = f[0] * f[3] - f[1] * f[2];
                let mu_j = mu - lambda * j.ln();
                [(lambda + 2.0 * mu_j) / j, lambda / j, mu_j / j]
            }
        }
    }

    /// New stress of one particle after a step of length `dt` with velocity gradient
    /// `L = [[lxx, lxy], [lyx, lyy]]`, given its stress before and its updated deformation
    /// gradient `F`:
    ///
    /// ```text
    /// linear elastic:  σ ← σ + C : (sym L Δt)
    /// neo-Hookean:     σ = σ(F)
    /// ```
    pub fn updated_stress(&self, sigma: [f64; 3], l: [f64; 4], f: [f64; 4], dt: f64) -> [f64; 3] {
        match self {
            Material::LinearElastic(m) => {
                let d = m.stress_increment(l[0] * dt, l[3] * dt, 0.5 * (l[1] + l[2]) * dt);
                [sigma[0] + d[0], sigma[1] + d[1], sigma[2] + d[2]]
            }
            Material::NeoHookean(m) => m.stress(f),
        }
    }

    /// [`Material::updated_stress`] and the particle's strain energy after the update
    /// ([`Material::strain_energy`] with the new stress and `F`, current volume `volume`), in one
    /// evaluation.
    pub fn update(&self, sigma: [f64; 3], l: [f64; 4], f: [f64; 4], dt: f64, volume: f64) -> ([f64; 3], f64) {
        match self {
            Material::LinearElastic(m) => {
                let s = self.updated_stress(sigma, l, f, dt);
                (s, volume * m.strain_energy_density(s[0], s[1], s[2]))
            }
            Material::NeoHookean(m) => {
                let (s, w) = m.stress_and_energy_density(f);
                (s, volume / (f[0] * f[3] - f[1] * f[2]) * w)
            }
        }
    }

    /// [`Material::update`] and the tangent's `C11` at the updated `F` ([`Material::tangent`]),
    /// sharing `ln J`: `(σ, strain energy, C11)`.
    pub fn update_with_modulus(
        &self,
        sigma: [f64; 3],
        l: [f64; 4],
        f: [f64; 4],
        dt: f64,
        volume: f64,
    ) -> ([f64; 3], f64, f64) {
        self.prepared().update_with_modulus(sigma, l, f, dt, volume)
    }

    /// The material's constants, computed once for a loop over many particles.
    pub(crate) fn prepared(&self) -> Prepared {
        match self {
            Material::LinearElastic(m) => {
                let (c11, c12) = m.normal_stiffness();
                Prepared::Linear {
                    c11,
                    c12,
                    shear: m.shear_modulus(),
                }
            }
            Material::NeoHookean(m) => {
                let (mu, lambda) = m.lame();
                Prepared::NeoHookean { mu, lambda }
            }
        }
    }

    /// Strain energy of a particle of current volume `V` with stress `σ` and deformation
    /// gradient `F`:
    ///
    /// ```text
    /// linear elastic:  V · ½ σ : C⁻¹ σ
    /// neo-Hookean:     V₀ W(F),  V₀ = V / det F
    /// ```
    pub fn strain_energy(&self, volume: f64, sigma: [f64; 3], f: [f64; 4]) -> f64 {
        match self {
            Material::LinearElastic(m) => volume * m.strain_energy_density(sigma[0], sigma[1], sigma[2]),
            Material::NeoHookean(m) => volume / (f[0] * f[3] - f[1] * f[2]) * m.strain_energy_density(f),
        }
    }
}
