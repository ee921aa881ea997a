//! Fields the grid represents exactly, which a consistent mass must keep: a neo-Hookean disk in
//! rigid rotation ([`spinning_disk`]) and the L2 projection of a rigid rotation onto the grid
//! from the particles of a strip one cell thick ([`strip_projection_error`]).
//!
//! A rigid rotation `v = ω × (x − c)` is linear, so it lies in the span of every kernel's
//! shape functions: the consistent projection `M v = N (m ∘ v_p)` reproduces it exactly at every
//! node with mass whenever the (stabilised) matrix keeps that property, the velocity gradient
//! at the particles is then the exact skew tensor, and no spurious strain arises. The lumped
//! projection smooths the field at a body's edge; the lost kinetic energy appears as strain
//! energy and the angular momentum decays.

use std::f64::consts::PI;
use std::time::Instant;

use super::{Choices, History, Outcome};
use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::mass::{Constraints, GridMass, Role};
use sparse_mpm::material::{Material, NeoHookean};
use sparse_mpm::operators::{Operator, Operators};
use sparse_mpm::particles::Particles;
use sparse_mpm::simulation::{Body, Simulation};
use sparse_mpm::transfer::VectorField;

/// Radius of the spinning disk.
pub const RADIUS: f64 = 0.3;
/// Its angular velocity (rad/s): one revolution takes 2π s.
pub const OMEGA: f64 = 1.0;

/// The disk of radius [`RADIUS`] centred at (0.5, 0.5) on `cells` cells across the unit square
/// (padded by the kernel's recommended cells), `particles_per_cell` per axis, density 1000,
/// neo-Hookean (E = 10⁴, ν = 0.3), spinning at [`OMEGA`] about its centre, for one
/// revolution. Metrics: `angular_momentum_change` (`|L(T) − L(0)| / L(0)` about the centre),
/// `strain_energy_peak` (largest strain energy over the initial kinetic energy).
///
/// # Errors
/// Those of [`Simulation::new`] and [`Simulation::step`].
pub fn spinning_disk(cells: usize, choices: &Choices) -> Result<Outcome> {
    let h = 1.0 / cells as f64;
    let pad = choices.shape.recommended_padding();
    let grid = Grid::new([-(pad as f64) * h; 2], [h, h], [cells + 2 * pad; 2])?;
    let n = choices.particles_per_cell.max(1);
    let spacing = h / n as f64;
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..cells * n {
        for i in 0..cells * n {
            let (px, py) = ((i as f64 + 0.5) * spacing, (j as f64 + 0.5) * spacing);
            if (px - 0.5).hypot(py - 0.5) < RADIUS {
                x.push(px);
                y.push(py);
            }
        }
    }
    let count = x.len();
    let vx = y.iter().map(|y| -OMEGA * (y - 0.5)).collect();
    let vy = x.iter().map(|x| OMEGA * (x - 0.5)).collect();
    let volume = spacing * spacing;
    let particles = Particles::new(x, y, vec![1000.0 * volume; count], vec![volume; count])?.with_velocity(vx, vy)?;
    let bodies = vec![Body {
        name: "disk".into(),
        material: Material::NeoHookean(NeoHookean {
            youngs_modulus: 1.0e4,
            poisson_ratio: 0.3,
        }),
    }];
    let mut sim = Simulation::new(grid, particles, bodies, choices.options(Vec::new()))?;
    let angular = |s: &Simulation| {
        let p = s.particles();
        (0..p.len())
            .map(|k| p.mass[k] * ((p.x[k] - 0.5) * p.vy[k] - (p.y[k] - 0.5) * p.vx[k]))
            .sum::<f64>()
    };
    let start = angular(&sim);
    let mut histories = ["angular_momentum", "strain_energy"].map(History::new);
    histories[0].push(0.0, start);
    let mut kinetic = None;
    let clock = Instant::now();
    sim.run_until(2.0 * PI / OMEGA, |s, r| {
        let k0 = *kinetic.get_or_insert(r.kinetic_energy);
        histories[0].push(r.time, angular(s));
        histories[1].push(r.time, r.strain_energy / k0);
        Ok(())
    })?;
    let seconds = clock.elapsed().as_secs_f64();
    let peak = histories[1].value.iter().copied().fold(0.0, f64::max);
    Ok(Outcome {
        problem: "spinning_disk".into(),
        cells,
        cell_size: 1.0 / cells as f64,
        metrics: vec![
            ("angular_momentum_change".into(), (angular(&sim) - start).abs() / start),
            ("strain_energy_peak".into(), peak),
        ],
        histories: histories.into_iter().collect(),
        steps: sim.steps(),
        seconds,
    })
}

/// The consistent projection (the velocity solve of `choices.mass`) of a rigid rotation onto
/// a 16 × 16 grid of unit cells from a strip one cell thick and ten long (two particles across,
/// `2 × 2` per cell): the largest nodal error over the nodes with mass, relative to the largest
/// nodal speed,
///
/// ```text
/// e = max_I |u_I − ω × (x_I − c)| / max_I |ω × (x_I − c)|,   M_s u = N (m ∘ v_p)
/// ```
///
/// Zero to round-off for a stabilisation that keeps linear fields; the one metric of the
/// returned outcome is `projection_error`.
///
/// # Errors
/// Those of [`Operators::assemble`] and [`GridMass::new`] (a singular matrix).
pub fn strip_projection_error(choices: &Choices) -> Result<Outcome> {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [16, 16])?;
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for i in 0..20 {
        for j in 0..2 {
            x.push(3.0 + (i as f64 + 0.5) / 2.0);
            y.push(7.0 + (j as f64 + 0.5) / 2.0);
        }
    }
    let count = x.len();
    let rotation = |x: f64, y: f64| [-0.7 * (y - 7.5), 0.7 * (x - 8.0)];
    let particles = Particles::new(x.clone(), y.clone(), vec![0.25; count], vec![0.25; count])?;
    let ops = Operators::assemble(&grid, choices.shape, &particles)?;
    let mass = GridMass::new(&ops, &particles.mass, &choices.mass, &Constraints::none())?;
    let (px, py): (Vec<f64>, Vec<f64>) = (0..count)
        .map(|p| {
            let [a, b] = rotation(x[p], y[p]);
            (0.25 * a, 0.25 * b)
        })
        .unzip();
    let mut rhs = VectorField::zeros(ops.num_nodes());
    ops.scatter(Operator::N, [&px, &py], [&mut rhs.x, &mut rhs.y]);
    let (u, _) = mass.solve(Role::Velocity, &rhs, None, &ops)?;
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for i in mass.active_nodes() {
        let [gx, gy] = grid.node_position(i);
        let exact = rotation(gx, gy);
        scale = scale.max(exact[0].hypot(exact[1]));
        worst = worst.max((u.x[i] - exact[0]).hypot(u.y[i] - exact[1]));
    }
    Ok(Outcome {
        problem: "strip_projection".into(),
        cells: 1,
        cell_size: 1.0,
        metrics: vec![("projection_error".into(), worst / scale)],
        histories: Vec::new(),
        steps: 0,
        seconds: 0.0,
    })
}
