//! The displacement database ΔQ(sx, sa, sy) of a tile (seed 004 §3), as stored on disk.
//!
//! A database is a directory with two files:
//!
//! - `axes.txt`: three lines, the sample values of `sx`, `sa` and `sy` (in that order),
//!   whitespace-separated, strictly increasing (not necessarily uniform), 1 to
//!   [`MAX_SAMPLES`] values each. The deformation parameters are unitless.
//! - `data.npy`: a NumPy `.npy` array of little-endian `f32`, shape `(R, 4)` with
//!   `R = n · |SX| · |SA| · |SY|`; each row is `(Δx, Δy, Δz, Δθ)`: the displacement (m) and
//!   twist change (rad) of one tile vertex at one sample. Row index
//!   `isx + |SX| · (isa + |SA| · (isy + |SY| · vertex))` ([`Database::index`]).
//!
//! **What ΔQ is relative to.** A table belongs to one tile, the `.pyp` computed with it (MADYPG
//! ships it as `pyp` beside `axes.txt`; `sim-periodic database` writes `pattern.pyp`). That
//! tile's positions and twists are the solver's equilibrium at zero strain, so the zero-strain
//! row of every vertex is zero in position (its Δθ only to solver tolerance), and the tile's
//! period is the period of every sample. `(Δx, Δy, Δz)` are material-space displacements in the
//! tile's frame (x along `pₓ`, y along `p_y`, z out of plane): the equilibrium's fluctuation
//! pulled back by `F₃⁻¹` (seed 004 Eq. 18, `F₂ = √I`), so the runtime adds them to the tile's
//! positions before mapping. A sample's rigid translation is fixed by the solver's constraints,
//! not by the mechanics; [`crate::agreement`] removes it before comparing tables.
//! `yarn-pattern/tests/published_tables.rs` checks this on MADYPG's published stockinette
//! tables.
//!
//! The writer produces `.npy` format version 1.0 with the header padded to a multiple of 64
//! bytes; the reader accepts versions 1.0 and 2.0. Errors name the file and, for `axes.txt`,
//! the 1-based line.

use std::path::{Path, PathBuf};

/// Largest number of samples per axis.
pub const MAX_SAMPLES: usize = 32;

/// Names of the three axes, in storage order.
pub const AXIS_NAMES: [&str; 3] = ["sx", "sa", "sy"];

/// Name of the axes file in a database directory.
pub const AXES_FILE: &str = "axes.txt";

/// Name of the data file in a database directory.
pub const DATA_FILE: &str = "data.npy";

/// The NumPy type string of the stored values: little-endian `f32`.
const F32_LE: &str = "<f4";

/// A displacement database ΔQ(sx, sa, sy) of a tile with `n_vertices` vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct Database {
    /// Sample values (unitless) of `sx`, `sa`, `sy`: strictly increasing, finite, 1 to
    /// [`MAX_SAMPLES`] each.
    pub axes: [Vec<f64>; 3],
    /// Number of tile vertices `n`.
    pub n_vertices: usize,
    /// Rows `(Δx, Δy, Δz, Δθ)`: vertex displacement (m) and twist change (rad), in the
    /// order of [`Database::index`]; `n · |SX| · |SA| · |SY|` rows.
    pub data: Vec<[f32; 4]>,
}

/// Why an axis is invalid.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AxisProblem {
    /// No samples.
    #[error("expected 1 to {MAX_SAMPLES} sample values of {axis}, found none")]
    Empty {
        /// Axis name.
        axis: &'static str,
    },
    /// More than [`MAX_SAMPLES`] samples.
    #[error("expected at most {MAX_SAMPLES} sample values of {axis}, found {found}")]
    TooMany {
        /// Axis name.
        axis: &'static str,
        /// Number of samples found.
        found: usize,
    },
    /// A token is not a number.
    #[error("expected a number as sample value of {axis}, found {token:?}")]
    NotANumber {
        /// Axis name.
        axis: &'static str,
        /// The token.
        token: String,
    },
    /// A sample is NaN or infinite.
    #[error("expected finite sample values of {axis}, found {value} at position {index}")]
    NonFinite {
        /// Axis name.
        axis: &'static str,
        /// 0-based position on the axis.
        index: usize,
        /// The value.
        value: f64,
    },
    /// Samples are not strictly increasing.
    #[error(
        "expected strictly increasing sample values of {axis}, found {value} after {previous} at position {index}"
    )]
    NotIncreasing {
        /// Axis name.
        axis: &'static str,
        /// 0-based position on the axis of the offending value.
        index: usize,
        /// The preceding value.
        previous: f64,
        /// The offending value.
        value: f64,
    },
}

