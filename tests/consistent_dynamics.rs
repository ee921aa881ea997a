//! The consistent mass in the time loop: with the default fringe stabilisation a body whose edge
//! crosses grid lines stays stable and accurate; the vibrating bar keeps the consistent mass's
//! error; one FLIP rule in both code paths; XPIC(1) and FMPM(1) are PIC.

use std::f64::consts::PI;

use sparse_mpm::boundary::BoundaryCondition;
use sparse_mpm::boundary::Condition;
use sparse_mpm::mass::{Constraints, MassOptions, MassScheme, Stabilization};
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};
use sparse_mpm::step::{explicit_step, PositionUpdate, StepOptions};
use sparse_mpm::{Grid, Particles, ShapeFunction};

/// Round-off allowance, relative to the scale of the quantity, after a thousand steps.
const ROUND_OFF: f64 = 1e-9;

fn consistent() -> MassOptions {
    MassOptions::both(MassScheme::Consistent)
}

/// A disk of radius 0.2 on 0.05 cells, 2 × 2 particles per cell, whose outermost particles start
/// a quarter cell from a grid line, translating at `v` with no forces.
fn translating_disk(shape: ShapeFunction, v: [f64; 2]) -> Simulation {
    let grid = Grid::new([0.0, 0.0], [0.05, 0.05], [30, 30]).unwrap();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..60 {
        for i in 0..60 {
            let (px, py) = ((i as f64 + 0.5) * 0.025, (j as f64 + 0.5) * 0.025);
            if (px - 0.5f64).hypot(py - 0.5) < 0.2 {
                x.push(px);
                y.push(py);
            }
        }
    }
    let n = x.len();
    let particles = Particles::new(x, y, vec![1000.0 * 0.025 * 0.025; n], vec![0.025 * 0.025; n])
        .and_then(|p| p.with_velocity(vec![v[0]; n], vec![v[1]; n]))
        .unwrap();
    let options = Options {
        shape,
        mass: consistent(),
        // With linear kernels under FLIP the stable step is half the frozen limit: 0.9 of it
        // there (0.5 otherwise), so that the disk crosses more than five grid lines in the
        // steps below and stays on the grid.
        time_step: TimeStep::Cfl {
            number: if shape == ShapeFunction::Linear { 0.9 } else { 0.45 },
        },
        ..Options::default()
    };
    let material = Material::LinearElastic(LinearElastic::new(1.0e3, 0.3, PlaneCondition::Strain).unwrap());
    let bodies = vec![Body {
        name: "disk".into(),
        material,
    }];
    Simulation::new(grid, particles, bodies, options).unwrap()
}

#[test]
fn a_disk_translating_across_grid_lines_stays_rigid_with_the_stabilised_consistent_mass() {
    let v = [0.037, 0.021];
    for shape in [ShapeFunction::Linear, ShapeFunction::QuadraticBSpline] {
        let mut sim = translating_disk(shape, v);
        let start = sim.particles();
        let (mut x0, mut y0) = (vec![0.0; start.len()], vec![0.0; start.len()]);
        for k in 0..start.len() {
            (x0[start.id[k]], y0[start.id[k]]) = (start.x[k], start.y[k]);
        }
        let kinetic = 0.5 * sim.particles().total_mass() * (v[0] * v[0] + v[1] * v[1]);
        let mut crossed = 0.0;
        for step in 0..1200 {
            let r = sim.step().unwrap();
            crossed = sim.time() * v[0] / 0.05;
            assert!(
                r.strain_energy <= ROUND_OFF * kinetic,
                "{}: step {step}: strain energy {:e} against kinetic {kinetic:e}",
                shape.name(),
                r.strain_energy
            );
            let (w, m) = (sim.grid_velocity(), sim.lumped_mass());
            let deviation = (0..m.len())
                .filter(|&i| m[i] > 0.0)
                .map(|i| (w.x[i] - v[0]).abs().max((w.y[i] - v[1]).abs()))
                .fold(0.0, f64::max);
            assert!(
                deviation <= ROUND_OFF * v[0],
                "{}: step {step}: grid velocity deviates by {deviation:e}",
                shape.name()
            );
        }
        assert!(
            crossed > 5.0,
            "{}: the disk must cross several grid lines ({crossed} cells)",
            shape.name()
        );
        let t = sim.time();
        let p = sim.particles();
        let drift = (0..p.len())
            .map(|k| {
                (p.x[k] - x0[p.id[k]] - v[0] * t)
                    .abs()
                    .max((p.y[k] - y0[p.id[k]] - v[1] * t).abs())
            })
            .fold(0.0, f64::max);
        assert!(
            drift < 1e-9,
            "{}: particles drift {drift:e} from the rigid motion",
            shape.name()
        );
    }
}

