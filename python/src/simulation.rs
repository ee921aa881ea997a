//! `Simulation`: a scene (file, TOML text or dict), NumPy arrays or a checkpoint run step by
//! step, its step reports as dicts or as rows, its particle state in and out, snapshots and
//! checkpoints.

use crate::choices::{scene_from_value, scene_grid_nodes, ToToml};
use crate::grid::{particles_dict, PyGrid, PyParticles};
use crate::inputs::{real_vec, Len};
use crate::operators::PyOperators;
use crate::{f64_array, index_array, mpm_err, mpm_msg};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use sparse_mpm::limits::{prepare_run, Limits};
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Simulation, StepReport};
use sparse_mpm::Particles;
use sparse_mpm_cli::run::SnapshotClock;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// An explicit MPM simulation built from a scene (TOML file, TOML text or dict), from arrays or
/// from a checkpoint.
#[pyclass(name = "Simulation", module = "sparse_mpm._core")]
pub(crate) struct PySimulation {
    sim: Simulation,
    /// The scene it was built from; `None` for arrays and checkpoints.
    scene: Option<Scene>,
    /// Whether the scene's bodies only stand for particles given as arrays (no scene text).
    from_arrays: bool,
    /// The default end of `run`: the scene's `[time] end`, or given.
    end_time: Option<f64>,
    /// Steps land on multiples of this interval (as `mpm run` lands on snapshot times).
    land_every: Option<f64>,
    next_landing: f64,
    /// Changes with every change of the state (steps, particle state set from Python).
    version: u64,
}

/// Longest stretch of steps `run_rows` takes before it lets a signal's handler run (Ctrl-C).
const SIGNAL_INTERVAL: Duration = Duration::from_millis(50);

/// The particle fields `set_particle_state` accepts.
const SETTABLE: [&str; 7] = ["vx", "vy", "sxx", "syy", "sxy", "bx", "by"];

/// The first landing time after `time` for steps landing every `every`, found by adding
/// `every` as `advance` does, so that a resumed simulation lands on the same bits.
fn next_landing_after(time: f64, every: f64) -> f64 {
    if time / every > 1e7 {
        return ((time / every).floor() + 1.0) * every;
    }
    let mut next = every;
    while time >= next * (1.0 - 1e-12) {
        next += every;
    }
    next
}

/// A step report as a dict with the keys of `StepReport::COLUMNS`.
fn report_dict<'py>(py: Python<'py>, r: &StepReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in StepReport::COLUMNS.iter().zip(r.values()) {
        d.set_item(*k, v)?;
    }
    Ok(d)
}

impl PySimulation {
    /// The simulation `mpm run` would run for `scene` (`prepare_run`; no resource limits with
    /// `allow_large`), landing on the scene's snapshot times.
    fn build(scene: Scene, allow_large: bool) -> PyResult<Self> {
        let limits = if allow_large {
            Limits::raised()
        } else {
            Limits::default()
        };
        let (sim, _) = prepare_run(&scene, &limits).map_err(mpm_err)?;
        Ok(Self::wrap(sim, scene, false))
    }

    /// `sim` built from `scene`, stepping as `mpm run` does: a CFL step lands on the scene's
    /// snapshot times, a fixed step stays fixed (`SnapshotClock`).
    fn wrap(sim: Simulation, scene: Scene, from_arrays: bool) -> Self {
        let interval = scene.snapshot_interval();
        let land_every =
            (interval.is_finite() && interval > 0.0 && SnapshotClock::lands(sim.options())).then_some(interval);
        PySimulation {
            sim,
            end_time: Some(scene.time.end),
            scene: Some(scene),
            from_arrays,
            land_every,
            next_landing: interval,
            version: 0,
        }
    }

    /// One step landing on the next landing time (if any) and on `end`.
    fn advance(&mut self, end: f64) -> sparse_mpm::Result<StepReport> {
        let target = match self.land_every {
            Some(_) => self.next_landing.min(end),
            None => end,
        };
        self.version += 1;
        let r = self.sim.step_capped(target - self.sim.time())?;
        if let Some(interval) = self.land_every {
            if self.sim.time() >= self.next_landing * (1.0 - 1e-12) {
                self.next_landing += interval;
            }
        }
        Ok(r)
    }
}

