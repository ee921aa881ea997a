//! The `mpm` program as a user meets it: help and version, refused arguments, output folders
//! that are not silently overwritten, limits that stop bombs before they run, `check` doing
//! what `run` does, a scene copy that reruns, and an interrupted run resumed bit for bit.

use std::path::Path;
use std::process::Command;

mod common;
use common::program::{mpm, scratch, text};

fn two_disks() -> &'static str {
    include_str!("../../scenes/two_disks.toml")
}

#[test]
fn help_version_and_unknown_arguments() {
    let dir = scratch("cli", "help");
    let v = mpm(&["--version"], &dir);
    assert!(v.status.success());
    assert!(text(&v).contains(env!("CARGO_PKG_VERSION")));
    for command in ["run", "resume", "check", "matrices", "study", "bench", "homework"] {
        let h = mpm(&[command, "--help"], &dir);
        assert!(h.status.success(), "{command} --help: {}", text(&h));
        assert!(text(&h).contains("Usage: mpm"), "{command}");
    }
    let bad = mpm(&["run", "--bogus"], &dir);
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("--bogus"));
    let extra = mpm(&["check", "a.toml", "b.toml"], &dir);
    assert_eq!(extra.status.code(), Some(2), "an extra argument is refused");
    let value = mpm(&["run", "--end-time", "-1"], &dir);
    assert_eq!(value.status.code(), Some(2));
    assert!(text(&value).contains("-1"));
}

