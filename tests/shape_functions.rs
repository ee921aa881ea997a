//! Properties of the bilinear shape functions `shape`, `dshape` and of the columns of N, Gx, Gy:
//! partition of unity, gradients summing to zero, reproduction of linear fields, agreement
//! with finite differences and with an independent tent-function reference.
//!
//! The second half checks every kernel (linear, uGIMP with two half-widths, quadratic and
//! cubic B-splines) through `shape::evaluate` and the assembled operators: the same
//! properties across the region where each kernel is accepted, agreement with independent
//! textbook formulas, and the behaviour at the grid's edge (margin, errors, boundary layers).

mod common;

use common::*;
use nalgebra::DMatrix;
use sparse_mpm::shape::evaluate;
use sparse_mpm::{dshape, shape, Grid, MpmError, NodeOrder, Operator, Operators, Particles, ShapeFunction};

/// A partition-of-unity sum adds four products of weights in `[0, 1]` computed from cell
/// coordinates of magnitude ≤ 6: a few ulps each. 1e-13 is ~500 ulps, while a wrong weight
/// (wrong cell, wrong node) would be off by O(0.01) or more.
const UNITY_TOL: f64 = 1e-13;
/// Sums of gradient entries are of magnitude `1/h`; the same few-ulp budget scaled by `1/h`.
const GRADIENT_SUM_TOL_PER_UNIT_INV_H: f64 = 1e-13;
/// Reproducing `x_p` from node coordinates of magnitude ≤ 6: a few ulps of 6.
const LINEAR_FIELD_TOL: f64 = 1e-12;
/// Central-difference step in cell units: small enough to stay inside the cell (points are
/// kept `FD_MARGIN` away from grid lines), large enough that rounding (~1e-16 / step) is tiny.
const FD_STEP: f64 = 1e-6;
/// Distance in cell units kept between finite-difference points and grid lines.
const FD_MARGIN: f64 = 1e-3;
/// The shape function is bilinear inside a cell, so a central difference is exact up to
/// rounding `≈ ε / FD_STEP ≈ 1e-10` per cell unit; 1e-8 per cell unit leaves a margin.
const FD_TOL_PER_CELL_UNIT: f64 = 1e-8;
/// Agreement with the tent reference, which computes the same weights in a different order.
const REFERENCE_TOL: f64 = 1e-13;
/// The seed's hand value 0.057 is computed from decimal inputs that are not exact in binary.
const HAND_VALUE_TOL: f64 = 1e-15;

/// Random positions, including grid lines, nodes and the outer boundary, per test grid.
fn points(grid: &Grid, seed: u64) -> (Vec<f64>, Vec<f64>) {
    random_positions(grid, 120, seed)
}

/// Every node, plus points on every grid line (interior and boundary) at random positions
/// along it.
fn grid_line_points(grid: &Grid, seed: u64) -> Vec<(f64, f64)> {
    let mut rng = Lcg::new(seed);
    let [cx, cy] = grid.cells();
    let [x0, x1, y0, y1] = grid.bounds();
    let mut out = Vec::new();
    for i in 0..=cx {
        for j in 0..=cy {
            out.push((grid_line_x(grid, i), grid_line_y(grid, j)));
        }
        out.push((grid_line_x(grid, i), rng.range(y0, y1)));
    }
    for j in 0..=cy {
        out.push((rng.range(x0, x1), grid_line_y(grid, j)));
    }
    out
}

/// Points on the outer boundary: corners and random points along each edge.
fn boundary_points(grid: &Grid, seed: u64) -> Vec<(f64, f64)> {
    let mut rng = Lcg::new(seed);
    let [x0, x1, y0, y1] = grid.bounds();
    let mut out = vec![(x0, y0), (x1, y0), (x0, y1), (x1, y1)];
    for _ in 0..5 {
        out.push((rng.range(x0, x1), y0));
        out.push((rng.range(x0, x1), y1));
        out.push((x0, rng.range(y0, y1)));
        out.push((x1, rng.range(y0, y1)));
    }
    out
}

fn sum_of_shape(grid: &Grid, x: f64, y: f64) -> f64 {
    (0..ref_num_nodes(grid)).map(|k| shape(grid, k, x, y)).sum()
}

fn assert_partition_of_unity(grid: &Grid, pts: &[(f64, f64)]) {
    for &(x, y) in pts {
        let sum = sum_of_shape(grid, x, y);
        assert!(
            (sum - 1.0).abs() <= UNITY_TOL,
            "Σ_I N_I({x}, {y}) = {sum} on grid {grid:?}"
        );
    }
}

#[test]
fn shape_functions_sum_to_one_at_random_particles_on_every_test_grid() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (x, y) = points(grid, 10 + g as u64);
        let pts: Vec<_> = x.iter().copied().zip(y.iter().copied()).collect();
        assert_partition_of_unity(grid, &pts);
    }
}

#[test]
fn shape_functions_sum_to_one_on_grid_lines_and_nodes() {
    for (g, grid) in test_grids().iter().enumerate() {
        assert_partition_of_unity(grid, &grid_line_points(grid, 20 + g as u64));
    }
}

#[test]
fn shape_functions_sum_to_one_on_the_outer_boundary() {
    for (g, grid) in test_grids().iter().enumerate() {
        assert_partition_of_unity(grid, &boundary_points(grid, 30 + g as u64));
    }
}

#[test]
fn columns_of_n_sum_to_one_for_every_particle() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (x, y) = points(grid, 40 + g as u64);
        let particles = Particles::new(x.clone(), y.clone(), vec![1.0; x.len()], vec![1.0; x.len()]).unwrap();
        let ops = Operators::assemble(grid, ShapeFunction::Linear, &particles).unwrap();
        for p in 0..x.len() {
            let sum: f64 = ops.column(p).map(|(_, n, _, _)| n).sum();
            assert!(
                (sum - 1.0).abs() <= UNITY_TOL,
                "column {p} of N sums to {sum} for the particle at ({}, {}) on grid {grid:?}",
                x[p],
                y[p]
            );
        }
    }
}

#[test]
fn shape_function_gradients_sum_to_zero() {
    for (g, grid) in test_grids().iter().enumerate() {
        let [hx, hy] = grid.cell_size();
        let (x, y) = points(grid, 50 + g as u64);
        let mut pts: Vec<_> = x.iter().copied().zip(y.iter().copied()).collect();
        pts.extend(grid_line_points(grid, 51 + g as u64));
        pts.extend(boundary_points(grid, 52 + g as u64));
        for (x, y) in pts {
            let (sx, sy) = (0..ref_num_nodes(grid))
                .map(|k| dshape(grid, k, x, y))
                .fold((0.0, 0.0), |(a, b), (gx, gy)| (a + gx, b + gy));
            assert!(
                sx.abs() <= GRADIENT_SUM_TOL_PER_UNIT_INV_H / hx,
                "Σ_I ∂N_I/∂x({x}, {y}) = {sx} on {grid:?}"
            );
            assert!(
                sy.abs() <= GRADIENT_SUM_TOL_PER_UNIT_INV_H / hy,
                "Σ_I ∂N_I/∂y({x}, {y}) = {sy} on {grid:?}"
            );
        }
    }
}

