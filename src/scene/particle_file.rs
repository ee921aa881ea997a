//! Particle files: where a scene's `{ file = "particles.csv" }` may lie, and how it is read.
//!
//! A particle file is CSV text read with the [`csv`](https://docs.rs/csv) crate: fields are
//! separated by `,` and records end with `\n` (a `\r` before it is trimmed with the spaces
//! around every field); quotes have no special meaning; a UTF-8 byte-order mark at the start,
//! blank lines and lines whose first non-space character is `#` are skipped. The first other
//! line is the header.

use std::path::{Component, Path, PathBuf};

use super::{invalid, BodySpec, Geometry, Scene, MAX_PARTICLE_FILE_BYTES, MAX_SPEED};
use crate::error::Result;
use crate::numbers::exact;

impl Scene {
    /// The file body `body` reads its particles from, checked as it will be read: `None` when
    /// the body's geometry is not a file; else the path, taken from [`Scene::base_dir`] (the
    /// current directory when `None`), with symbolic links resolved unless
    /// [`Scene::allow_outside_files`] is set. A program that reads or copies the file itself
    /// should use this path.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] at `bodies[k].geometry.file` naming the path when it is
    /// absolute, leaves the scene's folder (`..`, a symbolic link) or cannot be resolved
    /// (it does not exist), unless [`Scene::allow_outside_files`] is set.
    ///
    /// [`MpmError::InvalidScene`]: crate::error::MpmError::InvalidScene
    pub fn particle_file_path(&self, body: usize) -> Result<Option<PathBuf>> {
        let Some(BodySpec {
            geometry: Geometry::File(written),
            ..
        }) = self.bodies.get(body)
        else {
            return Ok(None);
        };
        self.locate_particle_file(written)
            .map(|(_, path)| Some(path))
            .map_err(|reason| invalid(format!("bodies[{body}].geometry.file"), reason))
    }

    /// The particle file named `written` in the scene: the path to show in messages (joined to
    /// the scene's folder) and the path to open (the same with symbolic links resolved, once it
    /// is known to lie in the folder).
    pub(super) fn locate_particle_file(&self, written: &Path) -> std::result::Result<(PathBuf, PathBuf), String> {
        let folder = match &self.base_dir {
            Some(dir) if !dir.as_os_str().is_empty() => dir.clone(),
            _ => PathBuf::from("."),
        };
        let joined = folder.join(written);
        if self.allow_outside_files {
            return Ok((joined.clone(), joined));
        }
        let refuse = |why: &str| {
            format!(
                "`{}` {why}; a particle file must lie in the scene file's folder ({}) or below it",
                written.display(),
                folder.display()
            )
        };
        // Decided from the path's text first, so that nothing outside the folder is looked at.
        let mut depth = 0usize;
        for part in written.components() {
            match part {
                Component::Normal(_) => depth += 1,
                Component::CurDir => {}
                Component::ParentDir if depth == 0 => return Err(refuse("leaves the folder through `..`")),
                Component::ParentDir => depth -= 1,
                Component::RootDir | Component::Prefix(_) => return Err(refuse("is an absolute path")),
            }
        }
        if depth == 0 {
            return Err(refuse("names the folder itself, not a file in it"));
        }
        // Then with symbolic links resolved: a link inside the folder must not lead out of it.
        let root = folder
            .canonicalize()
            .map_err(|e| format!("the scene file's folder {} cannot be resolved: {e}", folder.display()))?;
        let path = joined
            .canonicalize()
            .map_err(|e| format!("{}: {e}", joined.display()))?;
        if !path.starts_with(&root) {
            return Err(refuse("leads out of the folder through a symbolic link"));
        }
        Ok((joined, path))
    }
}

/// Columns of a particle file; optional ones are `None` when absent.
#[derive(Debug, Default)]
pub(super) struct ParticleColumns {
    pub(super) x: Vec<f64>,
    pub(super) y: Vec<f64>,
    pub(super) volume: Vec<f64>,
    pub(super) optional: [Option<Vec<f64>>; 6],
}

