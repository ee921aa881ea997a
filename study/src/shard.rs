//! A study split across processes and machines: plan, run shares, merge.
//!
//! ```text
//! mpm study plan --quick --out DIR          DIR/plan.json, DIR/plan.csv: every run, not run
//! mpm study run DIR --shard K/N             runs K, K + N, K + 2N, … (1-based K) not yet complete
//! mpm study merge DIR                       DIR/runs.csv, plots, DIR/report.md from the runs
//! ```
//!
//! A plan lists the runs of a [`StudySpec`] in report order, each with an id: the first 16
//! hexadecimal digits of the SHA-256 of its canonical parameters (crate version, part, problem,
//! cells, choices as JSON). A run writes its own folder `DIR/runs/ID/`: `params.json` (what it
//! runs), `result.json` (what it measured, or its error; the floats bit for bit) and `complete`
//! (the completion marker, written last). A share skips the runs already complete, so a
//! re-submitted or interrupted job finishes only what is missing, and any number of shares may
//! run at once on machines that see the same folder. The merge reads the complete runs in plan
//! order and writes the same `runs.csv`, plots and report as a study run in one process, listing
//! the runs missing; it refuses runs of another crate version or another plan.
//!
//! Wall-clock columns of `runs.csv` (`wall_seconds`, `wall_per_step_seconds`) are the only ones
//! that differ between two executions of one plan.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::{Part, Planned, Problem, StudyProgress, StudyRun, StudySpec, StudySummary};
use crate::verification::{Choices, History, Outcome};
use sparse_mpm::error::{MpmError, Result};

/// The version of the crate that plans, runs and merges; a plan is run and merged only by it.
const VERSION: &str = env!("CARGO_PKG_VERSION");

const PLAN_FORMAT: &str = "sparse-mpm study plan 1";
const RESULT_FORMAT: &str = "sparse-mpm study run 1";

/// Largest plan or result file read.
const MAX_RECORD_BYTES: u64 = 256 << 20;

/// Which runs of a plan one process takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Share {
    /// Every run.
    All,
    /// Shard `k` of `n` (1 ≤ k ≤ n): the runs whose 0-based plan index `i` has `i mod n = k − 1`.
    Shard {
        /// This shard, from 1.
        k: usize,
        /// Shards in all.
        n: usize,
    },
    /// The one run of 0-based plan index `i`.
    Index(usize),
}

impl Share {
    /// `"K/N"` as [`Share::Shard`].
    ///
    /// # Errors
    /// [`MpmError::InvalidOption`] (`--shard`) unless `1 ≤ K ≤ N`, both whole numbers.
    pub fn parse_shard(text: &str) -> Result<Share> {
        let bad = || MpmError::InvalidOption {
            option: "--shard",
            reason: format!("`{text}`: give K/N with whole numbers 1 ≤ K ≤ N (shard K of N)"),
        };
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (k, n): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if k == 0 || k > n {
            return Err(bad());
        }
        Ok(Share::Shard { k, n })
    }

    fn takes(&self, index: usize) -> bool {
        match *self {
            Share::All => true,
            Share::Shard { k, n } => index % n == k - 1,
            Share::Index(i) => index == i,
        }
    }
}

/// One run of a plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlannedRun {
    /// Position in the plan (report order), from 0.
    pub index: usize,
    /// The run's id (16 hexadecimal digits).
    pub id: String,
    /// The part it belongs to.
    pub part: Part,
    /// The problem it runs.
    problem: Problem,
    /// Cells.
    pub cells: usize,
    /// Its choices.
    pub choices: Choices,
}

impl PlannedRun {
    fn planned(&self) -> Planned {
        Planned {
            part: self.part,
            problem: self.problem,
            choices: self.choices,
            cells: self.cells,
        }
    }

    /// A line for progress displays and reports.
    pub fn describe(&self) -> String {
        self.planned().describe()
    }
}

