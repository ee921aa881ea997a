//! Grid construction, node numbering in both orders, recovery from node coordinate lists, and
//! the errors for unusable grid parameters or coordinate lists.

mod common;

use common::*;
use sparse_mpm::{Grid, MpmError, NodeOrder};

/// Positions of nodes built as `x₀ + i h` by the library and by the test: the same arithmetic,
/// but allow a couple of ulps in case the library evaluates it differently.
const POSITION_TOL: f64 = 1e-12;

fn both_orders(origin: [f64; 2], size: [f64; 2], cells: [usize; 2]) -> [Grid; 2] {
    let g = Grid::new(origin, size, cells).unwrap();
    [
        g.clone().with_node_order(NodeOrder::XFastest),
        g.with_node_order(NodeOrder::YFastest),
    ]
}

fn not_a_uniform_grid_reason(result: Result<Grid, MpmError>) -> String {
    let err = match result {
        Err(err) => err,
        Ok(grid) => panic!("expected NotAUniformGrid, got {grid:?}"),
    };
    let text = err.to_string();
    match err {
        MpmError::NotAUniformGrid { reason } => {
            assert!(text.contains(&reason), "the message carries the reason: {text}");
            reason
        }
        other => panic!("expected NotAUniformGrid, got {other:?}"),
    }
}

#[test]
fn new_grid_uses_x_fastest_numbering_by_default_and_reports_its_parameters() {
    let g = Grid::new([1.5, -2.0], [0.25, 0.75], [3, 5]).unwrap();
    assert_eq!(g.node_order(), NodeOrder::XFastest);
    assert_eq!(g.origin(), [1.5, -2.0]);
    assert_eq!(g.cell_size(), [0.25, 0.75]);
    assert_eq!(g.cells(), [3, 5]);
    assert_eq!(g.nodes_per_axis(), [4, 6]);
    assert_eq!(g.num_nodes(), 24);
    assert_eq!(g.bounds(), [1.5, 1.5 + 3.0 * 0.25, -2.0, -2.0 + 5.0 * 0.75]);
}

#[test]
fn node_index_follows_the_documented_formula_in_both_orders() {
    for grid in both_orders([0.0, 0.0], [1.0, 1.0], [3, 2]) {
        let [cx, cy] = grid.cells();
        for i in 0..=cx {
            for j in 0..=cy {
                let expected = match grid.node_order() {
                    NodeOrder::XFastest => i + j * (cx + 1),
                    NodeOrder::YFastest => j + i * (cy + 1),
                };
                assert_eq!(grid.node_index(i, j), expected, "({i}, {j}) in {:?}", grid.node_order());
            }
        }
        let [sx, sy] = grid.strides();
        assert_eq!(grid.node_index(1, 0), sx);
        assert_eq!(grid.node_index(0, 1), sy);
    }
}

#[test]
fn node_index_node_ij_and_node_position_round_trip_in_both_orders() {
    for grid in both_orders([-0.5, 3.0], [0.3, 0.7], [4, 3])
        .into_iter()
        .chain(both_orders([0.0, 0.0], [1.0, 1.0], [1, 1]))
    {
        let n = grid.num_nodes();
        assert_eq!(n, ref_num_nodes(&grid));
        let mut seen = vec![false; n];
        for id in 0..n {
            let (i, j) = grid.node_ij(id);
            assert_eq!((i, j), ref_node_ij(&grid, id));
            assert_eq!(grid.node_index(i, j), id);
            assert!(!seen[id]);
            seen[id] = true;
            let [x, y] = grid.node_position(id);
            let [ex, ey] = ref_node_position(&grid, id);
            assert!(
                (x - ex).abs() <= POSITION_TOL && (y - ey).abs() <= POSITION_TOL,
                "node {id}"
            );
        }
        assert!(seen.iter().all(|&s| s), "every node number is used once");
        let (ex, ey) = ref_node_coordinates(&grid);
        assert!(max_abs_diff_slice(&grid.node_x(), &ex) <= POSITION_TOL);
        assert!(max_abs_diff_slice(&grid.node_y(), &ey) <= POSITION_TOL);
    }
}

#[test]
fn from_node_coordinates_recovers_the_seed_grid_as_y_fastest_with_2x1_unit_cells() {
    let grid = Grid::from_node_coordinates(&SEED_NODE_X, &SEED_NODE_Y).unwrap();
    assert_eq!(grid.node_order(), NodeOrder::YFastest);
    assert_eq!(grid.cells(), [2, 1]);
    assert_eq!(grid.cell_size(), [1.0, 1.0]);
    assert_eq!(grid.origin(), [0.0, 0.0]);
    assert_eq!(grid.node_x(), SEED_NODE_X.to_vec());
    assert_eq!(grid.node_y(), SEED_NODE_Y.to_vec());
}

