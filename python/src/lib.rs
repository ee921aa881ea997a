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
use sparse_mpm::material::{LinearElastic, PlaneCondition};
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Simulation, StepReport};
use sparse_mpm::step::{PositionUpdate, StepOptions};
use sparse_mpm::transfer::VectorField;
use sparse_mpm::{mass, step, stiffness, transfer, Grid, NodeOrder, Operator, Operators, Particles, ShapeFunction};
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
    #[pyo3(signature = (x, y, mass, volume, vx = None, vy = None, *, sxx = None, syy = None, sxy = None, bx = None, by = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        x: PyArrayLike1<'_, f64, AllowTypeChange>,
        y: PyArrayLike1<'_, f64, AllowTypeChange>,
        mass: PyArrayLike1<'_, f64, AllowTypeChange>,
        volume: PyArrayLike1<'_, f64, AllowTypeChange>,
        vx: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
        vy: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
        sxx: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
        syy: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
        sxy: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
        bx: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
        by: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
    ) -> PyResult<Self> {
        let mut p = Particles::new(to_vec(&x), to_vec(&y), to_vec(&mass), to_vec(&volume)).map_err(mpm_err)?;
        let n = p.len();
        let or_zero =
            |a: Option<PyArrayLike1<'_, f64, AllowTypeChange>>| a.map(|a| to_vec(&a)).unwrap_or_else(|| vec![0.0; n]);
        if vx.is_some() || vy.is_some() {
            p = p.with_velocity(or_zero(vx), or_zero(vy)).map_err(mpm_err)?;
        }
        if sxx.is_some() || syy.is_some() || sxy.is_some() {
            p = p
                .with_stress(or_zero(sxx), or_zero(syy), or_zero(sxy))
                .map_err(mpm_err)?;
        }
        if bx.is_some() || by.is_some() {
            p = p.with_body_force(or_zero(bx), or_zero(by)).map_err(mpm_err)?;
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
    #[getter]
    fn sxx<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.sxx)
    }
    #[getter]
    fn syy<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.syy)
    }
    #[getter]
    fn sxy<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.sxy)
    }
    #[getter]
    fn bx<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.bx)
    }
    #[getter]
    fn by<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        f64_array(py, &self.inner.by)
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
    check_particle_field(ops, "m", m)
}

/// An error unless `v` has one entry per particle of `ops`.
fn check_particle_field(ops: &Operators, field: &'static str, v: &[f64]) -> PyResult<()> {
    if v.len() != ops.num_particles() {
        return Err(mpm_err(sparse_mpm::MpmError::LengthMismatch {
            field,
            expected: ops.num_particles(),
            found: v.len(),
        }));
    }
    Ok(())
}

/// The particle fields `(name, array)`, each copied and checked to have one entry per particle.
fn particle_fields<const K: usize>(
    ops: &Operators,
    fields: [(&'static str, PyArrayLike1<'_, f64, AllowTypeChange>); K],
) -> PyResult<[Vec<f64>; K]> {
    let mut out: [Vec<f64>; K] = std::array::from_fn(|_| Vec::new());
    for (slot, (name, a)) in out.iter_mut().zip(fields) {
        let v = to_vec(&a);
        check_particle_field(ops, name, &v)?;
        *slot = v;
    }
    Ok(out)
}

/// The x and y components of a nodal vector field.
type Pair<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

fn vector_pair<'py>(py: Python<'py>, f: &VectorField) -> Pair<'py> {
    (f64_array(py, &f.x), f64_array(py, &f.y))
}

fn mass_scheme(name: &str) -> PyResult<mass::MassScheme> {
    name.parse::<mass::MassScheme>()
        .map_err(|e| mpm_msg(format!("mass = {name:?}: {e}")))
}

fn plane_condition(name: &str) -> PyResult<PlaneCondition> {
    match name {
        "stress" => Ok(PlaneCondition::Stress),
        "strain" => Ok(PlaneCondition::Strain),
        other => Err(mpm_msg(format!("plane = {other:?}: expected \"stress\" or \"strain\""))),
    }
}

/// `q = N (m ∘ v)`: grid momentum `(qx, qy)`.
#[pyfunction]
fn momentum<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: PyArrayLike1<'_, f64, AllowTypeChange>,
    vx: PyArrayLike1<'_, f64, AllowTypeChange>,
    vy: PyArrayLike1<'_, f64, AllowTypeChange>,
) -> PyResult<Pair<'py>> {
    let [m, vx, vy] = particle_fields(&ops.inner, [("m", m), ("vx", vx), ("vy", vy)])?;
    Ok(vector_pair(py, &transfer::momentum(&ops.inner, &m, &vx, &vy)))
}

