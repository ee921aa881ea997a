//! Scene files: the shipped scenes run and write readable output, scenes round-trip through
//! TOML, bad scenes are refused with errors that name the key, and the `mpm` binary.

#[path = "../../tests/common/scratch.rs"]
mod scratch;
use std::path::{Path, PathBuf};
use std::process::Command;

use sparse_mpm::io::csv::read_csv;
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::StepReport;
use sparse_mpm::MpmError;
use sparse_mpm_cli::run::{run_scene, write_matrices, RunLimits};

#[path = "common/vtk_read.rs"]
mod vtk_read;

use vtk_read::{read_pvd, read_vtp};

const SHIPPED: [&str; 8] = [
    "seed_problem",
    "two_disks",
    "vibrating_bar",
    "cantilever",
    "block_in_box",
    "column",
    "cantilever_clamp",
    "rings",
];

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(format!("{name}.toml"))
}

/// A fresh, empty directory for one test.
fn scratch_dir(name: &str) -> scratch::Scratch {
    scratch::Scratch::new("scenes", name)
}

#[test]
fn every_shipped_scene_runs_and_its_snapshots_read_back() {
    for name in SHIPPED {
        let scene = Scene::load(&scene_path(name)).unwrap();
        let out = scratch_dir(name);
        let summary = run_scene(&scene, &out, RunLimits::default(), |_| {}).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            (summary.time - scene.time.end).abs() < 1e-9 * scene.time.end,
            "{name}: ended at {}",
            summary.time
        );
        // The time series lists every snapshot, in time order, and each file reads back through
        // the independent vtkio reader (the XML reader family ParaView's is).
        let series = read_pvd(&summary.pvd).unwrap();
        assert_eq!(series.len(), summary.snapshots.len(), "{name}");
        assert!(
            series.windows(2).all(|w| w[0].0 < w[1].0),
            "{name}: times not increasing"
        );
        assert_eq!(series.last().unwrap().0, summary.time);
        for (k, (_, file)) in series.iter().enumerate() {
            let data = read_vtp(&out.join(file)).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(data.len(), summary.particles, "{name}: {}", file.display());
            // The displacement is measured from the first snapshot's positions, by particle id.
            let displacement = data.array("displacement").expect("a displacement array");
            if k == 0 {
                assert!(
                    displacement.values.iter().all(|&u| u == 0.0),
                    "{name}: moved at the start"
                );
            }
            let radius = data.array("radius").expect("a radius array");
            let volume = data.array("volume").expect("a volume array");
            for (r, v) in radius.values.iter().zip(&volume.values) {
                assert_eq!(*r, 0.5 * v.sqrt(), "{name}: radius");
            }
            for array in ["id", "body", "mass", "velocity", "stress", "strain", "pressure", "J"] {
                assert!(
                    data.array(array).is_some(),
                    "{name}: no `{array}` in {}",
                    file.display()
                );
            }
        }
        // One report row per step, with the documented columns.
        let (header, rows) = read_csv(&summary.report).unwrap();
        assert_eq!(header, StepReport::COLUMNS.map(String::from).to_vec());
        assert_eq!(rows.len(), summary.steps, "{name}");
        let column = StepReport::COLUMNS.iter().position(|&c| c == "mass").unwrap();
        let mass = rows[0][column];
        assert!(
            rows.iter().all(|r| (r[column] - mass).abs() < 1e-12 * mass),
            "{name}: mass changed"
        );
        // The copy of the scene reads back to the same scene, its particle files copied beside
        // it (`input_<body>_<name>`) with the same content, and builds the same particles.
        let copy = Scene::load(&out.join("scene.toml")).unwrap();
        let mut expected = scene.clone();
        for (k, body) in expected.bodies.iter_mut().enumerate() {
            if let sparse_mpm::scene::Geometry::File(path) = &body.geometry {
                let copied = format!("input_{k}_{}", path.file_name().unwrap().to_string_lossy());
                assert_eq!(
                    std::fs::read(out.join(&copied)).unwrap(),
                    std::fs::read(scene.base_dir.as_ref().unwrap().join(path)).unwrap(),
                    "{name}: {copied}"
                );
                body.geometry = sparse_mpm::scene::Geometry::File(copied.into());
            }
        }
        assert_eq!(copy.particles().unwrap(), scene.particles().unwrap(), "{name}");
        assert_eq!(
            Scene { base_dir: None, ..copy },
            Scene {
                base_dir: None,
                ..expected
            }
        );
        std::fs::remove_dir_all(&out).unwrap();
    }
}

