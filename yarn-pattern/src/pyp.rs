//! Reading and writing periodic yarn patterns (`.pyp`, the tile format of Sperl et al. 2021/2022).
//!
//! Plain text; `#` starts a comment that runs to the end of the line; blank lines are ignored
//! (by convention they separate blocks); `\n` and `\r\n` line endings are accepted. Each block
//! starts with a header line `*name`, followed by its data lines. Units: metres, radians.
//!
//! | block | data lines | content |
//! |---|---|---|
//! | `*pattern` | 1 | `px py r n [skew]`: tile period along x and y (m), yarn radius (m), number of vertices `n` (= number of edges), and optionally the lattice skew ([`Tile::skew`], unitless, 0 when absent; our extension, written only when non-zero) |
//! | `*Q` | `n` | `x y z t`: vertex position (m), twist angle (rad) of the edge starting at this vertex |
//! | `*E` | `n` | `v0 v1 dx dy`: edge from `v0` to the copy of `v1` shifted by `(dx, dy)` periods (`dx a₁ + dy a₂`, [`Tile::period_offset`]) |
//! | `*RL` | `n` | rest length (m) of the edge starting at vertex `i` (line `i`) |
//! | `*RK` | `n` | `κ₁ κ₂`: rest curvature (material-frame components, unitless) per vertex |
//! | `*RT` | `n` | rest twist (rad) per vertex |
//! | `*RefD1` | `n` | `x y z`: reference director d1 of the edge starting at vertex `i` (line `i`) |
//! | `*RefT` | `n` | reference twist (rad) per vertex |
//!
//! **Per-edge blocks are listed by start vertex**, like the `t` column of `*Q`: line `i` of
//! `*RL` and `*RefD1` belongs to the edge that leaves vertex `i`, not to line `i` of `*E`.
//! The real data show this: in `stockinette.pyp` (where line `i` of `*E` *ends* at vertex
//! `i`), `*RL` matches the lengths of the edges leaving each vertex to 0.3 % and `*RefD1` is
//! orthogonal to them to 1e-5, while by `*E` line `*RL` is off by up to 31 % and `*RefD1`
//! is far from orthogonal. [`Tile`] stores them by edge index ([`Tile::rest_lengths`]`[e]`
//! for edge `e`); the reader and the writer convert.
//!
//! `*pattern` must come first; the other blocks may come in any order, each at most once.
//! `*pattern`, `*Q` and `*E` are required. A missing optional block is filled with a computed
//! default and listed in [`PypRead::defaulted`]:
//!
//! - `*RL`: the rest edge length `|X_v1 + dx a₁ + dy a₂ − X_v0|` from `*Q` and `*E`;
//! - `*RK`: `(0, 0)`; `*RT`: 0; `*RefT`: 0;
//! - `*RefD1`: a unit vector orthogonal to the rest edge (the coordinate axis least aligned
//!   with the edge, made orthogonal to it).
//!
//! Every parse error names the file, the 1-based line and what was expected, for example
//! `stockinette.pyp:17: expected 4 numbers "x y z t" in block *Q, found 3`.
//!
//! The writer emits the layout of the original files (same headers, a blank line after each
//! block, `\n` line endings) with numbers in Rust's shortest round-trip representation, so
//! write → read reproduces every `f64` bit for bit.

use std::fmt::{self, Write as _};
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use crate::tile::{Edge, Tile, TileError};

/// The blocks of a `.pyp` file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Block {
    /// `*pattern`: period, radius, vertex count.
    Pattern,
    /// `*Q`: vertex positions and edge twists.
    Q,
    /// `*E`: edges.
    E,
    /// `*RL`: rest lengths.
    RL,
    /// `*RK`: rest curvatures.
    RK,
    /// `*RT`: rest twists.
    RT,
    /// `*RefD1`: reference directors.
    RefD1,
    /// `*RefT`: reference twists.
    RefT,
}

impl Block {
    /// All blocks, in the order the writer emits them.
    pub const ALL: [Block; 8] = [
        Block::Pattern,
        Block::Q,
        Block::E,
        Block::RL,
        Block::RK,
        Block::RT,
        Block::RefD1,
        Block::RefT,
    ];

