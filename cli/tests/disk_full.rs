//! A full disk loses nothing already written and leaves nothing cut short: the report holds
//! whole rows under its header, a file copied into the output is whole or absent, and the error
//! names the file that could not be written.
//!
//! The disk is a small tmpfs mounted for each test, which needs root (or the right to mount);
//! without it the tests say they are skipped and pass.

#[path = "../../tests/common/scratch.rs"]
mod scratch;
use scratch::names;
use std::path::{Path, PathBuf};
use std::process::Command;

use sparse_mpm::io::csv::CsvWriter;
use sparse_mpm::scene::Scene;
use sparse_mpm::MpmError;
use sparse_mpm_cli::run::{run_scene_with, RunOptions};

const TWO_DISKS: &str = include_str!("../../scenes/two_disks.toml");

/// A tmpfs of `kib` KiB mounted for one test, unmounted (and its folder removed) when dropped.
struct SmallDisk {
    root: PathBuf,
}

impl SmallDisk {
    /// The mounted disk, or `None` (after saying why the test is skipped) when mounting is not
    /// possible here.
    fn mount(test: &str, kib: usize) -> Option<SmallDisk> {
        let root = std::env::temp_dir().join(format!("sparse_mpm_disk_full_{test}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).unwrap();
        let mounted = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={kib}k"), "tmpfs"])
            .arg(&root)
            .output();
        match mounted {
            Ok(out) if out.status.success() => Some(SmallDisk { root }),
            Ok(out) => {
                eprintln!(
                    "skipped {test}: mounting a small tmpfs failed (root is needed): {}",
                    String::from_utf8_lossy(&out.stderr).trim()
                );
                let _ = std::fs::remove_dir_all(&root);
                None
            }
            Err(e) => {
                eprintln!("skipped {test}: `mount` could not be run: {e}");
                let _ = std::fs::remove_dir_all(&root);
                None
            }
        }
    }

    /// Fills the disk up with one file, to the last byte it takes.
    fn fill(&self) {
        use std::io::Write;
        let mut f = std::fs::File::create(self.root.join("filler")).unwrap();
        let block = vec![0u8; 4096];
        while f.write_all(&block).is_ok() {}
        let byte = [0u8; 1];
        while f.write_all(&byte).is_ok() {}
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.root).status();
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

/// Checks that `path` holds a header of `columns` names and whole rows of `columns` numbers;
/// returns the number of rows.
fn whole_rows(path: &Path, columns: usize) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.ends_with('\n'), "{} ends inside a line", path.display());
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap().split(',').count(), columns, "the header");
    let mut rows = 0;
    for (k, line) in lines.enumerate() {
        let values: Vec<&str> = line.split(',').collect();
        assert_eq!(values.len(), columns, "row {k} is cut short: {line}");
        assert!(values.iter().all(|v| v.parse::<f64>().is_ok()), "row {k}: {line}");
        rows += 1;
    }
    rows
}

fn io_path(e: &MpmError) -> &Path {
    match e {
        MpmError::Io { path, .. } => path,
        other => panic!("expected an I/O error, got {other}"),
    }
}

#[test]
fn a_csv_file_appears_with_its_header_or_not_at_all() {
    let Some(disk) = SmallDisk::mount("csv_header", 64) else {
        return;
    };
    disk.fill();
    let path = disk.root.join("history.csv");
    let err = CsvWriter::create(&path, &["time", "energy"]).unwrap_err();
    assert_eq!(io_path(&err), path);
    assert!(!path.exists(), "no empty file is left under the final name");
    assert_eq!(names(&disk.root), ["filler"], "nor a temporary file");
}

