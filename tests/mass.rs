//! Lumped and consistent mass, conservation of the particle → grid transfers, the
//! consistent-mass solve and its singularity diagnostics.

mod common;

use common::*;
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use sparse_mpm::mass::{
    active_nodes, consistent_mass, lumped_mass, mark_active, ConsistentMassSolver, ConsistentSolveOptions, Constraints,
    GridMass, MassOptions, MassScheme, Role, SolveOutcome, DEFAULT_ACTIVE_MASS_TOLERANCE,
};
use sparse_mpm::transfer::{external_force, internal_force, momentum, VectorField};
use sparse_mpm::{Grid, MpmError, NodeOrder, Operators, Particles, ShapeFunction};

/// Sums of O(100) products of weights ≤ 1 and masses ≤ 2, compared with sums taken in another
/// order: the rounding is a few ulps of the total (≤ ~300), so 1e-12 relative to the total
/// mass is generous; a missing or doubled particle would be off by ≥ 0.5.
const MASS_SUM_REL_TOL: f64 = 1e-12;
/// Entrywise agreement of M with the dense N diag(m) Nᵀ, relative to the largest entry.
const MASS_MATRIX_REL_TOL: f64 = 1e-13;
/// The smallest eigenvalue of a PSD matrix computed in floating point can be a rounding-level
/// negative number: allow −1e-12 relative to the largest eigenvalue.
const PSD_REL_TOL: f64 = 1e-12;
/// Singular values below this fraction of the largest count as zero in the rank test.
/// Rank-deficient mass matrices here have exact null vectors, so their "zero" singular values
/// are ~1e-16 relative; well-posed ones have their smallest above ~1e-4 relative.
const RANK_REL_TOL: f64 = 1e-10;
/// A backward-stable Cholesky solve leaves a residual of a few ulps times ‖M‖‖x‖; with the
/// conditioning of these well-posed mass matrices (≲ 1e3) 1e-12 relative to ‖f‖ leaves margin.
const RESIDUAL_REL_TOL: f64 = 1e-12;
/// Agreement of the sparse and the dense solve: both have relative error ≲ cond(M) ε ≈ 1e-13.
const SOLUTION_REL_TOL: f64 = 1e-10;

fn ops_of(grid: &Grid, p: &Particles) -> Operators {
    Operators::assemble(grid, ShapeFunction::Linear, p).unwrap()
}

/// Dense consistent mass `N diag(m) Nᵀ` from the reference N.
fn dense_mass(grid: &Grid, p: &Particles) -> DMatrix<f64> {
    let n = ref_operators(grid, &p.x, &p.y).n;
    &n * DMatrix::from_diagonal(&dvec(&p.mass)) * n.transpose()
}

fn restrict(m: &DMatrix<f64>, nodes: &[usize]) -> DMatrix<f64> {
    m.select_rows(nodes.iter()).select_columns(nodes.iter())
}

fn rank(m: &DMatrix<f64>) -> usize {
    let sv = m.singular_values();
    let max = sv.max();
    sv.iter().filter(|&&s| s > RANK_REL_TOL * max).count()
}

/// Nodes with any lumped mass, from the dense reference (the library's default tolerance only
/// drops nodes lighter than 1e-12 of the heaviest, which never happens in these fixtures).
fn reference_active(grid: &Grid, p: &Particles) -> Vec<usize> {
    let m_l = ref_operators(grid, &p.x, &p.y).n * dvec(&p.mass);
    (0..m_l.len()).filter(|&i| m_l[i] > 0.0).collect()
}

fn well_posed_grid(order: NodeOrder) -> Grid {
    Grid::new([-0.5, 1.0], [0.5, 0.25], [4, 3])
        .unwrap()
        .with_node_order(order)
}

/// Random configurations: the test grids with random particles (including grid lines and the
/// boundary), and `k × k` jittered particles per cell.
fn configurations() -> Vec<(Grid, Particles)> {
    let mut out = Vec::new();
    for (g, grid) in test_grids().into_iter().enumerate() {
        let p = random_particles(&grid, 80, 1000 + g as u64);
        out.push((grid, p));
    }
    for (k, order) in [(2, NodeOrder::XFastest), (3, NodeOrder::YFastest)] {
        let grid = well_posed_grid(order);
        let (x, y) = positions_per_cell(&grid, k, 0.3, 1100 + k as u64);
        out.push((grid, random_particles_at(x, y, 1110 + k as u64)));
    }
    out
}

