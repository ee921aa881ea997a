//! Python values read as the library's choices: any value as a TOML value (scenes given as
//! dicts, shape functions given as dicts or strings; bounded in depth and size, self-references
//! refused, node lists no longer than the grid), the shape function, the mass scheme and
//! the plane condition, each error naming the argument.

use crate::{mpm_err, mpm_msg};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use sparse_mpm::material::PlaneCondition;
use sparse_mpm::{mass, ShapeFunction};

/// Most levels of nesting of a Python value read as TOML (a scene is some six levels deep).
pub(crate) const MAX_DEPTH: usize = 64;

/// Most values (numbers, strings, booleans, lists and dicts, each counted once) in one Python
/// value read as TOML: 2·10⁶. A scene file is at most `MAX_SCENE_BYTES` (16 MiB), room for node
/// lists of a million nodes; 2·10⁶ values leave room for those and the rest of a scene (such a
/// scene peaks at about 0.5 GB while it is converted, written as TOML and parsed).
pub(crate) const MAX_VALUES: usize = 2_000_000;

/// Most bytes of the strings and keys of one Python value read as TOML: a scene file's size.
const MAX_TEXT_BYTES: usize = sparse_mpm::scene::MAX_SCENE_BYTES as usize;

/// A Python value (dict, list, tuple, str, bool, int, float) as a TOML value, with no grid to
/// bound node lists by (see [`ToToml`]).
pub(crate) fn to_toml(obj: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    ToToml::new(None).convert(obj, key)
}

/// Python values read as TOML values, within bounds: at most [`MAX_DEPTH`] levels, at most
/// [`MAX_VALUES`] values and [`MAX_TEXT_BYTES`] of strings over every value converted by it, no
/// dict or list that contains itself, and a boundary's `nodes` list no longer than the grid's
/// node count. Each bound is checked before the values beyond it are read (a list's length
/// before its items), and its error names the key path.
pub(crate) struct ToToml {
    /// The containers being converted, outermost first: their address and key path.
    open: Vec<(usize, String)>,
    /// Values converted so far.
    values: usize,
    /// Bytes of strings and keys converted so far.
    text: usize,
    /// The grid's node count, when known: the longest a boundary's `nodes` list may be.
    max_nodes: Option<usize>,
}

impl ToToml {
    /// A converter with nothing converted yet; `max_nodes` bounds the boundaries' node lists.
    pub(crate) fn new(max_nodes: Option<usize>) -> Self {
        ToToml {
            open: Vec::new(),
            values: 0,
            text: 0,
            max_nodes,
        }
    }

    /// `obj` as a TOML value; `key` is its key path (empty for a whole scene).
    pub(crate) fn convert(&mut self, obj: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
        let shown = if key.is_empty() { "scene" } else { key };
        self.count(shown, 1)?;
        if obj.is_instance_of::<PyBool>() {
            return Ok(toml::Value::Boolean(obj.extract()?));
        }
        if obj.is_instance_of::<PyInt>() {
            let i: i64 = obj
                .extract()
                .map_err(|_| mpm_msg(format!("{shown}: integer {obj} does not fit in 64 bits")))?;
            return Ok(toml::Value::Integer(i));
        }
        if obj.is_instance_of::<PyFloat>() {
            return Ok(toml::Value::Float(obj.extract()?));
        }
        if let Ok(s) = obj.cast::<PyString>() {
            return Ok(toml::Value::String(self.string(s, shown)?));
        }
        // A container (or a NumPy value): its items are converted with it open.
        let address = obj.as_ptr() as usize;
        if let Some((_, outer)) = self.open.iter().find(|(a, _)| *a == address) {
            return Err(mpm_msg(format!(
                "{outer} contains itself at key path {shown}: a scene is a tree of values, no dict or list may \
                 hold itself"
            )));
        }
        if self.open.len() >= MAX_DEPTH {
            return Err(mpm_msg(format!(
                "{shown}: nested more than {MAX_DEPTH} levels deep (a scene is a few levels deep)"
            )));
        }
        self.open.push((address, shown.to_string()));
        let value = self.container(obj, key, shown);
        self.open.pop();
        value
    }

    /// An error naming `shown` when `more` values would take the converter past [`MAX_VALUES`];
    /// else they are counted.
    fn count(&mut self, shown: &str, more: usize) -> PyResult<()> {
        if more > MAX_VALUES - self.values.min(MAX_VALUES) {
            return Err(mpm_msg(format!(
                "{shown}: more than {MAX_VALUES} values in all, more than a scene holds (a scene file is at most \
                 {} MiB)",
                MAX_TEXT_BYTES >> 20
            )));
        }
        self.values += more;
        Ok(())
    }

