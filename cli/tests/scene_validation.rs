//! Scene files from an untrusted source: particle files stay inside the scene's folder, only
//! regular files of bounded size are read, and their content is not echoed; every number is
//! checked where it is given, with an error that names the key and the value; boundary node
//! lists name each node once and are no longer than the grid.

#[path = "../../tests/common/scratch.rs"]
mod scratch;
use std::path::Path;

use sparse_mpm::boundary::{resolve, BoundaryCondition, Condition};
use sparse_mpm::scene::{Scene, MAX_PARTICLE_FILE_BYTES};
use sparse_mpm::{Grid, MpmError, ShapeFunction};

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

const RECTANGLE: &str = "geometry = { rectangle = { min = [0.2, 0.2], max = [0.6, 0.6] } }";

/// A valid particle file: two particles inside the grid of [`BASE`].
const PARTICLES: &str = "x,y,volume\n0.45,0.45,0.0025\n0.55,0.55,0.0025\n";

/// A fresh, empty directory for one test.
fn scratch_dir(name: &str) -> scratch::Scratch {
    scratch::Scratch::new("scene_validation", name)
}

/// [`BASE`] with its body read from `file`, as if the scene file were in `folder`.
fn file_scene(folder: &Path, file: &str) -> Scene {
    let text = BASE.replace(RECTANGLE, &format!("geometry = {{ file = {file:?} }}"));
    let mut scene = Scene::from_toml_str(&text).unwrap();
    scene.base_dir = Some(folder.to_path_buf());
    scene
}

/// The message of the error building `scene`, which must be an invalid scene.
fn build_error(scene: &Scene) -> String {
    match scene.build() {
        Ok(_) => panic!("accepted: {scene:?}"),
        Err(e) => {
            assert!(matches!(e, MpmError::InvalidScene { .. }), "{e:?}");
            e.to_string()
        }
    }
}

/// The message of the error reading `text`: refused by validation, before anything is built.
fn validation_error(text: &str) -> String {
    match Scene::from_toml_str(text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => {
            assert!(matches!(e, MpmError::InvalidScene { .. }), "{e:?}");
            e.to_string()
        }
    }
}

fn assert_names(message: &str, needles: &[&str]) {
    for needle in needles {
        assert!(message.contains(needle), "`{needle}` not in: {message}");
    }
}

/// [`BASE`] with `table` (a TOML table with its header) added before `[time]`.
fn with_table(table: &str) -> String {
    BASE.replace("[time]", &format!("{table}\n\n[time]"))
}

