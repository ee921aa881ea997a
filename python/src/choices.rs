//! Python values read as the library's choices: any value as a TOML value (scenes given as
//! dicts, shape functions given as dicts or strings), the shape function, the mass scheme and
//! the plane condition, each error naming the argument.

use crate::{mpm_err, mpm_msg};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use sparse_mpm::material::PlaneCondition;
use sparse_mpm::{mass, ShapeFunction};

/// A Python value (dict, list, tuple, str, bool, int, float) as a TOML value.
pub(crate) fn to_toml(obj: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
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

/// The shape function given as a string or a dict (its scene-file form), validated.
pub(crate) fn parse_shape(shape: &Bound<'_, PyAny>) -> PyResult<ShapeFunction> {
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

/// The mass scheme named by `mass` (`"lumped"`, `"blended:0.5"`, …).
pub(crate) fn mass_scheme(name: &str) -> PyResult<mass::MassScheme> {
    name.parse::<mass::MassScheme>()
        .map_err(|e| mpm_msg(format!("mass = {name:?}: {e}")))
}

/// Plane stress (`"stress"`) or plane strain (`"strain"`).
pub(crate) fn plane_condition(name: &str) -> PyResult<PlaneCondition> {
    match name {
        "stress" => Ok(PlaneCondition::Stress),
        "strain" => Ok(PlaneCondition::Strain),
        other => Err(mpm_msg(format!("plane = {other:?}: expected \"stress\" or \"strain\""))),
    }
}
