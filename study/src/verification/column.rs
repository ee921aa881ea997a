//! The elastic column under its own weight: the classic test of the cell-crossing error
//! (Bardenhagen & Kober 2004; Steffen, Kirby & Berzins 2008; Wallstedt & Guilkey 2008). A column
//! of height `l0` and width `w`, density `ρ₀`, Poisson ratio 0, its base held vertically and its
//! sides on rollers, loaded by gravity `g` in increments. With `ν = 0` and the sides held the
//! lateral stretch is 1, the Cauchy and first Piola–Kirchhoff components `σ_yy` and `P_yy` are
//! equal, and equilibrium in the reference configuration gives, at any deformation and for any
//! material,
//!
//! ```text
//! σ_yy(Y) = −ρ₀ g (l0 − Y)          Y the particle's initial height above the base
//! ```
//!
//! Error (notes: the reference codes' measure), with `V_p⁰` the initial volumes:
//!
//! ```text
//! e = Σ_p |σ_yy,p − σ_yy(Y_p)| V_p⁰ / Σ_p ρ₀ g l0 V_p⁰
//! ```
//!
//! The grid is padded by the kernel's recommended cells on every side but the top (a few
//! cells above the column): the base is a fixed wall (mirrored for GIMP and the B-splines; the
//! exact horizontal displacement is zero, so fixed and roller bases are the same here), the
//! sides are slip walls. Neo-Hookean with `λ = 0` (`ν = 0`), which is linear elasticity at
//! small strain.
//!
//! Metrics of [`Column::run`]: `stress_error` (`e` above), `newton_iterations` (the most in
//! one increment), `final_height` (over `l0`, the highest particle's initial height mapped to its
//! final one), `kinetic_energy` (at the end, over `ρ₀ g l0` times the mass: 0 quasi-static).

use std::time::Instant;

use super::{Choices, Outcome};
use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge};
use sparse_mpm::damping::Damping;
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{Material, NeoHookean};
use sparse_mpm::particles::{lattice_within, Particles};
use sparse_mpm::simulation::{Body, Integrator, Options, QuasiStatic, Simulation, TimeStep};

/// The column's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Column {
    /// Young's modulus `E`.
    pub youngs_modulus: f64,
    /// Reference density `ρ₀`.
    pub density: f64,
    /// Gravity `g` (downward).
    pub gravity: f64,
    /// Initial height `l0`.
    pub height: f64,
    /// Cells across the column.
    pub cells_wide: usize,
    /// Load increments of the quasi-static run.
    pub load_steps: usize,
}

impl Column {
    /// Small strain: `E = 1 MPa`, `ρ₀ = 80`, `g = 10`, `l0 = 50` (`ρ₀ g l0 / E = 0.04`), one
    /// cell wide, 20 load increments.
    pub const SMALL_STRAIN: Column = Column {
        youngs_modulus: 1.0e6,
        density: 80.0,
        gravity: 10.0,
        height: 50.0,
        cells_wide: 1,
        load_steps: 20,
    };

    /// Large strain: [`Column::SMALL_STRAIN`] with `E = 10 kPa` (`ρ₀ g l0 / E = 4`: the column
    /// ends under half its height).
    pub const LARGE_STRAIN: Column = Column {
        youngs_modulus: 1.0e4,
        ..Column::SMALL_STRAIN
    };

    /// The period of the column's first mode at small strain, `4 l0 / c` with `c = √(E/ρ₀)`.
    pub fn period(&self) -> f64 {
        4.0 * self.height / (self.youngs_modulus / self.density).sqrt()
    }

    /// `σ_yy(Y) = −ρ₀ g (l0 − Y)`.
    pub fn stress_exact(&self, y: f64) -> f64 {
        -self.density * self.gravity * (self.height - y)
    }

    /// The quasi-static column with `cells_high` cells along its height, the kernel and
    /// particles per cell of `choices` (their mass schemes do not enter).
    ///
    /// # Errors
    /// Those of [`Simulation::new`].
    pub fn simulation(&self, cells_high: usize, choices: &Choices) -> Result<Simulation> {
        let h = self.height / cells_high as f64;
        let shape = choices.shape;
        let pad = shape.recommended_padding();
        let width = self.cells_wide as f64 * h;
        // Room above the column for nothing to leave the grid (it only shortens).
        let above = pad + 2;
        let grid = Grid::new(
            [-(pad as f64) * h, -(pad as f64) * h],
            [h, h],
            [self.cells_wide + 2 * pad, cells_high + pad + above],
        )?;
        let inside = |x: f64, y: f64| (0.0..width).contains(&x) && (0.0..self.height).contains(&y);
        let bounds = Some([[0.0, 0.0], [width, self.height]]);
        let (x, y, volume) = lattice_within(&grid, choices.particles_per_cell, bounds, inside);
        let n = x.len();
        let particles = Particles::new(x, y, vec![self.density * volume; n], vec![volume; n])?;
        let wall = |edge, condition| BoundaryCondition::edge(edge, condition);
        let options = Options {
            shape,
            mass: choices.mass,
            transfer: choices.transfer,
            gravity: [0.0, -self.gravity],
            time_step: TimeStep::Fixed {
                dt: 1.0 / self.load_steps as f64,
            },
            integrator: Integrator::QuasiStatic(QuasiStatic {
                load_steps: self.load_steps,
                ..QuasiStatic::default()
            }),
            boundaries: vec![
                wall(Edge::Bottom, Condition::Fixed),
                wall(Edge::Left, Condition::Slip),
                wall(Edge::Right, Condition::Slip),
            ],
            ..Options::default()
        };
        let material = Material::NeoHookean(NeoHookean {
            youngs_modulus: self.youngs_modulus,
            poisson_ratio: 0.0,
        });
        let body = Body {
            name: "column".into(),
            material,
        };
        Simulation::new(grid, particles, vec![body], options)
    }

