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

use crate::vtk::PvdWriter;
use sparse_mpm::error::{MpmError, Result};
use sparse_mpm::io::csv::CsvWriter;
use sparse_mpm::mass;
use sparse_mpm::operators::Operators;
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Simulation, StepReport};

mod clock;
mod identity;
mod output;
mod resume;
mod snapshot;

pub use clock::SnapshotClock;
use output::OutputClaim;
pub use output::MANIFEST;
pub use resume::resume_run;
pub use snapshot::{write_snapshot, write_snapshot_with_reference, ReferencePositions};

/// What to do with an output folder that already holds files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OutputPolicy {
    /// Refuse a folder that holds anything ([`MpmError::OutputExists`]).
    #[default]
    RefuseNonEmpty,
    /// Remove exactly the files the earlier run's manifest ([`MANIFEST`]) lists (snapshots,
    /// `particles.pvd`, `report.csv`, `scene.toml`, particle files copied beside it, checkpoints,
    /// and the temporary files of their interrupted writes) and write anew; other files stay. A
    /// file a run would write that no manifest lists is an error, and nothing is removed.
    Overwrite,
    /// Take up the output of the run being resumed (used by [`resume_run`]).
    Continue,
}

/// How to run a scene to files.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunOptions {
    /// End time and step limits.
    pub limits: RunLimits,
    /// What to do with files already in the output folder.
    pub output: OutputPolicy,
    /// Write a checkpoint every this many steps under `out/checkpoints/`.
    pub checkpoint_every: Option<usize>,
    /// Run even when the estimated memory or output exceeds [`sparse_mpm::limits::Limits::default`].
    pub allow_large: bool,
    /// Worker threads instead of the scene's `execution.threads` (or the checkpoint's).
    pub threads: Option<usize>,
}

/// Prepares `out` for a run under `policy`: creates it; refuses it when it holds files
/// ([`OutputPolicy::RefuseNonEmpty`]); removes exactly the files an earlier run's manifest lists
/// ([`OutputPolicy::Overwrite`], see [`MANIFEST`]). A run does this itself and holds the folder
/// while it writes there; this function releases it on return.
///
/// # Errors
/// [`MpmError::OutputInUse`] when a run holds the folder; [`MpmError::OutputExists`] naming the
/// folder and some of its files; [`MpmError::OutputNotOwned`] naming files in the way that no
/// manifest lists; [`MpmError::Io`] naming a file or folder that cannot be created or removed.
pub fn prepare_output(out: &Path, policy: OutputPolicy) -> Result<()> {
    OutputClaim::claim(out, policy).map(drop)
}

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
    /// The first step (and its time) a damped run reported settled (`loads.damping`).
    pub settled: Option<(usize, f64)>,
    /// The checkpoints written, in step order.
    pub checkpoints: Vec<PathBuf>,
}

fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| MpmError::Io {
        path: dir.to_path_buf(),
        source,
    })
}

/// Runs `scene` and writes its output into `out` (created if needed), replacing what an
/// earlier run wrote there ([`OutputPolicy::Overwrite`]): `scene.toml`,
/// `particles_NNNNNN.vtp` snapshots every `output.snapshot_interval` (and at the start and the
/// end), `particles.pvd`, `report.csv` (one row per step, columns [`StepReport::COLUMNS`]).
/// `progress` is called after every step. [`run_scene_with`] takes all the options.
///
/// # Errors
/// As [`run_scene_with`].
pub fn run_scene(scene: &Scene, out: &Path, limits: RunLimits, progress: impl FnMut(&Progress)) -> Result<RunSummary> {
    let options = RunOptions {
        limits,
        output: OutputPolicy::Overwrite,
        ..RunOptions::default()
    };
    run_scene_with(scene, out, &options, progress)
}

/// What a run needs besides the simulation to continue from a checkpoint (`run.json` in the
/// checkpoint folder).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct RunState {
    format: String,
    end_time: f64,
    snapshot_interval: f64,
    next_snapshot: f64,
    /// `(time, file)` of every snapshot written so far.
    snapshots: Vec<(f64, PathBuf)>,
    /// Rows of `report.csv` (= steps taken).
    report_rows: usize,
    /// SHA-256 of the run folder's `scene.toml` and its particle files
    /// ([`identity::scene_digest`]).
    scene_digest: String,
    /// The CRC-32 ending the `simulation.ckpt` this state was written with (0 until then).
    checkpoint_crc: u32,
}

const RUN_STATE_FORMAT: &str = "sparse-mpm run state 2";

