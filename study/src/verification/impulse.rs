//! The impulse-loaded bar: a bar fixed at `x = 0`, at rest and unstressed, pushed at its free end
//! `x = L` by a pressure pulse of duration `T`, against the closed form of d'Alembert's solution
//! with images. A strip one cell high with rollers on every node (a 1D bar, ν = 0, plane stress),
//! as in [`super::wave`].
//!
//! ```text
//! σ(L, t) = −p(t),   p(t) = p₀ sin²(π t / T) on 0 ≤ t ≤ T, 0 after;   u(0, t) = 0
//!
//! u(x, t) = 1/(ρc) Σ_{n≥0} (−1)ⁿ [ G(t − ((2n+1)L + x)/c) − G(t − ((2n+1)L − x)/c) ]
//! G(s) = ∫₀ˢ p = p₀ (s/2 − T/(4π) sin(2π s/T)) on 0 ≤ s ≤ T, 0 before, G(T) = p₀T/2 after
//! ```
//!
//! The pulse runs to the fixed end (where it reflects with the same stress), back to the loaded
//! end (where it reflects with the opposite stress), and so on; the run lasts `4L/c`, two round
//! trips. Displacements are measured in units of the incident pulse's `U = G(T)/(ρc)`.
//!
//! The traction is applied as a body force on the particles whose domains touch the end face,
//! `b_p = −p(t) A_p / m_p` (`A_p` the particle's share of the face), evaluated at the middle of
//! the step (from the previous step's length). This is how an MPM code loads a free surface, and
//! it puts the load half a particle spacing inside the bar: the error it adds falls as `h`.
//!
//! Metrics of [`ImpulseBar::run`] (over `U`): `displacement_error` (the largest over time of the
//! volume RMS of `u_p − u(X_p, t)`), `end_error` (the largest `|u − u_exact|` over time of the
//! particles at the loaded end), `fixed_end_stress` (the largest compressive stress of the
//! particles next to the fixed end over `2 p₀`: 1 in the exact solution, where the reflected
//! pulse doubles the stress), `energy_error` (the total energy at the end against the work of
//! the load, relative). Histories: `end_displacement`, `end_displacement_exact` (over `U`,
//! against time).

use std::f64::consts::PI;
use std::time::Instant;

use super::{Choices, History, Outcome};
use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge};
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::particles::{lattice, Particles};
use sparse_mpm::simulation::{Body, Simulation};

/// The impulse-loaded bar's parameters (defaults: L = 1, E = ρ = 1, T = L/(2c), p₀ = 4·10⁻⁴).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpulseBar {
    /// Length `L` of the bar.
    pub length: f64,
    /// Young's modulus `E`.
    pub youngs_modulus: f64,
    /// Density `ρ`.
    pub density: f64,
    /// Peak pressure `p₀` (small: the end moves `p₀T/(2ρc)`, a fraction of a cell).
    pub pressure: f64,
    /// Duration `T` of the pulse.
    pub duration: f64,
}

impl Default for ImpulseBar {
    fn default() -> Self {
        ImpulseBar {
            length: 1.0,
            youngs_modulus: 1.0,
            density: 1.0,
            pressure: 4e-4,
            duration: 0.5,
        }
    }
}

