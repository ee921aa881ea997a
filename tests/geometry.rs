//! Scene geometries: each shape's particles against its exact area, unions and differences,
//! transforms, and the messages of shapes that are malformed or leave the grid.

use sparse_mpm::error::MpmError;
use sparse_mpm::particles::Particles;
use sparse_mpm::scene::Scene;

/// A scene on the unit square (`cells` cells each way, from the origin) with one body of this
/// geometry and `ppc` particles per cell per axis.
fn scene(geometry: &str, cells: usize, ppc: usize) -> String {
    format!(
        r#"
[grid]
origin = [-1.0, -1.0]
cell_size = [{h}, {h}]
cells = [{n}, {n}]

[time]
end = 1.0

[[bodies]]
name = "shape"
material = {{ model = "linear_elastic", youngs_modulus = 1000.0, poisson_ratio = 0.3 }}
density = 1.0
particles_per_cell = {ppc}
geometry = {geometry}
"#,
        h = 2.0 / cells as f64,
        n = cells
    )
}

fn particles(geometry: &str, cells: usize, ppc: usize) -> Particles {
    Scene::from_toml_str(&scene(geometry, cells, ppc))
        .and_then(|s| s.particles())
        .unwrap_or_else(|e| panic!("{geometry}: {e}"))
}

fn refused(geometry: &str) -> (String, String) {
    match Scene::from_toml_str(&scene(geometry, 20, 2)).and_then(|s| s.particles()) {
        Err(MpmError::InvalidScene { key, reason }) => (key, reason),
        other => panic!("{geometry}: expected a refusal, got {:?}", other.map(|p| p.len())),
    }
}

fn area(p: &Particles) -> f64 {
    p.volume.iter().sum()
}

#[test]
fn shapes_on_grid_lines_are_filled_exactly() {
    // The cells are 0.1 wide: a rectangle, a union and a difference whose edges lie on cell
    // lines hold exactly their area of lattice points.
    let cases = [
        ("{ rectangle = { min = [-0.5, -0.3], max = [0.4, 0.2] } }", 0.9 * 0.5),
        (
            "{ union = [{ rectangle = { min = [-0.5, -0.5], max = [0.1, 0.1] } }, \
             { rectangle = { min = [-0.1, -0.1], max = [0.5, 0.5] } }] }",
            0.36 + 0.36 - 0.04,
        ),
        (
            "{ difference = { base = { rectangle = { min = [-0.5, -0.5], max = [0.5, 0.5] } }, \
             minus = [{ rectangle = { min = [-0.2, -0.2], max = [0.2, 0.3] } }] } }",
            1.0 - 0.4 * 0.5,
        ),
        (
            "{ polygon = { vertices = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.0], [0.0, 0.0], [0.0, 0.5], [-0.5, 0.5]] } }",
            0.75,
        ),
    ];
    for (g, exact) in cases {
        for ppc in [1, 2, 3] {
            let a = area(&particles(g, 20, ppc));
            assert!((a - exact).abs() < 1e-12, "{g}, {ppc} per cell: {a} against {exact}");
        }
    }
}

#[test]
fn curved_and_slanted_shapes_converge_to_their_area() {
    // The lattice's error is a boundary layer: at most a spacing times the perimeter, and
    // falling with the spacing.
    use std::f64::consts::PI;
    let cases = [
        (
            "{ disk = { center = [0.03, -0.02], radius = 0.61 } }",
            PI * 0.61 * 0.61,
            2.0 * PI * 0.61,
        ),
        (
            "{ annulus = { center = [0.03, -0.02], inner_radius = 0.3, outer_radius = 0.61 } }",
            PI * (0.61 * 0.61 - 0.09),
            2.0 * PI * 0.91,
        ),
        (
            "{ polygon = { vertices = [[-0.7, -0.6], [0.8, -0.3], [-0.1, 0.7]] } }",
            0.5 * (1.5 * 1.3 - 0.3 * 0.6),
            1.53 + 1.345 + 1.432,
        ),
        (
            "{ transformed = { shape = { rectangle = { min = [-0.5, -0.15], max = [0.5, 0.15] } }, angle = 33.0 } }",
            0.3,
            2.6,
        ),
    ];
    for (g, exact, perimeter) in cases {
        let mut errors = Vec::new();
        for cells in [20, 80] {
            let spacing = 2.0 / cells as f64 / 2.0;
            let a = area(&particles(g, cells, 2));
            let error = (a - exact).abs();
            assert!(
                error <= perimeter * spacing,
                "{g}: {a} against {exact} with {cells} cells"
            );
            errors.push(error);
        }
        // On the fine grid within a tenth of the bound (a boundary layer's errors cancel
        // along a smooth outline).
        assert!(errors[1] <= 0.1 * perimeter * 0.0125, "{g}: errors {errors:?}");
    }
}

