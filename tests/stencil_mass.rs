//! The consistent mass in stencil form equals the general sparse product `N diag(m) Nᵀ`,
//! its partial lumping equals the CSC one, its product equals the CSC product, and the
//! conjugate gradient on it solves the same systems as a Cholesky factorization.

use sparse_mpm::mass::stabilization::partially_lumped;
use sparse_mpm::mass::{lumped_mass, Constraints, GridMass, MassOptions, MassScheme, Role, Stabilization, StencilMass};
use sparse_mpm::operators::weighted_product;
use sparse_mpm::transfer::VectorField;
use sparse_mpm::{Grid, NodeOrder, Operator, Operators, Particles, ShapeFunction};

const SHAPES: [ShapeFunction; 4] = [
    ShapeFunction::Linear,
    ShapeFunction::Gimp { half_width: 0.25 },
    ShapeFunction::QuadraticBSpline,
    ShapeFunction::CubicBSpline,
];

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A disk of random particles (so its edge cuts cells at every fraction) in a 14 × 11 grid,
/// with random masses.
fn disk(order: NodeOrder, shape: ShapeFunction, seed: u64) -> (Operators, Vec<f64>) {
    let grid = Grid::new([0.0, 0.0], [0.5, 0.4], [14, 11])
        .unwrap()
        .with_node_order(order);
    let mut rng = Rng(seed);
    let (mut x, mut y, mut m) = (vec![], vec![], vec![]);
    while x.len() < 500 {
        let (px, py) = (1.0 + 5.0 * rng.next(), 0.9 + 2.6 * rng.next());
        if (px - 3.5).powi(2) / 6.25 + (py - 2.2).powi(2) / 1.69 < 1.0 {
            x.push(px);
            y.push(py);
            m.push(0.5 + rng.next());
        }
    }
    let np = x.len();
    let particles = Particles::new(x, y, m.clone(), vec![0.01; np]).unwrap();
    (Operators::assemble(&grid, shape, &particles).unwrap(), m)
}

fn max_difference(a: &nalgebra_sparse::CscMatrix<f64>, b: &nalgebra_sparse::CscMatrix<f64>) -> f64 {
    let (da, db) = (nalgebra::DMatrix::from(a), nalgebra::DMatrix::from(b));
    (da - db).abs().max()
}

#[test]
fn stencil_mass_equals_the_compressed_column_product_for_every_kernel_and_node_order() {
    for order in [NodeOrder::XFastest, NodeOrder::YFastest] {
        for shape in SHAPES {
            let (ops, m) = disk(order, shape, 7);
            // The independent reference: the general sparse product N diag(m) Nᵀ.
            let csc = weighted_product(&ops, Operator::N, Operator::N, &m);
            let stencil = StencilMass::assemble(&ops, &m);
            let scale = csc.values().iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let converted = stencil.to_csc();
            assert_eq!(converted.nnz(), csc.nnz(), "{shape:?} {order:?}: same pattern");
            assert_eq!(converted.row_indices(), csc.row_indices(), "{shape:?} {order:?}");
            assert!(max_difference(&converted, &csc) < 1e-14 * scale, "{shape:?} {order:?}");
            // The product, against the CSC product, on a vector with every node set.
            let mut rng = Rng(3);
            let x: Vec<f64> = (0..ops.num_nodes()).map(|_| rng.next() - 0.5).collect();
            let y = stencil.mul(&x);
            let d = nalgebra::DMatrix::from(&csc) * nalgebra::DVector::from_vec(x.clone());
            for i in 0..x.len() {
                assert!((y[i] - d[i]).abs() < 1e-13 * scale, "{shape:?} {order:?} row {i}");
            }
            // Partial lumping as the CSC routine does it, at two thresholds.
            let lumped = lumped_mass(&ops, &m);
            for threshold in [0.5, 1.0] {
                let mut s = stencil.clone();
                s.partially_lump(&lumped, threshold);
                let reference = partially_lumped(&csc, &lumped, threshold);
                let diff = max_difference(&s.to_csc(), &reference);
                assert!(diff < 1e-14 * scale, "{shape:?} {order:?} θ = {threshold}: {diff:e}");
            }
        }
    }
}

