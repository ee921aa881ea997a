//! The assembled operators N, Gx, Gy: entries against a naive dense reference, the shared
//! sorted pattern, the faer views, the scatter/gather kernels against dense products,
//! reassembly, errors, and Matrix Market round trips.

mod common;

use common::*;
use nalgebra::DMatrix;
use sparse_mpm::io::read_matrix_market;
use sparse_mpm::{Grid, MpmError, Operator, Operators, Particles, ShapeFunction};

/// Operator entries are weights ≤ 1 (or ≤ 1/h for gradients) computed in a different order
/// than the reference: a few ulps. A wrong entry would be off by O(0.01) or more.
const ENTRY_TOL: f64 = 1e-13;
/// Products with up to 4 non-zeros per column and a few hundred particles per node, with
/// fields of magnitude ≤ 10: the summation error is a few ulps of the sum of |terms|, which
/// stays below ~1e3. 1e-10 absolute bounds that with margin.
const PRODUCT_TOL: f64 = 1e-10;
/// Particles per random configuration: enough to hit every cell, grid line and boundary of
/// the test grids, few enough that dense n × P references are instant.
const NUM_PARTICLES: usize = 150;

fn particles_at(x: &[f64], y: &[f64]) -> Particles {
    Particles::new(x.to_vec(), y.to_vec(), vec![1.0; x.len()], vec![1.0; x.len()]).unwrap()
}

fn dense(ops: &Operators, op: Operator) -> DMatrix<f64> {
    DMatrix::from(&ops.matrix(op))
}

fn assemble_random(grid: &Grid, count: usize, seed: u64) -> (Operators, Vec<f64>, Vec<f64>) {
    let (x, y) = random_positions(grid, count, seed);
    let ops = Operators::assemble(grid, ShapeFunction::Linear, &particles_at(&x, &y)).unwrap();
    (ops, x, y)
}

/// Everything observable about an assembly, for equality checks.
fn snapshot(ops: &Operators) -> (usize, usize, Vec<usize>, Vec<usize>, [Vec<f64>; 3]) {
    (
        ops.num_nodes(),
        ops.num_particles(),
        ops.col_offsets().to_vec(),
        ops.row_indices().to_vec(),
        [Operator::N, Operator::Gx, Operator::Gy].map(|op| ops.values(op).to_vec()),
    )
}

#[test]
fn n_gx_gy_equal_the_naive_dense_reference_on_every_test_grid() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (ops, x, y) = assemble_random(grid, NUM_PARTICLES, 200 + g as u64);
        let reference = ref_operators(grid, &x, &y);
        let h_min = grid.cell_size()[0].min(grid.cell_size()[1]);
        assert_eq!(ops.num_nodes(), ref_num_nodes(grid));
        assert_eq!(ops.num_particles(), x.len());
        for (op, r, tol) in [
            (Operator::N, &reference.n, ENTRY_TOL),
            (Operator::Gx, &reference.gx, ENTRY_TOL / h_min),
            (Operator::Gy, &reference.gy, ENTRY_TOL / h_min),
        ] {
            let d = dense(&ops, op);
            assert_eq!(d.shape(), r.shape());
            let diff = max_abs_diff(&d, r);
            assert!(
                diff <= tol,
                "{op:?} differs from the reference by {diff} on grid {grid:?}"
            );
        }
        // The convenience accessors return the same matrices.
        assert_eq!(DMatrix::from(&ops.n_matrix()), dense(&ops, Operator::N));
        assert_eq!(DMatrix::from(&ops.gx_matrix()), dense(&ops, Operator::Gx));
        assert_eq!(DMatrix::from(&ops.gy_matrix()), dense(&ops, Operator::Gy));
    }
}

