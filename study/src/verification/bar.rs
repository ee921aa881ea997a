//! The axially vibrating bar (notes B1, B2): a strip one cell high, rollers on every node, one end
//! or both fixed, released in its first mode.
//!
//! ```text
//! v(x, 0) = v₀ sin(β x),   v(x, t) = v₀ sin(β x) cos(ω t),   ω = β c,   c = √(E/ρ)
//! fixed–free:  β = π/(2L), T = 4L/c;     fixed–fixed:  β = π/L, T = 2L/c
//! v_cm(t) = v₀ (1 − cos βL)/(βL) · cos(ω t)
//! ```
//!
//! Metrics of [`Bar::run`]: `rms_error` (RMS over the steps of `v_cm − v_cm,exact`, relative to
//! the amplitude of `v_cm`), `period_error` (`T_measured/T − 1`, from the zero crossings of
//! `v_cm`), `spatial_period_error` (the same with the explicit update's period error removed by
//! [`spatial_period`], which leaves the error of the space discretisation), `energy_drift` (`max_t |E − E₀|/E₀`), `energy_change` (`E_end/E₀ − 1`),
//! `stable_time_step` (at the start), `transfer_loss` (the report's cumulative transfer loss
//! over `E₀`). Histories: `v_cm`, `v_cm_exact`, `kinetic_energy`,
//! `strain_energy`, `total_energy`.

use std::f64::consts::PI;
use std::time::Instant;

use super::{energy_drift, period_from_zero_crossings, Choices, History, Outcome};
use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge, WallRule};
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::particles::{lattice, Particles};
use sparse_mpm::simulation::{Body, Integrator, Newmark, Simulation, TimeStep};

/// Which ends are fixed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ends {
    /// `x = 0` fixed, `x = L` free (B1).
    FixedFree,
    /// Both ends fixed (B2).
    FixedFixed,
}

/// The bar's parameters (defaults: E = 100, ρ = 1, L = 25, v₀ = 0.1, two periods).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bar {
    /// Boundary conditions at the ends.
    pub ends: Ends,
    /// Young's modulus `E` (ν = 0, plane stress: a 1D bar).
    pub youngs_modulus: f64,
    /// Density `ρ`.
    pub density: f64,
    /// Length `L`.
    pub length: f64,
    /// Velocity amplitude `v₀`.
    pub amplitude: f64,
    /// Simulated time in periods.
    pub periods: f64,
    /// The rule of the fixed ends (`None`: [`WallRule::default_for`] the kernel, the mirror
    /// rule for GIMP and B-splines).
    pub wall: Option<WallRule>,
    /// Integrate with Newmark's rule at this multiple of the explicit stable step at `t = 0`
    /// (`None`: the explicit update of the choices).
    pub newmark: Option<(Newmark, f64)>,
}

impl Bar {
    /// The published parameter set with the given ends.
    pub fn new(ends: Ends) -> Bar {
        Bar {
            ends,
            youngs_modulus: 100.0,
            density: 1.0,
            length: 25.0,
            amplitude: 0.1,
            periods: 2.0,
            wall: None,
            newmark: None,
        }
    }

