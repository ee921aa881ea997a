//! Reading and writing files.
//!
//! * Matrix Market for the operators and matrices: [`write_matrix_market`] (coordinate,
//!   `general`), [`write_matrix_market_symmetric`] (coordinate, `symmetric`: the lower triangle
//!   of a matrix checked to be symmetric), both with the standard `%%MatrixMarket` banner that
//!   SciPy, MATLAB and Julia read, written whole (temporary file, then rename); and
//!   [`read_matrix_market`].
//! * Time histories (energies, probe values …) as CSV, through the `csv` crate:
//!   [`csv::CsvWriter`], read back with [`csv::read_csv`].
//!
//! Every failure is an [`MpmError::Io`] naming the file; a file that does not have the layout
//! the readers ([`read_matrix_market`], [`csv::read_csv`]) expect gives an
//! [`std::io::ErrorKind::InvalidData`] error whose message says what is wrong.

use std::path::{Path, PathBuf};

use crate::error::MpmError;
use crate::operators::{Operator, Operators};

pub mod csv;
mod matrix_market;

pub use matrix_market::{read_matrix_market, write_matrix_market, write_matrix_market_symmetric};
pub use matrix_market::{write_with_comment as write_matrix_market_with_comment, Storage as MatrixMarketStorage};

/// Writes N, Gx and Gy to `dir/N.mtx`, `dir/Gx.mtx`, `dir/Gy.mtx` as Matrix Market
/// coordinate files with `general` storage (rows = nodes, columns = particles), as
/// [`write_matrix_market`] does, with a comment line naming the operator:
///
/// ```text
/// %%MatrixMarket matrix coordinate real general
/// % N: shape function values N[node, particle] of sparse-mpm (rows = grid nodes, columns = particles; 1-based)
/// nodes particles entries
/// row column value
/// …
/// ```
///
/// Creates `dir` if needed.
///
/// # Errors
/// [`MpmError::Io`] naming the file that could not be written.
pub fn write_operators(ops: &Operators, dir: &Path) -> crate::error::Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| MpmError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    for (op, name, what) in [
        (Operator::N, "N", "shape function values N[node, particle]"),
        (Operator::Gx, "Gx", "shape function x derivatives dN/dx[node, particle]"),
        (Operator::Gy, "Gy", "shape function y derivatives dN/dy[node, particle]"),
    ] {
        write_matrix_market_with_comment(
            &ops.matrix(op),
            &dir.join(format!("{name}.mtx")),
            MatrixMarketStorage::General,
            &format!("{name}: {what} of sparse-mpm (rows = grid nodes, columns = particles; 1-based)"),
        )?;
    }
    Ok(())
}

