//! The consistent mass on the cases that decide whether it can be trusted, for every
//! stabilisation: a rigid rotation, cantilevers one and two cells thick, and the exactness of the
//! projection of linear fields.
//!
//! ```text
//! cargo run --release --example trust_cases [-- <stabilisation> ...]
//! ```

use std::f64::consts::PI;

use sparse_mpm::mass::{MassOptions, MassScheme, Stabilization};
use sparse_mpm::material::{Material, NeoHookean};
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};
use sparse_mpm::verification::{cantilever, Choices};
use sparse_mpm::{Grid, Particles, ShapeFunction};

fn mass(scheme: MassScheme, stab: Stabilization) -> MassOptions {
    let mut m = MassOptions::both(scheme);
    m.stabilization = stab;
    m
}

/// A neo-Hookean disk (radius 0.3, centre (0.5, 0.5), 2 × 2 particles per cell on 0.05 cells)
/// spinning at ω = 1 rad/s; returns (|ΔL|/L after one revolution, max strain energy / KE0).
fn spinning_disk(shape: ShapeFunction, m: MassOptions) -> Result<(f64, f64), String> {
    let pad = shape.recommended_padding() as f64;
    let h = 0.05;
    let cells = 20 + 2 * pad as usize;
    let grid = Grid::new([-pad * h, -pad * h], [h, h], [cells, cells]).map_err(|e| e.to_string())?;
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..40 {
        for i in 0..40 {
            let (px, py) = ((i as f64 + 0.5) * 0.025, (j as f64 + 0.5) * 0.025);
            if (px - 0.5f64).hypot(py - 0.5) < 0.3 {
                x.push(px);
                y.push(py);
            }
        }
    }
    let n = x.len();
    let omega = 1.0;
    let vx: Vec<f64> = y.iter().map(|y| -omega * (y - 0.5)).collect();
    let vy: Vec<f64> = x.iter().map(|x| omega * (x - 0.5)).collect();
    let vol = 0.025 * 0.025;
    let particles = Particles::new(x, y, vec![1000.0 * vol; n], vec![vol; n])
        .and_then(|p| p.with_velocity(vx, vy))
        .map_err(|e| e.to_string())?;
    let options = Options {
        shape,
        mass: m,
        transfer: Transfer::Flip,
        update: UpdateScheme::Musl,
        time_step: TimeStep::Cfl { number: 0.5 },
        ..Options::default()
    };
    let material = Material::NeoHookean(NeoHookean {
        youngs_modulus: 1.0e4,
        poisson_ratio: 0.3,
    });
    let bodies = vec![Body {
        name: "disk".into(),
        material,
    }];
    let mut sim = Simulation::new(grid, particles, bodies, options).map_err(|e| e.to_string())?;
    let ang = |s: &Simulation| {
        let p = s.particles();
        (0..p.len())
            .map(|k| p.mass[k] * ((p.x[k] - 0.5) * p.vy[k] - (p.y[k] - 0.5) * p.vx[k]))
            .sum::<f64>()
    };
    let l0 = ang(&sim);
    let mut k0 = None;
    let mut worst = 0.0f64;
    sim.run_until(2.0 * PI / omega, |_, r| {
        let k = *k0.get_or_insert(r.kinetic_energy);
        worst = worst.max(r.strain_energy / k);
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    Ok(((ang(&sim) - l0).abs() / l0, worst))
}

struct SplitMix(u64);
impl SplitMix {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The benchmark's falling block (random layout, ~4 per cell, slip walls) on 32 cells at a
/// Courant number of 0.9: (steps run, failure, largest total-energy gain over E0's kinetic+potential scale).
fn random_fall(shape: ShapeFunction, m: MassOptions, steps: usize) -> (usize, Option<String>, f64) {
    use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge};
    let n_grid = 32;
    let h = 1.0 / n_grid as f64;
    let grid = Grid::new([0.0, 0.0], [h, h], [n_grid, n_grid]).unwrap();
    let mut rng = SplitMix(7);
    let n = 1024;
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for _ in 0..n {
        x.push(0.25 + 0.5 * rng.next());
        y.push(0.25 + 0.5 * rng.next());
    }
    let volume = 0.25 * h * h;
    let mut particles = Particles::new(x, y, vec![volume; n], vec![volume; n]).unwrap();
    particles.vy.iter_mut().for_each(|v| *v = -1.0);
    let bodies = vec![Body {
        name: "block".into(),
        material: Material::NeoHookean(NeoHookean {
            youngs_modulus: 400.0,
            poisson_ratio: 0.2,
        }),
    }];
    let boundaries = [Edge::Left, Edge::Right, Edge::Bottom, Edge::Top]
        .into_iter()
        .map(|edge| BoundaryCondition {
            layers: Some(3),
            ..BoundaryCondition::edge(edge, Condition::Slip)
        })
        .collect();
    let options = Options {
        shape,
        mass: m,
        transfer: Transfer::Flip,
        update: UpdateScheme::Musl,
        time_step: TimeStep::Cfl { number: 0.9 },
        gravity: [0.0, -9.8],
        boundaries,
        ..Options::default()
    };
    let mut sim = match Simulation::new(grid, particles, bodies, options) {
        Ok(s) => s,
        Err(e) => return (0, Some(e.to_string()), 0.0),
    };
    let mut e0 = None;
    let mut worst = 0.0f64;
    for k in 0..steps {
        match sim.step() {
            Ok(r) => {
                let (e, s) = *e0.get_or_insert((r.total_energy, r.kinetic_energy + r.potential_energy.abs()));
                worst = worst.max((r.total_energy - e) / s);
                if std::env::var("TRACE").is_ok() && k % 100 == 0 {
                    eprintln!(
                        "step {k} t {:.4} dt {:.3e} KE {:.4e} SE {:.4e} PE {:.4e} E {:.4e}",
                        r.time, r.dt, r.kinetic_energy, r.strain_energy, r.potential_energy, r.total_energy
                    );
                }
            }
            Err(err) => return (k, Some(err.to_string()), worst),
        }
    }
    (steps, None, worst)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let stabs: Vec<Stabilization> = if args.is_empty() {
        [
            "none",
            "partial_lumping:0.5",
            "ghost_penalty:0.1",
            "linear_extension:1:0.25",
        ]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect()
    } else {
        args.iter().map(|s| s.parse().unwrap()).collect()
    };
    let shapes = [ShapeFunction::Linear, ShapeFunction::QuadraticBSpline];
    if std::env::var("ONLY_FALL").is_ok() {
        println!("# random falling block, CFL 0.9, 2000 steps: steps, energy gain");
        for shape in shapes {
            let mut runs = vec![("lumped".to_string(), MassOptions::both(MassScheme::Lumped))];
            for &st in &stabs {
                runs.push((format!("consistent {st}"), mass(MassScheme::Consistent, st)));
                runs.push((format!("cg {st}"), mass("cg".parse().unwrap(), st)));
            }
            runs.push(("series:8".into(), MassOptions::both("series:8".parse().unwrap())));
            runs.push(("series:32".into(), MassOptions::both("series:32".parse().unwrap())));
            for (label, m) in runs {
                let (k, err, gain) = random_fall(shape, m, 2000);
                println!(
                    "{:<18} {label:<36} steps {k:<5} gain {gain:+.4} {}",
                    shape.to_string(),
                    err.unwrap_or_default()
                );
            }
        }
        return;
    }
    println!("# spinning disk, one revolution, FLIP MUSL: |dL|/L, max strain/KE0");
    for shape in shapes {
        match spinning_disk(shape, MassOptions::both(MassScheme::Lumped)) {
            Ok((dl, s)) => println!(
                "{:<18} lumped                 dL {dl:.4}  strain {s:.2e}",
                shape.to_string()
            ),
            Err(e) => println!("{:<18} lumped                 FAILED {e}", shape.to_string()),
        }
        for &st in &stabs {
            match spinning_disk(shape, mass(MassScheme::Consistent, st)) {
                Ok((dl, s)) => println!(
                    "{:<18} {:<22} dL {dl:.4}  strain {s:.2e}",
                    shape.to_string(),
                    st.to_string()
                ),
                Err(e) => println!("{:<18} {:<22} FAILED {e}", shape.to_string(), st.to_string()),
            }
        }
    }
    println!("# cantilever (quadratic, FLIP 0.99 MUSL): cells along 4 = 1 cell thick, 8 = 2 cells thick");
    let cells_list: Vec<usize> = std::env::var("CANT_CELLS")
        .map(|v| v.split(',').map(|c| c.parse().unwrap()).collect())
        .unwrap_or(vec![4, 8]);
    if std::env::var("ONLY_CANT").is_ok() {
        for cells in cells_list {
            let c = Choices {
                shape: ShapeFunction::QuadraticBSpline,
                ..Choices::default()
            };
            let o = cantilever::run(cells, &c).unwrap();
            let h = &o.histories[0];
            let peak = h.value.iter().cloned().fold(0.0, f64::max);
            let k = h.value.iter().position(|v| *v == peak).unwrap();
            println!("lumped cells {cells}: max {peak:.4} at t {:.3}", h.time[k]);
        }
        return;
    }
    for cells in cells_list {
        let base = Choices {
            shape: ShapeFunction::QuadraticBSpline,
            ..Choices::default()
        };
        let mut runs = vec![("lumped".to_string(), MassOptions::both(MassScheme::Lumped))];
        for &st in &stabs {
            runs.push((st.to_string(), mass(MassScheme::Consistent, st)));
        }
        for (label, m) in runs {
            let c = Choices { mass: m, ..base };
            match cantilever::run(cells, &c) {
                Ok(o) => {
                    let h = &o.histories[0];
                    // first swing: the largest deflection before it first comes back below 10% of it
                    let peak = h.value.iter().cloned().fold(0.0, f64::max);
                    let mut first = 0.0f64;
                    let mut t_first = 0.0;
                    for (t, v) in h.time.iter().zip(&h.value) {
                        if *v > first {
                            first = *v;
                            t_first = *t;
                        }
                        if first > 0.5 * peak && *v < 0.5 * first {
                            break;
                        }
                    }
                    println!("cells {cells:<3} {label:<24} first swing {first:.3} at t {t_first:.3}  max {peak:.3}  steps {}", o.steps)
                }
                Err(e) => println!("cells {cells:<3} {label:<24} FAILED {e}"),
            }
        }
    }
}