#[test]
fn column_accessor_lists_the_same_entries_as_the_matrices() {
    let grid = &test_grids()[3];
    let (ops, x, _) = assemble_random(grid, 60, 210);
    let (n, gx, gy) = (
        dense(&ops, Operator::N),
        dense(&ops, Operator::Gx),
        dense(&ops, Operator::Gy),
    );
    for p in 0..x.len() {
        let mut seen = vec![false; ops.num_nodes()];
        for (k, nv, gxv, gyv) in ops.column(p) {
            assert_eq!((nv, gxv, gyv), (n[(k, p)], gx[(k, p)], gy[(k, p)]));
            seen[k] = true;
        }
        for k in (0..ops.num_nodes()).filter(|&k| !seen[k]) {
            assert_eq!((n[(k, p)], gx[(k, p)], gy[(k, p)]), (0.0, 0.0, 0.0));
        }
    }
}

#[test]
fn columns_have_four_strictly_ascending_rows_forming_the_particles_cell() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (ops, x, y) = assemble_random(grid, NUM_PARTICLES, 220 + g as u64);
        let m = ops.n_matrix();
        for p in 0..x.len() {
            let rows = m.col(p).row_indices().to_vec();
            assert!(
                rows.windows(2).all(|w| w[0] < w[1]),
                "column {p} rows {rows:?} not ascending"
            );
            assert_eq!(
                rows,
                ref_support(grid, x[p], y[p]),
                "column {p}: particle at ({}, {})",
                x[p],
                y[p]
            );
        }
        let offsets: Vec<usize> = (0..=x.len()).map(|p| 4 * p).collect();
        assert_eq!(ops.col_offsets(), &offsets[..]);
        assert_eq!(ops.nnz(), 4 * x.len());
    }
}

#[test]
fn n_gx_and_gy_share_one_sparsity_pattern() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (ops, _, _) = assemble_random(grid, NUM_PARTICLES, 230 + g as u64);
        let (n, gx, gy) = (ops.n_matrix(), ops.gx_matrix(), ops.gy_matrix());
        for m in [&gx, &gy] {
            assert_eq!(m.col_offsets(), n.col_offsets());
            assert_eq!(m.row_indices(), n.row_indices());
        }
        assert_eq!(n.row_indices(), ops.row_indices());
        assert_eq!(n.col_offsets(), ops.col_offsets());
        assert_eq!(n.values(), ops.values(Operator::N));
        assert_eq!(gx.values(), ops.values(Operator::Gx));
        assert_eq!(gy.values(), ops.values(Operator::Gy));
    }
}

#[test]
fn faer_views_hold_the_same_entries_as_the_nalgebra_matrices() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (ops, x, y) = assemble_random(grid, NUM_PARTICLES, 240 + g as u64);
        let reference = ref_operators(grid, &x, &y);
        let h_min = grid.cell_size()[0].min(grid.cell_size()[1]);
        for (view, op, r, tol) in [
            (ops.n_faer(), Operator::N, &reference.n, ENTRY_TOL),
            (ops.gx_faer(), Operator::Gx, &reference.gx, ENTRY_TOL / h_min),
            (ops.gy_faer(), Operator::Gy, &reference.gy, ENTRY_TOL / h_min),
        ] {
            assert_eq!((view.nrows(), view.ncols()), (ops.num_nodes(), x.len()));
            let from_faer: Vec<(usize, usize, f64)> = view.triplet_iter().map(|t| (t.row, t.col, *t.val)).collect();
            let m = ops.matrix(op);
            let from_nalgebra: Vec<(usize, usize, f64)> = m.triplet_iter().map(|(i, j, v)| (i, j, *v)).collect();
            assert_eq!(from_faer, from_nalgebra, "{op:?}");
            let d = view.to_dense();
            let mut as_dmatrix = DMatrix::zeros(d.nrows(), d.ncols());
            for j in 0..d.ncols() {
                for i in 0..d.nrows() {
                    as_dmatrix[(i, j)] = d[(i, j)];
                }
            }
            assert!(max_abs_diff(&as_dmatrix, r) <= tol, "{op:?} faer view vs reference");
        }
    }
}

