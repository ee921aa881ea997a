//! Reading and writing files.
//!
//! * Matrix Market for the operators and matrices: [`write_matrix_market`] (coordinate,
//!   `general`), [`write_matrix_market_symmetric`] (coordinate, `symmetric`: the lower triangle
//!   of a matrix checked to be symmetric), both with the standard `%%MatrixMarket` banner that
//!   SciPy, MATLAB and Julia read, written whole (temporary file, then rename); and
//!   [`read_matrix_market`].
//! * Particle snapshots for ParaView: [`vtk::write_vtp`] writes one VTK XML PolyData file
//!   (`.vtp`) per snapshot, [`vtk::PvdWriter`] keeps a `.pvd` collection that lists them with their
//!   times, so ParaView opens a whole run as a time series. The crate only writes these files;
//!   ParaView, VTK's own readers and the `vtkio` crate read them.
//! * Time histories (energies, probe values …) as CSV, through the `csv` crate:
//!   [`csv::CsvWriter`], read back with [`csv::read_csv`].
//!
//! Every failure is an [`MpmError::Io`] naming the file; a file that does not have the layout
//! the readers ([`read_matrix_market`], [`csv::read_csv`]) expect gives an
//! [`std::io::ErrorKind::InvalidData`] error whose message says what is wrong.

use std::path::Path;

use crate::error::MpmError;

pub mod csv;
mod matrix_market;
pub mod vtk;

pub use matrix_market::{read_matrix_market, write_matrix_market, write_matrix_market_symmetric};
pub(crate) use matrix_market::{
    write_with_comment as write_matrix_market_with_comment, Storage as MatrixMarketStorage,
};

/// Writes `path` through `body` into `path` + `.tmp` in the same folder (buffered), then renames
/// it to `path`, so that an interrupted write never leaves a half file under the final name. The
/// temporary file is removed when anything fails; errors name `path`.
pub(crate) fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> crate::error::Result<()> {
    let file_name = path.file_name().ok_or_else(|| {
        io_error(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path does not name a file"),
        )
    })?;
    let mut tmp_name = file_name.to_os_string();
    tmp_name.push(".tmp");
    let tmp = path.with_file_name(tmp_name);
    let file = std::fs::File::create(&tmp).map_err(|e| io_error(path, e))?;
    let mut w = std::io::BufWriter::with_capacity(1 << 16, file);
    let written = body(&mut w)
        .and_then(|()| w.into_inner().map_err(|e| e.into_error()))
        .and_then(|file| {
            drop(file);
            std::fs::rename(&tmp, path)
        });
    written.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io_error(path, e)
    })
}

/// Wraps an I/O error with the file it concerns.
pub(crate) fn io_error(path: &Path, source: std::io::Error) -> MpmError {
    MpmError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// An [`MpmError::Io`] of kind `InvalidData` (a file that does not have the expected layout).
pub(crate) fn invalid_data(path: &Path, message: impl Into<String>) -> MpmError {
    io_error(
        path,
        std::io::Error::new(std::io::ErrorKind::InvalidData, message.into()),
    )
}

/// Appends `value` in the shortest form that reads back bit-for-bit with `str::parse::<f64>`:
/// Rust's `{}` for zero, non-finite values and magnitudes in `[1e-5, 1e16)`, and `{:e}` (also
/// shortest round-trip, e.g. `1e-300`) outside it, where `{}` would spell out hundreds of zeros.
/// NaN and the infinities are written `NaN`, `inf`, `-inf`; negative zero is `-0`.
pub(crate) fn push_f64(out: &mut String, value: f64) {
    use std::fmt::Write;
    let magnitude = value.abs();
    // Writing into a String cannot fail.
    if value == 0.0 || !value.is_finite() || (1e-5..1e16).contains(&magnitude) {
        let _ = write!(out, "{value}");
    } else {
        let _ = write!(out, "{value:e}");
    }
}
