//! `sparse_mpm._core`: the Rust side of the Python package `sparse_mpm`.
//!
//! Arrays cross the boundary as NumPy arrays and are copied both ways (inputs into the
//! library's own `Vec<f64>`, outputs into new NumPy arrays); inputs are checked first
//! (`inputs`: real numbers only, lengths before anything is copied, finite values, positive
//! masses and volumes). The sparse operators leave as their compressed-column arrays;
//! `sparse_mpm/__init__.py` wraps them in `scipy.sparse.csc_array`. Every library error
//! becomes `sparse_mpm.MpmError` (a `ValueError`) with the library's message; no input reaches
//! a panic.
//!
//! The modules: `grid` (`Grid`, `Particles`), `operators` (`Operators`, the lumped and
//! consistent mass, a scene's operators), `step` (the transfers and forces of one step, mass
//! diagnostics, the critical time step, `explicit_step`), `simulation` (`Simulation`, the
//! report columns), `choices` (Python values read as TOML, bounded in depth and size, shape
//! functions, mass schemes and plane conditions), `inputs` (the checks of the arrays given) and
//! `study` (a study planned, run in shares and merged: `sparse_mpm.study`).
//! This file holds the error type, the array conversions out and the module's registration.

mod choices;
mod grid;
mod inputs;
mod operators;
mod simulation;
mod step;
mod study;

use grid::{PyGrid, PyParticles};
use numpy::PyArray1;
use operators::{consistent_mass_csc, lumped_mass, scene_operators, PyOperators};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use simulation::{report_columns, PySimulation};
use step::{critical_time_step, dispersion, explicit_step, external_force, internal_force, mass_diagnostics, momentum};

pyo3::create_exception!(
    _core,
    MpmError,
    PyValueError,
    "An error of the sparse-mpm library (bad grid, particle outside the grid, invalid scene, \
     singular mass matrix …), with the library's message naming the particle, node or key."
);

/// A library error as `MpmError`, with the library's message.
fn mpm_err(e: sparse_mpm::MpmError) -> PyErr {
    MpmError::new_err(e.to_string())
}

/// An `MpmError` with the message given (an argument the binding checks itself).
fn mpm_msg(msg: impl Into<String>) -> PyErr {
    MpmError::new_err(msg.into())
}

/// A new float64 NumPy array holding a copy of `v`.
fn f64_array<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

/// A new int64 NumPy array holding `v` (offsets, node numbers, bodies, ids).
fn index_array<'py>(py: Python<'py>, v: &[usize]) -> Bound<'py, PyArray1<i64>> {
    PyArray1::from_vec(py, v.iter().map(|&i| i as i64).collect())
}

/// `a` made read-only (`a.flags.writeable = False`) and returned: an array that is cached and
/// handed out again must not be changed behind the cache's back.
fn read_only<'py, T: numpy::Element>(a: Bound<'py, PyArray1<T>>) -> PyResult<Bound<'py, PyArray1<T>>> {
    a.getattr("flags")?.setattr("writeable", false)?;
    Ok(a)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MpmError", m.py().get_type::<MpmError>())?;
    // The version of this package (python/Cargo.toml, the same in python/pyproject.toml).
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
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
    m.add_function(wrap_pyfunction!(dispersion, m)?)?;
    m.add_function(wrap_pyfunction!(critical_time_step, m)?)?;
    m.add_function(wrap_pyfunction!(explicit_step, m)?)?;
    m.add_function(wrap_pyfunction!(study::study_plan, m)?)?;
    m.add_function(wrap_pyfunction!(study::study_run, m)?)?;
    m.add_function(wrap_pyfunction!(study::study_merge, m)?)?;
    Ok(())
}
