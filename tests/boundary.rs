//! Boundary conditions: which nodes an edge, a rectangle or a node list selects, what each
//! condition prescribes, and the errors for contradictory conditions.

use sparse_mpm::boundary::{resolve, BoundaryCondition, Condition, Edge};
use sparse_mpm::{Grid, MpmError, ShapeFunction};

/// 4 × 3 cells of 0.5 × 0.25 at origin (1, 2): 5 × 4 nodes, x-fastest numbering.
fn grid() -> Grid {
    Grid::new([1.0, 2.0], [0.5, 0.25], [4, 3]).unwrap()
}

/// The nodes with a prescribed component `c` (0: x, 1: y), read back node by node.
fn prescribed_nodes(g: &Grid, p: &sparse_mpm::boundary::Prescribed, c: usize) -> Vec<usize> {
    (0..g.num_nodes()).filter(|&i| p.velocity(i)[c].is_some()).collect()
}

#[test]
fn an_edge_covers_the_kernels_boundary_layers_by_default() {
    let g = grid();
    for (shape, layers) in [
        (ShapeFunction::Linear, 1),
        (ShapeFunction::QuadraticBSpline, 2),
        (ShapeFunction::CubicBSpline, 3),
    ] {
        let p = resolve(&g, shape, &[BoundaryCondition::edge(Edge::Bottom, Condition::Fixed)]).unwrap();
        let expected: Vec<usize> = (0..5 * layers).collect();
        assert_eq!(prescribed_nodes(&g, &p, 0), expected, "{shape:?}");
        assert_eq!(prescribed_nodes(&g, &p, 1), expected, "{shape:?}");
        assert_eq!(p.constraints.fixed_x, expected, "{shape:?}");
        assert!(expected.iter().all(|&i| p.velocity(i) == [Some(0.0), Some(0.0)]));
    }
}

#[test]
fn slip_prescribes_only_the_normal_component() {
    let g = grid();
    let p = resolve(
        &g,
        ShapeFunction::Linear,
        &[
            BoundaryCondition::edge(Edge::Left, Condition::Slip),
            BoundaryCondition::edge(Edge::Top, Condition::Slip),
        ],
    )
    .unwrap();
    let left: Vec<usize> = (0..4).map(|j| g.node_index(0, j)).collect();
    let top: Vec<usize> = (0..5).map(|i| g.node_index(i, 3)).collect();
    assert_eq!(p.constraints.fixed_x, left);
    assert_eq!(p.constraints.fixed_y, top);
}

#[test]
fn rectangles_and_node_lists_select_their_nodes_and_later_conditions_win() {
    let g = grid();
    let conditions = [
        // Nodes with 1.5 ≤ x ≤ 2.0 and 2.25 ≤ y ≤ 2.5: i in 1..=2, j in 1..=2.
        BoundaryCondition::rectangle([[1.5, 2.25], [2.0, 2.5]], Condition::Velocity).with_velocity(Some(1.0), None),
        BoundaryCondition::nodes(vec![g.node_index(2, 2)], Condition::Velocity).with_velocity(Some(-3.0), Some(4.0)),
    ];
    let p = resolve(&g, ShapeFunction::Linear, &conditions).unwrap();
    let mut expected = vec![];
    for j in 1..=2 {
        for i in 1..=2 {
            expected.push(g.node_index(i, j));
        }
    }
    assert_eq!(prescribed_nodes(&g, &p, 0), expected);
    assert_eq!(prescribed_nodes(&g, &p, 1), vec![g.node_index(2, 2)]);
    assert_eq!(p.velocity(g.node_index(1, 1)), [Some(1.0), None]);
    assert_eq!(p.velocity(g.node_index(2, 2)), [Some(-3.0), Some(4.0)]);
    assert_eq!(p.velocity(g.node_index(0, 0)), [None, None]);
    // Applying them overwrites exactly those components.
    let (mut vx, mut vy) = (vec![9.0; g.num_nodes()], vec![9.0; g.num_nodes()]);
    p.apply_velocity(&mut vx, &mut vy);
    assert_eq!(vx.iter().filter(|&&v| v != 9.0).count(), 4);
    assert_eq!(vy.iter().filter(|&&v| v != 9.0).count(), 1);
}

#[test]
fn explicit_layers_override_the_default() {
    let g = grid();
    let p = resolve(
        &g,
        ShapeFunction::CubicBSpline,
        &[BoundaryCondition::edge(Edge::Right, Condition::Fixed).with_layers(1)],
    )
    .unwrap();
    let right: Vec<usize> = (0..4).map(|j| g.node_index(4, j)).collect();
    assert_eq!(p.constraints.fixed_x, right);
}

#[test]
fn contradictory_or_impossible_conditions_are_errors_naming_the_condition() {
    let g = grid();
    let both = BoundaryCondition {
        nodes: Some(vec![1]),
        ..BoundaryCondition::edge(Edge::Left, Condition::Fixed)
    };
    let cases: Vec<(BoundaryCondition, &str)> = vec![
        (both, "exactly one of"),
        (BoundaryCondition::nodes(vec![1], Condition::Slip), "needs an `edge`"),
        (
            BoundaryCondition::nodes(vec![1], Condition::Velocity),
            "needs `vx`, `vy`",
        ),
        (
            BoundaryCondition::nodes(vec![20], Condition::Fixed),
            "node 20 does not exist",
        ),
        (
            BoundaryCondition::edge(Edge::Top, Condition::Fixed).with_layers(5),
            "5 layers",
        ),
        (
            BoundaryCondition::rectangle([[5.0, 5.0], [6.0, 6.0]], Condition::Fixed),
            "contains no grid node",
        ),
        (
            BoundaryCondition::nodes(vec![1], Condition::Velocity).with_velocity(Some(f64::NAN), None),
            "not a finite number",
        ),
        (
            BoundaryCondition {
                vx: Some(1.0),
                ..BoundaryCondition::nodes(vec![1], Condition::Fixed)
            },
            "go with condition",
        ),
    ];
    for (k, (bc, needle)) in cases.into_iter().enumerate() {
        let ok = BoundaryCondition::edge(Edge::Bottom, Condition::Fixed);
        let err = resolve(&g, ShapeFunction::Linear, &[ok, bc]).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, MpmError::InvalidScene { .. }), "case {k}: {err:?}");
        assert!(
            text.contains("boundaries[1]") && text.contains(needle),
            "case {k}: {text}"
        );
    }
}