impl ImpulseBar {
    /// `"impulse_bar"`.
    pub fn name(&self) -> &'static str {
        "impulse_bar"
    }

    /// Wave speed `c = √(E/ρ)`.
    pub fn wave_speed(&self) -> f64 {
        (self.youngs_modulus / self.density).sqrt()
    }

    /// The end time `4L/c`: two round trips of the pulse.
    pub fn end_time(&self) -> f64 {
        4.0 * self.length / self.wave_speed()
    }

    /// The load `p(t) = p₀ sin²(π t/T)` on `0 ≤ t ≤ T`, zero otherwise.
    pub fn pressure_at(&self, t: f64) -> f64 {
        if (0.0..=self.duration).contains(&t) {
            self.pressure * (PI * t / self.duration).sin().powi(2)
        } else {
            0.0
        }
    }

    /// The impulse delivered by time `s`: `G(s) = ∫₀ˢ p = p₀ (s/2 − T/(4π) sin(2π s/T))`.
    pub fn impulse(&self, s: f64) -> f64 {
        let t = self.duration;
        let s = s.clamp(0.0, t);
        self.pressure * (0.5 * s - t / (4.0 * PI) * (2.0 * PI * s / t).sin())
    }

    /// The incident pulse's displacement `U = G(T)/(ρc)`, the unit of the metrics.
    pub fn unit(&self) -> f64 {
        self.impulse(self.duration) / (self.density * self.wave_speed())
    }

    /// The exact displacement `u(x, t)` (module docs): the image sum over the reflections that
    /// have reached `x` by `t`.
    pub fn displacement(&self, x: f64, t: f64) -> f64 {
        let (c, l) = (self.wave_speed(), self.length);
        let mut u = 0.0;
        let mut sign = 1.0;
        let mut n = 0.0;
        // Terms whose argument is negative vanish: stop at the first reflection not yet arrived.
        while t - ((2.0 * n + 1.0) * l - x) / c > 0.0 {
            u += sign
                * (self.impulse(t - ((2.0 * n + 1.0) * l + x) / c) - self.impulse(t - ((2.0 * n + 1.0) * l - x) / c));
            sign = -sign;
            n += 1.0;
        }
        u / (self.density * c)
    }

    /// The bar on `cells` cells along its length with `choices`, at rest: the grid padded by
    /// the kernel's recommended cells (and one more beyond the loaded end), the fixed end's wall
    /// on the node line `x = 0` (mirrored for GIMP and B-splines), rollers everywhere.
    ///
    /// # Errors
    /// Those of [`Simulation::new`].
    pub fn simulation(&self, cells: usize, choices: &Choices) -> Result<Simulation> {
        let h = self.length / cells as f64;
        let pad = choices.shape.recommended_padding();
        let grid = Grid::new(
            [-(pad as f64) * h, -(pad as f64) * h],
            [h, h],
            [cells + 2 * pad + 1, 1 + 2 * pad],
        )?;
        let (x, y, volume) = lattice(&grid, choices.particles_per_cell, |px, py| {
            px > 0.0 && px < self.length && py > 0.0 && py < h
        });
        let n = x.len();
        let particles = Particles::new(x, y, vec![self.density * volume; n], vec![volume; n])?;
        let boundaries = vec![
            BoundaryCondition::nodes((0..grid.num_nodes()).collect(), Condition::Velocity)
                .with_velocity(None, Some(0.0)),
            BoundaryCondition::edge(Edge::Left, Condition::Fixed).with_layers(pad + 1),
        ];
        let material = Material::LinearElastic(LinearElastic::new(self.youngs_modulus, 0.0, PlaneCondition::Stress)?);
        let bodies = vec![Body {
            name: "bar".into(),
            material,
        }];
        Simulation::new(grid, particles, bodies, choices.options(boundaries))
    }

    /// Runs the bar to [`ImpulseBar::end_time`] and compares it with the closed form (module
    /// docs).
    ///
    /// # Errors
    /// Those of [`ImpulseBar::simulation`] and [`Simulation::step`].
    pub fn run(&self, cells: usize, choices: &Choices) -> Result<Outcome> {
        let mut sim = self.simulation(cells, choices)?;
        let h = self.length / cells as f64;
        let spacing = h / choices.particles_per_cell as f64;
        let p = sim.particles();
        // Reference positions by permanent id, the loaded and the fixed-end particles.
        let mut reference = vec![0.0; p.len()];
        for k in 0..p.len() {
            reference[p.id[k]] = p.x[k];
        }
        let loaded: Vec<bool> = reference.iter().map(|&x| x > self.length - spacing).collect();
        let fixed: Vec<bool> = reference.iter().map(|&x| x < spacing).collect();
        // The face share per unit mass of a loaded particle: A_p / m_p = 1/(ρ · spacing).
        let per_mass = 1.0 / (self.density * spacing);
        let unit = self.unit();
        let (mut worst, mut end_error, mut fixed_stress) = (0.0f64, 0.0f64, 0.0f64);
        let mut end = History::new("end_displacement");
        let mut end_exact = History::new("end_displacement_exact");
        let (mut work, mut last_dt, mut energy) = (0.0, 0.0, 0.0);
        let t_end = self.end_time();
        let clock = Instant::now();
        while sim.time() < t_end * (1.0 - 1e-12) {
            let t_mid = sim.time() + 0.5 * last_dt;
            let b = -self.pressure_at(t_mid) * per_mass;
            sim.set_body_force(|id, _| [if loaded[id] { b } else { 0.0 }, 0.0]);
            let x_before: f64 = end_position(&sim, &loaded);
            let report = sim.step_capped(t_end - sim.time())?;
            // Work of the load: force on the face times the end's displacement in the step.
            let face = sim.grid().cell_size()[1];
            work += self.pressure_at(t_mid) * face * -(end_position(&sim, &loaded) - x_before);
            last_dt = report.dt;
            energy = report.total_energy;
            let (t, p) = (sim.time(), sim.particles());
            let (mut sq, mut vol) = (0.0, 0.0);
            let (mut u_end, mut u_end_exact, mut count) = (0.0, 0.0, 0.0);
            for k in 0..p.len() {
                let x0 = reference[p.id[k]];
                let (u, exact) = (p.x[k] - x0, self.displacement(x0, t));
                sq += p.volume[k] * (u - exact).powi(2);
                vol += p.volume[k];
                if loaded[p.id[k]] {
                    end_error = end_error.max((u - exact).abs() / unit);
                    u_end += u / unit;
                    u_end_exact += exact / unit;
                    count += 1.0;
                }
                if fixed[p.id[k]] {
                    fixed_stress = fixed_stress.max(-p.sxx[k] / (2.0 * self.pressure));
                }
            }
            worst = worst.max((sq / vol).sqrt() / unit);
            end.push(t, u_end / count);
            end_exact.push(t, u_end_exact / count);
        }
        let seconds = clock.elapsed().as_secs_f64();
        Ok(Outcome {
            problem: self.name().to_string(),
            cells,
            cell_size: h,
            metrics: vec![
                ("displacement_error".to_string(), worst),
                ("end_error".to_string(), end_error),
                ("fixed_end_stress".to_string(), fixed_stress),
                ("energy_error".to_string(), (energy - work) / work),
            ],
            histories: vec![end, end_exact],
            steps: sim.steps(),
            seconds,
        })
    }
}

/// The summed x position of the loaded particles (one cell high, so their mean times their
/// count); the load's work is the face force times its change.
fn end_position(sim: &Simulation, loaded: &[bool]) -> f64 {
    let p = sim.particles();
    let (sum, count) = (0..p.len())
        .filter(|&k| loaded[p.id[k]])
        .fold((0.0, 0.0), |(s, c), k| (s + p.x[k], c + 1.0));
    sum / count
}