/// The shipped two-disk scene with the consistent mass in both solves and `shape`, run to its end:
/// the largest |E(t) − E(0)| / KE(0) after the impact, at the end.
fn two_disks_energy_error(shape: &str, mass: &str) -> f64 {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/two_disks.toml")).unwrap();
    let padded = shape != "linear";
    let text = text
        .replace("shape = \"linear\"", &format!("shape = \"{shape}\""))
        .replace(
            "mass = { velocity = \"lumped\", acceleration = \"lumped\" }",
            &format!("mass = {{ velocity = \"{mass}\", acceleration = \"{mass}\" }}"),
        )
        .replace(
            "origin = [0.0, 0.0]",
            if padded {
                "origin = [-0.05, -0.05]"
            } else {
                "origin = [0.0, 0.0]"
            },
        )
        .replace(
            "cells = [20, 20]",
            if padded { "cells = [22, 22]" } else { "cells = [20, 20]" },
        );
    let scene = Scene::from_toml_str(&text).unwrap();
    let mut sim = scene.build().unwrap();
    let mut first = None;
    let mut last = 0.0;
    sim.run_until(scene.time.end, |_, r| {
        first.get_or_insert((r.total_energy, r.kinetic_energy));
        last = r.total_energy;
        Ok(())
    })
    .unwrap();
    let (e0, k0) = first.unwrap();
    (last - e0).abs() / k0
}

#[test]
fn the_two_disks_run_to_the_end_with_the_consistent_mass_and_keep_their_energy() {
    for shape in ["linear", "quadratic_bspline"] {
        let error = two_disks_energy_error(shape, "consistent");
        assert!(
            error < 0.03,
            "{shape}: total energy off by {:.2}% of the initial kinetic energy",
            100.0 * error
        );
    }
}

/// Period of the fixed–fixed bar (E = 100, ρ = 1, L = 25, first mode) on `cells` cells with the
/// consistent mass in both solves, relative error against T = 5.
fn bar_period_error(cells: usize, stabilization: Stabilization) -> f64 {
    let (length, c) = (25.0, 10.0);
    let h = length / cells as f64;
    let grid = Grid::new([0.0, 0.0], [h, h], [cells, 1]).unwrap();
    let (mut x, mut y, mut vx) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..2 * cells {
        for j in 0..2 {
            let px = (i as f64 + 0.5) * h / 2.0;
            x.push(px);
            y.push((j as f64 + 0.5) * h / 2.0);
            vx.push(0.1 * (PI * px / length).sin());
        }
    }
    let n = x.len();
    let v = h * h / 4.0;
    let particles = Particles::new(x, y, vec![v; n], vec![v; n])
        .and_then(|p| p.with_velocity(vx, vec![0.0; n]))
        .unwrap();
    let ends: Vec<usize> = (0..2)
        .flat_map(|j| [grid.node_index(0, j), grid.node_index(cells, j)])
        .collect();
    let options = Options {
        mass: MassOptions {
            stabilization,
            ..consistent()
        },
        time_step: TimeStep::Cfl { number: 0.2 },
        boundaries: vec![
            BoundaryCondition::nodes(ends, Condition::Fixed),
            BoundaryCondition::nodes((0..grid.num_nodes()).collect(), Condition::Velocity)
                .with_velocity(None, Some(0.0)),
        ],
        sort_interval: 0,
        ..Options::default()
    };
    let material = Material::LinearElastic(LinearElastic::new(100.0, 0.0, PlaneCondition::Stress).unwrap());
    let bodies = vec![Body {
        name: "bar".into(),
        material,
    }];
    let mut sim = Simulation::new(grid, particles, bodies, options).unwrap();
    let mass = sim.particles().total_mass();
    let (mut t_prev, mut v_prev) = (0.0, f64::NAN);
    let mut crossings = Vec::new();
    let period = 2.0 * length / c;
    sim.run_until(2.2 * period, |s, r| {
        let v = r.momentum[0] / mass;
        if v_prev.is_finite() && (v_prev > 0.0) != (v > 0.0) {
            crossings.push(t_prev + (s.time() - t_prev) * v_prev / (v_prev - v));
        }
        (t_prev, v_prev) = (s.time(), v);
        Ok(())
    })
    .unwrap();
    let measured = 2.0 * (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    measured / period - 1.0
}

#[test]
fn the_vibrating_bar_keeps_the_consistent_mass_error_sign_and_second_order() {
    let errors: Vec<f64> = [10, 20, 40]
        .iter()
        .map(|&cells| bar_period_error(cells, Stabilization::default()))
        .collect();
    for e in &errors {
        assert!(*e < 0.0, "the consistent mass shortens the period: errors {errors:?}");
    }
    for w in errors.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!((1.7..2.3).contains(&order), "order {order} from errors {errors:?}");
    }
    // The stabilisation changes the error by far less than the error itself.
    let plain = bar_period_error(20, Stabilization::None);
    assert!(
        (errors[1] - plain).abs() < 0.05 * plain.abs(),
        "{} vs plain {plain}",
        errors[1]
    );
}

