//! Comparison of recomputed figure data against guarded reference CSVs.
//!
//! An entry passes when `|actual - reference| <= atol + rtol * |reference|`
//! (the `numpy.isclose` rule); two NaNs are equal, and infinities must match
//! exactly. On failure the error holds a small aligned table of the worst
//! offending entries.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::bail;

use yarn_output::table::Table;

/// Relative and absolute tolerance for one column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Relative tolerance (scaled by `|reference|`).
    pub rtol: f64,
    /// Absolute tolerance.
    pub atol: f64,
}

impl Tolerance {
    /// Default for reference curves: the figures are deterministic, so this
    /// only absorbs last-bit `libm` and summation-order differences between
    /// machines (`rtol = 1e-6`, `atol = 1e-12`).
    pub const REFERENCE: Tolerance = Tolerance {
        rtol: 1e-6,
        atol: 1e-12,
    };

    /// Whether `actual` is within tolerance of `reference`.
    pub fn accepts(&self, reference: f64, actual: f64) -> bool {
        if reference.is_nan() || actual.is_nan() {
            return reference.is_nan() && actual.is_nan();
        }
        if reference.is_infinite() || actual.is_infinite() {
            return reference == actual;
        }
        (actual - reference).abs() <= self.atol + self.rtol * reference.abs()
    }
}

/// Tolerances for a whole table: a default plus per-column overrides.
#[derive(Debug, Clone, PartialEq)]
pub struct Tolerances {
    /// Used for columns without an override.
    pub default: Tolerance,
    /// Per-column overrides, by column name.
    pub columns: HashMap<String, Tolerance>,
}

impl Tolerances {
    /// The same tolerance for every column.
    pub fn uniform(tolerance: Tolerance) -> Self {
        Self {
            default: tolerance,
            columns: HashMap::new(),
        }
    }

    /// Overrides the tolerance of one column.
    pub fn with_column(mut self, column: impl Into<String>, tolerance: Tolerance) -> Self {
        self.columns.insert(column.into(), tolerance);
        self
    }

    /// The tolerance used for `column`.
    pub fn for_column(&self, column: &str) -> Tolerance {
        self.columns.get(column).copied().unwrap_or(self.default)
    }
}

impl Default for Tolerances {
    fn default() -> Self {
        Self::uniform(Tolerance::REFERENCE)
    }
}

/// How many offending entries the error message lists.
const MAX_LISTED: usize = 10;

/// Compares `actual` against `reference`.
///
/// Column names and row counts must match. On failure the error lists the
/// worst offending entries (row numbers are 1-based data rows; the CSV line
/// is the row number + 1 because of the header).
pub fn compare_tables(
    reference: &Table,
    actual: &Table,
    tolerances: &Tolerances,
) -> anyhow::Result<()> {
    if reference.columns != actual.columns {
        bail!(
            "column names differ:\n  reference: {}\n  actual:    {}",
            reference.columns.join(", "),
            actual.columns.join(", ")
        );
    }
    if reference.rows.len() != actual.rows.len() {
        bail!(
            "row counts differ: reference has {} rows, actual has {}",
            reference.rows.len(),
            actual.rows.len()
        );
    }

    struct Offence<'a> {
        row: usize,
        column: &'a str,
        reference: f64,
        actual: f64,
        /// Error divided by the allowed error (>1 means failing).
        excess: f64,
    }
    let mut offences = Vec::new();
    for (i, (r_row, a_row)) in reference.rows.iter().zip(&actual.rows).enumerate() {
        if r_row.len() != reference.columns.len() || a_row.len() != actual.columns.len() {
            bail!(
                "row {} does not have {} values",
                i + 1,
                reference.columns.len()
            );
        }
        for (j, column) in reference.columns.iter().enumerate() {
            let (r, a) = (r_row[j], a_row[j]);
            let tol = tolerances.for_column(column);
            if !tol.accepts(r, a) {
                let allowed = tol.atol + tol.rtol * r.abs();
                let excess = if allowed > 0.0 {
                    (a - r).abs() / allowed
                } else {
                    f64::INFINITY
                };
                offences.push(Offence {
                    row: i + 1,
                    column,
                    reference: r,
                    actual: a,
                    excess: if excess.is_nan() {
                        f64::INFINITY
                    } else {
                        excess
                    },
                });
            }
        }
    }
    if offences.is_empty() {
        return Ok(());
    }

    offences.sort_by(|a, b| b.excess.total_cmp(&a.excess));
    let total = reference.rows.len() * reference.columns.len();
    let mut msg = format!(
        "{} of {} values out of tolerance; worst {}:\n",
        offences.len(),
        total,
        offences.len().min(MAX_LISTED)
    );
    let width = offences
        .iter()
        .map(|o| o.column.len())
        .max()
        .unwrap_or(0)
        .max("column".len());
    writeln!(
        msg,
        "  {:>5}  {:<width$}  {:>13}  {:>13}  {:>10}  {:>10}  {:>8}  {:>8}",
        "row", "column", "reference", "actual", "abs err", "rel err", "rtol", "atol"
    )
    .unwrap();
    for o in offences.iter().take(MAX_LISTED) {
        let abs = (o.actual - o.reference).abs();
        let rel = abs / o.reference.abs();
        let tol = tolerances.for_column(o.column);
        writeln!(
            msg,
            "  {:>5}  {:<width$}  {:>13.6e}  {:>13.6e}  {:>10.3e}  {:>10.3e}  {:>8.1e}  {:>8.1e}",
            o.row, o.column, o.reference, o.actual, abs, rel, tol.rtol, tol.atol
        )
        .unwrap();
    }
    bail!(msg)
}

