//! The whole study in one process, and the files a study writes from its runs.

use std::fmt::Write as _;
use std::path::Path;

use super::report::section;
use super::runs_csv::write_runs_csv;
use super::{
    merge_study, plan_study, read_plan, run_share, shard, Share, StudyPlan, StudyProgress, StudyRun, StudySpec,
    StudySummary,
};
use sparse_mpm::error::{MpmError, Result};

/// Runs `spec`, writing `runs.csv`, the PNG plots and `report.md` into `out` (created if
/// needed): the plan ([`plan_study`]), every run ([`run_share`] with [`Share::All`]) and the
/// merge ([`merge_study`]) in one process. A run that fails (for example a singular consistent
/// mass with one particle per cell) is recorded with its error and left out of the plots; the
/// study goes on. Runs already complete in `out` from the same plan are not run again. The plan
/// and runs of another spec or crate version there are replaced: only the files a study writes
/// are removed, and nothing at all when `runs/` holds anything else.
///
/// # Errors
/// [`MpmError::Io`] when the folder or a file cannot be written, when `out/plan.json` is not a
/// study plan (damaged, edited, or another program's), or when `out/runs/` holds files a study
/// does not write; [`MpmError::InvalidScene`] for an invalid spec.
pub fn run_study(spec: &StudySpec, out: &Path, progress: impl FnMut(&StudyProgress)) -> Result<StudySummary> {
    let fresh = StudyPlan::of(spec)?;
    if std::fs::symlink_metadata(out.join("plan.json")).is_ok() {
        match read_plan(out) {
            Ok(plan) if plan.spec_digest == fresh.spec_digest => {}
            Ok(_) => remove_previous_study(out)?,
            Err(_) if shard::plan_version(out).is_some_and(|v| v != shard::version()) => remove_previous_study(out)?,
            Err(e) => {
                let reason = match e {
                    MpmError::Io { source, .. } => source.to_string(),
                    other => other.to_string(),
                };
                return Err(sparse_mpm::io::invalid_data(
                    &out.join("plan.json"),
                    format!("{reason}; nothing was removed: give another --out, or remove the folder"),
                ));
            }
        }
    }
    plan_study(spec, out)?;
    run_share(out, Share::All, progress)?;
    Ok(merge_study(out)?.study)
}

/// Removes the plan and the runs of the study in `out` (another spec's or crate version's):
/// `plan.json`, `plan.csv` and `runs/ID/` with the files a run writes. Anything else in `runs/`
/// is an error naming it, and then nothing is removed. The report, `runs.csv` and the plots
/// stay until the merge replaces them.
fn remove_previous_study(out: &Path) -> Result<()> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| MpmError::Io { path, source }
    };
    let list = |dir: &Path| -> Result<Vec<String>> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .map_err(io(dir))?
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        Ok(names)
    };
    let runs = out.join("runs");
    let mut files = Vec::new();
    let mut folders = Vec::new();
    if std::fs::symlink_metadata(&runs).is_ok_and(|m| m.is_dir()) {
        let mut foreign = Vec::new();
        for id in list(&runs)? {
            let folder = runs.join(&id);
            let is_folder = std::fs::symlink_metadata(&folder).is_ok_and(|m| m.is_dir());
            if !(shard::is_run_id(&id) && is_folder) {
                foreign.push(format!("runs/{id}"));
                continue;
            }
            for name in list(&folder)? {
                if shard::is_run_file(&name) && folder.join(&name).is_file() {
                    files.push(folder.join(&name));
                } else {
                    foreign.push(format!("runs/{id}/{name}"));
                }
            }
            folders.push(folder);
        }
        if !foreign.is_empty() {
            return Err(sparse_mpm::io::invalid_data(
                &runs,
                format!(
                    "the study folder's runs/ holds {} that a study does not write ({}): nothing was removed; move them, or give another --out",
                    if foreign.len() == 1 { "a file" } else { "files" },
                    foreign.iter().take(5).cloned().collect::<Vec<_>>().join(", ")
                ),
            ));
        }
        folders.push(runs);
    }
    for path in files {
        std::fs::remove_file(&path).or_else(ignore_missing).map_err(io(&path))?;
    }
    for path in folders {
        std::fs::remove_dir(&path).or_else(ignore_missing).map_err(io(&path))?;
    }
    for name in ["plan.json", "plan.csv"] {
        let path = out.join(name);
        std::fs::remove_file(&path).or_else(ignore_missing).map_err(io(&path))?;
    }
    Ok(())
}

