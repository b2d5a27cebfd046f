//! A small numeric table (named columns of `f64`) with CSV read/write.
//!
//! The CSV dialect is deliberately minimal: one header line of column names,
//! then one line per row of comma-separated numbers. No quoting; column names
//! may not contain commas or line breaks. Numbers are written in Rust's
//! shortest round-trip form, so reading a written table gives back the exact
//! same values.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, bail};

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
    pub fn to_csv_string(&self) -> anyhow::Result<String> {
        for c in &self.columns {
            if c.contains([',', '\n', '\r']) {
                bail!("column name {c:?} contains a comma or line break");
            }
        }
        let mut out = self.columns.join(",");
        out.push('\n');
        for (i, row) in self.rows.iter().enumerate() {
            if row.len() != self.columns.len() {
                bail!(
                    "row {} has {} values but there are {} columns",
                    i + 1,
                    row.len(),
                    self.columns.len()
                );
            }
            for (j, v) in row.iter().enumerate() {
                if j > 0 {
                    out.push(',');
                }
                write_number(&mut out, *v);
            }
            out.push('\n');
        }
        Ok(out)
    }

    /// Writes the table to a CSV file.
    pub fn write_csv(&self, path: &Path) -> anyhow::Result<()> {
        let text = self.to_csv_string()?;
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
    }

    /// Reads a CSV file written by [`Table::write_csv`].
    ///
    /// Errors name the file and line of the first bad entry.
    pub fn read_csv(path: &Path) -> anyhow::Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        Self::parse_csv(&text, &path.display().to_string())
    }

    /// Parses CSV text; `source` (e.g. a file name) is used in error messages.
    pub fn parse_csv(text: &str, source: &str) -> anyhow::Result<Self> {
        let mut lines = text.lines().enumerate();
        let Some((_, header)) = lines.next() else {
            bail!("{source}: empty file, expected a header line of column names");
        };
        let columns: Vec<String> = header.split(',').map(|c| c.trim().to_string()).collect();
        if columns.iter().any(String::is_empty) {
            bail!("{source}:1: empty column name in header {header:?}");
        }
        let mut rows = Vec::new();
        for (i, line) in lines {
            let line_no = i + 1;
            if line.trim().is_empty() {
                continue;
            }
            let fields: Vec<&str> = line.split(',').collect();
            if fields.len() != columns.len() {
                bail!(
                    "{source}:{line_no}: expected {} values (columns {}), found {}",
                    columns.len(),
                    columns.join(", "),
                    fields.len()
                );
            }
            let row = fields
                .iter()
                .zip(&columns)
                .map(|(field, column)| {
                    field.trim().parse::<f64>().map_err(|_| {
                        anyhow::anyhow!(
                            "{source}:{line_no}: column {column:?}: cannot parse {:?} as a number",
                            field.trim()
                        )
                    })
                })
                .collect::<anyhow::Result<Vec<f64>>>()?;
            rows.push(row);
        }
        Ok(Self { columns, rows })
    }
}

/// Writes `v` in shortest round-trip form, switching to exponent notation for
/// very small or very large magnitudes.
fn write_number(out: &mut String, v: f64) {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e15).contains(&a) {
        write!(out, "{v}").unwrap();
    } else {
        write!(out, "{v:e}").unwrap();
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