#[test]
fn particle_files_inside_the_scene_folder_are_read() {
    let dir = scratch_dir("inside");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(dir.join("p.csv"), PARTICLES).unwrap();
    std::fs::write(dir.join("sub").join("q.csv"), PARTICLES).unwrap();
    for file in ["p.csv", "./p.csv", "sub/q.csv", "sub/../p.csv"] {
        let scene = file_scene(&dir, file);
        assert_eq!(
            scene.particles().unwrap_or_else(|e| panic!("{file}: {e}")).len(),
            2,
            "{file}"
        );
        let path = scene.particle_file_path(0).unwrap().unwrap();
        assert!(path.is_absolute() && path.exists(), "{file}: {}", path.display());
    }
    assert_eq!(file_scene(&dir, "p.csv").particle_file_path(1).unwrap(), None);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn particle_files_outside_the_scene_folder_are_refused_naming_the_key_and_the_path() {
    let root = scratch_dir("outside");
    let folder = root.join("scene");
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::write(root.join("secret.csv"), PARTICLES).unwrap();
    let absolute = root.join("secret.csv").display().to_string();
    for (file, why) in [
        ("../../../etc/passwd", "leaves the folder"),
        ("../secret.csv", "leaves the folder"),
        ("sub/../../secret.csv", "leaves the folder"),
        (absolute.as_str(), "absolute path"),
        ("", "folder itself"),
    ] {
        let scene = file_scene(&folder, file);
        let message = build_error(&scene);
        assert_names(&message, &["`bodies[0].geometry.file`", &format!("`{file}`"), why]);
        let message = scene.particle_file_path(0).unwrap_err().to_string();
        assert_names(&message, &["`bodies[0].geometry.file`", &format!("`{file}`")]);
    }
    // A program that trusts its scenes may read them.
    let mut scene = file_scene(&folder, "../secret.csv");
    scene.allow_outside_files = true;
    assert_eq!(scene.particles().unwrap().len(), 2);
    let mut scene = file_scene(&folder, &absolute);
    scene.allow_outside_files = true;
    assert_eq!(scene.particles().unwrap().len(), 2);
    std::fs::remove_dir_all(&root).unwrap();
}

#[cfg(unix)]
#[test]
fn symbolic_links_out_of_the_scene_folder_are_refused() {
    use std::os::unix::fs::symlink;
    let root = scratch_dir("symlinks");
    let (folder, outside) = (root.join("scene"), root.join("outside"));
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::create_dir_all(&outside).unwrap();
    std::fs::write(outside.join("p.csv"), PARTICLES).unwrap();
    std::fs::write(folder.join("inside.csv"), PARTICLES).unwrap();
    symlink(outside.join("p.csv"), folder.join("link.csv")).unwrap();
    symlink(&outside, folder.join("dir")).unwrap();
    symlink(folder.join("inside.csv"), folder.join("inner_link.csv")).unwrap();
    for file in ["link.csv", "dir/p.csv"] {
        let message = build_error(&file_scene(&folder, file));
        assert_names(
            &message,
            &["`bodies[0].geometry.file`", &format!("`{file}`"), "symbolic link"],
        );
        let mut allowed = file_scene(&folder, file);
        allowed.allow_outside_files = true;
        assert_eq!(allowed.particles().unwrap().len(), 2, "{file}");
    }
    // A link that stays inside the folder is followed.
    assert_eq!(file_scene(&folder, "inner_link.csv").particles().unwrap().len(), 2);
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn only_regular_files_of_bounded_size_are_read() {
    let dir = scratch_dir("kinds");
    std::fs::create_dir_all(dir.join("folder.csv")).unwrap();
    let message = build_error(&file_scene(&dir, "folder.csv"));
    assert_names(
        &message,
        &[
            "`bodies[0].geometry.file`",
            "folder.csv",
            "a folder, not a regular file",
        ],
    );
    // Larger than the limit: refused from its size (the file is sparse; nothing is read).
    let big = std::fs::File::create(dir.join("big.csv")).unwrap();
    big.set_len(MAX_PARTICLE_FILE_BYTES + 1).unwrap();
    drop(big);
    let message = build_error(&file_scene(&dir, "big.csv"));
    assert_names(
        &message,
        &[
            "`bodies[0].geometry.file`",
            "big.csv",
            &format!("{} bytes", MAX_PARTICLE_FILE_BYTES + 1),
            &format!("more than the {MAX_PARTICLE_FILE_BYTES}"),
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[cfg(unix)]
#[test]
fn devices_and_named_pipes_are_refused_without_being_read() {
    let dir = scratch_dir("devices");
    let mut scene = file_scene(&dir, "/dev/zero");
    scene.allow_outside_files = true;
    let message = build_error(&scene);
    assert_names(
        &message,
        &["`bodies[0].geometry.file`", "/dev/zero", "a device, not a regular file"],
    );
    // Opening a FIFO for reading would wait for a writer: it must be refused from its type.
    let made = std::process::Command::new("mkfifo").arg(dir.join("pipe.csv")).status();
    if made.is_ok_and(|s| s.success()) {
        let message = build_error(&file_scene(&dir, "pipe.csv"));
        assert_names(
            &message,
            &[
                "`bodies[0].geometry.file`",
                "pipe.csv",
                "named pipe (FIFO), not a regular file",
            ],
        );
    } else {
        eprintln!("mkfifo is not available: the FIFO case is skipped");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn particle_file_errors_name_line_and_column_without_echoing_the_content() {
    let dir = scratch_dir("no-echo");
    let long = "SECRETSECRETSECRETSECRETSECRET";
    let cases = [
        // Not a particle file: nothing of it is shown, not even its first line.
        (
            "passwd.csv".to_string(),
            format!("root:x:0:0:{long}:/root:/bin/bash\nuser:x:1000:1000::/home/user:/bin/sh\n"),
            vec![
                "line 1",
                "must name the columns `x`, `y` and `volume`",
                "lacks `x`, `y`, `volume`",
            ],
        ),
        (
            "comment_then_header.csv".to_string(),
            format!("# a comment\n\nname,{long}\n"),
            vec!["line 3", "2 columns", "lacks `x`, `y`, `volume`"],
        ),
        // A particle file with a long or odd cell: the place is named, the cell is not shown.
        (
            "long_cell.csv".to_string(),
            format!("x,y,volume\n0.5,0.5,0.01\n0.5,{long},0.01\n"),
            vec!["line 3", "column `y` (column 2)", "not a number", "not shown"],
        ),
        (
            "odd_header.csv".to_string(),
            format!("x,y,volume,{long}:1\n0.5,0.5,0.01,1\n"),
            vec!["line 1", "column 4 of the header", "not shown"],
        ),
        (
            "control_character.csv".to_string(),
            "x,y,volume\n0.5,0.5,0.01\n0.5,\u{1}".to_string() + long,
            vec![],
        ),
        (
            "infinite.csv".to_string(),
            "x,y,volume\n0.5,0.5,0.01\ninf,0.5,0.01\n".to_string(),
            vec!["line 3", "column `x` (column 1)", "inf is not a finite number"],
        ),
        (
            "zero_mass.csv".to_string(),
            "x,y,volume,mass\n0.5,0.5,0.01,0\n".to_string(),
            vec!["line 2", "column `mass` (column 4)", "0 must be positive"],
        ),
        (
            "twice.csv".to_string(),
            "x,y,volume,x\n0.5,0.5,0.01,0.5\n".to_string(),
            vec!["line 1", "column `x` is named twice (columns 1 and 4)"],
        ),
    ];
    for (file, content, needles) in cases {
        std::fs::write(dir.join(&file), content).unwrap();
        let message = build_error(&file_scene(&dir, &file));
        assert_names(&message, &["`bodies[0].geometry.file`", &file]);
        assert_names(&message, &needles);
        for secret in [long, "/bin/bash", "user:x"] {
            assert!(!message.contains(secret), "`{secret}` echoed in: {message}");
        }
    }
    // Invalid UTF-8 names the line.
    std::fs::write(dir.join("latin1.csv"), b"x,y,volume\n0.5,0.5,0.01\n0.5,\xe9,0.01\n").unwrap();
    let message = build_error(&file_scene(&dir, "latin1.csv"));
    assert_names(
        &message,
        &["`bodies[0].geometry.file`", "latin1.csv line 3", "not UTF-8"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn gravity_is_finite_and_bounded_under_its_own_key() {
    let cases = [
        ("[0.0, -1e300]", vec!["1e300", "too large", "1e12"]),
        ("[0.0, -inf]", vec!["[0, -inf]", "must be finite"]),
        ("[nan, 0.0]", vec!["[NaN, 0]", "must be finite"]),
    ];
    for (gravity, needles) in cases {
        let message = validation_error(&format!("{BASE}\n[loads]\ngravity = {gravity}\n"));
        assert_names(&message, &["`loads.gravity`"]);
        assert_names(&message, &needles);
    }
    // Within the bound, but times the end time it overflows.
    let long = BASE.replace("end = 0.1", "end = 1e300");
    let message = validation_error(&format!("{long}\n[loads]\ngravity = [0.0, -1e10]\n"));
    assert_names(
        &message,
        &["`loads.gravity`", "[0, -1e10]", "`time.end`", "1e300", "overflows"],
    );
    // A large but acceptable gravity passes validation.
    Scene::from_toml_str(&format!("{BASE}\n[loads]\ngravity = [0.0, -1e6]\n")).unwrap();
}

#[test]
fn initial_velocities_are_checked_under_the_velocity_key() {
    let velocity = |v: &str| BASE.replace("density = 100.0", &format!("density = 100.0\nvelocity = {v}"));
    let message = validation_error(&velocity("[inf, 0.0]"));
    assert_names(&message, &["`bodies[0].velocity`", "[inf, 0]", "must be finite"]);
    assert!(!message.contains("geometry"), "{message}");
    // A finite speed is not called non-finite: it is too large, with the bound.
    let message = validation_error(&velocity("[1e200, 0.0]"));
    assert_names(&message, &["`bodies[0].velocity`", "[1e200, 0]", "too large", "1e12"]);
    assert!(!message.contains("non-finite"), "{message}");
    Scene::from_toml_str(&velocity("[1.0, -2.0]")).unwrap().build().unwrap();
    // The same for the velocity columns of a particle file.
    let dir = scratch_dir("file-velocity");
    std::fs::write(
        dir.join("fast.csv"),
        "x,y,volume,vx\n0.5,0.5,0.01,0\n0.5,0.6,0.01,1e200\n",
    )
    .unwrap();
    let message = build_error(&file_scene(&dir, "fast.csv"));
    assert_names(
        &message,
        &[
            "`bodies[0].geometry.file`",
            "line 3",
            "column `vx`",
            "1e200",
            "too large",
            "1e12",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn mass_solve_tolerances_and_regularization_are_validated_naming_the_key() {
    let cases = [
        (
            "mass = { velocity = \"consistent\", pivot_tolerance = nan }",
            vec!["`schemes.mass.pivot_tolerance`", "NaN", "[0, 1)"],
        ),
        (
            "mass = { velocity = \"consistent\", pivot_tolerance = -1e-10 }",
            vec!["`schemes.mass.pivot_tolerance`", "-1e-10", "[0, 1)"],
        ),
        (
            "mass = { velocity = \"consistent\", active_tolerance = nan }",
            vec!["`schemes.mass.active_tolerance`", "NaN", "[0, 1)"],
        ),
        (
            "mass = { velocity = \"consistent\", singularity = { regularize = { epsilon = -0.5 } } }",
            vec!["`schemes.mass.singularity.regularize.epsilon`", "-0.5", "(0, 1]"],
        ),
        (
            "mass = { velocity = \"consistent\", singularity = { regularize = { epsilon = nan } } }",
            vec!["`schemes.mass.singularity.regularize.epsilon`", "NaN", "(0, 1]"],
        ),
    ];
    for (line, needles) in cases {
        // Refused by validation: reading the scene fails, before anything runs.
        let message = validation_error(&with_table(&format!("[schemes]\n{line}")));
        assert_names(&message, &needles);
    }
}

#[test]
fn every_float_key_refuses_nan_and_infinity_naming_the_key_and_the_value() {
    let body = |from: &str, to: &str| BASE.replace(from, to);
    let boundary = |lines: &str| format!("{BASE}\n[[boundaries]]\n{lines}\n");
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            body("cell_size = [0.1, 0.1]", "cell_size = [0.1, 0.1]\norigin = [nan, 0.0]"),
            vec!["`grid.origin[0]`", "NaN", "finite"],
        ),
        (
            body("cell_size = [0.1, 0.1]", "cell_size = [0.1, 0.1]\norigin = [0.0, 1e20]"),
            vec!["`grid.origin[1]`", "1e20", "too far", "0.1"],
        ),
        (
            body("cell_size = [0.1, 0.1]", "cell_size = [0.1, 1e308]"),
            vec!["`grid.cell_size[1]`", "1e308", "overflow"],
        ),
        (
            body("cell_size = [0.1, 0.1]", "cell_size = [inf, 0.1]"),
            vec!["`grid.cell_size[0]`", "inf"],
        ),
        (body("end = 0.1", "end = inf"), vec!["`time.end`", "inf"]),
        (body("end = 0.1", "end = 0.1\ndt = nan"), vec!["`time.dt`", "NaN"]),
        (body("end = 0.1", "end = 0.1\ncfl = nan"), vec!["`time.cfl`", "NaN"]),
        (
            format!("{BASE}\n[output]\nsnapshot_interval = nan\n"),
            vec!["`output.snapshot_interval`", "NaN"],
        ),
        (body("density = 100.0", "density = nan"), vec!["`bodies[0].density`", "NaN"]),
        (
            body("youngs_modulus = 1000.0", "youngs_modulus = inf"),
            vec!["`bodies[0].material.youngs_modulus`", "inf"],
        ),
        (
            body("poisson_ratio = 0.3", "poisson_ratio = nan"),
            vec!["`bodies[0].material.poisson_ratio`", "NaN"],
        ),
        (
            body("youngs_modulus = 1000.0", "youngs_modulus = 1e300")
                .replace("density = 100.0", "density = 1e-300"),
            // Refused by its range before the wave speed √(E/ρ) (which would be infinite) is
            // formed.
            vec!["`bodies[0].density`", "1e-300", "between 1e-100 and 1e100"],
        ),
        (
            body("density = 100.0", "density = 100.0\nbody_force = [0.0, inf]"),
            vec!["`bodies[0].body_force`", "[0, inf]", "finite"],
        ),
        (
            body("density = 100.0", "density = 100.0\nbody_force = [1e300, 0.0]"),
            vec!["`bodies[0].body_force`", "[1e300, 0]", "too large", "1e12"],
        ),
        (
            body("max = [0.6, 0.6]", "max = [0.6, nan]"),
            vec!["`bodies[0].geometry.rectangle`", "[0.6, NaN]"],
        ),
        (
            body(RECTANGLE, "geometry = { disk = { center = [0.5, 0.5], radius = inf } }"),
            vec!["`bodies[0].geometry.disk`", "radius = inf"],
        ),
        (
            with_table("[schemes]\nshape = { gimp = { half_width = nan } }"),
            vec!["`schemes.shape.gimp.half_width`", "NaN"],
        ),
        (
            with_table("[schemes]\ntransfer = { blend = { flip = nan } }"),
            vec!["`schemes.transfer.blend.flip`", "NaN"],
        ),
        (
            with_table("[schemes]\nmass = { velocity = { blended = { gamma = nan } } }"),
            vec!["`schemes.mass.velocity.blended.gamma`", "NaN"],
        ),
        (
            with_table("[schemes]\nmass = { acceleration = { iterative = { tolerance = inf, max_iterations = 10 } } }"),
            vec!["`schemes.mass.acceleration.cg.tolerance`", "inf"],
        ),
        (
            with_table(
                "[schemes]\nmass = { velocity = \"consistent\", stabilization = { partial_lumping = { threshold = nan } } }",
            ),
            vec!["`schemes.mass.stabilization.partial_lumping.threshold`", "NaN"],
        ),
        (
            with_table(
                "[schemes]\nmass = { velocity = \"consistent\", stabilization = { ghost_penalty = { gamma = inf } } }",
            ),
            vec!["`schemes.mass.stabilization.ghost_penalty.gamma`", "inf"],
        ),
        (
            boundary("edge = \"left\"\ncondition = \"velocity\"\nvx = inf"),
            vec!["`boundaries[0].vx`", "inf"],
        ),
        (
            boundary("edge = \"left\"\ncondition = \"velocity\"\nvy = 1e200"),
            vec!["`boundaries[0].vy`", "1e200", "too large", "1e12"],
        ),
        (
            boundary("rectangle = [[0.0, 0.0], [nan, 0.5]]\ncondition = \"fixed\""),
            vec!["`boundaries[0].rectangle`", "NaN"],
        ),
    ];
    for (text, needles) in cases {
        let message = validation_error(&text);
        assert_names(&message, &needles);
    }
}

#[test]
fn duplicate_boundary_nodes_are_errors_naming_the_node_and_where_it_first_appeared() {
    let text = format!("{BASE}\n[[boundaries]]\nedge = \"left\"\ncondition = \"fixed\"\n\n[[boundaries]]\nnodes = [3, 7, 5, 7]\ncondition = \"fixed\"\n");
    let message = validation_error(&text);
    assert_names(
        &message,
        &["`boundaries[1].nodes`", "node 7", "listed twice", "index 1", "index 3"],
    );
    // The library's resolve says the same.
    let grid = Grid::new([0.0, 0.0], [0.1, 0.1], [10, 10]).unwrap();
    let bc = BoundaryCondition::nodes(vec![3, 7, 5, 7], Condition::Fixed);
    let message = resolve(&grid, ShapeFunction::Linear, &[bc]).unwrap_err().to_string();
    assert_names(&message, &["`boundaries[0].nodes`", "node 7", "index 1", "index 3"]);
}

#[test]
fn a_node_list_longer_than_the_grid_is_refused_before_it_is_looked_at() {
    // 10 x 10 cells: 121 nodes.
    let ids = vec!["0"; 122].join(", ");
    let message = validation_error(&format!(
        "{BASE}\n[[boundaries]]\nnodes = [{ids}]\ncondition = \"fixed\"\n"
    ));
    assert_names(
        &message,
        &["`boundaries[0].nodes`", "lists 122 nodes", "the 121 nodes of the grid"],
    );
    // Through the library, a list of ten million entries on a grid of 121 nodes.
    let grid = Grid::new([0.0, 0.0], [0.1, 0.1], [10, 10]).unwrap();
    let bc = BoundaryCondition::nodes(vec![usize::MAX; 10_000_000], Condition::Fixed);
    let message = resolve(&grid, ShapeFunction::Linear, &[bc]).unwrap_err().to_string();
    assert_names(
        &message,
        &["`boundaries[0].nodes`", "lists 10000000 nodes", "the 121 nodes"],
    );
}

#[test]
fn every_pair_takes_exactly_two_elements_of_its_type_and_finite_values() {
    let cases: [(&str, &str, &[&str]); 8] = [
        (
            "cell_size = [0.1, 0.1]",
            "cell_size = [0.1, 0.1, \"junk\", nan]",
            &["cell_size", "invalid type"],
        ),
        (
            "cell_size = [0.1, 0.1]",
            "cell_size = [0.1, 0.1, 0.1]",
            &["cell_size", "exactly 2 elements", "found 3"],
        ),
        ("cells = [10, 10]", "cells = [10]", &["cells", "found 1"]),
        ("cells = [10, 10]", "cells = [10, 10, -1]", &["cells"]),
        (
            "min = [0.2, 0.2]",
            "min = [0.2, nan]",
            &["bodies[0].geometry.rectangle", "NaN"],
        ),
        ("max = [0.6, 0.6]", "max = [0.6, 0.6, 0.6]", &["geometry", "found 3"]),
        (
            "[time]",
            "[loads]\ngravity = [0, -9.81, nan]\n\n[time]",
            &["gravity", "found 3"],
        ),
        (
            "density = 100.0",
            "density = 100.0\nvelocity = [1.0, inf]",
            &["velocity", "inf"],
        ),
    ];
    for (from, to, needles) in cases {
        assert!(BASE.contains(from), "{from}");
        assert_names(&validation_error(&BASE.replacen(from, to, 1)), needles);
    }
    let boundary =
        with_table("[[boundaries]]\nrectangle = [[0.0, 0.0], [0.1, 0.1], [0.2, 0.2]]\ncondition = \"fixed\"");
    assert_names(&validation_error(&boundary), &["rectangle", "found 3"]);
    let boundary = with_table("[[boundaries]]\nrectangle = [[0.0, 0.0], [0.1, 0.1, 9]]\ncondition = \"fixed\"");
    assert_names(&validation_error(&boundary), &["rectangle", "found 3"]);
    // The valid forms still read.
    Scene::from_toml_str(&with_table(
        "[[boundaries]]\nrectangle = [[0.0, 0.0], [0.1, 0.1]]\ncondition = \"fixed\"",
    ))
    .unwrap();
}

#[test]
fn series_and_iteration_counts_are_bounded_where_they_are_read() {
    let cases: [(&str, &str, &[&str]); 4] = [
        (
            "[time]",
            "[schemes]\nmass = { velocity = \"series:1000000\" }\n\n[time]",
            &["series", "at most 1000"],
        ),
        (
            "[time]",
            "[schemes]\ntransfer = \"fmpm:1000000000\"\n\n[time]",
            &["fmpm", "at most 1000"],
        ),
        (
            "[time]",
            "[schemes]\ntransfer = \"xpic:1001\"\n\n[time]",
            &["xpic", "at most 1000"],
        ),
        (
            "[time]",
            "[schemes]\nmass = { acceleration = \"cg:1e-8:1000000000\" }\n\n[time]",
            &["max_iterations", "100000"],
        ),
    ];
    for (from, to, needles) in cases {
        assert_names(&validation_error(&BASE.replacen(from, to, 1)), needles);
    }
    Scene::from_toml_str(&BASE.replacen(
        "[time]",
        "[schemes]\nmass = { velocity = \"series:1000\" }\n\n[time]",
        1,
    ))
    .unwrap();
}
