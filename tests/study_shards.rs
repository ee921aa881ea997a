//! A study planned, run in shares (in any order, one interrupted and run again, through GNU
//! parallel, through a Slurm job array) and merged gives the runs.csv and report of the study
//! run in one process; runs of another version or plan are refused.

use std::path::Path;
use std::process::{Command, Stdio};

mod common;
use common::program::{mpm, ok, scratch, text, MPM};

/// runs.csv without the `*_seconds` columns.
fn runs_table(dir: &Path) -> Vec<Vec<String>> {
    let mut reader = csv::Reader::from_path(dir.join("runs.csv")).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| !header[i].ends_with("_seconds"))
        .collect();
    assert!(
        keep.len() < header.len(),
        "runs.csv names its wall-clock columns *_seconds"
    );
    let mut rows = vec![keep.iter().map(|&i| header[i].clone()).collect::<Vec<_>>()];
    for record in reader.records() {
        let record = record.unwrap();
        rows.push(keep.iter().map(|&i| record[i].to_string()).collect());
    }
    rows
}

/// report.md.
fn report(dir: &Path) -> String {
    std::fs::read_to_string(dir.join("report.md")).unwrap()
}

/// The plots, but the one of wall-clock times.
fn plots(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "png") && !p.ends_with("cost.png"))
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