/// The columns every particle file has.
const REQUIRED_COLUMNS: [&str; 3] = ["x", "y", "volume"];

/// Optional particle-file columns, in the order of `ParticleColumns::optional`.
const OPTIONAL_COLUMNS: [&str; 6] = ["vx", "vy", "mass", "sxx", "syy", "sxy"];

/// The index of `mass` in [`OPTIONAL_COLUMNS`].
const MASS: usize = 2;

/// Reads the text of a particle file: a regular file of at most [`MAX_PARTICLE_FILE_BYTES`]
/// bytes, in UTF-8. `shown` is the path for messages, `path` the one opened.
fn read_particle_text(shown: &Path, path: &Path) -> std::result::Result<String, String> {
    let shown = shown.display();
    // The reason alone: the message names the path as the scene gave it.
    let reason = |e: crate::error::MpmError| match e {
        crate::error::MpmError::Io { source, .. } => source.to_string(),
        other => other.to_string(),
    };
    let bytes = crate::io::read_bounded(path, MAX_PARTICLE_FILE_BYTES, "particle")
        .map_err(|e| format!("{shown}: {}", reason(e)))?;
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..valid].iter().filter(|&&b| b == b'\n').count() + 1;
        format!("{shown} line {line}: not UTF-8 text (a particle file is CSV text)")
    })
}

/// Whether a piece of a particle file may be quoted in a message: a short word of letters,
/// digits and `+-._` (a misspelt number or column name), nothing longer or stranger.
fn quotable(text: &str) -> bool {
    !text.is_empty() && text.len() <= 24 && text.bytes().all(|b| b.is_ascii_alphanumeric() || b"+-._".contains(&b))
}

/// A particle file's header: the column names (trimmed) and the column of each known name.
struct Header {
    names: Vec<String>,
    required: [usize; 3],
    optional: [Option<usize>; 6],
}

/// The CSV reader of a particle file's text (see the [module docs](self)).
fn csv_reader(text: &str) -> csv::Reader<&[u8]> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .quoting(false)
        .terminator(csv::Terminator::Any(b'\n'))
        .from_reader(text.as_bytes())
}

/// Reads the next record of `reader` (over `text`) that is neither blank nor a comment into
/// `record`, and returns its line number; `None` at the end of the file.
fn next_record(
    shown: &std::path::Display<'_>,
    text: &str,
    reader: &mut csv::Reader<&[u8]>,
    record: &mut csv::StringRecord,
) -> std::result::Result<Option<u64>, String> {
    loop {
        // The text is UTF-8 and every record length is accepted: no error is expected here.
        let read = reader
            .read_record(record)
            .map_err(|e| format!("{shown}: not readable as CSV ({e})"))?;
        if !read {
            return Ok(None);
        }
        // The reader stands after the record and its `\n`, if it has one (the last line may
        // not); the record's own position would be that of the blank lines before it.
        let end = reader.position();
        let ended_by_newline = text.as_bytes()[..end.byte() as usize].ends_with(b"\n");
        let line = end.line() - u64::from(ended_by_newline);
        let first = record.get(0).unwrap_or("");
        let blank = record.len() <= 1 && first.trim().is_empty();
        if !blank && !first.trim_start().starts_with('#') {
            return Ok(Some(line));
        }
    }
}

