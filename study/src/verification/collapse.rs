//! The granular column collapse in a 2D channel: a column of cohesionless Drucker–Prager
//! material, width `L₀` and height `H₀ = a L₀`, against a smooth back wall (`x = 0`, slip) on a
//! rough floor (fixed: no slip), released at rest under gravity with its geostatic stress
//! (`K₀ = ν/(1 − ν)`), spreads and comes to rest. Compared with the experimental laws of quasi-2D
//! collapses of Lube, Huppert, Sparks & Freundt (Phys. Rev. E 72, 041301, 2005), sand in a
//! channel 10 cm wide:
//!
//! ```text
//! run-out       (L∞ − L₀)/L₀ ≈ 1.2 a            a ≲ 1.8
//!                            ≈ 1.9 a^(2/3)      a ≳ 2.8     (between: within these two)
//! final height  H∞/L₀ ≈ a  (a ≲ 1.15),   ≈ a^(2/5) beyond
//! duration      t∞ ≈ 3 √(H₀/g)
//! ```
//!
//! (the same laws hold for the other granular materials they used, and Lajeunesse, Monnier &
//! Homsy, Phys. Fluids 17, 103302, 2005, found the same linear and 2/3-power regimes with glass
//! beads). [`runout_law`] gives the law's band at `a`: one value outside the transition,
//! `[1.2 a, 1.9 a^(2/3)]` inside it.
//!
//! Measured by [`Collapse::run`] at the end of the run (`duration` times `√(H₀/g)`):
//!
//! - `runout`: `(L∞ − L₀)/L₀` with the front `L∞` the toe of the contiguous deposit: the
//!   far edge of the last of the columns of cells (one cell wide, from the back wall) that
//!   hold a particle before the first that holds none (grains thrown ahead of the deposit, which
//!   single particles represent badly, are not counted: the farthest particle does not converge
//!   with refinement); `runout_p99` with the front the 99th percentile of the particles' `x`;
//! - `final_height`: `H∞/L₀`, the highest particle within one cell of the back wall;
//! - `stop_time`: the time (over `√(H₀/g)`) after which the kinetic energy of the grid's
//!   motion, `½ Σ_p m_p |(Nᵀw)_p|²` (what moves the particles), stays below 10⁻³ of its peak;
//!   `kinetic_end` that energy at the end over its peak (FLIP keeps particle velocities the grid
//!   does not see, which move no particle);
//! - `dissipated`: plastic dissipation over the potential energy released; `energy_error`: the
//!   largest `|E(t) − E(0)|` of `E = kinetic + strain + potential + plastic dissipation +
//!   transfer loss` over the potential energy released (the balance of the report);
//! - `stress_deviation`: the RMS over the particles of `σ_yy − σ_lith`, `σ_lith = −ρ g (y_s(x) −
//!   y)` with `y_s(x)` the deposit's surface above the particle (its cell column's highest
//!   particle), over `ρ g H₀`: the noise of the stress field at rest, and how far the deposit's
//!   vertical stress is from the weight above it;
//! - `law_runout_low`, `law_runout_high`, `law_height`: the laws at `a`.

use std::time::Instant;

use super::{Choices, History, Outcome};
use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge};
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{DruckerPrager, Material};
use sparse_mpm::particles::{lattice_within, Particles};
use sparse_mpm::simulation::{Body, Simulation};