#[test]
fn a_second_run_into_the_same_folder_is_refused_and_overwrite_clears_the_old_output() {
    let dir = scratch("cli", "overwrite");
    let first = mpm(&["run", "--out", "o", "--steps", "30", "-q"], &dir);
    assert!(first.status.success(), "{}", text(&first));
    let snapshots = |d: &Path| {
        std::fs::read_dir(d)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".vtp"))
            .count()
    };
    let before = std::fs::read(dir.join("o/report.csv")).unwrap();
    let second = mpm(&["run", "--out", "o", "--steps", "10", "-q"], &dir);
    assert!(!second.status.success());
    let message = text(&second);
    assert!(
        message.contains("already holds") && message.contains("--overwrite"),
        "{message}"
    );
    assert!(!message.contains("output written"), "nothing was written: {message}");
    assert_eq!(std::fs::read(dir.join("o/report.csv")).unwrap(), before, "nothing lost");
    // A left-over temporary file of the run's (the atomic writer's `.NAME.PID-N-R.tmp`) and a
    // file of the user's.
    std::fs::write(
        dir.join("o/.particles_000001.vtp.4242-0-0123456789abcdef.tmp"),
        "partial",
    )
    .unwrap();
    std::fs::write(dir.join("o/notes.txt"), "mine").unwrap();
    let third = mpm(&["run", "--out", "o", "--steps", "10", "-q", "--overwrite"], &dir);
    assert!(third.status.success(), "{}", text(&third));
    assert!(!dir.join("o/.particles_000001.vtp.4242-0-0123456789abcdef.tmp").exists());
    assert!(dir.join("o/notes.txt").exists(), "files a run does not write are kept");
    let rows = std::fs::read_to_string(dir.join("o/report.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 11, "header and ten steps");
    assert!(snapshots(&dir.join("o")) >= 2);
}

#[test]
fn an_interrupted_run_resumes_bit_for_bit() {
    let dir = scratch("cli", "resume");
    let whole = mpm(&["run", "--out", "whole", "-q"], &dir);
    assert!(whole.status.success(), "{}", text(&whole));
    // The "interrupted" run stops at step 130, having checkpointed every 40 steps.
    let cut = mpm(
        &[
            "run",
            "--out",
            "cut",
            "--steps",
            "130",
            "--checkpoint-every",
            "40",
            "-q",
        ],
        &dir,
    );
    assert!(cut.status.success(), "{}", text(&cut));
    assert!(dir.join("cut/checkpoints/step_00000120/run.json").exists());
    for (checkpoint, out) in [
        ("cut/checkpoints/step_00000080", None),
        ("cut/checkpoints/step_00000040", Some("elsewhere")),
    ] {
        let mut args = vec!["resume", checkpoint, "-q"];
        if let Some(o) = out {
            args.extend(["--out", o]);
        }
        let resumed = mpm(&args, &dir);
        assert!(resumed.status.success(), "{}", text(&resumed));
        let folder = dir.join(out.unwrap_or("cut"));
        for entry in std::fs::read_dir(dir.join("whole")).unwrap() {
            let name = entry.unwrap().file_name();
            let name = name.to_string_lossy();
            if name.ends_with(".vtp") || name == "report.csv" || name == "particles.pvd" {
                assert_eq!(
                    std::fs::read(dir.join("whole").join(&*name)).unwrap(),
                    std::fs::read(folder.join(&*name)).unwrap_or_default(),
                    "{checkpoint}: {name} differs from the uninterrupted run's"
                );
            }
        }
    }
    let missing = mpm(&["resume", "cut/checkpoints/step_00000099"], &dir);
    assert!(!missing.status.success());
    assert!(text(&missing).contains("step_00000099"));
}

#[test]
fn the_scene_copy_reruns_from_the_output_folder_with_its_particle_file() {
    let dir = scratch("cli", "rerun");
    std::fs::create_dir_all(dir.join("scene")).unwrap();
    let mut csv = String::from("x,y,volume\n");
    for i in 0..6 {
        for j in 0..6 {
            csv.push_str(&format!("{},{},0.01\n", 0.45 + 0.1 * i as f64, 0.45 + 0.1 * j as f64));
        }
    }
    std::fs::write(dir.join("scene/block.csv"), csv).unwrap();
    let scene = r#"
title = "a block from a file"
[grid]
origin = [0.0, 0.0]
cell_size = [0.2, 0.2]
cells = [10, 10]
[time]
end = 0.01
dt = 1e-4
[loads]
gravity = [0.0, -9.81]
[[bodies]]
name = "block"
density = 1000.0
material = { model = "linear_elastic", youngs_modulus = 1e5, poisson_ratio = 0.3, plane = "strain" }
geometry = { file = "block.csv" }
"#;
    std::fs::write(dir.join("scene/scene.toml"), scene).unwrap();
    let first = mpm(&["run", "scene/scene.toml", "--out", "first", "-q"], &dir);
    assert!(first.status.success(), "{}", text(&first));
    // Rerun the copy from inside the output folder.
    let again = mpm(&["run", "scene.toml", "--out", "../again", "-q"], &dir.join("first"));
    assert!(again.status.success(), "{}", text(&again));
    assert_eq!(
        std::fs::read(dir.join("first/report.csv")).unwrap(),
        std::fs::read(dir.join("again/report.csv")).unwrap()
    );
    // A run resumed into another folder takes the particle file along: its scene.toml reruns.
    let cut = mpm(
        &[
            "run",
            "scene/scene.toml",
            "--out",
            "cut",
            "--steps",
            "60",
            "--checkpoint-every",
            "50",
            "-q",
        ],
        &dir,
    );
    assert!(cut.status.success(), "{}", text(&cut));
    let resumed = mpm(
        &["resume", "cut/checkpoints/step_00000050", "--out", "moved", "-q"],
        &dir,
    );
    assert!(resumed.status.success(), "{}", text(&resumed));
    let third = mpm(&["run", "scene.toml", "--out", "../third", "-q"], &dir.join("moved"));
    assert!(third.status.success(), "{}", text(&third));
    assert_eq!(
        std::fs::read(dir.join("first/report.csv")).unwrap(),
        std::fs::read(dir.join("third/report.csv")).unwrap()
    );
}

#[test]
fn check_refuses_what_run_refuses_naming_the_key() {
    let dir = scratch("cli", "check");
    let bombs = [
        // Memory: a huge grid with many particles per cell.
        (
            two_disks()
                .replace("cells = [20, 20]", "cells = [9998, 9998]")
                .replace("particles_per_cell = 2", "particles_per_cell = 32"),
            "grid.cells",
        ),
        // Snapshots without end.
        (
            two_disks().replace("snapshot_interval = 0.05", "snapshot_interval = 1e-300"),
            "output.snapshot_interval",
        ),
        // Steps without end.
        (two_disks().replace("end = 3.5", "end = 1e15"), "time.end"),
    ];
    for (k, (scene, key)) in bombs.iter().enumerate() {
        let path = dir.join(format!("bomb{k}.toml"));
        std::fs::write(&path, scene).unwrap();
        for command in ["check", "run"] {
            let mut args = vec![command, path.to_str().unwrap()];
            if command == "run" {
                args.extend(["--out", "never"]);
            }
            let o = mpm(&args, &dir);
            let message = text(&o);
            assert!(!o.status.success(), "{command} {key}: {message}");
            assert!(message.contains(key), "{command}: `{key}` not named in: {message}");
            assert!(message.contains("--allow-large"), "{message}");
        }
        assert!(!dir.join("never").exists(), "nothing written for a refused run");
    }
    let ok = mpm(
        &[
            "check",
            &format!("{}/../scenes/two_disks.toml", env!("CARGO_MANIFEST_DIR")),
        ],
        &dir,
    );
    assert!(ok.status.success(), "{}", text(&ok));
    let out = text(&ok);
    assert!(
        out.contains("estimated cost") && out.contains("stable time step"),
        "{out}"
    );
}

#[test]
fn check_refuses_a_fixed_step_above_the_stable_step_with_numbers_for_people() {
    let dir = scratch("cli", "bigdt");
    let path = dir.join("bigdt.toml");
    std::fs::write(&path, two_disks().replace("cfl = 0.5", "dt = 22.0")).unwrap();
    for command in ["check", "run"] {
        let o = mpm(&[command, path.to_str().unwrap()], &dir);
        let message = text(&o);
        assert!(!o.status.success(), "{message}");
        assert!(
            message.contains("the fixed time step 22 exceeds the stable step 0.03"),
            "{command}: {message}"
        );
        assert!(!message.contains("e-2"), "numbers for people: {message}");
    }
    assert!(!dir.join("out").exists(), "a refused run writes nothing");
}

#[test]
fn dispersion_prints_the_curve_as_csv_and_names_bad_input() {
    let dir = scratch("cli", "dispersion");
    let o = mpm(&["dispersion", "--mass", "consistent", "--cells", "8"], &dir);
    assert!(o.status.success(), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    let mut lines = out.lines();
    assert_eq!(lines.next(), Some("theta,c_ratio"));
    let rows: Vec<(f64, f64)> = lines
        .map(|l| {
            let (t, c) = l.split_once(',').unwrap();
            (t.parse().unwrap(), c.parse().unwrap())
        })
        .collect();
    assert_eq!(rows.len(), 4);
    // bilinear, 2 particles per cell, consistent: 1.033 at π/4, 1.139 at π/2, 4/π at π
    for ((t, c), (theta, want)) in rows.iter().zip([
        (0.25, 1.033),
        (0.5, 1.139),
        (0.75, 1.307),
        (1.0, 4.0 / std::f64::consts::PI),
    ]) {
        assert!(
            (t - theta * std::f64::consts::PI).abs() < 1e-12 && (c - want).abs() < 1e-3,
            "{t},{c}"
        );
    }
    let mixed = mpm(
        &[
            "dispersion",
            "--mass",
            "lumped",
            "--acceleration-mass",
            "consistent",
            "--samples",
            "2",
        ],
        &dir,
    );
    let out = String::from_utf8_lossy(&mixed.stdout).to_string();
    let last: f64 = out.lines().last().unwrap().split_once(',').unwrap().1.parse().unwrap();
    assert!((last - 2.0 / std::f64::consts::PI).abs() < 1e-12, "{out}");
    let bad = mpm(&["dispersion", "--particles-per-cell", "0"], &dir);
    assert!(
        !bad.status.success() && text(&bad).contains("particles_per_cell"),
        "{}",
        text(&bad)
    );
    let bad = mpm(&["dispersion", "--mass", "blended:3"], &dir);
    assert!(!bad.status.success() && text(&bad).contains("gamma"), "{}", text(&bad));
}

#[test]
fn threads_from_the_command_line_or_the_scene_change_no_bit_of_the_output() {
    let dir = scratch("cli", "threads");
    std::fs::write(
        dir.join("threaded.toml"),
        format!("{}\n[execution]\nthreads = 3\n", two_disks()),
    )
    .unwrap();
    let serial = mpm(&["run", "--out", "serial", "--steps", "60", "-q"], &dir);
    let flag = mpm(&["run", "--out", "flag", "--steps", "60", "--threads", "2", "-q"], &dir);
    let key = mpm(&["run", "threaded.toml", "--out", "key", "--steps", "60", "-q"], &dir);
    // Cut at step 30 and resumed on 2 threads.
    let cut = mpm(
        &[
            "run",
            "threaded.toml",
            "--out",
            "cut",
            "--steps",
            "30",
            "--checkpoint-every",
            "30",
            "-q",
        ],
        &dir,
    );
    for o in [&serial, &flag, &key, &cut] {
        assert!(o.status.success(), "{}", text(o));
    }
    let resumed = mpm(
        &[
            "resume",
            "cut/checkpoints/step_00000030",
            "--steps",
            "60",
            "--threads",
            "2",
            "-q",
        ],
        &dir,
    );
    assert!(resumed.status.success(), "{}", text(&resumed));
    for entry in std::fs::read_dir(dir.join("serial")).unwrap() {
        let name = entry.unwrap().file_name();
        let name = name.to_string_lossy().into_owned();
        if name.ends_with(".vtp") || name == "report.csv" {
            let want = std::fs::read(dir.join("serial").join(&name)).unwrap();
            for other in ["flag", "key", "cut"] {
                assert_eq!(
                    want,
                    std::fs::read(dir.join(other).join(&name)).unwrap_or_default(),
                    "{other}/{name} differs from the serial run's"
                );
            }
        }
    }
    // The scene copy keeps the key; out-of-range counts name where they came from.
    let copy = std::fs::read_to_string(dir.join("key/scene.toml")).unwrap();
    assert!(copy.contains("[execution]") && copy.contains("threads = 3"), "{copy}");
    std::fs::write(
        dir.join("zero.toml"),
        format!("{}\n[execution]\nthreads = 0\n", two_disks()),
    )
    .unwrap();
    let zero = mpm(&["check", "zero.toml"], &dir);
    assert!(
        !zero.status.success() && text(&zero).contains("execution.threads"),
        "{}",
        text(&zero)
    );
    let many = mpm(&["run", "--threads", "100000", "--out", "many"], &dir);
    assert!(
        !many.status.success() && text(&many).contains("--threads"),
        "{}",
        text(&many)
    );
    assert!(!dir.join("many").exists(), "a refused run writes nothing");
}

#[test]
fn a_run_json_naming_files_outside_its_run_is_refused_and_a_run_resumes_from_inside_its_folder() {
    let dir = scratch("cli", "resume_paths");
    let cut = mpm(
        &["run", "--out", "cut", "--steps", "60", "--checkpoint-every", "40", "-q"],
        &dir,
    );
    assert!(cut.status.success(), "{}", text(&cut));
    let state = dir.join("cut/checkpoints/step_00000040/run.json");
    let original = std::fs::read_to_string(&state).unwrap();
    assert!(original.contains("\"particles_000000.vtp\""), "{original}");
    let victim = dir.join("victim.vtp");
    for name in ["../../victim.vtp", victim.to_str().unwrap(), "sub/particles_000000.vtp"] {
        std::fs::write(&victim, "not to be touched").unwrap();
        let edited = original.replace("\"particles_000000.vtp\"", &serde_json_string(name));
        std::fs::write(&state, edited).unwrap();
        let o = mpm(&["resume", "cut/checkpoints/step_00000040", "--out", "new", "-q"], &dir);
        assert!(!o.status.success(), "{name}: resumed");
        assert!(text(&o).contains("not `particles_000000.vtp`"), "{name}: {}", text(&o));
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "not to be touched");
        assert!(!dir.join("new").exists(), "{name}: an output folder was made");
    }
    std::fs::write(&state, original).unwrap();
    // A temporary file of an interrupted write of a later checkpoint goes when it is rewritten.
    let stale = dir.join("cut/checkpoints/step_00000040/.simulation.ckpt.4242-0.tmp");
    std::fs::write(&stale, "half a checkpoint").unwrap();
    // From inside the run folder, the checkpoint's path has an empty run folder: `.`.
    let o = mpm(&["resume", "checkpoints/step_00000040", "-q"], &dir.join("cut"));
    assert!(o.status.success(), "{}", text(&o));
    assert!(stale.exists(), "the checkpoint resumed from is not rewritten");
    let o = mpm(
        &[
            "resume",
            "checkpoints/step_00000040",
            "--out",
            "../again",
            "--checkpoint-every",
            "40",
            "-q",
        ],
        &dir.join("cut"),
    );
    assert!(o.status.success(), "{}", text(&o));
    let rewritten = dir.join("again/checkpoints/step_00000120");
    assert!(rewritten.join("run.json").exists());
    std::fs::write(rewritten.join(".run.json.4242-1.tmp"), "stale").unwrap();
    let o = mpm(
        &["resume", "checkpoints/step_00000080", "--checkpoint-every", "40", "-q"],
        &dir.join("again"),
    );
    assert!(o.status.success(), "{}", text(&o));
    let left: Vec<_> = std::fs::read_dir(&rewritten)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

/// `s` as a JSON string literal (quotes and backslashes escaped).
fn serde_json_string(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

#[test]
fn an_end_time_option_meets_the_limits_of_the_scenes_time_end() {
    let dir = scratch("cli", "end_time");
    for end in ["1e12", "inf", "0"] {
        let o = mpm(&["run", "--out", "far", "--end-time", end, "-q"], &dir);
        assert!(!o.status.success(), "--end-time {end} ran");
        assert!(text(&o).contains("--end-time"), "{}", text(&o));
        assert!(!dir.join("far").exists(), "--end-time {end}: output written");
    }
    // Within the limits it runs, with the scene's own snapshot interval (0.05): 21 snapshots to 1.
    let o = mpm(&["run", "--out", "near", "--end-time", "1", "-q"], &dir);
    assert!(o.status.success(), "{}", text(&o));
    let snapshots = std::fs::read_dir(dir.join("near"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().ends_with(".vtp"))
        .count();
    assert_eq!(snapshots, 21);
}

#[test]
fn a_resumed_run_meets_the_limits_of_a_new_one() {
    let dir = scratch("cli", "resume_limits");
    let cut = mpm(
        &["run", "--out", "cut", "--steps", "50", "--checkpoint-every", "40", "-q"],
        &dir,
    );
    assert!(cut.status.success(), "{}", text(&cut));
    let state = dir.join("cut/checkpoints/step_00000040/run.json");
    let original = std::fs::read_to_string(&state).unwrap();
    let tiny = original.replace("\"snapshot_interval\": 0.05", "\"snapshot_interval\": 1e-9");
    assert_ne!(tiny, original, "{original}");
    std::fs::write(&state, tiny).unwrap();
    let o = mpm(&["resume", "cut/checkpoints/step_00000040", "--out", "new", "-q"], &dir);
    assert!(!o.status.success());
    assert!(text(&o).contains("more than the limit of 2000"), "{}", text(&o));
    assert!(!dir.join("new").exists());
    std::fs::write(&state, &original).unwrap();
    for end in ["1e12", "inf"] {
        let o = mpm(
            &[
                "resume",
                "cut/checkpoints/step_00000040",
                "--out",
                "new",
                "--end-time",
                end,
                "-q",
            ],
            &dir,
        );
        assert!(!o.status.success(), "--end-time {end} resumed");
        assert!(!dir.join("new").exists());
    }
    let o = mpm(&["resume", "cut/checkpoints/step_00000040", "--out", "new", "-q"], &dir);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn scene_checkpoint_and_run_files_are_read_only_when_regular_and_bounded() {
    let dir = scratch("cli", "bounded_reads");
    // A device, a pipe and a folder are refused before anything is read (nothing hangs).
    let fifo = dir.join("pipe.toml");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    std::fs::create_dir_all(dir.join("folder.toml")).unwrap();
    for scene in ["/dev/zero", fifo.to_str().unwrap(), "folder.toml"] {
        for args in [vec!["check", scene], vec!["run", scene, "--out", "o"]] {
            let command = args[0];
            let o = mpm(&args, &dir);
            assert!(!o.status.success());
            assert!(
                text(&o).contains("not a regular file"),
                "{command} {scene}: {}",
                text(&o)
            );
        }
    }
    // A scene over 16 MiB is refused before it is parsed.
    let big = dir.join("big.toml");
    std::fs::write(&big, "#".repeat((16 << 20) + 1)).unwrap();
    let o = mpm(&["check", big.to_str().unwrap()], &dir);
    assert!(text(&o).contains("more than the 16777216"), "{}", text(&o));
    // A checkpoint folder whose files are pipes.
    let checkpoint = dir.join("run/checkpoints/step_00000001");
    std::fs::create_dir_all(&checkpoint).unwrap();
    assert!(Command::new("mkfifo")
        .arg(checkpoint.join("run.json"))
        .status()
        .unwrap()
        .success());
    let o = mpm(&["resume", checkpoint.to_str().unwrap()], &dir);
    assert!(!o.status.success());
    assert!(text(&o).contains("not a regular file"), "{}", text(&o));
    assert!(!dir.join("o").exists());
}

#[test]
fn thread_counts_are_bounded_where_they_are_read() {
    let dir = scratch("cli", "threads");
    for args in [
        &["bench", "--threads", "1000000"][..],
        &["run", "--threads", "1000000", "--out", "o"][..],
        &["resume", "o/checkpoints/step_00000001", "--threads", "1000000"][..],
    ] {
        let out = mpm(args, &dir);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", text(&out));
        assert!(text(&out).contains("1000000"), "{args:?}: {}", text(&out));
    }
    assert!(!dir.join("o").exists(), "nothing written");
    // A scene asking for more threads than the program starts is refused naming the key.
    std::fs::write(
        dir.join("s.toml"),
        format!("{}\n[execution]\nthreads = 1000000\n", two_disks()),
    )
    .unwrap();
    let out = mpm(&["check", "s.toml"], &dir);
    assert!(!out.status.success());
    assert!(text(&out).contains("threads"), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}