    /// The problem's name: `bar_fixed_free` or `bar_fixed_fixed`.
    pub fn name(&self) -> &'static str {
        match self.ends {
            Ends::FixedFree => "bar_fixed_free",
            Ends::FixedFixed => "bar_fixed_fixed",
        }
    }

    /// Wavenumber `β` of the first mode.
    pub fn wavenumber(&self) -> f64 {
        match self.ends {
            Ends::FixedFree => PI / (2.0 * self.length),
            Ends::FixedFixed => PI / self.length,
        }
    }

    /// Wave speed `c = √(E/ρ)`.
    pub fn wave_speed(&self) -> f64 {
        (self.youngs_modulus / self.density).sqrt()
    }

    /// Period `T = 2π/(β c)`.
    pub fn period(&self) -> f64 {
        2.0 * PI / (self.wavenumber() * self.wave_speed())
    }

    /// The exact centre-of-mass velocity `v₀ (1 − cos βL)/(βL) cos(ω t)`.
    pub fn v_cm_exact(&self, t: f64) -> f64 {
        let (b, l) = (self.wavenumber(), self.length);
        self.amplitude * (1.0 - (b * l).cos()) / (b * l) * (b * self.wave_speed() * t).cos()
    }

    /// The simulation on `cells` cells along the bar: the grid padded by the kernel's
    /// recommended cells on every side (and one more beyond a free end), fixed edges at the
    /// fixed ends (the wall on the end's node line, the lines beyond it mirrored or held by
    /// [`Bar::wall`]), rollers everywhere.
    ///
    /// # Errors
    /// Those of [`Simulation::new`].
    pub fn simulation(&self, cells: usize, choices: &Choices) -> Result<Simulation> {
        let h = self.length / cells as f64;
        let pad = choices.shape.recommended_padding();
        let extra = usize::from(self.ends == Ends::FixedFree);
        let grid = Grid::new(
            [-(pad as f64) * h, -(pad as f64) * h],
            [h, h],
            [cells + 2 * pad + extra, 1 + 2 * pad],
        )?;
        let (x, y, volume) = lattice(&grid, choices.particles_per_cell, |px, py| {
            px > 0.0 && px < self.length && py > 0.0 && py < h
        });
        let n = x.len();
        let vx: Vec<f64> = x
            .iter()
            .map(|&px| self.amplitude * (self.wavenumber() * px).sin())
            .collect();
        let particles =
            Particles::new(x, y, vec![self.density * volume; n], vec![volume; n])?.with_velocity(vx, vec![0.0; n])?;
        let end = |edge| {
            let bc = BoundaryCondition::edge(edge, Condition::Fixed).with_layers(pad + 1);
            match self.wall {
                Some(rule) => bc.with_wall(rule),
                None => bc,
            }
        };
        let mut boundaries = vec![
            BoundaryCondition::nodes((0..grid.num_nodes()).collect(), Condition::Velocity)
                .with_velocity(None, Some(0.0)),
            end(Edge::Left),
        ];
        if self.ends == Ends::FixedFixed {
            boundaries.push(end(Edge::Right));
        }
        let options = choices.options(boundaries);
        let material = Material::LinearElastic(LinearElastic::new(self.youngs_modulus, 0.0, PlaneCondition::Stress)?);
        let bodies = vec![Body {
            name: "bar".into(),
            material,
        }];
        Simulation::new(grid, particles, bodies, options)
    }

    /// Runs the bar for [`Bar::periods`] periods and compares it with the exact solution (the
    /// metrics and histories of the [module docs](self)).
    ///
    /// # Errors
    /// Those of [`Bar::simulation`] and [`Simulation::step`].
    pub fn run(&self, cells: usize, choices: &Choices) -> Result<Outcome> {
        let mut sim = self.simulation(cells, choices)?;
        let stable = sim.stable_time_step();
        let implicit = self
            .newmark
            .or(choices.implicit_step.map(|factor| (Newmark::default(), factor)));
        if let Some((newmark, factor)) = implicit {
            sim.set_integrator(Integrator::Newmark(newmark), TimeStep::Fixed { dt: factor * stable })?;
        }
        let mass = sim.particles().total_mass();
        let kinetic = sim.particles().kinetic_energy();
        let mut h = ["v_cm", "v_cm_exact", "kinetic_energy", "strain_energy", "total_energy"].map(History::new);
        let v0 = sim.particles().momentum()[0] / mass;
        for (k, v) in [v0, self.v_cm_exact(0.0), kinetic, 0.0, kinetic]
            .into_iter()
            .enumerate()
        {
            h[k].push(0.0, v);
        }
        let mut transfer_loss = 0.0;
        let mut steps_dt = Vec::new();
        let clock = Instant::now();
        sim.run_until(self.periods * self.period(), |_, r| {
            let values = [
                r.momentum[0] / mass,
                self.v_cm_exact(r.time),
                r.kinetic_energy,
                r.strain_energy,
                r.total_energy,
            ];
            for (k, v) in values.into_iter().enumerate() {
                h[k].push(r.time, v);
            }
            transfer_loss = r.transfer_loss;
            steps_dt.push(r.dt);
            Ok(())
        })?;
        let seconds = clock.elapsed().as_secs_f64();
        let amplitude = self.v_cm_exact(0.0).abs();
        let [v_cm, exact, _, _, total] = &h;
        let rms = (v_cm
            .value
            .iter()
            .zip(&exact.value)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / v_cm.value.len() as f64)
            .sqrt()
            / amplitude;
        let measured = period_from_zero_crossings(v_cm);
        let period = measured.map_or(f64::NAN, |t| t / self.period() - 1.0);
        let dt = median(&mut steps_dt);
        let spatial = measured.map_or(f64::NAN, |t| {
            let space = match implicit {
                None => spatial_period(t, dt),
                Some((newmark, _)) => newmark_spatial_period(t, dt, &newmark),
            };
            space / self.period() - 1.0
        });
        let e0 = total.value[0];
        let metrics = vec![
            ("end_time".to_string(), self.periods * self.period()),
            ("rms_error".to_string(), rms),
            ("period_error".to_string(), period),
            ("spatial_period_error".to_string(), spatial),
            ("energy_drift".to_string(), energy_drift(total)),
            (
                "energy_change".to_string(),
                total.value[total.value.len() - 1] / e0 - 1.0,
            ),
            ("stable_time_step".to_string(), stable),
            ("dt".to_string(), dt),
            ("transfer_loss".to_string(), transfer_loss / e0),
        ];
        Ok(Outcome {
            problem: self.name().to_string(),
            cells,
            cell_size: self.length / cells as f64,
            metrics,
            histories: h.into_iter().collect(),
            steps: sim.steps(),
            seconds,
        })
    }
}

