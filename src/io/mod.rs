//! Reading and writing: Matrix Market for the operators and matrices.

use std::path::Path;

use nalgebra_sparse::CscMatrix;

use crate::error::{MpmError, Result};

/// Writes a sparse matrix in Matrix Market coordinate format (1-based indices), readable by
/// SciPy's `scipy.io.mmread`, MATLAB's `mmread` and nalgebra-sparse.
///
/// # Errors
/// [`MpmError::Io`] naming `path` when it cannot be written.
pub fn write_matrix_market(matrix: &CscMatrix<f64>, path: &Path) -> Result<()> {
    nalgebra_sparse::io::save_to_matrix_market_file(matrix, path).map_err(|source| MpmError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a real sparse matrix in Matrix Market format.
///
/// # Errors
/// [`MpmError::Io`] naming `path` when it cannot be read or parsed.
pub fn read_matrix_market(path: &Path) -> Result<CscMatrix<f64>> {
    let coo = nalgebra_sparse::io::load_coo_from_matrix_market_file::<f64, _>(path).map_err(|e| MpmError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
    })?;
    Ok(CscMatrix::from(&coo))
}
