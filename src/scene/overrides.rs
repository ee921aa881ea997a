//! Changing a scene's keys from outside its file: `KEY=VALUE` overrides (`mpm run --set`), for
//! scripted sweeps. A key is a path of table keys and array indices as the errors name them
//! (`time.end`, `bodies[0].material.youngs_modulus`, `schemes.mass.velocity`); a value is a TOML
//! value (`2e7`, `[0.0, -9.81]`, `{ disk = { center = [0, 0], radius = 1 } }`, `"apic"`), or,
//! when it does not read as one, the text itself as a string (`apic`); an empty value removes
//! the key (`time.cfl=` before `time.dt=1e-4`). Tables on the way are made when missing. The
//! overridden text is read and checked as a file would be, so a scene with overrides is the
//! scene of the edited file.

use super::{invalid, Scene};
use crate::error::{MpmError, Result};

/// One step of a key's path: a table key, or an index into an array.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

/// The most overrides one scene takes.
pub const MAX_OVERRIDES: usize = 1000;

/// The most steps (keys and indices) an override's key may have: a scene's deepest key has
/// about ten.
pub const MAX_OVERRIDE_STEPS: usize = 32;

/// The steps of `key` (`bodies[0].density` → `bodies`, `[0]`, `density`), at most
/// [`MAX_OVERRIDE_STEPS`].
fn steps(key: &str) -> std::result::Result<Vec<Step>, String> {
    let bound = |n: usize| {
        if n > MAX_OVERRIDE_STEPS {
            Err(format!(
                "the key has more than {MAX_OVERRIDE_STEPS} keys and indices; a scene's keys have about ten"
            ))
        } else {
            Ok(())
        }
    };
    // Counted before anything is built: a dot or a bracket starts each step.
    bound(1 + key.matches(['.', '[']).count())?;
    let mut out = Vec::new();
    for part in key.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        let bare = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        if name.is_empty() || !name.chars().all(bare) {
            return Err(format!(
                "`{part}` is not a key (letters, digits, `_` and `-`, then `[index]`s)"
            ));
        }
        out.push(Step::Key(name.to_string()));
        while !rest.is_empty() {
            let close = rest.find(']').filter(|_| rest.starts_with('['));
            let Some(close) = close else {
                return Err(format!("`{part}`: an index is written `[k]`"));
            };
            let index = rest[1..close]
                .parse::<usize>()
                .map_err(|_| format!("`{part}`: `{}` is not an index", &rest[1..close]))?;
            out.push(Step::Index(index));
            rest = &rest[close + 1..];
        }
    }
    Ok(out)
}

/// The TOML value of `text`, or `text` as a string when it reads as no value.
fn value(text: &str) -> toml::Value {
    let wrapped = format!("v = {text}");
    match toml::from_str::<toml::Table>(&wrapped) {
        Ok(mut t) => t.remove("v").unwrap_or_else(|| toml::Value::String(text.to_string())),
        Err(_) => toml::Value::String(text.to_string()),
    }
}

/// Sets (or with `None` removes) the value at `path` in `root`.
fn put(root: &mut toml::Table, path: &[Step], new: Option<toml::Value>) -> std::result::Result<(), String> {
    let mut whole = toml::Value::Table(std::mem::take(root));
    let result = put_in(&mut whole, path, 0, new);
    if let toml::Value::Table(t) = whole {
        *root = t;
    }
    result
}

/// [`put`] from step `k` of `path` on, at `here`.
fn put_in(
    here: &mut toml::Value,
    path: &[Step],
    k: usize,
    new: Option<toml::Value>,
) -> std::result::Result<(), String> {
    let last = k + 1 == path.len();
    let at = shown(&path[..=k]);
    match &path[k] {
        Step::Key(name) => {
            let toml::Value::Table(table) = here else {
                return Err(format!("`{}` is not a table", shown(&path[..k])));
            };
            if last {
                match new {
                    Some(v) => {
                        table.insert(name.clone(), v);
                    }
                    None => {
                        table.remove(name);
                    }
                }
                return Ok(());
            }
            let next = table
                .entry(name.clone())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            put_in(next, path, k + 1, new)
        }
        Step::Index(i) => {
            let toml::Value::Array(items) = here else {
                return Err(format!("`{}` is not an array", shown(&path[..k])));
            };
            let len = items.len();
            let Some(item) = items.get_mut(*i) else {
                return Err(format!("`{at}`: the array has {len} entries (indices from 0)"));
            };
            if last {
                return match new {
                    Some(v) => {
                        *item = v;
                        Ok(())
                    }
                    None => Err(format!("`{at}`: an array entry cannot be removed")),
                };
            }
            put_in(item, path, k + 1, new)
        }
    }
}

fn shown(path: &[Step]) -> String {
    let mut s = String::new();
    for step in path {
        match step {
            Step::Key(k) if s.is_empty() => s.push_str(k),
            Step::Key(k) => {
                s.push('.');
                s.push_str(k);
            }
            Step::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// `text` (a scene's TOML) with each `KEY=VALUE` of `sets` applied in order, as TOML text.
///
/// # Errors
/// [`MpmError::InvalidScene`](crate::error::MpmError::InvalidScene) at `--set KEY` for a
/// malformed override, a path through a value that is not a table or array, an index past an
/// array's end, or an override after which the scene no longer reads (an unknown key, a value
/// of the wrong type), with the parser's reason; more than [`MAX_OVERRIDES`] overrides, a key of
/// more than [`MAX_OVERRIDE_STEPS`] steps.
pub fn apply_overrides(text: &str, sets: &[String]) -> Result<String> {
    if sets.len() > MAX_OVERRIDES {
        return Err(invalid(
            "--set",
            format!(
                "{} overrides: at most {MAX_OVERRIDES} are read (each is checked against the whole scene)",
                sets.len()
            ),
        ));
    }
    let mut root: toml::Table =
        toml::from_str(text).map_err(|e| invalid("scene", format!("does not read as TOML: {}", e.message().trim())))?;
    for set in sets {
        let Some((key, raw)) = set.split_once('=') else {
            let shown: String = set.chars().take(80).collect();
            return Err(invalid(
                format!("--set {shown}"),
                "an override is KEY=VALUE (`time.end=2.0`; an empty VALUE removes the key)",
            ));
        };
        let key = key.trim();
        // A key is shown whole up to 80 characters, its start with an ellipsis beyond.
        let shown = match key.char_indices().nth(80) {
            Some((cut, _)) => format!("{}…", &key[..cut]),
            None => key.to_string(),
        };
        let at = |reason: String| invalid(format!("--set {shown}"), reason);
        let path = steps(key).map_err(at)?;
        let raw = raw.trim();
        let new = (!raw.is_empty()).then(|| value(raw));
        put(&mut root, &path, new).map_err(at)?;
        // The scene must still read with this key: an unknown key or a wrong type is named
        // here, at its override, rather than later in the regenerated text.
        let text = toml::to_string(&root).map_err(|e| at(format!("cannot be written as TOML: {e}")))?;
        match Scene::parse(&text) {
            // The parser's line is one of the regenerated text: its reason only.
            Err(MpmError::InvalidScene { reason, .. }) => return Err(at(reason)),
            Err(e) => return Err(at(e.to_string())),
            Ok(_) => {}
        }
    }
    toml::to_string(&root).map_err(|e| invalid("scene", format!("cannot be written as TOML: {e}")))
}
