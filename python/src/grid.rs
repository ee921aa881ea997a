//! `Grid` and `Particles`: the background grid and the particle state, copied in from NumPy
//! arrays and out into new ones.

use crate::{f64_array, index_array, mpm_err, mpm_msg, to_vec};
use numpy::{AllowTypeChange, PyArray1, PyArrayLike1};
use pyo3::prelude::*;
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
pub(crate) struct PyParticles {
    pub(crate) inner: Particles,
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
    d.set_item("body", index_array(py, &p.body))?;
    d.set_item("id", index_array(py, &p.id))?;
    Ok(d)
}