impl RunState {
    /// Whether a state read from a `run.json` holds together: times finite and ordered, and
    /// every snapshot a plain file name (`particles_NNNNNN.vtp`, in the run folder: no folder,
    /// no `..`, not absolute), in time order.
    fn validate(&self) -> std::result::Result<(), String> {
        if !(self.end_time.is_finite() && self.end_time > 0.0) {
            return Err(format!("end_time = {} is not a positive number", self.end_time));
        }
        if !(self.snapshot_interval.is_finite() && self.snapshot_interval > 0.0) {
            return Err(format!(
                "snapshot_interval = {} is not a positive number",
                self.snapshot_interval
            ));
        }
        if !(self.scene_digest.len() == 64 && self.scene_digest.bytes().all(|b| b.is_ascii_hexdigit())) {
            return Err("scene_digest is not a SHA-256 digest (64 hexadecimal digits)".into());
        }
        if !(self.next_snapshot.is_finite() && self.next_snapshot >= 0.0) {
            return Err(format!("next_snapshot = {} is not a time", self.next_snapshot));
        }
        for (k, (time, file)) in self.snapshots.iter().enumerate() {
            let expected = format!("particles_{k:06}.vtp");
            if file.as_os_str() != expected.as_str() {
                return Err(format!(
                    "snapshot {k} is `{}`, not `{expected}`: a run's snapshots are files of its own folder",
                    file.display()
                ));
            }
            if !time.is_finite() || (k > 0 && *time <= self.snapshots[k - 1].0) {
                return Err(format!("snapshot {k}'s time {time} does not follow the one before"));
            }
        }
        Ok(())
    }
}

/// Runs `scene` into `out` under `options`: the estimated cost against the limits and the
/// whole build first ([`sparse_mpm::limits::prepare_run`], what `mpm check` runs), then the output
/// folder ([`prepare_output`]), then the steps.
///
/// Output is never lost: every snapshot and checkpoint file is written whole (temporary file,
/// then rename), the `.pvd` is rewritten after each snapshot so it always lists what exists,
/// and the report is flushed after every step. A run that fails part-way keeps everything
/// written before the failing step and returns the error. `scene.toml` in `out` reruns the
/// same scene from there: particle files are copied beside it (`input_<body>_<name>`) and the
/// copy names them.
///
/// # Errors
/// The errors of [`sparse_mpm::limits::prepare_run`] (limits, [`Scene::build`]), of
/// [`prepare_output`], of [`Simulation::step`] (the output written so far stays) and
/// [`MpmError::Io`] naming a file that could not be written.
pub fn run_scene_with(
    scene: &Scene,
    out: &Path,
    options: &RunOptions,
    progress: impl FnMut(&Progress),
) -> Result<RunSummary> {
    let start = Instant::now();
    let limits = if options.allow_large {
        sparse_mpm::limits::Limits::raised()
    } else {
        sparse_mpm::limits::Limits::default()
    };
    let threaded;
    let scene = match options.threads {
        Some(threads) => {
            threaded = Scene {
                execution: sparse_mpm::scene::Execution {
                    threads,
                    ..scene.execution.clone()
                },
                ..scene.clone()
            };
            &threaded
        }
        None => scene,
    };
    // An --end-time goes through the same checks and limits as the scene's own `time.end`
    // (with the scene's snapshot interval, which a default would otherwise stretch with it).
    let ended;
    let scene = match options.limits.end_time {
        Some(end) if end != scene.time.end => {
            let mut copy = scene.clone();
            copy.output.snapshot_interval = Some(scene.snapshot_interval());
            copy.time.end = end;
            ended = copy;
            &ended
        }
        _ => scene,
    };
    let (sim, _) =
        sparse_mpm::limits::prepare_run(scene, &limits).map_err(|e| match (options.limits.end_time, &e) {
            (Some(end), MpmError::InvalidScene { key, .. })
                if key.ends_with("time.end") || key.ends_with("output.snapshot_interval") =>
            {
                MpmError::InvalidOption {
                    option: "end_time (--end-time)",
                    reason: format!("{end}: {e}"),
                }
            }
            _ => e,
        })?;
    let mut claim = OutputClaim::claim(out, options.output)?;
    write_scene_copy(scene, out, &mut claim)?;
    let state = RunState {
        format: RUN_STATE_FORMAT.into(),
        end_time: options.limits.end_time.unwrap_or(scene.time.end),
        snapshot_interval: scene.snapshot_interval(),
        next_snapshot: 0.0,
        snapshots: Vec::new(),
        report_rows: 0,
        scene_digest: identity::scene_digest(out)?,
        checkpoint_crc: 0,
    };
    claim.add("particles.pvd")?;
    let pvd = PvdWriter::create(&out.join("particles.pvd"))?;
    claim.add("report.csv")?;
    let csv = CsvWriter::create(&out.join("report.csv"), &StepReport::COLUMNS)?;
    let folder = OpenFolder { out, claim, pvd, csv };
    drive(sim, state, folder, options, start, progress)
}

