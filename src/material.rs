//! Constitutive models.

use crate::error::{MpmError, Result};
use crate::transfer::StrainRate;

/// Which 2D idealisation a material uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlaneCondition {
    /// Thin body, `σzz = 0` (the seed's choice).
    #[default]
    Stress,
    /// Long body, `εzz = 0`.
    Strain,
}

/// Isotropic linear elasticity in rate form on the small-strain increment `Δε = ε̇ Δt`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearElastic {
    /// Young's modulus `E` (> 0).
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν` (−1 < ν < ½).
    pub poisson_ratio: f64,
    /// Plane stress or plane strain.
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
