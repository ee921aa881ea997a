//! Reading `.vtp` snapshots and `.pvd` collections back (the files this module writes, and
//! ASCII or base64 binary files of the same layout from other tools).

use std::fs;
use std::path::{Path, PathBuf};

use super::base64::decode_base64;
use super::xml_unescape;
use crate::error::Result;
use crate::io::{invalid_data, io_error};

/// The contents of a `.vtp` file written by [`write_vtp`](super::write_vtp).
#[derive(Clone, Debug, PartialEq)]
pub struct VtpData {
    /// The particle positions `(x, y, z)` (`z` is 0 in files written by [`write_vtp`](super::write_vtp)).
    pub points: Vec<[f64; 3]>,
    /// The point-data arrays, in file order.
    pub arrays: Vec<VtpArray>,
}

impl VtpData {
    /// The number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the file holds no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The first point-data array called `name`.
    pub fn array(&self, name: &str) -> Option<&VtpArray> {
        self.arrays.iter().find(|a| a.name == name)
    }
}

/// One point-data array read from a `.vtp` file.
#[derive(Clone, Debug, PartialEq)]
pub struct VtpArray {
    /// The array's name (unescaped).
    pub name: String,
    /// Components per point: 1 for a scalar, 3 for a vector, 9 for a tensor written by
    /// [`write_vtp`](super::write_vtp).
    pub components: usize,
    /// `components` values per point, point after point (`len() == components × points`).
    pub values: Vec<f64>,
}

impl VtpArray {
    /// The `components` values of point `i`.
    ///
    /// # Panics
    /// When `i` is not less than the number of points.
    pub fn point(&self, i: usize) -> &[f64] {
        &self.values[i * self.components..(i + 1) * self.components]
    }

    /// Component `c` of every point (e.g. `component(1)` of a vector is its y components).
    ///
    /// # Panics
    /// When `c >= components`.
    pub fn component(&self, c: usize) -> Vec<f64> {
        assert!(
            c < self.components,
            "component {c} of a {}-component array",
            self.components
        );
        self.values.iter().skip(c).step_by(self.components).copied().collect()
    }
}

/// Reads a `.vtp` file in exactly the layout [`write_vtp`](super::write_vtp) writes (see the
/// [module documentation](super)); it is not a general VTK reader.
///
/// # Errors
/// [`MpmError::Io`](crate::MpmError::Io) naming `path` when it cannot be read, and of kind
/// [`std::io::ErrorKind::InvalidData`], with a message saying what is wrong, when its layout
/// differs (another data set type, big-endian, a 32-bit header, compressed or appended data,
/// a `DataArray` whose size does not match `NumberOfPoints`, malformed XML or base64 …).
pub fn read_vtp(path: &Path) -> Result<VtpData> {
    let text = fs::read_to_string(path).map_err(|e| io_error(path, e))?;
    parse_vtp(&text).map_err(|message| invalid_data(path, message))
}

