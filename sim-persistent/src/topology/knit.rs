//! The knit builder: any chart of [`crate::chart`] (stacked decreases, increases, yarn-overs,
//! slipped loops), flat with one yarn per row or one continuous yarn, or in the round
//! (seed 000 §3.1–§3.2.3).
//!
//! **Loops and cells.** Every row makes loops (the chart's `produces`); a slipped loop is the
//! loop of the row below carried up unworked. A loop pulled through something (every stitch
//! but `YO` and `SL`) has its two *feet* stitch contacts on the boundary below its row, each
//! with a `lo` and a `hi` node: together a [`Cell`] of four nodes. Boundary `b` holds the
//! cells of row `b`'s loops, left to right; boundary `H` (the bind-off) holds one cell of four
//! one-yarn nodes per loop of the last row. A loop's *head* runs through the cells of the
//! loop(s) pulled through it: one cell for `K`/`P`, the same cell for every loop of a
//! decrease (stacked, in the stitch's stacking order), two cells for `KFB`. An `M1` pulls
//! its loop through the *bar* of the row below, the yarn between two of its loops, which is
//! lifted into the new loop's cell.
//!
//! **Yarn paths.** Within a row, loop after loop (left to right in front view): left foot
//! `(L lo, L hi)`, the head through each of its cells `(L lo, L hi, R hi, R lo)`, right foot
//! `(R hi, R lo)`; a yarn-over has only its head, a slipped loop nothing (the yarn floats
//! past); the bars lifted by the next row's `M1`s are inserted between loops. For a rectangular
//! K/P chart this is exactly the grid of [`super::knit_node`]. [`Construction`] joins the rows:
//! each row its own yarn, or one yarn that reverses direction every row (flat) or keeps it
//! (round).

use super::{Construction, FabricKind, Side, StitchContact, Strand, Topology};
use crate::chart::{Chart, Source, Stitch};

/// Four contact nodes of one loop on one row boundary: its feet, or (at the bind-off) its
/// head (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    /// Row of the loop the cell belongs to (the boundary's row, or the last row at the
    /// bind-off).
    pub row: usize,
    /// Index of the loop among the loops of `row`.
    pub loop_index: usize,
    /// Centre of the loop across the fabric, in loop widths from the left edge of the cast-on
    /// (layout; for round knitting, along the circumference).
    pub x: f64,
    /// Out-of-plane sign of the cell's stitch ([`Stitch::sign`]; 0 at the bind-off).
    pub sign: f64,
    /// Whether the cell holds one-yarn nodes (bind-off) instead of stitch contacts.
    pub bind_off: bool,
    /// Nodes `[side][hi]`: `nodes[Side::Left as usize][1]` is the left contact's `hi` node.
    pub nodes: [[usize; 2]; 2],
    /// `(boundary, cell)` of the cell above along the wale: the first cell the loop's head runs
    /// through (itself at the bind-off).
    pub up: (usize, usize),
    /// `(boundary, cell)` of the cell below along the wale: the feet of the first loop this
    /// loop is pulled through (itself where there is none: cast-on, yarn-over, bar).
    pub down: (usize, usize),
}

/// Where a knit's nodes lie in its structure: per row boundary its cells, per node its cell.
#[derive(Clone, Debug, PartialEq)]
pub struct KnitMap {
    /// How the chart is knitted.
    pub construction: Construction,
    /// Cells per row boundary `0..=H`, left to right (front view).
    pub boundaries: Vec<Vec<Cell>>,
    /// Per node: `(boundary, cell, side, hi)`.
    pub sites: Vec<(usize, usize, Side, bool)>,
    /// Loops per row (what the chart's rows make).
    pub loops_per_row: Vec<usize>,
}

impl KnitMap {
    /// The cell of `(boundary, cell)`.
    pub fn cell(&self, at: (usize, usize)) -> &Cell {
        &self.boundaries[at.0][at.1]
    }

    /// Every node of boundary `b`, cells left to right, each `L lo, L hi, R lo, R hi`.
    pub fn boundary_nodes(&self, b: usize) -> Vec<usize> {
        self.boundaries[b]
            .iter()
            .flat_map(|c| [c.nodes[0][0], c.nodes[0][1], c.nodes[1][0], c.nodes[1][1]])
            .collect()
    }

    /// Every node of the first (`last = false`) or last cell of every boundary: the side
    /// edges of a flat knit, in boundary order, each `L lo, L hi, R lo, R hi`.
    pub fn edge_nodes(&self, last: bool) -> Vec<usize> {
        self.boundaries
            .iter()
            .filter_map(|cells| if last { cells.last() } else { cells.first() })
            .flat_map(|c| [c.nodes[0][0], c.nodes[0][1], c.nodes[1][0], c.nodes[1][1]])
            .collect()
    }
}

/// A loop of the fabric.
struct LoopRec {
    /// Row whose yarn makes it.
    row: usize,
    /// Its feet cell, if it is pulled through something.
    feet: Option<(usize, usize)>,
    /// The cells its head runs through, with its rank in each cell's stack (0 = top).
    head: Vec<(usize, usize, usize)>,
    /// Layout position (loop widths).
    x: f64,
}