/// Why a `data.npy` file is not a valid database array.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NpyProblem {
    /// Not a readable `.npy` file (magic string, version, header dictionary or data), as
    /// reported by the npyz reader.
    #[error(
        "expected a valid .npy file (format 1.0–3.0, header dictionary with 'descr', 'fortran_order', 'shape'): {0}"
    )]
    BadHeader(String),
    /// The element type is not little-endian `f32`.
    #[error("expected dtype '<f4' (little-endian float32), found {found:?}")]
    WrongDtype {
        /// The `descr` found.
        found: String,
    },
    /// A displacement is NaN or infinite.
    #[error("expected finite displacements, found {value} in row {row}")]
    NonFinite {
        /// 0-based row.
        row: usize,
        /// The value.
        value: f32,
    },
    /// The array is stored in Fortran (column-major) order.
    #[error("expected 'fortran_order': False (row-major data), found True")]
    FortranOrder,
    /// The shape is not `(R, 4)` with `R ≥ 1`.
    #[error("expected shape (R, 4) with R ≥ 1 rows of (Δx, Δy, Δz, Δθ), found {found:?}")]
    WrongShape {
        /// The shape found.
        found: Vec<usize>,
    },
    /// The row count is not a multiple of the number of samples per vertex.
    #[error(
        "expected a row count divisible by |SX|·|SA|·|SY| = {per_vertex} (from {AXES_FILE}), found {rows}"
    )]
    RowsNotDivisible {
        /// Rows in the file.
        rows: usize,
        /// `|SX| · |SA| · |SY|`.
        per_vertex: usize,
    },
    /// The data section has the wrong size.
    #[error("expected {expected} bytes of data for shape ({rows}, 4), found {found}")]
    DataLength {
        /// Rows of the shape.
        rows: usize,
        /// Bytes expected (`16 · rows`).
        expected: usize,
        /// Bytes found after the header.
        found: usize,
    },
}

/// Errors of reading, writing or validating a [`Database`].
#[derive(Debug, thiserror::Error)]
pub enum DatabaseError {
    /// A file or directory could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// `axes.txt` does not have exactly three lines of samples.
    #[error("{}:{line}: expected 3 lines of sample values (sx, sa, sy), found {found}", path.display())]
    AxesLineCount {
        /// The file.
        path: PathBuf,
        /// The line of the first extra line, or the last line when lines are missing.
        line: usize,
        /// Number of lines found (not counting trailing blank lines beyond the third).
        found: usize,
    },
    /// An axis in `axes.txt` is invalid.
    #[error("{}:{line}: {problem}", path.display())]
    Axis {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        problem: AxisProblem,
    },
    /// `data.npy` is invalid.
    #[error("{}: {problem}", path.display())]
    Npy {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: NpyProblem,
    },
    /// An in-memory database is inconsistent (checked before writing).
    #[error("invalid database: {0}")]
    InvalidAxis(AxisProblem),
    /// An in-memory database has the wrong number of rows (checked before writing).
    #[error("invalid database: expected n · |SX| · |SA| · |SY| = {expected} rows, found {found}")]
    DataLength {
        /// Rows expected.
        expected: usize,
        /// Rows found.
        found: usize,
    },
}

impl Database {
    /// Number of samples per vertex, `|SX| · |SA| · |SY|`.
    pub fn samples_per_vertex(&self) -> usize {
        self.axes.iter().map(Vec::len).product()
    }

    /// Row index of (vertex, isx, isa, isy): `isx + |SX| · (isa + |SA| · (isy + |SY| · vertex))`.
    /// No bounds check; see [`Database::get`].
    pub fn index(&self, vertex: usize, isx: usize, isa: usize, isy: usize) -> usize {
        let [sx, sa, sy] = [0, 1, 2].map(|k| self.axes[k].len());
        isx + sx * (isa + sa * (isy + sy * vertex))
    }

    /// The row `(Δx, Δy, Δz, Δθ)` (m, m, m, rad) of vertex `vertex` at sample
    /// `(sx[isx], sa[isa], sy[isy])`; `None` if an index is out of range.
    pub fn get(&self, vertex: usize, isx: usize, isa: usize, isy: usize) -> Option<[f32; 4]> {
        let in_range = vertex < self.n_vertices
            && isx < self.axes[0].len()
            && isa < self.axes[1].len()
            && isy < self.axes[2].len();
        if !in_range {
            return None;
        }
        self.data.get(self.index(vertex, isx, isa, isy)).copied()
    }

    /// Checks the axes (strictly increasing, finite, 1 to [`MAX_SAMPLES`] values) and the
    /// number of rows.
    pub fn validate(&self) -> Result<(), DatabaseError> {
        for (axis, values) in AXIS_NAMES.into_iter().zip(&self.axes) {
            check_axis(axis, values).map_err(DatabaseError::InvalidAxis)?;
        }
        let expected = self.n_vertices.checked_mul(self.samples_per_vertex());
        if expected != Some(self.data.len()) {
            return Err(DatabaseError::DataLength {
                expected: expected.unwrap_or(usize::MAX),
                found: self.data.len(),
            });
        }
        Ok(())
    }

