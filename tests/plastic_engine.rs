//! The elastoplastic models through the engine: a von Mises bar pulled quasi-statically (the
//! closed form of linear hardening in uniaxial stress, with the consistent tangent's Newton), a
//! plastic run resumed from a checkpoint bit for bit, the geostatic initial stress, and the
//! granular column collapse against the experimental laws (docs/verification.md).

use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge};
use sparse_mpm::grid::Grid;
use sparse_mpm::material::{Material, PlaneCondition, VonMises};
use sparse_mpm::particles::{lattice, Particles};
use sparse_mpm::scene::Scene;
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::{Body, Integrator, Options, QuasiStatic, Simulation, TimeStep};

const E: f64 = 1.0e6;
const YIELD: f64 = 1.0e3;

/// A bar `[0, 4] × [0, 1]` (h = 0.25, 2 × 2 particles per cell, bilinear functions) on a
/// roller at `x = 0` and a symmetry plane at `y = 0`, pushed by its end's node line `x = 4` at
/// a prescribed speed, quasi-statically (no particle crosses a cell boundary up to 0.5%
/// strain): the deformation is homogeneous and every particle in uniaxial stress, whose
/// magnitude follows the closed form of linear hardening in the log strain.
#[test]
fn a_von_mises_bar_loaded_quasi_statically_follows_linear_hardening() {
    // (Perfect plasticity has no unique solution under a prescribed displacement once the gauge
    // has yielded: tests/plasticity.rs checks H = 0 at a material point.)
    for hardening in [5.0e4, 2.0e5] {
        let material = VonMises {
            youngs_modulus: E,
            poisson_ratio: 0.3,
            yield_stress: YIELD,
            hardening_modulus: hardening,
            plane: PlaneCondition::Stress,
        };
        let grid = Grid::new([0.0, 0.0], [0.25, 0.25], [24, 8]).unwrap();
        let (x, y, volume) = lattice(&grid, 2, |px, py| px < 4.0 && py < 1.0);
        let n = x.len();
        let particles = Particles::new(x, y, vec![volume; n], vec![volume; n]).unwrap();
        let steps = 200;
        // 0.5% strain of the gauge: five times the yield strain.
        let speed = 0.005 * 4.0 / steps as f64;
        let options = Options {
            shape: ShapeFunction::Linear,
            time_step: TimeStep::Fixed { dt: 1.0 },
            integrator: Integrator::QuasiStatic(QuasiStatic {
                load_steps: 1,
                tolerance: 1e-12,
                max_iterations: 25,
            }),
            boundaries: vec![
                BoundaryCondition::edge(Edge::Left, Condition::Slip),
                BoundaryCondition::edge(Edge::Bottom, Condition::Slip),
                BoundaryCondition::rectangle([[3.99, -0.1], [4.01, 2.1]], Condition::Velocity)
                    .with_velocity(Some(-speed), None),
            ],
            ..Options::default()
        };
        let body = Body {
            name: "bar".into(),
            material: Material::VonMises(material),
        };
        let mut sim = Simulation::new(grid, particles, vec![body], options).unwrap();
        let mut newton = 0;
        for _ in 0..steps {
            newton = newton.max(sim.step().unwrap().acceleration_solve.iterations);
        }
        assert!(
            newton <= 8,
            "Newton with the consistent tangent: {newton} iterations at most"
        );
        let p = sim.particles();
        let mut checked = 0;
        for k in 0..p.len() {
            let j = p.fxx[k] * p.fyy[k] - p.fxy[k] * p.fyx[k];
            let (txx, tyy) = (p.sxx[k] * j, p.syy[k] * j);
            let eps = -p.fxx[k].ln();
            let (txx, tyy) = (-txx, -tyy);
            let expected = YIELD + E * hardening / (E + hardening) * (eps - YIELD / E);
            assert!(eps > 4.9e-3, "particle {k}: strain {eps}");
            assert!(
                (txx - expected).abs() <= 1e-6 * expected,
                "H = {hardening}, particle {k}: τxx {txx} against {expected}"
            );
            assert!(tyy.abs() <= 1e-6 * expected, "τyy {tyy}");
            let plastic = E / (E + hardening) * (eps - YIELD / E);
            assert!((p.plastic_strain[k] - plastic).abs() <= 1e-6 * plastic);
            checked += 1;
        }
        assert!(checked > 200, "{checked} particles in the gauge");
    }
}

