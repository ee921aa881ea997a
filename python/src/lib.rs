//! `sparse_mpm._core`: the Rust side of the Python package `sparse_mpm`.
//!
//! Arrays cross the boundary as NumPy arrays and are copied both ways (inputs into the
//! library's own `Vec<f64>`, outputs into new NumPy arrays). The sparse operators leave as
//! their compressed-column arrays; `sparse_mpm/__init__.py` wraps them in
//! `scipy.sparse.csc_array`. Every library error becomes `sparse_mpm.MpmError` (a
//! `ValueError`) with the library's message; no input reaches a panic.

use numpy::{AllowTypeChange, PyArray1, PyArrayLike1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use sparse_mpm::limits::{prepare_run, Limits};
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Simulation, StepReport};
use sparse_mpm::{mass, Grid, NodeOrder, Operator, Operators, Particles, ShapeFunction};
use std::path::PathBuf;

pyo3::create_exception!(
    _core,
    MpmError,
    PyValueError,
    "An error of the sparse-mpm library (bad grid, particle outside the grid, invalid scene, \
     singular mass matrix …), with the library's message naming the particle, node or key."
);

/// Most grid nodes a grid made from Python may have (2²⁸: a nodal vector is then 2 GiB).
const MAX_NODES: usize = 1 << 28;

fn mpm_err(e: sparse_mpm::MpmError) -> PyErr {
    MpmError::new_err(e.to_string())
}

fn mpm_msg(msg: impl Into<String>) -> PyErr {
    MpmError::new_err(msg.into())
}

/// A 1-D float64 array-like as a vector (copied).
fn to_vec(a: &PyArrayLike1<'_, f64, AllowTypeChange>) -> Vec<f64> {
    match a.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => a.as_array().iter().copied().collect(),
    }
}

fn f64_array<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

fn index_array<'py>(py: Python<'py>, v: &[usize]) -> Bound<'py, PyArray1<i64>> {
    PyArray1::from_vec(py, v.iter().map(|&i| i as i64).collect())
}

fn order_name(order: NodeOrder) -> &'static str {
    match order {
        NodeOrder::XFastest => "x_fastest",
        NodeOrder::YFastest => "y_fastest",
    }
}

/// A Python value (dict, list, tuple, str, bool, int, float) as a TOML value.
fn to_toml(obj: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        let i: i64 = obj
            .extract()
            .map_err(|_| mpm_msg(format!("{key}: integer {obj} does not fit in 64 bits")))?;
        return Ok(toml::Value::Integer(i));
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(obj.extract()?));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(obj.extract()?));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut table = toml::map::Map::new();
        for (k, v) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| mpm_msg(format!("{key}: dictionary keys must be strings, found {k}")))?;
            let sub = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            table.insert(k, to_toml(&v, &sub)?);
        }
        return Ok(toml::Value::Table(table));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, v) in obj.try_iter()?.enumerate() {
            items.push(to_toml(&v?, &format!("{key}[{i}]"))?);
        }
        return Ok(toml::Value::Array(items));
    }
    // NumPy scalars and arrays: their Python equivalents.
    if obj.hasattr("tolist")? {
        return to_toml(&obj.call_method0("tolist")?, key);
    }
    Err(mpm_msg(format!(
        "{}: a value of type {} has no TOML form",
        if key.is_empty() { "scene" } else { key },
        obj.get_type().name()?
    )))
}

fn parse_shape(shape: &Bound<'_, PyAny>) -> PyResult<ShapeFunction> {
    let value = to_toml(shape, "shape")?;
    let shape: ShapeFunction = value.try_into().map_err(|e: toml::de::Error| {
        mpm_msg(format!(
            "shape: {} (expected \"linear\", \"quadratic_bspline\", \"cubic_bspline\" or {{\"gimp\" = {{ half_width = … }}}})",
            e.message().trim()
        ))
    })?;
    shape.validate().map_err(mpm_err)?;
    Ok(shape)
}

/// Uniform background grid: origin, cell size `[hx, hy]` and `[cx, cy]` cells, nodes numbered
/// x-fastest (`id = i + j (cx+1)`) unless made by `Grid.from_node_coordinates`.
#[pyclass(name = "Grid", module = "sparse_mpm._core", frozen)]
struct PyGrid {
    inner: Grid,
}