/// Checks the header `record` (on line `line`): it names `x`, `y` and `volume`, and otherwise
/// only optional columns, each once.
fn parse_header(
    shown: &std::path::Display<'_>,
    line: u64,
    record: &csv::StringRecord,
) -> std::result::Result<Header, String> {
    let names: Vec<String> = record.iter().map(|n| n.trim().to_string()).collect();
    let column = |name: &str| names.iter().position(|n| n == name);
    let missing: Vec<String> = REQUIRED_COLUMNS
        .iter()
        .filter(|n| column(n).is_none())
        .map(|n| format!("`{n}`"))
        .collect();
    if !missing.is_empty() {
        return Err(format!(
            "{shown} line {line}: the header ({} column{}) must name the columns `x`, `y` and `volume`; it lacks {}",
            names.len(),
            if names.len() == 1 { "" } else { "s" },
            missing.join(", ")
        ));
    }
    for (c, name) in names.iter().enumerate() {
        let name = name.as_str();
        if !REQUIRED_COLUMNS.contains(&name) && !OPTIONAL_COLUMNS.contains(&name) {
            let known = format!("known: x, y, volume, {}", OPTIONAL_COLUMNS.join(", "));
            return Err(if quotable(name) {
                format!(
                    "{shown} line {line}: unknown column `{name}` (column {}; {known})",
                    c + 1
                )
            } else {
                format!(
                    "{shown} line {line}: column {} of the header is not a known column name (not shown; {known})",
                    c + 1
                )
            });
        }
        if let Some(first) = names[..c].iter().position(|n| n == name) {
            return Err(format!(
                "{shown} line {line}: column `{name}` is named twice (columns {} and {})",
                first + 1,
                c + 1
            ));
        }
    }
    Ok(Header {
        required: REQUIRED_COLUMNS.map(|n| column(n).unwrap_or(0)),
        optional: OPTIONAL_COLUMNS.map(column),
        names,
    })
}

/// Appends the particle of `record` (on line `line`) to `out`: one number per column, finite, a
/// positive volume whose mass (`density × volume` without a `mass` column) is finite, a
/// positive mass, speeds within [`MAX_SPEED`].
fn push_row(
    shown: &std::path::Display<'_>,
    header: &Header,
    density: f64,
    line: u64,
    record: &csv::StringRecord,
    out: &mut ParticleColumns,
) -> std::result::Result<(), String> {
    let names = &header.names;
    if record.len() != names.len() {
        return Err(format!(
            "{shown} line {line}: {} values but the header has {} columns",
            record.len(),
            names.len()
        ));
    }
    let at = |c: usize| format!("{shown} line {line}, column `{}` (column {})", names[c], c + 1);
    let value = |c: usize| -> std::result::Result<f64, String> {
        let cell = record.get(c).unwrap_or("").trim();
        let v = cell.parse::<f64>().map_err(|_| {
            if cell.is_empty() {
                format!("{}: the value is missing", at(c))
            } else if quotable(cell) {
                format!("{}: `{cell}` is not a number", at(c))
            } else {
                format!("{}: not a number ({} bytes, not shown)", at(c), cell.len())
            }
        })?;
        if !v.is_finite() {
            return Err(format!("{}: {} is not a finite number", at(c), exact(v)));
        }
        Ok(v)
    };
    let [cx, cy, cv] = header.required;
    out.x.push(value(cx)?);
    out.y.push(value(cy)?);
    let volume = value(cv)?;
    if volume <= 0.0 {
        return Err(format!("{}: {} must be positive", at(cv), exact(volume)));
    }
    if header.optional[MASS].is_none() && !(density * volume).is_finite() {
        return Err(format!(
            "{}: {} times the body's density {} (its mass) overflows",
            at(cv),
            exact(volume),
            exact(density)
        ));
    }
    out.volume.push(volume);
    for (k, c) in header.optional.iter().enumerate() {
        if let (Some(c), Some(values)) = (*c, out.optional[k].as_mut()) {
            let v = value(c)?;
            match OPTIONAL_COLUMNS[k] {
                "mass" if v <= 0.0 => return Err(format!("{}: {} must be positive", at(c), exact(v))),
                "vx" | "vy" if v.abs() > MAX_SPEED => {
                    return Err(format!(
                        "{}: {} is too large: speeds of at most {} are accepted",
                        at(c),
                        exact(v),
                        exact(MAX_SPEED)
                    ))
                }
                _ => {}
            }
            values.push(v);
        }
    }
    Ok(())
}