#[pymethods]
impl PySimulation {
    /// The simulation of a scene file; particle files are read from its folder. `overrides`:
    /// `KEY=VALUE` changes of the file's keys, as `mpm run --set` takes them.
    #[staticmethod]
    #[pyo3(signature = (path, allow_large = false, overrides = None))]
    fn from_scene(path: PathBuf, allow_large: bool, overrides: Option<Vec<String>>) -> PyResult<Self> {
        let sets = overrides.unwrap_or_default();
        Self::build(Scene::load_with(&path, &sets).map_err(mpm_err)?, allow_large)
    }

    /// The simulation of a scene given as TOML text; relative particle files are read from
    /// `base_dir` (none without it); `overrides` as for `from_scene`.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir = None, allow_large = false, overrides = None))]
    fn from_toml(
        text: &str,
        base_dir: Option<PathBuf>,
        allow_large: bool,
        overrides: Option<Vec<String>>,
    ) -> PyResult<Self> {
        if text.len() as u64 > sparse_mpm::scene::MAX_SCENE_BYTES {
            return Err(mpm_msg(format!(
                "the scene text is {} bytes, more than the {} a scene file may hold",
                text.len(),
                sparse_mpm::scene::MAX_SCENE_BYTES
            )));
        }
        let sets = overrides.unwrap_or_default();
        let text = if sets.is_empty() {
            text.to_string()
        } else {
            sparse_mpm::scene::apply_overrides(text, &sets).map_err(mpm_err)?
        };
        let mut scene = Scene::from_toml_str(&text).map_err(mpm_err)?;
        scene.base_dir = base_dir;
        Self::build(scene, allow_large)
    }

    /// The simulation of a scene given as a dict with the keys of a scene file.
    #[staticmethod]
    #[pyo3(signature = (scene, base_dir = None, allow_large = false))]
    fn from_dict(scene: &Bound<'_, PyDict>, base_dir: Option<PathBuf>, allow_large: bool) -> PyResult<Self> {
        // Bounded: depth, size, no self-reference, node lists no longer than the scene's grid.
        let value = ToToml::new(scene_grid_nodes(scene)).convert(scene.as_any(), "")?;
        let mut scene = scene_from_value(&value)?;
        scene.base_dir = base_dir;
        Self::build(scene, allow_large)
    }

    /// The simulation of `particles` (with `particles.body` indexing `bodies`) on `grid`:
    /// `bodies` a list of dicts with `name` and `material` (as in a scene's body), `options` a dict with the other tables of a scene (`time`, `schemes`,
    /// `loads`, `boundaries`, `output`, `execution`). Errors name the key path or the particle.
    #[staticmethod]
    #[pyo3(signature = (grid, particles, bodies, options = None))]
    fn from_arrays(
        grid: &PyGrid,
        particles: &PyParticles,
        bodies: &Bound<'_, PyList>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let p = &particles.inner;
        // One bound on the size of `options` and `bodies` together; node lists within the grid.
        let mut reader = ToToml::new(Some(grid.inner.num_nodes()));
        let mut table = match options {
            Some(o) => match reader.convert(o.as_any(), "")? {
                toml::Value::Table(t) => t,
                _ => unreachable!("a dict gives a table"),
            },
            None => toml::map::Map::new(),
        };
        for key in ["grid", "bodies"] {
            if table.contains_key(key) {
                return Err(mpm_msg(format!(
                    "options.{key}: give the {key} as the argument `{key}` of from_arrays, not in options"
                )));
            }
        }
        let g = &grid.inner;
        let [x0, x1, y0, y1] = g.bounds();
        let mut spec = toml::map::Map::new();
        spec.insert("origin".into(), toml::Value::try_from(g.origin()).expect("two floats"));
        spec.insert(
            "cell_size".into(),
            toml::Value::try_from(g.cell_size()).expect("two floats"),
        );
        let cells = g.cells();
        spec.insert(
            "cells".into(),
            toml::Value::Array(cells.iter().map(|&c| toml::Value::Integer(c as i64)).collect()),
        );
        table.insert("grid".into(), toml::Value::Table(spec));
        // Each body as a scene body whose geometry stands for its particles: the scene's checks
        // of the material then run, naming `bodies[k].material.…`.
        // The reference density the simulation uses for each body (the largest m_p / V_p of its
        // particles), for the scene's checks of the material (its wave speed): one pass.
        reader.check_len("bodies", bodies.len())?;
        let mut densities = vec![f64::NAN; bodies.len()];
        for i in 0..p.len() {
            if let Some(d) = densities.get_mut(p.body[i]) {
                *d = d.max(p.mass[i] / p.volume[i]);
            }
        }
        let mut specs = Vec::new();
        for (k, b) in bodies.iter().enumerate() {
            let key = format!("bodies[{k}]");
            let toml::Value::Table(mut t) = reader.convert(&b, &key)? else {
                return Err(mpm_msg(format!("{key}: expected a dict with `name` and `material`")));
            };
            if let Some(other) = t.keys().find(|k| !["name", "material"].contains(&k.as_str())) {
                return Err(mpm_msg(format!(
                    "{key}.{other}: not a key of a body given with arrays (`name`, `material`); masses, \
                     velocities, body forces and stresses are particle arrays"
                )));
            }
            let density = densities.get(k).copied().unwrap_or(f64::NAN);
            t.insert(
                "density".into(),
                toml::Value::Float(if density.is_nan() { 1.0 } else { density }),
            );
            let rectangle = toml::Value::try_from(std::collections::BTreeMap::from([(
                "rectangle",
                std::collections::BTreeMap::from([("min", [x0, y0]), ("max", [x1, y1])]),
            )]))
            .expect("a table of floats");
            t.insert("geometry".into(), rectangle);
            specs.push(toml::Value::Table(t));
        }
        if let Some(i) = p.body.iter().position(|&b| b >= specs.len()) {
            return Err(mpm_msg(format!(
                "body[{i}] = {}: particle {i} names a body that does not exist ({} given in `bodies`)",
                p.body[i],
                specs.len()
            )));
        }
        table.insert("bodies".into(), toml::Value::Array(specs));
        if !table.contains_key("time") {
            return Err(mpm_msg("options.time: missing; give at least {\"end\": …}"));
        }
        let scene = scene_from_value(&toml::Value::Table(table))?;
        let sim = Simulation::new(g.clone(), p.clone(), scene.bodies(), scene.options()).map_err(mpm_err)?;
        Ok(Self::wrap(sim, scene, true))
    }