#[test]
fn columns_of_gx_and_gy_sum_to_zero_for_every_particle() {
    for (g, grid) in test_grids().iter().enumerate() {
        let [hx, hy] = grid.cell_size();
        let (x, y) = points(grid, 60 + g as u64);
        let particles = Particles::new(x.clone(), y.clone(), vec![1.0; x.len()], vec![1.0; x.len()]).unwrap();
        let ops = Operators::assemble(grid, ShapeFunction::Linear, &particles).unwrap();
        for p in 0..x.len() {
            let (sx, sy) = ops
                .column(p)
                .fold((0.0, 0.0), |(a, b), (_, _, gx, gy)| (a + gx, b + gy));
            assert!(sx.abs() <= GRADIENT_SUM_TOL_PER_UNIT_INV_H / hx, "Σ Gx[:, {p}] = {sx}");
            assert!(sy.abs() <= GRADIENT_SUM_TOL_PER_UNIT_INV_H / hy, "Σ Gy[:, {p}] = {sy}");
        }
    }
}

#[test]
fn shape_functions_reproduce_linear_fields() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (node_x, node_y) = ref_node_coordinates(grid);
        let (x, y) = points(grid, 70 + g as u64);
        let mut pts: Vec<_> = x.iter().copied().zip(y.iter().copied()).collect();
        pts.extend(grid_line_points(grid, 71 + g as u64));
        for (x, y) in pts {
            let mut sums = [0.0; 6]; // Σ N x_I, Σ N y_I, Σ Gx x_I, Σ Gx y_I, Σ Gy x_I, Σ Gy y_I
            for k in 0..ref_num_nodes(grid) {
                let n = shape(grid, k, x, y);
                let (gx, gy) = dshape(grid, k, x, y);
                let (xi, yi) = (node_x[k], node_y[k]);
                for (s, v) in sums
                    .iter_mut()
                    .zip([n * xi, n * yi, gx * xi, gx * yi, gy * xi, gy * yi])
                {
                    *s += v;
                }
            }
            let expected = [x, y, 1.0, 0.0, 0.0, 1.0];
            let names = ["Σ N x_I", "Σ N y_I", "Σ Gx x_I", "Σ Gx y_I", "Σ Gy x_I", "Σ Gy y_I"];
            for ((s, e), name) in sums.iter().zip(expected).zip(names) {
                assert!(
                    (s - e).abs() <= LINEAR_FIELD_TOL,
                    "{name} = {s}, expected {e} at ({x}, {y}) on {grid:?}"
                );
            }
        }
    }
}

#[test]
fn operators_reproduce_linear_fields_at_every_particle() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (node_x, node_y) = ref_node_coordinates(grid);
        let (x, y) = points(grid, 80 + g as u64);
        let particles = Particles::new(x.clone(), y.clone(), vec![1.0; x.len()], vec![1.0; x.len()]).unwrap();
        let ops = Operators::assemble(grid, ShapeFunction::Linear, &particles).unwrap();
        for p in 0..x.len() {
            let mut sums = [0.0; 6];
            for (k, n, gx, gy) in ops.column(p) {
                let (xi, yi) = (node_x[k], node_y[k]);
                for (s, v) in sums
                    .iter_mut()
                    .zip([n * xi, n * yi, gx * xi, gx * yi, gy * xi, gy * yi])
                {
                    *s += v;
                }
            }
            let expected = [x[p], y[p], 1.0, 0.0, 0.0, 1.0];
            for (q, (s, e)) in sums.iter().zip(expected).enumerate() {
                assert!(
                    (s - e).abs() <= LINEAR_FIELD_TOL,
                    "sum {q} of column {p} = {s}, expected {e} on {grid:?}"
                );
            }
        }
    }
}

#[test]
fn dshape_agrees_with_central_finite_differences_away_from_grid_lines() {
    for (g, grid) in test_grids().iter().enumerate() {
        let [hx, hy] = grid.cell_size();
        let (dx, dy) = (FD_STEP * hx, FD_STEP * hy);
        let (x, y) = positions_off_grid_lines(grid, 40, FD_MARGIN, 90 + g as u64);
        for (&x, &y) in x.iter().zip(&y) {
            for k in 0..ref_num_nodes(grid) {
                let fd_x = (shape(grid, k, x + dx, y) - shape(grid, k, x - dx, y)) / (2.0 * dx);
                let fd_y = (shape(grid, k, x, y + dy) - shape(grid, k, x, y - dy)) / (2.0 * dy);
                let (gx, gy) = dshape(grid, k, x, y);
                assert!(
                    (gx - fd_x).abs() <= FD_TOL_PER_CELL_UNIT / hx,
                    "∂N_{k}/∂x at ({x}, {y}) = {gx}, central difference {fd_x}"
                );
                assert!(
                    (gy - fd_y).abs() <= FD_TOL_PER_CELL_UNIT / hy,
                    "∂N_{k}/∂y at ({x}, {y}) = {gy}, central difference {fd_y}"
                );
            }
        }
    }
}

/// On an interior grid line the point belongs to the cell above/right of the line, so the
/// derivative across the line is the one-sided difference into that cell.
#[test]
fn dshape_on_interior_grid_lines_is_the_right_hand_derivative() {
    for (g, grid) in test_grids().iter().enumerate() {
        let [cx, cy] = grid.cells();
        let [hx, hy] = grid.cell_size();
        let [x0, x1, y0, y1] = grid.bounds();
        let mut rng = Lcg::new(100 + g as u64);
        // Vertical lines: check ∂/∂x against a right-hand difference.
        for i in 1..cx {
            let (x, y) = (grid_line_x(grid, i), rng.range(y0, y1));
            let h = FD_STEP * hx;
            for k in 0..ref_num_nodes(grid) {
                let right = (shape(grid, k, x + h, y) - shape(grid, k, x, y)) / h;
                let left = (shape(grid, k, x, y) - shape(grid, k, x - h, y)) / h;
                let (gx, _) = dshape(grid, k, x, y);
                assert!(
                    (gx - right).abs() <= FD_TOL_PER_CELL_UNIT / hx,
                    "∂N_{k}/∂x on the line x = {x}: {gx}, right-hand difference {right} (left-hand {left})"
                );
            }
        }
        // Horizontal lines: ∂/∂y against a right-hand (upward) difference.
        for j in 1..cy {
            let (x, y) = (rng.range(x0, x1), grid_line_y(grid, j));
            let h = FD_STEP * hy;
            for k in 0..ref_num_nodes(grid) {
                let up = (shape(grid, k, x, y + h) - shape(grid, k, x, y)) / h;
                let (_, gy) = dshape(grid, k, x, y);
                assert!(
                    (gy - up).abs() <= FD_TOL_PER_CELL_UNIT / hy,
                    "∂N_{k}/∂y on the line y = {y}: {gy}, upward difference {up}"
                );
            }
        }
    }
}