/// A study's plan (`plan.json`): the spec, the crate version and every run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyPlan {
    format: String,
    /// The crate version that planned it.
    pub version: String,
    /// SHA-256 of the canonical spec (JSON), hexadecimal.
    pub spec_digest: String,
    /// The spec.
    pub spec: StudySpec,
    /// The runs, in report order.
    pub runs: Vec<PlannedRun>,
}

/// The id of a run: the first 16 hexadecimal digits of `SHA-256(version ‖ canonical JSON)`.
fn run_id(planned: &Planned) -> String {
    let canonical = serde_json::json!({
        "version": VERSION,
        "part": planned.part,
        "problem": planned.problem,
        "cells": planned.cells,
        "choices": planned.choices,
    });
    hex(&Sha256::digest(canonical.to_string().as_bytes()))[..16].to_string()
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn spec_digest(spec: &StudySpec) -> String {
    let json = serde_json::to_string(spec).expect("a spec always serializes");
    hex(&Sha256::digest(json.as_bytes()))
}

impl StudyPlan {
    /// The plan of `spec` (validated).
    ///
    /// # Errors
    /// The errors of the spec's validation.
    pub fn of(spec: &StudySpec) -> Result<StudyPlan> {
        spec.validate()?;
        let runs = spec
            .plan()
            .into_iter()
            .enumerate()
            .map(|(index, p)| PlannedRun {
                index,
                id: run_id(&p),
                part: p.part,
                problem: p.problem,
                cells: p.cells,
                choices: p.choices,
            })
            .collect::<Vec<PlannedRun>>();
        let mut seen = std::collections::HashMap::new();
        for r in &runs {
            if let Some(first) = seen.insert(r.id.as_str(), r) {
                return Err(MpmError::InvalidScene {
                    key: "study".into(),
                    reason: format!(
                        "runs {} and {} are the same run ({}): a key of the spec lists a value twice",
                        first.index,
                        r.index,
                        r.describe()
                    ),
                });
            }
        }
        Ok(StudyPlan {
            format: PLAN_FORMAT.into(),
            version: VERSION.into(),
            spec_digest: spec_digest(spec),
            spec: spec.clone(),
            runs,
        })
    }
}

fn io_error(path: &Path) -> impl Fn(std::io::Error) -> MpmError + '_ {
    move |source| MpmError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let json = serde_json::to_string_pretty(value).expect("study records always serialize");
    sparse_mpm::io::write_atomically(path, |w| std::io::Write::write_all(w, json.as_bytes()))
}

fn study_error(path: &Path, reason: String) -> MpmError {
    sparse_mpm::io::invalid_data(path, reason)
}

/// Writes the plan of `spec` into `dir` (created if needed): `plan.json` and `plan.csv` (one
/// row per run: index, id, part, problem, label, cells). Planning again with the same spec
/// and version leaves the folder as it is (runs already complete stay complete).
///
/// # Errors
/// The errors of [`StudyPlan::of`]; [`MpmError::Io`] naming `plan.json` when `dir` holds the
/// plan of another spec or crate version, or a file cannot be written.
pub fn plan_study(spec: &StudySpec, dir: &Path) -> Result<StudyPlan> {
    let plan = StudyPlan::of(spec)?;
    std::fs::create_dir_all(dir).map_err(io_error(dir))?;
    let path = dir.join("plan.json");
    if std::fs::symlink_metadata(&path).is_ok() {
        let existing = read_plan(dir)?;
        if existing.spec_digest != plan.spec_digest {
            return Err(study_error(
                &path,
                "the folder holds the plan of another spec: plan it in another folder, or remove the folder".into(),
            ));
        }
        if !dir.join("plan.csv").is_file() {
            write_plan_csv(&existing, dir)?;
        }
        return Ok(existing);
    }
    write_plan_csv(&plan, dir)?;
    write_json(&path, &plan)?;
    Ok(plan)
}

