//! Matrix Market files: the standard banner that SciPy, MATLAB and Julia require, bit-for-bit
//! read-back through nalgebra-sparse's reader (an independent implementation), symmetric storage
//! of the lower triangle, and errors that name the file and leave nothing behind.

mod common;

use std::path::{Path, PathBuf};

use common::unique_temp_dir;
use nalgebra_sparse::{CooMatrix, CscMatrix};
use sparse_mpm::io::{read_matrix_market, write_matrix_market, write_matrix_market_symmetric};
use sparse_mpm::MpmError;

const GENERAL_BANNER: &str = "%%MatrixMarket matrix coordinate real general";
const SYMMETRIC_BANNER: &str = "%%MatrixMarket matrix coordinate real symmetric";

/// A CSC matrix from `(row, column, value)` triplets (0-based).
fn csc(nrows: usize, ncols: usize, triplets: &[(usize, usize, f64)]) -> CscMatrix<f64> {
    let coo = CooMatrix::try_from_triplets(
        nrows,
        ncols,
        triplets.iter().map(|t| t.0).collect(),
        triplets.iter().map(|t| t.1).collect(),
        triplets.iter().map(|t| t.2).collect(),
    )
    .expect("valid triplets");
    CscMatrix::from(&coo)
}

/// Every stored entry as `(row, column, value bits)`, column by column.
fn stored_bits(m: &CscMatrix<f64>) -> Vec<(usize, usize, u64)> {
    let (offsets, rows, values) = (m.col_offsets(), m.row_indices(), m.values());
    (0..m.ncols())
        .flat_map(|j| (offsets[j]..offsets[j + 1]).map(move |k| (rows[k], j, values[k].to_bits())))
        .collect()
}

/// Asserts that `read` is `expected`: same shape, same stored entries, same bits.
fn assert_same_bits(read: &CscMatrix<f64>, expected: &CscMatrix<f64>, what: &str) {
    assert_eq!(
        (read.nrows(), read.ncols()),
        (expected.nrows(), expected.ncols()),
        "{what}: shape"
    );
    assert_eq!(stored_bits(read), stored_bits(expected), "{what}: entries");
}

/// Values that a careless writer would not bring back exactly.
fn awkward_values() -> Vec<f64> {
    vec![
        1e-300,
        -0.0,
        1.0 / 3.0,
        -2.0 / 3.0,
        0.1,
        f64::MIN_POSITIVE,
        5e-324,
        f64::MAX,
        -1.7976931348623157e300,
        123456789.12345679,
        1e16,
        1e16 - 2.0,
        1e-5,
        9.99999999999999e-6,
        std::f64::consts::PI,
        -std::f64::consts::E,
        0.0,
        1.0,
    ]
}

/// A rectangular matrix holding every awkward value, scattered over several columns.
fn awkward_general() -> CscMatrix<f64> {
    let values = awkward_values();
    let (nrows, ncols) = (7, 6);
    // Every other cell in column-major order: distinct positions (nothing is summed on
    // assembly), gaps in every column.
    let triplets: Vec<_> = values
        .iter()
        .enumerate()
        .map(|(k, &v)| ((2 * k) % nrows, (2 * k) / nrows, v))
        .collect();
    csc(nrows, ncols, &triplets)
}

/// A symmetric matrix holding every awkward value, on the diagonal and mirrored off it.
fn awkward_symmetric() -> CscMatrix<f64> {
    let values = awkward_values();
    let n = 10;
    let mut triplets = Vec::new();
    for (k, &v) in values.iter().enumerate() {
        if k < n {
            triplets.push((k, k, v));
        } else {
            let (i, j) = (k - n + 1, (k - n) / 2);
            assert!(i > j);
            triplets.push((i, j, v));
            triplets.push((j, i, v));
        }
    }
    csc(n, n, &triplets)
}

fn first_line(path: &Path) -> String {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .next()
        .unwrap_or_default()
        .to_string()
}

/// The data lines (after the banner, the comments and the size line) as `(row, column)`,
/// 1-based as written, and the size line.
fn data_lines(path: &Path) -> ((usize, usize, usize), Vec<(usize, usize)>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().skip(1).filter(|l| !l.starts_with('%'));
    let size: Vec<usize> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    let entries = lines
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(w.len(), 3, "data line {l:?}");
            (w[0].parse().unwrap(), w[1].parse().unwrap())
        })
        .collect();
    ((size[0], size[1], size[2]), entries)
}

