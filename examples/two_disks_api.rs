//! The two-disk impact built in Rust instead of a scene file, run with the time loop, and the
//! energy history compared with the start.
//!
//! ```text
//! cargo run --release --example two_disks_api
//! ```
//!
//! The same pieces a scene file describes (grid, particles with a body index, bodies with
//! materials, options) go straight into `Simulation::new`.

use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};
use sparse_mpm::{Grid, Particles, ShapeFunction};

// Sulsky, Chen & Schreyer (1994): E = 1000, ν = 0.3, ρ = 1000, disks of radius 0.2 at ±0.1 m/s.
const E: f64 = 1000.0;
const NU: f64 = 0.3;
const RHO: f64 = 1000.0;
const H: f64 = 0.05;
const PPC: usize = 2;
const END: f64 = 3.5;

fn main() -> Result<(), sparse_mpm::MpmError> {
    let grid = Grid::new([0.0, 0.0], [H, H], [20, 20])?;
    let mut particles = Particles::default();
    for (body, (center, v)) in [([0.2, 0.2], 0.1), ([0.8, 0.8], -0.1)].into_iter().enumerate() {
        let filled = disk(center, 0.2)?;
        let n = filled.len();
        let mut disk = filled.with_velocity(vec![v; n], vec![v; n])?;
        disk.body = vec![body; n];
        particles.append(disk)?;
    }
    let material = Material::LinearElastic(LinearElastic {
        youngs_modulus: E,
        poisson_ratio: NU,
        plane: PlaneCondition::Strain,
    });
    let bodies = vec![
        Body {
            name: "lower left".into(),
            material,
        },
        Body {
            name: "upper right".into(),
            material,
        },
    ];
    let options = Options {
        shape: ShapeFunction::Linear,
        update: UpdateScheme::Musl,
        transfer: Transfer::Flip,
        time_step: TimeStep::Cfl { number: 0.5 },
        ..Options::default()
    };
    let mut sim = Simulation::new(grid, particles, bodies, options)?;
    let e0 = sim.particles().kinetic_energy();
    println!("{} particles; initial kinetic energy {e0:.6}", sim.particles().len());
    println!("{:>8} {:>12} {:>12} {:>12}", "t", "kinetic", "strain", "total/E0");
    let mut next = 0.0;
    let (mut lowest, mut highest) = (f64::INFINITY, 0.0f64);
    sim.run_until(END, |_, r| {
        let total = r.kinetic_energy + r.strain_energy;
        lowest = lowest.min(total / e0);
        highest = highest.max(total / e0);
        if r.time >= next {
            println!(
                "{:8.3} {:12.6} {:12.6} {:12.6}",
                r.time,
                r.kinetic_energy,
                r.strain_energy,
                total / e0
            );
            next += 0.25;
        }
        Ok(())
    })?;
    println!(
        "{} steps; total energy stayed within [{lowest:.4}, {highest:.4}] of the initial kinetic energy",
        sim.steps()
    );
    Ok(())
}

/// Particles filling a disk, `PPC × PPC` per cell on the grid's sub-lattice.
fn disk(center: [f64; 2], radius: f64) -> Result<Particles, sparse_mpm::MpmError> {
    let d = H / PPC as f64;
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..(1.0 / d) as usize {
        for i in 0..(1.0 / d) as usize {
            let (px, py) = ((i as f64 + 0.5) * d, (j as f64 + 0.5) * d);
            if (px - center[0]).hypot(py - center[1]) < radius {
                x.push(px);
                y.push(py);
            }
        }
    }
    let n = x.len();
    Particles::new(x, y, vec![RHO * d * d; n], vec![d * d; n])
}