fn ignore_missing(e: std::io::Error) -> std::io::Result<()> {
    if e.kind() == std::io::ErrorKind::NotFound {
        Ok(())
    } else {
        Err(e)
    }
}

/// The list of the plots a merge drew, beside its report: the next merge removes those it does
/// not draw again, and nothing else.
const PLOTS_FILE: &str = "plots.json";

/// The plots the last merge in `out` drew (`plots.json`; plain `NAME.png` names only).
fn plots_drawn_before(out: &Path) -> Vec<String> {
    let Ok(text) = sparse_mpm::io::read_bounded_text(&out.join(PLOTS_FILE), 1 << 20, "study plot list") else {
        return Vec::new();
    };
    serde_json::from_str::<Vec<String>>(&text)
        .unwrap_or_default()
        .into_iter()
        .filter(|name| name.ends_with(".png") && !name.contains(['/', '\\']) && !name.starts_with('.'))
        .collect()
}

/// Writes `runs.csv`, the plots and `report.md` of `runs` (in plan order) into `out`, listing
/// the runs that failed and those `missing` (described).
pub(super) fn write_study(
    spec: &StudySpec,
    runs: Vec<StudyRun>,
    missing: &[String],
    out: &Path,
) -> Result<StudySummary> {
    // The old report goes first, the new one is written last: a merge that fails or is
    // stopped half-way leaves no report beside runs.csv and plots it does not describe.
    let old_plots = plots_drawn_before(out);
    let report_path = out.join("report.md");
    std::fs::remove_file(&report_path)
        .or_else(ignore_missing)
        .map_err(|source| MpmError::Io {
            path: report_path.clone(),
            source,
        })?;
    let csv = out.join("runs.csv");
    write_runs_csv(&runs, &csv)?;
    let mut plots = Vec::new();
    let mut report = String::new();
    writeln!(report, "# Consistent against lumped mass: a study\n").ok();
    writeln!(
        report,
        "Written by `mpm study`. Every run is a row of [`runs.csv`](runs.csv); the problems, references \
         and tolerances are in docs/verification.md. Courant number {} of each scheme's stable step, {} \
         update unless a part says otherwise; runs that failed are listed at the end.\n",
        spec.cfl,
        format!("{:?}", spec.update).to_uppercase()
    )
    .ok();
    for &part in &spec.parts {
        let of_part: Vec<&StudyRun> = runs.iter().filter(|r| r.part == part).collect();
        section(part, &of_part, out, &mut report, &mut plots)?;
    }
    let failures: Vec<&StudyRun> = runs.iter().filter(|r| r.outcome.is_err()).collect();
    if !failures.is_empty() {
        writeln!(report, "## Runs that failed\n").ok();
        for r in failures {
            writeln!(
                report,
                "- {} / {} / {} cells: {}",
                r.part.name(),
                r.choices.label(),
                r.cells,
                r.outcome.as_ref().err().map_or("", |e| e.as_str())
            )
            .ok();
        }
    }
    if !missing.is_empty() {
        writeln!(
            report,
            "## Runs missing\n\n{} of the plan's runs are not complete (not run yet, or interrupted); \
             `mpm study run` runs them:\n",
            missing.len()
        )
        .ok();
        for m in missing {
            writeln!(report, "- {m}").ok();
        }
    }
    let names: Vec<String> = plots
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    let list = serde_json::to_string_pretty(&names).expect("names always serialize");
    sparse_mpm::io::write_atomically(&out.join(PLOTS_FILE), |w| std::io::Write::write_all(w, list.as_bytes()))?;
    // Plots the last merge drew that this one does not (another spec's parts).
    for name in old_plots {
        let path = out.join(&name);
        if !plots.iter().any(|p: &std::path::PathBuf| p == &path) {
            std::fs::remove_file(&path)
                .or_else(ignore_missing)
                .map_err(|source| MpmError::Io { path, source })?;
        }
    }
    sparse_mpm::io::write_atomically(&report_path, |w| std::io::Write::write_all(w, report.as_bytes()))?;
    Ok(StudySummary {
        runs,
        report: report_path,
        csv,
        plots,
    })
}
