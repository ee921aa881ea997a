//! Time histories as CSV: a header line of column names, then one line of numbers per row.
//!
//! ```no_run
//! use std::path::Path;
//! use sparse_mpm::io::csv::{read_csv, CsvWriter};
//!
//! let mut history = CsvWriter::create(Path::new("energy.csv"), &["time", "kinetic", "strain"])?;
//! history.write_row(&[0.0, 1.0, 0.0])?;
//! history.write_row(&[1e-3, 0.75, 0.25])?;
//! history.flush()?; // both rows are in the file now
//! let (header, rows) = read_csv(Path::new("energy.csv"))?;
//! assert_eq!(header, ["time", "kinetic", "strain"]);
//! assert_eq!(rows[1], [1e-3, 0.75, 0.25]);
//! # Ok::<(), sparse_mpm::MpmError>(())
//! ```
//!
//! # Layout
//!
//! ```text
//! time,kinetic,strain
//! 0,1,0
//! 0.001,0.75,0.25
//! ```
//!
//! * Lines end with `\n`; fields are separated by `,` with no spaces.
//! * Header names are written as given, or, when they contain `,`, `"`, `\r` or `\n`, between
//!   double quotes with inner quotes doubled (RFC 4180). A header of one empty name is written
//!   `""`, so that the line is not empty.
//! * Values are written in the shortest form that reads back bit for bit with Rust's
//!   `str::parse::<f64>` (and with NumPy, pandas, Python's `float`): Rust's `{}` formatting (`0.001`,
//!   `-0`, `NaN`, `inf`, `-inf`), switching to exponent form (`1e-300`, `2.5e20`) below `1e-5` and
//!   from `1e16` on, where `{}` would spell out hundreds of zeros.
//!
//! Records are written and read by the [`csv`](https://docs.rs/csv) crate.

