//! `Grid` and `Particles`: the background grid and the particle state, copied in from NumPy
//! arrays and out into new ones.

use crate::inputs::{body_indices, real_vec, Len};
use crate::{f64_array, index_array, mpm_err, mpm_msg, read_only};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyDict;
use sparse_mpm::{Grid, NodeOrder, Particles};

/// Most grid nodes a grid made from Python may have (2²⁸: a nodal vector is then 2 GiB).
const MAX_NODES: usize = 1 << 28;

/// The Python name of a node order (`node_order` of `Grid`).
fn order_name(order: NodeOrder) -> &'static str {
    match order {
        NodeOrder::XFastest => "x_fastest",
        NodeOrder::YFastest => "y_fastest",
    }
}

/// Uniform background grid: origin, cell size `[hx, hy]` and `[cx, cy]` cells, nodes numbered
/// x-fastest (`id = i + j (cx+1)`) unless made by `Grid.from_node_coordinates`.
#[pyclass(name = "Grid", module = "sparse_mpm._core", frozen)]
pub(crate) struct PyGrid {
    pub(crate) inner: Grid,
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
    /// recovered from the lists; an error names the node out of place. The lists hold real
    /// numbers (a complex array is a TypeError) and are at most `MAX_NODES` long (checked
    /// before they are copied).
    #[staticmethod]
    fn from_node_coordinates(x_g: &Bound<'_, PyAny>, y_g: &Bound<'_, PyAny>) -> PyResult<Self> {
        let most = Len::AtMost(MAX_NODES, "nodes", "a grid made from Python may have");
        let (x_g, y_g) = (real_vec(x_g, "x_g", most)?, real_vec(y_g, "y_g", most)?);
        let grid = Grid::from_node_coordinates(&x_g, &y_g).map_err(mpm_err)?;
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

/// The float64 fields of `Particles` with a getter, in the order of `PyParticles::cache`.
const FIELDS: [&str; 11] = ["x", "y", "mass", "volume", "vx", "vy", "sxx", "syy", "sxy", "bx", "by"];

/// Particle state: positions, masses, volumes, velocities, stresses, body forces and bodies
/// (copied from the arrays given). Immutable: each attribute is a read-only array made on
/// first access and handed out again after (no copy per access). Every array as long as `x`
/// (checked before it is copied) and real (integers are taken as floats, a complex array is a
/// TypeError); values finite, masses and volumes positive (`Particles::validate`); `body` whole
/// numbers from 0.
#[pyclass(name = "Particles", module = "sparse_mpm._core", frozen)]
pub(crate) struct PyParticles {
    pub(crate) inner: Particles,
    /// The read-only arrays of `FIELDS`, made on first access.
    cache: [PyOnceLock<Py<PyArray1<f64>>>; 11],
    /// The read-only `body` array, made on first access.
    body: PyOnceLock<Py<PyArray1<i64>>>,
}

impl PyParticles {
    /// `p` as a Python object (nothing copied yet).
    pub(crate) fn wrap(p: Particles) -> Self {
        PyParticles {
            inner: p,
            cache: std::array::from_fn(|_| PyOnceLock::new()),
            body: PyOnceLock::new(),
        }
    }

    /// The read-only array of field `FIELDS[k]` (made on first access).
    fn field<'py>(&self, py: Python<'py>, k: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = &self.inner;
        let v: &[f64] = match FIELDS[k] {
            "x" => &p.x,
            "y" => &p.y,
            "mass" => &p.mass,
            "volume" => &p.volume,
            "vx" => &p.vx,
            "vy" => &p.vy,
            "sxx" => &p.sxx,
            "syy" => &p.syy,
            "sxy" => &p.sxy,
            "bx" => &p.bx,
            _ => &p.by,
        };
        let a = self.cache[k].get_or_try_init(py, || read_only(f64_array(py, v)).map(Bound::unbind))?;
        Ok(a.bind(py).clone())
    }
}

#[pymethods]
impl PyParticles {
    #[new]
    #[pyo3(signature = (x, y, mass, volume, vx = None, vy = None, *, sxx = None, syy = None, sxy = None, bx = None, by = None, body = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        x: &Bound<'_, PyAny>,
        y: &Bound<'_, PyAny>,
        mass: &Bound<'_, PyAny>,
        volume: &Bound<'_, PyAny>,
        vx: Option<&Bound<'_, PyAny>>,
        vy: Option<&Bound<'_, PyAny>>,
        sxx: Option<&Bound<'_, PyAny>>,
        syy: Option<&Bound<'_, PyAny>>,
        sxy: Option<&Bound<'_, PyAny>>,
        bx: Option<&Bound<'_, PyAny>>,
        by: Option<&Bound<'_, PyAny>>,
        body: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        // Every array real and as long as `x` (checked before it is copied); the values are
        // checked by the library (`Particles::validate`: finite, positive masses and volumes).
        let x = real_vec(x, "x", Len::Any)?;
        let n = x.len();
        let each = |a: &Bound<'_, PyAny>, name: &'static str| real_vec(a, name, Len::Exactly(n));
        let mut p = Particles::new(x, each(y, "y")?, each(mass, "mass")?, each(volume, "volume")?).map_err(mpm_err)?;
        let or_zero = |a: Option<&Bound<'_, PyAny>>, name: &'static str| match a {
            Some(a) => each(a, name),
            None => Ok(vec![0.0; n]),
        };
        if vx.is_some() || vy.is_some() {
            p = p
                .with_velocity(or_zero(vx, "vx")?, or_zero(vy, "vy")?)
                .map_err(mpm_err)?;
        }
        if sxx.is_some() || syy.is_some() || sxy.is_some() {
            p = p
                .with_stress(or_zero(sxx, "sxx")?, or_zero(syy, "syy")?, or_zero(sxy, "sxy")?)
                .map_err(mpm_err)?;
        }
        if bx.is_some() || by.is_some() {
            p = p
                .with_body_force(or_zero(bx, "bx")?, or_zero(by, "by")?)
                .map_err(mpm_err)?;
        }
        if let Some(body) = body {
            p.body = body_indices(body, n)?;
        }
        Ok(PyParticles::wrap(p))
    }
    fn __len__(&self) -> usize {
        self.inner.len()
    }
    /// The particle fields as a dict of new (writeable) arrays: the float64 fields, then
    /// `body` and `id` (int64).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        particles_dict(py, &self.inner)
    }
    /// x coordinates of the particles (read-only float64 array, made once).
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 0)
    }
    /// y coordinates of the particles (read-only float64 array, made once).
    #[getter]
    fn y<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 1)
    }
    /// Particle masses m_p > 0 (read-only float64 array, made once).
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 2)
    }
    /// Particle volumes V_p > 0 (read-only float64 array, made once).
    #[getter]
    fn volume<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 3)
    }
    /// x velocities (read-only float64 array, made once).
    #[getter]
    fn vx<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 4)
    }
    /// y velocities (read-only float64 array, made once).
    #[getter]
    fn vy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 5)
    }
    /// Cauchy stress σxx (read-only float64 array, made once).
    #[getter]
    fn sxx<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 6)
    }
    /// Cauchy stress σyy (read-only float64 array, made once).
    #[getter]
    fn syy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 7)
    }
    /// Cauchy stress σxy (read-only float64 array, made once).
    #[getter]
    fn sxy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 8)
    }
    /// Body force per unit mass, x component (read-only float64 array, made once).
    #[getter]
    fn bx<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 9)
    }
    /// Body force per unit mass, y component (read-only float64 array, made once).
    #[getter]
    fn by<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.field(py, 10)
    }
    /// The body each particle belongs to, an index into a simulation's bodies (read-only int64
    /// array, made once; 0 unless given).
    #[getter]
    fn body<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let a = self
            .body
            .get_or_try_init(py, || read_only(index_array(py, &self.inner.body)).map(Bound::unbind))?;
        Ok(a.bind(py).clone())
    }
    fn __repr__(&self) -> String {
        format!("Particles(<{} particles>)", self.inner.len())
    }
}

/// Every field of `p` as a new array in a dict: the float64 fields, then `body` and `id`
/// (int64).
pub(crate) fn particles_dict<'py>(py: Python<'py>, p: &Particles) -> PyResult<Bound<'py, PyDict>> {
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
    // The plastic state, when a body is elastoplastic.
    if p.has_plastic_state() {
        for (k, v) in [
            ("plastic_strain", &p.plastic_strain),
            ("elastic_xx", &p.elastic_xx),
            ("elastic_yy", &p.elastic_yy),
            ("elastic_xy", &p.elastic_xy),
            ("elastic_zz", &p.elastic_zz),
        ] {
            d.set_item(k, f64_array(py, v))?;
        }
    }
    d.set_item("body", index_array(py, &p.body))?;
    d.set_item("id", index_array(py, &p.id))?;
    Ok(d)
}
