//! The quasi-static integrator: the elastic column under its own weight against its exact
//! stress, Newton in every increment at large strain, checkpoints, and the keys refused.

use sparse_mpm::simulation::{Integrator, QuasiStatic, Simulation};
use sparse_mpm::ShapeFunction;
use sparse_mpm_study::verification::column::Column;
use sparse_mpm_study::verification::Choices;

fn choices(shape: ShapeFunction) -> Choices {
    Choices {
        shape,
        ..Choices::default()
    }
}

/// The stress error at 16, 32 and 64 cells high and the observed order from 16 to 64.
fn errors(column: &Column, shape: ShapeFunction) -> ([f64; 3], f64) {
    let e = [16, 32, 64].map(|cells| {
        let o = column.run(cells, &choices(shape)).unwrap();
        assert!(
            o.metric("kinetic_energy").unwrap() == 0.0,
            "{}: the particles are at rest",
            shape.name()
        );
        o.metric("stress_error").unwrap()
    });
    let order = (e[0] / e[2]).ln() / 4f64.ln();
    eprintln!("{}: errors {e:?}, order 16 → 64 {order:.2}", shape.name());
    (e, order)
}

/// E = 1 MPa, ν = 0, ρ₀ = 80, g = 10, l0 = 50, 2 × 2 particles per cell, 20 load steps: GIMP
/// converges (order ≥ 1.3 from 16 to 64 cells high, error below 2e-3 at 64); the B-splines are
/// below 2e-3 at 64 and fall from 16 to 64, the cubic ones at order ≥ 1.5 (the quadratic ones
/// to the floor of the increments' quadrature at moved particles, docs/verification.md);
/// bilinear functions do not converge (the
/// cell-crossing error: about 3% at every resolution).
#[test]
fn the_column_under_its_own_weight_converges_with_gimp_and_b_splines_and_not_with_linear() {
    let column = Column::SMALL_STRAIN;
    let (gimp, order) = errors(&column, ShapeFunction::Gimp { half_width: 0.25 });
    assert!(order >= 1.3 && gimp[2] < 2e-3, "GIMP: {gimp:?}, order {order}");
    for shape in [ShapeFunction::QuadraticBSpline, ShapeFunction::CubicBSpline] {
        let (e, order) = errors(&column, shape);
        assert!(e[2] < 2e-3 && e[2] < e[0], "{}: {e:?}, order {order}", shape.name());
        // The cubic B-spline converges at order ≥ 1.5 (1.56 measured); the quadratic one stops
        // at the floor of particle quadrature at knots (0.68, docs/verification.md).
        if shape == ShapeFunction::CubicBSpline {
            assert!(order >= 1.5, "cubic: {e:?}, order {order}");
        }
    }
    let (linear, _) = errors(&column, ShapeFunction::Linear);
    assert!(
        linear.iter().all(|&e| e > 2e-2),
        "bilinear functions do not converge on the column: {linear:?}"
    );
}

/// With one load increment the column is solved on the reference lattice, where the particles
/// are the quadrature of the B-splines: second order (the increments' quadrature at moved
/// particles is what limits the converged increments above).
#[test]
fn one_increment_converges_at_second_order_with_b_splines() {
    let column = Column {
        load_steps: 1,
        ..Column::SMALL_STRAIN
    };
    for shape in [ShapeFunction::QuadraticBSpline, ShapeFunction::CubicBSpline] {
        let (e, order) = errors(&column, shape);
        assert!(order > 1.9 && e[2] < 1e-4, "{}: {e:?}, order {order}", shape.name());
    }
}

/// E = 10 kPa: the column ends under half its height; Newton converges in every increment
/// (a step that does not is an error) and the error falls with h for GIMP and cubic B-splines.
#[test]
fn the_column_at_large_strain_converges_in_every_increment() {
    let column = Column::LARGE_STRAIN;
    for shape in [
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ] {
        let outcomes: Vec<_> = [8, 16, 32]
            .iter()
            .map(|&c| column.run(c, &choices(shape)).unwrap())
            .collect();
        let e: Vec<f64> = outcomes.iter().map(|o| o.metric("stress_error").unwrap()).collect();
        let height = outcomes[2].metric("final_height").unwrap();
        assert!(height < 0.5, "{}: final height {height}", shape.name());
        assert!(
            outcomes.iter().all(|o| o.metric("newton_iterations").unwrap() <= 10.0),
            "{}",
            shape.name()
        );
        assert!(e[2] < e[0] && e[2] < 1e-2, "{}: {e:?}", shape.name());
    }
}