fn parse_vtp(text: &str) -> std::result::Result<VtpData, String> {
    let mut xml = XmlReader::new(text);
    let root = xml.expect_start("VTKFile")?;
    root.expect_attr("type", "PolyData")?;
    root.expect_attr("byte_order", "LittleEndian")?;
    root.expect_attr("header_type", "UInt64")?;
    if let Some(c) = root.attr("compressor")? {
        return Err(format!("compressed data (compressor=\"{c}\") is not supported"));
    }
    xml.expect_start("PolyData")?;
    let piece = xml.expect_start("Piece")?;
    let n: usize = piece.parse_attr("NumberOfPoints")?;
    let verts: usize = piece.parse_attr("NumberOfVerts")?;
    if verts != n {
        return Err(format!(
            "NumberOfVerts = {verts} but NumberOfPoints = {n}: one vertex per point expected"
        ));
    }
    for other in ["NumberOfLines", "NumberOfStrips", "NumberOfPolys"] {
        if piece.attr(other)?.is_some_and(|v| v != "0") {
            return Err(format!("{other} must be 0: only vertex cells are supported"));
        }
    }

    let mut points = None;
    let mut arrays = Vec::new();
    let mut connectivity = None;
    let mut offsets = None;
    loop {
        match xml.next_tag()? {
            Tag::End("Piece") => break,
            Tag::Start(section) if section.name == "CellData" => {
                if !section.empty && !matches!(xml.next_tag()?, Tag::End("CellData")) {
                    return Err("CellData must be empty".into());
                }
            }
            Tag::Start(section) if ["PointData", "Points", "Verts"].contains(&section.name) => {
                if section.empty {
                    continue;
                }
                loop {
                    match xml.next_tag()? {
                        Tag::End(name) if name == section.name => break,
                        Tag::Start(array) if array.name == "DataArray" => {
                            let (name, components, data) = read_data_array(&mut xml, &array, n)?;
                            match (section.name, name.as_str()) {
                                ("PointData", _) => {
                                    let values = data.into_f64(&name)?;
                                    arrays.push(VtpArray {
                                        name,
                                        components,
                                        values,
                                    });
                                }
                                ("Points", _) => {
                                    if components != 3 {
                                        return Err(format!("Points has {components} components, 3 expected"));
                                    }
                                    points = Some(data.into_f64("Points")?);
                                }
                                ("Verts", "connectivity") => connectivity = Some(data.into_i64("connectivity")?),
                                ("Verts", "offsets") => offsets = Some(data.into_i64("offsets")?),
                                (_, other) => return Err(format!("unexpected DataArray `{other}` in Verts")),
                            }
                        }
                        other => return Err(format!("unexpected {other} in {}", section.name)),
                    }
                }
            }
            other => return Err(format!("unexpected {other} in Piece")),
        }
    }
    xml.expect_end("PolyData")?;
    xml.expect_end("VTKFile")?;
    xml.expect_eof()?;

    let points = points.ok_or("no Points array")?;
    let connectivity = connectivity.ok_or("no Verts connectivity array")?;
    let offsets = offsets.ok_or("no Verts offsets array")?;
    if let Some(i) = (0..n).find(|&i| connectivity[i] != i as i64) {
        return Err(format!(
            "connectivity[{i}] = {}, expected {i} (vertex cell i is point i)",
            connectivity[i]
        ));
    }
    if let Some(i) = (0..n).find(|&i| offsets[i] != i as i64 + 1) {
        return Err(format!(
            "offsets[{i}] = {}, expected {} (one point per vertex cell)",
            offsets[i],
            i + 1
        ));
    }
    Ok(VtpData {
        points: points.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect(),
        arrays,
    })
}

enum ArrayData {
    F64(Vec<f64>),
    I64(Vec<i64>),
}

impl ArrayData {
    fn into_f64(self, name: &str) -> std::result::Result<Vec<f64>, String> {
        match self {
            ArrayData::F64(v) => Ok(v),
            ArrayData::I64(_) => Err(format!("DataArray `{name}` is Int64, Float64 expected")),
        }
    }

    fn into_i64(self, name: &str) -> std::result::Result<Vec<i64>, String> {
        match self {
            ArrayData::I64(v) => Ok(v),
            ArrayData::F64(_) => Err(format!("DataArray `{name}` is Float64, Int64 expected")),
        }
    }
}

/// Reads the contents and the end tag of a `<DataArray …>` start tag: its name, components and
/// `n × components` values.
fn read_data_array(
    xml: &mut XmlReader<'_>,
    start: &StartTag<'_>,
    n: usize,
) -> std::result::Result<(String, usize, ArrayData), String> {
    let name = start.attr("Name")?.ok_or("a DataArray has no Name")?;
    let components: usize = match start.attr("NumberOfComponents")? {
        None => 1,
        Some(c) => c
            .parse()
            .map_err(|_| format!("DataArray `{name}`: NumberOfComponents = `{c}` is not a count"))?,
    };
    let format = start.attr("format")?.unwrap_or_default();
    if format != "binary" {
        return Err(format!(
            "DataArray `{name}` has format=\"{format}\"; only inline \"binary\" is supported"
        ));
    }
    let ty = start.attr("type")?.unwrap_or_default();
    if ty != "Float64" && ty != "Int64" {
        return Err(format!(
            "DataArray `{name}` has type=\"{ty}\"; Float64 or Int64 expected"
        ));
    }
    if start.empty {
        return Err(format!("DataArray `{name}` has no data"));
    }
    let text = xml.text();
    xml.expect_end("DataArray")?;
    let bytes = decode_base64(text).map_err(|e| format!("DataArray `{name}`: {e}"))?;
    if bytes.len() < 8 {
        return Err(format!(
            "DataArray `{name}`: {} bytes, shorter than its 8-byte header",
            bytes.len()
        ));
    }
    let (header, data) = bytes.split_at(8);
    let declared = u64::from_le_bytes(header.try_into().expect("8 bytes"));
    if declared != data.len() as u64 {
        return Err(format!(
            "DataArray `{name}`: header says {declared} bytes but {} follow",
            data.len()
        ));
    }
    let expected = n.checked_mul(components).and_then(|v| v.checked_mul(8));
    if expected != Some(data.len()) {
        return Err(format!(
            "DataArray `{name}`: {} bytes, but {n} points × {components} components × 8 bytes expected",
            data.len()
        ));
    }
    let words = data.chunks_exact(8).map(|b| b.try_into().expect("8 bytes"));
    let values = if ty == "Float64" {
        ArrayData::F64(words.map(f64::from_le_bytes).collect())
    } else {
        ArrayData::I64(words.map(i64::from_le_bytes).collect())
    };
    Ok((name, components, values))
}

