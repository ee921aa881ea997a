//! Particle snapshots for ParaView: VTK XML PolyData (`.vtp`) files and a `.pvd` time series.
//!
//! This module writes them, and reads them back ([`read_vtp`], [`read_pvd`]) for `mpm render`
//! and post-processing without ParaView; ParaView, VTK's own readers and the `vtkio` crate read
//! them too (the tests read every `.vtp` file back with `vtkio`).
//!
//! ```no_run
//! use std::path::Path;
//! use sparse_mpm_cli::vtk::{write_vtp, Field, PvdWriter};
//!
//! let (x, y) = (vec![0.25, 0.75], vec![0.5, 0.5]);
//! let (mass, vx, vy) = (vec![1.0, 2.0], vec![0.0, 0.1], vec![-1.0, 0.0]);
//! let (sxx, sxy, syy) = (vec![1e3, 2e3], vec![0.0, 5.0], vec![-1e3, 0.0]);
//! let mut series = PvdWriter::create(Path::new("out/run.pvd"))?;
//! for step in 0..3 {
//!     let name = format!("particles_{step:05}.vtp");
//!     write_vtp(
//!         &Path::new("out").join(&name),
//!         &x,
//!         &y,
//!         &[
//!             Field::Scalar { name: "mass", values: &mass },
//!             Field::Vector { name: "velocity", x: &vx, y: &vy },
//!             Field::Tensor { name: "stress", xx: &sxx, xy: &sxy, yx: &sxy, yy: &syy },
//!         ],
//!     )?;
//!     series.push(step as f64 * 1e-3, Path::new(&name))?; // relative to the .pvd's directory
//! }
//! # Ok::<(), sparse_mpm::MpmError>(())
//! ```
//!
//! # The `.vtp` layout
//!
//! One `Piece` with `P` points (the particles, `z = 0`) and `P` vertex cells (cell `i` is point
//! `i`), so ParaView draws the particles without a glyph filter:
//!
//! ```text
//! <?xml version="1.0"?>
//! <VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">
//!   <PolyData>
//!     <Piece NumberOfPoints="P" NumberOfVerts="P" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0">
//!       <PointData>
//!         <DataArray type="Float64" Name="mass" NumberOfComponents="1" format="binary">…</DataArray>
//!         <DataArray type="Float64" Name="velocity" NumberOfComponents="3" ComponentName0="x" ComponentName1="y" ComponentName2="z" format="binary">…</DataArray>
//!         <DataArray type="Float64" Name="stress" NumberOfComponents="9" ComponentName0="xx" … ComponentName8="zz" format="binary">…</DataArray>
//!       </PointData>
//!       <CellData>
//!       </CellData>
//!       <Points>
//!         <DataArray type="Float64" Name="Points" NumberOfComponents="3" format="binary">…</DataArray>
//!       </Points>
//!       <Verts>
//!         <DataArray type="Int64" Name="connectivity" NumberOfComponents="1" format="binary">…</DataArray>
//!         <DataArray type="Int64" Name="offsets" NumberOfComponents="1" format="binary">…</DataArray>
//!       </Verts>
//!     </Piece>
//!   </PolyData>
//! </VTKFile>
//! ```
//!
//! * Every array is *inline binary*: the base64 encoding (RFC 4648, with `=` padding, no line
//!   breaks) of one byte string made of an 8-byte little-endian `UInt64` header holding the number
//!   of data bytes that follow, then the values, little-endian, components of a point together
//!   (`x0 y0 z0 x1 y1 z1 …`). This is VTK's uncompressed binary format as `vtkXMLWriter` writes it.
//! * `Points` holds `(x, y, 0)`. `connectivity` is `0, 1, …, P−1` and `offsets` is `1, 2, …, P`
//!   (the end of each cell, the format of file version 1.0).
//! * An index [`Field`] (`id`, `body`) is written as `Int64`, every other one as `Float64`.
//!   Vectors and tensors name their components (`ComponentName0="x"`, … `"xx"`, `"xy"`, …),
//!   which ParaView shows in its menus (`stress_xy`).
//! * A scalar [`Field`] has 1 component. A 2D vector has 3, `(x, y, 0)`, so ParaView shows it
//!   as a vector (arrows, magnitude). A 2 × 2 tensor has 9, the 3 × 3 tensor
//!   `[[xx, xy, 0], [yx, yy, 0], [0, 0, 0]]` row by row (`xx xy 0 yx yy 0 0 0 0`), which ParaView
//!   recognises as a tensor (eigenvalues, tensor glyphs).
//! * Point data arrays appear in the order of the `fields` slice. Names are XML-escaped.
//! * Values, coordinates included, are written bit for bit: NaN and infinities are data and
//!   are written as they are (ParaView reads them; a non-finite coordinate makes that particle
//!   invisible or stretches the bounds).
//!
//! A file takes about `32/3 × (5 + c)` bytes per particle, `c` being the total number of
//! components of the fields (`5` for the points, connectivity and offsets): 352 bytes for four
//! scalars, two vectors and two tensors.
//!
//! Why inline base64 rather than `<AppendedData encoding="raw">`: raw appended bytes are 25 %
//! smaller, but they are not well-formed XML (any byte may follow the `_`), and XML-based
//! readers cannot read them: `vtkio` 0.6 stops at the first `<` byte in the data and 0.7 has no
//! raw encoding. Base64 keeps every file readable by any XML parser as well as by VTK and
//! ParaView.
//!
//! # The `.pvd` layout
//!
//! ```text
//! <?xml version="1.0"?>
//! <VTKFile type="Collection" version="0.1" byte_order="LittleEndian">
//!   <Collection>
//!     <DataSet timestep="0" group="" part="0" file="particles_00000.vtp"/>
//!     <DataSet timestep="0.001" group="" part="0" file="particles_00001.vtp"/>
//!   </Collection>
//! </VTKFile>
//! ```
//!
//! Times are written in the shortest form that reads back bit for bit (`0.001`, `2.5e-9`); file
//! names are relative to the `.pvd`'s directory and XML-escaped.
//!
//! # Never half-written
//!
//! Every file is written to a temporary file (`.NAME.PID-N-R.tmp`) in the same directory, synced
//! to disk and renamed to `NAME`, so a run that is stopped at any moment, or a machine that
//! loses power, leaves either the previous complete file or the new complete one, never a
//! truncated one (the temporary file is removed when writing fails).

