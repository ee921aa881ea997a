//! A study planned, run in shares (in any order, one interrupted and run again, through GNU
//! parallel, through a Slurm job array) and merged gives the runs.csv and report of the study
//! run in one process; runs of another version or plan are refused.

use std::path::Path;
use std::process::{Command, Stdio};

mod common;
use common::program::{mpm, ok, scratch, text, MPM};
use common::scratch::names;

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
    let scripts = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/slurm");
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

#[test]
fn a_study_replaces_only_what_a_study_wrote_and_refuses_a_folder_it_did_not_write() {
    let dir = scratch("study_shards", "replace");
    // A folder of the user's with a plan.json and runs/ of its own: refused, nothing removed.
    std::fs::create_dir_all(dir.join("proj/runs/2024-experiment")).unwrap();
    std::fs::write(dir.join("proj/plan.json"), "{\"project\": \"mine\"}").unwrap();
    std::fs::write(dir.join("proj/runs/2024-experiment/data.txt"), "irreplaceable").unwrap();
    let refused = mpm(
        &["study", "--quick", "--parts", "single_point", "-o", "proj", "-q"],
        &dir,
    );
    assert!(!refused.status.success(), "{}", text(&refused));
    assert!(
        text(&refused).contains("plan.json") && text(&refused).contains("nothing was removed"),
        "{}",
        text(&refused)
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("proj/runs/2024-experiment/data.txt")).unwrap(),
        "irreplaceable"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("proj/plan.json")).unwrap(),
        "{\"project\": \"mine\"}"
    );

    // A study of another spec is replaced, its plots with it.
    ok(mpm(
        &["study", "--quick", "--parts", "time_step", "-o", "s", "-q"],
        &dir,
    ));
    assert!(names(&dir.join("s")).contains(&"time_step.png".to_string()));
    std::fs::write(dir.join("s/notes.md"), "mine").unwrap();
    // A picture of the user's, linked from the report: not the study's, so it stays.
    std::fs::write(dir.join("s/setup.png"), "mine").unwrap();
    let mut linked = std::fs::read_to_string(dir.join("s/report.md")).unwrap();
    linked.push_str("\n![setup](setup.png)\n");
    std::fs::write(dir.join("s/report.md"), linked).unwrap();
    ok(mpm(
        &["study", "--quick", "--parts", "single_point", "-o", "s", "-q"],
        &dir,
    ));
    let left = names(&dir.join("s"));
    assert!(
        !left.iter().any(|n| n.ends_with(".png") && n != "setup.png"),
        "the replaced study's plots: {left:?}"
    );
    for kept in ["notes.md", "setup.png"] {
        assert!(left.contains(&kept.to_string()), "a file of the user's stays: {left:?}");
    }
    assert_eq!(
        names(&dir.join("s/runs")).len(),
        3,
        "the single-point part's three runs"
    );

    // A file of the user's in runs/: refused, naming it, nothing removed.
    std::fs::write(dir.join("s/runs/NOTES.txt"), "mine").unwrap();
    let before = names(&dir.join("s/runs"));
    let refused = mpm(&["study", "--quick", "--parts", "time_step", "-o", "s", "-q"], &dir);
    assert!(
        !refused.status.success() && text(&refused).contains("runs/NOTES.txt"),
        "{}",
        text(&refused)
    );
    assert_eq!(names(&dir.join("s/runs")), before);
    assert!(dir.join("s/plan.json").exists() && dir.join("s/report.md").exists());
    std::fs::remove_file(dir.join("s/runs/NOTES.txt")).unwrap();
    let before = names(&dir.join("s/runs"));

    // A damaged plan of a finished study: refused, the runs kept.
    let plan = std::fs::read_to_string(dir.join("s/plan.json")).unwrap();
    std::fs::write(dir.join("s/plan.json"), &plan[..100]).unwrap();
    let refused = mpm(&["study", "--quick", "--parts", "single_point", "-o", "s", "-q"], &dir);
    assert!(
        !refused.status.success() && text(&refused).contains("plan.json"),
        "{}",
        text(&refused)
    );
    assert_eq!(names(&dir.join("s/runs")), before);
}

#[test]
fn a_value_listed_twice_in_a_spec_is_refused_naming_the_key() {
    let dir = scratch("study_shards", "twice");
    let twice = mpm(
        &[
            "study",
            "plan",
            "--quick",
            "--parts",
            "single_point,single_point",
            "-o",
            "p",
        ],
        &dir,
    );
    assert!(
        !twice.status.success() && text(&twice).contains("parts") && text(&twice).contains("twice"),
        "{}",
        text(&twice)
    );
    std::fs::write(
        dir.join("dup.toml"),
        "parts = [\"time_step\"]\nparticles_per_cell = [2, 2]\n",
    )
    .unwrap();
    let twice = mpm(&["study", "--spec", "dup.toml", "-o", "q"], &dir);
    assert!(
        !twice.status.success() && text(&twice).contains("particles_per_cell") && text(&twice).contains("twice"),
        "{}",
        text(&twice)
    );
    assert!(!dir.join("q/runs").exists(), "nothing run");
}