/// `plan.csv`: a row per run of `plan` (index, id, part, problem, label, cells).
fn write_plan_csv(plan: &StudyPlan, dir: &Path) -> Result<()> {
    let mut csv = String::from("index,id,part,problem,label,cells\n");
    for r in &plan.runs {
        csv.push_str(&format!(
            "{},{},{},{:?},\"{}\",{}\n",
            r.index,
            r.id,
            r.part.name(),
            r.problem,
            r.choices.label().replace('"', "\"\""),
            r.cells
        ));
    }
    sparse_mpm::io::write_atomically(&dir.join("plan.csv"), |w| std::io::Write::write_all(w, csv.as_bytes()))
}

/// The crate version that planned `dir/plan.json` when it is a study plan of any version,
/// `None` when there is no such file or it is not a study plan.
pub(super) fn plan_version(dir: &Path) -> Option<String> {
    let text = sparse_mpm::io::read_bounded_text(&dir.join("plan.json"), MAX_RECORD_BYTES, "study plan").ok()?;
    let value: serde_json::Value = serde_json::from_str(&text).ok()?;
    (value.get("format")?.as_str()? == PLAN_FORMAT)
        .then(|| value.get("version")?.as_str().map(str::to_string))
        .flatten()
}

/// Whether `name` is a file a run writes into its folder `runs/ID/` (or a temporary file of
/// one's interrupted write).
pub(super) fn is_run_file(name: &str) -> bool {
    const FILES: [&str; 3] = ["params.json", "result.json", "complete"];
    FILES.contains(&name) || sparse_mpm::io::temporary_of(name).is_some_and(|of| FILES.contains(&of))
}

/// Whether `name` is a run id (16 lower-case hexadecimal digits).
pub(super) fn is_run_id(name: &str) -> bool {
    name.len() == 16 && name.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

/// The crate version that plans, runs and merges.
pub(super) fn version() -> &'static str {
    VERSION
}

/// Reads `dir/plan.json`, checking that this crate version planned it and that its runs are
/// the spec's.
///
/// # Errors
/// [`MpmError::Io`] naming `plan.json` when it cannot be read, is not a plan, was written by
/// another crate version, or does not hold together (ids or runs not those of its spec).
pub fn read_plan(dir: &Path) -> Result<StudyPlan> {
    let path = dir.join("plan.json");
    let text = sparse_mpm::io::read_bounded_text(&path, MAX_RECORD_BYTES, "study plan")?;
    let plan: StudyPlan =
        serde_json::from_str(&text).map_err(|e| study_error(&path, format!("not a study plan: {e}")))?;
    if plan.format != PLAN_FORMAT {
        return Err(study_error(
            &path,
            format!("its format is `{}`; this version reads `{PLAN_FORMAT}`", plan.format),
        ));
    }
    if plan.version != VERSION {
        return Err(study_error(
            &path,
            format!(
                "planned by sparse-mpm {}, and this is {VERSION}: runs of different versions are not mixed; plan \
                 again with this version in a new folder",
                plan.version
            ),
        ));
    }
    let expected = StudyPlan::of(&plan.spec).map_err(|e| study_error(&path, format!("its spec: {e}")))?;
    if expected != plan {
        return Err(study_error(
            &path,
            "its runs or digests are not those of its spec (the file was edited)".into(),
        ));
    }
    Ok(plan)
}

/// A float as JSON: a number when finite, else `"NaN"`, `"inf"` or `"-inf"` (JSON has no
/// non-finite numbers).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Float(f64);

impl Serialize for Float {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        if self.0.is_finite() {
            s.serialize_f64(self.0)
        } else {
            s.serialize_str(&self.0.to_string())
        }
    }
}

impl<'de> Deserialize<'de> for Float {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Either {
            Number(f64),
            Text(String),
        }
        match Either::deserialize(d)? {
            Either::Number(v) => Ok(Float(v)),
            Either::Text(t) => match t.as_str() {
                "NaN" => Ok(Float(f64::NAN)),
                "inf" => Ok(Float(f64::INFINITY)),
                "-inf" => Ok(Float(f64::NEG_INFINITY)),
                other => Err(serde::de::Error::custom(format!("`{other}` is not a number"))),
            },
        }
    }
}

