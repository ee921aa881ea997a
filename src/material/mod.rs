//! Constitutive models.
//!
//! - [`LinearElastic`]: isotropic Hooke's law in rate form on the small-strain increment,
//!   plane stress or plane strain;
//! - [`NeoHookean`]: compressible neo-Hookean hyperelasticity from the deformation gradient,
//!   plane strain (`F_zz = 1`);
//! - [`VonMises`]: J2 plasticity with linear isotropic hardening, and [`DruckerPrager`]:
//!   pressure-dependent plasticity for soils and granular materials, both on Hencky elasticity
//!   at finite strain ([`plastic`] for the return map and its tangent, [`hencky`] for the
//!   update of the elastic log strain that each particle carries).
//!
//! [`Material`] is the choice between them that a simulation body carries: it gives the
//! tangent, the strain energy and the wave speed that limits the time step; the time loop
//! updates the stress of a particle from its velocity gradient and deformation gradient.
//!
//! Each model's stress, strain energy density and tangent are written once, in one private
//! evaluation that the public accessors and the time loop's per-particle update share.

use serde::{Deserialize, Serialize};

pub mod hencky;
pub mod plastic;

pub use hencky::{PlasticState, Updated};
pub use plastic::{Cone, DruckerPrager, Regime, Returned, VonMises};

use crate::error::{MpmError, Result};
use crate::fields::StrainRate;
use crate::lanes::Real;

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
    #[serde(deserialize_with = "youngs_modulus")]
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν` (−1 < ν < ½).
    #[serde(deserialize_with = "poisson_ratio")]
    pub poisson_ratio: f64,
    /// Plane stress or plane strain.
    #[serde(default)]
    pub plane: PlaneCondition,
}

/// The Young's moduli accepted, `[E_min, E_max]` (in the scene's units): beyond them the
/// strain energy `½ σ : C⁻¹ σ` under- or overflows (10⁻³⁰⁰ gave NaN) and the stable step
/// `h / √(E/ρ)` rounds to zero or to centuries, with no body of any material between.
pub const MODULUS_RANGE: [f64; 2] = [1e-100, 1e100];

/// The densities accepted (a scene's `bodies[k].density`), `[ρ_min, ρ_max]`: beyond them a
/// particle's kinetic and potential energy overflow (ρ = 10³⁰⁰ gave NaN in the first step).
pub const DENSITY_RANGE: [f64; 2] = [1e-100, 1e100];

impl LinearElastic {
    /// A validated linear elastic material.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] when `E` lies outside [`MODULUS_RANGE`] (or is not finite)
    /// or `ν ∉ (−1, ½)`.
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
        let [low, high] = MODULUS_RANGE;
        if !(self.youngs_modulus.is_finite() && self.youngs_modulus > 0.0) {
            return Err(MpmError::InvalidParameter {
                name: "youngs_modulus",
                value: self.youngs_modulus,
                reason: "must be a positive finite number",
            });
        }
        if !(low..=high).contains(&self.youngs_modulus) {
            return Err(MpmError::InvalidParameter {
                name: "youngs_modulus",
                value: self.youngs_modulus,
                reason: "must lie between 1e-100 and 1e100 (material::MODULUS_RANGE)",
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

    /// The stiffness as a `4 × 4` matrix on the displacement gradient `∇u` (row-major
    /// `[xx, xy, yx, yy]`), `Δσ_ab = Σ_cd C_abcd (∇u)_cd` with the symmetric part taken:
    ///
    /// ```text
    /// C: xx,xx = yy,yy = C11;  xx,yy = yy,xx = C12;  {xy, yx} × {xy, yx} = G
    /// ```
    pub fn stiffness_tensor(&self) -> [[f64; 4]; 4] {
        let (c11, c12) = self.normal_stiffness();
        let g = self.shear_modulus();
        [
            [c11, 0.0, 0.0, c12],
            [0.0, g, g, 0.0],
            [0.0, g, g, 0.0],
            [c12, 0.0, 0.0, c11],
        ]
    }

    /// Stress increment for a strain increment `(Δεxx, Δεyy, Δεxy)` (tensor shear):
    ///
    /// ```text
    /// Δσxx = C11 Δεxx + C12 Δεyy,   Δσyy = C12 Δεxx + C11 Δεyy,   Δσxy = 2 G Δεxy
    /// ```
    pub fn stress_increment(&self, dexx: f64, deyy: f64, dexy: f64) -> [f64; 3] {
        self.hooke().increment([dexx, deyy, dexy])
    }

    /// Rate-form stress update of every particle (seed 4(F), dimensionally consistent form):
    ///
    /// ```text
    /// σ_p ← σ_p + C : (ε̇_p Δt)
    /// ```
    ///
    /// (the per-particle arithmetic of the time loop's linear elastic update).
    ///
    /// # Panics
    /// On length mismatch.
    pub fn update_stress(&self, sxx: &mut [f64], syy: &mut [f64], sxy: &mut [f64], rate: &StrainRate, dt: f64) {
        assert!(
            sxx.len() == rate.xx.len() && syy.len() == rate.yy.len() && sxy.len() == rate.xy.len(),
            "one stress and one strain rate per particle"
        );
        let hooke = self.hooke();
        for p in 0..sxx.len() {
            let strain = [rate.xx[p] * dt, rate.yy[p] * dt, rate.xy[p] * dt];
            [sxx[p], syy[p], sxy[p]] = hooke.updated([sxx[p], syy[p], sxy[p]], strain);
        }
    }

    /// Strain energy per unit volume from the stress, `W = ½ σ : ε` with `ε = C⁻¹ σ`:
    ///
    /// ```text
    /// W = ½ (σxx εxx + σyy εyy) + σxy² / (2 G),   (εxx, εyy) = [[C11, C12], [C12, C11]]⁻¹ (σxx, σyy)
    /// ```
    pub fn strain_energy_density(&self, sxx: f64, syy: f64, sxy: f64) -> f64 {
        self.hooke().energy_density([sxx, syy, sxy])
    }

    /// The constants `C11`, `C12`, `G` of [`LinearElastic::normal_stiffness`] and
    /// [`LinearElastic::shear_modulus`].
    fn hooke(&self) -> Hooke {
        let (c11, c12) = self.normal_stiffness();
        Hooke {
            c11,
            c12,
            shear: self.shear_modulus(),
        }
    }
}

