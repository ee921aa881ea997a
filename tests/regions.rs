//! Regions of a body: a region's material runs as the same particles split into two bodies
//! would; a region's velocity and initial stress reach exactly its particles; what regions
//! cannot do is refused by name.

use sparse_mpm::error::MpmError;
use sparse_mpm::scene::Scene;

const HEAD: &str = r#"
[grid]
origin = [-0.25, -0.25]
cell_size = [0.25, 0.25]
cells = [20, 12]

[schemes]
shape = "quadratic_bspline"

[time]
end = 0.05

[loads]
gravity = [0.0, -10.0]

[[boundaries]]
edge = "bottom"
condition = "fixed"
"#;

const SOFT: &str = r#"{ model = "linear_elastic", youngs_modulus = 1e5, poisson_ratio = 0.3, plane = "strain" }"#;
const STIFF: &str = r#"{ model = "neo_hookean", youngs_modulus = 1e6, poisson_ratio = 0.25 }"#;

/// A 3 × 2 block whose left third is stiff: as a region of one body, or as two bodies.
fn block(as_region: bool) -> String {
    if as_region {
        format!(
            r#"{HEAD}
[[bodies]]
name = "block"
material = {SOFT}
density = 1000.0
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [3.0, 2.0] }} }}

[[bodies.regions]]
geometry = {{ rectangle = {{ min = [-1.0, -1.0], max = [1.0, 3.0] }} }}
material = {STIFF}
"#
        )
    } else {
        format!(
            r#"{HEAD}
[[bodies]]
name = "block"
material = {SOFT}
density = 1000.0
geometry = {{ rectangle = {{ min = [1.0, 0.0], max = [3.0, 2.0] }} }}

[[bodies]]
name = "block/regions[0]"
material = {STIFF}
density = 1000.0
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [1.0, 2.0] }} }}
"#
        )
    }
}

#[test]
fn a_region_material_runs_as_the_same_particles_in_two_bodies() {
    let region = Scene::from_toml_str(&block(true)).unwrap();
    let split = Scene::from_toml_str(&block(false)).unwrap();
    assert_eq!(region.bodies(), split.bodies(), "the solver's bodies");
    let (mut a, mut b) = (region.build().unwrap(), split.build().unwrap());
    // Particle k of the split scene at the place of particle k of the region scene.
    let key = |x: f64, y: f64| ((x * 1e6).round() as i64, (y * 1e6).round() as i64);
    let pa = a.particles();
    let pb = b.particles();
    assert_eq!(pa.len(), pb.len());
    let index: std::collections::HashMap<_, _> = (0..pb.len()).map(|k| (key(pb.x[k], pb.y[k]), k)).collect();
    let pair: Vec<(usize, usize)> = (0..pa.len()).map(|k| (k, index[&key(pa.x[k], pa.y[k])])).collect();
    for &(i, j) in &pair {
        assert_eq!(pa.body[i], pb.body[j], "particle at ({}, {})", pa.x[i], pa.y[i]);
    }
    let ids: Vec<(usize, usize)> = pair.iter().map(|&(i, j)| (pa.id[i], pb.id[j])).collect();
    for _ in 0..200 {
        a.step().unwrap();
        b.step().unwrap();
    }
    let (pa, pb) = (a.particles(), b.particles());
    let ids_a: std::collections::HashMap<_, _> = (0..pa.len()).map(|k| (pa.id[k], k)).collect();
    let ids_b: std::collections::HashMap<_, _> = (0..pb.len()).map(|k| (pb.id[k], k)).collect();
    let mut largest = 0.0f64;
    for &(i, j) in &ids {
        let (ka, kb) = (ids_a[&i], ids_b[&j]);
        largest = largest
            .max((pa.x[ka] - pb.x[kb]).abs())
            .max((pa.y[ka] - pb.y[kb]).abs())
            .max((pa.syy[ka] - pb.syy[kb]).abs() * 1e-5);
    }
    assert!(largest < 1e-12, "the two runs differ by {largest}");
    // The stiff region sags less than the soft rest.
    let sag = |x0: f64, x1: f64| {
        let ks: Vec<usize> = (0..pa.len())
            .filter(|&k| pa.x[k] > x0 && pa.x[k] < x1 && pa.y[k] > 1.7)
            .collect();
        ks.iter().map(|&k| pa.vy[k]).sum::<f64>() / ks.len() as f64
    };
    assert!(
        sag(0.0, 0.8) > sag(2.2, 3.0),
        "stiff {} soft {}",
        sag(0.0, 0.8),
        sag(2.2, 3.0)
    );
}

