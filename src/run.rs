//! Running a scene to files: particle snapshots (`.vtp` + a `.pvd` time series for ParaView),
//! the per-step report (`report.csv`), the scene as read (`scene.toml`), and the matrices of the
//! initial configuration (`mpm matrices`).
//!
//! Output is never lost: every snapshot file is written whole (temporary file, then rename),
//! the `.pvd` is rewritten after each snapshot so it always lists what exists, and the report
//! is flushed after every step. A run that fails part-way keeps everything written before the
//! failing step and returns the error.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::error::{MpmError, Result};
use crate::io::csv::CsvWriter;
use crate::io::vtk::{write_vtp, Field, PvdWriter};
use crate::mass;
use crate::operators::Operators;
use crate::scene::Scene;
use crate::simulation::{Simulation, StepReport};

/// Limits that override the scene's end time (for quick looks and tests).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunLimits {
    /// Stop at this time instead of `time.end`.
    pub end_time: Option<f64>,
    /// Stop after this many steps.
    pub max_steps: Option<usize>,
}

/// Where a run is, for progress displays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Simulated time.
    pub time: f64,
    /// Time the run ends at.
    pub end_time: f64,
    /// Steps taken.
    pub steps: usize,
    /// Wall time since the start.
    pub elapsed: Duration,
    /// Length of the last step.
    pub dt: f64,
    /// The stable step at the start of the last step.
    pub stable_time_step: f64,
}

/// What a run did.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// Steps taken.
    pub steps: usize,
    /// Simulated time reached.
    pub time: f64,
    /// Particle count.
    pub particles: usize,
    /// Wall time spent in [`Simulation::step`].
    pub stepping: Duration,
    /// Wall time of the whole run, output included.
    pub total: Duration,
    /// `particles × steps / stepping time`.
    pub particle_steps_per_second: f64,
    /// The snapshot files written, in time order.
    pub snapshots: Vec<PathBuf>,
    /// The `.pvd` time series.
    pub pvd: PathBuf,
    /// The per-step report.
    pub report: PathBuf,
    /// The last step's report.
    pub last: Option<StepReport>,
}

fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| MpmError::Io {
        path: dir.to_path_buf(),
        source,
    })
}

/// Writes the particles of `sim` to `path` as a `.vtp` snapshot with the arrays `id`, `body`,
/// `mass`, `volume`, `velocity`, `stress` (symmetric tensor), `pressure` (`−(σxx + σyy)/2`),
/// `deformation_gradient` and `J` (`det F`).
///
/// # Errors
/// [`MpmError::Io`] naming the file.
pub fn write_snapshot(sim: &Simulation, path: &Path) -> Result<()> {
    let p = sim.particles();
    let id: Vec<f64> = p.id.iter().map(|&i| i as f64).collect();
    let body: Vec<f64> = p.body.iter().map(|&b| b as f64).collect();
    let pressure: Vec<f64> = (0..p.len()).map(|k| -0.5 * (p.sxx[k] + p.syy[k])).collect();
    let j: Vec<f64> = (0..p.len())
        .map(|k| p.fxx[k] * p.fyy[k] - p.fxy[k] * p.fyx[k])
        .collect();
    let fields = [
        Field::Scalar {
            name: "id",
            values: &id,
        },
        Field::Scalar {
            name: "body",
            values: &body,
        },
        Field::Scalar {
            name: "mass",
            values: &p.mass,
        },
        Field::Scalar {
            name: "volume",
            values: &p.volume,
        },
        Field::Vector {
            name: "velocity",
            x: &p.vx,
            y: &p.vy,
        },
        Field::Tensor {
            name: "stress",
            xx: &p.sxx,
            xy: &p.sxy,
            yx: &p.sxy,
            yy: &p.syy,
        },
        Field::Scalar {
            name: "pressure",
            values: &pressure,
        },
        Field::Tensor {
            name: "deformation_gradient",
            xx: &p.fxx,
            xy: &p.fxy,
            yx: &p.fyx,
            yy: &p.fyy,
        },
        Field::Scalar { name: "J", values: &j },
    ];
    write_vtp(path, &p.x, &p.y, &fields)
}