/// The folder holds the same study as `reference`, but for wall-clock figures.
fn assert_same_study(dir: &Path, reference: &Path) {
    assert_eq!(runs_table(dir), runs_table(reference), "{}", dir.display());
    assert_eq!(report(dir), report(reference), "{}", dir.display());
    let (a, b) = (plots(dir), plots(reference));
    assert_eq!(
        a.iter().map(|p| &p.0).collect::<Vec<_>>(),
        b.iter().map(|p| &p.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{name} differs");
    }
}

/// A PATH with the mpm program's folder first.
fn path_with_mpm(extra: &Path) -> String {
    let mpm_dir = Path::new(MPM).parent().unwrap();
    format!(
        "{}:{}:{}",
        extra.display(),
        mpm_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    )
}

#[test]
fn a_quick_study_in_shards_merges_to_the_single_process_study() {
    let dir = scratch("study_shards", "shards");
    ok(mpm(&["study", "--quick", "-o", "single", "-q"], &dir));

    // Planned, then shard 3 of 3, shard 1 interrupted and run again, shard 2.
    ok(mpm(&["study", "plan", "--quick", "-o", "sharded", "-q"], &dir));
    let plan = std::fs::read_to_string(dir.join("sharded/plan.csv")).unwrap();
    let runs = plan.lines().count() - 1;
    assert!(runs > 20, "{runs} runs");
    ok(mpm(&["study", "run", "sharded", "--shard", "3/3", "-q"], &dir));
    let mut first = Command::new(MPM)
        .args(["study", "run", "sharded", "--shard", "1/3", "-q"])
        .current_dir(&dir)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    let _ = first.kill();
    let _ = first.wait();
    // And a run of shard 1 cut inside its result (as a kill in its write would leave it, but
    // for the atomic writer): parameters written, no completion marker.
    let id = plan.lines().nth(1).unwrap().split(',').nth(1).unwrap();
    let cut = dir.join("sharded/runs").join(id);
    std::fs::create_dir_all(&cut).unwrap();
    let _ = std::fs::remove_file(cut.join("complete"));
    std::fs::write(cut.join("result.json"), "{\"format\": \"sparse-mpm st").unwrap();
    let partial = mpm(&["study", "merge", "sharded", "-q"], &dir);
    assert_eq!(partial.status.code(), Some(3), "runs are missing: {}", text(&partial));
    assert!(std::fs::read_to_string(dir.join("sharded/report.md"))
        .unwrap()
        .contains("## Runs missing"));
    let again = ok(mpm(&["study", "run", "sharded", "--shard", "1/3"], &dir));
    assert!(text(&again).contains("run now"), "{}", text(&again));
    ok(mpm(&["study", "run", "sharded", "--shard", "2/3", "-q"], &dir));
    // A share run once more has nothing left to do.
    let done = ok(mpm(&["study", "run", "sharded", "--shard", "2/3"], &dir));
    assert!(text(&done).contains(": 0 run now"), "{}", text(&done));
    ok(mpm(&["study", "merge", "sharded", "-q"], &dir));
    assert_same_study(&dir.join("sharded"), &dir.join("single"));

    // Runs of another version or plan are not mixed in.
    let result = dir.join("sharded/runs").join(id).join("result.json");
    let original = std::fs::read_to_string(&result).unwrap();
    let version = format!("\"version\": \"{}\"", env!("CARGO_PKG_VERSION"));
    assert!(original.contains(&version));
    std::fs::write(&result, original.replacen(&version, "\"version\": \"0.0.1\"", 1)).unwrap();
    let mixed = mpm(&["study", "merge", "sharded", "-q"], &dir);
    assert!(!mixed.status.success());
    assert!(
        text(&mixed).contains("result.json") && text(&mixed).contains("0.0.1"),
        "{}",
        text(&mixed)
    );
    let digest_at = original.find("\"spec_digest\": \"").unwrap() + "\"spec_digest\": \"".len();
    let mut other = original.clone();
    other.replace_range(digest_at..digest_at + 4, "0000");
    std::fs::write(&result, other).unwrap();
    let mixed = mpm(&["study", "merge", "sharded", "-q"], &dir);
    assert!(
        !mixed.status.success() && text(&mixed).contains("another plan"),
        "{}",
        text(&mixed)
    );
    // A plan of another spec in the folder is refused, naming it.
    let replanned = mpm(
        &["study", "plan", "--quick", "--parts", "time_step", "-o", "sharded"],
        &dir,
    );
    assert!(!replanned.status.success() && text(&replanned).contains("another spec"));

    // GNU parallel, as docs/study.md gives it.
    if Command::new("parallel").arg("--version").output().is_ok() {
        let recipe = "mpm study plan --quick --out par -q \
                      && parallel mpm study run par --shard {}/4 -q ::: $(seq 4) \
                      && mpm study merge par -q";
        let out = Command::new("bash")
            .args(["-c", recipe])
            .current_dir(&dir)
            .env("PATH", path_with_mpm(&dir))
            .output()
            .unwrap();
        ok(out);
        assert_same_study(&dir.join("par"), &dir.join("single"));
    } else {
        assert!(
            std::env::var_os("CI").is_none(),
            "GNU parallel is missing: .ci/run installs it"
        );
        eprintln!("skipped the GNU parallel recipe: `parallel` is not installed");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_slurm_scripts_run_unchanged_under_a_job_array() {
    // A stand-in for sbatch: runs an array's tasks at once (as a cluster would), each with the
    // variables Slurm sets, then a dependent job; prints job ids as `sbatch --parsable` does.
    let dir = scratch("study_shards", "slurm");
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let sbatch = r#"#!/bin/bash
array=""; script=""
for a in "$@"; do
  case $a in
    --array=*) array=${a#--array=} ;;
    --*) ;;
    *) script=$a ;;
  esac
done
if [ -n "$array" ]; then
  n=${array#1-}
  pids=()
  for k in $(seq 1 "$n"); do
    SLURM_ARRAY_TASK_ID=$k SLURM_ARRAY_TASK_COUNT=$n SLURM_ARRAY_TASK_MAX=$n bash "$script" > "task_$k.out" 2>&1 &
    pids+=($!)
  done
  for p in "${pids[@]}"; do wait "$p" || { echo "task failed" >&2; exit 1; }; done
  echo 1001
else
  bash "$script" > merge.out 2>&1 || { cat merge.out >&2; exit 1; }
  echo 1002
fi
"#;
    std::fs::write(bin.join("sbatch"), sbatch).unwrap();
    Command::new("chmod")
        .args(["+x"])
        .arg(bin.join("sbatch"))
        .status()
        .unwrap();
    let scripts = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/slurm");
    let submit = Command::new("bash")
        .arg(scripts.join("submit.sh"))
        .arg("--partition=test")
        .current_dir(&dir)
        .env("PATH", path_with_mpm(&bin))
        .env("SHARDS", "3")
        .env("STUDY_DIR", "slurm_study")
        .env("STUDY_OPTIONS", "--quick")
        .output()
        .unwrap();
    let said = text(&ok(submit));
    assert!(said.contains("shards: job 1001 (1-3); merge: job 1002"), "{said}");
    ok(mpm(&["study", "--quick", "-o", "single", "-q"], &dir));
    assert_same_study(&dir.join("slurm_study"), &dir.join("single"));
    std::fs::remove_dir_all(&dir).unwrap();
}
