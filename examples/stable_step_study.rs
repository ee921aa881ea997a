//! The stable step between estimates on the benchmark's random falling block.
//!
//! ```text
//! cargo run --release --example stable_step_study -- run SHAPE MASS CFL INTERVAL PARTICLES STEPS [TRANSFER [UPDATE]]
//! cargo run --release --example stable_step_study -- drift SHAPE MASS CFL PARTICLES STEPS
//! cargo run --release --example stable_step_study -- exact SHAPE MASS PARTICLES STEPS
//! cargo run --release --example stable_step_study -- policy SHAPE MASS PARTICLES STEPS EVERY
//! ```
//!
//! (`SEED=k` sets the seed of the positions.) `run`: the block at `CFL` of the reported stable step, estimated every `INTERVAL` steps;
//! prints the step of a failure (or the end), the largest total energy over the first and the
//! estimates made. `drift`: the same with an estimate at every step, and for each window of
//! 100 steps the smallest stable step relative to the one at the window's start (how far the
//! highest frequency rises between two estimates 100 steps apart). `exact`: every 25 steps,
//! the estimate against the exact `ω²_max` from a dense eigen-solve (small problems only).
//! `policy`: the block at 0.9 of the reported step with the default schedule; every `EVERY`
//! steps the step taken and the reported stable step against the exact FLIP limit `2/ω_max`
//! of the configuration the step was taken on (dense), and their smallest and largest ratios.

use nalgebra::{DMatrix, SymmetricEigen};
use sparse_mpm::bench::{falling_block, BenchSpec};
use sparse_mpm::mass::{consistent_mass, MassScheme, Role};
use sparse_mpm::simulation::{Simulation, TimeStep, Transfer, UpdateScheme};
use sparse_mpm::stiffness::apply_tangent_stiffness;
use sparse_mpm::transfer::VectorField;
use sparse_mpm::{Particles, ShapeFunction};

fn arg<T: std::str::FromStr>(args: &[String], i: usize, default: &str) -> T
where
    T::Err: std::fmt::Debug,
{
    args.get(i).map_or(default, String::as_str).parse().expect("argument")
}

