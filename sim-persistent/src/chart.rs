//! Stitch charts: the text format, its parser and builders for the simple knit patterns.
//!
//! A chart is a list of rows of stitches. Row 0 is the first row knitted (just above the
//! cast-on); the stitches of a row are listed from left to right **as the fabric is seen from
//! its front (right side)**, for flat and for round knitting alike (the construction, flat or
//! in the round, with one yarn per row or one continuous yarn, is chosen when the topology is
//! built: [`crate::topology::Construction`]). With this front-view convention garter is rows
//! of `K` alternating with rows of `P`, stockinette is all `K`. (Printed knitting charts read
//! right-side rows from right to left; write their rows reversed.)
//!
//! # Stitches
//!
//! Every stitch works into `consumes` loops of the row below (its *sources*, taken in order
//! from the left) and makes `produces` new loops (seed 000 §3.1). Row `r + 1` must work
//! exactly the loops that row `r` made, so row widths change with increases and decreases.
//!
//! | token | stitch | consumes | produces | what it is |
//! |---|---|---|---|---|
//! | `K` | knit | 1 | 1 | new loop pulled through to the front |
//! | `P` | purl | 1 | 1 | new loop pulled through to the back |
//! | `YO` | yarn-over | 0 | 1 | the yarn laid over the needle: a loop stitched to nothing (a hole) |
//! | `SL` | slip | 1 | 1 | the loop passes to the next row unworked; the yarn floats past it (no contact) |
//! | `K2TOG` | knit two together | 2 | 1 | right-leaning decrease, left loop on top of the stack |
//! | `SSK` | slip, slip, knit | 2 | 1 | left-leaning decrease, right loop on top |
//! | `K3TOG` | knit three together | 3 | 1 | right-leaning double decrease, stack left to right |
//! | `S2KP` | slip 2 together, k1, pass over | 3 | 1 | centred double decrease, centre loop on top, left loop at the bottom |
//! | `P2TOG`, `SSP`, `P3TOG`, `S2PP` | purl counterparts | 2, 2, 3, 3 | 1 | the same stacks, purled |
//! | `M1L`, `M1R` | make one, left / right | 0 | 1 | a knit loop through the running bar between two loops of the row below |
//! | `M1LP`, `M1RP` | make one purlwise | 0 | 1 | the same, purled |
//! | `KFB`, `PFB` | knit / purl front and back | 1 | 2 | two loops through one loop of the row below |
//! | `SSSK`, `SSSP` | slip, slip, slip, knit / purl 3 together | 3 | 1 | left-leaning double decrease, right loop on top |
//! | `SK2P`, `SP2P` | slip 1, k2tog / p2tog, pass over | 3 | 1 | left-leaning double decrease, the slipped right loop on top |
//! | `.` | no stitch | 0 | 0 | a placeholder that keeps printed charts aligned; ignored |
//!
//! Aliases: `SKP` reads as `SSK` (the same stack: right loop on top, leaning left), `CDD` as
//! `S2KP`, a bare `M1` as `M1L`. Not expressible: mid-row bind-off / cast-on (buttonholes:
//! every loop must be worked), through-the-back-loop twists (`K TBL`), repeat groups.
//!
//! Decreases make stacked stitches (seed 000 §3.2.3): the two or three loops of the row
//! below are stacked and the new loop goes through all of them, so its two stitch contacts
//! have `2 + n` yarn passes each. Increases through one loop (`KFB`) and yarn-overs keep every
//! stitch a two-yarn stitch (§3.2.2). `M1L` and `M1R` differ in the twist of the lifted bar,
//! which two-node stitch contacts do not resolve: they share one topology.
//!
//! Rules checked by the parser (errors name the line and column of the stitch):
//! - Row 0 is worked into the cast-on and takes `K` and `P` only.
//! - In the round, an `M1` may not lift the bar between the last and the first loop of the
//!   round below (the parser does not know the construction; the first stitch of a round
//!   needs a worked loop on its left).
//! - A stitch may not need more loops than are left of the row below, and a row must work
//!   every loop of the row below.
//! - `M1*` lifts the bar between two loops of the row below, so it needs a worked loop on its
//!   left and an unworked one on its right.
//! - A row may not be empty (only `.`).
//!
//! # Text format
//!
//! ```text
//! # a small lace repeat              <- comment: from '#' to the end of the line
//! K7                                 <- row 0 (first line with stitches = bottom row)
//! K K2TOG YO K YO SSK K              <- row 1: tokens separated by spaces, tabs or commas
//! K7                                 <- a stitch name and a repeat count ≥ 1 (`K7` = 7 knits)
//! ```
//!
//! Grammar (case-insensitive; one row per non-blank line):
//!
//! ```text
//! chart   = { line } ;              at least one row
//! line    = [ row ] [ "#" comment ] newline ;
//! row     = token { sep token } ;
//! sep     = ( " " | "\t" | "," ) { " " | "\t" | "," } ;
//! token   = name [ count ] ;        the longest stitch name that starts the token
//! name    = "K" | "P" | "YO" | "SL" | "K2TOG" | "SSK" | "K3TOG" | "S2KP" | "SSSK" | "SK2P"
//!         | "P2TOG" | "SSP" | "P3TOG" | "S2PP" | "SSSP" | "SP2P" | "M1L" | "M1R" | "M1LP"
//!         | "M1RP" | "KFB" | "PFB" | "SKP" | "CDD" | "M1" | "." ;
//! count   = digit { digit } ;       1 ≤ count ≤ MAX_RUN
//! ```
//!
//! Errors ([`ChartError`]) name the 1-based line and column (in characters) of the offending
//! token and what was expected there.

