//! A small numeric table (named columns of `f64`) with CSV read/write through the `csv` crate.
//!
//! The file is one header record of column names, then one record per row. Numbers are
//! written in Rust's shortest round-trip form (exponent notation below 1e-4 and from 1e15 in
//! magnitude), so reading a written table gives back the exact same values. Reading accepts
//! any RFC 4180 CSV whose fields are numbers; blank lines are skipped. Errors name the source
//! and the 1-based line of the first bad entry.

use std::path::Path;

use crate::error::{OutputError, Result};

/// Named columns of `f64` values, stored row by row.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Column names, in order.
    pub columns: Vec<String>,
    /// Rows; each has exactly `columns.len()` values.
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    /// An empty table with the given column names.
    pub fn new<S: AsRef<str>>(columns: &[S]) -> Self {
        Self {
            columns: columns.iter().map(|c| c.as_ref().to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row.
    ///
    /// # Panics
    /// If the row length differs from the number of columns (a programming error).
    pub fn push_row(&mut self, row: impl Into<Vec<f64>>) {
        let row = row.into();
        assert_eq!(
            row.len(),
            self.columns.len(),
            "row has {} values but the table has {} columns {:?}",
            row.len(),
            self.columns.len(),
            self.columns
        );
        self.rows.push(row);
    }

    /// The values of the named column, or `None` if there is no such column.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let j = self.columns.iter().position(|c| c == name)?;
        Some(self.rows.iter().map(|r| r[j]).collect())
    }

    /// Renders the table as CSV text.
    pub fn to_csv_string(&self) -> Result<String> {
        let invalid = |e: csv::Error| OutputError::Invalid(format!("CSV: {e}"));
        let mut w = csv::WriterBuilder::new()
            .terminator(csv::Terminator::Any(b'\n'))
            .from_writer(Vec::new());
        w.write_record(&self.columns).map_err(invalid)?;
        for (i, row) in self.rows.iter().enumerate() {
            if row.len() != self.columns.len() {
                return Err(OutputError::Invalid(format!(
                    "row {} has {} values but there are {} columns",
                    i + 1,
                    row.len(),
                    self.columns.len()
                )));
            }
            w.write_record(row.iter().map(|&v| number(v)))
                .map_err(invalid)?;
        }
        let bytes = w
            .into_inner()
            .map_err(|e| OutputError::Invalid(format!("CSV: {e}")))?;
        Ok(String::from_utf8(bytes).expect("CSV of UTF-8 names and numbers is UTF-8"))
    }

    /// Writes the table to a CSV file.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        crate::write_file(path, self.to_csv_string()?.as_bytes())
    }

    /// Reads a CSV file (e.g. one written by [`Table::write_csv`]).
    pub fn read_csv(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| OutputError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse_csv(&text, &path.display().to_string())
    }

    /// Parses CSV text; `source` (e.g. a file name) names it in errors.
    pub fn parse_csv(text: &str, source: &str) -> Result<Self> {
        let located = |line: u64, message: String| OutputError::Csv {
            source_name: source.to_string(),
            line,
            message,
        };
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let mut records = reader.records();
        let header = match records.next() {
            None => {
                return Err(located(
                    1,
                    "empty file, expected a header line of column names".into(),
                ));
            }
            Some(r) => r.map_err(|e| located(1, e.to_string()))?,
        };
        let columns: Vec<String> = header.iter().map(str::to_string).collect();
        if columns.iter().any(String::is_empty) {
            return Err(located(
                1,
                format!("empty column name in header {columns:?}"),
            ));
        }
        let mut rows = Vec::new();
        for record in records {
            let record = record.map_err(|e| {
                let line = e.position().map_or(0, |p| p.line());
                located(line, e.to_string())
            })?;
            let line = record.position().map_or(0, |p| p.line());
            if record.iter().all(str::is_empty) {
                continue;
            }
            if record.len() != columns.len() {
                return Err(located(
                    line,
                    format!(
                        "expected {} values (columns {}), found {}",
                        columns.len(),
                        columns.join(", "),
                        record.len()
                    ),
                ));
            }
            let row = record
                .iter()
                .zip(&columns)
                .map(|(field, column)| {
                    field.parse::<f64>().map_err(|_| {
                        located(
                            line,
                            format!("column {column:?}: cannot parse {field:?} as a number"),
                        )
                    })
                })
                .collect::<Result<Vec<f64>>>()?;
            rows.push(row);
        }
        Ok(Self { columns, rows })
    }
}

/// `v` in shortest round-trip form, in exponent notation for very small or very large
/// magnitudes.
fn number(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e15).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact() {
        let mut t = Table::new(&["x", "y"]);
        t.push_row([0.1, 1.0 / 3.0]);
        t.push_row([1e-20, -2.5e300]);
        t.push_row([0.0, f64::INFINITY]);
        let text = t.to_csv_string().unwrap();
        assert_eq!(text.lines().next(), Some("x,y"));
        let back = Table::parse_csv(&text, "t.csv").unwrap();
        assert_eq!(back, t);
    }

    #[test]
    fn bad_input_names_file_and_line() {
        let err = Table::parse_csv("x,y\n1,2\n3,abc\n", "data.csv").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("data.csv:3"), "{msg}");
        assert!(msg.contains("\"y\""), "{msg}");

        let err = Table::parse_csv("x,y\n1,2,3\n", "data.csv").unwrap_err();
        assert!(err.to_string().contains("data.csv:2"), "{err}");

        let err = Table::parse_csv("", "empty.csv").unwrap_err();
        assert!(err.to_string().contains("empty.csv:1"), "{err}");
    }

    #[test]
    fn blank_lines_and_quoted_fields_are_read() {
        let t = Table::parse_csv("\"a\", b\n1, 2\n\n3,\"4\"\n", "q.csv").unwrap();
        assert_eq!(t.columns, ["a", "b"]);
        assert_eq!(t.rows, [[1.0, 2.0], [3.0, 4.0]]);
    }

    #[test]
    fn column_lookup() {
        let mut t = Table::new(&["n", "err"]);
        t.push_row([1.0, 0.5]);
        t.push_row([2.0, 0.25]);
        assert_eq!(t.column("err"), Some(vec![0.5, 0.25]));
        assert_eq!(t.column("nope"), None);
    }
}