#[test]
fn a_rotated_rectangle_holds_its_particles_inside_its_rotated_outline() {
    let (angle, about, translate) = (27.0f64, [0.1, -0.05], [0.05, 0.1]);
    let g = format!(
        "{{ transformed = {{ shape = {{ rectangle = {{ min = [-0.4, -0.1], max = [0.5, 0.2] }} }}, \
         angle = {angle}, about = [{}, {}], translate = [{}, {}] }} }}",
        about[0], about[1], translate[0], translate[1]
    );
    let p = particles(&g, 40, 2);
    let (s, c) = angle.to_radians().sin_cos();
    let mut corners_hit = [false; 4];
    for k in 0..p.len() {
        // Undo the translation and the rotation about `about`.
        let (x, y) = (p.x[k] - translate[0] - about[0], p.y[k] - translate[1] - about[1]);
        let (u, v) = (c * x + s * y + about[0], -s * x + c * y + about[1]);
        assert!(
            u > -0.4 - 1e-12 && u < 0.5 + 1e-12 && v > -0.1 - 1e-12 && v < 0.2 + 1e-12,
            "particle {k} at ({}, {}) is outside the rotated rectangle",
            p.x[k],
            p.y[k]
        );
        // Particles reach every corner of the outline (within two spacings).
        for (i, (cu, cv)) in [(-0.4, -0.1), (0.5, -0.1), (0.5, 0.2), (-0.4, 0.2)]
            .into_iter()
            .enumerate()
        {
            corners_hit[i] |= (u - cu).hypot(v - cv) < 2.0 * 0.025 * 2f64.sqrt();
        }
    }
    assert!(corners_hit.iter().all(|&h| h), "corners reached: {corners_hit:?}");
    let a = area(&p);
    assert!((a - 0.27).abs() < 0.05 * 0.27, "area {a}");
}

#[test]
fn a_part_outside_the_grid_is_named() {
    let (key, reason) = refused(
        "{ union = [{ rectangle = { min = [-0.5, -0.5], max = [0.1, 0.1] } }, \
         { disk = { center = [0.8, 0.0], radius = 0.3 } }] }",
    );
    assert_eq!(key, "bodies[0].geometry.union[1].disk", "{reason}");
    assert!(reason.contains("not inside the grid"), "{reason}");
    // A shape moved out by its transform is named with the transform's path.
    let (key, _) = refused(
        "{ transformed = { shape = { rectangle = { min = [-0.5, -0.1], max = [0.5, 0.1] } }, translate = [0.6, 0.0] } }",
    );
    assert_eq!(key, "bodies[0].geometry.transformed.shape.rectangle");
}

#[test]
fn malformed_shapes_are_refused_by_key() {
    let cases = [
        (
            "{ annulus = { center = [0, 0], inner_radius = 0.5, outer_radius = 0.4 } }",
            "bodies[0].geometry.annulus",
            "inner_radius",
        ),
        (
            "{ polygon = { vertices = [[0, 0], [0.5, 0]] } }",
            "bodies[0].geometry.polygon.vertices",
            "at least 3",
        ),
        (
            "{ polygon = { vertices = [[0, 0], [0.2, 0.2], [0.4, 0.4]] } }",
            "bodies[0].geometry.polygon.vertices",
            "no area",
        ),
        ("{ union = [] }", "bodies[0].geometry.union", "at least one"),
        (
            "{ union = [{ file = \"p.csv\" }] }",
            "bodies[0].geometry.union[0].file",
            "whole geometry",
        ),
        (
            "{ difference = { base = { disk = { center = [0, 0], radius = -1 } }, minus = [] } }",
            "bodies[0].geometry.difference.base.disk",
            "positive",
        ),
    ];
    for (g, want_key, want) in cases {
        let (key, reason) = refused(g);
        assert!(key.ends_with(want_key), "{g}: key {key} ({reason})");
        assert!(reason.contains(want), "{g}: {reason}");
    }
    // An outline of more vertices than a particle's test should visit.
    let many: Vec<String> = (0..5000)
        .map(|k| {
            let t = k as f64 / 5000.0 * std::f64::consts::TAU;
            format!("[{}, {}]", 0.5 * t.cos(), 0.5 * t.sin())
        })
        .collect();
    let (key, reason) = refused(&format!("{{ polygon = {{ vertices = [{}] }} }}", many.join(", ")));
    assert_eq!(key, "bodies[0].geometry", "{reason}");
    assert!(reason.contains("at most 4096"), "{reason}");
    // A polygon vertex of the wrong length is refused by the parser.
    let text = scene("{ polygon = { vertices = [[0, 0], [0.5, 0, 1], [0, 0.5]] } }", 20, 2);
    let e = Scene::from_toml_str(&text).unwrap_err().to_string();
    assert!(e.contains("exactly 2"), "{e}");
}