/// On the last grid line along an axis the point belongs to the last cell, so the derivative
/// is the one-sided difference from inside the grid.
#[test]
fn dshape_on_the_last_grid_line_is_the_left_hand_derivative() {
    for (g, grid) in test_grids().iter().enumerate() {
        let [hx, hy] = grid.cell_size();
        let [x0, x1, y0, y1] = grid.bounds();
        let mut rng = Lcg::new(110 + g as u64);
        let (x, y) = (x1, rng.range(y0, y1));
        let h = FD_STEP * hx;
        for k in 0..ref_num_nodes(grid) {
            let left = (shape(grid, k, x, y) - shape(grid, k, x - h, y)) / h;
            let (gx, _) = dshape(grid, k, x, y);
            assert!(
                (gx - left).abs() <= FD_TOL_PER_CELL_UNIT / hx,
                "∂N_{k}/∂x on the right boundary: {gx}, left-hand difference {left}"
            );
        }
        let (x, y) = (rng.range(x0, x1), y1);
        let h = FD_STEP * hy;
        for k in 0..ref_num_nodes(grid) {
            let down = (shape(grid, k, x, y) - shape(grid, k, x, y - h)) / h;
            let (_, gy) = dshape(grid, k, x, y);
            assert!(
                (gy - down).abs() <= FD_TOL_PER_CELL_UNIT / hy,
                "∂N_{k}/∂y on the top boundary: {gy}, downward difference {down}"
            );
        }
    }
}

#[test]
fn shape_and_dshape_equal_the_tent_function_reference() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (x, y) = points(grid, 120 + g as u64);
        let mut pts: Vec<_> = x.iter().copied().zip(y.iter().copied()).collect();
        pts.extend(grid_line_points(grid, 121 + g as u64));
        pts.extend(boundary_points(grid, 122 + g as u64));
        let [hx, hy] = grid.cell_size();
        for (x, y) in pts {
            for k in 0..ref_num_nodes(grid) {
                let (n_ref, gx_ref, gy_ref) = ref_shape(grid, k, x, y);
                let n = shape(grid, k, x, y);
                let (gx, gy) = dshape(grid, k, x, y);
                assert!(
                    (n - n_ref).abs() <= REFERENCE_TOL,
                    "N_{k}({x}, {y}) = {n}, reference {n_ref}"
                );
                assert!(
                    (gx - gx_ref).abs() <= REFERENCE_TOL / hx,
                    "∂N_{k}/∂x({x}, {y}) = {gx}, reference {gx_ref} on {grid:?}"
                );
                assert!(
                    (gy - gy_ref).abs() <= REFERENCE_TOL / hy,
                    "∂N_{k}/∂y({x}, {y}) = {gy}, reference {gy_ref} on {grid:?}"
                );
            }
        }
    }
}

/// The docs promise `shape(grid, node, x_p, y_p)` is *exactly* `N[node, p]` (and likewise
/// `dshape` and Gx, Gy), including the zeros outside the particle's support.
#[test]
fn shape_and_dshape_equal_the_assembled_entries_exactly() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (x, y) = points(grid, 130 + g as u64);
        let particles = Particles::new(x.clone(), y.clone(), vec![1.0; x.len()], vec![1.0; x.len()]).unwrap();
        let ops = Operators::assemble(grid, ShapeFunction::Linear, &particles).unwrap();
        let n = nalgebra::DMatrix::from(&ops.n_matrix());
        let gx = nalgebra::DMatrix::from(&ops.gx_matrix());
        let gy = nalgebra::DMatrix::from(&ops.gy_matrix());
        for p in 0..x.len() {
            for k in 0..ref_num_nodes(grid) {
                assert_eq!(shape(grid, k, x[p], y[p]), n[(k, p)], "N[{k}, {p}]");
                assert_eq!(dshape(grid, k, x[p], y[p]), (gx[(k, p)], gy[(k, p)]), "Gx/Gy[{k}, {p}]");
            }
        }
    }
}

/// Seed: node 3 (1-based) is at (1, 0), particle 2 (1-based) at (1.7, 0.81):
/// N = (1 − 0.7)(1 − 0.81) = 0.057.
#[test]
fn seed_hand_value_of_node_3_at_particle_2_is_0_057() {
    let grid = seed_grid();
    assert_eq!(grid.node_position(2), [1.0, 0.0], "1-based node 3 is at (1, 0)");
    let expected: f64 = (1.0 - 0.7) * (1.0 - 0.81);
    assert!((expected - 0.057).abs() <= HAND_VALUE_TOL);
    let value = shape(&grid, 2, SEED_PARTICLE_X[1], SEED_PARTICLE_Y[1]);
    assert!((value - 0.057).abs() <= HAND_VALUE_TOL, "shape = {value}");
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &seed_particles()).unwrap();
    let n = nalgebra::DMatrix::from(&ops.n_matrix());
    assert!((n[(2, 1)] - 0.057).abs() <= HAND_VALUE_TOL, "N[2, 1] = {}", n[(2, 1)]);
    // The gradient by hand: ∂N/∂x = −(1 − 0.81) = −0.19, ∂N/∂y = −(1 − 0.7) = −0.3.
    let (gx, gy) = dshape(&grid, 2, SEED_PARTICLE_X[1], SEED_PARTICLE_Y[1]);
    assert!(
        (gx + 0.19).abs() <= HAND_VALUE_TOL && (gy + 0.3).abs() <= HAND_VALUE_TOL,
        "{gx}, {gy}"
    );
}

#[test]
fn seed_operators_equal_the_tent_function_reference() {
    let grid = seed_grid();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &seed_particles()).unwrap();
    let reference = ref_operators(&grid, &SEED_PARTICLE_X, &SEED_PARTICLE_Y);
    let n = nalgebra::DMatrix::from(&ops.n_matrix());
    assert!(
        max_abs_diff(&n, &reference.n) <= REFERENCE_TOL,
        "N = {n}, reference {}",
        reference.n
    );
    let gx = nalgebra::DMatrix::from(&ops.gx_matrix());
    assert!(max_abs_diff(&gx, &reference.gx) <= REFERENCE_TOL);
    let gy = nalgebra::DMatrix::from(&ops.gy_matrix());
    assert!(max_abs_diff(&gy, &reference.gy) <= REFERENCE_TOL);
}

#[test]
fn shape_functions_are_non_negative() {
    for (g, grid) in test_grids().iter().enumerate() {
        let (x, y) = points(grid, 140 + g as u64);
        let mut pts: Vec<_> = x.iter().copied().zip(y.iter().copied()).collect();
        pts.extend(grid_line_points(grid, 141 + g as u64));
        pts.extend(boundary_points(grid, 142 + g as u64));
        for &(x, y) in &pts {
            for k in 0..ref_num_nodes(grid) {
                let n = shape(grid, k, x, y);
                assert!(n >= 0.0, "N_{k}({x}, {y}) = {n}");
            }
        }
        let (px, py): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
        let particles = Particles::new(px.clone(), py, vec![1.0; px.len()], vec![1.0; px.len()]).unwrap();
        let ops = Operators::assemble(grid, ShapeFunction::Linear, &particles).unwrap();
        assert!(ops.n_matrix().values().iter().all(|&v| v >= 0.0));
    }
}

#[test]
fn shape_and_dshape_vanish_outside_the_grid() {
    for grid in test_grids() {
        let [x0, x1, y0, y1] = grid.bounds();
        let [hx, hy] = grid.cell_size();
        let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let tiny = 1e-9;
        let outside = [
            (x0 - tiny * hx, ym),
            (x1 + tiny * hx, ym),
            (xm, y0 - tiny * hy),
            (xm, y1 + tiny * hy),
            (x0 - 0.5 * hx, y0 - 0.5 * hy),
            (x1 + 0.5 * hx, y1 + 0.5 * hy),
            (x1 + 0.5 * hx, ym),
            (x0 - 100.0, y0 + 100.0),
            (f64::NAN, ym),
            (xm, f64::NAN),
            (f64::INFINITY, ym),
            (xm, f64::NEG_INFINITY),
        ];
        for (x, y) in outside {
            for k in 0..ref_num_nodes(&grid) {
                assert_eq!(shape(&grid, k, x, y), 0.0, "N_{k}({x}, {y})");
                assert_eq!(dshape(&grid, k, x, y), (0.0, 0.0), "∇N_{k}({x}, {y})");
            }
        }
    }
}

