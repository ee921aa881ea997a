//! A box on roller walls, and a symmetry plane: an exact mode of linear elasticity whose
//! velocity is odd across every wall in its normal component and even in its tangential one.
//!
//! The body fills `[0, a L] × [0, L]`, every edge a slip (roller) wall, plane strain. The
//! dilatational mode `u = ∇φ cos ωt` with `φ = cos(mπx/(aL)) cos(πy/L)` has zero normal
//! displacement and zero shear traction on every edge (`σ_xy = 2μ ∂²φ/∂x∂y` vanishes there), and
//! `ρ ü = (λ + 2μ) ∇∇²φ` holds with
//!
//! ```text
//! ω = c_p k,   c_p = √((λ + 2μ)/ρ),   k² = (mπ/(aL))² + (π/L)²
//! v(x, 0) = −v₀ (m/a sin(mπx/(aL)) cos(πy/L), cos(mπx/(aL)) sin(πy/L))     (u(x, 0) = 0)
//! ```
//!
//! With `a = 1, m = 1` the mode is the left half of the mode `a = 2, m = 2`, whose velocity
//! normal to the plane `x = L` vanishes and whose tangential velocity is even across it: the
//! box with a slip wall at `x = L` is the wider box cut at its symmetry plane
//! ([`SlipBox::HALF`], [`SlipBox::WHOLE`]), and the two give the same modal amplitude.
//!
//! The period is measured from the zero crossings of the modal amplitude
//! `A(t) = Σ_p m_p v_p·ψ(x_p) / Σ_p m_p |ψ(x_p)|²` (`ψ` the mode shape), and the explicit
//! update's own period error removed as for the bar ([`super::bar::spatial_period`]).

use std::f64::consts::PI;
use std::time::Instant;

use super::bar::spatial_period;
use super::{period_from_zero_crossings, Choices, History, Outcome};
use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge, WallRule};
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::particles::{lattice, Particles};
use sparse_mpm::simulation::{Body, Simulation};

/// The box and its mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipBox {
    /// Width over height, `a` (1 or 2).
    pub aspect: usize,
    /// Half-waves across the width, `m`.
    pub half_waves: usize,
    /// Height `L`.
    pub length: f64,
    /// Young's modulus.
    pub youngs_modulus: f64,
    /// Poisson's ratio (plane strain).
    pub poisson_ratio: f64,
    /// Density.
    pub density: f64,
    /// Velocity amplitude `v₀`.
    pub amplitude: f64,
    /// Periods simulated.
    pub periods: f64,
    /// The rule of the walls (`None`: the default, the mirror rule for GIMP and B-splines).
    pub wall: Option<WallRule>,
}

impl SlipBox {
    /// The unit square, mode (1, 1), `E = 100`, `ν = 0.25`, `ρ = 1`, a small amplitude, 2 periods.
    pub const HALF: SlipBox = SlipBox {
        aspect: 1,
        half_waves: 1,
        length: 1.0,
        youngs_modulus: 100.0,
        poisson_ratio: 0.25,
        density: 1.0,
        amplitude: 1e-4,
        periods: 2.0,
        wall: None,
    };

    /// [`SlipBox::HALF`] mirrored across its right wall: twice as wide, two half-waves.
    pub const WHOLE: SlipBox = SlipBox {
        aspect: 2,
        half_waves: 2,
        ..SlipBox::HALF
    };

