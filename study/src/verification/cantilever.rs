//! The cantilever under gravity (notes B9): the shipped scene `scenes/cantilever.toml`, a 4 × 1
//! neo-Hookean beam (E = 1e7, ν = 0.3, ρ = 1050, g = 10) clamped at `x = 0`, released under its
//! weight, to t = 1.5. No closed form (small-deflection beam theory gives a static tip deflection
//! of about 0.40, twice that at the first swing): a refinement study with its extrapolated value.
//!
//! Metrics of [`run`]: `tip_deflection` (the largest downward displacement of the particle
//! nearest the middle of the free end over the run), `energy_drift`. [`extrapolate`] turns three
//! resolutions into the Richardson extrapolation and the observed order.

use std::time::Instant;

use super::{energy_drift, Choices, History, Outcome};
use sparse_mpm::error::Result;
use sparse_mpm::scene::Scene;

/// The shipped scene.
pub const SCENE: &str = include_str!("../../../scenes/cantilever.toml");

/// Length of the beam.
pub const LENGTH: f64 = 4.0;

/// The scene with `cells` cells along the beam (the domain `[0, 5] × [−3, 2]`, padded by the
/// kernel's recommended cells, the clamp on the node lines at and left of `x = 0`).
///
/// # Errors
/// [`sparse_mpm::MpmError::InvalidScene`] if the choices make the scene invalid.
pub fn scene(cells: usize, choices: &Choices) -> Result<Scene> {
    let mut scene = Scene::from_toml_str(SCENE)?;
    let h = LENGTH / cells as f64;
    let pad = choices.shape.recommended_padding();
    let span = (5.0 / h).round() as usize;
    scene.grid.cell_size = [h, h];
    scene.grid.origin = [-(pad as f64) * h, -3.0 - pad as f64 * h];
    scene.grid.cells = [span + 2 * pad; 2];
    choices.apply_to(&mut scene);
    Ok(scene)
}

/// Runs the cantilever and records its tip.
///
/// # Errors
/// Those of [`Scene::build`] and [`sparse_mpm::simulation::Simulation::step`].
pub fn run(cells: usize, choices: &Choices) -> Result<Outcome> {
    let scene = scene(cells, choices)?;
    let mut sim = scene.build()?;
    choices.integrate(&mut sim)?;
    let p = sim.particles();
    let tip_id = (0..p.len())
        .min_by(|&a, &b| {
            let d = |k: usize| (p.x[k] - LENGTH).hypot(p.y[k] - 1.5);
            d(a).total_cmp(&d(b))
        })
        .map(|k| p.id[k])
        .expect("the beam has particles");
    let tip_y = |s: &sparse_mpm::simulation::Simulation| {
        let p = s.particles();
        (0..p.len()).find(|&k| p.id[k] == tip_id).map_or(f64::NAN, |k| p.y[k])
    };
    let y0 = tip_y(&sim);
    let mut h = ["tip_deflection", "total_energy"].map(History::new);
    h[0].push(0.0, 0.0);
    let clock = Instant::now();
    sim.run_until(scene.time.end, |s, r| {
        h[0].push(r.time, y0 - tip_y(s));
        h[1].push(r.time, r.total_energy);
        Ok(())
    })?;
    let seconds = clock.elapsed().as_secs_f64();
    let deflection = h[0].value.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let metrics = vec![
        ("end_time".to_string(), scene.time.end),
        ("tip_deflection".to_string(), deflection),
        ("energy_drift".to_string(), energy_drift(&h[1])),
    ];
    Ok(Outcome {
        problem: "cantilever".to_string(),
        cells,
        cell_size: LENGTH / cells as f64,
        metrics,
        histories: h.into_iter().collect(),
        steps: sim.steps(),
        seconds,
    })
}