/// Writes `path` whole or not at all: `body` writes into a new temporary file beside `path`
/// (`.NAME.PID-N-R.tmp`, created exclusively, buffered), which is flushed, synced to disk and
/// renamed over `path`; the folder is then synced too, so that after a crash `path` holds
/// either its previous contents or the whole new file. The temporary file is removed when
/// anything fails. Every whole-file output of the crate goes through here (snapshots, the
/// `.pvd`, Matrix Market files, run records, checkpoints).
///
/// # Errors
/// [`MpmError::Io`] naming `path` (kind `InvalidInput` when `path` names no file, such as `..`).
pub fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut std::io::BufWriter<&std::fs::File>) -> std::io::Result<()>,
) -> crate::error::Result<()> {
    let file_name = path.file_name().ok_or_else(|| {
        io_error(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path does not name a file"),
        )
    })?;
    let (tmp, file) = create_temporary(path, file_name)?;
    let written = (|| {
        let mut w = std::io::BufWriter::with_capacity(1 << 16, &file);
        body(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    drop(file);
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(io_error(path, e));
    }
    // The rename reaches the disk with the folder (best effort: some systems cannot open a
    // folder for this).
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// A new temporary file `.NAME.PID-N-R.tmp` beside `path`, created exclusively: `PID` this
/// process, `N` a counter, `R` 16 random hexadecimal digits, so that processes of equal ids on
/// machines (or containers) sharing a folder do not meet; a name taken is tried again.
fn create_temporary(path: &Path, file_name: &std::ffi::OsStr) -> crate::error::Result<(PathBuf, std::fs::File)> {
    use std::hash::{BuildHasher, Hasher};
    use std::sync::atomic::{AtomicUsize, Ordering};
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let mut attempt = 0;
    loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        // The standard library's hasher keys are random per process.
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_usize(n);
        h.write_u128(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos()),
        );
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(file_name);
        tmp_name.push(format!(".{}-{n}-{:016x}.tmp", std::process::id(), h.finish()));
        let tmp = path.with_file_name(tmp_name);
        match std::fs::OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(file) => return Ok((tmp, file)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 8 => attempt += 1,
            Err(e) => return Err(io_error(path, e)),
        }
    }
}

/// `NAME` when `entry` is `.NAME.PID-N-R.tmp` (or `.NAME.PID-N.tmp` of earlier versions), a
/// temporary file of the atomic writer.
pub fn temporary_of(entry: &str) -> Option<&str> {
    let inner = entry.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (name, serial) = inner.rsplit_once('.')?;
    let mut parts = serial.split('-');
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let (pid, n, random) = (parts.next()?, parts.next()?, parts.next());
    let random_ok = random.is_none_or(|r| r.len() == 16 && r.bytes().all(|b| b.is_ascii_hexdigit()));
    (digits(pid) && digits(n) && random_ok && parts.next().is_none()).then_some(name)
}

/// Wraps an I/O error with the file it concerns.
pub fn io_error(path: &Path, source: std::io::Error) -> MpmError {
    MpmError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// An [`MpmError::Io`] of kind `InvalidData` (a file that does not have the expected layout).
pub fn invalid_data(path: &Path, message: impl Into<String>) -> MpmError {
    io_error(
        path,
        std::io::Error::new(std::io::ErrorKind::InvalidData, message.into()),
    )
}

/// `Ok` for a regular file; else what it is, in words ("a named pipe (FIFO)", "a folder").
pub fn regular_file_kind(meta: &std::fs::Metadata) -> std::result::Result<(), &'static str> {
    let kind = meta.file_type();
    if kind.is_file() {
        return Ok(());
    }
    if kind.is_dir() {
        return Err("a folder");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return Err("a named pipe (FIFO)");
        }
        if kind.is_char_device() || kind.is_block_device() {
            return Err("a device");
        }
        if kind.is_socket() {
            return Err("a socket");
        }
    }
    Err("not a regular file")
}

/// The regular file `path` opened for reading, with its length, if it holds at most
/// `max_bytes`: the one way every file of the library is opened for reading, given on the
/// command line or found inside a folder. What is not a regular file (a FIFO, a device, a
/// folder, a socket) is refused before it is opened (opening a FIFO waits for a writer), and
/// again on the open file, which must be the file checked (a file swapped in between is
/// refused); so is a file of more than `max_bytes`. `what` names the file's role in the
/// messages ("scene", "checkpoint"). A reader that reads to the end takes at most
/// `max_bytes + 1` bytes of it ([`read_bounded`]).
///
/// # Errors
/// [`MpmError::Io`] naming `path`: of kind `InvalidInput` for what is not a regular file or
/// was replaced, `InvalidData` for a file over the bound, or the error of opening it.
pub fn open_regular(path: &Path, max_bytes: u64, what: &str) -> crate::error::Result<(std::fs::File, u64)> {
    let refuse = |kind: &str| {
        io_error(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{kind}, not a regular file: give a {what} file"),
            ),
        )
    };
    // Before opening (opening a FIFO waits for a writer), and again on the open file.
    let before = std::fs::metadata(path).map_err(|e| io_error(path, e))?;
    regular_file_kind(&before).map_err(refuse)?;
    let file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
    let meta = file.metadata().map_err(|e| io_error(path, e))?;
    regular_file_kind(&meta).map_err(refuse)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if (before.dev(), before.ino()) != (meta.dev(), meta.ino()) {
            return Err(refuse("replaced while it was being opened"));
        }
    }
    if meta.len() > max_bytes {
        return Err(invalid_data(
            path,
            format!(
                "it has {} bytes, more than the {max_bytes} a {what} file may have",
                meta.len()
            ),
        ));
    }
    Ok((file, meta.len()))
}