/// `f_ext = N (m ∘ b)`: external grid force `(fx, fy)` from body forces per unit mass.
#[pyfunction]
fn external_force<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: PyArrayLike1<'_, f64, AllowTypeChange>,
    bx: PyArrayLike1<'_, f64, AllowTypeChange>,
    by: PyArrayLike1<'_, f64, AllowTypeChange>,
) -> PyResult<Pair<'py>> {
    let [m, bx, by] = particle_fields(&ops.inner, [("m", m), ("bx", bx), ("by", by)])?;
    Ok(vector_pair(py, &transfer::external_force(&ops.inner, &m, &bx, &by)))
}

/// `f_int,x = −(Gx (V ∘ σxx) + Gy (V ∘ σxy))`, `f_int,y = −(Gx (V ∘ σxy) + Gy (V ∘ σyy))`.
#[pyfunction]
fn internal_force<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    volume: PyArrayLike1<'_, f64, AllowTypeChange>,
    sxx: PyArrayLike1<'_, f64, AllowTypeChange>,
    syy: PyArrayLike1<'_, f64, AllowTypeChange>,
    sxy: PyArrayLike1<'_, f64, AllowTypeChange>,
) -> PyResult<Pair<'py>> {
    let [v, sxx, syy, sxy] = particle_fields(
        &ops.inner,
        [("volume", volume), ("sxx", sxx), ("syy", syy), ("sxy", sxy)],
    )?;
    Ok(vector_pair(
        py,
        &transfer::internal_force(&ops.inner, &v, &sxx, &syy, &sxy),
    ))
}

/// `MassDiagnostics::compute(ops, m, MassOptions::both(scheme))` as a dict of its fields.
#[pyfunction]
#[pyo3(signature = (ops, m, mass = "lumped"))]
fn mass_diagnostics<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: PyArrayLike1<'_, f64, AllowTypeChange>,
    mass: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let options = mass::MassOptions::both(mass_scheme(mass)?);
    let m = to_vec(&m);
    check_masses(&ops.inner, &m)?;
    let inner = &ops.inner;
    let d = py
        .detach(|| mass::MassDiagnostics::compute(inner, &m, &options))
        .map_err(mpm_err)?;
    let out = PyDict::new(py);
    out.set_item("active_nodes", d.active_nodes)?;
    out.set_item("min_nodal_mass", d.min_nodal_mass)?;
    out.set_item("max_nodal_mass", d.max_nodal_mass)?;
    out.set_item("tiny_mass_nodes", d.tiny_mass_nodes)?;
    out.set_item("nullity_estimate", d.nullity_estimate)?;
    out.set_item("lambda_min_estimate", d.lambda_min_estimate)?;
    out.set_item("condition_number", d.condition_number)?;
    Ok(out)
}

/// `Δt_crit = 2 / ω_max`, `ω²_max = λ_max(M⁻¹ K)` (`stiffness::critical_time_step`, the
/// acceleration role of `GridMass::new(ops, m, MassOptions::both(scheme))`).
#[pyfunction]
#[pyo3(signature = (ops, m, volume, youngs_modulus, poisson_ratio, plane = "stress", mass = "lumped"))]
#[allow(clippy::too_many_arguments)]
fn critical_time_step(
    py: Python<'_>,
    ops: &PyOperators,
    m: PyArrayLike1<'_, f64, AllowTypeChange>,
    volume: PyArrayLike1<'_, f64, AllowTypeChange>,
    youngs_modulus: f64,
    poisson_ratio: f64,
    plane: &str,
    mass: &str,
) -> PyResult<f64> {
    let options = mass::MassOptions::both(mass_scheme(mass)?);
    let material = LinearElastic::new(youngs_modulus, poisson_ratio, plane_condition(plane)?).map_err(mpm_err)?;
    let [m, volume] = particle_fields(&ops.inner, [("m", m), ("volume", volume)])?;
    let inner = &ops.inner;
    py.detach(|| {
        let grid_mass = mass::GridMass::new(inner, &m, &options, &mass::Constraints::none())?;
        stiffness::critical_time_step(inner, &volume, &material, &grid_mass, mass::Role::Acceleration)
    })
    .map_err(mpm_err)
}