#[test]
fn lumped_mass_equals_row_sums_of_consistent_mass() {
    for (grid, p) in configurations() {
        let ops = ops_of(&grid, &p);
        let m_l = lumped_mass(&ops, &p.mass);
        let m = DMatrix::from(&consistent_mass(&ops, &p.mass));
        let tol = MASS_SUM_REL_TOL * p.total_mass();
        for i in 0..m_l.len() {
            let row_sum: f64 = m.row(i).sum();
            assert!(
                (m_l[i] - row_sum).abs() <= tol,
                "node {i}: m_L = {}, Σ_J M_IJ = {row_sum}",
                m_l[i]
            );
        }
    }
}

#[test]
fn lumped_mass_equals_dense_n_times_m() {
    for (grid, p) in configurations() {
        let ops = ops_of(&grid, &p);
        let expected = ref_operators(&grid, &p.x, &p.y).n * dvec(&p.mass);
        let diff = max_abs_diff_slice(&lumped_mass(&ops, &p.mass), expected.as_slice());
        assert!(diff <= MASS_SUM_REL_TOL * p.total_mass(), "off by {diff} on {grid:?}");
    }
}

#[test]
fn consistent_mass_equals_dense_n_diag_m_n_transpose() {
    for (grid, p) in configurations() {
        let ops = ops_of(&grid, &p);
        let sparse = consistent_mass(&ops, &p.mass);
        assert_eq!(
            (sparse.nrows(), sparse.ncols()),
            (ref_num_nodes(&grid), ref_num_nodes(&grid))
        );
        let m = DMatrix::from(&sparse);
        let expected = dense_mass(&grid, &p);
        let diff = max_abs_diff(&m, &expected);
        assert!(
            diff <= MASS_MATRIX_REL_TOL * max_abs(&expected),
            "off by {diff} on {grid:?}"
        );
    }
}

#[test]
fn consistent_mass_is_symmetric_in_pattern_and_values() {
    for (grid, p) in configurations() {
        let ops = ops_of(&grid, &p);
        let sparse = consistent_mass(&ops, &p.mass);
        let mut pattern: Vec<(usize, usize)> = sparse.triplet_iter().map(|(i, j, _)| (i, j)).collect();
        let mut transposed: Vec<(usize, usize)> = pattern.iter().map(|&(i, j)| (j, i)).collect();
        pattern.sort_unstable();
        transposed.sort_unstable();
        assert_eq!(pattern, transposed, "pattern of M is not symmetric");
        let m = DMatrix::from(&sparse);
        let diff = max_abs_diff(&m, &m.transpose());
        assert!(diff <= MASS_MATRIX_REL_TOL * max_abs(&m), "‖M − Mᵀ‖ = {diff}");
    }
}

#[test]
fn consistent_mass_is_positive_semi_definite() {
    let mut all = configurations();
    // Also rank-deficient ones, where eigenvalues sit at zero.
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [3, 3]).unwrap();
    let (x, y) = positions_per_cell(&grid, 1, 0.3, 1200);
    all.push((grid, random_particles_at(x, y, 1201)));
    for (grid, p) in all {
        let ops = ops_of(&grid, &p);
        let m = DMatrix::from(&consistent_mass(&ops, &p.mass));
        let eig = SymmetricEigen::new(m).eigenvalues;
        let (min, max) = (eig.min(), eig.max());
        assert!(
            min >= -PSD_REL_TOL * max,
            "smallest eigenvalue {min} (largest {max}) on {grid:?}"
        );
    }
}

#[test]
fn mass_is_conserved_from_particles_to_grid() {
    for (grid, p) in configurations() {
        let ops = ops_of(&grid, &p);
        let total: f64 = lumped_mass(&ops, &p.mass).iter().sum();
        let expected: f64 = p.mass.iter().sum();
        assert!(
            (total - expected).abs() <= MASS_SUM_REL_TOL * expected,
            "Σ m_L = {total}, Σ m_p = {expected}"
        );
    }
}