#[test]
fn the_seed_scene_reproduces_the_worked_problem_step() {
    let scene = Scene::load(&scene_path("seed_problem")).unwrap();
    let mut sim = scene.build().unwrap();
    sim.step().unwrap();
    let answers = sparse_mpm_study::homework::solve().unwrap();
    let (p, q) = (sim.particles(), &answers.after);
    for k in 0..4 {
        for (name, a, b) in [
            ("x", p.x[k], q.x[k]),
            ("y", p.y[k], q.y[k]),
            ("vx", p.vx[k], q.vx[k]),
            ("vy", p.vy[k], q.vy[k]),
            ("sxx", p.sxx[k], q.sxx[k]),
            ("syy", p.syy[k], q.syy[k]),
            ("sxy", p.sxy[k], q.sxy[k]),
        ] {
            assert!(
                (a - b).abs() < 1e-12 * (1.0 + b.abs()),
                "particle {k} {name}: scene {a} vs worked problem {b}"
            );
        }
    }
}

#[test]
fn the_vibrating_bar_follows_its_exact_centre_of_mass_velocity() {
    // v_cm(t) = (0.2 / π) cos(π t / 5) for the first mode with amplitude 0.1 (scene comments).
    let scene = Scene::load(&scene_path("vibrating_bar")).unwrap();
    let mut sim = scene.build().unwrap();
    let (mut sum_sq, mut count) = (0.0, 0);
    let amplitude = 0.2 / std::f64::consts::PI;
    sim.run_until(scene.time.end, |_, r| {
        let exact = amplitude * (std::f64::consts::PI * r.time / 5.0).cos();
        sum_sq += (r.momentum[0] / r.mass - exact).powi(2);
        count += 1;
        Ok(())
    })
    .unwrap();
    let rms = (sum_sq / count as f64).sqrt() / amplitude;
    // 25 cells along the bar, 2 particles per cell: the period error is a fraction of a
    // percent (docs/mass.md), which over two periods is about 2 % of the amplitude.
    assert!(rms < 0.03, "relative RMS error of v_cm: {rms}");
}

#[test]
fn every_shipped_scene_round_trips_through_toml() {
    for name in SHIPPED {
        let scene = Scene::load(&scene_path(name)).unwrap();
        let text = scene.to_toml_string().unwrap();
        let back = Scene::from_toml_str(&text).unwrap_or_else(|e| panic!("{name}: {e}\n{text}"));
        assert_eq!(
            back,
            Scene {
                base_dir: None,
                ..scene
            },
            "{name}"
        );
    }
}

/// A small valid scene to break in the tests below.
const BASE: &str = r#"
[grid]
cell_size = [0.1, 0.1]
cells = [10, 10]

[time]
end = 0.1

[[bodies]]
name = "block"
material = { model = "linear_elastic", youngs_modulus = 1000.0, poisson_ratio = 0.3 }
density = 100.0
geometry = { rectangle = { min = [0.2, 0.2], max = [0.6, 0.6] } }
"#;

fn error_of(text: &str) -> String {
    match Scene::from_toml_str(text).and_then(|s| s.build().map(|_| ())) {
        Ok(()) => panic!("accepted:\n{text}"),
        Err(e) => {
            assert!(matches!(e, MpmError::InvalidScene { .. }), "{e:?}");
            e.to_string()
        }
    }
}

#[test]
fn the_base_scene_is_valid() {
    Scene::from_toml_str(BASE).unwrap().build().unwrap();
}