use std::fmt;

/// Largest accepted repeat count of one token (and largest row width).
pub const MAX_RUN: usize = 100_000;

/// One stitch of a chart (seed 000 §3.1; the table of the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stitch {
    /// Knit: seen from the front, the loop is pulled through the loop below to the front.
    Knit,
    /// Purl: seen from the front, the loop is pulled through the loop below to the back.
    Purl,
    /// Yarn-over: a new loop stitched to nothing.
    YarnOver,
    /// Slip: the loop below passes to the next row unworked.
    Slip,
    /// Knit two together (right-leaning; left loop on top).
    K2tog,
    /// Slip, slip, knit (left-leaning; right loop on top).
    Ssk,
    /// Knit three together (right-leaning).
    K3tog,
    /// Slip two together, knit one, pass the slipped loops over (centred).
    S2kp,
    /// Purl two together.
    P2tog,
    /// Slip, slip, purl.
    Ssp,
    /// Purl three together.
    P3tog,
    /// Slip two together, purl one, pass the slipped loops over.
    S2pp,
    /// Make one left (knit through the lifted bar).
    M1l,
    /// Make one right (knit through the lifted bar).
    M1r,
    /// Make one left, purlwise.
    M1lp,
    /// Make one right, purlwise.
    M1rp,
    /// Knit front and back: two knit loops through one loop.
    Kfb,
    /// Purl front and back: two purl loops through one loop.
    Pfb,
    /// Slip, slip, slip, knit three together (left-leaning double decrease).
    Sssk,
    /// Slip, slip, slip, purl three together.
    Sssp,
    /// Slip one, knit two together, pass the slipped loop over (left-leaning double decrease).
    Sk2p,
    /// Slip one, purl two together, pass the slipped loop over.
    Sp2p,
}

/// Where a stitch's new loop(s) are pulled through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Through `n ≥ 1` consecutive loops of the row below (stacked when `n > 1`).
    Loops(usize),
    /// Through the running bar between the last worked and the next loop of the row below.
    Bar,
    /// Through nothing (yarn-over).
    None,
}