#[test]
fn momentum_is_conserved_from_particles_to_grid() {
    for (grid, p) in configurations() {
        let ops = ops_of(&grid, &p);
        let q = momentum(&ops, &p.mass, &p.vx, &p.vy).sum();
        let expected = [
            (0..p.len()).map(|k| p.mass[k] * p.vx[k]).sum::<f64>(),
            (0..p.len()).map(|k| p.mass[k] * p.vy[k]).sum::<f64>(),
        ];
        let scale: f64 = (0..p.len()).map(|k| p.mass[k] * (p.vx[k].abs() + p.vy[k].abs())).sum();
        for c in 0..2 {
            assert!(
                (q[c] - expected[c]).abs() <= MASS_SUM_REL_TOL * scale,
                "component {c}: Σ q = {}, Σ m v = {}",
                q[c],
                expected[c]
            );
        }
    }
}

#[test]
fn external_force_totals_the_particles_body_forces() {
    for (grid, p) in configurations() {
        let ops = ops_of(&grid, &p);
        let f = external_force(&ops, &p.mass, &p.bx, &p.by).sum();
        let expected = [
            (0..p.len()).map(|k| p.mass[k] * p.bx[k]).sum::<f64>(),
            (0..p.len()).map(|k| p.mass[k] * p.by[k]).sum::<f64>(),
        ];
        let scale: f64 = (0..p.len()).map(|k| p.mass[k] * (p.bx[k].abs() + p.by[k].abs())).sum();
        for c in 0..2 {
            assert!((f[c] - expected[c]).abs() <= MASS_SUM_REL_TOL * scale, "component {c}");
        }
    }
}

#[test]
fn internal_force_sums_to_zero() {
    for (grid, p) in configurations() {
        let ops = ops_of(&grid, &p);
        let f = internal_force(&ops, &p.volume, &p.sxx, &p.syy, &p.sxy).sum();
        let h_min = grid.cell_size()[0].min(grid.cell_size()[1]);
        // Each particle contributes terms of size V |σ| / h that cancel within its column.
        let scale: f64 = (0..p.len())
            .map(|k| p.volume[k] * (p.sxx[k].abs() + p.syy[k].abs() + 2.0 * p.sxy[k].abs()) / h_min)
            .sum();
        assert!(
            f[0].abs() <= MASS_SUM_REL_TOL * scale && f[1].abs() <= MASS_SUM_REL_TOL * scale,
            "Σ f_int = {f:?}"
        );
        // And it is not trivially zero: the nodal forces themselves are large.
        let nodal = internal_force(&ops, &p.volume, &p.sxx, &p.syy, &p.sxy);
        assert!(nodal.x.iter().any(|v| v.abs() > 1.0));
    }
}

/// Builds the solver for `k × k` jittered particles per cell and checks it against a dense
/// Cholesky solve of the active sub-matrix.
fn check_consistent_solve(k: usize, order: NodeOrder, seed: u64) {
    let grid = well_posed_grid(order);
    let (x, y) = positions_per_cell(&grid, k, 0.3, seed);
    let p = random_particles_at(x, y, seed + 1);
    let ops = ops_of(&grid, &p);
    let m_l = lumped_mass(&ops, &p.mass);
    let active = active_nodes(&m_l, DEFAULT_ACTIVE_MASS_TOLERANCE);
    assert_eq!(active, reference_active(&grid, &p));
    assert_eq!(active.len(), ref_num_nodes(&grid), "every node carries mass");
    let sparse = consistent_mass(&ops, &p.mass);
    let solver = ConsistentMassSolver::new(&sparse, &active, &ops, ConsistentSolveOptions::default()).unwrap();
    assert_eq!(solver.active_nodes(), &active[..]);

    let dense = restrict(&dense_mass(&grid, &p), &active);
    assert_eq!(rank(&dense), active.len(), "the fixture must be well posed");
    let mut rng = Lcg::new(seed + 2);
    let f: Vec<f64> = (0..ref_num_nodes(&grid)).map(|_| rng.range(-5.0, 5.0)).collect();
    let a = solver.solve(&f);
    let a_active = DVector::from_iterator(active.len(), active.iter().map(|&i| a[i]));
    let f_active = DVector::from_iterator(active.len(), active.iter().map(|&i| f[i]));
    let residual = (&dense * &a_active - &f_active).amax();
    assert!(
        residual <= RESIDUAL_REL_TOL * f_active.amax(),
        "‖M_AA a − f‖∞ = {residual} for {k}×{k} particles per cell"
    );
    let expected = dense
        .clone()
        .cholesky()
        .expect("M_AA is positive definite")
        .solve(&f_active);
    let diff = (&a_active - &expected).amax();
    assert!(
        diff <= SOLUTION_REL_TOL * expected.amax(),
        "sparse vs dense solve differ by {diff}"
    );

    // Several right-hand sides in one call give the same answers as one at a time.
    let g: Vec<f64> = (0..f.len()).map(|_| rng.range(-5.0, 5.0)).collect();
    let (mut f2, mut g2) = (f.clone(), g.clone());
    solver.solve_in_place([&mut f2, &mut g2]);
    assert_eq!(f2, a);
    assert_eq!(g2, solver.solve(&g));
}