/// Runs `scene` and writes its output into `out` (created if needed): `scene.toml`,
/// `particles_NNNNNN.vtp` snapshots every `output.snapshot_interval` (and at the start and the
/// end), `particles.pvd`, `report.csv` (one row per step, columns [`StepReport::COLUMNS`]).
/// `progress` is called after every step.
///
/// # Errors
/// The errors of [`Scene::build`], of [`Simulation::step`] (the output written so far stays)
/// and [`MpmError::Io`] naming a file that could not be written.
pub fn run_scene(
    scene: &Scene,
    out: &Path,
    limits: RunLimits,
    mut progress: impl FnMut(&Progress),
) -> Result<RunSummary> {
    let start = Instant::now();
    let mut sim = scene.build()?;
    create_dir(out)?;
    let scene_copy = out.join("scene.toml");
    std::fs::write(&scene_copy, scene.to_toml_string()?).map_err(|source| MpmError::Io {
        path: scene_copy.clone(),
        source,
    })?;
    let end_time = limits.end_time.unwrap_or(scene.time.end);
    let interval = scene.snapshot_interval();
    let mut pvd = PvdWriter::create(&out.join("particles.pvd"))?;
    let report_path = out.join("report.csv");
    let mut csv = CsvWriter::create(&report_path, &StepReport::COLUMNS)?;
    let mut snapshots = Vec::new();
    let mut snapshot = |sim: &Simulation, pvd: &mut PvdWriter| -> Result<()> {
        let name = format!("particles_{:06}.vtp", snapshots.len());
        write_snapshot(sim, &out.join(&name))?;
        pvd.push(sim.time(), Path::new(&name))?;
        snapshots.push(out.join(&name));
        Ok(())
    };
    snapshot(&sim, &mut pvd)?;
    let mut next_snapshot = interval;
    let mut stepping = Duration::ZERO;
    let mut last = None;
    let max_steps = limits.max_steps.unwrap_or(usize::MAX);
    while sim.time() < end_time * (1.0 - 1e-12) && sim.steps() < max_steps {
        let t0 = Instant::now();
        // Land exactly on snapshot times and on the end.
        let target = next_snapshot.min(end_time);
        let result = sim.step_capped(target - sim.time());
        stepping += t0.elapsed();
        let report = match result {
            Ok(r) => r,
            Err(e) => {
                csv.flush()?;
                return Err(e);
            }
        };
        csv.write_row(&report.values())?;
        csv.flush()?;
        if sim.time() >= next_snapshot * (1.0 - 1e-12) {
            snapshot(&sim, &mut pvd)?;
            next_snapshot += interval;
        }
        progress(&Progress {
            time: sim.time(),
            end_time,
            steps: sim.steps(),
            elapsed: start.elapsed(),
            dt: report.dt,
            stable_time_step: report.stable_time_step,
        });
        last = Some(report);
    }
    if pvd.entries().last().map(|e| e.0) != Some(sim.time()) {
        snapshot(&sim, &mut pvd)?;
    }
    let particles = sim.particles().len();
    let seconds = stepping.as_secs_f64();
    Ok(RunSummary {
        steps: sim.steps(),
        time: sim.time(),
        particles,
        stepping,
        total: start.elapsed(),
        particle_steps_per_second: if seconds > 0.0 {
            particles as f64 * sim.steps() as f64 / seconds
        } else {
            0.0
        },
        snapshots,
        pvd: pvd.path().to_path_buf(),
        report: report_path,
        last,
    })
}

/// Writes the matrices of the scene's initial configuration into `out`: `N.mtx`, `Gx.mtx`,
/// `Gy.mtx` (nodes × particles, coordinate `general`), `M.mtx` (consistent mass `N diag(m) Nᵀ`,
/// nodes × nodes, coordinate `symmetric`: the lower triangle, as
/// [`crate::io::write_matrix_market_symmetric`] writes it), `mL.mtx` (lumped mass `N m`, a dense
/// nodes × 1 array), all Matrix Market; and `nodes.csv`
/// (`node, x, y`) and `particles.csv` (`particle, x, y, mass, volume, body`) to name the rows
/// and columns (0-based; Matrix Market indices are 1-based).
///
/// # Errors
/// The errors of [`Scene::grid`], [`Scene::particles`], [`Operators::assemble`], and
/// [`MpmError::Io`] naming a file.
pub fn write_matrices(scene: &Scene, out: &Path) -> Result<Vec<PathBuf>> {
    let grid = scene.grid()?;
    let particles = scene.particles()?;
    let ops = Operators::assemble(&grid, scene.schemes.shape, &particles)?;
    create_dir(out)?;
    ops.write_matrix_market(out)?;
    let m = mass::consistent_mass(&ops, &particles.mass);
    crate::io::write_matrix_market_with_comment(
        &m,
        &out.join("M.mtx"),
        crate::io::MatrixMarketStorage::Symmetric,
        "M: consistent mass N diag(m) N^T of sparse-mpm (rows and columns = grid nodes; 1-based), \
         symmetric: lower triangle stored",
    )?;
    let m_l = mass::lumped_mass(&ops, &particles.mass);
    let mut text = format!(
        "%%MatrixMarket matrix array real general\n% lumped mass m_L = N m, one row per node\n{} 1\n",
        m_l.len()
    );
    for v in &m_l {
        crate::io::push_f64(&mut text, *v);
        text.push('\n');
    }
    let write = |name: &str, text: String| -> Result<PathBuf> {
        let path = out.join(name);
        std::fs::write(&path, text).map_err(|source| MpmError::Io {
            path: path.clone(),
            source,
        })?;
        Ok(path)
    };
    let mut files = vec![
        out.join("N.mtx"),
        out.join("Gx.mtx"),
        out.join("Gy.mtx"),
        out.join("M.mtx"),
    ];
    files.push(write("mL.mtx", text)?);
    let mut nodes = String::from("node,x,y\n");
    for i in 0..grid.num_nodes() {
        let [x, y] = grid.node_position(i);
        nodes.push_str(&format!("{i},"));
        crate::io::push_f64(&mut nodes, x);
        nodes.push(',');
        crate::io::push_f64(&mut nodes, y);
        nodes.push('\n');
    }
    files.push(write("nodes.csv", nodes)?);
    let mut table = String::from("particle,x,y,mass,volume,body\n");
    for k in 0..particles.len() {
        table.push_str(&format!("{k}"));
        for v in [particles.x[k], particles.y[k], particles.mass[k], particles.volume[k]] {
            table.push(',');
            crate::io::push_f64(&mut table, v);
        }
        table.push_str(&format!(",{}\n", particles.body[k]));
    }
    files.push(write("particles.csv", table)?);
    Ok(files)
}
