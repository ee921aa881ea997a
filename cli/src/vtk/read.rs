//! Reading snapshots back: the `.vtp` files and `.pvd` series this module writes (and VTK XML
//! PolyData written by others in the same encodings), for `mpm render` and for programs that
//! post-process a run without ParaView.
//!
//! What is read: the points and the point-data arrays of the first `Piece`, each array in
//! `format="binary"` (inline base64, uncompressed, `header_type` `UInt32` or `UInt64`) or
//! `format="ascii"`, of any VTK numeric type (converted to `f64`). Compressed arrays
//! (`compressor=…`) and `<AppendedData>` are refused with an error that says so.

use std::path::{Path, PathBuf};

use super::base64::decode_base64;
use sparse_mpm::error::{MpmError, Result};

/// The largest snapshot or series file read (bytes): 4 GiB, some 12 million particles with the
/// arrays a run writes.
pub const MAX_SNAPSHOT_BYTES: u64 = 4 << 30;

/// A snapshot read back: the particle positions and the point-data arrays, in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// `x` of every point.
    pub x: Vec<f64>,
    /// `y` of every point.
    pub y: Vec<f64>,
    /// The point-data arrays, in file order.
    pub arrays: Vec<SnapshotArray>,
}

/// One point-data array of a [`Snapshot`].
#[derive(Clone, Debug, PartialEq)]
pub struct SnapshotArray {
    /// The array's name.
    pub name: String,
    /// Values per point: 1 for a scalar, 3 for a vector, 9 for a tensor.
    pub components: usize,
    /// The components' names (`ComponentName0`, …), empty strings where the file gives none.
    pub component_names: Vec<String>,
    /// `components` values per point, point after point.
    pub values: Vec<f64>,
}

impl Snapshot {
    /// The number of points.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether the snapshot holds no points.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// The first point-data array called `name`.
    pub fn array(&self, name: &str) -> Option<&SnapshotArray> {
        self.arrays.iter().find(|a| a.name == name)
    }
}

impl SnapshotArray {
    /// Component `c` of every point (`component(1)` of a vector is its y components).
    /// `None` when `c` is not below [`SnapshotArray::components`].
    pub fn component(&self, c: usize) -> Option<Vec<f64>> {
        (c < self.components).then(|| self.values.iter().skip(c).step_by(self.components).copied().collect())
    }

    /// The Euclidean norm of each point's components: `|v| = √(Σ_c v_c²)` (for a vector its
    /// length, for a tensor its Frobenius norm, for a scalar its absolute value).
    pub fn magnitude(&self) -> Vec<f64> {
        self.values
            .chunks_exact(self.components.max(1))
            .map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt())
            .collect()
    }
}

/// Reads a `.vtp` snapshot: the points and the point-data arrays of the first `Piece`, in
/// `format="binary"` (inline base64, uncompressed) or `format="ascii"`, any VTK numeric type.
///
/// # Errors
/// [`MpmError::Io`] when the file cannot be read; [`MpmError::Snapshot`] naming the file when it
/// is larger than [`MAX_SNAPSHOT_BYTES`], not VTK XML PolyData, in an encoding this reader does
/// not take, or when an array is truncated or of the wrong length.
pub fn read_vtp(path: &Path) -> Result<Snapshot> {
    let text = read_bounded(path)?;
    parse_vtp(&text).map_err(|reason| MpmError::Snapshot {
        path: path.to_path_buf(),
        reason,
    })
}

/// Reads a `.pvd` series: `(time, file)` of every `<DataSet>`, in file order, the files joined
/// to the `.pvd`'s folder.
///
/// # Errors
/// [`MpmError::Io`] when the file cannot be read; [`MpmError::Snapshot`] naming it when it is not
/// a VTK collection, a data set has no `file` or a `timestep` that is not a number, or a file
/// name is absolute or leaves the folder (`..`).
pub fn read_pvd(path: &Path) -> Result<Vec<(f64, PathBuf)>> {
    let bad = |reason: String| MpmError::Snapshot {
        path: path.to_path_buf(),
        reason,
    };
    let text = read_bounded(path)?;
    if !text.contains("type=\"Collection\"") {
        return Err(bad("not a VTK collection (.pvd): no `type=\"Collection\"`".into()));
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut entries = Vec::new();
    for (k, tag) in tags(&text, "DataSet").enumerate() {
        let attrs = attributes(tag.attributes).map_err(|e| bad(format!("data set {k}: {e}")))?;
        let get = |key: &str| attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
        let file = get("file").ok_or_else(|| bad(format!("data set {k} has no `file`")))?;
        let time = match get("timestep") {
            Some(t) => t
                .trim()
                .parse::<f64>()
                .map_err(|_| bad(format!("data set {k}: timestep `{t}` is not a number")))?,
            None => k as f64,
        };
        let relative = Path::new(file);
        if relative.is_absolute()
            || relative
                .components()
                .any(|c| !matches!(c, std::path::Component::Normal(_) | std::path::Component::CurDir))
        {
            return Err(bad(format!(
                "data set {k}: `{file}` is not a file name inside the series' folder"
            )));
        }
        entries.push((time, dir.join(relative)));
    }
    Ok(entries)
}

fn read_bounded(path: &Path) -> Result<String> {
    sparse_mpm::io::read_bounded_text(path, MAX_SNAPSHOT_BYTES, "snapshot")
}

/// One XML element: its attribute text and its content (empty for `<…/>`).
struct Tag<'a> {
    attributes: &'a str,
    content: &'a str,
}