#[test]
fn from_node_coordinates_recovers_an_x_fastest_list_as_x_fastest() {
    let x = [0.0, 1.0, 2.0, 0.0, 1.0, 2.0];
    let y = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    let grid = Grid::from_node_coordinates(&x, &y).unwrap();
    assert_eq!(grid.node_order(), NodeOrder::XFastest);
    assert_eq!(grid.cells(), [2, 1]);
    assert_eq!(grid.cell_size(), [1.0, 1.0]);
}

#[test]
fn from_node_coordinates_recovers_grids_built_with_new_in_both_orders() {
    for (origin, size, cells) in [
        ([0.0, 0.0], [0.5, 0.5], [4, 3]),
        ([-1.5, 2.0], [0.25, 0.75], [3, 5]),
        ([0.1, -0.35], [0.3, 0.7], [5, 2]),
        ([3.0, -4.0], [2.0, 0.5], [1, 1]),
    ] {
        for grid in both_orders(origin, size, cells) {
            let (x, y) = ref_node_coordinates(&grid);
            let back = Grid::from_node_coordinates(&x, &y).unwrap();
            assert_eq!(back.node_order(), grid.node_order(), "{grid:?}");
            assert_eq!(back.cells(), grid.cells());
            for axis in 0..2 {
                assert!((back.origin()[axis] - grid.origin()[axis]).abs() <= POSITION_TOL);
                assert!((back.cell_size()[axis] - grid.cell_size()[axis]).abs() <= POSITION_TOL);
            }
        }
    }
}

#[test]
fn from_node_coordinates_with_mismatched_lengths_is_a_length_mismatch() {
    match Grid::from_node_coordinates(&SEED_NODE_X, &SEED_NODE_Y[..5]) {
        Err(MpmError::LengthMismatch { expected, found, .. }) => assert_eq!((expected, found), (6, 5)),
        other => panic!("expected LengthMismatch, got {other:?}"),
    }
}

/// An x-fastest list whose last node repeats the one before it.
#[test]
fn from_node_coordinates_with_a_duplicated_node_in_an_x_fastest_list_names_the_node() {
    let x = [0.0, 1.0, 2.0, 0.0, 1.0, 1.0];
    let y = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    let reason = not_a_uniform_grid_reason(Grid::from_node_coordinates(&x, &y));
    assert!(reason.contains("node 5"), "{reason}");
}

/// The seed's y-fastest list with node 5 replaced by a copy of node 4. Regression: the message
/// used to name node 1 (the first mismatch of the x-fastest order) although the list is
/// y-fastest up to the duplicated node.
#[test]
fn from_node_coordinates_with_a_duplicated_node_in_a_y_fastest_list_names_the_node() {
    let x = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0];
    let y = [0.0, 1.0, 0.0, 1.0, 0.0, 0.0];
    let reason = not_a_uniform_grid_reason(Grid::from_node_coordinates(&x, &y));
    assert!(reason.contains("node 5"), "{reason}");
}

#[test]
fn from_node_coordinates_with_shuffled_x_fastest_order_names_the_first_misplaced_node() {
    // Nodes 3 and 4 swapped.
    let x = [0.0, 1.0, 2.0, 1.0, 0.0, 2.0];
    let y = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    let reason = not_a_uniform_grid_reason(Grid::from_node_coordinates(&x, &y));
    assert!(reason.contains("node 3"), "{reason}");
}

/// The seed's list with nodes 4 and 5 swapped: the first misplaced node is 4. Regression: the
/// message used to name node 1 (see the duplicated-node case).
#[test]
fn from_node_coordinates_with_shuffled_y_fastest_order_names_the_first_misplaced_node() {
    let x = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0];
    let y = [0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
    let reason = not_a_uniform_grid_reason(Grid::from_node_coordinates(&x, &y));
    assert!(reason.contains("node 4"), "{reason}");
}

#[test]
fn from_node_coordinates_with_non_uniform_spacing_is_not_a_uniform_grid() {
    // Uneven in x (0, 1, 2.5), listed y-fastest.
    let x = [0.0, 0.0, 1.0, 1.0, 2.5, 2.5];
    let y = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
    not_a_uniform_grid_reason(Grid::from_node_coordinates(&x, &y));
    // Uneven in y (0, 1, 3), listed x-fastest.
    let x = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
    let y = [0.0, 0.0, 1.0, 1.0, 3.0, 3.0];
    not_a_uniform_grid_reason(Grid::from_node_coordinates(&x, &y));
}