/// Reads a `.pvd` collection in exactly the layout [`PvdWriter`](super::PvdWriter) writes: the `(timestep, file)`
/// of every `DataSet`, in file order, with `file` as written (relative to the `.pvd`'s
/// directory, unescaped).
///
/// # Errors
/// [`MpmError::Io`](crate::MpmError::Io) naming `path` when it cannot be read, and of kind
/// [`std::io::ErrorKind::InvalidData`], with a message saying what is wrong, when it is not
/// such a collection (malformed XML, another root type, a `DataSet` without `timestep` or
/// `file`, a time that is not a number …).
pub fn read_pvd(path: &Path) -> Result<Vec<(f64, PathBuf)>> {
    let text = fs::read_to_string(path).map_err(|e| io_error(path, e))?;
    parse_pvd(&text).map_err(|message| invalid_data(path, message))
}

fn parse_pvd(text: &str) -> std::result::Result<Vec<(f64, PathBuf)>, String> {
    let mut xml = XmlReader::new(text);
    let root = xml.expect_start("VTKFile")?;
    root.expect_attr("type", "Collection")?;
    let collection = xml.expect_start("Collection")?;
    let mut entries = Vec::new();
    if !collection.empty {
        loop {
            match xml.next_tag()? {
                Tag::End("Collection") => break,
                Tag::Start(data_set) if data_set.name == "DataSet" => {
                    let time: f64 = data_set.parse_attr("timestep")?;
                    let file = data_set.attr("file")?.ok_or("a DataSet has no `file` attribute")?;
                    if !data_set.empty {
                        xml.expect_end("DataSet")?;
                    }
                    entries.push((time, PathBuf::from(file)));
                }
                other => return Err(format!("unexpected {other} in Collection")),
            }
        }
    }
    xml.expect_end("VTKFile")?;
    xml.expect_eof()?;
    Ok(entries)
}

// ------------------------------------------------------------------------------------------------
// A minimal XML tag reader for the files written here.

struct StartTag<'a> {
    name: &'a str,
    /// The raw text between the name and `>` / `/>`.
    attrs: &'a str,
    /// `<name …/>`.
    empty: bool,
}

impl<'a> StartTag<'a> {
    /// The unescaped value of attribute `key`, if present.
    fn attr(&self, key: &str) -> std::result::Result<Option<String>, String> {
        let mut rest = self.attrs.trim_start();
        while !rest.is_empty() {
            let eq = rest
                .find('=')
                .ok_or_else(|| format!("malformed attributes in <{}>", self.name))?;
            let k = rest[..eq].trim_end();
            let after = rest[eq + 1..].trim_start();
            let quote = after
                .chars()
                .next()
                .filter(|&q| q == '"' || q == '\'')
                .ok_or_else(|| format!("attribute `{k}` of <{}> is not quoted", self.name))?;
            let end = after[1..]
                .find(quote)
                .ok_or_else(|| format!("unterminated attribute `{k}` in <{}>", self.name))?;
            if k == key {
                return xml_unescape(&after[1..1 + end]).map(Some);
            }
            rest = after[end + 2..].trim_start();
        }
        Ok(None)
    }

    fn expect_attr(&self, key: &str, value: &str) -> std::result::Result<(), String> {
        match self.attr(key)? {
            Some(v) if v == value => Ok(()),
            Some(v) => Err(format!("<{}> has {key}=\"{v}\"; \"{value}\" expected", self.name)),
            None => Err(format!(
                "<{}> has no {key} attribute; {key}=\"{value}\" expected",
                self.name
            )),
        }
    }

