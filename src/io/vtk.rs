//! Particle snapshots for ParaView: VTK XML PolyData (`.vtp`) files and a `.pvd` time series.
//!
//! ```no_run
//! use std::path::Path;
//! use sparse_mpm::io::vtk::{write_vtp, Field, PvdWriter};
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
//!         <DataArray type="Float64" Name="velocity" NumberOfComponents="3" format="binary">…</DataArray>
//!         <DataArray type="Float64" Name="stress" NumberOfComponents="9" format="binary">…</DataArray>
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
//! Every file is written to `NAME.tmp` in the same directory and then renamed to `NAME`, so a
//! run that is stopped at any moment leaves either the previous complete file or the new
//! complete one, never a truncated one (the temporary file is removed when writing fails). The
//! data is not `fsync`ed: this protects against the process stopping, not against the machine
//! losing power.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::{invalid_data, io_error, push_f64};
use crate::error::{MpmError, Result};

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
            Field::Scalar { name, .. } | Field::Vector { name, .. } | Field::Tensor { name, .. } => name,
        }
    }

    /// The number of components written per particle: 1, 3 or 9.
    pub fn components(&self) -> usize {
        match self {
            Field::Scalar { .. } => 1,
            Field::Vector { .. } => 3,
            Field::Tensor { .. } => 9,
        }
    }

    /// The slices the field is made of.
    fn slices(&self) -> Vec<&'a [f64]> {
        match *self {
            Field::Scalar { values, .. } => vec![values],
            Field::Vector { x, y, .. } => vec![x, y],
            Field::Tensor { xx, xy, yx, yy, .. } => vec![xx, xy, yx, yy],
        }
    }
}

