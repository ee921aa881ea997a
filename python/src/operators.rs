//! `Operators` (N, Gx, Gy in compressed-column form), the checks of per-particle arrays
//! against them (real, one per particle, finite, masses positive), the lumped and consistent
//! mass, and the operators of a scene file.

use crate::choices::parse_shape;
use crate::grid::{PyGrid, PyParticles};
use crate::inputs::{particle_vec, Sign};
use crate::{f64_array, index_array, mpm_err, mpm_msg};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use sparse_mpm::limits::Limits;
use sparse_mpm::scene::Scene;
use sparse_mpm::{mass, Operator, Operators, ShapeFunction};
use std::path::PathBuf;

/// N, Gx, Gy (nodes × particles) at the particles' positions, in compressed-column form with
/// one shared pattern.
#[pyclass(name = "Operators", module = "sparse_mpm._core", frozen)]
pub(crate) struct PyOperators {
    pub(crate) inner: Operators,
}

/// The operator named `"N"`, `"Gx"` or `"Gy"`.
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

/// The particle masses `m` of `ops`: real, one per particle, finite and positive.
pub(crate) fn masses(ops: &Operators, m: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    particle_vec(m, "m", ops.num_particles(), Sign::Positive)
}

/// The particle fields `(name, array, sign)` of `ops`, each real, one entry per particle
/// (checked before it is copied), finite, and positive with [`Sign::Positive`]; copied.
pub(crate) fn particle_fields<const K: usize>(
    ops: &Operators,
    fields: [(&'static str, &Bound<'_, PyAny>, Sign); K],
) -> PyResult<[Vec<f64>; K]> {
    let mut out: [Vec<f64>; K] = std::array::from_fn(|_| Vec::new());
    for (slot, (name, a, sign)) in out.iter_mut().zip(fields) {
        *slot = particle_vec(a, name, ops.num_particles(), sign)?;
    }
    Ok(out)
}

/// `m_L = N m`: the lumped (nodal) mass, one entry per node; `m` one finite positive mass per
/// particle (integers are taken as floats, a complex array is a TypeError).
#[pyfunction]
pub(crate) fn lumped_mass<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: &Bound<'_, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = masses(&ops.inner, m)?;
    let n = ops.inner.num_nodes();
    // The node vector and its copy into the array, refused where this process cannot have
    // them (an allocation that fails aborts the interpreter).
    sparse_mpm::limits::ensure_memory(16.0 * n as f64, || format!("lumped_mass on {n} nodes")).map_err(mpm_err)?;
    Ok(PyArray1::from_vec(py, mass::lumped_mass(&ops.inner, &m)))
}

/// `M = N diag(m) Nᵀ` as CSC arrays `(col_offsets, row_indices, values, num_nodes)`.
#[pyfunction]
pub(crate) fn consistent_mass_csc<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: &Bound<'_, PyAny>,
) -> PyResult<Bound<'py, PyTuple>> {
    let m = masses(&ops.inner, m)?;
    let inner = &ops.inner;
    // Column offsets per node and the couplings of every particle's stencil (at most
    // support⁴ each), twice (the matrix and the arrays it is copied into).
    let (n, s) = (inner.num_nodes() as f64, inner.support() as f64);
    let needed = 2.0 * (8.0 * (n + 1.0) + 16.0 * s.powi(4) * inner.num_particles() as f64);
    sparse_mpm::limits::ensure_memory(needed, || {
        format!(
            "consistent_mass on {} nodes and {} particles",
            inner.num_nodes(),
            inner.num_particles()
        )
    })
    .map_err(mpm_err)?;
    let mc = py.detach(|| mass::consistent_mass(inner, &m));
    (
        index_array(py, mc.col_offsets()),
        index_array(py, mc.row_indices()),
        f64_array(py, mc.values()),
        mc.nrows(),
    )
        .into_pyobject(py)
}

/// The grid, particles and operators of a scene file's initial configuration, as `mpm
/// matrices` assembles them.
#[pyfunction]
pub(crate) fn scene_operators(py: Python<'_>, path: PathBuf) -> PyResult<(PyGrid, PyParticles, PyOperators)> {
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
        PyParticles::wrap(particles),
        PyOperators { inner: ops },
    ))
}
