//! A single material point (notes B3; Bardenhagen 2002, Buzzi et al. 2008): one bilinear cell
//! `[0, L]²`, its left nodes fixed, rollers everywhere, one particle at the cell's centre.
//!
//! ```text
//! ω = √(E/ρ)/L,   v(t) = v₀ cos(ω t),   x(t) = x₀ exp((v₀/(L ω)) sin(ω t))
//! ```
//!
//! (the exponential form holds for strain rates in the updated configuration, which the
//! library's rate-form elasticity uses). Parameters: L = 1, x₀ = L/2, M = V = 1, E = 4π², ρ = 1,
//! v₀ = 0.1, Δt = 0.001, to t = 2. Bilinear shape functions whatever the choices say (the
//! problem is defined on one bilinear cell), and a fixed step (the Courant number is not used).
//! With one particle the consistent mass of the two free nodes is singular: use the lumped mass.
//!
//! Metrics: `velocity_error` (`max_t |v − v_exact| / v₀`), `position_error`
//! (`max_t |x − x_exact|` over the displacement amplitude `x₀ (e^{v₀/(Lω)} − 1)`),
//! `energy_drift`. Histories: `velocity`, `velocity_exact`, `position`, `position_exact`.

use std::f64::consts::PI;
use std::time::Instant;

use super::{energy_drift, Choices, History, Outcome};
use sparse_mpm::boundary::{BoundaryCondition, Condition};
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::particles::Particles;
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep};

/// Cell size `L`.
pub const LENGTH: f64 = 1.0;
/// The published initial velocity `v₀`.
pub const V0: f64 = 0.1;
/// Young's modulus `E = 4π²` (so that `ω = 2π`).
pub const YOUNGS_MODULUS: f64 = 4.0 * PI * PI;
/// Time step.
pub const DT: f64 = 1e-3;
/// End time.
pub const END: f64 = 2.0;

/// `ω = √(E/ρ)/L` (ρ = 1).
pub fn omega() -> f64 {
    YOUNGS_MODULUS.sqrt() / LENGTH
}

/// The exact velocity `v₀ cos(ω t)`.
pub fn velocity_exact(v0: f64, t: f64) -> f64 {
    v0 * (omega() * t).cos()
}

/// The exact position `x₀ exp((v₀/(L ω)) sin(ω t))`.
pub fn position_exact(v0: f64, t: f64) -> f64 {
    0.5 * LENGTH * (v0 / (LENGTH * omega()) * (omega() * t).sin()).exp()
}

/// Runs the single point with initial velocity `v0` to t = 2 with the transfer, update scheme
/// and masses of `choices`. The exact solution takes the particle's volume as constant; the
/// library updates it with the strain rate, by a fraction `v₀/(Lω)` of itself (1.6% at the
/// published `v₀`), which is the size of the errors at that amplitude.
///
/// # Errors
/// Those of [`Simulation::new`] and [`Simulation::step`].
pub fn run(v0: f64, choices: &Choices) -> Result<Outcome> {
    run_with_step(v0, DT, choices)
}

/// [`run`] with the fixed time step `dt` instead of [`DT`]: the time integrator's order is
/// read off a sequence of steps (the errors of a small `v0`, where the volume change is
/// negligible, against `dt`).
///
/// # Errors
/// Those of [`Simulation::new`] (a `dt` that is not positive and finite among them) and
/// [`Simulation::step`].
pub fn run_with_step(v0: f64, dt: f64, choices: &Choices) -> Result<Outcome> {
    let grid = Grid::new([0.0, 0.0], [LENGTH, LENGTH], [1, 1])?;
    let particles = Particles::new(vec![0.5 * LENGTH], vec![0.5 * LENGTH], vec![1.0], vec![1.0])?
        .with_velocity(vec![v0], vec![0.0])?;
    let left = vec![grid.node_index(0, 0), grid.node_index(0, 1)];
    let options = Options {
        shape: ShapeFunction::Linear,
        update: choices.update,
        transfer: choices.transfer,
        mass: choices.mass,
        time_step: TimeStep::Fixed { dt },
        boundaries: vec![
            BoundaryCondition::nodes((0..grid.num_nodes()).collect(), Condition::Velocity)
                .with_velocity(None, Some(0.0)),
            BoundaryCondition::nodes(left, Condition::Fixed),
        ],
        sort_interval: 0,
        ..Options::default()
    };
    let material = Material::LinearElastic(LinearElastic::new(YOUNGS_MODULUS, 0.0, PlaneCondition::Stress)?);
    let bodies = vec![Body {
        name: "point".into(),
        material,
    }];
    let mut sim = Simulation::new(grid, particles, bodies, options)?;
    let mut h = [
        "velocity",
        "velocity_exact",
        "position",
        "position_exact",
        "total_energy",
    ]
    .map(History::new);
    let e0 = sim.particles().kinetic_energy();
    for (k, v) in [v0, v0, 0.5 * LENGTH, 0.5 * LENGTH, e0].into_iter().enumerate() {
        h[k].push(0.0, v);
    }
    let clock = Instant::now();
    sim.run_until(END, |s, r| {
        let p = s.particles();
        let values = [
            p.vx[0],
            velocity_exact(v0, r.time),
            p.x[0],
            position_exact(v0, r.time),
            r.total_energy,
        ];
        for (k, v) in values.into_iter().enumerate() {
            h[k].push(r.time, v);
        }
        Ok(())
    })?;
    let seconds = clock.elapsed().as_secs_f64();
    let max_diff = |a: &History, b: &History| {
        a.value
            .iter()
            .zip(&b.value)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    };
    let amplitude = 0.5 * LENGTH * ((v0 / (LENGTH * omega())).exp() - 1.0);
    let metrics = vec![
        ("velocity_error".to_string(), max_diff(&h[0], &h[1]) / v0),
        ("position_error".to_string(), max_diff(&h[2], &h[3]) / amplitude),
        ("energy_drift".to_string(), energy_drift(&h[4])),
    ];
    Ok(Outcome {
        problem: "single_point".to_string(),
        cells: 1,
        cell_size: LENGTH,
        metrics,
        histories: h.into_iter().collect(),
        steps: sim.steps(),
        seconds,
    })
}
