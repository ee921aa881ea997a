//! The stable time step: the simulation's estimate against the exact limit of the update from a
//! dense eigen-solve, for every mass scheme; fixed steps above the limit refused, below it run.

use nalgebra::{DMatrix, SymmetricEigen};
use sparse_mpm::mass::{consistent_mass, Constraints, GridMass, MassOptions, MassScheme, Role, Stabilization};
use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep, Transfer};
use sparse_mpm::stiffness::{crossing_margin, stiffness_matrix};
use sparse_mpm::transfer::VectorField;
use sparse_mpm::{Grid, MpmError, Operators, Particles, ShapeFunction};

/// The estimate must lie on the safe side of the exact limit and within this fraction of it.
const WITHIN: f64 = 0.05;

fn material() -> LinearElastic {
    LinearElastic::new(1.0e3, 0.3, PlaneCondition::Strain).unwrap()
}

/// Particles at the quarter points of the cells whose centre lies inside `inside`, shifted by
/// `shift` cells.
fn particles(grid: &Grid, inside: impl Fn(f64, f64) -> bool, shift: [f64; 2]) -> Particles {
    let [h, _] = grid.cell_size();
    let [cx, cy] = grid.cells();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..2 * cy {
        for i in 0..2 * cx {
            let (px, py) = ((i as f64 + 0.5) * h / 2.0, (j as f64 + 0.5) * h / 2.0);
            if inside(px, py) {
                x.push(px + shift[0] * h);
                y.push(py + shift[1] * h);
            }
        }
    }
    let n = x.len();
    let v = h * h / 4.0;
    Particles::new(x, y, vec![v; n], vec![v; n]).unwrap()
}

/// A 10 × 10-cell block in a 16 × 16 grid.
fn block(grid: &Grid) -> Particles {
    particles(
        grid,
        |x, y| (3.0..13.0).contains(&x) && (3.0..13.0).contains(&y),
        [0.0, 0.0],
    )
}

/// A disk of radius 4.5 cells whose rightmost particles have just crossed a grid line.
fn disk(grid: &Grid) -> Particles {
    particles(grid, |x, y| (x - 8.0).hypot(y - 8.0) < 4.5, [0.26, 0.26 * 0.37])
}

/// The exact `ω²_max = λ_max(S K S M)` of the update with the mass inverse `S` of `options`
/// (both solves), from dense matrices on the active nodes, as the symmetric
/// `λ_max(K^½ (S M S) K^½)`.
fn exact_omega_squared(grid: &Grid, shape: ShapeFunction, p: &Particles, options: &MassOptions) -> f64 {
    let ops = Operators::assemble(grid, shape, p).unwrap();
    let mass = GridMass::new(&ops, &p.mass, options, &Constraints::none()).unwrap();
    let n = ops.num_nodes();
    let free: Vec<usize> = mass.active_nodes();
    let f = free.len();
    // S on the free nodes, one column per unit right-hand side (the same for x and y).
    let mut s = DMatrix::<f64>::zeros(f, f);
    for (c, &j) in free.iter().enumerate() {
        let mut r = VectorField::zeros(n);
        r.x[j] = 1.0;
        let (u, _) = mass.solve(Role::Acceleration, &r, None, &ops).unwrap();
        for (a, &i) in free.iter().enumerate() {
            s[(a, c)] = u.x[i];
        }
    }
    let s = (&s + s.transpose()) * 0.5;
    let m_full = consistent_mass(&ops, &p.mass);
    let m = DMatrix::from_fn(f, f, |a, b| {
        m_full.get_entry(free[a], free[b]).map_or(0.0, |e| e.into_value())
    });
    let sms = &s * m * &s;
    let k_full = stiffness_matrix(&ops, &p.volume, &material());
    let dof = |d: usize| if d < f { free[d] } else { n + free[d - f] };
    let k = DMatrix::from_fn(2 * f, 2 * f, |a, b| {
        k_full.get_entry(dof(a), dof(b)).map_or(0.0, |e| e.into_value())
    });
    let mut x = DMatrix::<f64>::zeros(2 * f, 2 * f);
    x.view_mut((0, 0), (f, f)).copy_from(&sms);
    x.view_mut((f, f), (f, f)).copy_from(&sms);
    let eig = SymmetricEigen::new((&k + k.transpose()) * 0.5);
    let root = &eig.eigenvectors
        * DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()))
        * eig.eigenvectors.transpose();
    let t = &root * x * &root;
    SymmetricEigen::new((&t + t.transpose()) * 0.5).eigenvalues.max()
}

fn simulation(
    grid: &Grid,
    shape: ShapeFunction,
    p: &Particles,
    mass: MassOptions,
    time_step: TimeStep,
) -> Result<Simulation, MpmError> {
    let options = Options {
        shape,
        mass,
        time_step,
        ..Options::default()
    };
    let bodies = vec![Body {
        name: "body".into(),
        material: Material::LinearElastic(material()),
    }];
    Simulation::new(grid.clone(), p.clone(), bodies, options)
}