/// Writes the particles at `(x, y)` and their `fields` as a VTK XML PolyData file (see the
/// [module documentation](self) for the layout), atomically: to `path` + `.tmp`, then renamed.
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
        for slice in field.slices() {
            check_len(field.name(), n, slice.len())?;
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
        start_array(w, "Float64", field.name(), components)?;
        enc.begin(w, (n * components * 8) as u64)?;
        match *field {
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
    start_array(w, "Float64", "Points", 3)?;
    enc.begin(w, (n * 24) as u64)?;
    for (&a, &b) in x.iter().zip(y) {
        enc.push(w, a.to_le_bytes())?;
        enc.push(w, b.to_le_bytes())?;
        enc.push(w, 0f64.to_le_bytes())?;
    }
    enc.finish(w)?;
    w.write_all(b"</DataArray>\n      </Points>\n      <Verts>\n")?;
    for (name, first) in [("connectivity", 0i64), ("offsets", 1i64)] {
        start_array(w, "Int64", name, 1)?;
        enc.begin(w, (n * 8) as u64)?;
        for i in 0..n as i64 {
            enc.push(w, (i + first).to_le_bytes())?;
        }
        enc.finish(w)?;
        w.write_all(b"</DataArray>\n")?;
    }
    w.write_all(b"      </Verts>\n    </Piece>\n  </PolyData>\n</VTKFile>\n")
}

fn start_array<W: Write>(w: &mut W, ty: &str, name: &str, components: usize) -> std::io::Result<()> {
    write!(
        w,
        "        <DataArray type=\"{ty}\" Name=\"{}\" NumberOfComponents=\"{components}\" format=\"binary\">",
        xml_escape(name)
    )
}

/// Writes `path` through `body` into `path.tmp`, then renames it to `path`. The temporary file is
/// removed when anything fails.
fn write_atomically(path: &Path, body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>) -> Result<()> {
    let file_name = path.file_name().ok_or_else(|| {
        io_error(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path does not name a file"),
        )
    })?;
    let mut tmp_name = file_name.to_os_string();
    tmp_name.push(".tmp");
    let tmp = path.with_file_name(tmp_name);
    let file = File::create(&tmp).map_err(|e| io_error(path, e))?;
    let mut w = BufWriter::with_capacity(1 << 16, file);
    let written = body(&mut w)
        .and_then(|()| w.into_inner().map_err(|e| e.into_error()))
        .and_then(|file| {
            drop(file);
            fs::rename(&tmp, path)
        });
    written.map_err(|e| {
        let _ = fs::remove_file(&tmp);
        io_error(path, e)
    })
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

fn xml_unescape(s: &str) -> std::result::Result<String, String> {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(amp) = rest.find('&') {
        out.push_str(&rest[..amp]);
        let semi = rest[amp..]
            .find(';')
            .ok_or_else(|| format!("unterminated entity in `{s}`"))?;
        let entity = &rest[amp + 1..amp + semi];
        out.push(match entity {
            "amp" => '&',
            "lt" => '<',
            "gt" => '>',
            "quot" => '"',
            "apos" => '\'',
            _ => return Err(format!("unknown entity `&{entity};` in `{s}`")),
        });
        rest = &rest[amp + semi + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

// ------------------------------------------------------------------------------------------------
// Base64 (RFC 4648, standard alphabet, `=` padding)

const BASE64_ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Raw bytes encoded per write: a multiple of 6, encoding to 1 MiB, which `BufWriter` passes
/// straight to the file.
const BASE64_CHUNK: usize = 3 << 18;

/// The base64 digits of every 12-bit value: two symbols per lookup.
static BASE64_PAIRS: [[u8; 2]; 4096] = {
    let mut table = [[0u8; 2]; 4096];
    let mut i = 0;
    while i < 4096 {
        table[i] = [BASE64_ALPHABET[i >> 6], BASE64_ALPHABET[i & 63]];
        i += 1;
    }
    table
};

/// A streaming base64 encoder for one array at a time: `begin` (writes the UInt64 header),
/// `push` (8 bytes at a time), `finish` (pads and writes the rest). Keeps its buffers between
/// arrays.
struct Base64Writer {
    /// `BASE64_CHUNK + 8` bytes, of which `len` are pending.
    raw: Vec<u8>,
    len: usize,
    /// `BASE64_CHUNK / 3 * 4` bytes.
    encoded: Vec<u8>,
}

impl Base64Writer {
    fn new() -> Self {
        Base64Writer {
            raw: vec![0; BASE64_CHUNK + 8],
            len: 0,
            encoded: vec![0; BASE64_CHUNK / 3 * 4],
        }
    }

    fn begin<W: Write>(&mut self, w: &mut W, data_bytes: u64) -> std::io::Result<()> {
        self.len = 0;
        self.push(w, data_bytes.to_le_bytes())
    }

    #[inline(always)]
    fn push<W: Write>(&mut self, w: &mut W, bytes: [u8; 8]) -> std::io::Result<()> {
        self.raw[self.len..self.len + 8].copy_from_slice(&bytes);
        self.len += 8;
        if self.len >= BASE64_CHUNK {
            self.drain(w)?;
        }
        Ok(())
    }

    /// Encodes and writes all whole 3-byte groups, keeping the 0–2 bytes left over.
    #[inline(never)]
    fn drain<W: Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        let whole = self.len / 3 * 3;
        let encoded = &mut self.encoded[..whole / 3 * 4];
        encode_base64(&self.raw[..whole], encoded);
        w.write_all(encoded)?;
        self.raw.copy_within(whole..self.len, 0);
        self.len -= whole;
        Ok(())
    }

    fn finish<W: Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        self.drain(w)?;
        if self.len > 0 {
            w.write_all(&encode_base64_tail(&self.raw[..self.len]))?;
        }
        self.len = 0;
        Ok(())
    }
}

/// Encodes `input` (a multiple of 3 bytes) into `out` (`input.len() / 3 * 4` bytes).
fn encode_base64(input: &[u8], out: &mut [u8]) {
    debug_assert!(input.len().is_multiple_of(3) && out.len() == input.len() / 3 * 4);
    let pair = |n: u64| BASE64_PAIRS[(n & 0xfff) as usize];
    // Six bytes (48 bits, four 12-bit pairs) at a time, then a last group of three.
    let mut src = input.chunks_exact(6);
    let mut dst = out.chunks_exact_mut(8);
    for (s, d) in (&mut src).zip(&mut dst) {
        let n = u64::from_be_bytes([0, 0, s[0], s[1], s[2], s[3], s[4], s[5]]);
        let (a, b, c, e) = (pair(n >> 36), pair(n >> 24), pair(n >> 12), pair(n));
        d.copy_from_slice(&[a[0], a[1], b[0], b[1], c[0], c[1], e[0], e[1]]);
    }
    if let [x, y, z] = *src.remainder() {
        let n = u64::from_be_bytes([0, 0, 0, 0, 0, x, y, z]);
        let (a, b) = (pair(n >> 12), pair(n));
        dst.into_remainder().copy_from_slice(&[a[0], a[1], b[0], b[1]]);
    }
}

/// Encodes the last one or two bytes of a stream, with `=` padding.
fn encode_base64_tail(tail: &[u8]) -> [u8; 4] {
    let symbol = |v: u8| BASE64_ALPHABET[v as usize];
    match *tail {
        [a] => [symbol(a >> 2), symbol((a & 3) << 4), b'=', b'='],
        [a, b] => [
            symbol(a >> 2),
            symbol(((a & 3) << 4) | (b >> 4)),
            symbol((b & 15) << 2),
            b'=',
        ],
        _ => unreachable!("a base64 tail has one or two bytes"),
    }
}

/// Base64 → bytes. ASCII whitespace is skipped; `=` may only pad the last group.
fn decode_base64(text: &str) -> std::result::Result<Vec<u8>, String> {
    const INVALID: u8 = 255;
    const TABLE: [u8; 256] = {
        let mut t = [INVALID; 256];
        let mut i = 0;
        while i < 64 {
            t[BASE64_ALPHABET[i] as usize] = i as u8;
            i += 1;
        }
        t
    };
    let bytes = text.as_bytes();
    let symbols: std::borrow::Cow<'_, [u8]> = if bytes.iter().any(u8::is_ascii_whitespace) {
        bytes
            .iter()
            .copied()
            .filter(|b| !b.is_ascii_whitespace())
            .collect::<Vec<u8>>()
            .into()
    } else {
        bytes.into()
    };
    if !symbols.len().is_multiple_of(4) {
        return Err(format!(
            "{} base64 symbols: not a whole number of 4-symbol groups",
            symbols.len()
        ));
    }
    let padding = symbols.iter().rev().take(2).take_while(|&&b| b == b'=').count();
    let mut out = Vec::with_capacity(symbols.len() / 4 * 3);
    let last_group = symbols.len() / 4;
    for (g, group) in symbols.chunks_exact(4).enumerate() {
        let mut n = 0u32;
        for (k, &c) in group.iter().enumerate() {
            let mut v = TABLE[c as usize];
            if v == INVALID {
                if c == b'=' && g + 1 == last_group && k >= 4 - padding {
                    v = 0;
                } else {
                    return Err(format!(
                        "invalid base64 character {:?} at symbol {}",
                        c as char,
                        4 * g + k
                    ));
                }
            }
            n = (n << 6) | u32::from(v);
        }
        out.extend_from_slice(&[(n >> 16) as u8, (n >> 8) as u8, n as u8]);
    }
    out.truncate(out.len() - padding);
    Ok(out)
}

// ------------------------------------------------------------------------------------------------
// Reading

/// The contents of a `.vtp` file written by [`write_vtp`].
#[derive(Clone, Debug, PartialEq)]
pub struct VtpData {
    /// The particle positions `(x, y, z)` (`z` is 0 in files written by [`write_vtp`]).
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
    /// [`write_vtp`].
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

/// Reads a `.vtp` file in exactly the layout [`write_vtp`] writes (see the
/// [module documentation](self)); it is not a general VTK reader.
///
/// # Errors
/// [`MpmError::Io`] naming `path` when it cannot be read, and of kind
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

/// Reads a `.pvd` collection in exactly the layout [`PvdWriter`] writes: the `(timestep, file)`
/// of every `DataSet`, in file order, with `file` as written (relative to the `.pvd`'s
/// directory, unescaped).
///
/// # Errors
/// [`MpmError::Io`] naming `path` when it cannot be read, and of kind
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
        push_f64(&mut self.lines, time);
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

    fn encode_all(bytes: &[u8]) -> String {
        let whole = bytes.len() / 3 * 3;
        let mut out = vec![0; whole / 3 * 4];
        encode_base64(&bytes[..whole], &mut out);
        if whole < bytes.len() {
            out.extend_from_slice(&encode_base64_tail(&bytes[whole..]));
        }
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn base64_matches_the_rfc_4648_test_vectors_and_decodes_back() {
        let vectors = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
            ("foobarb", "Zm9vYmFyYg=="),
        ];
        for (plain, encoded) in vectors {
            assert_eq!(encode_all(plain.as_bytes()), encoded);
            assert_eq!(decode_base64(encoded).unwrap(), plain.as_bytes());
        }
        assert_eq!(decode_base64(" Zm9v\nYmE=\n").unwrap(), b"fooba");
    }

    #[test]
    fn the_streaming_encoder_matches_the_one_shot_encoding_across_chunk_boundaries() {
        for words in [
            0,
            1,
            2,
            3,
            BASE64_CHUNK / 8 - 1,
            BASE64_CHUNK / 8,
            2 * BASE64_CHUNK / 8 + 5,
        ] {
            let values: Vec<u64> = (0..words as u64)
                .map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15))
                .collect();
            let mut enc = Base64Writer::new();
            let mut out = Vec::new();
            enc.begin(&mut out, 8 * words as u64).unwrap();
            for v in &values {
                enc.push(&mut out, v.to_le_bytes()).unwrap();
            }
            enc.finish(&mut out).unwrap();
            let mut raw = (8 * words as u64).to_le_bytes().to_vec();
            raw.extend(values.iter().flat_map(|v| v.to_le_bytes()));
            assert_eq!(
                String::from_utf8(out.clone()).unwrap(),
                encode_all(&raw),
                "{words} words"
            );
            assert_eq!(decode_base64(std::str::from_utf8(&out).unwrap()).unwrap(), raw);
        }
    }

    #[test]
    fn base64_decoding_rejects_bad_characters_and_lengths() {
        assert!(decode_base64("Zm9v!AAA").is_err());
        assert!(decode_base64("Zm9").is_err());
        assert!(decode_base64("Zg==Zg==").is_err());
        assert!(decode_base64("Z===").is_err());
    }

    #[test]
    fn xml_escaping_round_trips() {
        let s = "a<b>&\"c'";
        assert_eq!(xml_unescape(&xml_escape(s)).unwrap(), s);
        assert!(xml_unescape("&nope;").is_err());
    }
}