#[test]
fn consistent_mass_solver_matches_a_dense_solve_with_2x2_particles_per_cell() {
    check_consistent_solve(2, NodeOrder::XFastest, 1300);
    check_consistent_solve(2, NodeOrder::YFastest, 1310);
}

#[test]
fn consistent_mass_solver_matches_a_dense_solve_with_3x3_particles_per_cell() {
    check_consistent_solve(3, NodeOrder::XFastest, 1320);
    check_consistent_solve(3, NodeOrder::YFastest, 1330);
}

/// Because the shape functions sum to one, `M 1 = m_L`: solving `M x = m_L` gives `x = 1`.
#[test]
fn solving_consistent_mass_against_lumped_mass_gives_ones_on_active_nodes() {
    for (k, columns) in [(2, vec![0, 1, 2, 3]), (3, vec![1, 2])] {
        let grid = well_posed_grid(NodeOrder::XFastest);
        let (x, y) = positions_per_cell_in(&grid, columns, k, 0.3, 1400 + k as u64);
        let p = random_particles_at(x, y, 1410);
        let ops = ops_of(&grid, &p);
        let m_l = lumped_mass(&ops, &p.mass);
        let active = active_nodes(&m_l, DEFAULT_ACTIVE_MASS_TOLERANCE);
        let solver =
            ConsistentMassSolver::new(&consistent_mass(&ops, &p.mass), &active, &ops, Default::default()).unwrap();
        let ones = solver.solve(&m_l);
        for (i, v) in ones.iter().enumerate() {
            let expected = if active.contains(&i) { 1.0 } else { 0.0 };
            assert!((v - expected).abs() <= SOLUTION_REL_TOL, "node {i}: {v}");
        }
    }
}