/// The collapse's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Collapse {
    /// Aspect ratio `a = H₀/L₀`.
    pub aspect: f64,
    /// Initial width `L₀`.
    pub width: f64,
    /// Friction angle `φ` in degrees.
    pub friction_angle: f64,
    /// Young's modulus `E`.
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν`.
    pub poisson_ratio: f64,
    /// Density `ρ`.
    pub density: f64,
    /// Gravity `g`.
    pub gravity: f64,
    /// The run's length in `√(H₀/g)`.
    pub duration: f64,
    /// The floor: fixed (`None`, the default: every node line at and below it at rest) or a
    /// slip wall with Coulomb friction `μ` (`Some(μ)`, met through contact:
    /// [`BoundaryCondition::with_friction`]).
    pub floor_friction: Option<f64>,
}

impl Collapse {
    /// Sand of `φ = 32°` (Lube et al.'s quartz sand has an angle of repose of 29.5°; its
    /// friction angle in shear is a few degrees above), `E = 10 MPa`, `ν = 0.3`, `ρ = 1500`,
    /// `g = 9.81`, `L₀ = 0.2`, run for `6 √(H₀/g)`.
    pub fn new(aspect: f64) -> Collapse {
        Collapse {
            aspect,
            width: 0.2,
            friction_angle: 32.0,
            youngs_modulus: 1.0e7,
            poisson_ratio: 0.3,
            density: 1500.0,
            gravity: 9.81,
            duration: 6.0,
            floor_friction: None,
        }
    }

    /// `H₀ = a L₀`.
    pub fn height(&self) -> f64 {
        self.aspect * self.width
    }

    /// The time scale `√(H₀/g)`.
    pub fn time_scale(&self) -> f64 {
        (self.height() / self.gravity).sqrt()
    }

    /// The material: cohesionless Drucker–Prager, no dilatancy.
    pub fn material(&self) -> Material {
        Material::DruckerPrager(DruckerPrager {
            youngs_modulus: self.youngs_modulus,
            poisson_ratio: self.poisson_ratio,
            friction_angle: self.friction_angle,
            cohesion: 0.0,
            dilatancy_angle: 0.0,
        })
    }

    /// The collapse with `cells` cells across `L₀` and the choices' kernel, particles per
    /// cell, transfer, update, masses and Courant number. The grid reaches `L₀ (1 + 3.5 a) + 0.1`
    /// to the right and two cells above the column, padded by the kernel's cells.
    ///
    /// # Errors
    /// Those of [`Grid::new`] and [`Simulation::new`].
    pub fn simulation(&self, cells: usize, choices: &Choices) -> Result<Simulation> {
        let h = self.width / cells as f64;
        let pad = choices.shape.recommended_padding();
        let (l0, h0) = (self.width, self.height());
        let across = ((l0 * (1.0 + 3.5 * self.aspect) + 0.1) / h).ceil() as usize;
        let up = (h0 / h).ceil() as usize + 2;
        let grid = Grid::new(
            [-(pad as f64) * h, -(pad as f64) * h],
            [h, h],
            [across + 2 * pad, up + 2 * pad],
        )?;
        let bounds = Some([[0.0, 0.0], [l0, h0]]);
        let inside = |x: f64, y: f64| (0.0..l0).contains(&x) && (0.0..h0).contains(&y);
        let (x, y, volume) = lattice_within(&grid, choices.particles_per_cell, bounds, inside);
        let n = x.len();
        let mut particles = Particles::new(x, y, vec![self.density * volume; n], vec![volume; n])?;
        // Geostatic: σ_v = −ρ g (H₀ − y), σ_h = K₀ σ_v.
        let k0 = self.poisson_ratio / (1.0 - self.poisson_ratio);
        for k in 0..n {
            let sv = -self.density * self.gravity * (h0 - particles.y[k]);
            particles.syy[k] = sv;
            particles.sxx[k] = k0 * sv;
        }
        let floor = match self.floor_friction {
            None => BoundaryCondition::edge(Edge::Bottom, Condition::Fixed),
            Some(mu) => BoundaryCondition::edge(Edge::Bottom, Condition::Slip).with_friction(mu),
        };
        let mut options = choices.options(vec![BoundaryCondition::edge(Edge::Left, Condition::Slip), floor]);
        options.gravity = [0.0, -self.gravity];
        let body = Body {
            name: "column".into(),
            material: self.material(),
        };
        Simulation::new(grid, particles, vec![body], options)
    }

    /// Runs the collapse for [`Collapse::duration`] (the metrics of the [module docs](self);
    /// histories of the grid's kinetic energy and the front against time, both scaled, and the
    /// final deposit's profile, [`deposit_profile`]).
    ///
    /// # Errors
    /// Those of [`Collapse::simulation`] and [`Simulation::step`].
    pub fn run(&self, cells: usize, choices: &Choices) -> Result<Outcome> {
        let mut sim = self.simulation(cells, choices)?;
        let (l0, h0, g, rho) = (self.width, self.height(), self.gravity, self.density);
        let scale = self.time_scale();
        let end = self.duration * scale;
        let mut kinetic = History::new("kinetic_energy");
        let mut front = History::new("front");
        let mut energy = History::new("energy_balance");
        let started = Instant::now();
        let mut last_sample = f64::NEG_INFINITY;
        let (mut released, mut e0) = (0.0f64, None);
        let (mut potential0, mut dissipation, mut friction) = (None, 0.0, 0.0);
        while sim.time() < end {
            let r = sim.step()?;
            dissipation = r.plastic_dissipation;
            friction = r.friction_dissipation;
            let balance = r.total_energy + r.plastic_dissipation + r.transfer_loss + r.friction_dissipation;
            let e_start = *e0.get_or_insert(balance);
            let p0 = *potential0.get_or_insert(r.potential_energy);
            released = released.max(p0 - r.potential_energy);
            energy.push(r.time / scale, balance - e_start);
            kinetic.push(r.time / scale, r.grid_kinetic_energy_consistent);
            if r.time - last_sample >= 0.05 * scale {
                last_sample = r.time;
                let h = sim.grid().cell_size()[0];
                front.push(r.time / scale, (contiguous_front(sim.particles(), h) - l0) / l0);
            }
        }
        let seconds = started.elapsed().as_secs_f64();
        let p = sim.particles();
        let peak = kinetic.value.iter().copied().fold(0.0, f64::max);
        let stop = kinetic
            .value
            .iter()
            .rposition(|&k| k > 1e-3 * peak)
            .map_or(0.0, |i| kinetic.time[(i + 1).min(kinetic.time.len() - 1)]);
        let h = sim.grid().cell_size()[0];
        let height = (0..p.len()).filter(|&k| p.x[k] < h).map(|k| p.y[k]).fold(0.0, f64::max);
        let released = released.max(f64::MIN_POSITIVE);
        let error = energy.value.iter().map(|e| e.abs()).fold(0.0, f64::max) / released;
        let (low, high) = runout_law(self.aspect);
        let mut outcome = Outcome {
            problem: "collapse".into(),
            cells,
            cell_size: h,
            metrics: vec![
                ("aspect".into(), self.aspect),
                ("runout".into(), (contiguous_front(p, h) - l0) / l0),
                ("runout_p99".into(), (percentile_front(p) - l0) / l0),
                ("final_height".into(), height / l0),
                ("stop_time".into(), stop),
                (
                    "kinetic_end".into(),
                    kinetic.value.last().copied().unwrap_or(0.0) / peak.max(f64::MIN_POSITIVE),
                ),
                ("dissipated".into(), dissipation / released),
                ("friction_dissipated".into(), friction / released),
                ("energy_error".into(), error),
                (
                    "stress_deviation".into(),
                    stress_deviation(p, h, rho * g) / (rho * g * h0),
                ),
                ("law_runout_low".into(), low),
                ("law_runout_high".into(), high),
                ("law_height".into(), height_law(self.aspect)),
            ],
            histories: vec![kinetic, front, deposit_profile(p, h, l0)],
            steps: sim.steps(),
            seconds,
        };
        for hist in &mut outcome.histories {
            if hist.name == "kinetic_energy" {
                hist.value.iter_mut().for_each(|v| *v /= peak.max(f64::MIN_POSITIVE));
            }
        }
        Ok(outcome)
    }
}

/// Lube et al.'s run-out law at `a` as a band `(low, high)`: `1.2 a` for `a ≤ 1.8`,
/// `1.9 a^(2/3)` for `a ≥ 2.8`, and `[1.2 a, 1.9 a^(2/3)]` between (where they fit neither).
pub fn runout_law(a: f64) -> (f64, f64) {
    let (linear, power) = (1.2 * a, 1.9 * a.powf(2.0 / 3.0));
    if a <= 1.8 {
        (linear, linear)
    } else if a >= 2.8 {
        (power, power)
    } else {
        (linear.min(power), linear.max(power))
    }
}

/// Lube et al.'s final height `H∞/L₀`: `a` for `a ≤ 1.15`, `a^(2/5)` beyond.
pub fn height_law(a: f64) -> f64 {
    if a <= 1.15 {
        a
    } else {
        a.powf(0.4)
    }
}

/// The relative distance of `x` from the band `(low, high)`: 0 inside, `(x − high)/high` above,
/// `(x − low)/low` below.
pub fn from_band(x: f64, (low, high): (f64, f64)) -> f64 {
    if x > high {
        (x - high) / high
    } else if x < low {
        (x - low) / low
    } else {
        0.0
    }
}

/// The deposit's profile: for each column of cells of width `h` from `x = 0` that holds a
/// particle, its centre and its highest particle, both over `L₀` (the history's "time" is
/// `x/L₀`).
pub fn deposit_profile(p: &Particles, h: f64, l0: f64) -> History {
    let mut top: Vec<f64> = Vec::new();
    for k in 0..p.len() {
        let c = (p.x[k] / h).floor().max(0.0) as usize;
        if c >= top.len() {
            top.resize(c + 1, f64::NAN);
        }
        top[c] = if top[c].is_nan() { p.y[k] } else { top[c].max(p.y[k]) };
    }
    let mut profile = History::new("profile");
    for (c, &t) in top.iter().enumerate().filter(|(_, t)| !t.is_nan()) {
        profile.push((c as f64 + 0.5) * h / l0, t / l0);
    }
    profile
}

/// The toe of the contiguous deposit: `k h` for the first column of cells `[k h, (k + 1) h)`
/// from `x = 0` that holds no particle.
pub fn contiguous_front(p: &Particles, h: f64) -> f64 {
    let mut filled = Vec::new();
    for &x in &p.x {
        let k = (x / h).floor().max(0.0) as usize;
        if k >= filled.len() {
            filled.resize(k + 1, false);
        }
        filled[k] = true;
    }
    filled.iter().position(|&f| !f).unwrap_or(filled.len()) as f64 * h
}

/// The 99th percentile of the particles' `x` (all particles of the collapse have one mass).
pub fn percentile_front(p: &Particles) -> f64 {
    let mut x = p.x.clone();
    x.sort_by(f64::total_cmp);
    x.get(((0.99 * x.len() as f64) as usize).min(x.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0)
}

/// `√(mean_p (σ_yy,p − σ_lith,p)²)` with `σ_lith = −ρg (y_s − y)` and `y_s` the highest particle
/// of the particle's column of cells of width `h`.
fn stress_deviation(p: &Particles, h: f64, rho_g: f64) -> f64 {
    let column = |x: f64| (x / h).floor() as i64;
    let mut top = std::collections::HashMap::new();
    for k in 0..p.len() {
        let t = top.entry(column(p.x[k])).or_insert(f64::MIN);
        *t = f64::max(*t, p.y[k]);
    }
    let sum: f64 = (0..p.len())
        .map(|k| {
            let lith = -rho_g * (top[&column(p.x[k])] - p.y[k]);
            (p.syy[k] - lith).powi(2)
        })
        .sum();
    (sum / p.len().max(1) as f64).sqrt()
}
