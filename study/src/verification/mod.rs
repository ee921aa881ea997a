//! Verification problems with known answers (docs/verification.md): each builds a
//! [`Simulation`](sparse_mpm::simulation::Simulation) (or steps [`explicit_step`](sparse_mpm::step::explicit_step))
//! for a resolution and a set of algorithmic [`Choices`], runs it, and returns what it measured
//! against the reference as an [`Outcome`]. The examples print them, the tests assert them at
//! small sizes, and [`crate`] runs them over a matrix of choices.
//!
//! | problem | reference | module |
//! |---|---|---|
//! | axially vibrating bar, fixed–free and fixed–fixed (B1, B2) | exact centre-of-mass velocity and period | [`bar`] |
//! | single material point (B3) | exact `x(t)`, `v(t)` | [`single_point`] |
//! | axis-aligned manufactured solution (B5), generalised vortex (B6) and its smooth profile, expanding ring | exact displacement | [`manufactured`] |
//! | two elastic disks in impact (B8) | energy conservation | [`disks`] |
//! | cantilever under gravity (B9) | Richardson-extrapolated tip deflection | [`cantilever`] |
//! | elastic column under its own weight, quasi-static | exact `σ_yy(Y)` at any deformation | [`column`](mod@column) |
//! | the dispersion relation over the whole spectrum | closed-form symbols | [`dispersion`] |
//! | a velocity step and a pulse in a long bar | d'Alembert | [`wave`] |
//! | the impulse-loaded bar: a pressure pulse at the free end of a fixed–free bar | d'Alembert with images | [`impulse`] |
//! | disk in rigid rotation; projection of a rotation from a strip one cell thick | angular momentum; exact nodal field | [`rotation`] |

use serde::{Deserialize, Serialize};

use sparse_mpm::boundary::BoundaryCondition;
use sparse_mpm::mass::{MassOptions, MassScheme};
use sparse_mpm::scene::Scene;
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::{Options, TimeStep, Transfer, UpdateScheme};

pub mod bar;
pub mod cantilever;
pub mod collapse;
pub mod column;
pub mod disks;
pub mod dispersion;
pub mod impulse;
pub mod manufactured;
pub mod rotation;
pub mod single_point;
pub mod slip_box;
pub mod wave;

/// The algorithmic choices of a verification run: the axes a study varies.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Choices {
    /// Shape functions.
    pub shape: ShapeFunction,
    /// USF, USL or MUSL.
    pub update: UpdateScheme,
    /// Particle velocity transfer.
    pub transfer: Transfer,
    /// Mass schemes of the two solves.
    pub mass: MassOptions,
    /// Particles per cell along each axis.
    pub particles_per_cell: usize,
    /// Courant number: the fraction of the stable step taken.
    pub cfl: f64,
    /// Newmark's average-acceleration rule at this multiple of the explicit stable step at
    /// `t = 0` instead of the explicit update (`None`, the default: explicit).
    pub implicit_step: Option<f64>,
}

impl Default for Choices {
    fn default() -> Self {
        Choices {
            shape: ShapeFunction::Linear,
            update: UpdateScheme::Musl,
            transfer: Transfer::Flip,
            mass: MassOptions::both(MassScheme::Lumped),
            particles_per_cell: 2,
            cfl: 0.5,
            implicit_step: None,
        }
    }
}

impl Choices {
    /// The simulation options of these choices (a CFL step) with `boundaries`.
    pub fn options(&self, boundaries: Vec<BoundaryCondition>) -> Options {
        Options {
            shape: self.shape,
            update: self.update,
            transfer: self.transfer,
            mass: self.mass,
            time_step: TimeStep::Cfl { number: self.cfl },
            boundaries,
            ..Options::default()
        }
    }

    /// Sets these choices in `scene` (its schemes, Courant number and every body's particles per
    /// cell), keeping the rest.
    pub fn apply_to(&self, scene: &mut Scene) {
        scene.schemes.shape = self.shape;
        scene.schemes.update = self.update;
        scene.schemes.transfer = self.transfer;
        scene.schemes.mass = self.mass;
        scene.time.cfl = Some(self.cfl);
        scene.time.dt = None;
        for body in &mut scene.bodies {
            body.particles_per_cell = self.particles_per_cell;
        }
    }

    /// Switches `sim` to Newmark's rule at [`Choices::implicit_step`] times its explicit stable
    /// step, when set.
    ///
    /// # Errors
    /// Those of [`Simulation::set_integrator`](sparse_mpm::simulation::Simulation::set_integrator).
    pub fn integrate(&self, sim: &mut sparse_mpm::simulation::Simulation) -> sparse_mpm::error::Result<()> {
        if let Some(factor) = self.implicit_step {
            let dt = factor * sim.stable_time_step();
            sim.set_integrator(
                sparse_mpm::simulation::Integrator::Newmark(sparse_mpm::simulation::Newmark::default()),
                TimeStep::Fixed { dt },
            )?;
        }
        Ok(())
    }