    /// `c_p = √((λ + 2μ)/ρ)`.
    pub fn wave_speed(&self) -> f64 {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        (e * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu)) / self.density).sqrt()
    }

    /// `k_x = mπ/(aL)` and `k_y = π/L`.
    fn wavenumbers(&self) -> [f64; 2] {
        [
            self.half_waves as f64 * PI / (self.aspect as f64 * self.length),
            PI / self.length,
        ]
    }

    /// The exact period `2π/ω`.
    pub fn period(&self) -> f64 {
        let [kx, ky] = self.wavenumbers();
        2.0 * PI / (self.wave_speed() * kx.hypot(ky))
    }

    /// The mode shape `ψ = −∇φ / k_y` at `(x, y)` (the initial velocity over `v₀`).
    pub fn shape(&self, x: f64, y: f64) -> [f64; 2] {
        let [kx, ky] = self.wavenumbers();
        [
            kx / ky * (kx * x).sin() * (ky * y).cos(),
            (kx * x).cos() * (ky * y).sin(),
        ]
    }

    /// The box with `cells` cells along its height: the grid padded by the kernel's
    /// recommended cells, every edge a slip wall on the body's outline.
    ///
    /// # Errors
    /// Those of [`Simulation::new`].
    pub fn simulation(&self, cells: usize, choices: &Choices) -> Result<Simulation> {
        let h = self.length / cells as f64;
        let pad = choices.shape.recommended_padding();
        let width = self.aspect as f64 * self.length;
        let grid = Grid::new(
            [-(pad as f64) * h, -(pad as f64) * h],
            [h, h],
            [self.aspect * cells + 2 * pad, cells + 2 * pad],
        )?;
        let (x, y, volume) = lattice(&grid, choices.particles_per_cell, |px, py| {
            px > 0.0 && px < width && py > 0.0 && py < self.length
        });
        let n = x.len();
        let v: Vec<[f64; 2]> = x.iter().zip(&y).map(|(&px, &py)| self.shape(px, py)).collect();
        let (vx, vy) = v.iter().map(|s| (self.amplitude * s[0], self.amplitude * s[1])).unzip();
        let particles = Particles::new(x, y, vec![self.density * volume; n], vec![volume; n])?.with_velocity(vx, vy)?;
        let boundaries = [Edge::Left, Edge::Right, Edge::Bottom, Edge::Top]
            .into_iter()
            .map(|edge| {
                let bc = BoundaryCondition::edge(edge, Condition::Slip).with_layers(pad + 1);
                match self.wall {
                    Some(rule) => bc.with_wall(rule),
                    None => bc,
                }
            })
            .collect();
        let material = LinearElastic::new(self.youngs_modulus, self.poisson_ratio, PlaneCondition::Strain)?;
        let bodies = vec![Body {
            name: "box".into(),
            material: Material::LinearElastic(material),
        }];
        Simulation::new(grid, particles, bodies, choices.options(boundaries))
    }

    /// `A(t)` of the [module docs](self) for the particles of `sim`.
    pub fn modal_amplitude(&self, sim: &Simulation) -> f64 {
        let p = sim.particles();
        let (mut num, mut den) = (0.0, 0.0);
        for k in 0..p.len() {
            let s = self.shape(p.x[k], p.y[k]);
            num += p.mass[k] * (p.vx[k] * s[0] + p.vy[k] * s[1]);
            den += p.mass[k] * (s[0] * s[0] + s[1] * s[1]);
        }
        num / den
    }

    /// Runs [`SlipBox::periods`] periods. Metrics: `period_error` (`T_measured/T − 1`),
    /// `spatial_period_error` (the explicit update's error removed), `energy_change` (relative,
    /// from the step reports), `dt`; the history `amplitude` (`A(t)`).
    ///
    /// # Errors
    /// Those of [`SlipBox::simulation`] and [`Simulation::step`].
    pub fn run(&self, cells: usize, choices: &Choices) -> Result<Outcome> {
        let mut sim = self.simulation(cells, choices)?;
        let mut amplitude = History::new("amplitude");
        amplitude.push(0.0, self.modal_amplitude(&sim));
        let end = self.periods * self.period();
        let clock = Instant::now();
        let (mut first, mut last, mut dt) = (f64::NAN, f64::NAN, f64::NAN);
        while sim.time() < end {
            let report = sim.step()?;
            amplitude.push(report.time, self.modal_amplitude(&sim));
            if first.is_nan() {
                first = report.total_energy;
            }
            last = report.total_energy;
            dt = report.dt;
        }
        let seconds = clock.elapsed().as_secs_f64();
        let measured = period_from_zero_crossings(&amplitude);
        let period = self.period();
        let metrics = vec![
            (
                "period_error".to_string(),
                measured.map_or(f64::NAN, |t| t / period - 1.0),
            ),
            (
                "spatial_period_error".to_string(),
                measured.map_or(f64::NAN, |t| spatial_period(t, dt) / period - 1.0),
            ),
            ("energy_change".to_string(), last / first - 1.0),
            ("dt".to_string(), dt),
        ];
        Ok(Outcome {
            problem: "slip_box".into(),
            cells,
            cell_size: self.length / cells as f64,
            metrics,
            histories: vec![amplitude],
            steps: sim.steps(),
            seconds,
        })
    }
}