#[test]
fn a_region_velocity_and_initial_stress_reach_exactly_its_particles() {
    let text = format!(
        r#"{HEAD}
[[bodies]]
name = "block"
material = {SOFT}
density = 1000.0
velocity = [1.0, 0.0]
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [3.0, 2.0] }} }}

[[bodies.regions]]
geometry = {{ disk = {{ center = [1.5, 1.0], radius = 0.6 }} }}
velocity = [0.0, 2.0]

[[bodies.regions]]
geometry = {{ rectangle = {{ min = [2.0, 0.0], max = [3.0, 2.0] }} }}
initial_stress = {{ geostatic = {{ k0 = 0.5 }} }}
"#
    );
    let scene = Scene::from_toml_str(&text).unwrap();
    let p = scene.particles().unwrap();
    let (mut in_disk, mut in_strip) = (0, 0);
    for k in 0..p.len() {
        let disk = (p.x[k] - 1.5).hypot(p.y[k] - 1.0) < 0.6;
        let strip = p.x[k] > 2.0;
        assert_eq!(p.body[k], 0);
        if strip {
            in_strip += 1;
            // Depth below the body's top (y = 2), ρ g = 10⁴.
            let sv = -1.0e4 * (2.0 - p.y[k]);
            assert!((p.syy[k] - sv).abs() < 1e-9 && (p.sxx[k] - 0.5 * sv).abs() < 1e-9);
            assert_eq!([p.vx[k], p.vy[k]], [1.0, 0.0]);
        } else if disk {
            in_disk += 1;
            assert_eq!([p.vx[k], p.vy[k]], [0.0, 2.0]);
            assert_eq!([p.sxx[k], p.syy[k]], [0.0, 0.0]);
        } else {
            assert_eq!([p.vx[k], p.vy[k], p.sxx[k], p.syy[k]], [1.0, 0.0, 0.0, 0.0]);
        }
    }
    assert!(in_disk > 10 && in_strip > 10);
}

#[test]
fn what_a_region_cannot_be_is_refused_by_name() {
    let base = format!(
        r#"{HEAD}
[[bodies]]
name = "block"
material = {SOFT}
density = 1000.0
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [3.0, 2.0] }} }}

[[bodies.regions]]
"#
    );
    for (region, key, want) in [
        (
            format!("geometry = {{ rectangle = {{ min = [0, 0], max = [1, 1] }} }}\nmaterial = {STIFF}\n\n[contact]\n"),
            "bodies[0].regions[0].material",
            "[contact]",
        ),
        (
            "geometry = { file = \"p.csv\" }\nvelocity = [1.0, 0.0]\n".to_string(),
            "bodies[0].regions[0].geometry",
            "not a particle file",
        ),
        (
            "geometry = { disk = { center = [0, 0], radius = 0 } }\n".to_string(),
            "bodies[0].regions[0].geometry.disk",
            "positive",
        ),
        (
            "geometry = { disk = { center = [1, 1], radius = 0.5 } }\nvelocity = [1e300, 0]\n".to_string(),
            "bodies[0].regions[0].velocity",
            "",
        ),
    ] {
        let e = Scene::from_toml_str(&format!("{base}{region}"));
        match e {
            Err(MpmError::InvalidScene { key: k, reason }) => {
                assert!(k.ends_with(key), "{region}: key {k} ({reason})");
                assert!(reason.contains(want), "{region}: {reason}");
            }
            other => panic!("{region}: expected a refusal, got {:?}", other.map(|_| ())),
        }
    }
}