use std::fs::{self, File};
use std::io::{Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::{invalid_data, io_error};
use crate::error::{MpmError, Result};
use crate::numbers::push_round_trip;

/// Writes a CSV file row by row (see the [module documentation](self) for the layout).
///
/// Rows are buffered; [`flush`](CsvWriter::flush) hands every row written so far to the
/// operating system, so after it returns the rows are in the file even if the process stops
/// (the data is not `fsync`ed). Dropping the writer flushes too, ignoring errors: call `flush`
/// to see them.
///
/// The file holds whole rows only: it appears with its header (written to a temporary file and
/// renamed into place), and a flush that fails part-way (a full disk) cuts the file back to the
/// rows it held before, so a reader never meets a row cut short.
#[derive(Debug)]
pub struct CsvWriter {
    path: PathBuf,
    file: File,
    /// Bytes of the file that are whole lines (header and rows).
    committed: u64,
    /// Rows written since the last flush, as text.
    out: csv::Writer<Vec<u8>>,
    columns: usize,
    /// The text of one value, reused from value to value.
    field: String,
}

/// The writer settings of every file: `,`, `\n`, quotes only where needed.
fn writer_builder() -> csv::WriterBuilder {
    let mut builder = csv::WriterBuilder::new();
    builder
        .delimiter(b',')
        .terminator(csv::Terminator::Any(b'\n'))
        .quote_style(csv::QuoteStyle::Necessary);
    builder
}

/// The header line as [`CsvWriter::create`] writes it, newline included.
fn header_bytes(header: &[&str]) -> Vec<u8> {
    let mut w = writer_builder().from_writer(Vec::new());
    // Writing into memory cannot fail.
    w.write_record(header).expect("writing a record into memory");
    w.into_inner().expect("flushing into memory")
}

/// A `csv` error as an [`MpmError::Io`] naming `path`: I/O errors keep their kind, anything
/// else (a malformed record, invalid UTF-8) is `InvalidData`.
fn csv_error(path: &Path, e: csv::Error) -> MpmError {
    let message = e.to_string();
    match e.into_kind() {
        csv::ErrorKind::Io(source) => io_error(path, source),
        _ => invalid_data(path, message),
    }
}

impl CsvWriter {
    /// Creates (or replaces) `path` holding the header line; the file appears with its header
    /// whole or not at all.
    ///
    /// # Errors
    /// * [`MpmError::LengthMismatch`] with field `"header"` when `header` is empty (a CSV file
    ///   needs at least one column).
    /// * [`MpmError::Io`] naming `path` when it cannot be created or written.
    pub fn create(path: &Path, header: &[&str]) -> Result<Self> {
        if header.is_empty() {
            return Err(MpmError::LengthMismatch {
                field: "header",
                expected: 1,
                found: 0,
            });
        }
        let head = header_bytes(header);
        super::write_atomically(path, |w| std::io::Write::write_all(w, &head))?;
        Self::open_at(path, header.len(), head.len() as u64)
    }

    /// The writer appending to `path` after its first `committed` bytes (whole lines).
    fn open_at(path: &Path, columns: usize, committed: u64) -> Result<Self> {
        let mut file = fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(|e| io_error(path, e))?;
        file.set_len(committed).map_err(|e| io_error(path, e))?;
        file.seek(SeekFrom::End(0)).map_err(|e| io_error(path, e))?;
        Ok(CsvWriter {
            path: path.to_path_buf(),
            file,
            committed,
            out: writer_builder().from_writer(Vec::new()),
            columns,
            field: String::new(),
        })
    }

    /// Opens `path`, which must hold `rows` data rows under the header line `header` (as this
    /// writer writes it), drops any line after them, and appends from there: how a resumed run
    /// continues the report of the run it takes up.
    ///
    /// # Errors
    /// [`MpmError::Io`] naming `path` when it cannot be read or written, and of kind
    /// `InvalidData` when its header differs from `header` or it holds fewer than `rows` rows.
    pub fn append_after(path: &Path, header: &[&str], rows: usize) -> Result<Self> {
        use std::io::{Read, Seek, SeekFrom};
        // Read as a stream: a report grows with the run (about 600 bytes a step).
        let (mut file, len) = crate::io::open_regular(path, u64::MAX, "report")?;
        let head = header_bytes(header);
        let mut first = vec![0u8; head.len()];
        if len < head.len() as u64 || file.read_exact(&mut first).is_err() || first != head {
            return Err(invalid_data(path, "its header is not the report's header"));
        }
        let body_len = len - head.len() as u64;
        let ends_with_newline = body_len > 0 && {
            let mut last = [0u8; 1];
            file.seek(SeekFrom::End(-1)).map_err(|e| io_error(path, e))?;
            file.read_exact(&mut last).map_err(|e| io_error(path, e))?;
            file.seek(SeekFrom::Start(head.len() as u64))
                .map_err(|e| io_error(path, e))?;
            last[0] == b'\n'
        };
        // The end of the last of the `rows` records that end with their newline.
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(std::io::BufReader::new(file.take(body_len)));
        let mut record = csv::ByteRecord::new();
        let mut keep = 0;
        for k in 0..rows {
            let read = reader.read_byte_record(&mut record).map_err(|e| csv_error(path, e))?;
            let end = reader.position().byte();
            if !read || (end >= body_len && !ends_with_newline) {
                return Err(invalid_data(
                    path,
                    format!("it holds {k} whole rows, fewer than the {rows} the checkpoint was taken after"),
                ));
            }
            keep = end;
        }
        Self::open_at(path, header.len(), head.len() as u64 + keep)
    }

    /// Appends one row; it reaches the file at the latest at the next [`flush`](Self::flush).
    ///
    /// # Errors
    /// * [`MpmError::LengthMismatch`] with field `"row"` when `values` does not have one entry
    ///   per header column; nothing is written then.
    /// * [`MpmError::Io`] naming the file when writing fails.
    pub fn write_row(&mut self, values: &[f64]) -> Result<()> {
        if values.len() != self.columns {
            return Err(MpmError::LengthMismatch {
                field: "row",
                expected: self.columns,
                found: values.len(),
            });
        }
        for &v in values {
            self.field.clear();
            push_round_trip(&mut self.field, v);
            self.out
                .write_field(&self.field)
                .map_err(|e| csv_error(&self.path, e))?;
        }
        // An empty record ends the one the fields were written into.
        self.out
            .write_record(None::<&[u8]>)
            .map_err(|e| csv_error(&self.path, e))
    }

    /// Writes every buffered row to the file.
    ///
    /// # Errors
    /// [`MpmError::Io`] naming the file when writing fails.
    ///
    /// The rows reach the file whole or not at all: when writing fails part-way (a full disk),
    /// the file is cut back to the rows it held before, and the rows not written are dropped.
    pub fn flush(&mut self) -> Result<()> {
        use std::io::Write;
        let buffered = std::mem::replace(&mut self.out, writer_builder().from_writer(Vec::new()));
        // Into memory: cannot fail.
        let rows = buffered
            .into_inner()
            .map_err(|e| io_error(&self.path, e.into_error()))?;
        if rows.is_empty() {
            return Ok(());
        }
        match self.file.write_all(&rows) {
            Ok(()) => {
                self.committed += rows.len() as u64;
                Ok(())
            }
            Err(e) => {
                // Best effort: a cut-back that fails too leaves the file as the system left it.
                let _ = self.file.set_len(self.committed);
                let _ = self.file.seek(SeekFrom::Start(self.committed));
                Err(io_error(&self.path, e))
            }
        }
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The number of columns, i.e. of values per row.
    pub fn columns(&self) -> usize {
        self.columns
    }
}

impl Drop for CsvWriter {
    fn drop(&mut self) {
        let _ = self.flush();
    }
}

/// The largest CSV file [`read_csv`] reads (4 GiB: a report of about seven million steps).
pub const MAX_READ_BYTES: u64 = 4 << 30;

/// Reads a CSV file in the layout [`CsvWriter`] writes: the header's column names and the rows
/// of numbers. `\r\n` line ends are accepted, as are blank lines (skipped) and spaces around a
/// value; a file that ends without a final newline keeps its last row.
///
/// # Errors
/// [`MpmError::Io`] naming `path` when it cannot be read, and of kind
/// [`std::io::ErrorKind::InvalidData`] when it is empty or not UTF-8, or, naming the row (and
/// its line) and the column, when a row does not have one value per column or a value is not a
/// number.
pub fn read_csv(path: &Path) -> Result<(Vec<String>, Vec<Vec<f64>>)> {
    let (file, _) = crate::io::open_regular(path, MAX_READ_BYTES, "CSV")?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(file);
    let mut records = reader.records();
    let header: Vec<String> = match records.next() {
        None => return Err(invalid_data(path, "the file is empty: a header line is expected")),
        Some(record) => record
            .map_err(|e| csv_error(path, e))?
            .iter()
            .map(String::from)
            .collect(),
    };
    let mut rows = Vec::new();
    for (i, record) in records.enumerate() {
        let record = record.map_err(|e| csv_error(path, e))?;
        let row_number = i + 1;
        let line = record.position().map_or(0, |p| p.line());
        if record.len() != header.len() {
            return Err(invalid_data(
                path,
                format!(
                    "row {row_number} (line {line}) has {} values but the header has {} columns",
                    record.len(),
                    header.len()
                ),
            ));
        }
        let row = record
            .iter()
            .zip(&header)
            .enumerate()
            .map(|(c, (field, name))| {
                field.trim().parse::<f64>().map_err(|_| {
                    invalid_data(
                        path,
                        format!(
                            "row {row_number} (line {line}), column {} (`{name}`): `{field}` is not a number",
                            c + 1
                        ),
                    )
                })
            })
            .collect::<Result<Vec<f64>>>()?;
        rows.push(row);
    }
    Ok((header, rows))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh path in the temporary directory for one test.
    fn scratch_file(test: &str) -> PathBuf {
        std::env::temp_dir().join(format!("sparse-mpm-csv-{}-{test}.csv", std::process::id()))
    }

    /// The message of an `InvalidData` error.
    fn invalid_data_message(err: MpmError) -> String {
        match err {
            MpmError::Io { source, .. } if source.kind() == std::io::ErrorKind::InvalidData => source.to_string(),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn quoted_header_names_with_commas_quotes_and_newlines_parse_back() {
        let path = scratch_file("quoted");
        fs::write(&path, "plain,\"a,b\",\"say \"\"hi\"\"\",\"two\nlines\"\r\n1,2,3,4\n").unwrap();
        let (header, rows) = read_csv(&path).unwrap();
        assert_eq!(header, ["plain", "a,b", "say \"hi\"", "two\nlines"]);
        assert_eq!(rows, [[1.0, 2.0, 3.0, 4.0]]);
        fs::remove_file(&path).unwrap();
    }

    #[test]
    fn headers_are_written_as_before_quoting_only_where_needed() {
        assert_eq!(
            header_bytes(&["time", "kinetic energy", "J"]),
            b"time,kinetic energy,J\n"
        );
        assert_eq!(
            header_bytes(&["a,b", "say \"hi\"", "two\nlines", "cr\r"]),
            b"\"a,b\",\"say \"\"hi\"\"\",\"two\nlines\",\"cr\r\"\n"
        );
        assert_eq!(header_bytes(&["", "x"]), b",x\n");
        assert_eq!(header_bytes(&[""]), b"\"\"\n");
    }

    #[test]
    fn bad_rows_name_the_row_line_and_column() {
        let path = scratch_file("bad-rows");
        fs::write(&path, "t,e\n0,1\n1,x\n").unwrap();
        let message = invalid_data_message(read_csv(&path).unwrap_err());
        assert!(message.contains("row 2 (line 3), column 2 (`e`): `x`"), "{message}");
        fs::write(&path, "t,e\n0,1,2\n").unwrap();
        let message = invalid_data_message(read_csv(&path).unwrap_err());
        assert!(message.contains("row 1 (line 2) has 3 values"), "{message}");
        fs::write(&path, "").unwrap();
        let message = invalid_data_message(read_csv(&path).unwrap_err());
        assert!(message.contains("empty"), "{message}");
        fs::remove_file(&path).unwrap();
    }

    #[test]
    fn append_after_keeps_the_rows_asked_for_and_continues_byte_for_byte() {
        let header = ["t", "odd, \"name\""];
        let rows = [[0.0, -0.0], [1e-3, 1e300], [f64::NAN, 2.5]];
        let whole = scratch_file("append-whole");
        let mut csv = CsvWriter::create(&whole, &header).unwrap();
        for row in &rows {
            csv.write_row(row).unwrap();
        }
        drop(csv);
        let expected = fs::read(&whole).unwrap();

        // Two rows, a third cut off mid-line: resume after the two.
        let resumed = scratch_file("append-resumed");
        let mut text = expected.clone();
        text.truncate(expected.len() - 3);
        fs::write(&resumed, &text).unwrap();
        let mut csv = CsvWriter::append_after(&resumed, &header, 2).unwrap();
        assert_eq!(csv.columns(), 2);
        csv.write_row(&rows[2]).unwrap();
        drop(csv);
        assert_eq!(fs::read(&resumed).unwrap(), expected);

        // Asking for more whole rows than there are, or another header, is refused.
        fs::write(&resumed, &text).unwrap();
        let message = invalid_data_message(CsvWriter::append_after(&resumed, &header, 3).unwrap_err());
        assert!(message.contains("it holds 2 whole rows"), "{message}");
        let message = invalid_data_message(CsvWriter::append_after(&resumed, &["t", "e"], 0).unwrap_err());
        assert!(message.contains("header"), "{message}");
        // Zero rows keeps the header alone.
        drop(CsvWriter::append_after(&resumed, &header, 0).unwrap());
        assert_eq!(fs::read(&resumed).unwrap(), header_bytes(&header));
        fs::remove_file(&whole).unwrap();
        fs::remove_file(&resumed).unwrap();
    }
}