#[test]
fn bad_scenes_get_errors_naming_the_key_and_the_problem() {
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            BASE.replace("[time]", "[time]\nstop = 1.0"),
            vec!["unknown field `stop`", "line"],
        ),
        (BASE.replace("cells = [10, 10]", ""), vec!["missing field `cells`"]),
        (
            BASE.replace("density = 100.0", "density = \"heavy\""),
            vec!["density", "line"],
        ),
        (
            BASE.replace("density = 100.0", "density = -1.0"),
            vec!["bodies[0].density", "-1"],
        ),
        (
            BASE.replace("youngs_modulus = 1000.0", "youngs_modulus = 1000.0, yield = 3.0"),
            vec!["unknown field `yield`"],
        ),
        (BASE.replace("linear_elastic", "plastic"), vec!["plastic"]),
        (
            BASE.replace("end = 0.1", "end = 0.1\ndt = 1e-4\ncfl = 0.5"),
            vec!["`time`", "not both"],
        ),
        (
            BASE.replace("end = 0.1", "end = 0.1\ncfl = 1.5"),
            vec!["time.cfl", "1.5"],
        ),
        (BASE.replace("end = 0.1", "end = 0.0"), vec!["time.end"]),
        (
            BASE.replace("end = 0.1", "end = 0.1\ndt = -1e-4"),
            vec!["time.dt", "-0.0001"],
        ),
        (
            BASE.replace("[time]", "[schemes]\ntransfer = { xpic = { k = 0 } }\n\n[time]"),
            vec!["schemes.transfer.xpic.k", "at least one term"],
        ),
        (
            BASE.replace(
                "[time]",
                "[schemes]\ntransfer = { fmpm = { k = 2 } }\nmass = { velocity = \"consistent\" }\n\n[time]",
            ),
            vec!["schemes.transfer", "FMPM", "lumped"],
        ),
        (
            BASE.to_string() + "\n[loads]\ngravity = [0.0, nan]\n",
            vec!["loads.gravity", "finite"],
        ),
        (
            BASE.replace("cells = [10, 10]", "cells = [100000, 100000]"),
            vec!["grid.cells", "nodes"],
        ),
        (
            BASE.replace("density = 100.0", "density = 100.0\nparticles_per_cell = 1000"),
            vec!["bodies[0].particles_per_cell", "1000"],
        ),
        (
            BASE.replace("[time]", "[schemes]\ntransfer = { blend = { flip = 2.0 } }\n\n[time]"),
            vec!["schemes.transfer.blend.flip"],
        ),
        (
            BASE.replace(
                "[time]",
                "[schemes]\nmass = { velocity = { blended = { gamma = 3.0 } } }\n\n[time]",
            ),
            vec!["schemes.mass.velocity", "gamma"],
        ),
        (
            BASE.replace("poisson_ratio = 0.3", "poisson_ratio = 0.5"),
            vec!["bodies[0].material", "poisson_ratio"],
        ),
        (
            BASE.replace("[time]", "[schemes]\nshape = \"quintic\"\n\n[time]"),
            vec!["quintic", "linear", "quadratic_bspline"],
        ),
        (
            BASE.replace("[time]", "[schemes]\nshape = { gimp = { half_width = 0.9 } }\n\n[time]"),
            vec!["schemes.shape", "half_width"],
        ),
        (
            BASE.to_string() + "\n[[boundaries]]\nnodes = [1, 2]\ncondition = \"slip\"\n",
            vec!["boundaries[0]", "slip"],
        ),
        (
            BASE.to_string() + "\n[[boundaries]]\nnodes = [1, 500]\ncondition = \"fixed\"\n",
            vec!["boundaries[0].nodes", "500"],
        ),
        (
            BASE.to_string() + "\n[[boundaries]]\nedge = \"bottom\"\ncondition = \"velocity\"\n",
            vec!["boundaries[0]", "vx"],
        ),
        (
            BASE.replace("max = [0.6, 0.6]", "max = [0.6, 1.6]"),
            vec!["bodies[0].geometry", "not inside the grid"],
        ),
        (
            BASE.replace(
                "min = [0.2, 0.2], max = [0.6, 0.6]",
                "min = [0.2, 0.2], max = [0.21, 0.21]",
            ),
            vec!["bodies[0].geometry", "no particle"],
        ),
    ];
    for (text, needles) in cases {
        let message = error_of(&text);
        for needle in needles {
            assert!(message.contains(needle), "`{needle}` not in: {message}");
        }
    }
}

