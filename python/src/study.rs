//! The study split across processes (`sparse_mpm.study`): plan, run a share, merge.

use std::path::PathBuf;

use pyo3::prelude::*;
use sparse_mpm_study::{merge_study, plan_study, read_plan, run_share, Part, Share, StudySpec};

use crate::{mpm_err, mpm_msg};

/// Plans a study into `out` (`mpm study plan`): the spec from TOML text, else the quick or the
/// full default, restricted to `parts`; returns the number of runs.
#[pyfunction]
#[pyo3(signature = (out, spec_toml = None, quick = false, parts = None))]
pub(crate) fn study_plan(
    py: Python<'_>,
    out: PathBuf,
    spec_toml: Option<&str>,
    quick: bool,
    parts: Option<Vec<String>>,
) -> PyResult<usize> {
    let mut spec = match spec_toml {
        Some(text) if text.len() as u64 > sparse_mpm::scene::MAX_SCENE_BYTES => {
            return Err(mpm_msg("the study spec text is larger than 16 MiB"));
        }
        Some(text) => StudySpec::from_toml_str(text).map_err(mpm_err)?,
        None if quick => StudySpec::quick(),
        None => StudySpec::default(),
    };
    if let Some(names) = parts {
        spec.parts = names
            .iter()
            .map(|name| {
                Part::ALL.into_iter().find(|p| p.name() == name.trim()).ok_or_else(|| {
                    let all: Vec<&str> = Part::ALL.iter().map(|p| p.name()).collect();
                    mpm_msg(format!("parts: unknown part `{name}` (parts: {})", all.join(", ")))
                })
            })
            .collect::<PyResult<_>>()?;
    }
    let plan = py.detach(|| plan_study(&spec, &out)).map_err(mpm_err)?;
    Ok(plan.runs.len())
}

/// Runs shard `k` of `n` (1-based) of the plan in `dir`, or the one run of plan `index`
/// (`mpm study run`); returns `(taken, ran, skipped, failed)`. Runs without the GIL.
#[pyfunction]
#[pyo3(signature = (dir, k = None, n = None, index = None))]
pub(crate) fn study_run(
    py: Python<'_>,
    dir: PathBuf,
    k: Option<usize>,
    n: Option<usize>,
    index: Option<usize>,
) -> PyResult<(usize, usize, usize, usize)> {
    let share = match (k, n, index) {
        (Some(k), Some(n), None) if (1..=n).contains(&k) => Share::Shard { k, n },
        (Some(k), Some(n), None) => {
            return Err(mpm_msg(format!("k = {k}, n = {n}: give 1 <= k <= n (shard k of n)")));
        }
        (None, None, Some(i)) => Share::Index(i),
        (None, None, None) => Share::All,
        _ => return Err(mpm_msg("give k and n (shard k of n), or index, or neither (every run)")),
    };
    // Run by run, so that Ctrl-C (checked between runs) stops a shard within one run.
    let plan = py.detach(|| read_plan(&dir)).map_err(mpm_err)?;
    let indices: Vec<usize> = match share {
        Share::All => (0..plan.runs.len()).collect(),
        Share::Shard { k, n } => (0..plan.runs.len()).filter(|i| i % n == k - 1).collect(),
        Share::Index(i) => vec![i],
    };
    let mut total = (0, 0, 0, 0);
    for i in indices {
        let s = py
            .detach(|| run_share(&dir, Share::Index(i), |_| {}))
            .map_err(mpm_err)?;
        total = (
            total.0 + s.taken,
            total.1 + s.ran,
            total.2 + s.skipped,
            total.3 + s.failed,
        );
        py.check_signals()?;
    }
    Ok(total)
}

/// Merges the complete runs of the plan in `dir` (`mpm study merge`); returns
/// `(runs merged, runs failed, plan indices missing)`.
#[pyfunction]
pub(crate) fn study_merge(py: Python<'_>, dir: PathBuf) -> PyResult<(usize, usize, Vec<usize>)> {
    let m = py.detach(|| merge_study(&dir)).map_err(mpm_err)?;
    let failed = m.study.runs.iter().filter(|r| r.outcome.is_err()).count();
    Ok((m.study.runs.len(), failed, m.missing.iter().map(|r| r.index).collect()))
}