/// Linear elasticity with its constants computed: the one place where the stress increment
/// and the strain energy density of [`LinearElastic`] are written (its tangent is the
/// constants themselves).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Hooke {
    /// `C11` of [`LinearElastic::normal_stiffness`].
    c11: f64,
    /// `C12` of [`LinearElastic::normal_stiffness`].
    c12: f64,
    /// The shear modulus `G`.
    shear: f64,
}

impl Hooke {
    /// `Δσ = C : Δε` for `Δε = (Δεxx, Δεyy, Δεxy)` (tensor shear).
    #[inline(always)]
    fn increment<R: Real>(&self, [dexx, deyy, dexy]: [R; 3]) -> [R; 3] {
        let (c11, c12, shear) = (R::splat(self.c11), R::splat(self.c12), R::splat(self.shear));
        [
            c11 * dexx + c12 * deyy,
            c12 * dexx + c11 * deyy,
            R::splat(2.0) * shear * dexy,
        ]
    }

    /// `σ + C : Δε`.
    #[inline(always)]
    fn updated<R: Real>(&self, sigma: [R; 3], strain: [R; 3]) -> [R; 3] {
        let d = self.increment(strain);
        [sigma[0] + d[0], sigma[1] + d[1], sigma[2] + d[2]]
    }

    /// `W = ½ σ : C⁻¹ σ`.
    #[inline(always)]
    fn energy_density<R: Real>(&self, s: [R; 3]) -> R {
        let Hooke { c11, c12, shear } = *self;
        let det = R::splat(c11 * c11 - c12 * c12);
        let (c11, c12) = (R::splat(c11), R::splat(c12));
        let exx = (c11 * s[0] - c12 * s[1]) / det;
        let eyy = (c11 * s[1] - c12 * s[0]) / det;
        R::splat(0.5) * (s[0] * exx + s[1] * eyy) + s[2] * s[2] / R::splat(2.0 * shear)
    }