#[test]
fn a_damaged_run_is_run_again_and_a_merge_lists_every_missing_run() {
    let dir = scratch("study_shards", "damaged");
    ok(mpm(
        &["study", "plan", "--quick", "--parts", "time_step", "-o", "p", "-q"],
        &dir,
    ));
    ok(mpm(&["study", "run", "p", "--shard", "1/2", "-q"], &dir));
    // Runs of shard 2 are missing: exit 3, each named on stderr by its id.
    let plan = std::fs::read_to_string(dir.join("p/plan.csv")).unwrap();
    let ids: Vec<&str> = plan.lines().skip(1).map(|l| l.split(',').nth(1).unwrap()).collect();
    let merged = mpm(&["study", "merge", "p", "-q"], &dir);
    assert_eq!(merged.status.code(), Some(3), "{}", text(&merged));
    let stderr = String::from_utf8_lossy(&merged.stderr);
    for id in ids.iter().skip(1).step_by(2) {
        assert!(stderr.contains(id), "{id} missing from: {stderr}");
    }
    ok(mpm(&["study", "run", "p", "--shard", "2/2", "-q"], &dir));
    // A completion marker beside a result cut short, and one beside no result: both run again.
    let cut = dir.join("p/runs").join(ids[0]).join("result.json");
    let whole = std::fs::read_to_string(&cut).unwrap();
    std::fs::write(&cut, &whole[..whole.len() / 2]).unwrap();
    std::fs::remove_file(dir.join("p/runs").join(ids[1]).join("result.json")).unwrap();
    let again = ok(mpm(&["study", "run", "p", "--shard", "1/1"], &dir));
    assert!(text(&again).contains(": 2 run now"), "{}", text(&again));
    assert_eq!(std::fs::read_to_string(&cut).unwrap().len(), whole.len());
    ok(mpm(&["study", "merge", "p", "-q"], &dir));
    assert!(!std::fs::read_to_string(dir.join("p/report.md"))
        .unwrap()
        .contains("## Runs missing"));

    // A merge that cannot write runs.csv leaves no report describing other runs than those
    // beside it: the old report goes first, the new one comes last.
    std::fs::remove_file(dir.join("p/runs.csv")).unwrap();
    std::fs::create_dir(dir.join("p/runs.csv")).unwrap();
    let failed = mpm(&["study", "merge", "p", "-q"], &dir);
    assert!(
        !failed.status.success() && text(&failed).contains("runs.csv"),
        "{}",
        text(&failed)
    );
    assert!(!dir.join("p/report.md").exists(), "no stale report");
    std::fs::remove_dir(dir.join("p/runs.csv")).unwrap();
    ok(mpm(&["study", "merge", "p", "-q"], &dir));
    assert!(dir.join("p/report.md").exists());
}

#[test]
fn a_shard_or_index_that_cannot_be_exits_with_status_two() {
    let dir = scratch("study_shards", "usage");
    ok(mpm(
        &["study", "plan", "--quick", "--parts", "single_point", "-o", "p", "-q"],
        &dir,
    ));
    for shard in ["0/3", "4/3", "1/0", "a/b", "1/3/5"] {
        let o = mpm(&["study", "run", "p", "--shard", shard], &dir);
        assert_eq!(o.status.code(), Some(2), "--shard {shard}: {}", text(&o));
        assert!(text(&o).contains("K/N"), "{}", text(&o));
    }
    let o = mpm(&["study", "run", "p", "--index", "3"], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("runs 0 to 2"), "{}", text(&o));
    // plan.csv, removed, is written again by planning again.
    std::fs::remove_file(dir.join("p/plan.csv")).unwrap();
    ok(mpm(
        &["study", "plan", "--quick", "--parts", "single_point", "-o", "p", "-q"],
        &dir,
    ));
    assert_eq!(
        std::fs::read_to_string(dir.join("p/plan.csv")).unwrap().lines().count(),
        4
    );
}

#[test]
fn a_list_longer_than_a_study_takes_is_refused_before_it_is_compared_or_planned() {
    let dir = scratch("study_shards", "long_list");
    // 100,000 distinct blends: the check for a value listed twice compared every pair, and the
    // plan would list their product with the cell counts.
    let masses: Vec<String> = (1..=100_000)
        .map(|k| {
            format!(
                "{{ velocity = \"blended:{}\", acceleration = \"lumped\" }}",
                k as f64 / 100_001.0
            )
        })
        .collect();
    std::fs::write(
        dir.join("long.toml"),
        format!("parts = [\"frequency\"]\nmasses = [{}]\n", masses.join(", ")),
    )
    .unwrap();
    let o = mpm(&["study", "plan", "--spec", "long.toml", "-o", "p"], &dir);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("masses") && text(&o).contains("lists 100000 values, more than the 64"),
        "{}",
        text(&o)
    );
    assert!(!dir.join("p/plan.json").exists(), "nothing planned");
}