/// The names of the files in `dir`.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn expect_io_error(result: sparse_mpm::Result<()>, path: &PathBuf) -> std::io::Error {
    match result {
        Err(MpmError::Io { path: p, source }) => {
            assert_eq!(&p, path, "the error names the file");
            source
        }
        other => panic!("expected an Io error naming {}, got {other:?}", path.display()),
    }
}

#[test]
fn banner_line_is_exactly_the_standard_one() {
    let dir = unique_temp_dir("mm_banner");
    std::fs::create_dir_all(&dir).unwrap();
    let general = dir.join("A.mtx");
    write_matrix_market(&awkward_general(), &general).unwrap();
    assert_eq!(first_line(&general), GENERAL_BANNER);
    let symmetric = dir.join("S.mtx");
    write_matrix_market_symmetric(&awkward_symmetric(), &symmetric).unwrap();
    assert_eq!(first_line(&symmetric), SYMMETRIC_BANNER);
    // No temporary file is left beside them.
    assert_eq!(listing(&dir), ["A.mtx", "S.mtx"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn general_file_reads_back_bit_for_bit_in_column_order() {
    let dir = unique_temp_dir("mm_general");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("A.mtx");
    let a = awkward_general();
    write_matrix_market(&a, &path).unwrap();
    assert_same_bits(&read_matrix_market(&path).unwrap(), &a, "general");
    // Size line and 1-based entries, column by column.
    let (size, entries) = data_lines(&path);
    assert_eq!(size, (a.nrows(), a.ncols(), a.nnz()));
    let expected: Vec<_> = stored_bits(&a).iter().map(|&(i, j, _)| (i + 1, j + 1)).collect();
    assert_eq!(entries, expected);
    // The text keeps the awkward values readable and exact.
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains(" 1e-300\n"), "{text}");
    assert!(text.contains(" -0\n"), "{text}");
    assert!(text.contains(" 0.3333333333333333\n"), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn empty_and_single_entry_matrices_read_back() {
    let dir = unique_temp_dir("mm_small");
    std::fs::create_dir_all(&dir).unwrap();
    for (name, m) in [
        ("empty.mtx", csc(3, 4, &[])),
        ("one.mtx", csc(1, 1, &[(0, 0, -0.0)])),
        ("tiny.mtx", csc(2, 3, &[(1, 2, 1e-300)])),
    ] {
        let path = dir.join(name);
        write_matrix_market(&m, &path).unwrap();
        assert_same_bits(&read_matrix_market(&path).unwrap(), &m, name);
    }
    let path = dir.join("empty_sym.mtx");
    let empty = csc(3, 3, &[]);
    write_matrix_market_symmetric(&empty, &path).unwrap();
    assert_same_bits(&read_matrix_market(&path).unwrap(), &empty, "empty symmetric");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn symmetric_file_holds_the_lower_triangle_and_reads_back_to_the_full_matrix() {
    let dir = unique_temp_dir("mm_symmetric");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("S.mtx");
    let s = awkward_symmetric();
    write_matrix_market_symmetric(&s, &path).unwrap();
    let (size, entries) = data_lines(&path);
    let lower: Vec<_> = stored_bits(&s)
        .iter()
        .filter(|&&(i, j, _)| i >= j)
        .map(|&(i, j, _)| (i + 1, j + 1))
        .collect();
    assert!(lower.len() < s.nnz(), "the test matrix has entries above the diagonal");
    assert_eq!(size, (s.nrows(), s.ncols(), lower.len()));
    assert_eq!(entries, lower, "only the lower triangle, column by column");
    assert_same_bits(&read_matrix_market(&path).unwrap(), &s, "symmetric");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn non_symmetric_matrix_is_refused_naming_the_entry_and_writes_nothing() {
    let dir = unique_temp_dir("mm_asymmetric");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("A.mtx");
    // Symmetric except (row 3, column 1) = 0.5 against (row 1, column 3) = 0.25 (0-based).
    let a = csc(
        4,
        4,
        &[
            (0, 0, 2.0),
            (1, 0, 1.0),
            (0, 1, 1.0),
            (1, 1, 2.0),
            (3, 1, 0.5),
            (1, 3, 0.25),
            (2, 2, 2.0),
            (3, 3, 2.0),
        ],
    );
    let source = expect_io_error(write_matrix_market_symmetric(&a, &path), &path);
    assert_eq!(source.kind(), std::io::ErrorKind::InvalidInput);
    let message = source.to_string();
    assert!(message.contains("row 3, column 1"), "{message}");
    assert!(message.contains("0.5") && message.contains("0.25"), "{message}");

    // An entry whose mirror is not stored, and a single flipped sign of zero.
    let missing = csc(3, 3, &[(0, 0, 1.0), (2, 0, 1e-300), (2, 2, 1.0)]);
    let message = expect_io_error(write_matrix_market_symmetric(&missing, &path), &path).to_string();
    assert!(
        message.contains("row 2, column 0") && message.contains("not stored"),
        "{message}"
    );
    let signed_zero = csc(2, 2, &[(1, 0, -0.0), (0, 1, 0.0)]);
    let message = expect_io_error(write_matrix_market_symmetric(&signed_zero, &path), &path).to_string();
    assert!(message.contains("row 1, column 0"), "{message}");

    // A rectangular matrix is not symmetric either.
    let rectangular = csc(2, 3, &[(0, 0, 1.0)]);
    let source = expect_io_error(write_matrix_market_symmetric(&rectangular, &path), &path);
    assert!(source.to_string().contains("2 × 3"), "{source}");

    assert!(listing(&dir).is_empty(), "nothing written: {:?}", listing(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn writing_into_a_missing_folder_is_an_io_error_naming_the_path_and_leaves_nothing() {
    let parent = unique_temp_dir("mm_missing");
    std::fs::create_dir_all(&parent).unwrap();
    let path = parent.join("no_such_folder").join("N.mtx");
    let source = expect_io_error(write_matrix_market(&awkward_general(), &path), &path);
    assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
    let path = parent.join("no_such_folder").join("M.mtx");
    expect_io_error(write_matrix_market_symmetric(&awkward_symmetric(), &path), &path);
    assert!(listing(&parent).is_empty(), "nothing written: {:?}", listing(&parent));
    std::fs::remove_dir_all(&parent).unwrap();
}

#[test]
fn a_failed_rename_removes_the_temporary_file() {
    // The final name is an existing non-empty folder, so the rename fails after the temporary
    // file was written in full.
    let dir = unique_temp_dir("mm_rename");
    let path = dir.join("A.mtx");
    std::fs::create_dir_all(path.join("occupied")).unwrap();
    expect_io_error(write_matrix_market(&awkward_general(), &path), &path);
    assert_eq!(listing(&dir), ["A.mtx"], "only the folder that was there");
    assert!(path.is_dir());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_existing_file_is_replaced_whole() {
    let dir = unique_temp_dir("mm_replace");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("A.mtx");
    write_matrix_market(&awkward_general(), &path).unwrap();
    let small = csc(2, 2, &[(1, 1, 0.1)]);
    write_matrix_market(&small, &path).unwrap();
    assert_same_bits(&read_matrix_market(&path).unwrap(), &small, "replaced");
    assert_eq!(listing(&dir), ["A.mtx"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn mpm_matrices_writes_m_symmetric_and_every_file_reads_back() {
    use sparse_mpm::{mass, Operator, Operators};
    let scene = sparse_mpm::scene::Scene::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/two_disks.toml"
    )))
    .expect("the shipped scene reads");
    let dir = unique_temp_dir("mm_scene");
    sparse_mpm_cli::run::write_matrices(&scene, &dir).unwrap();
    let grid = scene.grid().unwrap();
    let particles = scene.particles().unwrap();
    let ops = Operators::assemble(&grid, scene.schemes.shape, &particles).unwrap();
    for (op, name) in [(Operator::N, "N"), (Operator::Gx, "Gx"), (Operator::Gy, "Gy")] {
        let path = dir.join(format!("{name}.mtx"));
        assert_eq!(first_line(&path), GENERAL_BANNER, "{name}.mtx");
        assert_same_bits(&read_matrix_market(&path).unwrap(), &ops.matrix(op), name);
    }
    let path = dir.join("M.mtx");
    assert_eq!(first_line(&path), SYMMETRIC_BANNER);
    let m = mass::consistent_mass(&ops, &particles.mass);
    assert_same_bits(&read_matrix_market(&path).unwrap(), &m, "M");
    let (_, entries) = data_lines(&path);
    assert!(
        entries.iter().all(|&(i, j)| i >= j),
        "M.mtx holds the lower triangle only"
    );
    assert!(
        !listing(&dir).iter().any(|n| n.ends_with(".tmp")),
        "{:?}",
        listing(&dir)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