#[test]
fn bad_particle_files_get_errors_naming_the_file_line_and_column() {
    let dir = scratch_dir("particle-files");
    let cases = [
        ("missing_column.csv", "x,y\n0.5,0.5\n", vec!["`volume`"]),
        (
            "bad_number.csv",
            "x,y,volume\n0.5,0.5,0.01\n0.5,zero,0.01\n",
            vec!["line 3", "`y`", "zero"],
        ),
        ("short_row.csv", "x,y,volume\n0.5,0.5\n", vec!["line 2", "2 values"]),
        (
            "unknown_column.csv",
            "x,y,volume,colour\n0.5,0.5,0.01,1\n",
            vec!["unknown column `colour`"],
        ),
        (
            "negative_volume.csv",
            "x,y,volume\n0.5,0.5,-0.01\n",
            vec!["line 2", "`volume`", "positive"],
        ),
    ];
    for (file, content, needles) in cases {
        std::fs::write(dir.join(file), content).unwrap();
        let text = BASE.replace(
            "geometry = { rectangle = { min = [0.2, 0.2], max = [0.6, 0.6] } }",
            &format!("geometry = {{ file = \"{file}\" }}"),
        );
        let mut scene = Scene::from_toml_str(&text).unwrap();
        scene.base_dir = Some(dir.to_path_buf());
        let message = scene.build().unwrap_err().to_string();
        assert!(message.contains("bodies[0].geometry"), "{message}");
        for needle in needles {
            assert!(message.contains(needle), "`{needle}` not in: {message}");
        }
    }
    let missing = BASE.replace(
        "geometry = { rectangle = { min = [0.2, 0.2], max = [0.6, 0.6] } }",
        "geometry = { file = \"no_such_file.csv\" }",
    );
    let message = Scene::from_toml_str(&missing).unwrap().build().unwrap_err().to_string();
    assert!(message.contains("no_such_file.csv"), "{message}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn matrices_of_a_scene_are_written_and_consistent() {
    let scene = Scene::load(&scene_path("two_disks")).unwrap();
    let out = scratch_dir("matrices");
    write_matrices(&scene, &out).unwrap();
    let n = sparse_mpm::io::read_matrix_market(&out.join("N.mtx")).unwrap();
    let m = sparse_mpm::io::read_matrix_market(&out.join("M.mtx")).unwrap();
    let particles = scene.particles().unwrap();
    assert_eq!(n.ncols(), particles.len());
    assert_eq!(n.nrows(), 21 * 21);
    // Every column of N sums to 1 and the rows of M sum to m_L = N m.
    let mut column_sums = vec![0.0; n.ncols()];
    for (_, j, v) in n.triplet_iter() {
        column_sums[j] += v;
    }
    assert!(column_sums.iter().all(|s| (s - 1.0).abs() < 1e-12));
    let lumped: Vec<f64> = std::fs::read_to_string(out.join("mL.mtx"))
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('%'))
        .skip(1)
        .map(|l| l.trim().parse().unwrap())
        .collect();
    let mut row_sums = vec![0.0; m.nrows()];
    for (i, _, v) in m.triplet_iter() {
        row_sums[i] += v;
    }
    for i in 0..lumped.len() {
        assert!((row_sums[i] - lumped[i]).abs() < 1e-12 * (1.0 + lumped[i]), "node {i}");
    }
    let (header, nodes) = read_csv(&out.join("nodes.csv")).unwrap();
    assert_eq!(header, ["node", "x", "y"]);
    assert_eq!(nodes.len(), 441);
    std::fs::remove_dir_all(&out).unwrap();
}