/// Every stitch with its chart name, longest names first (the parser matches prefixes).
const NAMES: [(&str, Stitch); 22] = [
    ("K2TOG", Stitch::K2tog),
    ("K3TOG", Stitch::K3tog),
    ("P2TOG", Stitch::P2tog),
    ("P3TOG", Stitch::P3tog),
    ("M1LP", Stitch::M1lp),
    ("M1RP", Stitch::M1rp),
    ("S2KP", Stitch::S2kp),
    ("S2PP", Stitch::S2pp),
    ("SSSK", Stitch::Sssk),
    ("SSSP", Stitch::Sssp),
    ("SK2P", Stitch::Sk2p),
    ("SP2P", Stitch::Sp2p),
    ("SSK", Stitch::Ssk),
    ("SSP", Stitch::Ssp),
    ("M1L", Stitch::M1l),
    ("M1R", Stitch::M1r),
    ("KFB", Stitch::Kfb),
    ("PFB", Stitch::Pfb),
    ("YO", Stitch::YarnOver),
    ("SL", Stitch::Slip),
    ("K", Stitch::Knit),
    ("P", Stitch::Purl),
];

/// Other names knitters use for the same stitch in this model (the parser accepts them; a
/// chart is written back with the names of [`NAMES`]): `SKP` (slip, knit, pass over) makes
/// the stack of `SSK` (the right loop on top, leaning left), `CDD` is `S2KP`, a bare `M1` is
/// `M1L`.
const ALIASES: [(&str, Stitch); 3] = [
    ("SKP", Stitch::Ssk),
    ("CDD", Stitch::S2kp),
    ("M1", Stitch::M1l),
];

/// What the tokens of a row may be (for errors).
const EXPECTED_TOKEN: &str = "a stitch (K, P, YO, SL, K2TOG, SSK, K3TOG, S2KP, SSSK, SK2P, \
P2TOG, SSP, P3TOG, S2PP, SSSP, SP2P, M1L, M1R, M1LP, M1RP, KFB, PFB; also SKP, CDD, M1) or \
`.`, with an optional repeat count (e.g. `K3`)";

impl Stitch {
    /// Every stitch, in the order of the module documentation's table.
    pub const ALL: [Stitch; 22] = [
        Stitch::Knit,
        Stitch::Purl,
        Stitch::YarnOver,
        Stitch::Slip,
        Stitch::K2tog,
        Stitch::Ssk,
        Stitch::K3tog,
        Stitch::S2kp,
        Stitch::P2tog,
        Stitch::Ssp,
        Stitch::P3tog,
        Stitch::S2pp,
        Stitch::M1l,
        Stitch::M1r,
        Stitch::M1lp,
        Stitch::M1rp,
        Stitch::Kfb,
        Stitch::Pfb,
        Stitch::Sssk,
        Stitch::Sssp,
        Stitch::Sk2p,
        Stitch::Sp2p,
    ];