    /// The name after the `*` of the header line (`"pattern"`, `"Q"`, …).
    pub fn name(self) -> &'static str {
        match self {
            Block::Pattern => "pattern",
            Block::Q => "Q",
            Block::E => "E",
            Block::RL => "RL",
            Block::RK => "RK",
            Block::RT => "RT",
            Block::RefD1 => "RefD1",
            Block::RefT => "RefT",
        }
    }

    /// Whether a file must contain the block.
    pub fn is_required(self) -> bool {
        matches!(self, Block::Pattern | Block::Q | Block::E)
    }

    fn from_name(name: &str) -> Option<Block> {
        Block::ALL.into_iter().find(|b| b.name() == name)
    }

    /// Names of the values on one data line.
    fn layout(self) -> &'static str {
        match self {
            Block::Pattern => "px py r n [skew]",
            Block::Q => "x y z t",
            Block::E => "v0 v1 dx dy",
            Block::RL => "length",
            Block::RK => "k1 k2",
            Block::RT => "twist",
            Block::RefD1 => "d1x d1y d1z",
            Block::RefT => "twist",
        }
    }

    /// Number of values on one data line.
    fn width(self) -> usize {
        match self {
            Block::Pattern | Block::Q | Block::E => 4,
            Block::RefD1 => 3,
            Block::RK => 2,
            Block::RL | Block::RT | Block::RefT => 1,
        }
    }

    /// The header comment the writer emits (as in the original files).
    fn comment(self) -> &'static str {
        match self {
            Block::Pattern => "px py radius num_vertedges",
            Block::Q => "dofs: x y z t",
            Block::E => "edges [v0, v1, dx, dy]",
            Block::RL => "rest lengths",
            Block::RK => "rest kappas",
            Block::RT => "rest twists",
            Block::RefD1 => "reference directors",
            Block::RefT => "reference twists",
        }
    }

    /// The block whose lines hold the given [`Tile`] field.
    fn of_field(field: &str) -> Block {
        match field {
            "positions" | "twists" => Block::Q,
            "edges" => Block::E,
            "rest_lengths" => Block::RL,
            "rest_curvatures" => Block::RK,
            "rest_twists" => Block::RT,
            "reference_directors" => Block::RefD1,
            "reference_twists" => Block::RefT,
            _ => Block::Pattern,
        }
    }
}

impl fmt::Display for Block {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "*{}", self.name())
    }
}

/// A tile read from a `.pyp` file, with the optional blocks that were missing and filled with
/// computed defaults (see the [module documentation](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct PypRead {
    /// The tile (validated with [`Tile::validate`]).
    pub tile: Tile,
    /// Optional blocks absent from the file, in [`Block::ALL`] order; their data are defaults.
    pub defaulted: Vec<Block>,
}

