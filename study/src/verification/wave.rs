//! A wave front in a long bar against d'Alembert's solution: a strip one cell high with rollers
//! on every node (a 1D bar, ν = 0, plane stress), free ends, released with a right-going wave.
//!
//! ```text
//! v(x, 0) = v₀ f(x),   σ(x, 0) = −ρ c v₀ f(x)      ⇒   v(x, t) = v₀ f(x − c t),   σ = −ρ c v
//! ```
//!
//! with `f` a step (`f = 1` for `x < x₀`) or a square pulse of width `w` (`f = 1` for
//! `x₀ − w < x < x₀`), `x₀ = L/4`, run until the front has travelled `L/2` (t = L/(2c)). The
//! discrete bar is dispersive (verification::dispersion): the lumped mass's short waves are slow
//! and trail behind the front, the consistent mass's are fast and run ahead of it. The free
//! left end sends a release wave that stays `x₀` behind the front.
//!
//! Metrics of [`Wave::run`] (velocities over `v₀`, positions in cells `h`, which are also times
//! in `h/c`), read on the zone from `x₀/2` behind the rear edge (the front for a step) to the
//! bar's end: `arrival_error` (where the wave is: the step's integral front
//! `x_zone + ∫ v/v₀ dx`, the pulse's centroid `∫ x v dx / ∫ v dx`, minus d'Alembert's; both
//! travel at exactly `c` where momentum is conserved), `front_error` (the crossing of `v₀/2`
//! nearest to the exact front minus the exact front: dispersion moves it by about
//! `(c t / h)^{1/3}` cells, the Airy scaling of a dispersive step), `precursor`
//! (`max |v − v_exact|` more than two cells ahead of the front), `trailing` (the same more
//! than two cells behind the rear edge), `overshoot` (`max v/v₀ − 1`), `stress_error` (volume
//! RMS of `σ − σ_exact` over `ρ c v₀`).
//! Histories (the profile at the end, `time` holding the position `x`): `velocity_profile`,
//! `velocity_exact`.

use std::time::Instant;

use super::{Choices, History, Outcome};
use sparse_mpm::boundary::{BoundaryCondition, Condition};
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::particles::{lattice, Particles};
use sparse_mpm::simulation::{Body, Simulation};

/// The initial wave's shape `f`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Profile {
    /// `f = 1` behind the front (`x < x₀`).
    Step,
    /// `f = 1` on `x₀ − width < x < x₀`.
    Pulse {
        /// Width `w` of the pulse, in units of the bar's length.
        width: f64,
    },
}

/// The wave problem's parameters (defaults: L = 1, E = ρ = 1, v₀ = 10⁻³, a step).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wave {
    /// The initial shape.
    pub profile: Profile,
    /// Length `L` of the bar.
    pub length: f64,
    /// Young's modulus `E`.
    pub youngs_modulus: f64,
    /// Density `ρ`.
    pub density: f64,
    /// Velocity amplitude `v₀` (small: the particles move a fraction of a cell).
    pub amplitude: f64,
}

impl Default for Wave {
    fn default() -> Self {
        Wave {
            profile: Profile::Step,
            length: 1.0,
            youngs_modulus: 1.0,
            density: 1.0,
            amplitude: 1e-3,
        }
    }
}

impl Wave {
    /// A step (`Profile::Step`) with the default parameters.
    pub fn step() -> Wave {
        Wave::default()
    }

    /// A square pulse of width `width · L` with the default parameters.
    pub fn pulse(width: f64) -> Wave {
        Wave {
            profile: Profile::Pulse { width },
            ..Wave::default()
        }
    }