/// With node numbers along x the assembly adds runs of adjacent rows; along y it takes the
/// general loop. Both add the same products in particle order, so the two matrices agree to the
/// bit once the nodes are renumbered.
#[test]
fn the_runs_along_x_give_the_bits_of_the_general_loop() {
    let nodes = [15usize, 12];
    let along_y = |i: usize| (i % nodes[0]) * nodes[1] + i / nodes[0];
    for shape in SHAPES {
        let (ops_x, m) = disk(NodeOrder::XFastest, shape, 11);
        let (ops_y, _) = disk(NodeOrder::YFastest, shape, 11);
        let a = nalgebra::DMatrix::from(&StencilMass::assemble(&ops_x, &m).to_csc());
        let b = nalgebra::DMatrix::from(&StencilMass::assemble(&ops_y, &m).to_csc());
        let mut nonzero = 0;
        for i in 0..a.nrows() {
            for j in 0..a.ncols() {
                let (u, v) = (a[(i, j)], b[(along_y(i), along_y(j))]);
                assert_eq!(u.to_bits(), v.to_bits(), "{shape:?}: M[{i}][{j}] {u:e} against {v:e}");
                nonzero += usize::from(u != 0.0);
            }
        }
        assert!(nonzero > 500, "{shape:?}: {nonzero} couplings compared");
    }
}