/// Copies `from` to `to` through the atomic writer: `to` holds the whole copy or does not exist
/// (a full disk leaves no truncated copy under the final name).
///
/// # Errors
/// [`MpmError::Io`] naming `from` when it cannot be opened, `to` when the copy cannot be written.
fn copy(from: &Path, to: &Path) -> Result<()> {
    let (mut source, _) = sparse_mpm::io::open_regular(from, sparse_mpm::scene::MAX_PARTICLE_FILE_BYTES, "particle")?;
    sparse_mpm::io::write_atomically(to, |w| std::io::copy(&mut source, w).map(|_| ()))
}

/// Writes `out/scene.toml`, copying particle files beside it and naming the copies, so that
/// the copy reruns the same scene from `out`.
fn write_scene_copy(scene: &Scene, out: &Path, claim: &mut OutputClaim) -> Result<()> {
    let mut copy_scene = scene.clone();
    for (k, body) in copy_scene.bodies.iter_mut().enumerate() {
        if let sparse_mpm::scene::Geometry::File(path) = &body.geometry {
            // The path the build read, with the same checks (inside the scene's folder, a
            // regular file within the size limit).
            let source = scene.particle_file_path(k)?.unwrap_or_else(|| path.clone());
            let size = std::fs::metadata(&source).map_or(u64::MAX, |m| m.len());
            if size > sparse_mpm::scene::MAX_PARTICLE_FILE_BYTES {
                return Err(MpmError::InvalidScene {
                    key: format!("bodies[{k}].geometry.file"),
                    reason: format!("{} changed since it was read", source.display()),
                });
            }
            let name = format!(
                "input_{k}_{}",
                path.file_name()
                    .map_or("particles.csv".into(), |n| n.to_string_lossy().into_owned())
            );
            claim.add(&name)?;
            copy(&source, &out.join(&name))?;
            body.geometry = sparse_mpm::scene::Geometry::File(PathBuf::from(name));
        }
    }
    let text = copy_scene.to_toml_string()?;
    claim.add("scene.toml")?;
    sparse_mpm::io::write_atomically(&out.join("scene.toml"), |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })
}

/// A run folder ready for the time loop: its path, what the run has claimed in it, and the
/// open series and report.
struct OpenFolder<'a> {
    out: &'a Path,
    claim: OutputClaim,
    pvd: PvdWriter,
    csv: CsvWriter,
}

/// The time loop of [`run_scene_with`] and [`resume_run`], from the state of `sim` and `state`.
fn drive(
    mut sim: Simulation,
    mut state: RunState,
    folder: OpenFolder<'_>,
    options: &RunOptions,
    start: Instant,
    mut progress: impl FnMut(&Progress),
) -> Result<RunSummary> {
    let OpenFolder { out, claim, pvd, csv } = folder;
    let end_time = state.end_time;
    // The displacement's reference: the positions now at the start, else those of the first
    // snapshot (a resumed run writes the same displacements as the uninterrupted one).
    let reference = match state.snapshots.first() {
        None => ReferencePositions::of(sim.particles()),
        Some((_, first)) => {
            let path = out.join(first);
            ReferencePositions::from_snapshot(&crate::vtk::read_vtp(&path)?).ok_or_else(|| MpmError::Snapshot {
                path,
                reason: "the run's first snapshot has no usable `id` array for the displacement's reference".into(),
            })?
        }
    };
    let mut files = RunFiles {
        out,
        claim,
        reference,
        pvd,
        csv,
        snapshots: state.snapshots.iter().map(|(_, f)| out.join(f)).collect(),
        checkpoints: Vec::new(),
    };
    if state.snapshots.is_empty() {
        files.snapshot(&sim, &mut state)?;
        state.next_snapshot = state.snapshot_interval;
    }
    let mut clock = SnapshotClock::for_options(sim.options(), state.snapshot_interval, state.next_snapshot);
    let mut stepping = Duration::ZERO;
    let (mut last, mut settled) = (None, None);
    let max_steps = options.limits.max_steps.unwrap_or(usize::MAX);
    let steps_before = sim.steps();
    while sim.time() < end_time * (1.0 - 1e-12) && sim.steps() < max_steps {
        let t0 = Instant::now();
        // A fixed step stays fixed (only the last is shortened, to end at the end time); a CFL
        // step lands on the snapshot times too.
        let result = sim.step_capped(clock.max_step(sim.time(), end_time));
        stepping += t0.elapsed();
        let report = match result {
            Ok(r) => r,
            Err(e) => {
                files.csv.flush()?;
                return Err(e);
            }
        };
        files.record_step(&sim, &mut state, &mut clock, &report, options.checkpoint_every)?;
        progress(&Progress {
            time: sim.time(),
            end_time,
            steps: sim.steps(),
            elapsed: start.elapsed(),
            dt: report.dt,
            stable_time_step: report.stable_time_step,
        });
        if report.settled && settled.is_none() {
            settled = Some((report.step, report.time));
        }
        last = Some(report);
    }
    if files.pvd.entries().last().map(|e| e.0) != Some(sim.time()) {
        files.snapshot(&sim, &mut state)?;
    }
    Ok(files.summary(&sim, sim.steps() - steps_before, stepping, start, (last, settled)))
}

