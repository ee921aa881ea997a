//! What a scene file gets told: errors that name the file, the key and its line (a missing
//! table, a body outside the grid, a run over the limits), a warning for bodies whose
//! particles lie in the same place, a step count that is the count the run takes, and a
//! fixed time step that stays fixed.

#[path = "../../tests/common/scratch.rs"]
mod scratch;
use std::path::{Path, PathBuf};
use std::process::Command;

use sparse_mpm::limits::{prepare_run, run_steps, Limits};
use sparse_mpm::scene::{overlaps, Scene};
use sparse_mpm_cli::run::{run_scene_with, OutputPolicy, RunOptions};

const TWO_DISKS: &str = include_str!("../../scenes/two_disks.toml");

/// A fresh folder for one test.
fn scratch(name: &str) -> scratch::Scratch {
    scratch::Scratch::new("scene_errors", name)
}

/// `text` written to `dir/scene.toml`.
fn write_scene(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The 1-based line of `text` holding the `n`-th (0-based) occurrence of `needle`.
fn line_of(text: &str, needle: &str, n: usize) -> usize {
    let (at, _) = text.match_indices(needle).nth(n).expect("the needle is in the text");
    text[..at].matches('\n').count() + 1
}

/// The two-disk scene with its upper disk moved to `center`.
fn disks_with_upper_at(center: &str) -> String {
    let moved = TWO_DISKS.replace("center = [0.8, 0.8]", &format!("center = {center}"));
    assert_ne!(moved, TWO_DISKS);
    moved
}

#[test]
fn a_missing_table_is_named_with_the_file_not_the_first_line() {
    let dir = scratch("missing_table");
    for (table, header) in [("time", "[time]"), ("grid", "[grid]")] {
        // The table and its keys gone (up to the blank line that ends it).
        let start = TWO_DISKS.find(&format!("{header}\n")).unwrap();
        let end = start + TWO_DISKS[start..].find("\n\n").unwrap();
        let text = format!("{}{}", &TWO_DISKS[..start], &TWO_DISKS[end..]);
        let path = write_scene(&dir, &text);
        let message = Scene::load(&path).unwrap_err().to_string();
        assert!(
            message.starts_with(&format!("`{}: {table}`", path.display())),
            "{message}"
        );
        assert!(message.contains(&format!("missing table {header}")), "{message}");
        assert!(!message.contains("line 1") && !message.contains("title"), "{message}");
    }
    // A missing key of a table still points at the table's header.
    let text = TWO_DISKS.replace("cells = [20, 20]\n", "");
    let path = write_scene(&dir, &text);
    let message = Scene::load(&path).unwrap_err().to_string();
    assert!(
        message.contains(&format!("line {}, [grid]", line_of(&text, "[grid]", 0))),
        "{message}"
    );
    assert!(message.contains("missing field `cells`"), "{message}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_body_outside_the_grid_is_named_with_the_file_key_and_line() {
    let dir = scratch("outside");
    let text = disks_with_upper_at("[0.9, 0.8]");
    let path = write_scene(&dir, &text);
    let message = Scene::load(&path).unwrap_err().to_string();
    let line = line_of(&text, "geometry = { disk", 1);
    assert!(
        message.starts_with(&format!("`{}: line {line}, bodies[1].geometry.disk`", path.display())),
        "{message}"
    );
    assert!(message.contains("not inside the grid [0, 1] x [0, 1]"), "{message}");
    // The same check in the build of a scene made in a program: the key, no file.
    let mut scene = Scene::from_toml_str(TWO_DISKS).unwrap();
    scene.bodies[0].geometry = sparse_mpm::scene::Geometry::Rectangle {
        min: [-0.5, 0.1],
        max: [0.3, 0.3],
    };
    let Err(e) = scene.build() else {
        panic!("a body outside the grid accepted")
    };
    let message = e.to_string();
    assert!(
        message.starts_with("`bodies[0].geometry.rectangle`: spans [-0.5, 0.3]"),
        "{message}"
    );
    // Any other check of a loaded scene names its line as well.
    let text = TWO_DISKS.replace(
        "density = 1000.0\nparticles_per_cell = 2\nvelocity = [-0.1",
        "density = -1.0\nparticles_per_cell = 2\nvelocity = [-0.1",
    );
    let path = write_scene(&dir, &text);
    let message = Scene::load(&path).unwrap_err().to_string();
    let line = line_of(&text, "density = -1.0", 0);
    assert!(
        message.starts_with(&format!("`{}: line {line}, bodies[1].density`", path.display())),
        "{message}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_run_over_the_limits_names_the_file_and_line_of_the_key() {
    let dir = scratch("limits");
    let text = TWO_DISKS.replace("snapshot_interval = 0.05", "snapshot_interval = 1e-6");
    let path = write_scene(&dir, &text);
    let scene = Scene::load(&path).unwrap();
    let Err(e) = prepare_run(&scene, &Limits::default()) else {
        panic!("a run over the limits accepted")
    };
    let message = e.to_string();
    let line = line_of(&text, "snapshot_interval", 0);
    assert!(
        message.starts_with(&format!("`{}: line {line}, output.snapshot_interval`", path.display())),
        "{message}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn overlapping_bodies_are_warned_about_and_touching_ones_are_not() {
    // The shipped disks and two blocks that share an edge: no warning.
    let disks = Scene::from_toml_str(TWO_DISKS).unwrap();
    assert!(disks.warnings().is_empty());
    let blocks = TWO_DISKS
        .replace(
            "geometry = { disk = { center = [0.2, 0.2], radius = 0.2 } }",
            "geometry = { rectangle = { min = [0.2, 0.2], max = [0.5, 0.6] } }",
        )
        .replace(
            "geometry = { disk = { center = [0.8, 0.8], radius = 0.2 } }",
            "geometry = { rectangle = { min = [0.5, 0.2], max = [0.8, 0.6] } }",
        );
    let blocks = Scene::from_toml_str(&blocks).unwrap();
    assert_eq!(blocks.bodies.len(), 2);
    assert!(blocks.warnings().is_empty(), "{:?}", blocks.warnings());

    // The upper disk moved onto the lower one: every particle in the lens is counted.
    let dir = scratch("overlap");
    let text = disks_with_upper_at("[0.45, 0.45]");
    let path = write_scene(&dir, &text);
    let scene = Scene::load(&path).unwrap();
    let particles = scene.particles().unwrap();
    let list = overlaps(&particles);
    assert_eq!(list.len(), 1, "{list:?}");
    let o = &list[0];
    assert_eq!((o.first, o.second), (0, 1));
    // The same lattice fills both disks: the shared particles are those in both.
    let inside = |x: f64, y: f64, c: [f64; 2]| (x - c[0]).hypot(y - c[1]) < 0.2;
    let shared = (0..particles.len())
        .filter(|&i| particles.body[i] == 1 && inside(particles.x[i], particles.y[i], [0.2, 0.2]))
        .count();
    assert!(shared > 0);
    assert_eq!(o.particles, shared);
    let warnings = scene.warnings();
    assert_eq!(warnings.len(), 1);
    let line = line_of(&text, "geometry = { disk", 1);
    assert_eq!(
        warnings[0].key,
        format!("{}: line {line}, bodies[1].geometry", path.display())
    );
    assert!(
        warnings[0].message.starts_with(&format!(
            "{shared} particles of body `upper right disk` lie on particles of bodies[0]"
        )),
        "{}",
        warnings[0].message
    );
    // Still a valid scene: `mpm check` and `mpm run` go on, and both print the warning.
    for args in [vec!["check"], vec!["run", "--steps", "2", "--out", "out"]] {
        let output = Command::new(env!("CARGO_BIN_EXE_mpm"))
            .args(&args)
            .arg(&path)
            .current_dir(&dir)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{args:?}: {stderr}");
        assert!(
            stderr.contains(&format!(
                "warning: `{}: line {line}, bodies[1].geometry`",
                path.display()
            )),
            "{args:?}: {stderr}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_step_count_of_check_is_the_count_the_run_takes() {
    // A fixed step stays fixed: ⌈end / dt⌉ steps, only the last shortened (to the end).
    assert_eq!(run_steps(3.5, 0.03, None), (117.0, 1.0));
    assert_eq!(run_steps(1.0, 0.01, None), (100.0, 0.0));
    assert_eq!(run_steps(1.0, 0.3, None), (4.0, 1.0));
    // A CFL step lands on the snapshot times too. dt = 0.03 against snapshots every 0.05: two
    // steps per interval, the second shortened.
    assert_eq!(run_steps(3.5, 0.03, Some(0.05)), (140.0, 70.0));
    // A step that divides the interval (to rounding) is never shortened.
    assert_eq!(run_steps(1.0, 0.01, Some(0.05)), (100.0, 0.0));
    // The last interval, cut by the end: 3 snapshot intervals of 0.4 in 1.0, the last 0.2.
    assert_eq!(run_steps(1.0, 0.3, Some(0.4)), (5.0, 3.0));
    // Beyond the counted range, the upper bound.
    assert_eq!(run_steps(1e3, 1e-5, Some(0.3)), (1e8 + 3334.0, 3334.0));
    assert_eq!(run_steps(1e3, 1e-5, None), (1e8, 1.0));

    // The prediction of `mpm check` is the count of `mpm run`, for fixed steps and CFL steps.
    let dir = scratch("steps");
    for (step, interval) in [
        ("dt = 0.02", "0.05"),
        ("dt = 0.013", "0.05"),
        ("dt = 0.01", "0.1"),
        ("dt = 0.015", "0.07"),
        ("cfl = 0.5", "0.05"),
        ("cfl = 0.3", "0.07"),
    ] {
        let text = TWO_DISKS
            .replace("cfl = 0.5", step)
            .replace("snapshot_interval = 0.05", &format!("snapshot_interval = {interval}"));
        let scene = Scene::from_toml_str(&text).unwrap();
        let (_, estimate) = prepare_run(&scene, &Limits::default()).unwrap();
        let options = RunOptions {
            output: OutputPolicy::Overwrite,
            ..RunOptions::default()
        };
        let summary = run_scene_with(&scene, &dir.join("out"), &options, |_| {}).unwrap();
        if step.starts_with("dt") {
            assert_eq!(
                estimate.steps,
                Some(summary.steps as f64),
                "{step}, interval {interval}"
            );
            let expected = format!("{} steps", summary.steps);
            assert!(estimate.to_string().contains(&expected), "{estimate}");
        } else {
            // The CFL prediction holds the step of t = 0; the run's step follows the state.
            let predicted = estimate.steps.unwrap();
            assert!(predicted > 0.0 && (predicted - summary.steps as f64).abs() < 0.2 * predicted);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The `dt` column and the times of `report.csv` in `out`.
fn report_steps(out: &Path) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(out.join("report.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t, dt) = (col("time"), col("dt"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[t], v[dt])
        })
        .collect()
}

#[test]
fn a_fixed_time_step_stays_fixed_and_snapshots_record_the_time_reached() {
    let dir = scratch("fixed_dt");
    let out = dir.join("out");
    // 0.013 does not divide the snapshot interval 0.05, nor the end 3.5.
    let scene = Scene::from_toml_str(&TWO_DISKS.replace("cfl = 0.5", "dt = 0.013")).unwrap();
    let options = RunOptions {
        output: OutputPolicy::Overwrite,
        ..RunOptions::default()
    };
    let summary = run_scene_with(&scene, &out, &options, |_| {}).unwrap();
    let steps = report_steps(&out);
    assert_eq!(steps.len(), (3.5f64 / 0.013).ceil() as usize);
    assert_eq!(summary.steps, steps.len());
    let (last, rest) = steps.split_last().unwrap();
    assert!(rest.iter().all(|&(_, dt)| dt == 0.013), "every step but the last is dt");
    assert!(last.1 > 0.0 && last.1 <= 0.013);
    assert!(
        (last.0 - 3.5).abs() < 1e-12,
        "the last step ends at time.end: {}",
        last.0
    );

    // Every snapshot is at the time of a step: the first step to reach or pass its multiple of
    // the interval, and the time written is the time reached.
    let series = sparse_mpm_cli::vtk::read_pvd(&out.join("particles.pvd")).unwrap();
    assert_eq!(series[0].0, 0.0);
    let times: Vec<f64> = steps.iter().map(|s| s.0).collect();
    for (k, &(t, _)) in series.iter().enumerate().skip(1) {
        let at = times.iter().position(|&s| s == t).expect("a snapshot at a step's time");
        let due = 0.05 * k as f64;
        assert!(t >= due * (1.0 - 1e-12) || at == times.len() - 1, "snapshot {k} at {t}");
        assert!(
            at == 0 || times[at - 1] < due * (1.0 - 1e-12),
            "snapshot {k} one step late"
        );
    }
    assert_eq!(series.last().unwrap().0, last.0, "a snapshot at the end");
    std::fs::remove_dir_all(&dir).unwrap();
}
