//! Files found inside a folder are read only when they are regular files (nothing hangs on a
//! pipe), a checkpoint is found from every working directory and spelling a user would use,
//! and a file of ours of another format is refused naming the file, the format found and the
//! one this version reads.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::program::{mpm, scratch, text, MPM};

/// `mpm args` in `dir`, killed after `seconds` (then `None`: it hung).
fn mpm_within(args: &[&str], dir: &Path, seconds: u64) -> Option<Output> {
    let mut child = Command::new(MPM)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the mpm binary runs");
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(seconds) {
        if child.try_wait().expect("wait").is_some() {
            return Some(child.wait_with_output().expect("output"));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.kill().ok();
    child.wait().ok();
    None
}

fn mkfifo(path: &Path) -> bool {
    Command::new("mkfifo").arg(path).status().is_ok_and(|s| s.success())
}

/// A run of the default scene cut at step 60 with a checkpoint at step 40, in `dir/cut`.
fn cut_run(dir: &Path) {
    let o = mpm(
        &["run", "--out", "cut", "--steps", "60", "--checkpoint-every", "40", "-q"],
        dir,
    );
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn a_checkpoint_file_that_is_a_pipe_is_refused_without_waiting_for_a_writer() {
    let dir = scratch("paths", "fifo_inside");
    cut_run(&dir);
    let ckpt = dir.join("cut/checkpoints/step_00000040/simulation.ckpt");
    let bytes = std::fs::read(&ckpt).unwrap();
    std::fs::remove_file(&ckpt).unwrap();
    if !mkfifo(&ckpt) {
        eprintln!("mkfifo is not available: the case is skipped");
        return;
    }
    let o = mpm_within(&["resume", "cut/checkpoints/step_00000040", "-q"], &dir, 60)
        .expect("mpm resume of a checkpoint whose simulation.ckpt is a FIFO hung");
    assert!(!o.status.success());
    assert!(
        text(&o).contains("simulation.ckpt") && text(&o).contains("named pipe (FIFO), not a regular file"),
        "{}",
        text(&o)
    );
    // The run folder's scene copy as a pipe: refused too, the folder untouched.
    std::fs::remove_file(&ckpt).unwrap();
    std::fs::write(&ckpt, bytes).unwrap();
    let report = std::fs::read(dir.join("cut/report.csv")).unwrap();
    let scene = dir.join("cut/scene.toml");
    std::fs::remove_file(&scene).unwrap();
    assert!(mkfifo(&scene));
    let o = mpm_within(&["resume", "cut/checkpoints/step_00000040", "-q"], &dir, 60)
        .expect("mpm resume with a scene copy that is a FIFO hung");
    assert!(!o.status.success());
    assert!(
        text(&o).contains("scene.toml") && text(&o).contains("not a regular file"),
        "{}",
        text(&o)
    );
    assert_eq!(std::fs::read(dir.join("cut/report.csv")).unwrap(), report);
}

#[test]
fn a_checkpoint_resumes_from_every_working_directory_and_spelling() {
    let dir = scratch("paths", "resume_spellings");
    cut_run(&dir);
    let whole = mpm(&["run", "--out", "whole", "--steps", "60", "-q"], &dir);
    assert!(whole.status.success(), "{}", text(&whole));
    let expected = std::fs::read(dir.join("whole/report.csv")).unwrap();
    let run = dir.join("cut");
    #[cfg(unix)]
    std::os::unix::fs::symlink(&run, dir.join("link")).unwrap();
    let mut cases: Vec<(&str, std::path::PathBuf)> = vec![
        ("step_00000040", run.join("checkpoints")),
        ("./step_00000040", run.join("checkpoints")),
        (".", run.join("checkpoints/step_00000040")),
        ("../step_00000040", run.join("checkpoints/step_00000040")),
        ("checkpoints/step_00000040", run.clone()),
        ("./checkpoints//step_00000040/", run.clone()),
        ("cut/checkpoints/../checkpoints/step_00000040", dir.to_path_buf()),
    ];
    #[cfg(unix)]
    cases.push(("link/checkpoints/step_00000040", dir.to_path_buf()));
    for (spelling, from) in cases {
        let o = mpm(&["resume", spelling, "--steps", "60", "-q"], &from);
        assert!(o.status.success(), "`{spelling}` from {}: {}", from.display(), text(&o));
        assert_eq!(
            std::fs::read(run.join("report.csv")).unwrap(),
            expected,
            "`{spelling}` from {}: the resumed report differs",
            from.display()
        );
    }
    // A folder that is not a run's checkpoint is refused naming it.
    std::fs::create_dir_all(dir.join("loose/step_00000040")).unwrap();
    for file in ["run.json", "simulation.ckpt"] {
        std::fs::copy(
            run.join("checkpoints/step_00000040").join(file),
            dir.join("loose/step_00000040").join(file),
        )
        .unwrap();
    }
    let o = mpm(&["resume", "loose/step_00000040", "-q"], &dir);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("not inside a run folder's `checkpoints/`"),
        "{}",
        text(&o)
    );
}

#[test]
fn files_of_another_format_are_refused_naming_the_file_and_both_formats() {
    let dir = scratch("paths", "formats");
    cut_run(&dir);
    // run.json
    let state = dir.join("cut/checkpoints/step_00000040/run.json");
    let original = std::fs::read_to_string(&state).unwrap();
    let edited = original.replace("sparse-mpm run state 2", "sparse-mpm run state 1");
    assert_ne!(edited, original, "the format is written");
    std::fs::write(&state, edited).unwrap();
    let o = mpm(&["resume", "cut/checkpoints/step_00000040", "--out", "new", "-q"], &dir);
    assert!(!o.status.success());
    for part in ["run.json", "`sparse-mpm run state 1`", "`sparse-mpm run state 2`"] {
        assert!(text(&o).contains(part), "{part}: {}", text(&o));
    }
    assert!(!dir.join("new").exists());
    std::fs::write(&state, original).unwrap();
    // The run folder's manifest.
    let manifest = dir.join("cut/manifest.json");
    let original = std::fs::read_to_string(&manifest).unwrap();
    let edited = original.replace("sparse-mpm run files 1", "sparse-mpm run files 9");
    assert_ne!(edited, original, "the format is written");
    std::fs::write(&manifest, edited).unwrap();
    let o = mpm(&["run", "--out", "cut", "--overwrite", "-q"], &dir);
    assert!(!o.status.success());
    for part in ["manifest.json", "`sparse-mpm run files 9`", "`sparse-mpm run files 1`"] {
        assert!(text(&o).contains(part), "{part}: {}", text(&o));
    }
}

#[test]
fn a_body_costs_the_lattice_points_of_its_box_not_of_the_grid() {
    use sparse_mpm::particles::{lattice, lattice_within};
    let grid = sparse_mpm::Grid::new([0.0, 0.0], [0.01, 0.01], [1000, 1000]).unwrap();
    for (min, max) in [
        ([0.2, 0.3], [0.25, 0.32]),
        ([0.0, 0.0], [0.013, 0.5]),
        ([9.99, 9.99], [10.0, 10.0]),
    ] {
        let inside = |x: f64, y: f64| x > min[0] && x < max[0] && y > min[1] && y < max[1];
        let calls = std::cell::Cell::new(0usize);
        let counted = |x: f64, y: f64| {
            calls.set(calls.get() + 1);
            inside(x, y)
        };
        let boxed = lattice_within(&grid, 2, Some([min, max]), counted);
        assert_eq!(boxed, lattice(&grid, 2, inside), "{min:?}–{max:?}: other points");
        // The box's points with three more each way: not the 4·10⁶ of the grid.
        let side = |a: usize| ((max[a] - min[a]) / 0.005).ceil() as usize + 6;
        assert!(
            calls.get() <= side(0) * side(1),
            "{min:?}–{max:?}: {} points looked at",
            calls.get()
        );
    }
}

#[test]
fn boundary_conditions_cost_their_own_nodes_and_are_bounded_in_all() {
    use sparse_mpm::boundary::{resolve, BoundaryCondition, Condition, Edge, MAX_NODE_VISITS_PER_NODE};
    use sparse_mpm::{Grid, ShapeFunction};
    let grid = Grid::new([-0.3, 0.1], [0.1, 0.05], [40, 60]).unwrap();
    let tol = 1e-9 * 0.05;
    // Rectangles on node lines, between them, over the grid's edges, a single node: the nodes
    // found are those whose position lies inside (closed, within the tolerance), every one.
    let rectangles = [
        [[0.0, 0.5], [0.4, 0.9]],
        [[-0.25, 0.12], [0.03, 0.13]],
        [[-1.0, -1.0], [10.0, 10.0]],
        [[3.6, 3.05], [3.7, 3.1]],
        [[0.2, 1.1], [0.2, 1.1]],
        [[-0.3, 0.1], [-0.3 + 1e-12, 0.1]],
    ];
    for r in rectangles {
        let [[x0, y0], [x1, y1]] = r;
        let inside: Vec<usize> = (0..grid.num_nodes())
            .filter(|&id| {
                let [x, y] = grid.node_position(id);
                x >= x0 - tol && x <= x1 + tol && y >= y0 - tol && y <= y1 + tol
            })
            .collect();
        let found = resolve(
            &grid,
            ShapeFunction::Linear,
            &[BoundaryCondition::rectangle(r, Condition::Fixed)],
        );
        match found {
            Ok(p) => assert_eq!(p.constraints.fixed_x, inside, "{r:?}"),
            Err(e) => assert!(inside.is_empty(), "{r:?}: {e}"),
        }
    }
    // Each edge with one and three layers: the band of node lines along it.
    let [nx, ny] = grid.nodes_per_axis();
    for edge in [Edge::Left, Edge::Right, Edge::Bottom, Edge::Top] {
        for layers in [1, 3] {
            let mut bc = BoundaryCondition::edge(edge, Condition::Fixed);
            bc.layers = Some(layers);
            let p = resolve(&grid, ShapeFunction::Linear, &[bc]).unwrap();
            let band: Vec<usize> = (0..grid.num_nodes())
                .filter(|&id| {
                    let (i, j) = (id % nx, id / nx);
                    match edge {
                        Edge::Left => i < layers,
                        Edge::Right => i >= nx - layers,
                        Edge::Bottom => j < layers,
                        Edge::Top => j >= ny - layers,
                    }
                })
                .collect();
            assert_eq!(p.constraints.fixed_x, band, "{edge:?}, {layers} layers");
        }
    }
    // Whole-grid conditions, one more than the bound allows: refused naming the condition that
    // passes it, before its nodes are visited.
    let whole = BoundaryCondition::rectangle([[-1.0, -1.0], [10.0, 10.0]], Condition::Fixed);
    let mut many = vec![whole; MAX_NODE_VISITS_PER_NODE];
    assert!(resolve(&grid, ShapeFunction::Linear, &many).is_ok());
    many.push(BoundaryCondition::edge(Edge::Left, Condition::Fixed));
    let message = resolve(&grid, ShapeFunction::Linear, &many).unwrap_err().to_string();
    let last = format!("boundaries[{MAX_NODE_VISITS_PER_NODE}]");
    assert!(message.contains(&last) && message.contains("merge"), "{message}");
}