    /// The simulation saved in a checkpoint file (`write_checkpoint`, `mpm run --checkpoint`);
    /// its steps continue the saved run bit for bit. `end_time` is the default end of `run`;
    /// steps land on multiples of `land_every` when given.
    #[staticmethod]
    #[pyo3(signature = (path, end_time = None, land_every = None))]
    fn from_checkpoint(path: PathBuf, end_time: Option<f64>, land_every: Option<f64>) -> PyResult<Self> {
        let sim = Simulation::read_checkpoint(&path).map_err(mpm_err)?;
        if let Some(t) = end_time {
            if !t.is_finite() {
                return Err(mpm_msg(format!("end_time = {t}: must be a finite time")));
            }
        }
        let mut me = PySimulation {
            sim,
            scene: None,
            from_arrays: false,
            end_time,
            land_every: None,
            next_landing: f64::INFINITY,
            version: 0,
        };
        me.set_land_every(land_every)?;
        Ok(me)
    }

    /// Writes the simulation to a checkpoint file (`Simulation::write_checkpoint`).
    fn write_checkpoint(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let sim = &self.sim;
        py.detach(|| sim.write_checkpoint(&path)).map_err(mpm_err)
    }

    /// Writes the particles to a `.vtp` snapshot as `mpm run` does (`run::write_snapshot`).
    fn write_snapshot(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let sim = &self.sim;
        py.detach(|| sparse_mpm_cli::run::write_snapshot(sim, &path))
            .map_err(mpm_err)
    }

    /// Changes with every change of the state (a step, particle state set from Python).
    #[getter]
    fn version(&self) -> u64 {
        self.version
    }