/// Reads a CSV particle file: columns `x, y, volume` and optionally `vx, vy, mass, sxx, syy, sxy`.
/// `density` gives the mass of a file without a `mass` column. `shown` is the path for
/// messages, `path` the one opened.
///
/// Messages name the line and the column and say what is wrong. They show nothing of a file
/// whose header does not name `x`, `y` and `volume` (it is not a particle file, and its content
/// is none of the scene's business), and of a particle file at most a short word ([`quotable`]).
pub(super) fn read_particle_file(
    shown: &Path,
    path: &Path,
    density: f64,
) -> std::result::Result<ParticleColumns, String> {
    let text = read_particle_text(shown, path)?;
    let shown = shown.display();
    let mut reader = csv_reader(&text);
    let mut record = csv::StringRecord::new();
    let line = next_record(&shown, &text, &mut reader, &mut record)?
        .ok_or_else(|| format!("{shown}: the file has no header line (it is empty or only comments)"))?;
    let header = parse_header(&shown, line, &record)?;
    let mut out = ParticleColumns::default();
    for (k, c) in header.optional.iter().enumerate() {
        if c.is_some() {
            out.optional[k] = Some(Vec::new());
        }
    }
    while let Some(line) = next_record(&shown, &text, &mut reader, &mut record)? {
        push_row(&shown, &header, density, line, &record, &mut out)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads `content` as a particle file of a body of density 2.
    fn read(test: &str, content: &[u8]) -> std::result::Result<ParticleColumns, String> {
        let path = std::env::temp_dir().join(format!("sparse-mpm-particle-file-{}-{test}.csv", std::process::id()));
        std::fs::write(&path, content).unwrap();
        let read = read_particle_file(Path::new("p.csv"), &path, 2.0);
        std::fs::remove_file(&path).unwrap();
        read
    }

    #[test]
    fn line_ends_a_byte_order_mark_comments_blank_lines_and_spaces_leave_the_numbers_unchanged() {
        let plain = read("plain", b"x,y,volume,vx\n0.25,0.5,0.01,-1e-3\n0.75,0.5,0.02,2\n").unwrap();
        for (test, content) in [
            ("crlf", &b"x,y,volume,vx\r\n0.25,0.5,0.01,-1e-3\r\n0.75,0.5,0.02,2\r\n"[..]),
            ("bom", b"\xef\xbb\xbfx,y,volume,vx\n0.25,0.5,0.01,-1e-3\n0.75,0.5,0.02,2"),
            (
                "comments",
                b"# a comment\n\n  \t\n x , y,volume ,vx\n   # another, with, commas\n\r\n0.25, 0.5 ,0.01,-1e-3\n0.75,0.5,0.02,2\n#",
            ),
        ] {
            let read = read(test, content).unwrap_or_else(|e| panic!("{test}: {e}"));
            assert_eq!((&read.x, &read.y, &read.volume), (&plain.x, &plain.y, &plain.volume), "{test}");
            assert_eq!(read.optional[0], plain.optional[0], "{test}");
            assert!(read.optional[1..].iter().all(Option::is_none), "{test}");
        }
    }

    #[test]
    fn errors_name_the_line_after_blank_lines_comments_and_at_the_end_without_newline() {
        let message = read("blank", b"\n\n# c\nx,y,volume\n\n\n0.5,0.5,0.01\n\n#\n\n0.5,zz,0.01\n").unwrap_err();
        assert!(
            message.contains("p.csv line 11, column `y` (column 2): `zz` is not a number"),
            "{message}"
        );
        let message = read("last", b"x,y,volume\r\n0.5,0.5,0.01\r\n\r\n0.5,0.5").unwrap_err();
        assert!(
            message.contains("p.csv line 4: 2 values but the header has 3 columns"),
            "{message}"
        );
        let message = read("empty", b"\xef\xbb\xbf\n# only a comment\n").unwrap_err();
        assert!(message.contains("p.csv: the file has no header line"), "{message}");
    }

    #[test]
    fn quotes_are_characters_of_their_field() {
        let message = read("quoted", b"x,y,volume\n\"0.5\",0.5,0.01\n").unwrap_err();
        assert!(
            message.contains("line 2, column `x` (column 1): not a number (5 bytes, not shown)"),
            "{message}"
        );
        let message = read("quoted_header", b"\"x\",y,volume\n").unwrap_err();
        assert!(message.contains("line 1: the header (3 columns)"), "{message}");
        assert!(message.contains("it lacks `x`"), "{message}");
    }
}
