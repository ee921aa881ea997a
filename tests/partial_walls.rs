//! Walls on part of an edge (`range`): a cantilever clamped over part of its left edge swings as
//! Euler–Bernoulli says at small deflection, explicit and Newmark, with both masses, and a
//! floppy one swings past the unclamped part of the edge; the keys are checked by name.

use sparse_mpm::error::MpmError;
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::Simulation;

const LENGTH: f64 = 8.0;
const E: f64 = 1.0e7;
const NU: f64 = 0.3;
const RHO: f64 = 1050.0;

/// An 8 × 1 beam `[0, 8] × [0, 1]` (8 cells thick) on a grid reaching its length below it and
/// one padding cell around,
/// clamped on the left edge over `y ∈ [0, 1]` only (quadratic B-splines: the ghost line at
/// `x = −h` and the wall line at `x = 0`, held in the range).
fn scene(gravity: f64, youngs_modulus: f64, mass: &str, integrator: &str, end: f64) -> String {
    let h = 0.125;
    format!(
        r#"
[grid]
origin = [{o}, {y0}]
cell_size = [{h}, {h}]
cells = [{nx}, {ny}]

[schemes]
shape = "quadratic_bspline"
update = "musl"
transfer = "flip"
mass = {{ velocity = "{mass}", acceleration = "{mass}" }}
{integrator}

[time]
end = {end}
{step}

[loads]
gravity = [0.0, -{gravity}]

[[bodies]]
name = "beam"
material = {{ model = "neo_hookean", youngs_modulus = {youngs_modulus}, poisson_ratio = {NU} }}
density = {RHO}
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [{LENGTH}, 1.0] }} }}

[[boundaries]]
edge = "left"
range = [0.0, 1.0]

condition = "fixed"
"#,
        o = -h,
        y0 = -1.5 * LENGTH - h,
        nx = ((LENGTH + 1.0) / h).round() as usize + 2,
        ny = ((1.5 * LENGTH + 1.5) / h).round() as usize + 2,
        step = if integrator.is_empty() {
            "cfl = 0.5"
        } else {
            "dt = 0.02"
        },
    )
}

/// The particle nearest `(x, y)`: its id.
fn nearest(sim: &Simulation, x: f64, y: f64) -> usize {
    let p = sim.particles();
    (0..p.len())
        .min_by(|&a, &b| {
            (p.x[a] - x)
                .hypot(p.y[a] - y)
                .total_cmp(&(p.x[b] - x).hypot(p.y[b] - y))
        })
        .map(|k| p.id[k])
        .unwrap()
}

fn position(sim: &Simulation, id: usize) -> [f64; 2] {
    let p = sim.particles();
    let k = (0..p.len()).find(|&k| p.id[k] == id).unwrap();
    [p.x[k], p.y[k]]
}

/// The largest downward deflection of the middle of the free end during the first swing (until
/// it has come back up by half).
fn first_swing(text: &str) -> f64 {
    let scene = Scene::from_toml_str(text).unwrap();
    let mut sim = scene.build().unwrap();
    let tip = nearest(&sim, LENGTH, 0.5);
    let y0 = position(&sim, tip)[1];
    let (mut largest, mut done) = (0.0f64, false);
    while !done && sim.time() < scene.time.end {
        sim.step().unwrap();
        let d = y0 - position(&sim, tip)[1];
        largest = largest.max(d);
        done = largest > 0.0 && d < 0.5 * largest;
    }
    assert!(done, "the first swing ends within the run (largest {largest})");
    largest
}

/// Twice the static tip deflection `q L⁴ / (8 E' I)` of Euler–Bernoulli under a suddenly applied
/// weight, `q = ρ g`, `I = 1/12`, `E' = E/(1 − ν²)` (plane strain).
fn euler_bernoulli(gravity: f64) -> f64 {
    2.0 * RHO * gravity * LENGTH.powi(4) / (8.0 * E / (1.0 - NU * NU) / 12.0)
}