/// Errors of reading or writing `.pyp` files.
#[derive(Debug, thiserror::Error)]
pub enum PypError {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The text is not a valid `.pyp` tile.
    #[error("{file}:{line}: {problem}")]
    Parse {
        /// The file (or source name given to [`parse_pyp`]).
        file: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong, and what was expected.
        problem: ParseProblem,
    },
    /// A tile passed to the writer is inconsistent.
    #[error("cannot write an invalid tile: {0}")]
    InvalidTile(#[from] TileError),
}

/// What is wrong at a line of a `.pyp` file (see [`PypError::Parse`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParseProblem {
    /// A data line before the first block header.
    #[error("expected a block header such as *pattern, found data {found:?} outside any block")]
    DataOutsideBlock {
        /// The first token of the line.
        found: String,
    },
    /// The first block is not `*pattern`.
    #[error("expected block *pattern first, found {found}")]
    PatternNotFirst {
        /// The first block of the file.
        found: Block,
    },
    /// A header names no known block.
    #[error(
        "unknown block *{name}; expected one of *pattern, *Q, *E, *RL, *RK, *RT, *RefD1, *RefT"
    )]
    UnknownBlock {
        /// The name after `*`.
        name: String,
    },
    /// A header line has more than the block name (outside a comment).
    #[error("expected only the block name on the header line of {block}, found extra {found:?}")]
    HeaderExtra {
        /// The block.
        block: Block,
        /// The first extra token.
        found: String,
    },
    /// A block appears twice.
    #[error(
        "duplicate block {block} (first on line {first_line}); expected each block at most once"
    )]
    DuplicateBlock {
        /// The block.
        block: Block,
        /// Line of its first header.
        first_line: usize,
    },
    /// A required block is absent.
    #[error("expected block {block} (required), found end of file without it")]
    MissingBlock {
        /// The block.
        block: Block,
    },
    /// A data line has the wrong number of values.
    #[error(
        "expected {expected} {} {layout:?} in block {block}, found {found}",
        if *expected == 1 { "number" } else { "numbers" }
    )]
    WrongCount {
        /// The block.
        block: Block,
        /// Values expected on the line.
        expected: usize,
        /// Names of the expected values.
        layout: &'static str,
        /// Values found.
        found: usize,
    },
    /// A token is not a number.
    #[error("expected a number in block {block}, found {token:?}")]
    NotANumber {
        /// The block.
        block: Block,
        /// The token.
        token: String,
    },
    /// A token is not an integer of the required kind.
    #[error("expected {what} in block {block}, found {token:?}")]
    NotAnInteger {
        /// The block.
        block: Block,
        /// What kind of integer was expected.
        what: &'static str,
        /// The token.
        token: String,
    },
    /// A number is NaN or infinite.
    #[error("expected a finite number in block {block}, found {token:?}")]
    NonFinite {
        /// The block.
        block: Block,
        /// The token.
        token: String,
    },
    /// `n = 0` in `*pattern`.
    #[error("expected a vertex count n ≥ 1 in block *pattern, found 0")]
    ZeroVertices,
    /// A block has fewer data lines than expected (reported at its header line).
    #[error("expected {expected} data lines in block {block} (n = {expected}), found {found}")]
    TooFewLines {
        /// The block.
        block: Block,
        /// Lines expected (`n`, or 1 for `*pattern`).
        expected: usize,
        /// Lines found.
        found: usize,
    },
    /// A block has more data lines than expected (reported at the first extra line).
    #[error(
        "expected {expected} data lines in block {block} (n = {expected}), found an extra line"
    )]
    TooManyLines {
        /// The block.
        block: Block,
        /// Lines expected (`n`, or 1 for `*pattern`).
        expected: usize,
    },
    /// An edge names a vertex that does not exist.
    #[error("expected a vertex index < n = {n} in block *E, found {vertex}")]
    VertexOutOfRange {
        /// The vertex index found.
        vertex: usize,
        /// Number of vertices.
        n: usize,
    },
    /// The tile is inconsistent (topology, non-positive rest length or period, …).
    #[error("inconsistent tile: {0}")]
    Tile(TileError),
}

/// Reads a `.pyp` file. Errors name the path and line.
pub fn read_pyp(path: impl AsRef<Path>) -> Result<PypRead, PypError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| PypError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_pyp(&text, &path.display().to_string())
}

/// Parses the text of a `.pyp` file; `source_name` (for example the file name) prefixes
/// error messages.
pub fn parse_pyp(text: &str, source_name: &str) -> Result<PypRead, PypError> {
    parse(text).map_err(|(line, problem)| PypError::Parse {
        file: source_name.to_string(),
        line,
        problem,
    })
}