/// Particles only in the two left cell columns of a 4 × 3 grid: the nodes of the right two
/// columns are inactive, and every solve must give exactly 0 there, whatever the right-hand
/// side holds at those nodes.
#[test]
fn inactive_nodes_get_exactly_zero_from_lumped_and_consistent_solves() {
    for order in [NodeOrder::XFastest, NodeOrder::YFastest] {
        let grid = well_posed_grid(order);
        let (x, y) = positions_per_cell_in(&grid, vec![0, 1], 2, 0.3, 1500);
        let p = random_particles_at(x, y, 1501);
        let ops = ops_of(&grid, &p);
        // Nodes in grid columns 0..=2 carry mass; ascending because ids are visited in order.
        let active: Vec<usize> = (0..ref_num_nodes(&grid))
            .filter(|&k| ref_node_ij(&grid, k).0 <= 2)
            .collect();
        let n = ref_num_nodes(&grid);
        let mut rng = Lcg::new(1502);
        // Large values at inactive nodes, to make any leak visible.
        let r = VectorField {
            x: (0..n).map(|_| rng.range(-1e3, 1e3)).collect(),
            y: (0..n).map(|_| rng.range(-1e3, 1e3)).collect(),
        };
        for choice in [MassScheme::Lumped, MassScheme::Consistent] {
            let gm = GridMass::new(&ops, &p.mass, &MassOptions::plain(choice), &Constraints::none()).unwrap();
            assert_eq!(gm.active_nodes(), active, "{choice:?}");
            assert_eq!(gm.lumped(), lumped_mass(&ops, &p.mass));
            for role in [Role::Velocity, Role::Acceleration] {
                let (u, report) = gm.solve(role, &r, None, &ops).unwrap();
                assert_eq!(report.outcome, SolveOutcome::Solved);
                for i in 0..n {
                    assert!(
                        u.x[i].is_finite() && u.y[i].is_finite(),
                        "node {i} not finite with {choice:?}"
                    );
                    if !active.contains(&i) {
                        assert_eq!((u.x[i], u.y[i]), (0.0, 0.0), "inactive node {i} with {choice:?}");
                        assert_eq!(gm.lumped()[i], 0.0);
                    }
                }
            }
        }
        // The lumped solve is r / m_L on active nodes (to the rounding of the stored inverse).
        let lumped = GridMass::new(
            &ops,
            &p.mass,
            &MassOptions::plain(MassScheme::Lumped),
            &Constraints::none(),
        )
        .unwrap();
        let m_l = lumped_mass(&ops, &p.mass);
        let (u, _) = lumped.solve(Role::Acceleration, &r, None, &ops).unwrap();
        for i in 0..n {
            let expected = if active.contains(&i) { r.x[i] / m_l[i] } else { 0.0 };
            assert!(
                (u.x[i] - expected).abs() <= 2.0 * f64::EPSILON * expected.abs(),
                "node {i}: {} against r / m_L = {expected}",
                u.x[i]
            );
        }
    }
}

#[test]
fn active_nodes_are_those_above_the_relative_lumped_mass_tolerance() {
    let lumped = [0.0, 1e-13, 1e-11, 2.0, 0.5, 2e-12, -1.0];
    // Threshold 1e-12 · max = 2e-12: strictly above it.
    assert_eq!(active_nodes(&lumped, 1e-12), vec![2, 3, 4]);
    assert_eq!(active_nodes(&lumped, 0.0), vec![1, 2, 3, 4, 5]);
    assert_eq!(active_nodes(&[0.0; 4], 1e-12), Vec::<usize>::new());
    let mut mask = [true; 7];
    assert_eq!(mark_active(&lumped, 1e-12, &mut mask), 3);
    assert_eq!(mask, [false, false, true, true, true, false, false]);
}

#[test]
fn grid_mass_keeps_the_one_active_set_of_the_lumped_mass_it_is_given() {
    let grid = well_posed_grid(NodeOrder::XFastest);
    let (x, y) = positions_per_cell(&grid, 2, 0.3, 7);
    let p = random_particles_at(x, y, 8);
    let ops = ops_of(&grid, &p);
    let m_l = lumped_mass(&ops, &p.mass);
    let options = MassOptions::both(MassScheme::Consistent);
    let from_particles = GridMass::new(&ops, &p.mass, &options, &Constraints::none()).unwrap();
    let mut given = GridMass::default();
    given.lumped_mut().clone_from(&m_l);
    given.prepare(&ops, &p.mass, &options, &Constraints::none()).unwrap();
    let active = active_nodes(&m_l, options.active_tolerance);
    for mass in [&from_particles, &given] {
        assert_eq!(mass.active_nodes(), active);
        let mask: Vec<usize> = (0..m_l.len()).filter(|&i| mass.is_active()[i]).collect();
        assert_eq!(mask, active);
        assert_eq!(mass.lumped(), m_l);
    }
}