/// Reads the reference CSV at `path` and compares `actual` against it.
///
/// A missing file is an error that says how to create it.
pub fn compare_with_file(
    path: &Path,
    actual: &Table,
    tolerances: &Tolerances,
) -> anyhow::Result<()> {
    if !path.exists() {
        bail!(
            "reference file {} does not exist; create it with \
             `cargo xtask reproduce-figures --bless` and commit it",
            path.display()
        );
    }
    let reference = Table::read_csv(path)?;
    compare_tables(&reference, actual, tolerances)
        .map_err(|e| anyhow::anyhow!("data differs from reference {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Table {
        let mut t = Table::new(&["segments", "tip deflection"]);
        for n in [4.0, 8.0, 16.0, 32.0] {
            t.push_row([n, 1.0 / (n * n)]);
        }
        t
    }

    #[test]
    fn equal_tables_pass() {
        compare_tables(&sample(), &sample(), &Tolerances::default()).unwrap();
    }

    #[test]
    fn tiny_differences_pass() {
        let mut actual = sample();
        actual.rows[2][1] *= 1.0 + 1e-9;
        compare_tables(&sample(), &actual, &Tolerances::default()).unwrap();
    }

    #[test]
    fn perturbed_entry_fails_and_names_row_and_column() {
        let mut actual = sample();
        actual.rows[2][1] *= 1.01;
        let msg = compare_tables(&sample(), &actual, &Tolerances::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("1 of 8 values"), "{msg}");
        let line = msg
            .lines()
            .find(|l| l.contains("tip deflection"))
            .expect("offending row listed");
        assert!(line.trim_start().starts_with('3'), "{msg}");
        assert!(line.contains("3.906250e-3"), "{msg}");
    }

    #[test]
    fn per_column_tolerance_applies() {
        let mut actual = sample();
        actual.rows[2][1] *= 1.01;
        let loose = Tolerances::default().with_column(
            "tip deflection",
            Tolerance {
                rtol: 0.1,
                atol: 0.0,
            },
        );
        compare_tables(&sample(), &actual, &loose).unwrap();
    }

    #[test]
    fn nan_handling() {
        let mut reference = sample();
        reference.rows[0][1] = f64::NAN;
        let mut actual = reference.clone();
        compare_tables(&reference, &actual, &Tolerances::default()).unwrap();
        actual.rows[0][1] = 0.0;
        assert!(compare_tables(&reference, &actual, &Tolerances::default()).is_err());
    }

    #[test]
    fn mismatched_shapes_fail_clearly() {
        let mut fewer_rows = sample();
        fewer_rows.rows.pop();
        let msg = compare_tables(&sample(), &fewer_rows, &Tolerances::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("reference has 4 rows, actual has 3"), "{msg}");

        let mut renamed = sample();
        renamed.columns[1] = "tip rotation".into();
        let msg = compare_tables(&sample(), &renamed, &Tolerances::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("column names differ"), "{msg}");
        assert!(msg.contains("tip rotation"), "{msg}");
    }

    #[test]
    fn missing_reference_file_says_how_to_bless() {
        let path = Path::new("/nonexistent/reference/rod-cantilever.csv");
        let msg = compare_with_file(path, &sample(), &Tolerances::default())
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("cargo xtask reproduce-figures --bless"),
            "{msg}"
        );
    }
}