fn outcome_dict<'py>(py: Python<'py>, r: &mass::SolveReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("scheme", r.scheme.to_string())?;
    let (outcome, node) = match r.outcome {
        mass::SolveOutcome::Solved => ("solved", None),
        mass::SolveOutcome::FellBackToLumped { node, .. } => ("fell_back_to_lumped", node),
        mass::SolveOutcome::Regularized { node, .. } => ("regularized", node),
    };
    d.set_item("outcome", outcome)?;
    d.set_item("node", node)?;
    d.set_item("iterations", r.iterations)?;
    d.set_item("relative_residual", r.relative_residual)?;
    Ok(d)
}

/// `step::explicit_step` on a copy of `particles`; every intermediate of its `StepRecord` and
/// the particles after the step, as a dict.
#[pyfunction]
#[pyo3(signature = (grid, particles, youngs_modulus, poisson_ratio, dt, plane = "stress", shape = None, mass = "lumped", position_update = "grid_velocity"))]
#[allow(clippy::too_many_arguments)]
fn explicit_step<'py>(
    py: Python<'py>,
    grid: &PyGrid,
    particles: &PyParticles,
    youngs_modulus: f64,
    poisson_ratio: f64,
    dt: f64,
    plane: &str,
    shape: Option<&Bound<'_, PyAny>>,
    mass: &str,
    position_update: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let shape = match shape {
        Some(s) => parse_shape(s)?,
        None => ShapeFunction::Linear,
    };
    let position_update = match position_update {
        "grid_velocity" => PositionUpdate::GridVelocity,
        "trapezoidal" => PositionUpdate::Trapezoidal,
        other => {
            return Err(mpm_msg(format!(
                "position_update = {other:?}: expected \"grid_velocity\" or \"trapezoidal\""
            )))
        }
    };
    let options = StepOptions {
        dt,
        shape,
        mass: mass::MassOptions::both(mass_scheme(mass)?),
        constraints: mass::Constraints::none(),
        position_update,
    };
    let material = LinearElastic::new(youngs_modulus, poisson_ratio, plane_condition(plane)?).map_err(mpm_err)?;
    let mut after = particles.inner.clone();
    let g = &grid.inner;
    let record = py
        .detach(|| step::explicit_step(g, &mut after, &material, &options))
        .map_err(mpm_err)?;
    let d = PyDict::new(py);
    d.set_item("lumped_mass", f64_array(py, record.mass.lumped()))?;
    d.set_item("active_nodes", index_array(py, &record.mass.active_nodes()))?;
    let vectors: [(&str, &VectorField); 6] = [
        ("momentum", &record.momentum),
        ("external_force", &record.external_force),
        ("internal_force", &record.internal_force),
        ("acceleration", &record.acceleration),
        ("grid_velocity", &record.grid_velocity),
        ("updated_grid_velocity", &record.updated_grid_velocity),
    ];
    for (k, f) in vectors {
        d.set_item(format!("{k}_x"), f64_array(py, &f.x))?;
        d.set_item(format!("{k}_y"), f64_array(py, &f.y))?;
    }
    let l = &record.velocity_gradient;
    for (k, v) in [("xx", &l.xx), ("xy", &l.xy), ("yx", &l.yx), ("yy", &l.yy)] {
        d.set_item(format!("velocity_gradient_{k}"), f64_array(py, v))?;
    }
    let r = &record.strain_rate;
    for (k, v) in [("xx", &r.xx), ("yy", &r.yy), ("xy", &r.xy)] {
        d.set_item(format!("strain_rate_{k}"), f64_array(py, v))?;
    }
    d.set_item("velocity_report", outcome_dict(py, &record.velocity_report)?)?;
    d.set_item("acceleration_report", outcome_dict(py, &record.acceleration_report)?)?;
    let ops = record.operators;
    ops.col_offsets();
    d.set_item("operators", PyOperators { inner: ops })?;
    d.set_item("particles", PyParticles { inner: after })?;
    Ok(d)
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
    m.add_function(wrap_pyfunction!(momentum, m)?)?;
    m.add_function(wrap_pyfunction!(external_force, m)?)?;
    m.add_function(wrap_pyfunction!(internal_force, m)?)?;
    m.add_function(wrap_pyfunction!(mass_diagnostics, m)?)?;
    m.add_function(wrap_pyfunction!(critical_time_step, m)?)?;
    m.add_function(wrap_pyfunction!(explicit_step, m)?)?;
    Ok(())
}
