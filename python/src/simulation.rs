//! `Simulation`: a scene (file, TOML text or dict) run step by step, its step reports as dicts
//! or as rows.

use crate::choices::to_toml;
use crate::grid::{particles_dict, PyGrid};
use crate::operators::PyOperators;
use crate::{f64_array, mpm_err, mpm_msg};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sparse_mpm::limits::{prepare_run, Limits};
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Simulation, StepReport};
use std::path::PathBuf;

/// An explicit MPM simulation built from a scene (TOML file, TOML text or dict).
#[pyclass(name = "Simulation", module = "sparse_mpm._core")]
pub(crate) struct PySimulation {
    sim: Simulation,
    scene: Scene,
    /// Steps land on multiples of this interval (as `mpm run` lands on snapshot times).
    land_every: Option<f64>,
    next_landing: f64,
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
        let interval = scene.snapshot_interval();
        let land_every = (interval.is_finite() && interval > 0.0).then_some(interval);
        Ok(PySimulation {
            sim,
            scene,
            land_every,
            next_landing: interval,
        })
    }

    /// One step landing on the next landing time (if any) and on `end`.
    fn advance(&mut self, end: f64) -> sparse_mpm::Result<StepReport> {
        let target = match self.land_every {
            Some(_) => self.next_landing.min(end),
            None => end,
        };
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
    /// The simulation of a scene file; particle files are read from its folder.
    #[staticmethod]
    #[pyo3(signature = (path, allow_large = false))]
    fn from_scene(path: PathBuf, allow_large: bool) -> PyResult<Self> {
        Self::build(Scene::load(&path).map_err(mpm_err)?, allow_large)
    }

    /// The simulation of a scene given as TOML text; relative particle files are read from
    /// `base_dir` (none without it).
    #[staticmethod]
    #[pyo3(signature = (text, base_dir = None, allow_large = false))]
    fn from_toml(text: &str, base_dir: Option<PathBuf>, allow_large: bool) -> PyResult<Self> {
        let mut scene = Scene::from_toml_str(text).map_err(mpm_err)?;
        scene.base_dir = base_dir;
        Self::build(scene, allow_large)
    }

    /// The simulation of a scene given as a dict with the keys of a scene file.
    #[staticmethod]
    #[pyo3(signature = (scene, base_dir = None, allow_large = false))]
    fn from_dict(scene: &Bound<'_, PyDict>, base_dir: Option<PathBuf>, allow_large: bool) -> PyResult<Self> {
        let value = to_toml(scene.as_any(), "")?;
        let text = toml::to_string(&value).map_err(|e| mpm_msg(format!("scene: cannot be written as TOML: {e}")))?;
        Self::from_toml(&text, base_dir, allow_large)
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
    /// The scene's end time (`[time] end`).
    #[getter]
    fn end_time(&self) -> f64 {
        self.scene.time.end
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
            self.next_landing = ((self.sim.time() / e).floor() + 1.0) * e;
        }
        self.land_every = every;
        Ok(())
    }
    /// The scene as TOML text.
    fn scene_toml(&self) -> PyResult<String> {
        self.scene.to_toml_string().map_err(mpm_err)
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
    /// (rows × 25), and the number of rows.
    fn run_rows<'py>(&mut self, py: Python<'py>, until: f64) -> PyResult<(Bound<'py, PyArray1<f64>>, usize)> {
        if !until.is_finite() {
            return Err(mpm_msg(format!("until = {until}: must be a finite time")));
        }
        let me = &mut *self;
        let (rows, error) = py.detach(|| {
            let mut rows: Vec<f64> = Vec::new();
            let mut error = None;
            while me.sim.time() < until * (1.0 - 1e-12) {
                match me.advance(until) {
                    Ok(r) => rows.extend_from_slice(&r.values()),
                    Err(e) => {
                        error = Some(e);
                        break;
                    }
                }
            }
            (rows, error)
        });
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