/// The upper boundary is at `x₀ + cx·hx = 0.30000000000000004` for `hx = 0.1`, `cx = 3`:
/// `Grid::contains` accepts it (it is exactly `bounds()[1]`), but the cell coordinate
/// `(x − x₀)/hx` rounds to `3.0000000000000004 > cx`. Regression: the kernel used to treat the
/// point as outside, so every shape function was 0 there.
#[test]
fn shape_functions_sum_to_one_on_the_upper_boundary_of_a_grid_with_cell_size_0_1() {
    let grid = Grid::new([0.0, 0.0], [0.1, 0.1], [3, 3]).unwrap();
    let [_, x1, _, y1] = grid.bounds();
    assert!(grid.contains(x1, 0.15));
    assert_partition_of_unity(&grid, &[(x1, 0.15), (0.15, y1), (x1, y1)]);
}

// =============================================================================================
// Every kernel: linear, uGIMP, quadratic and cubic B-splines
// =============================================================================================

/// Sums of up to 16 products of weights in `[0, 1]`: a few ulps each, as for the bilinear
/// functions. A wrong weight or a missing node would be off by O(0.01) or more.
const KERNEL_UNITY_TOL: f64 = 1e-13;
/// `Σ N_I x_I` with node coordinates of magnitude ≤ 5: a few ulps of 5 per term, 16 terms.
const KERNEL_LINEAR_FIELD_TOL: f64 = 1e-12;
/// `Σ Gx_I`, `Σ Gx_I x_I`, …: terms of magnitude up to `(1 + |x_I|)/h` with `|x_I| ≤ 5`, so
/// the rounding budget is a few hundred ulps of `6/h`; this bound is taken per unit `1/h`.
const KERNEL_GRADIENT_TOL_PER_UNIT_INV_H: f64 = 1e-12;
/// Central-difference step in cell units, as for the bilinear functions.
const KERNEL_FD_STEP: f64 = 1e-6;
/// Distance in cell units kept between finite-difference points and every breakpoint of the
/// kernel (where a derivative of some order jumps) and from the margin.
const KERNEL_FD_MARGIN: f64 = 1e-3;
/// Between breakpoints the kernels are polynomials of degree ≤ 3, so the central difference
/// errs by (third derivative) · step²/6 ≲ 1e-12 plus rounding ≈ ε/step ≈ 1e-10 per cell unit.
const KERNEL_FD_TOL_PER_CELL_UNIT: f64 = 1e-8;
/// Agreement with the independent 1D formulas below, which compute the same numbers in a
/// different order (the uGIMP one by differences of an antiderivative): a few ulps of 1 per
/// unit value, and of up to `1/l = 4` cell units per unit derivative.
const KERNEL_REFERENCE_TOL: f64 = 1e-13;
/// The same for 1D derivatives per unit `ξ` with uGIMP half-widths down to `l = 0.1`: the
/// reference divides differences of order ε by `2l`.
const KERNEL_DERIVATIVE_REFERENCE_TOL: f64 = 1e-12;
/// Random points per grid and kernel, on top of the special ones.
const RANDOM_POINTS: usize = 100;
/// A point this far inside the margin (in cells) is far beyond rounding: it must be rejected.
const INSIDE_MARGIN: f64 = 1e-6;
/// A point this far outside `[margin, cells − margin]` (in cells) is a rounding error: it must
/// be accepted and treated as on the margin.
const ROUNDING_OUTSIDE_MARGIN: f64 = 1e-12;