#[pymethods]
impl PyGrid {
    #[new]
    #[pyo3(signature = (origin, cell_size, cells, node_order = "x_fastest"))]
    fn new(origin: [f64; 2], cell_size: [f64; 2], cells: [i64; 2], node_order: &str) -> PyResult<Self> {
        let mut c = [0usize; 2];
        for (axis, name) in ["x", "y"].iter().enumerate() {
            if cells[axis] < 1 {
                return Err(mpm_msg(format!(
                    "invalid grid: the grid needs at least one cell along {name} (cells = {:?})",
                    cells
                )));
            }
            c[axis] = cells[axis] as usize;
        }
        let nodes = (c[0] as u128 + 1) * (c[1] as u128 + 1);
        if nodes > MAX_NODES as u128 {
            return Err(mpm_msg(format!(
                "invalid grid: {} × {} cells give {nodes} nodes, more than the {MAX_NODES} a grid made from Python may have",
                c[0], c[1]
            )));
        }
        let order = match node_order {
            "x_fastest" => NodeOrder::XFastest,
            "y_fastest" => NodeOrder::YFastest,
            other => {
                return Err(mpm_msg(format!(
                    "node_order = {other:?}: expected \"x_fastest\" or \"y_fastest\""
                )))
            }
        };
        let grid = Grid::new(origin, cell_size, c).map_err(mpm_err)?.with_node_order(order);
        Ok(PyGrid { inner: grid })
    }

    /// The grid whose nodes are at `(x_g[k], y_g[k])`, with its node order (x- or y-fastest)
    /// recovered from the lists; an error names the node out of place.
    #[staticmethod]
    fn from_node_coordinates(
        x_g: PyArrayLike1<'_, f64, AllowTypeChange>,
        y_g: PyArrayLike1<'_, f64, AllowTypeChange>,
    ) -> PyResult<Self> {
        let grid = Grid::from_node_coordinates(&to_vec(&x_g), &to_vec(&y_g)).map_err(mpm_err)?;
        Ok(PyGrid { inner: grid })
    }

    #[getter]
    fn origin(&self) -> (f64, f64) {
        let o = self.inner.origin();
        (o[0], o[1])
    }
    #[getter]
    fn cell_size(&self) -> (f64, f64) {
        let h = self.inner.cell_size();
        (h[0], h[1])
    }
    #[getter]
    fn cells(&self) -> (usize, usize) {
        let c = self.inner.cells();
        (c[0], c[1])
    }
    #[getter]
    fn num_nodes(&self) -> usize {
        self.inner.num_nodes()
    }
    #[getter]
    fn node_order(&self) -> &'static str {
        order_name(self.inner.node_order())
    }
    /// x coordinates of the nodes, in node order (a new array).
    fn node_x<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.node_x())
    }
    /// y coordinates of the nodes, in node order (a new array).
    fn node_y<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.node_y())
    }
    fn __repr__(&self) -> String {
        let (o, h, c) = (self.inner.origin(), self.inner.cell_size(), self.inner.cells());
        format!(
            "Grid(origin=({}, {}), cell_size=({}, {}), cells=({}, {}), node_order={:?})",
            o[0],
            o[1],
            h[0],
            h[1],
            c[0],
            c[1],
            order_name(self.inner.node_order())
        )
    }
}

/// Particle state: positions, masses, volumes, velocities (copied from the arrays given).
#[pyclass(name = "Particles", module = "sparse_mpm._core", frozen)]
struct PyParticles {
    inner: Particles,
}