    /// The chart name (upper case), e.g. `"K"` or `"K2TOG"`.
    pub fn name(self) -> &'static str {
        NAMES
            .iter()
            .find(|(_, s)| *s == self)
            .map(|(n, _)| *n)
            .expect("every stitch has a name")
    }

    /// Where the new loop(s) are pulled through.
    pub fn source(self) -> Source {
        use Stitch::*;
        match self {
            Knit | Purl | Slip | Kfb | Pfb => Source::Loops(1),
            K2tog | Ssk | P2tog | Ssp => Source::Loops(2),
            K3tog | S2kp | P3tog | S2pp | Sssk | Sssp | Sk2p | Sp2p => Source::Loops(3),
            M1l | M1r | M1lp | M1rp => Source::Bar,
            YarnOver => Source::None,
        }
    }

    /// Loops of the row below this stitch works (`0` for yarn-overs and bar increases).
    pub fn consumes(self) -> usize {
        match self.source() {
            Source::Loops(n) => n,
            Source::Bar | Source::None => 0,
        }
    }

    /// New loops this stitch makes (2 for `KFB`/`PFB`, else 1).
    pub fn produces(self) -> usize {
        match self {
            Stitch::Kfb | Stitch::Pfb => 2,
            _ => 1,
        }
    }

    /// Out-of-plane sign of the stitch contacts as seen from the front: `+1` for knit-type
    /// stitches (the new loop comes through to the front), `−1` for purl-type ones, `0` for
    /// yarn-overs and slipped loops, which make no stitch contact.
    pub fn sign(self) -> f64 {
        use Stitch::*;
        match self {
            Knit | K2tog | Ssk | K3tog | S2kp | Sssk | Sk2p | M1l | M1r | Kfb => 1.0,
            Purl | P2tog | Ssp | P3tog | S2pp | Sssp | Sp2p | M1lp | M1rp | Pfb => -1.0,
            YarnOver | Slip => 0.0,
        }
    }

    /// Whether the new loop is pulled through something (a stitch contact is made).
    pub fn makes_contacts(self) -> bool {
        self.sign() != 0.0
    }

    /// The stacking order of a decrease's source loops, front (top) first, as indices into
    /// its sources (left to right, front view): `K2TOG` `[0, 1]` (the left loop lies on
    /// top), `SSK` `[1, 0]`, `K3TOG` `[0, 1, 2]`, `S2KP` `[1, 2, 0]` (a right-side row is
    /// worked from the right: the centre and right loops are slipped together — the centre
    /// ends on top — and passed over the left loop, knitted, at the bottom); purl
    /// counterparts alike (seen from the front, a P2TOG's left loop lies in front of its
    /// right one, like a K2TOG's); `SSSK` `[2, 1, 0]`, `SK2P` `[2, 0, 1]` (the right loop,
    /// slipped, passed over the two others knitted together). One source: `[0]`.
    pub fn stack_order(self) -> &'static [usize] {
        use Stitch::*;
        match self {
            K2tog | P2tog => &[0, 1],
            Ssk | Ssp => &[1, 0],
            K3tog | P3tog => &[0, 1, 2],
            S2kp | S2pp => &[1, 2, 0],
            Sssk | Sssp => &[2, 1, 0],
            Sk2p | Sp2p => &[2, 0, 1],
            _ => &[0],
        }
    }

    /// The purl counterpart of a knit-type stitch and back (same sources, same stacking
    /// order; yarn-overs and slips stay).
    pub fn flipped(self) -> Self {
        use Stitch::*;
        match self {
            Knit => Purl,
            Purl => Knit,
            K2tog => P2tog,
            P2tog => K2tog,
            Ssk => Ssp,
            Ssp => Ssk,
            K3tog => P3tog,
            P3tog => K3tog,
            S2kp => S2pp,
            S2pp => S2kp,
            M1l => M1lp,
            M1lp => M1l,
            M1r => M1rp,
            M1rp => M1r,
            Kfb => Pfb,
            Pfb => Kfb,
            Sssk => Sssp,
            Sssp => Sssk,
            Sk2p => Sp2p,
            Sp2p => Sk2p,
            YarnOver => YarnOver,
            Slip => Slip,
        }
    }
}

/// A malformed chart. Lines and columns are 1-based; columns count characters.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ChartError {
    /// A token that is not a stitch.
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
    /// A stitch that does not fit the loops of the row below (see the rules in the module
    /// documentation), or a row that leaves loops of the row below unworked.
    #[error("line {line}, column {column}: {message}")]
    StitchCount {
        /// Line of the stitch (or of the row, for unworked loops).
        line: usize,
        /// Column of the stitch (or one past the row's last token, for unworked loops).
        column: usize,
        /// What went wrong and what was expected.
        message: String,
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
    #[error("line {line}, column 1: chart has no rows, expected at least one row of stitches")]
    Empty {
        /// The line after the last one (where a row was expected).
        line: usize,
    },
    /// A chart built in code that breaks a rule: a zero size, an empty rib, or a stitch
    /// count (the message names the 0-based row and stitch).
    #[error("invalid chart: {0}")]
    InvalidSize(String),
}

/// A stitch chart (see the module documentation for the conventions).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Chart {
    rows: Vec<Vec<Stitch>>,
}

/// A broken stitch-count rule at (row, stitch index), or past the row's end
/// (`stitch == row.len()`).
struct CountError {
    row: usize,
    stitch: usize,
    message: String,
}