/// The elements `<name …>…</name>` or `<name …/>` of `text`, in order (not nested in themselves).
fn tags<'a>(text: &'a str, name: &'a str) -> impl Iterator<Item = Tag<'a>> + 'a {
    let open = format!("<{name}");
    let close = format!("</{name}>");
    let mut rest = text;
    std::iter::from_fn(move || loop {
        let start = rest.find(&open)?;
        let after = &rest[start + open.len()..];
        // `<DataSetX` is another element.
        if !after.starts_with(|c: char| c.is_ascii_whitespace() || c == '>' || c == '/') {
            rest = after;
            continue;
        }
        let end = after.find('>')?;
        let (attributes, self_closing) = match after[..end].strip_suffix('/') {
            Some(a) => (a, true),
            None => (&after[..end], false),
        };
        let body = &after[end + 1..];
        if self_closing {
            rest = body;
            return Some(Tag {
                attributes,
                content: "",
            });
        }
        let stop = body.find(&close).unwrap_or(body.len());
        rest = &body[(stop + close.len()).min(body.len())..];
        return Some(Tag {
            attributes,
            content: &body[..stop],
        });
    })
}

/// The `key="value"` (or `'value'`) pairs of an element's attribute text, values unescaped.
fn attributes(text: &str) -> std::result::Result<Vec<(String, String)>, String> {
    let mut out = Vec::new();
    let mut rest = text.trim_start();
    while !rest.is_empty() {
        let eq = rest
            .find('=')
            .ok_or_else(|| format!("attribute text `{}` has no `=`", rest.trim()))?;
        let key = rest[..eq].trim().to_string();
        let after = rest[eq + 1..].trim_start();
        let quote = after
            .chars()
            .next()
            .filter(|&c| c == '"' || c == '\'')
            .ok_or_else(|| format!("attribute `{key}` has no quoted value"))?;
        let close = after[1..]
            .find(quote)
            .ok_or_else(|| format!("attribute `{key}`'s value is not closed"))?;
        out.push((key, unescape(&after[1..1 + close])));
        rest = after[close + 2..].trim_start();
    }
    Ok(out)
}