/// x = 0, 1, 2.5: the offending nodes are 2 and 3 (x = 1, where even spacing puts 1.25); the
/// error's docs promise the reason names "the offending node (0-based) where there is one".
/// Regression: the message used to name only the value.
#[test]
fn from_node_coordinates_with_non_uniform_spacing_names_the_node() {
    let x = [0.0, 0.0, 1.0, 1.0, 2.5, 2.5];
    let y = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
    let reason = not_a_uniform_grid_reason(Grid::from_node_coordinates(&x, &y));
    assert!(reason.contains("node 2") || reason.contains("node 3"), "{reason}");
}

#[test]
fn from_node_coordinates_with_a_non_finite_coordinate_names_the_node() {
    let mut y = SEED_NODE_Y;
    y[3] = f64::NAN;
    let reason = not_a_uniform_grid_reason(Grid::from_node_coordinates(&SEED_NODE_X, &y));
    assert!(reason.contains("node 3"), "{reason}");
}

#[test]
fn from_node_coordinates_with_too_few_distinct_values_is_not_a_uniform_grid() {
    not_a_uniform_grid_reason(Grid::from_node_coordinates(&[0.0, 1.0, 2.0], &[0.0, 0.0, 0.0]));
    not_a_uniform_grid_reason(Grid::from_node_coordinates(&[0.0], &[0.0]));
    // 3 distinct x and 2 distinct y make 6 nodes, but 5 are given.
    not_a_uniform_grid_reason(Grid::from_node_coordinates(
        &[0.0, 0.0, 1.0, 1.0, 2.0],
        &[0.0, 1.0, 0.0, 1.0, 0.0],
    ));
}

/// User data never causes a panic. Regression: empty lists used to overflow an index
/// (`v[v.len() - 1]`) in the search for distinct coordinates.
#[test]
fn from_node_coordinates_with_empty_lists_is_an_error_not_a_panic() {
    let result = std::panic::catch_unwind(|| Grid::from_node_coordinates(&[], &[]));
    let result = result.expect("from_node_coordinates panicked on empty lists");
    not_a_uniform_grid_reason(result);
}

fn invalid_grid(result: Result<Grid, MpmError>) -> String {
    match result {
        Err(MpmError::InvalidGrid { reason }) => reason,
        other => panic!("expected InvalidGrid, got {other:?}"),
    }
}

#[test]
fn new_grid_rejects_zero_cells() {
    invalid_grid(Grid::new([0.0, 0.0], [1.0, 1.0], [0, 3]));
    invalid_grid(Grid::new([0.0, 0.0], [1.0, 1.0], [3, 0]));
}

#[test]
fn new_grid_rejects_non_positive_or_non_finite_cell_size() {
    for bad in [0.0, -1.0, -0.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let rx = invalid_grid(Grid::new([0.0, 0.0], [bad, 1.0], [2, 2]));
        assert!(rx.contains('x'), "{rx}");
        let ry = invalid_grid(Grid::new([0.0, 0.0], [1.0, bad], [2, 2]));
        assert!(ry.contains('y'), "{ry}");
    }
}

#[test]
fn new_grid_rejects_a_non_finite_origin() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        invalid_grid(Grid::new([bad, 0.0], [1.0, 1.0], [2, 2]));
        invalid_grid(Grid::new([0.0, bad], [1.0, 1.0], [2, 2]));
    }
}

#[test]
fn contains_accepts_the_closed_rectangle_and_cell_of_uses_half_open_cells() {
    let grid = Grid::new([-1.0, 2.0], [0.5, 0.25], [4, 2]).unwrap();
    let [x0, x1, y0, y1] = grid.bounds();
    assert!(grid.contains(x0, y0) && grid.contains(x1, y1) && grid.contains(x0, y1) && grid.contains(x1, y0));
    assert!(!grid.contains(x1 + 1e-12, y0) && !grid.contains(x0, y0 - 1e-12));
    assert!(!grid.contains(f64::NAN, y0));
    // Interior line x = −0.5 belongs to the cell on its right; the last line to the last cell.
    assert_eq!(grid.cell_of(-0.5, 2.1), Some((1, 0)));
    assert_eq!(grid.cell_of(x1, y1), Some((3, 1)));
    assert_eq!(grid.cell_of(x0, 2.25), Some((0, 1)));
    assert_eq!(grid.cell_of(x1 + 0.1, y0), None);
}
