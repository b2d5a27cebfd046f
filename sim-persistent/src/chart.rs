//! Stitch charts: the text format, its parser and builders for the simple knit patterns.
//!
//! A chart is a grid of stitches, `height` rows of `width` stitches each. Row 0 is the first
//! row knitted (the bottom of the fabric, just above the cast-on); stitch `c` of a row is
//! column `c` counted from the left **as the fabric is seen from its front (right side)**.
//! Every cell says how the loop of that row is pulled through the loop of the row below it
//! (seed 000 §3.1): `K` (knit: seen from the front, the new loop comes through to the front)
//! or `P` (purl: it goes through to the back). With this front-view convention garter is
//! rows of `K` alternating with rows of `P`, stockinette is all `K`.
//!
//! # Text format
//!
//! ```text
//! # garter, 6 stitches wide        <- comment: from '#' to the end of the line
//! K6                               <- row 0 (first line with stitches = bottom row)
//! P P P P P P                      <- row 1: tokens separated by spaces, tabs or commas
//! K2 K4                            <- run-length: a stitch letter and a repeat count ≥ 1
//! ```
//!
//! Grammar (case-insensitive letters; one row per non-blank line):
//!
//! ```text
//! chart   = { line } ;              at least one row
//! line    = [ row ] [ "#" comment ] newline ;
//! row     = token { sep token } ;   every row has the same number of stitches
//! sep     = ( " " | "\t" | "," ) { " " | "\t" | "," } ;
//! token   = stitch [ count ] | reserved ;
//! stitch  = "K" | "P" ;
//! count   = digit { digit } ;       1 ≤ count ≤ MAX_RUN
//! reserved = "YO" | "K2TOG" | "SSK" | "M1" ;   parsed, rejected as not supported yet
//! ```
//!
//! Yarn-overs, increases and decreases (seed 000 §3.1, §3.2.3: stacked stitches) are part of
//! the grammar so that charts using them fail with [`ChartError::Unsupported`] rather than a
//! generic syntax error; the topology for them (n-yarn contact nodes) comes later.
//!
//! Errors ([`ChartError`]) name the 1-based line and column (in characters) of the offending
//! token and what was expected there.

use std::fmt;

/// Largest accepted repeat count of one token (and largest chart width).
pub const MAX_RUN: usize = 100_000;

/// One stitch of a chart (seed 000 §3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stitch {
    /// Knit: seen from the front, the loop is pulled through the loop below to the front.
    Knit,
    /// Purl: seen from the front, the loop is pulled through the loop below to the back.
    Purl,
}

impl Stitch {
    /// The chart letter (`'K'` or `'P'`).
    pub fn letter(self) -> char {
        match self {
            Stitch::Knit => 'K',
            Stitch::Purl => 'P',
        }
    }

    /// Out-of-plane sign of the stitch as seen from the front: `+1` for knit, `−1` for purl.
    /// Used by the layout to offset the two contact nodes of each stitch contact.
    pub fn sign(self) -> f64 {
        match self {
            Stitch::Knit => 1.0,
            Stitch::Purl => -1.0,
        }
    }

    /// The other stitch (a knit seen from the back is a purl).
    pub fn flipped(self) -> Self {
        match self {
            Stitch::Knit => Stitch::Purl,
            Stitch::Purl => Stitch::Knit,
        }
    }
}

/// Stitch names that are part of the grammar but not supported yet.
pub const RESERVED: [&str; 4] = ["YO", "K2TOG", "SSK", "M1"];

