//! A body's initial stress: `bodies[k].initial_stress`, the geostatic stress of a body at rest
//! under gravity.
//!
//! ```text
//! σ_v = −ρ |g| d,   σ_h = K₀ σ_v,   σ = σ_v ĝ⊗ĝ + σ_h (I − ĝ⊗ĝ)
//! ```
//!
//! with `d` the depth of a particle below the body's top along the gravity `g` (of
//! `loads.gravity` and the body's `body_force`, `ĝ = g/|g|`), compression negative, and
//! `K₀ = ν/(1 − ν)` (the lateral stress of a laterally confined elastic body) unless given.
//! The top is the highest point of the body's rectangle or disk against gravity, or its highest
//! particle for a particle file. The stress is added to a particle file's `sxx`, `syy`, `sxy`.
//! Elastoplastic bodies start with the elastic strain of this stress (plane strain: no
//! out-of-plane elastic strain); a state outside the yield surface is returned onto it in the
//! first step.
//!
//! ```toml
//! initial_stress = "geostatic"                   # K₀ = ν/(1 − ν)
//! initial_stress = { geostatic = { k0 = 0.5 } }
//! ```

use serde::{Deserialize, Serialize};

use super::{invalid, BodySpec};
use crate::error::Result;
use crate::material::Material;
use crate::particles::Particles;

/// A body's initial stress ([module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Written", into = "Written")]
pub enum InitialStress {
    /// The geostatic stress, with `K₀` (`None`: `ν/(1 − ν)` of the material).
    Geostatic {
        /// The lateral earth pressure coefficient `K₀ = σ_h / σ_v`.
        k0: Option<f64>,
    },
}

/// The written forms: `"geostatic"` or `{ geostatic = { k0 = … } }`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(untagged)]
enum Written {
    Name(String),
    Table(Table),
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Table {
    geostatic: Coefficients,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Coefficients {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    k0: Option<f64>,
}

impl TryFrom<Written> for InitialStress {
    type Error = String;
    fn try_from(w: Written) -> std::result::Result<Self, String> {
        match w {
            Written::Name(name) if name == "geostatic" => Ok(InitialStress::Geostatic { k0: None }),
            Written::Name(name) => Err(format!(
                "unknown initial stress `{name}`: the one known is \"geostatic\" (or {{ geostatic = {{ k0 = … }} }})"
            )),
            Written::Table(t) => Ok(InitialStress::Geostatic { k0: t.geostatic.k0 }),
        }
    }
}

impl From<InitialStress> for Written {
    fn from(s: InitialStress) -> Written {
        match s {
            InitialStress::Geostatic { k0: None } => Written::Name("geostatic".into()),
            InitialStress::Geostatic { k0 } => Written::Table(Table {
                geostatic: Coefficients { k0 },
            }),
        }
    }
}

/// The Young's modulus and Poisson's ratio of a material.
fn elastic_constants(m: &Material) -> (f64, f64) {
    match m {
        Material::LinearElastic(m) => (m.youngs_modulus, m.poisson_ratio),
        Material::NeoHookean(m) => (m.youngs_modulus, m.poisson_ratio),
        Material::VonMises(m) => (m.youngs_modulus, m.poisson_ratio),
        Material::DruckerPrager(m) => (m.youngs_modulus, m.poisson_ratio),
    }
}

/// Adds `body`'s initial stress to its particles `p` where `select` holds, under the
/// acceleration `g` (gravity and the body force); errors at `at.initial_stress`.
///
/// # Errors
/// [`crate::error::MpmError::InvalidScene`] at `bodies[k].initial_stress` for a neo-Hookean
/// body (its stress is a function of `F`), a body without gravity, a `k0` that is not a
/// finite non-negative number, or a stress at the body's base beyond its Young's modulus.
pub(super) fn apply(at: &str, body: &BodySpec, g: [f64; 2], p: &mut Particles, select: &[bool]) -> Result<()> {
    let Some(InitialStress::Geostatic { k0 }) = body.initial_stress else {
        return Ok(());
    };
    let key = format!("{at}.initial_stress");
    if matches!(body.material, Material::NeoHookean(_)) {
        return Err(invalid(
            key,
            "a neo-Hookean stress is a function of the deformation gradient and cannot be set: \
             use linear_elastic, von_mises or drucker_prager",
        ));
    }
    let magnitude = g[0].hypot(g[1]);
    if magnitude.is_nan() || magnitude <= 0.0 {
        return Err(invalid(
            key,
            "the geostatic stress needs gravity (loads.gravity or the body's body_force)",
        ));
    }
    let (youngs_modulus, nu) = elastic_constants(&body.material);
    let k0 = k0.unwrap_or(nu / (1.0 - nu));
    if !(k0.is_finite() && k0 >= 0.0) {
        return Err(invalid(
            format!("{key}.geostatic.k0"),
            format!("{k0} is not a finite non-negative number"),
        ));
    }
    let u = [g[0] / magnitude, g[1] / magnitude];
    // Height against gravity: h = −ĝ · x; the top is the largest.
    let height = |x: f64, y: f64| -(u[0] * x + u[1] * y);
    let top = body
        .geometry
        .highest([-u[0], -u[1]])
        .unwrap_or_else(|| (0..p.len()).map(|i| height(p.x[i], p.y[i])).fold(f64::MIN, f64::max));
    // The deepest particle's vertical stress, against the material's stiffness: beyond E the
    // elastic strain that carries it exceeds 1 (a body crushed to a third of its height).
    let deepest = (0..p.len())
        .filter(|&i| select[i])
        .map(|i| (p.mass[i] / p.volume[i]) * magnitude * (top - height(p.x[i], p.y[i])).max(0.0))
        .fold(0.0, f64::max);
    if deepest.max(k0 * deepest) > youngs_modulus {
        return Err(invalid(
            key,
            format!(
                "the geostatic stress reaches {deepest:.4e} (ρ |g| × depth) at the body's base, more than its \
                 Young's modulus {youngs_modulus:.4e}: no elastic state carries it (a smaller density or gravity, \
                 a stiffer material, or no initial stress)"
            ),
        ));
    }
    for i in (0..p.len()).filter(|&i| select[i]) {
        let depth = (top - height(p.x[i], p.y[i])).max(0.0);
        let rho = p.mass[i] / p.volume[i];
        let sv = -rho * magnitude * depth;
        let sh = k0 * sv;
        // σ = σ_v ĝĝᵀ + σ_h (I − ĝĝᵀ).
        p.sxx[i] += sh + (sv - sh) * u[0] * u[0];
        p.syy[i] += sh + (sv - sh) * u[1] * u[1];
        p.sxy[i] += (sv - sh) * u[0] * u[1];
    }
    Ok(())
}