/// [`Outcome`] as stored in `result.json`.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct OutcomeRecord {
    problem: String,
    cells: usize,
    cell_size: Float,
    metrics: Vec<(String, Float)>,
    histories: Vec<(String, Vec<Float>, Vec<Float>)>,
    steps: usize,
    wall_seconds: Float,
}

impl OutcomeRecord {
    fn of(o: &Outcome) -> Self {
        let floats = |v: &[f64]| v.iter().map(|&x| Float(x)).collect();
        OutcomeRecord {
            problem: o.problem.clone(),
            cells: o.cells,
            cell_size: Float(o.cell_size),
            metrics: o.metrics.iter().map(|(n, v)| (n.clone(), Float(*v))).collect(),
            histories: o
                .histories
                .iter()
                .map(|h| (h.name.clone(), floats(&h.time), floats(&h.value)))
                .collect(),
            steps: o.steps,
            wall_seconds: Float(o.seconds),
        }
    }

    fn into_outcome(self) -> Outcome {
        let values = |v: Vec<Float>| v.into_iter().map(|x| x.0).collect();
        Outcome {
            problem: self.problem,
            cells: self.cells,
            cell_size: self.cell_size.0,
            metrics: self.metrics.into_iter().map(|(n, v)| (n, v.0)).collect(),
            histories: self
                .histories
                .into_iter()
                .map(|(name, time, value)| History {
                    name,
                    time: values(time),
                    value: values(value),
                })
                .collect(),
            steps: self.steps,
            seconds: self.wall_seconds.0,
        }
    }
}

/// `runs/ID/result.json`.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RunRecord {
    format: String,
    version: String,
    spec_digest: String,
    run: PlannedRun,
    outcome: std::result::Result<OutcomeRecord, String>,
}

/// The folder of run `id`.
fn run_dir(dir: &Path, id: &str) -> PathBuf {
    dir.join("runs").join(id)
}

/// What one share did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ShareSummary {
    /// Runs taken by the share.
    pub taken: usize,
    /// Of them, run now.
    pub ran: usize,
    /// Of them, complete before (skipped).
    pub skipped: usize,
    /// Of those run now, failed (recorded with their error).
    pub failed: usize,
}

/// Runs the share `share` of the plan in `dir`, skipping runs already complete; each run
/// writes `runs/ID/params.json`, `result.json` and, last, `complete`. A run that fails is
/// complete too, with its error (the merge lists it).
///
/// # Errors
/// The errors of [`read_plan`]; [`MpmError::InvalidOption`] for an index beyond the plan;
/// [`MpmError::Io`] when a run's files cannot be written.
pub fn run_share(dir: &Path, share: Share, mut progress: impl FnMut(&StudyProgress)) -> Result<ShareSummary> {
    let plan = read_plan(dir)?;
    if let Share::Index(i) = share {
        if i >= plan.runs.len() {
            return Err(MpmError::InvalidOption {
                option: "--index",
                reason: match plan.runs.len() {
                    0 => format!("{i}: the plan has no runs"),
                    len => format!("{i}: the plan has runs 0 to {}", len - 1),
                },
            });
        }
    }
    let taken: Vec<&PlannedRun> = plan.runs.iter().filter(|r| share.takes(r.index)).collect();
    let mut summary = ShareSummary {
        taken: taken.len(),
        ..ShareSummary::default()
    };
    for (k, run) in taken.iter().enumerate() {
        progress(&StudyProgress {
            done: k,
            total: taken.len(),
            current: run.describe(),
        });
        if read_result(dir, &plan, run)?.is_some() {
            summary.skipped += 1;
            continue;
        }
        let folder = run_dir(dir, &run.id);
        std::fs::create_dir_all(&folder).map_err(io_error(&folder))?;
        // A marker left beside a result that is missing or not whole: the run is done again.
        let marker = folder.join("complete");
        match std::fs::remove_file(&marker) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io_error(&marker)(e)),
            _ => {}
        }
        write_json(&folder.join("params.json"), run)?;
        let outcome = run.planned().run().map_err(|e| e.to_string());
        summary.failed += usize::from(outcome.is_err());
        let record = RunRecord {
            format: RESULT_FORMAT.into(),
            version: VERSION.into(),
            spec_digest: plan.spec_digest.clone(),
            run: (*run).clone(),
            outcome: outcome.as_ref().map(OutcomeRecord::of).map_err(Clone::clone),
        };
        write_json(&folder.join("result.json"), &record)?;
        sparse_mpm::io::write_atomically(&folder.join("complete"), |w| {
            std::io::Write::write_all(w, b"complete\n")
        })?;
        summary.ran += 1;
    }
    progress(&StudyProgress {
        done: taken.len(),
        total: taken.len(),
        current: String::new(),
    });
    Ok(summary)
}

