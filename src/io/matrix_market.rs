//! Matrix Market coordinate files, written by our own writer so that the banner is the standard
//! `%%MatrixMarket` that SciPy (`scipy.io.mmread`), MATLAB and Julia require, and read with
//! nalgebra-sparse's reader.

use std::io::Write;
use std::path::Path;

use nalgebra_sparse::CscMatrix;

use super::{io_error, write_atomically};
use crate::error::Result;
use crate::numbers::push_round_trip;

/// How the entries of a matrix are stored in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// Every stored entry (`general`).
    General,
    /// Only the lower triangle, `row ≥ column` (`symmetric`); the matrix is checked first.
    Symmetric,
}

impl Storage {
    fn qualifier(self) -> &'static str {
        match self {
            Storage::General => "general",
            Storage::Symmetric => "symmetric",
        }
    }
}

/// Writes a sparse matrix as a Matrix Market coordinate file with `general` storage, readable by
/// SciPy's `scipy.io.mmread`, MATLAB's `mmread`, Julia's `MatrixMarket.mmread` and
/// nalgebra-sparse ([`read_matrix_market`]).
///
/// The file is:
///
/// ```text
/// %%MatrixMarket matrix coordinate real general
/// % sparse real matrix written by sparse-mpm (1-based row, column, value; column by column)
/// 3 2 4
/// 1 1 0.5
/// 3 1 1e-300
/// 2 2 -0.3333333333333333
/// 3 2 7
/// ```
///
/// that is the banner, one comment line, `rows columns entries`, then one `row column value` line
/// per stored entry (1-based indices), column by column and by increasing row within a column.
/// Values are written in the shortest form that reads back bit for bit (`-0` keeps its sign;
/// magnitudes below `1e-5` or from `1e16` up use an exponent). Explicitly stored zeros are
/// written like any other entry.
///
/// The file is written to a temporary file in the same folder, synced and renamed to `path`
/// ([`crate::io`]'s one atomic writer), so an interrupted write never leaves a partial file
/// under the final name; on an error the temporary file is removed.
///
/// # Errors
/// [`MpmError::Io`](crate::MpmError::Io) naming `path` when it cannot be written (a missing folder, no permission, a
/// path that names no file …).
pub fn write_matrix_market(matrix: &CscMatrix<f64>, path: &Path) -> Result<()> {
    write_with_comment(
        matrix,
        path,
        Storage::General,
        "sparse real matrix written by sparse-mpm (1-based row, column, value; column by column)",
    )
}

/// Writes a symmetric sparse matrix as a Matrix Market coordinate file with `symmetric` storage:
/// only the lower triangle (`row ≥ column`) is stored, and readers (SciPy's `scipy.io.mmread`,
/// MATLAB's `mmread`, Julia's `MatrixMarket.mmread`, nalgebra-sparse's reader behind
/// [`read_matrix_market`]) mirror it to rebuild the full matrix.
///
/// The file is:
///
/// ```text
/// %%MatrixMarket matrix coordinate real symmetric
/// % symmetric sparse real matrix written by sparse-mpm: lower triangle only (1-based row, column, value; column by column)
/// 2 2 3
/// 1 1 4
/// 2 1 0.3333333333333333
/// 2 2 5
/// ```
///
/// with the entry count of the lower triangle on the size line; otherwise as in
/// [`write_matrix_market`] (shortest round-trip values, temporary file then rename).
///
/// The matrix is checked first, and nothing is written unless it is square and exactly
/// symmetric: every stored entry `A[i, j]` must have the same bits as `A[j, i]`, an entry that is
/// not stored counting as `0.0` (so `-0.0` against a missing mirror is asymmetric). The file then
/// reads back to the same values; only explicitly stored zeros above the diagonal may come back
/// unstored, or unstored ones below it come back stored.
///
/// # Errors
/// [`MpmError::Io`](crate::MpmError::Io) naming `path`: of kind [`std::io::ErrorKind::InvalidInput`] when the matrix
/// is not square or not symmetric, the message naming the first asymmetric entry in column
/// order (0-based row and column, both values); otherwise when the file cannot be written.
pub fn write_matrix_market_symmetric(matrix: &CscMatrix<f64>, path: &Path) -> Result<()> {
    write_with_comment(
        matrix,
        path,
        Storage::Symmetric,
        "symmetric sparse real matrix written by sparse-mpm: lower triangle only \
         (1-based row, column, value; column by column)",
    )
}