/// The bytes of the regular file `path`, at most `max_bytes` of them ([`open_regular`]): a
/// FIFO, a device or a folder is refused before anything is read (nothing hangs on a pipe or
/// reads `/dev/zero` for ever), and so is a file larger than `max_bytes` (checked on the open
/// file, then again while reading, so a file that grows meanwhile cannot exceed it). `what`
/// names the file's role in the messages ("scene", "checkpoint").
///
/// # Errors
/// [`MpmError::Io`] naming `path`: of kind `InvalidInput` for what is not a regular file,
/// `InvalidData` for a file over the bound, or the error of opening or reading it.
pub fn read_bounded(path: &Path, max_bytes: u64, what: &str) -> crate::error::Result<Vec<u8>> {
    use std::io::Read;
    let (file, len) = open_regular(path, max_bytes, what)?;
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(len as usize)
        .map_err(|_| invalid_data(path, format!("a {what} file of {len} bytes does not fit in memory")))?;
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| io_error(path, e))?;
    if bytes.len() as u64 > max_bytes {
        return Err(invalid_data(
            path,
            format!("a {what} file of more than {max_bytes} bytes is not read (it grew while being read)"),
        ));
    }
    Ok(bytes)
}

/// [`read_bounded`] as UTF-8 text.
///
/// # Errors
/// As [`read_bounded`]; `InvalidData` naming the first byte that is not UTF-8.
pub fn read_bounded_text(path: &Path, max_bytes: u64, what: &str) -> crate::error::Result<String> {
    String::from_utf8(read_bounded(path, max_bytes, what)?).map_err(|e| {
        invalid_data(
            path,
            format!(
                "not a text {what} file: byte {} is not UTF-8",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_names_are_told_apart_from_other_files() {
        for (entry, name) in [
            (".report.csv.12-0-0123456789abcdef.tmp", "report.csv"),
            (".run.json.4242-17.tmp", "run.json"),
            (".a.b.c.1-2-ffffffffffffffff.tmp", "a.b.c"),
        ] {
            assert_eq!(temporary_of(entry), Some(name), "{entry}");
        }
        for entry in [
            "report.csv",
            ".report.csv.tmp",
            ".report.csv.12.tmp",
            ".report.csv.12-x.tmp",
            ".report.csv.12-0-0123.tmp",
            ".report.csv.12-0-0123456789abcdeg.tmp",
            ".report.csv.12-0-0123456789abcdef-1.tmp",
            "report.csv.12-0.tmp",
        ] {
            assert_eq!(temporary_of(entry), None, "{entry}");
        }
    }

    #[test]
    fn temporary_files_of_one_name_never_meet() {
        let dir = std::env::temp_dir().join(format!("sparse-mpm-io-temporary-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.json");
        let made: Vec<PathBuf> = (0..50)
            .map(|_| create_temporary(&path, std::ffi::OsStr::new("x.json")).unwrap().0)
            .collect();
        let distinct: std::collections::BTreeSet<&PathBuf> = made.iter().collect();
        assert_eq!(distinct.len(), made.len());
        for p in &made {
            let name = p.file_name().unwrap().to_string_lossy();
            assert_eq!(temporary_of(&name), Some("x.json"), "{name}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