/// The granular column of the collapse scene resumes from a checkpoint bit for bit: the plastic
/// state is part of the checkpoint.
#[test]
fn a_plastic_run_resumes_from_a_checkpoint_bit_for_bit() {
    let text = collapse_scene(0.5, 0.02);
    let scene = Scene::from_toml_str(&text).unwrap();
    let mut whole = scene.build().unwrap();
    let mut first = scene.build().unwrap();
    for _ in 0..60 {
        whole.step().unwrap();
        first.step().unwrap();
    }
    let dir = std::env::temp_dir().join(format!("plastic-checkpoint-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("state.ckpt");
    first.write_checkpoint(&path).unwrap();
    let mut resumed = Simulation::read_checkpoint(&path).unwrap();
    assert!(resumed.particles().has_plastic_state());
    for _ in 0..60 {
        let (a, b) = (whole.step().unwrap(), resumed.step().unwrap());
        assert_eq!(a.values().map(f64::to_bits), b.values().map(f64::to_bits));
    }
    assert_eq!(whole.particles(), resumed.particles());
    assert!(
        whole.particles().plastic_strain.iter().any(|&e| e > 0.0),
        "the column yields"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `initial_stress = "geostatic"`: `σ_yy = −ρ g (H − y)`, `σ_xx = K₀ σ_yy` with `K₀ = ν/(1 − ν)`
/// or the given one; a Drucker–Prager body starts with the elastic strain of that stress; a
/// neo-Hookean body and a bad `k0` are refused by name.
#[test]
fn the_geostatic_initial_stress_is_the_weight_above() {
    for (k0_key, k0) in [("\"geostatic\"", 0.3 / 0.7), ("{ geostatic = { k0 = 0.8 } }", 0.8)] {
        let text = collapse_scene(0.5, 0.02).replace("\"geostatic\"", k0_key);
        let scene = Scene::from_toml_str(&text).unwrap();
        let sim = scene.build().unwrap();
        let p = sim.particles();
        let top = 0.1;
        for k in 0..p.len() {
            let sv = -1500.0 * 9.81 * (top - p.y[k]);
            assert!(
                (p.syy[k] - sv).abs() <= 1e-9 * 1500.0 * 9.81 * top,
                "σyy {} against {sv}",
                p.syy[k]
            );
            assert!((p.sxx[k] - k0 * sv).abs() <= 1e-9 * 1500.0 * 9.81 * top);
            assert_eq!(p.sxy[k], 0.0);
            // Hencky's law on the elastic strain gives the particle's stress, with no
            // out-of-plane elastic strain's stress beyond ν (σxx + σyy).
            let (e, nu) = (1e7, 0.3);
            let (lambda, mu) = (e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu)));
            let tr = p.elastic_xx[k] + p.elastic_yy[k] + p.elastic_zz[k];
            let hencky = |ei: f64| lambda * tr + 2.0 * mu * ei;
            let tol = 1e-9 * 1500.0 * 9.81 * top;
            assert!((hencky(p.elastic_xx[k]) - p.sxx[k]).abs() <= tol);
            assert!((hencky(p.elastic_yy[k]) - p.syy[k]).abs() <= tol);
            assert!((hencky(p.elastic_zz[k]) - nu * (p.sxx[k] + p.syy[k])).abs() <= tol);
            assert_eq!(p.elastic_xy[k], 0.0);
            assert_eq!(p.plastic_strain[k], 0.0);
        }
    }
    let neo = collapse_scene(0.5, 0.02).replace(
        "model = \"drucker_prager\", youngs_modulus = 1e7, poisson_ratio = 0.3, friction_angle = 32.0",
        "model = \"neo_hookean\", youngs_modulus = 1e7, poisson_ratio = 0.3",
    );
    let err = Scene::from_toml_str(&neo)
        .and_then(|s| s.build())
        .unwrap_err()
        .to_string();
    assert!(err.contains("initial_stress") && err.contains("neo-Hookean"), "{err}");
    let bad = collapse_scene(0.5, 0.02).replace("\"geostatic\"", "{ geostatic = { k0 = -1.0 } }");
    let err = Scene::from_toml_str(&bad)
        .and_then(|s| s.build())
        .unwrap_err()
        .to_string();
    assert!(err.contains("k0"), "{err}");
    // A stress at the base beyond the Young's modulus has no elastic state: refused by name.
    let crushed = collapse_scene(0.5, 0.02).replace("density = 1500.0", "density = 1.5e9");
    let err = Scene::from_toml_str(&crushed)
        .and_then(|s| s.build())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("initial_stress") && err.contains("Young's modulus"),
        "{err}"
    );
    // So is a particle of a plastic body given such a stress by hand.
    let scene =
        Scene::from_toml_str(&collapse_scene(0.5, 0.02).replace("initial_stress = \"geostatic\"\n", "")).unwrap();
    let mut p = scene.particles().unwrap();
    p.syy[3] = -2e7;
    let err = Simulation::new(scene.grid().unwrap(), p, scene.bodies(), scene.options())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("particle 3") && err.contains("elastic log strain"),
        "{err}"
    );
    let unknown = collapse_scene(0.5, 0.02).replace("\"geostatic\"", "\"hydrostatic\"");
    let err = Scene::from_toml_str(&unknown)
        .and_then(|s| s.build())
        .unwrap_err()
        .to_string();
    assert!(err.contains("initial_stress") || err.contains("hydrostatic"), "{err}");
}

/// The shipped collapse scene's set-up at aspect ratio `a` (`L₀ = 0.2`), cells of side `h`.
fn collapse_scene(a: f64, h: f64) -> String {
    let h0 = a * 0.2;
    let across = ((0.2 * (1.0 + 3.5 * a) + 0.1) / h).ceil() as usize + 2;
    let up = (h0 / h).ceil() as usize + 4;
    format!(
        r#"
[grid]
origin = [{o}, {o}]
cell_size = [{h}, {h}]
cells = [{across}, {up}]
[schemes]
shape = "quadratic_bspline"
update = "musl"
transfer = "apic"
[time]
end = 1.0
cfl = 0.4
[loads]
gravity = [0.0, -9.81]
[[bodies]]
name = "sand"
material = {{ model = "drucker_prager", youngs_modulus = 1e7, poisson_ratio = 0.3, friction_angle = 32.0 }}
density = 1500.0
initial_stress = "geostatic"
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [0.2, {h0}] }} }}
[[boundaries]]
edge = "left"
condition = "slip"
[[boundaries]]
edge = "bottom"
condition = "fixed"
"#,
        o = -h
    )
}