/// Reads a real sparse matrix in Matrix Market format (coordinate or array; `general`,
/// `symmetric` or `skew-symmetric` storage) with nalgebra-sparse's reader. The banner is read
/// case-insensitively; symmetric storage is mirrored back to the full matrix.
///
/// # Errors
/// [`MpmError::Io`](crate::MpmError::Io) naming `path` when it cannot be read or parsed.
pub fn read_matrix_market(path: &Path) -> Result<CscMatrix<f64>> {
    let coo = nalgebra_sparse::io::load_coo_from_matrix_market_file::<f64, _>(path).map_err(|e| {
        io_error(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
        )
    })?;
    Ok(CscMatrix::from(&coo))
}

/// Writes `matrix` to `path` with the given storage and `comment` (one `% ` line per line of
/// it) after the banner. See [`write_matrix_market`] and [`write_matrix_market_symmetric`].
pub fn write_with_comment(matrix: &CscMatrix<f64>, path: &Path, storage: Storage, comment: &str) -> Result<()> {
    if storage == Storage::Symmetric {
        check_symmetric(matrix, path)?;
    }
    let (nrows, ncols) = (matrix.nrows(), matrix.ncols());
    let nnz = match storage {
        Storage::General => matrix.nnz(),
        Storage::Symmetric => entries(matrix).filter(|&(i, j, _)| kept(storage, i, j)).count(),
    };
    let mut head = format!("%%MatrixMarket matrix coordinate real {}\n", storage.qualifier());
    for line in comment.lines() {
        head.push_str("% ");
        head.push_str(line);
        head.push('\n');
    }
    head.push_str(&format!("{nrows} {ncols} {nnz}\n"));

    write_atomically(path, |file| {
        const CHUNK: usize = 1 << 16;
        let mut text = head;
        for (i, j, v) in entries(matrix).filter(|&(i, j, _)| kept(storage, i, j)) {
            text.push_str(&(i + 1).to_string());
            text.push(' ');
            text.push_str(&(j + 1).to_string());
            text.push(' ');
            push_round_trip(&mut text, v);
            text.push('\n');
            if text.len() >= CHUNK {
                file.write_all(text.as_bytes())?;
                text.clear();
            }
        }
        file.write_all(text.as_bytes())
    })
}

/// Every stored entry `(row, column, value)`, column by column, rows increasing.
fn entries(matrix: &CscMatrix<f64>) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
    let (offsets, rows, values) = (matrix.col_offsets(), matrix.row_indices(), matrix.values());
    (0..matrix.ncols()).flat_map(move |j| (offsets[j]..offsets[j + 1]).map(move |k| (rows[k], j, values[k])))
}

/// Whether `storage` writes the entry at `(row, column)`.
fn kept(storage: Storage, row: usize, column: usize) -> bool {
    storage == Storage::General || row >= column
}

/// `A[row, col]`, or `None` when it is not stored.
fn stored(matrix: &CscMatrix<f64>, row: usize, col: usize) -> Option<f64> {
    let range = matrix.col_offsets()[col]..matrix.col_offsets()[col + 1];
    let rows = &matrix.row_indices()[range.clone()];
    rows.binary_search(&row).ok().map(|k| matrix.values()[range.start + k])
}

/// Checks that `matrix` is square and that every stored entry equals its mirror bit for bit (an
/// entry not stored counts as `0.0`).
fn check_symmetric(matrix: &CscMatrix<f64>, path: &Path) -> Result<()> {
    let invalid = |message: String| io_error(path, std::io::Error::new(std::io::ErrorKind::InvalidInput, message));
    if matrix.nrows() != matrix.ncols() {
        return Err(invalid(format!(
            "a symmetric matrix must be square, this one is {} × {}",
            matrix.nrows(),
            matrix.ncols()
        )));
    }
    for (i, j, v) in entries(matrix) {
        if i == j {
            continue;
        }
        let mirror = stored(matrix, j, i);
        if mirror.unwrap_or(0.0).to_bits() != v.to_bits() {
            let mirror = match mirror {
                Some(m) => format!("{m:?}"),
                None => "0 (not stored)".to_string(),
            };
            return Err(invalid(format!(
                "the matrix is not symmetric: entry (row {i}, column {j}) = {v:?} but \
                 (row {j}, column {i}) = {mirror} (0-based indices)"
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_run_column_by_column() {
        let coo =
            nalgebra_sparse::CooMatrix::try_from_triplets(3, 2, vec![2, 0, 1], vec![0, 0, 1], vec![3.0, 1.0, 2.0])
                .unwrap();
        let csc = CscMatrix::from(&coo);
        let got: Vec<_> = entries(&csc).collect();
        assert_eq!(got, vec![(0, 0, 1.0), (2, 0, 3.0), (1, 1, 2.0)]);
        assert_eq!(stored(&csc, 2, 0), Some(3.0));
        assert_eq!(stored(&csc, 0, 1), None);
    }
}