/// The files a run writes as it goes: the snapshots and the `.pvd` that lists them, the
/// per-step report, and the checkpoints.
struct RunFiles<'a> {
    /// The output folder.
    out: &'a Path,
    /// The folder's lock and manifest: every file is listed before it is written.
    claim: OutputClaim,
    /// The positions the snapshots' displacements are measured from.
    reference: ReferencePositions,
    /// `particles.pvd`.
    pvd: PvdWriter,
    /// `report.csv`.
    csv: CsvWriter,
    /// Every snapshot of the run, the resumed run's earlier ones included.
    snapshots: Vec<PathBuf>,
    /// The checkpoints written by this call of [`drive`].
    checkpoints: Vec<PathBuf>,
}

impl RunFiles<'_> {
    /// Writes the particles of `sim` as the next `particles_NNNNNN.vtp` and lists it in the
    /// `.pvd`, in the snapshots and in `state`.
    fn snapshot(&mut self, sim: &Simulation, state: &mut RunState) -> Result<()> {
        let name = format!("particles_{:06}.vtp", state.snapshots.len());
        self.claim.add(&name)?;
        write_snapshot_with_reference(sim, &self.reference, &self.out.join(&name))?;
        self.pvd.push(sim.time(), Path::new(&name))?;
        self.snapshots.push(self.out.join(&name));
        state.snapshots.push((sim.time(), PathBuf::from(name)));
        Ok(())
    }

    /// Records the step `sim` has just taken: its row of the report (flushed), a snapshot
    /// when one is due by `clock`, and a checkpoint every `checkpoint_every` steps.
    fn record_step(
        &mut self,
        sim: &Simulation,
        state: &mut RunState,
        clock: &mut SnapshotClock,
        report: &StepReport,
        checkpoint_every: Option<usize>,
    ) -> Result<()> {
        self.csv.write_row(&report.values())?;
        self.csv.flush()?;
        state.report_rows += 1;
        if clock.due(sim.time()) {
            self.snapshot(sim, state)?;
            state.next_snapshot = clock.next();
        }
        if checkpoint_every.is_some_and(|k| k > 0 && sim.steps().is_multiple_of(k)) {
            self.checkpoints
                .push(write_run_checkpoint(sim, state, self.out, &mut self.claim)?);
        }
        Ok(())
    }

    /// What the run did: where `sim` stands, the throughput of the `taken` steps over the
    /// `stepping` time, and the files written.
    fn summary(
        self,
        sim: &Simulation,
        taken: usize,
        stepping: Duration,
        start: Instant,
        (last, settled): (Option<StepReport>, Option<(usize, f64)>),
    ) -> RunSummary {
        let particles = sim.particles().len();
        let seconds = stepping.as_secs_f64();
        RunSummary {
            steps: sim.steps(),
            time: sim.time(),
            particles,
            stepping,
            total: start.elapsed(),
            particle_steps_per_second: if seconds > 0.0 {
                particles as f64 * taken as f64 / seconds
            } else {
                0.0
            },
            snapshots: self.snapshots,
            pvd: self.pvd.path().to_path_buf(),
            report: self.csv.path().to_path_buf(),
            last,
            settled,
            checkpoints: self.checkpoints,
        }
    }
}