    /// Sets particle fields (`vx`, `vy`, `sxx`, `syy`, `sxy`, `bx`, `by`), each an array in the
    /// current particle order. Body forces may be set at any time; the others before the first
    /// step only (the simulation is then rebuilt with them). Errors name the field and particle.
    fn set_particle_state(&mut self, fields: &Bound<'_, PyDict>) -> PyResult<()> {
        let n = self.sim.particles().len();
        let mut given: Vec<(&'static str, Vec<f64>)> = Vec::new();
        for (k, v) in fields.iter() {
            let name: String = k.extract()?;
            let Some(&field) = SETTABLE.iter().find(|f| **f == name) else {
                return Err(mpm_msg(format!(
                    "{name}: not a particle field that can be set (settable: {})",
                    SETTABLE.join(", ")
                )));
            };
            // Real (a complex array is a TypeError), one per particle, checked before copying.
            let values = real_vec(&v, field, Len::Exactly(n))?;
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(mpm_msg(format!(
                    "{field}[{i}] = {}: particle {i} (id {}) must have a finite {field}",
                    values[i],
                    self.sim.particles().id[i]
                )));
            }
            given.push((field, values));
        }
        let only_body_force = given.iter().all(|(f, _)| *f == "bx" || *f == "by");
        if given.is_empty() {
            return Ok(());
        }
        if only_body_force {
            let p = self.sim.particles();
            let mut b: Vec<[f64; 2]> = (0..n).map(|i| [p.bx[i], p.by[i]]).collect();
            for (f, v) in &given {
                let c = usize::from(*f == "by");
                for (i, x) in v.iter().enumerate() {
                    b[i][c] = *x;
                }
            }
            // The library sets body forces by permanent id.
            let mut by_id = std::collections::HashMap::with_capacity(n);
            for (i, &id) in p.id.iter().enumerate() {
                by_id.insert(id, b[i]);
            }
            self.sim.set_body_force(|id, _| by_id[&id]);
        } else if self.sim.steps() > 0 {
            // Between steps: the library's setters, in the current particle order.
            let p = self.sim.particles();
            let pick = |name: &str, now: &[f64]| -> Vec<f64> {
                given
                    .iter()
                    .find(|(f, _)| *f == name)
                    .map_or_else(|| now.to_vec(), |(_, v)| v.clone())
            };
            let (vx, vy) = (pick("vx", &p.vx), pick("vy", &p.vy));
            let (sxx, syy, sxy) = (pick("sxx", &p.sxx), pick("syy", &p.syy), pick("sxy", &p.sxy));
            let (bx, by) = (pick("bx", &p.bx), pick("by", &p.by));
            let mut k = 0;
            self.sim
                .set_velocity(|_, _| {
                    k += 1;
                    [vx[k - 1], vy[k - 1]]
                })
                .map_err(mpm_err)?;
            let mut k = 0;
            self.sim
                .set_stress(|_, _| {
                    k += 1;
                    [sxx[k - 1], syy[k - 1], sxy[k - 1]]
                })
                .map_err(mpm_err)?;
            let mut k = 0;
            self.sim.set_body_force(|_, _| {
                k += 1;
                [bx[k - 1], by[k - 1]]
            });
        } else {
            let mut p: Particles = self.sim.particles().clone();
            for (f, v) in given {
                let slot = match f {
                    "vx" => &mut p.vx,
                    "vy" => &mut p.vy,
                    "sxx" => &mut p.sxx,
                    "syy" => &mut p.syy,
                    "sxy" => &mut p.sxy,
                    "bx" => &mut p.bx,
                    _ => &mut p.by,
                };
                *slot = v;
            }
            let s = &self.sim;
            self.sim =
                Simulation::new(s.grid().clone(), p, s.bodies().to_vec(), s.options().clone()).map_err(mpm_err)?;
        }
        self.version += 1;
        Ok(())
    }