/// Checks the stitch-count rules of the module documentation.
fn check_counts(rows: &[Vec<Stitch>]) -> Result<(), CountError> {
    let mut below: Option<usize> = None;
    for (r, row) in rows.iter().enumerate() {
        let err = |stitch: usize, message: String| CountError {
            row: r,
            stitch,
            message,
        };
        if row.is_empty() {
            return Err(err(0, "row has no stitches (only `.`)".into()));
        }
        let Some(available) = below else {
            if let Some(i) = row
                .iter()
                .position(|s| !matches!(s, Stitch::Knit | Stitch::Purl))
            {
                return Err(err(
                    i,
                    format!(
                        "`{}` in the first row: the first row is worked into the cast-on and takes K and P only",
                        row[i].name()
                    ),
                ));
            }
            below = Some(row.len());
            continue;
        };
        let mut worked = 0;
        for (i, s) in row.iter().enumerate() {
            match s.source() {
                Source::Loops(n) => {
                    if worked + n > available {
                        return Err(err(
                            i,
                            format!(
                                "`{}` works {n} loop(s) but only {} of the {available} loops of the row below are left",
                                s.name(),
                                available - worked
                            ),
                        ));
                    }
                    worked += n;
                }
                Source::Bar => {
                    if worked == 0 || worked == available {
                        return Err(err(
                            i,
                            format!(
                                "`{}` lifts the bar between two loops of the row below, expected a worked loop on its left and an unworked one on its right ({worked} of {available} worked)",
                                s.name()
                            ),
                        ));
                    }
                }
                Source::None => {}
            }
        }
        if worked != available {
            return Err(err(
                row.len(),
                format!(
                    "row works {worked} of the {available} loops of the row below, expected all (add {} more)",
                    available - worked
                ),
            ));
        }
        below = Some(row.iter().map(|s| s.produces()).sum());
    }
    Ok(())
}