fn unescape(s: &str) -> String {
    if !s.contains('&') {
        return s.to_string();
    }
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

fn parse_vtp(text: &str) -> std::result::Result<Snapshot, String> {
    let root = tags(text, "VTKFile")
        .next()
        .ok_or("not a VTK XML file: no <VTKFile> element")?;
    let root_attrs = attributes(root.attributes)?;
    let root_get = |key: &str| root_attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
    if root_get("type") != Some("PolyData") {
        return Err(format!(
            "a VTK file of type `{}`, not PolyData (.vtp)",
            root_get("type").unwrap_or("")
        ));
    }
    if root_get("compressor").is_some() {
        return Err("compressed data (a `compressor`) is not read: write the file uncompressed".into());
    }
    if root.content.contains("<AppendedData") {
        return Err("<AppendedData> is not read: write the arrays inline (binary or ascii)".into());
    }
    if root_get("byte_order").is_some_and(|o| o != "LittleEndian") {
        return Err("big-endian data is not read".into());
    }
    let header_bytes = match root_get("header_type") {
        None | Some("UInt32") => 4,
        Some("UInt64") => 8,
        Some(other) => return Err(format!("header_type `{other}` is not UInt32 or UInt64")),
    };
    let piece = tags(root.content, "Piece").next().ok_or("no <Piece>")?;
    let piece_attrs = attributes(piece.attributes)?;
    let n: usize = piece_attrs
        .iter()
        .find(|(k, _)| k == "NumberOfPoints")
        .ok_or("the <Piece> has no NumberOfPoints")?
        .1
        .trim()
        .parse()
        .map_err(|_| "NumberOfPoints is not a count")?;
    let mut scratch = Vec::new();
    let points = tags(piece.content, "Points").next().ok_or("no <Points>")?;
    let coordinates = tags(points.content, "DataArray")
        .next()
        .ok_or("<Points> holds no array")?;
    let (_, components, _, values) = read_array(&coordinates, n, header_bytes, &mut scratch)?;
    if components != 3 {
        return Err(format!("Points have {components} components, not 3"));
    }
    let (x, y) = values.chunks_exact(3).map(|p| (p[0], p[1])).unzip();
    let mut arrays = Vec::new();
    if let Some(data) = tags(piece.content, "PointData").next() {
        for array in tags(data.content, "DataArray") {
            let (name, components, component_names, values) = read_array(&array, n, header_bytes, &mut scratch)?;
            arrays.push(SnapshotArray {
                name,
                components,
                component_names,
                values,
            });
        }
    }
    Ok(Snapshot { x, y, arrays })
}

type Array = (String, usize, Vec<String>, Vec<f64>);

fn read_array(
    tag: &Tag<'_>,
    n: usize,
    header_bytes: usize,
    scratch: &mut Vec<u8>,
) -> std::result::Result<Array, String> {
    let attrs = attributes(tag.attributes)?;
    let get = |key: &str| attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
    let name = get("Name").unwrap_or("").to_string();
    let what = |reason: String| format!("array `{name}`: {reason}");
    let components: usize = match get("NumberOfComponents") {
        Some(c) => c
            .trim()
            .parse()
            .ok()
            .filter(|&c| (1..=64).contains(&c))
            .ok_or_else(|| what(format!("NumberOfComponents `{c}` is not a count from 1 to 64")))?,
        None => 1,
    };
    let component_names = (0..components)
        .map(|c| get(&format!("ComponentName{c}")).unwrap_or("").to_string())
        .collect();
    let ty = get("type").ok_or_else(|| what("no type".into()))?;
    let size = match ty {
        "Float64" | "Int64" | "UInt64" => 8,
        "Float32" | "Int32" | "UInt32" => 4,
        "Int16" | "UInt16" => 2,
        "Int8" | "UInt8" => 1,
        other => return Err(what(format!("type `{other}` is not a VTK numeric type"))),
    };
    let count = n
        .checked_mul(components)
        .ok_or_else(|| what("too many values".into()))?;
    let values: Vec<f64> = match get("format").unwrap_or("ascii") {
        "ascii" => tag
            .content
            .split_ascii_whitespace()
            .map(|t| t.parse::<f64>().map_err(|_| what(format!("`{t}` is not a number"))))
            .collect::<std::result::Result<_, _>>()?,
        "binary" => {
            decode_base64(tag.content.as_bytes(), scratch)
                .ok_or_else(|| what("the binary data is not base64".into()))?;
            if scratch.len() < header_bytes {
                return Err(what("the binary data has no header".into()));
            }
            let mut header = [0u8; 8];
            header[..header_bytes].copy_from_slice(&scratch[..header_bytes]);
            let declared = u64::from_le_bytes(header);
            let data = &scratch[header_bytes..];
            if declared > data.len() as u64 {
                return Err(what(format!(
                    "the header declares {declared} bytes but {} follow (truncated?)",
                    data.len()
                )));
            }
            let data = &data[..(declared as usize).min(data.len())];
            if !data.len().is_multiple_of(size) {
                return Err(what(format!(
                    "{} bytes is not a whole number of {ty} values",
                    data.len()
                )));
            }
            data.chunks_exact(size).map(|b| number(ty, b)).collect()
        }
        other => return Err(what(format!("format `{other}` is not read (binary or ascii only)"))),
    };
    if values.len() != count {
        return Err(what(format!(
            "{} values, but {n} points × {components} components = {count} are needed",
            values.len()
        )));
    }
    Ok((name, components, component_names, values))
}

fn number(ty: &str, b: &[u8]) -> f64 {
    let a = |k: usize| -> [u8; 8] {
        let mut out = [0; 8];
        out[..k].copy_from_slice(&b[..k]);
        out
    };
    match ty {
        "Float64" => f64::from_le_bytes(a(8)),
        "Int64" => i64::from_le_bytes(a(8)) as f64,
        "UInt64" => u64::from_le_bytes(a(8)) as f64,
        "Float32" => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        "Int32" => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        "UInt32" => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        "Int16" => f64::from(i16::from_le_bytes([b[0], b[1]])),
        "UInt16" => f64::from(u16::from_le_bytes([b[0], b[1]])),
        "Int8" => f64::from(b[0] as i8),
        _ => f64::from(b[0]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vtk::{write_vtp, Field};

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("sparse-mpm-vtk-read-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn what_write_vtp_writes_reads_back_bit_for_bit() {
        let dir = scratch("roundtrip");
        let path = dir.join("p.vtp");
        let x = [0.1, -2.5e-300, f64::NAN];
        let y = [1.0, 2.0, -0.0];
        let s = [1.5, f64::INFINITY, -3.0];
        let ids = [7usize, 0, 1 << 40];
        write_vtp(
            &path,
            &x,
            &y,
            &[
                Field::Index {
                    name: "id",
                    values: &ids,
                },
                Field::Scalar {
                    name: "a&b",
                    values: &s,
                },
                Field::Vector {
                    name: "v",
                    x: &y,
                    y: &x,
                },
                Field::Tensor {
                    name: "t",
                    xx: &s,
                    xy: &x,
                    yx: &y,
                    yy: &s,
                },
            ],
        )
        .unwrap();
        let snap = read_vtp(&path).unwrap();
        let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&snap.x), bits(&x));
        assert_eq!(bits(&snap.y), bits(&y));
        assert_eq!(snap.array("id").unwrap().values, [7.0, 0.0, (1u64 << 40) as f64]);
        assert_eq!(bits(&snap.array("a&b").unwrap().values), bits(&s));
        let v = snap.array("v").unwrap();
        assert_eq!(v.components, 3);
        assert_eq!(v.component_names, ["x", "y", "z"]);
        assert_eq!(bits(&v.component(1).unwrap()), bits(&x));
        let t = snap.array("t").unwrap();
        assert_eq!(t.components, 9);
        assert_eq!(t.component_names[3], "yx");
        assert_eq!(bits(&t.component(3).unwrap()), bits(&y));
        assert!(v.component(3).is_none());
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn ascii_arrays_and_32_bit_headers_are_read() {
        let text = r#"<?xml version="1.0"?>
<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian">
  <PolyData><Piece NumberOfPoints="2" NumberOfVerts="0">
    <PointData><DataArray type="Int32" Name="k" format="ascii">3 -4</DataArray>
    <DataArray type="Float32" Name="f" format="binary">CAAAAAAAwD8AACDA</DataArray></PointData>
    <Points><DataArray type="Float32" NumberOfComponents="3" format="ascii">0 1 0  2 3 0</DataArray></Points>
  </Piece></PolyData></VTKFile>"#;
        let snap = parse_vtp(text).unwrap();
        assert_eq!(snap.x, [0.0, 2.0]);
        assert_eq!(snap.y, [1.0, 3.0]);
        assert_eq!(snap.array("k").unwrap().values, [3.0, -4.0]);
        assert_eq!(snap.array("f").unwrap().values, [1.5, -2.5]);
    }

    #[test]
    fn bad_files_are_refused_with_the_reason() {
        let cases = [
            ("<html></html>", "no <VTKFile>"),
            (r#"<VTKFile type="UnstructuredGrid"></VTKFile>"#, "not PolyData"),
            (
                r#"<VTKFile type="PolyData" compressor="vtkZLibDataCompressor"></VTKFile>"#,
                "compressed",
            ),
            (
                r#"<VTKFile type="PolyData"><PolyData><Piece NumberOfPoints="2"><Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 1 0</DataArray></Points></Piece></PolyData></VTKFile>"#,
                "3 values, but 2 points",
            ),
            (
                r#"<VTKFile type="PolyData" header_type="UInt64"><PolyData><Piece NumberOfPoints="1"><Points><DataArray type="Float64" NumberOfComponents="3" format="binary">GAAAAAAAAAAAAAAA</DataArray></Points></Piece></PolyData></VTKFile>"#,
                "truncated",
            ),
            (
                r#"<VTKFile type="PolyData"><PolyData><Piece NumberOfPoints="1"><Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 x 0</DataArray></Points></Piece></PolyData></VTKFile>"#,
                "`x` is not a number",
            ),
        ];
        for (text, expected) in cases {
            let err = parse_vtp(text).unwrap_err();
            assert!(err.contains(expected), "{text}: {err}");
        }
    }

    #[test]
    fn a_series_lists_its_files_and_refuses_paths_outside_its_folder() {
        let dir = scratch("pvd");
        let path = dir.join("run.pvd");
        std::fs::write(
            &path,
            r#"<VTKFile type="Collection"><Collection>
<DataSet timestep="0" group="" part="0" file="a.vtp"/>
<DataSet timestep="2.5e-3" file="b&amp;c.vtp"/></Collection></VTKFile>"#,
        )
        .unwrap();
        assert_eq!(
            read_pvd(&path).unwrap(),
            [(0.0, dir.join("a.vtp")), (2.5e-3, dir.join("b&c.vtp"))]
        );
        for file in ["../x.vtp", "/etc/passwd"] {
            std::fs::write(
                &path,
                format!(r#"<VTKFile type="Collection"><Collection><DataSet timestep="0" file="{file}"/></Collection></VTKFile>"#),
            )
            .unwrap();
            let err = read_pvd(&path).unwrap_err().to_string();
            assert!(err.contains("not a file name inside"), "{err}");
        }
        std::fs::remove_dir_all(dir).unwrap();
    }
}