/// A malformed chart. Lines and columns are 1-based; columns count characters.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ChartError {
    /// A token that is neither a stitch nor a reserved name.
    #[error("line {line}, column {column}: unexpected `{token}`, expected {expected}")]
    UnexpectedToken {
        /// Line of the token.
        line: usize,
        /// Column of the token's first character.
        column: usize,
        /// The token as written.
        token: String,
        /// What the grammar allows here.
        expected: &'static str,
    },
    /// A reserved stitch (`YO`, `K2TOG`, `SSK`, `M1`) that is not supported yet.
    #[error("line {line}, column {column}: stitch `{token}` is not supported yet (only K and P)")]
    Unsupported {
        /// Line of the token.
        line: usize,
        /// Column of the token's first character.
        column: usize,
        /// The reserved name as written.
        token: String,
    },
    /// A repeat count of 0 or above [`MAX_RUN`].
    #[error(
        "line {line}, column {column}: repeat count `{count}` out of range, expected 1 to {max}"
    )]
    BadCount {
        /// Line of the token.
        line: usize,
        /// Column of the first digit.
        column: usize,
        /// The count as written.
        count: String,
        /// [`MAX_RUN`].
        max: usize,
    },
    /// A row whose stitch count differs from the first row's.
    #[error(
        "line {line}, column {column}: row has {found} stitches, expected {expected} (the width of the first row, line {first_line})"
    )]
    RaggedRow {
        /// Line of the row.
        line: usize,
        /// Column of the row's first token.
        column: usize,
        /// Stitches found in this row.
        found: usize,
        /// Width of the first row.
        expected: usize,
        /// Line of the first row.
        first_line: usize,
    },
    /// A row wider than [`MAX_RUN`] stitches.
    #[error("line {line}, column {column}: row is wider than {max} stitches")]
    TooWide {
        /// Line of the row.
        line: usize,
        /// Column of the token that made it too wide.
        column: usize,
        /// [`MAX_RUN`].
        max: usize,
    },
    /// No row at all (only blank lines and comments).
    #[error("line {line}, column 1: chart has no rows, expected at least one row of K/P stitches")]
    Empty {
        /// The line after the last one (where a row was expected).
        line: usize,
    },
    /// A builder was called with a zero size or an empty rib.
    #[error("invalid chart size: {0}")]
    InvalidSize(String),
}

/// A rectangular stitch chart (see the module documentation for the conventions).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Chart {
    width: usize,
    stitches: Vec<Stitch>,
}

impl Chart {
    /// A chart from rows (row 0 first). Errors if there are no rows, a row is empty, or the
    /// rows differ in width.
    pub fn from_rows(rows: Vec<Vec<Stitch>>) -> Result<Self, ChartError> {
        let width = rows.first().map_or(0, Vec::len);
        if width == 0 {
            return Err(ChartError::InvalidSize(
                "a chart needs ≥ 1 row of ≥ 1 stitch".into(),
            ));
        }
        if let Some(r) = rows.iter().position(|row| row.len() != width) {
            return Err(ChartError::InvalidSize(format!(
                "row {r} has {} stitches, row 0 has {width}",
                rows[r].len()
            )));
        }
        Ok(Self {
            width,
            stitches: rows.into_iter().flatten().collect(),
        })
    }

    /// A `width × height` chart whose stitch at (row, column) is `f(row, column)`.
    pub fn from_fn(
        width: usize,
        height: usize,
        f: impl Fn(usize, usize) -> Stitch,
    ) -> Result<Self, ChartError> {
        if width == 0 || height == 0 {
            return Err(ChartError::InvalidSize(format!(
                "{width} × {height}: width and height must be ≥ 1"
            )));
        }
        let rows = (0..height)
            .map(|r| (0..width).map(|c| f(r, c)).collect())
            .collect();
        Self::from_rows(rows)
    }

    /// Stockinette: every stitch a knit (seed 000 §3.1, Fig. 2).
    pub fn stockinette(width: usize, height: usize) -> Result<Self, ChartError> {
        Self::from_fn(width, height, |_, _| Stitch::Knit)
    }

    /// Garter: rows of knits alternating with rows of purls (front view), starting with knit.
    pub fn garter(width: usize, height: usize) -> Result<Self, ChartError> {
        Self::from_fn(width, height, |r, _| {
            if r % 2 == 0 {
                Stitch::Knit
            } else {
                Stitch::Purl
            }
        })
    }

    /// `k × p` rib: in every row, `k` knits then `p` purls, repeated across (columns line up).
    pub fn rib(width: usize, height: usize, k: usize, p: usize) -> Result<Self, ChartError> {
        if k == 0 || p == 0 {
            return Err(ChartError::InvalidSize(format!(
                "rib {k}×{p}: both counts must be ≥ 1"
            )));
        }
        Self::from_fn(width, height, |_, c| {
            if c % (k + p) < k {
                Stitch::Knit
            } else {
                Stitch::Purl
            }
        })
    }

    /// Seed (moss) stitch: knits and purls alternate along rows and along columns.
    pub fn seed(width: usize, height: usize) -> Result<Self, ChartError> {
        Self::from_fn(width, height, |r, c| {
            if (r + c) % 2 == 0 {
                Stitch::Knit
            } else {
                Stitch::Purl
            }
        })
    }

