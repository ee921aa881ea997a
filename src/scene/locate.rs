//! Where a key of a scene is written: the line of `bodies[1].geometry.disk` in the scene's text,
//! for errors found after the text was read (checks, the build, the cost limits).

use toml::de::{DeTable, DeValue};

/// The 1-based line of the deepest part of `key` (a dotted path with indices:
/// `bodies[1].geometry.disk`, `grid.cell_size[0]`) written in `text`; `None` when the text is
/// not TOML or not even the first part of the key is in it.
pub(super) fn line_of(text: &str, key: &str) -> Option<usize> {
    let document = DeTable::parse(text).ok()?;
    let mut table = document.get_ref();
    let mut value: Option<&DeValue<'_>> = None;
    let mut found: Option<usize> = None;
    for part in key.split('.') {
        let (name, indices) = match part.find('[') {
            Some(at) => (&part[..at], &part[at..]),
            None => (part, ""),
        };
        if let Some(v) = value {
            match v {
                DeValue::Table(t) => table = t,
                _ => break,
            }
        }
        let Some((written, entry)) = table.iter().find(|(k, _)| k.get_ref() == name) else {
            break;
        };
        found = Some(written.span().start);
        let mut current = entry;
        let mut complete = true;
        for index in indices.split(['[', ']']).filter(|s| !s.is_empty()) {
            let element = match (current.get_ref(), index.parse::<usize>()) {
                (DeValue::Array(items), Ok(i)) => items.get(i),
                _ => None,
            };
            match element {
                Some(e) => {
                    current = e;
                    // An element of an array of tables (`[[bodies]]`) has no span of its own
                    // in every form; its first key is found at the next part.
                    if !current.span().is_empty() {
                        found = Some(current.span().start);
                    }
                }
                None => {
                    complete = false;
                    break;
                }
            }
        }
        if !complete {
            break;
        }
        value = Some(current.get_ref());
    }
    found.map(|at| text[..at.min(text.len())].matches('\n').count() + 1)
}