/// An 8-cell bar with both ends fixed and rollers, stepped by the time loop (USL, FLIP) and by
/// `explicit_step`: the particle velocities after 40 steps.
fn bar_velocities_by_both_paths(mass: MassOptions) -> (Vec<f64>, Vec<f64>) {
    let cells = 8;
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [cells, 1]).unwrap();
    let (mut x, mut y, mut vx) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..2 * cells {
        for j in 0..2 {
            let px = (i as f64 + 0.5) / 2.0;
            x.push(px);
            y.push((j as f64 + 0.5) / 2.0);
            vx.push(1e-3 * (PI * px / cells as f64).sin());
        }
    }
    let n = x.len();
    let particles = Particles::new(x, y, vec![0.25; n], vec![0.25; n])
        .and_then(|p| p.with_velocity(vx, vec![0.0; n]))
        .unwrap();
    let ends: Vec<usize> = (0..2)
        .flat_map(|j| [grid.node_index(0, j), grid.node_index(cells, j)])
        .collect();
    let all: Vec<usize> = (0..grid.num_nodes()).collect();
    let (dt, steps) = (0.01, 40);
    let material = LinearElastic::new(100.0, 0.0, PlaneCondition::Stress).unwrap();
    // The single step.
    let mut p = particles.clone();
    let options = StepOptions {
        dt,
        mass,
        constraints: Constraints {
            fixed_x: ends.clone(),
            fixed_y: all.clone(),
        },
        position_update: PositionUpdate::GridVelocity,
        ..StepOptions::default()
    };
    for _ in 0..steps {
        explicit_step(&grid, &mut p, &material, &options).unwrap();
    }
    // The time loop.
    let options = Options {
        update: UpdateScheme::Usl,
        transfer: Transfer::Flip,
        mass,
        time_step: TimeStep::Fixed { dt },
        boundaries: vec![
            BoundaryCondition::nodes(ends, Condition::Fixed),
            BoundaryCondition::nodes(all, Condition::Velocity).with_velocity(None, Some(0.0)),
        ],
        sort_interval: 0,
        ..Options::default()
    };
    let bodies = vec![Body {
        name: "bar".into(),
        material: Material::LinearElastic(material),
    }];
    let mut sim = Simulation::new(grid, particles, bodies, options).unwrap();
    for _ in 0..steps {
        sim.step().unwrap();
    }
    (p.vx, sim.particles().vx.clone())
}

#[test]
fn the_flip_rule_is_the_same_in_the_time_loop_and_the_single_step_for_every_mass_pair() {
    let lumped = MassScheme::Lumped;
    let consistent = MassScheme::Consistent;
    for (velocity, acceleration) in [
        (lumped, lumped),
        (consistent, consistent),
        (lumped, consistent),
        (consistent, lumped),
    ] {
        let mass = MassOptions {
            velocity,
            acceleration,
            ..MassOptions::both(lumped)
        };
        let (single, looped) = bar_velocities_by_both_paths(mass);
        let scale = single.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let diff = single
            .iter()
            .zip(&looped)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            diff <= 1e-8 * scale,
            "{:#} / {:#}: the two paths differ by {diff:e} (scale {scale:e})",
            velocity,
            acceleration
        );
    }
}

