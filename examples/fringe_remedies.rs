//! The consistent mass at a body's fringe: the remedies compared on stability, accuracy and cost.
//!
//! ```text
//! cargo run --release --example fringe_remedies
//! ```
//!
//! For each stabilisation of the consistent mass (none, ghost penalty with three weights, partial
//! lumping with three thresholds, the linear-extension penalty with three weights), with the
//! consistent mass in both solves:
//! - the stable step of the update (FLIP, MUSL) at rest, in units of h/c, on a filled block and on
//!   a disk whose edge particles have just crossed a grid line (the fringe);
//! - a disk translating across grid lines for 600 steps: the largest deviation of the grid
//!   velocity from the rigid velocity (0 in exact arithmetic);
//! - the vibrating bar with both ends fixed (25 cells): the period error (lumped +0.20%,
//!   consistent −0.079%: docs/mass.md);
//! - the shipped two-disk scene (linear and quadratic B-splines): the total energy at the end and
//!   its largest excursion, relative to the initial kinetic energy;
//! - the cost: wall time per step of the two-disk scene on a 4× finer grid.

use std::f64::consts::PI;
use std::time::Instant;

use sparse_mpm::boundary::{BoundaryCondition, Condition};
use sparse_mpm::mass::{MassOptions, MassScheme, Stabilization};
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep};
use sparse_mpm::{Grid, Particles, ShapeFunction};

const E: f64 = 1000.0;
const RHO: f64 = 1000.0;

fn material() -> Material {
    Material::LinearElastic(LinearElastic::new(E, 0.3, PlaneCondition::Strain).unwrap())
}

fn options(mass: MassOptions, time_step: TimeStep) -> Options {
    Options {
        mass,
        time_step,
        ..Options::default()
    }
}

/// Particles at the quarter points of 0.05 cells inside `inside`, shifted by `shift` cells.
fn particles(inside: impl Fn(f64, f64) -> bool, shift: [f64; 2], v: [f64; 2]) -> Particles {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..60 {
        for i in 0..60 {
            let (px, py) = ((i as f64 + 0.5) * 0.025, (j as f64 + 0.5) * 0.025);
            if inside(px, py) {
                x.push(px + shift[0] * 0.05);
                y.push(py + shift[1] * 0.05);
            }
        }
    }
    let n = x.len();
    let vol = 0.025 * 0.025;
    Particles::new(x, y, vec![RHO * vol; n], vec![vol; n])
        .and_then(|p| p.with_velocity(vec![v[0]; n], vec![v[1]; n]))
        .unwrap()
}

fn simulation(p: Particles, mass: MassOptions, time_step: TimeStep) -> sparse_mpm::Result<Simulation> {
    let grid = Grid::new([0.0, 0.0], [0.05, 0.05], [30, 30])?;
    let bodies = vec![Body {
        name: "body".into(),
        material: material(),
    }];
    Simulation::new(grid, p, bodies, options(mass, time_step))
}

/// Stable step at rest in units of h/c, block and fringe disk.
fn stable_steps(mass: MassOptions) -> [f64; 2] {
    let c = material().wave_speed(RHO);
    let block = particles(
        |x, y| (0.5..1.0).contains(&x) && (0.5..1.0).contains(&y),
        [0.0; 2],
        [0.0; 2],
    );
    let disk = particles(|x, y| (x - 0.75f64).hypot(y - 0.75) < 0.2, [0.26, 0.1], [0.0; 2]);
    [block, disk].map(|p| {
        simulation(p, mass, TimeStep::Cfl { number: 1.0 }).map_or(f64::NAN, |s| s.stable_time_step() * c / 0.05)
    })
}

/// Largest |w − v| over 600 steps of a translating disk, or the step it failed at.
fn rigid_deviation(mass: MassOptions) -> String {
    let v = [0.037, 0.021];
    let disk = particles(|x, y| (x - 0.5f64).hypot(y - 0.5) < 0.2, [0.0; 2], v);
    let Ok(mut sim) = simulation(disk, mass, TimeStep::Cfl { number: 0.5 }) else {
        return "not started".into();
    };
    let mut worst = 0.0f64;
    for step in 1..=600 {
        if sim.step().is_err() {
            return format!("failed at step {step}");
        }
        let (w, m) = (sim.grid_velocity(), sim.lumped_mass());
        for i in (0..m.len()).filter(|&i| m[i] > 0.0) {
            worst = worst.max((w.x[i] - v[0]).abs()).max((w.y[i] - v[1]).abs());
        }
    }
    format!("{worst:.1e}")
}

