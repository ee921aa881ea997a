//! `runs.csv` of a study: one row per run, its choices, then every metric any run measured.

use std::collections::BTreeSet;
use std::path::Path;

use super::StudyRun;
use sparse_mpm::error::{MpmError, Result};

/// `runs.csv`: one row per run, the choices, then every metric any run measured.
pub(super) fn write_runs_csv(runs: &[StudyRun], path: &Path) -> Result<()> {
    let names: BTreeSet<&str> = runs
        .iter()
        .filter_map(|r| r.outcome.as_ref().ok())
        .flat_map(|o| o.metrics.iter().map(|(n, _)| n.as_str()))
        .collect();
    let io = |e: csv::Error| MpmError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    };
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec![
        "part",
        "problem",
        "label",
        "shape",
        "update",
        "transfer",
        "velocity_mass",
        "acceleration_mass",
        "particles_per_cell",
        "cfl",
        "cells",
        "cell_size",
        "steps",
        "wall_seconds",
        "wall_per_step_seconds",
        "wall_per_simulated_time_seconds",
        "error",
    ];
    header.extend(names.iter());
    w.write_record(&header).map_err(io)?;
    for r in runs {
        let c = &r.choices;
        let mut row = vec![
            r.part.name().to_string(),
            r.outcome.as_ref().map_or(String::new(), |o| o.problem.clone()),
            c.label(),
            c.shape.name().to_string(),
            format!("{:?}", c.update).to_lowercase(),
            format!("{:?}", c.transfer).to_lowercase(),
            format!("{:#}", c.mass.velocity),
            format!("{:#}", c.mass.acceleration),
            c.particles_per_cell.to_string(),
            c.cfl.to_string(),
            r.cells.to_string(),
        ];
        match &r.outcome {
            Ok(o) => {
                row.push(o.cell_size.to_string());
                row.push(o.steps.to_string());
                row.push(o.seconds.to_string());
                row.push(if o.steps > 0 {
                    (o.seconds / o.steps as f64).to_string()
                } else {
                    String::new()
                });
                // Wall time per unit of simulated time, where the problem simulates one.
                row.push(
                    o.metric("end_time")
                        .filter(|&t| t > 0.0)
                        .map_or(String::new(), |t| (o.seconds / t).to_string()),
                );
                row.push(String::new());
                for n in &names {
                    row.push(o.metric(n).map_or(String::new(), |v| v.to_string()));
                }
            }
            Err(e) => {
                row.extend([
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    e.clone(),
                ]);
                row.extend(names.iter().map(|_| String::new()));
            }
        }
        w.write_record(&row).map_err(io)?;
    }
    let bytes = w.into_inner().map_err(|e| MpmError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    })?;
    sparse_mpm::io::write_atomically(path, |f| std::io::Write::write_all(f, &bytes))
}
