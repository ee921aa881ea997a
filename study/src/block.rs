//! The time-step part's problem: a block at rest, its stable step with each mass and the
//! smallest eigenvalue of `M_L⁻¹ M` against particles per cell.

use crate::verification::Outcome;
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::mass::{MassDiagnostics, MassOptions, MassScheme};
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::operators::Operators;
use sparse_mpm::particles::{lattice, Particles};
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep};

/// The time-step part's block: 8 × 8 cells filled with `n × n` particles per cell in a 12 × 12
/// grid (h = 1, E = 1000, ν = 0.3 plane strain, ρ = 1), at rest. Metrics: `stable_step_lumped`,
/// `stable_step_consistent` (FLIP, in units of h/c; NaN when the consistent mass is singular)
/// and `lambda_min` (`λ_min(M_L⁻¹M)`, Lanczos).
pub(crate) fn block_time_steps(n: usize) -> Result<Outcome> {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [12, 12])?;
    let (x, y, volume) = lattice(&grid, n, |px, py| {
        (2.0..10.0).contains(&px) && (2.0..10.0).contains(&py)
    });
    let count = x.len();
    let particles = Particles::new(x, y, vec![volume; count], vec![volume; count])?;
    let material = LinearElastic::new(1000.0, 0.3, PlaneCondition::Strain)?;
    let c = material.wave_speed(1.0);
    let stable = |scheme| -> f64 {
        let options = Options {
            mass: MassOptions::both(scheme),
            time_step: TimeStep::Cfl { number: 1.0 },
            ..Options::default()
        };
        let bodies = vec![Body {
            name: "block".into(),
            material: Material::LinearElastic(material),
        }];
        Simulation::new(grid.clone(), particles.clone(), bodies, options).map_or(f64::NAN, |s| s.stable_time_step() * c)
    };
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &particles)?;
    let diagnostics = MassDiagnostics::compute(&ops, &particles.mass, &MassOptions::plain(MassScheme::Consistent))?;
    Ok(Outcome {
        problem: "block".into(),
        cells: 8,
        cell_size: 1.0,
        metrics: vec![
            ("stable_step_lumped".into(), stable(MassScheme::Lumped)),
            ("stable_step_consistent".into(), stable(MassScheme::Consistent)),
            ("lambda_min".into(), diagnostics.lambda_min_estimate),
        ],
        histories: Vec::new(),
        steps: 0,
        seconds: 0.0,
    })
}
