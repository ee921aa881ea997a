//! Properties of the bilinear shape functions `shape`, `dshape` and of the columns of N, Gx, Gy:
//! partition of unity, gradients summing to zero, reproduction of linear fields, agreement
//! with finite differences and with an independent tent-function reference.

mod common;

use common::*;
use sparse_mpm::{dshape, shape, Grid, Operators, Particles, ShapeFunction};

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