#[test]
fn xpic_1_and_fmpm_1_give_pic_velocities_and_fmpm_1_is_pic_with_the_trapezoidal_rule() {
    let run = |transfer, position_update| {
        let mut sim = translating_disk(ShapeFunction::Linear, [0.0, 0.0]);
        let mut options = sim.options().clone();
        options.transfer = transfer;
        options.mass = MassOptions::both(MassScheme::Lumped);
        options.position_update = position_update;
        options.time_step = TimeStep::Fixed { dt: 1e-3 };
        // A disk with a velocity field that is not rigid, so that PIC's filter matters.
        let mut p = sim.particles().clone();
        for k in 0..p.len() {
            p.vx[k] = 0.1 * (7.0 * p.y[k]).sin();
            p.vy[k] = 0.05 * (5.0 * p.x[k]).cos();
        }
        sim = Simulation::new(sim.grid().clone(), p, sim.bodies().to_vec(), options).unwrap();
        for _ in 0..30 {
            sim.step().unwrap();
        }
        sim.particles().clone()
    };
    let pic = run(Transfer::Pic, PositionUpdate::Trapezoidal);
    let fmpm = run(Transfer::Fmpm { k: 1 }, PositionUpdate::GridVelocity);
    let diff = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    assert!(
        diff(&pic.vx, &fmpm.vx) < 1e-14 && diff(&pic.x, &fmpm.x) < 1e-14,
        "FMPM(1) is PIC + trapezoidal"
    );
    // XPIC(1): PIC's velocity update; its own position rule. Compare one step from the same state.
    let one = |transfer| {
        let mut sim = translating_disk(ShapeFunction::Linear, [0.0, 0.0]);
        let mut options = sim.options().clone();
        options.transfer = transfer;
        options.mass = MassOptions::both(MassScheme::Lumped);
        options.time_step = TimeStep::Fixed { dt: 1e-3 };
        let mut p = sim.particles().clone();
        for k in 0..p.len() {
            p.vx[k] = 0.1 * (7.0 * p.y[k]).sin();
        }
        sim = Simulation::new(sim.grid().clone(), p, sim.bodies().to_vec(), options).unwrap();
        sim.step().unwrap();
        sim.particles().clone()
    };
    let (pic, xpic) = (one(Transfer::Pic), one(Transfer::Xpic { k: 1 }));
    assert!(diff(&pic.vx, &xpic.vx) < 1e-15 && diff(&pic.vy, &xpic.vy) < 1e-15);
    assert!(diff(&pic.x, &xpic.x) > 0.0, "XPIC(1) moves particles by its own rule");
}

/// Nairn's two-disk impact (examples/fmpm_disks.rs) on `cells` cells: total energy lost by
/// t = 6, relative to the initial.
fn nairn_disks_energy_loss(cells: usize, transfer: &str) -> f64 {
    let h = 1.0 / cells as f64;
    let body = |x: f64, v: f64| {
        format!(
            "[[bodies]]\nname = \"disk at {x}\"\nmaterial = {{ model = \"neo_hookean\", youngs_modulus = 1000.0, \
             poisson_ratio = 0.33 }}\ndensity = 1000.0\nparticles_per_cell = 2\nvelocity = [{v}, 0.0]\n\
             geometry = {{ disk = {{ center = [{x}, 0.5], radius = 0.2 }} }}\n"
        )
    };
    let text = format!(
        "[grid]\ncell_size = [{h}, {h}]\ncells = [{cells}, {cells}]\n[schemes]\nshape = {{ gimp = {{ half_width = \
         0.25 }} }}\nupdate = \"usl\"\ntransfer = {transfer}\n[time]\nend = 6.0\ncfl = 0.2\n{}{}",
        body(0.29, 0.0061),
        body(0.71, -0.0061)
    );
    let mut sim = Scene::from_toml_str(&text).unwrap().build().unwrap();
    let mut first = None;
    let mut last = 0.0;
    sim.run_until(6.0, |_, r| {
        first.get_or_insert(r.total_energy);
        last = r.total_energy;
        Ok(())
    })
    .unwrap();
    let e0 = first.unwrap();
    (e0 - last) / e0
}

#[test]
fn fmpm_energy_loss_on_the_two_disks_falls_with_k_and_does_not_grow_under_refinement() {
    let ks = [4, 8, 16];
    let losses: Vec<Vec<f64>> = [20, 40]
        .iter()
        .map(|&cells| {
            ks.iter()
                .map(|k| nairn_disks_energy_loss(cells, &format!("{{ fmpm = {{ k = {k} }} }}")))
                .collect()
        })
        .collect();
    for (cells, row) in [20, 40].iter().zip(&losses) {
        assert!(row.iter().all(|&l| l > 0.0), "{cells} cells: FMPM dissipates, {row:?}");
        assert!(
            row.windows(2).all(|w| w[1] < w[0]),
            "{cells} cells: loss falls with k {ks:?}: {row:?}"
        );
    }
    for (k, (coarse, fine)) in ks.iter().zip(losses[0].iter().zip(&losses[1])) {
        assert!(
            fine < coarse,
            "FMPM({k}): loss {fine} on 40 cells against {coarse} on 20"
        );
    }
}