fn random_vec(rng: &mut Lcg, len: usize) -> Vec<f64> {
    (0..len).map(|_| rng.range(-10.0, 10.0)).collect()
}

/// Runs `scatter`, `scatter_scaled` and `gather` with `K` fields on every operator and checks
/// them against dense products with the reference matrices.
fn check_products<const K: usize>(grid: &Grid, seed: u64) {
    let (ops, x, y) = assemble_random(grid, NUM_PARTICLES, seed);
    let reference = ref_operators(grid, &x, &y);
    let (n, np) = (ops.num_nodes(), x.len());
    let mut rng = Lcg::new(seed + 1);
    let fields: Vec<Vec<f64>> = (0..K).map(|_| random_vec(&mut rng, np)).collect();
    let grid_fields: Vec<Vec<f64>> = (0..K).map(|_| random_vec(&mut rng, n)).collect();
    let w: Vec<f64> = (0..np).map(|_| rng.range(0.1, 3.0)).collect();
    let h_min = grid.cell_size()[0].min(grid.cell_size()[1]);
    for (op, r) in [
        (Operator::N, &reference.n),
        (Operator::Gx, &reference.gx),
        (Operator::Gy, &reference.gy),
    ] {
        let tol = if op == Operator::N {
            PRODUCT_TOL
        } else {
            PRODUCT_TOL / h_min
        };
        // scatter: out[k] = op · x[k]; outputs pre-filled with garbage to check overwriting.
        let mut out: Vec<Vec<f64>> = vec![vec![1234.5; n]; K];
        {
            let xs: [&[f64]; K] = std::array::from_fn(|k| fields[k].as_slice());
            let mut it = out.iter_mut();
            let outs: [&mut [f64]; K] = std::array::from_fn(|_| it.next().unwrap().as_mut_slice());
            ops.scatter(op, xs, outs);
        }
        for k in 0..K {
            let expected = r * dvec(&fields[k]);
            let diff = max_abs_diff_slice(&out[k], expected.as_slice());
            assert!(diff <= tol, "scatter {op:?} K={K} field {k}: off by {diff}");
        }
        // scatter_scaled: out[k] = op · (w ∘ x[k]), and with w = None it equals scatter.
        let mut scaled: Vec<Vec<f64>> = vec![vec![-99.0; n]; K];
        let mut unscaled: Vec<Vec<f64>> = vec![vec![-99.0; n]; K];
        {
            let xs: [&[f64]; K] = std::array::from_fn(|k| fields[k].as_slice());
            let mut it = scaled.iter_mut();
            let outs: [&mut [f64]; K] = std::array::from_fn(|_| it.next().unwrap().as_mut_slice());
            ops.scatter_scaled(op, Some(&w), xs, outs);
            let mut it = unscaled.iter_mut();
            let outs: [&mut [f64]; K] = std::array::from_fn(|_| it.next().unwrap().as_mut_slice());
            ops.scatter_scaled(op, None, xs, outs);
        }
        for k in 0..K {
            let wx = dvec(&w).component_mul(&dvec(&fields[k]));
            let expected = r * wx;
            let diff = max_abs_diff_slice(&scaled[k], expected.as_slice());
            assert!(diff <= tol, "scatter_scaled {op:?} K={K} field {k}: off by {diff}");
            assert_eq!(unscaled[k], out[k], "scatter_scaled with w = None must equal scatter");
        }
        // gather: out[k] = opᵀ · y[k].
        let mut gathered: Vec<Vec<f64>> = vec![vec![f64::NAN; np]; K];
        {
            let ys: [&[f64]; K] = std::array::from_fn(|k| grid_fields[k].as_slice());
            let mut it = gathered.iter_mut();
            let outs: [&mut [f64]; K] = std::array::from_fn(|_| it.next().unwrap().as_mut_slice());
            ops.gather(op, ys, outs);
        }
        for k in 0..K {
            let expected = r.transpose() * dvec(&grid_fields[k]);
            let diff = max_abs_diff_slice(&gathered[k], expected.as_slice());
            assert!(diff <= tol, "gather {op:?} K={K} field {k}: off by {diff}");
        }
    }
}