fn schemes() -> Vec<MassOptions> {
    let mut out = vec![
        MassOptions::both(MassScheme::Lumped),
        MassOptions::both(MassScheme::Consistent),
        MassOptions {
            stabilization: Stabilization::GhostPenalty { gamma: 0.1 },
            ..MassOptions::both(MassScheme::Consistent)
        },
        MassOptions::both(MassScheme::Blended { gamma: 0.5 }),
    ];
    out.extend([2, 4, 8, 16, 32].map(|k| MassOptions::both(MassScheme::TruncatedSeries { k })));
    out
}

fn check_estimates(shape: ShapeFunction, body: fn(&Grid) -> Particles) {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [16, 16]).unwrap();
    let p = body(&grid);
    for mass in schemes() {
        let exact = 2.0 / exact_omega_squared(&grid, shape, &p, &mass).sqrt();
        let sim = simulation(&grid, shape, &p, mass, TimeStep::Cfl { number: 1.0 }).unwrap();
        // The frozen-configuration limit: the stable step less the margin for grid crossings.
        let estimate = sim.stable_time_step()
            / crossing_margin(shape, [mass.velocity, mass.acceleration], Transfer::Flip.flip_weight());
        let ratio = estimate / exact;
        println!(
            "{:<18} {:<14} {:<14} exact {exact:.4e}  estimate/exact {ratio:.4}",
            shape.name(),
            mass.acceleration,
            mass.stabilization
        );
        assert!(
            (1.0 - WITHIN..=1.0).contains(&ratio),
            "{} with {:#} / {:#}: estimate {estimate:.5e}, exact {exact:.5e} (ratio {ratio:.4})",
            shape.name(),
            mass.acceleration,
            mass.stabilization
        );
    }
}

#[test]
fn estimate_is_within_a_few_per_cent_below_the_exact_limit_on_a_block_linear() {
    check_estimates(ShapeFunction::Linear, block);
}

#[test]
fn estimate_is_within_a_few_per_cent_below_the_exact_limit_on_a_disk_at_a_fringe_linear() {
    check_estimates(ShapeFunction::Linear, disk);
}

#[test]
fn estimate_is_within_a_few_per_cent_below_the_exact_limit_on_a_disk_at_a_fringe_quadratic() {
    check_estimates(ShapeFunction::QuadraticBSpline, disk);
}

/// Energy after `steps` steps relative to the initial, for a small random velocity field.
fn energy_growth(sim: &mut Simulation, steps: usize) -> f64 {
    let mut first = None;
    let mut last = 0.0;
    for _ in 0..steps {
        match sim.step() {
            Ok(r) => {
                first.get_or_insert(r.total_energy);
                last = r.total_energy;
            }
            Err(_) => return f64::INFINITY,
        }
    }
    last / first.unwrap()
}

fn with_noise(mut p: Particles) -> Particles {
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-3
    };
    for k in 0..p.len() {
        p.vx[k] = next();
        p.vy[k] = next();
    }
    p
}

#[test]
fn a_fixed_step_above_the_exact_limit_is_refused_and_one_below_it_runs_stably() {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [16, 16]).unwrap();
    let shape = ShapeFunction::Linear;
    let p = with_noise(block(&grid));
    for mass in [
        MassOptions::both(MassScheme::Lumped),
        MassOptions::both(MassScheme::Consistent),
        MassOptions::both(MassScheme::TruncatedSeries { k: 8 }),
    ] {
        let exact = 2.0 / exact_omega_squared(&grid, shape, &p, &mass).sqrt();
        let label = format!("{:#}", mass.acceleration);
        match simulation(&grid, shape, &p, mass, TimeStep::Fixed { dt: 1.1 * exact }) {
            Err(MpmError::TimeStepAboveStable { dt, stable, .. }) => {
                assert!(stable < dt, "{label}: refused with stable {stable} ≥ dt {dt}")
            }
            other => panic!("{label}: a step 10% above the limit must be refused, got {other:?}"),
        }
        // The frozen limit is real: 5% below it (allowed: the stable step keeps a margin for
        // grid crossings below it, crossing_margin) the energy stays, 10% above it blows up.
        let allowed = |dt: f64| {
            let options = Options {
                shape,
                mass,
                time_step: TimeStep::Fixed { dt },
                allow_unstable_time_step: true,
                ..Options::default()
            };
            let bodies = vec![Body {
                name: "body".into(),
                material: Material::LinearElastic(material()),
            }];
            Simulation::new(grid.clone(), p.clone(), bodies, options).unwrap()
        };
        let growth = energy_growth(&mut allowed(0.95 * exact), 300);
        assert!(growth < 1.01, "{label}: 5% below the limit the energy grew by {growth}");
        let growth = energy_growth(&mut allowed(1.1 * exact), 300);
        assert!(
            growth > 10.0,
            "{label}: 10% above the limit the energy only grew by {growth}"
        );
    }
}
