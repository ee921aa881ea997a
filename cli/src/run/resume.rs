//! Continuing a run from a checkpoint folder, with the same checks and limits as a new run.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{
    copy, drive, OpenFolder, OutputClaim, OutputPolicy, Progress, RunOptions, RunState, RunSummary, RUN_STATE_FORMAT,
};
use crate::vtk::PvdWriter;
use sparse_mpm::error::{MpmError, Result};
use sparse_mpm::io::csv::CsvWriter;
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Simulation, StepReport};

/// Continues the run whose checkpoint folder is `checkpoint` (written by a run with
/// [`RunOptions::checkpoint_every`]) in `out` (default: the run folder the checkpoint lies
/// in). The report and snapshots of the run before the checkpoint are kept (copied when `out`
/// is another folder) and the rest written as the uninterrupted run would have: the resumed
/// run's `report.csv` and snapshots are bit-identical to an uninterrupted run's. Returns the
/// summary and the output folder.
///
/// # Errors
/// [`MpmError::Checkpoint`] for a checkpoint folder that is incomplete or of another format;
/// the errors of [`Simulation::read_checkpoint`] and of [`super::run_scene_with`]'s steps.
pub fn resume_run(
    checkpoint: &Path,
    out: Option<&Path>,
    options: &RunOptions,
    progress: impl FnMut(&Progress),
) -> Result<(RunSummary, PathBuf)> {
    let start = Instant::now();
    let bad = |reason: String| MpmError::Checkpoint {
        path: Some(checkpoint.to_path_buf()),
        reason,
    };
    // The checkpoint folder resolved once (`./`, `..`, symlinks, a name given from inside
    // `checkpoints/`): its run folder is the folder above `checkpoints/`, whatever the working
    // directory and spelling.
    let resolved = std::fs::canonicalize(checkpoint).map_err(|e| {
        bad(format!(
            "cannot find it ({e}): give the checkpoint folder `checkpoints/step_NNNNNNNN` a run wrote"
        ))
    })?;
    let checkpoint = resolved.as_path();
    let state_path = checkpoint.join("run.json");
    let text = sparse_mpm::io::read_bounded_text(&state_path, 64 << 20, "run.json").map_err(|e| {
        bad(format!(
            "cannot read {} ({e}): give the checkpoint folder `checkpoints/step_NNNNNNNN` a run wrote",
            state_path.display()
        ))
    })?;
    let mut state: RunState = serde_json::from_str(&text).map_err(|e| bad(format!("run.json: {e}")))?;
    if state.format != RUN_STATE_FORMAT {
        return Err(bad(format!(
            "{} is of the format `{}`; this version reads `{RUN_STATE_FORMAT}`",
            state_path.display(),
            state.format
        )));
    }
    state.validate().map_err(|reason| bad(format!("run.json: {reason}")))?;
    let ckpt = checkpoint.join("simulation.ckpt");
    let crc = super::identity::checkpoint_checksum(&ckpt)?;
    if crc != state.checkpoint_crc {
        return Err(bad(format!(
            "{} (checksum {crc:08x}) is not the file {} was written with (checksum {:08x}): the folder mixes \
             two checkpoints",
            ckpt.display(),
            state_path.display(),
            state.checkpoint_crc
        )));
    }
    let mut sim = Simulation::read_checkpoint(&ckpt)?;
    if let Some(threads) = options.threads {
        sim.set_threads(threads)?;
    }
    if sim.steps() != state.report_rows {
        return Err(bad(format!(
            "run.json says {} steps, the simulation {}",
            state.report_rows,
            sim.steps()
        )));
    }
    if let Some(end) = options.limits.end_time {
        state.end_time = end;
        state.validate().map_err(|reason| MpmError::InvalidOption {
            option: "end_time (--end-time)",
            reason,
        })?;
    }
    check_resume_limits(&state, &sim, options.allow_large, checkpoint)?;
    let run_dir = checkpoint
        .parent()
        .filter(|folder| folder.file_name().is_some_and(|name| name == "checkpoints"))
        .and_then(Path::parent)
        .ok_or_else(|| {
            bad(format!(
                "{} is not inside a run folder's `checkpoints/`",
                checkpoint.display()
            ))
        })?
        .to_path_buf();
    let digest = super::identity::scene_digest(&run_dir)?;
    if digest != state.scene_digest {
        return Err(bad(format!(
            "it was written by a run of another scene: its run.json records the scene digest {}…, and {} with its \
             particle files gives {}…; resume a checkpoint in the run folder that wrote it",
            &state.scene_digest[..16],
            run_dir.join("scene.toml").display(),
            &digest[..16]
        )));
    }
    // An output folder that exists is compared by what it is, not how it is spelt.
    let out = out.map_or(run_dir.clone(), |o| {
        std::fs::canonicalize(o).unwrap_or_else(|_| o.to_path_buf())
    });
    // The run folder is held while the resume reads or continues it (a run still writing
    // there is not taken up).
    let held = OutputClaim::claim(&run_dir, OutputPolicy::Continue)?;
    let (mut claim, _source) = if out != run_dir {
        (OutputClaim::claim(&out, OutputPolicy::RefuseNonEmpty)?, Some(held))
    } else {
        (held, None)
    };
    if out != run_dir {
        for name in ["report.csv", "scene.toml"] {
            claim.add(name)?;
            copy(&run_dir.join(name), &out.join(name))?;
        }
        // The particle files the scene copy names (plain names beside it), so that
        // NEW/scene.toml reruns the scene as RUN/scene.toml does.
        if let Ok(scene) = Scene::load(&run_dir.join("scene.toml")) {
            for body in &scene.bodies {
                if let sparse_mpm::scene::Geometry::File(file) = &body.geometry {
                    let plain = file.components().count() == 1
                        && matches!(file.components().next(), Some(std::path::Component::Normal(_)));
                    let name = file.to_string_lossy();
                    if plain && super::output::is_run_output(&name) && run_dir.join(file).is_file() {
                        claim.add(&name)?;
                        copy(&run_dir.join(file), &out.join(file))?;
                    }
                }
            }
        }
        for (_, file) in &state.snapshots {
            claim.add(&file.to_string_lossy())?;
            copy(&run_dir.join(file), &out.join(file))?;
        }
        claim.add("particles.pvd")?;
    } else {
        // Snapshots written after the checkpoint by the interrupted run are written again.
        let kept: std::collections::HashSet<&PathBuf> = state.snapshots.iter().map(|(_, f)| f).collect();
        let entries = std::fs::read_dir(&out).map_err(|source| MpmError::Io {
            path: out.clone(),
            source,
        })?;
        for entry in entries.filter_map(|e| e.ok()) {
            let name = PathBuf::from(entry.file_name());
            let text = name.to_string_lossy();
            let after = text.starts_with("particles_") && text.ends_with(".vtp") && !kept.contains(&name);
            // Only what the run wrote (its manifest lists it), and the atomic writer's `.NAME.PID-N-R.tmp`.
            let temporary =
                sparse_mpm::io::temporary_of(&text).is_some_and(|of| of == super::MANIFEST || claim.lists(of));
            if (after && claim.lists(&text)) || temporary {
                let path = out.join(&name);
                std::fs::remove_file(&path).map_err(|source| MpmError::Io { path, source })?;
                claim.forget(&text)?;
            }
        }
    }
    let pvd = PvdWriter::with_entries(&out.join("particles.pvd"), &state.snapshots)?;
    let csv = CsvWriter::append_after(&out.join("report.csv"), &StepReport::COLUMNS, state.report_rows)?;
    let folder = OpenFolder {
        out: &out,
        claim,
        pvd,
        csv,
    };
    let summary = drive(sim, state, folder, options, start, progress)?;
    Ok((summary, out))
}