    /// The tangent `[C11, C12, G]`.
    #[inline(always)]
    fn tangent(&self) -> [f64; 3] {
        [self.c11, self.c12, self.shear]
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
    #[serde(deserialize_with = "youngs_modulus")]
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν` (−1 < ν < ½) of the small-strain limit.
    #[serde(deserialize_with = "poisson_ratio")]
    pub poisson_ratio: f64,
}

/// A number whose error names `key`: the fields of an internally tagged enum (`model = …`)
/// lose their names in serde's own messages ("invalid type: string, expected f64").
fn number_named<'de, D: serde::Deserializer<'de>>(d: D, key: &str) -> std::result::Result<f64, D::Error> {
    use serde::de::Error;
    f64::deserialize(d).map_err(|e| D::Error::custom(format!("`{key}`: {e}")))
}

fn youngs_modulus<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    number_named(d, "youngs_modulus")
}

fn poisson_ratio<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    number_named(d, "poisson_ratio")
}

impl NeoHookean {
    /// Lamé constants `(μ, λ)`:
    ///
    /// ```text
    /// μ = E / (2(1 + ν)),   λ = E ν / ((1 + ν)(1 − 2ν))
    /// ```
    pub fn lame(&self) -> (f64, f64) {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        (e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)))
    }

    /// Cauchy stress `(σxx, σyy, σxy)` for the deformation gradient `F = [[fxx, fxy], [fyx, fyy]]`:
    ///
    /// ```text
    /// σ = (μ / J) (F Fᵀ − I) + (λ ln J / J) I,   J = det F
    /// ```
    ///
    /// `J ≤ 0` gives non-finite values; the simulation checks `J` first.
    pub fn stress(&self, f: [f64; 4]) -> [f64; 3] {
        self.constants().at(f).stress
    }

    /// Strain energy per unit reference volume:
    ///
    /// ```text
    /// W(F) = μ/2 (tr(Fᵀ F) − 2) − μ ln J + λ/2 (ln J)²,   J = det F
    /// ```
    pub fn strain_energy_density(&self, f: [f64; 4]) -> f64 {
        self.constants().at(f).energy_density
    }

    /// The first Piola–Kirchhoff stress and its derivative at `F` (each `2 × 2` index pair
    /// row-major, `[xx, xy, yx, yy]`): the stress and tangent of the implicit integrators
    /// ([`crate::implicit`]), the same model as [`NeoHookean::stress`] (`σ = P Fᵀ / J`):
    ///
    /// ```text
    /// P(F) = μ F + (λ ln J − μ) F⁻ᵀ,
    /// A_aBcD = ∂P_aB/∂F_cD = μ δ_ac δ_BD + λ F⁻¹_Ba F⁻¹_Dc + (μ − λ ln J) F⁻¹_Bc F⁻¹_Da
    /// ```
    ///
    /// `J ≤ 0` gives non-finite values; the callers check `J` first.
    pub fn first_piola_kirchhoff(&self, f: [f64; 4]) -> ([f64; 4], [[f64; 4]; 4]) {
        let (mu, lambda) = self.lame();
        let j = f[0] * f[3] - f[1] * f[2];
        let inv = [f[3] / j, -f[1] / j, -f[2] / j, f[0] / j]; // F⁻¹
        let ln_j = j.ln();
        // (F^{-T})_aB = F⁻¹_Ba.
        let at = |r: usize, c: usize| inv[2 * r + c];
        let mut big_p = [0.0; 4];
        for a in 0..2 {
            for b in 0..2 {
                big_p[2 * a + b] = mu * f[2 * a + b] + (lambda * ln_j - mu) * at(b, a);
            }
        }
        let delta = |i: usize, k: usize| if i == k { 1.0 } else { 0.0 };
        let mut big_a = [[0.0; 4]; 4];
        for a in 0..2 {
            for bb in 0..2 {
                for c in 0..2 {
                    for d in 0..2 {
                        big_a[2 * a + bb][2 * c + d] = mu * delta(a, c) * delta(bb, d)
                            + lambda * at(bb, a) * at(d, c)
                            + (mu - lambda * ln_j) * at(bb, c) * at(d, a);
                    }
                }
            }
        }
        (big_p, big_a)
    }

    /// The Lamé constants of [`NeoHookean::lame`].
    fn constants(&self) -> Lame {
        let (mu, lambda) = self.lame();
        Lame { mu, lambda }
    }
}

/// Neo-Hookean hyperelasticity with its Lamé constants computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Lame {
    /// `μ`.
    mu: f64,
    /// `λ`.
    lambda: f64,
}

/// What the neo-Hookean model gives at one deformation gradient (or four, [`Real`]).
#[derive(Debug, Clone, Copy)]
struct NeoHookeanState<R> {
    /// `1/J`, `J = det F`.
    inv_j: R,
    /// The Cauchy stress `(σxx, σyy, σxy)`.
    stress: [R; 3],
    /// `W(F)` per unit reference volume.
    energy_density: R,
    /// The spatial tangent `[C11, C12, G]` (see [`Material::tangent`]).
    tangent: [R; 3],
}