/// Checks a `SingularMassMatrix` error against the operators and the dense matrix.
fn check_singular(grid: &Grid, p: &Particles) {
    let ops = ops_of(grid, p);
    let m_l = lumped_mass(&ops, &p.mass);
    let active = active_nodes(&m_l, DEFAULT_ACTIVE_MASS_TOLERANCE);
    assert_eq!(active, reference_active(grid, p));
    let dense = restrict(&dense_mass(grid, p), &active);
    assert!(rank(&dense) < active.len(), "fixture must be rank-deficient");

    let options = ConsistentSolveOptions::default();
    let err = ConsistentMassSolver::new(&consistent_mass(&ops, &p.mass), &active, &ops, options).unwrap_err();
    let MpmError::SingularMassMatrix {
        node,
        particles,
        relative_pivot,
        cause,
    } = err
    else {
        panic!("expected SingularMassMatrix, got {err:?}");
    };
    assert!(active.contains(&node), "node {node} is not active ({active:?})");
    assert!(!particles.is_empty(), "no particles named");
    assert_eq!(particles, ops.particles_touching(node));
    let reference_n = ref_operators(grid, &p.x, &p.y).n;
    let touching: Vec<usize> = (0..p.len()).filter(|&q| reference_n[(node, q)] > 0.0).collect();
    assert_eq!(
        particles, touching,
        "particles with N[node, p] > 0 in the dense reference"
    );
    assert!(
        relative_pivot <= options.pivot_tolerance,
        "relative pivot {relative_pivot}"
    );
    assert!(!cause.is_empty());

    // GridMass reports the same.
    let gm = GridMass::new(
        &ops,
        &p.mass,
        &MassOptions::plain(MassScheme::Consistent),
        &Constraints::none(),
    );
    match gm {
        Err(MpmError::SingularMassMatrix { node: n2, .. }) => assert_eq!(n2, node),
        other => panic!("GridMass::new: expected SingularMassMatrix, got {other:?}"),
    }
    // The lumped mass is fine for the same configuration.
    assert!(GridMass::new(
        &ops,
        &p.mass,
        &MassOptions::plain(MassScheme::Lumped),
        &Constraints::none()
    )
    .is_ok());
}

#[test]
fn one_particle_per_cell_on_3x3_cells_is_a_singular_mass_matrix_error() {
    for order in [NodeOrder::XFastest, NodeOrder::YFastest] {
        let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [3, 3])
            .unwrap()
            .with_node_order(order);
        let (x, y) = positions_per_cell(&grid, 1, 0.3, 1600);
        check_singular(&grid, &random_particles_at(x, y, 1601));
    }
}

#[test]
fn two_particles_in_a_single_cell_grid_is_a_singular_mass_matrix_error() {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [1, 1]).unwrap();
    let p = random_particles_at(vec![0.3, 0.6], vec![0.25, 0.7], 1700);
    check_singular(&grid, &p);
}

#[test]
fn two_particles_in_one_cell_of_an_otherwise_empty_grid_is_a_singular_mass_matrix_error() {
    for order in [NodeOrder::XFastest, NodeOrder::YFastest] {
        let grid = Grid::new([1.0, -1.0], [0.5, 0.5], [3, 3])
            .unwrap()
            .with_node_order(order);
        let p = random_particles_at(vec![1.6, 1.85], vec![-0.35, -0.1], 1800);
        check_singular(&grid, &p);
    }
}

#[test]
fn seed_consistent_mass_equals_the_dense_reference() {
    let grid = seed_grid();
    let p = seed_particles();
    let ops = ops_of(&grid, &p);
    let m = DMatrix::from(&consistent_mass(&ops, &p.mass));
    let expected = dense_mass(&grid, &p);
    assert!(max_abs_diff(&m, &expected) <= MASS_MATRIX_REL_TOL * max_abs(&expected));
    // The seed's particles all sit in cell (1, 0): nodes 0 and 1 (x = 0) carry no mass.
    let m_l = lumped_mass(&ops, &p.mass);
    assert_eq!((m_l[0], m_l[1]), (0.0, 0.0));
    assert!((m_l.iter().sum::<f64>() - 4.0 * SEED_MASS).abs() <= MASS_SUM_REL_TOL * 4.0);
}

#[test]
fn consistent_mass_solver_with_no_active_nodes_returns_zeros() {
    let grid = well_posed_grid(NodeOrder::XFastest);
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &Particles::default()).unwrap();
    let m = consistent_mass(&ops, &[]);
    let solver = ConsistentMassSolver::new(&m, &[], &ops, Default::default()).unwrap();
    let x = solver.solve(&vec![1.0; ref_num_nodes(&grid)]);
    assert!(x.iter().all(|&v| v == 0.0));
}