    fn parse_attr<T: std::str::FromStr>(&self, key: &str) -> std::result::Result<T, String> {
        let v = self
            .attr(key)?
            .ok_or_else(|| format!("<{}> has no {key} attribute", self.name))?;
        v.parse()
            .map_err(|_| format!("<{}>: {key}=\"{v}\" is not a valid value", self.name))
    }
}

enum Tag<'a> {
    Start(StartTag<'a>),
    End(&'a str),
    Eof,
}

impl std::fmt::Display for Tag<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Tag::Start(s) => write!(f, "<{}>", s.name),
            Tag::End(name) => write!(f, "</{name}>"),
            Tag::Eof => f.write_str("end of file"),
        }
    }
}

/// Walks the tags of a document, checking that they nest properly; text between tags is only
/// allowed where [`XmlReader::text`] reads it (inside `DataArray`), otherwise it must be
/// whitespace.
struct XmlReader<'a> {
    text: &'a str,
    pos: usize,
    open: Vec<&'a str>,
}

impl<'a> XmlReader<'a> {
    fn new(text: &'a str) -> Self {
        XmlReader {
            text,
            pos: 0,
            open: Vec::new(),
        }
    }

    /// The text up to the next `<`.
    fn text(&mut self) -> &'a str {
        let rest = &self.text[self.pos..];
        let end = rest.find('<').unwrap_or(rest.len());
        self.pos += end;
        &rest[..end]
    }

    fn next_tag(&mut self) -> std::result::Result<Tag<'a>, String> {
        loop {
            let between = self.text();
            if !between.trim().is_empty() {
                let shown: String = between.trim().chars().take(40).collect();
                return Err(format!(
                    "unexpected text `{shown}` at byte {}",
                    self.pos - between.len()
                ));
            }
            let rest = &self.text[self.pos..];
            if rest.is_empty() {
                return match self.open.last() {
                    None => Ok(Tag::Eof),
                    Some(name) => Err(format!("the file ends inside <{name}>")),
                };
            }
            // Declarations and comments.
            for (open, close) in [("<?", "?>"), ("<!--", "-->")] {
                if rest.starts_with(open) {
                    let end = rest
                        .find(close)
                        .ok_or_else(|| format!("unterminated `{open}` at byte {}", self.pos))?;
                    self.pos += end + close.len();
                }
            }
            let rest = &self.text[self.pos..];
            if rest.starts_with("<?") || rest.starts_with("<!--") || !rest.starts_with('<') {
                continue;
            }
            let end = find_tag_end(rest).ok_or_else(|| format!("unterminated tag at byte {}", self.pos))?;
            let inner = &rest[1..end];
            self.pos += end + 1;
            if let Some(name) = inner.strip_prefix('/') {
                let name = name.trim();
                return match self.open.pop() {
                    Some(open) if open == name => Ok(Tag::End(name)),
                    Some(open) => Err(format!("</{name}> closes <{open}>")),
                    None => Err(format!("</{name}> closes nothing")),
                };
            }
            let (inner, empty) = match inner.strip_suffix('/') {
                Some(inner) => (inner, true),
                None => (inner, false),
            };
            let name_end = inner.find(|c: char| c.is_ascii_whitespace()).unwrap_or(inner.len());
            let name = &inner[..name_end];
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || "_-:.".contains(c)) {
                return Err(format!("malformed tag `<{inner}>`"));
            }
            if !empty {
                self.open.push(name);
            }
            return Ok(Tag::Start(StartTag {
                name,
                attrs: &inner[name_end..],
                empty,
            }));
        }
    }

    fn expect_start(&mut self, name: &str) -> std::result::Result<StartTag<'a>, String> {
        match self.next_tag()? {
            Tag::Start(tag) if tag.name == name => Ok(tag),
            other => Err(format!("<{name}> expected, found {other}")),
        }
    }

    fn expect_end(&mut self, name: &str) -> std::result::Result<(), String> {
        match self.next_tag()? {
            Tag::End(n) if n == name => Ok(()),
            other => Err(format!("</{name}> expected, found {other}")),
        }
    }

    fn expect_eof(&mut self) -> std::result::Result<(), String> {
        match self.next_tag()? {
            Tag::Eof => Ok(()),
            other => Err(format!("{other} after the end of the document")),
        }
    }
}

/// The index of the `>` closing the tag that starts `s`, skipping quoted attribute values.
fn find_tag_end(s: &str) -> Option<usize> {
    let mut quote = None;
    for (i, c) in s.char_indices() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            (None, '>') => return Some(i),
            _ => {}
        }
    }
    None
}