#[test]
fn scatter_scatter_scaled_and_gather_equal_dense_products_for_one_field() {
    for (g, grid) in test_grids().iter().enumerate() {
        check_products::<1>(grid, 300 + 10 * g as u64);
    }
}

#[test]
fn scatter_scatter_scaled_and_gather_equal_dense_products_for_two_fields() {
    for (g, grid) in test_grids().iter().enumerate() {
        check_products::<2>(grid, 400 + 10 * g as u64);
    }
}

#[test]
fn scatter_scatter_scaled_and_gather_equal_dense_products_for_three_fields() {
    for (g, grid) in test_grids().iter().enumerate() {
        check_products::<3>(grid, 500 + 10 * g as u64);
    }
}

#[test]
fn reassemble_into_used_operators_equals_a_fresh_assembly() {
    let grids = test_grids();
    let mut ops = Operators::default();
    // Same grid, same count; then fewer particles; then more; then another grid entirely.
    let plan = [(1, 100), (1, 100), (1, 37), (1, 160), (3, 80), (0, 5), (5, 120), (2, 1)];
    for (step, &(g, count)) in plan.iter().enumerate() {
        let grid = &grids[g];
        let (x, y) = random_positions(grid, count, 600 + step as u64);
        ops.reassemble(grid, ShapeFunction::Linear, &x, &y).unwrap();
        let fresh = Operators::assemble(grid, ShapeFunction::Linear, &particles_at(&x, &y)).unwrap();
        assert_eq!(
            snapshot(&ops),
            snapshot(&fresh),
            "step {step}: grid {g}, {count} particles"
        );
        let reference = ref_operators(grid, &x, &y);
        assert!(max_abs_diff(&dense(&ops, Operator::N), &reference.n) <= ENTRY_TOL);
    }
}

#[test]
fn reassemble_with_no_particles_gives_empty_operators() {
    let grid = &test_grids()[1];
    let (mut ops, _, _) = assemble_random(grid, 20, 650);
    ops.reassemble(grid, ShapeFunction::Linear, &[], &[]).unwrap();
    assert_eq!(ops.num_particles(), 0);
    assert_eq!(ops.nnz(), 0);
    assert_eq!(ops.n_matrix().nrows(), ref_num_nodes(grid));
    assert_eq!(ops.n_matrix().ncols(), 0);
}

fn assert_outside_error(err: MpmError, particle: usize, position: [f64; 2], grid: &Grid) {
    match err {
        MpmError::ParticleOutsideGrid {
            particle: p,
            position: pos,
            bounds,
        } => {
            assert_eq!(p, particle);
            assert!(
                pos.iter()
                    .zip(position)
                    .all(|(a, b)| a == &b || (a.is_nan() && b.is_nan())),
                "{pos:?} vs {position:?}"
            );
            assert_eq!(bounds, grid.bounds());
        }
        other => panic!("expected ParticleOutsideGrid for particle {particle}, got {other:?}"),
    }
}

