//! Reading the `.vtp` snapshots and `.pvd` collections the library writes, for the tests: the
//! snapshots through the independent `vtkio` reader, the collection (a small XML file that
//! `vtkio` does not read) with a few lines of attribute parsing.
//!
//! Use it with `#[path = "common/vtk_read.rs"] mod vtk_read;`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use vtkio::model::{Attribute, DataSet, Piece};
use vtkio::IOBuffer;

/// The points and point-data arrays of a `.vtp` snapshot.
#[derive(Clone, Debug, PartialEq)]
pub struct VtpData {
    /// The particle positions `(x, y, z)` (`z` is 0 in the files the library writes).
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

/// One point-data array of a snapshot.
#[derive(Clone, Debug, PartialEq)]
pub struct VtpArray {
    /// The array's name.
    pub name: String,
    /// Components per point: 1 for a scalar, 3 for a vector, 9 for a tensor.
    pub components: usize,
    /// `components` values per point, point after point.
    pub values: Vec<f64>,
}

impl VtpArray {
    /// The `components` values of point `i`.
    pub fn point(&self, i: usize) -> &[f64] {
        &self.values[i * self.components..(i + 1) * self.components]
    }

    /// Component `c` of every point (e.g. `component(1)` of a vector is its y components).
    pub fn component(&self, c: usize) -> Vec<f64> {
        assert!(
            c < self.components,
            "component {c} of a {}-component array",
            self.components
        );
        self.values.iter().skip(c).step_by(self.components).copied().collect()
    }
}

/// The values of a buffer of `Float64` data.
pub fn f64_values(buffer: &IOBuffer, what: &str) -> Result<Vec<f64>, String> {
    match buffer {
        IOBuffer::F64(v) => Ok(v.clone()),
        // Index arrays (`id`, `body`) are written as Int64; their values are exact in f64 below 2^53.
        IOBuffer::I64(v) => Ok(v.iter().map(|&i| i as f64).collect()),
        other => Err(format!(
            "{what}: expected Float64 or Int64 data, found {:?}",
            other.scalar_type()
        )),
    }
}

/// Reads a `.vtp` file of one inline piece with `vtkio`: its points and point-data arrays (every
/// array must be `Float64` or `Int64`; `vtkio` skips arrays it cannot read, so compare the count with what
/// was written).
pub fn read_vtp(path: &Path) -> Result<VtpData, String> {
    let vtk = vtkio::Vtk::import(path).map_err(|e| format!("{}: vtkio: {e:?}", path.display()))?;
    let DataSet::PolyData { pieces, .. } = vtk.data else {
        return Err(format!("{}: not poly data", path.display()));
    };
    let [Piece::Inline(piece)] = pieces.as_slice() else {
        return Err(format!("{}: not one inline piece", path.display()));
    };
    let points = f64_values(&piece.points, "Points")?;
    if points.len() % 3 != 0 {
        return Err(format!("{}: {} point coordinates", path.display(), points.len()));
    }
    let mut arrays = Vec::new();
    for attribute in &piece.data.point {
        let Attribute::DataArray(array) = attribute else {
            return Err(format!("{}: a point attribute is not a data array", path.display()));
        };
        arrays.push(VtpArray {
            name: array.name.clone(),
            components: array.num_comp(),
            values: f64_values(&array.data, &array.name)?,
        });
    }
    Ok(VtpData {
        points: points.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect(),
        arrays,
    })
}

/// Reads the `(time, file)` pairs of a `.pvd` collection, in file order: the `timestep` and
/// `file` attributes of every `<DataSet …/>` element, XML entities unescaped.
pub fn read_pvd(path: &Path) -> Result<Vec<(f64, PathBuf)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    if !text.contains("<VTKFile type=\"Collection\"") || !text.contains("</Collection>") {
        return Err(format!("{}: not a whole collection", path.display()));
    }
    text.split("<DataSet ")
        .skip(1)
        .map(|element| {
            let tag = &element[..element.find("/>").ok_or("an unterminated <DataSet>")?];
            let time = attribute(tag, "timestep")?;
            let time = time
                .parse::<f64>()
                .map_err(|_| format!("timestep=\"{time}\" is not a number"))?;
            Ok((time, PathBuf::from(attribute(tag, "file")?)))
        })
        .collect::<Result<_, String>>()
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The unescaped value of attribute `name` in the inside of a tag.
fn attribute(tag: &str, name: &str) -> Result<String, String> {
    let key = format!(" {name}=\"");
    let start = format!(" {tag}")
        .find(&key)
        .ok_or_else(|| format!("no `{name}` in <DataSet {tag}/>"))?
        + key.len()
        - 1;
    let value = &tag[start..start + tag[start..].find('"').ok_or("an unterminated attribute")?];
    let mut out = String::new();
    let mut rest = value;
    while let Some(amp) = rest.find('&') {
        out.push_str(&rest[..amp]);
        let semi = amp + rest[amp..].find(';').ok_or("an unterminated entity")?;
        out.push(match &rest[amp + 1..semi] {
            "amp" => '&',
            "lt" => '<',
            "gt" => '>',
            "quot" => '"',
            "apos" => '\'',
            other => return Err(format!("unknown entity `&{other};`")),
        });
        rest = &rest[semi + 1..];
    }
    out.push_str(rest);
    Ok(out)
}