    /// Stitches per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.stitches.len() / self.width
    }

    /// The stitch at `row` (0 = bottom) and `column` (0 = left, front view).
    ///
    /// # Panics
    /// If the position is outside the chart.
    pub fn stitch(&self, row: usize, column: usize) -> Stitch {
        assert!(column < self.width, "column {column} outside the chart");
        self.stitches[row * self.width + column]
    }

    /// Row `row` as a slice.
    pub fn row(&self, row: usize) -> &[Stitch] {
        &self.stitches[row * self.width..(row + 1) * self.width]
    }

    /// The chart in the text format, run-length encoded, one row per line (row 0 first).
    /// [`Chart::parse`] reads it back to an equal chart.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        for r in 0..self.height() {
            let row = self.row(r);
            let mut tokens = Vec::new();
            let mut i = 0;
            while i < row.len() {
                let mut j = i + 1;
                while j < row.len() && row[j] == row[i] {
                    j += 1;
                }
                let n = j - i;
                tokens.push(if n == 1 {
                    row[i].letter().to_string()
                } else {
                    format!("{}{n}", row[i].letter())
                });
                i = j;
            }
            out.push_str(&tokens.join(" "));
            out.push('\n');
        }
        out
    }

    /// Parses the text format (see the module documentation).
    pub fn parse(text: &str) -> Result<Self, ChartError> {
        let mut rows: Vec<Vec<Stitch>> = Vec::new();
        let mut first_line = 0;
        let mut n_lines = 0;
        for (li, raw) in text.lines().enumerate() {
            let line = li + 1;
            n_lines = line;
            let content = raw.split('#').next().unwrap_or("");
            let mut row = Vec::new();
            let mut row_column = 0;
            for (column, token) in tokens(content) {
                if row_column == 0 {
                    row_column = column;
                }
                let (stitch, count) = parse_token(token, line, column)?;
                if row.len() + count > MAX_RUN {
                    return Err(ChartError::TooWide {
                        line,
                        column,
                        max: MAX_RUN,
                    });
                }
                row.extend(std::iter::repeat_n(stitch, count));
            }
            if row.is_empty() {
                continue;
            }
            if let Some(first) = rows.first() {
                if row.len() != first.len() {
                    return Err(ChartError::RaggedRow {
                        line,
                        column: row_column,
                        found: row.len(),
                        expected: first.len(),
                        first_line,
                    });
                }
            } else {
                first_line = line;
            }
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(ChartError::Empty { line: n_lines + 1 });
        }
        Self::from_rows(rows)
    }
}

impl fmt::Display for Chart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_text())
    }
}

impl std::str::FromStr for Chart {
    type Err = ChartError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s)
    }
}

/// Splits a line (comment already removed) into `(1-based column, token)` pairs.
fn tokens(content: &str) -> Vec<(usize, &str)> {
    let is_sep = |c: char| c == ' ' || c == '\t' || c == ',';
    let mut out = Vec::new();
    let mut start: Option<(usize, usize)> = None; // (byte offset, column)
    for (column0, (byte, ch)) in content.char_indices().enumerate() {
        match (is_sep(ch), start) {
            (false, None) => start = Some((byte, column0 + 1)),
            (true, Some((b, c))) => {
                out.push((c, &content[b..byte]));
                start = None;
            }
            _ => {}
        }
    }
    if let Some((b, c)) = start {
        out.push((c, &content[b..]));
    }
    out
}

/// Parses one token at (`line`, `column`) into a stitch and its repeat count.
fn parse_token(token: &str, line: usize, column: usize) -> Result<(Stitch, usize), ChartError> {
    let upper = token.to_ascii_uppercase();
    if RESERVED.contains(&upper.as_str()) {
        return Err(ChartError::Unsupported {
            line,
            column,
            token: token.to_owned(),
        });
    }
    let unexpected = || ChartError::UnexpectedToken {
        line,
        column,
        token: token.to_owned(),
        expected: "a stitch `K` or `P` with an optional repeat count (e.g. `K3`)",
    };
    let mut chars = upper.chars();
    let stitch = match chars.next() {
        Some('K') => Stitch::Knit,
        Some('P') => Stitch::Purl,
        _ => return Err(unexpected()),
    };
    let digits = &upper[1..];
    if digits.is_empty() {
        return Ok((stitch, 1));
    }
    if !digits.chars().all(|c| c.is_ascii_digit()) {
        return Err(unexpected());
    }
    let bad_count = || ChartError::BadCount {
        line,
        column: column + 1,
        count: digits.to_owned(),
        max: MAX_RUN,
    };
    let count: usize = digits.parse().map_err(|_| bad_count())?;
    if count == 0 || count > MAX_RUN {
        return Err(bad_count());
    }
    Ok((stitch, count))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_carry_character_columns() {
        let t = tokens("  K3,P\tK");
        assert_eq!(t, vec![(3, "K3"), (6, "P"), (8, "K")]);
        // Multi-byte characters count as one column.
        let t = tokens("é K");
        assert_eq!(t, vec![(1, "é"), (3, "K")]);
    }
}