    /// `"wave_step"` or `"wave_pulse"`.
    pub fn name(&self) -> &'static str {
        match self.profile {
            Profile::Step => "wave_step",
            Profile::Pulse { .. } => "wave_pulse",
        }
    }

    /// Wave speed `c = √(E/ρ)`.
    pub fn wave_speed(&self) -> f64 {
        (self.youngs_modulus / self.density).sqrt()
    }

    /// The initial front `x₀ = L/4`.
    pub fn start(&self) -> f64 {
        0.25 * self.length
    }

    /// The end time `L/(2c)`: the front travels half the bar.
    pub fn end_time(&self) -> f64 {
        0.5 * self.length / self.wave_speed()
    }

    /// `f(x − c t)`: the exact velocity over `v₀`.
    pub fn shape(&self, x: f64, t: f64) -> f64 {
        let s = x - self.wave_speed() * t;
        let x0 = self.start();
        let inside = match self.profile {
            Profile::Step => s < x0,
            Profile::Pulse { width } => s < x0 && s > x0 - width * self.length,
        };
        f64::from(u8::from(inside))
    }

    /// The bar on `cells` cells along its length with `choices`, at `t = 0`.
    ///
    /// # Errors
    /// Those of [`Simulation::new`].
    pub fn simulation(&self, cells: usize, choices: &Choices) -> Result<Simulation> {
        let h = self.length / cells as f64;
        let pad = choices.shape.recommended_padding();
        let grid = Grid::new(
            [-(pad as f64) * h, -(pad as f64) * h],
            [h, h],
            [cells + 2 * pad, 1 + 2 * pad],
        )?;
        let (x, y, volume) = lattice(&grid, choices.particles_per_cell, |px, py| {
            px > 0.0 && px < self.length && py > 0.0 && py < h
        });
        let n = x.len();
        let v: Vec<f64> = x.iter().map(|&px| self.amplitude * self.shape(px, 0.0)).collect();
        let impedance = self.density * self.wave_speed();
        let sxx: Vec<f64> = v.iter().map(|&vx| -impedance * vx).collect();
        let particles = Particles::new(x, y, vec![self.density * volume; n], vec![volume; n])?
            .with_velocity(v, vec![0.0; n])?
            .with_stress(sxx, vec![0.0; n], vec![0.0; n])?;
        let boundaries = vec![
            BoundaryCondition::nodes((0..grid.num_nodes()).collect(), Condition::Velocity)
                .with_velocity(None, Some(0.0)),
        ];
        let material = Material::LinearElastic(LinearElastic::new(self.youngs_modulus, 0.0, PlaneCondition::Stress)?);
        let bodies = vec![Body {
            name: "bar".into(),
            material,
        }];
        Simulation::new(grid, particles, bodies, choices.options(boundaries))
    }

    /// Runs the wave to [`Wave::end_time`] and measures the front (module docs).
    ///
    /// # Errors
    /// Those of [`Wave::simulation`] and [`Simulation::step`].
    pub fn run(&self, cells: usize, choices: &Choices) -> Result<Outcome> {
        let mut sim = self.simulation(cells, choices)?;
        let h = self.length / cells as f64;
        let clock = Instant::now();
        let t_end = self.end_time();
        sim.run_until(t_end, |_, _| Ok(()))?;
        let seconds = clock.elapsed().as_secs_f64();
        let p = sim.particles();
        let t = sim.time();
        let v0 = self.amplitude;
        let impedance = self.density * self.wave_speed();
        // The profile along the bar: particles sorted by position (the motion is a fraction of
        // a cell), each with its volume as its quadrature weight.
        let mut rows: Vec<(f64, f64, f64, f64)> = (0..p.len())
            .map(|k| (p.x[k], p.vx[k] / v0, p.sxx[k], p.volume[k]))
            .collect();
        rows.sort_by(|a, b| a.0.total_cmp(&b.0));
        let c = self.wave_speed();
        let front = self.start() + c * t;
        let width = match self.profile {
            Profile::Step => 0.0,
            Profile::Pulse { width } => width * self.length,
        };
        let rear = front - width;
        // The zone the metrics read: from x₀/2 behind the rear edge to the bar's end (the free
        // left end's release wave stays x₀ behind).
        let zone = rear - 0.5 * self.start();
        let mut crossing = f64::NAN;
        for w in rows.windows(2) {
            let ((xa, va, ..), (xb, vb, ..)) = (w[0], w[1]);
            if (va - 0.5) * (vb - 0.5) <= 0.0 && va != vb {
                let x = xa + (xb - xa) * (va - 0.5) / (va - vb);
                if crossing.is_nan() || (x - front).abs() < (crossing - front).abs() {
                    crossing = x;
                }
            }
        }
        let (mut precursor, mut trailing, mut overshoot) = (0.0f64, 0.0f64, f64::NEG_INFINITY);
        let (mut stress, mut weight) = (0.0, 0.0);
        let (mut area, mut moment) = (0.0, 0.0);
        for &(x, v, s, vol) in rows.iter().filter(|r| r.0 > zone) {
            let exact = self.shape(x, t);
            overshoot = overshoot.max(v - 1.0);
            stress += vol * ((s + impedance * v0 * exact) / (impedance * v0)).powi(2);
            weight += vol;
            area += vol * v / h;
            moment += vol * v * x / h;
            if x > front + 2.0 * h {
                precursor = precursor.max((v - exact).abs());
            } else if x < rear - 2.0 * h {
                trailing = trailing.max((v - exact).abs());
            }
        }
        // Arrival: the step's integral front `x_zone + ∫ v/v₀ dx`, the pulse's centroid
        // `∫ x v dx / ∫ v dx`; both travel at exactly c where momentum is conserved.
        let arrival = match self.profile {
            Profile::Step => (zone + area - front) / h,
            Profile::Pulse { .. } => (moment / area - (front - 0.5 * width)) / h,
        };
        let stress_error = (stress / weight).sqrt();
        let mut profile = History::new("velocity_profile");
        let mut exact = History::new("velocity_exact");
        for &(x, v, ..) in &rows {
            profile.push(x, v);
            exact.push(x, self.shape(x, t));
        }
        Ok(Outcome {
            problem: self.name().to_string(),
            cells,
            cell_size: h,
            metrics: vec![
                ("front_error".to_string(), (crossing - front) / h),
                ("arrival_error".to_string(), arrival),
                ("precursor".to_string(), precursor),
                ("trailing".to_string(), trailing),
                ("overshoot".to_string(), overshoot),
                ("stress_error".to_string(), stress_error),
            ],
            histories: vec![profile, exact],
            steps: sim.steps(),
            seconds,
        })
    }
}
