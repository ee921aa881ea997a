//! Random samplings of a body's shape: Poisson-disk sampling keeps its minimum distance and
//! fills the shape to the lattice's count within 5%; jittered sampling keeps one particle in
//! each sub-cell; both are the same for a seed and differ between seeds.

use sparse_mpm::particles::Particles;
use sparse_mpm::scene::{Scene, POISSON_DISK_RADIUS};

const SHAPES: [(&str, f64); 3] = [
    (
        "{ disk = { center = [0.5, 0.5], radius = 0.4 } }",
        std::f64::consts::PI * 0.16,
    ),
    ("{ rectangle = { min = [0.1, 0.1], max = [0.9, 0.6] } }", 0.4),
    (
        "{ annulus = { center = [0.5, 0.5], inner_radius = 0.3, outer_radius = 0.4 } }",
        std::f64::consts::PI * 0.07,
    ),
];

/// Cells of 0.02 on the unit square, 2 particles per cell and axis: sub-cells of 0.01.
const SUB_CELL: f64 = 0.01;

fn particles(geometry: &str, sampling: &str, seed: u64) -> Particles {
    let text = format!(
        r#"
[grid]
origin = [0.0, 0.0]
cell_size = [0.02, 0.02]
cells = [50, 50]

[time]
end = 1.0

[[bodies]]
name = "shape"
material = {{ model = "linear_elastic", youngs_modulus = 1000.0, poisson_ratio = 0.3 }}
density = 1.0
particles_per_cell = 2
sampling = "{sampling}"
seed = {seed}
geometry = {geometry}
"#
    );
    Scene::from_toml_str(&text)
        .and_then(|s| s.particles())
        .unwrap_or_else(|e| panic!("{geometry}, {sampling}: {e}"))
}

fn bits(p: &Particles) -> Vec<u64> {
    p.x.iter().chain(&p.y).chain(&p.volume).map(|v| v.to_bits()).collect()
}

#[test]
fn poisson_disk_sampling_keeps_its_distance_and_fills_the_shape() {
    let r = POISSON_DISK_RADIUS * SUB_CELL;
    for (g, area) in SHAPES {
        for seed in [1, 7] {
            let p = particles(g, "poisson_disk", seed);
            let n = p.len();
            let expected = area / (SUB_CELL * SUB_CELL);
            assert!(
                (n as f64 - expected).abs() <= 0.05 * expected,
                "{g}, seed {seed}: {n} particles against {expected}"
            );
            let mut closest = f64::INFINITY;
            for i in 0..n {
                for j in i + 1..n {
                    closest = closest.min((p.x[i] - p.x[j]).hypot(p.y[i] - p.y[j]));
                }
            }
            assert!(
                closest >= r * (1.0 - 1e-12),
                "{g}: two particles {closest} apart, below {r}"
            );
            // Not much farther apart than the radius either: the sampling is dense.
            assert!(closest < 1.1 * r, "{g}: closest pair {closest}");
            // Each particle's volume is its share of the area the regular lattice gives the body.
            let regular: f64 = particles(g, "regular", 0).volume.iter().sum();
            let total: f64 = p.volume.iter().sum();
            assert!(
                (total - regular).abs() <= 1e-12 * regular,
                "{g}: {total} against {regular}"
            );
            assert!(p.volume.iter().all(|&v| v == p.volume[0]));
        }
    }
}

#[test]
fn jittered_sampling_keeps_one_particle_per_sub_cell_and_its_expected_area() {
    for (g, area) in SHAPES {
        let p = particles(g, "jittered", 3);
        let expected = area / (SUB_CELL * SUB_CELL);
        let n = p.len() as f64;
        assert!(
            (n - expected).abs() <= 0.05 * expected,
            "{g}: {n} particles against {expected}"
        );
        let mut cells: Vec<(i64, i64)> = (0..p.len())
            .map(|k| ((p.x[k] / SUB_CELL).floor() as i64, (p.y[k] / SUB_CELL).floor() as i64))
            .collect();
        cells.sort_unstable();
        let before = cells.len();
        cells.dedup();
        assert_eq!(cells.len(), before, "{g}: two particles in one sub-cell");
        // Off the sub-cell centres (the regular lattice's places).
        let off = (0..p.len())
            .filter(|&k| ((p.x[k] / SUB_CELL).fract() - 0.5).abs() > 1e-9)
            .count();
        assert!(off == p.len(), "{g}: {} particles at sub-cell centres", p.len() - off);
        assert!(p.volume.iter().all(|&v| (v - SUB_CELL * SUB_CELL).abs() < 1e-18));
    }
}

#[test]
fn a_seed_gives_the_same_particles_and_another_seed_others() {
    for sampling in ["jittered", "poisson_disk"] {
        let (g, _) = SHAPES[0];
        let a = particles(g, sampling, 11);
        let b = particles(g, sampling, 11);
        let c = particles(g, sampling, 12);
        assert_eq!(bits(&a), bits(&b), "{sampling}: the same seed");
        assert_ne!(bits(&a), bits(&c), "{sampling}: another seed");
    }
    // The regular lattice ignores the seed.
    let (g, _) = SHAPES[1];
    assert_eq!(bits(&particles(g, "regular", 0)), bits(&particles(g, "regular", 5)));
}

#[test]
fn a_particle_file_refuses_a_sampling() {
    let text = r#"
[grid]
origin = [0.0, 0.0]
cell_size = [0.1, 0.1]
cells = [10, 10]

[time]
end = 1.0

[[bodies]]
name = "listed"
material = { model = "linear_elastic", youngs_modulus = 1000.0, poisson_ratio = 0.3 }
density = 1.0
sampling = "jittered"
geometry = { file = "p.csv" }
"#;
    let e = Scene::from_toml_str(text).unwrap_err().to_string();
    assert!(e.contains("bodies[0].sampling"), "{e}");
}