impl Lame {
    /// The one place where the neo-Hookean `σ(F)`, `W(F)` and tangent are written, sharing
    /// `J`, `ln J` and `F Fᵀ` (equations in [`NeoHookean`] and [`Material::tangent`]).
    #[inline(always)]
    fn at<R: Real>(&self, f: [R; 4]) -> NeoHookeanState<R> {
        let c = R::splat;
        let (mu, lambda) = (c(self.mu), c(self.lambda));
        let [fxx, fxy, fyx, fyy] = f;
        let j = fxx * fyy - fxy * fyx;
        let ln_j = j.ln();
        // One division: 1/J, which every quantity below is a product with.
        let inv_j = c(1.0) / j;
        let (a, b) = (mu * inv_j, lambda * ln_j * inv_j);
        let stress = [
            a * (fxx * fxx + fxy * fxy - c(1.0)) + b,
            a * (fyx * fyx + fyy * fyy - c(1.0)) + b,
            a * (fxx * fyx + fxy * fyy),
        ];
        let energy_density = c(0.5) * mu * (fxx * fxx + fxy * fxy + fyx * fyx + fyy * fyy - c(2.0)) - mu * ln_j
            + c(0.5) * lambda * ln_j * ln_j;
        let mu_j = mu - lambda * ln_j;
        NeoHookeanState {
            inv_j,
            stress,
            energy_density,
            tangent: [(lambda + c(2.0) * mu_j) * inv_j, lambda * inv_j, mu_j * inv_j],
        }
    }
}

/// A material's constants (stiffness, Lamé parameters) computed once, for the per-particle
/// update of the time loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Prepared {
    /// Linear elasticity: `C11`, `C12` and the shear modulus.
    Linear(Hooke),
    /// Neo-Hookean: the Lamé parameters.
    NeoHookean(Lame),
    /// An elastoplastic model: its cone and elastic constants (the update takes the particle's
    /// plastic state, [`Cone::update`](plastic::Cone::update)).
    Plastic(plastic::Cone),
}

impl Prepared {
    /// [`Material::tangent`] with the constants computed (for a loop over many particles).
    #[inline]
    pub(crate) fn tangent(&self, f: [f64; 4]) -> [f64; 3] {
        match self {
            Prepared::Linear(hooke) => hooke.tangent(),
            Prepared::NeoHookean(lame) => lame.at(f).tangent,
            Prepared::Plastic(cone) => {
                let j = f[0] * f[3] - f[1] * f[2];
                let c11 = cone.c11();
                let shear = cone.shear / j;
                [c11 / j, c11 / j - 2.0 * shear, shear]
            }
        }
    }

    /// The cone of an elastoplastic model, if this is one.
    #[inline]
    pub(crate) fn plastic(&self) -> Option<&plastic::Cone> {
        match self {
            Prepared::Plastic(cone) => Some(cone),
            _ => None,
        }
    }

    /// The stress update of one particle after a step of length `dt` with velocity gradient
    /// `L = [[lxx, lxy], [lyx, lyy]]`, given its stress before, its updated deformation gradient
    /// `F` and its current volume `V`: `(σ, strain energy, C11)` with
    ///
    /// ```text
    /// linear elastic:  σ ← σ + C : (sym L Δt),   energy V · ½ σ : C⁻¹ σ,   C11 of the material
    /// neo-Hookean:     σ = σ(F),                 energy V₀ W(F), V₀ = V / det F,   C11 at F
    /// ```
    ///
    /// (`C11` as in [`Material::tangent`]).
    #[inline(always)]
    pub(crate) fn update_with_modulus<R: Real>(
        &self,
        sigma: [R; 3],
        l: [R; 4],
        f: [R; 4],
        dt: f64,
        volume: R,
    ) -> ([R; 3], R, R) {
        match *self {
            Prepared::Linear(hooke) => {
                let dt = R::splat(dt);
                let s = hooke.updated(sigma, [l[0] * dt, l[3] * dt, R::splat(0.5) * (l[1] + l[2]) * dt]);
                (s, volume * hooke.energy_density(s), R::splat(hooke.c11))
            }
            Prepared::NeoHookean(lame) => {
                let at = lame.at(f);
                (at.stress, volume * at.inv_j * at.energy_density, at.tangent[0])
            }
            // The step's plan sends the particles of elastoplastic bodies through the update
            // that carries their state (`simulation::phases::update_stress`).
            Prepared::Plastic(_) => unreachable!("an elastoplastic material's update takes its plastic state"),
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
    /// von Mises (J2) plasticity with linear isotropic hardening.
    VonMises(VonMises),
    /// Drucker–Prager plasticity, plane strain.
    DruckerPrager(DruckerPrager),
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
            Material::VonMises(m) => m.validate(),
            Material::DruckerPrager(m) => m.validate(),
        }
    }

