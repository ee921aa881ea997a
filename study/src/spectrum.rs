//! The plans and runs of the parts that look past the first mode: `dispersion` (the discrete
//! dispersion relation of each kernel and mass pair), `waves` (a step and a pulse against
//! d'Alembert for each mass pair) and `time_order` (the single material point under a sequence
//! of time steps for each update scheme).

use std::f64::consts::PI;

use super::{Problem, StudySpec};
use crate::verification::dispersion::dispersion;
use crate::verification::{single_point, Choices, History, Outcome};
use sparse_mpm::error::Result;
use sparse_mpm::mass::MassOptions;
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::{Transfer, UpdateScheme};

/// The largest time step of the time-order part; each further run halves it.
pub(super) const TIME_ORDER_STEP: f64 = 4e-3;
/// The single point's initial velocity in the time-order part (its volume change, 1.6e-4 of
/// itself, stays below the time error of every step).
pub(super) const TIME_ORDER_V0: f64 = 1e-3;

impl StudySpec {
    /// The dispersion part: every shape of the spec with every mass pair, 2 particles per cell.
    pub(super) fn plan_dispersion(&self) -> Vec<(Problem, Choices, usize)> {
        let mut runs = Vec::new();
        for &shape in &self.shapes {
            for &mass in &self.masses {
                let choices = Choices {
                    shape,
                    particles_per_cell: 2,
                    ..self.choices(mass)
                };
                runs.push((Problem::Dispersion, choices, 0));
            }
        }
        runs
    }

    /// The waves part: the step and the pulse with bilinear functions for every mass pair on
    /// every wave grid of the spec, then the impulse-loaded bar on every impulse grid.
    pub(super) fn plan_waves(&self) -> Vec<(Problem, Choices, usize)> {
        let mut runs = Vec::new();
        for (problem, grids) in [
            (Problem::WaveStep, &self.wave_cells),
            (Problem::WavePulse, &self.wave_cells),
            (Problem::ImpulseBar, &self.impulse_cells),
        ] {
            for &mass in &self.masses {
                let choices = Choices {
                    shape: ShapeFunction::Linear,
                    cfl: 0.5,
                    ..self.choices(mass)
                };
                for &cells in grids {
                    runs.push((problem, choices, cells));
                }
            }
        }
        runs
    }

    /// The time-order part: the single point (lumped, FLIP) under USF, USL and MUSL, at
    /// `Δt = 4e-3 / 2^k` for `k < time_steps`; `cells` carries `k`.
    pub(super) fn plan_time_order(&self) -> Vec<(Problem, Choices, usize)> {
        let mut runs = Vec::new();
        for update in [UpdateScheme::Usf, UpdateScheme::Usl, UpdateScheme::Musl] {
            for k in 0..self.time_steps {
                let choices = Choices {
                    update,
                    transfer: Transfer::Flip,
                    mass: MassOptions::default(),
                    ..Choices::default()
                };
                runs.push((Problem::SinglePointStep, choices, k));
            }
        }
        runs
    }
}

/// The time step of the time-order run `k`: `4e-3 / 2^k`.
pub(super) fn time_order_step(k: usize) -> f64 {
    TIME_ORDER_STEP / f64::from(1u32 << k.min(30))
}

/// The single point at the `k`-th step of the sequence (metric `dt` added).
pub(super) fn time_order_run(k: usize, choices: &Choices) -> Result<Outcome> {
    let dt = time_order_step(k);
    let mut o = single_point::run_with_step(TIME_ORDER_V0, dt, choices)?;
    o.metrics.push(("dt".into(), dt));
    Ok(o)
}

/// The dispersion curve of `choices` (shape, mass pair, particles per cell) at 96 points of
/// `(0, π]` as an outcome: metrics `c_ratio_pi_4`, `c_ratio_pi_2`, `c_ratio_3pi_4`, `c_ratio_pi`
/// (`c_h/c` there), history `c_ratio` (its `time` is θ).
pub(super) fn dispersion_run(choices: &Choices) -> Result<Outcome> {
    let samples = 96;
    let curve = dispersion(
        choices.shape,
        choices.mass.velocity,
        choices.mass.acceleration,
        choices.particles_per_cell,
        samples,
        None,
    )?;
    let at = |j: usize| curve[j * samples / 4 - 1].c_ratio;
    let mut history = History::new("c_ratio");
    for p in &curve {
        history.push(p.theta, p.c_ratio);
    }
    debug_assert!((curve[samples - 1].theta - PI).abs() < 1e-12);
    Ok(Outcome {
        problem: "dispersion".into(),
        cells: 0,
        cell_size: 1.0,
        metrics: vec![
            ("c_ratio_pi_4".into(), at(1)),
            ("c_ratio_pi_2".into(), at(2)),
            ("c_ratio_3pi_4".into(), at(3)),
            ("c_ratio_pi".into(), at(4)),
        ],
        histories: vec![history],
        steps: 0,
        seconds: 0.0,
    })
}
