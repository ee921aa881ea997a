//! The whole study in one process, and the files a study writes from its runs.

use std::fmt::Write as _;
use std::path::Path;

use super::report::section;
use super::runs_csv::write_runs_csv;
use super::{
    merge_study, plan_study, read_plan, run_share, Share, StudyPlan, StudyProgress, StudyRun, StudySpec, StudySummary,
};
use crate::error::{MpmError, Result};

/// Runs `spec`, writing `runs.csv`, the PNG plots and `report.md` into `out` (created if
/// needed): the plan ([`plan_study`]), every run ([`run_share`] with [`Share::All`]) and the
/// merge ([`merge_study`]) in one process. A run that fails (for example a singular consistent
/// mass with one particle per cell) is recorded with its error and left out of the plots; the
/// study goes on. Runs already complete in `out` from the same plan are not run again; the
/// plan and runs of another spec or crate version there are replaced.
///
/// # Errors
/// [`MpmError::Io`] when the folder or a file cannot be written; [`MpmError::InvalidScene`]
/// for an invalid spec.
pub fn run_study(spec: &StudySpec, out: &Path, progress: impl FnMut(&StudyProgress)) -> Result<StudySummary> {
    let fresh = StudyPlan::of(spec)?;
    if out.join("plan.json").exists() && read_plan(out).map_or(true, |p| p.spec_digest != fresh.spec_digest) {
        for name in ["plan.json", "plan.csv"] {
            let path = out.join(name);
            std::fs::remove_file(&path)
                .or_else(ignore_missing)
                .map_err(|source| MpmError::Io { path, source })?;
        }
        let runs = out.join("runs");
        std::fs::remove_dir_all(&runs)
            .or_else(ignore_missing)
            .map_err(|source| MpmError::Io { path: runs, source })?;
    }
    plan_study(spec, out)?;
    run_share(out, Share::All, progress)?;
    Ok(merge_study(out)?.study)
}

fn ignore_missing(e: std::io::Error) -> std::io::Result<()> {
    if e.kind() == std::io::ErrorKind::NotFound {
        Ok(())
    } else {
        Err(e)
    }
}

/// Writes `runs.csv`, the plots and `report.md` of `runs` (in plan order) into `out`, listing
/// the runs that failed and those `missing` (described).
pub(super) fn write_study(
    spec: &StudySpec,
    runs: Vec<StudyRun>,
    missing: &[String],
    out: &Path,
) -> Result<StudySummary> {
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
    let report_path = out.join("report.md");
    std::fs::write(&report_path, report).map_err(|source| MpmError::Io {
        path: report_path.clone(),
        source,
    })?;
    Ok(StudySummary {
        runs,
        report: report_path,
        csv,
        plots,
    })
}