/// The period of the space-discrete system whose explicit (leapfrog) integration at step `Δt`
/// has the measured period `T_Δt`: the central difference maps a frequency ω_h to ω_Δt with
/// `sin(ω_Δt Δt / 2) = ω_h Δt / 2`, so
///
/// ```text
/// T_h = π Δt / sin(π Δt / T_Δt)
/// ```
///
/// (the time integration's −(ω Δt)²/24 removed exactly, for a linear problem at a fixed step).
#[must_use]
pub fn spatial_period(measured: f64, dt: f64) -> f64 {
    if dt <= 0.0 || !dt.is_finite() {
        return measured;
    }
    PI * dt / (PI * dt / measured).sin()
}

/// The period of the space-discrete system whose integration by Newmark's average-acceleration
/// rule at step `Δt` has the measured period `T_Δt`: the rule maps ω_h to ω_Δt with
/// `tan(ω_Δt Δt / 2) = ω_h Δt / 2`, so
///
/// ```text
/// T_h = π Δt / tan(π Δt / T_Δt)
/// ```
///
/// (NaN for other `β`, `γ`, whose map this does not invert).
#[must_use]
pub fn newmark_spatial_period(measured: f64, dt: f64, newmark: &Newmark) -> f64 {
    if newmark.beta != 0.25 || newmark.gamma != 0.5 {
        return f64::NAN;
    }
    if dt <= 0.0 || !dt.is_finite() {
        return measured;
    }
    PI * dt / (PI * dt / measured).tan()
}

impl Bar {
    /// The closed-form period of the space-discrete bar with FLIP (both ends fixed, bilinear
    /// functions, `ppc` particles per cell along the bar at `ξ_j = (j + ½)/ppc` of a cell,
    /// `cells` cells). The first mode `sin(kx)`, `k = π/L`, is an eigenvector of the stiffness,
    /// of the particles' consistent mass `N diag(m) Nᵀ` and of the lumped mass, with
    ///
    /// ```text
    /// K φ = (E/h) (2 − 2 cos kh) φ,   M φ = ρh (2a + 2b cos kh) φ,   M_L φ = ρh φ
    /// a = Σ_j (1 − ξ_j)² / ppc,   b = Σ_j ξ_j (1 − ξ_j) / ppc     (2 per cell: a = 5/16, b = 3/16)
    /// ```
    ///
    /// With the consistent mass in both solves the grid equations are `M a = −K u`:
    /// `ω_h² = c² (2 − 2 cos kh) / (h² (2a + 2b cos kh))`. With the lumped mass and FLIP the
    /// particles hand back to the grid `M_L⁻¹ N m Nᵀ Δv = (M_L⁻¹M) Δv`, the fraction
    /// `λ = 2a + 2b cos kh` of each step's velocity change, so the grid's inertia is `M_L/λ`:
    /// `ω_h² = c² (2 − 2 cos kh) λ / h²`. `T_h = 2π/ω_h`; `None` for a fixed–free bar.
    #[must_use]
    pub fn discrete_period(&self, cells: usize, ppc: usize, consistent: bool) -> Option<f64> {
        if self.ends != Ends::FixedFixed || cells == 0 || ppc == 0 {
            return None;
        }
        let h = self.length / cells as f64;
        let kh = self.wavenumber() * h;
        let xi = (0..ppc).map(|j| (j as f64 + 0.5) / ppc as f64);
        let a = xi.clone().map(|x| (1.0 - x) * (1.0 - x)).sum::<f64>() / ppc as f64;
        let b = xi.map(|x| x * (1.0 - x)).sum::<f64>() / ppc as f64;
        let lambda = 2.0 * a + 2.0 * b * kh.cos();
        let stiffness = self.youngs_modulus / (h * h * self.density) * (2.0 - 2.0 * kh.cos());
        let omega2 = if consistent {
            stiffness / lambda
        } else {
            stiffness * lambda
        };
        Some(2.0 * PI / omega2.sqrt())
    }
}

/// The period the average-acceleration rule at step `Δt` gives a mode of period `T_h`:
///
/// ```text
/// T_Δt = π Δt / arctan(π Δt / T_h)
/// ```
#[must_use]
pub fn newmark_period(space_period: f64, dt: f64) -> f64 {
    PI * dt / (PI * dt / space_period).atan()
}

/// The median of `values` (NaN when empty).
fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}