fn spec(args: &[String], shape: usize, mass: usize, transfer: usize) -> BenchSpec {
    BenchSpec {
        shape: arg::<ShapeFunction>(args, shape, "linear"),
        mass: arg::<MassScheme>(args, mass, "consistent"),
        transfer: arg::<Transfer>(args, transfer, "flip"),
        update: arg::<UpdateScheme>(args, transfer + 1, "musl"),
        seed: std::env::var("SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1),
        ..BenchSpec::default()
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("run") => run(&args),
        Some("drift") => drift(&args),
        Some("exact") => exact(&args),
        Some("policy") => policy(&args),
        _ => eprintln!("usage: stable_step_study run|drift|exact|policy …"),
    }
}

fn run(args: &[String]) {
    let spec = spec(args, 1, 2, 7);
    let (cfl, interval): (f64, usize) = (arg(args, 3, "0.9"), arg(args, 4, "100"));
    let (n, steps): (usize, usize) = (arg(args, 5, "1024"), arg(args, 6, "2000"));
    let mut sim = falling_block(n, &spec, TimeStep::Cfl { number: cfl }, interval).expect("problem");
    let mut first = None;
    let mut largest = f64::NEG_INFINITY;
    let mut estimates = 0;
    let mut last_at = usize::MAX;
    for _ in 0..steps {
        match sim.step() {
            Ok(r) => {
                let e = r.total_energy;
                let e0 = *first.get_or_insert(e);
                largest = largest.max((e - e0) / e0.abs());
                if let Some((_, at)) = sim.frequency_estimate() {
                    if at != last_at {
                        estimates += 1;
                        last_at = at;
                    }
                }
            }
            Err(e) => {
                println!(
                    "{} {} cfl {cfl}: failed at step {}: {e}",
                    spec.shape,
                    spec.mass,
                    sim.steps()
                );
                return;
            }
        }
    }
    println!(
        "{} {} cfl {cfl}: {steps} steps, t = {:.4}, total energy first {:.4e}, largest rise {:+.2}%, {estimates} estimates",
        spec.shape,
        spec.mass,
        sim.time(),
        first.unwrap_or(0.0),
        100.0 * largest
    );
}

fn drift(args: &[String]) {
    let spec = spec(args, 1, 2, 6);
    let cfl: f64 = arg(args, 3, "0.5");
    let (n, steps): (usize, usize) = (arg(args, 4, "1024"), arg(args, 5, "1000"));
    let mut sim = falling_block(n, &spec, TimeStep::Cfl { number: cfl }, 1).expect("problem");
    let mut worst = 1.0f64;
    let (mut start, mut low) = (0.0, f64::INFINITY);
    for s in 0..steps {
        let r = match sim.step() {
            Ok(r) => r,
            Err(e) => {
                println!("failed at step {s}: {e}");
                break;
            }
        };
        let wave = wave_step(&sim);
        if s % 100 == 0 {
            if s > 0 {
                println!(
                    "steps {:4}–{:4}: smallest wave step / first {:.3}",
                    s - 100,
                    s,
                    low / start
                );
                worst = worst.min(low / start);
            }
            (start, low) = (wave, wave);
        }
        low = low.min(wave);
        let _ = r;
    }
    println!("{} {}: worst ratio {worst:.3}", spec.shape, spec.mass);
}

/// `√2·2 / ω_max` without the particle-speed term (FLIP), from the last estimate.
fn wave_step(sim: &Simulation) -> f64 {
    let (e, _) = sim.frequency_estimate().expect("estimated");
    2.0 / e.omega_squared.sqrt()
}

fn exact(args: &[String]) {
    let spec = spec(args, 1, 2, 5);
    let (n, steps): (usize, usize) = (arg(args, 3, "256"), arg(args, 4, "400"));
    let mut sim = falling_block(n, &spec, TimeStep::Cfl { number: 0.5 }, 1).expect("problem");
    for s in 0..steps {
        let before = sim.particles().clone();
        if sim.step().is_err() {
            println!("failed at step {s}");
            return;
        }
        if s % 25 == 1 {
            let (e, lanczos) = sim.frequency_estimate().expect("estimated");
            let dense = dense_omega_squared(&sim, &before);
            println!(
                "step {s:4}: Lanczos ω² = {:.6e} ({:3} steps), dense {:.6e}, ratio {:.4}",
                e.omega_squared,
                e.lanczos_steps,
                dense,
                e.omega_squared / dense
            );
            let _ = lanczos;
        }
    }
}

fn policy(args: &[String]) {
    let spec = spec(args, 1, 2, 6);
    let (n, steps, every): (usize, usize, usize) = (arg(args, 3, "1024"), arg(args, 4, "400"), arg(args, 5, "10"));
    let interval = sparse_mpm::simulation::DEFAULT_STABILITY_INTERVAL;
    let mut sim = falling_block(n, &spec, TimeStep::Cfl { number: 0.9 }, interval).expect("problem");
    let (mut taken, mut reported) = ([f64::INFINITY, 0.0f64], [f64::INFINITY, 0.0f64]);
    for s in 0..steps {
        let before = sim.particles().clone();
        let r = match sim.step() {
            Ok(r) => r,
            Err(e) => {
                println!("failed at step {s}: {e}");
                return;
            }
        };
        if s % every != 0 {
            continue;
        }
        let limit = 2.0 / dense_omega_squared(&sim, &before).sqrt();
        let (t, p) = (r.dt / limit, r.stable_time_step / limit);
        taken = [taken[0].min(t), taken[1].max(t)];
        reported = [reported[0].min(p), reported[1].max(p)];
        println!("step {s:4}: step taken / exact limit {t:.3}, reported stable step / exact limit {p:.3}");
    }
    println!(
        "step taken / exact limit {:.3} to {:.3}; reported stable step / exact limit {:.3} to {:.3}",
        taken[0], taken[1], reported[0], reported[1]
    );
}

/// `λ_max(S K S M)` on the free degrees of freedom from dense matrices, with `S` the
/// simulation's acceleration solve, for the configuration `p` its grid mass was prepared for.
fn dense_omega_squared(sim: &Simulation, p: &Particles) -> f64 {
    let (ops, mass) = (sim.operators(), sim.grid_mass());
    let n = ops.num_nodes();
    let [fx, fy] = mass.free_dofs();
    let dofs: Vec<usize> = fx.iter().copied().chain(fy.iter().map(|&i| n + i)).collect();
    let f = dofs.len();
    let unit = |d: usize| {
        let mut r = VectorField::zeros(n);
        if d < n {
            r.x[d] = 1.0;
        } else {
            r.y[d - n] = 1.0;
        }
        r
    };
    let pick = |u: &VectorField, d: usize| if d < n { u.x[d] } else { u.y[d - n] };
    let mut s = DMatrix::<f64>::zeros(f, f);
    let mut k = DMatrix::<f64>::zeros(f, f);
    let tangent: Vec<[f64; 3]> = (0..p.len())
        .map(|q| {
            sim.bodies()[p.body[q]]
                .material
                .tangent([p.fxx[q], p.fxy[q], p.fyx[q], p.fyy[q]])
        })
        .collect();
    for (c, &j) in dofs.iter().enumerate() {
        let (u, _) = mass.solve(Role::Acceleration, &unit(j), None, ops).expect("solve");
        let ku = apply_tangent_stiffness(ops, &p.volume, &tangent, &unit(j));
        for (a, &i) in dofs.iter().enumerate() {
            s[(a, c)] = pick(&u, i);
            k[(a, c)] = pick(&ku, i);
        }
    }
    let m_full = consistent_mass(ops, &p.mass);
    let m = DMatrix::from_fn(f, f, |a, b| {
        let (i, j) = (dofs[a], dofs[b]);
        if (i < n) != (j < n) {
            return 0.0;
        }
        m_full.get_entry(i % n, j % n).map_or(0.0, |e| e.into_value())
    });
    let s = (&s + s.transpose()) * 0.5;
    let sms = &s * m * &s;
    let eig = SymmetricEigen::new((&k + k.transpose()) * 0.5);
    let root = &eig.eigenvectors
        * DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()))
        * eig.eigenvectors.transpose();
    let t = &root * sms * &root;
    SymmetricEigen::new((&t + t.transpose()) * 0.5).eigenvalues.max()
}