#[pymethods]
impl PyParticles {
    #[new]
    #[pyo3(signature = (x, y, mass, volume, vx = None, vy = None))]
    fn new(
        x: PyArrayLike1<'_, f64, AllowTypeChange>,
        y: PyArrayLike1<'_, f64, AllowTypeChange>,
        mass: PyArrayLike1<'_, f64, AllowTypeChange>,
        volume: PyArrayLike1<'_, f64, AllowTypeChange>,
        vx: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
        vy: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
    ) -> PyResult<Self> {
        let mut p = Particles::new(to_vec(&x), to_vec(&y), to_vec(&mass), to_vec(&volume)).map_err(mpm_err)?;
        if vx.is_some() || vy.is_some() {
            let n = p.len();
            let vx = vx.map(|a| to_vec(&a)).unwrap_or_else(|| vec![0.0; n]);
            let vy = vy.map(|a| to_vec(&a)).unwrap_or_else(|| vec![0.0; n]);
            p = p.with_velocity(vx, vy).map_err(mpm_err)?;
        }
        Ok(PyParticles { inner: p })
    }
    fn __len__(&self) -> usize {
        self.inner.len()
    }
    /// The particle fields as a dict of new float64 arrays.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        particles_dict(py, &self.inner)
    }
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.x)
    }
    #[getter]
    fn y<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.y)
    }
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.mass)
    }
    #[getter]
    fn volume<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.volume)
    }
    #[getter]
    fn vx<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.vx)
    }
    #[getter]
    fn vy<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.vy)
    }
    fn __repr__(&self) -> String {
        format!("Particles(<{} particles>)", self.inner.len())
    }
}

fn particles_dict<'py>(py: Python<'py>, p: &Particles) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let fields: [(&str, &Vec<f64>); 15] = [
        ("x", &p.x),
        ("y", &p.y),
        ("vx", &p.vx),
        ("vy", &p.vy),
        ("mass", &p.mass),
        ("volume", &p.volume),
        ("sxx", &p.sxx),
        ("syy", &p.syy),
        ("sxy", &p.sxy),
        ("bx", &p.bx),
        ("by", &p.by),
        ("fxx", &p.fxx),
        ("fxy", &p.fxy),
        ("fyx", &p.fyx),
        ("fyy", &p.fyy),
    ];
    for (k, v) in fields {
        d.set_item(k, f64_array(py, v))?;
    }
    d.set_item("body", index_array(py, &p.body))?;
    d.set_item("id", index_array(py, &p.id))?;
    Ok(d)
}

/// N, Gx, Gy (nodes × particles) at the particles' positions, in compressed-column form with
/// one shared pattern.
#[pyclass(name = "Operators", module = "sparse_mpm._core", frozen)]
struct PyOperators {
    inner: Operators,
}

fn operator(name: &str) -> PyResult<Operator> {
    match name {
        "N" => Ok(Operator::N),
        "Gx" => Ok(Operator::Gx),
        "Gy" => Ok(Operator::Gy),
        other => Err(mpm_msg(format!("operator {other:?}: expected \"N\", \"Gx\" or \"Gy\""))),
    }
}

#[pymethods]
impl PyOperators {
    /// `N_Ip = S_I(x_p)`, `Gx_Ip = ∂S_I/∂x (x_p)`, `Gy_Ip = ∂S_I/∂y (x_p)`.
    #[staticmethod]
    #[pyo3(signature = (grid, particles, shape = None))]
    fn assemble(
        py: Python<'_>,
        grid: &PyGrid,
        particles: &PyParticles,
        shape: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let shape = match shape {
            Some(s) => parse_shape(s)?,
            None => ShapeFunction::Linear,
        };
        let (g, p) = (&grid.inner, &particles.inner);
        let ops = py.detach(|| {
            let ops = Operators::assemble(g, shape, p)?;
            ops.col_offsets(); // build the CSC arrays here, without the GIL
            Ok::<_, sparse_mpm::MpmError>(ops)
        });
        Ok(PyOperators {
            inner: ops.map_err(mpm_err)?,
        })
    }
    #[getter]
    fn num_nodes(&self) -> usize {
        self.inner.num_nodes()
    }
    #[getter]
    fn num_particles(&self) -> usize {
        self.inner.num_particles()
    }
    #[getter]
    fn nnz(&self) -> usize {
        self.inner.nnz()
    }
    #[getter]
    fn shape_function(&self) -> &'static str {
        self.inner.shape_function().name()
    }
    /// CSC column offsets (length P + 1), int64, a copy.
    fn col_offsets<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        index_array(py, self.inner.col_offsets())
    }
    /// CSC row indices (node numbers, ascending in each column), int64, a copy.
    fn row_indices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        index_array(py, self.inner.row_indices())
    }
    /// CSC values of "N", "Gx" or "Gy", aligned with `row_indices()`, a copy.
    fn values<'py>(&self, py: Python<'py>, op: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(f64_array(py, self.inner.values(operator(op)?)))
    }
}

