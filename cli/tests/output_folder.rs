//! An output folder belongs to one run at a time and holds nothing of another: `--overwrite`
//! removes exactly what the earlier run's manifest lists, two runs into one folder never mix,
//! and a checkpoint of another run is refused.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;

mod common;
use common::program::{mpm, scratch, text};

/// The names `dir/manifest.json` lists.
fn manifest(dir: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("manifest.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect()
}

/// Every file and folder under `dir`, as paths relative to it.
fn tree(dir: &Path) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let path = e.unwrap().path();
            out.insert(path.strip_prefix(dir).unwrap().to_string_lossy().into_owned());
            if path.is_dir() {
                stack.push(path);
            }
        }
    }
    out
}

/// The folder is one run's output: the manifest lists every run file present and each file it
/// lists exists; the report has `steps` rows; the series lists exactly the snapshots present.
fn assert_one_run(out: &Path, steps: usize) {
    let listed = manifest(out);
    for name in &listed {
        assert!(out.join(name).exists(), "{name} is listed but missing");
    }
    let snapshots: BTreeSet<String> = tree(out)
        .into_iter()
        .filter(|n| n.starts_with("particles_") && n.ends_with(".vtp"))
        .collect();
    for s in &snapshots {
        assert!(listed.contains(s), "{s} is not listed");
    }
    let series: BTreeSet<String> = sparse_mpm_cli::vtk::read_pvd(&out.join("particles.pvd"))
        .unwrap()
        .into_iter()
        .map(|(_, f)| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(series, snapshots, "the series lists exactly the snapshots present");
    let rows = std::fs::read_to_string(out.join("report.csv")).unwrap().lines().count();
    assert_eq!(rows, steps + 1, "the header and one row per step of one run");
}

#[test]
fn overwrite_removes_exactly_the_files_the_manifest_lists() {
    let dir = scratch("output", "manifest");
    let first = mpm(
        &["run", "--out", "o", "--steps", "60", "--checkpoint-every", "20", "-q"],
        &dir,
    );
    assert!(first.status.success(), "{}", text(&first));
    assert_one_run(&dir.join("o"), 60);
    let listed = manifest(&dir.join("o"));
    for name in [
        "scene.toml",
        "report.csv",
        "particles.pvd",
        "checkpoints",
        "checkpoints/step_00000040",
    ] {
        assert!(listed.iter().any(|l| l == name), "{name} in {listed:?}");
    }
    // Files of the user's beside the run's, one of them inside checkpoints/.
    std::fs::write(dir.join("o/notes.txt"), "mine").unwrap();
    std::fs::write(dir.join("o/checkpoints/mine.txt"), "mine").unwrap();
    std::fs::write(dir.join("o/particles_000001.vtp.bak"), "mine").unwrap();
    std::fs::write(dir.join("o/checkpoints/step_00000040/mynotes.txt"), "mine").unwrap();
    let second = mpm(&["run", "--out", "o", "--steps", "10", "-q", "--overwrite"], &dir);
    assert!(second.status.success(), "{}", text(&second));
    assert_one_run(&dir.join("o"), 10);
    let left = tree(&dir.join("o"));
    for kept in [
        "notes.txt",
        "checkpoints/mine.txt",
        "particles_000001.vtp.bak",
        "checkpoints/step_00000040/mynotes.txt",
    ] {
        assert!(left.contains(kept), "{kept} is kept: {left:?}");
    }
    let checkpoint_files: Vec<&String> = left
        .iter()
        .filter(|n| n.starts_with("checkpoints/step_") && !n.ends_with("mynotes.txt"))
        .collect();
    assert_eq!(
        checkpoint_files,
        ["checkpoints/step_00000040"],
        "the earlier run's checkpoint files are removed, a folder with a file of the user's stays"
    );
}

#[test]
fn a_checkpoint_folder_no_manifest_lists_is_not_written_over() {
    let dir = scratch("output", "unlisted_checkpoint");
    let other = mpm(
        &[
            "run",
            "--out",
            "other",
            "--steps",
            "20",
            "--checkpoint-every",
            "10",
            "-q",
        ],
        &dir,
    );
    assert!(other.status.success(), "{}", text(&other));
    let first = mpm(&["run", "--out", "o", "--steps", "5", "-q"], &dir);
    assert!(first.status.success(), "{}", text(&first));
    // Another run's checkpoint copied in, where this run would write its own.
    std::fs::create_dir_all(dir.join("o/checkpoints/step_00000010")).unwrap();
    for name in ["simulation.ckpt", "run.json"] {
        std::fs::copy(
            dir.join("other/checkpoints/step_00000010").join(name),
            dir.join("o/checkpoints/step_00000010").join(name),
        )
        .unwrap();
    }
    let copied = std::fs::read(dir.join("o/checkpoints/step_00000010/simulation.ckpt")).unwrap();
    let second = mpm(
        &[
            "run",
            "--out",
            "o",
            "--steps",
            "20",
            "--checkpoint-every",
            "10",
            "-q",
            "--overwrite",
        ],
        &dir,
    );
    assert!(!second.status.success(), "{}", text(&second));
    assert!(
        text(&second).contains("checkpoints/step_00000010") && text(&second).contains("nothing was removed"),
        "{}",
        text(&second)
    );
    assert_eq!(
        std::fs::read(dir.join("o/checkpoints/step_00000010/simulation.ckpt")).unwrap(),
        copied,
        "the unlisted checkpoint is not written over"
    );
    assert!(dir.join("o/report.csv").exists(), "nothing was removed");
}

#[test]
fn a_checkpoint_folder_holding_only_a_users_file_is_used_again() {
    let dir = scratch("output", "user_file_in_checkpoint");
    let args = ["run", "--out", "o", "--steps", "30", "--checkpoint-every", "10", "-q"];
    let first = mpm(&args, &dir);
    assert!(first.status.success(), "{}", text(&first));
    std::fs::write(dir.join("o/checkpoints/step_00000010/notes.txt"), "mine").unwrap();
    for _ in 0..2 {
        let again = mpm(&[&args[..], &["--overwrite"]].concat(), &dir);
        assert!(again.status.success(), "{}", text(&again));
        assert_one_run(&dir.join("o"), 30);
        assert!(dir.join("o/checkpoints/step_00000010/simulation.ckpt").exists());
        assert_eq!(
            std::fs::read_to_string(dir.join("o/checkpoints/step_00000010/notes.txt")).unwrap(),
            "mine"
        );
    }
}

#[test]
fn overwrite_refuses_files_in_the_way_that_no_manifest_lists_and_removes_nothing() {
    // `--out .` in a scene's own folder: the scene file is in the way of the scene copy.
    let dir = scratch("output", "scene_folder");
    std::fs::write(dir.join("scene.toml"), include_str!("../../scenes/seed_problem.toml")).unwrap();
    std::fs::write(
        dir.join("seed_particles.csv"),
        include_str!("../../scenes/seed_particles.csv"),
    )
    .unwrap();
    let before = tree(&dir);
    let run = mpm(&["run", "scene.toml", "--out", ".", "--overwrite", "-q"], &dir);
    assert!(!run.status.success());
    let message = text(&run);
    assert!(
        message.contains("scene.toml") && message.contains("manifest"),
        "{message}"
    );
    assert!(!message.contains("output written"), "{message}");
    assert_eq!(tree(&dir), before, "nothing removed or added");
    assert_eq!(
        std::fs::read_to_string(dir.join("scene.toml")).unwrap(),
        include_str!("../../scenes/seed_problem.toml")
    );

    // A look-alike snapshot in a run's folder that the run did not write.
    let run = mpm(&["run", "--out", "o", "--steps", "5", "-q"], &dir);
    assert!(run.status.success(), "{}", text(&run));
    std::fs::write(dir.join("o/particles_009999.vtp"), "not the run's").unwrap();
    let report = std::fs::read(dir.join("o/report.csv")).unwrap();
    let again = mpm(&["run", "--out", "o", "--steps", "3", "-q", "--overwrite"], &dir);
    assert!(!again.status.success());
    assert!(text(&again).contains("particles_009999.vtp"), "{}", text(&again));
    assert_eq!(
        std::fs::read(dir.join("o/report.csv")).unwrap(),
        report,
        "nothing removed"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_manifest_naming_files_outside_the_folder_is_refused() {
    let dir = scratch("output", "hostile_manifest");
    let run = mpm(&["run", "--out", "o", "--steps", "5", "-q"], &dir);
    assert!(run.status.success(), "{}", text(&run));
    std::fs::write(dir.join("victim.txt"), "keep me").unwrap();
    for name in ["../victim.txt", "/etc/hostname", "notes/../../victim.txt"] {
        let hostile = format!(r#"{{"format": "sparse-mpm run files 1", "files": ["report.csv", "{name}"]}}"#);
        std::fs::write(dir.join("o/manifest.json"), hostile).unwrap();
        let again = mpm(&["run", "--out", "o", "--steps", "3", "-q", "--overwrite"], &dir);
        assert!(!again.status.success(), "{name}");
        assert!(text(&again).contains("manifest.json"), "{}", text(&again));
        assert!(dir.join("o/report.csv").exists(), "nothing removed");
        assert_eq!(std::fs::read_to_string(dir.join("victim.txt")).unwrap(), "keep me");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn two_runs_into_one_folder_at_the_same_time_never_mix() {
    let dir = scratch("output", "concurrent");
    let steps = "250";
    for attempt in 0..5 {
        let spawn = || {
            Command::new(env!("CARGO_BIN_EXE_mpm"))
                .args(["run", "--out", "o", "--steps", steps, "-q", "--overwrite"])
                .current_dir(&dir)
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (a, b) = (spawn(), spawn());
        let outputs = [a.wait_with_output().unwrap(), b.wait_with_output().unwrap()];
        let ok = outputs.iter().filter(|o| o.status.success()).count();
        assert!(
            ok >= 1,
            "attempt {attempt}: {} / {}",
            text(&outputs[0]),
            text(&outputs[1])
        );
        for o in outputs.iter().filter(|o| !o.status.success()) {
            assert!(
                text(o).contains("in use by another run"),
                "attempt {attempt}: {}",
                text(o)
            );
        }
        assert_one_run(&dir.join("o"), 250);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_checkpoint_of_another_run_is_refused_naming_both() {
    let dir = scratch("output", "foreign");
    let scene = include_str!("../../scenes/two_disks.toml");
    let other = scene.replace("youngs_modulus = 1000.0", "youngs_modulus = 1200.0");
    assert_ne!(scene, other);
    std::fs::write(dir.join("a.toml"), scene).unwrap();
    std::fs::write(dir.join("b.toml"), &other).unwrap();
    for (name, out) in [("a.toml", "a"), ("b.toml", "b")] {
        let run = mpm(
            &[
                "run",
                name,
                "--out",
                out,
                "--steps",
                "40",
                "--checkpoint-every",
                "20",
                "-q",
            ],
            &dir,
        );
        assert!(run.status.success(), "{}", text(&run));
    }
    let step = "checkpoints/step_00000020";
    let report = std::fs::read(dir.join("a/report.csv")).unwrap();

    // b's simulation.ckpt put into a's checkpoint folder (same step): the checksum differs.
    std::fs::copy(
        dir.join("b").join(step).join("simulation.ckpt"),
        dir.join("a").join(step).join("simulation.ckpt"),
    )
    .unwrap();
    let resumed = mpm(&["resume", &format!("a/{step}"), "-q"], &dir);
    assert!(!resumed.status.success());
    let message = text(&resumed);
    assert!(
        message.contains("simulation.ckpt") && message.contains("run.json") && message.contains("mixes"),
        "{message}"
    );
    assert_eq!(
        std::fs::read(dir.join("a/report.csv")).unwrap(),
        report,
        "a is untouched"
    );

    // b's whole checkpoint folder put into a's run folder: the scene digest differs.
    let foreign = dir.join("a/checkpoints/step_00000020");
    std::fs::remove_dir_all(&foreign).unwrap();
    for file in ["simulation.ckpt", "run.json"] {
        std::fs::create_dir_all(&foreign).unwrap();
        std::fs::copy(dir.join("b").join(step).join(file), foreign.join(file)).unwrap();
    }
    let resumed = mpm(&["resume", &format!("a/{step}"), "-q"], &dir);
    assert!(!resumed.status.success());
    let message = text(&resumed);
    assert!(
        message.contains("another scene") && message.contains("a/scene.toml") && message.contains(step),
        "{message}"
    );
    assert_eq!(
        std::fs::read(dir.join("a/report.csv")).unwrap(),
        report,
        "a is untouched"
    );

    // Its own checkpoint resumes.
    let own = mpm(&["resume", &format!("b/{step}"), "-q"], &dir);
    assert!(own.status.success(), "{}", text(&own));
    std::fs::remove_dir_all(&dir).unwrap();
}