fn mpm(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mpm")).args(args).output().unwrap()
}

#[test]
fn mpm_run_writes_the_output_and_prints_particle_steps_per_second() {
    let out = scratch_dir("cli-run");
    let scene = scene_path("two_disks");
    let o = mpm(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--end-time",
        "0.2",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("particle-steps per second"), "{stdout}");
    assert!(stdout.contains("particles.pvd"), "{stdout}");
    assert!(out.join("particles.pvd").exists() && out.join("report.csv").exists());
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn mpm_refuses_a_bad_scene_with_the_key_and_a_failure_status() {
    let dir = scratch_dir("cli-bad");
    let path = dir.join("bad.toml");
    std::fs::write(&path, BASE.replace("[time]", "[time]\nstop = 1.0")).unwrap();
    let o = mpm(&[
        "run",
        path.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("bad.toml") && stderr.contains("unknown field `stop`"),
        "{stderr}"
    );
    let o = mpm(&["frobnicate"]);
    assert_eq!(o.status.code(), Some(2), "an unknown command is a usage error");
    let o = mpm(&["run", "--steps", "many"]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn mpm_homework_prints_the_worked_problem() {
    let o = mpm(&["homework"]);
    assert!(o.status.success());
    let expected = sparse_mpm_study::homework::solve().unwrap().report();
    assert_eq!(String::from_utf8_lossy(&o.stdout), expected);
}

#[test]
fn mpm_matrices_writes_matrix_market_files() {
    let out = scratch_dir("cli-matrices");
    let o = mpm(&[
        "matrices",
        scene_path("seed_problem").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "N.mtx",
        "Gx.mtx",
        "Gy.mtx",
        "M.mtx",
        "mL.mtx",
        "nodes.csv",
        "particles.csv",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    let n = sparse_mpm::io::read_matrix_market(&out.join("N.mtx")).unwrap();
    assert_eq!((n.nrows(), n.ncols(), n.nnz()), (6, 4, 16));
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn every_documented_scheme_spelling_parses_to_its_value() {
    use sparse_mpm::mass::{MassScheme, SingularityPolicy, Stabilization};
    use sparse_mpm::simulation::{Transfer, UpdateScheme};
    use sparse_mpm::step::PositionUpdate;
    use sparse_mpm::ShapeFunction;
    let text = BASE.replace(
        "[time]",
        r#"[schemes]
shape = { gimp = { half_width = 0.25 } }
update = "usf"
transfer = { blend = { flip = 0.95 } }
position_update = "trapezoidal"
sort_interval = 0
mass = { velocity = { truncated_series = { k = 3 } }, acceleration = { iterative = { tolerance = 1e-8, max_iterations = 100 } }, singularity = { regularize = { epsilon = 0.01 } }, active_tolerance = 1e-10 }

[time]"#,
    );
    let scene = Scene::from_toml_str(&text).unwrap();
    let s = &scene.schemes;
    assert_eq!(s.shape, ShapeFunction::Gimp { half_width: 0.25 });
    assert_eq!(s.update, UpdateScheme::Usf);
    assert_eq!(s.transfer, Transfer::Blend { flip: 0.95 });
    assert_eq!(s.position_update, PositionUpdate::Trapezoidal);
    assert_eq!(s.sort_interval, 0);
    assert_eq!(s.mass.velocity, MassScheme::TruncatedSeries { k: 3 });
    assert_eq!(
        s.mass.acceleration,
        MassScheme::Iterative {
            tolerance: 1e-8,
            max_iterations: 100
        }
    );
    assert_eq!(s.mass.singularity, SingularityPolicy::Regularize { epsilon: 0.01 });
    assert_eq!(s.mass.active_tolerance, 1e-10);
    for (spelling, shape) in [
        ("linear", ShapeFunction::Linear),
        ("quadratic_bspline", ShapeFunction::QuadraticBSpline),
        ("cubic_bspline", ShapeFunction::CubicBSpline),
    ] {
        let text = BASE.replace("[time]", &format!("[schemes]\nshape = \"{spelling}\"\n\n[time]"));
        assert_eq!(Scene::from_toml_str(&text).unwrap().schemes.shape, shape);
    }
    for (spelling, policy) in [
        ("error", SingularityPolicy::Error),
        ("fallback_to_lumped", SingularityPolicy::FallbackToLumped),
    ] {
        let text = BASE.replace(
            "[time]",
            &format!("[schemes]\nmass = {{ singularity = \"{spelling}\" }}\n\n[time]"),
        );
        assert_eq!(Scene::from_toml_str(&text).unwrap().schemes.mass.singularity, policy);
    }
    for (spelling, stabilization) in [
        ("\"none\"", Stabilization::None),
        (
            "{ partial_lumping = { threshold = 0.25 } }",
            Stabilization::PartialLumping { threshold: 0.25 },
        ),
        (
            "{ ghost_penalty = { gamma = 0.1 } }",
            Stabilization::GhostPenalty { gamma: 0.1 },
        ),
    ] {
        let text = BASE.replace(
            "[time]",
            &format!("[schemes]\nmass = {{ stabilization = {spelling} }}\n\n[time]"),
        );
        let parsed = Scene::from_toml_str(&text).unwrap();
        assert_eq!(parsed.schemes.mass.stabilization, stabilization);
        assert_eq!(Scene::from_toml_str(&parsed.to_toml_string().unwrap()).unwrap(), parsed);
    }
    for (spelling, transfer) in [
        ("{ xpic = { k = 4 } }", Transfer::Xpic { k: 4 }),
        ("{ fmpm = { k = 8 } }", Transfer::Fmpm { k: 8 }),
    ] {
        let text = BASE.replace("[time]", &format!("[schemes]\ntransfer = {spelling}\n\n[time]"));
        let parsed = Scene::from_toml_str(&text).unwrap();
        assert_eq!(parsed.schemes.transfer, transfer);
        assert_eq!(Scene::from_toml_str(&parsed.to_toml_string().unwrap()).unwrap(), parsed);
    }
    let text = BASE.replace("[time]", "[time]\nstability_interval = 7");
    assert_eq!(Scene::from_toml_str(&text).unwrap().options().stability_interval, 7);
    // And it round-trips.
    assert_eq!(Scene::from_toml_str(&scene.to_toml_string().unwrap()).unwrap(), scene);
}

/// A damped run (`loads.damping`) says when it settled: the first step whose `settled` column
/// is 1, in the summary and in report.csv, and the damping's work closes the energy balance.
#[test]
fn a_damped_run_reports_when_it_settled() {
    let mut scene = Scene::load(&scene_path("block_in_box")).unwrap();
    scene.loads.damping = Some(sparse_mpm::damping::Damping {
        model: sparse_mpm::damping::DampingModel::Local,
        alpha: 0.8,
        settled: sparse_mpm::damping::DEFAULT_SETTLED,
    });
    scene.time.end = 2.0;
    let out = scratch_dir("damped");
    let summary = run_scene(&scene, &out, RunLimits::default(), |_| {}).unwrap();
    let (step, time) = summary.settled.expect("the damped block settles within 2 s");
    assert!(time > 0.2 && time < 2.0, "settled at {time}");
    let (header, rows) = read_csv(&summary.report).unwrap();
    assert_eq!(header, StepReport::COLUMNS.map(String::from));
    let column = |name: &str| StepReport::COLUMNS.iter().position(|c| *c == name).unwrap();
    let (settled, work, total) = (column("settled"), column("damping_work"), column("total_energy"));
    let first = rows.iter().position(|r| r[settled] == 1.0).unwrap();
    assert_eq!(rows[first][0] as usize, step);
    let balance: Vec<f64> = rows.iter().map(|r| r[total] + r[work]).collect();
    let drift = balance.iter().map(|b| (b - balance[0]).abs()).fold(0.0, f64::max) / balance[0].abs();
    let removed = rows.last().unwrap()[work];
    assert!(
        removed > 0.0 && drift < 0.05,
        "damping work {removed}, balance drift {drift}"
    );
}