#[test]
fn a_beam_clamped_on_part_of_its_edge_swings_as_euler_bernoulli_says() {
    // g = 0.1: the first swing is 0.117, 1.5% of the length.
    let g = 0.1;
    let theory = euler_bernoulli(g);
    let newmark = "integrator = { newmark = { tolerance = 1e-8 } }";
    for (label, mass, integrator) in [
        ("explicit, lumped", "lumped", ""),
        ("explicit, consistent", "consistent", ""),
        ("Newmark, lumped", "lumped", newmark),
        ("Newmark, consistent", "consistent", newmark),
    ] {
        let swing = first_swing(&scene(g, E, mass, integrator, 5.0));
        let off = (swing - theory) / theory;
        println!(
            "{label}: first swing {swing:.5} against Euler–Bernoulli {theory:.5} ({:+.1}%)",
            100.0 * off
        );
        assert!(
            off.abs() <= 0.1,
            "{label}: {swing} against {theory} ({:+.1}%)",
            100.0 * off
        );
    }
}

/// A slender beam `[0, 8] × [0, 0.25]` (two cells thick) clamped on the left edge over its
/// thickness, with gravity `g`, on a grid reaching 1.2 lengths below it.
fn slender(g: f64, mass: &str, range: &str) -> String {
    let h = 0.125;
    format!(
        r#"
[grid]
origin = [{o}, {y0}]
cell_size = [{h}, {h}]
cells = [{nx}, {ny}]

[schemes]
shape = "quadratic_bspline"
update = "musl"
transfer = "flip"
mass = {{ velocity = "{mass}", acceleration = "{mass}" }}

[time]
end = 9.0
cfl = 0.5

[loads]
gravity = [0.0, -{g}]

[[bodies]]
name = "beam"
material = {{ model = "neo_hookean", youngs_modulus = {E}, poisson_ratio = {NU} }}
density = {RHO}
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [{LENGTH}, 0.25] }} }}

[[boundaries]]
edge = "left"
{range}
condition = "fixed"
"#,
        o = -h,
        y0 = -1.2 * LENGTH - h,
        nx = ((LENGTH + 1.0) / h).round() as usize + 2,
        ny = ((1.2 * LENGTH + 1.0) / h).round() as usize + 2,
    )
}

/// The slender beam under `g = 0.85` from rest: how close its tip comes to the left edge
/// (below the clamp) before it swings back or comes within a cell of the grid's edge, and how
/// far the clamped end's corner particle moved.
fn closest_approach(mass: &str, range: &str) -> (f64, f64) {
    let scene = Scene::from_toml_str(&slender(0.85, mass, range)).unwrap();
    let mut sim = scene.build().unwrap();
    let (tip, root) = (nearest(&sim, LENGTH, 0.125), nearest(&sim, 0.0, 0.0));
    let r0 = position(&sim, root);
    let (mut closest, mut moved) = (f64::INFINITY, 0.0f64);
    while sim.time() < 8.0 {
        sim.step().unwrap_or_else(|e| panic!("{mass}, {range}: {e}"));
        let [x, y] = position(&sim, tip);
        let r = position(&sim, root);
        moved = moved.max((r[0] - r0[0]).hypot(r[1] - r0[1]));
        if y < -3.0 {
            closest = closest.min(x);
        }
        // Swung back by a length's tenth, or about to leave the grid past the edge.
        if x < 0.125 || x > closest + 0.1 * LENGTH {
            break;
        }
    }
    (closest, moved)
}

#[test]
fn a_beam_clamped_on_part_of_its_edge_swings_past_the_rest_of_the_edge() {
    // With the whole edge fixed, the tip meets the held nodes below the clamp and stops short of
    // the edge; with the clamp on the beam's end only, it swings on past where they were.
    let (caught, _) = closest_approach("lumped", "");
    assert!(caught > 0.5, "the whole edge held the tip back at x = {caught}");
    for mass in ["lumped", "consistent"] {
        let (closest, moved) = closest_approach(mass, "range = [0.0, 0.25]");
        println!("{mass}: the tip came to x = {closest} (the whole edge: {caught}); the clamped corner moved {moved}");
        assert!(closest < 0.3, "{mass}: the tip came no closer than x = {closest}");
        // The clamp holds: its corner particle moves by less than a tenth of a cell.
        assert!(moved < 0.0125, "{mass}: the clamped corner moved {moved}");
    }
}