/// Every kernel under test, uGIMP with the half-widths of 2 × 2 and 1 × 1 particles per cell.
fn kernels() -> [ShapeFunction; 5] {
    [
        ShapeFunction::Linear,
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::Gimp { half_width: 0.5 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ]
}

/// Non-square grids with origins away from zero and `hx ≠ hy`, both node orders, cell sizes
/// that are not exactly representable, and one with the fewest cells along x that a cubic
/// B-spline support fits in (3).
fn kernel_grids() -> Vec<Grid> {
    let g = |origin, size, cells, order| Grid::new(origin, size, cells).unwrap().with_node_order(order);
    vec![
        g([-1.3, 2.1], [0.25, 0.6], [7, 5], NodeOrder::XFastest),
        g([0.1, -0.35], [0.3, 0.7], [5, 4], NodeOrder::YFastest),
        g([2.5, -4.0], [0.5, 0.2], [3, 6], NodeOrder::XFastest),
    ]
}

/// Coordinate along `axis` of cell coordinate `s`.
fn at(grid: &Grid, axis: usize, s: f64) -> f64 {
    grid.origin()[axis] + s * grid.cell_size()[axis]
}

/// A random coordinate along `axis` where `shape` is accepted.
fn random_allowed(grid: &Grid, shape: ShapeFunction, axis: usize, rng: &mut Lcg) -> f64 {
    let m = shape.margin();
    at(grid, axis, rng.range(m, grid.cells()[axis] as f64 - m))
}

/// The two margin lines along `axis`, computed in the ways a user would: from the origin, from
/// the grid's edges and as `allowed_region` reports them.
fn margin_lines(grid: &Grid, shape: ShapeFunction, axis: usize) -> Vec<f64> {
    let m = shape.margin();
    let cells = grid.cells()[axis] as f64;
    let (h, lo, hi) = (
        grid.cell_size()[axis],
        grid.bounds()[2 * axis],
        grid.bounds()[2 * axis + 1],
    );
    let allowed = shape.allowed_region(grid);
    vec![
        at(grid, axis, m),
        lo + m * h,
        allowed[2 * axis],
        at(grid, axis, cells - m),
        hi - m * h,
        allowed[2 * axis + 1],
    ]
}

/// Points where `shape` is accepted: the corners and edges of the allowed region, every grid
/// line, half- and quarter-cell line (the kernels' breakpoints) and node inside it, and random
/// points.
fn allowed_points(grid: &Grid, shape: ShapeFunction, seed: u64) -> Vec<(f64, f64)> {
    let mut rng = Lcg::new(seed);
    let m = shape.margin();
    let [cx, cy] = grid.cells();
    let (mx, my) = (margin_lines(grid, shape, 0), margin_lines(grid, shape, 1));
    let mut out = Vec::new();
    for &x in &mx {
        for &y in &my {
            out.push((x, y));
        }
        out.push((x, random_allowed(grid, shape, 1, &mut rng)));
    }
    for &y in &my {
        out.push((random_allowed(grid, shape, 0, &mut rng), y));
    }
    let inside = |s: f64, cells: usize| s >= m && s <= cells as f64 - m;
    for k in 0..=4 * cx {
        let s = k as f64 / 4.0;
        if inside(s, cx) {
            out.push((at(grid, 0, s), random_allowed(grid, shape, 1, &mut rng)));
        }
    }
    for k in 0..=4 * cy {
        let t = k as f64 / 4.0;
        if inside(t, cy) {
            out.push((random_allowed(grid, shape, 0, &mut rng), at(grid, 1, t)));
        }
    }
    for i in 0..=cx {
        for j in 0..=cy {
            if inside(i as f64, cx) && inside(j as f64, cy) {
                out.push((grid_line_x(grid, i), grid_line_y(grid, j)));
            }
        }
    }
    for _ in 0..RANDOM_POINTS {
        out.push((
            random_allowed(grid, shape, 0, &mut rng),
            random_allowed(grid, shape, 1, &mut rng),
        ));
    }
    out
}

/// Breakpoints of the kernel (where it or a derivative jumps), as offsets in `[0, 1)` from the
/// nodes.
fn breakpoints(shape: ShapeFunction) -> Vec<f64> {
    match shape {
        ShapeFunction::Linear | ShapeFunction::CubicBSpline => vec![0.0],
        ShapeFunction::Gimp { half_width } => vec![half_width, 1.0 - half_width],
        ShapeFunction::QuadraticBSpline => vec![0.5],
    }
}

/// Random points at least `KERNEL_FD_MARGIN` cells away from every breakpoint and from the
/// margin, so that central differences see one polynomial piece and stay accepted.
fn points_off_breakpoints(grid: &Grid, shape: ShapeFunction, count: usize, seed: u64) -> Vec<(f64, f64)> {
    let mut rng = Lcg::new(seed);
    let bps = breakpoints(shape);
    let m = shape.margin() + KERNEL_FD_MARGIN;
    let mut draw = |cells: usize| loop {
        let s = rng.range(m, cells as f64 - m);
        let clear = bps.iter().all(|b| {
            let f = (s - b).rem_euclid(1.0);
            f.min(1.0 - f) >= KERNEL_FD_MARGIN
        });
        if clear {
            return s;
        }
    };
    let [cx, cy] = grid.cells();
    (0..count)
        .map(|_| (at(grid, 0, draw(cx)), at(grid, 1, draw(cy))))
        .collect()
}

/// Independent 1D kernels `(S(ξ), S'(ξ))`, written from the textbook formulas (the uGIMP one
/// as the average of the tent over the particle domain, through the tent's antiderivative).
/// Linear is checked against `common::ref_axis`, which encodes its convention at kinks.
fn textbook_kernel(shape: ShapeFunction, xi: f64) -> (f64, f64) {
    let a = xi.abs();
    let sign = xi.signum();
    match shape {
        ShapeFunction::QuadraticBSpline => {
            if a < 0.5 {
                (0.75 - xi * xi, -2.0 * xi)
            } else if a < 1.5 {
                (0.5 * (1.5 - a).powi(2), -sign * (1.5 - a))
            } else {
                (0.0, 0.0)
            }
        }
        ShapeFunction::CubicBSpline => {
            if a < 1.0 {
                (2.0 / 3.0 - a * a + 0.5 * a.powi(3), -2.0 * xi + 1.5 * sign * a * a)
            } else if a < 2.0 {
                ((2.0 - a).powi(3) / 6.0, -sign * 0.5 * (2.0 - a).powi(2))
            } else {
                (0.0, 0.0)
            }
        }
        ShapeFunction::Gimp { half_width: l } => {
            // T(u) = ∫_{−∞}^{u} tent: S(ξ) = (T(ξ + l) − T(ξ − l))/(2l), S'(ξ) = (tent(ξ + l) − tent(ξ − l))/(2l).
            let antiderivative = |u: f64| {
                if u <= -1.0 {
                    0.0
                } else if u <= 0.0 {
                    0.5 * (1.0 + u).powi(2)
                } else if u <= 1.0 {
                    1.0 - 0.5 * (1.0 - u).powi(2)
                } else {
                    1.0
                }
            };
            (
                (antiderivative(xi + l) - antiderivative(xi - l)) / (2.0 * l),
                (tent(xi + l) - tent(xi - l)) / (2.0 * l),
            )
        }
        ShapeFunction::Linear => panic!("linear is checked against common::ref_axis"),
    }
}

/// `(N, Gx, Gy)` of every node at `(x, y)`.
fn all_nodes(grid: &Grid, shape: ShapeFunction, x: f64, y: f64) -> Vec<(f64, f64, f64)> {
    (0..ref_num_nodes(grid))
        .map(|k| evaluate(grid, shape, k, x, y))
        .collect()
}

/// Assembles `shape` at `(x, y)` through `reassemble`.
fn assemble_at(grid: &Grid, shape: ShapeFunction, x: &[f64], y: &[f64]) -> Result<Operators, MpmError> {
    let mut ops = Operators::default();
    ops.reassemble(grid, shape, x, y).map(|()| ops)
}

/// Pattern and values of an assembly, for "unchanged" checks.
fn pattern_and_values(ops: &Operators) -> (Vec<usize>, Vec<usize>, [Vec<f64>; 3]) {
    (
        ops.col_offsets().to_vec(),
        ops.row_indices().to_vec(),
        [Operator::N, Operator::Gx, Operator::Gy].map(|op| ops.values(op).to_vec()),
    )
}

#[test]
fn kernels_report_their_name_support_margin_and_boundary_layers() {
    let gimp = |half_width| ShapeFunction::Gimp { half_width };
    let table = [
        (ShapeFunction::Linear, "linear", 2, 0.0, 1),
        (gimp(0.25), "gimp", 3, 0.25, 2),
        (gimp(0.5), "gimp", 3, 0.5, 2),
        (ShapeFunction::QuadraticBSpline, "quadratic_bspline", 3, 0.5, 2),
        (ShapeFunction::CubicBSpline, "cubic_bspline", 4, 1.0, 3),
    ];
    for (shape, name, support, margin, layers) in table {
        assert_eq!(shape.name(), name);
        assert_eq!(shape.support(), support, "{name}");
        assert_eq!(shape.nodes_per_particle(), support * support, "{name}");
        assert_eq!(shape.margin(), margin, "{name}");
        assert_eq!(shape.boundary_layers(), layers, "{name}");
        assert!(shape.validate().is_ok(), "{name}");
    }
    assert_eq!(ShapeFunction::default(), ShapeFunction::Linear);
}

#[test]
fn every_kernel_sums_to_one_across_the_allowed_region_including_its_boundary_and_grid_lines() {
    for (g, grid) in kernel_grids().iter().enumerate() {
        for (k, shape) in kernels().into_iter().enumerate() {
            for (x, y) in allowed_points(grid, shape, 1000 + 10 * g as u64 + k as u64) {
                let sum: f64 = all_nodes(grid, shape, x, y).iter().map(|w| w.0).sum();
                assert!(
                    (sum - 1.0).abs() <= KERNEL_UNITY_TOL,
                    "{shape:?}: Σ_I N_I({x}, {y}) = {sum} on {grid:?}"
                );
            }
        }
    }
}

#[test]
fn every_kernel_reproduces_linear_fields() {
    for (g, grid) in kernel_grids().iter().enumerate() {
        let (node_x, node_y) = ref_node_coordinates(grid);
        for (k, shape) in kernels().into_iter().enumerate() {
            for (x, y) in allowed_points(grid, shape, 1100 + 10 * g as u64 + k as u64) {
                let w = all_nodes(grid, shape, x, y);
                let sx: f64 = w.iter().zip(&node_x).map(|(w, xi)| w.0 * xi).sum();
                let sy: f64 = w.iter().zip(&node_y).map(|(w, yi)| w.0 * yi).sum();
                assert!(
                    (sx - x).abs() <= KERNEL_LINEAR_FIELD_TOL,
                    "{shape:?}: Σ N_I x_I = {sx} at x = {x} on {grid:?}"
                );
                assert!(
                    (sy - y).abs() <= KERNEL_LINEAR_FIELD_TOL,
                    "{shape:?}: Σ N_I y_I = {sy} at y = {y} on {grid:?}"
                );
            }
        }
    }
}

#[test]
fn every_kernel_gradient_sums_to_zero_and_reproduces_the_gradient_of_linear_fields() {
    for (g, grid) in kernel_grids().iter().enumerate() {
        let (node_x, node_y) = ref_node_coordinates(grid);
        let [hx, hy] = grid.cell_size();
        for (k, shape) in kernels().into_iter().enumerate() {
            for (x, y) in allowed_points(grid, shape, 1200 + 10 * g as u64 + k as u64) {
                let w = all_nodes(grid, shape, x, y);
                let sum = |f: &dyn Fn(usize) -> f64| (0..w.len()).map(f).sum::<f64>();
                let checks = [
                    ("Σ Gx_I", sum(&|i| w[i].1), 0.0, hx),
                    ("Σ Gy_I", sum(&|i| w[i].2), 0.0, hy),
                    ("Σ Gx_I x_I", sum(&|i| w[i].1 * node_x[i]), 1.0, hx),
                    ("Σ Gx_I y_I", sum(&|i| w[i].1 * node_y[i]), 0.0, hx),
                    ("Σ Gy_I x_I", sum(&|i| w[i].2 * node_x[i]), 0.0, hy),
                    ("Σ Gy_I y_I", sum(&|i| w[i].2 * node_y[i]), 1.0, hy),
                ];
                for (name, value, expected, h) in checks {
                    assert!(
                        (value - expected).abs() <= KERNEL_GRADIENT_TOL_PER_UNIT_INV_H / h,
                        "{shape:?}: {name} = {value}, expected {expected} at ({x}, {y}) on {grid:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn every_kernel_gradient_agrees_with_central_finite_differences_away_from_kinks() {
    for (g, grid) in kernel_grids().iter().enumerate() {
        let [hx, hy] = grid.cell_size();
        let (dx, dy) = (KERNEL_FD_STEP * hx, KERNEL_FD_STEP * hy);
        for (k, shape) in kernels().into_iter().enumerate() {
            for (x, y) in points_off_breakpoints(grid, shape, 40, 1300 + 10 * g as u64 + k as u64) {
                for node in 0..ref_num_nodes(grid) {
                    let n = |x: f64, y: f64| evaluate(grid, shape, node, x, y).0;
                    let fd_x = (n(x + dx, y) - n(x - dx, y)) / (2.0 * dx);
                    let fd_y = (n(x, y + dy) - n(x, y - dy)) / (2.0 * dy);
                    let (_, gx, gy) = evaluate(grid, shape, node, x, y);
                    assert!(
                        (gx - fd_x).abs() <= KERNEL_FD_TOL_PER_CELL_UNIT / hx,
                        "{shape:?}: ∂N_{node}/∂x at ({x}, {y}) = {gx}, central difference {fd_x}"
                    );
                    assert!(
                        (gy - fd_y).abs() <= KERNEL_FD_TOL_PER_CELL_UNIT / hy,
                        "{shape:?}: ∂N_{node}/∂y at ({x}, {y}) = {gy}, central difference {fd_y}"
                    );
                }
            }
        }
    }
}

#[test]
fn every_kernel_is_non_negative() {
    for (g, grid) in kernel_grids().iter().enumerate() {
        for (k, shape) in kernels().into_iter().enumerate() {
            let pts = allowed_points(grid, shape, 1400 + 10 * g as u64 + k as u64);
            for &(x, y) in &pts {
                for (node, w) in all_nodes(grid, shape, x, y).iter().enumerate() {
                    assert!(w.0 >= 0.0, "{shape:?}: N_{node}({x}, {y}) = {}", w.0);
                }
            }
            let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
            let ops = assemble_at(grid, shape, &x, &y).unwrap();
            assert!(ops.values(Operator::N).iter().all(|&v| v >= 0.0), "{shape:?}");
        }
    }
}

#[test]
fn every_kernel_equals_its_textbook_formula_at_every_node() {
    for (g, grid) in kernel_grids().iter().enumerate() {
        let ([x0, y0], [hx, hy], [cx, cy]) = (grid.origin(), grid.cell_size(), grid.cells());
        for (k, shape) in kernels().into_iter().enumerate() {
            for (x, y) in allowed_points(grid, shape, 1500 + 10 * g as u64 + k as u64) {
                for node in 0..ref_num_nodes(grid) {
                    let (n, gx, gy) = evaluate(grid, shape, node, x, y);
                    let (i, j) = ref_node_ij(grid, node);
                    let (s, t) = ((x - x0) / hx, (y - y0) / hy);
                    let ((sx, dsx), (sy, dsy)) = if shape == ShapeFunction::Linear {
                        // `(x − x₀)/h` may round a hair past the last grid line: clamp as the
                        // grid's closed bounds imply.
                        let axis = |s: f64, i: usize, cells: usize| {
                            ref_axis(s.clamp(0.0, cells as f64), i, cells).expect("the point is on the grid")
                        };
                        (axis(s, i, cx), axis(t, j, cy))
                    } else {
                        (
                            textbook_kernel(shape, s - i as f64),
                            textbook_kernel(shape, t - j as f64),
                        )
                    };
                    let (n_ref, gx_ref, gy_ref) = (sx * sy, dsx / hx * sy, sx * dsy / hy);
                    let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= KERNEL_REFERENCE_TOL * scale;
                    assert!(
                        close(n, n_ref, 1.0) && close(gx, gx_ref, 4.0 / hx) && close(gy, gy_ref, 4.0 / hy),
                        "{shape:?}: node {node} at ({x}, {y}): (N, Gx, Gy) = {:?}, textbook {:?} on {grid:?}",
                        (n, gx, gy),
                        (n_ref, gx_ref, gy_ref)
                    );
                }
            }
        }
    }
}

#[test]
fn assembled_columns_have_support_squared_ascending_entries_equal_to_evaluate_for_every_kernel() {
    for (g, grid) in kernel_grids().iter().enumerate() {
        for (k, shape) in kernels().into_iter().enumerate() {
            let (x, y): (Vec<f64>, Vec<f64>) = allowed_points(grid, shape, 1600 + 10 * g as u64 + k as u64)
                .into_iter()
                .unzip();
            let ops = assemble_at(grid, shape, &x, &y).unwrap();
            assert_eq!(ops.shape_function(), shape);
            assert_eq!(ops.nnz(), x.len() * shape.nodes_per_particle(), "{shape:?}");
            let [n, gx, gy] = [Operator::N, Operator::Gx, Operator::Gy].map(|op| DMatrix::from(&ops.matrix(op)));
            for p in 0..x.len() {
                let rows: Vec<usize> = ops.column(p).map(|e| e.0).collect();
                assert_eq!(rows.len(), shape.nodes_per_particle(), "{shape:?}: column {p}");
                assert!(
                    rows.windows(2).all(|w| w[0] < w[1]),
                    "{shape:?}: column {p} rows {rows:?} are not strictly ascending"
                );
                for node in 0..ref_num_nodes(grid) {
                    assert_eq!(
                        (n[(node, p)], gx[(node, p)], gy[(node, p)]),
                        evaluate(grid, shape, node, x[p], y[p]),
                        "{shape:?}: entries [{node}, {p}] (particle at ({}, {})) differ from evaluate",
                        x[p],
                        y[p]
                    );
                }
            }
        }
    }
}

#[test]
fn a_particle_inside_the_margin_is_a_support_outside_grid_error_naming_it() {
    for (g, grid) in kernel_grids().iter().enumerate() {
        let [cx, cy] = grid.cells();
        let [x0, _, _, y1] = grid.bounds();
        for (k, shape) in kernels().into_iter().enumerate() {
            let m = shape.margin();
            if m == 0.0 {
                continue; // linear: every point of the grid is accepted.
            }
            let seed = 1700 + 10 * g as u64 + k as u64;
            let (x, y): (Vec<f64>, Vec<f64>) = allowed_points(grid, shape, seed).into_iter().unzip();
            let mut ops = assemble_at(grid, shape, &x, &y).unwrap();
            let before = pattern_and_values(&ops);
            let mut rng = Lcg::new(seed);
            let (xm, ym) = (
                random_allowed(grid, shape, 0, &mut rng),
                random_allowed(grid, shape, 1, &mut rng),
            );
            let inside_margin = [
                (at(grid, 0, m - INSIDE_MARGIN), ym),
                (at(grid, 0, cx as f64 - m + INSIDE_MARGIN), ym),
                (xm, at(grid, 1, m - INSIDE_MARGIN)),
                (xm, at(grid, 1, cy as f64 - m + INSIDE_MARGIN)),
                (at(grid, 0, 0.5 * m), at(grid, 1, cy as f64 - 0.5 * m)),
                (x0, ym),
                (xm, y1),
            ];
            for (case, (px, py)) in inside_margin.into_iter().enumerate() {
                let (mut bx, mut by) = (x.clone(), y.clone());
                let p = 3 + case;
                bx[p] = px;
                by[p] = py;
                // A second offender later on: the error names the first.
                let last = bx.len() - 1;
                bx[last] = at(grid, 0, 0.25 * m);
                let err = ops.reassemble(grid, shape, &bx, &by).unwrap_err();
                let message = err.to_string();
                match err {
                    MpmError::SupportOutsideGrid {
                        particle,
                        position,
                        shape: name,
                        allowed,
                        padding,
                    } => {
                        assert_eq!(particle, p, "{shape:?}");
                        assert_eq!(position, [px, py]);
                        assert_eq!(name, shape.name());
                        assert_eq!(allowed, shape.allowed_region(grid));
                        assert_eq!(padding, shape.recommended_padding());
                    }
                    other => panic!("{shape:?}: expected SupportOutsideGrid for particle {p}, got {other:?}"),
                }
                for part in [
                    format!("particle {p} "),
                    shape.name().to_string(),
                    "pad the grid".to_string(),
                ] {
                    assert!(message.contains(&part), "message {message:?} lacks {part:?}");
                }
                assert_eq!(
                    pattern_and_values(&ops),
                    before,
                    "{shape:?}: a failed reassembly changed the operators"
                );
                assert!(
                    all_nodes(grid, shape, px, py).iter().all(|&w| w == (0.0, 0.0, 0.0)),
                    "{shape:?}: evaluate gives weights inside the margin at ({px}, {py})"
                );
            }
        }
    }
}

#[test]
fn a_particle_outside_the_grid_is_still_a_particle_outside_grid_error_for_every_kernel() {
    let grid = &kernel_grids()[0];
    let [x0, x1, y0, y1] = grid.bounds();
    for shape in kernels() {
        let mut rng = Lcg::new(1800);
        let (mut x, mut y): (Vec<f64>, Vec<f64>) = (0..10)
            .map(|_| {
                (
                    random_allowed(grid, shape, 0, &mut rng),
                    random_allowed(grid, shape, 1, &mut rng),
                )
            })
            .unzip();
        let outside = [
            (x1 + 1e-9, 0.5 * (y0 + y1)),
            (0.5 * (x0 + x1), y0 - 1.0),
            (f64::NAN, 0.5 * (y0 + y1)),
        ];
        for (px, py) in outside {
            x[4] = px;
            y[4] = py;
            match assemble_at(grid, shape, &x, &y).unwrap_err() {
                MpmError::ParticleOutsideGrid { particle, bounds, .. } => {
                    assert_eq!(particle, 4);
                    assert_eq!(bounds, grid.bounds());
                }
                other => panic!("{shape:?}: expected ParticleOutsideGrid, got {other:?}"),
            }
        }
    }
}

#[test]
fn a_particle_a_rounding_error_outside_the_margin_is_accepted_as_on_the_margin() {
    for grid in kernel_grids() {
        let [cx, cy] = grid.cells();
        for shape in kernels() {
            let m = shape.margin();
            if m == 0.0 {
                continue; // linear: outside the margin is outside the grid.
            }
            let mut rng = Lcg::new(1900);
            let (xm, ym) = (
                random_allowed(&grid, shape, 0, &mut rng),
                random_allowed(&grid, shape, 1, &mut rng),
            );
            let (lo, hi) = (m - ROUNDING_OUTSIDE_MARGIN, ROUNDING_OUTSIDE_MARGIN - m);
            // (a hair outside, exactly on the margin)
            let pairs = [
                ((at(&grid, 0, lo), ym), (at(&grid, 0, m), ym)),
                ((at(&grid, 0, cx as f64 + hi), ym), (at(&grid, 0, cx as f64 - m), ym)),
                ((xm, at(&grid, 1, lo)), (xm, at(&grid, 1, m))),
                ((xm, at(&grid, 1, cy as f64 + hi)), (xm, at(&grid, 1, cy as f64 - m))),
            ];
            for ((px, py), (ex, ey)) in pairs {
                let hair = assemble_at(&grid, shape, &[px], &[py])
                    .unwrap_or_else(|e| panic!("{shape:?}: ({px}, {py}) was rejected: {e}"));
                let on = assemble_at(&grid, shape, &[ex], &[ey]).unwrap();
                assert_eq!(hair.row_indices(), on.row_indices(), "{shape:?}");
                for (a, b) in hair.values(Operator::N).iter().zip(on.values(Operator::N)) {
                    assert!((a - b).abs() <= KERNEL_UNITY_TOL, "{shape:?}: {a} vs {b}");
                }
                let sum: f64 = hair.values(Operator::N).iter().sum();
                assert!((sum - 1.0).abs() <= KERNEL_UNITY_TOL, "{shape:?}: Σ N = {sum}");
            }
        }
    }
}

#[test]
fn a_particle_exactly_at_the_margin_has_zero_weight_beyond_the_boundary_layers_and_not_one_layer_less() {
    for grid in kernel_grids() {
        let [cx, cy] = grid.cells();
        for shape in kernels() {
            let (m, layers) = (shape.margin(), shape.boundary_layers());
            let mut rng = Lcg::new(2000);
            // (axis, low edge?, a particle at the margin of that edge)
            let edges = [
                (0, true, (at(&grid, 0, m), random_allowed(&grid, shape, 1, &mut rng))),
                (
                    0,
                    false,
                    (at(&grid, 0, cx as f64 - m), random_allowed(&grid, shape, 1, &mut rng)),
                ),
                (1, true, (random_allowed(&grid, shape, 0, &mut rng), at(&grid, 1, m))),
                (
                    1,
                    false,
                    (random_allowed(&grid, shape, 0, &mut rng), at(&grid, 1, cy as f64 - m)),
                ),
            ];
            for (axis, low, (x, y)) in edges {
                let cells = grid.cells()[axis];
                // Layer of a node counted from the edge (0 = the nodes on the edge).
                let layer = |node: usize| {
                    let (i, j) = ref_node_ij(&grid, node);
                    let index = [i, j][axis];
                    if low {
                        index
                    } else {
                        cells - index
                    }
                };
                // The position is at the margin up to rounding, so "zero" is up to rounding too.
                let weighted: Vec<usize> = all_nodes(&grid, shape, x, y)
                    .iter()
                    .enumerate()
                    .filter(|(_, w)| w.0 > KERNEL_UNITY_TOL)
                    .map(|(node, _)| layer(node))
                    .collect();
                assert!(
                    weighted.iter().all(|&l| l < layers),
                    "{shape:?}: a particle at the margin ({x}, {y}) weighs on layers {weighted:?}, beyond the \
                     {layers} held"
                );
                assert!(
                    weighted.contains(&(layers - 1)),
                    "{shape:?}: at ({x}, {y}) layer {} carries no weight, so fewer than {layers} layers would do",
                    layers - 1
                );
            }
        }
    }
}

#[test]
fn an_invalid_gimp_half_width_is_rejected() {
    let grid = &kernel_grids()[0];
    let [x0, x1, y0, y1] = grid.bounds();
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let invalid = [
        0.0,
        -0.25,
        0.5 + 1e-12,
        0.75,
        1.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for half_width in invalid {
        let shape = ShapeFunction::Gimp { half_width };
        let check = |err: MpmError| match err {
            MpmError::InvalidParameter { name, value, .. } => {
                assert_eq!(name, "half_width");
                assert!(value == half_width || (value.is_nan() && half_width.is_nan()));
            }
            other => panic!("half_width = {half_width}: expected InvalidParameter, got {other:?}"),
        };
        check(shape.validate().unwrap_err());
        check(assemble_at(grid, shape, &[xm], &[ym]).unwrap_err());
        check(assemble_at(grid, shape, &[], &[]).unwrap_err());
        assert!(shape.axis_weights(grid, 0, xm).is_none());
        assert!(all_nodes(grid, shape, xm, ym).iter().all(|&w| w == (0.0, 0.0, 0.0)));
    }
    for half_width in [1e-3, 0.125, 0.25, 0.5] {
        assert!(ShapeFunction::Gimp { half_width }.validate().is_ok(), "{half_width}");
    }
}

#[test]
fn a_grid_with_too_few_cells_for_the_support_is_an_invalid_grid_error() {
    let too_small = [
        (ShapeFunction::QuadraticBSpline, [1, 4]),
        (ShapeFunction::Gimp { half_width: 0.5 }, [4, 1]),
        (ShapeFunction::CubicBSpline, [2, 5]),
    ];
    for (shape, cells) in too_small {
        let grid = Grid::new([0.5, -1.0], [0.4, 0.3], cells).unwrap();
        let m = shape.margin();
        let (x, y) = (at(&grid, 0, m), at(&grid, 1, m));
        match assemble_at(&grid, shape, &[x], &[y]).unwrap_err() {
            MpmError::InvalidGrid { reason } => assert!(reason.contains(shape.name()), "{reason}"),
            other => panic!("{shape:?} on {cells:?} cells: expected InvalidGrid, got {other:?}"),
        }
        assert!(all_nodes(&grid, shape, x, y).iter().all(|&w| w == (0.0, 0.0, 0.0)));
        // No particles, nothing to place: not an error.
        assert!(assemble_at(&grid, shape, &[], &[]).is_ok());
    }
}

/// The public 1D kernels and per-stencil weight functions, swept across their support
/// (including the breakpoints), against the independent textbook formulas above; uGIMP also
/// with half-widths other than the two the 2D tests use.
#[test]
fn public_1d_kernels_and_stencil_weights_equal_the_textbook_formulas() {
    use sparse_mpm::shape::{bspline, gimp, linear};
    let sweep: Vec<f64> = (-2400..=2400)
        .map(|k| k as f64 / 960.0) // hits every multiple of 1/2, 1/4, 1/6, 1/8, 1/10
        .collect();
    let close = |a: (f64, f64), b: (f64, f64), what: &str| {
        assert!(
            (a.0 - b.0).abs() <= KERNEL_REFERENCE_TOL && (a.1 - b.1).abs() <= KERNEL_DERIVATIVE_REFERENCE_TOL,
            "{what}: {a:?}, textbook {b:?}"
        );
    };
    for &xi in &sweep {
        let q = ShapeFunction::QuadraticBSpline;
        let c = ShapeFunction::CubicBSpline;
        close(
            (bspline::quadratic(xi), bspline::quadratic_derivative(xi)),
            textbook_kernel(q, xi),
            &format!("quadratic at ξ = {xi}"),
        );
        close(
            (bspline::cubic(xi), bspline::cubic_derivative(xi)),
            textbook_kernel(c, xi),
            &format!("cubic at ξ = {xi}"),
        );
        assert_eq!(linear::tent(xi), tent(xi));
        for l in [0.1, 1.0 / 6.0, 0.25, 0.5] {
            let g = ShapeFunction::Gimp { half_width: l };
            close(
                gimp::kernel(xi, l),
                textbook_kernel(g, xi),
                &format!("uGIMP l = {l} at ξ = {xi}"),
            );
            assert_eq!((gimp::value(xi, l), gimp::derivative(xi, l)), gimp::kernel(xi, l));
        }
    }
    // Stencil weights: node k of the stencil is at ξ = (offset of the point from it).
    for &t in sweep.iter().filter(|t| t.abs() <= 0.5) {
        let (w, d) = bspline::quadratic_weights(t);
        for k in 0..3 {
            let xi = t + 1.0 - k as f64;
            close(
                (w[k], d[k]),
                textbook_kernel(ShapeFunction::QuadraticBSpline, xi),
                &format!("quadratic_weights({t})[{k}]"),
            );
        }
        for l in [0.1, 1.0 / 6.0, 0.25, 0.5] {
            let (w, d) = gimp::nearest_weights(t, l);
            for k in 0..3 {
                let xi = t + 1.0 - k as f64;
                close(
                    (w[k], d[k]),
                    textbook_kernel(ShapeFunction::Gimp { half_width: l }, xi),
                    &format!("nearest_weights({t}, {l})[{k}]"),
                );
            }
        }
    }
    for &t in sweep.iter().filter(|t| (0.0..=1.0).contains(*t)) {
        let (w, d) = bspline::cubic_weights(t);
        for k in 0..4 {
            let xi = t + 1.0 - k as f64;
            close(
                (w[k], d[k]),
                textbook_kernel(ShapeFunction::CubicBSpline, xi),
                &format!("cubic_weights({t})[{k}]"),
            );
        }
    }
}