#[test]
fn a_full_disk_leaves_whole_rows_in_a_csv_file() {
    let Some(disk) = SmallDisk::mount("csv_rows", 64) else {
        return;
    };
    let path = disk.root.join("history.csv");
    let mut w = CsvWriter::create(&path, &["time", "a", "b", "c"]).unwrap();
    let mut flushed = 0usize;
    let err = loop {
        for _ in 0..7 {
            w.write_row(&[flushed as f64 * 1e-3, 1.0 / 3.0, -2.0 / 7.0, std::f64::consts::PI])
                .unwrap();
        }
        match w.flush() {
            Ok(()) => flushed += 7,
            Err(e) => break e,
        }
        assert!(flushed < 1_000_000, "the disk never filled");
    };
    assert_eq!(io_path(&err), path, "the error names the file");
    assert_eq!(
        whole_rows(&path, 4),
        flushed,
        "every flushed row, and no part of the failed ones"
    );
    drop(w);
    assert_eq!(
        whole_rows(&path, 4),
        flushed,
        "dropping the writer after the error adds nothing"
    );
}

#[test]
fn a_run_on_a_full_disk_keeps_whole_rows_and_names_the_report() {
    // One snapshot at the start (~200 KiB) fits; 3500 report rows (~2 MiB) do not.
    let Some(disk) = SmallDisk::mount("run_report", 1024) else {
        return;
    };
    let scene = Scene::from_toml_str(
        &TWO_DISKS
            .replace("cfl = 0.5", "dt = 0.001")
            .replace("snapshot_interval = 0.05", "snapshot_interval = 3.5"),
    )
    .unwrap();
    let out = disk.root.join("out");
    let err = run_scene_with(&scene, &out, &RunOptions::default(), |_| {}).unwrap_err();
    assert_eq!(io_path(&err), out.join("report.csv"), "{err}");
    let rows = whole_rows(
        &out.join("report.csv"),
        sparse_mpm::simulation::StepReport::COLUMNS.len(),
    );
    assert!(rows > 100, "the rows written before the disk filled are kept ({rows})");
    let left = names(&out);
    assert!(!left.iter().any(|n| n.ends_with(".tmp")), "{left:?}");
    // The series lists what exists, and each listed snapshot reads back whole.
    for (_, file) in sparse_mpm_cli::vtk::read_pvd(&out.join("particles.pvd")).unwrap() {
        sparse_mpm_cli::vtk::read_vtp(&out.join(file)).unwrap();
    }
}

#[test]
fn a_particle_file_copied_into_a_full_disk_is_whole_or_absent() {
    let Some(disk) = SmallDisk::mount("copy", 128) else {
        return;
    };
    // The scene and its particle file (~500 KiB) outside the small disk.
    let src = std::env::temp_dir().join(format!("sparse_mpm_disk_full_src_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&src);
    std::fs::create_dir_all(&src).unwrap();
    let mut csv = String::from("x,y,volume,mass\n");
    let n = 120;
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (
                0.1 + 0.8 * (i as f64 + 0.5) / n as f64,
                0.1 + 0.8 * (j as f64 + 0.5) / n as f64,
            );
            csv.push_str(&format!(
                "{x:.17},{y:.17},0.0000444444444444444,0.0000444444444444444\n"
            ));
        }
    }
    std::fs::write(src.join("block.csv"), &csv).unwrap();
    let scene_text = r#"
[grid]
origin = [0.0, 0.0]
cell_size = [0.1, 0.1]
cells = [10, 10]

[time]
end = 0.001
dt = 0.001

[[bodies]]
name = "block"
material = { model = "linear_elastic", youngs_modulus = 100.0, poisson_ratio = 0.3 }
density = 1.0
geometry = { file = "block.csv" }
"#;
    std::fs::write(src.join("scene.toml"), scene_text).unwrap();
    let scene = Scene::load(&src.join("scene.toml")).unwrap();
    let out = disk.root.join("out");
    let err = run_scene_with(&scene, &out, &RunOptions::default(), |_| {}).unwrap_err();
    assert_eq!(
        io_path(&err),
        out.join("input_0_block.csv"),
        "the error names the copy: {err}"
    );
    let left = names(&out);
    assert!(
        !left.iter().any(|n| n.starts_with("input_") || n.ends_with(".tmp")),
        "no truncated copy under its final name, no temporary file: {left:?}"
    );
    std::fs::remove_dir_all(&src).unwrap();
}