    /// `e` of the [module docs](self) for the particles of `sim`, whose initial heights by id
    /// are `initial` ([`initial_heights`]).
    pub fn stress_error(&self, sim: &Simulation, initial: &[f64]) -> f64 {
        let p = sim.particles();
        let (mut error, mut scale) = (0.0, 0.0);
        for k in 0..p.len() {
            let v0 = p.mass[k] / self.density;
            error += (p.syy[k] - self.stress_exact(initial[p.id[k]])).abs() * v0;
            scale += self.density * self.gravity * self.height * v0;
        }
        error / scale
    }

    /// The column run explicitly under its weight, applied over `ramp` (`None`: at once), with
    /// `damping` (dynamic relaxation) at the Courant number and masses of `choices`, until the
    /// run reports itself settled after the ramp or `max_time` has passed: the simulation at its
    /// end and the metrics of [`Column::run`] (and `time`, when it settled or stopped).
    ///
    /// # Errors
    /// Those of [`Column::simulation`], [`Simulation::set_integrator`] and [`Simulation::step`].
    pub fn relax(
        &self,
        cells_high: usize,
        choices: &Choices,
        damping: Damping,
        ramp: Option<f64>,
        max_time: f64,
    ) -> Result<(Simulation, Outcome)> {
        let mut options = self.simulation(cells_high, choices)?.options().clone();
        options.integrator = Integrator::Explicit;
        options.time_step = TimeStep::Cfl { number: choices.cfl };
        options.update = choices.update;
        options.damping = Some(damping);
        options.gravity_ramp = ramp;
        let quasi_static = self.simulation(cells_high, choices)?;
        let mut sim = Simulation::new(
            quasi_static.grid().clone(),
            quasi_static.particles().clone(),
            quasi_static.bodies().to_vec(),
            options,
        )?;
        let initial = initial_heights(sim.particles());
        let started = Instant::now();
        while sim.time() < max_time {
            if sim.step()?.settled && sim.time() > ramp.unwrap_or(0.0) {
                break;
            }
        }
        let seconds = started.elapsed().as_secs_f64();
        let p = sim.particles();
        let weight = self.density * self.gravity * self.height * p.total_mass();
        let outcome = Outcome {
            problem: "column_relaxed".into(),
            cells: cells_high,
            cell_size: self.height / cells_high as f64,
            metrics: vec![
                ("stress_error".into(), self.stress_error(&sim, &initial)),
                ("time".into(), sim.time()),
                ("kinetic_energy".into(), p.kinetic_energy() / weight),
            ],
            histories: Vec::new(),
            steps: sim.steps(),
            seconds,
        };
        Ok((sim, outcome))
    }

    /// Runs the quasi-static column to the full load ([module docs](self) for the metrics).
    ///
    /// # Errors
    /// Those of [`Column::simulation`] and [`Simulation::step`].
    pub fn run(&self, cells_high: usize, choices: &Choices) -> Result<Outcome> {
        let mut sim = self.simulation(cells_high, choices)?;
        let initial = initial_heights(sim.particles());
        let started = Instant::now();
        let mut iterations = 0usize;
        for _ in 0..self.load_steps {
            let report = sim.step()?;
            iterations = iterations.max(report.acceleration_solve.iterations);
        }
        let seconds = started.elapsed().as_secs_f64();
        let p = sim.particles();
        let top = (0..p.len()).max_by(|&a, &b| initial[p.id[a]].total_cmp(&initial[p.id[b]]));
        let final_height = top.map_or(f64::NAN, |k| p.y[k] / initial[p.id[k]]);
        let weight = self.density * self.gravity * self.height * p.total_mass();
        Ok(Outcome {
            problem: "column".into(),
            cells: cells_high,
            cell_size: self.height / cells_high as f64,
            metrics: vec![
                ("stress_error".into(), self.stress_error(&sim, &initial)),
                ("newton_iterations".into(), iterations as f64),
                ("final_height".into(), final_height),
                ("kinetic_energy".into(), p.kinetic_energy() / weight),
            ],
            histories: Vec::new(),
            steps: sim.steps(),
            seconds,
        })
    }
}

/// Each particle's height by id (the heights of `particles`, which may be sorted).
pub fn initial_heights(particles: &Particles) -> Vec<f64> {
    let mut heights = vec![f64::NAN; particles.id.iter().max().map_or(0, |m| m + 1)];
    for (k, &id) in particles.id.iter().enumerate() {
        heights[id] = particles.y[k];
    }
    heights
}