/// Writes `tile` as a `.pyp` file (after validating it).
pub fn write_pyp(tile: &Tile, path: impl AsRef<Path>) -> Result<(), PypError> {
    let text = to_pyp_string(tile)?;
    let path = path.as_ref();
    std::fs::write(path, text).map_err(|source| PypError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The `.pyp` text of `tile` (after validating it), with all eight blocks.
pub fn to_pyp_string(tile: &Tile) -> Result<String, TileError> {
    let topology = tile.topology()?; // validates
    let mut s = String::new();
    header(&mut s, Block::Pattern);
    let [px, py] = tile.period;
    let n = tile.n_vertices();
    let _ = write!(
        s,
        "{} {} {} {n}",
        fmt_f64(px),
        fmt_f64(py),
        fmt_f64(tile.radius)
    );
    if tile.skew != 0.0 {
        let _ = write!(s, " {}", fmt_f64(tile.skew));
    }
    s.push('\n');
    header(&mut s, Block::Q);
    for (p, &t) in tile.positions.iter().zip(&tile.twists) {
        line(&mut s, &[p.x, p.y, p.z, t]);
    }
    header(&mut s, Block::E);
    for e in &tile.edges {
        let _ = writeln!(s, "{} {} {} {}", e.v0, e.v1, e.shift[0], e.shift[1]);
    }
    // Per-edge blocks are listed by start vertex: line v holds the edge leaving vertex v.
    header(&mut s, Block::RL);
    for v in 0..n {
        line(&mut s, &[tile.rest_lengths[topology.outgoing(v)]]);
    }
    header(&mut s, Block::RK);
    for k in &tile.rest_curvatures {
        line(&mut s, k);
    }
    header(&mut s, Block::RT);
    for &t in &tile.rest_twists {
        line(&mut s, &[t]);
    }
    header(&mut s, Block::RefD1);
    for v in 0..n {
        let d = tile.reference_directors[topology.outgoing(v)];
        line(&mut s, &[d.x, d.y, d.z]);
    }
    header(&mut s, Block::RefT);
    for &t in &tile.reference_twists {
        line(&mut s, &[t]);
    }
    s.push('\n');
    Ok(s)
}

/// Appends a block header, after a blank line unless it is the first.
fn header(s: &mut String, block: Block) {
    if !s.is_empty() {
        s.push('\n');
    }
    let _ = writeln!(s, "{block} # {}", block.comment());
}

/// Appends one data line of numbers.
fn line(s: &mut String, values: &[f64]) {
    let text: Vec<String> = values.iter().map(|&x| fmt_f64(x)).collect();
    s.push_str(&text.join(" "));
    s.push('\n');
}

/// Shortest round-trip representation; exponent notation for very small or large magnitudes.
fn fmt_f64(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-5..1e7).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// One data line: its 1-based number and its tokens (comment removed).
struct Row<'a> {
    line: usize,
    tokens: Vec<&'a str>,
}

/// One block as it appears in the file.
struct RawBlock<'a> {
    block: Block,
    header_line: usize,
    rows: Vec<Row<'a>>,
}

type Located<T> = Result<T, (usize, ParseProblem)>;

fn parse(text: &str) -> Located<PypRead> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let last_line = text.lines().count().max(1);
    let blocks = split_blocks(text)?;
    let missing = |block| Err((last_line, ParseProblem::MissingBlock { block }));

    // *pattern (always the first block, see split_blocks).
    let Some(pattern) = blocks.first() else {
        return missing(Block::Pattern);
    };
    let row = &exact_rows(pattern, 1)?[0];
    // An optional fifth number is the lattice skew (rectangular tiles omit it).
    let skew = if row.tokens.len() == 5 {
        number(Block::Pattern, row, 4)?
    } else {
        check_width(Block::Pattern, row)?;
        0.0
    };
    let px = number(Block::Pattern, row, 0)?;
    let py = number(Block::Pattern, row, 1)?;
    let radius = number(Block::Pattern, row, 2)?;
    let n: usize = integer(Block::Pattern, row, 3, "a vertex count n (integer ≥ 1)")?;
    if n == 0 {
        return Err((row.line, ParseProblem::ZeroVertices));
    }

    // The remaining blocks in file order, so that the first bad line is reported.
    let mut q = None;
    let mut edges = None;
    let mut rl = None;
    let mut rk = None;
    let mut rt = None;
    let mut refd1 = None;
    let mut reft = None;
    for raw in &blocks[1..] {
        let rows = exact_rows(raw, n)?;
        match raw.block {
            Block::Pattern => {} // only blocks[0] (duplicates are rejected)
            Block::Q => q = Some(numbers::<4>(raw.block, rows)?),
            Block::E => edges = Some(parse_edges(rows, n)?),
            Block::RL => rl = Some(numbers::<1>(raw.block, rows)?),
            Block::RK => rk = Some(numbers::<2>(raw.block, rows)?),
            Block::RT => rt = Some(numbers::<1>(raw.block, rows)?),
            Block::RefD1 => refd1 = Some(numbers::<3>(raw.block, rows)?),
            Block::RefT => reft = Some(numbers::<1>(raw.block, rows)?),
        }
    }
    let Some(q) = q else { return missing(Block::Q) };
    let Some(edges) = edges else {
        return missing(Block::E);
    };

    let mut defaulted = Vec::new();
    for (block, present) in [
        (Block::RL, rl.is_some()),
        (Block::RK, rk.is_some()),
        (Block::RT, rt.is_some()),
        (Block::RefD1, refd1.is_some()),
        (Block::RefT, reft.is_some()),
    ] {
        if !present {
            defaulted.push(block);
        }
    }
    let scalars = |v: Option<Vec<[f64; 1]>>| v.map(|v| v.iter().map(|x| x[0]).collect());
    let rest_lengths = scalars(rl);
    let reference_directors: Option<Vec<Vector3<f64>>> =
        refd1.map(|v| v.iter().map(|d| Vector3::new(d[0], d[1], d[2])).collect());
    let mut tile = Tile {
        period: [px, py],
        skew,
        radius,
        positions: q.iter().map(|v| Vector3::new(v[0], v[1], v[2])).collect(),
        twists: q.iter().map(|v| v[3]).collect(),
        edges,
        // Per-edge blocks are filled in once the topology is known to be valid.
        rest_lengths: vec![1.0; n],
        rest_curvatures: rk.unwrap_or_else(|| vec![[0.0; 2]; n]),
        rest_twists: scalars(rt).unwrap_or_else(|| vec![0.0; n]),
        reference_directors: vec![Vector3::x(); n],
        reference_twists: scalars(reft).unwrap_or_else(|| vec![0.0; n]),
    };
    let located =
        |err: TileError, tile: &Tile| (error_line(&err, &blocks, tile), ParseProblem::Tile(err));
    tile.validate().map_err(|err| located(err, &tile))?;

    // The topology is valid: reorder the per-edge blocks from start-vertex order to edge
    // order, or compute their defaults, and check them.
    tile.rest_lengths = match rest_lengths {
        Some(by_vertex) => tile.edges.iter().map(|e| by_vertex[e.v0]).collect(),
        None => (0..n).map(|e| tile.edge_vector(e).norm()).collect(),
    };
    tile.reference_directors = match reference_directors {
        Some(by_vertex) => tile.edges.iter().map(|e| by_vertex[e.v0]).collect(),
        None => (0..n)
            .map(|e| orthogonal_director(&tile.edge_vector(e)))
            .collect(),
    };
    tile.validate().map_err(|err| located(err, &tile))?;
    Ok(PypRead { tile, defaulted })
}