impl Chart {
    /// A chart from rows (row 0 first). Errors if there are no rows or a stitch-count rule is
    /// broken (module documentation).
    pub fn from_rows(rows: Vec<Vec<Stitch>>) -> Result<Self, ChartError> {
        if rows.is_empty() {
            return Err(ChartError::InvalidSize(
                "a chart needs ≥ 1 row of ≥ 1 stitch".into(),
            ));
        }
        check_counts(&rows).map_err(|e| {
            ChartError::InvalidSize(format!("row {}, stitch {}: {}", e.row, e.stitch, e.message))
        })?;
        Ok(Self { rows })
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

    /// A lace repeat `across` times wide and `up` times high, with a knit row on top: yarn-overs
    /// paired with decreases (K2TOG, SSK, S2KP, K3TOG), so every row keeps its 9 × `across`
    /// loops. The repeat (seven rows with the closing knit row):
    ///
    /// ```text
    /// K9
    /// K K2TOG YO K YO SSK K2 K
    /// K9
    /// K2 YO S2KP YO K2 K2
    /// K9
    /// K YO K3TOG YO K YO K3TOG YO K
    /// K9
    /// ```
    pub fn lace(across: usize, up: usize) -> Result<Self, ChartError> {
        if across == 0 || up == 0 {
            return Err(ChartError::InvalidSize(format!(
                "lace {across} × {up} repeats: both counts must be ≥ 1"
            )));
        }
        const ROWS: [&str; 6] = [
            "K9",
            "K K2TOG YO K YO SSK K2 K",
            "K9",
            "K2 YO S2KP YO K2 K2",
            "K9",
            "K YO K3TOG YO K YO K3TOG YO K",
        ];
        let row = |r: &str| format!("{}\n", vec![r; across].join(" "));
        let mut text: String = (0..up).flat_map(|_| ROWS.map(row)).collect();
        text.push_str(&row("K9"));
        Self::parse(&text)
    }

    /// Loops of the cast-on: the width of row 0 (for a rectangular K/P chart, the
    /// width of every row).
    pub fn width(&self) -> usize {
        self.rows[0].len()
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.rows.len()
    }

    /// Number of stitches (tokens) of row `row`.
    pub fn row_width(&self, row: usize) -> usize {
        self.rows[row].len()
    }

    /// Loops made by row `row` (the loops row `row + 1` works, or the bind-off's).
    pub fn loops_made(&self, row: usize) -> usize {
        self.rows[row].iter().map(|s| s.produces()).sum()
    }

    /// Whether every row has the cast-on's width and holds only `K` and `P`: the charts of the
    /// simple patterns, whose nodes form a regular grid ([`crate::topology::knit_node`]).
    pub fn is_rectangular(&self) -> bool {
        let w = self.width();
        self.rows.iter().all(|row| {
            row.len() == w && row.iter().all(|s| matches!(s, Stitch::Knit | Stitch::Purl))
        })
    }

    /// The stitch at `row` (0 = bottom) and `column` (0 = left, front view).
    ///
    /// # Panics
    /// If the position is outside the chart.
    pub fn stitch(&self, row: usize, column: usize) -> Stitch {
        self.rows[row][column]
    }

    /// Row `row` as a slice.
    pub fn row(&self, row: usize) -> &[Stitch] {
        &self.rows[row]
    }

    /// The chart in the text format, run-length encoded, one row per line (row 0 first).
    /// [`Chart::parse`] reads it back to an equal chart.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        for row in &self.rows {
            let mut tokens = Vec::new();
            let mut i = 0;
            while i < row.len() {
                let mut j = i + 1;
                while j < row.len() && row[j] == row[i] {
                    j += 1;
                }
                let n = j - i;
                tokens.push(if n == 1 {
                    row[i].name().to_string()
                } else {
                    format!("{}{n}", row[i].name())
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
        // Per row: its line, the column of every stitch, and the column after its last token.
        let mut places: Vec<(usize, Vec<usize>, usize)> = Vec::new();
        let mut n_lines = 0;
        for (li, raw) in text.lines().enumerate() {
            let line = li + 1;
            n_lines = line;
            let content = raw.split('#').next().unwrap_or("");
            let mut row = Vec::new();
            let mut columns = Vec::new();
            let mut end = 1;
            let mut any = false;
            for (column, token) in tokens(content) {
                any = true;
                end = column + token.chars().count();
                let (stitch, count) = parse_token(token, line, column)?;
                let Some(stitch) = stitch else {
                    continue;
                };
                if row.len() + count > MAX_RUN {
                    return Err(ChartError::TooWide {
                        line,
                        column,
                        max: MAX_RUN,
                    });
                }
                row.extend(std::iter::repeat_n(stitch, count));
                columns.extend(std::iter::repeat_n(column, count));
            }
            if !any {
                continue;
            }
            rows.push(row);
            places.push((line, columns, end));
        }
        if rows.is_empty() {
            return Err(ChartError::Empty { line: n_lines + 1 });
        }
        check_counts(&rows).map_err(|e| {
            let (line, columns, end) = &places[e.row];
            ChartError::StitchCount {
                line: *line,
                column: columns.get(e.stitch).copied().unwrap_or(*end),
                message: e.message,
            }
        })?;
        Ok(Self { rows })
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

/// Parses one token at (`line`, `column`) into a stitch (`None` for the `.` placeholder) and
/// its repeat count.
fn parse_token(
    token: &str,
    line: usize,
    column: usize,
) -> Result<(Option<Stitch>, usize), ChartError> {
    let upper = token.to_ascii_uppercase();
    let unexpected = || ChartError::UnexpectedToken {
        line,
        column,
        token: token.to_owned(),
        expected: EXPECTED_TOKEN,
    };
    let (stitch, name_len) = if upper.starts_with('.') {
        (None, 1)
    } else {
        // The longest name (or alias) that starts the token.
        let (name, stitch) = NAMES
            .iter()
            .chain(&ALIASES)
            .filter(|(name, _)| upper.starts_with(name))
            .max_by_key(|(name, _)| name.len())
            .ok_or_else(unexpected)?;
        (Some(*stitch), name.len())
    };
    let digits = &upper[name_len..];
    if digits.is_empty() {
        return Ok((stitch, 1));
    }
    if !digits.chars().all(|c| c.is_ascii_digit()) {
        return Err(unexpected());
    }
    let bad_count = || ChartError::BadCount {
        line,
        column: column + name_len,
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