/// The outcome of `run` when it is complete in `dir`, `None` when it is not: no completion
/// marker, or a marker beside a result that is missing or not a whole result (a damaged run is
/// run again).
///
/// # Errors
/// [`MpmError::Io`] naming the result file when it is a result of another crate version, plan
/// or run (runs of different studies are not mixed), or cannot be read.
fn read_result(dir: &Path, plan: &StudyPlan, run: &PlannedRun) -> Result<Option<std::result::Result<Outcome, String>>> {
    let folder = run_dir(dir, &run.id);
    if !folder.join("complete").is_file() {
        return Ok(None);
    }
    let path = folder.join("result.json");
    if !path.is_file() {
        return Ok(None);
    }
    let text = match sparse_mpm::io::read_bounded_text(&path, MAX_RECORD_BYTES, "study run") {
        Ok(text) => text,
        Err(MpmError::Io { source, .. }) if source.kind() == std::io::ErrorKind::InvalidData => return Ok(None),
        Err(e) => return Err(e),
    };
    let Ok(record) = serde_json::from_str::<RunRecord>(&text) else {
        return Ok(None);
    };
    if record.format != RESULT_FORMAT {
        return Ok(None);
    }
    if record.version != plan.version {
        return Err(study_error(
            &path,
            format!(
                "run by sparse-mpm {}, the plan by {}: runs of different versions are not mixed (remove runs/{} to run \
                 it again)",
                record.version, plan.version, run.id
            ),
        ));
    }
    if record.spec_digest != plan.spec_digest || record.run != *run {
        return Err(study_error(
            &path,
            format!(
                "a run of another plan or spec: runs of different studies are not mixed (remove runs/{} to run it \
                 again)",
                run.id
            ),
        ));
    }
    Ok(Some(record.outcome.map(OutcomeRecord::into_outcome)))
}

/// What a merge found.
#[derive(Debug, Clone)]
pub struct MergeSummary {
    /// The report, plots and runs written.
    pub study: StudySummary,
    /// The runs not complete (not run yet, or interrupted), in plan order.
    pub missing: Vec<PlannedRun>,
}

/// Gathers the complete runs of the plan in `dir`, in plan order, and writes `runs.csv`, the
/// plots and `report.md` as a study run in one process does, listing the runs missing.
///
/// # Errors
/// The errors of [`read_plan`]; [`MpmError::Io`] naming a result of another crate version or
/// plan (nothing is mixed), or a file that cannot be written.
pub fn merge_study(dir: &Path) -> Result<MergeSummary> {
    let plan = read_plan(dir)?;
    let mut runs = Vec::with_capacity(plan.runs.len());
    let mut missing = Vec::new();
    for run in &plan.runs {
        match read_result(dir, &plan, run)? {
            Some(outcome) => runs.push(StudyRun {
                part: run.part,
                choices: run.choices,
                cells: run.cells,
                outcome,
            }),
            None => missing.push(run.clone()),
        }
    }
    let missing_lines: Vec<String> = missing
        .iter()
        .map(|r| format!("{} (runs/{}): {}", r.index, r.id, r.describe()))
        .collect();
    let study = super::write_study(&plan.spec, runs, &missing_lines, dir)?;
    Ok(MergeSummary { study, missing })
}