use std::io::Write;
use std::path::{Path, PathBuf};

use sparse_mpm::io::{io_error, write_atomically};
use sparse_mpm::numbers::push_round_trip;

mod base64;
mod read;

use base64::Base64Writer;
pub use read::{read_pvd, read_vtp, Snapshot, SnapshotArray, MAX_SNAPSHOT_BYTES};
use sparse_mpm::error::{MpmError, Result};

/// One point-data array of a snapshot: a value per particle.
///
/// Names are `&'static str` so that a length error can name the field
/// ([`MpmError::LengthMismatch`] holds a `&'static str`). Names should be distinct and non-empty
/// for ParaView to show every array.
#[derive(Clone, Copy, Debug)]
pub enum Field<'a> {
    /// One component per particle (mass, volume, pressure …).
    Scalar {
        /// Array name shown in ParaView.
        name: &'static str,
        /// One value per particle.
        values: &'a [f64],
    },
    /// A count or index per particle (id, body …), written as `Int64`.
    Index {
        /// Array name shown in ParaView.
        name: &'static str,
        /// One value per particle.
        values: &'a [usize],
    },
    /// A 2D vector per particle (velocity, displacement …), written with 3 components
    /// `(x, y, 0)`.
    Vector {
        /// Array name shown in ParaView.
        name: &'static str,
        /// x components, one per particle.
        x: &'a [f64],
        /// y components, one per particle.
        y: &'a [f64],
    },
    /// A 2 × 2 tensor per particle (stress, velocity gradient, deformation gradient …), written
    /// with 9 components: the 3 × 3 tensor `[[xx, xy, 0], [yx, yy, 0], [0, 0, 0]]` row by row.
    /// For a symmetric tensor pass the same slice as `xy` and `yx`.
    Tensor {
        /// Array name shown in ParaView.
        name: &'static str,
        /// Component (x, x), one per particle.
        xx: &'a [f64],
        /// Component (x, y) (first row, second column), one per particle.
        xy: &'a [f64],
        /// Component (y, x) (second row, first column), one per particle.
        yx: &'a [f64],
        /// Component (y, y), one per particle.
        yy: &'a [f64],
    },
}

impl<'a> Field<'a> {
    /// The array's name.
    pub fn name(&self) -> &'static str {
        match *self {
            Field::Scalar { name, .. }
            | Field::Index { name, .. }
            | Field::Vector { name, .. }
            | Field::Tensor { name, .. } => name,
        }
    }

    /// The number of components written per particle: 1, 3 or 9.
    pub fn components(&self) -> usize {
        match self {
            Field::Scalar { .. } | Field::Index { .. } => 1,
            Field::Vector { .. } => 3,
            Field::Tensor { .. } => 9,
        }
    }

    /// The names of its components, written as `ComponentName0`, … (ParaView shows them):
    /// none for a scalar, `x y z` for a vector, `xx xy xz yx yy yz zx zy zz` for a tensor.
    pub fn component_names(&self) -> &'static [&'static str] {
        match self {
            Field::Scalar { .. } | Field::Index { .. } => &[],
            Field::Vector { .. } => &["x", "y", "z"],
            Field::Tensor { .. } => &["xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"],
        }
    }

    /// The lengths of the slices the field is made of.
    fn lengths(&self) -> Vec<usize> {
        match *self {
            Field::Index { values, .. } => vec![values.len()],
            _ => self.slices().iter().map(|s| s.len()).collect(),
        }
    }

    /// The floating-point slices the field is made of (none for an index field).
    fn slices(&self) -> Vec<&'a [f64]> {
        match *self {
            Field::Index { .. } => vec![],
            Field::Scalar { values, .. } => vec![values],
            Field::Vector { x, y, .. } => vec![x, y],
            Field::Tensor { xx, xy, yx, yy, .. } => vec![xx, xy, yx, yy],
        }
    }
}