/// The limits of a run ([`sparse_mpm::limits::Limits`]) on what is left of a resumed one: its
/// snapshots (those written and those to come), its steps at a fixed step, its output; the
/// same bounds as `mpm run` and `mpm check` apply to a scene.
fn check_resume_limits(state: &RunState, sim: &Simulation, allow_large: bool, checkpoint: &Path) -> Result<()> {
    let limits = if allow_large {
        sparse_mpm::limits::Limits::raised()
    } else {
        sparse_mpm::limits::Limits::default()
    };
    let left = (state.end_time - sim.time()).max(0.0);
    let snapshots = state.snapshots.len() as f64 + (left / state.snapshot_interval).ceil() + 1.0;
    let steps = match sim.options().time_step {
        sparse_mpm::simulation::TimeStep::Fixed { dt } => Some(left / dt),
        sparse_mpm::simulation::TimeStep::Cfl { .. } => None,
    };
    let output = snapshots * sparse_mpm::limits::SNAPSHOT_BYTES_PER_PARTICLE * sim.particles().len() as f64
        + steps.unwrap_or(0.0) * sparse_mpm::limits::REPORT_BYTES_PER_STEP;
    let over = |what: String| MpmError::Checkpoint {
        path: Some(checkpoint.to_path_buf()),
        reason: format!("{what}; raise the limits with --allow-large (docs/reliability.md)"),
    };
    if snapshots > limits.snapshots {
        return Err(over(format!(
            "a snapshot every {} to t = {} makes {snapshots:.3e} snapshots, more than the limit of {}",
            state.snapshot_interval, state.end_time, limits.snapshots
        )));
    }
    if let Some(steps) = steps.filter(|&s| s > limits.steps) {
        return Err(over(format!(
            "the fixed step to t = {} takes {steps:.3e} more steps, more than the limit of {:.0e}",
            state.end_time, limits.steps
        )));
    }
    if output > limits.output_bytes {
        return Err(over(format!(
            "the rest of the run writes about {output:.3e} bytes, more than the limit of {:.3e}",
            limits.output_bytes
        )));
    }
    Ok(())
}
