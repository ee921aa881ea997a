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
//!   double quotes with inner quotes doubled (RFC 4180).
//! * Values are written in the shortest form that reads back bit for bit with Rust's
//!   `str::parse::<f64>` (and with NumPy, pandas, Python's `float`): Rust's `{}` formatting (`0.001`,
//!   `-0`, `NaN`, `inf`, `-inf`), switching to exponent form (`1e-300`, `2.5e20`) below `1e-5` and
//!   from `1e16` on, where `{}` would spell out hundreds of zeros.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::{invalid_data, io_error, push_f64};
use crate::error::{MpmError, Result};

/// Writes a CSV file row by row (see the [module documentation](self) for the layout).
///
/// Rows are buffered; [`flush`](CsvWriter::flush) hands every row written so far to the
/// operating system, so after it returns the rows are in the file even if the process stops
/// (the data is not `fsync`ed). Dropping the writer flushes too, ignoring errors: call `flush`
/// to see them.
#[derive(Debug)]
pub struct CsvWriter {
    path: PathBuf,
    out: BufWriter<File>,
    columns: usize,
    line: String,
}

impl CsvWriter {
    /// Creates (or truncates) `path` and writes the header line.
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
        let file = File::create(path).map_err(|e| io_error(path, e))?;
        let mut writer = CsvWriter {
            path: path.to_path_buf(),
            out: BufWriter::new(file),
            columns: header.len(),
            line: String::new(),
        };
        for (i, name) in header.iter().enumerate() {
            if i > 0 {
                writer.line.push(',');
            }
            if name.contains([',', '"', '\r', '\n']) {
                writer.line.push('"');
                writer.line.push_str(&name.replace('"', "\"\""));
                writer.line.push('"');
            } else {
                writer.line.push_str(name);
            }
        }
        writer.end_line()?;
        Ok(writer)
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
        for (i, &v) in values.iter().enumerate() {
            if i > 0 {
                self.line.push(',');
            }
            push_f64(&mut self.line, v);
        }
        self.end_line()
    }

    /// Writes every buffered row to the file.
    ///
    /// # Errors
    /// [`MpmError::Io`] naming the file when writing fails.
    pub fn flush(&mut self) -> Result<()> {
        self.out.flush().map_err(|e| io_error(&self.path, e))
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The number of columns, i.e. of values per row.
    pub fn columns(&self) -> usize {
        self.columns
    }

    fn end_line(&mut self) -> Result<()> {
        self.line.push('\n');
        let written = self.out.write_all(self.line.as_bytes());
        self.line.clear();
        written.map_err(|e| io_error(&self.path, e))
    }
}

/// Reads a CSV file in the layout [`CsvWriter`] writes: the header's column names and the rows
/// of numbers. `\r\n` line ends are accepted; a file that ends without a final newline keeps its
/// last row.
///
/// # Errors
/// [`MpmError::Io`] naming `path` when it cannot be read, and of kind
/// [`std::io::ErrorKind::InvalidData`], naming the line and column, when a row does not have one
/// value per column or a value is not a number.
pub fn read_csv(path: &Path) -> Result<(Vec<String>, Vec<Vec<f64>>)> {
    let text = fs::read_to_string(path).map_err(|e| io_error(path, e))?;
    parse_csv(&text).map_err(|message| invalid_data(path, message))
}

fn parse_csv(text: &str) -> std::result::Result<(Vec<String>, Vec<Vec<f64>>), String> {
    let (header, body, header_lines) = parse_header(text)?;
    let mut rows = Vec::new();
    let mut lines: Vec<&str> = body.split('\n').collect();
    if lines.last() == Some(&"") {
        lines.pop();
    }
    for (i, line) in lines.into_iter().enumerate() {
        let line_number = header_lines + i + 1;
        let line = line.strip_suffix('\r').unwrap_or(line);
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != header.len() {
            return Err(format!(
                "line {line_number} has {} values but the header has {} columns",
                fields.len(),
                header.len()
            ));
        }
        let row = fields
            .iter()
            .zip(&header)
            .enumerate()
            .map(|(c, (field, name))| {
                field.trim().parse::<f64>().map_err(|_| {
                    format!(
                        "line {line_number}, column {} (`{name}`): `{field}` is not a number",
                        c + 1
                    )
                })
            })
            .collect::<std::result::Result<Vec<f64>, String>>()?;
        rows.push(row);
    }
    Ok((header, rows))
}

/// Splits off the header record (RFC 4180 quoting, which may span lines): its fields, the rest
/// of the text, and the number of lines the header took.
fn parse_header(text: &str) -> std::result::Result<(Vec<String>, &str, usize), String> {
    if text.is_empty() {
        return Err("the file is empty: a header line is expected".into());
    }
    let mut fields = Vec::new();
    let mut field = String::new();
    let mut lines = 1;
    let mut chars = text.char_indices().peekable();
    let mut at_field_start = true;
    while let Some((i, c)) = chars.next() {
        match c {
            '"' if at_field_start => {
                // A quoted field: up to the closing quote, `""` standing for `"`.
                loop {
                    match chars.next() {
                        None => return Err("the header ends inside a quoted name".into()),
                        Some((_, '"')) if chars.peek().map(|&(_, c)| c) == Some('"') => {
                            chars.next();
                            field.push('"');
                        }
                        Some((_, '"')) => break,
                        Some((_, c)) => {
                            if c == '\n' {
                                lines += 1;
                            }
                            field.push(c);
                        }
                    }
                }
                at_field_start = false;
                match chars.peek() {
                    None | Some((_, ',' | '\n' | '\r')) => {}
                    Some(&(_, c)) => return Err(format!("header: `{c}` after a quoted name")),
                }
            }
            ',' => {
                fields.push(std::mem::take(&mut field));
                at_field_start = true;
            }
            '\r' if chars.peek().map(|&(_, c)| c) == Some('\n') => {}
            '\n' => {
                fields.push(field);
                return Ok((fields, &text[i + 1..], lines));
            }
            c => {
                field.push(c);
                at_field_start = false;
            }
        }
    }
    fields.push(field);
    Ok((fields, "", lines))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_header_names_with_commas_quotes_and_newlines_parse_back() {
        let (header, rows) = parse_csv("plain,\"a,b\",\"say \"\"hi\"\"\",\"two\nlines\"\r\n1,2,3,4\n").unwrap();
        assert_eq!(header, ["plain", "a,b", "say \"hi\"", "two\nlines"]);
        assert_eq!(rows, [[1.0, 2.0, 3.0, 4.0]]);
    }

    #[test]
    fn bad_rows_name_the_line_and_column() {
        let err = parse_csv("t,e\n0,1\n1,x\n").unwrap_err();
        assert!(err.contains("line 3, column 2 (`e`)"), "{err}");
        let err = parse_csv("t,e\n0,1,2\n").unwrap_err();
        assert!(err.contains("line 2 has 3 values"), "{err}");
    }
}