    /// The updated grid velocity `w` of the last step, `(vx, vy)` per node (copies).
    fn grid_velocity<'py>(&self, py: Python<'py>) -> (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>) {
        let w = self.sim.grid_velocity();
        (f64_array(py, &w.x), f64_array(py, &w.y))
    }

    /// The active nodes of the last step (nodes with mass), ascending (a copy).
    fn active_nodes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        index_array(py, &self.sim.grid_mass().active_nodes())
    }

    /// Time reached.
    #[getter]
    fn time(&self) -> f64 {
        self.sim.time()
    }
    /// Steps taken.
    #[getter]
    fn steps(&self) -> usize {
        self.sim.steps()
    }
    /// The default end of `run`: the scene's `[time] end` (None for a checkpoint read without one).
    #[getter]
    fn end_time(&self) -> Option<f64> {
        self.end_time
    }
    /// The interval steps land on (the scene's snapshot interval), or None.
    #[getter]
    fn get_land_every(&self) -> Option<f64> {
        self.land_every
    }
    #[setter]
    fn set_land_every(&mut self, every: Option<f64>) -> PyResult<()> {
        if let Some(e) = every {
            if !(e.is_finite() && e > 0.0) {
                return Err(mpm_msg(format!(
                    "land_every = {e}: must be a positive finite number or None"
                )));
            }
            self.next_landing = next_landing_after(self.sim.time(), e);
        }
        self.land_every = every;
        Ok(())
    }
    /// The scene as TOML text.
    fn scene_toml(&self) -> PyResult<String> {
        match &self.scene {
            Some(scene) if !self.from_arrays => scene.to_toml_string().map_err(mpm_err),
            _ => Err(mpm_msg(
                "scene_toml: this simulation was built from arrays or a checkpoint, not from a scene",
            )),
        }
    }
    /// The stable time step for the current state (see `Simulation::stable_time_step`).
    fn stable_time_step(&self) -> f64 {
        self.sim.stable_time_step()
    }
    /// One step; its report as a dict with the keys of `StepReport::COLUMNS`.
    #[pyo3(signature = (max_dt = None))]
    fn step<'py>(&mut self, py: Python<'py>, max_dt: Option<f64>) -> PyResult<Bound<'py, PyDict>> {
        let cap = max_dt.unwrap_or(f64::INFINITY);
        if cap.is_nan() || cap <= 0.0 {
            return Err(mpm_msg(format!("max_dt = {cap}: must be positive")));
        }
        let r = {
            let me = &mut *self;
            py.detach(|| {
                let end = me.sim.time() + cap;
                me.advance(end)
            })
        }
        .map_err(mpm_err)?;
        report_dict(py, &r)
    }
    /// Steps until `until`; one row per step in `StepReport::COLUMNS` order, flattened
    /// (rows × 25), and the number of rows. A signal (Ctrl-C) is handled between steps: its
    /// exception (KeyboardInterrupt) is raised with the steps taken kept.
    fn run_rows<'py>(&mut self, py: Python<'py>, until: f64) -> PyResult<(Bound<'py, PyArray1<f64>>, usize)> {
        if !until.is_finite() {
            return Err(mpm_msg(format!("until = {until}: must be a finite time")));
        }
        // One row of 8-byte numbers per step, kept until the run returns: the rows the steps to
        // `until` need at today's step are checked against the memory this process can have,
        // and again whenever the rows grow (the step may shorten on the way).
        let row_bytes = (StepReport::COLUMNS.len() * std::mem::size_of::<f64>()) as f64;
        let dt = match self.sim.options().time_step {
            sparse_mpm::simulation::TimeStep::Fixed { dt } => dt,
            sparse_mpm::simulation::TimeStep::Cfl { number } => number * self.sim.stable_time_step(),
        };
        let steps = ((until - self.sim.time()) / dt).max(0.0).ceil();
        let what = |steps: f64| {
            move || format!("run(until = {until}): the report rows of about {steps:.3e} steps (25 numbers each)")
        };
        if dt > 0.0 {
            sparse_mpm::limits::ensure_memory(steps * row_bytes, what(steps)).map_err(mpm_err)?;
        }
        // Whole steps without the GIL, in batches of about `SIGNAL_INTERVAL`; between batches a
        // signal's handler runs (Ctrl-C raises KeyboardInterrupt there, the steps taken stay taken).
        let mut rows: Vec<f64> = Vec::new();
        let error = loop {
            let me = &mut *self;
            let rows = &mut rows;
            let (done, error) = py.detach(|| {
                let start = Instant::now();
                while me.sim.time() < until * (1.0 - 1e-12) {
                    if rows.len() == rows.capacity() {
                        let grown = (2 * rows.capacity()).max(1024) as f64 * 8.0;
                        if let Err(e) = sparse_mpm::limits::ensure_memory(grown, what(grown / row_bytes)) {
                            return (true, Some(e));
                        }
                    }
                    match me.advance(until) {
                        Ok(r) => rows.extend_from_slice(&r.values()),
                        Err(e) => return (true, Some(e)),
                    }
                    if start.elapsed() >= SIGNAL_INTERVAL {
                        return (false, None);
                    }
                }
                (true, None)
            });
            if done {
                break error;
            }
            py.check_signals()?;
        };
        if let Some(e) = error {
            return Err(mpm_err(e));
        }
        let n = rows.len() / StepReport::COLUMNS.len();
        Ok((PyArray1::from_vec(py, rows), n))
    }
    /// The particle fields as a dict of new arrays.
    fn particles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        particles_dict(py, self.sim.particles())
    }
    /// The grid.
    fn grid(&self) -> PyGrid {
        PyGrid {
            inner: self.sim.grid().clone(),
        }
    }
    /// N, Gx, Gy at the current particle positions (a copy).
    fn operators(&self) -> PyOperators {
        let ops = self.sim.operators().clone();
        ops.col_offsets();
        PyOperators { inner: ops }
    }
    /// The lumped mass `m_L = N m` of the last step (a copy).
    fn lumped_mass<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, self.sim.lumped_mass())
    }
}

/// Columns of the step report, in order.
#[pyfunction]
pub(crate) fn report_columns() -> Vec<&'static str> {
    StepReport::COLUMNS.to_vec()
}