/// Richardson extrapolation from values `f₁, f₂, f₃` on cells `h, h/r, h/r²`:
///
/// ```text
/// p = ln((f₁ − f₂)/(f₂ − f₃)) / ln r,   f_∞ = f₃ + (f₃ − f₂)/(r^p − 1)
/// ```
///
/// Returns `(f_∞, p)`, or `None` when the differences do not shrink monotonically.
pub fn extrapolate(f: [f64; 3], r: f64) -> Option<(f64, f64)> {
    let (d1, d2) = (f[0] - f[1], f[1] - f[2]);
    if !(d1 != 0.0 && d2 != 0.0 && d1.signum() == d2.signum() && d2.abs() < d1.abs()) {
        return None;
    }
    let p = (d1 / d2).ln() / r.ln();
    Some((f[2] + (f[2] - f[1]) / (r.powf(p) - 1.0), p))
}

/// The thin beam of tests/thin_cantilever.rs and `examples/thin_beam_statics`: an 8 × 1
/// neo-Hookean beam (E = 10⁹, ν = 0.3, plane strain, ρ = 1050, g = 10) clamped by a fixed left
/// edge on the node line `x = 0` (mirrored with B-splines), on cells `1/cells_thick`, quadratic
/// B-splines, 2 × 2 particles per cell, MUSL, FLIP, `mass` in both solves (a scheme as text:
/// `"lumped"`, `"consistent"` …), Courant number 0.5, to t = 0.6.
pub mod thin_beam {
    use sparse_mpm::error::Result;
    use sparse_mpm::scene::Scene;

    /// Length of the beam (its thickness is 1).
    pub const LENGTH: f64 = 8.0;
    /// Young's modulus.
    pub const YOUNGS_MODULUS: f64 = 1.0e9;
    /// Poisson's ratio.
    pub const POISSON_RATIO: f64 = 0.3;
    /// Density.
    pub const DENSITY: f64 = 1050.0;
    /// Gravity (downwards).
    pub const GRAVITY: f64 = 10.0;

    /// The scene (module docs).
    ///
    /// # Errors
    /// [`sparse_mpm::MpmError::InvalidScene`] for a `mass` that is not a scheme, or `cells_thick = 0`.
    pub fn scene(cells_thick: usize, mass: &str) -> Result<Scene> {
        let h = 1.0 / cells_thick.max(1) as f64;
        let text = format!(
            r#"
[grid]
origin = [{o}, -2.0]
cell_size = [{h}, {h}]
cells = [{nx}, {ny}]

[schemes]
shape = "quadratic_bspline"
update = "musl"
transfer = "flip"
mass = {{ velocity = "{mass}", acceleration = "{mass}" }}

[time]
end = 0.6
cfl = 0.5

[loads]
gravity = [0.0, -{GRAVITY}]

[[bodies]]
name = "beam"
material = {{ model = "neo_hookean", youngs_modulus = {YOUNGS_MODULUS}, poisson_ratio = {POISSON_RATIO} }}
density = {DENSITY}
particles_per_cell = 2
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [{LENGTH}, 1.0] }} }}

[[boundaries]]
edge = "left"
condition = "fixed"
"#,
            o = -h,
            nx = ((LENGTH + 2.0) / h).round() as usize + 1,
            ny = (4.0 / h).round() as usize,
        );
        Scene::from_toml_str(&text)
    }

    /// Euler–Bernoulli under a suddenly applied weight: twice the static tip deflection
    /// `q L⁴ / (8 E' I)`, `q = ρ g t`, `I = t³/12`, `E' = E/(1 − ν²)` (plane strain), `t = 1`.
    pub fn euler_bernoulli_first_swing() -> f64 {
        let (q, i, e) = (
            DENSITY * GRAVITY,
            1.0 / 12.0,
            YOUNGS_MODULUS / (1.0 - POISSON_RATIO * POISSON_RATIO),
        );
        2.0 * q * LENGTH.powi(4) / (8.0 * e * i)
    }
}
