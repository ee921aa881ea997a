//! `--set KEY=VALUE`: a scene changed from the command line runs to the same bits as the edited
//! file; a bad key or value is refused by name and nothing is written; `mpm scene --print`
//! shows the scene with its defaults, as TOML that reads back to itself.

use std::path::Path;

mod common;
use common::program::{mpm, ok, scratch, text};

const CANTILEVER: &str = include_str!("../../scenes/cantilever.toml");

fn read(dir: &Path, file: &str) -> Vec<u8> {
    std::fs::read(dir.join(file)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(file).display()))
}

#[test]
fn overrides_run_to_the_bits_of_the_edited_file() {
    let dir = scratch("overrides", "bits");
    std::fs::write(dir.join("cantilever.toml"), CANTILEVER).unwrap();
    let edited = CANTILEVER
        .replace("end = 1.5", "end = 0.05")
        .replace("density = 1050.0", "density = 1200.0")
        .replace("gravity = [0.0, -10.0]", "gravity = [0.0, -9.0]")
        .replace("shape = \"linear\"", "shape = \"linear\"\nsort_interval = 7");
    assert_ne!(edited, CANTILEVER);
    std::fs::write(dir.join("edited.toml"), &edited).unwrap();
    ok(mpm(&["run", "edited.toml", "-o", "edited", "-q"], &dir));
    ok(mpm(
        &[
            "run",
            "cantilever.toml",
            "-o",
            "set",
            "-q",
            "--set",
            "time.end=0.05",
            "--set",
            "bodies[0].density=1200.0",
            "--set",
            "loads.gravity=[0.0, -9.0]",
            "--set",
            "schemes.sort_interval=7",
        ],
        &dir,
    ));
    for file in ["report.csv", "scene.toml", "particles_000001.vtp"] {
        assert!(
            read(&dir.join("set"), file) == read(&dir.join("edited"), file),
            "{file} differs"
        );
    }
}

#[test]
fn a_bad_override_is_refused_by_name_and_writes_nothing() {
    let dir = scratch("overrides", "refused");
    std::fs::write(dir.join("cantilever.toml"), CANTILEVER).unwrap();
    for (set, want) in [
        ("bodies[0].densty=1", "--set bodies[0].densty`: unknown field `densty`"),
        ("bodies[2].density=1", "the array has 1 entries"),
        ("time.end=soon", "--set time.end`: invalid type: string \"soon\""),
        ("time.end=-1", "time.end"),
        ("grid", "KEY=VALUE"),
        ("time.end[0]=1", "is not an array"),
        ("bodies[99999999999999999999999].density=1", "is not an index"),
        (
            "a.b.c.d.e.f.g.h.i.j.k.l.m.n.o.p.q.r.s.t.u.v.w.x.y.z.a.b.c.d.e.f.g=1",
            "more than 32",
        ),
    ] {
        let out = mpm(&["run", "cantilever.toml", "-o", "out", "-q", "--set", set], &dir);
        assert!(!out.status.success(), "{set}: {}", text(&out));
        assert!(text(&out).contains(want), "{set}: {}", text(&out));
        assert!(!dir.join("out").exists(), "{set}: output written");
    }
    // A key of fifty thousand steps is refused before anything is built from it.
    let long = format!("{}=1", vec!["a"; 50_000].join("."));
    let out = mpm(&["check", "cantilever.toml", "--set", &long], &dir);
    assert!(!out.status.success(), "{}", text(&out));
    assert!(
        text(&out).contains("more than 32") && text(&out).len() < 1000,
        "{}",
        text(&out)
    );
}

#[test]
fn the_printed_scene_has_its_defaults_and_reads_back_to_itself() {
    let dir = scratch("overrides", "print");
    std::fs::write(dir.join("cantilever.toml"), CANTILEVER).unwrap();
    let printed = ok(mpm(
        &["scene", "--print", "cantilever.toml", "--set", "schemes.transfer=apic"],
        &dir,
    ));
    let printed = String::from_utf8(printed.stdout).unwrap();
    for default in [
        "sort_interval = 50",
        "singularity = \"error\"",
        "transfer = \"apic\"",
        "particles_per_cell = 2",
    ] {
        assert!(printed.contains(default), "{default} missing:\n{printed}");
    }
    std::fs::write(dir.join("printed.toml"), &printed).unwrap();
    let again = ok(mpm(&["scene", "printed.toml"], &dir));
    assert_eq!(String::from_utf8(again.stdout).unwrap(), printed);
}