/// Splits the text into blocks, checking headers (known, not duplicated, `*pattern` first).
fn split_blocks(text: &str) -> Located<Vec<RawBlock<'_>>> {
    let mut blocks: Vec<RawBlock> = Vec::new();
    for (i, raw_line) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw_line.split('#').next().unwrap_or("");
        let tokens: Vec<&str> = content.split_whitespace().collect();
        let Some(first) = tokens.first() else {
            continue;
        };
        if let Some(name) = first.strip_prefix('*') {
            let Some(block) = Block::from_name(name) else {
                return Err((
                    line,
                    ParseProblem::UnknownBlock {
                        name: name.to_string(),
                    },
                ));
            };
            if let Some(extra) = tokens.get(1) {
                return Err((
                    line,
                    ParseProblem::HeaderExtra {
                        block,
                        found: extra.to_string(),
                    },
                ));
            }
            if blocks.is_empty() && block != Block::Pattern {
                return Err((line, ParseProblem::PatternNotFirst { found: block }));
            }
            if let Some(first) = blocks.iter().find(|b| b.block == block) {
                let first_line = first.header_line;
                return Err((line, ParseProblem::DuplicateBlock { block, first_line }));
            }
            blocks.push(RawBlock {
                block,
                header_line: line,
                rows: Vec::new(),
            });
        } else {
            let Some(current) = blocks.last_mut() else {
                return Err((
                    line,
                    ParseProblem::DataOutsideBlock {
                        found: first.to_string(),
                    },
                ));
            };
            current.rows.push(Row { line, tokens });
        }
    }
    Ok(blocks)
}

/// The rows of `raw`, which must number exactly `expected`.
fn exact_rows<'r, 'a>(raw: &'r RawBlock<'a>, expected: usize) -> Located<&'r [Row<'a>]> {
    let block = raw.block;
    if let Some(extra) = raw.rows.get(expected) {
        return Err((extra.line, ParseProblem::TooManyLines { block, expected }));
    }
    if raw.rows.len() < expected {
        let found = raw.rows.len();
        return Err((
            raw.header_line,
            ParseProblem::TooFewLines {
                block,
                expected,
                found,
            },
        ));
    }
    Ok(&raw.rows)
}