#[test]
fn conjugate_gradient_on_the_stencil_form_matches_the_cholesky_solve_with_walls() {
    for shape in SHAPES {
        let (ops, m) = disk(NodeOrder::XFastest, shape, 11);
        let n = ops.num_nodes();
        // Fix x on two columns of nodes the disk touches, y on one row.
        let grid = ops.grid().unwrap().clone();
        let fixed_x: Vec<usize> = (0..n).filter(|&i| matches!(grid.node_ij(i).0, 4 | 9)).collect();
        let fixed_y: Vec<usize> = (0..n).filter(|&i| grid.node_ij(i).1 == 5).collect();
        let constraints = Constraints { fixed_x, fixed_y };
        let mut rng = Rng(5);
        let r = VectorField {
            x: (0..n).map(|_| rng.next() - 0.5).collect(),
            y: (0..n).map(|_| rng.next() - 0.5).collect(),
        };
        let prescribed = VectorField {
            x: vec![0.3; n],
            y: vec![-0.2; n],
        };
        // Partial lumping keeps the stencil's pattern; the default penalty widens it by the
        // couplings two nodes apart along a line. Both run on the stencil form; the ghost
        // penalty on compressed columns.
        for (stabilization, on_stencil) in [
            ("partial_lumping:0.5".parse().unwrap(), true),
            (Stabilization::default(), true),
            ("ghost_penalty:0.1".parse().unwrap(), false),
        ] {
            let solve = |scheme: MassScheme| {
                let options = MassOptions {
                    stabilization,
                    ..MassOptions::both(scheme)
                };
                let mass = GridMass::new(&ops, &m, &options, &constraints).unwrap();
                let (u, report) = mass.solve(Role::Velocity, &r, Some(&prescribed), &ops).unwrap();
                (u, report, mass.stencil().is_some())
            };
            let (direct, _, direct_stencil) = solve(MassScheme::Consistent);
            let (cg, report, cg_stencil) = solve(MassScheme::Iterative {
                tolerance: 1e-13,
                max_iterations: 2000,
            });
            assert!(
                !direct_stencil && cg_stencil == on_stencil,
                "{shape:?}, {stabilization}: the CG runs on the stencil form: {cg_stencil}"
            );
            assert!(report.iterations > 3, "{shape:?}: it iterated");
            let scale = direct.x.iter().chain(&direct.y).fold(0.0f64, |a, v| a.max(v.abs()));
            for i in 0..n {
                for (a, b) in [(direct.x[i], cg.x[i]), (direct.y[i], cg.y[i])] {
                    assert!(
                        (a - b).abs() < 1e-8 * scale,
                        "{shape:?}, {stabilization} node {i}: {a} vs {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn a_second_solve_starts_from_the_first_and_needs_fewer_iterations() {
    let (ops, m) = disk(NodeOrder::XFastest, ShapeFunction::QuadraticBSpline, 2);
    let n = ops.num_nodes();
    let scheme = MassScheme::Iterative {
        tolerance: 1e-12,
        max_iterations: 1000,
    };
    let mut rng = Rng(9);
    let r = VectorField {
        x: (0..n).map(|_| rng.next()).collect(),
        y: (0..n).map(|_| rng.next()).collect(),
    };
    // On the stencil form (partial lumping) the recurrence's residual is the true one to the
    // last digits: the same system again is solved on arrival. With the default penalty the
    // true residual of the first solution is a little above the recurrence's: a few iterations.
    for (stabilization, again) in [("partial_lumping:0.5", 0), ("linear_extension", 40)] {
        let options = MassOptions {
            stabilization: stabilization.parse().unwrap(),
            ..MassOptions::both(scheme)
        };
        let mut mass = GridMass::new(&ops, &m, &options, &Constraints::none()).unwrap();
        let (mut u1, mut u2) = (VectorField::default(), VectorField::default());
        let first = mass.solve_warm_into(Role::Velocity, &r, None, &ops, &mut u1).unwrap();
        let second = mass.solve_warm_into(Role::Velocity, &r, None, &ops, &mut u2).unwrap();
        assert!(first.iterations > 10);
        assert!(
            second.iterations <= again && second.iterations * 5 < first.iterations,
            "{stabilization}: {} iterations, then {}",
            first.iterations,
            second.iterations
        );
        if again == 0 {
            assert_eq!(u1.x, u2.x);
        }
    }
}

/// A large body (where the factorization uses supernodal storage) plus one lone particle far
/// from it: the lone particle's four nodes have a rank-one mass, and the direct solve names one
/// of them.
#[test]
fn a_singular_node_is_named_by_the_direct_solve_of_a_large_mass_matrix() {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [170, 170]).unwrap();
    let g = 0.5 / 3f64.sqrt();
    let (mut x, mut y) = (vec![], vec![]);
    for cj in 2..150 {
        for ci in 2..150 {
            for (a, b) in [(-g, -g), (g, -g), (-g, g), (g, g)] {
                x.push(ci as f64 + 0.5 + a);
                y.push(cj as f64 + 0.5 + b);
            }
        }
    }
    x.push(160.3);
    y.push(160.6);
    let np = x.len();
    let particles = Particles::new(x, y, vec![1.0; np], vec![0.25; np]).unwrap();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &particles).unwrap();
    let lone: Vec<usize> = [(160, 160), (161, 160), (160, 161), (161, 161)]
        .iter()
        .map(|&(i, j)| grid.node_index(i, j))
        .collect();
    let result = GridMass::new(
        &ops,
        &particles.mass,
        &MassOptions::plain(MassScheme::Consistent),
        &Constraints::none(),
    );
    match result {
        Err(sparse_mpm::MpmError::SingularMassMatrix { node, particles, .. }) => {
            assert!(
                lone.contains(&node),
                "node {node} is not one of the lone particle's {lone:?}"
            );
            assert_eq!(particles, vec![np - 1]);
        }
        other => panic!("expected a singular mass matrix, got {other:?}"),
    }
    // Without the lone particle the same body factorizes.
    let body = Particles::new(
        particles.x[..np - 1].to_vec(),
        particles.y[..np - 1].to_vec(),
        vec![1.0; np - 1],
        vec![0.25; np - 1],
    )
    .unwrap();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &body).unwrap();
    let options = MassOptions::plain(MassScheme::Consistent);
    assert!(GridMass::new(&ops, &body.mass, &options, &Constraints::none()).is_ok());
}

/// The time loop's velocity solve starts from the last updated grid velocity, which is the next
/// projection but for the particles' motion: for a body falling freely (uniform velocity, the
/// penalty zero on it) the projection then needs no iteration, where a start from the last
/// projection needed about 30 (the acceleration then needs none either).
#[test]
fn a_freely_falling_body_is_projected_from_its_updated_velocity_without_iterations() {
    use sparse_mpm::bench::{falling_block, BenchSpec};
    use sparse_mpm::simulation::{TimeStep, Transfer};
    let spec = BenchSpec {
        shape: ShapeFunction::Linear,
        transfer: Transfer::Flip,
        mass: MassScheme::Iterative {
            tolerance: 1e-10,
            max_iterations: 1000,
        },
        ..BenchSpec::default()
    };
    let mut sim = falling_block(4096, &spec, TimeStep::Cfl { number: 0.9 }, 100).unwrap();
    // The first solves start from the lumped solution, exact for a uniform field.
    sim.step().unwrap();
    for _ in 0..5 {
        let r = sim.step().unwrap();
        assert_eq!(
            (r.velocity_solve.iterations, r.acceleration_solve.iterations),
            (0, 0),
            "step {}: {:?} {:?}",
            r.step,
            r.velocity_solve,
            r.acceleration_solve
        );
    }
}