#[test]
fn a_quasi_static_run_resumes_from_a_checkpoint_bit_for_bit() {
    let column = Column::SMALL_STRAIN;
    let c = choices(ShapeFunction::QuadraticBSpline);
    let mut whole = column.simulation(16, &c).unwrap();
    let mut cut = column.simulation(16, &c).unwrap();
    for _ in 0..10 {
        whole.step().unwrap();
    }
    for _ in 0..4 {
        cut.step().unwrap();
    }
    let dir = std::env::temp_dir().join(format!("sparse_mpm_quasi_static_ckpt_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sim.ckpt");
    cut.write_checkpoint(&path).unwrap();
    let mut resumed = Simulation::read_checkpoint(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(resumed.options().integrator, whole.options().integrator);
    for _ in 0..6 {
        resumed.step().unwrap();
    }
    let (a, b) = (whole.particles(), resumed.particles());
    for (name, x, y) in [("y", &a.y, &b.y), ("syy", &a.syy, &b.syy), ("fyy", &a.fyy, &b.fyy)] {
        assert!(
            x.iter().zip(y.iter()).all(|(u, v)| u.to_bits() == v.to_bits()),
            "{name} differs after resuming"
        );
    }
}

#[test]
fn quasi_static_keys_are_checked_by_name() {
    let scene = |integrator: &str, time: &str| {
        format!(
            "[grid]\ncell_size = [0.25, 0.25]\ncells = [8, 8]\n[schemes]\nshape = \"linear\"\nintegrator = \
             {integrator}\n[time]\n{time}\n[loads]\ngravity = [0.0, -10.0]\n[[bodies]]\nname = \"b\"\nmaterial = {{ \
             model = \"neo_hookean\", youngs_modulus = 1e6, poisson_ratio = 0.0 }}\ndensity = 80.0\ngeometry = {{ \
             rectangle = {{ min = [0.5, 0.0], max = [1.5, 1.0] }} }}\n[[boundaries]]\nedge = \"bottom\"\ncondition = \
             \"fixed\"\n"
        )
    };
    let read = |integrator: &str, time: &str| {
        sparse_mpm::scene::Scene::from_toml_str(&scene(integrator, time)).and_then(|s| s.build().map(|_| s))
    };
    let ok = read("{ quasi_static = { load_steps = 4 } }", "end = 1.0").unwrap();
    assert_eq!(
        ok.schemes.integrator,
        Integrator::QuasiStatic(QuasiStatic {
            load_steps: 4,
            ..QuasiStatic::default()
        })
    );
    for (integrator, time, key) in [
        (
            "{ quasi_static = { load_steps = 4 } }",
            "end = 1.0\ndt = 0.1",
            "time.dt",
        ),
        (
            "{ quasi_static = { load_steps = 4 } }",
            "end = 1.0\ncfl = 0.5",
            "time.cfl",
        ),
        ("{ quasi_static = { load_steps = 0 } }", "end = 1.0", "load_steps"),
        ("{ quasi_static = { tolerance = 2.0 } }", "end = 1.0", "tolerance"),
        (
            "{ quasi_static = { max_iterations = 0 } }",
            "end = 1.0",
            "max_iterations",
        ),
        ("{ quasi_static = { load_step = 4 } }", "end = 1.0", "load_step"),
    ] {
        let e = read(integrator, time).unwrap_err().to_string();
        assert!(e.contains(key), "{integrator} {time}: {e}");
    }
}

/// The quasi-static step from a scene: 20 increments of `time.end / 20`, the particles at rest
/// and the report's Newton columns filled.
#[test]
fn a_scene_runs_the_load_in_its_increments() {
    let column = Column::SMALL_STRAIN;
    let mut sim = column.simulation(8, &choices(ShapeFunction::CubicBSpline)).unwrap();
    let mut reports = Vec::new();
    sim.run_until(1.0, |_, r| {
        reports.push(r.clone());
        Ok(())
    })
    .unwrap();
    assert_eq!(reports.len(), column.load_steps);
    for r in &reports {
        assert!(r.acceleration_solve.iterations >= 1 && r.acceleration_solve.relative_residual <= 1e-10);
        assert_eq!(r.kinetic_energy, 0.0);
    }
    // Half the load at half the increments: the strain energy grows as λ².
    let (half, full) = (reports[9].strain_energy, reports[19].strain_energy);
    assert!((full / half - 4.0).abs() < 0.1, "{half} {full}");
}

/// Dynamic relaxation (the explicit step with local damping, α = 0.8) brings the column under
/// its full weight to within 1% of the quasi-static answer (`Σ |σ_relaxed − σ_static| V⁰` over
/// `Σ ρ₀ g l0 V⁰`), with the lumped and the consistent mass; the damping's work closes the
/// energy balance.
#[test]
fn dynamic_relaxation_reaches_the_quasi_static_column_with_either_mass() {
    use sparse_mpm::damping::{Damping, DampingModel};
    use sparse_mpm::mass::{MassOptions, MassScheme};
    use sparse_mpm_study::verification::column::initial_heights;
    let column = Column::SMALL_STRAIN;
    let damping = Damping {
        model: DampingModel::Local,
        alpha: 0.8,
        settled: sparse_mpm::damping::DEFAULT_SETTLED,
    };
    for mass in [MassScheme::Lumped, MassScheme::Consistent] {
        let c = Choices {
            shape: ShapeFunction::QuadraticBSpline,
            mass: MassOptions::both(mass),
            ..Choices::default()
        };
        let mut statics = column.simulation(16, &c).unwrap();
        let initial = initial_heights(statics.particles());
        for _ in 0..column.load_steps {
            statics.step().unwrap();
        }
        let (relaxed, outcome) = column.relax(16, &c, damping, None, 200.0).unwrap();
        let stress_by_id = |sim: &Simulation| {
            let p = sim.particles();
            let mut s = vec![0.0; p.len()];
            for k in 0..p.len() {
                s[p.id[k]] = p.syy[k];
            }
            s
        };
        let (a, b) = (stress_by_id(&statics), stress_by_id(&relaxed));
        let difference: f64 = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).sum::<f64>()
            / (a.len() as f64 * column.density * column.gravity * column.height);
        eprintln!(
            "{mass:?}: settled at t = {:.1} after {} steps; relaxed against quasi-static {difference:.2e}, against \
             the exact stress {:.2e}",
            outcome.metric("time").unwrap(),
            outcome.steps,
            column.stress_error(&relaxed, &initial)
        );
        assert!(outcome.metric("time").unwrap() < 200.0, "{mass:?}: not settled");
        assert!(difference < 0.01, "{mass:?}: {difference}");
    }
}

/// A displacement-driven increment: a block pressed by its top (prescribed `vy`, `vx` free) on
/// a roller floor, held on the left by a roller, free on the right, no body force. Uniaxial
/// stress in plane strain: `σ_yy = E/(1 − ν²) ε`, `σ_xx = 0`, at every particle (bilinear
/// functions represent the uniform strain exactly), and the residual is measured by the
/// reactions at the pressed nodes.
#[test]
fn a_block_pressed_by_prescribed_displacements_reaches_uniaxial_stress() {
    let text = "[grid]\ncell_size = [0.1, 0.1]\ncells = [12, 10]\n[schemes]\nshape = \"linear\"\nintegrator = { \
                quasi_static = { load_steps = 4 } }\n[time]\nend = 1.0\n[[bodies]]\nname = \"block\"\nmaterial = { \
                model = \"linear_elastic\", youngs_modulus = 1e6, poisson_ratio = 0.3, plane = \"strain\" }\ndensity \
                = 1000.0\ngeometry = { rectangle = { min = [0.0, 0.0], max = [1.0, 1.0] } }\n[[boundaries]]\nedge = \
                \"bottom\"\ncondition = \"slip\"\n[[boundaries]]\nedge = \"left\"\ncondition = \"slip\"\n[[boundaries]]\n\
                edge = \"top\"\ncondition = \"velocity\"\nvy = -0.001\n";
    let scene = sparse_mpm::scene::Scene::from_toml_str(text).unwrap();
    let mut sim = scene.build().unwrap();
    let mut last = None;
    sim.run_until(1.0, |_, r| {
        last = Some(r.clone());
        Ok(())
    })
    .unwrap();
    let report = last.unwrap();
    assert!(report.acceleration_solve.relative_residual <= 1e-10, "{report:?}");
    let expected = -1e6 / (1.0 - 0.09) * 1e-3;
    let p = sim.particles();
    for k in 0..p.len() {
        assert!(
            (p.syy[k] / expected - 1.0).abs() < 1e-3 && p.sxx[k].abs() < 1e-3 * expected.abs(),
            "particle {k}: σ_yy {} (expected {expected}), σ_xx {}",
            p.syy[k],
            p.sxx[k]
        );
    }
}

/// `loads.gravity_ramp`: gravity rises linearly over the ramp (the first step of a block at
/// rest feels none of it, the step after the ramp all of it); refused with the quasi-static
/// integrator, whose increments apply the loads, and when not positive, naming the key.
#[test]
fn gravity_rises_over_its_ramp_and_the_key_is_checked() {
    use sparse_mpm::simulation::Options;
    let o = Options {
        gravity: [0.0, -10.0],
        gravity_ramp: Some(2.0),
        ..Options::default()
    };
    assert_eq!(o.gravity_at(0.0), [0.0, 0.0]);
    assert_eq!(o.gravity_at(1.0), [0.0, -5.0]);
    assert_eq!(o.gravity_at(3.0), [0.0, -10.0]);
    let scene = |extra: &str, integrator: &str, time: &str| {
        format!(
            "[grid]\ncell_size = [0.25, 0.25]\ncells = [8, 8]\n[schemes]\nintegrator = {integrator}\n[time]\n{time}\n\
             [loads]\ngravity = [0.0, -10.0]\n{extra}\n[[bodies]]\nname = \"b\"\nmaterial = {{ model = \
             \"linear_elastic\", youngs_modulus = 1e6, poisson_ratio = 0.3 }}\ndensity = 80.0\ngeometry = {{ \
             rectangle = {{ min = [0.5, 0.5], max = [1.5, 1.5] }} }}\n"
        )
    };
    let build = |text: String| sparse_mpm::scene::Scene::from_toml_str(&text).and_then(|s| s.build());
    let mut sim = build(scene("gravity_ramp = 1.0", "\"explicit\"", "end = 2.0\ncfl = 0.5")).unwrap();
    let first = sim.step().unwrap();
    assert_eq!(first.momentum, [0.0, 0.0], "no gravity at t = 0");
    let second = sim.step().unwrap();
    assert!(second.momentum[1] < 0.0);
    for (extra, integrator, time) in [
        ("gravity_ramp = 1.0", "{ quasi_static = {} }", "end = 1.0"),
        ("gravity_ramp = 0.0", "\"explicit\"", "end = 1.0"),
        ("gravity_ramp = -1.0", "\"explicit\"", "end = 1.0"),
    ] {
        let e = build(scene(extra, integrator, time)).unwrap_err().to_string();
        assert!(e.contains("loads.gravity_ramp"), "{extra} {integrator}: {e}");
    }
}

/// The cantilever two cells thick settling under its weight in 10 increments: Newton converges
/// in a few iterations in every increment with every kernel wider than bilinear (the cubic
/// B-splines' fringe nodes, of relative mass below 1e-3, follow their particles instead of
/// leaving the Newton matrix too ill-conditioned to converge), and the tip deflections agree
/// within 10% at 8 cells along (small-deflection beam theory: 0.36 in plane strain to 0.40).
#[test]
fn the_cantilever_settles_in_every_increment_with_each_wide_kernel() {
    use sparse_mpm_study::verification::cantilever;
    let mut tips = Vec::new();
    for shape in [
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ] {
        let mut scene = cantilever::scene(8, &choices(shape)).unwrap();
        scene.schemes.integrator = Integrator::QuasiStatic(QuasiStatic {
            load_steps: 10,
            ..QuasiStatic::default()
        });
        (scene.time.cfl, scene.time.dt, scene.time.end) = (None, None, 1.0);
        let mut sim = scene.build().unwrap();
        let p = sim.particles();
        let distance = |k: usize| (p.x[k] - cantilever::LENGTH).hypot(p.y[k] - 1.5);
        let tip = (0..p.len())
            .min_by(|&a, &b| distance(a).total_cmp(&distance(b)))
            .unwrap();
        let (id, y0) = (p.id[tip], p.y[tip]);
        let mut most = 0;
        sim.run_until(1.0, |_, r| {
            most = most.max(r.acceleration_solve.iterations);
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{}: {e}", shape.name()));
        let p = sim.particles();
        let k = (0..p.len()).find(|&k| p.id[k] == id).unwrap();
        assert!(most <= 6, "{}: {most} Newton iterations", shape.name());
        tips.push(y0 - p.y[k]);
    }
    let (low, high) = tips.iter().fold((f64::MAX, 0.0f64), |(l, h), &t| (l.min(t), h.max(t)));
    assert!(low > 0.3 && high < 0.42 && high / low < 1.1, "tip deflections {tips:?}");
}