    /// Writes `dir/axes.txt` and `dir/data.npy` (creating `dir`), after validating.
    pub fn write(&self, dir: impl AsRef<Path>) -> Result<(), DatabaseError> {
        self.validate()?;
        let dir = dir.as_ref();
        std::fs::create_dir_all(dir).map_err(|source| io_error(dir, source))?;

        let mut axes = String::new();
        for values in &self.axes {
            let line: Vec<String> = values.iter().map(f64::to_string).collect();
            axes.push_str(&line.join(" "));
            axes.push('\n');
        }
        let path = dir.join(AXES_FILE);
        std::fs::write(&path, axes).map_err(|source| io_error(&path, source))?;

        let path = dir.join(DATA_FILE);
        let bytes = npy_bytes(&self.data).map_err(|source| io_error(&path, source))?;
        std::fs::write(&path, bytes).map_err(|source| io_error(&path, source))
    }

    /// Reads and validates `dir/axes.txt` and `dir/data.npy`.
    pub fn read(dir: impl AsRef<Path>) -> Result<Database, DatabaseError> {
        let dir = dir.as_ref();
        let path = dir.join(AXES_FILE);
        let text = std::fs::read_to_string(&path).map_err(|source| io_error(&path, source))?;
        let path = dir.join(DATA_FILE);
        let bytes = std::fs::read(&path).map_err(|source| io_error(&path, source))?;
        Self::parse(&text, &bytes, dir)
    }

    /// Parses and validates the contents of `axes.txt` (`axes_text`) and `data.npy`
    /// (`npy`) of a database folder `dir` (named in errors).
    pub fn parse(axes_text: &str, npy: &[u8], dir: &Path) -> Result<Database, DatabaseError> {
        let axes = parse_axes(axes_text, &dir.join(AXES_FILE))?;
        let path = dir.join(DATA_FILE);
        let npy_error = |problem| DatabaseError::Npy {
            path: path.clone(),
            problem,
        };
        let (rows, data) = parse_npy(npy).map_err(npy_error)?;
        let per_vertex: usize = axes.iter().map(Vec::len).product();
        if rows % per_vertex != 0 {
            return Err(npy_error(NpyProblem::RowsNotDivisible { rows, per_vertex }));
        }
        Ok(Database {
            axes,
            n_vertices: rows / per_vertex,
            data,
        })
    }
}