fn check_masses(ops: &Operators, m: &[f64]) -> PyResult<()> {
    if m.len() != ops.num_particles() {
        return Err(mpm_err(sparse_mpm::MpmError::LengthMismatch {
            field: "m",
            expected: ops.num_particles(),
            found: m.len(),
        }));
    }
    Ok(())
}

/// `m_L = N m`: the lumped (nodal) mass, one entry per node.
#[pyfunction]
fn lumped_mass<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: PyArrayLike1<'_, f64, AllowTypeChange>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = to_vec(&m);
    check_masses(&ops.inner, &m)?;
    Ok(PyArray1::from_vec(py, mass::lumped_mass(&ops.inner, &m)))
}

/// `M = N diag(m) Nᵀ` as CSC arrays `(col_offsets, row_indices, values, num_nodes)`.
#[pyfunction]
fn consistent_mass_csc<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: PyArrayLike1<'_, f64, AllowTypeChange>,
) -> PyResult<Bound<'py, PyTuple>> {
    let m = to_vec(&m);
    check_masses(&ops.inner, &m)?;
    let inner = &ops.inner;
    let mc = py.detach(|| mass::consistent_mass(inner, &m));
    (
        index_array(py, mc.col_offsets()),
        index_array(py, mc.row_indices()),
        f64_array(py, mc.values()),
        mc.nrows(),
    )
        .into_pyobject(py)
}

/// An explicit MPM simulation built from a scene (TOML file, TOML text or dict).
#[pyclass(name = "Simulation", module = "sparse_mpm._core")]
struct PySimulation {
    sim: Simulation,
    scene: Scene,
    /// Steps land on multiples of this interval (as `mpm run` lands on snapshot times).
    land_every: Option<f64>,
    next_landing: f64,
}

fn report_dict<'py>(py: Python<'py>, r: &StepReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in StepReport::COLUMNS.iter().zip(r.values()) {
        d.set_item(*k, v)?;
    }
    Ok(d)
}

impl PySimulation {
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

/// The grid, particles and operators of a scene file's initial configuration, as `mpm
/// matrices` assembles them.
#[pyfunction]
fn scene_operators(py: Python<'_>, path: PathBuf) -> PyResult<(PyGrid, PyParticles, PyOperators)> {
    let scene = Scene::load(&path).map_err(mpm_err)?;
    let limits = Limits::default();
    let estimate = sparse_mpm::limits::estimate_scene(&scene);
    sparse_mpm::limits::check(&estimate, &limits, &scene).map_err(mpm_err)?;
    let grid = scene.grid().map_err(mpm_err)?;
    let particles = scene.particles().map_err(mpm_err)?;
    let shape = scene.schemes.shape;
    let ops = py
        .detach(|| {
            let ops = Operators::assemble(&grid, shape, &particles)?;
            ops.col_offsets();
            Ok::<_, sparse_mpm::MpmError>(ops)
        })
        .map_err(mpm_err)?;
    Ok((
        PyGrid { inner: grid },
        PyParticles { inner: particles },
        PyOperators { inner: ops },
    ))
}

/// Columns of the step report, in order.
#[pyfunction]
fn report_columns() -> Vec<&'static str> {
    StepReport::COLUMNS.to_vec()
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MpmError", m.py().get_type::<MpmError>())?;
    m.add_class::<PyGrid>()?;
    m.add_class::<PyParticles>()?;
    m.add_class::<PyOperators>()?;
    m.add_class::<PySimulation>()?;
    m.add_function(wrap_pyfunction!(lumped_mass, m)?)?;
    m.add_function(wrap_pyfunction!(consistent_mass_csc, m)?)?;
    m.add_function(wrap_pyfunction!(report_columns, m)?)?;
    m.add_function(wrap_pyfunction!(scene_operators, m)?)?;
    Ok(())
}