/// What one yarn pass is part of (to find the strands of the stitch contacts afterwards).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Role {
    /// The feet of the loop of this cell: the upper strand.
    Feet(usize, usize),
    /// A head (or lifted bar) through this cell, with its stack rank.
    Head(usize, usize, usize),
}

/// The head strands through one contact, with their stack ranks.
type RankedStrands = Vec<(usize, Strand)>;

/// Appends a cell of four new nodes to boundary `b` and returns its `(boundary, cell)`.
fn new_cell(
    boundaries: &mut [Vec<Cell>],
    n_nodes: &mut usize,
    b: usize,
    (row, loop_index): (usize, usize),
    x: f64,
    sign: f64,
) -> (usize, usize) {
    let n = *n_nodes;
    *n_nodes += 4;
    let c = boundaries[b].len();
    boundaries[b].push(Cell {
        row,
        loop_index,
        x,
        sign,
        bind_off: b == boundaries.len() - 1,
        nodes: [[n, n + 1], [n + 2, n + 3]],
        up: (b, c),
        down: (b, c),
    });
    (b, c)
}

/// Builds the knit of `chart` knitted as `construction` (module documentation). Rows whose
/// yarn makes no loop (only slipped loops) get no yarn of their own with
/// [`Construction::FlatPerRow`].
pub(super) fn build(chart: &Chart, construction: Construction) -> Topology {
    let h = chart.height();
    let centre = 0.5 * chart.width() as f64;
    let mut loops: Vec<LoopRec> = Vec::new();
    // Live loops per row (loop ids), and per row the cells of its stitch contacts.
    let mut live: Vec<Vec<usize>> = Vec::with_capacity(h);
    let mut boundaries: Vec<Vec<Cell>> = vec![Vec::new(); h + 1];
    // The cells of the M1s lifting each bar `(row, before live slot k)` of a row.
    let mut bars: std::collections::HashMap<(usize, usize), Vec<(usize, usize)>> =
        std::collections::HashMap::new();
    let mut n_nodes = 0;
    for r in 0..h {
        let row = chart.row(r);
        let n_made = chart.loops_made(r);
        let x_of = |j: usize| centre + j as f64 + 0.5 - 0.5 * n_made as f64;
        let mut row_live = Vec::with_capacity(n_made);
        let mut k = 0; // loops of the row below worked so far
        for &s in row {
            let sources: Vec<usize> = match s.source() {
                Source::Loops(n) if r > 0 => {
                    k += n;
                    live[r - 1][k - n..k].to_vec()
                }
                _ => Vec::new(),
            };
            if s == Stitch::Slip {
                row_live.push(sources[0]);
                continue;
            }
            for _ in 0..s.produces() {
                let j = row_live.len();
                let id = loops.len();
                loops.push(LoopRec {
                    row: r,
                    feet: None,
                    head: Vec::new(),
                    x: x_of(j),
                });
                row_live.push(id);
                if !s.makes_contacts() {
                    continue;
                }
                let cell = new_cell(&mut boundaries, &mut n_nodes, r, (r, j), x_of(j), s.sign());
                loops[id].feet = Some(cell);
                if s.source() == Source::Bar {
                    bars.entry((r - 1, k)).or_default().push(cell);
                }
                for (rank, &src) in s.stack_order().iter().enumerate() {
                    if let Some(&l) = sources.get(src) {
                        loops[l].head.push((cell.0, cell.1, rank));
                    }
                }
                let down = sources.first().and_then(|&l| loops[l].feet).unwrap_or(cell);
                boundaries[cell.0][cell.1].down = down;
            }
        }
        live.push(row_live);
    }
    for (j, &l) in live[h - 1].clone().iter().enumerate() {
        let x = loops[l].x;
        let cell = new_cell(&mut boundaries, &mut n_nodes, h, (h - 1, j), x, 0.0);
        loops[l].head.push((cell.0, cell.1, 0));
        boundaries[h][cell.1].down = loops[l].feet.unwrap_or(cell);
    }
    for l in &loops {
        if let (Some(feet), Some(&(b, c, _))) = (l.feet, l.head.first()) {
            boundaries[feet.0][feet.1].up = (b, c);
        }
    }
    // Yarn paths per row, with the role of every pass.
    let mut rows: Vec<Vec<(usize, Option<Role>)>> = Vec::with_capacity(h);
    for r in 0..h {
        let mut path: Vec<(usize, Option<Role>)> = Vec::new();
        let head = |path: &mut Vec<(usize, Option<Role>)>, cells: &[(usize, usize, usize)]| {
            for &(b, c, rank) in cells {
                let n = boundaries[b][c].nodes;
                let role = (!boundaries[b][c].bind_off).then_some(Role::Head(b, c, rank));
                for node in [n[0][0], n[0][1], n[1][1], n[1][0]] {
                    path.push((node, role));
                }
            }
        };
        for (j, &l) in live[r].iter().enumerate() {
            for &(b, c) in bars.get(&(r, j)).into_iter().flatten() {
                head(&mut path, &[(b, c, 0)]);
            }
            let rec = &loops[l];
            if rec.row != r {
                continue; // slipped: the yarn floats past
            }
            match rec.feet {
                Some((b, c)) => {
                    let n = boundaries[b][c].nodes;
                    let role = Some(Role::Feet(b, c));
                    path.push((n[0][0], role));
                    path.push((n[0][1], role));
                    head(&mut path, &rec.head);
                    path.push((n[1][1], role));
                    path.push((n[1][0], role));
                }
                None => head(&mut path, &rec.head),
            }
        }
        rows.push(path);
    }
    let paths: Vec<Vec<(usize, Option<Role>)>> = match construction {
        Construction::FlatPerRow => rows.into_iter().filter(|p| !p.is_empty()).collect(),
        Construction::Flat => vec![
            rows.into_iter()
                .enumerate()
                .flat_map(|(r, mut p)| {
                    if r % 2 == 1 {
                        p.reverse();
                    }
                    p
                })
                .collect(),
        ],
        Construction::Round => vec![rows.into_iter().flatten().collect()],
    };
    let yarn_nodes: Vec<Vec<usize>> = paths
        .iter()
        .map(|p| p.iter().map(|&(n, _)| n).collect())
        .collect();
    let mut topo = Topology::from_yarn_nodes(n_nodes, &yarn_nodes, FabricKind::Knit(chart.clone()));
    // Stitch contacts from consecutive passes through the two nodes of one contact.
    let mut upper: Vec<Vec<[Option<Strand>; 2]>> = boundaries
        .iter()
        .map(|cs| vec![[None; 2]; cs.len()])
        .collect();
    let mut lower: Vec<Vec<[RankedStrands; 2]>> = boundaries
        .iter()
        .map(|cs| vec![[Vec::new(), Vec::new()]; cs.len()])
        .collect();
    for (y, p) in paths.iter().enumerate() {
        for i in 0..p.len() - 1 {
            let (Some(ra), Some(rb)) = (p[i].1, p[i + 1].1) else {
                continue;
            };
            if ra != rb {
                continue;
            }
            let (b, c) = match ra {
                Role::Feet(b, c) | Role::Head(b, c, _) => (b, c),
            };
            let nodes = boundaries[b][c].nodes;
            for side in [Side::Left, Side::Right] {
                let s = side as usize;
                // Geometric order q₀ → q₁: lo → hi on the left, hi → lo on the right.
                let (q0, q1) = if side == Side::Left {
                    (nodes[s][0], nodes[s][1])
                } else {
                    (nodes[s][1], nodes[s][0])
                };
                let (a, z) = (p[i].0, p[i + 1].0);
                let strand = if (a, z) == (q0, q1) {
                    Strand {
                        yarn: y,
                        index: i,
                        forward: true,
                    }
                } else if (a, z) == (q1, q0) {
                    Strand {
                        yarn: y,
                        index: i + 1,
                        forward: false,
                    }
                } else {
                    continue;
                };
                match ra {
                    Role::Feet(..) => upper[b][c][s] = Some(strand),
                    Role::Head(_, _, rank) => lower[b][c][s].push((rank, strand)),
                }
            }
        }
    }
    for (b, cells) in boundaries.iter().enumerate() {
        for (c, cell) in cells.iter().enumerate() {
            if cell.bind_off {
                continue;
            }
            for side in [Side::Left, Side::Right] {
                let s = side as usize;
                let mut lows = std::mem::take(&mut lower[b][c][s]);
                if lows.is_empty() {
                    continue; // cast-on feet
                }
                lows.sort_by_key(|&(rank, _)| rank);
                // Every cell with heads through it has its own loop's feet (construction).
                let Some(up) = upper[b][c][s] else {
                    debug_assert!(
                        false,
                        "boundary {b}, cell {c}: contact without its upper yarn"
                    );
                    continue;
                };
                let n = cell.nodes[s];
                let nodes = if side == Side::Left {
                    [n[0], n[1]]
                } else {
                    [n[1], n[0]]
                };
                topo.stitch_contacts.push(StitchContact {
                    nodes,
                    upper: up,
                    lower: lows.into_iter().map(|(_, st)| st).collect(),
                    sign: cell.sign,
                    row: b,
                    column: cell.loop_index,
                    side,
                });
            }
        }
    }
    let mut sites = vec![(0, 0, Side::Left, false); n_nodes];
    for (b, cells) in boundaries.iter().enumerate() {
        for (c, cell) in cells.iter().enumerate() {
            for side in [Side::Left, Side::Right] {
                for hi in [false, true] {
                    sites[cell.nodes[side as usize][hi as usize]] = (b, c, side, hi);
                }
            }
        }
    }
    topo.knit = Some(KnitMap {
        construction,
        boundaries,
        sites,
        loops_per_row: (0..h).map(|r| chart.loops_made(r)).collect(),
    });
    topo
}