    /// Whether the model is elastoplastic (its particles carry a plastic state).
    pub fn is_plastic(&self) -> bool {
        matches!(self, Material::VonMises(_) | Material::DruckerPrager(_))
    }

    /// The cone of an elastoplastic model ([`plastic`]).
    pub fn cone(&self) -> Option<plastic::Cone> {
        match self {
            Material::VonMises(m) => Some(m.cone()),
            Material::DruckerPrager(m) => Some(m.cone()),
            _ => None,
        }
    }

    /// The P-wave speed of the small-strain limit at reference density `ρ`, `c = √(C11/ρ)`
    /// (plane strain `C11 = λ + 2μ` for neo-Hookean and the plastic models in plane strain,
    /// `E/(1 − ν²)` in plane stress).
    pub fn wave_speed(&self, density: f64) -> f64 {
        if let Some(cone) = self.cone() {
            return (cone.c11() / density).sqrt();
        }
        match self {
            Material::LinearElastic(m) => m.wave_speed(density),
            Material::NeoHookean(m) => LinearElastic {
                youngs_modulus: m.youngs_modulus,
                poisson_ratio: m.poisson_ratio,
                plane: PlaneCondition::Strain,
            }
            .wave_speed(density),
            Material::VonMises(_) | Material::DruckerPrager(_) => unreachable!("the cone's wave speed is above"),
        }
    }

    /// The isotropic spatial tangent `[C11, C12, G]` at the deformation gradient `F`, which
    /// relates a stress rate to the rate of deformation (`σ̇xx = C11 ε̇xx + C12 ε̇yy`,
    /// `σ̇xy = 2 G ε̇xy`):
    ///
    /// ```text
    /// linear elastic:  C11, C12, G of the material (independent of F)
    /// neo-Hookean:     C11 = (λ + 2μ')/J,  C12 = λ/J,  G = μ'/J,   μ' = μ − λ ln J,  J = det F
    /// plastic:         C11 = C11ᵉ/J,  C12 = (C11ᵉ − 2μ)/J,  G = μ/J   (the elastic constants)
    /// ```
    ///
    /// (the neo-Hookean one without the initial-stress term). It sets the stiffness of the
    /// stable-time-step estimate.
    pub fn tangent(&self, f: [f64; 4]) -> [f64; 3] {
        self.prepared().tangent(f)
    }

    /// The material's constants, computed once for a loop over many particles.
    pub(crate) fn prepared(&self) -> Prepared {
        match self {
            Material::LinearElastic(m) => Prepared::Linear(m.hooke()),
            Material::NeoHookean(m) => Prepared::NeoHookean(m.constants()),
            Material::VonMises(m) => Prepared::Plastic(m.cone()),
            Material::DruckerPrager(m) => Prepared::Plastic(m.cone()),
        }
    }

    /// Strain energy of a particle of current volume `V` with stress `σ` and deformation
    /// gradient `F`:
    ///
    /// ```text
    /// linear elastic:  V · ½ σ : C⁻¹ σ
    /// neo-Hookean:     V₀ W(F),  V₀ = V / det F
    /// plastic:         V₀ W(ε_e),  ε_e the elastic log strain of the Kirchhoff stress τ = J σ
    /// ```
    ///
    /// (for a plastic model `ε_e` as [`Cone::strain_of_stress`] has it, without out-of-plane
    /// elastic strain in plane strain: a particle's [`PlasticState`] has the exact one).
    pub fn strain_energy(&self, volume: f64, sigma: [f64; 3], f: [f64; 4]) -> f64 {
        match self.prepared() {
            Prepared::Plastic(cone) => {
                let j = f[0] * f[3] - f[1] * f[2];
                let [xx, yy, xy, zz] = cone.strain_of_stress(sigma.map(|s| s * j));
                let (values, _) = hencky::principal([xx, yy, xy]);
                volume / j * cone.energy_density([values[0], values[1], zz])
            }
            Prepared::Linear(hooke) => volume * hooke.energy_density(sigma),
            Prepared::NeoHookean(lame) => {
                let at = lame.at(f);
                volume * at.inv_j * at.energy_density
            }
        }
    }
}

#[cfg(test)]
mod tests;