    /// The string `s` at `shown`, its size checked (against the bytes left) before it is copied.
    fn string(&mut self, s: &Bound<'_, PyString>, shown: &str) -> PyResult<String> {
        // A character is at least one byte of UTF-8.
        let chars = s.len()?;
        if chars > MAX_TEXT_BYTES - self.text.min(MAX_TEXT_BYTES) {
            return Err(mpm_msg(format!(
                "{shown}: a string of {chars} characters takes the strings past the {} MiB a scene file may have",
                MAX_TEXT_BYTES >> 20
            )));
        }
        let text: String = s.extract()?;
        self.text += text.len();
        Ok(text)
    }

    /// The dict, list, tuple or NumPy value `obj` at `key` (`shown` in errors).
    fn container(&mut self, obj: &Bound<'_, PyAny>, key: &str, shown: &str) -> PyResult<toml::Value> {
        if let Ok(d) = obj.cast::<PyDict>() {
            self.check_len(shown, d.len())?;
            let mut table = toml::map::Map::new();
            // The items as they are now (a list of pairs): nothing run while converting them
            // can change what is iterated over.
            for item in d.items().iter() {
                let (k, v): (Bound<'_, PyAny>, Bound<'_, PyAny>) = item.extract()?;
                let Ok(k) = k.cast::<PyString>() else {
                    return Err(mpm_msg(format!("{shown}: dictionary keys must be strings, found {k}")));
                };
                let k = self.string(k, shown)?;
                let sub = if key.is_empty() {
                    k.clone()
                } else {
                    format!("{key}.{k}")
                };
                let value = self.convert(&v, &sub)?;
                table.insert(k, value);
            }
            return Ok(toml::Value::Table(table));
        }
        if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
            self.check_len(shown, obj.len()?)?;
            let mut items = Vec::new();
            for (i, v) in obj.try_iter()?.enumerate() {
                items.push(self.convert(&v?, &format!("{key}[{i}]"))?);
            }
            return Ok(toml::Value::Array(items));
        }
        // NumPy scalars and arrays: their Python equivalents (an array's size checked first).
        if let Ok(a) = obj.cast::<numpy::PyUntypedArray>() {
            self.check_len(shown, numpy::PyUntypedArrayMethods::len(a))?;
        }
        if obj.hasattr("tolist")? {
            return self.convert(&obj.call_method0("tolist")?, key);
        }
        Err(mpm_msg(format!(
            "{shown}: a value of type {} has no TOML form",
            obj.get_type().name()?
        )))
    }

    /// An error naming `shown` unless a container of `len` items fits the bounds: no longer
    /// than the grid's node count for a boundary's `nodes`, within [`MAX_VALUES`].
    pub(crate) fn check_len(&self, shown: &str, len: usize) -> PyResult<()> {
        if let Some(n) = self.max_nodes.filter(|&n| len > n && is_node_list(shown)) {
            return Err(mpm_err(sparse_mpm::MpmError::InvalidScene {
                key: shown.to_string(),
                reason: format!(
                    "lists {len} nodes, more than the {n} nodes of the grid (each node can be listed once)"
                ),
            }));
        }
        if len > MAX_VALUES - self.values.min(MAX_VALUES) {
            return Err(mpm_msg(format!(
                "{shown}: {len} values, more than the {MAX_VALUES} a scene may hold in all (a scene file is at \
                 most {} MiB)",
                MAX_TEXT_BYTES >> 20
            )));
        }
        Ok(())
    }
}

/// Whether `key` is a boundary's node list, `boundaries[k].nodes`.
fn is_node_list(key: &str) -> bool {
    key.strip_prefix("boundaries[")
        .and_then(|rest| rest.strip_suffix("].nodes"))
        .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
}

/// The node count of the grid of the scene dict `scene` (`(cx + 1) (cy + 1)` from its
/// `grid.cells`), when it has a readable one.
pub(crate) fn scene_grid_nodes(scene: &Bound<'_, PyDict>) -> Option<usize> {
    let grid = scene.get_item("grid").ok()??;
    let cells = grid.cast::<PyDict>().ok()?.get_item("cells").ok()??;
    let [cx, cy]: [u64; 2] = cells.extract().ok()?;
    let nodes = (cx as u128 + 1) * (cy as u128 + 1);
    usize::try_from(nodes).ok()
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