/// Period error of the fixed–fixed bar (25 cells of h = 1, E = 100, ρ = 1, T = 5), in per cent.
fn bar_period_error(mass: MassOptions) -> f64 {
    let cells = 25;
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [cells, 1]).unwrap();
    let (mut x, mut y, mut vx) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..2 * cells {
        for j in 0..2 {
            let px = (i as f64 + 0.5) / 2.0;
            x.push(px);
            y.push((j as f64 + 0.5) / 2.0);
            vx.push(0.1 * (PI * px / 25.0).sin());
        }
    }
    let n = x.len();
    let p = Particles::new(x, y, vec![0.25; n], vec![0.25; n])
        .and_then(|p| p.with_velocity(vx, vec![0.0; n]))
        .unwrap();
    let ends: Vec<usize> = (0..2)
        .flat_map(|j| [grid.node_index(0, j), grid.node_index(cells, j)])
        .collect();
    let mut o = options(mass, TimeStep::Cfl { number: 0.2 });
    o.boundaries = vec![
        BoundaryCondition::nodes(ends, Condition::Fixed),
        BoundaryCondition::nodes((0..grid.num_nodes()).collect(), Condition::Velocity).with_velocity(None, Some(0.0)),
    ];
    let bar = Material::LinearElastic(LinearElastic::new(100.0, 0.0, PlaneCondition::Stress).unwrap());
    let bodies = vec![Body {
        name: "bar".into(),
        material: bar,
    }];
    let Ok(mut sim) = Simulation::new(grid, p, bodies, o) else {
        return f64::NAN;
    };
    let total = sim.particles().total_mass();
    let (mut t0, mut v0) = (0.0, f64::NAN);
    let mut crossings = Vec::new();
    let run = sim.run_until(11.0, |s, r| {
        let v = r.momentum[0] / total;
        if v0.is_finite() && (v0 > 0.0) != (v > 0.0) {
            crossings.push(t0 + (s.time() - t0) * v0 / (v0 - v));
        }
        (t0, v0) = (s.time(), v);
        Ok(())
    });
    if run.is_err() || crossings.len() < 2 {
        return f64::NAN;
    }
    let period = 2.0 * (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    100.0 * (period / 5.0 - 1.0)
}

/// The shipped two-disk scene with `mass`, `shape` and `refine` times finer cells: energy at the
/// end and largest excursion (% of the initial kinetic energy), and seconds per step.
fn two_disks(mass: MassOptions, shape: ShapeFunction, refine: usize) -> (String, f64) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/two_disks.toml");
    let mut scene = Scene::load(std::path::Path::new(path)).unwrap();
    scene.schemes.mass = mass;
    scene.schemes.shape = shape;
    let pad = shape.recommended_padding() as f64;
    let h = 0.05 / refine as f64;
    scene.grid.cell_size = [h, h];
    scene.grid.origin = [-pad * h, -pad * h];
    let cells = 20 * refine + 2 * shape.recommended_padding();
    scene.grid.cells = [cells, cells];
    let mut sim = match scene.build() {
        Ok(s) => s,
        Err(e) => return (format!("{e}").chars().take(30).collect(), f64::NAN),
    };
    let (mut first, mut last, mut worst) = (None, 0.0, 0.0f64);
    let clock = Instant::now();
    let result = sim.run_until(scene.time.end, |_, r| {
        let (e0, k0) = *first.get_or_insert((r.total_energy, r.kinetic_energy));
        last = (r.total_energy - e0) / k0;
        worst = worst.max(last.abs());
        Ok(())
    });
    let per_step = clock.elapsed().as_secs_f64() / sim.steps().max(1) as f64;
    match result {
        Ok(()) => (format!("{:+.2}% / {:.1}%", 100.0 * last, 100.0 * worst), per_step),
        Err(_) => (format!("failed at t = {:.2}", sim.time()), per_step),
    }
}

fn main() {
    let consistent = |stabilization| MassOptions {
        stabilization,
        ..MassOptions::both(MassScheme::Consistent)
    };
    let rows = [
        ("lumped", MassOptions::both(MassScheme::Lumped)),
        ("consistent, none", consistent(Stabilization::None)),
        (
            "ghost γ = 0.01",
            consistent(Stabilization::GhostPenalty { gamma: 0.01 }),
        ),
        ("ghost γ = 0.1", consistent(Stabilization::GhostPenalty { gamma: 0.1 })),
        ("ghost γ = 1", consistent(Stabilization::GhostPenalty { gamma: 1.0 })),
        (
            "lumping θ = 0.25",
            consistent(Stabilization::PartialLumping { threshold: 0.25 }),
        ),
        (
            "lumping θ = 0.5",
            consistent(Stabilization::PartialLumping { threshold: 0.5 }),
        ),
        (
            "lumping θ = 1",
            consistent(Stabilization::PartialLumping { threshold: 1.0 }),
        ),
        (
            "extension γ = 0.1",
            consistent("linear_extension:0.1:0.5".parse().unwrap()),
        ),
        (
            "extension γ = 0.3",
            consistent("linear_extension:0.3:0.5".parse().unwrap()),
        ),
        ("extension γ = 1", consistent("linear_extension:1:0.5".parse().unwrap())),
    ];
    println!("consistent mass in both solves (FLIP, MUSL); stable steps in h/c at rest\n");
    println!(
        "{:<18} {:>7} {:>7} {:>16} {:>9} {:>22} {:>22} {:>9}",
        "mass", "block", "fringe", "rigid |w - v|", "bar T err", "two disks linear", "two disks quadratic", "ms/step"
    );
    for (label, mass) in rows {
        let [block, fringe] = stable_steps(mass);
        let rigid = rigid_deviation(mass);
        let bar = bar_period_error(mass);
        let (linear, _) = two_disks(mass, ShapeFunction::Linear, 1);
        let (quadratic, _) = two_disks(mass, ShapeFunction::QuadraticBSpline, 1);
        let (_, cost) = two_disks(mass, ShapeFunction::Linear, 4);
        println!(
            "{label:<18} {block:>7.3} {fringe:>7.3} {rigid:>16} {:>8.4}% {linear:>22} {quadratic:>22} {:>9.2}",
            bar,
            1e3 * cost
        );
    }
    println!("\ntwo disks: total energy at the end / largest excursion, % of the initial kinetic energy");
}