/// Writes the particles at `(x, y)` and their `fields` as a VTK XML PolyData file (see the
/// [module documentation](self) for the layout), atomically (a synced temporary file renamed to `path`).
///
/// Non-finite coordinates and values are data and are written as they are.
///
/// # Errors
/// * [`MpmError::LengthMismatch`] when `y` or a field's slice does not have `x.len()` entries;
///   `field` is `"y"` or the field's name. Nothing is written then.
/// * [`MpmError::Io`] naming `path` when the file cannot be written (missing directory, no
///   permission, disk full …).
pub fn write_vtp(path: &Path, x: &[f64], y: &[f64], fields: &[Field<'_>]) -> Result<()> {
    let n = x.len();
    check_len("y", n, y.len())?;
    for field in fields {
        for len in field.lengths() {
            check_len(field.name(), n, len)?;
        }
    }
    write_atomically(path, |w| write_vtp_body(w, x, y, fields))
}

fn check_len(field: &'static str, expected: usize, found: usize) -> Result<()> {
    if expected == found {
        Ok(())
    } else {
        Err(MpmError::LengthMismatch { field, expected, found })
    }
}

fn write_vtp_body<W: Write>(w: &mut W, x: &[f64], y: &[f64], fields: &[Field<'_>]) -> std::io::Result<()> {
    let n = x.len();
    let mut enc = Base64Writer::new();
    write!(
        w,
        "<?xml version=\"1.0\"?>\n\
         <VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  \
         <PolyData>\n    \
         <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{n}\" NumberOfLines=\"0\" NumberOfStrips=\"0\" \
         NumberOfPolys=\"0\">\n      \
         <PointData>\n"
    )?;
    for field in fields {
        let components = field.components();
        let ty = if matches!(field, Field::Index { .. }) {
            "Int64"
        } else {
            "Float64"
        };
        start_array(w, ty, field.name(), components, field.component_names())?;
        enc.begin(w, (n * components * 8) as u64)?;
        match *field {
            Field::Index { values, .. } => {
                for &v in values {
                    enc.push(w, (v as i64).to_le_bytes())?;
                }
            }
            Field::Scalar { values, .. } => {
                for &v in values {
                    enc.push(w, v.to_le_bytes())?;
                }
            }
            Field::Vector { x: vx, y: vy, .. } => {
                for (&a, &b) in vx.iter().zip(vy) {
                    enc.push(w, a.to_le_bytes())?;
                    enc.push(w, b.to_le_bytes())?;
                    enc.push(w, 0f64.to_le_bytes())?;
                }
            }
            Field::Tensor { xx, xy, yx, yy, .. } => {
                for i in 0..n {
                    let row = [xx[i], xy[i], 0.0, yx[i], yy[i], 0.0, 0.0, 0.0, 0.0];
                    for v in row {
                        enc.push(w, v.to_le_bytes())?;
                    }
                }
            }
        }
        enc.finish(w)?;
        w.write_all(b"</DataArray>\n")?;
    }
    w.write_all(b"      </PointData>\n      <CellData>\n      </CellData>\n      <Points>\n")?;
    start_array(w, "Float64", "Points", 3, &[])?;
    enc.begin(w, (n * 24) as u64)?;
    for (&a, &b) in x.iter().zip(y) {
        enc.push(w, a.to_le_bytes())?;
        enc.push(w, b.to_le_bytes())?;
        enc.push(w, 0f64.to_le_bytes())?;
    }
    enc.finish(w)?;
    w.write_all(b"</DataArray>\n      </Points>\n      <Verts>\n")?;
    for (name, first) in [("connectivity", 0i64), ("offsets", 1i64)] {
        start_array(w, "Int64", name, 1, &[])?;
        enc.begin(w, (n * 8) as u64)?;
        for i in 0..n as i64 {
            enc.push(w, (i + first).to_le_bytes())?;
        }
        enc.finish(w)?;
        w.write_all(b"</DataArray>\n")?;
    }
    w.write_all(b"      </Verts>\n    </Piece>\n  </PolyData>\n</VTKFile>\n")
}

fn start_array<W: Write>(
    w: &mut W,
    ty: &str,
    name: &str,
    components: usize,
    component_names: &[&str],
) -> std::io::Result<()> {
    write!(
        w,
        "        <DataArray type=\"{ty}\" Name=\"{}\" NumberOfComponents=\"{components}\"",
        xml_escape(name)
    )?;
    for (c, component) in component_names.iter().enumerate() {
        write!(w, " ComponentName{c}=\"{component}\"")?;
    }
    w.write_all(b" format=\"binary\">")
}

fn xml_escape(s: &str) -> std::borrow::Cow<'_, str> {
    if !s.contains(['&', '<', '>', '"', '\'']) {
        return s.into();
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out.into()
}

// ------------------------------------------------------------------------------------------------
// The .pvd time series

/// A ParaView collection (`.pvd`) listing snapshots with their times, rewritten whole (and
/// atomically) after every [`push`](PvdWriter::push), so a run stopped at any moment leaves a
/// valid collection listing every snapshot pushed so far. See the
/// [module documentation](self) for the layout.
#[derive(Debug)]
pub struct PvdWriter {
    path: PathBuf,
    entries: Vec<(f64, PathBuf)>,
    /// The `<DataSet …/>` lines written so far.
    lines: String,
}

impl PvdWriter {
    /// Starts a collection at `path`, writing it at once with no data sets (replacing any file
    /// there), so a missing directory is reported here rather than at the first snapshot.
    ///
    /// # Errors
    /// [`MpmError::Io`] naming `path` when it cannot be written.
    pub fn create(path: &Path) -> Result<Self> {
        let writer = PvdWriter {
            path: path.to_path_buf(),
            entries: Vec::new(),
            lines: String::new(),
        };
        writer.write()?;
        Ok(writer)
    }

    /// Adds the snapshot `file` at `time` and rewrites the collection. `file` is written as
    /// given and should be relative to the `.pvd`'s directory (so the output directory can be
    /// moved); it is XML-escaped. Times are written in their shortest round-trip form and need
    /// not increase (ParaView sorts them).
    ///
    /// # Errors
    /// * [`MpmError::InvalidParameter`] named `"time"` when `time` is not finite, and
    ///   [`MpmError::Io`] of kind `InvalidInput` naming `file` when it is not valid UTF-8; the
    ///   collection is unchanged then.
    /// * [`MpmError::Io`] naming the `.pvd` when it cannot be written; the snapshot is then not
    ///   part of the collection (the file on disk keeps the previous list).
    pub fn push(&mut self, time: f64, file: &Path) -> Result<()> {
        if !time.is_finite() {
            return Err(MpmError::InvalidParameter {
                name: "time",
                value: time,
                reason: "a snapshot time must be finite",
            });
        }
        let name = file.to_str().ok_or_else(|| {
            io_error(
                file,
                std::io::Error::new(std::io::ErrorKind::InvalidInput, "the file name is not valid UTF-8"),
            )
        })?;
        let previous = self.lines.len();
        self.lines.push_str("    <DataSet timestep=\"");
        push_round_trip(&mut self.lines, time);
        self.lines.push_str("\" group=\"\" part=\"0\" file=\"");
        self.lines.push_str(&xml_escape(name));
        self.lines.push_str("\"/>\n");
        if let Err(e) = self.write() {
            self.lines.truncate(previous);
            return Err(e);
        }
        self.entries.push((time, file.to_path_buf()));
        Ok(())
    }

    /// A collection at `path` listing `entries` (as [`PvdWriter::push`] would have after each
    /// of them), written at once: how a resumed run takes up the collection of the run it
    /// continues.
    ///
    /// # Errors
    /// As [`PvdWriter::push`] for each entry.
    pub fn with_entries(path: &Path, entries: &[(f64, PathBuf)]) -> Result<Self> {
        let mut writer = PvdWriter::create(path)?;
        for (time, file) in entries {
            writer.push(*time, file)?;
        }
        Ok(writer)
    }

    /// The `.pvd` file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The `(time, file)` pairs pushed so far.
    pub fn entries(&self) -> &[(f64, PathBuf)] {
        &self.entries
    }

    fn write(&self) -> Result<()> {
        write_atomically(&self.path, |w| {
            w.write_all(
                b"<?xml version=\"1.0\"?>\n\
                  <VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  \
                  <Collection>\n",
            )?;
            w.write_all(self.lines.as_bytes())?;
            w.write_all(b"  </Collection>\n</VTKFile>\n")
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xml_escaping_replaces_the_five_special_characters() {
        assert_eq!(xml_escape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&apos;");
        assert!(matches!(
            xml_escape("plain.vtp"),
            std::borrow::Cow::Borrowed("plain.vtp")
        ));
    }
}
