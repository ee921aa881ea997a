//! The consistent mass on the cases that decide whether it can be trusted, for every
//! stabilisation: a rigid rotation, cantilevers one and two cells thick, and (with
//! `ONLY_FALL=1`) the benchmark's random block falling into a box at a Courant number of 0.9.
//!
//! ```text
//! cargo run --release --example trust_cases [-- <stabilisation> ...]
//! ONLY_FALL=1 cargo run --release --example trust_cases -- linear_extension:0.3:0.5
//! ```

use sparse_mpm::bench::{falling_block, BenchSpec};
use sparse_mpm::mass::{MassOptions, MassScheme, Stabilization};
use sparse_mpm::simulation::{TimeStep, Transfer, UpdateScheme, DEFAULT_STABILITY_INTERVAL};
use sparse_mpm::ShapeFunction;
use sparse_mpm_study::verification::{cantilever, rotation, Choices};

/// The choices of every case: `shape`, FLIP, MUSL, the consistent mass in both solves under
/// `stabilization` (or the lumped mass for `None`).
fn choices(shape: ShapeFunction, stabilization: Option<Stabilization>) -> Choices {
    let mass = match stabilization {
        None => MassOptions::both(MassScheme::Lumped),
        Some(stabilization) => MassOptions {
            stabilization,
            ..MassOptions::both(MassScheme::Consistent)
        },
    };
    Choices {
        shape,
        mass,
        transfer: Transfer::Flip,
        update: UpdateScheme::Musl,
        ..Choices::default()
    }
}

fn label(stabilization: Option<Stabilization>) -> String {
    stabilization.map_or("lumped".into(), |s| s.to_string())
}

/// The falling block (1,024 particles) at a Courant number of 0.9 for 2,000 steps: the steps
/// run, the failure if any, and the largest total-energy rise over the initial kinetic plus
/// potential energy.
fn random_fall(shape: ShapeFunction, mass: MassScheme, stabilization: Stabilization) -> (usize, String, f64) {
    let spec = BenchSpec {
        shape,
        mass,
        stabilization,
        transfer: Transfer::Flip,
        update: UpdateScheme::Musl,
        ..BenchSpec::default()
    };
    let mut sim = match falling_block(1024, &spec, TimeStep::Cfl { number: 0.9 }, DEFAULT_STABILITY_INTERVAL) {
        Ok(s) => s,
        Err(e) => return (0, e.to_string(), 0.0),
    };
    let (mut start, mut worst) = (None, 0.0f64);
    for k in 0..2000 {
        match sim.step() {
            Ok(r) => {
                let (e, s) = *start.get_or_insert((r.total_energy, r.kinetic_energy + r.potential_energy.abs()));
                worst = worst.max((r.total_energy - e) / s);
            }
            Err(err) => return (k, err.to_string(), worst),
        }
    }
    (2000, String::new(), worst)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let names = if args.is_empty() {
        vec!["partial_lumping:0.5", "ghost_penalty:0.1", "linear_extension:0.3:0.5"]
    } else {
        args.iter().map(String::as_str).collect()
    };
    let stabs: Vec<Stabilization> = names.iter().map(|s| s.parse().expect("a stabilisation")).collect();
    let shapes = [ShapeFunction::Linear, ShapeFunction::QuadraticBSpline];
    if std::env::var("ONLY_FALL").is_ok() {
        println!("# random falling block, CFL 0.9, 2000 steps: steps, energy gain");
        for shape in shapes {
            let mut runs = vec![(MassScheme::Lumped, Stabilization::default())];
            for &st in &stabs {
                runs.push((MassScheme::Consistent, st));
                runs.push(("cg".parse().unwrap(), st));
            }
            runs.push(("series:8".parse().unwrap(), Stabilization::default()));
            runs.push(("series:32".parse().unwrap(), Stabilization::default()));
            for (mass, st) in runs {
                let (k, err, gain) = random_fall(shape, mass, st);
                println!(
                    "{:<18} {:<12} {:<26} steps {k:<5} gain {gain:+.4} {err}",
                    shape.to_string(),
                    mass.to_string(),
                    st.to_string()
                );
            }
        }
        return;
    }
    let runs: Vec<Option<Stabilization>> = std::iter::once(None).chain(stabs.iter().copied().map(Some)).collect();
    println!("# spinning disk (20 cells), one revolution, FLIP MUSL: |dL|/L, max strain/KE0");
    for shape in shapes {
        for &st in &runs {
            match rotation::spinning_disk(20, &choices(shape, st)) {
                Ok(o) => println!(
                    "{:<18} {:<26} dL {:.4}  strain {:.2e}",
                    shape.to_string(),
                    label(st),
                    o.metric("angular_momentum_change").unwrap_or(f64::NAN),
                    o.metric("strain_energy_peak").unwrap_or(f64::NAN)
                ),
                Err(e) => println!("{:<18} {:<26} FAILED {e}", shape.to_string(), label(st)),
            }
        }
    }
    println!("# cantilever (quadratic B-splines): 4 cells along = 1 cell thick, 8 = 2 cells thick");
    for cells in [4usize, 8] {
        for &st in &runs {
            match cantilever::run(cells, &choices(ShapeFunction::QuadraticBSpline, st)) {
                Ok(o) => println!(
                    "cells {cells:<3} {:<26} largest tip deflection {:.3}  steps {}",
                    label(st),
                    o.metric("tip_deflection").unwrap_or(f64::NAN),
                    o.steps
                ),
                Err(e) => println!("cells {cells:<3} {:<26} FAILED {e}", label(st)),
            }
        }
    }
}