    /// A short label: `"linear, MUSL, FLIP, lumped"`, with the velocity and acceleration masses
    /// separated by `/` when they differ.
    pub fn label(&self) -> String {
        let m = &self.mass;
        let mass = if m.velocity == m.acceleration {
            format!("{:#}", m.velocity)
        } else {
            format!("{:#}/{:#}", m.velocity, m.acceleration)
        };
        let transfer = match self.transfer {
            Transfer::Pic => "PIC".to_string(),
            Transfer::Flip => "FLIP".to_string(),
            Transfer::Apic => "APIC".to_string(),
            Transfer::Blend { flip } => format!("blend({flip})"),
            Transfer::Xpic { k } => format!("XPIC({k})"),
            Transfer::Fmpm { k } => format!("FMPM({k})"),
        };
        let stabilized = m.velocity.needs_consistent_matrix() || m.acceleration.needs_consistent_matrix();
        let mass = if stabilized && m.stabilization != Default::default() {
            format!("{mass} ({:#})", m.stabilization)
        } else {
            mass
        };
        let integrator = self
            .implicit_step
            .map_or(String::new(), |f| format!(", Newmark at {f} × the explicit step"));
        format!(
            "{}, {:?}, {transfer}, {mass}{integrator}",
            self.shape.name(),
            self.update
        )
        .replace("Musl", "MUSL")
        .replace("Usl", "USL")
        .replace("Usf", "USF")
    }
}

/// A quantity against time.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct History {
    /// What it is (`"kinetic_energy"`, `"v_cm"`, `"v_cm_exact"` …).
    pub name: String,
    /// Times.
    pub time: Vec<f64>,
    /// Values at those times.
    pub value: Vec<f64>,
}

impl History {
    /// An empty history called `name`.
    pub fn new(name: &str) -> History {
        History {
            name: name.to_string(),
            ..History::default()
        }
    }

    /// Appends the value `v` at time `t`.
    pub fn push(&mut self, t: f64, v: f64) {
        self.time.push(t);
        self.value.push(v);
    }
}

/// What one verification run measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The problem's name (`"bar_fixed_free"` …).
    pub problem: String,
    /// Cells along the problem's characteristic length.
    pub cells: usize,
    /// Cell size.
    pub cell_size: f64,
    /// Named results: errors against the reference, energy drift, stable step … (the
    /// problem's docs list them).
    pub metrics: Vec<(String, f64)>,
    /// Time series.
    pub histories: Vec<History>,
    /// Steps taken.
    pub steps: usize,
    /// Wall time of the stepping, seconds.
    pub seconds: f64,
}

impl Outcome {
    /// The metric called `name`, if measured.
    pub fn metric(&self, name: &str) -> Option<f64> {
        self.metrics.iter().find(|(n, _)| n == name).map(|&(_, v)| v)
    }

    /// The history called `name`, if recorded.
    pub fn history(&self, name: &str) -> Option<&History> {
        self.histories.iter().find(|h| h.name == name)
    }
}

/// The least-squares slope of `ln y` against `ln x`, the order `p` of `y ≈ C x^p`:
///
/// ```text
/// p = Σ (ln x − mean ln x)(ln y − mean ln y) / Σ (ln x − mean ln x)²
/// ```
///
/// over the points with positive finite `x` and `y`; `None` with fewer than two.
pub fn fitted_order(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if logs.len() < 2 {
        return None;
    }
    let n = logs.len() as f64;
    let (mx, my) = (
        logs.iter().map(|p| p.0).sum::<f64>() / n,
        logs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The largest relative energy excursion `max_t |E(t) − E(0)| / E(0)` of a history.
pub fn energy_drift(total: &History) -> f64 {
    let Some(&e0) = total.value.first() else {
        return 0.0;
    };
    total.value.iter().map(|e| (e - e0).abs()).fold(0.0, f64::max) / e0.abs()
}

/// Period of an oscillating signal from its zero crossings: twice the mean spacing of the
/// crossings (linear interpolation between samples); `None` with fewer than two.
pub fn period_from_zero_crossings(h: &History) -> Option<f64> {
    let mut crossings = Vec::new();
    for k in 1..h.value.len() {
        let (a, b) = (h.value[k - 1], h.value[k]);
        if (a > 0.0 && b <= 0.0) || (a < 0.0 && b >= 0.0) {
            crossings.push(h.time[k - 1] + (h.time[k] - h.time[k - 1]) * a / (a - b));
        }
    }
    (crossings.len() >= 2).then(|| 2.0 * (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64)
}