fn io_error(path: &Path, source: std::io::Error) -> DatabaseError {
    DatabaseError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn check_axis(axis: &'static str, values: &[f64]) -> Result<(), AxisProblem> {
    if values.is_empty() {
        return Err(AxisProblem::Empty { axis });
    }
    if values.len() > MAX_SAMPLES {
        return Err(AxisProblem::TooMany {
            axis,
            found: values.len(),
        });
    }
    for (index, &value) in values.iter().enumerate() {
        if !value.is_finite() {
            return Err(AxisProblem::NonFinite { axis, index, value });
        }
        if index > 0 && value <= values[index - 1] {
            let previous = values[index - 1];
            return Err(AxisProblem::NotIncreasing {
                axis,
                index,
                previous,
                value,
            });
        }
    }
    Ok(())
}

/// Parses `axes.txt`: three lines of samples; trailing blank lines are allowed.
fn parse_axes(text: &str, path: &Path) -> Result<[Vec<f64>; 3], DatabaseError> {
    let mut lines: Vec<&str> = text.lines().collect();
    while lines.len() > 3 && lines.last().is_some_and(|l| l.trim().is_empty()) {
        lines.pop();
    }
    if lines.len() != 3 {
        return Err(DatabaseError::AxesLineCount {
            path: path.to_path_buf(),
            line: lines.len().clamp(1, 4),
            found: lines.len(),
        });
    }
    let mut axes: [Vec<f64>; 3] = Default::default();
    for (k, (line, axis)) in lines.iter().zip(AXIS_NAMES).enumerate() {
        let located = |problem| DatabaseError::Axis {
            path: path.to_path_buf(),
            line: k + 1,
            problem,
        };
        for token in line.split_whitespace() {
            let value = token.parse::<f64>().map_err(|_| {
                located(AxisProblem::NotANumber {
                    axis,
                    token: token.to_string(),
                })
            })?;
            axes[k].push(value);
        }
        check_axis(axis, &axes[k]).map_err(located)?;
    }
    Ok(axes)
}

/// The `.npy` bytes (format 1.0, through npyz) of an `(R, 4)` little-endian `f32` array.
fn npy_bytes(rows: &[[f32; 4]]) -> std::io::Result<Vec<u8>> {
    use npyz::WriterBuilder as _;
    let mut bytes = Vec::with_capacity(128 + 16 * rows.len());
    let mut writer = npyz::WriteOptions::new()
        .dtype(npyz::DType::Plain(
            F32_LE.parse().expect("a valid type string"),
        ))
        .shape(&[rows.len() as u64, 4])
        .writer(&mut bytes)
        .begin_nd()?;
    writer.extend(rows.iter().flatten().copied())?;
    writer.finish()?;
    Ok(bytes)
}

/// Parses an `.npy` file (through npyz) holding an `(R, 4)` little-endian `f32` array:
/// `(R, rows)`.
/// Checks the header dictionary of a `.npy` file before npyz parses it: at most
/// [`MAX_NPY_HEADER`] bytes of ASCII, only the characters of a plain
/// `{'descr': '<f4', 'fortran_order': False, 'shape': (R, 4), }` dictionary, no lists, and
/// brackets nested at most two deep (the dictionary and its shape tuple). npyz parses the
/// header as a Python literal with a backtracking parser that takes exponential time on
/// nested brackets (found by fuzzing: headers of nested `[`, `{` or `(` ran past 10 s), and
/// a database never needs them (a structured dtype is refused anyway).
fn check_npy_header(bytes: &[u8]) -> Result<(), NpyProblem> {
    let bad = |what: &str| NpyProblem::BadHeader(what.to_string());
    let body = bytes
        .strip_prefix(b"\x93NUMPY".as_slice())
        .ok_or_else(|| bad("no .npy magic string"))?;
    let (length, start) = match body {
        [1, _, a, b, ..] => (usize::from(u16::from_le_bytes([*a, *b])), 4usize),
        [2 | 3, _, a, b, c, d, ..] => (u32::from_le_bytes([*a, *b, *c, *d]) as usize, 6),
        [major, ..] => return Err(bad(&format!("unsupported format version {major}"))),
        [] => return Err(bad("truncated before the version")),
    };
    if length > MAX_NPY_HEADER {
        return Err(bad(&format!(
            "a header of {length} bytes; a float32 array's takes about 128 (at most \
             {MAX_NPY_HEADER} are read)"
        )));
    }
    let header = body
        .get(start..start + length)
        .ok_or_else(|| bad("the header is longer than the file"))?;
    let allowed = |c: u8| c.is_ascii_alphanumeric() || b"{}'\"():,<>|=_-. \n\t\r".contains(&c);
    if let Some(c) = header.iter().find(|&&c| !allowed(c)) {
        return Err(bad(&format!(
            "the header dictionary holds {:?}, which a plain float32 array's header never does",
            char::from(*c)
        )));
    }
    let mut depth = 0usize;
    for &c in header {
        match c {
            b'{' | b'(' => depth += 1,
            b'}' | b')' => depth = depth.saturating_sub(1),
            _ => {}
        }
        if depth > 2 {
            return Err(bad(
                "brackets nested more than two deep; a float32 array's header holds a \
                 dictionary and its shape tuple",
            ));
        }
    }
    Ok(())
}

/// The longest `.npy` header [`check_npy_header`] accepts (bytes).
const MAX_NPY_HEADER: usize = 4096;

fn parse_npy(bytes: &[u8]) -> Result<(usize, Vec<[f32; 4]>), NpyProblem> {
    check_npy_header(bytes)?;
    let mut rest = bytes;
    let npy = npyz::NpyHeader::from_reader(&mut rest)
        .map_err(|e| NpyProblem::BadHeader(e.to_string()))?;
    match npy.dtype() {
        npyz::DType::Plain(t) if t.to_string() == F32_LE => {}
        other => {
            let found = match other {
                npyz::DType::Plain(t) => t.to_string(),
                other => other.descr().to_string(),
            };
            return Err(NpyProblem::WrongDtype { found });
        }
    }
    if npy.order() == npyz::Order::Fortran {
        return Err(NpyProblem::FortranOrder);
    }
    let shape: Vec<usize> = npy.shape().iter().map(|&d| d as usize).collect();
    let rows = match shape[..] {
        [rows, 4] if rows >= 1 => rows,
        _ => return Err(NpyProblem::WrongShape { found: shape }),
    };
    let expected = rows.saturating_mul(16);
    if rest.len() != expected {
        return Err(NpyProblem::DataLength {
            rows,
            expected,
            found: rest.len(),
        });
    }
    let values = npyz::NpyFile::with_header(npy, rest)
        .into_vec::<f32>()
        .map_err(|e| NpyProblem::BadHeader(e.to_string()))?;
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        return Err(NpyProblem::NonFinite {
            row: k / 4,
            value: values[k],
        });
    }
    let data = values
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    Ok((rows, data))
}
