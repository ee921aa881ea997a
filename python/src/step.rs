//! One explicit step and its parts as functions: the grid momentum, the external and internal
//! forces, the mass diagnostics, the critical time step and `explicit_step` with every
//! intermediate of its record.

use crate::choices::{mass_scheme, parse_shape, plane_condition};
use crate::grid::{PyGrid, PyParticles};
use crate::inputs::Sign::{Any, Positive};
use crate::operators::{masses, particle_fields, PyOperators};
use crate::{f64_array, index_array, mpm_err, mpm_msg};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sparse_mpm::material::LinearElastic;
use sparse_mpm::step::{PositionUpdate, StepOptions};
use sparse_mpm::transfer::VectorField;
use sparse_mpm::{mass, step, stiffness, transfer, ShapeFunction};

/// The x and y components of a nodal vector field.
type Pair<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

/// The two components of a nodal vector field, as new arrays.
fn vector_pair<'py>(py: Python<'py>, f: &VectorField) -> Pair<'py> {
    (f64_array(py, &f.x), f64_array(py, &f.y))
}

/// `q = N (m ∘ v)`: grid momentum `(qx, qy)`.
#[pyfunction]
pub(crate) fn momentum<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: &Bound<'_, PyAny>,
    vx: &Bound<'_, PyAny>,
    vy: &Bound<'_, PyAny>,
) -> PyResult<Pair<'py>> {
    let [m, vx, vy] = particle_fields(&ops.inner, [("m", m, Positive), ("vx", vx, Any), ("vy", vy, Any)])?;
    Ok(vector_pair(py, &transfer::momentum(&ops.inner, &m, &vx, &vy)))
}

/// `f_ext = N (m ∘ b)`: external grid force `(fx, fy)` from body forces per unit mass.
#[pyfunction]
pub(crate) fn external_force<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: &Bound<'_, PyAny>,
    bx: &Bound<'_, PyAny>,
    by: &Bound<'_, PyAny>,
) -> PyResult<Pair<'py>> {
    let [m, bx, by] = particle_fields(&ops.inner, [("m", m, Positive), ("bx", bx, Any), ("by", by, Any)])?;
    Ok(vector_pair(py, &transfer::external_force(&ops.inner, &m, &bx, &by)))
}

/// `f_int,x = −(Gx (V ∘ σxx) + Gy (V ∘ σxy))`, `f_int,y = −(Gx (V ∘ σxy) + Gy (V ∘ σyy))`.
#[pyfunction]
pub(crate) fn internal_force<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    volume: &Bound<'_, PyAny>,
    sxx: &Bound<'_, PyAny>,
    syy: &Bound<'_, PyAny>,
    sxy: &Bound<'_, PyAny>,
) -> PyResult<Pair<'py>> {
    let [v, sxx, syy, sxy] = particle_fields(
        &ops.inner,
        [
            ("volume", volume, Positive),
            ("sxx", sxx, Any),
            ("syy", syy, Any),
            ("sxy", sxy, Any),
        ],
    )?;
    Ok(vector_pair(
        py,
        &transfer::internal_force(&ops.inner, &v, &sxx, &syy, &sxy),
    ))
}

/// `MassDiagnostics::compute(ops, m, MassOptions::both(scheme))` as a dict of its fields.
#[pyfunction]
#[pyo3(signature = (ops, m, mass = "lumped"))]
pub(crate) fn mass_diagnostics<'py>(
    py: Python<'py>,
    ops: &PyOperators,
    m: &Bound<'_, PyAny>,
    mass: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let options = mass::MassOptions::both(mass_scheme(mass)?);
    let m = masses(&ops.inner, m)?;
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

/// The discrete dispersion relation `c_h/c` against `θ = kh` (`verification::dispersion`):
/// `(theta, c_ratio)` arrays, at `θ = π j / samples` or, with `cells`, at the wavenumbers of a
/// periodic bar of that many cells.
#[pyfunction]
#[pyo3(signature = (shape, mass, acceleration_mass=None, particles_per_cell=2, samples=64, cells=None))]
pub(crate) fn dispersion<'py>(
    py: Python<'py>,
    shape: &Bound<'_, PyAny>,
    mass: &str,
    acceleration_mass: Option<&str>,
    particles_per_cell: usize,
    samples: usize,
    cells: Option<usize>,
) -> PyResult<Pair<'py>> {
    let shape = parse_shape(shape)?;
    let velocity = mass_scheme(mass)?;
    let acceleration = match acceleration_mass {
        Some(a) => mass_scheme(a)?,
        None => velocity,
    };
    let curve = sparse_mpm_study::verification::dispersion::dispersion(
        shape,
        velocity,
        acceleration,
        particles_per_cell,
        samples,
        cells,
    )
    .map_err(mpm_err)?;
    let theta: Vec<f64> = curve.iter().map(|p| p.theta).collect();
    let ratio: Vec<f64> = curve.iter().map(|p| p.c_ratio).collect();
    Ok((f64_array(py, &theta), f64_array(py, &ratio)))
}

/// `Δt_crit = 2 / ω_max`, `ω²_max = λ_max(M⁻¹ K)` (`stiffness::critical_time_step`, the
/// acceleration role of `GridMass::new(ops, m, MassOptions::both(scheme))`).
#[pyfunction]
#[pyo3(signature = (ops, m, volume, youngs_modulus, poisson_ratio, plane = "stress", mass = "lumped"))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn critical_time_step(
    py: Python<'_>,
    ops: &PyOperators,
    m: &Bound<'_, PyAny>,
    volume: &Bound<'_, PyAny>,
    youngs_modulus: f64,
    poisson_ratio: f64,
    plane: &str,
    mass: &str,
) -> PyResult<f64> {
    let options = mass::MassOptions::both(mass_scheme(mass)?);
    let material = LinearElastic::new(youngs_modulus, poisson_ratio, plane_condition(plane)?).map_err(mpm_err)?;
    let [m, volume] = particle_fields(&ops.inner, [("m", m, Positive), ("volume", volume, Positive)])?;
    let inner = &ops.inner;
    py.detach(|| {
        let grid_mass = mass::GridMass::new(inner, &m, &options, &mass::Constraints::none())?;
        stiffness::critical_time_step(inner, &volume, &material, &grid_mass, mass::Role::Acceleration)
    })
    .map_err(mpm_err)
}

/// A mass solve's report (scheme, outcome, node, iterations, relative residual) as a dict.
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
pub(crate) fn explicit_step<'py>(
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
    d.set_item("particles", PyParticles::wrap(after))?;
    Ok(d)
}