#[test]
fn a_particle_outside_the_grid_is_an_error_naming_it_and_leaves_the_operators_unchanged() {
    let grid = test_grids()[3].clone();
    let [x0, x1, y0, y1] = grid.bounds();
    let (mut ops, _, _) = assemble_random(&grid, 50, 700);
    let before = snapshot(&ops);
    let outside = [
        (x1 + 1e-9, 0.5 * (y0 + y1)),
        (x0 - 0.3, 0.5 * (y0 + y1)),
        (0.5 * (x0 + x1), y1 + 2.0),
        (0.5 * (x0 + x1), y0 - 1e-12),
        (f64::NAN, 0.5 * (y0 + y1)),
        (0.5 * (x0 + x1), f64::INFINITY),
    ];
    for (case, &(px, py)) in outside.iter().enumerate() {
        for bad in [0usize, 7, 29] {
            let (mut x, mut y) = random_positions(&grid, 30, 710 + case as u64);
            x[bad] = px;
            y[bad] = py;
            // A second bad particle later on: the error names the first.
            if bad < 29 {
                x[29] = x1 + 5.0;
            }
            let err = ops.reassemble(&grid, ShapeFunction::Linear, &x, &y).unwrap_err();
            assert_outside_error(err, bad, [px, py], &grid);
            assert_eq!(snapshot(&ops), before, "a failed reassembly changed the operators");
        }
    }
    // Through `assemble` with a Particles value (finite positions only: NaN is rejected earlier).
    let (mut x, y) = random_positions(&grid, 10, 720);
    x[4] = x0 - 1.0;
    let err = Operators::assemble(&grid, ShapeFunction::Linear, &particles_at(&x, &y)).unwrap_err();
    assert_outside_error(err, 4, [x0 - 1.0, y[4]], &grid);
}

#[test]
fn particles_touching_a_node_are_the_particles_whose_cell_has_that_node() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (ops, x, y) = assemble_random(grid, 60, 750 + g as u64);
        for node in 0..ref_num_nodes(grid) {
            let expected: Vec<usize> = (0..x.len())
                .filter(|&p| ref_support(grid, x[p], y[p]).contains(&node))
                .collect();
            assert_eq!(ops.particles_touching(node), expected, "node {node} on {grid:?}");
        }
    }
}

#[test]
fn matrix_market_round_trip_reproduces_n_gx_and_gy() {
    let grid = test_grids()[5].clone();
    let (ops, _, _) = assemble_random(&grid, 40, 800);
    let dir = unique_temp_dir("mtx");
    sparse_mpm::io::write_operators(&ops, &dir).unwrap();
    for (op, name) in [(Operator::N, "N"), (Operator::Gx, "Gx"), (Operator::Gy, "Gy")] {
        let read = read_matrix_market(&dir.join(format!("{name}.mtx"))).unwrap();
        let original = ops.matrix(op);
        assert_eq!((read.nrows(), read.ncols()), (original.nrows(), original.ncols()));
        // Values are written in Rust's shortest round-trip form, so they come back exactly.
        assert_eq!(DMatrix::from(&read), DMatrix::from(&original), "{name}.mtx");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn reading_a_missing_matrix_market_file_is_an_io_error_naming_the_file() {
    let path = unique_temp_dir("missing").join("N.mtx");
    match read_matrix_market(&path) {
        Err(MpmError::Io { path: p, .. }) => assert_eq!(p, path),
        other => panic!("expected an Io error, got {other:?}"),
    }
}

/// `Grid::contains` accepts `x = bounds()[1] = 0.30000000000000004` (hx = 0.1, 3 cells), whose
/// cell coordinate `(x − x₀)/hx` rounds to `3.0000000000000004 > 3`. Regression: the kernel
/// used to treat it as outside, and `reassemble` panicked on its
/// `expect("position checked against the grid above")`.
#[test]
fn assemble_handles_a_particle_on_the_upper_boundary_of_a_grid_with_cell_size_0_1() {
    let grid = Grid::new([0.0, 0.0], [0.1, 0.1], [3, 3]).unwrap();
    let [_, x1, _, _] = grid.bounds();
    let result =
        std::panic::catch_unwind(|| Operators::assemble(&grid, ShapeFunction::Linear, &particles_at(&[x1], &[0.15])));
    let ops = result
        .expect("assemble panicked for a particle inside Grid::contains")
        .expect("the particle is inside the grid");
    let sum: f64 = ops.column(0).map(|(_, n, _, _)| n).sum();
    assert!((sum - 1.0).abs() <= ENTRY_TOL, "column sums to {sum}");
}