#[test]
fn range_keys_are_checked_by_name() {
    let base = slender(0.85, "lumped", "RANGE");
    for (range, key, want) in [
        ("range = [1.0, 0.0]", "boundaries[0].range", "from <= to"),
        ("range = [5.01, 5.02]", "boundaries[0].range", "no node line"),
        (
            "range = [0.0, 0.25]\nwall = \"mirror\"",
            "boundaries[0].wall",
            "whole edge",
        ),
    ] {
        let text = base.replace("RANGE", range);
        let e = Scene::from_toml_str(&text).and_then(|s| s.build().map(|_| ()));
        match e {
            Err(MpmError::InvalidScene { key: k, reason }) => {
                assert!(k.ends_with(key), "{range}: key {k} ({reason})");
                assert!(reason.contains(want), "{range}: {reason}");
            }
            other => panic!("{range}: expected a refusal, got {:?}", other.err()),
        }
    }
    // A range on a rectangle or node list is refused too.
    let text = base.replace(
        "edge = \"left\"\nRANGE",
        "rectangle = [[0.0, 0.0], [0.0, 0.25]]\nrange = [0.0, 0.25]",
    );
    let e = Scene::from_toml_str(&text)
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("range") && e.contains("only to an `edge`"), "{e}");
}

#[test]
fn a_range_prescribes_exactly_the_edge_nodes_it_covers() {
    use sparse_mpm::boundary::{resolve, BoundaryCondition, Condition, Edge};
    use sparse_mpm::grid::Grid;
    use sparse_mpm::shape::ShapeFunction;
    // 10 × 8 cells of 0.5 from (−0.5, −0.5): node lines at x, y = −0.5, 0, 0.5, …
    let grid = Grid::new([-0.5, -0.5], [0.5, 0.5], [10, 8]).unwrap();
    let cases = [
        // (condition, edge, range, kernel): the layers held, and the lines along the edge.
        (
            Condition::Fixed,
            Edge::Left,
            [0.0, 1.0],
            ShapeFunction::QuadraticBSpline,
            3,
        ),
        (
            Condition::Slip,
            Edge::Bottom,
            [1.0, 2.2],
            ShapeFunction::QuadraticBSpline,
            2,
        ),
        (Condition::Fixed, Edge::Top, [0.2, 0.8], ShapeFunction::Linear, 1),
    ];
    for (condition, edge, [from, to], shape, layers) in cases {
        let bc = BoundaryCondition::edge(edge, condition).with_range(from, to);
        let p = resolve(&grid, shape, &[bc]).unwrap();
        let [nx, ny] = grid.nodes_per_axis();
        let mut want = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let [x, y] = grid.node_position(grid.node_index(i, j));
                let (across, along) = match edge {
                    Edge::Left => (i, y),
                    Edge::Right => (nx - 1 - i, y),
                    Edge::Bottom => (j, x),
                    Edge::Top => (ny - 1 - j, x),
                };
                if across < layers && along >= from - 1e-12 && along <= to + 1e-12 {
                    want.push(grid.node_index(i, j));
                }
            }
        }
        want.sort_unstable();
        let normal_is_y = matches!(edge, Edge::Bottom | Edge::Top);
        let got = if condition == Condition::Slip && !normal_is_y {
            p.constraints.fixed_x.clone()
        } else {
            p.constraints.fixed_y.clone()
        };
        assert_eq!(
            got, want,
            "{condition:?} on {edge:?} over [{from}, {to}] with {shape:?}"
        );
        assert!(
            p.mirror.is_empty() && p.slip.is_empty(),
            "a range is held, not mirrored"
        );
    }
    // A wall with friction over part of an edge keeps its range.
    let bc = BoundaryCondition::edge(Edge::Bottom, Condition::Slip)
        .with_friction(0.3)
        .with_range(0.0, 2.0);
    let p = resolve(&grid, ShapeFunction::QuadraticBSpline, &[bc]).unwrap();
    assert_eq!(p.friction[0].range, Some([0.0, 2.0]));
    assert!(p.constraints.fixed_y.is_empty());
}
