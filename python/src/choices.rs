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

/// A scene written as TOML text with, for each line of it, the key path it sets
/// (`bodies[0].material.youngs_modulus`): a parse error's line is then named by its key path.
pub(crate) struct PathText {
    pub(crate) text: String,
    /// `paths[i]` is the key path of line `i` (0-based).
    pub(crate) paths: Vec<String>,
}

impl PathText {
    /// `root` (a table) as TOML text: top-level values, then one `[table]` per table and one
    /// `[[array]]` per element of an array of tables, their contents as dotted keys one per line
    /// (arrays of tables below those inline on their line).
    pub(crate) fn write(root: &toml::Value) -> PathText {
        let mut out = PathText {
            text: String::new(),
            paths: Vec::new(),
        };
        let Some(table) = root.as_table() else {
            out.line(format!("scene = {root}"), "scene".into());
            return out;
        };
        for (k, v) in table {
            let empty_table = v.as_table().is_some_and(|t| t.is_empty());
            if empty_table || !(v.is_table() || is_table_array(v)) {
                out.line(format!("{} = {}", key_text(k), v), k.clone());
            }
        }
        for (k, v) in table {
            if let Some(t) = v.as_table().filter(|t| !t.is_empty()) {
                out.line(format!("[{}]", key_text(k)), k.clone());
                out.dotted(t, "", k);
            } else if is_table_array(v) {
                for (i, item) in v.as_array().into_iter().flatten().enumerate() {
                    let path = format!("{k}[{i}]");
                    out.line(format!("[[{}]]", key_text(k)), path.clone());
                    if let Some(t) = item.as_table() {
                        out.dotted(t, "", &path);
                    }
                }
            }
        }
        out
    }

    fn line(&mut self, text: String, path: String) {
        self.text.push_str(&text);
        self.text.push('\n');
        self.paths.push(path);
    }

    /// The entries of `t` as `prefix.key = value` lines, sub-tables as longer dotted keys.
    fn dotted(&mut self, t: &toml::map::Map<String, toml::Value>, prefix: &str, path: &str) {
        for (k, v) in t {
            let key = format!("{prefix}{}", key_text(k));
            let sub = format!("{path}.{k}");
            match v.as_table() {
                Some(inner) if !inner.is_empty() => self.dotted(inner, &format!("{key}."), &sub),
                _ => self.line(format!("{key} = {v}"), sub),
            }
        }
    }

    /// The key path of the line holding byte `offset` of the text.
    pub(crate) fn path_at(&self, offset: usize) -> &str {
        let offset = offset.min(self.text.len());
        let line = self.text[..offset].matches('\n').count();
        self.paths
            .get(line.min(self.paths.len().saturating_sub(1)))
            .map_or("scene", String::as_str)
    }
}

/// A non-empty array whose items are all tables (written as `[[key]]` sections).
fn is_table_array(v: &toml::Value) -> bool {
    v.as_array()
        .is_some_and(|a| !a.is_empty() && a.iter().all(toml::Value::is_table))
}

/// `k` as a TOML key: bare when it can be, quoted otherwise.
fn key_text(k: &str) -> String {
    if !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
        k.to_string()
    } else {
        toml::Value::String(k.to_string()).to_string()
    }
}

/// The scene in `value` (a table with the keys of a scene file), parsed and validated; a parse
/// error (unknown key, wrong type, missing key) names the key path, as do the scene's checks.
pub(crate) fn scene_from_value(value: &toml::Value) -> PyResult<sparse_mpm::scene::Scene> {
    use sparse_mpm::scene::Scene;
    let written = PathText::write(value);
    if let Err(e) = toml::from_str::<Scene>(&written.text) {
        let key = e.span().map_or("scene", |s| written.path_at(s.start)).to_string();
        return Err(mpm_err(sparse_mpm::MpmError::InvalidScene {
            key,
            reason: e.message().trim().to_string(),
        }));
    }
    Scene::from_toml_str(&written.text).map_err(mpm_err)
}