/// Writes `out/checkpoints/step_NNNNNNNN/` with `simulation.ckpt` and `run.json` (the run
/// state last, so a folder without it is an unfinished checkpoint).
fn write_run_checkpoint(sim: &Simulation, state: &RunState, out: &Path, claim: &mut OutputClaim) -> Result<PathBuf> {
    let name = format!("checkpoints/step_{:08}", sim.steps());
    let dir = out.join(&name);
    // A checkpoint folder of this step that the manifest does not list, with checkpoint files
    // in it, is another run's (`--overwrite` refuses those before it removes anything; this
    // holds for one that appeared since). One that holds only a user's files is used.
    if !claim.lists(&name) && output::holds_checkpoint_files(&dir) {
        return Err(sparse_mpm::io::invalid_data(
            &dir,
            "holds a checkpoint this run's manifest does not list (another run's): it is not written over; move it \
             away and resume from the last checkpoint",
        ));
    }
    claim.add("checkpoints")?;
    claim.add(&name)?;
    create_dir(&dir)?;
    sim.write_checkpoint(&dir.join("simulation.ckpt"))?;
    let record = RunState {
        checkpoint_crc: identity::checkpoint_checksum(&dir.join("simulation.ckpt"))?,
        ..state.clone()
    };
    let json = serde_json::to_string_pretty(&record).expect("the run state always serializes");
    sparse_mpm::io::write_atomically(&dir.join("run.json"), |w| std::io::Write::write_all(w, json.as_bytes()))?;
    // Temporary files of an earlier, interrupted write of this checkpoint (`.NAME.PID-N-R.tmp`).
    if let Ok(entries) = std::fs::read_dir(&dir) {
        for entry in entries.filter_map(|e| e.ok()) {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if sparse_mpm::io::temporary_of(&name).is_some_and(|of| output::CHECKPOINT_FILES.contains(&of)) {
                let path = entry.path();
                std::fs::remove_file(&path).map_err(|source| MpmError::Io { path, source })?;
            }
        }
    }
    Ok(dir)
}

/// Writes the matrices of the scene's initial configuration into `out`: `N.mtx`, `Gx.mtx`,
/// `Gy.mtx` (nodes × particles, coordinate `general`), `M.mtx` (consistent mass `N diag(m) Nᵀ`,
/// nodes × nodes, coordinate `symmetric`: the lower triangle, as
/// [`sparse_mpm::io::write_matrix_market_symmetric`] writes it), `mL.mtx` (lumped mass `N m`, a dense
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
    sparse_mpm::io::write_operators(&ops, out)?;
    let m = mass::consistent_mass(&ops, &particles.mass);
    sparse_mpm::io::write_matrix_market_with_comment(
        &m,
        &out.join("M.mtx"),
        sparse_mpm::io::MatrixMarketStorage::Symmetric,
        "M: consistent mass N diag(m) N^T of sparse-mpm (rows and columns = grid nodes; 1-based), \
         symmetric: lower triangle stored",
    )?;
    let m_l = mass::lumped_mass(&ops, &particles.mass);
    let mut text = format!(
        "%%MatrixMarket matrix array real general\n% lumped mass m_L = N m, one row per node\n{} 1\n",
        m_l.len()
    );
    for v in &m_l {
        sparse_mpm::numbers::push_round_trip(&mut text, *v);
        text.push('\n');
    }
    // Whole files only (temporary file, then rename), as the Matrix Market writer does.
    let write = |name: &str, text: String| -> Result<PathBuf> {
        let path = out.join(name);
        sparse_mpm::io::write_atomically(&path, |w| std::io::Write::write_all(w, text.as_bytes()))?;
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
        sparse_mpm::numbers::push_round_trip(&mut nodes, x);
        nodes.push(',');
        sparse_mpm::numbers::push_round_trip(&mut nodes, y);
        nodes.push('\n');
    }
    files.push(write("nodes.csv", nodes)?);
    let mut table = String::from("particle,x,y,mass,volume,body\n");
    for k in 0..particles.len() {
        table.push_str(&format!("{k}"));
        for v in [particles.x[k], particles.y[k], particles.mass[k], particles.volume[k]] {
            table.push(',');
            sparse_mpm::numbers::push_round_trip(&mut table, v);
        }
        table.push_str(&format!(",{}\n", particles.body[k]));
    }
    files.push(write("particles.csv", table)?);
    Ok(files)
}
