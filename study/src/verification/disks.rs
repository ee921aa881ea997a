//! Two elastic disks in impact (notes B8; Sulsky, Chen & Schreyer 1994): the shipped scene
//! `scenes/two_disks.toml` (radius 0.2 on `[0, 1]²`, E = 1000, ν = 0.3, ρ = 1000, plane strain,
//! velocities ±(0.1, 0.1), to t = 3.5) with the grid refined to `cells` cells per side (padded
//! by the kernel's recommended cells) and the choices applied. No exact solution: the total
//! energy should stay constant.
//!
//! Metrics: `energy_drift` (`max_t |E − E₀|/E₀`), `energy_change` (`E_end/E₀ − 1`),
//! `energy_dip` (`1 − min_t E/E₀`), `stable_time_step`, `transfer_loss` (the report's cumulative
//! transfer loss over `E₀`). Histories: `kinetic_energy`,
//! `strain_energy`, `total_energy`.

use std::time::Instant;

use super::{energy_drift, Choices, History, Outcome};
use sparse_mpm::error::Result;
use sparse_mpm::scene::Scene;

/// The shipped scene.
pub const SCENE: &str = include_str!("../../../scenes/two_disks.toml");

/// The scene on `cells × cells` cells of `[0, 1]²` with `choices`.
///
/// # Errors
/// [`sparse_mpm::MpmError::InvalidScene`] if the choices make the scene invalid.
pub fn scene(cells: usize, choices: &Choices) -> Result<Scene> {
    let mut scene = Scene::from_toml_str(SCENE)?;
    let h = 1.0 / cells as f64;
    let pad = choices.shape.recommended_padding();
    scene.grid.cell_size = [h, h];
    scene.grid.origin = [-(pad as f64) * h; 2];
    scene.grid.cells = [cells + 2 * pad; 2];
    choices.apply_to(&mut scene);
    Ok(scene)
}

/// Runs the scene to its end.
///
/// # Errors
/// Those of [`Scene::build`] and [`sparse_mpm::simulation::Simulation::step`].
pub fn run(cells: usize, choices: &Choices) -> Result<Outcome> {
    let scene = scene(cells, choices)?;
    let mut sim = scene.build()?;
    let stable = sim.stable_time_step();
    choices.integrate(&mut sim)?;
    let mut h = ["kinetic_energy", "strain_energy", "total_energy"].map(History::new);
    let kinetic = sim.particles().kinetic_energy();
    for (k, v) in [kinetic, 0.0, kinetic].into_iter().enumerate() {
        h[k].push(0.0, v);
    }
    let mut transfer_loss = 0.0;
    let clock = Instant::now();
    sim.run_until(scene.time.end, |_, r| {
        for (k, v) in [r.kinetic_energy, r.strain_energy, r.total_energy]
            .into_iter()
            .enumerate()
        {
            h[k].push(r.time, v);
        }
        transfer_loss = r.transfer_loss;
        Ok(())
    })?;
    let seconds = clock.elapsed().as_secs_f64();
    let total = &h[2];
    let e0 = total.value[0];
    let lowest = total.value.iter().cloned().fold(f64::INFINITY, f64::min);
    let metrics = vec![
        ("end_time".to_string(), scene.time.end),
        ("energy_drift".to_string(), energy_drift(total)),
        (
            "energy_change".to_string(),
            total.value[total.value.len() - 1] / e0 - 1.0,
        ),
        ("energy_dip".to_string(), 1.0 - lowest / e0),
        ("stable_time_step".to_string(), stable),
        ("transfer_loss".to_string(), transfer_loss / e0),
    ];
    Ok(Outcome {
        problem: "two_disks".to_string(),
        cells,
        cell_size: 1.0 / cells as f64,
        metrics,
        histories: h.into_iter().collect(),
        steps: sim.steps(),
        seconds,
    })
}