fn check_width(block: Block, row: &Row) -> Located<()> {
    let expected = block.width();
    if row.tokens.len() != expected {
        let found = row.tokens.len();
        let layout = block.layout();
        return Err((
            row.line,
            ParseProblem::WrongCount {
                block,
                expected,
                layout,
                found,
            },
        ));
    }
    Ok(())
}

/// Token `k` of `row` as a finite `f64`.
fn number(block: Block, row: &Row, k: usize) -> Located<f64> {
    let token = row.tokens[k];
    match token.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err((
            row.line,
            ParseProblem::NonFinite {
                block,
                token: token.to_string(),
            },
        )),
        Err(_) => Err((
            row.line,
            ParseProblem::NotANumber {
                block,
                token: token.to_string(),
            },
        )),
    }
}

/// Token `k` of `row` as an integer of type `T`.
fn integer<T: std::str::FromStr>(
    block: Block,
    row: &Row,
    k: usize,
    what: &'static str,
) -> Located<T> {
    let token = row.tokens[k];
    token.parse::<T>().map_err(|_| {
        (
            row.line,
            ParseProblem::NotAnInteger {
                block,
                what,
                token: token.to_string(),
            },
        )
    })
}

/// All rows of a block of `W` finite numbers per line.
fn numbers<const W: usize>(block: Block, rows: &[Row]) -> Located<Vec<[f64; W]>> {
    rows.iter()
        .map(|row| {
            check_width(block, row)?;
            let mut values = [0.0; W];
            for (k, v) in values.iter_mut().enumerate() {
                *v = number(block, row, k)?;
            }
            Ok(values)
        })
        .collect()
}

fn parse_edges(rows: &[Row], n: usize) -> Located<Vec<Edge>> {
    let block = Block::E;
    rows.iter()
        .map(|row| {
            check_width(block, row)?;
            let index = "a vertex index (integer ≥ 0)";
            let shift = "an integer period shift";
            let v0: usize = integer(block, row, 0, index)?;
            let v1: usize = integer(block, row, 1, index)?;
            let dx: i32 = integer(block, row, 2, shift)?;
            let dy: i32 = integer(block, row, 3, shift)?;
            for vertex in [v0, v1] {
                if vertex >= n {
                    return Err((row.line, ParseProblem::VertexOutOfRange { vertex, n }));
                }
            }
            Ok(Edge {
                v0,
                v1,
                shift: [dx, dy],
            })
        })
        .collect()
}

/// The line a [`TileError`] of `tile` refers to: the data line of the entry it names (per-edge
/// blocks are listed by start vertex), the line in `*E` of the edge a defaulted per-edge value
/// was computed from, or the `*pattern` line.
fn error_line(err: &TileError, blocks: &[RawBlock], tile: &Tile) -> usize {
    let find = |block: Block| blocks.iter().find(|b| b.block == block);
    let row_line = |raw: &RawBlock, i: usize| raw.rows.get(i).map_or(raw.header_line, |r| r.line);
    let pattern = &blocks[0];
    let Some(loc) = err.location() else {
        return row_line(pattern, 0);
    };
    let block = Block::of_field(loc.field);
    let (Some(i), Some(raw)) = (loc.index, find(block)) else {
        // Whole-tile errors point at *pattern; defaulted per-edge values at their edge.
        return match (loc.index, find(Block::E)) {
            (Some(e), Some(raw)) if matches!(block, Block::RL | Block::RefD1) => row_line(raw, e),
            _ => row_line(pattern, 0),
        };
    };
    match block {
        Block::RL | Block::RefD1 => row_line(raw, tile.edges.get(i).map_or(i, |e| e.v0)),
        _ => row_line(raw, i),
    }
}

/// A unit vector orthogonal to `edge`: the coordinate axis least aligned with it, with its
/// component along the edge removed. The x axis for a zero (or non-finite) edge.
fn orthogonal_director(edge: &Vector3<f64>) -> Vector3<f64> {
    let Some(t) = edge.try_normalize(0.0) else {
        return Vector3::x();
    };
    let k = t.iamin();
    let mut axis = Vector3::zeros();
    axis[k] = 1.0;
    (axis - t * t.dot(&axis))
        .try_normalize(0.0)
        .unwrap_or_else(Vector3::x)
}
